//! Map edits: remove, move, change or add an instance as one transaction that keeps the
//! hierarchy whole (its points, `IN_SEGMENT`, geometric `RELATED` edges and every index), record
//! each applied edit as a `MapEdit` node, and undo an edit exactly (same node and relationship
//! ids, same properties and points). The paper's interactive map update (OpenGraph, Sec. V-D).
//!
//! A `MapEdit` node holds `text` (what the person said), `kind`, `time_unix_s`, `parsed_by`,
//! `summary` (JSON: what changed, for people), `touched` (the node ids it changed or linked),
//! `undone`; its `diff` payload holds the exact before-state in the store's binary value encoding
//! ([`Value::to_bytes`]): deleted nodes and relationships, the properties and points of changed
//! nodes, and the ids of what it created.
//!
//! After an edit, relations of the edited instance are re-derived with the hierarchy's own
//! geometry ([`crate::hierarchy::relations::label_pair`], default [`RelationConfig`]) against every
//! instance within `near_m`, and its segment is the nearest segment area, as a build does.

use std::collections::BTreeMap;

use graphstore::{Direction, GraphRead, PointCloud, Store, Value, WriteTxn};

use crate::hierarchy::relations::{RelationConfig, label_pair, read_instance_box};
use crate::{Error, Result};
use scene::GroundFrame;

use scene::key;
use scene::label::MAP_EDIT;
use scene::records::{EditRecord, GEOMETRIC, InSegmentRecord, InstanceRecord, RelationRecord};

/// One change to apply. Positions are on the ground plane of the map's frame (metres).
#[derive(Debug, Clone, PartialEq)]
pub enum Change {
    /// Delete the instance, its points and relationships.
    Remove {
        /// Instance node id.
        id: u64,
    },
    /// Move the instance (box, centroid, points) so its ground centre is `to_ground`.
    Move {
        /// Instance node id.
        id: u64,
        /// The new ground centre.
        to_ground: [f64; 2],
    },
    /// Give the instance a new caption (and feature; a new class when given).
    Recaption {
        /// Instance node id.
        id: u64,
        /// The new caption.
        caption: String,
        /// Its sentence embedding (the map's embedder).
        feature: Vec<f32>,
        /// A new class, when the object was replaced by another kind.
        class: Option<String>,
    },
    /// A new instance: a box of `size_m` (ground width, ground depth, height) standing on
    /// `base_height_m` at `centre_ground`.
    Add {
        /// Caption.
        caption: String,
        /// SemanticKITTI class name.
        class: String,
        /// Its sentence embedding.
        feature: Vec<f32>,
        /// Ground centre.
        centre_ground: [f64; 2],
        /// Height of the box's bottom (positive up).
        base_height_m: f64,
        /// Ground extent along the frame's two ground axes, then height.
        size_m: [f64; 3],
    },
}

impl Change {
    fn kind(&self) -> &'static str {
        match self {
            Change::Remove { .. } => "remove",
            Change::Move { .. } => "move",
            Change::Recaption { .. } => "change",
            Change::Add { .. } => "add",
        }
    }
}

/// What an applied edit did.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Applied {
    /// The `MapEdit` node id (give it to [`undo`]).
    pub edit_id: u64,
    /// remove, move, change or add.
    pub kind: String,
    /// Nodes made (the added instance).
    pub created_nodes: Vec<u64>,
    /// Nodes deleted (the removed instance).
    pub deleted_nodes: Vec<u64>,
    /// Nodes whose properties or points changed.
    pub changed_nodes: Vec<u64>,
    /// Relationships made (`IN_SEGMENT`, `RELATED`).
    pub created_relationships: usize,
    /// Relationships deleted.
    pub deleted_relationships: usize,
}

/// One recorded edit.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct EditInfo {
    /// The `MapEdit` node id.
    pub edit_id: u64,
    /// What the person said.
    pub text: String,
    /// remove, move, change or add.
    pub kind: String,
    /// Seconds since 1970.
    pub time_unix_s: f64,
    /// Whether it was undone.
    pub undone: bool,
    /// What changed (JSON).
    pub summary: serde_json::Value,
}

