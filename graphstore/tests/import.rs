//! Neo4j bulk-import CSV: a graph exported and imported again is the same graph (same node
//! ids, labels, properties and relationships), and bad files fail with the file and line.

use graphstore::export::export_neo4j_csv;
use graphstore::import::{CsvFile, CsvFiles, import_neo4j_csv};
use graphstore::{GraphRead, Store, Value};

/// Every node as (id, sorted labels, sorted named properties); every relationship as
/// (start, type, end, sorted named properties), sorted.
type Nodes = Vec<(u64, Vec<String>, Vec<(String, String)>)>;
type Rels = Vec<(u64, String, u64, Vec<(String, String)>)>;

fn canon(store: &Store) -> (Nodes, Rels) {
    let r = store.read().unwrap();
    let named = |props: &[(graphstore::PropKey, Value)]| {
        let mut v: Vec<(String, String)> = props
            .iter()
            .map(|(k, v)| (r.name_of(k.0).unwrap(), format!("{v:?}")))
            .collect();
        v.sort();
        v
    };
    let mut nodes = Vec::new();
    for id in r.all_node_ids().unwrap() {
        let n = r.node(id).unwrap().unwrap();
        let mut labels: Vec<String> = n.labels.iter().map(|l| r.name_of(l.0).unwrap()).collect();
        labels.sort();
        nodes.push((id, labels, named(&n.props)));
    }
    let mut rels = Vec::new();
    for id in r.all_rel_ids().unwrap() {
        let x = r.rel(id).unwrap().unwrap();
        rels.push((x.start, r.name_of(x.ty.0).unwrap(), x.end, named(&x.props)));
    }
    rels.sort_by(|a, b| format!("{a:?}").cmp(&format!("{b:?}")));
    (nodes, rels)
}

#[test]
fn an_exported_graph_imports_as_the_same_graph() {
    let dir = tempfile::tempdir().unwrap();
    let src = Store::create(dir.path().join("src.og")).unwrap();
    src.write(|tx| {
        let a = tx.create_node_named(
            &["Instance", "Object"],
            &[
                ("caption", Value::String("a red, \"quoted\"\nbench".into())),
                ("center", Value::Point3D([1.5, -2.25, 0.125])),
                ("feature", Value::Vector(vec![0.25, -0.5, 1.0])),
                ("count", Value::Int(-7)),
                ("ok", Value::Bool(true)),
                ("tags", Value::List(vec!["x".into(), "y".into()])),
                ("ids", Value::List(vec![Value::Int(1), Value::Int(2)])),
                // a list of floats (a pose matrix) stays a list, not a vector
                (
                    "m",
                    Value::List(vec![Value::Float(0.5), Value::Float(-1.25)]),
                ),
            ],
        )?;
        // a gap in the ids: the import must keep them anyway
        let gone = tx.create_node_named(&["Tmp"], &[])?;
        tx.delete_node(gone)?;
        let b = tx.create_node_named(&["Segment"], &[("kind", Value::String("T".into()))])?;
        let c = tx.create_node_named(&[], &[("w", Value::Float(2.5))])?;
        tx.create_rel_named(a, "IN_SEGMENT", b, &[("distance_m", Value::Float(0.5))])?;
        tx.create_rel_named(b, "CONNECTS", c, &[])?;
        tx.create_rel_named(a, "IN_SEGMENT", b, &[])?;
        Ok(())
    })
    .unwrap();
    let out = dir.path().join("csv");
    export_neo4j_csv(&src.read().unwrap(), &out).unwrap();

    let dst = Store::create(dir.path().join("dst.og")).unwrap();
    let files = CsvFiles::from_folder(&out).unwrap();
    let mut calls = 0;
    let got = import_neo4j_csv(&dst, &files, 1, &mut |done, total| {
        assert!(done <= total, "{done} > {total}");
        calls += 1;
    })
    .unwrap();
    assert_eq!((got.nodes, got.relationships), (3, 3));
    assert!(got.ids_kept);
    assert!(
        calls >= 6,
        "one progress call per batch of one row: {calls}"
    );
    assert_eq!(canon(&dst), canon(&src));
    assert_eq!(
        dst.counts().unwrap().total_nodes,
        3,
        "counts kept in step by the import"
    );
}

