//! The server under attack, over real loopback connections to `opengraph serve` on a
//! simulated city (hash embedder): hostile reads without the token (every procedure's size
//! argument, every expression that can grow: paths, lists, strings, maps, `range`, `reduce`,
//! `UNWIND`, `collect`), ids out of range, foreign `Host` headers, MCP protocol errors, and
//! slow or idle clients. Throughout, `/healthz` answers within 1 s; afterwards the server's
//! resident memory is back near its baseline and the map file is unchanged.

mod common;
use common::{Server, serve};

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

/// One small simulated city mapped once for all tests here.
fn map() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    common::map_once(&DIR, "5")
}

fn addr(server: &Server) -> String {
    server.url.trim_start_matches("http://").to_string()
}

/// A raw HTTP/1.1 exchange: sends `head` (the request line and headers, without the blank
/// line; `Connection: close` is added) and `body`, reads to the end (`secs` at most).
/// (status, headers, body).
fn raw(addr: &str, head: &str, body: &[u8], secs: u64) -> (u16, String, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(secs))).unwrap();
    s.set_write_timeout(Some(Duration::from_secs(secs)))
        .unwrap();
    let mut req = format!("{head}\r\nConnection: close\r\n");
    if !body.is_empty() {
        req.push_str(&format!("Content-Length: {}\r\n", body.len()));
    }
    req.push_str("\r\n");
    s.write_all(req.as_bytes()).unwrap();
    s.write_all(body).unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out).to_string();
    let (headers, _) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let status = headers
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body_at = out
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .map_or(out.len(), |p| p + 4);
    (status, headers.to_string(), out[body_at..].to_vec())
}

fn post_json(addr: &str, path: &str, body: &Value, secs: u64) -> (u16, Value) {
    let (st, _, b) = raw(
        addr,
        &format!("POST {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json"),
        body.to_string().as_bytes(),
        secs,
    );
    (st, serde_json::from_slice(&b).unwrap_or(Value::Null))
}

fn get_json(addr: &str, path: &str) -> (u16, Value) {
    let (st, _, b) = raw(
        addr,
        &format!("GET {path} HTTP/1.1\r\nHost: 127.0.0.1"),
        b"",
        30,
    );
    (st, serde_json::from_slice(&b).unwrap_or(Value::Null))
}

/// Resident and peak resident size of a process, in MiB.
fn rss_mib(pid: u32) -> (f64, f64) {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
            / 1024.0
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// Polls `/healthz` every 100 ms on fresh connections until stopped; the slowest answer in
/// ms and the number of failures.
struct HealthWatch {
    stop: Arc<AtomicBool>,
    slowest_ms: Arc<AtomicU64>,
    failures: Arc<AtomicU64>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl HealthWatch {
    fn start(addr: &str) -> HealthWatch {
        let stop = Arc::new(AtomicBool::new(false));
        let slowest_ms = Arc::new(AtomicU64::new(0));
        let failures = Arc::new(AtomicU64::new(0));
        let (a, st, sl, fl) = (
            addr.to_string(),
            stop.clone(),
            slowest_ms.clone(),
            failures.clone(),
        );
        let thread = std::thread::spawn(move || {
            while !st.load(Ordering::Relaxed) {
                let t = Instant::now();
                let (code, _, _) = raw(&a, "GET /healthz HTTP/1.1\r\nHost: localhost", b"", 5);
                let ms = t.elapsed().as_millis() as u64;
                sl.fetch_max(ms, Ordering::Relaxed);
                if code != 200 {
                    fl.fetch_add(1, Ordering::Relaxed);
                }
                std::thread::sleep(Duration::from_millis(100));
            }
        });
        HealthWatch {
            stop,
            slowest_ms,
            failures,
            thread: Some(thread),
        }
    }

    /// (slowest ms, failures).
    fn finish(mut self) -> (u64, u64) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.join().unwrap();
        }
        (
            self.slowest_ms.load(Ordering::Relaxed),
            self.failures.load(Ordering::Relaxed),
        )
    }
}

