//! Planning on lane graphs extracted from the real seq 00 and 05 trajectories and stored in a
//! graph store: routes exist between far-apart lane nodes, are never longer than the
//! reference unit-cost route, and OMPL refines them into valid paths.

use graphstore::Store;
use ingest::hierarchy::{HierarchyConfig, build_hierarchy};
use planner::{Anchor, MotionConfig, RoadGraph, Validity, astar, plan_path, unit_cost_route};
use scene::GroundFrame;
use scene::opengraph_schema;

#[test]
fn real_lane_graph_routes_and_paths() {
    let Some(data) = opengraph_tests::shared_data() else {
        eprintln!("skipping: ../shared/data is absent");
        return;
    };
    for seq in ["00", "05"] {
        let dir = data.join("kitti/sequences").join(seq);
        let traj = ingest::sources::kitti::load_trajectory(
            &dir.join("poses.txt"),
            Some(&dir.join("calib.txt")),
        )
        .unwrap();
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::create(tmp.path().join("s.og")).unwrap();
        store.set_schema(opengraph_schema()).unwrap();
        build_hierarchy(
            &store,
            &traj,
            GroundFrame::KittiCam,
            seq,
            &HierarchyConfig::default(),
        )
        .unwrap();
        let r = store.read().unwrap();
        let g = RoadGraph::from_store(&r).unwrap();
        assert_eq!(
            scene::records::ground_frame(&r).unwrap(),
            scene::GroundFrame::KittiCam
        );
        // every pair of lane nodes is connected (one continuous drive), and A* is never longer
        // than the fewest-hops route
        let mut longer = 0;
        let mut far = (0, 0, 0.0);
        for a in 0..g.nodes.len() {
            for b in 0..g.nodes.len() {
                let route = astar(&g, Anchor::Node(a), Anchor::Node(b)).unwrap();
                let (_, unit_len) = unit_cost_route(&g, a, b).unwrap();
                assert!(
                    route.length_m <= unit_len + 1e-6,
                    "seq {seq}: A* {} > unit-cost {unit_len}",
                    route.length_m
                );
                if unit_len > route.length_m + 1.0 {
                    longer += 1;
                }
                if route.length_m > far.2 {
                    far = (a, b, route.length_m);
                }
            }
        }
        eprintln!(
            "seq {seq}: {} lane nodes; the unit-cost route is longer for {longer} ordered pairs; longest route {:.0} m",
            g.nodes.len(),
            far.2
        );
        // an OMPL path between two nodes some 300 m apart along the road
        let (a, b) = (0..g.nodes.len())
            .flat_map(|a| (0..g.nodes.len()).map(move |b| (a, b)))
            .map(|(a, b)| {
                (
                    a,
                    b,
                    astar(&g, Anchor::Node(a), Anchor::Node(b))
                        .unwrap()
                        .length_m,
                )
            })
            .min_by(|x, y| (x.2 - 300.0).abs().total_cmp(&(y.2 - 300.0).abs()))
            .map(|(a, b, _)| (a, b))
            .unwrap();
        let route = astar(&g, Anchor::Node(a), Anchor::Node(b)).unwrap();
        let cfg = MotionConfig {
            budget_ms: 4000.0,
            ..MotionConfig::default()
        };
        let path = plan_path(&route, &[], &cfg).unwrap();
        assert!(!path.fallback, "seq {seq}: {:?}", path.warning);
        let v = Validity::new(&route.polyline, cfg.corridor_half_width_m, &[], 0.0);
        for p in &path.poses {
            assert!(v.corridor_distance([p[0], p[1]]) <= cfg.corridor_half_width_m + 1e-3);
        }
        eprintln!(
            "seq {seq}: route {} -> {} of {:.0} m, OMPL path {:.0} m by {}",
            route.nodes[0],
            route.nodes.last().unwrap(),
            route.length_m,
            path.length_m,
            path.planner
        );
    }
}