fn write(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn string_ids_in_id_spaces_and_given_labels_and_types() {
    let dir = tempfile::tempdir().unwrap();
    let people = write(
        dir.path(),
        "people.csv",
        "uid:ID(P),name,age:int\nalice,Alice,30\nbob,Bob,\n",
    );
    let towns = write(
        dir.path(),
        "towns.csv",
        "tid:ID(T),name\nalice,Aliceville\n",
    );
    let lives = write(
        dir.path(),
        "lives.csv",
        ":START_ID(P),:END_ID(T),since:long\nalice,alice,2001\nbob,alice,\n",
    );
    let store = Store::create(dir.path().join("g.og")).unwrap();
    let files = CsvFiles {
        nodes: vec![
            CsvFile::parse(&format!("Person={}", people.display())),
            CsvFile::parse(&format!("Town={}", towns.display())),
        ],
        relationships: vec![CsvFile::parse(&format!("LIVES_IN={}", lives.display()))],
    };
    let got = import_neo4j_csv(&store, &files, 1000, &mut |_, _| {}).unwrap();
    assert_eq!((got.nodes, got.relationships, got.ids_kept), (3, 2, false));
    let q = store
        .query(
            "MATCH (p:Person)-[l:LIVES_IN]->(t:Town) RETURN p.uid, p.age, l.since, t.name \
             ORDER BY p.uid",
            &graphstore::cypher::QueryOptions::default(),
        )
        .unwrap();
    let rows: Vec<String> = q.rows.iter().map(|row| format!("{row:?}")).collect();
    assert_eq!(rows.len(), 2, "{rows:?}");
    assert!(rows[0].contains("alice") && rows[0].contains("30") && rows[0].contains("2001"));
    assert!(
        rows[1].contains("bob") && rows[1].contains("Null"),
        "{rows:?}"
    );
}

#[test]
fn bad_files_fail_with_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            ":ID,n:int\n1,2\n2,x\n",
            None,
            "nodes.csv:3",
            "not an integer",
        ),
        (
            ":ID,n:int\n1,2\n1,3\n",
            None,
            "nodes.csv:3",
            "appears twice",
        ),
        (":ID,n:int\n1,2\n2,3,4\n", None, "nodes.csv:3", "3 fields"),
        (":ID,n:vec3\n1,2\n", None, "nodes.csv:1", "unknown type"),
        (
            ":ID\n1\n2\n",
            Some(":START_ID,:END_ID,:TYPE\n1,2,R\n1,9,R\n"),
            "relationships.csv:3",
            "no node has the :ID \"9\"",
        ),
        (
            ":ID\n1\n2\n",
            Some(":START_ID,:END_ID,:TYPE\n1,2,R\n2,1,R\n7,1,R\n2,2,R\n"),
            "relationships.csv:4",
            "column 1: no node has the :ID \"7\"",
        ),
        (
            ":ID\n1\n",
            Some(":START_ID,:END_ID\n1,1\n"),
            "relationships.csv:1",
            "no :TYPE column",
        ),
    ];
    for (i, (nodes, rels, at, what)) in cases.iter().enumerate() {
        let sub = dir.path().join(format!("case{i}"));
        std::fs::create_dir_all(&sub).unwrap();
        write(&sub, "nodes.csv", nodes);
        if let Some(r) = rels {
            write(&sub, "relationships.csv", r);
        }
        let store = Store::create(sub.join("g.og")).unwrap();
        let files = CsvFiles::from_folder(&sub).unwrap();
        let e = import_neo4j_csv(&store, &files, 1000, &mut |_, _| {})
            .expect_err(&format!("case {i} must fail"))
            .to_string();
        assert!(e.contains(at) && e.contains(what), "case {i}: {e}");
    }
}

