//! The Cypher engine against the store: atomic writes, safety limits, index-aware plans,
//! index procedures, error positions, a reference model, and a parser fuzz.

use std::collections::BTreeMap;
use std::time::Duration;

use graphstore::cypher::{Engine, ErrorKind, QueryError, QueryOptions, Val};
use graphstore::{Error, Store, Value};
use proptest::prelude::*;
use scene::opengraph_schema;

fn store() -> (tempfile::TempDir, Store) {
    let dir = tempfile::tempdir().expect("tempdir");
    let s = Store::create(dir.path().join("g.og")).expect("store");
    (dir, s)
}

fn q(s: &Store, text: &str) -> graphstore::cypher::QueryResult {
    s.query(text, &QueryOptions::default())
        .unwrap_or_else(|e| panic!("{text}: {e}"))
}

fn qerr(s: &Store, text: &str, opts: &QueryOptions) -> QueryError {
    match s.query(text, opts) {
        Err(Error::Query(e)) => e,
        Err(other) => panic!("{text}: not a query error: {other}"),
        Ok(_) => panic!("{text}: expected an error"),
    }
}

fn count(s: &Store) -> (u64, u64) {
    let c = s.counts().expect("counts");
    (c.total_nodes, c.total_relationships)
}

/// An OpenGraph-schema store with a few instances and lane nodes.
fn city() -> (tempfile::TempDir, Store) {
    let (d, s) = store();
    s.set_schema(opengraph_schema()).expect("schema");
    s.write(|tx| {
        for i in 0..50i64 {
            let x = (i % 10) as f64 * 10.0;
            let y = (i / 10) as f64 * 10.0;
            let mut feature = vec![0.0f32; scene::FEATURE_DIM];
            feature[(i % 7) as usize] = 1.0;
            let class = ["bench", "car", "pole", "bus shelter", "tree"][(i % 5) as usize];
            tx.create_node_named(
                &["Instance"],
                &[
                    ("instance_id", Value::Int(i)),
                    ("caption", Value::from(format!("a {class} number {i}"))),
                    ("semantic_class", Value::from(class)),
                    ("centroid", Value::Point3D([x, y, 0.5])),
                    (
                        "bbox",
                        Value::box3d([x - 0.5, y - 0.5, 0.0], [x + 0.5, y + 0.5, 1.0]),
                    ),
                    ("feature", Value::Vector(feature)),
                ],
            )?;
        }
        let mut prev = None;
        for i in 0..20i64 {
            let n = tx.create_node_named(
                &["LaneNode"],
                &[
                    ("lane_id", Value::Int(i)),
                    ("kind", Value::from("breakpoint")),
                    ("position", Value::Point3D([i as f64 * 5.0, 0.0, 0.0])),
                ],
            )?;
            if let Some(p) = prev {
                tx.create_rel_named(p, "LANE_EDGE", n, &[("length_m", Value::Float(5.0))])?;
            }
            prev = Some(n);
        }
        Ok(())
    })
    .expect("fill");
    (d, s)
}

#[test]
fn a_failing_statement_leaves_the_store_as_it_was() {
    let (_d, s) = store();
    q(&s, "CREATE (:A {v: 1})-[:R]->(:B)");
    let before = count(&s);
    // creates, then divides by zero in the same statement
    let e = qerr(
        &s,
        "CREATE (a:A {v: 2}) WITH a RETURN 1 / 0",
        &QueryOptions::default(),
    );
    assert_eq!(e.kind, ErrorKind::Argument);
    assert_eq!(count(&s), before);
    // deleting a connected node fails; nothing else of the statement stays either
    let e = qerr(
        &s,
        "MATCH (b:B) SET b.touched = true WITH b MATCH (a:A) DELETE a",
        &QueryOptions::default(),
    );
    assert_eq!(e.kind, ErrorKind::Constraint);
    let r = q(&s, "MATCH (b:B) RETURN b.touched");
    assert_eq!(r.rows, vec![vec![Val::Null]]);
    assert_eq!(count(&s), before);
    // a successful write is one transaction with its statistics
    let r = q(&s, "MATCH (a:A) DETACH DELETE a");
    assert_eq!(
        (r.stats.nodes_deleted, r.stats.relationships_deleted),
        (1, 1)
    );
    assert_eq!(count(&s), (1, 0));
}

#[test]
fn read_only_timeout_and_row_limit() {
    let (_d, s) = store();
    let ro = QueryOptions {
        read_only: true,
        ..QueryOptions::default()
    };
    let e = qerr(&s, "MATCH (n)\nCREATE (m:X)", &ro);
    assert_eq!(e.kind, ErrorKind::ReadOnly);
    assert_eq!(e.pos.map(|p| (p.line, p.col)), Some((2, 1)));
    assert_eq!(count(&s), (0, 0));
    assert!(s.query("RETURN 1 AS one", &ro).is_ok());

    let slow = QueryOptions {
        timeout: Some(Duration::from_millis(200)),
        ..QueryOptions::default()
    };
    let t0 = std::time::Instant::now();
    let e = qerr(
        &s,
        "UNWIND range(1, 3000) AS x UNWIND range(1, 3000) AS y RETURN count(*)",
        &slow,
    );
    assert_eq!(e.kind, ErrorKind::Timeout);
    assert!(
        t0.elapsed() < Duration::from_secs(20),
        "timeout took {:?}",
        t0.elapsed()
    );

    let limited = QueryOptions {
        row_limit: Some(10),
        ..QueryOptions::default()
    };
    assert_eq!(
        s.query("UNWIND range(1, 10) AS x RETURN x", &limited)
            .map(|r| r.rows.len())
            .ok(),
        Some(10)
    );
    assert_eq!(
        qerr(&s, "UNWIND range(1, 11) AS x RETURN x", &limited).kind,
        ErrorKind::RowLimit
    );
    // a runaway intermediate result stops at the cap instead of eating memory: rows an
    // operator holds (a sort) count, on both engines
    let capped = QueryOptions {
        max_intermediate_rows: 100_000,
        ..QueryOptions::default()
    };
    for engine in [Engine::Auto, Engine::Interpreter] {
        let e = qerr(
            &s,
            "UNWIND range(1, 1000) AS x UNWIND range(1, 1000) AS y RETURN x, y ORDER BY y DESC",
            &QueryOptions {
                engine,
                ..capped.clone()
            },
        );
        assert_eq!(
            (e.kind, e.code),
            (ErrorKind::RowLimit, "IntermediateRowLimit")
        );
    }
    // the interpreter holds the rows of two UNWINDs before counting them; the pipeline
    // streams them into the count and holds none
    let e = qerr(
        &s,
        "UNWIND range(1, 1000) AS x UNWIND range(1, 1000) AS y RETURN count(*)",
        &QueryOptions {
            engine: Engine::Interpreter,
            ..capped.clone()
        },
    );
    assert_eq!(
        (e.kind, e.code),
        (ErrorKind::RowLimit, "IntermediateRowLimit")
    );
    let r = s
        .query(
            "UNWIND range(1, 1000) AS x UNWIND range(1, 1000) AS y RETURN count(*) AS n",
            &capped,
        )
        .expect("streamed");
    assert_eq!(r.rows, vec![vec![Val::Int(1_000_000)]]);
    let r = s
        .query(
            "UNWIND range(1, 300) AS x UNWIND range(1, 300) AS y RETURN count(*) AS n",
            &capped,
        )
        .expect("under the cap");
    assert_eq!(r.rows, vec![vec![Val::Int(90_000)]]);
}

