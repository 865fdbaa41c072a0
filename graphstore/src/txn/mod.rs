//! Read and write transactions.

use std::collections::HashMap;
use std::ops::Bound;
use std::sync::{Arc, OnceLock};

use redb::{ReadOnlyTable, ReadTransaction, ReadableTable, Table, WriteTransaction};

use crate::codec::{self, sort_key};
use crate::compiled::Compiled;
use crate::error::{Error, Result, corrupt, storage};
use crate::layout::{
    ADJ, COUNTS, Committed, K_NEXT_NODE, K_NEXT_REL, LABELS, META, NODES, NodeRec, PAYLOADS,
    PROPIDX, PendingMem, RELS, TOKENS, decode_rel, in_record, spatial_entry, text_entry, u64_meta,
    vector_entry,
};
use crate::model::{Relationship, raw_normalized, raw_props};
use crate::payload::PointCloud;
use crate::read::{GraphRead, Raw, View};
use crate::tokens::{LabelId, PropKey, RelType, TokenKind};
use crate::value::Value;

mod install;
mod rels;
pub(crate) use rels::EndLabels;
mod validate;

/// A read snapshot. Holds the redb read transaction and the matching index state.
///
/// Its tables are opened on first use (a statement that reads one index and a
/// few records opens three or four of the eight: opening a table is a B-tree lookup in redb's
/// table of tables).
pub struct ReadTxn {
    /// The commit's read transaction, shared by every reader of it (see `Store::read`).
    txn: Arc<ReadTransaction>,
    base: Arc<Committed>,
    format: u32,
    meta: OnceLock<ReadOnlyTable<&'static str, &'static [u8]>>,
    nodes: OnceLock<ReadOnlyTable<u64, &'static [u8]>>,
    rels: OnceLock<ReadOnlyTable<u64, &'static [u8]>>,
    adj: OnceLock<crate::adjacency::AdjTable>,
    labels: OnceLock<ReadOnlyTable<(u32, u64), ()>>,
    propidx: OnceLock<ReadOnlyTable<&'static [u8], ()>>,
    counts: OnceLock<ReadOnlyTable<(u8, u32), u64>>,
    payloads: OnceLock<ReadOnlyTable<(u64, &'static str), &'static [u8]>>,
}

/// `ReadTxn::t_NAME()`: table `NAME`, opened on its first use.
macro_rules! lazy_tables {
    ($($name:ident: $field:ident = $def:expr => $ty:ty;)*) => {
        impl ReadTxn {
            $(
                fn $name(&self) -> Result<&$ty> {
                    if let Some(t) = self.$field.get() {
                        return Ok(t);
                    }
                    let t = self.txn.open_table($def).map_err(storage)?;
                    Ok(self.$field.get_or_init(|| t))
                }
            )*
        }
    };
}

lazy_tables! {
    t_meta: meta = META => ReadOnlyTable<&'static str, &'static [u8]>;
    t_nodes: nodes = NODES => ReadOnlyTable<u64, &'static [u8]>;
    t_rels: rels = RELS => ReadOnlyTable<u64, &'static [u8]>;
    t_labels: labels = LABELS => ReadOnlyTable<(u32, u64), ()>;
    t_propidx: propidx = PROPIDX => ReadOnlyTable<&'static [u8], ()>;
    t_payloads: payloads = PAYLOADS => ReadOnlyTable<(u64, &'static str), &'static [u8]>;
    t_counts: counts = COUNTS => ReadOnlyTable<(u8, u32), u64>;
}

impl std::fmt::Debug for ReadTxn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReadTxn").finish_non_exhaustive()
    }
}

impl ReadTxn {
    /// `format`: the store's format version (1: format 1's adjacency, read as it is).
    pub(crate) fn new(
        txn: Arc<ReadTransaction>,
        base: Arc<Committed>,
        format: u32,
    ) -> Result<ReadTxn> {
        Ok(ReadTxn {
            txn,
            base,
            format,
            meta: OnceLock::new(),
            nodes: OnceLock::new(),
            rels: OnceLock::new(),
            adj: OnceLock::new(),
            labels: OnceLock::new(),
            propidx: OnceLock::new(),
            counts: OnceLock::new(),
            payloads: OnceLock::new(),
        })
    }

    /// The node (`nodes`) or relationship records table.
    fn t_records(&self, nodes: bool) -> Result<&ReadOnlyTable<u64, &'static [u8]>> {
        if nodes { self.t_nodes() } else { self.t_rels() }
    }

    /// The adjacency table, opened on first use (format 1's as it is).
    fn t_adj(&self) -> Result<&crate::adjacency::AdjTable> {
        if let Some(t) = self.adj.get() {
            return Ok(t);
        }
        let t = if self.format == 1 {
            crate::adjacency::AdjTable::V1(
                self.txn
                    .open_table(crate::adjacency::ADJ_V1)
                    .map_err(storage)?,
            )
        } else {
            crate::adjacency::AdjTable::Chunks(self.txn.open_table(ADJ).map_err(storage)?)
        };
        Ok(self.adj.get_or_init(|| t))
    }

    pub(crate) fn base(&self) -> &Arc<Committed> {
        &self.base
    }
}

/// The last node record a statement read from the node table (see
/// [`ReadTxn::node_prop_memo`]).
#[derive(Debug, Default)]
pub(crate) struct RecordMemo {
    id: Option<u64>,
    present: bool,
    bytes: Vec<u8>,
}

impl RecordMemo {
    /// Records longer than this are read in place, not kept.
    const MAX_BYTES: usize = 512;
}