/// Files longer than the reader's read-ahead block: rows and errors past the first blocks keep
/// their lines; ids equal as integers but not as text ("7", "007") are two nodes.
#[test]
fn long_files_keep_their_lines_and_ids_are_text() {
    let dir = tempfile::tempdir().unwrap();
    let rows = |bad: Option<(usize, &str)>| {
        let mut text = String::from(":ID,n:int\n");
        for i in 1..=10_000usize {
            match bad {
                Some((at, row)) if at == i => text.push_str(row),
                _ => text.push_str(&format!("{i},{i}")),
            }
            text.push('\n');
        }
        text
    };
    for (i, (bad, line, what)) in [
        ((9_000, "9000,x"), 9_001, "not an integer"),
        ((4_097, "4097,1,2"), 4_098, "3 fields"),
        ((8_193, "5,5"), 8_194, "appears twice"),
    ]
    .into_iter()
    .enumerate()
    {
        let sub = dir.path().join(format!("long{i}"));
        std::fs::create_dir_all(&sub).unwrap();
        write(&sub, "nodes.csv", &rows(Some(bad)));
        let store = Store::create(sub.join("g.og")).unwrap();
        let files = CsvFiles::from_folder(&sub).unwrap();
        let e = import_neo4j_csv(&store, &files, 1000, &mut |_, _| {})
            .expect_err("must fail")
            .to_string();
        assert!(
            e.contains(&format!("nodes.csv:{line}")) && e.contains(what),
            "{e}"
        );
    }
    let sub = dir.path().join("whole");
    std::fs::create_dir_all(&sub).unwrap();
    write(&sub, "nodes.csv", &rows(None));
    let store = Store::create(sub.join("g.og")).unwrap();
    let files = CsvFiles::from_folder(&sub).unwrap();
    let got = import_neo4j_csv(&store, &files, 3000, &mut |_, _| {}).unwrap();
    assert_eq!((got.nodes, got.ids_kept), (10_000, true));
    let q = store
        .query(
            "MATCH (n) WHERE id(n) = 9999 RETURN n.n",
            &graphstore::cypher::QueryOptions::default(),
        )
        .unwrap();
    assert_eq!(format!("{:?}", q.rows), "[[Int(9999)]]");

    let sub = dir.path().join("text");
    std::fs::create_dir_all(&sub).unwrap();
    write(&sub, "nodes.csv", ":ID,n:int\n7,1\n007,2\n");
    write(
        &sub,
        "relationships.csv",
        ":START_ID,:END_ID,:TYPE\n7,007,R\n",
    );
    let store = Store::create(sub.join("g.og")).unwrap();
    let files = CsvFiles::from_folder(&sub).unwrap();
    let got = import_neo4j_csv(&store, &files, 1000, &mut |_, _| {}).unwrap();
    assert_eq!((got.nodes, got.relationships, got.ids_kept), (2, 1, false));
    let q = store
        .query(
            "MATCH (a)-[:R]->(b) RETURN a.n, b.n",
            &graphstore::cypher::QueryOptions::default(),
        )
        .unwrap();
    assert_eq!(format!("{:?}", q.rows), "[[Int(1), Int(2)]]");
}

/// Everything a relationship store holds, for comparing two stores: each relationship by id,
/// each node's adjacency, and the counts.
fn rel_state(store: &Store) -> String {
    let r = store.read().unwrap();
    let mut out = String::new();
    for id in r.all_rel_ids().unwrap() {
        out += &format!("{:?}\n", r.rel(id).unwrap());
    }
    for id in r.all_node_ids().unwrap() {
        out += &format!(
            "{id}: {:?}\n",
            r.neighbours(id, graphstore::Direction::Both, None).unwrap()
        );
    }
    out + &format!("{:?}", r.counts().unwrap())
}

fn numbered(n: usize) -> (tempfile::TempDir, Store, Vec<u64>) {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("g.og")).unwrap();
    let ids = store
        .write(|tx| (0..n).map(|_| tx.create_node_named(&["N"], &[])).collect())
        .unwrap();
    (dir, store, ids)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 32, ..Default::default() })]

    /// `create_rels` (the bulk path the import takes) leaves the store exactly as
    /// `create_rel` row by row does: same ids, records, adjacency and counts.
    #[test]
    fn bulk_relationships_equal_one_by_one(
        n in 1usize..20,
        edges in proptest::collection::vec((0usize..20, 0usize..20, 0usize..3, proptest::option::of(-5i64..5)), 0..60),
    ) {
        let types = ["A", "B", "C"];
        let (_d1, one, ids1) = numbered(n);
        let (_d2, bulk, ids2) = numbered(n);
        one.write(|tx| {
            for (a, b, t, w) in &edges {
                let props: Vec<(&str, Value)> = w.iter().map(|w| ("w", Value::Int(*w))).collect();
                tx.create_rel_named(ids1[a % n], types[*t], ids1[b % n], &props)?;
            }
            Ok(())
        }).unwrap();
        bulk.write(|tx| {
            let mut rows = Vec::new();
            for (a, b, t, w) in &edges {
                let ty = tx.rel_type_id(types[*t])?;
                let props = match w {
                    Some(w) => vec![(tx.prop_key_id("w")?, Value::Int(*w))],
                    None => Vec::new(),
                };
                rows.push((ids2[a % n], ty, ids2[b % n], props));
            }
            tx.create_rels(rows).map_err(|(_, e)| e)?;
            Ok(())
        }).unwrap();
        proptest::prop_assert_eq!(rel_state(&one), rel_state(&bulk));
    }
}

