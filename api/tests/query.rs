//! `opengraph query`: tables, JSON rows, parameters, EXPLAIN, read-only mode and errors.

mod common;
use common::{json, og, ok, s};

#[test]
fn query_prints_tables_and_json_and_takes_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("demo.og");
    ok(&og(&["demo", "--db", s(&db)]));

    let out = og(&[
        "query",
        "--db",
        s(&db),
        "MATCH (i:Instance) RETURN i.instance_id AS id, i.semantic_class AS class ORDER BY id LIMIT 2",
    ]);
    ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0]
            .split('|')
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .collect::<Vec<_>>(),
        ["id", "class"]
    );
    assert!(
        lines[2].contains("| 1 ") && lines[2].contains("'bench'"),
        "{text}"
    );
    assert_eq!(lines.len(), 4, "{text}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("2 row(s)"));

    let rows = json(&og(&[
        "query",
        "--db",
        s(&db),
        "--json",
        "--param",
        "cls=\"car\"",
        "--param",
        "k=5",
        "MATCH (i:Instance) WHERE i.semantic_class = $cls RETURN i.caption AS caption, i.centroid AS c LIMIT $k",
    ]));
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["caption"], "a silver hatchback parked at the kerb");
    assert!(rows[0]["c"]["x"].is_number(), "{rows:?}");

    // a plain-text parameter and a node in JSON
    let rows = json(&og(&[
        "query",
        "--db",
        s(&db),
        "--json",
        "--param",
        "name=bench",
        "MATCH (i:Instance {semantic_class: $name}) RETURN i",
    ]));
    let node = &rows[0]["i"];
    assert_eq!(node["_labels"], serde_json::json!(["Instance"]));
    assert_eq!(node["semantic_class"], "bench");

    let out = og(&[
        "query",
        "--db",
        s(&db),
        "EXPLAIN MATCH (i:Instance {instance_id: 3}) RETURN i",
    ]);
    ok(&out);
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("NodeIndexSeek i:Instance(instance_id = 3)")
    );
}

