//! The narrow read interface the physical operators run over ([`Source`]), and its
//! implementation over a committed snapshot of the store ([`StoreSource`]).
//!
//! Operators never see redb, records or the store's caches: they ask for a label's nodes, a
//! label check, one node's relationships, one property of a node or relationship, and an
//! index lookup. That is all a read-only pipeline needs, so the operators can be tested over a
//! plain in-memory graph (the tests' `MemSource`), and the store can answer each ask from
//! whatever is cheapest in this commit: per-commit columns and label sets when whole-graph
//! reads made them worth building, single-value decodes from the records before that.

use std::cell::RefCell;
use std::sync::Arc;

use super::R;
use super::value::Val;
use crate::columns::{Cell, Column, LabelMembers};
use crate::hot::{AdjMem, Lazy};
use crate::{GraphRead, ReadTxn, Value, ValueBound};

/// Which way a relationship is followed from a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Way {
    /// Relationships that start at the node.
    Out,
    /// Relationships that end at the node.
    In,
    /// Both: the outgoing ones, then the incoming ones (a self-loop once).
    Both,
}

/// Relationship types an expansion takes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Types {
    /// Any type.
    Any,
    /// Exactly these (ascending type ids; empty: the pattern names only types the store has
    /// never seen, so nothing matches).
    Only(Vec<u32>),
}

/// Reads a pipeline makes. Node and relationship ids are the store's; property handles come
/// from [`Source::node_prop_handle`] / [`Source::rel_prop_handle`] when the plan is built.
pub(crate) trait Source {
    /// A label's id, if the store has seen it.
    fn label_id(&self, name: &str) -> Option<u32>;
    /// A relationship type's id, if the store has seen it.
    fn type_id(&self, name: &str) -> Option<u32>;
    /// A property key's id, if the store has seen it.
    fn key_id(&self, name: &str) -> Option<u32>;
    /// The nodes with a label, ascending.
    fn label_nodes(&self, label: u32) -> R<Arc<LabelMembers>>;
    /// Every node, ascending.
    fn all_nodes(&self) -> R<Vec<u64>>;
    /// Whether an existing node carries a label.
    fn has_label(&self, node: u64, label: u32) -> R<bool>;
    /// `node`'s relationships of `types` followed `way`, appended to `out` as (relationship,
    /// node at the other end), in the store's adjacency order: by direction (out first), type,
    /// relationship id.
    fn expand(&self, node: u64, way: Way, types: &Types, out: &mut Vec<(u64, u64)>) -> R<()>;
    /// A handle for reading node property `key` (`None`: a key the store has never seen).
    fn node_prop_handle(&self, key: Option<u32>) -> usize;
    /// A handle for reading relationship property `key`.
    fn rel_prop_handle(&self, key: Option<u32>) -> usize;
    /// A node's property through a handle (null when absent).
    fn node_prop(&self, node: u64, handle: usize) -> R<Val>;
    /// A relationship's property through a handle (null when absent).
    fn rel_prop(&self, rel: u64, handle: usize) -> R<Val>;
    /// The column behind a node property handle, for whole-graph kernels: None until the
    /// commit has it (with `force`, built now unless the table cannot be a column), and
    /// always None for a source without columns.
    fn node_column(&self, handle: usize, force: bool) -> Option<Arc<Column>>;
    /// The column behind a relationship property handle, as [`Source::node_column`].
    fn rel_column(&self, handle: usize, force: bool) -> Option<Arc<Column>>;
    /// The adjacency in memory, for whole-graph kernels (as [`Source::node_column`]).
    fn adjacency(&self, force: bool) -> Option<Arc<AdjMem>>;
    /// Whether `label.key` has a property index.
    fn has_index(&self, label: &str, key: &str) -> bool;
    /// Nodes of `label` whose `key` equals `v`, by the property index.
    fn index_eq(&self, label: &str, key: &str, v: &Value) -> R<Vec<u64>>;
    /// Nodes of `label` whose `key` lies in the range, by the property index.
    fn index_range(&self, label: &str, key: &str, lo: ValueBound, hi: ValueBound) -> R<Vec<u64>>;
    /// Nodes carrying `label` (0 for an unknown label): planning statistics.
    fn label_count(&self, label: &str) -> u64;
    /// Nodes in the graph: planning statistics.
    fn node_count(&self) -> u64;
}

/// The property keys behind a source's handles, in handle order (node properties, then
/// relationship properties). A plan holds handles, not keys, so a plan built over one source
/// runs over another only when that one is [`StoreSource::primed`] with the first one's keys.
pub(crate) type HandleKeys = (Vec<Option<u32>>, Vec<Option<u32>>);

/// One property's state for one statement: the commit's column once it is built.
#[derive(Debug)]
struct PropState {
    key: Option<u32>,
    lazy: Option<Arc<Lazy<Column>>>,
    col: Option<Arc<Column>>,
}

/// One label's state for one statement.
#[derive(Debug)]
struct LabelState {
    label: u32,
    checks: u32,
    members: Option<Arc<LabelMembers>>,
}

