//! The `opengraph` binary: demo, info, export and its exit codes.

use std::process::Command;

fn og(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn demo_info_export_roundtrip() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("demo.og");
    let db_s = db.to_str().unwrap();
    let out = og(&["demo", "--db", db_s]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = og(&["info", "--db", db_s, "--json"]);
    assert_eq!(out.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
    assert_eq!(keys, ["nodes", "relationships"]);
    assert_eq!(v["nodes"]["Instance"], 5);
    assert_eq!(v["nodes"]["LaneNode"], 7);
    assert_eq!(v["relationships"]["LANE"], 6);
    let text = String::from_utf8(og(&["info", "--db", db_s]).stdout).unwrap();
    assert!(text.contains("vector instance_feature"), "{text}");

    let json = dir.path().join("g.json");
    let out = og(&[
        "export",
        "--db",
        db_s,
        "--format",
        "node-link",
        "--out",
        json.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let g: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(g["directed"], true);
    assert_eq!(g["multigraph"], true);
    assert_eq!(g["nodes"].as_array().unwrap().len(), 17);
    assert_eq!(g["edges"].as_array().unwrap().len(), 19);
    let out = og(&[
        "export",
        "--db",
        db_s,
        "--format",
        "node-link",
        "--edges-key",
        "links",
        "--out",
        json.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let g: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(g["links"].as_array().unwrap().len(), 19);

    let gml = dir.path().join("g.graphml");
    let out = og(&[
        "export",
        "--db",
        db_s,
        "--format",
        "graphml",
        "--out",
        gml.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let xml = std::fs::read_to_string(&gml).unwrap();
    assert_eq!(xml.matches("<node ").count(), 17);
    assert_eq!(xml.matches("<edge ").count(), 19);
    assert!(xml.contains("attr.name=\"caption\" attr.type=\"string\""));
}

#[test]
fn bad_input_exits_2_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.og");
    let out = og(&["info", "--db", missing.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no such file"));

    let junk = dir.path().join("junk.og");
    std::fs::write(&junk, vec![7u8; 4096]).unwrap();
    let out = og(&["info", "--db", junk.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("junk.og"));

    let out = og(&[
        "export",
        "--db",
        junk.to_str().unwrap(),
        "--format",
        "csv",
        "--out",
        "x",
    ]);
    assert_eq!(out.status.code(), Some(2), "clap rejects an unknown format");
    let out = og(&["info"]);
    assert_eq!(out.status.code(), Some(2));

    let db = dir.path().join("d.og");
    assert!(og(&["demo", "--db", db.to_str().unwrap()]).status.success());
    let out = og(&["demo", "--db", db.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "demo refuses to overwrite");
}