#[test]
fn query_refuses_writes_when_read_only_and_reports_errors_with_positions() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("demo.og");
    ok(&og(&["demo", "--db", s(&db)]));
    let count = || {
        let rows = json(&og(&[
            "query",
            "--db",
            s(&db),
            "--json",
            "MATCH (n) RETURN count(n) AS n",
        ]));
        rows[0]["n"].as_i64().unwrap()
    };
    let before = count();

    let out = og(&[
        "query",
        "--db",
        s(&db),
        "--read-only",
        "MATCH (n) DETACH DELETE n",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("read-only") && err.contains("line 1, column 11"),
        "{err}"
    );
    assert_eq!(count(), before);

    let out = og(&["query", "--db", s(&db), "MATCH (n)\nRETURN n.name +"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("SyntaxError") && err.contains("line 2, column 16"),
        "{err}"
    );

    let out = og(&["query", "--db", s(&db), "--param", "no-equals", "RETURN 1"]);
    assert_eq!(out.status.code(), Some(2));

    let out = og(&[
        "query",
        "--db",
        s(&db),
        "--max-rows",
        "3",
        "MATCH (n) RETURN n",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("more than 3 rows"));

    // a write that fails half way leaves nothing behind
    let out = og(&[
        "query",
        "--db",
        s(&db),
        "CREATE (:Scratch) WITH 1 AS x RETURN x / 0",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(count(), before);
    let out = og(&[
        "query",
        "--db",
        s(&db),
        "CREATE (:Scratch {k: 1}) RETURN 1 AS one",
    ]);
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stderr).contains("1 nodes created"));
    assert_eq!(count(), before + 1);
}

#[test]
fn reads_leave_the_file_as_it_was_and_need_no_write_permission() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("d.og");
    ok(&og(&["demo", "--db", s(&db)]));
    let mut perm = std::fs::metadata(&db).unwrap().permissions();
    perm.set_readonly(true);
    std::fs::set_permissions(&db, perm).unwrap();
    let before = std::fs::read(&db).unwrap();
    let out = dir.path().join("e.json");
    for args in [
        vec!["info", "--db", s(&db)],
        vec![
            "query",
            "--db",
            s(&db),
            "--read-only",
            "MATCH (n) RETURN count(n) AS n",
        ],
        vec![
            "export",
            "--db",
            s(&db),
            "--format",
            "node-link",
            "--out",
            s(&out),
        ],
    ] {
        ok(&og(&args));
    }
    // two readers at once
    let spawn = || {
        std::process::Command::new(env!("CARGO_BIN_EXE_opengraph"))
            .args([
                "query",
                "--db",
                s(&db),
                "--read-only",
                "UNWIND range(1, 300000) AS x RETURN count(*) AS n",
            ])
            .output()
    };
    let (a, b) = std::thread::scope(|sc| {
        let a = sc.spawn(spawn);
        let b = sc.spawn(spawn);
        (a.join().unwrap().unwrap(), b.join().unwrap().unwrap())
    });
    ok(&a);
    ok(&b);
    assert_eq!(
        std::fs::read(&db).unwrap(),
        before,
        "a read changed the file"
    );
    // a write through --read-only is refused by the parser, the file unchanged
    let w = og(&["query", "--db", s(&db), "--read-only", "CREATE (:X)"]);
    assert_eq!(w.status.code(), Some(2));
    assert_eq!(std::fs::read(&db).unwrap(), before);
    // without --read-only, a statement that does not write leaves the file as it was too
    ok(&og(&[
        "query",
        "--db",
        s(&db),
        "MATCH (n) RETURN count(n) AS n",
    ]));
    assert_eq!(
        std::fs::read(&db).unwrap(),
        before,
        "a read without --read-only changed the file"
    );
}

/// An integer parameter is an INTEGER exactly at the ends of the 64-bit range, and one beyond
/// it is refused (exit 2) instead of turning into an inexact FLOAT; also inside lists.
#[test]
fn integer_parameters_beyond_64_bits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("demo.og");
    ok(&og(&["demo", "--db", s(&db)]));
    for v in ["9223372036854775807", "-9223372036854775808"] {
        let r = json(&og(&[
            "query",
            "--db",
            s(&db),
            "--read-only",
            "--json",
            "--param",
            &format!("x={v}"),
            "RETURN $x AS x",
        ]));
        assert_eq!(r[0]["x"].to_string(), v, "{r}");
    }
    for v in [
        "9223372036854775808",
        "-9223372036854775809",
        "99999999999999999999",
        "[1, 18446744073709551615]",
    ] {
        let out = og(&[
            "query",
            "--db",
            s(&db),
            "--read-only",
            "--param",
            &format!("x={v}"),
            "RETURN $x AS x",
        ]);
        assert_eq!(out.status.code(), Some(2), "{v}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("outside the INTEGER range"), "{v}: {err}");
    }
}

#[test]
fn explain_with_json_prints_the_plan_as_json() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("e.og");
    ok(&og(&["init", "--db", s(&db)]));
    let out = og(&[
        "query",
        "--db",
        s(&db),
        "--json",
        "EXPLAIN MATCH (n:Note) WHERE n.x > 1 RETURN n",
    ]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let plan = v["plan"].as_array().unwrap();
    assert_eq!(
        plan[0],
        serde_json::json!({"operator": "Physical plan (pipelined operators)", "depth": 0}),
        "{v}"
    );
    for op in [
        "NodeByLabelScan n:Note",
        "Filter n.x > 1",
        "ProduceResults n",
    ] {
        assert!(
            plan.iter().any(|o| o["operator"] == op && o["depth"] == 1),
            "{op}: {v}"
        );
    }
    assert!(
        plan.iter()
            .any(|o| o["operator"] == "Logical plan" && o["depth"] == 0),
        "{v}"
    );
    // and without --json, the text plan
    let out = og(&["query", "--db", s(&db), "EXPLAIN MATCH (n:Note) RETURN n"]);
    ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.starts_with("Physical plan (pipelined operators)\n"),
        "{text}"
    );
    assert!(text.contains("\n  NodeByLabelScan n:Note\n"), "{text}");
}

#[test]
fn table_cells_show_control_characters_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("t.og");
    ok(&og(&["init", "--db", s(&db)]));
    let out = og(&["query", "--db", s(&db), "RETURN 'a\\rb\\nc\\td' AS x"]);
    ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    // header, rule, one row: the cell is one line
    assert_eq!(text.lines().count(), 3, "{text}");
    assert!(text.contains("a\\rb\\nc\\td"), "{text}");
}