fn invalid(e: impl std::fmt::Display) -> graphstore::Error {
    graphstore::Error::InvalidValue(e.to_string())
}

fn map(entries: Vec<(&str, Value)>) -> Value {
    Value::Map(
        entries
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect(),
    )
}

fn ids(v: &[u64]) -> Value {
    Value::List(v.iter().map(|i| Value::Int(*i as i64)).collect())
}

fn props_map(tx: &WriteTxn<'_>, props: &[(graphstore::PropKey, Value)]) -> Value {
    Value::Map(
        props
            .iter()
            .map(|(k, v)| (tx.name_of(k.0).unwrap_or_default(), v.clone()))
            .collect(),
    )
}

fn props_from(
    tx: &mut WriteTxn<'_>,
    m: &Value,
) -> graphstore::Result<Vec<(graphstore::PropKey, Value)>> {
    let Value::Map(m) = m else {
        return Err(invalid("a recorded property map is not a map"));
    };
    m.iter()
        .map(|(k, v)| Ok((tx.prop_key_id(k)?, v.clone())))
        .collect()
}

/// The whole state of a node: id, labels, properties, payloads.
fn snapshot_node(tx: &WriteTxn<'_>, id: u64) -> graphstore::Result<Value> {
    let node = tx.node(id)?.ok_or(graphstore::Error::NodeNotFound(id))?;
    let labels = node
        .labels
        .iter()
        .map(|l| Value::String(tx.name_of(l.0).unwrap_or_default()))
        .collect();
    let mut payloads = BTreeMap::new();
    for k in tx.payload_keys(id)? {
        if let Some(b) = tx.payload(id, &k)? {
            payloads.insert(k, Value::Bytes(b));
        }
    }
    Ok(map(vec![
        ("id", Value::Int(id as i64)),
        ("labels", Value::List(labels)),
        ("props", props_map(tx, &node.props)),
        ("payloads", Value::Map(payloads)),
    ]))
}

fn snapshot_rel(tx: &WriteTxn<'_>, rel: &graphstore::Relationship) -> Value {
    map(vec![
        ("id", Value::Int(rel.id as i64)),
        (
            "type",
            Value::String(tx.name_of(rel.ty.0).unwrap_or_default()),
        ),
        ("start", Value::Int(rel.start as i64)),
        ("end", Value::Int(rel.end as i64)),
        ("props", props_map(tx, &rel.props)),
    ])
}

fn get<'a>(m: &'a Value, k: &str) -> graphstore::Result<&'a Value> {
    match m {
        Value::Map(m) => m
            .get(k)
            .ok_or_else(|| invalid(format!("the edit record lacks {k:?}"))),
        _ => Err(invalid("the edit record is not a map")),
    }
}

fn get_u64(m: &Value, k: &str) -> graphstore::Result<u64> {
    match get(m, k)? {
        Value::Int(i) if *i >= 0 => Ok(*i as u64),
        _ => Err(invalid(format!("the edit record's {k:?} is not an id"))),
    }
}

fn get_list<'a>(m: &'a Value, k: &str) -> graphstore::Result<&'a [Value]> {
    match get(m, k)? {
        Value::List(l) => Ok(l),
        _ => Err(invalid(format!("the edit record's {k:?} is not a list"))),
    }
}

/// The diff an edit builds while it runs.
#[derive(Default)]
struct Diff {
    created_nodes: Vec<u64>,
    created_rels: Vec<u64>,
    deleted_nodes: Vec<Value>,
    deleted_rels: Vec<Value>,
    /// (id, props before, payloads before)
    changed_nodes: Vec<Value>,
    touched: Vec<u64>,
}

impl Diff {
    fn delete_rel(&mut self, tx: &mut WriteTxn<'_>, rel_id: u64) -> graphstore::Result<()> {
        let rel = tx
            .rel(rel_id)?
            .ok_or(graphstore::Error::RelNotFound(rel_id))?;
        self.deleted_rels.push(snapshot_rel(tx, &rel));
        self.touched.extend([rel.start, rel.end]);
        tx.delete_rel(rel_id)
    }

