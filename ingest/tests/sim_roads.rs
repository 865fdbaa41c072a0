//! The simulator's ground-truth junction types against what lane extraction finds on the
//! simulated drive (work in progress for issue 6).

use ingest::hierarchy::lanes::{LaneConfig, LaneNodeKind, extract_lanes};
use ingest::sources::sim::roads::{JunctionKind, RoadNetwork, SimSize, sample_path};

#[test]
fn lane_extraction_recovers_the_ground_truth_junctions() {
    let (mut agree, mut total) = (0, 0);
    for seed in 0..4 {
        let net = RoadNetwork::generate(seed, SimSize::Small);
        let path = net.drive_path(&net.exploration_route(), 1.75);
        // 10 Hz at 8 m/s
        let traj: Vec<[f64; 2]> = sample_path(&path, 0.8).into_iter().map(|s| s.0).collect();
        let g = extract_lanes(&traj, &LaneConfig::default()).unwrap();
        for n in &net.nodes {
            let want = match n.kind {
                JunctionKind::Crossroads => LaneNodeKind::Intersection,
                JunctionKind::TJunction => LaneNodeKind::TIntersection,
                JunctionKind::LBend => LaneNodeKind::LIntersection,
                JunctionKind::DeadEnd => LaneNodeKind::Breakpoint,
                JunctionKind::Straight => continue,
            };
            total += 1;
            let near = g
                .nodes
                .iter()
                .filter(|m| (m.xy[0] - n.pos[0]).hypot(m.xy[1] - n.pos[1]) < 15.0)
                .min_by(|a, b| {
                    let d = |m: &&ingest::hierarchy::lanes::LaneNode| {
                        (m.xy[0] - n.pos[0]).hypot(m.xy[1] - n.pos[1])
                    };
                    d(a).total_cmp(&d(b))
                });
            match near {
                Some(m) if m.kind == want => agree += 1,
                other => {
                    let nearest = g.nodes.iter().min_by(|a, b| {
                        let d = |m: &ingest::hierarchy::lanes::LaneNode| {
                            (m.xy[0] - n.pos[0]).hypot(m.xy[1] - n.pos[1])
                        };
                        d(a).total_cmp(&d(b))
                    });
                    eprintln!(
                        "seed {seed}: {:?} at {:?} found as {:?}; nearest {:?}",
                        n.kind,
                        n.pos,
                        other.map(|m| (m.kind, m.xy)),
                        nearest.map(|m| (m.kind, m.xy, m.disfluency_rad.to_degrees(), m.ways))
                    )
                }
            }
        }
    }
    let rate = agree as f64 / total as f64;
    eprintln!("junction agreement {agree}/{total} = {rate:.3}");
    // measured 39/44 on seeds 0-3: the misses are grid corners (and one T) that lane
    // extraction does not report; see the note in sources/sim/mod.rs
    assert!(rate >= 0.85, "{agree}/{total}");
}