/// Label checks of one label answered from node records, in one statement, before the label's
/// members are read (an anchored pattern checks a few nodes and must stay cheap).
const LABEL_CHECKS_BEFORE_SET: u32 = 2048;

/// [`Source`] over a committed snapshot: per-commit columns, label sets and the adjacency in
/// memory once whole-graph reads made them worth building ([`crate::hot`]), reads of single
/// values from the records before.
#[derive(Debug)]
pub(crate) struct StoreSource<'t> {
    txn: &'t ReadTxn,
    node_props: RefCell<Vec<PropState>>,
    rel_props: RefCell<Vec<PropState>>,
    labels: RefCell<Vec<LabelState>>,
    adj: RefCell<Option<Arc<AdjMem>>>,
    label_counts: std::cell::OnceCell<std::collections::BTreeMap<String, u64>>,
    /// The last node record read for a property (a filter, then a projection, of one node).
    record_memo: RefCell<crate::txn::RecordMemo>,
}

impl<'t> StoreSource<'t> {
    pub(crate) fn new(txn: &'t ReadTxn) -> Self {
        StoreSource {
            txn,
            node_props: RefCell::new(Vec::new()),
            rel_props: RefCell::new(Vec::new()),
            labels: RefCell::new(Vec::new()),
            adj: RefCell::new(None),
            label_counts: std::cell::OnceCell::new(),
            record_memo: RefCell::default(),
        }
    }

    /// A source over `txn` whose property handles are `keys`' (see [`HandleKeys`]).
    pub(crate) fn primed(txn: &'t ReadTxn, keys: &HandleKeys) -> Self {
        let s = StoreSource::new(txn);
        for k in &keys.0 {
            s.handle(true, *k);
        }
        for k in &keys.1 {
            s.handle(false, *k);
        }
        s
    }

    /// The property keys behind this source's handles so far.
    pub(crate) fn handle_keys(&self) -> HandleKeys {
        let keys = |v: &RefCell<Vec<PropState>>| v.borrow().iter().map(|p| p.key).collect();
        (keys(&self.node_props), keys(&self.rel_props))
    }

    fn handle(&self, nodes: bool, key: Option<u32>) -> usize {
        let mut v = if nodes {
            self.node_props.borrow_mut()
        } else {
            self.rel_props.borrow_mut()
        };
        if let Some(i) = v.iter().position(|p| p.key == key) {
            return i;
        }
        v.push(PropState {
            key,
            lazy: key.map(|k| self.txn.column_state(nodes, k)),
            col: None,
        });
        v.len() - 1
    }

    fn column_of(&self, nodes: bool, handle: usize, force: bool) -> Option<Arc<Column>> {
        let mut v = if nodes {
            self.node_props.borrow_mut()
        } else {
            self.rel_props.borrow_mut()
        };
        let st = v.get_mut(handle)?;
        if st.col.is_none() {
            let (Some(key), Some(lazy)) = (st.key, &st.lazy) else {
                return None;
            };
            st.col = self.txn.column(lazy, nodes, key, force);
        }
        st.col.clone()
    }

    fn prop(&self, nodes: bool, id: u64, handle: usize) -> R<Val> {
        let mut v = if nodes {
            self.node_props.borrow_mut()
        } else {
            self.rel_props.borrow_mut()
        };
        let Some(st) = v.get_mut(handle) else {
            return Ok(Val::Null);
        };
        let (Some(key), Some(lazy)) = (st.key, &st.lazy) else {
            return Ok(Val::Null);
        };
        if st.col.is_none() {
            st.col = self.txn.column(lazy, nodes, key, false);
        }
        if let Some(c) = &st.col {
            return Ok(cell_val(c.get(id)));
        }
        drop(v);
        let v = if nodes {
            self.txn
                .node_prop_memo(id, key, &mut self.record_memo.borrow_mut())?
        } else {
            self.txn.rel_prop(id, crate::PropKey(key))?
        };
        Ok(v.map(Val::from).unwrap_or(Val::Null))
    }
}

/// A column entry as a query value.
#[inline]
pub(crate) fn cell_val(c: Cell<'_>) -> Val {
    match c {
        Cell::Absent => Val::Null,
        Cell::Int(i) => Val::Int(i),
        Cell::Float(f) => Val::Float(f),
        Cell::Str(s) => Val::Str(s.to_string()),
        Cell::Other(v) => Val::from(v.clone()),
    }
}

/// `(relationship, other end)` rows of one direction of `a`, of `types`, appended to `out`;
/// for [`Way::Both`]'s incoming half, self-loops are left out (the outgoing half had them).
fn push_rows(
    rels: &[u64],
    tys: &[u32],
    others: &[u64],
    types: &Types,
    skip_other: Option<u64>,
    out: &mut Vec<(u64, u64)>,
) {
    for i in 0..rels.len() {
        if let Types::Only(ts) = types
            && ts.len() > 1
            && !ts.contains(&tys[i])
        {
            continue;
        }
        if skip_other == Some(others[i]) {
            continue;
        }
        out.push((rels[i], others[i]));
    }
}