/// A write transaction, alive inside [`crate::Store::write`]. It sees its own writes.
pub struct WriteTxn<'a> {
    base: Arc<Committed>,
    schema: Arc<Compiled>,
    pending: PendingMem,
    new_tokens: Vec<String>,
    new_token_ids: HashMap<String, u32>,
    /// Count changes, written to the counts table once at the end.
    count_deltas: HashMap<(u8, u32), i64>,
    next_node: u64,
    next_rel: u64,
    meta: Table<'a, &'static str, &'static [u8]>,
    tokens: Table<'a, u32, &'static str>,
    nodes: Table<'a, u64, &'static [u8]>,
    rels: Table<'a, u64, &'static [u8]>,
    adj: Table<'a, crate::adjacency::ChunkKey, &'static [u8]>,
    labels: Table<'a, (u32, u64), ()>,
    propidx: Table<'a, &'static [u8], ()>,
    counts: Table<'a, (u8, u32), u64>,
    payloads: Table<'a, (u64, &'static str), &'static [u8]>,
    /// The nodes this transaction changed, for the commit's [`crate::layout::ChangeLog`].
    touched: crate::layout::Touched,
}

impl std::fmt::Debug for WriteTxn<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WriteTxn")
            .field("next_node", &self.next_node)
            .field("next_rel", &self.next_rel)
            .finish_non_exhaustive()
    }
}

/// The writer's tables under the reader's accessor names (open for the whole transaction).
impl<'a> WriteTxn<'a> {
    fn t_meta(&self) -> Result<&Table<'a, &'static str, &'static [u8]>> {
        Ok(&self.meta)
    }
    fn t_nodes(&self) -> Result<&Table<'a, u64, &'static [u8]>> {
        Ok(&self.nodes)
    }
    fn t_rels(&self) -> Result<&Table<'a, u64, &'static [u8]>> {
        Ok(&self.rels)
    }
    fn t_adj(&self) -> Result<&Table<'a, crate::adjacency::ChunkKey, &'static [u8]>> {
        Ok(&self.adj)
    }
    fn t_labels(&self) -> Result<&Table<'a, (u32, u64), ()>> {
        Ok(&self.labels)
    }
    fn t_propidx(&self) -> Result<&Table<'a, &'static [u8], ()>> {
        Ok(&self.propidx)
    }
    fn t_counts(&self) -> Result<&Table<'a, (u8, u32), u64>> {
        Ok(&self.counts)
    }
    fn t_payloads(&self) -> Result<&Table<'a, (u64, &'static str), &'static [u8]>> {
        Ok(&self.payloads)
    }
}

/// The low-level reads are the same code over read-only and writable redb tables.
macro_rules! raw_reads {
    () => {
        fn load_rec(&self, id: u64) -> Result<Option<NodeRec>> {
            if let Some(hot) = self.hot_records(true) {
                return hot.get(id).map(|b| NodeRec::decode(b, id)).transpose();
            }
            match self.t_nodes()?.get(&id).map_err(storage)? {
                Some(g) => Ok(Some(NodeRec::decode(g.value(), id)?)),
                None => Ok(None),
            }
        }

        fn load_rec_keys(&self, id: u64, keep: &[u32]) -> Result<Option<NodeRec>> {
            if let Some(hot) = self.hot_records(true) {
                return hot
                    .get(id)
                    .map(|b| NodeRec::decode_keys(b, id, keep))
                    .transpose();
            }
            match self.t_nodes()?.get(&id).map_err(storage)? {
                Some(g) => Ok(Some(NodeRec::decode_keys(g.value(), id, keep)?)),
                None => Ok(None),
            }
        }

        fn load_rel(&self, id: u64) -> Result<Option<Relationship>> {
            if let Some(hot) = self.hot_records(false) {
                return hot.get(id).map(|b| decode_rel(b, id)).transpose();
            }
            match self.t_rels()?.get(&id).map_err(storage)? {
                Some(g) => Ok(Some(decode_rel(g.value(), id)?)),
                None => Ok(None),
            }
        }

        fn load_rel_prop(&self, id: u64, key: u32) -> Result<Option<Value>> {
            if let Some(hot) = self.hot_records(false) {
                return match hot.get(id) {
                    Some(b) => codec::rel_prop(b, key).map_err(in_record("relationship", id)),
                    None => Ok(None),
                };
            }
            match self.t_rels()?.get(&id).map_err(storage)? {
                Some(g) => codec::rel_prop(g.value(), key).map_err(in_record("relationship", id)),
                None => Ok(None),
            }
        }

        fn adj(&self, node: u64, dir: u8, ty: Option<u32>) -> Result<Vec<(u64, u32, u64)>> {
            if let Some(hot) = self.hot_adjacency() {
                return Ok(hot.get(node, dir, ty));
            }
            crate::adjacency::AdjRead::adj_read(self.t_adj()?, node, dir, ty)
        }

        fn label_nodes(&self, label: u32) -> Result<Vec<u64>> {
            let mut out = Vec::new();
            for row in self
                .t_labels()?
                .range((label, 0u64)..=(label, u64::MAX))
                .map_err(storage)?
            {
                let (k, _) = row.map_err(storage)?;
                out.push(k.value().1);
            }
            Ok(out)
        }

        fn propidx(&self, lo: Bound<&[u8]>, hi: Bound<&[u8]>) -> Result<Vec<u64>> {
            let mut out = Vec::new();
            for row in self
                .t_propidx()?
                .range::<&[u8]>((lo, hi))
                .map_err(storage)?
            {
                let (k, _) = row.map_err(storage)?;
                let key = k.value();
                let tail = key.len().checked_sub(8).map(|s| &key[s..]);
                let id = tail
                    .and_then(|t| <[u8; 8]>::try_from(t).ok())
                    .map(u64::from_be_bytes)
                    .ok_or_else(|| corrupt("property index", "short key"))?;
                out.push(id);
            }
            Ok(out)
        }

        fn count_rows(&self) -> Result<Vec<((u8, u32), u64)>> {
            let mut out = std::collections::BTreeMap::new();
            for row in self.t_counts()?.iter().map_err(storage)? {
                let (k, v) = row.map_err(storage)?;
                out.insert(k.value(), v.value());
            }
            for (k, d) in self.deltas() {
                let e = out.entry(*k).or_insert(0u64);
                *e = e.saturating_add_signed(*d);
            }
            Ok(out.into_iter().filter(|(_, n)| *n > 0).collect())
        }

        fn payload(&self, node: u64, key: &str) -> Result<Option<Vec<u8>>> {
            Ok(self
                .t_payloads()?
                .get(&(node, key))
                .map_err(storage)?
                .map(|g| g.value().to_vec()))
        }

        fn payload_keys(&self, node: u64) -> Result<Vec<String>> {
            let mut out = Vec::new();
            for row in self
                .t_payloads()?
                .range((node, "")..(node.saturating_add(1), ""))
                .map_err(storage)?
            {
                let (k, _) = row.map_err(storage)?;
                let (n, key) = k.value();
                if n == node {
                    out.push(key.to_string());
                }
            }
            Ok(out)
        }

        fn all_nodes(&self) -> Result<Vec<u64>> {
            let mut out = Vec::new();
            for row in self.t_nodes()?.iter().map_err(storage)? {
                out.push(row.map_err(storage)?.0.value());
            }
            Ok(out)
        }

        fn all_rels(&self) -> Result<Vec<u64>> {
            let mut out = Vec::new();
            for row in self.t_rels()?.iter().map_err(storage)? {
                out.push(row.map_err(storage)?.0.value());
            }
            Ok(out)
        }

        fn raw_adjacency_rows(&self) -> Result<Vec<crate::read::AdjRow>> {
            crate::adjacency::AdjRead::adj_rows(self.t_adj()?)?.collect()
        }

        fn raw_label_rows(&self) -> Result<Vec<(u32, u64)>> {
            let mut out = Vec::new();
            for row in self.t_labels()?.iter().map_err(storage)? {
                out.push(row.map_err(storage)?.0.value());
            }
            Ok(out)
        }

        fn raw_propidx_rows(&self) -> Result<Vec<Vec<u8>>> {
            let mut out = Vec::new();
            for row in self.t_propidx()?.iter().map_err(storage)? {
                out.push(row.map_err(storage)?.0.value().to_vec());
            }
            Ok(out)
        }

        fn next_ids(&self) -> Result<(u64, u64)> {
            let n = self.t_meta()?.get(K_NEXT_NODE).map_err(storage)?;
            let r = self.t_meta()?.get(K_NEXT_REL).map_err(storage)?;
            Ok((
                u64_meta(n.as_ref().map(|g| g.value()), K_NEXT_NODE)?,
                u64_meta(r.as_ref().map(|g| g.value()), K_NEXT_REL)?,
            ))
        }
    };
}

