//! The schema resolved to token ids, so write-path checks never touch strings.

use std::collections::HashMap;

use crate::index::vector::VectorParams;
use crate::schema::{PropertyRule, Schema};
use crate::value::ValueType;

#[derive(Debug, Clone)]
pub(crate) struct CRule {
    pub(crate) key: u32,
    pub(crate) ty: ValueType,
    pub(crate) required: bool,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct CLabelRule {
    pub(crate) props: Vec<CRule>,
    /// Unique keys, each with the property index that enforces it.
    pub(crate) unique: Vec<(u32, u32)>,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct CRelRule {
    pub(crate) props: Vec<CRule>,
    pub(crate) from: Vec<u32>,
    pub(crate) to: Vec<u32>,
}

#[derive(Debug, Clone)]
pub(crate) struct CPropIndex {
    pub(crate) label: u32,
    pub(crate) key: u32,
}

#[derive(Debug, Clone)]
pub(crate) struct CSpatial {
    pub(crate) label: u32,
    pub(crate) position: u32,
    pub(crate) bbox: Option<u32>,
}

#[derive(Debug, Clone)]
pub(crate) struct CVector {
    pub(crate) label: u32,
    pub(crate) key: u32,
    pub(crate) params: VectorParams,
}

#[derive(Debug, Clone)]
pub(crate) struct CText {
    pub(crate) label: u32,
    pub(crate) key: u32,
}

/// A schema with every name replaced by its token id.
#[derive(Debug, Clone, Default)]
pub(crate) struct Compiled {
    pub(crate) schema: Schema,
    pub(crate) labels: HashMap<u32, CLabelRule>,
    pub(crate) rels: HashMap<u32, CRelRule>,
    pub(crate) prop_indexes: Vec<CPropIndex>,
    pub(crate) prop_index_of: HashMap<(u32, u32), u32>,
    pub(crate) spatial: Vec<CSpatial>,
    pub(crate) vector: Vec<CVector>,
    pub(crate) text: Vec<CText>,
}

impl Compiled {
    /// Resolves names with `intern` (which creates missing tokens in a write transaction).
    pub(crate) fn compile(
        schema: &Schema,
        mut label: impl FnMut(&str) -> crate::Result<u32>,
        mut rel_type: impl FnMut(&str) -> crate::Result<u32>,
        mut key: impl FnMut(&str) -> crate::Result<u32>,
    ) -> crate::Result<Compiled> {
        let mut c = Compiled {
            schema: schema.clone(),
            ..Default::default()
        };
        for (i, spec) in schema.effective_property_indexes().iter().enumerate() {
            let (l, k) = (label(&spec.label)?, key(&spec.key)?);
            c.prop_indexes.push(CPropIndex { label: l, key: k });
            c.prop_index_of.insert((l, k), i as u32);
        }
        let mut rules = |props: &[PropertyRule]| -> crate::Result<Vec<CRule>> {
            props
                .iter()
                .map(|p| {
                    Ok(CRule {
                        key: key(&p.key)?,
                        ty: p.ty,
                        required: p.required,
                    })
                })
                .collect()
        };
        let mut label_rules = Vec::new();
        for (name, rule) in &schema.labels {
            label_rules.push((name, rules(&rule.properties)?, rule));
        }
        let mut rel_rules = Vec::new();
        for (name, rule) in &schema.relationships {
            rel_rules.push((name, rules(&rule.properties)?, rule));
        }
        for (name, props, rule) in label_rules {
            let l = label(name)?;
            let mut unique = Vec::new();
            for u in &rule.unique {
                let k = key(u)?;
                let idx = *c.prop_index_of.get(&(l, k)).ok_or_else(|| {
                    crate::Error::Schema(format!("unique key {name}.{u} has no index"))
                })?;
                unique.push((k, idx));
            }
            c.labels.insert(l, CLabelRule { props, unique });
        }
        for (name, props, rule) in rel_rules {
            let t = rel_type(name)?;
            let from = rule
                .from_labels
                .iter()
                .map(|s| label(s))
                .collect::<crate::Result<_>>()?;
            let to = rule
                .to_labels
                .iter()
                .map(|s| label(s))
                .collect::<crate::Result<_>>()?;
            c.rels.insert(t, CRelRule { props, from, to });
        }
        for s in &schema.spatial_indexes {
            c.spatial.push(CSpatial {
                label: label(&s.label)?,
                position: key(&s.position_key)?,
                bbox: s.box_key.as_deref().map(&mut key).transpose()?,
            });
        }
        for v in &schema.vector_indexes {
            c.vector.push(CVector {
                label: label(&v.label)?,
                key: key(&v.key)?,
                params: VectorParams {
                    dim: v.dim,
                    int8: v.int8,
                },
            });
        }
        for t in &schema.text_indexes {
            c.text.push(CText {
                label: label(&t.label)?,
                key: key(&t.key)?,
            });
        }
        Ok(c)
    }

    pub(crate) fn spatial_by_name(&self, name: &str) -> crate::Result<usize> {
        self.schema
            .spatial_indexes
            .iter()
            .position(|s| s.name == name)
            .ok_or_else(|| crate::Error::NoSuchIndex {
                kind: "spatial",
                name: name.into(),
            })
    }

    pub(crate) fn vector_by_name(&self, name: &str) -> crate::Result<usize> {
        self.schema
            .vector_indexes
            .iter()
            .position(|s| s.name == name)
            .ok_or_else(|| crate::Error::NoSuchIndex {
                kind: "vector",
                name: name.into(),
            })
    }

    pub(crate) fn text_by_name(&self, name: &str) -> crate::Result<usize> {
        self.schema
            .text_indexes
            .iter()
            .position(|s| s.name == name)
            .ok_or_else(|| crate::Error::NoSuchIndex {
                kind: "text",
                name: name.into(),
            })
    }
}