#[test]
fn errors_carry_line_and_column() {
    let (_d, s) = store();
    let o = QueryOptions::default();
    let e = qerr(&s, "MATCH (n)\nRETURN m.name", &o);
    assert_eq!(
        (e.code, e.pos.map(|p| (p.line, p.col))),
        ("UndefinedVariable", Some((2, 8)))
    );
    let e = qerr(&s, "MATCH (n)\nWHERE n.x = 1\nRETURN nosuch(n)", &o);
    assert_eq!(
        (e.code, e.pos.map(|p| (p.line, p.col))),
        ("UnknownFunction", Some((3, 8)))
    );
    let e = qerr(&s, "MATCH (n) RETURN n ORDER", &o);
    assert_eq!(e.kind, ErrorKind::Syntax);
    assert_eq!(e.pos.map(|p| (p.line, p.col)), Some((1, 25)));
    let e = qerr(&s, "RETURN 'unterminated", &o);
    assert_eq!(e.pos.map(|p| (p.line, p.col)), Some((1, 8)));
    assert!(e.to_string().contains("line 1, column 8"), "{e}");
    let e = qerr(&s, "RETURN $missing", &o);
    assert_eq!(e.kind, ErrorKind::Parameter);
    // a runtime error points at least at its clause
    let e = qerr(&s, "UNWIND [1, 2] AS x\nWITH x\nRETURN x + true", &o);
    assert_eq!((e.kind, e.pos.map(|p| p.line)), (ErrorKind::Type, Some(3)));
}

#[test]
fn parameters_lists_maps_case_and_functions() {
    let (_d, s) = store();
    let mut o = QueryOptions::default();
    o.params.insert(
        "names".into(),
        Val::List(vec![Val::Str("b".into()), Val::Str("a".into())]),
    );
    let r = s
        .query(
            "UNWIND $names AS n WITH n ORDER BY n RETURN collect(toUpper(n)) AS up, \
             CASE WHEN size($names) > 1 THEN 'many' ELSE 'one' END AS how, \
             [x IN range(1, 5) WHERE x % 2 = 1 | x * x] AS odd_squares, {k: 1}.k AS k",
            &o,
        )
        .expect("query");
    assert_eq!(r.columns, ["up", "how", "odd_squares", "k"]);
    assert_eq!(
        r.rows[0],
        vec![
            Val::List(vec![Val::Str("A".into()), Val::Str("B".into())]),
            Val::Str("many".into()),
            Val::List(vec![Val::Int(1), Val::Int(9), Val::Int(25)]),
            Val::Int(1),
        ]
    );
    let r = q(
        &s,
        "RETURN point.distance(point({x: 0, y: 0, z: 0}), point({x: 3, y: 4, z: 0})) AS d, vector.similarity.cosine([1, 0], [0, 1]) AS c",
    );
    let (Val::Float(d), Val::Float(c)) = (&r.rows[0][0], &r.rows[0][1]) else {
        panic!("{:?}", r.rows)
    };
    assert!(
        (d - 5.0).abs() < 1e-12 && (c - 0.5).abs() < 1e-12,
        "{d} {c}"
    );
}

#[test]
fn the_planner_uses_indexes_and_explain_shows_it() {
    let (_d, s) = city();
    let plan = s
        .explain("MATCH (i:Instance {instance_id: 7}) RETURN i.caption")
        .expect("explain");
    assert!(
        plan.contains("NodeIndexSeek i:Instance(instance_id = 7)"),
        "{plan}"
    );
    let plan = s
        .explain("MATCH (i:Instance) WHERE i.instance_id >= 40 RETURN count(*)")
        .expect("explain");
    assert!(plan.contains("NodeIndexRangeScan"), "{plan}");
    let plan = s
        .explain("MATCH (a:LaneNode)-[:LANE_EDGE]->(b:LaneNode {lane_id: 3}) RETURN a")
        .expect("explain");
    assert!(
        plan.contains("NodeIndexSeek b:LaneNode(lane_id = 3)")
            && plan.contains("Expand (b:LaneNode)<-[:LANE_EDGE]-(a:LaneNode)"),
        "{plan}"
    );
    let plan = s.explain("MATCH (n:Instance) RETURN n").expect("explain");
    assert!(plan.contains("NodeByLabelScan n:Instance"), "{plan}");
    // of two label scans the smaller label (20 lane nodes against 50 instances) goes first
    let plan = s
        .explain("MATCH (a:Instance)-[:NEAR]-(b:LaneNode) RETURN a")
        .expect("explain");
    assert!(plan.contains("NodeByLabelScan b:LaneNode"), "{plan}");
    let r = q(&s, "EXPLAIN MATCH (n) RETURN n");
    assert!(
        r.plan
            .as_deref()
            .is_some_and(|p| p.contains("AllNodesScan n"))
            && r.rows.is_empty()
    );

    // the index answers the same as a full scan
    let via_index = q(
        &s,
        "MATCH (i:Instance) WHERE i.instance_id >= 40 AND i.instance_id < 45 RETURN i.instance_id AS id ORDER BY id",
    );
    let via_scan = q(
        &s,
        "MATCH (i) WHERE i.instance_id + 0 >= 40 AND i.instance_id + 0 < 45 RETURN i.instance_id AS id ORDER BY id",
    );
    assert_eq!(via_index.rows, via_scan.rows);
    assert_eq!(via_index.rows.len(), 5);
    let r = q(
        &s,
        "MATCH (a:LaneNode)-[:LANE_EDGE]->(b:LaneNode {lane_id: 3}) RETURN a.lane_id",
    );
    assert_eq!(r.rows, vec![vec![Val::Int(2)]]);
}

#[test]
fn ground_procedures_measure_on_the_declared_ground_plane() {
    let (_d, s) = city();
    let ids = |r: graphstore::cypher::QueryResult| -> Vec<i64> {
        r.rows
            .iter()
            .map(|row| match row[0] {
                Val::Int(i) => i,
                ref o => panic!("{o:?}"),
            })
            .collect()
    };
    let run = |axes: Option<[usize; 2]>, text: &str| {
        let o = QueryOptions {
            ground_axes: axes,
            ..QueryOptions::default()
        };
        s.query(text, &o)
    };
    // the city's objects stand on x, y (an enu ground): 100 m above the origin is over it
    let high = "CALL db.index.spatial.withinGroundDistance('instance_space', point({x: 0, y: 0, z: 100}), 14.0) \
                YIELD node RETURN node.instance_id AS id ORDER BY id";
    assert_eq!(
        ids(run(Some([0, 1]), high).expect("enu")),
        vec![0, 1, 10, 11]
    );
    let r = q(
        &s,
        "CALL db.index.spatial.withinDistance('instance_space', point({x: 0, y: 0, z: 100}), 14.0) YIELD node RETURN node",
    );
    assert!(
        r.rows.is_empty(),
        "3-D distance from 100 m up finds nothing"
    );
    // a kitti_cam ground (x, z): every box spans z 0..1, so only x separates them
    let kitti = "CALL db.index.spatial.withinGroundDistance('instance_space', [0, 0.5], 0.6) \
                 YIELD node, distance RETURN node.instance_id AS id ORDER BY id";
    assert_eq!(
        ids(run(Some([0, 2]), kitti).expect("kitti")),
        vec![0, 10, 20, 30, 40]
    );
    let nearest = "CALL db.index.spatial.nearestOnGround('instance_space', [30.2, 19.8], 3) \
                   YIELD node, distance RETURN node.instance_id AS id, distance";
    let r = run(Some([0, 1]), nearest).expect("nearest");
    // (30.2, 19.8) lies over the box around (30, 20), instance 23
    assert_eq!(r.rows[0][0], Val::Int(23));
    assert!(matches!(r.rows[0][1], Val::Float(d) if d.abs() < 1e-9));
    assert_eq!(r.rows.len(), 3);
    // no ground plane declared: the ground procedures say so
    let e = match run(None, kitti) {
        Err(Error::Query(e)) => e,
        other => panic!("{other:?}"),
    };
    assert_eq!((e.kind, e.code), (ErrorKind::Procedure, "NoGroundPlane"));
    // with a ground plane, a 2-D point given to the 3-D procedures is refused, not read as z = 0
    let e = match run(
        Some([0, 2]),
        "CALL db.index.spatial.withinDistance('instance_space', [0, 0.5], 3.0) YIELD node RETURN node",
    ) {
        Err(Error::Query(e)) => e,
        other => panic!("{other:?}"),
    };
    assert!(e.message.contains("withinGroundDistance"), "{e}");
}

