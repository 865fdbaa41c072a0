//! One set of requests through the three adapters — the CLI (`opengraph tool`), HTTP
//! (`POST /api/tools/{name}`) and MCP over streamable HTTP (the official Python client) — and
//! the answers compared: the same JSON for every read tool, and the same refusal (exit 2,
//! a 4xx, `isError`) with the same message for bad requests.

mod common;
use common::{json, json_of_run, og, python_with_mcp, read_query, s, serve, sim_map};

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use serde_json::{Value, json};

/// Drops what legitimately differs between two runs of the same request (timings).
fn stable(mut v: Value) -> Value {
    if let Some(o) = v.as_object_mut() {
        o.remove("timings_ms");
        if let Some(p) = o.get_mut("plan").and_then(Value::as_object_mut) {
            p.remove("timings_ms");
            if let Some(path) = p.get_mut("path").and_then(Value::as_object_mut) {
                // the motion planner is randomised per run; the route is not
                path.clear();
            }
        }
    }
    v
}

#[test]
fn cli_http_and_mcp_give_the_same_answers() {
    let Some(py) = python_with_mcp() else {
        eprintln!("skipping: no Python with the mcp package (run scripts/setup.sh)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (_, db) = sim_map(
        dir.path(),
        &["--seed", "3", "--frames", "24"],
        &["--embedder", "hash"],
    );
    let ids = read_query(
        &db,
        "MATCH (i:Instance) WITH i ORDER BY id(i) LIMIT 1 MATCH (g:Segment) RETURN id(i) AS i, min(id(g)) AS g",
    );
    let (inst, seg) = (ids[0]["i"].as_u64().unwrap(), ids[0]["g"].as_u64().unwrap());
    let calls: Vec<(&str, Value)> = vec![
        ("get_schema", json!({})),
        (
            "read_cypher",
            json!({"query": "MATCH (s:Segment) RETURN s.kind AS kind, count(*) AS n ORDER BY kind"}),
        ),
        (
            "read_cypher",
            json!({"query": "MATCH (i:Instance) WHERE i.semantic_class = $c RETURN count(i) AS n", "params": {"c": "car"}}),
        ),
        (
            "find_objects",
            json!({"text": "the bench near the bus stop", "k": 3}),
        ),
        (
            "find_objects",
            json!({"text": "somewhere to post a letter", "k": 2, "semantic_class": "pole"}),
        ),
        (
            "locate",
            json!({"text": "I'm at a T-junction next to a bus stop", "k": 2}),
        ),
        (
            "plan_route",
            json!({"from": "the T-junction", "to": "a bus stop"}),
        ),
        ("describe_area", json!({})),
        ("describe_area", json!({"segment_id": seg})),
        ("get_instance", json!({"id": inst})),
        (
            "nearest_objects",
            json!({"kind": "benches", "near": "the T-junction", "k": 2}),
        ),
        ("count_objects", json!({"kind": "trees", "list": 3})),
        (
            "measure_distance",
            json!({"from": format!("instance:{inst}"), "to": "the start of the drive"}),
        ),
        ("neighbours", json!({"id": inst, "k": 3})),
        // refusals: bad arguments, a node that does not exist, a write through the read tool
        ("find_objects", json!({"k": 0})),
        ("get_instance", json!({"id": 999_999_999u64})),
        ("read_cypher", json!({"query": "CREATE (n:Hack) RETURN n"})),
        ("describe_area", json!({"segment_id": inst})),
    ];
    let srv = serve(&db, &[]);
    // MCP, all calls in one session
    let mcp: Vec<Value> = mcp_calls(&py, &format!("{}/mcp", srv.url), &calls, None);
    assert_eq!(mcp.len(), calls.len());
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_global(Some(Duration::from_secs(60)))
        .http_status_as_error(false)
        .build()
        .into();
    let mut refusals = 0;
    for ((name, args), m) in calls.iter().zip(&mcp) {
        let what = format!("{name} {args}");
        // HTTP
        let mut resp = agent
            .post(format!("{}/api/tools/{name}", srv.url))
            .header("Content-Type", "application/json")
            .send(args.to_string().as_bytes())
            .unwrap();
        let status = resp.status().as_u16();
        let http: Value = serde_json::from_slice(&resp.body_mut().read_to_vec().unwrap()).unwrap();
        // CLI
        let cli = og(&["tool", "--db", s(&db), name, &args.to_string()]);
        if status == 200 {
            assert_eq!(
                m["is_error"], false,
                "{what}: MCP refused what HTTP answered: {}",
                m["text"]
            );
            let cli = stable(json(&cli));
            assert_eq!(stable(http.clone()), cli, "{what}: HTTP and CLI differ");
            assert_eq!(
                stable(m["value"].clone()),
                cli,
                "{what}: MCP and CLI differ"
            );
        } else {
            refusals += 1;
            assert!((400..500).contains(&status), "{what}: HTTP {status}");
            assert_eq!(cli.status.code(), Some(2), "{what}: the CLI's exit code");
            assert_eq!(m["is_error"], true, "{what}: MCP did not refuse");
            let msg = http["error"]["message"].as_str().unwrap();
            assert_eq!(m["text"], msg, "{what}: MCP and HTTP messages differ");
            let err = String::from_utf8_lossy(&cli.stderr);
            assert!(
                err.contains(msg),
                "{what}: the CLI says {err}, HTTP says {msg}"
            );
        }
    }
    assert_eq!(refusals, 4);

    // navigate: the CLI's command and the plan_route tool are one service operation
    let nav = og(&[
        "navigate",
        "--db",
        s(&db),
        "--from",
        "the T-junction",
        "--to",
        "a bus stop",
        "--json",
    ]);
    assert_eq!(
        nav.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&nav.stderr)
    );
    let tool = og(&[
        "tool",
        "--db",
        s(&db),
        "plan_route",
        &json!({"from": "the T-junction", "to": "a bus stop", "poses": true}).to_string(),
    ]);
    assert_eq!(
        stable(json(&nav)),
        stable(json(&tool)),
        "navigate and plan_route differ"
    );
    // and they refuse an end that names nothing alike
    let bad = json!({"from": "lane:999999999", "to": "a bus stop"});
    let mut resp = agent
        .post(format!("{}/api/tools/plan_route", srv.url))
        .header("Content-Type", "application/json")
        .send(bad.to_string().as_bytes())
        .unwrap();
    assert_eq!(resp.status().as_u16(), 400);
    let http: Value = serde_json::from_slice(&resp.body_mut().read_to_vec().unwrap()).unwrap();
    let msg = http["error"]["message"].as_str().unwrap().to_string();
    let cli = og(&[
        "navigate",
        "--db",
        s(&db),
        "--from",
        "lane:999999999",
        "--to",
        "a bus stop",
    ]);
    assert_eq!(cli.status.code(), Some(2));
    let err = String::from_utf8_lossy(&cli.stderr);
    assert!(err.contains(&msg), "navigate says {err}, HTTP says {msg}");

    // ask: the service checks the request for every adapter (a server without a model
    // refuses a bad question for the question, before it says it has no model)
    for (question, why) in [
        ("   ".to_string(), "empty"),
        ("x".repeat(2001), "longer than 2000"),
    ] {
        let mut resp = agent
            .post(format!("{}/api/ask", srv.url))
            .header("Content-Type", "application/json")
            .send(json!({"question": question}).to_string().as_bytes())
            .unwrap();
        assert_eq!(resp.status().as_u16(), 400, "{why}");
        let http: Value = serde_json::from_slice(&resp.body_mut().read_to_vec().unwrap()).unwrap();
        let msg = http["error"]["message"].as_str().unwrap().to_string();
        assert!(msg.contains("question"), "{why}: {msg}");
        let cli = og(&["ask", "--db", s(&db), &question]);
        assert_eq!(cli.status.code(), Some(2), "{why}");
        let err = String::from_utf8_lossy(&cli.stderr);
        assert!(err.contains(&msg), "{why}: ask says {err}, HTTP says {msg}");
    }
}

