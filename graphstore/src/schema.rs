//! Declared schema: per-label and per-relationship-type rules, and index declarations.
//!
//! The schema is stored in the file (as JSON in the meta table) and enforced on every
//! write: a write that breaks a rule fails with [`crate::Error::Constraint`] and changes
//! nothing.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::value::ValueType;

/// One property rule.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PropertyRule {
    /// Property key.
    pub key: String,
    /// Required type when present.
    #[serde(rename = "type")]
    pub ty: ValueType,
    /// Whether the property must be present.
    pub required: bool,
}

/// Rules for nodes carrying a label.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LabelRule {
    /// Typed properties.
    #[serde(default)]
    pub properties: Vec<PropertyRule>,
    /// Properties whose values must be unique among nodes with this label.
    #[serde(default)]
    pub unique: Vec<String>,
    /// Free text for docs and `info`.
    #[serde(default)]
    pub description: String,
}

/// Rules for relationships of a type.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RelRule {
    /// Typed properties.
    #[serde(default)]
    pub properties: Vec<PropertyRule>,
    /// Allowed start-node labels (empty: any).
    #[serde(default)]
    pub from_labels: Vec<String>,
    /// Allowed end-node labels (empty: any).
    #[serde(default)]
    pub to_labels: Vec<String>,
    /// Free text for docs.
    #[serde(default)]
    pub description: String,
}

/// A property index: equality and range lookups of `label.key`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PropertyIndexSpec {
    /// Label of indexed nodes.
    pub label: String,
    /// Indexed property.
    pub key: String,
}

/// A spatial (R-tree) index over nodes with `label`: each entry is the node's box
/// (`box_key`, a [`ValueType::Box3D`]) or else its position (`position_key`, a point).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SpatialIndexSpec {
    /// Index name used in queries.
    pub name: String,
    /// Label of indexed nodes.
    pub label: String,
    /// Point property.
    pub position_key: String,
    /// Optional box property; preferred over the position when present.
    #[serde(default)]
    pub box_key: Option<String>,
}

/// An exact top-k cosine index over f32 vectors.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct VectorIndexSpec {
    /// Index name used in queries.
    pub name: String,
    /// Label of indexed nodes.
    pub label: String,
    /// Vector property.
    pub key: String,
    /// Required dimension.
    pub dim: usize,
    /// Keep an int8 copy to scan first; results stay exact (candidates are re-ranked in f32
    /// with a proven error bound).
    #[serde(default = "yes")]
    pub int8: bool,
    /// Search method. Only the exact flat scan exists today; the field is stored so an
    /// approximate method can be added without a format change.
    #[serde(default)]
    pub method: VectorMethod,
}

/// How a vector index searches.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum VectorMethod {
    /// Exact scan over contiguous rows (with the optional int8 pre-scan).
    #[default]
    Flat,
}

fn yes() -> bool {
    true
}

/// A BM25 full-text index over a string (or list of strings) property.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TextIndexSpec {
    /// Index name used in queries.
    pub name: String,
    /// Label of indexed nodes.
    pub label: String,
    /// Text property.
    pub key: String,
}

/// The whole declared schema.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Schema {
    /// Rules per node label.
    #[serde(default)]
    pub labels: BTreeMap<String, LabelRule>,
    /// Rules per relationship type.
    #[serde(default)]
    pub relationships: BTreeMap<String, RelRule>,
    /// Property indexes (unique keys get one automatically).
    #[serde(default)]
    pub property_indexes: Vec<PropertyIndexSpec>,
    /// Spatial indexes.
    #[serde(default)]
    pub spatial_indexes: Vec<SpatialIndexSpec>,
    /// Vector indexes.
    #[serde(default)]
    pub vector_indexes: Vec<VectorIndexSpec>,
    /// Text indexes.
    #[serde(default)]
    pub text_indexes: Vec<TextIndexSpec>,
}

impl Schema {
    /// The rule for a label, if declared.
    pub fn label_rule(&self, label: &str) -> Option<&LabelRule> {
        self.labels.get(label)
    }

    /// Property indexes including the implicit ones behind unique keys, deduplicated, in a
    /// stable order.
    pub fn effective_property_indexes(&self) -> Vec<PropertyIndexSpec> {
        let mut out: Vec<PropertyIndexSpec> = self.property_indexes.clone();
        for (label, rule) in &self.labels {
            for key in &rule.unique {
                out.push(PropertyIndexSpec {
                    label: label.clone(),
                    key: key.clone(),
                });
            }
        }
        let mut seen = std::collections::BTreeSet::new();
        out.retain(|s| seen.insert((s.label.clone(), s.key.clone())));
        out
    }

