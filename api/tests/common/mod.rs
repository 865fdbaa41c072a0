//! Helpers shared by the binary's integration tests (each test file uses some of them).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs `opengraph` with `args`.
pub fn og(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .env_remove("OPENGRAPH_TOKEN")
        .args(args)
        .output()
        .unwrap()
}

/// A path as `&str`.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Asserts the command succeeded, showing its output if not.
pub fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The stdout of a successful command as JSON.
pub fn json(out: &Output) -> serde_json::Value {
    ok(out);
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The rows of a read-only Cypher query (`query --read-only --json`).
pub fn read_query(db: &Path, cypher: &str) -> serde_json::Value {
    json(&og(&[
        "query",
        "--db",
        s(db),
        "--read-only",
        "--json",
        cypher,
    ]))
}

/// The node id of the lane-graph node with `lane_id` 0 (the start of the drive), asked in
/// Cypher: specs such as `lane:ID` take node ids.
pub fn first_lane_node(db: &Path) -> u64 {
    let v = read_query(db, "MATCH (l:LaneNode {lane_id: 0}) RETURN id(l) AS id");
    v[0]["id"].as_u64().expect("a LaneNode with lane_id 0")
}

/// Checks that a `plan --json` answer goes to node `id` (an Instance) at `centroid` (KITTI
/// world frame, ground plane x, z) and that its path ends on the road beside it, within
/// `max_gap_m` of the centroid.
pub fn assert_route_ends_at(plan: &serde_json::Value, id: u64, centroid: [f64; 3], max_gap_m: f64) {
    assert_eq!(plan["to"]["node"].as_u64(), Some(id), "{plan}");
    assert_eq!(plan["to"]["kind"], "Instance", "{plan}");
    let xy = [
        plan["to"]["xy"][0].as_f64().unwrap(),
        plan["to"]["xy"][1].as_f64().unwrap(),
    ];
    assert!(
        (xy[0] - centroid[0]).abs() < 1e-6 && (xy[1] - centroid[2]).abs() < 1e-6,
        "the route goes to {xy:?}, the object is at {centroid:?}"
    );
    let last = plan["path"]["poses"]
        .as_array()
        .and_then(|p| p.last())
        .expect("a path");
    let end = [last[0].as_f64().unwrap(), last[1].as_f64().unwrap()];
    let gap = (end[0] - centroid[0]).hypot(end[1] - centroid[2]);
    assert!(
        gap <= max_gap_m,
        "the path ends {gap:.1} m from the object that was found (limit {max_gap_m} m)"
    );
}

/// A JSON `[x, y, z]` array as numbers.
pub fn xyz(v: &serde_json::Value) -> [f64; 3] {
    [0, 1, 2].map(|i| v[i].as_f64().expect("a number"))
}

/// Simulates a city (`sim_args`, e.g. `["--seed", "3", "--frames", "24"]`) and maps it from
/// its detections (`build_args`, e.g. `["--embedder", "hash"]`); returns (sim folder, store),
/// the store a private copy at `dir/city.og`.
///
/// The simulation and its map are made once per binary and arguments for the whole test run
/// and kept in the target's temporary folder (several test files map the same small city;
/// each debug-build mapping costs tens of seconds). The sim folder is shared: read it only.
pub fn sim_map(
    dir: &Path,
    sim_args: &[&str],
    build_args: &[&str],
) -> (std::path::PathBuf, std::path::PathBuf) {
    let cached = cached_sim_map(sim_args, build_args);
    let db = dir.join("city.og");
    std::fs::copy(cached.join("city.og"), &db).unwrap();
    (cached.join("sim"), db)
}

/// The folder holding `sim/` and `city.og` made by `sim_args` and `build_args` with this
/// build of the binary, made on first use. Test binaries (which cargo runs one after another)
/// and the tests inside one (which run at once) wait on a file lock for the one that makes it;
/// a folder is only used once complete.
fn cached_sim_map(sim_args: &[&str], build_args: &[&str]) -> std::path::PathBuf {
    use std::hash::{Hash, Hasher};
    let exe = Path::new(env!("CARGO_BIN_EXE_opengraph"));
    let meta = std::fs::metadata(exe).unwrap();
    let mut h = std::hash::DefaultHasher::new();
    (sim_args, build_args, meta.len(), meta.modified().unwrap()).hash(&mut h);
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("og-fixtures");
    std::fs::create_dir_all(&root).unwrap();
    let key = format!("{:016x}", h.finish());
    let done = root.join(&key);
    let lock = std::fs::File::create(root.join(format!("{key}.lock"))).unwrap();
    lock.lock().unwrap();
    if !done.join("city.og").exists() {
        // maps made by older builds of the binary are never used again (the key holds the
        // binary's time): remove them, or a developer's disk fills by ~1 GB per rebuild
        let built = meta.modified().unwrap();
        for e in std::fs::read_dir(&root).unwrap().flatten() {
            let stale = e
                .metadata()
                .and_then(|m| m.modified())
                .is_ok_and(|t| t < built);
            let name = e.file_name().to_string_lossy().to_string();
            if stale && e.path().is_dir() && !name.ends_with(".partial") {
                let _ = std::fs::remove_dir_all(e.path());
                let _ = std::fs::remove_file(root.join(format!("{name}.lock")));
            }
        }
        let tmp = root.join(format!("{key}.partial"));
        let _ = std::fs::remove_dir_all(&tmp);
        std::fs::create_dir_all(&tmp).unwrap();
        let sim = tmp.join("sim");
        let mut a = vec!["sim", "--out", s(&sim), "--json"];
        a.extend_from_slice(sim_args);
        json(&og(&a));
        build_map(&sim, &tmp.join("city.og"), build_args);
        std::fs::rename(&tmp, &done).unwrap();
    }
    lock.unlock().unwrap();
    done
}

/// `opengraph build --json` of the simulator's sequence `sim` (its detections) into `db`,
/// with `build_args` added; the build's report.
pub fn build_map(sim: &Path, db: &Path, build_args: &[&str]) -> serde_json::Value {
    let dets = sim.join("detections");
    let mut b = vec![
        "build",
        "--kitti",
        s(sim),
        "--detections",
        s(&dets),
        "--db",
        s(db),
        "--json",
    ];
    b.extend_from_slice(build_args);
    json(&og(&b))
}

/// A running `opengraph serve`; killed on drop.
pub struct Server {
    child: std::process::Child,
    /// `http://127.0.0.1:PORT`, without a trailing slash.
    pub url: String,
}

impl Server {
    /// The server process's id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `opengraph serve --db DB` on 127.0.0.1 port 0 with `extra` flags and waits (60 s at
/// most) for the address it prints.
pub fn serve(db: &Path, extra: &[&str]) -> Server {
    serve_with_env(db, extra, None)
}

/// [`serve`] with `$OPENGRAPH_TOKEN` set to `token` (`None`: unset, whatever the test's own
/// environment holds).
#[allow(dead_code)]
pub fn serve_with_env(db: &Path, extra: &[&str], token: Option<&str>) -> Server {
    use std::io::BufRead;
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_opengraph"));
    match token {
        Some(t) => cmd.env("OPENGRAPH_TOKEN", t),
        None => cmd.env_remove("OPENGRAPH_TOKEN"),
    };
    let mut child = cmd
        .args(["serve", "--db", s(db), "--bind", "127.0.0.1:0"])
        .args(extra)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = std::io::BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let line = rx
        .recv_timeout(std::time::Duration::from_secs(60))
        .expect("the server printed its address within 60 s");
    let start = line.find("http://").expect("an address in the first line");
    let url = line[start..]
        .split_whitespace()
        .next()
        .unwrap()
        .trim_end_matches('/')
        .to_string();
    Server { child, url }
}

/// The Python of `$OPENGRAPH_VENV` (default `~/.cache/opengraph/venv`) when it can import
/// `modules` (comma-separated, as `import` takes them).
pub fn python_importing(modules: &str) -> Option<std::path::PathBuf> {
    let venv = std::env::var_os("OPENGRAPH_VENV")
        .map(std::path::PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME").map(|h| Path::new(&h).join(".cache/opengraph/venv"))
        })?;
    let py = venv.join("bin/python");
    let ok = Command::new(&py)
        .args(["-c", &format!("import {modules}")])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(py)
}

/// The project's Python when it has the official MCP client (`scripts/setup.sh` installs it).
pub fn python_with_mcp() -> Option<std::path::PathBuf> {
    python_importing("mcp")
}

/// A free TCP port on loopback (bound, read, released).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Runs `cmd` with its output captured, waiting `secs` at most, and returns what it did.
pub fn output_within(mut cmd: Command, secs: u64) -> std::process::Output {
    let child = cmd
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    rx.recv_timeout(std::time::Duration::from_secs(secs))
        .unwrap_or_else(|_| panic!("{cmd:?} did not finish within {secs} s"))
        .unwrap()
}

/// Runs `cmd` with its output captured, waiting `secs` at most; asserts it succeeded and
/// returns the last line of its stdout as JSON (the Python clients print one JSON line).
pub fn json_of_run(cmd: Command, secs: u64) -> serde_json::Value {
    let shown = format!("{cmd:?}");
    let out = output_within(cmd, secs);
    assert!(
        out.status.success(),
        "{shown} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(text.lines().last().unwrap_or_default()).unwrap()
}

/// Exports a map as node-link JSON to `out` and reads it back.
pub fn export(db: &Path, out: &Path) -> serde_json::Value {
    ok(&og(&[
        "export",
        "--db",
        s(db),
        "--format",
        "node-link",
        "--out",
        s(out),
    ]));
    serde_json::from_slice(&std::fs::read(out).unwrap()).unwrap()
}

/// Every instance's points by `Instance.instance_id`, sorted; each instance must have them.
pub fn point_clouds(db: &Path) -> Vec<(i64, Vec<[f32; 3]>)> {
    use graphstore::GraphRead;
    let store = graphstore::Store::open_read_only(db).unwrap();
    let r = store.read().unwrap();
    let mut v: Vec<(i64, Vec<[f32; 3]>)> = r
        .nodes_with_label("Instance")
        .unwrap()
        .into_iter()
        .map(|n| {
            let id = r
                .node_prop(n, "instance_id")
                .unwrap()
                .unwrap()
                .as_int()
                .unwrap();
            let points = r
                .point_cloud(n, "points")
                .unwrap()
                .unwrap_or_else(|| panic!("instance {id} has no points"));
            (id, points.xyz)
        })
        .collect();
    v.sort_by_key(|x| x.0);
    v
}

/// A small simulated city (`sim --seed SEED --frames 24`, hash embedder: no model files),
/// mapped once into `cell` for every test of one test binary; the map's path.
pub fn map_once(
    cell: &'static std::sync::OnceLock<tempfile::TempDir>,
    seed: &str,
) -> &'static Path {
    let dir = cell.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        sim_map(
            dir.path(),
            &["--seed", seed, "--frames", "24"],
            &["--embedder", "hash"],
        );
        dir
    });
    Box::leak(dir.path().join("city.og").into_boxed_path())
}

