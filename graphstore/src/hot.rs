//! Per-commit in-memory copies of hot tables, built on demand and shared by every read
//! transaction of that commit.
//!
//! A traversal asks the adjacency table for one node's relationships at a time, and reads
//! node and relationship records one id at a time; each ask is a B-tree descent in redb
//! (1–2 µs). Once read transactions of one commit have asked a table often enough (see
//! [`Lazy::get`]), the table is copied into memory in one sequential pass: the adjacency as
//! columns in key order ([`AdjMem`], about 20 bytes a row, up to [`ADJ_MAX_ROWS`] rows), the
//! record tables as one byte arena indexed by id ([`RecordsMem`], dense ids only, up to
//! [`RECORDS_MAX_BYTES`]), a property index as a hash table by value ([`EqIndex`], for
//! equality lookups); later asks are a slice or hash lookup. A table past those sizes keeps being
//! read from redb. The copies belong to the commit's [`crate::Committed`] state: a new commit
//! starts without them, so they are never stale, and the last reader of an old commit frees
//! them. Write transactions never use them (they must see their own changes).

use hashbrown::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};

use crate::columns::Column;

/// Adjacency asks, per commit, answered from redb before the table is copied into memory.
pub(crate) const ASKS_BEFORE_COPY: u64 = 4096;
/// Adjacency rows (two per relationship) above which the table is not copied (about 160 MB).
pub(crate) const ADJ_MAX_ROWS: usize = 8 << 20;

/// Bytes of records (node or relationship table) above which a table is not copied.
pub(crate) const RECORDS_MAX_BYTES: usize = 256 << 20;

/// One table's copy: asks so far, then the copy (or `None`: too large or unreadable, and not
/// tried again).
#[derive(Debug)]
pub(crate) struct Lazy<T> {
    asks: AtomicU64,
    /// Asks answered from redb before the copy is made.
    due_after: OnceLock<u64>,
    copy: OnceLock<Option<Arc<T>>>,
}

impl<T> Default for Lazy<T> {
    fn default() -> Self {
        Lazy {
            asks: AtomicU64::new(0),
            due_after: OnceLock::new(),
            copy: OnceLock::new(),
        }
    }
}

impl<T> Lazy<T> {
    /// The copy if it is built, or due now; then `build` makes it. It is due after
    /// [`ASKS_BEFORE_COPY`] asks, or an eighth of the table's `rows` if more (a sequential copy
    /// of a row costs far less than one point read, so the copy at most doubles the reads'
    /// cost even if no more asks come).
    pub(crate) fn get(
        &self,
        rows: impl FnOnce() -> u64,
        build: impl FnOnce() -> Option<T>,
    ) -> Option<Arc<T>> {
        if let Some(m) = self.copy.get() {
            return m.clone();
        }
        let due = *self
            .due_after
            .get_or_init(|| ASKS_BEFORE_COPY.max(rows() / 8));
        if self.asks.fetch_add(1, Ordering::Relaxed) < due {
            return None;
        }
        // the copy outlives the statement that triggers it: not charged to its memory budget
        self.copy
            .get_or_init(|| crate::mem::uncounted(|| build().map(Arc::new)))
            .clone()
    }
}

impl<T> Lazy<T> {
    /// The copy if it has been made.
    pub(crate) fn built(&self) -> Option<Arc<T>> {
        self.copy.get().cloned().flatten()
    }

    /// The copy, built now if it is not yet (for a reader about to read the whole table
    /// anyway); None when it cannot be made.
    pub(crate) fn force(&self, build: impl FnOnce() -> Option<T>) -> Option<Arc<T>> {
        self.copy
            .get_or_init(|| crate::mem::uncounted(|| build().map(Arc::new)))
            .clone()
    }
}

/// The hot-table state of one commit.
#[derive(Debug, Default)]
pub(crate) struct Hot {
    /// The adjacency table.
    pub(crate) adj: Lazy<AdjMem>,
    /// The node records.
    pub(crate) nodes: Lazy<RecordsMem>,
    /// The relationship records.
    pub(crate) rels: Lazy<RecordsMem>,
    /// Per label id: its nodes, read once from the label index by the first reader that
    /// scans the label.
    pub(crate) labels: Keyed<OnceLock<Arc<crate::columns::LabelMembers>>>,
    /// Per property key: that property of every node, as a column (see [`crate::columns`]).
    pub(crate) node_columns: Keyed<Lazy<crate::columns::Column>>,
    /// Per property key: that property of every relationship.
    pub(crate) rel_columns: Keyed<Lazy<crate::columns::Column>>,
    /// Per property index id: its entries as a hash table, for equality lookups.
    pub(crate) prop_eq: Keyed<Lazy<EqIndex>>,
    /// Copies of earlier commits to bring up to this one instead of copying afresh.
    pub(crate) seed: Seed,
}

/// A copy made at an earlier commit: `(its commit sequence, the copy)`.
type Seeded<T> = (u64, Arc<T>);

/// The newest copies of earlier commits that the next commit's readers bring up to date from
/// the nodes changed since ([`crate::layout::ChangeLog`]): the adjacency, node property
/// columns and label members (what a commit's writes change little of, and a reader would
/// otherwise copy whole again after every commit). Relationship columns and record copies are
/// not carried (the change log lists nodes). A seed is taken by the reader that uses it, so
/// a commit does not keep its seed beside its own copy.
#[derive(Debug, Default)]
pub(crate) struct Seed {
    adj: std::sync::Mutex<Option<Seeded<AdjMem>>>,
    node_columns: std::sync::Mutex<HashMap<u32, Seeded<Column>>>,
    labels: std::sync::Mutex<HashMap<u32, Seeded<crate::columns::LabelMembers>>>,
}

