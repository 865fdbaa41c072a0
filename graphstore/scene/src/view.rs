//! The map as retrieval, localisation and the tools read it: every instance with its box,
//! feature and segment, and every road segment with its areas, loaded once per commit
//! ([`MapView::load`]) and shared by the requests until the next.

use std::collections::{BTreeMap, BTreeSet};

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

/// Every `Segment` node with a `kind`, by node id.
fn segment_kinds(r: &impl GraphRead) -> Result<BTreeMap<u64, String>> {
    let mut seg_kind = BTreeMap::new();
    for s in r.nodes_with_label(label::SEGMENT)? {
        if let Some(Value::String(k)) = r.node_prop(s, crate::key::KIND)? {
            seg_kind.insert(s, k);
        }
    }
    Ok(seg_kind)
}

/// Instance `id` as retrieval sees it; `None` when it is not an instance or has no feature.
fn scene_object(
    r: &impl GraphRead,
    id: u64,
    ground: GroundFrame,
    seg_kind: &BTreeMap<u64, String>,
) -> Result<Option<SceneObject>> {
    let Some(inst) = InstanceRecord::read_for_view(r, id)? else {
        return Ok(None);
    };
    let Some(feature) = inst.feature else {
        return Ok(None);
    };
    let (lo, hi) = inst.bbox;
    let (g0, g1) = (ground.ground(lo), ground.ground(hi));
    let (h0, h1) = (ground.height(lo), ground.height(hi));
    let segment = match r.rel_type(rel::IN_SEGMENT) {
        Some(t) => r
            .neighbours(id, Direction::Outgoing, Some(t))?
            .first()
            .and_then(|a| seg_kind.get(&a.other).map(|k| (a.other, k.clone()))),
        None => None,
    };
    Ok(Some(SceneObject {
        id,
        surface: SURFACE_CLASSES.contains(&inst.semantic_class.as_str()) || inst.tile.is_some(),
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
    }))
}