#[test]
fn bulk_relationships_over_many_nodes_and_a_bad_row() {
    // more distinct ends than the bulk path keeps records for at once
    let n = 70_000;
    let (_d, store, ids) = numbered(n);
    let rows = |tx: &mut graphstore::WriteTxn<'_>, bad: Option<usize>| {
        let ty = tx.rel_type_id("R").unwrap();
        (0..n)
            .map(|i| {
                let end = if Some(i) == bad {
                    10 * n as u64
                } else {
                    ids[(i * 7919) % n]
                };
                (ids[i], ty, end, Vec::new())
            })
            .collect::<Vec<_>>()
    };
    // a missing end in row 50,000: that row is named and nothing is written
    let e = store
        .write(|tx| {
            let r = rows(tx, Some(50_000));
            match tx.create_rels(r) {
                Err((i, e)) => Err(graphstore::Error::InvalidValue(format!("row {i}: {e}"))),
                Ok(_) => Ok(()),
            }
        })
        .expect_err("a missing end");
    assert!(e.to_string().contains("row 50000"), "{e}");
    assert_eq!(store.counts().unwrap().total_relationships, 0);
    store
        .write(|tx| {
            let r = rows(tx, None);
            tx.create_rels(r).map_err(|(_, e)| e)
        })
        .unwrap();
    let r = store.read().unwrap();
    assert_eq!(store.counts().unwrap().total_relationships, n as u64);
    let out = r
        .neighbours(ids[3], graphstore::Direction::Outgoing, None)
        .unwrap();
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].other, ids[(3 * 7919) % n]);
}

