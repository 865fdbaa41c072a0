//! Reading the map top-down for agents: `get_schema` (labels, relationship types, counts,
//! indexes and what the layers mean), `describe_area` (the environment's segments, or one
//! segment's objects) and `get_instance` (one instance with its segment and relations).

use std::collections::BTreeMap;

use graphstore::{Direction, GraphRead, Value};
use scene::{key, label, rel};
use serde_json::Value as Json;

use crate::error::{ToolError, ToolResult, failed};
use crate::ops::{
    AreaAnswer, EnvironmentOverview, EnvironmentRef, InstanceAnswer, LabelCount, LabelSchema,
    Notable, PropertySchema, RelatedRef, RelationshipTypeSchema, SchemaAnswer, SegmentDetail,
    SegmentRef, SegmentSummary,
};
use crate::toolbox::Toolbox;

/// What the layers of an OpenGraph map mean (returned by `get_schema`).
pub const LAYERS: &str = "An OpenGraph map is a hierarchy: one Environment node CONTAINS Segment nodes \
(kind: intersection = crossroads, t_intersection, l_intersection = bend, straight_roadway), which \
CONNECTS to each other; LaneNode nodes (the lane graph along the driven path) are linked by LANE \
relationships (length_m); Instance nodes are mapped objects (caption, class, centroid point3d, bbox, \
feature vector) with IN_SEGMENT to their segment and RELATED to nearby instances (relation, \
distance_m). MapEdit nodes record applied map edits (text, kind, undone). Node ids (id(n)) are \
the ids every tool takes and returns.";

/// Which id each tool takes (returned by `get_schema`).
pub const IDS: &str = "Every tool takes and returns node ids: id(n) in Cypher, the id find_objects, nearest_objects and \
count_objects print. Specs name the node id with its label: instance:ID (an Instance), segment:ID (a Segment), \
lane:ID (a LaneNode), node:ID (any node); get_instance, neighbours and undo_map_edit take node ids too. \
instance_id, segment_id and lane_id are the mapping's and the hierarchy's own numbering, kept for \
provenance: no tool takes them as an id. MATCH (n) WHERE id(n) = 42 finds a node by id.";

/// Notable objects `describe_area` lists for one segment at most.
pub const MAX_NOTABLE: usize = 25;

/// The `Instance` node with this node id: [`ToolError::NotFound`] when no node has it,
/// [`ToolError::BadArguments`] when it is another kind of node.
pub(crate) fn instance_node(r: &impl GraphRead, id: u64) -> ToolResult<graphstore::Node> {
    let node = r
        .node(id)
        .map_err(failed)?
        .ok_or_else(|| ToolError::NotFound(format!("no node {id}")))?;
    if !r
        .label(label::INSTANCE)
        .is_some_and(|l| node.labels.contains(&l))
    {
        return Err(ToolError::BadArguments(format!(
            "node {id} is not an Instance"
        )));
    }
    Ok(node)
}

fn str_prop(r: &impl GraphRead, id: u64, k: &str) -> ToolResult<Option<String>> {
    Ok(r.node_prop(id, k)
        .map_err(failed)?
        .and_then(|v| v.as_str().map(str::to_string)))
}

impl Toolbox {
    pub(crate) fn get_schema(&self) -> ToolResult<SchemaAnswer> {
        let c = self.store().counts().map_err(failed)?;
        let s = self.store().schema();
        let mut indexes: Vec<String> = s
            .effective_property_indexes()
            .iter()
            .map(|p| format!("property {}.{}", p.label, p.key))
            .collect();
        indexes.extend(s.spatial_indexes.iter().map(|x| match &x.box_key {
            Some(b) => format!(
                "spatial {} ({}.{b}, else {})",
                x.name, x.label, x.position_key
            ),
            None => format!("spatial {} ({}.{})", x.name, x.label, x.position_key),
        }));
        indexes.extend(
            s.vector_indexes
                .iter()
                .map(|x| format!("vector {} ({}.{})", x.name, x.label, x.key)),
        );
        indexes.extend(
            s.text_indexes
                .iter()
                .map(|x| format!("text {} ({}.{})", x.name, x.label, x.key)),
        );
        let props = |owner: &str, rules: &[graphstore::PropertyRule]| -> Vec<PropertySchema> {
            rules
                .iter()
                .map(|p| PropertySchema {
                    key: p.key.clone(),
                    value_type: p.ty.to_string(),
                    required: p.required,
                    meaning: scene::property_meaning(owner, &p.key).map(str::to_string),
                })
                .collect()
        };
        let labels = s
            .labels
            .iter()
            .map(|(name, rule)| {
                let schema = LabelSchema {
                    description: rule.description.clone(),
                    properties: props(name, &rule.properties),
                    unique: rule.unique.clone(),
                };
                (name.clone(), schema)
            })
            .collect();
        let relationship_types = s
            .relationships
            .iter()
            .map(|(name, rule)| {
                let schema = RelationshipTypeSchema {
                    description: rule.description.clone(),
                    from: rule.from_labels.clone(),
                    to: rule.to_labels.clone(),
                    properties: props(name, &rule.properties),
                };
                (name.clone(), schema)
            })
            .collect();
        let r = self.store().read().map_err(failed)?;
        let frame = match scene::records::ground_frame(&r) {
            Ok(g) => g.describe().to_string(),
            Err(e) => format!("The map's ground frame is not known yet ({e})."),
        };
        Ok(SchemaAnswer {
            layers: LAYERS.to_string(),
            frame,
            ids: IDS.to_string(),
            labels,
            relationship_types,
            nodes: c.nodes,
            relationships: c.relationships,
            indexes,
        })
    }