/// The instance layer of a map, loaded once for many requests.
#[derive(Debug, Clone, PartialEq)]
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
        let seg_kind = segment_kinds(r)?;
        let mut objects = Vec::new();
        for id in r.nodes_with_label(label::INSTANCE)? {
            objects.extend(scene_object(r, id, ground, &seg_kind)?);
        }
        let segments = load_segments(r, ground)?;
        Ok(MapView {
            ground,
            objects,
            segments,
        })
    }

    /// This view brought up to the commit `r` sees, given the nodes `changed` since the
    /// commit it was loaded at (ascending; [`GraphRead::nodes_changed_since`]): the objects of
    /// the changed nodes are read again and the rest kept. Equal to [`MapView::load`] of
    /// `r`; it loads afresh when a road segment or the ground frame changed (every object's
    /// segment may then differ). For a server taking writes: a small edit costs a few
    /// records, not the whole map.
    ///
    /// # Errors
    /// As [`MapView::load`].
    pub fn refresh(&self, r: &impl GraphRead, changed: &[u64]) -> Result<MapView> {
        if changed.is_empty() {
            return Ok(self.clone());
        }
        let ground = crate::records::ground_frame(r)?;
        if ground != self.ground {
            return MapView::load(r);
        }
        let seg_kind = segment_kinds(r)?;
        // a segment is listed when an instance joins or leaves it, too: read the segments
        // again, and load afresh only when one of them or a kind objects name differs
        let mut segment_ids: BTreeSet<u64> =
            r.nodes_with_label(label::SEGMENT)?.into_iter().collect();
        segment_ids.extend(self.segments.iter().map(|s| s.id));
        segment_ids.extend(
            self.objects
                .iter()
                .filter_map(|o| o.segment.as_ref().map(|s| s.0)),
        );
        let touched: Vec<&u64> = changed
            .iter()
            .filter(|id| segment_ids.contains(id))
            .collect();
        let segments = if !touched.is_empty() {
            // one the view did not hold (new, or unreadable before) may give objects a segment
            if touched
                .iter()
                .any(|id| !self.segments.iter().any(|s| s.id == **id))
            {
                return MapView::load(r);
            }
            let now = load_segments(r, ground)?;
            let kinds_hold = self.objects.iter().all(|o| {
                o.segment
                    .as_ref()
                    .is_none_or(|(s, k)| seg_kind.get(s) == Some(k))
            });
            if now != self.segments || !kinds_hold {
                return MapView::load(r);
            }
            now
        } else {
            self.segments.clone()
        };
        // every kept object keeps its segment; a changed node's record is read again
        let mut objects = Vec::with_capacity(self.objects.len() + changed.len());
        let mut kept = self.objects.iter().peekable();
        for id in changed {
            while let Some(o) = kept.next_if(|o| o.id < *id) {
                objects.push(o.clone());
            }
            kept.next_if(|o| o.id == *id);
            // none for a node that is gone or of another layer
            objects.extend(scene_object(r, *id, ground, &seg_kind)?);
        }
        objects.extend(kept.cloned());
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::records::tests::{instance, segment};
    use crate::records::{EnvironmentRecord, InSegmentRecord, SegmentRecord};
    use graphstore::{PropKey, Store, WriteTxn};
    use proptest::prelude::*;

    /// An edit of a map of `n` instances (`i`) and `m` segments (`s`), by index.
    #[derive(Debug, Clone)]
    enum Edit {
        DeleteInstance(usize),
        AddInstance(Box<InstanceRecord>, Option<usize>),
        Caption(usize, String),
        DropFeature(usize),
        MoveToSegment(usize, usize),
        SegmentKind(usize, String),
        AddSegment(Box<SegmentRecord>),
        /// A node of another layer, linked to an instance (changes nothing the view shows).
        Unrelated(usize),
    }

    fn edit() -> impl Strategy<Value = Edit> {
        let i = 0..64usize;
        prop_oneof![
            i.clone().prop_map(Edit::DeleteInstance),
            (instance(), prop::option::of(0..8usize))
                .prop_map(|(r, s)| Edit::AddInstance(Box::new(r), s)),
            (i.clone(), "[a-z ]{1,20}").prop_map(|(i, c)| Edit::Caption(i, c)),
            i.clone().prop_map(Edit::DropFeature),
            (i.clone(), 0..8usize).prop_map(|(i, s)| Edit::MoveToSegment(i, s)),
            (0..8usize, "[a-z]{1,8}").prop_map(|(s, k)| Edit::SegmentKind(s, k)),
            segment().prop_map(|s| Edit::AddSegment(Box::new(s))),
            i.prop_map(Edit::Unrelated),
        ]
    }

    fn key(tx: &mut WriteTxn<'_>, k: &str) -> PropKey {
        tx.prop_key_id(k).unwrap()
    }

    fn apply(tx: &mut WriteTxn<'_>, e: &Edit) -> graphstore::Result<()> {
        let inst = tx.nodes_with_label(label::INSTANCE)?;
        let segs = tx.nodes_with_label(label::SEGMENT)?;
        let pick = |v: &[u64], i: usize| (!v.is_empty()).then(|| v[i % v.len()]);
        match e {
            Edit::DeleteInstance(i) => {
                if let Some(id) = pick(&inst, *i) {
                    tx.detach_delete_node(id)?;
                }
            }
            Edit::AddInstance(r, s) => {
                let id = r.create(tx)?;
                if let Some(s) = s.and_then(|s| pick(&segs, s)) {
                    InSegmentRecord { distance_m: 0.0 }.create(tx, id, s)?;
                }
            }
            Edit::Caption(i, c) => {
                if let Some(id) = pick(&inst, *i) {
                    let k = key(tx, crate::key::CAPTION);
                    tx.set_node_prop(id, k, Value::String(c.clone()))?;
                }
            }
            Edit::DropFeature(i) => {
                if let Some(id) = pick(&inst, *i) {
                    let k = key(tx, crate::key::FEATURE);
                    tx.set_node_prop(id, k, Value::Null)?;
                }
            }
            Edit::MoveToSegment(i, s) => {
                if let (Some(id), Some(s)) = (pick(&inst, *i), pick(&segs, *s)) {
                    let t = tx.rel_type_id(rel::IN_SEGMENT)?;
                    for a in tx.neighbours(id, Direction::Outgoing, Some(t))? {
                        tx.delete_rel(a.rel)?;
                    }
                    InSegmentRecord { distance_m: 2.0 }.create(tx, id, s)?;
                }
            }
            Edit::SegmentKind(s, k) => {
                if let Some(id) = pick(&segs, *s) {
                    let key = key(tx, crate::key::KIND);
                    tx.set_node_prop(id, key, Value::String(k.clone()))?;
                }
            }
            Edit::AddSegment(s) => {
                s.create(tx)?;
            }
            Edit::Unrelated(i) => {
                if let Some(id) = pick(&inst, *i) {
                    let l = tx.label_id("Note")?;
                    let n = tx.create_node(&[l], Vec::new())?;
                    let t = tx.rel_type_id("ABOUT")?;
                    tx.create_rel(n, t, id, Vec::new())?;
                }
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// A view brought up to date from the changed nodes equals one loaded afresh, after
        /// any edits in any number of commits.
        #[test]
        fn a_refreshed_view_equals_a_fresh_load(
            segs in prop::collection::vec(segment(), 1..4),
            insts in prop::collection::vec((instance(), prop::option::of(0..4usize)), 1..8),
            commits in prop::collection::vec(prop::collection::vec(edit(), 1..4), 1..4),
        ) {
            let dir = tempfile::tempdir().unwrap();
            let store = Store::create(dir.path().join("m.og")).unwrap();
            store.set_schema(crate::opengraph_schema()).unwrap();
            store.write(|tx| {
                EnvironmentRecord { name: "city".into(), source: None, ground_frame: Some(GroundFrame::KittiCam) }.create(tx)?;
                let s: Vec<u64> = segs.iter().map(|s| s.create(tx)).collect::<graphstore::Result<_>>()?;
                for (n, (r, k)) in insts.iter().enumerate() {
                    // distinct instance ids (the schema keeps them unique)
                    let r = InstanceRecord { instance_id: n as i64, ..r.clone() };
                    let id = r.create(tx)?;
                    if let Some(k) = k {
                        InSegmentRecord { distance_m: 0.0 }.create(tx, id, s[k % s.len()])?;
                    }
                }
                Ok(())
            }).unwrap();
            let r0 = store.read().unwrap();
            let seq0 = r0.commit_seq().unwrap();
            let view0 = MapView::load(&r0).unwrap();
            let mut view = view0.clone();
            let mut seq = seq0;
            for edits in &commits {
                if store.write(|tx| edits.iter().try_for_each(|e| apply(tx, e))).is_err() {
                    // refused by the schema (say an instance id taken): nothing changed
                    prop_assert_eq!(store.read().unwrap().nodes_changed_since(seq), Some(Vec::new()));
                    continue;
                }
                let r = store.read().unwrap();
                let fresh = MapView::load(&r).unwrap();
                // from the last commit, and from the first
                let changed = r.nodes_changed_since(seq).unwrap();
                view = view.refresh(&r, &changed).unwrap();
                prop_assert_eq!(&view, &fresh);
                let all = r.nodes_changed_since(seq0).unwrap();
                prop_assert_eq!(&view0.refresh(&r, &all).unwrap(), &fresh);
                seq = r.commit_seq().unwrap();
            }
        }
    }
}
