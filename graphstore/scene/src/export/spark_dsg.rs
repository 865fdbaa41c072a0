//! The map as a Spark-DSG `DynamicSceneGraph` (Hydra's scene-graph format) in its JSON file
//! form, version 1.1.3, which `spark_dsg.DynamicSceneGraph.load("map.json")` reads.
//!
//! | layer | id | nodes | attributes |
//! |---|---|---|---|
//! | `OBJECTS` | 2 | instances, `O(node id)` | `ObjectNodeAttributes`: `name` the label (the SemanticKITTI class when it has none), `metadata.semantic_class`, `semantic_label` its SemanticKITTI learning id (1..=19), `color` its colour, `bounding_box` the oriented box (`OBB`; `AABB` when it has none), `metadata.caption` |
//! | `PLACES` (`LANES`) | 3 | lane-graph nodes, `P(node id)` | `PlaceNodeAttributes`: `name` the kind, `metadata.lane_id` |
//! | `ROOMS` (`ROAD_SEGMENTS`) | 4 | road segments, `R(node id)` | `RoomNodeAttributes`: `name` the kind, `metadata.segment_id` |
//! | `BUILDINGS` (`ENVIRONMENT`) | 5 | the environment root, `B(node id)` | `SemanticNodeAttributes`: `name` |
//!
//! Edges: `LANE` (places, weighted by length), `CONNECTS` (rooms), `RELATED` (objects, the
//! relation in `metadata`), `IN_SEGMENT` (object or place to room) and `CONTAINS` (building
//! to room). A pair of nodes gets one edge however many relationships join them (Spark-DSG
//! refuses a second). Node ids are Spark-DSG `NodeSymbol`s: the character in the top 8 bits,
//! the store's node id below, so `O(1052)` is instance node 1052.
//!
//! Positions are metres in a **z-up** frame made from the map's world frame: for
//! `kitti_cam`, `(x, z, -y)` (KITTI's ground x, z become x, y; up is z); for `enu`, the world
//! frame itself. The file's `metadata.opengraph` says which.
//!
//! The format was read from Spark-DSG 1.1.3's JSON serialisation and checked by loading the
//! files with the `spark_dsg` package (`api/tests/python/test_exports.py`).

use std::collections::BTreeSet;

use serde_json::{Value as Json, json};

use super::MapLayers;
use crate::GroundFrame;
use crate::classes::{class_colour, class_id};

/// Spark-DSG's layer ids for the four layers written.
pub const OBJECTS: i64 = 2;
/// See [`OBJECTS`].
pub const PLACES: i64 = 3;
/// See [`OBJECTS`].
pub const ROOMS: i64 = 4;
/// See [`OBJECTS`].
pub const BUILDINGS: i64 = 5;

/// A Spark-DSG `NodeSymbol`: `c` in the top 8 bits, `index` in the low 56.
///
/// # Panics
/// Never: an index of 2^56 or more is refused by [`write`] before.
pub fn node_symbol(c: char, index: u64) -> u64 {
    ((c as u64 & 0xff) << 56) | (index & 0x00ff_ffff_ffff_ffff)
}

/// A world point in the z-up frame of the export.
fn zup(g: GroundFrame, p: [f64; 3]) -> [f64; 3] {
    let q = g.ground(p);
    [q[0], q[1], g.height(p)]
}

fn quat_z(yaw_rad: f64) -> Json {
    json!({"w": (yaw_rad / 2.0).cos(), "x": 0.0, "y": 0.0, "z": (yaw_rad / 2.0).sin()})
}