// ---- HTTP

pub fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .timeout_global(Some(std::time::Duration::from_secs(60)))
        .http_status_as_error(false)
        .build()
        .into()
}

/// (status, content type, body bytes) of a request.
pub fn request(
    method: &str,
    url: &str,
    headers: &[(&str, &str)],
    body: Option<&[u8]>,
) -> (u16, String, Vec<u8>) {
    try_request(method, url, headers, body).unwrap_or_else(|e| panic!("{method} {url}: {e}"))
}

/// [`request`], or the transport error (a server may answer 413 and close the connection
/// while a client is still sending an oversized body).
pub fn try_request(
    method: &str,
    url: &str,
    headers: &[(&str, &str)],
    body: Option<&[u8]>,
) -> Result<(u16, String, Vec<u8>), ureq::Error> {
    let a = agent();
    let resp = match (method, body) {
        ("GET", _) => {
            let mut r = a.get(url);
            for (k, v) in headers {
                r = r.header(*k, *v);
            }
            r.call()
        }
        (m, b) => {
            let mut r = match m {
                "POST" => a.post(url),
                "PUT" => a.put(url),
                _ => a.patch(url),
            };
            for (k, v) in headers {
                r = r.header(*k, *v);
            }
            r.send(b.unwrap_or_default())
        }
    };
    let mut resp = resp?;
    let status = resp.status().as_u16();
    let ct = resp
        .headers()
        .get("content-type")
        .and_then(|v| v.to_str().ok())
        .unwrap_or_default()
        .to_string();
    let bytes = resp
        .body_mut()
        .with_config()
        .limit(64 << 20)
        .read_to_vec()?;
    Ok((status, ct, bytes))
}

pub fn get(url: &str) -> (u16, serde_json::Value) {
    let (st, _, b) = request("GET", url, &[], None);
    (
        st,
        serde_json::from_slice(&b).unwrap_or(serde_json::Value::Null),
    )
}

pub fn post(url: &str, body: &serde_json::Value, token: Option<&str>) -> (u16, serde_json::Value) {
    let auth = token.map(|t| format!("Bearer {t}"));
    let headers: Vec<(&str, &str)> = auth
        .as_deref()
        .map(|a| vec![("Authorization", a)])
        .unwrap_or_default();
    let (st, _, b) = request("POST", url, &headers, Some(body.to_string().as_bytes()));
    (
        st,
        serde_json::from_slice(&b).unwrap_or(serde_json::Value::Null),
    )
}

/// A write token in `dir/token`: (its path, the token).
pub fn write_token(dir: &Path) -> (std::path::PathBuf, String) {
    let token = "test-token-0123456789abcdef".to_string();
    let path = dir.join("token");
    std::fs::write(&path, format!("{token}\n")).unwrap();
    (path, token)
}