fn locked<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Seed {
    /// The adjacency seed, taken.
    pub(crate) fn take_adj(&self) -> Option<Seeded<AdjMem>> {
        locked(&self.adj).take()
    }

    /// The seed of node property `key`'s column, taken.
    pub(crate) fn take_column(&self, key: u32) -> Option<Seeded<Column>> {
        locked(&self.node_columns).remove(&key)
    }

    /// The seed of label `label`'s members, taken.
    pub(crate) fn take_labels(&self, label: u32) -> Option<Seeded<crate::columns::LabelMembers>> {
        locked(&self.labels).remove(&label)
    }

    /// Whether an adjacency seed is there (for tests).
    #[cfg(test)]
    pub(crate) fn has_adj(&self) -> bool {
        locked(&self.adj).is_some()
    }
}

impl Hot {
    /// The hot state of the commit after `base` (made at commit `seq`): no copies yet, and
    /// as seeds the copies `base` made, or the seeds it had, while the change log still
    /// reaches back to them.
    pub(crate) fn after(base: &Hot, seq: u64) -> Hot {
        let fresh = |s: &u64| seq - s < crate::layout::CHANGE_LOG_COMMITS as u64;
        let adj = match base.adj.built() {
            Some(c) => Some((seq, c)),
            None => locked(&base.seed.adj).clone().filter(|(s, _)| fresh(s)),
        };
        // per token: the copy `base` made, else its seed while still fresh
        fn carried<T>(
            seeds: &std::sync::Mutex<HashMap<u32, Seeded<T>>>,
            built: impl Iterator<Item = (u32, Arc<T>)>,
            seq: u64,
            fresh: impl Fn(&u64) -> bool,
        ) -> std::sync::Mutex<HashMap<u32, Seeded<T>>> {
            let mut m: HashMap<u32, Seeded<T>> = locked(seeds)
                .iter()
                .filter(|(_, (s, _))| fresh(s))
                .map(|(k, v)| (*k, v.clone()))
                .collect();
            m.extend(built.map(|(k, c)| (k, (seq, c))));
            std::sync::Mutex::new(m)
        }
        let columns = base.node_columns.entries().into_iter();
        let labels = base.labels.entries().into_iter();
        Hot {
            seed: Seed {
                adj: std::sync::Mutex::new(adj),
                node_columns: carried(
                    &base.seed.node_columns,
                    columns.filter_map(|(k, lazy)| lazy.built().map(|c| (k, c))),
                    seq,
                    fresh,
                ),
                labels: carried(
                    &base.seed.labels,
                    labels.filter_map(|(k, cell)| cell.get().map(|m| (k, m.clone()))),
                    seq,
                    fresh,
                ),
            },
            ..Hot::default()
        }
    }
}

/// Per-token state of one commit, made on first use (a statement resolves the few it needs
/// once, then uses them without this lock).
#[derive(Debug)]
pub(crate) struct Keyed<T>(std::sync::Mutex<HashMap<u32, Arc<T>>>);

impl<T> Default for Keyed<T> {
    fn default() -> Self {
        Keyed(std::sync::Mutex::new(HashMap::new()))
    }
}

impl<T> Keyed<T> {
    /// Every token's state made so far.
    pub(crate) fn entries(&self) -> Vec<(u32, Arc<T>)> {
        locked(&self.0)
            .iter()
            .map(|(k, v)| (*k, v.clone()))
            .collect()
    }
}

impl<T: Default> Keyed<T> {
    /// The state of token `id`.
    pub(crate) fn get(&self, id: u32) -> Arc<T> {
        let mut m = self
            .0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        m.entry(id).or_default().clone()
    }
}

/// A table `id → record bytes` in memory: one byte arena, and per id (dense ids only) where its
/// record lies.
#[derive(Debug)]
pub(crate) struct RecordsMem {
    /// Record `id` is `data[ends[id - 1]..ends[id]]` (from 0 for id 0) when bit `id` of
    /// `present` is set.
    ends: Vec<u64>,
    present: Vec<u64>,
    data: Vec<u8>,
    /// Records held.
    count: u64,
}

impl RecordsMem {
    /// An empty copy to [`RecordsMem::push`] rows into.
    pub(crate) fn new() -> RecordsMem {
        RecordsMem {
            ends: Vec::new(),
            present: Vec::new(),
            data: Vec::new(),
            count: 0,
        }
    }

    /// Adds the next row (ids ascending); false when the copy must be given up: the ids are
    /// sparse (more than four slots per record so far), the bytes pass
    /// [`RECORDS_MAX_BYTES`], or the id is out of order.
    pub(crate) fn push(&mut self, id: u64, bytes: &[u8]) -> bool {
        let slots = 4 * (self.count + 1) + 4096;
        if id >= slots
            || (id as usize) < self.ends.len()
            || self.data.len() + bytes.len() > RECORDS_MAX_BYTES
        {
            return false;
        }
        let end = self.data.len() as u64;
        self.ends.resize(id as usize, end);
        self.data.extend_from_slice(bytes);
        self.ends.push(self.data.len() as u64);
        self.present.resize(id as usize / 64 + 1, 0);
        self.present[id as usize / 64] |= 1 << (id % 64);
        self.count += 1;
        true
    }