impl Raw for ReadTxn {
    fn base(&self) -> &Arc<Committed> {
        &self.base
    }
    fn pending_mem(&self) -> Option<&PendingMem> {
        None
    }
    fn mem(&self) -> Result<&crate::layout::Mem> {
        self.base.mem.get_or_build(|| crate::store::build_mem(self))
    }
    fn token(&self, kind: TokenKind, name: &str) -> Option<u32> {
        self.base.tokens.get(kind, name)
    }
    fn token_name(&self, id: u32) -> Option<String> {
        self.base.tokens.name(id).map(str::to_string)
    }
    fn propidx_eq(&self, index: u32, sort_key: &[u8]) -> Result<Vec<u64>> {
        let lazy = self.base.hot.prop_eq.get(index);
        if let Some(m) = lazy.get(|| self.total(0), || self.copy_property_index(index)) {
            return Ok(m.get(sort_key));
        }
        crate::read::propidx_eq_scan(self, index, sort_key)
    }
    raw_reads!();
}

impl Raw for WriteTxn<'_> {
    fn base(&self) -> &Arc<Committed> {
        &self.base
    }
    fn pending_mem(&self) -> Option<&PendingMem> {
        Some(&self.pending)
    }
    fn mem(&self) -> Result<&crate::layout::Mem> {
        self.base
            .mem
            .get()
            .ok_or_else(|| corrupt("in-memory indexes", "the writer's base has none built"))
    }
    fn token(&self, kind: TokenKind, name: &str) -> Option<u32> {
        self.base
            .tokens
            .get(kind, name)
            .or_else(|| self.new_token_ids.get(&kind.qualify(name)).copied())
    }
    fn token_name(&self, id: u32) -> Option<String> {
        let committed = self.base.tokens.len();
        if id < committed {
            self.base.tokens.name(id).map(str::to_string)
        } else {
            self.new_tokens
                .get((id - committed) as usize)
                .map(|q| q[2..].to_string())
        }
    }
    raw_reads!();
}

impl ReadTxn {
    /// Property index `index` read into memory in one pass (None: too large, or unreadable).
    pub(crate) fn copy_property_index(&self, index: u32) -> Option<crate::hot::EqIndex> {
        let lo = crate::read::index_prefix(index);
        let hi = index.checked_add(1).map(crate::read::index_prefix);
        let upper = hi.as_deref().map_or(Bound::Unbounded, Bound::Excluded);
        let range = self
            .t_propidx()
            .ok()?
            .range::<&[u8]>((Bound::Included(lo.as_slice()), upper))
            .ok()?;
        let rows = range.map(|row| {
            let (k, _) = row.map_err(storage)?;
            let key = k.value();
            let split = key
                .len()
                .checked_sub(8)
                .filter(|s| *s >= lo.len())
                .ok_or_else(|| corrupt("property index", "short key"))?;
            let id = <[u8; 8]>::try_from(&key[split..])
                .map(u64::from_be_bytes)
                .map_err(|_| corrupt("property index", "short key"))?;
            Ok((key[lo.len()..split].to_vec(), id))
        });
        match crate::hot::EqIndex::from_entries(rows) {
            Ok(m) => m,
            Err(e) => {
                tracing::warn!(error = %e, "property index not copied into memory");
                None
            }
        }
    }

