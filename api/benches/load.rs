//! Load on `opengraph serve` over loopback: N concurrent clients (find, locate and Cypher reads
//! mixed, closed loop) plus one writer (a map update applied, then undone, over and over) for a
//! fixed time. Prints throughput, p50/p99 per route and the errors, then checks the store's
//! consistency. Not a CI test: run it by hand.
//!
//! ```sh
//! cargo bench -p api --bench load                       # the default small city, 32 clients, 60 s
//! OPENGRAPH_LOAD_DB=out/city.og OPENGRAPH_LOAD_SECS=20 OPENGRAPH_LOAD_CLIENTS=8 cargo bench -p api --bench load
//! ```
//! `OPENGRAPH_LOAD_RATE=500` paces the readers to 500 requests/s in all (open loop: each
//! client sends on a fixed schedule, and a request's latency counts from when it was due, so
//! a server that falls behind is not flattered); without it every client sends its next
//! request as soon as the last one is answered (closed loop), and latency is mostly queueing.
//! `OPENGRAPH_LOAD_UNIQUE=1` makes every find and locate text unique (a request number is
//! appended), so that none is answered from the server's query-embedding cache.
//! `OPENGRAPH_LOAD_WRITES=E` paces the writer to E edits a second (each an update and its undo,
//! so 2E commits a second; default 5); 0 lets it write as fast as the server answers.
//! `OPENGRAPH_LOAD_WORKERS=N` passes `--workers N` to the server.
//! `OPENGRAPH_LOAD_TRACE=FILE` writes every request (`at_s,route,ms,ok`: when it was sent,
//! seconds from the start) to a CSV file, to see when the slow ones happen.
//! The map is copied first (the writer changes it); without `OPENGRAPH_LOAD_DB` the default small
//! city is simulated and built (MiniLM; about 15 s).

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

const BIN: &str = env!("CARGO_BIN_EXE_opengraph");

fn env_or<T: std::str::FromStr>(k: &str, d: T) -> T {
    std::env::var(k)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(d)
}

fn run(args: &[&str]) -> anyhow::Result<()> {
    let out = Command::new(BIN).args(args).output()?;
    anyhow::ensure!(
        out.status.success(),
        "opengraph {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Ok(())
}

fn map(dir: &Path) -> anyhow::Result<PathBuf> {
    let db = dir.join("city.og");
    if let Ok(src) = std::env::var("OPENGRAPH_LOAD_DB") {
        std::fs::copy(src, &db)?;
        return Ok(db);
    }
    let sim = dir.join("sim");
    let sim_s = sim.to_str().unwrap();
    eprintln!("simulating and building the default small city ...");
    run(&["sim", "--out", sim_s, "--size", "small", "--seed", "0"])?;
    run(&[
        "build",
        "--kitti",
        sim_s,
        "--detections",
        sim.join("detections").to_str().unwrap(),
        "--db",
        db.to_str().unwrap(),
    ])?;
    Ok(db)
}

struct Sample {
    route: &'static str,
    /// When it was sent (due, in the open loop), seconds from the start.
    at_s: f64,
    ms: f64,
    ok: bool,
}

/// POSTs JSON; (2xx, the answer).
fn post(
    a: &ureq::Agent,
    url: &str,
    path: &str,
    body: &Value,
    token: Option<&str>,
) -> (bool, Value) {
    let mut r = a.post(format!("{url}{path}"));
    if let Some(t) = token {
        r = r.header("Authorization", format!("Bearer {t}"));
    }
    match r
        .header("Content-Type", "application/json")
        .send(body.to_string().as_bytes())
    {
        Ok(mut resp) => {
            let ok = resp.status().is_success();
            let v = resp
                .body_mut()
                .read_to_vec()
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok())
                .unwrap_or(Value::Null);
            (ok, v)
        }
        Err(_) => (false, Value::Null),
    }
}

fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .timeout_global(Some(Duration::from_secs(60)))
        .http_status_as_error(false)
        .build()
        .into()
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 - 1.0) * p).round() as usize]
}

