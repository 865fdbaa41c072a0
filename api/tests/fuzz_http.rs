//! Fuzz targets `http_requests` and `mcp_bodies` (`og-fuzz`): raw HTTP/1.1 requests, and
//! JSON-RPC bodies posted to `/mcp`, mutated as bytes and sent over real loopback connections
//! to the server's own accept loop and router (`api::http::serve`) over the demo map. Each
//! input must get an HTTP answer or a closed connection within the client timeout, never a
//! crash; every 50 cases `/healthz` must answer 200 within 1 s; and the Cypher statements the
//! inputs reach run under the statement memory budget, since this test binary counts
//! allocations as `opengraph` does. The map stays consistent.
//!
//! Opt-in soak (ten minutes each, the process capped at 4 GiB of address space):
//! `OG_FUZZ_SECS=600 prlimit --as=4294967296 cargo test --release -p api --test fuzz_http -- --nocapture`

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

use api::find::Finder;
use api::http::ServeOptions;
use api::service::Service;
use api::tools::Toolbox;

#[global_allocator]
static ALLOC: graphstore::mem::CountingAlloc = graphstore::mem::CountingAlloc;

/// The demo map served in this process on 127.0.0.1 port 0; (address, store, runtime).
fn served(
    dir: &Path,
) -> (
    std::net::SocketAddr,
    graphstore::Store,
    tokio::runtime::Runtime,
) {
    let store = graphstore::Store::create(dir.join("demo.og")).unwrap();
    api::demo::build(&store).unwrap();
    let finder = || {
        Finder::new(
            Box::new(llm_tools::HashEmbedder::new(scene::FEATURE_DIM)),
            None,
        )
    };
    let first = Toolbox::new(store.clone(), finder(), false);
    let second = first.fork(finder());
    let service = Service::new(vec![first, second], Duration::from_secs(10)).unwrap();
    let opts = ServeOptions {
        bind: std::net::SocketAddr::from(([127, 0, 0, 1], 0)),
        header_timeout: Duration::from_secs(1),
        body_timeout: Duration::from_secs(1),
        ..ServeOptions::default()
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let listener = rt
        .block_on(tokio::net::TcpListener::bind(opts.bind))
        .unwrap();
    let addr = listener.local_addr().unwrap();
    let app = api::http::router(service, &opts);
    rt.spawn(async move {
        let _ = api::http::serve(listener, app, &opts, std::future::pending()).await;
    });
    (addr, store, rt)
}

/// Sends `bytes` on a fresh connection and reads the answer (2 s at most); what came back.
fn exchange(addr: std::net::SocketAddr, bytes: &[u8]) -> Vec<u8> {
    let mut s = match TcpStream::connect_timeout(&addr, Duration::from_secs(2)) {
        Ok(s) => s,
        Err(e) => panic!("the server no longer accepts connections: {e}"),
    };
    s.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    s.set_write_timeout(Some(Duration::from_secs(2))).unwrap();
    let _ = s.write_all(bytes);
    let _ = s.shutdown(std::net::Shutdown::Write);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    out
}

fn healthy(addr: std::net::SocketAddr) {
    let t = Instant::now();
    let out = exchange(
        addr,
        b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n",
    );
    assert!(
        out.starts_with(b"HTTP/1.1 200"),
        "healthz: {:?}",
        String::from_utf8_lossy(&out)
    );
    assert!(
        t.elapsed() < Duration::from_secs(1),
        "healthz took {:?}",
        t.elapsed()
    );
}

fn regressions() -> &'static Path {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fuzz-regressions"
    ))
}

