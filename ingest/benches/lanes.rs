//! Lane-graph extraction time on the real KITTI trajectories (seq 08: 4071 poses, seq 00:
//! 4541 poses), single thread. Run with `cargo bench -p ingest --bench lanes`; skips when
//! ../shared/data is absent.

use std::path::PathBuf;
use std::time::Instant;

use ingest::hierarchy::lanes::{LaneConfig, extract_lanes};
use ingest::hierarchy::segments::{SegmentConfig, build_segments};
use ingest::sources::kitti::{ground_trajectory, read_calib, read_poses};

fn main() -> anyhow::Result<()> {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/kitti/sequences");
    if !data.is_dir() {
        println!("skipping: {} is absent", data.display());
        return Ok(());
    }
    let quick = !std::env::args().any(|a| a == "--bench");
    let runs = if quick { 2 } else { 30 };
    println!("lane extraction (+ segments), {runs} runs each, one thread");
    for seq in ["08", "00", "05", "03"] {
        let dir = data.join(seq);
        let poses = read_poses(&dir.join("poses.txt"))?;
        let calib = read_calib(&dir.join("calib.txt"))?;
        let traj = ground_trajectory(&poses, Some(&calib));
        let (mut lanes_ms, mut seg_ms) = (Vec::new(), Vec::new());
        let mut summary = String::new();
        for _ in 0..runs {
            let t = Instant::now();
            let g = extract_lanes(&traj, &LaneConfig::default())?;
            lanes_ms.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            let s = build_segments(&g, &SegmentConfig::default());
            seg_ms.push(t.elapsed().as_secs_f64() * 1e3);
            summary = format!(
                "{} nodes, {} edges, {} segments",
                g.nodes.len(),
                g.edges.len(),
                s.segments.len()
            );
        }
        lanes_ms.sort_by(f64::total_cmp);
        seg_ms.sort_by(f64::total_cmp);
        println!(
            "  seq {seq} ({} poses): lanes p50 {:.2} ms (min {:.2}), segments p50 {:.2} ms; {summary}",
            poses.len(),
            lanes_ms[lanes_ms.len() / 2],
            lanes_ms[0],
            seg_ms[seg_ms.len() / 2]
        );
    }
    Ok(())
}
