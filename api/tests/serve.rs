//! `opengraph serve` over real loopback HTTP: every route in the OpenAPI document answers, and
//! its answers validate against the document's schemas; HTTP and the CLI tool adapter give the
//! same answers; writes need the token and read routes are read-only by the parser; hostile
//! requests get a clear 4xx and change nothing; a non-loopback bind needs a token; a CLI
//! command against a served map says where the server is; MCP over streamable HTTP with the
//! official Python client.

mod common;
use common::{
    get, json, json_of_run, og, post, python_with_mcp, read_query, request, s, serve,
    serve_with_env, try_request, write_token,
};

use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;
use std::time::Duration;

use serde_json::{Value, json};

/// One small simulated city mapped once for all tests here (hash embedder: no model files).
fn map() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    // each test copies what it writes to
    common::map_once(&DIR, "3")
}

/// A copy of the map in a fresh folder (for servers that write).
fn copy_of_map() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("city.og");
    std::fs::copy(map(), &db).unwrap();
    (dir, db)
}

/// Validates `value` against the schema named by a `$ref` into the document's components.
fn assert_valid(doc: &Value, schema_ref: &str, value: &Value, what: &str) {
    let name = schema_ref.rsplit('/').next().unwrap();
    let schema = &doc["components"]["schemas"][name];
    assert!(!schema.is_null(), "{what}: no schema {schema_ref}");
    let v = jsonschema::validator_for(schema).unwrap();
    let errors: Vec<String> = v.iter_errors(value).map(|e| e.to_string()).collect();
    assert!(
        errors.is_empty(),
        "{what}: the answer breaks {name}: {errors:?}\n{value}"
    );
}

