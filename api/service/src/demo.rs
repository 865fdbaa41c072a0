//! A small hand-made graph in the OpenGraph schema, for the README's main job until the
//! simulator exists. Nothing here is perception output: every value is written by hand.

use graphstore::Store;
use scene::records::{
    EnvironmentRecord, InSegmentRecord, InstanceRecord, LaneEdgeRecord, LaneNodeRecord,
    RelationRecord, SegmentRecord,
};

/// The `source` of everything the demo writes.
const DEMO: &str = "hand-made demo";

/// Writes one environment, four segments, a lane graph, a few instances and their relations.
pub fn build(store: &Store) -> graphstore::Result<()> {
    store.set_schema(scene::opengraph_schema())?;
    store.write(|tx| {
        let env = EnvironmentRecord {
            name: "demo block".into(),
            source: Some(DEMO.into()),
            ground_frame: None,
        }
        .create(tx)?;
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
            lane_ids.push(
                LaneNodeRecord {
                    lane_id: i,
                    kind: kind.into(),
                    position: p,
                }
                .create(tx)?,
            );
        }
        for (a, b) in [(0, 1), (1, 2), (0, 3), (0, 4), (1, 5), (2, 6)] {
            let (pa, pb) = (lanes[a].2, lanes[b].2);
            let len = ((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2)).sqrt();
            LaneEdgeRecord {
                length_m: len,
                polyline: vec![pa, pb],
                frames: Vec::new(),
                directed: false,
            }
            .create(tx, lane_ids[a], lane_ids[b])?;
        }
        let segments = [
            (0, "intersection", [0.0, 0.0, 0.0]),
            (1, "straight_roadway", [40.0, 0.0, 0.0]),
            (2, "t_intersection", [80.0, 0.0, 0.0]),
            (3, "l_intersection", [80.0, 60.0, 0.0]),
        ];
        let mut seg_ids = Vec::new();
        for (i, kind, c) in segments {
            let s = SegmentRecord {
                segment_id: i,
                kind: kind.into(),
                centroid: c,
                shape: None,
                bbox: Some((
                    [c[0] - 10.0, c[1] - 10.0, -1.0],
                    [c[0] + 10.0, c[1] + 10.0, 4.0],
                )),
                polygon: Vec::new(),
                drivable_area_m2: None,
            }
            .create(tx)?;
            tx.create_rel_named(env, scene::rel::CONTAINS, s, &[])?;
            seg_ids.push(s);
        }
        for (a, b) in [(0, 1), (1, 2), (2, 3)] {
            tx.create_rel_named(seg_ids[a], scene::rel::CONNECTS, seg_ids[b], &[])?;
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
            let (label, colour, material) = llm_tools::labels::of_caption(caption);
            let n = InstanceRecord {
                instance_id: i,
                caption: caption.into(),
                semantic_class: class.into(),
                label: Some(label),
                colour,
                material,
                centroid: c,
                bbox: (
                    [c[0] - 0.8, c[1] - 0.4, 0.0],
                    [c[0] + 0.8, c[1] + 0.4, 2.0 * c[2]],
                ),
                captions: Some(vec![caption.into()]),
                feature: None,
                point_count: None,
                detection_count: None,
                first_frame: None,
                last_frame: None,
                source: Some(DEMO.into()),
                detection_feature: None,
                obb: None,
                tile: None,
            }
            .create(tx)?;
            InSegmentRecord { distance_m: 0.0 }.create(tx, n, seg_ids[seg])?;
            inst.push(n);
        }
        RelationRecord {
            relation: "next_to".into(),
            distance_m: 1.8,
            source: scene::records::GEOMETRIC.into(),
            confidence: 1.0,
        }
        .create(tx, inst[4], inst[0])?;
        Ok(())
    })?;
    Ok(())
}