/// A graph exported as node-link JSON (either edge key) imports as the same graph, properties
/// named like node-link's own keys included; string ids get new node ids, and edges without a
/// type get the default type.
#[test]
fn node_link_json_imports_as_the_same_graph() {
    use graphstore::import::import_node_link;
    let dir = tempfile::tempdir().unwrap();
    let src = Store::create(dir.path().join("src.og")).unwrap();
    src.write(|tx| {
        let a = tx.create_node_named(
            &["P", "Q"],
            &[
                ("id", Value::String("own id".into())),
                ("_id", Value::String("under".into())),
                ("__labels", Value::Int(7)),
                ("labels", Value::Int(3)),
                ("at", Value::Point3D([1.0, 2.5, -3.0])),
                ("tags", Value::List(vec![Value::String("x".into())])),
            ],
        )?;
        let b = tx.create_node_named(&[], &[("w", Value::Float(0.5))])?;
        tx.create_rel_named(
            a,
            "R",
            b,
            &[("type", Value::String("own".into())), ("d", Value::Int(2))],
        )?;
        tx.create_rel_named(b, "S", b, &[])?;
        tx.create_rel_named(a, "R", b, &[])?;
        Ok(())
    })
    .unwrap();
    for key in ["edges", "links"] {
        let path = dir.path().join(format!("{key}.json"));
        let mut f = std::fs::File::create(&path).unwrap();
        graphstore::export::export_node_link(&src.read().unwrap(), key, &mut f).unwrap();
        drop(f);
        let dst = Store::create(dir.path().join(format!("{key}.og"))).unwrap();
        let got = import_node_link(&dst, &path, "RELATED_TO", 2, &mut |_, _| {}).unwrap();
        assert!(got.ids_kept);
        assert_eq!((got.nodes, got.relationships), (2, 3));
        assert_eq!(canon(&dst), canon(&src), "{key}");
    }
    let text = r#"{"nodes": [{"id": "a", "labels": ["City"], "pop": 3}, {"id": "b"}],
                   "links": [{"source": "a", "target": "b", "km": 2.5}]}"#;
    let path = dir.path().join("strings.json");
    std::fs::write(&path, text).unwrap();
    let dst = Store::create(dir.path().join("strings.og")).unwrap();
    let got = import_node_link(&dst, &path, "ROAD", 100, &mut |_, _| {}).unwrap();
    assert!(!got.ids_kept);
    let r = dst
        .query(
            "MATCH (c:City)-[r:ROAD]->(o) RETURN c.pop AS pop, r.km AS km, labels(o) AS l, c.id AS a, o.id AS b",
            &Default::default(),
        )
        .unwrap();
    assert_eq!(
        format!("{:?}", r.rows),
        "[[Int(3), Float(2.5), List([]), Str(\"a\"), Str(\"b\")]]"
    );
    for (bad, says) in [
        (
            r#"{"nodes": [{"id": 1}, {"id": 1}]}"#,
            "nodes[1]: the id 1 appears twice",
        ),
        (r#"{"nodes": [{"name": 1}]}"#, "nodes[0] has no \"id\""),
        (r#"{"edges": []}"#, "no \"nodes\" list"),
        (
            r#"{"nodes": [{"id": 1, "labels": "P"}]}"#,
            "list of strings",
        ),
        (
            r#"{"nodes": [{"id": 1, "labels": ["P", ""]}]}"#,
            "nodes[0]: ",
        ),
        (
            r#"{"nodes": [], "edges": [], "links": []}"#,
            "both \"edges\" and \"links\"",
        ),
        ("{\"nodes\": [\n1,,]}", "strings.json:2: not JSON"),
        (
            r#"{"nodes": [{"id": 1}], "edges": [{"source": 1, "target": 1, "type": 4}]}"#,
            "edges[0]: \"type\"",
        ),
    ] {
        std::fs::write(&path, bad).unwrap();
        let dst = Store::create(dir.path().join("bad.og")).unwrap();
        let e = import_node_link(&dst, &path, "R", 100, &mut |_, _| {})
            .expect_err(bad)
            .to_string();
        assert!(e.contains(says), "{bad}: {e}");
        drop(dst);
        std::fs::remove_file(dir.path().join("bad.og")).unwrap();
    }
}

/// An import into an empty store holds the adjacency back and writes it at the end, and also
/// when a later batch fails: the batches that stay are whole (adjacency, counts, consistency).
#[test]
fn held_back_adjacency_is_written_on_success_and_on_failure() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "nodes.csv", ":ID\n1\n2\n3\n");
    let rels = ":START_ID,:END_ID,:TYPE\n1,2,R\n2,3,R\n3,1,R\n";
    for bad in [false, true] {
        let sub = dir.path().join(format!("bad{bad}"));
        std::fs::create_dir_all(&sub).unwrap();
        std::fs::copy(dir.path().join("nodes.csv"), sub.join("nodes.csv")).unwrap();
        let text = if bad {
            format!("{rels}1,9,R\n")
        } else {
            rels.to_string()
        };
        write(&sub, "relationships.csv", &text);
        let store = Store::create(sub.join("g.og")).unwrap();
        let files = CsvFiles::from_folder(&sub).unwrap();
        let got = import_neo4j_csv(&store, &files, 1, &mut |_, _| {});
        if bad {
            let e = got.expect_err("row 5 names a missing node").to_string();
            assert!(e.contains("relationships.csv:5"), "{e}");
        } else {
            assert_eq!(got.unwrap().relationships, 3);
        }
        assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
        assert_eq!(store.counts().unwrap().total_relationships, 3);
        let r = store.read().unwrap();
        for (node, other) in [(1, 2), (2, 3), (3, 1)] {
            let out = r
                .neighbours(node, graphstore::Direction::Outgoing, None)
                .unwrap();
            assert_eq!(out.len(), 1, "bad={bad} node {node}");
            assert_eq!(out[0].other, other);
        }
    }
}

/// The bulk path checks a type's end labels against the schema, also for an end first seen
/// on a row whose type names no labels.
#[test]
fn bulk_relationships_check_end_labels() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("g.og")).unwrap();
    let mut schema = graphstore::Schema::default();
    schema.relationships.insert(
        "IN".into(),
        graphstore::RelRule {
            from_labels: vec!["A".into()],
            to_labels: vec!["B".into()],
            ..Default::default()
        },
    );
    store.set_schema(schema).unwrap();
    let (a, b) = store
        .write(|tx| {
            Ok((
                tx.create_node_named(&["A"], &[])?,
                tx.create_node_named(&["B"], &[])?,
            ))
        })
        .unwrap();
    let attempt = |rows: &[(u64, &str, u64)]| {
        store.write(|tx| {
            let rows = rows
                .iter()
                .map(|(s, t, e)| Ok((*s, tx.rel_type_id(t)?, *e, Vec::new())))
                .collect::<graphstore::Result<Vec<_>>>()?;
            tx.create_rels(rows)
                .map_err(|(i, e)| graphstore::Error::InvalidValue(format!("row {i}: {e}")))
        })
    };
    // b is seen first by a type without rules, then ends wrongly as the start of IN
    let e = attempt(&[(b, "FREE", a), (b, "IN", a)]).expect_err("B cannot start IN");
    assert!(
        e.to_string().contains("row 1") && e.to_string().contains("must be labelled A"),
        "{e}"
    );
    assert_eq!(attempt(&[(b, "FREE", a), (a, "IN", b)]).unwrap().len(), 2);
    assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
}

