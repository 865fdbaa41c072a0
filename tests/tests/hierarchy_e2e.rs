//! The hierarchy written into a store: five layers, relations, idempotent re-runs, and the
//! real seq 00 trajectory.

use graphstore::{GraphRead, Store, Value};
use ingest::hierarchy::{HierarchyConfig, build_hierarchy};
use scene::GroundFrame;
use scene::opengraph_schema;

/// A drive in ENU at 1 m per pose, 1.7 m above ground.
fn drive(waypoints: &[[f64; 2]]) -> Vec<[f64; 3]> {
    let mut out = vec![[waypoints[0][0], waypoints[0][1], 1.7]];
    for w in waypoints.windows(2) {
        let n = ((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
            .round()
            .max(1.0) as usize;
        for k in 1..=n {
            let f = k as f64 / n as f64;
            out.push([
                w[0][0] + f * (w[1][0] - w[0][0]),
                w[0][1] + f * (w[1][1] - w[0][1]),
                1.7,
            ]);
        }
    }
    out
}

fn instance(
    tx: &mut graphstore::WriteTxn<'_>,
    id: i64,
    class: &str,
    min: [f64; 3],
    max: [f64; 3],
) -> u64 {
    let c = [0, 1, 2].map(|i| (min[i] + max[i]) / 2.0);
    tx.create_node_named(
        &["Instance"],
        &[
            ("instance_id", Value::Int(id)),
            ("caption", format!("a {class}").into()),
            ("semantic_class", class.into()),
            ("centroid", Value::Point3D(c)),
            ("bbox", Value::box3d(min, max)),
        ],
    )
    .unwrap()
}

fn count(r: &impl GraphRead, label: &str) -> u64 {
    r.counts().unwrap().nodes.get(label).copied().unwrap_or(0)
}

fn rels(r: &impl GraphRead, ty: &str) -> u64 {
    r.counts()
        .unwrap()
        .relationships
        .get(ty)
        .copied()
        .unwrap_or(0)
}

#[test]
fn t_junction_hierarchy_with_instances() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("h.og")).unwrap();
    store.set_schema(opengraph_schema()).unwrap();
    let (car_a, car_b, lamp, bench) = store
        .write(|tx| {
            // two parked cars one behind the other along the west road (heading +x), a lamp
            // and a bench on the north road's east side
            let a = instance(tx, 1, "car", [-80.0, -4.0, 0.0], [-76.0, -2.0, 1.5]);
            let b = instance(tx, 2, "car", [-75.5, -4.0, 0.0], [-71.5, -2.0, 1.5]);
            let l = instance(tx, 3, "pole", [5.0, 60.0, 0.0], [5.3, 60.3, 5.0]);
            let c = instance(tx, 4, "bench", [5.0, 62.0, 0.0], [5.6, 63.5, 0.9]);
            Ok((a, b, l, c))
        })
        .unwrap();
    let traj = drive(&[
        [-200.0, 0.0],
        [0.0, 0.0],
        [0.0, 200.0],
        [0.0, 0.0],
        [200.0, 0.0],
    ]);
    let (lanes, segs, report) = build_hierarchy(
        &store,
        &traj,
        GroundFrame::Enu,
        "t-junction",
        &HierarchyConfig::default(),
    )
    .unwrap();
    assert_eq!(lanes.nodes.len(), 4);
    assert_eq!(segs.segments.len(), 4);
    let r = store.read().unwrap();
    assert_eq!(count(&r, "Environment"), 1);
    assert_eq!(count(&r, "Segment"), 4);
    assert_eq!(count(&r, "LaneNode"), 4);
    assert_eq!(rels(&r, "CONTAINS"), 4);
    assert_eq!(rels(&r, "CONNECTS"), 3);
    assert_eq!(rels(&r, "LANE"), 3);
    assert_eq!(rels(&r, "IN_SEGMENT"), 4 + 4, "lane nodes and instances");
    assert_eq!(report.instances_linked, 4);
    assert_eq!(
        r.find_nodes("Segment", "kind", &"t_intersection".into())
            .unwrap()
            .len(),
        1
    );
    assert_eq!(
        r.find_nodes("LaneNode", "kind", &"breakpoint".into())
            .unwrap()
            .len(),
        3
    );
    // lane polylines follow the drive and carry lengths and frames
    let lane = r
        .rel(
            r.neighbours(
                r.nodes_with_label("LaneNode").unwrap()[0],
                graphstore::Direction::Both,
                r.rel_type("LANE"),
            )
            .unwrap()[0]
                .rel,
        )
        .unwrap()
        .unwrap();
    let len = lane
        .get(r.prop_key("length_m").unwrap())
        .unwrap()
        .as_f64()
        .unwrap();
    assert!((len - 200.0).abs() < 5.0, "{len}");
    // the relations that geometry supports
    let related = |a: u64, b: u64, rel: &str| {
        r.neighbours(a, graphstore::Direction::Outgoing, r.rel_type("RELATED"))
            .unwrap()
            .iter()
            .filter(|x| x.other == b)
            .any(|x| {
                r.rel(x.rel)
                    .unwrap()
                    .unwrap()
                    .get(r.prop_key("relation").unwrap())
                    == Some(&Value::from(rel))
            })
    };
    assert!(related(car_a, car_b, "next_to"));
    assert!(
        related(car_b, car_a, "in_front_of"),
        "{:?}",
        report.relations
    );
    assert!(related(car_a, car_b, "behind"));
    assert!(related(lamp, bench, "near"));
    assert!(!related(car_a, lamp, "near"));
    assert!(store.check_consistency().unwrap().is_empty());
    // a re-run replaces the hierarchy instead of duplicating it
    let before = store.counts().unwrap();
    build_hierarchy(
        &store,
        &traj,
        GroundFrame::Enu,
        "t-junction",
        &HierarchyConfig::default(),
    )
    .unwrap();
    assert_eq!(store.counts().unwrap(), before);
    assert!(store.check_consistency().unwrap().is_empty());
}