    /// Record `id`'s bytes, if it exists.
    /// Every record, ids ascending.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u64, &[u8])> + '_ {
        (0..self.ends.len() as u64).filter_map(|id| self.get(id).map(|b| (id, b)))
    }

    pub(crate) fn get(&self, id: u64) -> Option<&[u8]> {
        let i = usize::try_from(id).ok()?;
        if self.present.get(i / 64)? & (1 << (i % 64)) == 0 {
            return None;
        }
        let start = if i == 0 { 0 } else { self.ends[i - 1] };
        Some(&self.data[start as usize..self.ends[i] as usize])
    }
}

/// Where each node's rows start in [`AdjMem`]'s columns.
#[derive(Debug)]
enum Starts {
    /// Indexed by node id: rows of node `n` are `starts[n]..starts[n + 1]`.
    Dense(Vec<u32>),
    /// Node id → (first row, end row), for sparse ids.
    Sparse(HashMap<u64, (u32, u32)>),
}

/// The adjacency's rows `(node, direction, type, relationship) → other node` in memory, in that
/// order (as [`crate::adjacency::Rows`] reads them from the chunks), as columns.
#[derive(Debug)]
pub(crate) struct AdjMem {
    starts: Starts,
    dirs: Vec<u8>,
    tys: Vec<u32>,
    rels: Vec<u64>,
    others: Vec<u64>,
    /// Per (direction, type): where each node's rows of it lie, made on first use.
    typed: Derived<(u8, u32), Vec<[u32; 2]>>,
    /// Per (direction, type, target label, self-loops skipped): each node's count of such
    /// rows, made on first use.
    degrees: Derived<(u8, u32, Option<u32>, bool), Vec<u32>>,
    /// Relationship property columns of this commit and the same columns in row order.
    aligned: std::sync::Mutex<Vec<(Arc<Column>, Arc<Column>)>>,
}

/// Tables derived from the adjacency on first use, shared by the commit's readers.
type Derived<K, V> = std::sync::Mutex<HashMap<K, Arc<V>>>;

/// The derived table `key`, made by `make` if it is not yet (outside the statement's memory
/// budget: it belongs to the commit).
fn derived<K: std::hash::Hash + Eq + Copy, V>(
    table: &Derived<K, V>,
    key: K,
    make: impl FnOnce() -> V,
) -> Arc<V> {
    let mut m = table
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    m.entry(key)
        .or_insert_with(|| Arc::new(crate::mem::uncounted(make)))
        .clone()
}

impl AdjMem {
    /// The table from its rows in key order; `None` past [`ADJ_MAX_ROWS`] rows or when a row
    /// is out of order (the caller then keeps reading the table).
    pub(crate) fn from_rows(
        rows: impl Iterator<Item = crate::Result<((u64, u8, u32, u64), u64)>>,
    ) -> crate::Result<Option<AdjMem>> {
        let (mut nodes, mut dirs, mut tys, mut rels, mut others) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut last: Option<(u64, u8, u32, u64)> = None;
        for row in rows {
            let (key, other) = row?;
            if nodes.len() >= ADJ_MAX_ROWS || last.is_some_and(|l| l >= key) {
                return Ok(None);
            }
            last = Some(key);
            nodes.push(key.0);
            dirs.push(key.1);
            tys.push(key.2);
            rels.push(key.3);
            others.push(other);
        }
        let distinct = nodes.windows(2).filter(|w| w[0] != w[1]).count() + 1;
        let max = nodes.last().copied().unwrap_or(0);
        let starts = if max < 4 * distinct as u64 + 4096 {
            let mut starts = vec![0u32; max as usize + 2];
            // count rows per node, then prefix sums
            for &n in &nodes {
                starts[n as usize + 1] += 1;
            }
            for i in 1..starts.len() {
                starts[i] += starts[i - 1];
            }
            Starts::Dense(starts)
        } else {
            let mut m = HashMap::with_capacity(distinct);
            let mut i = 0;
            while i < nodes.len() {
                let j = i + nodes[i..].partition_point(|&n| n == nodes[i]);
                m.insert(nodes[i], (i as u32, j as u32));
                i = j;
            }
            Starts::Sparse(m)
        };
        Ok(Some(AdjMem {
            starts,
            dirs,
            tys,
            rels,
            others,
            typed: Default::default(),
            degrees: Default::default(),
            aligned: Default::default(),
        }))
    }

    /// Where node `node`'s rows lie (empty when it has none).
    fn range_of(&self, node: u64) -> (usize, usize) {
        match &self.starts {
            Starts::Dense(st) => match (st.get(node as usize), st.get(node as usize + 1)) {
                (Some(&s), Some(&e)) => (s as usize, e as usize),
                _ => (0, 0),
            },
            Starts::Sparse(m) => m
                .get(&node)
                .map_or((0, 0), |&(s, e)| (s as usize, e as usize)),
        }
    }

    /// The nodes with rows, ascending.
    fn nodes(&self) -> Vec<u64> {
        match &self.starts {
            Starts::Dense(st) => (0..st.len().saturating_sub(1))
                .filter(|&n| st[n + 1] > st[n])
                .map(|n| n as u64)
                .collect(),
            Starts::Sparse(m) => {
                let mut v: Vec<u64> = m.keys().copied().collect();
                v.sort_unstable();
                v
            }
        }
    }

