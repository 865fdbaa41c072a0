//! OMPL path validity: inside the corridor, within the turning radius, ending where asked,
//! around a blocking box; the fallback; and routing on a real Argoverse 2 map.

use planner::graph::{RoadEdge, RoadNode};
use planner::{
    Anchor, MotionConfig, Obstacle, Refinement, RoadGraph, Validity, astar, plan_path, snap,
};

fn l_graph() -> RoadGraph {
    let nodes = vec![
        RoadNode {
            key: "lane:0".into(),
            xy: [0.0, 0.0],
        },
        RoadNode {
            key: "lane:1".into(),
            xy: [100.0, 0.0],
        },
        RoadNode {
            key: "lane:2".into(),
            xy: [100.0, 70.0],
        },
    ];
    let edges = vec![
        RoadEdge {
            from: 0,
            to: 1,
            polyline: vec![[0.0, 0.0], [100.0, 0.0]],
            length_m: 100.0,
            directed: false,
        },
        RoadEdge {
            from: 1,
            to: 2,
            polyline: vec![[100.0, 0.0], [100.0, 70.0]],
            length_m: 70.0,
            directed: false,
        },
    ];
    RoadGraph::new(nodes, edges).unwrap()
}

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

fn check_path(
    path: &planner::MotionPath,
    validity: &Validity,
    cfg: &MotionConfig,
    start: [f64; 2],
    goal: [f64; 2],
) {
    assert!(!path.fallback, "{:?}", path.warning);
    assert!(path.poses.len() > 10);
    for p in &path.poses {
        let d = validity.corridor_distance([p[0], p[1]]);
        assert!(
            d <= cfg.corridor_half_width_m + 1e-3,
            "pose {p:?} is {d:.2} m from the route"
        );
    }
    // driving direction of each step: forwards or in reverse (Reeds-Shepp may reverse)
    let gear: Vec<bool> = path
        .poses
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]) * w[0][2].cos() + (w[1][1] - w[0][1]) * w[0][2].sin() >= 0.0)
        .collect();
    for (i, w) in path.poses.windows(2).enumerate() {
        let ds = ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt();
        // no jumps, also where planning chunks meet
        assert!(
            ds <= 2.0 * cfg.sample_step_m + 0.05,
            "jump of {ds:.2} m at {w:?}"
        );
        // next to a reversal cusp the chord is shorter than the arc driven, so the chord test
        // below does not apply to the steps on either side of it
        let at_cusp =
            (i > 0 && gear[i - 1] != gear[i]) || (i + 1 < gear.len() && gear[i + 1] != gear[i]);
        if at_cusp {
            continue;
        }
        let dyaw = wrap(w[1][2] - w[0][2]).abs();
        // curvature 1/R at most (5% slack for interpolation), straight-line steps need no turn
        assert!(
            dyaw <= ds / cfg.turning_radius_m * 1.05 + 1e-3,
            "turn of {dyaw:.3} rad over {ds:.3} m at {w:?}"
        );
    }
    let first = path.poses[0];
    let last = path.poses.last().unwrap();
    assert!(((first[0] - start[0]).powi(2) + (first[1] - start[1]).powi(2)).sqrt() < 1e-6);
    assert!(
        ((last[0] - goal[0]).powi(2) + (last[1] - goal[1]).powi(2)).sqrt() < 0.1,
        "{last:?} vs {goal:?}"
    );
}