#[test]
fn procedures_query_the_vector_spatial_and_text_indexes() {
    let (_d, s) = city();
    let mut o = QueryOptions::default();
    let mut query = vec![Val::Float(0.0); scene::FEATURE_DIM];
    query[3] = Val::Float(1.0);
    o.params.insert("q".into(), Val::List(query));
    let r = s
        .query(
            "CALL db.index.vector.queryNodes('instance_feature', 5, $q) YIELD node, score \
             RETURN node.instance_id % 7 AS slot, score",
            &o,
        )
        .expect("vector");
    assert_eq!(r.rows.len(), 5);
    for row in &r.rows {
        assert_eq!(row[0], Val::Int(3));
        assert!(matches!(row[1], Val::Float(f) if (f - 1.0).abs() < 1e-6));
    }
    let r = q(
        &s,
        "CALL db.index.spatial.withinDistance('instance_space', point({x: 0, y: 0, z: 0}), 14.0) YIELD node, distance RETURN node.instance_id AS id ORDER BY id",
    );
    // boxes within 14 m of the origin: (0,0), (10,0), (0,10), (10,10)
    assert_eq!(
        r.rows,
        vec![
            vec![Val::Int(0)],
            vec![Val::Int(1)],
            vec![Val::Int(10)],
            vec![Val::Int(11)]
        ]
    );
    let r = q(
        &s,
        "CALL db.index.spatial.inBox('instance_space', point({x: 15, y: -1, z: 0}), point({x: 25, y: 1, z: 1})) YIELD node RETURN node.instance_id",
    );
    assert_eq!(r.rows, vec![vec![Val::Int(2)]]);
    let r = q(
        &s,
        "CALL db.index.fulltext.queryNodes('instance_caption', 'shelter', 3) YIELD node RETURN node.semantic_class AS c",
    );
    assert_eq!(r.rows.len(), 3);
    assert!(
        r.rows
            .iter()
            .all(|row| row[0] == Val::Str("bus shelter".into()))
    );
    let e = qerr(
        &s,
        "CALL db.index.vector.queryNodes('nope', 5, [1.0]) YIELD node RETURN node",
        &QueryOptions::default(),
    );
    assert_eq!(e.kind, ErrorKind::Procedure);
    let e = qerr(
        &s,
        "CALL no.such.proc() YIELD x RETURN x",
        &QueryOptions::default(),
    );
    assert_eq!(e.code, "ProcedureNotFound");
    // a list of numbers written to a schema vector property becomes a vector the index sees
    let mut o = QueryOptions::default();
    let mut v = vec![Val::Float(0.0); scene::FEATURE_DIM];
    v[100] = Val::Float(1.0);
    o.params.insert("v".into(), Val::List(v));
    s.query("MATCH (i:Instance {instance_id: 9}) SET i.feature = $v", &o)
        .expect("set feature");
    let r = s
        .query(
            "CALL db.index.vector.queryNodes('instance_feature', 1, $v) YIELD node RETURN node.instance_id",
            &o,
        )
        .expect("vector");
    assert_eq!(r.rows, vec![vec![Val::Int(9)]]);
}

#[test]
fn variable_length_paths_union_and_optional_match() {
    let (_d, s) = city();
    let r = q(
        &s,
        "MATCH p = (a:LaneNode {lane_id: 0})-[:LANE_EDGE*2..3]->(b) RETURN b.lane_id AS id, length(p) AS hops ORDER BY id",
    );
    assert_eq!(
        r.rows,
        vec![
            vec![Val::Int(2), Val::Int(2)],
            vec![Val::Int(3), Val::Int(3)]
        ]
    );
    let r = q(
        &s,
        "MATCH (a:LaneNode {lane_id: 19}) OPTIONAL MATCH (a)-[:LANE_EDGE]->(b) RETURN a.lane_id, b",
    );
    assert_eq!(r.rows, vec![vec![Val::Int(19), Val::Null]]);
    let r = q(
        &s,
        "MATCH (i:Instance) RETURN i.semantic_class AS c UNION MATCH (i:Instance) RETURN i.semantic_class AS c",
    );
    assert_eq!(r.rows.len(), 5);
    let r = q(
        &s,
        "MATCH (i:Instance) RETURN i.semantic_class AS c, count(*) AS n ORDER BY n DESC, c LIMIT 2",
    );
    assert_eq!(
        r.rows,
        vec![
            vec![Val::Str("bench".into()), Val::Int(10)],
            vec![Val::Str("bus shelter".into()), Val::Int(10)]
        ]
    );
}

#[test]
fn merge_set_remove_and_schema_errors() {
    let (_d, s) = city();
    let r = q(
        &s,
        "MERGE (e:Environment {name: 'sim'}) ON CREATE SET e.source = 'test' RETURN e.source",
    );
    assert_eq!(r.rows, vec![vec![Val::Str("test".into())]]);
    let r = q(
        &s,
        "MERGE (e:Environment {name: 'sim'}) ON MATCH SET e.source = 'again' RETURN e.source",
    );
    assert_eq!(r.rows, vec![vec![Val::Str("again".into())]]);
    assert_eq!(
        q(&s, "MATCH (e:Environment) RETURN count(e)").rows,
        vec![vec![Val::Int(1)]]
    );
    q(&s, "MATCH (e:Environment) REMOVE e.source SET e:Root");
    let r = q(&s, "MATCH (e:Root) RETURN e.source, labels(e)");
    assert_eq!(
        r.rows,
        vec![vec![
            Val::Null,
            Val::List(vec![
                Val::Str("Environment".into()),
                Val::Str("Root".into())
            ])
        ]]
    );
    // the schema's unique key still holds, and the failed write changes nothing
    let before = count(&s);
    let e = qerr(
        &s,
        "CREATE (:Environment {name: 'other'}), (:Environment {name: 'sim'})",
        &QueryOptions::default(),
    );
    assert_eq!(e.kind, ErrorKind::Constraint);
    assert_eq!(count(&s), before);
}

// ----------------------------------------------------------- reference model

/// A store with nodes `(:N {v: 0..n})` and a relationship `(start)-[:TYPE]->(end)` for each
/// `(start, end, TYPE)` of `edges`, by `v`.
fn numbered_graph(n: usize, edges: &[(usize, usize, &str)]) -> (tempfile::TempDir, Store) {
    let (d, s) = store();
    s.write(|tx| {
        let ids: Vec<u64> = (0..n)
            .map(|i| tx.create_node_named(&["N"], &[("v", Value::Int(i as i64))]))
            .collect::<Result<_, _>>()?;
        for (a, b, ty) in edges {
            tx.create_rel_named(ids[*a], ty, ids[*b], &[])?;
        }
        Ok(())
    })
    .expect("fill");
    (d, s)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    /// Counts of a 2-hop pattern with a filter match a brute-force count over the same edges.
    #[test]
    fn two_hop_counts_match_a_reference(
        n in 2usize..12,
        edges in proptest::collection::vec((0usize..12, 0usize..12), 0..30),
        threshold in 0i64..12,
    ) {
        let edges: Vec<(usize, usize)> = edges.into_iter().map(|(a, b)| (a % n, b % n)).collect();
        let typed: Vec<(usize, usize, &str)> = edges.iter().map(|&(a, b)| (a, b, "R")).collect();
        let (_d, s) = numbered_graph(n, &typed);
        let r = s.query(
            &format!("MATCH (a:N)-[r1:R]->(b)-[r2:R]->(c) WHERE c.v >= {threshold} RETURN count(*) AS n"),
            &QueryOptions::default(),
        ).expect("query");
        // reference: ordered pairs of distinct edges e1, e2 with e1.end == e2.start
        let mut expected = 0i64;
        for (i, e1) in edges.iter().enumerate() {
            for (j, e2) in edges.iter().enumerate() {
                if i != j && e1.1 == e2.0 && e2.1 as i64 >= threshold {
                    expected += 1;
                }
            }
        }
        prop_assert_eq!(&r.rows, &vec![vec![Val::Int(expected)]]);
        // and grouping agrees with a reference per start node
        let r = s.query("MATCH (a:N)-->(b) RETURN a.v AS v, count(b) AS k ORDER BY v", &QueryOptions::default()).expect("group");
        let mut per: BTreeMap<i64, i64> = BTreeMap::new();
        for (a, _) in &edges {
            *per.entry(*a as i64).or_default() += 1;
        }
        let want: Vec<Vec<Val>> = per.into_iter().map(|(v, k)| vec![Val::Int(v), Val::Int(k)]).collect();
        prop_assert_eq!(r.rows, want);
    }
}