/// A request with a correct `Content-Length` for `body`.
fn request(head: &str, body: &str) -> Vec<u8> {
    format!(
        "{head}\r\nHost: 127.0.0.1\r\nConnection: close\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .into_bytes()
}

#[test]
fn fuzz_http_requests() {
    let dir = tempfile::tempdir().unwrap();
    let (addr, store, _rt) = served(dir.path());
    let json = "Content-Type: application/json";
    let seeds: Vec<Vec<u8>> = vec![
        b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n".to_vec(),
        b"GET /api/info HTTP/1.1\r\nHost: localhost:7878\r\nConnection: close\r\n\r\n".to_vec(),
        b"GET /api/instances/3/points HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"
            .to_vec(),
        b"GET /api/segments/1 HTTP/1.1\r\nHost: [::1]:80\r\nConnection: close\r\n\r\n".to_vec(),
        request(
            &format!("POST /api/cypher HTTP/1.1\r\n{json}"),
            r#"{"query": "MATCH (n) RETURN n LIMIT 3", "params": {"x": [1, 2.5, "s", null]}}"#,
        ),
        request(
            &format!("POST /api/cypher HTTP/1.1\r\n{json}"),
            r#"{"query": "RETURN size([x IN range(1, 1000) | toString(x) + 'a'])"}"#,
        ),
        request(
            &format!("POST /api/find HTTP/1.1\r\n{json}"),
            r#"{"text": "the bench near the bus stop", "k": 5}"#,
        ),
        request(
            &format!("POST /api/tools/get_instance HTTP/1.1\r\n{json}"),
            r#"{"id": 2}"#,
        ),
        request(
            &format!("POST /api/route HTTP/1.1\r\n{json}\r\nAuthorization: Bearer x"),
            r#"{"from": "0,0", "to": "lane:1"}"#,
        ),
        b"POST /api/locate HTTP/1.1\r\nHost: 127.0.0.1\r\nTransfer-Encoding: chunked\r\nConnection: close\r\n\r\n5\r\n{\"tex\r\n0\r\n\r\n".to_vec(),
    ];
    let mut cases = 0u64;
    let mut answered = 0u64;
    og_fuzz::fuzz("http_requests", &seeds, regressions(), |bytes| {
        cases += 1;
        let out = exchange(addr, bytes);
        if !out.is_empty() {
            assert!(
                out.starts_with(b"HTTP/1."),
                "not an HTTP answer: {:?}",
                String::from_utf8_lossy(&out[..out.len().min(200)])
            );
            answered += 1;
        }
        if cases.is_multiple_of(50) {
            healthy(addr);
        }
    });
    healthy(addr);
    eprintln!("fuzz http_requests: {cases} requests, {answered} answered");
    assert!(answered > 0);
    assert!(store.check_consistency().unwrap().is_empty());
}

#[test]
fn fuzz_mcp_bodies() {
    let dir = tempfile::tempdir().unwrap();
    let (addr, store, _rt) = served(dir.path());
    let seeds: Vec<Vec<u8>> = [
        r#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{"protocolVersion":"2025-06-18","capabilities":{},"clientInfo":{"name":"f","version":"0"}}}"#,
        r#"{"jsonrpc":"2.0","id":2,"method":"tools/list"}"#,
        r#"{"jsonrpc":"2.0","id":3,"method":"tools/call","params":{"name":"read_cypher","arguments":{"query":"MATCH (n) RETURN count(n)"}}}"#,
        r#"{"jsonrpc":"2.0","id":"a","method":"tools/call","params":{"name":"get_instance","arguments":{"id":1e308}}}"#,
        r#"{"jsonrpc":"2.0","method":"notifications/initialized"}"#,
        r#"[{"jsonrpc":"2.0","id":1,"method":"ping"}]"#,
    ]
    .iter()
    .map(|b| b.as_bytes().to_vec())
    .collect();
    let mut cases = 0u64;
    let mut statuses = std::collections::BTreeMap::<String, u64>::new();
    og_fuzz::fuzz("mcp_bodies", &seeds, regressions(), |body| {
        cases += 1;
        let mut req = format!(
            "POST /mcp HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nContent-Type: application/json\r\nAccept: application/json, text/event-stream\r\nContent-Length: {}\r\n\r\n",
            body.len()
        )
        .into_bytes();
        req.extend_from_slice(body);
        let out = exchange(addr, &req);
        assert!(
            out.starts_with(b"HTTP/1.1 "),
            "no HTTP answer to {:?}: {:?}",
            String::from_utf8_lossy(body),
            String::from_utf8_lossy(&out[..out.len().min(200)])
        );
        let status = String::from_utf8_lossy(&out[9..12.min(out.len())]).to_string();
        *statuses.entry(status).or_default() += 1;
        if cases.is_multiple_of(50) {
            healthy(addr);
        }
    });
    healthy(addr);
    eprintln!("fuzz mcp_bodies: {cases} bodies; statuses {statuses:?}");
    // a 5xx would be our failure, not the input's
    assert!(!statuses.keys().any(|s| s.starts_with('5')), "{statuses:?}");
    assert!(store.check_consistency().unwrap().is_empty());
}