    pub(crate) fn describe_area(&self, segment: Option<u64>) -> ToolResult<AreaAnswer> {
        let r = self.store().read().map_err(failed)?;
        let in_seg = r.rel_type(rel::IN_SEGMENT);
        let surfaces = scene::classes::SURFACE_CLASSES;
        let members = |seg: u64| -> ToolResult<Vec<u64>> {
            let Some(t) = in_seg else {
                return Ok(Vec::new());
            };
            let mut v: Vec<u64> = r
                .neighbours(seg, Direction::Incoming, Some(t))
                .map_err(failed)?
                .into_iter()
                .map(|a| a.other)
                .collect();
            v.sort_unstable();
            v.retain(|id| {
                r.node(*id).ok().flatten().is_some_and(|n| {
                    r.label(label::INSTANCE)
                        .is_some_and(|l| n.labels.contains(&l))
                })
            });
            Ok(v)
        };
        // (SemanticKITTI class, label): surfaces are told by the class, kinds by the label
        let kind_of = |id: u64| -> ToolResult<(String, String)> {
            let class = str_prop(&r, id, key::SEMANTIC_CLASS)?.unwrap_or_default();
            let label = str_prop(&r, id, key::LABEL)?
                .filter(|l| !l.is_empty() && !surfaces.contains(&class.as_str()))
                .unwrap_or_else(|| class.clone());
            Ok((class, label))
        };
        match segment {
            None => {
                let env = r.nodes_with_label(label::ENVIRONMENT).map_err(failed)?;
                let mut segments = Vec::new();
                for s in r.nodes_with_label(label::SEGMENT).map_err(failed)? {
                    let mut by_label: BTreeMap<String, u64> = BTreeMap::new();
                    let ids = members(s)?;
                    for id in &ids {
                        let (c, l) = kind_of(*id)?;
                        if !surfaces.contains(&c.as_str()) {
                            *by_label.entry(l).or_insert(0) += 1;
                        }
                    }
                    let mut common: Vec<(String, u64)> = by_label.into_iter().collect();
                    common.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
                    common.truncate(4);
                    segments.push(SegmentSummary {
                        id: s,
                        kind: str_prop(&r, s, key::KIND)?,
                        objects: ids.len() as u64,
                        common_labels: common
                            .into_iter()
                            .map(|(label, count)| LabelCount { label, count })
                            .collect(),
                    });
                }
                let environment = env.first().map(|e| EnvironmentRef {
                    id: *e,
                    name: str_prop(&r, *e, key::NAME)
                        .unwrap_or_default()
                        .unwrap_or_default(),
                });
                Ok(AreaAnswer::Environment(EnvironmentOverview {
                    environment,
                    segments,
                }))
            }
            Some(seg) => {
                let Some(kind) = str_prop(&r, seg, key::KIND)? else {
                    return Err(ToolError::BadArguments(format!(
                        "node {seg} is not a Segment"
                    )));
                };
                let ids = members(seg)?;
                let mut objects_by_label: BTreeMap<String, u64> = BTreeMap::new();
                let mut notable = Vec::new();
                for id in &ids {
                    let (class, label) = kind_of(*id)?;
                    *objects_by_label.entry(label.clone()).or_insert(0) += 1;
                    if !surfaces.contains(&class.as_str()) && notable.len() < MAX_NOTABLE {
                        notable.push(Notable {
                            id: *id,
                            label,
                            semantic_class: class,
                            caption: str_prop(&r, *id, key::CAPTION)?.unwrap_or_default(),
                        });
                    }
                }
                Ok(AreaAnswer::Segment(SegmentDetail {
                    id: seg,
                    kind,
                    objects_by_label,
                    notable,
                }))
            }
        }
    }

    pub(crate) fn get_instance(&self, id: u64) -> ToolResult<InstanceAnswer> {
        let r = self.store().read().map_err(failed)?;
        let node = instance_node(&r, id)?;
        let mut properties = serde_json::Map::new();
        for (k, v) in &node.props {
            let name = r.name_of(k.0).unwrap_or_default();
            if matches!(v, Value::Vector(_)) || name == key::CAPTIONS {
                continue;
            }
            properties.insert(name, v.to_json());
        }
        let mut related = Vec::new();
        let mut segment = None;
        let mut segment_distance_m = None;
        for adj in r.neighbours(id, Direction::Both, None).map_err(failed)? {
            let ty = r.name_of(adj.ty.0).unwrap_or_default();
            match ty.as_str() {
                rel::RELATED => {
                    let found = r.rel(adj.rel).map_err(failed)?;
                    let get = |k: &str| {
                        found
                            .as_ref()
                            .and_then(|x| {
                                let pk = r.prop_key(k)?;
                                x.props
                                    .iter()
                                    .find(|(n, _)| *n == pk)
                                    .map(|(_, v)| v.clone())
                            })
                            .map(|v| v.to_json())
                            .unwrap_or(Json::Null)
                    };
                    related.push(RelatedRef {
                        id: adj.other,
                        outgoing: adj.outgoing,
                        relation: get(key::RELATION),
                        distance_m: get(key::DISTANCE_M),
                        source: get(key::SOURCE),
                        caption: str_prop(&r, adj.other, key::CAPTION)?,
                    });
                }
                rel::IN_SEGMENT if adj.outgoing => {
                    segment = Some(SegmentRef {
                        id: adj.other,
                        kind: str_prop(&r, adj.other, key::KIND)?,
                    });
                    segment_distance_m = match r.prop_key(key::DISTANCE_M) {
                        Some(k) => r
                            .rel_prop(adj.rel, k)
                            .map_err(failed)?
                            .and_then(|v| v.as_f64()),
                        None => None,
                    };
                }
                _ => {}
            }
        }
        Ok(InstanceAnswer {
            id,
            properties,
            segment,
            segment_distance_m,
            related,
        })
    }
}
