//! `opengraph lanes`.

use anyhow::Context;

use super::args::*;

/// `opengraph lanes`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Lanes {
        poses,
        calib,
        stride,
        out,
        png,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Lanes here")
    };
    use ingest::hierarchy::{lanes, render, segments};
    let world = ingest::sources::kitti::load_trajectory(&poses, calib.as_deref())?;
    let frame = scene::GroundFrame::KittiCam;
    let full: Vec<[f64; 2]> = world.iter().map(|p| frame.ground(*p)).collect();
    let traj: Vec<[f64; 2]> = full.iter().step_by(stride as usize).copied().collect();
    let t0 = std::time::Instant::now();
    let mut g = lanes::extract_lanes(&traj, &lanes::LaneConfig::default())?;
    let segs = segments::build_segments(&g, &segments::SegmentConfig::default());
    let took = t0.elapsed();
    for e in &mut g.edges {
        for f in &mut e.frames {
            *f *= stride;
        }
    }
    for gap in &mut g.gaps {
        gap.after_pose *= stride;
    }
    let gj = render::geojson(&g, Some(&segs));
    std::fs::write(&out, serde_json::to_vec_pretty(&gj)?)
        .with_context(|| format!("writing {}", out.display()))?;
    if let Some(png) = &png {
        render::write_png(png, &full, &g, Some(&segs))?;
    }
    if json {
        outln!("{}", serde_json::to_string_pretty(&render::lanes_json(&g))?);
    } else {
        let kinds: Vec<String> = g
            .kind_counts()
            .iter()
            .map(|(k, n)| format!("{} {n}", k.as_str()))
            .collect();
        outln!(
            "{} poses -> {} lane nodes ({}), {} lane edges ({:.0} m), {} segments, in {:.1} ms",
            full.len(),
            g.nodes.len(),
            if kinds.is_empty() {
                "none".to_string()
            } else {
                kinds.join(", ")
            },
            g.edges.len(),
            // + 0.0 turns an empty sum's -0 into 0
            g.edges.iter().map(|e| e.length_m).sum::<f64>() + 0.0,
            segs.segments.len(),
            took.as_secs_f64() * 1e3
        );
        if g.edges.is_empty() {
            outln!("no lane edges: the trajectory does not move far enough to drive a road");
        }
        for gap in &g.gaps {
            outln!(
                "gap in the recording: {:.0} m after pose {}; the trajectory is split there",
                gap.distance_m,
                gap.after_pose
            );
        }
    }
    Ok(())
}