    /// How many nodes (`which` 0) or relationships (1) the store holds (0 if unreadable).
    fn total(&self, which: u32) -> u64 {
        let Ok(counts) = self.t_counts() else {
            return 0;
        };
        match counts.get((2u8, which)) {
            Ok(Some(g)) => g.value(),
            _ => 0,
        }
    }

    /// The commit's in-memory adjacency, once enough asks made it worth building (see
    /// [`crate::hot`]).
    fn hot_adjacency(&self) -> Option<Arc<crate::hot::AdjMem>> {
        self.base
            .hot
            .adj
            .get(|| 2 * self.total(1), || self.copy_adjacency())
    }

    /// The adjacency in memory: an earlier commit's copy with the changed nodes' rows read
    /// again when there is one ([`crate::hot::Seed`]), else [`ReadTxn::copy_adjacency_whole`].
    fn copy_adjacency(&self) -> Option<crate::hot::AdjMem> {
        if let Some((seq, old)) = self.base.hot.seed.take_adj()
            && let Some(changed) = self.nodes_changed_since(seq)
        {
            let t = self.t_adj().ok()?;
            let fresh = |n: u64| -> Result<Vec<crate::adjacency::AdjRow>> {
                let mut rows = Vec::new();
                for dir in 0..2u8 {
                    for (rel, ty, other) in crate::adjacency::AdjRead::adj_read(t, n, dir, None)? {
                        rows.push(((n, dir, ty, rel), other));
                    }
                }
                Ok(rows)
            };
            match old.patched(&changed, fresh) {
                Ok(m) => return m,
                Err(e) => tracing::warn!(error = %e, "adjacency not brought up to date"),
            }
        }
        self.copy_adjacency_whole()
    }

    /// The adjacency table read into memory in one pass (None: too large, or unreadable).
    pub(crate) fn copy_adjacency_whole(&self) -> Option<crate::hot::AdjMem> {
        let rows = crate::adjacency::AdjRead::adj_rows(self.t_adj().ok()?).ok()?;
        match crate::hot::AdjMem::from_rows(rows) {
            Ok(m) => m,
            Err(e) => {
                tracing::warn!(error = %e, "adjacency not copied into memory");
                None
            }
        }
    }

    /// The commit's node (`nodes`) or relationship records in memory, once enough reads made
    /// it worth copying them (see [`crate::hot`]).
    fn hot_records(&self, nodes: bool) -> Option<Arc<crate::hot::RecordsMem>> {
        let (lazy, which) = if nodes {
            (&self.base.hot.nodes, 0)
        } else {
            (&self.base.hot.rels, 1)
        };
        lazy.get(
            || self.total(which),
            || {
                let mut m = crate::hot::RecordsMem::new();
                for row in self.t_records(nodes).ok()?.iter().ok()? {
                    match row {
                        Ok((k, v)) if m.push(k.value(), v.value()) => {}
                        Ok(_) => return None,
                        Err(e) => {
                            tracing::warn!(error = %e, "records not copied into memory");
                            return None;
                        }
                    }
                }
                Some(m)
            },
        )
    }

    fn deltas(&self) -> std::iter::Empty<(&(u8, u32), &i64)> {
        std::iter::empty()
    }

    /// The commit's adjacency in memory, once it is built or due (each call is one ask; see
    /// [`crate::hot`]); with `force`, built now.
    pub(crate) fn adjacency_mem(&self, force: bool) -> Option<Arc<crate::hot::AdjMem>> {
        if force {
            return self.base.hot.adj.force(|| self.copy_adjacency());
        }
        self.hot_adjacency()
    }

    /// The nodes of label `label`, read from the label index once per commit and shared by
    /// every reader of it.
    pub(crate) fn label_members(&self, label: u32) -> Result<Arc<crate::columns::LabelMembers>> {
        let cell = self.base.hot.labels.get(label);
        if let Some(m) = cell.get() {
            return Ok(m.clone());
        }
        // the list outlives the statement that reads it: not charged to its memory budget
        let members = crate::mem::uncounted(|| self.label_members_now(label))?;
        Ok(cell.get_or_init(|| Arc::new(members)).clone())
    }

    /// The nodes of `label`: an earlier commit's list with the changed nodes checked again
    /// when there is one ([`crate::hot::Seed`]), else read from the label index.
    fn label_members_now(&self, label: u32) -> Result<crate::columns::LabelMembers> {
        if let Some((seq, old)) = self.base.hot.seed.take_labels(label)
            && let Some(changed) = self.nodes_changed_since(seq)
        {
            return old.patched(&changed, |id| {
                Ok(match self.t_nodes()?.get(&id).map_err(storage)? {
                    Some(g) => codec::node_labels(g.value())?.contains(&label),
                    None => false,
                })
            });
        }
        Ok(crate::columns::LabelMembers::new(self.label_nodes(label)?))
    }

    /// The nodes of `label` if a reader of this commit has read them already.
    pub(crate) fn label_members_if_read(
        &self,
        label: u32,
    ) -> Option<Arc<crate::columns::LabelMembers>> {
        self.base.hot.labels.get(label).get().cloned()
    }

    /// The state of the node (`nodes`) or relationship column of property `key` in this
    /// commit: resolve it once, then ask [`ReadTxn::column`] per read.
    pub(crate) fn column_state(
        &self,
        nodes: bool,
        key: u32,
    ) -> Arc<crate::hot::Lazy<crate::columns::Column>> {
        if nodes {
            self.base.hot.node_columns.get(key)
        } else {
            self.base.hot.rel_columns.get(key)
        }
    }

