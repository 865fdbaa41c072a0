//! `plan` over a map whose segments have drivable polygons measured from the map: the path is
//! kept on them when they cover the road, and planned in the corridor alone (with a
//! warning) when they have a gap across it.

use graphstore::{Store, Value};
use opengraph_service::plan::{PlanOptions, plan};

/// A straight 100 m road along x in an ENU map, its lane graph, and one road segment whose
/// polygon covers y in -2..4 along the road, or, with `gap`, leaves x in 49..51 out.
fn road_map(dir: &std::path::Path, gap: bool) -> Store {
    let store = Store::create(dir.join(if gap { "gap.og" } else { "whole.og" })).unwrap();
    store.set_schema(scene::opengraph_schema()).unwrap();
    store
        .write(|tx| {
            let env = tx.create_node_named(
                &["Environment"],
                &[("name", "road".into()), ("ground_frame", "enu".into())],
            )?;
            let a = tx.create_node_named(
                &["LaneNode"],
                &[
                    ("lane_id", Value::Int(0)),
                    ("kind", "breakpoint".into()),
                    ("position", Value::Point3D([0.0, 0.0, 0.0])),
                ],
            )?;
            let b = tx.create_node_named(
                &["LaneNode"],
                &[
                    ("lane_id", Value::Int(1)),
                    ("kind", "breakpoint".into()),
                    ("position", Value::Point3D([100.0, 0.0, 0.0])),
                ],
            )?;
            tx.create_rel_named(
                a,
                "LANE",
                b,
                &[
                    ("length_m", Value::Float(100.0)),
                    (
                        "polyline",
                        Value::List(vec![
                            Value::Point3D([0.0, 0.0, 0.0]),
                            Value::Point3D([100.0, 0.0, 0.0]),
                        ]),
                    ),
                ],
            )?;
            let ring = |x0: f64, x1: f64| {
                Value::List(
                    [[x0, -2.0], [x1, -2.0], [x1, 4.0], [x0, 4.0]]
                        .iter()
                        .map(|p| Value::Point3D([p[0], p[1], 0.0]))
                        .collect(),
                )
            };
            let rings = if gap {
                vec![ring(-10.0, 49.0), ring(51.0, 110.0)]
            } else {
                vec![ring(-10.0, 110.0)]
            };
            let s = tx.create_node_named(
                &["Segment"],
                &[
                    ("segment_id", Value::Int(0)),
                    ("kind", "straight_roadway".into()),
                    ("centroid", Value::Point3D([50.0, 0.0, 0.0])),
                    ("polygon", Value::List(rings)),
                ],
            )?;
            tx.create_rel_named(env, "CONTAINS", s, &[])?;
            Ok(())
        })
        .unwrap();
    store
}

#[test]
fn the_path_keeps_to_the_drivable_areas_or_says_why_not() {
    let dir = tempfile::tempdir().unwrap();
    let opts = PlanOptions {
        turning_radius_m: 5.0,
        budget_ms: 2000.0,
        corridor_m: 6.0,
        snap_m: 10.0,
        png: None,
    };
    let (from, to) = (
        planner::Spec::Point([5.0, 0.0]),
        planner::Spec::Point([95.0, 0.0]),
    );
    let whole = road_map(dir.path(), false);
    let p = plan(&whole.read().unwrap(), &from, &to, &opts).unwrap();
    assert!(!p.path.fallback, "{:?}", p.path.warning);
    assert_eq!(p.drivable_segments, 1);
    for q in &p.path.poses {
        assert!(q[1] >= -2.5 && q[1] <= 4.5, "off the drivable area: {q:?}");
    }
    // a 2 m gap right across the road: OMPL cannot stay on the areas, so the corridor
    // alone bounds the path and the answer says so
    let gap = road_map(dir.path(), true);
    let p = plan(&gap.read().unwrap(), &from, &to, &opts).unwrap();
    assert!(!p.path.fallback, "{:?}", p.path.warning);
    assert_eq!(p.drivable_segments, 0);
    assert!(
        p.path.warning.as_deref().unwrap_or("").contains("gaps"),
        "{:?}",
        p.path.warning
    );
}