/// Node rows keeping their ids are written in bulk (appended through cursors when their ids
/// ascend) or one by one (ids out of order, a unique property): every way gives the graph a
/// row-by-row reference gives, the label index and counts included.
#[test]
fn bulk_node_rows_equal_one_by_one() {
    let dir = tempfile::tempdir().unwrap();
    // two labels per row, so a later batch's label rows fall before the index's last row;
    // a second file with ids out of order
    let mut a = String::from(":ID,n:int,:LABEL\n");
    for i in 0..50u64 {
        a.push_str(&format!("{i},{},X;Y\n", i * 3));
    }
    let b = ":ID,n:int,:LABEL\n90,1,Z\n70,2,Z;X\n80,3,Z\n";
    write(dir.path(), "nodes_a.csv", &a);
    write(dir.path(), "nodes_b.csv", b);
    let files = || CsvFiles::from_folder(dir.path()).unwrap();
    let reference = |unique: bool| {
        let store = Store::create(dir.path().join(format!("ref{unique}.og"))).unwrap();
        if unique {
            store.set_schema(unique_n()).unwrap();
        }
        store
            .write(|tx| {
                tx.reserve_node_ids(91);
                for i in 0..50u64 {
                    let ls = [tx.label_id("X")?, tx.label_id("Y")?];
                    let k = tx.prop_key_id("n")?;
                    tx.restore_node(i, &ls, vec![(k, Value::Int(i as i64 * 3))])?;
                }
                for (id, n, labels) in [(90, 1, &["Z"][..]), (70, 2, &["Z", "X"]), (80, 3, &["Z"])]
                {
                    let ls = labels
                        .iter()
                        .map(|l| tx.label_id(l))
                        .collect::<graphstore::Result<Vec<_>>>()?;
                    let k = tx.prop_key_id("n")?;
                    tx.restore_node(id, &ls, vec![(k, Value::Int(n))])?;
                }
                Ok(())
            })
            .unwrap();
        store
    };
    let counts = |s: &Store| {
        let q = s
            .query(
                "MATCH (n:X) WITH count(n) AS x MATCH (m:Y) WITH x, count(m) AS y \
                 MATCH (z:Z) RETURN x, y, count(z)",
                &graphstore::cypher::QueryOptions::default(),
            )
            .unwrap();
        format!("{:?} {:?}", q.rows, s.counts().unwrap())
    };
    for (batch, unique) in [(7, false), (1000, false), (7, true)] {
        let store = Store::create(dir.path().join(format!("g{batch}{unique}.og"))).unwrap();
        if unique {
            store.set_schema(unique_n()).unwrap();
        }
        let got = import_neo4j_csv(&store, &files(), batch, &mut |_, _| {}).unwrap();
        assert_eq!((got.nodes, got.ids_kept), (53, true));
        let want = reference(unique);
        assert_eq!(
            canon(&store),
            canon(&want),
            "batch {batch}, unique {unique}"
        );
        assert_eq!(
            counts(&store),
            counts(&want),
            "batch {batch}, unique {unique}"
        );
        let r = store.read().unwrap();
        assert_eq!(r.nodes_with_label("Z").unwrap(), vec![70, 80, 90]);
        assert_eq!(r.nodes_with_label("X").unwrap().len(), 51);
        drop(r);
        std::fs::remove_file(dir.path().join(format!("ref{unique}.og"))).unwrap();
    }
    // a unique property still fails on a repeat in one batch
    let dup = tempfile::tempdir().unwrap();
    write(dup.path(), "nodes.csv", ":ID,n:int,:LABEL\n1,5,X\n2,5,X\n");
    let store = Store::create(dup.path().join("d.og")).unwrap();
    store.set_schema(unique_n()).unwrap();
    let e = import_neo4j_csv(
        &store,
        &CsvFiles::from_folder(dup.path()).unwrap(),
        100,
        &mut |_, _| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("nodes.csv:3") && e.contains("unique"), "{e}");
}

fn unique_n() -> graphstore::Schema {
    let mut s = graphstore::Schema::default();
    s.labels.insert(
        "X".into(),
        graphstore::LabelRule {
            unique: vec!["n".into()],
            ..Default::default()
        },
    );
    s
}
