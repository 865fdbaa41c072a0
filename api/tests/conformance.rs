//! One set of requests through the three adapters — the CLI (`opengraph tool`), HTTP
//! (`POST /api/tools/{name}`) and MCP over streamable HTTP (the official Python client) — and
//! the answers compared: the same JSON for every read tool, and the same refusal (exit 2,
//! a 4xx, `isError`) with the same message for bad requests.

mod common;
use common::{json, og, read_query, s, sim_map};

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use serde_json::{Value, json};

struct Server(Child, String);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn serve(db: &Path) -> Server {
    let mut child = Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args(["serve", "--db", s(db), "--bind", "127.0.0.1:0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let line = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("the server's address");
    let url = line[line.find("http://").unwrap()..]
        .split_whitespace()
        .next()
        .unwrap()
        .trim_end_matches('/')
        .to_string();
    Server(child, url)
}

fn python_with_mcp() -> Option<std::path::PathBuf> {
    let venv = std::env::var_os("OPENGRAPH_VENV")
        .map(std::path::PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME").map(|h| Path::new(&h).join(".cache/opengraph/venv"))
        })?;
    let py = venv.join("bin/python");
    let ok = Command::new(&py)
        .args(["-c", "import mcp"])
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(py)
}

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
            json!({"query": "MATCH (i:Instance) WHERE i.class = $c RETURN count(i) AS n", "params": {"c": "car"}}),
        ),
        (
            "find_objects",
            json!({"text": "the bench near the bus stop", "k": 3}),
        ),
        (
            "find_objects",
            json!({"text": "somewhere to post a letter", "k": 2, "class": "pole"}),
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
        // refusals: bad arguments, a node that does not exist, a write through the read tool
        ("find_objects", json!({"k": 0})),
        ("get_instance", json!({"id": 999_999_999u64})),
        ("read_cypher", json!({"query": "CREATE (n:Hack) RETURN n"})),
        ("describe_area", json!({"segment_id": inst})),
    ];
    let srv = serve(&db);
    // MCP, all calls in one session
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/mcp_calls.py");
    let list: Vec<Value> = calls.iter().map(|(n, a)| json!([n, a])).collect();
    let child = Command::new(&py)
        .arg(&script)
        .arg(format!("{}/mcp", srv.1))
        .arg(Value::Array(list).to_string())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    let out = rx
        .recv_timeout(Duration::from_secs(300))
        .expect("the MCP client finished within 300 s")
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mcp: Vec<Value> = serde_json::from_str(
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .last()
            .unwrap_or_default(),
    )
    .unwrap();
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
            .post(format!("{}/api/tools/{name}", srv.1))
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
}