#[test]
fn every_route_answers_as_its_openapi_document_says() {
    let db = map();
    let srv = serve(db, &[]);
    let (st, doc) = get(&format!("{}/openapi.json", srv.url));
    assert_eq!(st, 200);
    assert_eq!(doc["openapi"], "3.1.0");
    // an instance and a segment to ask about
    let ids = json(&og(&[
        "query",
        "--db",
        s(db),
        "--read-only",
        "--json",
        "MATCH (i:Instance) WITH i ORDER BY id(i) LIMIT 1 MATCH (g:Segment) RETURN id(i) AS i, min(id(g)) AS g",
    ]));
    let (inst, seg) = (ids[0]["i"].as_u64().unwrap(), ids[0]["g"].as_u64().unwrap());
    // a valid request for every documented route: (method, path) -> (url path, body)
    let sample = |method: &str, path: &str| -> (String, Option<Value>) {
        let p = path
            .replace("/segments/{id}", &format!("/segments/{seg}"))
            .replace("{id}", &inst.to_string())
            .replace("{name}", "get_schema")
            .replace("{format}", "graphml");
        let body = match (method, path) {
            ("post", "/api/tools/{name}") => Some(json!({})),
            ("post", "/api/cypher") => {
                Some(json!({"query": "MATCH (s:Segment) RETURN count(s) AS n"}))
            }
            ("post", "/api/cypher/write") => Some(json!({"query": "RETURN 1 AS one"})),
            ("post", "/api/update") => Some(json!({"text": "the bench is gone"})),
            ("post", "/api/update/undo") => Some(json!({"edit_id": 1})),
            ("post", "/api/ask") => Some(json!({"question": "How many road segments are there?"})),
            ("post", "/api/find") => Some(json!({"text": "the bench near the bus stop", "k": 3})),
            ("post", "/api/locate") => {
                Some(json!({"text": "I'm at a T-junction next to a traffic light"}))
            }
            ("post", "/api/route") => Some(json!({"from": "the T-junction", "to": "a bus stop"})),
            ("post", other) => panic!("no sample request for POST {other}: add one"),
            _ => None,
        };
        (p, body)
    };
    let mut seen = 0;
    for (path, item) in doc["paths"].as_object().unwrap() {
        for (method, op) in item.as_object().unwrap() {
            let (p, body) = sample(method, path);
            let url = format!("{}{p}", srv.url);
            let what = format!("{} {path}", method.to_uppercase());
            let ok = &op["responses"]["200"]["content"];
            if path == "/api/ask" {
                // a server without --llm: the rule parser reads the question, the answer is
                // composed from describe_area's segments
                let (st, v) = post(&url, body.as_ref().unwrap(), None);
                assert_eq!(st, 200, "{what}: {v}");
                assert_valid(&doc, "#/components/schemas/ask_output", &v, &what);
                assert_eq!(v["model"], "rules", "{v}");
                assert_eq!(v["task"]["task"], "count_segments", "{v}");
                let truth = read_query(map(), "MATCH (s:Segment) RETURN count(s) AS n");
                assert_eq!(v["value"], truth[0]["n"], "{v}");
                seen += 1;
                continue;
            }
            if ["/api/cypher/write", "/api/update", "/api/update/undo"].contains(&path.as_str()) {
                // a read-only server has no write tools: a JSON 404 that says how to enable them
                let (st, v) = post(&url, body.as_ref().unwrap(), None);
                assert_eq!(st, 404, "{what}: {v}");
                assert_valid(&doc, "#/components/schemas/Error", &v, &what);
                assert!(
                    v["error"]["message"]
                        .as_str()
                        .unwrap()
                        .contains("--token-file")
                );
                seen += 1;
                continue;
            }
            let (st, ct, bytes) = match &body {
                Some(b) => request("POST", &url, &[], Some(b.to_string().as_bytes())),
                None => request("GET", &url, &[], None),
            };
            assert_eq!(st, 200, "{what}: {}", String::from_utf8_lossy(&bytes));
            if let Some(schema) = ok["application/json"]["schema"]["$ref"].as_str() {
                assert!(ct.starts_with("application/json"), "{what}: {ct}");
                let v: Value = serde_json::from_slice(&bytes).unwrap();
                assert_valid(&doc, schema, &v, &what);
            } else if path == "/api/export/{format}" {
                assert_eq!(ct, "application/graphml+xml", "{what}");
                let text = String::from_utf8(bytes).unwrap();
                assert!(
                    text.starts_with("<?xml") && text.contains("<graphml"),
                    "{what}"
                );
                // the other format, and a bad one
                let (st, v) = get(&format!("{}/api/export/node-link", srv.url));
                assert_eq!(st, 200);
                assert!(!v["nodes"].as_array().unwrap().is_empty());
                let (st, v) = get(&format!("{}/api/export/csv", srv.url));
                assert_eq!(st, 400, "{v}");
            } else if let Some(kind) = ["text/html", "text/javascript"]
                .into_iter()
                .find(|k| ok.get(*k).is_some())
            {
                // the viewer: its page and script, served by the binary
                assert!(ct.starts_with(kind), "{what}: {ct}");
                let text = String::from_utf8(bytes).unwrap();
                assert!(
                    text.contains(if kind == "text/html" {
                        "viewer.js"
                    } else {
                        "/api/view"
                    }),
                    "{what}"
                );
                assert!(
                    !text.contains("http://") && !text.contains("https://"),
                    "{what}: an external resource"
                );
            } else {
                assert!(ok.get("application/octet-stream").is_some(), "{what}");
                assert_eq!(ct, "application/octet-stream");
                assert!(
                    !bytes.is_empty() && bytes.len() % 12 == 0,
                    "{what}: {} bytes",
                    bytes.len()
                );
            }
            seen += 1;
        }
    }
    assert_eq!(seen, 23, "every route is documented and was exercised");

    // the points are the instance's: inside its bounding box (1 cm for the store's rounding)
    let (_, _, bytes) = request(
        "GET",
        &format!("{}/api/instances/{inst}/points", srv.url),
        &[],
        None,
    );
    let (_, inst_json) = get(&format!("{}/api/instances/{inst}", srv.url));
    let bbox = &inst_json["properties"]["bbox"];
    let (lo, hi) = (&bbox[0], &bbox[1]);
    assert_eq!(
        (bytes.len() / 12) as u64,
        inst_json["properties"]["point_count"].as_u64().unwrap()
    );
    for p in bytes.chunks_exact(12) {
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            let v = f64::from(f32::from_le_bytes(p[k * 4..k * 4 + 4].try_into().unwrap()));
            let (l, h) = (lo[axis].as_f64().unwrap(), hi[axis].as_f64().unwrap());
            assert!(
                v >= l - 0.01 && v <= h + 0.01,
                "{axis} = {v} outside [{l}, {h}]"
            );
        }
    }

    // conformance: HTTP and the CLI tool adapter give the same answers
    for (route, tool, args) in [
        (
            "/api/find",
            "find_objects",
            json!({"text": "the bench near the bus stop", "k": 3}),
        ),
        (
            "/api/locate",
            "locate",
            json!({"text": "a T-junction with a bus stop"}),
        ),
        (
            "/api/cypher",
            "read_cypher",
            json!({"query": "MATCH (i:Instance) RETURN i.semantic_class AS c, count(*) AS n ORDER BY c"}),
        ),
    ] {
        let (st, mut http) = post(&format!("{}{route}", srv.url), &args, None);
        assert_eq!(st, 200);
        let mut cli = json(&og(&["tool", "--db", s(db), tool, &args.to_string()]));
        // timings differ between runs
        http.as_object_mut().unwrap().remove("timings_ms");
        cli.as_object_mut().unwrap().remove("timings_ms");
        assert_eq!(http, cli, "HTTP and CLI answers differ for {tool}");
    }
}