    /// Checks the declarations for internal consistency.
    pub fn validate(&self) -> crate::Result<()> {
        let err = |m: String| Err(crate::Error::Schema(m));
        let mut names = std::collections::BTreeSet::new();
        for n in self
            .spatial_indexes
            .iter()
            .map(|s| &s.name)
            .chain(self.vector_indexes.iter().map(|s| &s.name))
            .chain(self.text_indexes.iter().map(|s| &s.name))
        {
            if n.is_empty() {
                return err("index names must not be empty".into());
            }
            if !names.insert(n.clone()) {
                return err(format!("index name {n:?} is declared twice"));
            }
        }
        for v in &self.vector_indexes {
            if v.dim == 0 || v.dim > 65_536 {
                return err(format!(
                    "vector index {:?}: dim {} is out of range 1..=65536",
                    v.name, v.dim
                ));
            }
        }
        for (label, rule) in &self.labels {
            let mut keys = std::collections::BTreeSet::new();
            for p in &rule.properties {
                if !keys.insert(&p.key) {
                    return err(format!("label {label}: property {:?} has two rules", p.key));
                }
                if p.required && p.ty == ValueType::Null {
                    return err(format!(
                        "label {label}: required property {:?} cannot be of type null",
                        p.key
                    ));
                }
            }
        }
        Ok(())
    }

    /// Adds everything declared in `other` to `self` (rules of the same name are replaced).
    pub fn merge(&mut self, other: &Schema) {
        for (k, v) in &other.labels {
            self.labels.insert(k.clone(), v.clone());
        }
        for (k, v) in &other.relationships {
            self.relationships.insert(k.clone(), v.clone());
        }
        fn add<T: PartialEq + Clone>(into: &mut Vec<T>, from: &[T], same: impl Fn(&T, &T) -> bool) {
            for f in from {
                if let Some(slot) = into.iter_mut().find(|x| same(x, f)) {
                    *slot = f.clone();
                } else {
                    into.push(f.clone());
                }
            }
        }
        add(
            &mut self.property_indexes,
            &other.property_indexes,
            |a, b| a == b,
        );
        add(&mut self.spatial_indexes, &other.spatial_indexes, |a, b| {
            a.name == b.name
        });
        add(&mut self.vector_indexes, &other.vector_indexes, |a, b| {
            a.name == b.name
        });
        add(&mut self.text_indexes, &other.text_indexes, |a, b| {
            a.name == b.name
        });
    }
}

fn req(key: &str, ty: ValueType) -> PropertyRule {
    PropertyRule {
        key: key.into(),
        ty,
        required: true,
    }
}

fn opt(key: &str, ty: ValueType) -> PropertyRule {
    PropertyRule {
        key: key.into(),
        ty,
        required: false,
    }
}

fn rel(from: &[&str], to: &[&str], properties: Vec<PropertyRule>, description: &str) -> RelRule {
    RelRule {
        properties,
        from_labels: from.iter().map(|s| s.to_string()).collect(),
        to_labels: to.iter().map(|s| s.to_string()).collect(),
        description: description.into(),
    }
}

/// Dimension of the sentence-embedding features (all-MiniLM-L6-v2).
pub const FEATURE_DIM: usize = 384;

