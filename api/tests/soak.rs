//! `build` killed with SIGKILL at random moments and resumed each time, on a simulated city:
//! every reopening of the half-built map is consistent, and the finished map equals an
//! uninterrupted build (the exported graph and every instance's points). `OG_SOAK_KILLS`
//! kills (default 3 in CI; the figure is 100 on the default small city:
//! `OG_SOAK_KILLS=100 OG_SOAK_FRAMES=300 cargo test --release -p api --test soak -- --nocapture`).

mod common;
use common::{export, og, ok, point_clouds, s};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn env_or<T: std::str::FromStr>(k: &str, d: T) -> T {
    std::env::var(k)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(d)
}

#[test]
fn a_build_killed_at_random_moments_resumes_to_the_same_map() {
    let kills: usize = env_or("OG_SOAK_KILLS", 3);
    let frames: u32 = env_or("OG_SOAK_FRAMES", 30);
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    ok(&og(&[
        "sim",
        "--out",
        s(&sim),
        "--size",
        "small",
        "--seed",
        "0",
        "--frames",
        &frames.to_string(),
    ]));
    let cfg = dir.path().join("cfg.toml");
    std::fs::write(&cfg, "[mapping]\ncommit_every = 1\n").unwrap();
    let dets = sim.join("detections");
    let args = |db: &Path| -> Vec<String> {
        [
            "build",
            "--kitti",
            s(&sim),
            "--detections",
            s(&dets),
            "--config",
            s(&cfg),
            "--embedder",
            "hash",
            "--db",
            s(db),
        ]
        .iter()
        .map(|x| x.to_string())
        .collect()
    };
    let whole = dir.path().join("whole.og");
    let t0 = Instant::now();
    ok(&og(&args(&whole)
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>()));
    let uninterrupted = t0.elapsed().as_secs_f64();

    // each run is killed at a random moment (seeded, in [0, T/kills] with T the uninterrupted
    // build's time) after its first commit, so every kill lands on a build that moved on
    let killed = dir.path().join("killed.og");
    let mut rng = env_or("OG_SOAK_SEED", 0u64) ^ 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng % 10_000) as f64 / 10_000.0
    };
    let window = uninterrupted.max(0.5) / kills.max(1) as f64;
    let (mut done, mut landed, mut reopened) = (0usize, 0usize, 0usize);
    let mut progress: Vec<i64> = Vec::new();
    for _ in 0..kills {
        let mut a = args(&killed);
        if killed.exists() {
            a.push("--resume".into());
        }
        let mut child = Command::new(env!("CARGO_BIN_EXE_opengraph"))
            .args(&a)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let stderr = child.stderr.take().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            use std::io::BufRead;
            for line in std::io::BufReader::new(stderr)
                .lines()
                .map_while(Result::ok)
            {
                if line.contains("committed through frame") && tx.send(()).is_err() {
                    break;
                }
            }
        });
        // the first commit of this run, or its end
        let committed = rx.recv_timeout(Duration::from_secs(300)).is_ok();
        if committed {
            std::thread::sleep(Duration::from_secs_f64(next() * window));
        }
        if let Some(status) = child.try_wait().unwrap() {
            assert!(status.success(), "a build run failed on its own: {status}");
            done += 1;
            break;
        }
        child.kill().unwrap(); // SIGKILL
        let _ = child.wait();
        landed += 1;
        // every reopening is consistent; the build record says how far it got
        let store = graphstore::Store::open_read_only(&killed).unwrap();
        assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
        reopened += 1;
        let next_frame = store
            .query(
                "MATCH (b:Build) RETURN b.next_frame AS f",
                &graphstore::cypher::QueryOptions::default(),
            )
            .ok()
            .and_then(|r| {
                r.rows.first().and_then(|row| match row[0] {
                    graphstore::cypher::Val::Int(f) => Some(f),
                    _ => None,
                })
            })
            .unwrap_or(-1);
        progress.push(next_frame);
    }
    if done == 0 {
        let mut a = args(&killed);
        if killed.exists() {
            a.push("--resume".into());
        }
        ok(&og(&a.iter().map(String::as_str).collect::<Vec<_>>()));
    }
    let mut distinct = progress.clone();
    distinct.dedup();
    eprintln!(
        "soak: {frames} frames, uninterrupted build {uninterrupted:.1} s; {landed} SIGKILLs landed (each after its run's first commit), {reopened} reopenings consistent; the build's next frame took {} distinct values across the kills, the last {:?}",
        distinct.len(),
        progress.last()
    );
    let (ga, gb) = (
        export(&whole, &dir.path().join("a.json")),
        export(&killed, &dir.path().join("b.json")),
    );
    if ga != gb {
        // say where: the first differing node or edge, and the keys that differ
        let mut first = String::new();
        for part in ["nodes", "edges"] {
            let (a, b) = (ga[part].as_array().unwrap(), gb[part].as_array().unwrap());
            if a.len() != b.len() {
                first.push_str(&format!("{part}: {} vs {}; ", a.len(), b.len()));
            }
            if let Some((x, y)) = a.iter().zip(b).find(|(x, y)| x != y) {
                let keys: Vec<String> = x
                    .as_object()
                    .unwrap()
                    .iter()
                    .filter(|(k, v)| y.get(k.as_str()) != Some(v))
                    .map(|(k, v)| {
                        let t = |v: &serde_json::Value| {
                            v.to_string().chars().take(200).collect::<String>()
                        };
                        format!("{k}: {} vs {}", t(v), t(&y[k.as_str()]))
                    })
                    .collect();
                first.push_str(&format!(
                    "first differing {part} id {}: {}; ",
                    x["id"],
                    keys.join(", ")
                ));
                break;
            }
        }
        panic!("the resumed map differs from the uninterrupted one: {first}");
    }
    assert_eq!(point_clouds(&whole), point_clouds(&killed));
}