#[test]
fn writes_need_the_token_and_reads_are_read_only() {
    let (dir, db) = copy_of_map();
    let (token_file, token) = write_token(dir.path());
    let srv = serve(&db, &["--token-file", s(&token_file)]);
    let create = json!({"query": "CREATE (n:Hack {x: 1}) RETURN id(n) AS id"});
    let count = || {
        let (st, v) = post(
            &format!("{}/api/cypher", srv.url),
            &json!({"query": "MATCH (n:Hack) RETURN count(n) AS n"}),
            None,
        );
        assert_eq!(st, 200, "{v}");
        v["rows"][0]["n"].as_u64().unwrap()
    };
    let write_url = format!("{}/api/cypher/write", srv.url);
    // no token, a wrong one, one with a changed last character
    for t in [None, Some("nope"), Some("test-token-0123456789abcdeF")] {
        let (st, v) = post(&write_url, &create, t);
        assert_eq!(st, 401, "{t:?}: {v}");
        assert!(v["error"]["message"].as_str().unwrap().contains("token"));
    }
    // the generic tool route is gated the same way
    let (st, _) = post(
        &format!("{}/api/tools/write_cypher", srv.url),
        &create,
        None,
    );
    assert_eq!(st, 401);
    assert_eq!(count(), 0);
    // a write through the read route is refused by the parser, token or not
    for t in [None, Some(token.as_str())] {
        let (st, v) = post(&format!("{}/api/cypher", srv.url), &create, t);
        assert_eq!(st, 400, "{v}");
        assert!(
            v["error"]["message"]
                .as_str()
                .unwrap()
                .contains("read-only"),
            "{v}"
        );
    }
    assert_eq!(count(), 0);
    // with the token the write happens, and find sees the change (the scene caches reload)
    let (st, v) = post(&write_url, &create, Some(&token));
    assert_eq!(st, 200, "{v}");
    assert_eq!(count(), 1);
    let find = |text: &str| {
        let (st, v) = post(
            &format!("{}/api/find", srv.url),
            &json!({"text": text, "k": 1}),
            None,
        );
        assert_eq!(st, 200, "{v}");
        v["results"][0]["id"].as_u64()
    };
    let before = find("a bench").unwrap();
    let (st, v) = post(
        &write_url,
        &json!({"query": "MATCH (i:Instance) WHERE id(i) = $id DETACH DELETE i", "params": {"id": before}}),
        Some(&token),
    );
    assert_eq!(st, 200, "{v}");
    // both workers answer (two requests at least), and neither returns the deleted node
    for _ in 0..4 {
        assert_ne!(
            find("a bench"),
            Some(before),
            "find returned a deleted instance"
        );
    }
    // a CLI command on the map names the server
    let out = og(&["info", "--db", s(&db)]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&srv.url) && err.contains("opengraph serve"),
        "{err}"
    );
    drop(srv);
    // the marker goes with the server... unless it was killed; a later open still works
    let store = graphstore::Store::open_read_only(&db).unwrap();
    assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
}

