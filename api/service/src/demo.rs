//! A small hand-made graph in the OpenGraph schema, for the README's main job until the
//! simulator exists. Nothing here is perception output: every value is written by hand.

use graphstore::{Store, Value};

/// Writes one environment, four segments, a lane graph, a few instances and their relations.
pub fn build(store: &Store) -> graphstore::Result<()> {
    store.set_schema(graphstore::opengraph_schema())?;
    store.write(|tx| {
        let env = tx.create_node_named(
            &["Environment"],
            &[
                ("name", "demo block".into()),
                ("source", "hand-made demo".into()),
            ],
        )?;
        // a crossing at the origin, a T-junction 80 m east, an L-bend 60 m north of it
        let lanes = [
            (0, "intersection", [0.0, 0.0, 0.0]),
            (1, "t_intersection", [80.0, 0.0, 0.0]),
            (2, "l_intersection", [80.0, 60.0, 0.0]),
            (3, "breakpoint", [-50.0, 0.0, 0.0]),
            (4, "breakpoint", [0.0, -40.0, 0.0]),
            (5, "breakpoint", [120.0, 0.0, 0.0]),
            (6, "breakpoint", [40.0, 60.0, 0.0]),
        ];
        let mut lane_ids = Vec::new();
        for (i, kind, p) in lanes {
            lane_ids.push(tx.create_node_named(
                &["LaneNode"],
                &[
                    ("lane_id", Value::Int(i)),
                    ("kind", kind.into()),
                    ("position", Value::Point3D(p)),
                ],
            )?);
        }
        for (a, b) in [(0, 1), (1, 2), (0, 3), (0, 4), (1, 5), (2, 6)] {
            let (pa, pb) = (lanes[a].2, lanes[b].2);
            let len = ((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2)).sqrt();
            tx.create_rel_named(
                lane_ids[a],
                "LANE",
                lane_ids[b],
                &[
                    ("length_m", Value::Float(len)),
                    (
                        "polyline",
                        Value::List(vec![Value::Point3D(pa), Value::Point3D(pb)]),
                    ),
                ],
            )?;
        }
        let segments = [
            (0, "intersection", [0.0, 0.0, 0.0]),
            (1, "straight_roadway", [40.0, 0.0, 0.0]),
            (2, "t_intersection", [80.0, 0.0, 0.0]),
            (3, "l_intersection", [80.0, 60.0, 0.0]),
        ];
        let mut seg_ids = Vec::new();
        for (i, kind, c) in segments {
            let s = tx.create_node_named(
                &["Segment"],
                &[
                    ("segment_id", Value::Int(i)),
                    ("kind", kind.into()),
                    ("centroid", Value::Point3D(c)),
                    (
                        "bbox",
                        Value::box3d(
                            [c[0] - 10.0, c[1] - 10.0, -1.0],
                            [c[0] + 10.0, c[1] + 10.0, 4.0],
                        ),
                    ),
                ],
            )?;
            tx.create_rel_named(env, "CONTAINS", s, &[])?;
            seg_ids.push(s);
        }
        for (a, b) in [(0, 1), (1, 2), (2, 3)] {
            tx.create_rel_named(seg_ids[a], "CONNECTS", seg_ids[b], &[])?;
        }
        let objects = [
            (
                1,
                "bench",
                "a green wooden bench beside the crossing",
                [6.0, 8.0, 0.5],
                0,
            ),
            (
                2,
                "car",
                "a silver hatchback parked at the kerb",
                [38.0, 4.0, 0.8],
                1,
            ),
            (
                3,
                "traffic-sign",
                "a red stop sign on a grey pole",
                [74.0, 6.0, 2.0],
                2,
            ),
            (
                4,
                "vegetation",
                "a row of trimmed hedges",
                [84.0, 52.0, 1.0],
                3,
            ),
            (
                5,
                "fire hydrant",
                "a short yellow fire hydrant",
                [7.5, 9.0, 0.4],
                0,
            ),
        ];
        let mut inst = Vec::new();
        for (i, class, caption, c, seg) in objects {
            let n = tx.create_node_named(
                &["Instance"],
                &[
                    ("instance_id", Value::Int(i)),
                    ("class", class.into()),
                    ("caption", caption.into()),
                    ("captions", Value::List(vec![caption.into()])),
                    ("centroid", Value::Point3D(c)),
                    (
                        "bbox",
                        Value::box3d(
                            [c[0] - 0.8, c[1] - 0.4, 0.0],
                            [c[0] + 0.8, c[1] + 0.4, 2.0 * c[2]],
                        ),
                    ),
                    ("source", "hand-made demo".into()),
                ],
            )?;
            tx.create_rel_named(n, "IN_SEGMENT", seg_ids[seg], &[])?;
            inst.push(n);
        }
        tx.create_rel_named(
            inst[4],
            "RELATED",
            inst[0],
            &[
                ("relation", "next_to".into()),
                ("distance_m", Value::Float(1.8)),
                ("source", "geometric".into()),
                ("confidence", Value::Float(1.0)),
            ],
        )?;
        Ok(())
    })?;
    Ok(())
}