#[test]
fn ompl_path_stays_in_the_corridor_and_respects_the_turning_radius() {
    let g = l_graph();
    let (a, b) = (
        snap(&g, [10.0, 0.0], 5.0).unwrap(),
        snap(&g, [100.0, 60.0], 5.0).unwrap(),
    );
    let route = astar(&g, a, b).unwrap();
    // RRT* alone, and the default: the route followed by the car's curves, no RRT* needed
    for (refinement, name) in [
        (Refinement::RrtOnly, "RRTstar"),
        (Refinement::FollowThenRrt, "follow/ReedsShepp"),
        (Refinement::FollowOnly, "follow/ReedsShepp"),
    ] {
        let cfg = MotionConfig {
            budget_ms: 2000.0,
            refinement,
            ..MotionConfig::default()
        };
        let path = plan_path(&route, &[], &cfg).unwrap();
        let validity = Validity::new(
            &route.polyline,
            cfg.corridor_half_width_m,
            &[],
            cfg.obstacle_margin_m,
        );
        check_path(&path, &validity, &cfg, [10.0, 0.0], [100.0, 60.0]);
        assert!(path.planner.starts_with(name), "{}", path.planner);
        assert!(path.length_m >= route.length_m - 2.0 * cfg.corridor_half_width_m);
        if refinement != Refinement::RrtOnly {
            // deterministic: the same path again, without touching the budget
            assert_eq!(plan_path(&route, &[], &cfg).unwrap(), path);
            // the corner is cut by an arc of the turning radius, not driven as a right angle
            let nearest = path
                .poses
                .iter()
                .map(|p| (p[0] - 100.0).hypot(p[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest > 1.0,
                "the path passes {nearest:.2} m from the corner"
            );
        }
    }
}

#[test]
fn only_the_blocked_chunk_is_left_to_rrt_star() {
    // 170 m in two chunks: a truck on the first one's road, leaving a gap only beyond the
    // deterministic pass's farthest offset (3 m; 3.3 m with the margin), the second chunk
    // (round the corner) free
    let g = l_graph();
    let route = astar(&g, Anchor::Node(0), Anchor::Node(2)).unwrap();
    let truck = Obstacle::axis_aligned([40.0, -7.0], [48.0, 3.0]);
    let cfg = MotionConfig {
        budget_ms: 3000.0,
        ..MotionConfig::default()
    };
    let path = plan_path(&route, &[truck], &cfg).unwrap();
    let validity = Validity::new(
        &route.polyline,
        cfg.corridor_half_width_m,
        &[truck],
        cfg.obstacle_margin_m,
    );
    check_path(&path, &validity, &cfg, [0.0, 0.0], [100.0, 70.0]);
    for p in &path.poses {
        assert!(validity.is_valid([p[0], p[1]]), "{p:?}");
    }
    assert_eq!(
        path.planner,
        "follow/ReedsShepp (1 chunk) + RRTstar/ReedsShepp (1 chunk, simplified)"
    );
    // following only: the blocked chunk makes it fall back at once, naming the chunk
    let follow_only = MotionConfig {
        refinement: Refinement::FollowOnly,
        ..cfg
    };
    let t = std::time::Instant::now();
    let path = plan_path(&route, &[truck], &follow_only).unwrap();
    assert!(t.elapsed().as_secs_f64() < 1.0, "{:?}", t.elapsed());
    assert!(path.fallback);
    let warning = path.warning.unwrap();
    assert!(
        warning.contains("chunk 1 of 2 (1 of 2 followed)"),
        "{warning}"
    );
}

#[test]
fn ompl_path_avoids_a_blocking_box() {
    // followed beside the route, and by RRT* alone
    for (refinement, name) in [
        (Refinement::FollowThenRrt, "follow/ReedsShepp (1 chunk)"),
        (
            Refinement::RrtOnly,
            "RRTstar/ReedsShepp (1 chunk, simplified)",
        ),
    ] {
        avoids_a_blocking_box(refinement, name);
    }
}

fn avoids_a_blocking_box(refinement: Refinement, name: &str) {
    let g = l_graph();
    let route = astar(
        &g,
        snap(&g, [5.0, 0.0], 5.0).unwrap(),
        snap(&g, [95.0, 0.0], 5.0).unwrap(),
    )
    .unwrap();
    // a parked truck over the right half of the road at x = 40..48
    let truck = Obstacle::axis_aligned([40.0, -3.0], [48.0, 1.0]);
    let cfg = MotionConfig {
        budget_ms: 3000.0,
        refinement,
        ..MotionConfig::default()
    };
    let path = plan_path(&route, &[truck], &cfg).unwrap();
    let validity = Validity::new(
        &route.polyline,
        cfg.corridor_half_width_m,
        &[truck],
        cfg.obstacle_margin_m,
    );
    check_path(&path, &validity, &cfg, [5.0, 0.0], [95.0, 0.0]);
    // the route straight through the truck is refused: the path goes round it
    assert_eq!(path.planner, name);
    for p in &path.poses {
        assert!(validity.is_valid([p[0], p[1]]));
    }
    // walk the path in 5 cm steps: it passes the truck's stretch of road and never enters the
    // truck, so it swerved (left or right, whichever was found)
    let mut alongside = 0;
    for w in path.poses.windows(2) {
        let (a, b) = (w[0], w[1]);
        let n = (((b[0] - a[0]).hypot(b[1] - a[1])) / 0.05).ceil().max(1.0) as usize;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            let (x, y) = (a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t);
            let inside =
                x >= truck.min[0] && x <= truck.max[0] && y >= truck.min[1] && y <= truck.max[1];
            assert!(
                !inside,
                "the path drives through the truck at ({x:.2}, {y:.2})"
            );
            if x > truck.min[0] && x < truck.max[0] {
                alongside += 1;
            }
        }
    }
    assert!(
        alongside > 0,
        "the path never passes the truck's stretch of road"
    );
}

#[test]
fn zero_budget_and_blocked_goal_fall_back_to_the_route() {
    let g = l_graph();
    let route = astar(&g, Anchor::Node(0), Anchor::Node(2)).unwrap();
    let cfg = MotionConfig {
        budget_ms: 0.0,
        ..MotionConfig::default()
    };
    let path = plan_path(&route, &[], &cfg).unwrap();
    assert!(path.fallback);
    assert_eq!(path.planner, "fallback:route");
    assert!(path.warning.as_deref().unwrap().contains("budget"));
    assert!((path.length_m - 170.0).abs() < 1e-6);
    // a wall across the whole corridor: OMPL cannot pass, so the route comes back with a warning
    let wall = Obstacle::axis_aligned([50.0, -10.0], [52.0, 10.0]);
    let cfg = MotionConfig {
        budget_ms: 150.0,
        ..MotionConfig::default()
    };
    let path = plan_path(&route, &[wall], &cfg).unwrap();
    assert!(path.fallback, "{}", path.planner);
    assert!(path.warning.is_some());
    assert!(
        plan_path(
            &route,
            &[],
            &MotionConfig {
                turning_radius_m: -1.0,
                ..MotionConfig::default()
            }
        )
        .is_err()
    );
}

#[test]
fn argoverse2_route_follows_successor_links() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/av2");
    if !dir.is_dir() {
        eprintln!("skipping: ../shared/data is absent");
        return;
    }
    let mut maps: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.to_string_lossy().contains("log_map_archive"))
        .collect();
    maps.sort();
    for map in maps {
        let (g, start_of) = RoadGraph::from_av2(&map).unwrap();
        assert!(g.edges.iter().all(|e| e.directed));
        // the longest shortest route from node 0's component: try pairs until one is routable
        let mut best: Option<planner::Route> = None;
        for a in 0..g.nodes.len().min(40) {
            for b in 0..g.nodes.len() {
                if let Ok(r) = astar(&g, Anchor::Node(a), Anchor::Node(b))
                    && best.as_ref().is_none_or(|x| r.length_m > x.length_m)
                {
                    best = Some(r);
                }
            }
        }
        let r = best.unwrap();
        eprintln!(
            "{}: {} lane segments, {} junction points, longest route {:.0} m over {} nodes",
            map.file_name().unwrap().to_string_lossy(),
            start_of.len(),
            g.nodes.len(),
            r.length_m,
            r.nodes.len()
        );
        assert!(r.length_m > 50.0);
        // consecutive route nodes are joined by a lane segment driven forwards
        for w in r.nodes.windows(2) {
            let (a, b) = (g.node_by_key(&w[0]).unwrap(), g.node_by_key(&w[1]).unwrap());
            assert!(
                g.edges.iter().any(|e| e.from == a && e.to == b),
                "{} -> {} is not a successor link",
                w[0],
                w[1]
            );
        }
    }
    let bad = std::env::temp_dir().join("og_bad_av2.json");
    std::fs::write(&bad, "{\"lane_segments\": 3}").unwrap();
    assert!(
        RoadGraph::from_av2(&bad)
            .unwrap_err()
            .to_string()
            .contains("og_bad_av2.json")
    );
}