/// The OpenGraph layers as a schema. `docs/schema.md` documents every name here.
pub fn opengraph_schema() -> Schema {
    use ValueType as T;
    let mut s = Schema::default();
    s.labels.insert(
        "Environment".into(),
        LabelRule {
            properties: vec![
                req("name", T::String),
                opt("source", T::String),
                opt("ground_frame", T::String),
            ],
            unique: vec!["name".into()],
            description: "Root of the hierarchy: one per mapped environment.".into(),
        },
    );
    s.labels.insert(
        "Segment".into(),
        LabelRule {
            properties: vec![
                req("segment_id", T::Int),
                req("kind", T::String),
                req("centroid", T::Point3D),
                opt("area", T::List),
                opt("radius_m", T::Float),
                opt("centerline", T::List),
                opt("half_width_m", T::Float),
                opt("bbox", T::Box3D),
                opt("polygon", T::List),
                opt("drivable_area_m2", T::Float),
            ],
            unique: vec!["segment_id".into()],
            description:
                "Road segment: intersection, t_intersection, l_intersection or straight_roadway; polygon is its drivable area measured from the map (rings of points, even-odd)."
                    .into(),
        },
    );
    s.labels.insert(
        "LaneNode".into(),
        LabelRule {
            properties: vec![
                req("lane_id", T::Int),
                req("kind", T::String),
                req("position", T::Point3D),
            ],
            unique: vec!["lane_id".into()],
            description:
                "Lane-graph vertex: intersection, t_intersection, l_intersection or breakpoint."
                    .into(),
        },
    );
    s.labels.insert(
        "Instance".into(),
        LabelRule {
            properties: vec![
                req("instance_id", T::Int),
                req("caption", T::String),
                req("class", T::String),
                req("centroid", T::Point3D),
                req("bbox", T::Box3D),
                opt("captions", T::List),
                opt("feature", T::Vector),
                opt("point_count", T::Int),
                opt("detection_count", T::Int),
                opt("first_frame", T::Int),
                opt("last_frame", T::Int),
                opt("source", T::String),
                opt("detection_feature", T::Vector),
                opt("tile", T::List),
                opt("obb", T::List),
            ],
            unique: vec!["instance_id".into()],
            description: "A mapped object with caption, feature, class, box and points; obb is its oriented box on the ground plane: [center_0, center_1, half_length_m, half_width_m, yaw_rad, bottom_m, top_m] in the environment's ground frame.".into(),
        },
    );
    s.labels.insert(
        "Frame".into(),
        LabelRule {
            properties: vec![
                req("index", T::Int),
                req("world_from_velo", T::List),
                opt("timestamp_secs", T::Float),
            ],
            unique: vec!["index".into()],
            description: "A key frame with its pose (3x4 row-major, 12 floats).".into(),
        },
    );
    s.labels.insert(
        "Build".into(),
        LabelRule {
            properties: vec![
                req("build_id", T::Int),
                req("args", T::String),
                req("next_frame", T::Int),
                req("next_instance_id", T::Int),
                req("finished", T::Bool),
                opt("hierarchy_done", T::Bool),
                opt("source", T::String),
            ],
            unique: vec!["build_id".into()],
            description:
                "Provenance and checkpoint of a map build (lets `build --resume` continue).".into(),
        },
    );
    s.labels.insert(
        "MapEdit".into(),
        LabelRule {
            properties: vec![
                req("text", T::String),
                req("kind", T::String),
                req("time_unix_s", T::Float),
                req("undone", T::Bool),
                opt("parsed_by", T::String),
                opt("summary", T::String),
                opt("touched", T::List),
                opt("target", T::Int),
                opt("undone_unix_s", T::Float),
            ],
            unique: vec![],
            description: "An applied map edit (remove, move, change, add) from a described change; its `diff` payload lets `update --undo` revert it exactly.".into(),
        },
    );
    s.relationships.insert(
        "CONTAINS".into(),
        rel(
            &["Environment"],
            &["Segment"],
            vec![],
            "Environment to each of its segments.",
        ),
    );
    s.relationships.insert(
        "CONNECTS".into(),
        rel(
            &["Segment"],
            &["Segment"],
            vec![],
            "Traversable adjacency between segments.",
        ),
    );
    s.relationships.insert(
        "LANE".into(),
        rel(
            &["LaneNode"],
            &["LaneNode"],
            vec![
                req("length_m", T::Float),
                opt("polyline", T::List),
                opt("frames", T::List),
                opt("directed", T::Bool),
            ],
            "Lane-graph edge with its metric polyline.",
        ),
    );
    s.relationships.insert(
        "IN_SEGMENT".into(),
        rel(
            &["Instance", "LaneNode"],
            &["Segment"],
            vec![opt("distance_m", T::Float)],
            "Membership in the closest segment.",
        ),
    );
    s.relationships.insert(
        "RELATED".into(),
        rel(
            &["Instance"],
            &["Instance"],
            vec![
                req("relation", T::String),
                req("distance_m", T::Float),
                req("source", T::String),
                req("confidence", T::Float),
            ],
            "Instance-layer relation (geometric or LLM-inferred).",
        ),
    );
    s.relationships.insert(
        "OBSERVED_IN".into(),
        rel(
            &["Instance"],
            &["Frame"],
            vec![opt("detections", T::Int)],
            "Instance seen in a key frame.",
        ),
    );
    s.property_indexes = vec![
        PropertyIndexSpec {
            label: "Instance".into(),
            key: "class".into(),
        },
        PropertyIndexSpec {
            label: "LaneNode".into(),
            key: "kind".into(),
        },
        PropertyIndexSpec {
            label: "Segment".into(),
            key: "kind".into(),
        },
    ];
    s.spatial_indexes = vec![
        SpatialIndexSpec {
            name: "instance_space".into(),
            label: "Instance".into(),
            position_key: "centroid".into(),
            box_key: Some("bbox".into()),
        },
        SpatialIndexSpec {
            name: "lane_space".into(),
            label: "LaneNode".into(),
            position_key: "position".into(),
            box_key: None,
        },
        SpatialIndexSpec {
            name: "segment_space".into(),
            label: "Segment".into(),
            position_key: "centroid".into(),
            box_key: Some("bbox".into()),
        },
    ];
    s.vector_indexes = vec![VectorIndexSpec {
        name: "instance_feature".into(),
        label: "Instance".into(),
        key: "feature".into(),
        dim: FEATURE_DIM,
        int8: true,
        method: VectorMethod::Flat,
    }];
    s.text_indexes = vec![TextIndexSpec {
        name: "instance_caption".into(),
        label: "Instance".into(),
        key: "caption".into(),
    }];
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opengraph_schema_is_valid_and_roundtrips() {
        let s = opengraph_schema();
        s.validate().unwrap();
        let json = serde_json::to_string(&s).unwrap();
        let back: Schema = serde_json::from_str(&json).unwrap();
        assert_eq!(back, s);
        let idx = s.effective_property_indexes();
        assert!(idx.iter().any(|i| i.label == "Frame" && i.key == "index"));
        assert!(
            idx.iter()
                .any(|i| i.label == "Instance" && i.key == "class")
        );
    }

    #[test]
    fn duplicate_index_names_are_rejected() {
        let mut s = opengraph_schema();
        s.text_indexes.push(TextIndexSpec {
            name: "instance_feature".into(),
            label: "X".into(),
            key: "y".into(),
        });
        assert!(s.validate().is_err());
    }
}