fn main() -> anyhow::Result<()> {
    // `cargo bench` passes --bench; nothing else is taken
    let secs: f64 = env_or("OPENGRAPH_LOAD_SECS", 60.0);
    let clients: usize = env_or("OPENGRAPH_LOAD_CLIENTS", 32);
    let dir = tempfile::tempdir()?;
    let db = map(dir.path())?;
    let workers: Option<usize> = std::env::var("OPENGRAPH_LOAD_WORKERS")
        .ok()
        .and_then(|v| v.parse().ok());
    let edits_per_s: f64 = env_or("OPENGRAPH_LOAD_WRITES", 5.0);
    let token = "load-test-token-0123456789";
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, token)?;
    let mut server = Command::new(BIN)
        .args([
            "serve",
            "--db",
            db.to_str().unwrap(),
            "--bind",
            "127.0.0.1:0",
        ])
        .args(["--token-file", token_file.to_str().unwrap()])
        .args(["--max-concurrent", "256"])
        .args(
            workers
                .map(|w| ["--workers".to_string(), w.to_string()])
                .into_iter()
                .flatten(),
        )
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()?;
    let mut line = String::new();
    BufReader::new(server.stdout.take().unwrap()).read_line(&mut line)?;
    let url = line[line.find("http://").unwrap()..]
        .split_whitespace()
        .next()
        .unwrap()
        .trim_end_matches('/')
        .to_string();
    // the writer's target: an instance whose description `update` resolves without ambiguity
    let a0 = agent();
    let (_, v) = post(
        &a0,
        &url,
        "/api/cypher",
        &json!({"query": "MATCH (i:Instance) WHERE NOT i.semantic_class IN ['road','sidewalk','parking','terrain','other-ground'] \
                 WITH i.caption AS c, collect(id(i)) AS ids WHERE size(ids) = 1 RETURN c ORDER BY c LIMIT 40"}),
        None,
    );
    let caption = v["rows"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|r| r["c"].as_str())
        .find(|c| {
            let (ok, p) = post(
                &a0,
                &url,
                "/api/update",
                &json!({"text": format!("{c} is gone")}),
                Some(token),
            );
            ok && p["ambiguous"] == false
        })
        .unwrap_or("a bench")
        .to_string();
    eprintln!("the writer removes and restores: {caption:?}");
    // warm every worker
    for _ in 0..8 {
        post(
            &a0,
            &url,
            "/api/find",
            &json!({"text": "a bench", "k": 5}),
            None,
        );
    }
    let finds = [
        "the bench near the bus stop",
        "somewhere to sit while waiting for the bus",
        "a red car at the T-junction",
        "the post box by the crossroads",
        "a tree next to a lamp post",
        "who could I ask for directions",
    ];
    let locates = [
        "I'm at a T-junction next to a bus stop",
        "I'm at a crossroads, there's a traffic light and a post box",
    ];
    let reads = [
        "MATCH (s:Segment) RETURN s.kind AS kind, count(*) AS n ORDER BY kind",
        "MATCH (i:Instance)-[:IN_SEGMENT]->(s:Segment {kind: 't_intersection'}) RETURN i.semantic_class AS c, count(*) AS n ORDER BY n DESC LIMIT 5",
        "MATCH (a:Instance)-[r:RELATED]->(b:Instance) WHERE r.relation = 'next_to' RETURN count(*) AS n",
    ];
    let unique = env_or("OPENGRAPH_LOAD_UNIQUE", 0u8) == 1;
    let rate: f64 = env_or("OPENGRAPH_LOAD_RATE", 0.0);
    // each client's interval on the open-loop schedule
    let period = (rate > 0.0).then(|| Duration::from_secs_f64(clients as f64 / rate));
    let samples = Arc::new(Mutex::new(Vec::<Sample>::new()));
    let deadline = Instant::now() + Duration::from_secs_f64(secs);
    let start = Instant::now();
    let mut handles = Vec::new();
    for c in 0..clients {
        let samples = samples.clone();
        let url = url.clone();
        handles.push(std::thread::spawn(move || {
            let a = agent();
            let mut i = c;
            let mut local = Vec::new();
            // clients start spread over one interval
            let mut due = period.map(|p| start + p.mul_f64(c as f64 / clients as f64));
            while Instant::now() < deadline {
                if let Some(d) = due {
                    let now = Instant::now();
                    if d > now {
                        std::thread::sleep(d - now);
                    }
                }
                // half find, a quarter each locate and Cypher reads
                // a request number makes the text new to the embedding cache
                let text = |t: &str| {
                    if unique {
                        format!("{t} {c}x{i}")
                    } else {
                        t.to_string()
                    }
                };
                let (route, path, body) = match i % 4 {
                    0 | 2 => (
                        "find",
                        "/api/find",
                        json!({"text": text(finds[i % finds.len()]), "k": 5}),
                    ),
                    1 => (
                        "locate",
                        "/api/locate",
                        json!({"text": text(locates[i % locates.len()]), "k": 3}),
                    ),
                    _ => (
                        "cypher",
                        "/api/cypher",
                        json!({"query": reads[i % reads.len()]}),
                    ),
                };
                // open loop: from when it was due
                let t = due.unwrap_or_else(Instant::now);
                let (ok, _) = post(&a, &url, path, &body, None);
                local.push(Sample {
                    route,
                    at_s: t.saturating_duration_since(start).as_secs_f64(),
                    ms: t.elapsed().as_secs_f64() * 1e3,
                    ok,
                });
                i += 1;
                if let (Some(d), Some(p)) = (due.as_mut(), period) {
                    *d += p;
                }
            }
            samples.lock().unwrap().extend(local);
        }));
    }
    {
        let samples = samples.clone();
        let caption = caption.clone();
        let url = url.clone();
        handles.push(std::thread::spawn(move || {
            let a = agent();
            let mut local = Vec::new();
            let every = (edits_per_s > 0.0).then(|| Duration::from_secs_f64(1.0 / edits_per_s));
            let mut due = Instant::now();
            while Instant::now() < deadline {
                if let Some(every) = every {
                    let now = Instant::now();
                    if due > now {
                        std::thread::sleep(due - now);
                    }
                    due += every;
                }
                let t = Instant::now();
                let (ok, v) = post(
                    &a,
                    &url,
                    "/api/update",
                    &json!({"text": format!("{caption} is gone"), "apply": true}),
                    Some(token),
                );
                let applied = ok && v["applied"]["edit_id"].is_u64();
                if !applied && local.is_empty() {
                    eprintln!(
                        "update failed: {}",
                        v.to_string().chars().take(600).collect::<String>()
                    );
                }
                local.push(Sample {
                    route: "update",
                    at_s: t.saturating_duration_since(start).as_secs_f64(),
                    ms: t.elapsed().as_secs_f64() * 1e3,
                    ok: applied,
                });
                if let Some(edit) = v["applied"]["edit_id"].as_u64() {
                    let t = Instant::now();
                    let (ok, _) = post(
                        &a,
                        &url,
                        "/api/update/undo",
                        &json!({"edit_id": edit}),
                        Some(token),
                    );
                    local.push(Sample {
                        route: "undo",
                        at_s: t.saturating_duration_since(start).as_secs_f64(),
                        ms: t.elapsed().as_secs_f64() * 1e3,
                        ok,
                    });
                }
            }
            samples.lock().unwrap().extend(local);
        }));
    }
    for h in handles {
        let _ = h.join();
    }
    let wall = start.elapsed().as_secs_f64();
    let _ = server.kill();
    let _ = server.wait();
    let samples = samples.lock().unwrap();
    let mut by: BTreeMap<&str, (Vec<f64>, usize)> = BTreeMap::new();
    for s in samples.iter() {
        let e = by.entry(s.route).or_default();
        e.0.push(s.ms);
        if !s.ok {
            e.1 += 1;
        }
    }
    if let Ok(path) = std::env::var("OPENGRAPH_LOAD_TRACE") {
        let mut rows: Vec<&Sample> = samples.iter().collect();
        rows.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        let mut csv = String::from("at_s,route,ms,ok\n");
        for s in rows {
            csv.push_str(&format!("{:.4},{},{:.3},{}\n", s.at_s, s.route, s.ms, s.ok));
        }
        std::fs::write(&path, csv)?;
        eprintln!("every request written to {path}");
    }
    let total = samples.len();
    let errors: usize = by.values().map(|v| v.1).sum();
    println!(
        "{clients} clients + 1 writer, {wall:.1} s: {total} requests, {:.0} requests/s, {errors} errors, {:.1} commits/s",
        total as f64 / wall,
        samples
            .iter()
            .filter(|s| matches!(s.route, "update" | "undo") && s.ok)
            .count() as f64
            / wall
    );
    println!(
        "{:<8} {:>8} {:>9} {:>9} {:>9} {:>7}",
        "route", "count", "per s", "p50 ms", "p99 ms", "errors"
    );
    let mut report = serde_json::Map::new();
    for (route, (mut ms, err)) in by {
        let (p50, p99) = (pct(&mut ms, 0.5), pct(&mut ms, 0.99));
        println!(
            "{route:<8} {:>8} {:>9.1} {p50:>9.1} {p99:>9.1} {err:>7}",
            ms.len(),
            ms.len() as f64 / wall
        );
        report.insert(
            route.into(),
            json!({"count": ms.len(), "p50_ms": p50, "p99_ms": p99, "errors": err}),
        );
    }
    let store = graphstore::Store::open_read_only(&db)?;
    let problems = store.check_consistency()?;
    println!(
        "check_consistency: {}",
        if problems.is_empty() {
            "clean".to_string()
        } else {
            format!("{problems:?}")
        }
    );
    println!(
        "{}",
        json!({"clients": clients, "secs": wall, "edits_per_s": edits_per_s, "workers": workers, "requests": total, "errors": errors, "unique_texts": unique, "rate": rate,
               "consistent": problems.is_empty(), "routes": report})
    );
    Ok(())
}
