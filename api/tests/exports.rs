//! Every export format of a simulated city's map, written by `opengraph export` and read back
//! with its consumer's own library (`tests/python/check_exports.py`: networkx for node-link
//! and GraphML, Kùzu for the Neo4j bulk-import CSV, `spark_dsg` for Spark-DSG, shapely for
//! GeoJSON, plyfile for PLY), checked against the store. Skips with a message when the
//! project's Python environment lacks those libraries (`scripts/setup.sh` installs them).

mod common;
use common::{json, og, read_query, s, sim_map};

/// The Python of `$OPENGRAPH_VENV` when it has the export consumers.
fn python_with_consumers() -> Option<std::path::PathBuf> {
    let py = common::python_with_mcp()?;
    let ok = std::process::Command::new(&py)
        .args(["-c", "import networkx, shapely, plyfile, kuzu, spark_dsg"])
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(py)
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