fn sha256_of(path: &Path) -> Vec<u8> {
    // a cheap fingerprint is enough: the file's bytes
    std::fs::read(path).unwrap()
}

#[test]
fn hostile_reads_are_refused_without_taking_the_server_down_or_holding_its_memory() {
    let db = map();
    let before = sha256_of(db);
    let server = serve(db, &["--workers", "2"]);
    let a = addr(&server);
    // warm up: the workers' scenes, the query path
    for q in [
        "MATCH (n:Instance) RETURN count(n) AS n",
        "MATCH (s:Segment) RETURN s.kind AS k, count(*) AS n",
    ] {
        let (st, v) = post_json(&a, "/api/cypher", &json!({"query": q}), 30);
        assert_eq!(st, 200, "{v}");
    }
    let (base_rss, _) = rss_mib(server.pid());
    let watch = HealthWatch::start(&a);
    // a vector as a client writes one: 384 numbers, about 4 KB of statement
    let zeros = format!(
        "[{}]",
        (0..384)
            .map(|i| format!("{:.7}", 0.05 + f64::from(i) * 1e-7))
            .collect::<Vec<_>>()
            .join(",")
    );
    assert!(zeros.len() > 3000);
    let big = i64::MAX.to_string();
    // (what, statement): each must be refused (400 with an error class) or stopped by the
    // time limit (504), never crash the server or make it hold gigabytes
    let hostile: Vec<(&str, String)> = vec![
        (
            "vector k at i64::MAX",
            format!(
                "CALL db.index.vector.queryNodes('instance_feature', {big}, {zeros}) YIELD node RETURN count(node) AS n"
            ),
        ),
        (
            "vector k at 10^12",
            format!(
                "CALL db.index.vector.queryNodes('instance_feature', 1000000000000, {zeros}) YIELD node RETURN count(node) AS n"
            ),
        ),
        (
            "fulltext k at i64::MAX",
            format!(
                "CALL db.index.fulltext.queryNodes('instance_caption', 'car', {big}) YIELD node RETURN count(node) AS n"
            ),
        ),
        (
            "spatial nearest k at i64::MAX",
            format!(
                "CALL db.index.spatial.nearest('instance_space', [0.0, 0.0, 0.0], {big}) YIELD node RETURN count(node) AS n"
            ),
        ),
        (
            "unbounded variable-length path count",
            "MATCH p = (a)-[*]-(b) RETURN count(p) AS n".into(),
        ),
        (
            "variable-length paths collected",
            "MATCH p = (a:Instance)-[:RELATED*1..12]-(b) RETURN size(collect(p)) AS n".into(),
        ),
        (
            "nested list comprehension",
            "RETURN size([x IN range(1, 20000) | [y IN range(1, 20000) | y]]) AS n".into(),
        ),
        (
            "range of i64::MAX elements",
            format!("RETURN size(range(0, {big})) AS n"),
        ),
        (
            "string doubled by reduce",
            "RETURN size(reduce(s = 'x', i IN range(1, 40) | s + s)) AS n".into(),
        ),
        (
            "list doubled by reduce",
            "RETURN size(reduce(l = [1], i IN range(1, 40) | l + l)) AS n".into(),
        ),
        (
            "replace blow-up",
            "WITH reduce(s = 'x', i IN range(1, 20) | s + s) AS s RETURN size(replace(s, 'x', s)) AS n"
                .into(),
        ),
        (
            "split into characters",
            "WITH reduce(s = 'ab', i IN range(1, 25) | s + s) AS s RETURN size(split(s, '')) AS n"
                .into(),
        ),
        (
            "maps in a comprehension",
            "RETURN size([i IN range(1, 9000000) | {a: i, b: toString(i), c: [i, i]}]) AS n".into(),
        ),
        (
            "UNWIND cross product",
            "UNWIND range(1, 10000000) AS x UNWIND range(1, 1000) AS y RETURN count(*) AS n".into(),
        ),
        (
            "collect of lists",
            "UNWIND range(1, 10000000) AS x RETURN size(collect([x, x, x, x, toString(x)])) AS n"
                .into(),
        ),
        (
            "cartesian product of every node",
            "MATCH (a), (b), (c) RETURN count(*) AS n".into(),
        ),
    ];
    let mut peak_growth = 0.0f64;
    for (what, q) in &hostile {
        let t = Instant::now();
        let (st, v) = post_json(&a, "/api/cypher", &json!({"query": q}), 60);
        let secs = t.elapsed().as_secs_f64();
        eprintln!(
            "{what}: {st} in {secs:.2} s: {}",
            v["error"]["message"].as_str().unwrap_or("")
        );
        assert!(
            st == 400 || st == 504 || (st == 200 && v["rows"].is_array()),
            "{what}: {st} {v}"
        );
        if st == 400 {
            assert!(
                v["error"]["message"]
                    .as_str()
                    .unwrap_or("")
                    .contains("Error")
                    || v["error"]["message"]
                        .as_str()
                        .unwrap_or("")
                        .contains("Limit"),
                "{what}: no error class in {v}"
            );
        }
        let (h, _) = get_json(&a, "/healthz");
        assert_eq!(h, 200, "{what}: the server did not survive");
        let (rss, hwm) = rss_mib(server.pid());
        peak_growth = peak_growth.max(hwm - base_rss);
        eprintln!("  rss {rss:.0} MiB, peak {hwm:.0} MiB (baseline {base_rss:.0})");
    }
    // the refusals that must come from a size check, not from running out the clock
    for what in [
        "vector k at i64::MAX",
        "range of i64::MAX elements",
        "string doubled by reduce",
        "nested list comprehension",
    ] {
        let q = &hostile.iter().find(|(w, _)| *w == what).unwrap().1;
        let t = Instant::now();
        let (st, v) = post_json(&a, "/api/cypher", &json!({"query": q}), 60);
        if what == "vector k at i64::MAX" {
            assert_eq!(st, 200, "{what}: {v}");
        } else {
            assert_eq!(st, 400, "{what}: {v}");
        }
        assert!(t.elapsed() < Duration::from_secs(9), "{what}");
    }
    // a statement over the length limit is refused saying so, not with its own text cut off
    let long = format!("RETURN '{}' AS s", "x".repeat(100_001));
    let (st, v) = post_json(&a, "/api/cypher", &json!({"query": long}), 30);
    assert_eq!(st, 400, "{v}");
    let msg = v["error"]["message"].as_str().unwrap_or_default();
    assert!(msg.contains("longer than 100000"), "{msg}");
    assert!(msg.len() < 400, "{msg}");
    let (slowest, failures) = watch.finish();
    eprintln!("healthz: slowest {slowest} ms, {failures} failures");
    assert_eq!(failures, 0);
    assert!(slowest < 1000, "healthz took {slowest} ms");
    // at most the statement budget per worker (512 MiB, two readers) above the baseline
    assert!(
        peak_growth < 1400.0,
        "the server grew {peak_growth:.0} MiB above its baseline"
    );
    // memory back near the baseline once the statements are over
    std::thread::sleep(Duration::from_millis(500));
    let (after, _) = rss_mib(server.pid());
    eprintln!("rss after: {after:.0} MiB, baseline {base_rss:.0} MiB");
    assert!(
        after - base_rss < 150.0,
        "the server holds {after:.0} MiB after the statements, {base_rss:.0} before"
    );
    drop(server);
    assert!(before == sha256_of(db), "the map file changed");
}