/// The map as Spark-DSG JSON.
///
/// # Errors
/// [`crate::Error::Invalid`] when a node id does not fit a `NodeSymbol`'s 56-bit index.
pub fn to_json(m: &MapLayers) -> crate::Result<Json> {
    let g = m.ground;
    let all_ids = m
        .instances
        .keys()
        .chain(m.lane_nodes.keys())
        .chain(m.segments.keys())
        .chain(m.environments.keys());
    if let Some(id) = all_ids.into_iter().find(|id| **id >= 1 << 56) {
        return Err(crate::Error::Invalid(format!(
            "node id {id} does not fit a Spark-DSG node symbol (56 bits)"
        )));
    }
    let mut nodes = Vec::new();
    for (id, i) in &m.instances {
        let (r, gr, b) = class_colour(&i.semantic_class);
        let bbox = match i.obb {
            Some(o) => {
                let c = o.center;
                json!({"type": "OBB",
                       "dimensions": [2.0 * o.half_extents[0], 2.0 * o.half_extents[1],
                                      o.height_m[1] - o.height_m[0]],
                       "world_P_center": [c[0], c[1], (o.height_m[0] + o.height_m[1]) / 2.0],
                       "world_R_center": quat_z(o.yaw_rad)})
            }
            None => {
                let (a, b) = (zup(g, i.bbox.0), zup(g, i.bbox.1));
                json!({"type": "AABB",
                       "dimensions": [(b[0] - a[0]).abs(), (b[1] - a[1]).abs(), (b[2] - a[2]).abs()],
                       "world_P_center": [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, (a[2] + b[2]) / 2.0],
                       "world_R_center": quat_z(0.0)})
            }
        };
        let mut attrs = json!({
            "type": "ObjectNodeAttributes",
            "position": zup(g, i.centroid),
            "name": i.label.as_deref().unwrap_or(&i.semantic_class),
            "color": {"r": r, "g": gr, "b": b, "a": 255},
            "bounding_box": bbox,
            "metadata": {"caption": i.caption, "semantic_class": i.semantic_class, "instance_id": i.instance_id, "node_id": id},
        });
        if let Some(l) = class_id(&i.semantic_class) {
            attrs["semantic_label"] = json!(l);
        }
        nodes.push(
            json!({"id": node_symbol('O', *id), "layer": OBJECTS, "partition": 0,
                          "attributes": attrs}),
        );
    }
    for (id, n) in &m.lane_nodes {
        nodes.push(
            json!({"id": node_symbol('P', *id), "layer": PLACES, "partition": 0,
            "attributes": {"type": "PlaceNodeAttributes", "position": zup(g, n.position),
                           "name": n.kind,
                           "metadata": {"lane_id": n.lane_id, "node_id": id}}}),
        );
    }
    for (id, s) in &m.segments {
        nodes.push(
            json!({"id": node_symbol('R', *id), "layer": ROOMS, "partition": 0,
            "attributes": {"type": "RoomNodeAttributes", "position": zup(g, s.centroid),
                           "name": s.kind,
                           "metadata": {"segment_id": s.segment_id, "node_id": id}}}),
        );
    }
    for (id, e) in &m.environments {
        nodes.push(
            json!({"id": node_symbol('B', *id), "layer": BUILDINGS, "partition": 0,
            "attributes": {"type": "SemanticNodeAttributes", "position": [0.0, 0.0, 0.0],
                           "name": e.name, "metadata": {"node_id": id}}}),
        );
    }
    let mut seen: BTreeSet<(u64, u64)> = BTreeSet::new();
    let mut edges = Vec::new();
    let mut edge = |a: u64, b: u64, info: Json| {
        let key = (a.min(b), a.max(b));
        if a != b && seen.insert(key) {
            edges.push(json!({"source": a, "target": b, "info": info}));
        }
    };
    let plain = |kind: &str| json!({"type": "EdgeAttributes", "metadata": {"opengraph": kind}});
    for (_, a, b, e) in &m.lane_edges {
        let mut info = plain("LANE");
        if e.length_m.is_finite() {
            info["weighted"] = json!(true);
            info["weight"] = json!(e.length_m);
        }
        edge(node_symbol('P', *a), node_symbol('P', *b), info);
    }
    for (a, b) in &m.connects {
        edge(
            node_symbol('R', *a),
            node_symbol('R', *b),
            plain("CONNECTS"),
        );
    }
    for (_, a, b, rel) in &m.related {
        let mut info = plain("RELATED");
        info["metadata"]["relation"] = json!(rel.relation);
        edge(node_symbol('O', *a), node_symbol('O', *b), info);
    }
    for (child, seg, _) in &m.in_segment {
        let c = if m.instances.contains_key(child) {
            'O'
        } else {
            'P'
        };
        edge(
            node_symbol('R', *seg),
            node_symbol(c, *child),
            plain("IN_SEGMENT"),
        );
    }
    for (env, seg) in &m.contains {
        edge(
            node_symbol('B', *env),
            node_symbol('R', *seg),
            plain("CONTAINS"),
        );
    }
    let key = |l: i64| json!({"layer": l, "partition": 0});
    Ok(json!({
        "SPARK_DSG_header": {"project_name": "main", "version": {"major": 1, "minor": 1, "patch": 3}},
        "directed": false,
        "multigraph": false,
        "layer_keys": [key(OBJECTS), key(PLACES), key(ROOMS), key(BUILDINGS)],
        "layer_names": {"OBJECTS": key(OBJECTS), "PLACES": key(PLACES), "LANES": key(PLACES),
                        "ROOMS": key(ROOMS), "ROAD_SEGMENTS": key(ROOMS),
                        "BUILDINGS": key(BUILDINGS), "ENVIRONMENT": key(BUILDINGS)},
        "metadata": {"opengraph": {
            "frame": match g {
                GroundFrame::KittiCam => "z-up frame (x, z, -y) of the KITTI camera world frame, metres",
                GroundFrame::Enu => "the map's east-north-up world frame, metres",
            },
            "world_frame": m.frame_words(),
            "layers": {"2": "instances", "3": "lane-graph nodes", "4": "road segments", "5": "environment"}
        }},
        "nodes": nodes,
        "edges": edges,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_symbols_match_spark_dsg() {
        // spark_dsg.NodeSymbol('O', 0).value and ('S', 5), checked with spark-dsg 1.1.3
        assert_eq!(node_symbol('O', 0), 5_692_549_928_996_306_944);
        assert_eq!(node_symbol('S', 5), 5_980_780_305_148_018_693);
        assert_eq!(node_symbol('B', 0), 4_755_801_206_503_243_776);
    }

    #[test]
    fn kitti_up_becomes_z() {
        let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
        assert!(close(
            zup(GroundFrame::KittiCam, [1.0, -2.0, 3.0]),
            [1.0, 3.0, 2.0]
        ));
        assert!(close(
            zup(GroundFrame::Enu, [1.0, 2.0, 3.0]),
            [1.0, 2.0, 3.0]
        ));
    }
}
