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
    /// The nodes each of the last commits changed, up to this one.
    pub(crate) changes: ChangeLog,
}

/// Commits a [`ChangeLog`] remembers.
pub(crate) const CHANGE_LOG_COMMITS: usize = 64;
/// Nodes one commit may change and still be listed in a [`ChangeLog`] (a bulk load is not).
pub(crate) const CHANGE_LOG_NODES: usize = 4096;

/// The nodes that each of the last [`CHANGE_LOG_COMMITS`] commits changed, oldest first:
/// `(commit sequence, node ids ascending)`, or `None` for a commit whose changes are not
/// listed (more than [`CHANGE_LOG_NODES`] nodes, or a schema change). A node is changed when
/// its record or payloads were written, created or deleted, or a relationship it is an end of
/// was created, deleted or given new properties. Lets a reader that keeps something derived
/// from an earlier commit bring it up to date instead of deriving it again
/// ([`crate::GraphRead::nodes_changed_since`]).
#[derive(Debug, Clone, Default)]
pub(crate) struct ChangeLog(std::collections::VecDeque<(u64, Option<Arc<[u64]>>)>);

impl ChangeLog {
    /// This log with commit `seq`'s changes added (the oldest dropped past the limit).
    pub(crate) fn then(&self, seq: u64, changed: Option<Arc<[u64]>>) -> ChangeLog {
        let mut log = self.0.clone();
        log.push_back((seq, changed));
        while log.len() > CHANGE_LOG_COMMITS {
            log.pop_front();
        }
        ChangeLog(log)
    }

    /// The nodes changed by the commits after `from` up to `to` (the log's own last commit),
    /// ascending; `None` when the log does not reach back to `from`, or a commit on the way
    /// is not listed. Empty when `from == to`.
    pub(crate) fn since(&self, from: u64, to: u64) -> Option<Vec<u64>> {
        if from >= to {
            return (from == to).then(Vec::new);
        }
        let start = self.0.iter().position(|(s, _)| *s == from + 1)?;
        let mut out = Vec::new();
        for (s, changed) in self.0.iter().skip(start) {
            if *s > to {
                break;
            }
            out.extend_from_slice(changed.as_deref()?);
        }
        out.sort_unstable();
        out.dedup();
        Some(out)
    }
}

/// The nodes one write transaction changed (see [`ChangeLog`]), or that there were too many.
#[derive(Debug, Default)]
pub(crate) struct Touched {
    ids: Vec<u64>,
    overflow: bool,
}

impl Touched {
    /// Notes that node `id` changed.
    pub(crate) fn add(&mut self, id: u64) {
        if self.overflow {
            return;
        }
        self.ids.push(id);
        if self.ids.len() > 2 * CHANGE_LOG_NODES {
            self.compact();
        }
    }

    /// Notes that changes went unlisted (the log then says it does not know).
    pub(crate) fn lose_track(&mut self) {
        self.overflow = true;
        self.ids = Vec::new();
    }

    fn compact(&mut self) {
        self.ids.sort_unstable();
        self.ids.dedup();
        if self.ids.len() > CHANGE_LOG_NODES {
            self.lose_track();
        }
    }

    /// The changed nodes, ascending, or `None` when they were not all listed.
    pub(crate) fn into_list(mut self) -> Option<Arc<[u64]>> {
        self.compact();
        (!self.overflow).then(|| self.ids.into())
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn log(entries: &[(u64, Option<&[u64]>)]) -> ChangeLog {
        let mut l = ChangeLog::default();
        for (seq, ids) in entries {
            l = l.then(*seq, ids.map(Arc::from));
        }
        l
    }

    #[test]
    fn the_change_log_unites_the_commits_after_a_point() {
        let l = log(&[(1, Some(&[5, 9])), (2, Some(&[])), (3, Some(&[9, 2]))]);
        assert_eq!(l.since(0, 3), Some(vec![2, 5, 9]));
        assert_eq!(l.since(1, 3), Some(vec![2, 9]));
        assert_eq!(l.since(2, 3), Some(vec![2, 9]));
        assert_eq!(l.since(3, 3), Some(vec![]));
        // up to an earlier commit: the log of that commit ends there
        assert_eq!(l.since(0, 1), Some(vec![5, 9]));
        // from a later commit, or from before the log
        assert_eq!(l.since(4, 3), None);
        let short = log(&[(7, Some(&[1])), (8, Some(&[2]))]);
        assert_eq!(short.since(5, 8), None);
        assert_eq!(short.since(6, 8), Some(vec![1, 2]));
    }

    #[test]
    fn an_unlisted_commit_makes_the_changes_across_it_unknown() {
        let l = log(&[(1, Some(&[1])), (2, None), (3, Some(&[3]))]);
        assert_eq!(l.since(0, 3), None);
        assert_eq!(l.since(1, 3), None);
        assert_eq!(l.since(2, 3), Some(vec![3]));
    }

    #[test]
    fn the_change_log_keeps_the_last_commits_only() {
        let mut l = ChangeLog::default();
        for seq in 1..=(CHANGE_LOG_COMMITS as u64 + 10) {
            l = l.then(seq, Some(Arc::from(vec![seq])));
        }
        let last = CHANGE_LOG_COMMITS as u64 + 10;
        assert_eq!(l.since(9, last), None);
        assert_eq!(l.since(10, last).map(|v| v.len()), Some(CHANGE_LOG_COMMITS));
    }

    #[test]
    fn a_transaction_touching_too_many_nodes_is_not_listed() {
        let mut t = Touched::default();
        for id in 0..CHANGE_LOG_NODES as u64 {
            t.add(id);
            t.add(id);
        }
        assert_eq!(t.into_list().map(|l| l.len()), Some(CHANGE_LOG_NODES));
        let mut t = Touched::default();
        for id in 0..=CHANGE_LOG_NODES as u64 * 3 {
            t.add(id);
        }
        assert_eq!(t.into_list(), None);
    }
}