/// Reference breadth-first search over `edges` (typed `A` or `B`; `both`: either way) from
/// `s`: for every node, the fewest hops from `s` and how many shortest paths reach it
/// (each relationship counts as its own path).
fn reference_bfs(
    n: usize,
    edges: &[(usize, usize, bool)],
    s: usize,
    both: bool,
) -> (Vec<Option<usize>>, Vec<u64>) {
    let mut depth = vec![None; n];
    let mut ways = vec![0u64; n];
    depth[s] = Some(0);
    ways[s] = 1;
    let mut frontier = vec![s];
    let mut d = 0;
    while !frontier.is_empty() {
        let mut next = Vec::new();
        for &u in &frontier {
            for &(a, b, is_a) in edges {
                if !is_a {
                    continue;
                }
                let mut hop = |v: usize| {
                    if depth[v].is_none() {
                        depth[v] = Some(d + 1);
                        next.push(v);
                    }
                    if depth[v] == Some(d + 1) {
                        ways[v] += ways[u];
                    }
                };
                if a == u {
                    hop(b);
                }
                if both && b == u && a != b {
                    hop(a);
                }
            }
        }
        frontier = next;
        d += 1;
    }
    (depth, ways)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    /// shortestPath's length and allShortestPaths' count against a reference breadth-first
    /// search, directed and undirected, over relationships of one type among two.
    #[test]
    fn shortest_paths_match_a_reference(
        n in 2usize..10,
        edges in proptest::collection::vec((0usize..10, 0usize..10, proptest::bool::ANY), 0..24),
        s_i in 0usize..10,
        t_i in 0usize..10,
        both in proptest::bool::ANY,
    ) {
        let edges: Vec<(usize, usize, bool)> = edges.into_iter().map(|(a, b, t)| (a % n, b % n, t)).collect();
        let (s_i, t_i) = (s_i % n, t_i % n);
        let typed: Vec<(usize, usize, &str)> = edges.iter().map(|&(a, b, is_a)| (a, b, if is_a { "A" } else { "B" })).collect();
        let (_d, s) = numbered_graph(n, &typed);
        let arrow = if both { "-" } else { "->" };
        let mut o = QueryOptions::default();
        o.params.insert("s".into(), Val::Int(s_i as i64));
        o.params.insert("t".into(), Val::Int(t_i as i64));
        let one = s.query(
            &format!("MATCH (a:N {{v: $s}}), (b:N {{v: $t}}) MATCH p = shortestPath((a)-[:A*]{arrow}(b)) RETURN length(p) AS len, [x IN nodes(p) | x.v] AS vs"),
            &o,
        ).expect("shortestPath");
        let all = s.query(
            &format!("MATCH (a:N {{v: $s}}), (b:N {{v: $t}}) MATCH p = allShortestPaths((a)-[r:A*]{arrow}(b)) RETURN length(p) AS len, size(r) AS k"),
            &o,
        ).expect("allShortestPaths");
        let (depth, ways) = reference_bfs(n, &edges, s_i, both);
        match depth[t_i] {
            Some(d) if d >= 1 => {
                prop_assert_eq!(one.rows.len(), 1);
                prop_assert_eq!(&one.rows[0][0], &Val::Int(d as i64));
                // the path runs from s to t, one A relationship a hop
                let Val::List(vs) = &one.rows[0][1] else { panic!() };
                prop_assert_eq!(vs.first(), Some(&Val::Int(s_i as i64)));
                prop_assert_eq!(vs.last(), Some(&Val::Int(t_i as i64)));
                prop_assert_eq!(all.rows.len() as u64, ways[t_i]);
                for row in &all.rows {
                    prop_assert_eq!(&row[0], &Val::Int(d as i64));
                    prop_assert_eq!(&row[1], &Val::Int(d as i64));
                }
            }
            // unreachable, or the start itself (a path needs at least one hop)
            _ => {
                prop_assert!(one.rows.is_empty());
                prop_assert!(all.rows.is_empty());
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, .. ProptestConfig::default() })]

    /// COUNT { } and EXISTS { } against counts over the same edges: per node, the outgoing
    /// edges to a node at or past a threshold, and whether a 2-hop walk of distinct edges
    /// starts there.
    #[test]
    fn count_and_exists_subqueries_match_a_reference(
        n in 1usize..10,
        edges in proptest::collection::vec((0usize..10, 0usize..10), 0..24),
        threshold in 0i64..10,
    ) {
        let edges: Vec<(usize, usize)> = edges.into_iter().map(|(a, b)| (a % n, b % n)).collect();
        let typed: Vec<(usize, usize, &str)> = edges.iter().map(|&(a, b)| (a, b, "R")).collect();
        let (_d, s) = numbered_graph(n, &typed);
        let r = s.query(
            &format!("MATCH (a:N) RETURN a.v AS v, COUNT {{ (a)-[:R]->(b) WHERE b.v >= {threshold} }} AS k, \
                      EXISTS {{ MATCH (a)-[:R]->()-[:R]->() }} AS two ORDER BY v"),
            &QueryOptions::default(),
        ).expect("subqueries");
        let want: Vec<Vec<Val>> = (0..n).map(|a| {
            let k = edges.iter().filter(|(x, y)| *x == a && *y as i64 >= threshold).count();
            let two = edges.iter().enumerate().any(|(i, e1)| e1.0 == a
                && edges.iter().enumerate().any(|(j, e2)| i != j && e2.0 == e1.1));
            vec![Val::Int(a as i64), Val::Int(k as i64), Val::Bool(two)]
        }).collect();
        prop_assert_eq!(r.rows, want);
    }
}

#[test]
fn subquery_expressions_scope_and_errors() {
    let (_d, s) = store();
    q(
        &s,
        "CREATE (a:P {v: 1})-[:K]->(:P {v: 2}), (a)-[:K]->(:P {v: 3}), (:P {v: 4})",
    );
    // in WHERE, with a variable of its own that does not leak
    let r = q(
        &s,
        "MATCH (a:P) WHERE EXISTS { (a)-[:K]->(b:P) WHERE b.v > 2 } RETURN a.v",
    );
    assert_eq!(r.rows, vec![vec![Val::Int(1)]]);
    let r = q(&s, "MATCH (a:P) WHERE COUNT { (a)--() } = 0 RETURN a.v");
    assert_eq!(r.rows, vec![vec![Val::Int(4)]]);
    let e = qerr(
        &s,
        "MATCH (a:P) WHERE EXISTS { (a)-[:K]->(b) } RETURN b",
        &QueryOptions::default(),
    );
    assert_eq!(e.code, "UndefinedVariable", "{e}");
    let e = qerr(
        &s,
        "MATCH (a:P) RETURN COUNT { MATCH (a)-->(b) RETURN b }",
        &QueryOptions::default(),
    );
    assert_eq!(e.kind, ErrorKind::Syntax, "{e}");
    // count(...) and count(*) are still the aggregate
    let r = q(&s, "MATCH (a:P) RETURN count(*), count(a.v)");
    assert_eq!(r.rows, vec![vec![Val::Int(4), Val::Int(4)]]);
}

