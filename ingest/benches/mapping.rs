//! Mapping back-end speed on the real KITTI sequence-00 scans with oracle detections, one
//! thread: milliseconds per key frame by stage (projection, denoising, transform,
//! association, fusion; no embedding), then MiniLM embedding time per detection, then peak
//! RSS. Run with `cargo bench -p ingest --bench mapping`; skips when ../shared/data is absent.
//!
//! Only frames 0-2 of the six scans have SemanticKITTI labels, so the oracle can run on those
//! three; each repetition maps them in order into a fresh map.

use std::time::Instant;

use ingest::mapping::{FrameInput, Mapper, MappingConfig, StageTimes};
use llm_tools::{Embedder, MiniLm};
use scene::GroundFrame;

mod common;

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let l = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    Some(l.split_whitespace().nth(1)?.parse::<f64>().ok()? / 1024.0)
}

fn main() -> anyhow::Result<()> {
    let quick = !std::env::args().any(|a| a == "--bench");
    let reps = if quick { 3 } else { 100 };
    let cfg = MappingConfig::default();
    let Some((camera, oracle)) = common::seq00_oracle_frames(&cfg)? else {
        return Ok(());
    };
    let oracle_ms: Vec<f64> = oracle.iter().map(|f| f.oracle_ms).collect();
    let frames: Vec<_> = oracle
        .into_iter()
        .map(|f| {
            let classes: Vec<u8> = f.truth.iter().map(|t| t.class).collect();
            (
                f.index,
                f.world_from_velo,
                f.points,
                f.detections,
                f.features,
                classes,
            )
        })
        .collect();
    let n_dets: usize = frames.iter().map(|f| f.3.detections.len()).sum();
    println!(
        "seq 00 frames 0-2, {} points/scan, {n_dets} oracle detections in all; oracle {:.1} ms/frame",
        frames[0].2.len(),
        oracle_ms.iter().sum::<f64>() / 3.0
    );
    let mut per_frame: Vec<f64> = Vec::new();
    let mut stages = StageTimes::default();
    for _ in 0..reps {
        let mut m = Mapper::new(cfg.clone(), GroundFrame::KittiCam);
        for (i, pose, pts, dets, feats, classes) in &frames {
            let t = Instant::now();
            let st = m.integrate(&FrameInput {
                index: *i,
                world_from_velo: *pose,
                points: pts,
                camera: &camera,
                detections: dets,
                features: feats,
                // the integration alone: no dynamic filter ran
                moving: None,
                classes,
            });
            per_frame.push(t.elapsed().as_secs_f64() * 1e3);
            stages.add(&st.times);
        }
        std::hint::black_box(m.post_process());
    }
    let n = per_frame.len() as f64;
    let mean = per_frame.iter().sum::<f64>() / n;
    println!(
        "mapping back end, {reps} x 3 frames: p50 {:.2} ms, p99 {:.2} ms, mean {mean:.2} ms per frame = {:.0} frames/s",
        pct(&mut per_frame, 0.5),
        pct(&mut per_frame, 0.99),
        1e3 / mean
    );
    println!(
        "  by stage (mean ms/frame): project {:.2}, denoise {:.2}, transform {:.2}, associate {:.2}, fuse {:.2}",
        stages.project_ms / n,
        stages.denoise_ms / n,
        stages.transform_ms / n,
        stages.associate_ms / n,
        stages.fuse_ms / n
    );
    if let Some(m) = peak_rss_mib() {
        println!("peak RSS before loading MiniLM {m:.0} MiB");
    }
    match MiniLm::from_dir(&llm_tools::embed::default_models_dir()) {
        Ok(mut e) => {
            let caps: Vec<String> = frames
                .iter()
                .flat_map(|f| f.3.detections.iter().map(|d| d.caption.clone()))
                .collect();
            let refs: Vec<&str> = caps.iter().map(String::as_str).collect();
            e.embed(&refs[..4])?; // warm-up
            let mut per_det = Vec::new();
            for _ in 0..if quick { 1 } else { 5 } {
                for f in &frames {
                    let c: Vec<&str> = f.3.detections.iter().map(|d| d.caption.as_str()).collect();
                    let t = Instant::now();
                    std::hint::black_box(e.embed(&c)?);
                    per_det.push(t.elapsed().as_secs_f64() * 1e3 / c.len() as f64);
                }
            }
            println!(
                "MiniLM caption embedding, one batch per frame: p50 {:.2} ms per detection",
                pct(&mut per_det, 0.5)
            );
        }
        Err(e) => println!("MiniLM not installed ({e}); embedding time not measured"),
    }
    if let Some(m) = peak_rss_mib() {
        println!("peak RSS with MiniLM {m:.0} MiB");
    }
    Ok(())
}
