//! Exports of the map model for the tools people use with scene graphs: GeoJSON of the road
//! layers and object footprints ([`geojson`]), Hydra's Spark-DSG scene-graph JSON
//! ([`spark_dsg`]), and a PLY of the point-cloud layer ([`ply`]). Each reads the map's layers
//! once through the records ([`MapLayers::load`]) and states its frame and units in the file.
//! (The generic graph exports, node-link, GraphML and Neo4j's bulk-import CSV, are
//! graphstore's.)

pub mod geojson;
pub mod ply;
pub mod spark_dsg;

use std::collections::BTreeMap;

use graphstore::{Direction, GraphRead};

use crate::GroundFrame;
use crate::error::Result;
use crate::names::{label, rel};
use crate::records::{
    EnvironmentRecord, InstanceRecord, LaneEdgeRecord, LaneNodeRecord, RelationRecord,
    SegmentRecord, ground_frame,
};

/// Every layer of a map, by node id, read through the records.
#[derive(Debug, Clone)]
pub struct MapLayers {
    /// Which world axes span the ground.
    pub ground: GroundFrame,
    /// `Environment` nodes.
    pub environments: BTreeMap<u64, EnvironmentRecord>,
    /// `Segment` nodes.
    pub segments: BTreeMap<u64, SegmentRecord>,
    /// `LaneNode` nodes.
    pub lane_nodes: BTreeMap<u64, LaneNodeRecord>,
    /// `LANE` edges: (relationship id, from, to, edge).
    pub lane_edges: Vec<(u64, u64, u64, LaneEdgeRecord)>,
    /// `Instance` nodes.
    pub instances: BTreeMap<u64, InstanceRecord>,
    /// `IN_SEGMENT` edges (instance or lane node, segment, distance_m).
    pub in_segment: Vec<(u64, u64, f64)>,
    /// `RELATED` edges (relationship id, from, to, relation).
    pub related: Vec<(u64, u64, u64, RelationRecord)>,
    /// `CONTAINS` edges (environment, segment).
    pub contains: Vec<(u64, u64)>,
    /// `CONNECTS` edges (segment, segment).
    pub connects: Vec<(u64, u64)>,
}

impl MapLayers {
    /// Reads every layer of the map.
    ///
    /// # Errors
    /// The store fails, has no ground frame, or a record lacks a required property.
    pub fn load(r: &impl GraphRead) -> Result<MapLayers> {
        let ground = ground_frame(r)?;
        let mut m = MapLayers {
            ground,
            environments: BTreeMap::new(),
            segments: BTreeMap::new(),
            lane_nodes: BTreeMap::new(),
            lane_edges: Vec::new(),
            instances: BTreeMap::new(),
            in_segment: Vec::new(),
            related: Vec::new(),
            contains: Vec::new(),
            connects: Vec::new(),
        };
        let out = |id: u64, ty: &str| -> Result<Vec<graphstore::Adjacent>> {
            Ok(match r.rel_type(ty) {
                Some(t) => r.neighbours(id, Direction::Outgoing, Some(t))?,
                None => Vec::new(),
            })
        };
        let distance = r.prop_key(crate::key::DISTANCE_M);
        let in_seg = |id: u64| -> Result<Vec<(u64, u64, f64)>> {
            let mut v = Vec::new();
            for a in out(id, rel::IN_SEGMENT)? {
                let d = match distance {
                    Some(k) => r.rel_prop(a.rel, k)?.and_then(|x| x.as_f64()),
                    None => None,
                }
                .unwrap_or(0.0);
                v.push((id, a.other, d));
            }
            Ok(v)
        };
        for id in r.nodes_with_label(label::ENVIRONMENT)? {
            if let Some(e) = EnvironmentRecord::read(r, id)? {
                m.environments.insert(id, e);
                for a in out(id, rel::CONTAINS)? {
                    m.contains.push((id, a.other));
                }
            }
        }
        for id in r.nodes_with_label(label::SEGMENT)? {
            if let Some(s) = SegmentRecord::read(r, id)? {
                m.segments.insert(id, s);
                for a in out(id, rel::CONNECTS)? {
                    m.connects.push((id, a.other));
                }
            }
        }
        for id in r.nodes_with_label(label::LANE_NODE)? {
            if let Some(n) = LaneNodeRecord::read(r, id)? {
                m.lane_nodes.insert(id, n);
                for a in out(id, rel::LANE)? {
                    m.lane_edges
                        .push((a.rel, id, a.other, LaneEdgeRecord::read(r, a.rel)?));
                }
                m.in_segment.extend(in_seg(id)?);
            }
        }
        for id in r.nodes_with_label(label::INSTANCE)? {
            if let Some(i) = InstanceRecord::read(r, id)? {
                m.instances.insert(id, i);
                for a in out(id, rel::RELATED)? {
                    m.related
                        .push((a.rel, id, a.other, RelationRecord::read(r, a.rel)?));
                }
                m.in_segment.extend(in_seg(id)?);
            }
        }
        // only edges whose ends are both in their layers
        let (segs, lanes) = (&m.segments, &m.lane_nodes);
        m.contains.retain(|(_, s)| segs.contains_key(s));
        m.connects
            .retain(|(a, b)| segs.contains_key(a) && segs.contains_key(b));
        m.lane_edges
            .retain(|(_, a, b, _)| lanes.contains_key(a) && lanes.contains_key(b));
        let insts = &m.instances;
        m.related
            .retain(|(_, a, b, _)| insts.contains_key(a) && insts.contains_key(b));
        m.in_segment.retain(|(_, s, _)| segs.contains_key(s));
        Ok(m)
    }

    /// The ground frame in words, for a file's header: which axes are the ground and up.
    pub fn frame_words(&self) -> &'static str {
        match self.ground {
            GroundFrame::KittiCam => {
                "KITTI camera world frame (x right, y down, z forward; the ground plane is x, z and up is -y), metres"
            }
            GroundFrame::Enu => {
                "east-north-up world frame (the ground plane is x, y and up is +z), metres"
            }
        }
    }
}