#[test]
fn profile_returns_the_rows_and_rows_and_time_per_operator() {
    let (_d, s) = store();
    q(
        &s,
        "UNWIND range(1, 10) AS i CREATE (:P {v: i})-[:K]->(:Q {v: i * 2})",
    );
    let text = "MATCH (p:P)-[:K]->(x) WHERE p.v > 3 WITH p, x ORDER BY p.v LIMIT 4 RETURN p.v, x.v";
    let plain = q(&s, text);
    let prof = q(&s, &format!("PROFILE {text}"));
    assert_eq!(prof.columns, plain.columns);
    assert_eq!(prof.rows, plain.rows);
    assert!(plain.plan.is_none());
    let plan = prof.plan.expect("a profile");
    let steps: Vec<&str> = plan
        .lines()
        .skip_while(|l| !l.starts_with("Profile"))
        .skip(1)
        .map(str::trim)
        .collect();
    let rows_of = |op: &str| -> Option<u64> {
        let line = steps.iter().find(|l| l.starts_with(op))?;
        line.rsplit_once(": ")?.1.split(' ').next()?.parse().ok()
    };
    // 10 P nodes scanned, 7 pass the filter (pushed below the expansion), 7 expanded, the
    // top-4 sort hands on 4, and 4 rows are produced
    assert_eq!(rows_of("NodeByLabelScan p:P"), Some(10), "{plan}");
    assert_eq!(rows_of("Filter p.v > 3"), Some(7), "{plan}");
    assert_eq!(rows_of("Expand (p:P)-[:K]->(x)"), Some(7), "{plan}");
    assert_eq!(rows_of("Top p.v"), Some(4), "{plan}");
    assert_eq!(rows_of("Limit 4"), Some(4), "{plan}");
    assert_eq!(rows_of("ProduceResults p.v, x.v"), Some(4), "{plan}");
    assert!(
        steps.iter().all(|l| l.ends_with(" ms")),
        "every operator has its time: {plan}"
    );
    // the physical plan and the logical plan come first
    assert!(plan.starts_with("Physical plan"), "{plan}");
    assert!(plan.contains("Logical plan"), "{plan}");
    // a streamed aggregation and a count from the store say so
    let agg = q(&s, "PROFILE MATCH (p:P)-->(x) RETURN count(x)")
        .plan
        .unwrap();
    assert!(
        agg.contains("Aggregate (grouping keys: none) count: 1 rows"),
        "{agg}"
    );
    let count = q(&s, "PROFILE MATCH (p:P) RETURN count(*)").plan.unwrap();
    assert!(count.contains("CountFromStore: 1 rows"), "{count}");
    // the interpreter's profile is per clause
    let interp = s
        .query(
            &format!("PROFILE {text}"),
            &QueryOptions {
                engine: Engine::Interpreter,
                ..QueryOptions::default()
            },
        )
        .unwrap();
    assert_eq!(interp.rows, plain.rows);
    assert!(
        interp.plan.unwrap().contains("Match: 7 rows"),
        "the interpreter's profile"
    );
}

#[test]
fn shortest_path_forms_and_errors() {
    let (_d, s) = store();
    q(
        &s,
        "CREATE (a:L {v: 0})-[:LANE {length_m: 5.0}]->(b:L {v: 1})-[:LANE {length_m: 5.0}]->(c:L {v: 2}), \
         (a)-[:LANE {length_m: 1.0, closed: true}]->(c)",
    );
    // the one-hop path wins; a property map on the relationship steers the search
    let r = q(
        &s,
        "MATCH (a:L {v: 0}), (c:L {v: 2}) MATCH p = shortestPath((a)-[:LANE*]-(c)) RETURN length(p)",
    );
    assert_eq!(r.rows, vec![vec![Val::Int(1)]]);
    let r = q(
        &s,
        "MATCH (a:L {v: 0}), (c:L {v: 2}) MATCH p = shortestPath((a)-[:LANE* {length_m: 5.0}]-(c)) \
         RETURN length(p), reduce(m = 0.0, x IN relationships(p) | m + x.length_m) AS metres",
    );
    assert_eq!(r.rows, vec![vec![Val::Int(2), Val::Float(10.0)]]);
    // unbound ends are matched as any other node pattern; *0.. lets a node reach itself
    let r = q(
        &s,
        "MATCH p = shortestPath((x:L {v: 2})-[:LANE*0..]-(y:L {v: 2})) RETURN length(p)",
    );
    assert_eq!(r.rows, vec![vec![Val::Int(0)]]);
    let r = q(
        &s,
        "MATCH p = shortestPath((x:L)-[:LANE*..1]->(y:L)) RETURN x.v AS x, y.v AS y ORDER BY x, y",
    );
    assert_eq!(r.rows.len(), 3);
    // a single hop without a star, and OPTIONAL MATCH with no path
    let r = q(
        &s,
        "MATCH (c:L {v: 2}), (a:L {v: 0}) OPTIONAL MATCH p = shortestPath((c)-[:LANE]->(a)) RETURN p",
    );
    assert_eq!(r.rows, vec![vec![Val::Null]]);
    let explain = s
        .explain(
            "MATCH (a:L {v: 0}), (c:L {v: 2}) MATCH p = shortestPath((a)-[:LANE*]-(c)) RETURN p",
        )
        .expect("explain");
    assert!(explain.contains("ShortestPath"), "{explain}");
    for bad in [
        "MATCH p = shortestPath((a)-[:LANE*]-(b)-[:LANE]-(c)) RETURN p",
        "MATCH p = shortestPath((a)-[:LANE*2..]-(b)) RETURN p",
        "CREATE p = shortestPath((a)-[:LANE]->(b))",
    ] {
        let e = qerr(&s, bad, &QueryOptions::default());
        assert_eq!(e.code, "InvalidShortestPath", "{bad}: {e}");
    }
}

// ------------------------------------------------------------------- fuzzing

const SEEDS: &[&str] = &[
    "MATCH (a:Lane {id: 1}), (b:Lane) MATCH p = allShortestPaths((a)-[:NEXT*0..4]-(b)) RETURN b.id, length(p), nodes(p)",
    "MATCH (a:Lane {id: 1})-[:NEXT*1..3]->(b) WHERE b.x > 2 RETURN a, count(*) AS n ORDER BY n DESC LIMIT 5",
    "UNWIND [1, 2, 3] AS x WITH x WHERE x > 1 RETURN collect(x), sum(x), avg(x)",
    "CREATE (a:A {v: [1, 2]})-[:R {w: 0.5}]->(b:B) SET a.k = 'x' REMOVE b.z RETURN a",
    "MATCH (n) OPTIONAL MATCH (n)-[r]-(m) RETURN n, r, m UNION ALL RETURN 1 AS n, 2 AS r, 3 AS m",
    "RETURN CASE WHEN 1 < 2 THEN [x IN range(0, 3) | x ^ 2] ELSE null END AS v",
    "MERGE (n:N {k: 1}) ON CREATE SET n.c = 1 ON MATCH SET n.c = n.c + 1 RETURN n.c",
    "CALL db.labels() YIELD label RETURN label",
    "MATCH p = (a)-[*]->(b) WHERE all(x IN nodes(p) WHERE x.v IS NOT NULL) RETURN p, reduce(s = 0, r IN relationships(p) | s + 1)",
];

const TOKENS: &[&str] = &[
    "MATCH",
    "RETURN",
    "WITH",
    "WHERE",
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    "-",
    "->",
    "<-",
    ":",
    "*",
    "..",
    ",",
    ".",
    "n",
    "m",
    "x",
    "1",
    "2.5",
    "'s'",
    "$p",
    "=",
    "<",
    "+",
    "AND",
    "NOT",
    "IN",
    "CASE",
    "WHEN",
    "THEN",
    "END",
    "count",
    "|",
    "UNWIND",
    "AS",
    "CREATE",
    "DELETE",
    "SET",
    "ORDER BY",
    "LIMIT",
    "null",
    "\"",
    "`",
    "/*",
    "\\",
    "é",
    "0x",
    "9999999999999999999999",
];

