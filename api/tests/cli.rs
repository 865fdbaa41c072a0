//! The `opengraph` binary: demo, info, export and its exit codes.

mod common;
use common::{first_lane_node, json, og, ok, s};

#[test]
fn demo_info_export_roundtrip() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("demo.og");
    let db_s = s(&db);
    let out = og(&["demo", "--db", db_s]);
    ok(&out);
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
    assert!(!text.contains("consistency"), "{text}");
    // --check reads every index and count against the data
    let out = og(&["info", "--db", db_s, "--json", "--check"]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["consistency"]["consistent"], true, "{v}");
    assert_eq!(v["consistency"]["problems"], serde_json::json!([]), "{v}");
    let text = String::from_utf8(og(&["info", "--db", db_s, "--check"]).stdout).unwrap();
    assert!(
        text.contains("consistency: every index and count agrees"),
        "{text}"
    );

    let json = dir.path().join("g.json");
    let out = og(&[
        "export",
        "--db",
        db_s,
        "--format",
        "node-link",
        "--out",
        s(&json),
    ]);
    ok(&out);
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
        s(&json),
    ]);
    ok(&out);
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
        s(&gml),
    ]);
    ok(&out);
    let xml = std::fs::read_to_string(&gml).unwrap();
    assert_eq!(xml.matches("<node ").count(), 17);
    assert_eq!(xml.matches("<edge ").count(), 19);
    assert!(xml.contains("attr.name=\"caption\" attr.type=\"string\""));
}

