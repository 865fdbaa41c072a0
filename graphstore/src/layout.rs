//! The store's layout: the redb tables and their keys, the node record, and the state a
//! commit leaves for the next transaction (tokens, the compiled schema, the in-memory index
//! layers), with the index entries a node record contributes. The store, its transactions,
//! the read API and the consistency checks all stand on this; it uses none of them.

use std::collections::BTreeMap;
use std::sync::Arc;

use redb::TableDefinition;

use crate::codec;
use crate::compiled::Compiled;
use crate::error::{Error, Result, corrupt};
use crate::index::spatial::SpatialLayer;
use crate::index::text::{Doc, TextLayer};
use crate::index::vector::{VectorLayer, normalize};
use crate::index::{Pending, Stack};
use crate::model::{Relationship, typed_props};
use crate::tokens::{RelType, Tokens};
use crate::value::Value;

/// On-disk format version; bump on any incompatible change to tables or encodings. Version 2
/// packs the adjacency into chunks ([`crate::adjacency`]); a store of version 1 is converted
/// when it is opened for writing ([`crate::Store::open`]).
pub const FORMAT_VERSION: u32 = 2;
pub(crate) const MAGIC: &[u8] = b"opengraph-graphstore";

pub(crate) const META: TableDefinition<'static, &str, &[u8]> = TableDefinition::new("og_meta");
pub(crate) const TOKENS: TableDefinition<'static, u32, &str> = TableDefinition::new("og_tokens");
pub(crate) const NODES: TableDefinition<'static, u64, &[u8]> = TableDefinition::new("og_nodes");
pub(crate) const RELS: TableDefinition<'static, u64, &[u8]> = TableDefinition::new("og_rels");
/// (node, direction 0=out 1=in, first rel) -> packed chunk (see [`crate::adjacency`])
pub(crate) use crate::adjacency::ADJ;
/// (label, node)
pub(crate) const LABELS: TableDefinition<'static, (u32, u64), ()> =
    TableDefinition::new("og_labels");
/// index id (4 BE) | sortable value | node (8 BE)
pub(crate) const PROPIDX: TableDefinition<'static, &[u8], ()> = TableDefinition::new("og_propidx");
/// (kind, token) -> count; kind 0 = label, 1 = relationship type, 2 = totals (0 nodes, 1 rels)
pub(crate) const COUNTS: TableDefinition<'static, (u8, u32), u64> =
    TableDefinition::new("og_counts");
/// (node, key) -> bytes
pub(crate) const PAYLOADS: TableDefinition<'static, (u64, &str), &[u8]> =
    TableDefinition::new("og_payloads");

pub(crate) const K_NEXT_NODE: &str = "next_node_id";
pub(crate) const K_NEXT_REL: &str = "next_rel_id";
pub(crate) const K_MAGIC: &str = "magic";
pub(crate) const K_VERSION: &str = "format_version";
pub(crate) const K_SCHEMA: &str = "schema";

/// In-memory index snapshots, parallel to the compiled schema's lists.
#[derive(Debug, Clone, Default)]
pub(crate) struct Mem {
    pub(crate) spatial: Vec<Stack<SpatialLayer>>,
    pub(crate) vector: Vec<Stack<VectorLayer>>,
    pub(crate) text: Vec<Stack<TextLayer>>,
}

/// A transaction's private index changes.
#[derive(Debug, Default)]
pub(crate) struct PendingMem {
    pub(crate) spatial: Vec<Pending<crate::index::spatial::Aabb>>,
    pub(crate) vector: Vec<Pending<crate::index::vector::Unit>>,
    pub(crate) text: Vec<Pending<Doc>>,
}

impl PendingMem {
    pub(crate) fn for_schema(c: &Compiled) -> Self {
        PendingMem {
            spatial: c.spatial.iter().map(|_| Pending::default()).collect(),
            vector: c.vector.iter().map(|_| Pending::default()).collect(),
            text: c.text.iter().map(|_| Pending::default()).collect(),
        }
    }
}