fn run_fuzz(s: &Store, text: &str) {
    let o = QueryOptions {
        timeout: Some(Duration::from_millis(200)),
        row_limit: Some(1000),
        ..QueryOptions::default()
    };
    // any outcome but a panic is fine
    let _ = s.query(text, &o);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, .. ProptestConfig::default() })]

    #[test]
    fn random_token_soup_never_panics(toks in proptest::collection::vec(0usize..TOKENS.len(), 0..25)) {
        let (_d, s) = store();
        let text: Vec<&str> = toks.iter().map(|i| TOKENS[*i]).collect();
        run_fuzz(&s, &text.join(" "));
    }

    #[test]
    fn mutated_queries_never_panic(seed in 0usize..SEEDS.len(), cuts in proptest::collection::vec((0usize..200, 0usize..TOKENS.len(), 0u8..3), 1..4)) {
        let (_d, s) = store();
        s.query("CREATE (:Lane {id: 1, x: 3})-[:NEXT]->(:Lane {id: 2, x: 1})", &QueryOptions::default()).expect("seed graph");
        let mut text = SEEDS[seed].to_string();
        for (at, tok, op) in cuts {
            let mut at = at.min(text.len());
            while !text.is_char_boundary(at) {
                at -= 1;
            }
            match op {
                0 => text.insert_str(at, TOKENS[tok]),
                1 => {
                    let mut end = (at + 3).min(text.len());
                    while !text.is_char_boundary(end) {
                        end -= 1;
                    }
                    text.replace_range(at..end, "");
                }
                _ => text.truncate(at),
            }
        }
        run_fuzz(&s, &text);
    }

    #[test]
    fn arbitrary_unicode_never_panics(text in "\\PC{0,80}") {
        let (_d, s) = store();
        run_fuzz(&s, &text);
        prop_assert!(graphstore::cypher::validate(&text).is_ok() || graphstore::cypher::validate(&text).is_err());
    }
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let (_d, s) = store();
    let deep = format!("RETURN {}1{}", "(".repeat(5000), ")".repeat(5000));
    assert_eq!(
        qerr(&s, &deep, &QueryOptions::default()).kind,
        ErrorKind::Syntax
    );
    let deep = format!("RETURN {}1", "NOT ".repeat(5000));
    assert_eq!(
        qerr(&s, &deep, &QueryOptions::default()).kind,
        ErrorKind::Syntax
    );
    let deep = format!("RETURN {}1{}", "[".repeat(5000), "]".repeat(5000));
    assert_eq!(
        qerr(&s, &deep, &QueryOptions::default()).kind,
        ErrorKind::Syntax
    );
    // long operator chains nest to the left: bounded too, while 200 OR-ed tests still run
    let sum = format!("RETURN {} AS s", vec!["1"; 5000].join(" + "));
    assert_eq!(
        qerr(&s, &sum, &QueryOptions::default()).kind,
        ErrorKind::Syntax
    );
    let ors: Vec<String> = (0..200).map(|i| format!("x = {i}")).collect();
    let r = q(
        &s,
        &format!(
            "UNWIND [3, 500] AS x WITH x WHERE {} RETURN x",
            ors.join(" OR ")
        ),
    );
    assert_eq!(r.rows, vec![vec![Val::Int(3)]]);
    // variable-length paths are searched without recursion: a 3,000-hop chain is fine
    s.write(|tx| {
        let mut prev = tx.create_node_named(&["C"], &[("i", Value::Int(0))])?;
        for i in 1..3000 {
            let n = tx.create_node_named(&["C"], &[("i", Value::Int(i))])?;
            tx.create_rel_named(prev, "NEXT", n, &[])?;
            prev = n;
        }
        Ok(())
    })
    .expect("chain");
    let r = q(
        &s,
        "MATCH (a:C {i: 0})-[:NEXT*]->(b) RETURN count(b) AS n, max(b.i) AS last",
    );
    assert_eq!(r.rows, vec![vec![Val::Int(2999), Val::Int(2999)]]);
}

/// Mixed INTEGER/FLOAT comparison, equality, ordering, DISTINCT and grouping follow the exact
/// values at every magnitude: near 2^53, where floats skip integers, and at the ends of the
/// i64 range, where i64::MAX rounds to 2^63 as a float.
#[test]
fn integers_and_floats_compare_by_exact_value() {
    let (_d, s) = store();
    let row = |text: &str| -> Vec<Val> { q(&s, text).rows.remove(0) };
    let b = |v: &Val| match v {
        Val::Bool(x) => *x,
        o => panic!("{o:?}"),
    };
    for (text, want) in [
        ("RETURN 9223372036854775807 < 9223372036854775808.0", true),
        ("RETURN 9223372036854775807 = 9223372036854775808.0", false),
        ("RETURN 9223372036854775808.0 > 9223372036854775807", true),
        ("RETURN -9223372036854775808 = -9223372036854775808.0", true),
        ("RETURN -9223372036854775808 > -9223372036854777856.0", true),
        ("RETURN 9007199254740993 > 9007199254740992.0", true),
        ("RETURN 9007199254740993 = 9007199254740992.0", false),
        ("RETURN 9007199254740993 < 9007199254740994.0", true),
        ("RETURN 9007199254740992 = 9007199254740992.0", true),
        ("RETURN 3 < 3.5 AND 3 > 2.5 AND -3 < -2.5", true),
        ("RETURN 1 < 1.0e300 AND -1 > -1.0e300", true),
        ("RETURN toInteger(-2^63) = -9223372036854775808", true),
        ("RETURN toInteger(2^63) IS NULL", true),
        (
            "RETURN toInteger(9.2233720368547748e18) = 9223372036854774784",
            true,
        ),
        (
            "RETURN toInteger('-9.223372036854775808e18') = -9223372036854775808",
            true,
        ),
    ] {
        assert_eq!(b(&row(text)[0]), want, "{text}");
    }
    // ordering, DISTINCT and grouping keep 2^53 + 1 apart from 2^53
    let r = q(
        &s,
        "UNWIND [9007199254740993, 9007199254740992.0, 9007199254740992, 9223372036854775807, 9223372036854775808.0] AS x \
         RETURN x, count(*) AS n ORDER BY x",
    );
    let got: Vec<(String, i64)> = r
        .rows
        .iter()
        .map(|row| {
            (
                r.render(&row[0]),
                match row[1] {
                    Val::Int(n) => n,
                    _ => panic!(),
                },
            )
        })
        .collect();
    assert_eq!(got.len(), 4, "{got:?}");
    assert_eq!(got[1].0, "9007199254740993", "{got:?}");
    assert_eq!(
        got[0].1, 2,
        "2^53 as integer and float are one group: {got:?}"
    );
    assert_eq!(got[2].0, "9223372036854775807", "{got:?}");
    let r = q(
        &s,
        "UNWIND [9223372036854775807, 9223372036854775808.0, 9223372036854775807] AS x RETURN DISTINCT x",
    );
    assert_eq!(r.rows.len(), 2);
}