#[test]
fn bad_input_exits_2_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.og");
    let out = og(&["info", "--db", s(&missing)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no such file"));

    let junk = dir.path().join("junk.og");
    std::fs::write(&junk, vec![7u8; 4096]).unwrap();
    let out = og(&["info", "--db", s(&junk), "--json"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("junk.og"));

    let out = og(&["export", "--db", s(&junk), "--format", "csv", "--out", "x"]);
    assert_eq!(out.status.code(), Some(2), "clap rejects an unknown format");
    let out = og(&["info"]);
    assert_eq!(out.status.code(), Some(2));

    let db = dir.path().join("d.og");
    ok(&og(&["demo", "--db", s(&db)]));
    let out = og(&["demo", "--db", s(&db)]);
    assert_eq!(out.status.code(), Some(2), "demo refuses to overwrite");
}

/// A KITTI-format poses.txt for a T-junction drive at 1 m per pose (ground plane x, z).
fn t_junction_poses(path: &std::path::Path) {
    let way = [
        [-150.0, 0.0],
        [0.0, 0.0],
        [0.0, 150.0],
        [0.0, 0.0],
        [150.0, 0.0],
    ];
    let mut s = String::new();
    for w in way.windows(2) {
        let a: [f64; 2] = w[0];
        let b: [f64; 2] = w[1];
        let n = (b[0] - a[0]).hypot(b[1] - a[1]).round() as usize;
        for k in 0..n {
            let f = k as f64 / n as f64;
            let (x, z) = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
            s.push_str(&format!("1 0 0 {x} 0 1 0 0 0 0 1 {z}\n"));
        }
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn lanes_json_geojson_png_and_hierarchy() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.txt");
    t_junction_poses(&poses);
    let gj = dir.path().join("l.geojson");
    let png = dir.path().join("l.png");
    let out = og(&[
        "lanes",
        "--poses",
        s(&poses),
        "--out",
        s(&gj),
        "--png",
        s(&png),
        "--json",
    ]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let kinds: Vec<&str> = v["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n["kind"].as_str().unwrap())
        .collect();
    assert_eq!(
        kinds.iter().filter(|k| **k == "t_intersection").count(),
        1,
        "{kinds:?}"
    );
    assert_eq!(kinds.iter().filter(|k| **k == "breakpoint").count(), 3);
    assert_eq!(v["edges"].as_array().unwrap().len(), 3);
    assert_eq!(v["nodes"][0]["xy"].as_array().unwrap().len(), 2);
    assert!(v["edges"][0]["length_m"].as_f64().unwrap() > 100.0);
    let g: serde_json::Value = serde_json::from_slice(&std::fs::read(&gj).unwrap()).unwrap();
    assert_eq!(g["type"], "FeatureCollection");
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));

    let db = dir.path().join("h.og");
    let out = og(&["hierarchy", "--db", s(&db), "--poses", s(&poses), "--json"]);
    ok(&out);
    let info: serde_json::Value =
        serde_json::from_slice(&og(&["info", "--db", s(&db), "--json"]).stdout).unwrap();
    assert_eq!(info["nodes"]["Environment"], 1);
    assert_eq!(info["nodes"]["LaneNode"], 4);
    assert_eq!(info["relationships"]["LANE"], 3);
    assert_eq!(info["relationships"]["CONNECTS"], 3);
}

#[test]
fn lanes_bad_poses_name_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.txt");
    std::fs::write(&poses, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 x 0 1 0 0 0 0 1 1\n").unwrap();
    let out = og(&[
        "lanes",
        "--poses",
        s(&poses),
        "--out",
        dir.path().join("o").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("poses.txt:2"), "{err}");
    let out = og(&[
        "lanes",
        "--poses",
        dir.path().join("none.txt").to_str().unwrap(),
        "--out",
        "o",
    ]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn plan_json_png_fallback_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.txt");
    t_junction_poses(&poses);
    let db = dir.path().join("p.og");
    let d = s(&db);
    assert!(
        og(&["hierarchy", "--db", d, "--poses", s(&poses)])
            .status
            .success()
    );
    let png = dir.path().join("plan.png");
    let lane0 = format!("lane:{}", first_lane_node(&db));
    // KITTI ground plane is (x, z): the west arm is at negative x
    let out = og(&[
        "plan",
        "--db",
        d,
        "--from",
        "-100,0",
        "--to",
        &lane0,
        "--budget-ms",
        "3000",
        "--json",
        "--png",
        s(&png),
    ]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["route"]["nodes"][0], "start");
    assert!(v["route"]["length_m"].as_f64().unwrap() > 40.0);
    let poses_out = v["path"]["poses"].as_array().unwrap();
    assert!(poses_out.len() > 10);
    assert_eq!(poses_out[0].as_array().unwrap().len(), 3);
    // the route followed by the car's curves, RRT* where that could not (never the fallback)
    let planner = v["path"]["planner"].as_str().unwrap();
    assert!(
        planner.starts_with("follow/ReedsShepp") || planner.starts_with("RRTstar/ReedsShepp"),
        "{planner}"
    );
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    // no budget: the route comes back as a fallback, with a warning
    let out = og(&[
        "plan",
        "--db",
        d,
        "--from",
        "-100,0",
        "--to",
        &lane0,
        "--budget-ms",
        "0",
        "--json",
    ]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["path"]["planner"], "fallback:route");
    assert!(String::from_utf8_lossy(&out.stderr).contains("warning"));
    // bad input: unknown id, a point too far from every lane, a malformed spec
    let lane_as_segment = format!("segment:{}", &lane0[5..]);
    for (from, msg) in [
        ("lane:99999", "no node with id 99999"),
        (lane_as_segment.as_str(), "not a Segment"),
        ("500,500", "snap limit"),
        ("lane:x", "bad location"),
    ] {
        let out = og(&["plan", "--db", d, "--from", from, "--to", &lane0]);
        assert_eq!(out.status.code(), Some(2), "{from}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(msg),
            "{from}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn a_closed_stdout_is_a_quiet_exit_and_bad_text_exits_2() {
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("d.og");
    ok(&og(&["demo", "--db", s(&db)]));
    // a reader that goes away at once (`| head -c 0`): no panic, exit 0
    for args in [
        vec![
            "query",
            "--db",
            s(&db),
            "--json",
            "UNWIND range(1, 90000) AS x RETURN x",
        ],
        vec![
            "query",
            "--db",
            s(&db),
            "UNWIND range(1, 90000) AS x RETURN x",
        ],
        vec!["info", "--db", s(&db), "--json"],
        vec![
            "export",
            "--db",
            s(&db),
            "--format",
            "graphml",
            "--out",
            "-",
        ],
        vec![
            "export",
            "--db",
            s(&db),
            "--format",
            "node-link",
            "--out",
            "-",
        ],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_opengraph"))
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
    }
    // an empty question is the user's mistake: exit 2
    let out = og(&["find", "--db", s(&db), "", "--embedder", "hash"]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Arguments a new user got wrong in a trial, each refused before any work with exit 2 and a
/// message that says what is allowed.
#[test]
fn find_locate_navigate_and_eval_arguments_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("d.og");
    assert!(og(&["demo", "--db", s(&db)]).status.success());
    let empty = dir.path().join("empty.jsonl");
    std::fs::write(&empty, "# nothing\n").unwrap();
    let long = "a".repeat(3000);
    for (args, needle) in [
        (vec!["find", "--db", s(&db), "bench", "-k", "0"], "1..=1000"),
        (
            vec!["find", "--db", s(&db), "x", "--class", "fire hydrant"],
            "SemanticKITTI classes",
        ),
        (vec!["find", "--db", s(&db), long.as_str()], "at most 2000"),
        (vec!["locate", "--db", s(&db), "x", "-k", "0"], "1..=1000"),
        (
            vec![
                "navigate",
                "--db",
                s(&db),
                "--from",
                "lane:1",
                "--to",
                "lane:2",
                "--turning-radius-m",
                "-3",
            ],
            "outside [0.5, 100]",
        ),
        (
            vec![
                "eval",
                "retrieval",
                "--db",
                s(&db),
                "--sim",
                s(dir.path()),
                "--queries",
                s(&empty),
            ],
            "no queries",
        ),
        (
            vec![
                "tool",
                "--db",
                s(&db),
                "write_cypher",
                r#"{"query": "RETURN 1"}"#,
            ],
            "--writes",
        ),
    ] {
        let out = og(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn init_makes_an_empty_store_to_try_cypher_on() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("new.og");
    let out = og(&["init", "--db", s(&db)]);
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("created"));
    let v = json(&og(&[
        "query",
        "--db",
        s(&db),
        "--json",
        "CREATE (a:Place {name: 'home'})-[:ROAD {km: 2.5}]->(b:Place {name: 'work'}) RETURN a.name AS a, b.name AS b",
    ]));
    assert_eq!(v[0]["a"], "home");
    let v = json(&og(&[
        "query",
        "--db",
        s(&db),
        "--read-only",
        "--json",
        "MATCH (:Place)-[r:ROAD]->(p:Place) RETURN p.name AS p, r.km AS km",
    ]));
    assert_eq!(v[0]["p"], "work");
    assert_eq!(v[0]["km"], 2.5);
    // an existing file and a missing folder are the user's errors
    let out = og(&["init", "--db", s(&db)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("already exists"));
    let out = og(&["init", "--db", s(&dir.path().join("no/such/dir/x.og"))]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("does not exist"));
    // with the map schema, its constraints hold
    let db2 = dir.path().join("map.og");
    ok(&og(&["init", "--db", s(&db2), "--schema", "opengraph"]));
    let out = og(&[
        "query",
        "--db",
        s(&db2),
        "CREATE (:Instance {caption: 'no id'})",
    ]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Output paths are checked before any work: a missing folder, a folder where a file is
/// wanted, a file where a folder is wanted; each exits 2 naming the path.
#[test]
fn bad_output_paths_exit_2_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("afile");
    std::fs::write(&file, "x").unwrap();
    let missing = dir.path().join("no/such/folder/out.json");
    let under_file = file.join("sim");
    let d = s(dir.path());
    let cases: Vec<Vec<&str>> = vec![
        vec![
            "export",
            "--db",
            "x.og",
            "--format",
            "graphml",
            "--out",
            s(&missing),
        ],
        vec!["export", "--db", "x.og", "--format", "graphml", "--out", d],
        vec!["lanes", "--poses", "p.txt", "--out", s(&missing)],
        vec![
            "lanes",
            "--poses",
            "p.txt",
            "--out",
            "l.geojson",
            "--png",
            d,
        ],
        vec![
            "plan",
            "--db",
            "x.og",
            "--from",
            "0,0",
            "--to",
            "1,1",
            "--png",
            s(&missing),
        ],
        vec![
            "navigate",
            "--db",
            "x.og",
            "from a to b",
            "--png",
            s(&missing),
        ],
        vec!["sim", "--out", s(&file)],
        vec!["sim", "--out", s(&under_file)],
        vec!["oracle", "--kitti", "k", "--out", s(&file)],
    ];
    for args in cases {
        let out = og(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        let named = [s(&missing), d, s(&file), s(&under_file)]
            .iter()
            .any(|p| err.contains(p) || err.contains(&p[..p.rfind('/').unwrap_or(0)]));
        assert!(named, "{args:?}: {err}");
    }
}

/// `export --out -` writes to stdout.
#[test]
fn export_to_stdout() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("d.og");
    ok(&og(&["demo", "--db", s(&db)]));
    let out = og(&[
        "export",
        "--db",
        s(&db),
        "--format",
        "node-link",
        "--out",
        "-",
    ]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(!v["nodes"].as_array().unwrap().is_empty());
    assert!(!std::path::Path::new("-").exists());
}

/// JSON has no number for NaN or ±infinity and `null` is Cypher's null: the tagged form
/// tells them apart. GraphML keeps carriage returns and tabs (as character references) and
/// writes control characters XML 1.0 cannot carry as their control pictures, with a warning.
#[test]
fn special_floats_and_control_characters_survive_export() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("t.og");
    ok(&og(&["init", "--db", s(&db)]));
    let out = og(&[
        "query",
        "--db",
        s(&db),
        "--json",
        "RETURN 0.0/0.0 AS nan, 1.0/0.0 AS inf, -1.0/0.0 AS ninf, null AS n, [1.5, 0.0/0.0] AS l",
    ]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v[0]["nan"], serde_json::json!({"$float": "NaN"}), "{v}");
    assert_eq!(v[0]["inf"], serde_json::json!({"$float": "Infinity"}));
    assert_eq!(v[0]["ninf"], serde_json::json!({"$float": "-Infinity"}));
    assert!(v[0]["n"].is_null());
    assert_eq!(v[0]["l"], serde_json::json!([1.5, {"$float": "NaN"}]));

    ok(&og(&[
        "query",
        "--db",
        s(&db),
        "CREATE (:Note {text: 'one\\r\\ntwo\\tthree\\u0001'})",
    ]));
    let gml = dir.path().join("t.graphml");
    let out = og(&[
        "export",
        "--db",
        s(&db),
        "--format",
        "graphml",
        "--out",
        s(&gml),
    ]);
    ok(&out);
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .matches("control pictures")
            .count()
            == 1,
        "the substitution is reported: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    // a real XML parser reads the text back
    let py = std::process::Command::new("python3")
        .args([
            "-c",
            "import sys, xml.etree.ElementTree as ET, json\n\
             ns = {'g': 'http://graphml.graphdrawing.org/xmlns'}\n\
             t = ET.parse(sys.argv[1])\n\
             keys = {k.get('id'): k.get('attr.name') for k in t.getroot().findall('g:key', ns)}\n\
             out = {keys[d.get('key')]: d.text for d in t.getroot().iter('{http://graphml.graphdrawing.org/xmlns}data')}\n\
             print(json.dumps(out))",
            s(&gml),
        ])
        .output()
        .unwrap();
    assert!(
        py.status.success(),
        "{}",
        String::from_utf8_lossy(&py.stderr)
    );
    let back: serde_json::Value = serde_json::from_slice(&py.stdout).unwrap();
    assert_eq!(back["text"], "one\r\ntwo\tthree\u{2401}", "{back}");
}

/// `plan --av2-map`: a route over an Argoverse 2 HD map from `../shared/data/av2` (skipped
/// with a message when it is absent), along successor links, refined by OMPL.
#[test]
fn plan_over_an_argoverse_2_map() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/av2");
    let map = dir.join("log_map_archive_0a1e6f0a-1817-4a98-b02e-db8c9327d151.json");
    if !map.exists() {
        eprintln!("skipping: {} is absent", map.display());
        return;
    }
    // seven lane segments along successor links, from the first one's start
    let out = og(&[
        "plan",
        "--av2-map",
        s(&map),
        "--from=-438.53,1317.34",
        "--to=-429.36,1440.21",
        "--json",
    ]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let len = v["route"]["length_m"].as_f64().unwrap();
    assert!((100.0..160.0).contains(&len), "{v}");
    assert!(v["path"]["length_m"].as_f64().unwrap() > 100.0, "{v}");
    // node ids mean nothing on such a map; a far point is refused with the distance
    let out = og(&[
        "plan",
        "--av2-map",
        s(&map),
        "--from",
        "lane:3",
        "--to=-429.36,1440.21",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no node ids"));
    let out = og(&["plan", "--av2-map", s(&map), "--from", "0,0", "--to", "1,1"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("snap limit"));
    // a map without lanes says so (not "run opengraph hierarchy")
    let tmp = tempfile::tempdir().unwrap();
    let empty = tmp.path().join("log_map_archive_empty.json");
    std::fs::write(&empty, r#"{"lane_segments": {}}"#).unwrap();
    let out = og(&[
        "plan",
        "--av2-map",
        s(&empty),
        "--from",
        "0,0",
        "--to",
        "1,1",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no lane segments") && err.contains("log_map_archive_empty.json"),
        "{err}"
    );
}