impl Mem {
    pub(crate) fn commit(&self, p: PendingMem) -> Mem {
        Mem {
            spatial: self
                .spatial
                .iter()
                .zip(p.spatial)
                .map(|(s, p)| s.commit(p))
                .collect(),
            vector: self
                .vector
                .iter()
                .zip(p.vector)
                .map(|(s, p)| s.commit(p))
                .collect(),
            text: self
                .text
                .iter()
                .zip(p.text)
                .map(|(s, p)| s.commit(p))
                .collect(),
        }
    }
}

/// One commit's in-memory spatial, vector and text indexes, built from the store the first
/// time a reader needs them (opening a store reads nothing for them: a one-shot `query` on a
/// city map does not pay for decoding every indexed record), or carried over from the commit
/// before with the writer's changes merged in.
#[derive(Debug, Default)]
pub(crate) struct MemSlot(std::sync::OnceLock<Arc<Mem>>);

impl MemSlot {
    /// A slot holding `mem` already.
    pub(crate) fn built(mem: Mem) -> MemSlot {
        let slot = MemSlot::default();
        let _ = slot.0.set(Arc::new(mem));
        slot
    }

    /// The indexes, if built.
    pub(crate) fn get(&self) -> Option<&Mem> {
        self.0.get().map(|m| &**m)
    }

    /// The indexes, built by `build` if they are not yet (two readers racing may both build;
    /// the first to finish is kept).
    pub(crate) fn get_or_build(
        &self,
        build: impl FnOnce() -> crate::Result<Mem>,
    ) -> crate::Result<&Mem> {
        if self.0.get().is_none() {
            let mem = crate::mem::uncounted(build)?;
            let _ = self.0.set(Arc::new(mem));
        }
        self.get().ok_or_else(|| crate::Error::Corrupt {
            what: "in-memory indexes".into(),
            detail: "not kept after building".into(),
        })
    }
}

/// Everything a transaction needs from the last commit.
#[derive(Debug)]
pub struct Committed {
    pub(crate) tokens: Arc<Tokens>,
    pub(crate) schema: Arc<Compiled>,
    pub(crate) mem: MemSlot,
    /// Commits since the store was opened (see [`crate::Store::commit_seq`]).
    pub(crate) seq: u64,
    /// In-memory copies of hot tables for this commit's readers, built on demand.
    pub(crate) hot: crate::hot::Hot,
}

/// Index entries of nodes, gathered per index (for rebuilding and for checking).
pub(crate) struct EntryLists {
    pub(crate) spatial: Vec<Vec<(u64, crate::index::spatial::Aabb)>>,
    pub(crate) vector: Vec<Vec<(u64, crate::index::vector::Unit)>>,
    pub(crate) text: Vec<Vec<(u64, Doc)>>,
}

impl EntryLists {
    pub(crate) fn new(c: &Compiled) -> EntryLists {
        EntryLists {
            spatial: vec![Vec::new(); c.spatial.len()],
            vector: vec![Vec::new(); c.vector.len()],
            text: vec![Vec::new(); c.text.len()],
        }
    }

    /// Adds whatever node `id` contributes to each index.
    pub(crate) fn add(&mut self, c: &Compiled, id: u64, rec: &NodeRec) {
        for (i, s) in c.spatial.iter().enumerate() {
            if let Some(e) = spatial_entry(s, rec) {
                self.spatial[i].push((id, e));
            }
        }
        for (i, v) in c.vector.iter().enumerate() {
            if let Some(e) = vector_entry(v, rec) {
                self.vector[i].push((id, e));
            }
        }
        for (i, t) in c.text.iter().enumerate() {
            if let Some(e) = text_entry(t, rec) {
                self.text[i].push((id, e));
            }
        }
    }
}