    /// This table with the rows of the nodes `changed` (ascending) replaced by `fresh`'s rows
    /// of each (in key order); equal to a copy of the table where those are the only changes
    /// (`None` as for [`AdjMem::from_rows`]).
    pub(crate) fn patched(
        &self,
        changed: &[u64],
        fresh: impl Fn(u64) -> crate::Result<Vec<crate::adjacency::AdjRow>>,
    ) -> crate::Result<Option<AdjMem>> {
        let old = self.nodes();
        let (mut i, mut j) = (0, 0);
        let mut buf: std::collections::VecDeque<crate::Result<crate::adjacency::AdjRow>> =
            std::collections::VecDeque::new();
        let rows = std::iter::from_fn(|| {
            loop {
                if let Some(r) = buf.pop_front() {
                    return Some(r);
                }
                let (a, b) = (old.get(i).copied(), changed.get(j).copied());
                let n = match (a, b) {
                    (None, None) => return None,
                    (Some(a), Some(b)) => a.min(b),
                    (Some(n), None) | (None, Some(n)) => n,
                };
                if a == Some(n) {
                    i += 1;
                }
                if b == Some(n) {
                    j += 1;
                    match fresh(n) {
                        Ok(rows) => buf.extend(rows.into_iter().map(Ok)),
                        Err(e) => buf.push_back(Err(e)),
                    }
                } else {
                    let (s, e) = self.range_of(n);
                    buf.extend((s..e).map(|k| {
                        Ok(((n, self.dirs[k], self.tys[k], self.rels[k]), self.others[k]))
                    }));
                }
            }
        });
        AdjMem::from_rows(rows)
    }

    /// The part of rows `s..e` (one node's, in key order) with direction `dir` and a type in
    /// `t0..=t1`.
    fn narrow(&self, s: usize, e: usize, dir: u8, t0: u32, t1: u32) -> (usize, usize) {
        if e - s <= 16 {
            // a typical node: a linear pass over its few rows beats two binary searches
            let (dirs, tys) = (&self.dirs[s..e], &self.tys[s..e]);
            let below = |i: usize| (dirs[i], tys[i]) < (dir, t0);
            let within = |i: usize| (dirs[i], tys[i]) <= (dir, t1);
            let lo = (0..dirs.len()).find(|&i| !below(i)).unwrap_or(dirs.len());
            let hi = (lo..dirs.len()).find(|&i| !within(i)).unwrap_or(dirs.len());
            return (s + lo, s + hi);
        }
        let key = |i: usize| (self.dirs[s + i], self.tys[s + i]);
        let n = e - s;
        let lo = partition(n, |i| key(i) < (dir, t0));
        let hi = lo + partition(n - lo, |i| key(lo + i) <= (dir, t1));
        (s + lo, s + hi)
    }

    /// Per node id, where its rows of direction `dir` and type `ty` lie (for [`AdjMem::rows`];
    /// a node past the end has none); `None` for sparse node ids. Made once per commit: 8
    /// bytes per node.
    pub(crate) fn typed(&self, dir: u8, ty: u32) -> Option<Arc<Vec<[u32; 2]>>> {
        let Starts::Dense(st) = &self.starts else {
            return None;
        };
        Some(derived(&self.typed, (dir, ty), || {
            st.windows(2)
                .map(|w| {
                    let (s, e) = self.narrow(w[0] as usize, w[1] as usize, dir, ty, ty);
                    [s as u32, e as u32]
                })
                .collect()
        }))
    }

    /// `rel_column` (a relationship property column of this commit) in the order of this
    /// table's rows: entry `i` is the property of row `i`'s relationship, so a traversal that
    /// knows its row ([`AdjSlice::start`]) reads it sequentially. Made once per commit and
    /// column: 8 bytes per row.
    pub(crate) fn aligned(&self, rel_column: &Arc<Column>) -> Arc<Column> {
        let mut m = self
            .aligned
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, a)) = m.iter().find(|(c, _)| Arc::ptr_eq(c, rel_column)) {
            return a.clone();
        }
        let a = Arc::new(crate::mem::uncounted(|| rel_column.gather(&self.rels)));
        m.push((rel_column.clone(), a.clone()));
        a
    }

    /// The rows at `at` (an entry of [`AdjMem::typed`]).
    #[inline]
    pub(crate) fn rows(&self, at: [u32; 2]) -> AdjSlice<'_> {
        let r = at[0] as usize..at[1] as usize;
        AdjSlice {
            start: r.start,
            rels: &self.rels[r.clone()],
            tys: &self.tys[r.clone()],
            others: &self.others[r],
        }
    }

    /// Per node id, how many of its rows of direction `dir` and type `ty` lead to a node in
    /// `to` (a label id and its members; `None`: any node), leaving out self-loops when
    /// `skip_loops`; `None` for sparse node ids. Made once per commit: 4 bytes per node.
    pub(crate) fn degrees(
        &self,
        dir: u8,
        ty: u32,
        to: Option<(u32, &crate::columns::IdSet)>,
        skip_loops: bool,
    ) -> Option<Arc<Vec<u32>>> {
        let typed = self.typed(dir, ty)?;
        Some(derived(
            &self.degrees,
            (dir, ty, to.map(|t| t.0), skip_loops),
            || {
                typed
                    .iter()
                    .enumerate()
                    .map(|(n, &at)| {
                        let others = self.rows(at).others;
                        others
                            .iter()
                            .filter(|&&o| {
                                !(skip_loops && o == n as u64)
                                    && to.is_none_or(|(_, set)| set.contains(o))
                            })
                            .count() as u32
                    })
                    .collect()
            },
        ))
    }

    /// Rows of `node` in direction `dir` (0 out, 1 in), of type `ty` or all types, in key
    /// order, as columns borrowed from the table: (relationships, types, other nodes).
    pub(crate) fn slice(&self, node: u64, dir: u8, ty: Option<u32>) -> AdjSlice<'_> {
        let (s, e) = self.range_of(node);
        let (t0, t1) = ty.map_or((0, u32::MAX), |t| (t, t));
        let (lo, hi) = self.narrow(s, e, dir, t0, t1);
        self.rows([lo as u32, hi as u32])
    }

    /// Rows of `node` in direction `dir` (0 out, 1 in), of type `ty` or all types, as
    /// (relationship, type, other node) in key order: what the table's range scan gives.
    pub(crate) fn get(&self, node: u64, dir: u8, ty: Option<u32>) -> Vec<(u64, u32, u64)> {
        let a = self.slice(node, dir, ty);
        (0..a.rels.len())
            .map(|i| (a.rels[i], a.tys[i], a.others[i]))
            .collect()
    }
}