/// Counts the store answers from its counts equal the counts of a scan (the same statement
/// with `WHERE true`, which takes the general path), after writes and deletes, and the
/// shapes the counts cannot answer (self-loops, two labels, both directions) still scan.
#[test]
fn counts_from_the_store_equal_a_scan() {
    let (_d, s) = store();
    q(
        &s,
        "CREATE (a:A:B)-[:R]->(b:A), (b)-[:R]->(b), (b)-[:S]->(c:C), (c)-[:R]->(a), (:A), (:B)",
    );
    q(&s, "MATCH (n:B) WHERE NOT n:A DELETE n");
    let statements = [
        "MATCH (n) RETURN count(*) AS n",
        "MATCH (n:A) RETURN count(*) AS n",
        "MATCH (n:A) RETURN count(n) AS n",
        "MATCH (n:Missing) RETURN count(*) AS n",
        "MATCH (n:A:B) RETURN count(*) AS n",
        "MATCH ()-[r]->() RETURN count(r) AS n",
        "MATCH ()-[r:R]->() RETURN count(*) AS n",
        "MATCH ()<-[r:S]-() RETURN count(*) AS n",
        "MATCH (a)-[r:R]->(a) RETURN count(*) AS n",
        "MATCH ()-[r:R]-() RETURN count(*) AS n",
        "MATCH (a:A)-[r:R]->() RETURN count(*) AS n",
        "MATCH ()-[r:NONE]->() RETURN count(*) AS n",
    ];
    for st in statements {
        let fast = q(&s, st);
        let slow = q(&s, &st.replace(" RETURN", " WHERE true RETURN"));
        assert_eq!(fast.columns, slow.columns, "{st}");
        assert_eq!(
            format!("{:?}", fast.rows),
            format!("{:?}", slow.rows),
            "{st}"
        );
    }
    // spot values: 3 :A nodes left ((a:A:B), (b:A), (:A)); 3 :R relationships, 1 a self-loop
    let v = |st: &str| format!("{:?}", q(&s, st).rows[0][0]);
    assert_eq!(v("MATCH (n:A) RETURN count(*) AS n"), "Int(3)");
    assert_eq!(v("MATCH ()-[r:R]->() RETURN count(*) AS n"), "Int(3)");
    assert_eq!(v("MATCH (a)-[r:R]->(a) RETURN count(*) AS n"), "Int(1)");
}

/// CREATE INDEX makes the planner seek instead of scanning, with the same rows; SHOW
/// INDEXES lists it; DROP INDEX removes it; read-only sessions cannot create one.
#[test]
fn create_show_and_drop_a_property_index() {
    let (_d, s) = store();
    q(
        &s,
        "UNWIND range(0, 199) AS i CREATE (:Seg {name: 'seg' + toString(i), n: i})",
    );
    let find = "MATCH (s:Seg {name: 'seg17'}) RETURN s.n AS n";
    let plan = |st: &str| q(&s, &format!("EXPLAIN {st}")).plan.unwrap_or_default();
    assert!(!plan(find).contains("NodeIndexSeek"), "{}", plan(find));
    let before = format!("{:?}", q(&s, find).rows);
    let ro = QueryOptions {
        read_only: true,
        ..QueryOptions::default()
    };
    let e = qerr(&s, "CREATE INDEX FOR (s:Seg) ON (s.name)", &ro);
    assert_eq!(e.kind, ErrorKind::ReadOnly);
    q(&s, "CREATE INDEX seg_name FOR (s:Seg) ON (s.name)");
    assert!(plan(find).contains("NodeIndexSeek"), "{}", plan(find));
    assert_eq!(format!("{:?}", q(&s, find).rows), before);
    assert_eq!(before, "[[Int(17)]]");
    // ranges use it too, and new nodes are indexed
    q(&s, "CREATE (:Seg {name: 'zzz', n: 1000})");
    assert_eq!(
        format!(
            "{:?}",
            q(
                &s,
                "MATCH (s:Seg) WHERE s.name > 'seg98' RETURN s.n AS n ORDER BY n"
            )
            .rows
        ),
        "[[Int(99)], [Int(1000)]]"
    );
    let shown = q(&s, "SHOW INDEXES");
    assert_eq!(shown.columns[0], "name");
    assert_eq!(format!("{:?}", shown.rows[0][0]), "Str(\"seg_name\")");
    let dup = qerr(
        &s,
        "CREATE INDEX FOR (x:Seg) ON (x.name)",
        &QueryOptions::default(),
    );
    assert!(dup.message.contains("already exists"), "{dup}");
    q(&s, "CREATE INDEX IF NOT EXISTS FOR (x:Seg) ON (x.name)");
    q(&s, "DROP INDEX seg_name");
    assert!(!plan(find).contains("NodeIndexSeek"));
    let gone = qerr(&s, "DROP INDEX seg_name", &QueryOptions::default());
    assert_eq!(gone.kind, ErrorKind::EntityNotFound);
    q(&s, "DROP INDEX seg_name IF EXISTS");
    q(&s, "CREATE INDEX ON :Seg(n)");
    assert_eq!(
        format!("{:?}", q(&s, "SHOW INDEXES").rows[0][0]),
        "Str(\"seg_n\")"
    );
    let bad = qerr(
        &s,
        "CREATE INDEX FOR (x:Seg) ON (y.name)",
        &QueryOptions::default(),
    );
    assert_eq!(bad.kind, ErrorKind::Syntax);
}

/// The in-memory copies of the adjacency and record tables (made once a commit's readers have
/// asked them often) answer exactly as the tables do, and a commit is never answered from an
/// older commit's copies.
#[test]
fn hot_table_copies_answer_as_the_tables_do() {
    let n = 3000;
    let edges: Vec<(usize, usize, &str)> = (0..n)
        .flat_map(|i| [(i, (i * 7 + 1) % n, "R"), (i, (i * 13 + 5) % n, "S")])
        .collect();
    let (_d, s) = numbered_graph(n, &edges);
    q(&s, "MATCH ()-[r]->() SET r.w = id(r) % 97");
    let queries = [
        "MATCH (a:N)-[:R]->(b:N)-[:S]->(c:N) WHERE c.v < 500 RETURN count(*) AS n, sum(a.v + c.v) AS t",
        "MATCH (a:N)<-[r]-(b) RETURN a.v % 10 AS k, count(*) AS n, sum(r.w) AS w ORDER BY k",
        "MATCH ()-[r:S]->(b) RETURN r.w AS w, b.v AS v ORDER BY w DESC, v LIMIT 7",
    ];
    let run = |s: &Store| -> Vec<String> {
        queries
            .iter()
            .map(|t| format!("{:?}", q(s, t).rows))
            .collect()
    };
    // the first run reads the tables; by the last the copies answer
    let first = run(&s);
    for _ in 0..4 {
        assert_eq!(run(&s), first);
    }
    // a commit changes what the copies held: the next reads see the change
    q(&s, "MATCH (a:N {v: 1})-[r:S]->() SET r.w = 1000");
    q(&s, "MATCH (a:N {v: 2})-[r:R]->() DELETE r");
    let after = run(&s);
    assert_ne!(after, first);
    let expect = "[[Int(1000), Int(18)]";
    assert!(after[2].starts_with(expect), "{}", after[2]);
    for _ in 0..4 {
        assert_eq!(run(&s), after);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, .. ProptestConfig::default() })]

    /// A MATCH straight into RETURN … [ORDER BY] … LIMIT, which keeps only the rows it needs
    /// as they are matched, gives exactly the rows (ties in the same order) of the same query
    /// with the rows all held first (a `WITH *` between MATCH and RETURN).
    #[test]
    fn streamed_limit_and_top_rows_match_the_held_rows(
        n in 1usize..14,
        // past 64 matched rows the kept rows are cut while matching
        edges in proptest::collection::vec((0usize..14, 0usize..14), 0..300),
        modulo in 1i64..5,
        desc in any::<bool>(),
        ordered in any::<bool>(),
        skip in 0usize..6,
        limit in 0usize..9,
    ) {
        let typed: Vec<(usize, usize, &str)> = edges.iter().map(|&(a, b)| (a % n, b % n, "R")).collect();
        let (_d, s) = numbered_graph(n, &typed);
        let order = if ordered {
            format!("ORDER BY a.v % {modulo} {} ", if desc { "DESC" } else { "" })
        } else {
            String::new()
        };
        let tail = format!("RETURN a.v AS x, b.v AS y {order}SKIP {skip} LIMIT {limit}");
        let streamed = q(&s, &format!("MATCH (a:N)-[:R]->(b) WHERE b.v <> 3 {tail}"));
        let held = q(&s, &format!("MATCH (a:N)-[:R]->(b) WHERE b.v <> 3 WITH * {tail}"));
        prop_assert_eq!(format!("{:?}", streamed.rows), format!("{:?}", held.rows));
    }
}