    fn create_rel(
        &mut self,
        tx: &mut WriteTxn<'_>,
        start: u64,
        ty: &str,
        end: u64,
        props: &[(&str, Value)],
    ) -> graphstore::Result<()> {
        let id = tx.create_rel_named(start, ty, end, props)?;
        self.created_rels.push(id);
        self.touched.extend([start, end]);
        Ok(())
    }

    fn record_change(&mut self, tx: &WriteTxn<'_>, id: u64) -> graphstore::Result<()> {
        let snap = snapshot_node(tx, id)?;
        self.changed_nodes.push(snap);
        self.touched.push(id);
        Ok(())
    }
}

/// Re-derives the instance's segment and geometric relations after it moved or appeared:
/// deletes its `IN_SEGMENT` and `RELATED` edges, links it to the nearest segment, and labels it
/// against every instance within `near_m` as the hierarchy does.
fn relink(
    tx: &mut WriteTxn<'_>,
    id: u64,
    frame: GroundFrame,
    segments: &[llm_tools::locate::SegmentInfo],
    cfg: &RelationConfig,
    diff: &mut Diff,
) -> graphstore::Result<()> {
    for ty in [scene::rel::IN_SEGMENT, scene::rel::RELATED] {
        let Some(t) = tx.rel_type(ty) else { continue };
        let mut rels: Vec<u64> = tx
            .neighbours(id, Direction::Both, Some(t))?
            .into_iter()
            .map(|a| a.rel)
            .collect();
        rels.sort_unstable();
        rels.dedup();
        for r in rels {
            diff.delete_rel(tx, r)?;
        }
    }
    let Some(me) = read_instance_box(tx, id, frame)? else {
        return Ok(());
    };
    let centre = frame.ground(me.centre());
    if let Some((seg, d)) = segments
        .iter()
        .map(|s| (s.id, s.distance(centre)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
    {
        diff.create_rel(
            tx,
            id,
            scene::rel::IN_SEGMENT,
            seg,
            &InSegmentRecord { distance_m: d }.props(),
        )?;
    }
    let mut others = Vec::new();
    for other in tx.nodes_with_label(scene::label::INSTANCE)? {
        if other == id {
            continue;
        }
        if let Some(b) = read_instance_box(tx, other, frame)?
            && crate::hierarchy::relations::box_distance(&me, &b) <= cfg.near_m
        {
            others.push((other, b));
        }
    }
    let roads = scene::area::RoadDirections::new(segments.iter().map(|s| &s.area));
    let road_dir = |g: [f64; 2]| roads.direction_near(g);
    for (other, b) in others {
        let boxes = [me, b];
        let c = frame.ground(boxes[1].centre());
        let mid = [(centre[0] + c[0]) / 2.0, (centre[1] + c[1]) / 2.0];
        for r in label_pair(&boxes, 0, 1, frame, road_dir(mid), cfg) {
            let (a, b) = if r.a == 0 { (id, other) } else { (other, id) };
            diff.create_rel(
                tx,
                a,
                scene::rel::RELATED,
                b,
                &RelationRecord {
                    relation: r.relation.to_string(),
                    distance_m: r.distance_m,
                    source: GEOMETRIC.into(),
                    confidence: r.confidence,
                }
                .props(),
            )?;
        }
    }
    Ok(())
}

fn is_instance(tx: &WriteTxn<'_>, id: u64) -> graphstore::Result<()> {
    let node = tx.node(id)?.ok_or(graphstore::Error::NodeNotFound(id))?;
    if !tx
        .label(scene::label::INSTANCE)
        .is_some_and(|l| node.labels.contains(&l))
    {
        return Err(invalid(format!("node {id} is not an Instance")));
    }
    Ok(())
}

fn now_unix_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// The map's ground frame (from its Environment node).
///
/// # Errors
/// No Environment node or no `ground_frame`.
pub fn ground_frame(r: &impl GraphRead) -> Result<GroundFrame> {
    scene::records::ground_frame(r).map_err(|e| Error::Invalid(e.to_string()))
}

/// Applies a change as one transaction and records it as a `MapEdit` node. `text` is what the
/// person said, `parsed_by` who understood it (rules, or a model with its prompt id).
///
/// # Errors
/// The instance does not exist or is no Instance; the map has no ground frame; the store
/// fails. Nothing is written then.
pub fn apply(store: &Store, change: &Change, text: &str, parsed_by: &str) -> Result<Applied> {
    let (frame, segments) = {
        let r = store.read()?;
        let g = scene::records::ground_frame(&r).map_err(|e| Error::Invalid(e.to_string()))?;
        (ground_frame(&r)?, llm_tools::locate::load_segments(&r, g)?)
    };
    let cfg = RelationConfig::default();
    let applied = store.write(|tx| {
        let mut diff = Diff::default();
        let mut summary = serde_json::Map::new();
        match change {
            Change::Remove { id } => {
                is_instance(tx, *id)?;
                summary.insert(
                    "caption".into(),
                    tx.node_prop(*id, key::CAPTION)?
                        .map(|v| v.to_json())
                        .unwrap_or_default(),
                );
                let mut rels: Vec<u64> = tx
                    .neighbours(*id, Direction::Both, None)?
                    .into_iter()
                    .map(|a| a.rel)
                    .collect();
                rels.sort_unstable();
                rels.dedup();
                for r in rels {
                    diff.delete_rel(tx, r)?;
                }
                diff.deleted_nodes.push(snapshot_node(tx, *id)?);
                diff.touched.push(*id);
                tx.delete_node(*id)?;
            }
            Change::Move { id, to_ground } => {
                is_instance(tx, *id)?;
                diff.record_change(tx, *id)?;
                let b = read_instance_box(tx, *id, frame)?
                    .ok_or_else(|| invalid(format!("instance {id} has no box")))?;
                let from = frame.ground(b.centre());
                let dg = [to_ground[0] - from[0], to_ground[1] - from[1]];
                let d = frame.world(dg, 0.0);
                let shift = |p: [f64; 3]| [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
                let min = shift(b.min);
                let max = shift(b.max);
                let bbox = tx.prop_key_id(key::BBOX)?;
                tx.set_node_prop(
                    *id,
                    bbox,
                    Value::List(vec![Value::Point3D(min), Value::Point3D(max)]),
                )?;
                if let Some(c) = tx.node_prop(*id, key::CENTROID)?.and_then(|v| v.as_point3()) {
                    let k = tx.prop_key_id(key::CENTROID)?;
                    tx.set_node_prop(*id, k, Value::Point3D(shift(c)))?;
                }
                if tx.node_prop(*id, key::OBB)?.is_some() {
                    let mut o = b.obb;
                    o.center = [o.center[0] + dg[0], o.center[1] + dg[1]];
                    let k = tx.prop_key_id(key::OBB)?;
                    tx.set_node_prop(*id, k, scene::records::obb_value(&o))?;
                }
                if let Some(bytes) = tx.payload(*id, scene::payload::POINTS)? {
                    let mut pc = PointCloud::decode(&bytes)?;
                    for p in &mut pc.xyz {
                        for k in 0..3 {
                            p[k] = (f64::from(p[k]) + d[k]) as f32;
                        }
                    }
                    tx.put_point_cloud(*id, scene::payload::POINTS, &pc)?;
                }
                relink(tx, *id, frame, &segments, &cfg, &mut diff)?;
                summary.insert("from".into(), serde_json::json!(from));
                summary.insert("to".into(), serde_json::json!(to_ground));
                summary.insert("moved_m".into(), serde_json::json!(dg[0].hypot(dg[1])));
            }
            Change::Recaption {
                id,
                caption,
                feature,
                class,
            } => {
                is_instance(tx, *id)?;
                diff.record_change(tx, *id)?;
                summary.insert(
                    "caption_before".into(),
                    tx.node_prop(*id, key::CAPTION)?
                        .map(|v| v.to_json())
                        .unwrap_or_default(),
                );
                let k = tx.prop_key_id(key::CAPTION)?;
                tx.set_node_prop(*id, k, Value::String(caption.clone()))?;
                let k = tx.prop_key_id(key::FEATURE)?;
                tx.set_node_prop(*id, k, Value::Vector(feature.clone()))?;
                // the merged caption list no longer describes the object
                let k = tx.prop_key_id(key::CAPTIONS)?;
                tx.set_node_prop(*id, k, Value::List(vec![Value::String(caption.clone())]))?;
                if let Some(c) = class {
                    let k = tx.prop_key_id(key::SEMANTIC_CLASS)?;
                    tx.set_node_prop(*id, k, Value::String(c.clone()))?;
                }
                // the label and attributes follow the new caption
                let (label, colour, material) = llm_tools::labels::of_caption(caption);
                let k = tx.prop_key_id(key::LABEL)?;
                tx.set_node_prop(*id, k, Value::String(label))?;
                for (key_name, v) in [(key::COLOUR, colour), (key::MATERIAL, material)] {
                    let k = tx.prop_key_id(key_name)?;
                    match v {
                        Some(v) => tx.set_node_prop(*id, k, Value::String(v))?,
                        None => {
                            tx.remove_node_prop(*id, k)?;
                        }
                    }
                }
                summary.insert("caption".into(), serde_json::json!(caption));
            }
            Change::Add {
                caption,
                class,
                feature,
                centre_ground,
                base_height_m,
                size_m,
            } => {
                let mut next = 0i64;
                for i in tx.nodes_with_label(scene::label::INSTANCE)? {
                    if let Some(Value::Int(n)) = tx.node_prop(i, key::INSTANCE_ID)? {
                        next = next.max(n + 1);
                    }
                }
                let lo_g = [
                    centre_ground[0] - size_m[0] / 2.0,
                    centre_ground[1] - size_m[1] / 2.0,
                ];
                let hi_g = [
                    centre_ground[0] + size_m[0] / 2.0,
                    centre_ground[1] + size_m[1] / 2.0,
                ];
                let a = frame.world(lo_g, *base_height_m);
                let b = frame.world(hi_g, base_height_m + size_m[2]);
                let min = [0, 1, 2].map(|k| a[k].min(b[k]));
                let max = [0, 1, 2].map(|k| a[k].max(b[k]));
                let centroid = [0, 1, 2].map(|k| (min[k] + max[k]) / 2.0);
                let (label, colour, material) = llm_tools::labels::of_caption(caption);
                let id = InstanceRecord {
                    instance_id: next,
                    caption: caption.clone(),
                    semantic_class: class.clone(),
                    label: Some(label),
                    colour,
                    material,
                    centroid,
                    bbox: (min, max),
                    captions: Some(vec![caption.clone()]),
                    feature: Some(feature.clone()),
                    point_count: Some(0),
                    detection_count: Some(0),
                    first_frame: None,
                    last_frame: None,
                    source: Some("map_edit".into()),
                    detection_feature: None,
                    obb: None,
                    tile: None,
                }
                .create(tx)?;
                diff.created_nodes.push(id);
                diff.touched.push(id);
                relink(tx, id, frame, &segments, &cfg, &mut diff)?;
                summary.insert("caption".into(), serde_json::json!(caption));
                summary.insert("semantic_class".into(), serde_json::json!(class));
                summary.insert("centroid".into(), serde_json::json!(centroid));
            }
        }
        diff.touched.sort_unstable();
        diff.touched.dedup();
        let target = match change {
            Change::Remove { id } | Change::Move { id, .. } | Change::Recaption { id, .. } => {
                Some(*id)
            }
            Change::Add { .. } => diff.created_nodes.first().copied(),
        };
        // the properties the edit left on every node it changed or made, so that undo can tell
        // whether anything (the live mapper, another write) changed them since
        let changed: Vec<u64> = diff
            .changed_nodes
            .iter()
            .map(|n| get_u64(n, "id"))
            .collect::<graphstore::Result<_>>()?;
        let mut after = Vec::new();
        for &id in changed.iter().chain(&diff.created_nodes) {
            if let Some(node) = tx.node(id)? {
                after.push(map(vec![
                    ("id", Value::Int(id as i64)),
                    ("props", props_map(tx, &node.props)),
                ]));
            }
        }
        let record = map(vec![
            ("created_nodes", ids(&diff.created_nodes)),
            ("created_rels", ids(&diff.created_rels)),
            ("deleted_nodes", Value::List(diff.deleted_nodes.clone())),
            ("deleted_rels", Value::List(diff.deleted_rels.clone())),
            ("changed_nodes", Value::List(diff.changed_nodes.clone())),
            ("after_nodes", Value::List(after)),
        ]);
        let deleted: Vec<u64> = diff
            .deleted_nodes
            .iter()
            .map(|n| get_u64(n, "id"))
            .collect::<graphstore::Result<_>>()?;
        summary.insert("target".into(), serde_json::json!(target));
        summary.insert("created_nodes".into(), serde_json::json!(diff.created_nodes));
        summary.insert("deleted_nodes".into(), serde_json::json!(deleted));
        summary.insert("changed_nodes".into(), serde_json::json!(changed));
        summary.insert(
            "relationships".into(),
            serde_json::json!({"created": diff.created_rels.len(), "deleted": diff.deleted_rels.len()}),
        );
        let edit = EditRecord {
            text: text.to_string(),
            kind: change.kind().into(),
            time_unix_s: now_unix_s(),
            undone: false,
            parsed_by: Some(parsed_by.to_string()),
            summary: Some(serde_json::Value::Object(summary).to_string()),
            touched: diff.touched.iter().map(|t| *t as i64).collect(),
            target: target.map(|t| t as i64),
            undone_unix_s: None,
        }
        .create(tx)?;
        tx.put_payload(edit, scene::payload::DIFF, &record.to_bytes())?;
        Ok(Applied {
            edit_id: edit,
            kind: change.kind().into(),
            created_nodes: diff.created_nodes.clone(),
            deleted_nodes: deleted,
            changed_nodes: changed,
            created_relationships: diff.created_rels.len(),
            deleted_relationships: diff.deleted_rels.len(),
        })
    });
    applied.map_err(|e| match e {
        graphstore::Error::InvalidValue(m) => Error::Invalid(m),
        other => Error::Store(other),
    })
}

/// Reverts an applied edit exactly, as one transaction: what it created goes, what it deleted
/// comes back under the same ids, what it changed gets its old properties and points. The
/// `MapEdit` node stays, marked `undone`.
///
/// # Errors
/// [`Error::Invalid`] when the id is no `MapEdit`, the edit was undone already, or a later edit
/// that is still applied touched the same nodes (undo that one first).
pub fn undo(store: &Store, edit_id: u64) -> Result<EditInfo> {
    store
        .write(|tx| {
            let node = tx
                .node(edit_id)?
                .ok_or_else(|| invalid(format!("no map edit {edit_id}")))?;
            if !tx.label(MAP_EDIT).is_some_and(|l| node.labels.contains(&l)) {
                return Err(invalid(format!("node {edit_id} is not a MapEdit")));
            }
            if tx.node_prop(edit_id, key::UNDONE)? == Some(Value::Bool(true)) {
                return Err(invalid(format!("map edit {edit_id} was undone already")));
            }
            let touched = touched_of(tx, edit_id)?;
            for later in tx.nodes_with_label(MAP_EDIT)? {
                if later <= edit_id || tx.node_prop(later, key::UNDONE)? == Some(Value::Bool(true))
                {
                    continue;
                }
                let theirs = touched_of(tx, later)?;
                if let Some(n) = touched.iter().find(|n| theirs.contains(n)) {
                    return Err(invalid(format!(
                        "map edit {later} came later and also changed node {n}; undo {later} first"
                    )));
                }
            }
            let bytes = tx
                .payload(edit_id, scene::payload::DIFF)?
                .ok_or_else(|| invalid(format!("map edit {edit_id} has no recorded diff")))?;
            let d = Value::from_bytes(&bytes)?;
            // refuse to overwrite what changed after the edit (edits recorded before this
            // check have no after-state and are undone as before)
            if let Value::Map(m) = &d
                && let Some(Value::List(after)) = m.get("after_nodes")
            {
                for n in after {
                    let id = get_u64(n, "id")?;
                    let now = tx.node(id)?.map(|node| props_map(tx, &node.props));
                    if now.as_ref() != Some(get(n, "props")?) {
                        return Err(invalid(format!(
                            "node {id} changed after map edit {edit_id} (by live mapping or another write): \
                             undoing the edit would overwrite that; nothing was changed"
                        )));
                    }
                }
            }
            for r in get_list(&d, "created_rels")? {
                let Value::Int(r) = r else { continue };
                if tx.rel(*r as u64)?.is_some() {
                    tx.delete_rel(*r as u64)?;
                }
            }
            for n in get_list(&d, "created_nodes")? {
                let Value::Int(n) = n else { continue };
                tx.detach_delete_node(*n as u64)?;
            }
            for n in get_list(&d, "deleted_nodes")? {
                let id = get_u64(n, "id")?;
                let labels = get_list(n, "labels")?
                    .iter()
                    .map(|l| match l {
                        Value::String(s) => tx.label_id(s),
                        _ => Err(invalid("a recorded label is not a string")),
                    })
                    .collect::<graphstore::Result<Vec<_>>>()?;
                let props = props_from(tx, get(n, "props")?)?;
                tx.restore_node(id, &labels, props)?;
                if let Value::Map(p) = get(n, "payloads")? {
                    for (k, v) in p {
                        if let Value::Bytes(b) = v {
                            tx.put_payload(id, k, b)?;
                        }
                    }
                }
            }
            for n in get_list(&d, "changed_nodes")? {
                let id = get_u64(n, "id")?;
                let props = props_from(tx, get(n, "props")?)?;
                tx.replace_node_props(id, props)?;
                for k in tx.payload_keys(id)? {
                    tx.delete_payload(id, &k)?;
                }
                if let Value::Map(p) = get(n, "payloads")? {
                    for (k, v) in p {
                        if let Value::Bytes(b) = v {
                            tx.put_payload(id, k, b)?;
                        }
                    }
                }
            }
            for r in get_list(&d, "deleted_rels")? {
                let ty = match get(r, "type")? {
                    Value::String(s) => tx.rel_type_id(s)?,
                    _ => return Err(invalid("a recorded type is not a string")),
                };
                let props = props_from(tx, get(r, "props")?)?;
                tx.restore_rel(
                    get_u64(r, "id")?,
                    get_u64(r, "start")?,
                    ty,
                    get_u64(r, "end")?,
                    props,
                )?;
            }
            let k = tx.prop_key_id(key::UNDONE)?;
            tx.set_node_prop(edit_id, k, Value::Bool(true))?;
            let k = tx.prop_key_id(key::UNDONE_UNIX_S)?;
            tx.set_node_prop(edit_id, k, Value::Float(now_unix_s()))?;
            edit_info(tx, edit_id)
        })
        .map_err(|e| match e {
            graphstore::Error::InvalidValue(m) => Error::Invalid(m),
            other => Error::Store(other),
        })
}

fn touched_of(r: &impl GraphRead, edit: u64) -> graphstore::Result<Vec<u64>> {
    Ok(match r.node_prop(edit, key::TOUCHED)? {
        Some(Value::List(l)) => l
            .iter()
            .filter_map(|v| match v {
                Value::Int(i) => Some(*i as u64),
                _ => None,
            })
            .collect(),
        _ => Vec::new(),
    })
}

fn edit_info(r: &impl GraphRead, id: u64) -> graphstore::Result<EditInfo> {
    let s = |k: &str| -> graphstore::Result<String> {
        Ok(match r.node_prop(id, k)? {
            Some(Value::String(s)) => s,
            _ => String::new(),
        })
    };
    Ok(EditInfo {
        edit_id: id,
        text: s(key::TEXT)?,
        kind: s(key::KIND)?,
        time_unix_s: match r.node_prop(id, key::TIME_UNIX_S)? {
            Some(Value::Float(f)) => f,
            _ => 0.0,
        },
        undone: r.node_prop(id, key::UNDONE)? == Some(Value::Bool(true)),
        summary: serde_json::from_str(&s(key::SUMMARY)?).unwrap_or_default(),
    })
}

/// Every recorded edit, oldest first.
///
/// # Errors
/// The store fails.
pub fn list(r: &impl GraphRead) -> Result<Vec<EditInfo>> {
    let mut v = Vec::new();
    for id in r.nodes_with_label(MAP_EDIT)? {
        v.push(edit_info(r, id)?);
    }
    v.sort_by_key(|e| e.edit_id);
    Ok(v)
}