#[test]
fn ids_out_of_range_are_refused_naming_the_argument() {
    let server = serve(map(), &[]);
    let a = addr(&server);
    for (tool, args, arg) in [
        ("get_instance", json!({"id": 1e308}), "id"),
        ("get_instance", json!({"id": 5.5}), "id"),
        ("get_instance", json!({"id": 5.0}), "id"),
        ("get_instance", json!({"id": -1}), "id"),
        ("get_instance", json!({"id": "3"}), "id"),
        (
            "get_instance",
            serde_json::from_str::<Value>(r#"{"id": 18446744073709551616}"#).unwrap(),
            "id",
        ),
        ("describe_area", json!({"segment_id": 1e308}), "segment_id"),
        ("find_objects", json!({"text": "a car", "k": 5.0}), "k"),
    ] {
        let (st, v) = post_json(&a, &format!("/api/tools/{tool}"), &args, 30);
        let msg = v["error"]["message"].as_str().unwrap_or_default();
        assert_eq!(st, 400, "{tool} {args}: {v}");
        assert!(msg.contains(arg), "{tool} {args}: {msg}");
    }
    for path in [
        "/api/instances/18446744073709551616",
        "/api/instances/1e308",
        "/api/instances/-1",
        "/api/segments/99999999999999999999999",
        "/api/instances/18446744073709551616/points",
    ] {
        let (st, v) = get_json(&a, path);
        assert_eq!(st, 400, "{path}: {v}");
    }
    // an id in range that names nothing is 404, not node 0's data
    let (st, v) = post_json(&a, "/api/tools/get_instance", &json!({"id": u64::MAX}), 30);
    assert_eq!(st, 404, "{v}");
}

#[test]
fn only_this_servers_host_names_are_answered() {
    let server = serve(map(), &[]);
    let a = addr(&server);
    let port = a.rsplit(':').next().unwrap();
    for host in [
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        "localhost".into(),
        format!("[::1]:{port}"),
    ] {
        let (st, _, _) = raw(
            &a,
            &format!("GET /api/info HTTP/1.1\r\nHost: {host}"),
            b"",
            30,
        );
        assert_eq!(st, 200, "{host}");
    }
    for path in [
        "/api/info",
        "/api/export/node-link",
        "/",
        "/api/view",
        "/openapi.json",
    ] {
        for host in [
            "evil.example",
            "evil.example:80",
            "127.0.0.1.evil.example",
            "localhost:x",
        ] {
            let (st, _, b) = raw(&a, &format!("GET {path} HTTP/1.1\r\nHost: {host}"), b"", 30);
            assert_eq!(st, 403, "{path} with Host {host}");
            let v: Value = serde_json::from_slice(&b).unwrap();
            assert_eq!(v["error"]["code"], "forbidden_host");
        }
    }
    let (st, _, _) = raw(
        &a,
        "POST /mcp HTTP/1.1\r\nHost: evil.example\r\nContent-Type: application/json\r\nAccept: application/json, text/event-stream",
        br#"{"jsonrpc":"2.0","id":1,"method":"ping"}"#,
        30,
    );
    assert_eq!(st, 403);
    // a name given with --allowed-host is answered
    let named = serve(map(), &["--allowed-host", "map.example"]);
    let (st, _, _) = raw(
        &addr(&named),
        "GET /api/info HTTP/1.1\r\nHost: map.example:8080",
        b"",
        30,
    );
    assert_eq!(st, 200);
}

/// The JSON-RPC messages of an MCP answer (JSON or server-sent events).
fn jsonrpc_messages(body: &[u8]) -> Vec<Value> {
    let text = String::from_utf8_lossy(body);
    if let Ok(v) = serde_json::from_str::<Value>(&text) {
        return vec![v];
    }
    text.lines()
        .filter_map(|l| l.strip_prefix("data:"))
        .filter_map(|d| serde_json::from_str(d.trim()).ok())
        .collect()
}

#[test]
fn mcp_protocol_errors_follow_json_rpc() {
    let server = serve(map(), &[]);
    let a = addr(&server);
    let head = "POST /mcp HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nAccept: application/json, text/event-stream";
    for (body, code) in [
        (&b"this is not json"[..], -32700),
        (b"{\"jsonrpc\": \"2.0\", ", -32700),
        (b"[1, 2, 3]", -32600),
        (b"[]", -32600),
        (b"{\"foo\": 1}", -32600),
        (
            b"{\"jsonrpc\": \"1.0\", \"id\": 1, \"method\": \"ping\"}",
            -32600,
        ),
        (b"{\"jsonrpc\": \"2.0\", \"id\": 1}", -32600),
        (b"17", -32600),
    ] {
        let (st, _, b) = raw(&a, head, body, 30);
        let v: Value = serde_json::from_slice(&b).unwrap_or_else(|_| {
            panic!(
                "{}: not JSON: {}",
                String::from_utf8_lossy(body),
                String::from_utf8_lossy(&b)
            )
        });
        assert_eq!(st, 400, "{}: {v}", String::from_utf8_lossy(body));
        assert_eq!(
            v["error"]["code"],
            code,
            "{}: {v}",
            String::from_utf8_lossy(body)
        );
        assert_eq!(v["jsonrpc"], "2.0");
    }
    // a session: initialize, then calls with bad params and unknown methods
    let init = json!({"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": {
        "protocolVersion": "2025-06-18", "capabilities": {},
        "clientInfo": {"name": "attack", "version": "0"}}});
    let (st, headers, b) = raw(&a, head, init.to_string().as_bytes(), 30);
    assert_eq!(st, 200, "{}", String::from_utf8_lossy(&b));
    let session = headers
        .lines()
        .find_map(|l| {
            let (k, v) = l.split_once(':')?;
            k.eq_ignore_ascii_case("mcp-session-id")
                .then(|| v.trim().to_string())
        })
        .expect("a session id");
    let with_session =
        format!("{head}\r\nMcp-Session-Id: {session}\r\nMcp-Protocol-Version: 2025-06-18");
    let (st, _, _) = raw(
        &a,
        &with_session,
        br#"{"jsonrpc":"2.0","method":"notifications/initialized"}"#,
        30,
    );
    assert_eq!(st, 202);
    for (msg, code) in [
        (
            json!({"jsonrpc": "2.0", "id": 2, "method": "tools/call", "params": {"name": "get_instance", "arguments": "x"}}),
            -32602,
        ),
        (
            json!({"jsonrpc": "2.0", "id": 3, "method": "tools/call", "params": {"name": 5}}),
            -32602,
        ),
        (
            json!({"jsonrpc": "2.0", "id": 4, "method": "tools/call", "params": {"name": "no_such_tool", "arguments": {}}}),
            -32602,
        ),
        (
            json!({"jsonrpc": "2.0", "id": 5, "method": "no/such/method", "params": {}}),
            -32601,
        ),
    ] {
        let (_, _, b) = raw(&a, &with_session, msg.to_string().as_bytes(), 30);
        let answers = jsonrpc_messages(&b);
        let answer = answers
            .iter()
            .find(|m| m["id"] == msg["id"])
            .unwrap_or_else(|| panic!("{msg}: no answer in {}", String::from_utf8_lossy(&b)));
        assert_eq!(answer["error"]["code"], code, "{msg}: {answer}");
    }
    // a call whose arguments break the tool's schema is a tool error the model can read
    let bad_args = json!({"jsonrpc": "2.0", "id": 6, "method": "tools/call",
        "params": {"name": "get_instance", "arguments": {"id": 1e308}}});
    let (_, _, b) = raw(&a, &with_session, bad_args.to_string().as_bytes(), 30);
    let answers = jsonrpc_messages(&b);
    let answer = answers.iter().find(|m| m["id"] == 6).unwrap();
    assert_eq!(answer["result"]["isError"], true, "{answer}");
    // ending the session: 204, then the session is gone (404)
    let (st, _, _) = raw(
        &a,
        &format!(
            "DELETE /mcp HTTP/1.1\r\nHost: 127.0.0.1\r\nMcp-Session-Id: {session}\r\nMcp-Protocol-Version: 2025-06-18"
        ),
        b"",
        30,
    );
    assert_eq!(st, 204);
    let (st, _, _) = raw(
        &a,
        &with_session,
        br#"{"jsonrpc":"2.0","id":9,"method":"ping"}"#,
        30,
    );
    assert_eq!(st, 404);
}

#[test]
fn healthz_answers_outside_the_request_gate() {
    // two request slots, both taken by slow statements
    let server = serve(map(), &["--max-concurrent", "2", "--workers", "1"]);
    let a = addr(&server);
    let slow = "MATCH (a), (b), (c) RETURN count(*) AS n";
    let busy: Vec<_> = (0..2)
        .map(|_| {
            let a = a.clone();
            std::thread::spawn(move || post_json(&a, "/api/cypher", &json!({"query": slow}), 60))
        })
        .collect();
    std::thread::sleep(Duration::from_millis(700));
    let t = Instant::now();
    let (st, v) = get_json(&a, "/healthz");
    assert_eq!(st, 200, "{v}");
    assert!(t.elapsed() < Duration::from_secs(1));
    let (st, v) = get_json(&a, "/readyz");
    assert_eq!(st, 503, "{v}");
    let (st, _) = get_json(&a, "/api/info");
    assert_eq!(st, 503, "a third request while both slots are taken");
    for b in busy {
        let (st, v) = b.join().unwrap();
        assert!(st == 504 || st == 200 || st == 400, "{st} {v}");
    }
    let (st, v) = get_json(&a, "/readyz");
    assert_eq!((st, v["status"].as_str()), (200, Some("ready")));
}

#[test]
fn slow_clients_are_closed_and_do_not_starve_others() {
    let server = serve(map(), &["--client-timeout-secs", "2"]);
    let a = addr(&server);
    let mut slow = Vec::new();
    // 70 that send the headers and one byte of a 1000-byte body, then wait (more than the
    // 64 request slots)
    for _ in 0..70 {
        let mut s = TcpStream::connect(&a).unwrap();
        s.write_all(b"POST /api/cypher HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: 1000\r\n\r\n{")
            .unwrap();
        slow.push(s);
    }
    // 20 that send half a request line
    for _ in 0..20 {
        let mut s = TcpStream::connect(&a).unwrap();
        s.write_all(b"GET /api/inf").unwrap();
        slow.push(s);
    }
    // 100 that send nothing
    for _ in 0..100 {
        slow.push(TcpStream::connect(&a).unwrap());
    }
    // 5 that send one whole request, read its answer and then idle on the kept-alive connection
    for _ in 0..5 {
        let mut s = TcpStream::connect(&a).unwrap();
        s.write_all(b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
            .unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut buf = [0u8; 1024];
        let n = s.read(&mut buf).unwrap();
        assert!(buf[..n].starts_with(b"HTTP/1.1 200"));
        slow.push(s);
    }
    std::thread::sleep(Duration::from_millis(300));
    // a normal client is served at once, however many slow ones wait
    for _ in 0..5 {
        let t = Instant::now();
        let (st, v) = post_json(
            &a,
            "/api/cypher",
            &json!({"query": "MATCH (s:Segment) RETURN count(s) AS n"}),
            5,
        );
        assert_eq!(st, 200, "{v}");
        assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
        let (st, _) = get_json(&a, "/healthz");
        assert_eq!(st, 200);
    }
    // a body dripped a byte every 300 ms is cut off at the timeout (408), not accepted
    let drip = {
        let a = a.clone();
        std::thread::spawn(move || {
            let mut s = TcpStream::connect(&a).unwrap();
            s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
            let body = br#"{"query": "RETURN 1 AS one"}"#;
            s.write_all(
                format!(
                    "POST /api/cypher HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n",
                    body.len()
                )
                .as_bytes(),
            )
            .unwrap();
            let t = Instant::now();
            for b in body {
                if s.write_all(&[*b]).is_err() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(300));
                if t.elapsed() > Duration::from_secs(6) {
                    break;
                }
            }
            let mut out = Vec::new();
            let _ = s.read_to_end(&mut out);
            String::from_utf8_lossy(&out).to_string()
        })
    };
    // the slow ones are closed by the server once the timeout has passed
    std::thread::sleep(Duration::from_secs(4));
    let mut closed = 0;
    for s in &mut slow {
        s.set_read_timeout(Some(Duration::from_secs(3))).unwrap();
        let mut buf = [0u8; 4096];
        // a 408 answer and then the end, or the end at once
        let mut ended = false;
        for _ in 0..4 {
            match s.read(&mut buf) {
                Ok(0) => {
                    ended = true;
                    break;
                }
                Ok(_) => continue,
                Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => {
                    ended = true;
                    break;
                }
                Err(_) => break,
            }
        }
        closed += usize::from(ended);
    }
    assert_eq!(closed, slow.len(), "slow connections the server closed");
    let dripped = drip.join().unwrap();
    assert!(
        dripped.starts_with("HTTP/1.1 408"),
        "a dripped body: {dripped:?}"
    );
    // and the server still serves
    let (st, _) = get_json(&a, "/healthz");
    assert_eq!(st, 200);
}

#[test]
fn connections_over_the_cap_are_refused_at_once() {
    let server = serve(map(), &["--max-connections-per-client", "8"]);
    let a = addr(&server);
    let held: Vec<TcpStream> = (0..8).map(|_| TcpStream::connect(&a).unwrap()).collect();
    std::thread::sleep(Duration::from_millis(200));
    let (st, _, b) = raw(&a, "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1", b"", 5);
    assert_eq!(st, 503, "{}", String::from_utf8_lossy(&b));
    drop(held);
    std::thread::sleep(Duration::from_millis(300));
    let (st, _, _) = raw(&a, "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1", b"", 5);
    assert_eq!(st, 200);
}

#[test]
fn the_map_names_no_absolute_input_path() {
    let server = serve(map(), &[]);
    let a = addr(&server);
    let (st, v) = post_json(
        &a,
        "/api/cypher",
        &json!({"query": "MATCH (b:Build) RETURN b.args AS args"}),
        30,
    );
    assert_eq!(st, 200, "{v}");
    let args: Value = serde_json::from_str(v["rows"][0]["args"].as_str().unwrap()).unwrap();
    let dir = map().parent().unwrap().to_string_lossy().to_string();
    let text = args.to_string();
    assert!(!text.contains(&dir), "{text}");
    assert_eq!(args["sequence"], "sim");
    assert_eq!(args["poses"], "poses.txt");
    assert_eq!(args["source"], "detections:detections");
    assert_eq!(args["inputs_sha256"].as_str().unwrap().len(), 64);
    let (st, _, export) = raw(
        &a,
        "GET /api/export/node-link HTTP/1.1\r\nHost: 127.0.0.1",
        b"",
        60,
    );
    assert_eq!(st, 200);
    assert!(!String::from_utf8_lossy(&export).contains(&dir));
}

#[test]
fn the_official_mcp_client_ends_its_session_cleanly() {
    let Some(py) = common::python_with_mcp() else {
        eprintln!("skipping: no Python with the mcp package (run scripts/setup.sh)");
        return;
    };
    let server = serve(map(), &[]);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/mcp_session_end.py");
    let mut cmd = std::process::Command::new(py);
    cmd.arg(&script).arg(format!("{}/mcp", server.url));
    let r = common::json_of_run(cmd, 120);
    // an unknown tool is invalid params, as the MCP specification has it
    assert_eq!(r["unknown_tool_code"], -32602, "{r}");
    // and ending the session logs no "Session termination failed"
    assert_eq!(r["warnings"], json!([]), "{r}");
}