impl Source for StoreSource<'_> {
    fn label_id(&self, name: &str) -> Option<u32> {
        self.txn.label(name).map(|l| l.0)
    }
    fn type_id(&self, name: &str) -> Option<u32> {
        self.txn.rel_type(name).map(|t| t.0)
    }
    fn key_id(&self, name: &str) -> Option<u32> {
        self.txn.prop_key(name).map(|k| k.0)
    }

    fn label_nodes(&self, label: u32) -> R<Arc<LabelMembers>> {
        let m = self.txn.label_members(label)?;
        let mut ls = self.labels.borrow_mut();
        match ls.iter_mut().find(|s| s.label == label) {
            Some(s) => s.members = Some(m.clone()),
            None => ls.push(LabelState {
                label,
                checks: 0,
                members: Some(m.clone()),
            }),
        }
        Ok(m)
    }

    fn all_nodes(&self) -> R<Vec<u64>> {
        Ok(self.txn.all_node_ids()?)
    }

    fn has_label(&self, node: u64, label: u32) -> R<bool> {
        let mut ls = self.labels.borrow_mut();
        let i = match ls.iter().position(|s| s.label == label) {
            Some(i) => i,
            None => {
                ls.push(LabelState {
                    label,
                    checks: 0,
                    // a label another reader of this commit scanned is a set already
                    members: self.txn.label_members_if_read(label),
                });
                ls.len() - 1
            }
        };
        let st = &mut ls[i];
        if st.members.is_none() {
            st.checks += 1;
            if st.checks > LABEL_CHECKS_BEFORE_SET {
                st.members = Some(self.txn.label_members(label)?);
            }
        }
        match &st.members {
            Some(m) => Ok(m.set.contains(node)),
            None => Ok(self.txn.node_has_label(node, label)?),
        }
    }

    fn expand(&self, node: u64, way: Way, types: &Types, out: &mut Vec<(u64, u64)>) -> R<()> {
        let ty = match types {
            Types::Only(ts) if ts.is_empty() => return Ok(()),
            Types::Only(ts) if ts.len() == 1 => Some(ts[0]),
            _ => None,
        };
        let mut adj = self.adj.borrow_mut();
        if adj.is_none() {
            *adj = self.txn.adjacency_mem(false);
        }
        let dirs: &[(u8, Option<u64>)] = match way {
            Way::Out => &[(0, None)],
            Way::In => &[(1, None)],
            Way::Both => &[(0, None), (1, Some(node))],
        };
        for &(d, skip) in dirs {
            match &*adj {
                Some(m) => {
                    let a = m.slice(node, d, ty);
                    push_rows(a.rels, a.tys, a.others, types, skip, out);
                }
                None => {
                    let rows = crate::read::Raw::adj(self.txn, node, d, ty)?;
                    let rels: Vec<u64> = rows.iter().map(|r| r.0).collect();
                    let tys: Vec<u32> = rows.iter().map(|r| r.1).collect();
                    let others: Vec<u64> = rows.iter().map(|r| r.2).collect();
                    push_rows(&rels, &tys, &others, types, skip, out);
                }
            }
        }
        Ok(())
    }

    fn node_prop_handle(&self, key: Option<u32>) -> usize {
        self.handle(true, key)
    }
    fn rel_prop_handle(&self, key: Option<u32>) -> usize {
        self.handle(false, key)
    }
    fn node_prop(&self, node: u64, handle: usize) -> R<Val> {
        self.prop(true, node, handle)
    }
    fn rel_prop(&self, rel: u64, handle: usize) -> R<Val> {
        self.prop(false, rel, handle)
    }

    fn node_column(&self, handle: usize, force: bool) -> Option<Arc<Column>> {
        self.column_of(true, handle, force)
    }
    fn rel_column(&self, handle: usize, force: bool) -> Option<Arc<Column>> {
        self.column_of(false, handle, force)
    }
    fn adjacency(&self, force: bool) -> Option<Arc<AdjMem>> {
        let mut adj = self.adj.borrow_mut();
        if adj.is_none() {
            *adj = self.txn.adjacency_mem(force);
        }
        adj.clone()
    }

    fn has_index(&self, label: &str, key: &str) -> bool {
        self.txn.has_property_index(label, key)
    }
    fn index_eq(&self, label: &str, key: &str, v: &Value) -> R<Vec<u64>> {
        Ok(self.txn.find_nodes(label, key, v)?)
    }
    fn index_range(&self, label: &str, key: &str, lo: ValueBound, hi: ValueBound) -> R<Vec<u64>> {
        Ok(self.txn.find_range(label, key, lo, hi)?)
    }

    fn label_count(&self, label: &str) -> u64 {
        let c = self
            .label_counts
            .get_or_init(|| self.txn.counts().map(|c| c.nodes).unwrap_or_default());
        c.get(label).copied().unwrap_or(0)
    }
    fn node_count(&self) -> u64 {
        self.txn.total_of(0)
    }
}
