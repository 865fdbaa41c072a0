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
    /// The index's name (`CREATE INDEX name FOR ...`); None: `label_key` in lower case.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
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
                    name: None,
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
