//! Helpers shared by the binary's integration tests (each test file uses some of them).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs `opengraph` with `args`.
pub fn og(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_opengraph"))
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

/// Simulates a city into `dir/sim` (`sim_args`, e.g. `["--seed", "3", "--frames", "24"]`) and
/// maps it from its detections into `dir/city.og` (`build_args`, e.g. `["--embedder",
/// "hash"]`); returns (sim folder, store).
pub fn sim_map(
    dir: &Path,
    sim_args: &[&str],
    build_args: &[&str],
) -> (std::path::PathBuf, std::path::PathBuf) {
    let sim = dir.join("sim");
    let db = dir.join("city.og");
    let mut a = vec!["sim", "--out", s(&sim), "--json"];
    a.extend_from_slice(sim_args);
    json(&og(&a));
    let dets = sim.join("detections");
    let mut b = vec![
        "build",
        "--kitti",
        s(&sim),
        "--detections",
        s(&dets),
        "--db",
        s(&db),
        "--json",
    ];
    b.extend_from_slice(build_args);
    json(&og(&b));
    (sim, db)
}
