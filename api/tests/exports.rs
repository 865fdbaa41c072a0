//! Every export format of a simulated city's map, written by `opengraph export` and read back
//! with its consumer's own library (`tests/python/check_exports.py`: networkx for node-link
//! and GraphML, Kùzu for the Neo4j bulk-import CSV, `spark_dsg` for Spark-DSG, shapely for
//! GeoJSON, plyfile for PLY), checked against the store. Skips with a message when the
//! project's Python environment lacks those libraries (`scripts/setup.sh` installs them).

mod common;
use common::{json, og, ok, read_query, s, sim_map};

/// The Python of `$OPENGRAPH_VENV` when it has the export consumers.
fn python_with_consumers() -> Option<std::path::PathBuf> {
    common::python_importing("mcp, networkx, shapely, plyfile, kuzu, spark_dsg")
}

#[test]
fn every_export_loads_in_its_consumers_library() {
    let Some(py) = python_with_consumers() else {
        eprintln!(
            "skipping: no Python with networkx, shapely, plyfile, kuzu and spark_dsg (run scripts/setup.sh)"
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (_, db) = sim_map(
        dir.path(),
        &["--seed", "3", "--frames", "24"],
        &["--embedder", "hash"],
    );
    let out = dir.path().join("exports");
    std::fs::create_dir_all(&out).unwrap();
    let mut answers = serde_json::Map::new();
    for (name, format, file, extra) in [
        ("node-link", "node-link", "map.json", None),
        ("graphml", "graphml", "map.graphml", None),
        ("neo4j-csv", "neo4j-csv", "csv", None),
        ("geojson", "geojson", "map.geojson", None),
        ("spark-dsg", "spark-dsg", "map.dsg.json", None),
        ("ply-class", "ply", "map_class.ply", Some("class")),
        ("ply-instance", "ply", "map_instance.ply", Some("instance")),
    ] {
        let target = out.join(file);
        let mut args = vec![
            "export",
            "--db",
            s(&db),
            "--format",
            format,
            "--out",
            s(&target),
            "--json",
        ];
        if let Some(c) = extra {
            args.extend(["--colour", c]);
        }
        let a = json(&og(&args));
        assert_eq!(a["format"], format, "{a}");
        assert!(a["frame"].as_str().unwrap().contains("metres"), "{a}");
        answers.insert(name.into(), a);
    }
    std::fs::write(
        out.join("answers.json"),
        serde_json::to_vec(&answers).unwrap(),
    )
    .unwrap();
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/check_exports.py");
    let mut cmd = std::process::Command::new(&py);
    cmd.arg(&script).arg(&out);
    let got = common::json_of_run(cmd, 600);
    // the counts the consumers read equal the store's own
    let count = |q: &str| read_query(&db, q)[0]["n"].as_u64().unwrap();
    let nodes = count("MATCH (n) RETURN count(n) AS n");
    let rels = count("MATCH ()-[r]->() RETURN count(r) AS n");
    let instances = count("MATCH (n:Instance) RETURN count(n) AS n");
    assert_eq!(got["networkx"]["nodes"], nodes);
    assert_eq!(got["kuzu"]["nodes"], nodes);
    assert_eq!(got["kuzu"]["relationships"], rels);
    assert_eq!(got["spark_dsg"]["objects"], instances);
    assert_eq!(got["geojson"]["instance"], instances);
    assert!(
        got["geojson"]["instances_in_their_segment"]
            .as_u64()
            .unwrap()
            > 0
    );
    let with_points = count("MATCH (n:Instance) WHERE n.point_count > 0 RETURN count(n) AS n");
    assert_eq!(got["ply_class"]["instances"], with_points, "{got}");
    eprintln!("{got}");
}

/// A folder format to stdout, and a one-file format to a folder, are refused with exit 2.
#[test]
fn an_export_to_the_wrong_kind_of_target_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("d.og");
    common::ok(&og(&["demo", "--db", s(&db)]));
    let e = og(&[
        "export",
        "--db",
        s(&db),
        "--format",
        "neo4j-csv",
        "--out",
        "-",
    ]);
    assert_eq!(e.status.code(), Some(2));
    let err = String::from_utf8_lossy(&e.stderr);
    assert!(err.contains("writes a folder"), "{err}");
    let e = og(&["export", "--db", s(&db), "--format", "xml", "--out", "-"]);
    assert_eq!(e.status.code(), Some(2));
}

/// A map exported as Neo4j bulk-import CSV and imported with `opengraph import` is the same
/// map: the same counts per label and type, the same node ids with the same properties
/// (embeddings and points included), the map schema's indexes working again; importing over
/// an existing file, or a file with a bad field, exits 2 and leaves no store behind.
#[test]
fn a_map_exported_as_neo4j_csv_imports_as_the_same_map() {
    let dir = tempfile::tempdir().unwrap();
    let (_, db) = sim_map(
        dir.path(),
        &["--seed", "5", "--frames", "16"],
        &["--embedder", "hash"],
    );
    let csv = dir.path().join("csv");
    ok(&og(&[
        "export",
        "--db",
        s(&db),
        "--format",
        "neo4j-csv",
        "--out",
        s(&csv),
    ]));
    let copy = dir.path().join("copy.og");
    let a = json(&og(&[
        "import",
        "--db",
        s(&copy),
        "--schema",
        "opengraph",
        "--batch-rows",
        "500",
        "--json",
        s(&csv),
    ]));
    assert_eq!(a["ids_kept"], true, "{a}");
    assert!(a["batches"].as_u64().unwrap() > 2, "{a}");
    let info = |p: &std::path::Path| {
        let mut v = json(&og(&["info", "--db", s(p), "--json"]));
        // the file's own size and path differ
        if let Some(o) = v.as_object_mut() {
            o.retain(|k, _| !k.contains("bytes") && !k.contains("path") && k != "db");
        }
        v
    };
    assert_eq!(info(&copy), info(&db));
    for q in [
        "MATCH (n:Instance) RETURN id(n) AS id, n.caption AS caption, n.center AS center, \
         n.feature AS feature ORDER BY id",
        "MATCH (s:Segment) RETURN id(s) AS id, properties(s) AS p ORDER BY id",
    ] {
        assert_eq!(read_query(&copy, q), read_query(&db, q), "{q}");
    }
    // relationships get new ids: compared as sorted lists
    let rels = |p: &std::path::Path| {
        let v = read_query(
            p,
            "MATCH (a)-[r]->(b) RETURN id(a) AS a, type(r) AS t, id(b) AS b, properties(r) AS p",
        );
        let mut rows: Vec<String> = v
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r.to_string())
            .collect();
        rows.sort();
        rows
    };
    let (got, want) = (rels(&copy), rels(&db));
    assert!(want.len() > 100, "{}", want.len());
    assert_eq!(got, want);
    // the schema's unique-key index answers a seek on the copy
    let plan = og(&[
        "query",
        "--db",
        s(&copy),
        "EXPLAIN MATCH (i:Instance {instance_id: 1}) RETURN i",
    ]);
    assert!(String::from_utf8_lossy(&plan.stdout).contains("NodeIndexSeek"));
    // over an existing store, and with a bad field: exit 2, nothing written
    let again = og(&["import", "--db", s(&copy), s(&csv)]);
    assert_eq!(again.status.code(), Some(2));
    std::fs::write(
        csv.join("nodes_Zbad.csv"),
        ":ID,n:int,:LABEL\n999999,x,Bad\n",
    )
    .unwrap();
    let bad_db = dir.path().join("bad.og");
    let bad = og(&["import", "--db", s(&bad_db), s(&csv)]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("nodes_Zbad.csv:2") && err.contains("not an integer"),
        "{err}"
    );
    assert!(!bad_db.exists());
    assert!(!dir.path().join("bad.og.importing").exists());

    // the same map through node-link JSON: the same nodes, ids, properties and relationships
    let nl = dir.path().join("map.json");
    ok(&og(&[
        "export",
        "--db",
        s(&db),
        "--format",
        "node-link",
        "--out",
        s(&nl),
    ]));
    let from_json = dir.path().join("from_json.og");
    let a = json(&og(&[
        "import",
        "--db",
        s(&from_json),
        "--schema",
        "opengraph",
        "--node-link",
        s(&nl),
        "--json",
    ]));
    assert_eq!(a["ids_kept"], true, "{a}");
    assert_eq!(info(&from_json), info(&db));
    for q in [
        "MATCH (n:Instance) RETURN id(n) AS id, n.caption AS caption, n.center AS center, \
         n.feature AS feature, n.bbox AS bbox ORDER BY id",
        "MATCH (s:Segment) RETURN id(s) AS id, properties(s) AS p ORDER BY id",
    ] {
        assert_eq!(read_query(&from_json, q), read_query(&db, q), "{q}");
    }
    assert_eq!(rels(&from_json), want);
    // the vector index works on the copy: an instance's own feature finds it first
    let top = read_query(
        &from_json,
        "MATCH (i:Instance) WITH i ORDER BY id(i) LIMIT 1 \
         CALL db.index.vector.queryNodes('instance_feature', 1, i.feature) YIELD node \
         RETURN id(node) = id(i) AS same",
    );
    assert_eq!(top[0]["same"], true, "{top}");
    // a node-link file with an edge to nowhere: exit 2 naming the edge, nothing left behind
    std::fs::write(
        dir.path().join("bad.json"),
        r#"{"nodes": [{"id": 1}], "links": [{"source": 1, "target": 7}]}"#,
    )
    .unwrap();
    let bad_db = dir.path().join("bad_json.og");
    let bad = og(&[
        "import",
        "--db",
        s(&bad_db),
        "--node-link",
        s(&dir.path().join("bad.json")),
    ]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("edges[0]: target 7 is no node's id"), "{err}");
    assert!(!bad_db.exists());
    // bad JSON: the line and column
    std::fs::write(
        dir.path().join("broken.json"),
        "{\"nodes\": [\n{\"id\": 1},,\n]}",
    )
    .unwrap();
    let bad = og(&[
        "import",
        "--db",
        s(&bad_db),
        "--node-link",
        s(&dir.path().join("broken.json")),
    ]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("broken.json:2: not JSON"), "{err}");
}