    /// The column behind `state` (from [`ReadTxn::column_state`]) once it is built or due:
    /// after as many reads of the property in this commit as a record copy waits for (see
    /// [`crate::hot::Lazy::get`]); None before, or when the table cannot be a column.
    pub(crate) fn column(
        &self,
        state: &crate::hot::Lazy<crate::columns::Column>,
        nodes: bool,
        key: u32,
        force: bool,
    ) -> Option<Arc<crate::columns::Column>> {
        if force {
            return state.force(|| self.build_column(nodes, key));
        }
        state.get(
            || self.total(if nodes { 0 } else { 1 }),
            || self.build_column(nodes, key),
        )
    }

    /// Property `key` of every node or relationship: for nodes, an earlier commit's column
    /// with the changed nodes read again when there is one ([`crate::hot::Seed`]); else read
    /// in one pass.
    fn build_column(&self, nodes: bool, key: u32) -> Option<crate::columns::Column> {
        if nodes
            && let Some((seq, old)) = self.base.hot.seed.take_column(key)
            && let Some(changed) = self.nodes_changed_since(seq)
        {
            let value = |id: u64| -> Result<Option<Value>> {
                match self.t_nodes()?.get(&id).map_err(storage)? {
                    Some(g) => codec::node_prop(g.value(), key),
                    None => Ok(None),
                }
            };
            match old.patched(&changed, value) {
                Ok(c) => return c,
                Err(e) => tracing::warn!(error = %e, "column not brought up to date"),
            }
        }
        self.build_column_whole(nodes, key)
    }

    /// Property `key` of every node or relationship, read in one pass.
    pub(crate) fn build_column_whole(
        &self,
        nodes: bool,
        key: u32,
    ) -> Option<crate::columns::Column> {
        let mut b = crate::columns::ColumnBuilder::default();
        let one = |bytes: &[u8]| {
            if nodes {
                codec::node_prop(bytes, key)
            } else {
                codec::rel_prop(bytes, key)
            }
        };
        if let Some(hot) = self.hot_records(nodes) {
            for (id, bytes) in hot.iter() {
                if !b.push(id, one(bytes).ok()?) {
                    return None;
                }
            }
        } else {
            for row in self.t_records(nodes).ok()?.iter().ok()? {
                let (k, v) = row.ok()?;
                if !b.push(k.value(), one(v.value()).ok()?) {
                    return None;
                }
            }
        }
        b.finish()
    }

    /// Node (`which` 0) or relationship (1) total of the commit.
    pub(crate) fn total_of(&self, which: u32) -> u64 {
        self.total(which)
    }

    /// One property of a node, decoding only that value (None: no such node or property),
    /// through a one-record memo: a statement that reads several properties of one node in a
    /// row (a filter, then a projection) descends the node table once. `memo` is the
    /// statement's, and only valid in this snapshot.
    pub(crate) fn node_prop_memo(
        &self,
        id: u64,
        key: u32,
        memo: &mut RecordMemo,
    ) -> Result<Option<Value>> {
        let one = |b: &[u8]| codec::node_prop(b, key).map_err(in_record("node", id));
        if let Some(hot) = self.hot_records(true) {
            return hot.get(id).map(one).transpose().map(Option::flatten);
        }
        if memo.id != Some(id) {
            memo.id = None;
            memo.bytes.clear();
            memo.present = match self.t_nodes()?.get(&id).map_err(storage)? {
                // a large record (an embedding, a long text) is not copied to read one value
                Some(g) if g.value().len() > RecordMemo::MAX_BYTES => return one(g.value()),
                Some(g) => {
                    memo.bytes.extend_from_slice(g.value());
                    true
                }
                None => false,
            };
            memo.id = Some(id);
        }
        if memo.present {
            one(&memo.bytes)
        } else {
            Ok(None)
        }
    }

    /// Whether node `id` exists and carries label `label`, reading only its labels.
    pub(crate) fn node_has_label(&self, id: u64, label: u32) -> Result<bool> {
        let one = |b: &[u8]| codec::node_has_label(b, label).map_err(in_record("node", id));
        if let Some(hot) = self.hot_records(true) {
            return hot.get(id).map_or(Ok(false), one);
        }
        match self.t_nodes()?.get(&id).map_err(storage)? {
            Some(g) => one(g.value()),
            None => Ok(false),
        }
    }
}

impl WriteTxn<'_> {
    /// Never: a write transaction reads its own changes from the tables.
    fn hot_adjacency(&self) -> Option<Arc<crate::hot::AdjMem>> {
        None
    }

    /// Never, as for [`WriteTxn::hot_adjacency`].
    fn hot_records(&self, _nodes: bool) -> Option<Arc<crate::hot::RecordsMem>> {
        None
    }

    fn deltas(&self) -> impl Iterator<Item = (&(u8, u32), &i64)> {
        self.count_deltas.iter()
    }
}

impl GraphRead for ReadTxn {
    fn view(&self) -> View<'_> {
        View { raw: self }
    }

    fn commit_seq(&self) -> Option<u64> {
        Some(self.base.seq)
    }

    fn nodes_changed_since(&self, seq: u64) -> Option<Vec<u64>> {
        self.base.changes.since(seq, self.base.seq)
    }
}

impl GraphRead for WriteTxn<'_> {
    fn view(&self) -> View<'_> {
        View { raw: self }
    }
}

fn pidx_key(index: u32, v: &Value, node: u64) -> Option<Vec<u8>> {
    let sk = sort_key(v)?;
    let mut k = Vec::with_capacity(4 + sk.len() + 8);
    k.extend_from_slice(&index.to_be_bytes());
    k.extend_from_slice(&sk);
    k.extend_from_slice(&node.to_be_bytes());
    Some(k)
}