#[test]
fn the_write_token_can_come_from_the_environment() {
    let (dir, db) = copy_of_map();
    let (token_file, token) = write_token(dir.path());
    let create = json!({"query": "CREATE (n:Hack {x: 1}) RETURN id(n) AS id"});
    {
        let srv = serve_with_env(&db, &[], Some(&token));
        let url = format!("{}/api/cypher/write", srv.url);
        let (st, v) = post(&url, &create, None);
        assert_eq!(st, 401, "{v}");
        let (st, v) = post(&url, &create, Some(&token));
        assert_eq!(st, 200, "{v}");
    }
    // refused before the server starts (exit 2, saying why): both ways at once, a short
    // token; an empty variable is no token (a read-only server: the write route is absent)
    let refused = |env_token: &str, extra: &[&str]| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_opengraph"))
            .env("OPENGRAPH_TOKEN", env_token)
            .args(["serve", "--db", s(&db), "--bind", "127.0.0.1:0"])
            .args(extra)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let deadline = std::time::Instant::now() + Duration::from_secs(60);
        while child.try_wait().unwrap().is_none() {
            if std::time::Instant::now() > deadline {
                let _ = child.kill();
                panic!("serve {extra:?} with OPENGRAPH_TOKEN={env_token:?} did not refuse");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let out = child.wait_with_output().unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let (code, err) = refused(&token, &["--token-file", s(&token_file)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("OPENGRAPH_TOKEN") && err.contains("--token-file"),
        "{err}"
    );
    let (code, err) = refused("short", &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("16 or more"), "{err}");
    let srv = serve_with_env(&db, &[], Some(""));
    let (st, v) = post(
        &format!("{}/api/cypher/write", srv.url),
        &create,
        Some(&token),
    );
    assert_eq!(st, 404, "{v}");
}

#[test]
fn map_updates_over_http_need_the_token_and_undo_exactly() {
    let (dir, db) = copy_of_map();
    let (token_file, token) = write_token(dir.path());
    // an instance with a caption no other has
    let v = common::read_query(
        &db,
        "MATCH (i:Instance) WHERE NOT i.semantic_class IN ['road', 'sidewalk', 'parking', 'terrain', 'other-ground'] \
         WITH i.caption AS c, collect(id(i)) AS ids WHERE size(ids) = 1 RETURN ids[0] AS id, c ORDER BY id LIMIT 1",
    );
    let (id, caption) = (
        v[0]["id"].as_u64().unwrap(),
        v[0]["c"].as_str().unwrap().to_string(),
    );
    let srv = serve(&db, &["--token-file", s(&token_file)]);
    let url = |p: &str| format!("{}{p}", srv.url);
    let (_, before) = get(&url("/api/info"));
    // whether find over HTTP returns it, asked of each of the workers' scenes
    let found = |want: bool| {
        for _ in 0..4 {
            let (_, f) = post(&url("/api/find"), &json!({"text": caption, "k": 3}), None);
            let ids: Vec<_> = f["results"]
                .as_array()
                .unwrap()
                .iter()
                .map(|r| r["id"].as_u64())
                .collect();
            assert_eq!(ids.contains(&Some(id)), want, "{f}");
        }
    };
    found(true);
    // a proposal changes nothing and needs no token
    let proposal = json!({"text": format!("{caption} is gone")});
    let (st, v) = post(&url("/api/update"), &proposal, None);
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["target"]["candidates"][0]["id"].as_u64(), Some(id), "{v}");
    assert!(v["applied"].is_null(), "{v}");
    let (st, _) = get(&url(&format!("/api/instances/{id}")));
    assert_eq!(st, 200);
    let body = json!({"text": format!("{caption} is gone"), "apply": true});
    let (st, v) = post(&url("/api/update"), &body, None);
    assert_eq!(st, 401, "{v}");
    let (st, v) = post(&url("/api/update"), &body, Some(&token));
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["target"]["candidates"][0]["id"].as_u64(), Some(id), "{v}");
    let edit = v["applied"]["edit_id"].as_u64().expect("applied");
    let (st, _) = get(&url(&format!("/api/instances/{id}")));
    assert_eq!(st, 404);
    // find no longer returns it (every worker's scene is brought up to the edit)
    found(false);
    let (st, v) = post(&url("/api/update/undo"), &json!({"edit_id": edit}), None);
    assert_eq!(st, 401, "{v}");
    let (st, v) = post(
        &url("/api/update/undo"),
        &json!({"edit_id": edit}),
        Some(&token),
    );
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["undone"], true);
    let (st, _) = get(&url(&format!("/api/instances/{id}")));
    assert_eq!(st, 200);
    found(true);
    let (_, after) = get(&url("/api/info"));
    assert_eq!(before["relationships"], after["relationships"]);
    let mut nodes = after["nodes"].clone();
    assert_eq!(nodes["MapEdit"], 1);
    nodes.as_object_mut().unwrap().remove("MapEdit");
    assert_eq!(before["nodes"], nodes);
    // undoing twice is the caller's error
    let (st, v) = post(
        &url("/api/update/undo"),
        &json!({"edit_id": edit}),
        Some(&token),
    );
    assert_eq!(st, 400, "{v}");
}