/// Node and relationship counts by label and type.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct GraphCounts {
    /// Nodes per label.
    pub nodes: BTreeMap<String, u64>,
    /// Relationships per type.
    pub relationships: BTreeMap<String, u64>,
    /// All nodes (a node with several labels counts once).
    pub total_nodes: u64,
    /// All relationships.
    pub total_relationships: u64,
}

pub(crate) fn codec_err(what: &str, detail: &str) -> Error {
    Error::Corrupt {
        what: what.into(),
        detail: detail.into(),
    }
}

pub(crate) fn spatial_entry(
    s: &crate::compiled::CSpatial,
    rec: &NodeRec,
) -> Option<crate::index::spatial::Aabb> {
    if !rec.has_label(s.label) {
        return None;
    }
    if let Some(b) = s.bbox.and_then(|k| rec.get(k)).and_then(Value::as_box3d) {
        return Some(b);
    }
    rec.get(s.position)
        .and_then(Value::as_point3)
        .map(|p| (p, p))
}

pub(crate) fn vector_entry(
    v: &crate::compiled::CVector,
    rec: &NodeRec,
) -> Option<crate::index::vector::Unit> {
    if !rec.has_label(v.label) {
        return None;
    }
    rec.get(v.key)
        .and_then(Value::as_vector)
        .filter(|x| x.len() == v.params.dim)
        .and_then(normalize)
}

pub(crate) fn text_entry(t: &crate::compiled::CText, rec: &NodeRec) -> Option<Doc> {
    if !rec.has_label(t.label) {
        return None;
    }
    match rec.get(t.key)? {
        Value::String(s) => Some(Doc::from_text(s)),
        Value::List(items) => {
            let joined: Vec<&str> = items.iter().filter_map(Value::as_str).collect();
            Some(Doc::from_text(&joined.join(" ")))
        }
        _ => None,
    }
}

pub(crate) fn u64_meta(bytes: Option<&[u8]>, what: &str) -> Result<u64> {
    let b = bytes.ok_or_else(|| codec_err(what, "missing"))?;
    <[u8; 8]>::try_from(b)
        .map(u64::from_le_bytes)
        .map_err(|_| codec_err(what, "not 8 bytes"))
}

/// A decoded node record: sorted label ids and sorted `(key id, value)` pairs.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct NodeRec {
    pub(crate) labels: Vec<u32>,
    pub(crate) props: Vec<(u32, Value)>,
}

impl NodeRec {
    pub(crate) fn has_label(&self, l: u32) -> bool {
        self.labels.binary_search(&l).is_ok()
    }
    pub(crate) fn get(&self, k: u32) -> Option<&Value> {
        self.props
            .binary_search_by_key(&k, |(x, _)| *x)
            .ok()
            .map(|i| &self.props[i].1)
    }
    pub(crate) fn decode(bytes: &[u8], id: u64) -> Result<NodeRec> {
        let (labels, props) = codec::decode_node(bytes).map_err(in_record("node", id))?;
        Ok(NodeRec { labels, props })
    }

    /// [`NodeRec::decode`] with only the properties whose key is in `keep` (sorted).
    pub(crate) fn decode_keys(bytes: &[u8], id: u64, keep: &[u32]) -> Result<NodeRec> {
        let (labels, props) =
            codec::decode_node_keys(bytes, keep).map_err(in_record("node", id))?;
        Ok(NodeRec { labels, props })
    }
}

/// Names the record in a codec's corruption error ("node 7", "relationship 9").
pub(crate) fn in_record(kind: &'static str, id: u64) -> impl FnOnce(Error) -> Error {
    move |e| match e {
        Error::Corrupt { detail, .. } => corrupt(format!("{kind} {id}"), detail),
        other => other,
    }
}

pub(crate) fn decode_rel(bytes: &[u8], id: u64) -> Result<Relationship> {
    let (ty, start, end, props) =
        codec::decode_rel(bytes).map_err(in_record("relationship", id))?;
    Ok(Relationship {
        id,
        ty: RelType(ty),
        start,
        end,
        props: typed_props(props),
    })
}