#[test]
fn real_seq00_hierarchy() {
    let Some(data) = opengraph_tests::shared_data() else {
        eprintln!("skipping: ../shared/data is absent");
        return;
    };
    let seq = data.join("kitti/sequences/00");
    let traj = ingest::sources::kitti::load_trajectory(
        &seq.join("poses.txt"),
        Some(&seq.join("calib.txt")),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("00.og")).unwrap();
    store.set_schema(opengraph_schema()).unwrap();
    let (_, _, report) = build_hierarchy(
        &store,
        &traj,
        GroundFrame::KittiCam,
        "kitti-00",
        &HierarchyConfig::default(),
    )
    .unwrap();
    eprintln!("seq 00 hierarchy: {report:?}");
    let r = store.read().unwrap();
    let segments = count(&r, "Segment");
    assert_eq!(rels(&r, "CONTAINS"), segments);
    assert!(segments >= 20);
    assert!(store.check_consistency().unwrap().is_empty());
    // every lane node sits on the drive: within half the association distance of a pose on the
    // ground plane (a visit passes that close; a junction is re-centred onto the crossing of
    // its roads, so it need not lie on the driven curve), and at the height of the sensor
    // there (KITTI y is down: the camera's height plus terrain)
    let half_association_m = HierarchyConfig::default().lanes.association_m / 2.0;
    let lane_nodes = r.nodes_with_label("LaneNode").unwrap();
    assert!(lane_nodes.len() >= 10);
    for n in lane_nodes {
        let p = r
            .node_prop(n, "position")
            .unwrap()
            .unwrap()
            .as_point3()
            .unwrap();
        let (nearest_m, pose) = traj
            .iter()
            .map(|t| (((t[0] - p[0]).powi(2) + (t[2] - p[2]).powi(2)).sqrt(), t))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap();
        assert!(
            nearest_m < half_association_m,
            "lane node {p:?} is {nearest_m} m from the trajectory"
        );
        assert!(
            (p[1] - pose[1]).abs() < 1.0,
            "lane node {p:?} is not at the height of the pose {pose:?}"
        );
    }
    // the segment of the first pose's position is found through the spatial index
    let hits = r.spatial_within("segment_space", traj[0], 1.0).unwrap();
    assert!(!hits.is_empty());
}