impl<'a> WriteTxn<'a> {
    pub(crate) fn new(txn: &'a WriteTransaction, base: Arc<Committed>) -> Result<WriteTxn<'a>> {
        let meta = txn.open_table(META).map_err(storage)?;
        let next_node = u64_meta(
            meta.get(K_NEXT_NODE)
                .map_err(storage)?
                .as_ref()
                .map(|g| g.value()),
            K_NEXT_NODE,
        )?;
        let next_rel = u64_meta(
            meta.get(K_NEXT_REL)
                .map_err(storage)?
                .as_ref()
                .map(|g| g.value()),
            K_NEXT_REL,
        )?;
        Ok(WriteTxn {
            schema: base.schema.clone(),
            pending: PendingMem::for_schema(&base.schema),
            base,
            new_tokens: Vec::new(),
            new_token_ids: HashMap::new(),
            count_deltas: HashMap::new(),
            next_node,
            next_rel,
            meta,
            tokens: txn.open_table(TOKENS).map_err(storage)?,
            nodes: txn.open_table(NODES).map_err(storage)?,
            rels: txn.open_table(RELS).map_err(storage)?,
            adj: txn.open_table(ADJ).map_err(storage)?,
            labels: txn.open_table(LABELS).map_err(storage)?,
            propidx: txn.open_table(PROPIDX).map_err(storage)?,
            counts: txn.open_table(COUNTS).map_err(storage)?,
            payloads: txn.open_table(PAYLOADS).map_err(storage)?,
            touched: Default::default(),
        })
    }

    /// Writes the id counters; returns the index changes, the new tokens and the changed
    /// nodes (None: not listed) for the commit.
    #[allow(clippy::type_complexity)]
    pub(crate) fn finish(mut self) -> Result<(PendingMem, Vec<String>, Option<Arc<[u64]>>)> {
        self.flush_counts()?;
        self.meta
            .insert(K_NEXT_NODE, self.next_node.to_le_bytes().as_slice())
            .map_err(storage)?;
        self.meta
            .insert(K_NEXT_REL, self.next_rel.to_le_bytes().as_slice())
            .map_err(storage)?;
        Ok((
            std::mem::take(&mut self.pending),
            std::mem::take(&mut self.new_tokens),
            std::mem::take(&mut self.touched).into_list(),
        ))
    }

    fn intern(&mut self, kind: TokenKind, name: &str) -> Result<u32> {
        if let Some(id) = Raw::token(self, kind, name) {
            return Ok(id);
        }
        if name.is_empty() {
            return Err(Error::InvalidValue(format!(
                "an empty {} is not allowed",
                kind.noun()
            )));
        }
        let q = kind.qualify(name);
        let id = self.base.tokens.len() + self.new_tokens.len() as u32;
        self.tokens.insert(id, q.as_str()).map_err(storage)?;
        self.new_token_ids.insert(q.clone(), id);
        self.new_tokens.push(q);
        Ok(id)
    }

    /// The id of a label, created if new.
    pub fn label_id(&mut self, name: &str) -> Result<LabelId> {
        self.intern(TokenKind::Label, name).map(LabelId)
    }

    /// The id of a relationship type, created if new.
    pub fn rel_type_id(&mut self, name: &str) -> Result<RelType> {
        self.intern(TokenKind::RelType, name).map(RelType)
    }

    /// The id of a property key, created if new.
    pub fn prop_key_id(&mut self, name: &str) -> Result<PropKey> {
        self.intern(TokenKind::PropKey, name).map(PropKey)
    }

    fn name(&self, id: u32) -> String {
        Raw::token_name(self, id).unwrap_or_else(|| format!("#{id}"))
    }

    // ---- counts ----

    fn bump(&mut self, kind: u8, tok: u32, delta: i64) -> Result<()> {
        *self.count_deltas.entry((kind, tok)).or_default() += delta;
        Ok(())
    }

    fn flush_counts(&mut self) -> Result<()> {
        let mut deltas: Vec<((u8, u32), i64)> =
            self.count_deltas.drain().filter(|(_, d)| *d != 0).collect();
        deltas.sort_unstable();
        for ((kind, tok), delta) in deltas {
            let cur = self
                .counts
                .get(&(kind, tok))
                .map_err(storage)?
                .map(|g| g.value())
                .unwrap_or(0);
            let next = cur.checked_add_signed(delta).ok_or_else(|| {
                corrupt(
                    "counts",
                    format!("count for ({kind}, {tok}) would go negative"),
                )
            })?;
            if next == 0 {
                self.counts.remove(&(kind, tok)).map_err(storage)?;
            } else {
                self.counts.insert(&(kind, tok), &next).map_err(storage)?;
            }
        }
        Ok(())
    }

    // ---- the single node write path ----

    /// Moves node `id` from `before` to `after`, keeping every index and count in step.
    /// Validation happens first, so an error leaves everything untouched.
    fn apply_node(
        &mut self,
        id: u64,
        before: Option<&NodeRec>,
        after: Option<&NodeRec>,
    ) -> Result<()> {
        if let Some(a) = after {
            self.check_node(id, a)?;
        }
        match after {
            Some(a) => {
                let bytes = codec::encode_node(&a.labels, &a.props);
                self.nodes.insert(&id, bytes.as_slice()).map_err(storage)?;
            }
            None => {
                self.nodes.remove(&id).map_err(storage)?;
            }
        }
        self.apply_node_indexes(id, before, after, None)
    }

    /// The rest of [`WriteTxn::apply_node`] once the record is written: the label index,
    /// the counts and the property, spatial, vector and text indexes. With `label_rows`,
    /// new label index rows are pushed there for the caller to write instead.
    fn apply_node_indexes(
        &mut self,
        id: u64,
        before: Option<&NodeRec>,
        after: Option<&NodeRec>,
        mut label_rows: Option<&mut Vec<(u32, u64)>>,
    ) -> Result<()> {
        self.touched.add(id);
        let empty = NodeRec::default();
        let b = before.unwrap_or(&empty);
        let a = after.unwrap_or(&empty);
        for l in b.labels.iter().filter(|l| !a.has_label(**l)) {
            self.labels.remove(&(*l, id)).map_err(storage)?;
            self.bump(0, *l, -1)?;
        }
        for l in a.labels.iter().filter(|l| !b.has_label(**l)) {
            match label_rows.as_deref_mut() {
                Some(rows) => rows.push((*l, id)),
                None => {
                    self.labels.insert(&(*l, id), &()).map_err(storage)?;
                }
            }
            self.bump(0, *l, 1)?;
        }
        match (before.is_some(), after.is_some()) {
            (false, true) => self.bump(2, 0, 1)?,
            (true, false) => self.bump(2, 0, -1)?,
            _ => {}
        }
        let schema = self.schema.clone();
        for (i, pi) in schema.prop_indexes.iter().enumerate() {
            let key_of = |r: &NodeRec| {
                if r.has_label(pi.label) {
                    r.get(pi.key).and_then(|v| pidx_key(i as u32, v, id))
                } else {
                    None
                }
            };
            let (old, new) = (key_of(b), key_of(a));
            if old != new {
                if let Some(k) = old {
                    self.propidx.remove(k.as_slice()).map_err(storage)?;
                }
                if let Some(k) = new {
                    self.propidx.insert(k.as_slice(), &()).map_err(storage)?;
                }
            }
        }
        for (i, s) in schema.spatial.iter().enumerate() {
            let (old, new) = (spatial_entry(s, b), spatial_entry(s, a));
            if old != new {
                self.pending.spatial[i].set(id, new);
            }
        }
        for (i, v) in schema.vector.iter().enumerate() {
            let (old, new) = (vector_entry(v, b), vector_entry(v, a));
            if old != new {
                self.pending.vector[i].set(id, new);
            }
        }
        for (i, t) in schema.text.iter().enumerate() {
            let (old, new) = (text_entry(t, b), text_entry(t, a));
            if old != new {
                self.pending.text[i].set(id, new);
            }
        }
        Ok(())
    }

    fn rec(&self, id: u64) -> Result<NodeRec> {
        Raw::load_rec(self, id)?.ok_or(Error::NodeNotFound(id))
    }

    /// A node's labels (sorted), decoding nothing else. `None` when there is no such node.
    fn node_labels(&self, id: u64) -> Result<Option<Vec<u32>>> {
        match self.nodes.get(&id).map_err(storage)? {
            Some(g) => Ok(Some(codec::node_labels(g.value())?)),
            None => Ok(None),
        }
    }

    // ---- public writes ----

    /// Creates a node. Null property values are dropped; of duplicate keys the last wins.
    pub fn create_node(&mut self, labels: &[LabelId], props: Vec<(PropKey, Value)>) -> Result<u64> {
        let rec = new_rec(labels, props);
        let id = self.next_node;
        self.apply_node(id, None, Some(&rec))?;
        self.next_node += 1;
        Ok(id)
    }

    /// Re-creates a deleted node under its old id (for undoing an edit exactly): the id must
    /// have been handed out before and be free now.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when the id was never used or a node has it; schema errors as
    /// for [`WriteTxn::create_node`].
    pub fn restore_node(
        &mut self,
        id: u64,
        labels: &[LabelId],
        props: Vec<(PropKey, Value)>,
    ) -> Result<()> {
        if id >= self.next_node || Raw::load_rec(self, id)?.is_some() {
            return Err(Error::InvalidValue(format!(
                "cannot restore node {id}: the id is in use or was never handed out"
            )));
        }
        let rec = new_rec(labels, props);
        self.apply_node(id, None, Some(&rec))
    }

    /// Re-creates many nodes under their ids, as [`WriteTxn::restore_node`] does one by one
    /// (a bulk load keeping its files' ids). When the ids ascend past every stored node and no
    /// label has a unique property, the records and the label index rows are appended through
    /// table cursors (full leaves, no descent per row); otherwise the nodes go in one by one.
    ///
    /// # Errors
    /// As [`WriteTxn::restore_node`], with the index of the failing row; the transaction is
    /// then to be dropped (rows before it may be written).
    pub(crate) fn restore_nodes(
        &mut self,
        rows: Vec<crate::model::RestoredNode>,
    ) -> std::result::Result<(), (usize, Error)> {
        let n = rows.len();
        let last = self
            .nodes
            .last()
            .map_err(|e| (0, storage(e)))?
            .map(|(k, _)| k.value());
        let ascending = rows.windows(2).all(|w| w[0].0 < w[1].0)
            && rows.first().is_none_or(|r| last.is_none_or(|l| r.0 > l))
            && rows.last().is_none_or(|r| r.0 < self.next_node);
        // a unique property is checked against the stored nodes, which the appended ones
        // are not until the end
        let unique = self.schema.labels.values().any(|r| !r.unique.is_empty());
        if !ascending || unique {
            for (i, (id, labels, props)) in rows.into_iter().enumerate() {
                self.restore_node(id, &labels, props).map_err(|e| (i, e))?;
            }
            return Ok(());
        }
        let mut bytes: Vec<u8> = Vec::new();
        let mut ends: Vec<(u64, usize)> = Vec::with_capacity(n);
        let mut label_rows: Vec<(u32, u64)> = Vec::with_capacity(n);
        for (i, (id, labels, props)) in rows.into_iter().enumerate() {
            let rec = new_rec(&labels, props);
            self.check_node(id, &rec).map_err(|e| (i, e))?;
            bytes.extend_from_slice(&codec::encode_node(&rec.labels, &rec.props));
            ends.push((id, bytes.len()));
            self.apply_node_indexes(id, None, Some(&rec), Some(&mut label_rows))
                .map_err(|e| (i, e))?;
        }
        let store = |e| (n, e);
        append_records(&mut self.nodes, &bytes, ends).map_err(store)?;
        label_rows.sort_unstable();
        let last_label = self
            .labels
            .last()
            .map_err(|e| store(storage(e)))?
            .map(|(k, _)| k.value());
        if label_rows
            .first()
            .is_some_and(|r| last_label.is_none_or(|l| *r > l))
        {
            let mut cursor = self
                .labels
                .upper_bound_mut(Bound::<(u32, u64)>::Unbounded)
                .map_err(|e| store(storage(e)))?;
            for r in &label_rows {
                cursor.insert_before(r, ()).map_err(|e| store(storage(e)))?;
            }
            cursor.close().map_err(|e| store(storage(e)))?;
        } else {
            for r in &label_rows {
                self.labels.insert(r, ()).map_err(|e| store(storage(e)))?;
            }
        }
        Ok(())
    }

    /// Marks every node id below `next` as handed out, so [`WriteTxn::restore_node`] can
    /// place nodes under the ids they had elsewhere (an import keeping its files' ids). Never
    /// lowers the counter.
    pub fn reserve_node_ids(&mut self, next: u64) {
        self.next_node = self.next_node.max(next);
    }

    /// Creates a node from names: `create("Note", &[("text", "a bench".into())])`.
    pub fn create_node_named(&mut self, labels: &[&str], props: &[(&str, Value)]) -> Result<u64> {
        let ls = labels
            .iter()
            .map(|l| self.label_id(l))
            .collect::<Result<Vec<_>>>()?;
        let ps = props
            .iter()
            .map(|(k, v)| Ok((self.prop_key_id(k)?, v.clone())))
            .collect::<Result<Vec<_>>>()?;
        self.create_node(&ls, ps)
    }

    /// Sets a node property; `Value::Null` removes it.
    pub fn set_node_prop(&mut self, id: u64, key: PropKey, value: Value) -> Result<()> {
        let before = self.rec(id)?;
        let mut after = before.clone();
        match after.props.binary_search_by_key(&key.0, |(k, _)| *k) {
            Ok(i) if value.is_null() => {
                after.props.remove(i);
            }
            Ok(i) => after.props[i].1 = value,
            Err(_) if value.is_null() => return Ok(()),
            Err(i) => after.props.insert(i, (key.0, value)),
        }
        self.apply_node(id, Some(&before), Some(&after))
    }

    /// Replaces all properties of a node.
    pub fn replace_node_props(&mut self, id: u64, props: Vec<(PropKey, Value)>) -> Result<()> {
        let before = self.rec(id)?;
        let after = NodeRec {
            labels: before.labels.clone(),
            props: raw_normalized(props),
        };
        self.apply_node(id, Some(&before), Some(&after))
    }

    /// Removes a node property, returning its old value.
    pub fn remove_node_prop(&mut self, id: u64, key: PropKey) -> Result<Option<Value>> {
        let old = self.rec(id)?.get(key.0).cloned();
        self.set_node_prop(id, key, Value::Null)?;
        Ok(old)
    }

    /// Adds a label (no-op if present).
    pub fn add_label(&mut self, id: u64, label: LabelId) -> Result<()> {
        let before = self.rec(id)?;
        let Err(i) = before.labels.binary_search(&label.0) else {
            return Ok(());
        };
        let mut after = before.clone();
        after.labels.insert(i, label.0);
        self.apply_node(id, Some(&before), Some(&after))
    }

    /// Removes a label (no-op if absent).
    pub fn remove_label(&mut self, id: u64, label: LabelId) -> Result<()> {
        let before = self.rec(id)?;
        let Ok(i) = before.labels.binary_search(&label.0) else {
            return Ok(());
        };
        let mut after = before.clone();
        after.labels.remove(i);
        self.apply_node(id, Some(&before), Some(&after))
    }

    /// Deletes a node that has no relationships, and its payloads.
    pub fn delete_node(&mut self, id: u64) -> Result<()> {
        let before = self.rec(id)?;
        let out = Raw::adj(self, id, 0, None)?.len();
        let inc = Raw::adj(self, id, 1, None)?.len();
        if out + inc > 0 {
            let self_loops = Raw::adj(self, id, 0, None)?
                .iter()
                .filter(|(_, _, o)| *o == id)
                .count();
            return Err(Error::NodeHasRelationships {
                node: id,
                count: out + inc - self_loops,
            });
        }
        for k in Raw::payload_keys(self, id)? {
            self.payloads.remove(&(id, k.as_str())).map_err(storage)?;
        }
        self.apply_node(id, Some(&before), None)
    }

    /// Deletes a node together with all its relationships.
    pub fn detach_delete_node(&mut self, id: u64) -> Result<()> {
        self.rec(id)?;
        let mut rels: Vec<u64> = Raw::adj(self, id, 0, None)?
            .into_iter()
            .chain(Raw::adj(self, id, 1, None)?)
            .map(|(r, _, _)| r)
            .collect();
        rels.sort_unstable();
        rels.dedup();
        for r in rels {
            self.delete_rel(r)?;
        }
        self.delete_node(id)
    }
}

/// A node record from its labels (sorted, without repeats) and properties
/// ([`raw_normalized`]).
fn new_rec(labels: &[LabelId], props: Vec<(PropKey, Value)>) -> NodeRec {
    let mut ls: Vec<u32> = labels.iter().map(|l| l.0).collect();
    ls.sort_unstable();
    ls.dedup();
    NodeRec {
        labels: ls,
        props: raw_normalized(props),
    }
}

/// Appends records to a table keyed by id through a cursor, which packs them into full leaves
/// instead of descending the tree per insert: `ends` gives each record's id (ascending, above
/// every key of the table) and where it ends in `bytes`, the records one after another.
fn append_records(
    table: &mut Table<'_, u64, &'static [u8]>,
    bytes: &[u8],
    ends: impl IntoIterator<Item = (u64, usize)>,
) -> Result<()> {
    let mut cursor = table
        .upper_bound_mut(Bound::<u64>::Unbounded)
        .map_err(storage)?;
    let mut from = 0;
    for (id, to) in ends {
        cursor
            .insert_before(id, &bytes[from..to])
            .map_err(storage)?;
        from = to;
    }
    cursor.close().map_err(storage)
}