/// Runs the Python MCP client over HTTP with these calls; one answer per call.
fn mcp_calls(py: &Path, url: &str, calls: &[(&str, Value)], token: Option<&str>) -> Vec<Value> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/mcp_calls.py");
    let list: Vec<Value> = calls.iter().map(|(n, a)| json!([n, a])).collect();
    let mut cmd = Command::new(py);
    cmd.arg(&script)
        .arg(url)
        .arg(Value::Array(list).to_string());
    if let Some(t) = token {
        cmd.args(["--token", t]);
    }
    serde_json::from_value(json_of_run(cmd, 300)).unwrap()
}

/// Drops the wall-clock fields of write answers.
fn no_clock(mut v: Value) -> Value {
    if let Some(o) = v.as_object_mut() {
        o.remove("time_unix_s");
        o.remove("undone_unix_s");
    }
    v
}

/// The write tools through the three adapters, each on its own copy of one map: the same
/// writes give the same answers (the same new ids, the same edit, the same undo).
#[test]
fn cli_http_and_mcp_write_alike() {
    let Some(py) = python_with_mcp() else {
        eprintln!("skipping: no Python with the mcp package (run scripts/setup.sh)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (_, db) = sim_map(
        dir.path(),
        &["--seed", "3", "--frames", "24"],
        &["--embedder", "hash"],
    );
    let v = read_query(
        &db,
        "MATCH (i:Instance) WHERE NOT i.semantic_class IN ['road', 'sidewalk', 'parking', 'terrain', 'other-ground'] \
         WITH i.caption AS c, collect(id(i)) AS ids WHERE size(ids) = 1 RETURN c ORDER BY c LIMIT 1",
    );
    let caption = v[0]["c"].as_str().unwrap().to_string();
    let copies: Vec<std::path::PathBuf> = ["cli", "http", "mcp"]
        .iter()
        .map(|n| {
            let p = dir.path().join(format!("{n}.og"));
            std::fs::copy(&db, &p).unwrap();
            p
        })
        .collect();
    let token = "conformance-token-0123456789";
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, token).unwrap();
    // the edit id is the next node id: the same on every copy
    let create = json!({"query": "CREATE (n:Note {text: 'hello'}) RETURN id(n) AS id"});
    let update = json!({"text": format!("{caption} is gone"), "apply": true});
    // CLI
    let cli_tool = |name: &str, args: &Value| {
        json(&og(&[
            "tool",
            "--db",
            s(&copies[0]),
            "--writes",
            name,
            &args.to_string(),
        ]))
    };
    let c1 = cli_tool("write_cypher", &create);
    let c2 = cli_tool("update_map", &update);
    let edit = c2["applied"]["edit_id"]
        .as_u64()
        .expect("the CLI applied the edit");
    let c3 = cli_tool("undo_map_edit", &json!({"edit_id": edit}));
    // HTTP
    let srv = serve(&copies[1], &["--token-file", s(&token_file)]);
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_global(Some(Duration::from_secs(60)))
        .http_status_as_error(false)
        .build()
        .into();
    let http = |name: &str, args: &Value| -> Value {
        let mut resp = agent
            .post(format!("{}/api/tools/{name}", srv.url))
            .header("Authorization", format!("Bearer {token}"))
            .send(args.to_string().as_bytes())
            .unwrap();
        assert_eq!(resp.status().as_u16(), 200, "{name}");
        serde_json::from_slice(&resp.body_mut().read_to_vec().unwrap()).unwrap()
    };
    let h1 = http("write_cypher", &create);
    let h2 = http("update_map", &update);
    let h3 = http("undo_map_edit", &json!({"edit_id": edit}));
    drop(srv);
    // MCP
    let srv = serve(&copies[2], &["--token-file", s(&token_file)]);
    let m = mcp_calls(
        &py,
        &format!("{}/mcp", srv.url),
        &[
            ("write_cypher", create.clone()),
            ("update_map", update.clone()),
            ("undo_map_edit", json!({"edit_id": edit})),
        ],
        Some(token),
    );
    drop(srv);
    for (what, cli, http, mcp) in [
        ("write_cypher", &c1, &h1, &m[0]),
        ("update_map", &c2, &h2, &m[1]),
        ("undo_map_edit", &c3, &h3, &m[2]),
    ] {
        assert_eq!(mcp["is_error"], false, "{what}: {}", mcp["text"]);
        assert_eq!(
            no_clock(http.clone()),
            no_clock(cli.clone()),
            "{what}: HTTP and CLI differ"
        );
        assert_eq!(
            no_clock(mcp["value"].clone()),
            no_clock(cli.clone()),
            "{what}: MCP and CLI differ"
        );
    }
    // and the three maps end alike
    let dump = |p: &Path| {
        read_query(
            p,
            "MATCH (n) WHERE NOT n:MapEdit RETURN id(n) AS id, labels(n) AS l, properties(n) AS p ORDER BY id",
        )
    };
    let first = dump(&copies[0]);
    assert_eq!(dump(&copies[1]), first);
    assert_eq!(dump(&copies[2]), first);
}
