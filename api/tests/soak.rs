//! `build` killed with SIGKILL at random moments and resumed each time, on a simulated city:
//! every reopening of the half-built map is consistent, and the finished map equals an
//! uninterrupted build (the exported graph and every instance's points). `OG_SOAK_KILLS`
//! kills (default 3 in CI; the figure is 100 on the default small city:
//! `OG_SOAK_KILLS=100 OG_SOAK_FRAMES=300 cargo test --release -p api --test soak -- --nocapture`).

mod common;
use common::{og, ok, s};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn env_or<T: std::str::FromStr>(k: &str, d: T) -> T {
    std::env::var(k)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(d)
}

fn export(db: &Path, out: &Path) -> serde_json::Value {
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

/// Every instance's points, by instance id.
fn point_clouds(db: &Path) -> Vec<(i64, Vec<[f32; 3]>)> {
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
            (
                id,
                r.point_cloud(n, "points")
                    .unwrap()
                    .map(|p| p.xyz)
                    .unwrap_or_default(),
            )
        })
        .collect();
    v.sort_by_key(|x| x.0);
    v
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
    std::fs::write(&cfg, "[mapping]\ncommit_every = 2\n").unwrap();
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

    // kill at a moment drawn from [0, 2T/kills] (T the uninterrupted build's time; seeded),
    // so that about `kills` runs are needed to finish
    let killed = dir.path().join("killed.og");
    let mut rng = env_or("OG_SOAK_SEED", 0u64) ^ 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng % 10_000) as f64 / 10_000.0
    };
    let (mut done, mut landed, mut reopened) = (0usize, 0usize, 0usize);
    for _ in 0..kills {
        let mut a = args(&killed);
        if killed.exists() {
            a.push("--resume".into());
        }
        let mut child = Command::new(env!("CARGO_BIN_EXE_opengraph"))
            .args(&a)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let window = 2.0 * uninterrupted.max(0.5) / kills.max(1) as f64;
        std::thread::sleep(Duration::from_secs_f64(next() * window));
        if let Some(status) = child.try_wait().unwrap() {
            assert!(status.success(), "a build run failed on its own: {status}");
            done += 1;
            break;
        }
        child.kill().unwrap(); // SIGKILL
        let _ = child.wait();
        landed += 1;
        if killed.exists() {
            // every reopening is consistent
            let store = graphstore::Store::open_read_only(&killed).unwrap();
            assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
            reopened += 1;
        }
    }
    if done == 0 {
        let mut a = args(&killed);
        if killed.exists() {
            a.push("--resume".into());
        }
        ok(&og(&a.iter().map(String::as_str).collect::<Vec<_>>()));
    }
    eprintln!(
        "soak: {frames} frames, uninterrupted build {uninterrupted:.1} s; {landed} SIGKILLs landed, {reopened} reopenings consistent"
    );
    let (ga, gb) = (
        export(&whole, &dir.path().join("a.json")),
        export(&killed, &dir.path().join("b.json")),
    );
    assert_eq!(ga, gb, "the resumed map differs from the uninterrupted one");
    assert_eq!(point_clouds(&whole), point_clouds(&killed));
}