#[test]
fn streamed_limit_stops_early_and_checks_its_arguments() {
    let edges: Vec<(usize, usize, &str)> = (0..400).map(|i| (i, (i + 1) % 400, "R")).collect();
    let (_d, s) = numbered_graph(400, &edges);
    let r = q(&s, "PROFILE MATCH (a:N)-[:R]->(b) RETURN a.v AS v LIMIT 3");
    assert_eq!(r.rows.len(), 3);
    let plan = r.plan.expect("a profile");
    // the scan stops once the limit has its rows
    assert!(plan.contains("NodeByLabelScan a:N: 3 rows"), "{plan}");
    assert!(plan.contains("Limit 3: 3 rows"), "{plan}");
    let top = q(
        &s,
        "PROFILE MATCH (a:N)-[:R]->(b) RETURN a.v AS v ORDER BY v DESC LIMIT 2",
    );
    assert_eq!(format!("{:?}", top.rows), "[[Int(399)], [Int(398)]]");
    let opts = QueryOptions::default();
    let e = qerr(&s, "MATCH (a:N) RETURN a.v LIMIT -1", &opts);
    assert!(e.to_string().contains("LIMIT must not be negative"), "{e}");
    let e = qerr(
        &s,
        "MATCH (a:N) RETURN a.v ORDER BY a.v SKIP 'x' LIMIT 2",
        &opts,
    );
    assert!(e.to_string().contains("SKIP"), "{e}");
}

#[test]
fn create_vector_index_indexes_existing_and_new_nodes() {
    let (_d, s) = store();
    q(
        &s,
        "UNWIND range(0, 9) AS i CREATE (:Doc {i: i, e: [toFloat(i), 1.0, 0.0]})",
    );
    q(
        &s,
        "CREATE VECTOR INDEX doc_e IF NOT EXISTS FOR (d:Doc) ON d.e OPTIONS \
         {indexConfig: {`vector.dimensions`: 3, `vector.similarity_function`: 'cosine'}}",
    );
    // written after the index: stored as a vector
    q(&s, "CREATE (:Doc {i: 100, e: [0.0, 0.0, 1.0]})");
    let top = |v: &str| -> Vec<String> {
        let r = q(
            &s,
            &format!(
                "CALL db.index.vector.queryNodes('doc_e', 2, {v}) YIELD node, score \
                 RETURN node.i AS i ORDER BY score DESC, i"
            ),
        );
        r.rows.iter().map(|row| format!("{:?}", row[0])).collect()
    };
    assert_eq!(top("[9.0, 1.0, 0.0]"), ["Int(9)", "Int(8)"]);
    assert_eq!(top("[0.0, 1.0, 0.0]"), ["Int(0)", "Int(1)"]);
    assert_eq!(top("[0.0, 0.1, 5.0]")[0], "Int(100)");
    // scores stay within [0, 1] even where f32 rounding puts a cosine a hair above 1
    let best = q(
        &s,
        "CALL db.index.vector.queryNodes('doc_e', 11, [9.0, 1.0, 0.0]) YIELD score RETURN max(score) AS m, min(score) AS n",
    );
    let (hi, lo) = match (&best.rows[0][0], &best.rows[0][1]) {
        (graphstore::cypher::Val::Float(a), graphstore::cypher::Val::Float(b)) => (*a, *b),
        other => panic!("{other:?}"),
    };
    assert!(hi <= 1.0 && hi > 0.999 && lo >= 0.0, "{hi} {lo}");
    // a query vector with no direction is an argument error, not an empty answer
    let e = qerr(
        &s,
        "CALL db.index.vector.queryNodes('doc_e', 2, [0.0, 0.0, 0.0])",
        &QueryOptions::default(),
    );
    assert!(e.to_string().contains("not all zeros"), "{e}");
    let shown = q(&s, "SHOW INDEXES");
    assert!(
        format!("{:?}", shown.rows).contains("VECTOR"),
        "{:?}",
        shown.rows
    );
    // the same name again: refused, or nothing with IF NOT EXISTS
    let opts = QueryOptions::default();
    let again = "CREATE VECTOR INDEX doc_e FOR (d:Doc) ON d.e OPTIONS {indexConfig: {`vector.dimensions`: 3}}";
    assert!(
        qerr(&s, again, &opts)
            .to_string()
            .contains("already exists")
    );
    let read_only = QueryOptions {
        read_only: true,
        ..QueryOptions::default()
    };
    assert!(
        qerr(&s, again, &read_only)
            .to_string()
            .contains("read-only")
    );
    q(&s, "DROP INDEX doc_e");
    let e = qerr(
        &s,
        "CALL db.index.vector.queryNodes('doc_e', 2, [1.0, 0.0, 0.0])",
        &opts,
    );
    assert!(e.to_string().contains("doc_e"), "{e}");
}

/// A statement asked again comes from the thread's parsed-statement cache: it still takes new
/// parameters and sees new data, and a bad statement fails every time.
#[test]
fn repeated_statements_take_new_parameters_and_data() {
    let (_d, s) = store();
    q(&s, "UNWIND range(1, 5) AS i CREATE (:P {v: i})");
    let text = "MATCH (p:P) WHERE p.v >= $min RETURN count(*) AS n";
    let run = |min: i64| {
        let opts = QueryOptions {
            params: [("min".to_string(), graphstore::cypher::Val::Int(min))].into(),
            ..QueryOptions::default()
        };
        format!("{:?}", s.query(text, &opts).unwrap().rows)
    };
    assert_eq!(run(2), "[[Int(4)]]");
    assert_eq!(run(5), "[[Int(1)]]");
    q(&s, "CREATE (:P {v: 9})");
    assert_eq!(run(5), "[[Int(2)]]");
    let opts = QueryOptions::default();
    for _ in 0..2 {
        let e = qerr(&s, "MATCH (p:P) RETURN q", &opts);
        assert!(e.to_string().contains("q"), "{e}");
    }
}

/// `round(x)` sends a half towards positive infinity and just under a half down;
/// `round(x, precision[, mode])` rounds the decimal the float prints as (Neo4j's).
#[test]
fn round_of_one_two_and_three_arguments() {
    let (_d, s) = store();
    for (text, want) in [
        ("RETURN round(2.5) = 3.0", true),
        ("RETURN round(-2.5) = -2.0", true),
        ("RETURN round(-0.5) = 0.0", true),
        ("RETURN round(0.49999999999999994) = 0.0", true),
        ("RETURN round(-1.7) = -2.0", true),
        ("RETURN round(2.675, 2) = 2.68", true),
        ("RETURN round(-2.5, 0) = -3.0", true),
        ("RETURN round(2.5, 0, 'HALF_EVEN') = 2.0", true),
        ("RETURN round(1234.5, -2) = 1200.0", true),
        ("RETURN round(-0.0004, 2, 'floor') = -0.01", true),
        ("RETURN round(null, 2) IS NULL", true),
        ("RETURN round(1.5, null) IS NULL", true),
    ] {
        let r = q(&s, text);
        assert_eq!(r.rows, vec![vec![Val::Bool(want)]], "{text}");
    }
    let e = qerr(
        &s,
        "RETURN round(1.5, 1, 'SIDEWAYS')",
        &QueryOptions::default(),
    );
    assert!(e.message.contains("HALF_EVEN"), "{}", e.message);
    let e = qerr(&s, "RETURN round(1.5, 1.5)", &QueryOptions::default());
    assert_eq!(e.kind, ErrorKind::Type);
}