#[test]
fn an_oriented_obstacle_blocks_only_its_footprint() {
    // a 10 m × 1 m fence turned 45° in a straight 4 m-wide corridor along x
    let fence = Obstacle::oriented(scene::OrientedBox {
        center: [20.0, 0.0],
        half_extents: [5.0, 0.5],
        yaw_rad: std::f64::consts::FRAC_PI_4,
        height_m: [0.0, 1.5],
    });
    let route = [[0.0, 0.0], [40.0, 0.0]];
    let v = Validity::new(&route, 4.0, &[fence], 0.0);
    assert!(!v.is_valid([20.0, 0.0]), "on the fence");
    assert!(!v.is_valid([22.0, 2.0]), "on the fence, further along it");
    // inside the fence's axis-aligned bounds (16.1..23.9) but off the fence itself
    assert!(v.is_valid([22.0, -2.0]));
    assert!(v.is_valid([17.0, 2.5]));
    assert!(fence.min[0] < 17.0 && fence.max[1] > 2.5);
}

#[test]
fn a_path_keeps_to_the_drivable_area() {
    // a 100 m road along x whose drivable area is only its upper half (y in 0..4) with a
    // 1 m-wide gap at x = 50: the corridor alone would allow y < 0 and the gap
    let half = |x0: f64, x1: f64| {
        vec![
            [[x0, 0.0], [x1, 0.0], [x1, 4.0]],
            [[x0, 0.0], [x1, 4.0], [x0, 4.0]],
        ]
    };
    let mut tris = half(-5.0, 49.5);
    tris.extend(half(50.5, 105.0));
    let area = scene::area::Drivable::from_triangles(&tris);
    let v = Validity::new(&[[0.0, 2.0], [100.0, 2.0]], 6.0, &[], 0.0).within(&[area], 0.2);
    assert!(v.is_valid([20.0, 2.0]) && v.is_valid([20.0, -0.1]));
    assert!(
        !v.is_valid([20.0, -1.0]),
        "outside the area, inside the corridor"
    );
    assert!(!v.is_valid([50.0, 2.0]), "in the gap");
    assert!(Validity::new(&[[0.0, 2.0], [100.0, 2.0]], 6.0, &[], 0.0).is_valid([20.0, -1.0]));
    // planned over the whole area: every pose stays on it; across the gap: the fallback
    let g = l_graph();
    let route = astar(
        &g,
        snap(&g, [5.0, 0.0], 5.0).unwrap(),
        snap(&g, [95.0, 0.0], 5.0).unwrap(),
    )
    .unwrap();
    let cfg = MotionConfig {
        budget_ms: 3000.0,
        ..MotionConfig::default()
    };
    let whole = scene::area::Drivable::from_triangles(&[
        [[-5.0, -3.0], [105.0, -3.0], [105.0, 1.5]],
        [[-5.0, -3.0], [105.0, 1.5], [-5.0, 1.5]],
    ]);
    let path =
        planner::motion::plan_path_on(&route, &[], std::slice::from_ref(&whole), &cfg).unwrap();
    assert!(!path.fallback, "{:?}", path.warning);
    for p in &path.poses {
        assert!(
            whole.distance([p[0], p[1]]) <= cfg.drivable_tolerance_m + 1e-6,
            "{p:?}"
        );
    }
}