#[test]
fn hostile_requests_get_a_clear_4xx_and_change_nothing() {
    let (dir, db) = copy_of_map();
    let (token_file, token) = write_token(dir.path());
    let srv = serve(
        &db,
        &[
            "--token-file",
            s(&token_file),
            "--body-limit-bytes",
            "65536",
        ],
    );
    let (_, before) = get(&format!("{}/api/info", srv.url));
    let deep = "[".repeat(60_000);
    let big = format!("{{\"text\": \"{}\"}}", "a".repeat(200_000));
    let bodies: Vec<(&str, Vec<u8>)> = vec![
        ("not JSON", b"hello".to_vec()),
        ("truncated", br#"{"text": "the bench"#.to_vec()),
        ("an array", b"[1, 2, 3]".to_vec()),
        ("a string", br#""text""#.to_vec()),
        ("deep nesting", deep.into_bytes()),
        ("oversized", big.into_bytes()),
        (
            "invalid UTF-8",
            vec![b'{', b'"', 0xff, 0xfe, b'"', b':', b'1', b'}'],
        ),
        ("NaN", br#"{"text": NaN}"#.to_vec()),
        (
            "wrong types",
            br#"{"text": 5, "k": "five", "query": [], "from": {}, "to": null}"#.to_vec(),
        ),
        (
            "unknown fields",
            br#"{"text": "a bench", "query": "MATCH (n) DETACH DELETE n", "evil": true}"#.to_vec(),
        ),
        ("huge k", br#"{"text": "a bench", "k": 1e300}"#.to_vec()),
        ("negative k", br#"{"text": "a bench", "k": -1}"#.to_vec()),
        ("empty text", br#"{"text": ""}"#.to_vec()),
        (
            "a write as a read",
            br#"{"query": "MATCH (n) DETACH DELETE n"}"#.to_vec(),
        ),
        ("bad Cypher", br#"{"query": "MATCH (n RETURN"}"#.to_vec()),
        (
            "params overflow",
            br#"{"query": "RETURN $x", "params": {"x": 99999999999999999999999}}"#.to_vec(),
        ),
        ("NUL bytes", b"{\"text\": \"\\u0000\\u0000\"}".to_vec()),
    ];
    let posts = [
        "/api/find",
        "/api/locate",
        "/api/route",
        "/api/cypher",
        "/api/cypher/write",
        "/api/update",
        "/api/update/undo",
        "/api/tools/find_objects",
        "/api/tools/write_cypher",
        "/api/tools/no_such_tool",
    ];
    let headers_sets: [&[(&str, &str)]; 4] = [
        &[],
        &[("Content-Type", "text/evil; charset=nope")],
        &[("Authorization", "Bearer ")],
        &[("Authorization", "Basic Zm9vOmJhcg==")],
    ];
    let mut n = 0;
    let mut too_large = 0;
    for path in posts {
        for (what, body) in &bodies {
            for headers in headers_sets {
                let label = format!("POST {path} with {what} and {headers:?}");
                let answer =
                    try_request("POST", &format!("{}{path}", srv.url), headers, Some(body));
                n += 1;
                let (st, ct, bytes) = match answer {
                    Ok(a) => a,
                    // refused before the client finished sending: fine for an oversized body
                    Err(ureq::Error::Io(e)) if *what == "oversized" => {
                        assert!(
                            matches!(
                                e.kind(),
                                std::io::ErrorKind::BrokenPipe
                                    | std::io::ErrorKind::ConnectionReset
                            ),
                            "{label}: {e}"
                        );
                        continue;
                    }
                    Err(e) => panic!("{label}: {e}"),
                };
                if *what == "oversized" {
                    assert_eq!(st, 413, "{label}");
                    too_large += 1;
                }
                // a few bodies are valid for some routes (unknown fields, a write as a read, ...)
                // only where the route accepts them: never a 5xx, never a write
                assert!((200..500).contains(&st), "{label}: {st}");
                if st >= 400 {
                    assert!(ct.starts_with("application/json"), "{label}: {ct}");
                    let v: Value = serde_json::from_slice(&bytes).unwrap_or(Value::Null);
                    let msg = v["error"]["message"].as_str().unwrap_or_default();
                    assert!(
                        msg.len() > 10,
                        "{label}: no clear message: {}",
                        String::from_utf8_lossy(&bytes)
                    );
                }
            }
        }
    }
    // bad paths and methods
    for (method, path, want) in [
        ("GET", "/api/instances/-1", 400),
        ("GET", "/api/instances/99999999999999999999999", 400),
        ("GET", "/api/instances/%00", 400),
        ("GET", "/api/instances/4294967295000", 404),
        ("GET", "/api/instances/4294967295000/points", 404),
        ("GET", "/api/segments/abc", 400),
        ("GET", "/api/nothing", 404),
        ("GET", "/api/find", 405),
        ("PUT", "/api/find", 405),
        ("GET", "/../../etc/passwd", 404),
    ] {
        let (st, ct, bytes) = request(method, &format!("{}{path}", srv.url), &[], Some(b"{}"));
        n += 1;
        assert_eq!(
            st,
            want,
            "{method} {path}: {}",
            String::from_utf8_lossy(&bytes)
        );
        assert!(ct.starts_with("application/json"), "{method} {path}: {ct}");
    }
    assert!(n > 500);
    // a client that sends a body over the limit is answered 413 or cut off while sending
    // (above); one that declares it gets the 413 at once, before sending it
    let addr = srv.url.trim_start_matches("http://");
    let mut sock = std::net::TcpStream::connect(addr).unwrap();
    sock.set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    use std::io::{Read, Write};
    sock.write_all(
        b"POST /api/find HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: 200000\r\n\r\n",
    )
    .unwrap();
    let mut head = vec![0u8; 4096];
    let got = sock
        .read(&mut head)
        .expect("an answer before the body was sent");
    let text = String::from_utf8_lossy(&head[..got]);
    assert!(text.starts_with("HTTP/1.1 413"), "{text}");
    assert!(text.contains("--body-limit-bytes"), "{text}");
    let _ = too_large;
    // the server still answers, and the map is as it was
    let (st, after) = get(&format!("{}/api/info", srv.url));
    assert_eq!(st, 200);
    assert_eq!(before["nodes"], after["nodes"]);
    assert_eq!(before["relationships"], after["relationships"]);
    drop(srv);
    let _ = token;
    let store = graphstore::Store::open_read_only(&db).unwrap();
    assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
}

#[test]
fn bad_settings_are_refused_before_serving() {
    let db = map();
    let dir = tempfile::tempdir().unwrap();
    let short = dir.path().join("short");
    std::fs::write(&short, "abc").unwrap();
    for (args, needle) in [
        (vec!["--bind", "0.0.0.0:0"], "without a token"),
        (vec!["--token-file", s(&short)], "16 or more"),
        (vec!["--token-file", "/nonexistent/token"], "token file"),
        (vec!["--timeout-secs", "nan"], "--timeout-secs"),
        (vec!["--timeout-secs=-1"], "--timeout-secs"),
        (vec!["--workers", "0"], "--workers"),
        (vec!["--body-limit-bytes", "0"], "--body-limit-bytes"),
        (vec!["--max-concurrent", "0"], "--max-concurrent"),
    ] {
        let mut a = vec!["serve", "--db", s(db)];
        a.extend(args.iter().copied());
        if !args.contains(&"--bind") {
            a.extend(["--bind", "127.0.0.1:0"]);
        }
        let out = og(&a);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

fn mcp_client(py: &Path, url: &str, token: Option<&str>) -> Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/mcp_client.py");
    let mut cmd = Command::new(py);
    cmd.arg(&script).arg(url);
    if let Some(t) = token {
        cmd.args(["--token", t]);
    }
    json_of_run(cmd, 300)
}

#[test]
fn a_real_mcp_client_over_streamable_http() {
    let Some(py) = python_with_mcp() else {
        eprintln!("skipping: no Python with the mcp package (run scripts/setup.sh)");
        return;
    };
    let (dir, db) = copy_of_map();
    let (token_file, token) = write_token(dir.path());
    let srv = serve(&db, &["--token-file", s(&token_file)]);
    let url = format!("{}/mcp", srv.url);
    // without the token: the write tool is listed (the server has a token) but refused
    let r = mcp_client(&py, &url, None);
    assert_eq!(r["server"], "opengraph");
    assert!(
        r["tools"]
            .as_array()
            .unwrap()
            .iter()
            .any(|t| t == "write_cypher")
    );
    assert_eq!(r["find"]["is_error"], false, "{}", r["find"]);
    assert!(!r["find"]["value"]["results"].as_array().unwrap().is_empty());
    assert_eq!(r["cypher_write_refused"]["is_error"], true);
    assert_eq!(r["locate"]["is_error"], false, "{}", r["locate"]);
    assert_eq!(r["bad_args"]["is_error"], true);
    assert_eq!(r["write"]["is_error"], true, "{}", r["write"]);
    assert!(r["write"]["text"].as_str().unwrap().contains("token"));
    assert_eq!(r["after_write"]["value"]["rows"][0]["n"], 0);
    // MCP and HTTP answer find alike
    let (_, http) = post(
        &format!("{}/api/find", srv.url),
        &json!({"text": "the bench near the bus stop", "k": 3}),
        None,
    );
    assert_eq!(http, r["find"]["value"]);
    // with the token the write happens
    let r = mcp_client(&py, &url, Some(&token));
    assert_eq!(r["write"]["is_error"], false, "{}", r["write"]);
    assert_eq!(r["after_write"]["value"]["rows"][0]["n"], 1);
}

#[test]
fn a_read_only_server_leaves_the_map_to_other_readers() {
    let db = map();
    let srv = serve(db, &[]);
    // a read-only server holds no write lock: the CLI reads alongside it
    let out = og(&["info", "--db", s(db), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (st, v) = get(&format!("{}/api/info", srv.url));
    assert_eq!(st, 200);
    assert_eq!(json(&out)["nodes"], v["nodes"]);
}

/// `POST /api/ask` with the smallest real model (SmolLM2-135M, fetched by scripts/setup.sh):
/// the answer records the model and the prompt, and validates against the document.
#[test]
fn ask_over_http_with_a_local_model() {
    let smol = llm_tools::embed::default_models_dir().join(llm_tools::chat::SMALLEST_LOCAL_MODEL);
    if !smol.exists() {
        eprintln!(
            "skipping: {} not found (run scripts/setup.sh)",
            smol.display()
        );
        return;
    }
    let srv = serve(map(), &["--llm", "local", "--llm-model", s(&smol)]);
    let (_, doc) = get(&format!("{}/openapi.json", srv.url));
    let (st, v) = post(
        &format!("{}/api/ask", srv.url),
        &json!({"question": "How many road segments are there?", "max_steps": 2}),
        None,
    );
    assert_eq!(st, 200, "{v}");
    assert_valid(&doc, "#/components/schemas/ask_output", &v, "POST /api/ask");
    // the model reads the question as a task (or the rules do, after its unusable form)
    let model = v["model"].as_str().unwrap();
    assert!(
        model.contains("SmolLM2") && model.contains(&llm_tools::prompts::ASK_TASK.id()),
        "{model}"
    );
    assert!(v["task"].is_object() && v["timings_ms"].is_array(), "{v}");
    // no write tool is offered to a caller without the token
    for step in v["steps"].as_array().unwrap() {
        assert_ne!(step["tool"], "write_cypher", "{v}");
    }
    let (st, v) = post(
        &format!("{}/api/ask", srv.url),
        &json!({"question": ""}),
        None,
    );
    assert_eq!(st, 400, "{v}");
}
