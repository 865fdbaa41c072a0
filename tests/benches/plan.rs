//! Planning on the seq 00 lane graph (extracted from ../shared/data poses, stored, reloaded):
//! A* route time, A* + OMPL path time (p50), and the reference unit-cost route (fewest hops,
//! as the reference code's Dijkstra does) for the same pairs: time and length.
//! Run with `cargo bench -p opengraph-tests --bench plan`.

use std::time::Instant;

use graphstore::Store;
use ingest::hierarchy::{HierarchyConfig, build_hierarchy};
use planner::{Anchor, MotionConfig, RoadGraph, astar, plan_path, unit_cost_route};
use scene::GroundFrame;
use scene::opengraph_schema;

fn p(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn main() -> anyhow::Result<()> {
    let Some(data) = opengraph_tests::shared_data() else {
        println!("skipping: ../shared/data is absent");
        return Ok(());
    };
    let quick = !std::env::args().any(|a| a == "--bench");
    let dir = data.join("kitti/sequences/00");
    let traj = ingest::sources::kitti::load_trajectory(
        &dir.join("poses.txt"),
        Some(&dir.join("calib.txt")),
    )?;
    let tmp = tempfile::tempdir()?;
    let store = Store::create(tmp.path().join("00.og"))?;
    store.set_schema(opengraph_schema())?;
    build_hierarchy(
        &store,
        &traj,
        GroundFrame::KittiCam,
        "kitti-00",
        &HierarchyConfig::default(),
    )?;
    let r = store.read()?;
    let g = RoadGraph::from_store(&r)?;
    let n = g.nodes.len();
    let pairs: Vec<(usize, usize)> = (0..n)
        .flat_map(|a| (0..n).map(move |b| (a, b)))
        .filter(|(a, b)| a != b)
        .collect();
    let pairs: Vec<(usize, usize)> = if quick {
        pairs.into_iter().take(5).collect()
    } else {
        pairs
    };
    let mut cfg = MotionConfig::default();
    if let Some(v) = std::env::var("OG_CHUNK_M")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        cfg.chunk_m = v;
    }
    if let Some(v) = std::env::var("OG_GOOD_ENOUGH")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        cfg.good_enough_ratio = v;
    }
    let (mut t_route, mut t_full, mut t_unit) = (Vec::new(), Vec::new(), Vec::new());
    let (mut len_astar, mut len_unit, mut longer, mut fallbacks) = (0.0, 0.0, 0, 0);
    for &(a, b) in &pairs {
        let t = Instant::now();
        let route = astar(&g, Anchor::Node(a), Anchor::Node(b))?;
        t_route.push(t.elapsed().as_secs_f64() * 1e3);
        let path = plan_path(&route, &[], &cfg)?;
        t_full.push(t.elapsed().as_secs_f64() * 1e3);
        fallbacks += usize::from(path.fallback);
        let t = Instant::now();
        let (_, unit) = unit_cost_route(&g, a, b).expect("connected");
        t_unit.push(t.elapsed().as_secs_f64() * 1e3);
        len_astar += route.length_m;
        len_unit += unit;
        longer += usize::from(unit > route.length_m + 1.0);
    }
    let k = pairs.len();
    println!(
        "seq 00 lane graph: {n} nodes, {} edges; {k} ordered node pairs; OMPL budget {} ms, turning radius {} m, chunks of {} m, good enough at {}x the route",
        g.edges.len(),
        cfg.budget_ms,
        cfg.turning_radius_m,
        cfg.chunk_m,
        cfg.good_enough_ratio
    );
    println!(
        "  A* route:            p50 {:.3} ms, p99 {:.3} ms",
        p(&mut t_route.clone(), 0.5),
        p(&mut t_route, 0.99)
    );
    println!(
        "  A* route + OMPL:     p50 {:.1} ms, p99 {:.1} ms, {fallbacks} fallbacks",
        p(&mut t_full.clone(), 0.5),
        p(&mut t_full, 0.99)
    );
    println!("  unit-cost (hops):    p50 {:.3} ms", p(&mut t_unit, 0.5));
    println!(
        "  route length: A* {:.0} m on average, unit-cost {:.0} m ({:+.1}%); unit-cost is longer for {longer} of {k} pairs",
        len_astar / k as f64,
        len_unit / k as f64,
        100.0 * (len_unit - len_astar) / len_astar
    );
    Ok(())
}