/// One node's adjacency rows in one direction, as borrowed columns of equal length.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AdjSlice<'a> {
    /// The table row of the first entry.
    pub(crate) start: usize,
    pub(crate) rels: &'a [u64],
    pub(crate) tys: &'a [u32],
    pub(crate) others: &'a [u64],
}

/// The first `i` in `0..n` where `pred` turns false (`pred` true then false).
fn partition(n: usize, pred: impl Fn(usize) -> bool) -> usize {
    let (mut lo, mut hi) = (0, n);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Entries of one property index above which it is not copied (about 400 MB at 24 bytes an
/// entry).
pub(crate) const EQ_MAX_ENTRIES: usize = 16 << 20;

/// Bytes of non-numeric keys above which a property index is not copied.
pub(crate) const EQ_MAX_KEY_BYTES: usize = 256 << 20;

/// The value of a slot that holds several nodes: the high bit, and the list's position.
const EQ_MANY: u64 = 1 << 63;

/// One property index's entries in memory, by value: a hash lookup instead of a B-tree descent
/// for `{key: value}` equality. Keys are the index's sort keys ([`crate::codec::sort_key`]),
/// exact for every indexed value: numbers by their 8-byte key, other values by their bytes.
/// A slot holds one node id, or (high bit set) where the list of several lies.
#[derive(Debug, Default)]
pub(crate) struct EqIndex {
    numbers: HashMap<u64, u64>,
    others: HashMap<Box<[u8]>, u64>,
    many: Vec<Vec<u64>>,
    key_bytes: usize,
    entries: usize,
}

impl EqIndex {
    /// The index from its entries `(sort key, node id)` in key order (ids ascending within a
    /// key, as the table holds them); `None` past [`EQ_MAX_ENTRIES`] or [`EQ_MAX_KEY_BYTES`],
    /// or for a node id with the high bit set.
    pub(crate) fn from_entries<K: AsRef<[u8]>>(
        entries: impl Iterator<Item = crate::Result<(K, u64)>>,
    ) -> crate::Result<Option<EqIndex>> {
        let mut m = EqIndex::default();
        for e in entries {
            let (key, id) = e?;
            let key = key.as_ref();
            if id & EQ_MANY != 0 || m.entries >= EQ_MAX_ENTRIES {
                return Ok(None);
            }
            m.entries += 1;
            let slot = match Self::number(key) {
                Some(n) => match m.numbers.entry(n) {
                    hashbrown::hash_map::Entry::Occupied(o) => o.into_mut(),
                    hashbrown::hash_map::Entry::Vacant(v) => {
                        v.insert(id);
                        continue;
                    }
                },
                None => match m.others.get_mut(key) {
                    Some(slot) => slot,
                    None => {
                        m.key_bytes += key.len();
                        if m.key_bytes > EQ_MAX_KEY_BYTES {
                            return Ok(None);
                        }
                        m.others.insert(key.into(), id);
                        continue;
                    }
                },
            };
            Self::add(&mut m.many, slot, id);
        }
        Ok(Some(m))
    }

    fn add(many: &mut Vec<Vec<u64>>, slot: &mut u64, id: u64) {
        if *slot & EQ_MANY != 0 {
            many[(*slot & !EQ_MANY) as usize].push(id);
        } else {
            many.push(vec![*slot, id]);
            *slot = EQ_MANY | (many.len() - 1) as u64;
        }
    }

    /// A numeric sort key as its 8 bytes.
    fn number(key: &[u8]) -> Option<u64> {
        match key {
            [k, rest @ ..] if *k == crate::codec::K_NUMBER => {
                <[u8; 8]>::try_from(rest).ok().map(u64::from_be_bytes)
            }
            _ => None,
        }
    }

    /// The nodes whose value has sort key `key`, ascending.
    pub(crate) fn get(&self, key: &[u8]) -> Vec<u64> {
        let slot = match Self::number(key) {
            Some(n) => self.numbers.get(&n),
            None => self.others.get(key),
        };
        match slot {
            None => Vec::new(),
            Some(&s) if s & EQ_MANY != 0 => self.many[(s & !EQ_MANY) as usize].clone(),
            Some(&s) => vec![s],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    type Row = ((u64, u8, u32, u64), u64);

    fn reference(rows: &[Row], node: u64, dir: u8, ty: Option<u32>) -> Vec<(u64, u32, u64)> {
        rows.iter()
            .filter(|((n, d, t, _), _)| *n == node && *d == dir && ty.is_none_or(|ty| ty == *t))
            .map(|((_, _, t, r), o)| (*r, *t, *o))
            .collect()
    }

    proptest! {
        /// Every (node, direction, type) lookup gives what a scan of the rows gives, for dense
        /// and sparse node ids.
        #[test]
        fn lookups_match_a_scan_of_the_rows(
            raw in proptest::collection::vec(((0u64..40, 0u8..2, 0u32..4, 0u64..1000), 0u64..40), 0..200),
            sparse in any::<bool>(),
        ) {
            let mut rows: Vec<Row> = raw
                .into_iter()
                .map(|((n, d, t, r), o)| ((if sparse { n << 33 } else { n }, d, t, r), o))
                .collect();
            rows.sort_unstable();
            rows.dedup_by_key(|r| r.0);
            let m = AdjMem::from_rows(rows.iter().map(|r| Ok(*r))).unwrap().unwrap();
            if sparse && rows.iter().any(|r| r.0.0 > 0) {
                prop_assert!(matches!(m.starts, Starts::Sparse(_)));
            }
            for n in 0..42u64 {
                let node = if sparse { n << 33 } else { n };
                for dir in 0..2 {
                    for ty in [None, Some(0), Some(1), Some(3), Some(9)] {
                        prop_assert_eq!(m.get(node, dir, ty), reference(&rows, node, dir, ty));
                        let a = m.slice(node, dir, ty);
                        prop_assert_eq!(a.rels.len(), a.others.len());
                        prop_assert_eq!(a.rels.len(), a.tys.len());
                    }
                }
            }
            // the per-type ranges and degrees agree with the scan (dense ids only)
            let to = crate::columns::IdSet::new(&[1, 2, 3, 5, 8, 13, 21, 34]);
            for dir in 0..2 {
                for ty in [0, 1, 3, 9] {
                    let Some(typed) = m.typed(dir, ty) else {
                        prop_assert!(matches!(m.starts, Starts::Sparse(_)));
                        continue;
                    };
                    for skip in [false, true] {
                        let any = m.degrees(dir, ty, None, skip).unwrap();
                        let some = m.degrees(dir, ty, Some((7, &to)), skip).unwrap();
                        for n in 0..42u64 {
                            let want = reference(&rows, n, dir, Some(ty));
                            let at = typed.get(n as usize).copied().unwrap_or([0, 0]);
                            let got = m.rows(at);
                            let got: Vec<_> = (0..got.rels.len())
                                .map(|i| (got.rels[i], got.tys[i], got.others[i]))
                                .collect();
                            prop_assert_eq!(&got, &want);
                            let kept = |o: &u64| !(skip && *o == n);
                            let deg = |d: &[u32]| d.get(n as usize).copied().unwrap_or(0) as usize;
                            prop_assert_eq!(deg(&any), want.iter().filter(|w| kept(&w.2)).count());
                            prop_assert_eq!(
                                deg(&some),
                                want.iter().filter(|w| kept(&w.2) && to.contains(w.2)).count()
                            );
                        }
                    }
                }
            }
        }
    }

    /// A change to a small graph, by index into its nodes and relationships.
    #[derive(Debug, Clone)]
    enum Op {
        Create(bool, Option<i64>),
        Delete(usize),
        Set(usize, Option<i64>),
        Relabel(usize),
        Link(usize, usize, bool),
        Unlink(usize),
    }

    fn op() -> impl Strategy<Value = Op> {
        let v = proptest::option::of(-3i64..3);
        prop_oneof![
            (any::<bool>(), v.clone()).prop_map(|(a, v)| Op::Create(a, v)),
            (0usize..64).prop_map(Op::Delete),
            (0usize..64, v).prop_map(|(i, v)| Op::Set(i, v)),
            (0usize..64).prop_map(Op::Relabel),
            (0usize..64, 0usize..64, any::<bool>()).prop_map(|(a, b, t)| Op::Link(a, b, t)),
            (0usize..64).prop_map(Op::Unlink),
        ]
    }

    /// The value of `k` a node gets: integers, and a string for negatives (so a column can
    /// change kind).
    fn value(v: i64) -> crate::Value {
        if v < 0 {
            crate::Value::String(format!("s{v}"))
        } else {
            crate::Value::Int(v)
        }
    }

    fn apply(tx: &mut crate::WriteTxn<'_>, op: &Op) -> crate::Result<()> {
        use crate::GraphRead;
        let (a, b) = (tx.label_id("A")?, tx.label_id("B")?);
        let k = tx.prop_key_id("k")?;
        let nodes = tx.all_node_ids()?;
        let rels = tx.all_rel_ids()?;
        let pick = |v: &[u64], i: usize| (!v.is_empty()).then(|| v[i % v.len()]);
        match op {
            Op::Create(la, v) => {
                let props = v.map(|v| vec![(k, value(v))]).unwrap_or_default();
                tx.create_node(&[if *la { a } else { b }], props)?;
            }
            Op::Delete(i) => {
                if let Some(n) = pick(&nodes, *i) {
                    tx.detach_delete_node(n)?;
                }
            }
            Op::Set(i, v) => {
                if let Some(n) = pick(&nodes, *i) {
                    tx.set_node_prop(n, k, v.map_or(crate::Value::Null, value))?;
                }
            }
            Op::Relabel(i) => {
                if let Some(n) = pick(&nodes, *i) {
                    if tx.node(n)?.is_some_and(|x| x.labels.contains(&a)) {
                        tx.remove_label(n, a)?;
                    } else {
                        tx.add_label(n, a)?;
                    }
                }
            }
            Op::Link(x, y, t) => {
                if let (Some(x), Some(y)) = (pick(&nodes, *x), pick(&nodes, *y)) {
                    let ty = tx.rel_type_id(if *t { "R" } else { "S" })?;
                    tx.create_rel(x, ty, y, Vec::new())?;
                }
            }
            Op::Unlink(i) => {
                if let Some(r) = pick(&rels, *i) {
                    tx.delete_rel(r)?;
                }
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// The adjacency, a node column and a label's members brought up to date from an
        /// earlier commit's copies equal the same read whole, after any changes in any number
        /// of commits, made with or without a copy in between.
        #[test]
        fn copies_brought_up_to_date_equal_copies_read_whole(
            first in proptest::collection::vec(op(), 1..30),
            commits in proptest::collection::vec((proptest::collection::vec(op(), 1..6), any::<bool>()), 1..6),
        ) {
            use crate::read::Raw;
            let dir = tempfile::tempdir().unwrap();
            let store = crate::Store::create(dir.path().join("h.og")).unwrap();
            store.write(|tx| first.iter().try_for_each(|o| apply(tx, o))).unwrap();
            let (a, k) = store
                .write(|tx| Ok((tx.label_id("A")?.0, tx.prop_key_id("k")?.0)))
                .unwrap();
            let copy = |r: &crate::ReadTxn| {
                (
                    r.adjacency_mem(true),
                    r.column(&r.column_state(true, k), true, k, true),
                    r.label_members(a).unwrap(),
                )
            };
            copy(&store.read().unwrap());
            let mut seeded = 0;
            for (ops, read_between) in &commits {
                store.write(|tx| ops.iter().try_for_each(|o| apply(tx, o))).unwrap();
                let r = store.read().unwrap();
                if !read_between {
                    continue;
                }
                seeded += usize::from(r.base().hot.seed.has_adj());
                let (adj, col, members) = copy(&r);
                let whole_adj = r.copy_adjacency_whole().unwrap();
                let adj = adj.unwrap();
                let top = r.next_ids().unwrap().0 + 2;
                for n in 0..top {
                    for d in 0..2 {
                        prop_assert_eq!(adj.get(n, d, None), whole_adj.get(n, d, None), "node {} dir {}", n, d);
                    }
                }
                let whole_col = r.build_column_whole(true, k);
                match (col, whole_col) {
                    (Some(c), Some(w)) => {
                        for id in 0..top {
                            prop_assert_eq!(c.get(id), w.get(id), "node {}", id);
                        }
                    }
                    (None, None) => {}
                    (c, w) => prop_assert!(w.is_none(), "patched {:?}, whole {:?}", c.is_some(), w.is_some()),
                }
                prop_assert_eq!(&members.ids, &r.label_nodes(a).unwrap());
            }
            // a commit after a copy always has a seed
            prop_assert!(seeded > 0 || commits.iter().all(|(_, b)| !b));
        }
    }

    /// Indexed values of every kind, with the pairs an index must tell apart or join: 1 and
    /// 1.0, 0.0 and -0.0, integers past f64's exact range, strings with a NUL byte.
    fn eq_value(i: u8) -> crate::Value {
        use crate::Value::*;
        match i % 14 {
            0 => Int(1),
            1 => Float(1.0),
            2 => Float(0.0),
            3 => Float(-0.0),
            4 => Int((1 << 53) + 1),
            5 => Int(1 << 53),
            6 => String(std::string::String::new()),
            7 => String("a\0b".into()),
            8 => String("a".into()),
            9 => Bool(true),
            10 => Bool(false),
            11 => Float(f64::INFINITY),
            12 => Int(-7),
            _ => String("bus stop".into()),
        }
    }

    proptest! {
        /// An equality lookup answered from the in-memory copy of a property index gives the
        /// nodes the index's range scan gives, for every kind of value.
        #[test]
        fn index_copy_lookups_equal_range_scans(
            nodes in proptest::collection::vec((any::<bool>(), proptest::option::of(0u8..14)), 0..60),
        ) {
            use crate::GraphRead;
            let dir = tempfile::tempdir().unwrap();
            let store = crate::Store::create(dir.path().join("e.og")).unwrap();
            store
                .set_schema(crate::Schema {
                    property_indexes: vec![crate::PropertyIndexSpec {
                        name: None,
                        label: "A".into(),
                        key: "k".into(),
                    }],
                    ..crate::Schema::default()
                })
                .unwrap();
            store
                .write(|tx| {
                    let (a, b, k) = (tx.label_id("A")?, tx.label_id("B")?, tx.prop_key_id("k")?);
                    for (in_a, v) in &nodes {
                        let props = v.map(|v| vec![(k, eq_value(v))]).unwrap_or_default();
                        tx.create_node(&[if *in_a { a } else { b }], props)?;
                    }
                    Ok(())
                })
                .unwrap();
            let r = store.read().unwrap();
            let idx = crate::read::property_index(r.view(), "A", "k").unwrap().unwrap();
            let lookups = |r: &crate::ReadTxn| -> Vec<Vec<u64>> {
                (0..14).map(|i| r.find_nodes("A", "k", &eq_value(i)).unwrap()).collect()
            };
            let scanned = lookups(&r);
            prop_assert!(r.base().hot.prop_eq.get(idx).built().is_none());
            let copy = r.base().hot.prop_eq.get(idx).force(|| r.copy_property_index(idx));
            prop_assert!(copy.is_some());
            prop_assert_eq!(lookups(&r), scanned.clone());
            // and both give what the nodes hold
            for (i, ids) in scanned.iter().enumerate() {
                let want = eq_value(i as u8);
                let expect: Vec<u64> = (0..nodes.len() as u64)
                    .filter(|id| {
                        let (in_a, v) = nodes[*id as usize];
                        in_a && v.is_some_and(|v| {
                            crate::read::compare(&eq_value(v), &want) == Some(std::cmp::Ordering::Equal)
                        })
                    })
                    .collect();
                prop_assert_eq!(ids, &expect, "value {:?}", want);
            }
            // ranges with exclusive and inclusive bounds keep every node on the right side,
            // also where integers share one index key
            use crate::ValueBound::{Exclusive, Inclusive, Unbounded};
            for i in 0..14u8 {
                let b = eq_value(i);
                if !matches!(b, crate::Value::Int(_) | crate::Value::Float(_)) {
                    continue;
                }
                for (lo, hi, keep) in [
                    (Exclusive(b.clone()), Unbounded, [std::cmp::Ordering::Greater].as_slice()),
                    (Inclusive(b.clone()), Unbounded, &[std::cmp::Ordering::Greater, std::cmp::Ordering::Equal]),
                    (Unbounded, Exclusive(b.clone()), &[std::cmp::Ordering::Less]),
                    (Unbounded, Inclusive(b.clone()), &[std::cmp::Ordering::Less, std::cmp::Ordering::Equal]),
                ] {
                    let mut got = r.find_range("A", "k", lo.clone(), hi.clone()).unwrap();
                    got.sort_unstable();
                    let expect: Vec<u64> = (0..nodes.len() as u64)
                        .filter(|id| {
                            let (in_a, v) = nodes[*id as usize];
                            in_a && v.is_some_and(|v| {
                                crate::read::compare(&eq_value(v), &b).is_some_and(|o| keep.contains(&o))
                            })
                        })
                        .collect();
                    prop_assert_eq!(got, expect, "{:?}..{:?}", lo, hi);
                }
            }
        }
    }

    #[test]
    fn unsorted_rows_are_not_copied() {
        let rows = [((2u64, 0u8, 0u32, 1u64), 5u64), ((1, 0, 0, 2), 6)];
        assert!(
            AdjMem::from_rows(rows.iter().map(|r| Ok(*r)))
                .unwrap()
                .is_none()
        );
    }

    #[test]
    fn the_copy_is_made_once_after_enough_asks() {
        let hot = Hot::default();
        let mut builds = 0;
        for _ in 0..ASKS_BEFORE_COPY {
            assert!(hot.adj.get(|| 0, || unreachable!()).is_none());
        }
        let rows = [((1u64, 0u8, 0u32, 1u64), 5u64)];
        let m = hot.adj.get(
            || 0,
            || {
                builds += 1;
                AdjMem::from_rows(rows.iter().map(|r| Ok(*r))).unwrap()
            },
        );
        assert_eq!(m.unwrap().get(1, 0, None), vec![(1, 0, 5)]);
        assert!(hot.adj.get(|| 0, || unreachable!()).is_some());
        assert_eq!(builds, 1);
        // a large table waits for an eighth of its rows in asks
        let hot = Hot::default();
        for _ in 0..100_000 {
            assert!(hot.adj.get(|| 800_000, || unreachable!()).is_none());
        }
        assert!(hot.adj.get(|| unreachable!(), || None).is_none());
        assert!(hot.adj.get(|| unreachable!(), || unreachable!()).is_none());
    }

    proptest! {
        /// Every id reads back its own bytes, and ids without a record read nothing.
        #[test]
        fn records_read_back(
            recs in proptest::collection::btree_map(0u64..300, proptest::collection::vec(any::<u8>(), 0..20), 0..60),
        ) {
            let mut m = RecordsMem::new();
            for (id, b) in &recs {
                prop_assert!(m.push(*id, b));
            }
            for id in 0..320u64 {
                prop_assert_eq!(m.get(id), recs.get(&id).map(Vec::as_slice));
            }
            prop_assert_eq!(m.get(u64::MAX), None);
        }
    }

    #[test]
    fn sparse_or_unordered_records_are_not_copied() {
        assert!(!RecordsMem::new().push(1 << 40, b"x"));
        let mut m = RecordsMem::new();
        assert!(m.push(5, b"x"));
        assert!(!m.push(3, b"y"));
        assert!(!m.push(5, b"y"));
    }
}
