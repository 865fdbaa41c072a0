//! The map as retrieval, localisation and the tools read it: every instance with its box,
//! feature and segment, and every road segment with its areas, loaded once per commit
//! ([`MapView::load`]) and shared by the requests until the next.

use std::collections::BTreeMap;

use graphstore::{Direction, GraphRead, Value};

use crate::GroundFrame;
use crate::area::SegmentArea;
use crate::classes::SURFACE_CLASSES;
use crate::error::Result;
use crate::names::{label, rel};
use crate::records::InstanceRecord;

/// Running sums of [`feature_dot`]: eight, so the loop vectorises.
const DOT_LANES: usize = 8;

/// Dot product of two features, summed in f64 over eight running sums (then the remainder
/// in order), 0 when the lengths differ. Every cosine of features is built from it
/// (`llm_tools::embed::cosine`), so a squared norm kept with a feature
/// ([`SceneObject::feature_sq_norm`]) is bit-identical to one summed at query time.
pub fn feature_dot(a: &[f32], b: &[f32]) -> f64 {
    if a.len() != b.len() {
        return 0.0;
    }
    let mut lanes = [0f64; DOT_LANES];
    let (ca, cb) = (a.chunks_exact(DOT_LANES), b.chunks_exact(DOT_LANES));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for i in 0..DOT_LANES {
            lanes[i] += f64::from(x[i]) * f64::from(y[i]);
        }
    }
    let mut sum = lanes.iter().sum::<f64>();
    for (x, y) in ra.iter().zip(rb) {
        sum += f64::from(*x) * f64::from(*y);
    }
    sum
}

/// One instance as retrieval sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneObject {
    /// Node id.
    pub id: u64,
    /// Its SemanticKITTI class (`Instance.semantic_class`).
    pub semantic_class: String,
    /// Open-vocabulary label (`Instance.label`; empty on maps built without labels).
    pub label: String,
    /// Caption.
    pub caption: String,
    /// Centroid, world frame, metres.
    pub centroid: [f64; 3],
    /// Ground-plane bounds (min, max) of the box, metres.
    pub ground_min: [f64; 2],
    /// See `ground_min`.
    pub ground_max: [f64; 2],
    /// Height range (bottom, top) along the frame's up axis, metres.
    pub heights: (f64, f64),
    /// Fused feature.
    pub feature: Vec<f32>,
    /// `feature_dot(&feature, &feature)` ([`feature_dot`]): the squared norm that a cosine
    /// against this feature divides by, summed once per map load instead of once per query.
    pub feature_sq_norm: f64,
    /// A ground-surface tile or class.
    pub surface: bool,
    /// Its segment (node id, kind), from `IN_SEGMENT`.
    pub segment: Option<(u64, String)>,
}

/// A road segment of the map.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentInfo {
    /// Node id.
    pub id: u64,
    /// `Segment.kind`.
    pub kind: String,
    /// Ground-plane centroid.
    pub centroid: [f64; 2],
    /// Its area from the trajectory.
    pub area: SegmentArea,
    /// Its drivable area measured from the map (`Segment.polygon`), when it has one.
    pub drivable: Option<crate::area::Drivable>,
}

impl SegmentInfo {
    /// Distance from `p` to the segment for membership
    /// ([`crate::area::membership_distance`]): its drivable polygon when it has one.
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        crate::area::membership_distance(&self.area, self.drivable.as_ref(), p)
    }
}

/// Reads the map's segments with their areas.
///
/// # Errors
/// The store fails or has no ground frame.
pub fn load_segments(r: &impl GraphRead, g: GroundFrame) -> Result<Vec<SegmentInfo>> {
    let mut out = Vec::new();
    for id in r.nodes_with_label(label::SEGMENT)? {
        let Some(rec) = crate::records::SegmentRecord::read(r, id)? else {
            continue;
        };
        out.push(SegmentInfo {
            id,
            centroid: g.ground(rec.centroid),
            area: rec.area(g),
            drivable: rec.drivable(g),
            kind: rec.kind,
        });
    }
    Ok(out)
}

/// The instance layer of a map, loaded once for many requests.
#[derive(Debug, Clone)]
pub struct MapView {
    /// The ground frame.
    pub ground: GroundFrame,
    /// Instances, ascending id.
    pub objects: Vec<SceneObject>,
    /// Road segments with their areas.
    pub segments: Vec<SegmentInfo>,
}

impl MapView {
    /// Reads every `Instance` with its box, feature and segment.
    ///
    /// # Errors
    /// The store fails, or it has no ground frame ([`Error::NoGroundFrame`](crate::Error::NoGroundFrame)).
    pub fn load(r: &impl GraphRead) -> Result<MapView> {
        let ground = crate::records::ground_frame(r)?;
        let in_segment = r.rel_type(rel::IN_SEGMENT);
        let mut seg_kind: BTreeMap<u64, String> = BTreeMap::new();
        for s in r.nodes_with_label(label::SEGMENT)? {
            if let Some(Value::String(k)) = r.node_prop(s, crate::key::KIND)? {
                seg_kind.insert(s, k);
            }
        }
        let mut objects = Vec::new();
        for id in r.nodes_with_label(label::INSTANCE)? {
            let Some(inst) = InstanceRecord::read_for_view(r, id)? else {
                continue;
            };
            let Some(feature) = inst.feature else {
                continue;
            };
            let (lo, hi) = inst.bbox;
            let (g0, g1) = (ground.ground(lo), ground.ground(hi));
            let (h0, h1) = (ground.height(lo), ground.height(hi));
            let segment = match in_segment {
                Some(t) => r
                    .neighbours(id, Direction::Outgoing, Some(t))?
                    .first()
                    .and_then(|a| seg_kind.get(&a.other).map(|k| (a.other, k.clone()))),
                None => None,
            };
            objects.push(SceneObject {
                id,
                surface: SURFACE_CLASSES.contains(&inst.semantic_class.as_str())
                    || inst.tile.is_some(),
                semantic_class: inst.semantic_class,
                label: inst.label.unwrap_or_default(),
                caption: inst.caption,
                centroid: inst.centroid,
                ground_min: [g0[0].min(g1[0]), g0[1].min(g1[1])],
                ground_max: [g0[0].max(g1[0]), g0[1].max(g1[1])],
                heights: (h0.min(h1), h0.max(h1)),
                feature_sq_norm: feature_dot(&feature, &feature),
                feature,
                segment,
            });
        }
        let segments = load_segments(r, ground)?;
        Ok(MapView {
            ground,
            objects,
            segments,
        })
    }

    /// Ground-plane gap between two boxes (0 when their footprints overlap), metres.
    pub fn gap_m(a: &SceneObject, b: &SceneObject) -> f64 {
        let dx = (a.ground_min[0] - b.ground_max[0])
            .max(b.ground_min[0] - a.ground_max[0])
            .max(0.0);
        let dz = (a.ground_min[1] - b.ground_max[1])
            .max(b.ground_min[1] - a.ground_max[1])
            .max(0.0);
        dx.hypot(dz)
    }
}
