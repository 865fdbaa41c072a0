//! Clause execution: pattern matching, projection, aggregation, writes and procedures.

use std::cell::Cell;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::rc::Rc;
use std::time::Instant;

use super::ast::*;
use super::eval::{arg_err, dir_of, sort_key_cmp, type_err};
use super::plan::{Anchor, Source, choose_anchor, conjuncts};
use super::value::{Key, Val, equals};
use super::{ErrorKind, QueryError, R, Stats};
use crate::{GraphRead, ReadTxn, Value, WriteTxn};

/// A row of named values.
#[derive(Debug, Clone, Default)]
pub(crate) struct Row(pub Vec<(Rc<str>, Val)>);

impl Row {
    pub fn get(&self, n: &str) -> Option<&Val> {
        self.0.iter().rev().find(|(k, _)| &**k == n).map(|(_, v)| v)
    }
    pub fn set(&mut self, n: &str, v: Val) {
        if let Some(slot) = self.0.iter_mut().find(|(k, _)| &**k == n) {
            slot.1 = v;
        } else {
            self.0.push((Rc::from(n), v));
        }
    }
}

pub(crate) enum Tx<'a, 'b> {
    Read(&'a ReadTxn),
    Write(&'a mut WriteTxn<'b>),
}

pub(crate) struct Ctx<'a, 'b> {
    tx: Tx<'a, 'b>,
    pub params: &'a BTreeMap<String, Val>,
    deadline: Option<Instant>,
    ticks: Cell<u64>,
    rng: Cell<u64>,
    deleted_nodes: HashSet<u64>,
    deleted_rels: HashSet<u64>,
    deleted_rel_types: BTreeMap<u64, String>,
    pub stats: Stats,
    /// Where the clause being run starts, for errors that know no better place.
    pub clause_pos: Option<super::Pos>,
    /// Cap on the rows any clause may produce.
    pub max_rows: usize,
    /// Cap on the bytes the statement may hold at once (see [`crate::mem`]); `u64::MAX`: none.
    pub max_memory: u64,
    /// The world axes of the ground plane, for the ground procedures (see
    /// [`super::QueryOptions::ground_axes`]).
    pub ground_axes: Option<[usize; 2]>,
    /// For `PROFILE`: one step per clause run, and the step open now with its start.
    pub profile: Option<Profile>,
    /// This thread's net allocation when the statement started.
    mem_start: i64,
    /// Bytes announced by [`Ctx::reserve`] (the measure where allocations are not counted).
    mem_reserved: Cell<u64>,
    /// The most the statement was seen to hold, in bytes.
    mem_peak: Cell<u64>,
    /// Nodes per label, read once per statement when the planner compares label scans.
    label_counts: std::cell::OnceCell<BTreeMap<String, u64>>,
    /// Decoded nodes of a read-only statement, most recently used kept: a pattern checks
    /// the same node's labels and properties many times (every instance's segment, every
    /// edge's end), and a record decodes whole.
    node_cache: std::cell::RefCell<lru::LruCache<u64, std::rc::Rc<crate::Node>>>,
    /// Label membership without node records, for read-only statements (see
    /// [`super::label_set`]).
    label_sets: super::label_set::LabelSets,
}

/// What `PROFILE` measured of one clause.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ProfileStep {
    /// Which single query of a UNION (0 first).
    pub part: usize,
    /// The clause (`Match`, `With`, ...), or what answered in its place.
    pub clause: String,
    /// Rows it handed on.
    pub rows: usize,
    /// Time it took, milliseconds.
    pub ms: f64,
}

/// The steps of a `PROFILE` so far.
#[derive(Debug, Default)]
pub(crate) struct Profile {
    pub steps: Vec<ProfileStep>,
    open: Option<(usize, String, Instant)>,
}

impl Profile {
    /// Closes the open step with `rows` handed on.
    fn close(&mut self, rows: usize) {
        if let Some((part, clause, t)) = self.open.take() {
            self.steps.push(ProfileStep {
                part,
                clause,
                rows,
                ms: t.elapsed().as_secs_f64() * 1e3,
            });
        }
    }

    /// Closes the open step (the previous clause handed on `rows`) and opens one.
    fn open(&mut self, part: usize, clause: &str, rows: usize) {
        self.close(rows);
        self.open = Some((part, clause.to_string(), Instant::now()));
    }

    /// Renames the open step (a shortcut answered for it).
    fn rename(&mut self, clause: &str) {
        if let Some((_, c, _)) = &mut self.open {
            *c = clause.to_string();
        }
    }
}

/// Where matched rows go.
pub(crate) trait RowSink {
    /// Takes one matched row; true stops the match.
    fn push(&mut self, ctx: &Ctx<'_, '_>, row: Row) -> R<bool>;
}

/// Rows kept in a list, at most `limit`.
struct Collect {
    rows: Vec<Row>,
    limit: Option<usize>,
}

impl RowSink for Collect {
    fn push(&mut self, ctx: &Ctx<'_, '_>, row: Row) -> R<bool> {
        self.rows.push(row);
        ctx.room(self.rows.len())?;
        Ok(self.limit.is_some_and(|l| self.rows.len() >= l))
    }
}

/// A non-aggregating RETURN with LIMIT fed one matched row at a time: without ORDER BY it
/// takes the first `keep` rows and stops the match; with ORDER BY it keeps the best `keep`
/// (ties in the order they came, as the full sort would), sorting and cutting whenever the
/// buffer doubles, so it holds at most 2 × `keep` rows however many match.
struct TopRows<'p> {
    p: &'p Projection,
    items: Vec<Item>,
    cols: Vec<String>,
    keep: usize,
    asc: Vec<bool>,
    rows: Vec<(Vec<Val>, Vec<Val>, Option<usize>)>,
}

impl<'p> TopRows<'p> {
    fn new(p: &'p Projection, keep: usize) -> Self {
        TopRows {
            p,
            items: p.items.clone(),
            cols: p.items.iter().map(|i| i.name.clone()).collect(),
            keep,
            asc: p.order.iter().map(|(_, a, _)| *a).collect(),
            rows: Vec::new(),
        }
    }

    /// Without ORDER BY: whether the rows wanted are all here.
    fn full(&self) -> bool {
        self.p.order.is_empty() && self.rows.len() >= self.keep
    }

    fn cut(&mut self) {
        let asc = &self.asc;
        self.rows.sort_by(|a, b| sort_key_cmp(&a.1, &b.1, asc));
        self.rows.truncate(self.keep);
    }

    fn finish(mut self) -> Vec<(Vec<Val>, Vec<Val>, Option<usize>)> {
        if !self.p.order.is_empty() {
            self.cut();
        }
        self.rows
    }
}

impl RowSink for TopRows<'_> {
    fn push(&mut self, ctx: &Ctx<'_, '_>, row: Row) -> R<bool> {
        if self.full() {
            return Ok(true);
        }
        let (vals, okeys) = ctx.project_row(self.p, &self.items, &self.cols, &row)?;
        self.rows.push((vals, okeys, None));
        ctx.room(self.rows.len())?;
        if !self.p.order.is_empty() && self.rows.len() >= self.keep.saturating_mul(2).max(64) {
            self.cut();
        }
        Ok(self.full())
    }
}

/// One aggregate's running input: a count for `count(*)`, else the values seen.
enum Acc {
    Count(i64),
    Vals(Vec<Val>),
}

/// A grouping projection (RETURN or WITH with aggregates), fed one row at a time: the
/// grouping keys are the items without aggregates; each group keeps its first row (for the
/// items that mix keys and aggregates) and one accumulator per aggregate call.
struct Aggregator {
    cols: Vec<String>,
    items: Vec<Item>,
    /// (function, DISTINCT, arguments) per aggregate call, in the order of `rewritten`'s slots.
    specs: Vec<(String, bool, Vec<Expr>)>,
    /// Per item: the expression over aggregate slots, or None for a grouping key.
    rewritten: Vec<Option<Expr>>,
    order_exprs: Vec<Expr>,
    key_idx: Vec<usize>,
    groups: BTreeMap<Key, usize>,
    group_rows: Vec<(Row, Vec<Val>, Vec<Acc>)>,
}

impl Aggregator {
    fn new(p: &Projection) -> Aggregator {
        Aggregator::with_items(p, p.items.clone())
    }

    fn with_items(p: &Projection, items: Vec<Item>) -> Aggregator {
        let cols: Vec<String> = items.iter().map(|i| i.name.clone()).collect();
        let mut specs: Vec<(String, bool, Vec<Expr>)> = Vec::new();
        let rewritten: Vec<Option<Expr>> = items
            .iter()
            .map(|i| {
                i.expr
                    .has_aggregate()
                    .then(|| rewrite_aggs(&i.expr, &mut specs))
            })
            .collect();
        // order keys that are aggregates not among the items get their own slots
        let order_exprs: Vec<Expr> = p
            .order
            .iter()
            .map(
                |(e, _, text)| match items.iter().find(|i| &i.text == text || &i.name == text) {
                    Some(i) => Expr::Var(i.name.clone(), p.pos),
                    None => {
                        let e = super::check::subst_keys(e, &items);
                        if e.has_aggregate() {
                            rewrite_aggs(&e, &mut specs)
                        } else {
                            e
                        }
                    }
                },
            )
            .collect();
        let key_idx: Vec<usize> = (0..items.len())
            .filter(|i| rewritten[*i].is_none())
            .collect();
        Aggregator {
            cols,
            items,
            specs,
            rewritten,
            order_exprs,
            key_idx,
            groups: BTreeMap::new(),
            group_rows: Vec::new(),
        }
    }

    fn fresh_accs(&self) -> Vec<Acc> {
        self.specs
            .iter()
            .map(|(name, _, _)| {
                if name == "count*" {
                    Acc::Count(0)
                } else {
                    Acc::Vals(Vec::new())
                }
            })
            .collect()
    }

    fn add(&mut self, ctx: &Ctx<'_, '_>, row: &Row) -> R<()> {
        ctx.tick()?;
        let key: Vec<Val> = self
            .key_idx
            .iter()
            .map(|i| ctx.eval(&self.items[*i].expr, row))
            .collect::<R<_>>()?;
        let gi = match self.groups.get(&Key(key.clone())) {
            Some(gi) => *gi,
            None => {
                let accs = self.fresh_accs();
                self.group_rows.push((row.clone(), key.clone(), accs));
                let gi = self.group_rows.len() - 1;
                self.groups.insert(Key(key), gi);
                ctx.room(self.group_rows.len())?;
                gi
            }
        };
        for (si, (_, _, args)) in self.specs.iter().enumerate() {
            match &mut self.group_rows[gi].2[si] {
                Acc::Count(n) => *n += 1,
                Acc::Vals(vals) => {
                    let mut vs = args
                        .iter()
                        .map(|a| ctx.eval(a, row))
                        .collect::<R<Vec<_>>>()?;
                    vals.push(if vs.len() == 1 {
                        vs.pop().unwrap_or_default()
                    } else {
                        Val::List(vs)
                    });
                }
            }
        }
        Ok(())
    }

    /// The groups' rows: (values, order keys, None), in the order the groups were first seen.
    #[allow(clippy::type_complexity)]
    fn finish(mut self, ctx: &Ctx<'_, '_>) -> R<Vec<(Vec<Val>, Vec<Val>, Option<usize>)>> {
        if self.group_rows.is_empty() && self.key_idx.is_empty() {
            let accs = self.fresh_accs();
            self.group_rows.push((Row::default(), Vec::new(), accs));
        }
        let mut out = Vec::with_capacity(self.group_rows.len());
        for (row, key, inputs) in self.group_rows {
            let aggs = self
                .specs
                .iter()
                .zip(inputs)
                .map(|((name, distinct, _), acc)| match acc {
                    Acc::Count(n) => Ok(Val::Int(n)),
                    Acc::Vals(vals) => aggregate(name, *distinct, vals),
                })
                .collect::<R<Vec<_>>>()?;
            let mut vals = Vec::with_capacity(self.items.len());
            let mut ki = key.into_iter();
            for r in &self.rewritten {
                match r {
                    None => vals.push(ki.next().unwrap_or_default()),
                    Some(e) => vals.push(ctx.eval_in(e, &row, &aggs)?),
                }
            }
            let mut orow = Row::default();
            for (c, v) in self.cols.iter().zip(&vals) {
                orow.set(c, v.clone());
            }
            let okeys = self
                .order_exprs
                .iter()
                .map(|e| ctx.eval_in(e, &orow, &aggs))
                .collect::<R<Vec<_>>>()?;
            out.push((vals, okeys, None));
        }
        Ok(out)
    }
}

impl RowSink for Aggregator {
    fn push(&mut self, ctx: &Ctx<'_, '_>, row: Row) -> R<bool> {
        self.add(ctx, &row)?;
        Ok(false)
    }
}

/// Decoded nodes one read-only statement keeps (a few MiB for typical records).
const NODE_CACHE: std::num::NonZeroUsize = std::num::NonZeroUsize::new(4096).unwrap();

fn sem(code: &'static str, msg: impl Into<String>) -> QueryError {
    QueryError::new(ErrorKind::Semantic, code, msg, None)
}

impl<'a, 'b> Ctx<'a, 'b> {
    pub fn new(
        tx: Tx<'a, 'b>,
        params: &'a BTreeMap<String, Val>,
        deadline: Option<Instant>,
        seed: u64,
    ) -> Self {
        Ctx {
            tx,
            params,
            deadline,
            ticks: Cell::new(0),
            rng: Cell::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1),
            deleted_nodes: HashSet::new(),
            deleted_rels: HashSet::new(),
            deleted_rel_types: BTreeMap::new(),
            clause_pos: None,
            max_rows: usize::MAX,
            max_memory: u64::MAX,
            ground_axes: None,
            profile: None,
            mem_start: crate::mem::thread_net_bytes(),
            mem_reserved: Cell::new(0),
            mem_peak: Cell::new(0),
            label_counts: std::cell::OnceCell::new(),
            node_cache: std::cell::RefCell::new(lru::LruCache::sparse(NODE_CACHE)),
            label_sets: Default::default(),
            stats: Stats::default(),
        }
    }

    /// A node by id, decoded once per read-only statement (see `node_cache`); a writing
    /// statement reads it afresh every time, since its own writes change it.
    pub(crate) fn node_cached(&self, id: u64) -> R<Option<std::rc::Rc<crate::Node>>> {
        if matches!(self.tx, Tx::Write(_)) {
            return Ok(self.g().node(id)?.map(std::rc::Rc::new));
        }
        if let Some(n) = self.node_cache.borrow_mut().get(&id) {
            return Ok(Some(n.clone()));
        }
        let n = self.g().node(id)?.map(std::rc::Rc::new);
        if let Some(n) = &n {
            self.node_cache.borrow_mut().put(id, n.clone());
        }
        Ok(n)
    }

    /// The read transaction of a read-only statement (None while writing).
    pub(crate) fn read_txn(&self) -> Option<&'a ReadTxn> {
        match &self.tx {
            Tx::Read(r) => Some(*r),
            Tx::Write(_) => None,
        }
    }

    pub fn g(&self) -> &dyn GraphRead {
        match &self.tx {
            Tx::Read(r) => *r,
            Tx::Write(w) => &**w,
        }
    }

    fn w(&mut self) -> R<&mut WriteTxn<'b>> {
        match &mut self.tx {
            Tx::Write(w) => Ok(w),
            Tx::Read(_) => Err(QueryError::new(
                ErrorKind::ReadOnly,
                "ReadOnly",
                "this query runs read-only and cannot write",
                None,
            )),
        }
    }

    /// Bytes the statement holds now: this thread's allocations since it started where
    /// [`crate::mem::CountingAlloc`] counts them, else what [`Ctx::reserve`] was told.
    fn mem_used(&self) -> u64 {
        if crate::mem::counting() {
            (crate::mem::thread_net_bytes() - self.mem_start).max(0) as u64
        } else {
            self.mem_reserved.get()
        }
    }

    /// The most the statement was seen to hold, in bytes.
    pub fn mem_peak(&self) -> u64 {
        self.mem_peak.get().max(self.mem_used())
    }

    /// Fails when the statement holds, or with `extra` more bytes would hold, more than its
    /// memory budget.
    fn check_mem(&self, extra: u64, what: &str) -> R<()> {
        if self.max_memory == u64::MAX {
            return Ok(());
        }
        let used = self.mem_used();
        if used > self.mem_peak.get() {
            self.mem_peak.set(used);
        }
        if used.saturating_add(extra) > self.max_memory {
            return Err(QueryError::new(
                ErrorKind::MemoryLimit,
                "MemoryLimitExceeded",
                format!(
                    "the statement would hold more than its memory limit of {} MiB{}; narrow the pattern, add LIMIT, or aggregate earlier",
                    self.max_memory >> 20,
                    if what.is_empty() {
                        String::new()
                    } else {
                        format!(" ({what})")
                    }
                ),
                None,
            ));
        }
        Ok(())
    }

    /// Checks that a value of about `bytes` bytes may be built before building it (a size
    /// that could not be allocated at all fails here instead of aborting the process).
    pub(crate) fn reserve(&self, bytes: u64, what: &str) -> R<()> {
        self.check_mem(bytes, what)?;
        if !crate::mem::counting() {
            self.mem_reserved
                .set(self.mem_reserved.get().saturating_add(bytes));
        }
        Ok(())
    }

    pub fn tick(&self) -> R<()> {
        let t = self.ticks.get().wrapping_add(1);
        self.ticks.set(t);
        // the memory check reads a thread-local counter: every 64th unit of work is often
        // enough (a value too large to build is refused by `reserve` before it is built)
        if t.is_multiple_of(64) {
            self.check_mem(0, "")?;
        }
        if t.is_multiple_of(1024)
            && let Some(d) = self.deadline
            && Instant::now() > d
        {
            return Err(QueryError::new(
                ErrorKind::Timeout,
                "Timeout",
                "the query ran past its time limit",
                None,
            ));
        }
        Ok(())
    }

    /// Fails when an intermediate result grows past the cap (memory guard).
    pub(crate) fn room(&self, rows: usize) -> R<()> {
        if rows > self.max_rows {
            return Err(QueryError::new(
                ErrorKind::RowLimit,
                "IntermediateRowLimit",
                format!(
                    "an intermediate result grew past {} rows; narrow the pattern or add LIMIT",
                    self.max_rows
                ),
                None,
            ));
        }
        Ok(())
    }

    pub fn rand(&self) -> f64 {
        // xorshift64*
        let mut x = self.rng.get();
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.rng.set(x);
        (x.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn remember_type(&mut self, rel: u64) -> R<()> {
        let g = self.g();
        if let Some(r) = g.rel(rel)?
            && let Some(t) = g.name_of(r.ty.0)
        {
            self.deleted_rel_types.insert(rel, t);
        }
        Ok(())
    }

    /// The type of a relationship, also after this query deleted it.
    pub fn rel_type_name(&self, rel: u64) -> R<Option<String>> {
        if let Some(t) = self.deleted_rel_types.get(&rel) {
            return Ok(Some(t.clone()));
        }
        let g = self.g();
        Ok(g.rel(rel)?.and_then(|r| g.name_of(r.ty.0)))
    }

    /// How many nodes carry a label, as of the statement's first look (it only steers the
    /// choice between label scans, so writes later in the statement need not refresh it).
    fn label_count(&self, label: &str) -> u64 {
        let counts = self
            .label_counts
            .get_or_init(|| self.g().counts().map(|c| c.nodes).unwrap_or_default());
        counts.get(label).copied().unwrap_or(0)
    }

    pub fn deleted_node(&self, id: u64) -> bool {
        self.deleted_nodes.contains(&id)
    }
    pub fn deleted_rel(&self, id: u64) -> bool {
        self.deleted_rels.contains(&id)
    }

    // ---------------------------------------------------------------- queries

    /// Runs one single query; returns the column names and rows of its RETURN (if any).
    /// Runs one single query (a part of a UNION, `part` from 0): its columns and rows.
    pub fn run_single(&mut self, q: &SingleQuery, part: usize) -> R<(Vec<String>, Vec<Vec<Val>>)> {
        let out = self.run_clauses(q, part);
        if let (Some(p), Ok((_, rows))) = (self.profile.as_mut(), &out) {
            p.close(rows.len());
        }
        out
    }

    fn run_clauses(&mut self, q: &SingleQuery, part: usize) -> R<(Vec<String>, Vec<Vec<Val>>)> {
        // a read's whole-label or whole-type count comes from the store's counts (a write
        // transaction's counts are settled only at commit, so writes take the general path)
        if let (Tx::Read(_), Some((what, column))) = (&self.tx, super::count::store_count(q)) {
            if let Some(p) = self.profile.as_mut() {
                p.open(part, "CountFromStore", 0);
            }
            let n = super::count::read_count(self.g(), &what)?;
            return Ok((vec![column], vec![vec![n]]));
        }
        let mut rows = vec![Row::default()];
        let mut scope: Vec<String> = Vec::new();
        for (ci, clause) in q.clauses.iter().enumerate() {
            self.clause_pos = q.positions.get(ci).copied();
            if let Some(p) = self.profile.as_mut() {
                p.open(part, clause.name(), rows.len());
            }
            match clause {
                Clause::Match {
                    optional,
                    patterns,
                    where_,
                    ..
                } => {
                    let mut new_vars = Vec::new();
                    for p in patterns {
                        for (v, _, _) in p.vars() {
                            if !scope.iter().any(|s| s == v) && !new_vars.contains(&v.to_string()) {
                                new_vars.push(v.to_string());
                            }
                        }
                    }
                    // MATCH straight into an aggregating RETURN: rows go into the groups as
                    // they are matched instead of all being held first
                    if let (false, Some(Clause::Return(p))) = (*optional, q.clauses.get(ci + 1))
                        && !p.star
                        && p.items.iter().any(|i| i.expr.has_aggregate())
                    {
                        if let Some(prof) = self.profile.as_mut() {
                            prof.rename("Match + aggregating Return (streamed)");
                        }
                        let mut agg = Aggregator::new(p);
                        for row in &rows {
                            self.match_into(row, patterns, where_.as_ref(), &mut agg)?;
                        }
                        self.clause_pos = q.positions.get(ci + 1).copied();
                        let cols = agg.cols.clone();
                        let out = agg.finish(self)?;
                        let rows = self.order_and_slice(p, out)?;
                        return Ok((cols, rows.into_iter().map(|(v, _)| v).collect()));
                    }
                    // MATCH straight into a RETURN with LIMIT: only the first SKIP + LIMIT rows
                    // are matched, or with ORDER BY only the best SKIP + LIMIT are kept
                    if let (false, Some(Clause::Return(p))) = (*optional, q.clauses.get(ci + 1))
                        && !p.star
                        && !p.distinct
                        && p.limit.is_some()
                        && !p.items.iter().any(|i| i.expr.has_aggregate())
                    {
                        self.clause_pos = q.positions.get(ci + 1).copied();
                        let skip = self.count_arg(p.skip.as_ref(), "SKIP")?.unwrap_or(0);
                        let limit = self.count_arg(p.limit.as_ref(), "LIMIT")?.unwrap_or(0);
                        self.clause_pos = q.positions.get(ci).copied();
                        if let Some(prof) = self.profile.as_mut() {
                            prof.rename(if p.order.is_empty() {
                                "Match + Return with LIMIT (stops early)"
                            } else {
                                "Match + Return with ORDER BY and LIMIT (top rows kept)"
                            });
                        }
                        let mut top = TopRows::new(p, skip.saturating_add(limit));
                        for row in &rows {
                            if top.full() {
                                break;
                            }
                            self.match_into(row, patterns, where_.as_ref(), &mut top)?;
                        }
                        self.clause_pos = q.positions.get(ci + 1).copied();
                        let cols = top.cols.clone();
                        let rows = self.order_and_slice(p, top.finish())?;
                        return Ok((cols, rows.into_iter().map(|(v, _)| v).collect()));
                    }
                    let mut out = Vec::new();
                    for row in &rows {
                        let m = self.match_paths(row, patterns, where_.as_ref(), None)?;
                        if m.is_empty() && *optional {
                            let mut r = row.clone();
                            for v in &new_vars {
                                r.set(v, Val::Null);
                            }
                            out.push(r);
                            self.room(out.len())?;
                        } else {
                            out.extend(m);
                            self.room(out.len())?;
                        }
                    }
                    scope.extend(new_vars);
                    rows = out;
                }
                Clause::Unwind { expr, var } => {
                    let mut out = Vec::new();
                    for row in &rows {
                        match self.eval(expr, row)? {
                            Val::Null => {}
                            Val::List(items) => {
                                for it in items {
                                    self.tick()?;
                                    let mut r = row.clone();
                                    r.set(var, it);
                                    out.push(r);
                                    self.room(out.len())?;
                                }
                            }
                            other => {
                                let mut r = row.clone();
                                r.set(var, other);
                                out.push(r);
                                self.room(out.len())?;
                            }
                        }
                    }
                    scope.push(var.clone());
                    rows = out;
                }
                Clause::With(p) => {
                    let (cols, out) = self.project_rows(p, &rows, &scope)?;
                    let mut next = Vec::with_capacity(out.len());
                    for (vals, src) in out {
                        self.tick()?;
                        let mut r = Row::default();
                        for (c, v) in cols.iter().zip(vals) {
                            r.set(c, v);
                        }
                        if let Some(w) = &p.where_ {
                            // WHERE also sees the variables from before a non-aggregating WITH
                            let pass = match src {
                                Some(i) => {
                                    let mut merged = rows[i].clone();
                                    for (k, v) in &r.0 {
                                        merged.set(k, v.clone());
                                    }
                                    self.eval(w, &merged)?
                                }
                                None => self.eval(w, &r)?,
                            };
                            if !matches!(pass, Val::Bool(true)) {
                                continue;
                            }
                        }
                        next.push(r);
                    }
                    scope = cols;
                    rows = next;
                }
                Clause::Return(p) => {
                    return self.project(p, &rows, &scope);
                }
                Clause::Create(patterns) => {
                    for row in rows.iter_mut() {
                        for p in patterns {
                            self.create_path(row, p)?;
                        }
                    }
                    for p in patterns {
                        for (v, _, _) in p.vars() {
                            if !scope.iter().any(|s| s == v) {
                                scope.push(v.to_string());
                            }
                        }
                    }
                }
                Clause::Merge {
                    pattern,
                    on_create,
                    on_match,
                } => {
                    let mut out = Vec::new();
                    for row in &rows {
                        self.check_merge_props(row, pattern)?;
                        let found =
                            self.match_paths(row, std::slice::from_ref(pattern), None, None)?;
                        if found.is_empty() {
                            let mut r = row.clone();
                            self.create_path(&mut r, pattern)?;
                            for it in on_create {
                                self.set_item(&mut r, it)?;
                            }
                            out.push(r);
                            self.room(out.len())?;
                        } else {
                            for mut r in found {
                                for it in on_match {
                                    self.set_item(&mut r, it)?;
                                }
                                out.push(r);
                                self.room(out.len())?;
                            }
                        }
                    }
                    for (v, _, _) in pattern.vars() {
                        if !scope.iter().any(|s| s == v) {
                            scope.push(v.to_string());
                        }
                    }
                    rows = out;
                }
                Clause::Set(items) => {
                    for row in rows.iter_mut() {
                        for it in items {
                            self.set_item(row, it)?;
                        }
                    }
                }
                Clause::Remove(items) => {
                    for row in &rows {
                        for it in items {
                            self.remove_item(row, it)?;
                        }
                    }
                }
                Clause::Delete { detach, exprs } => {
                    let mut nodes = Vec::new();
                    let mut rels = Vec::new();
                    for row in &rows {
                        for e in exprs {
                            let v = self.eval(e, row)?;
                            collect_deletes(&v, &mut nodes, &mut rels)?;
                        }
                    }
                    self.delete(nodes, rels, *detach)?;
                }
                Clause::Call {
                    name,
                    args,
                    yields,
                    where_,
                    pos,
                } => {
                    let mut out = Vec::new();
                    for row in &rows {
                        let argv = args
                            .iter()
                            .map(|a| self.eval(a, row))
                            .collect::<R<Vec<_>>>()?;
                        let (cols, results) = self.procedure(name, argv).map_err(|e| e.at(*pos))?;
                        let chosen: Vec<(usize, String)> = match yields {
                            None => cols.iter().enumerate().map(|(i, c)| (i, c.to_string())).collect(),
                            Some(ys) if ys.len() == 1 && ys[0].0 == "*" => cols.iter().enumerate().map(|(i, c)| (i, c.to_string())).collect(),
                            Some(ys) => ys
                                .iter()
                                .map(|(n, alias)| {
                                    cols.iter()
                                        .position(|c| c == n)
                                        .map(|i| (i, alias.clone()))
                                        .ok_or_else(|| QueryError::new(ErrorKind::Syntax, "UndefinedVariable", format!("procedure {name} has no output `{n}` (it has {})", cols.join(", ")), Some(*pos)))
                                })
                                .collect::<R<_>>()?,
                        };
                        for res in results {
                            let mut r = row.clone();
                            for (i, alias) in &chosen {
                                r.set(alias, res[*i].clone());
                            }
                            if let Some(w) = where_
                                && !matches!(self.eval(w, &r)?, Val::Bool(true))
                            {
                                continue;
                            }
                            out.push(r);
                            self.room(out.len())?;
                        }
                        if q.clauses.len() == 1 {
                            let names: Vec<String> =
                                chosen.iter().map(|(_, a)| a.clone()).collect();
                            let data = out
                                .iter()
                                .map(|r| {
                                    names
                                        .iter()
                                        .map(|n| r.get(n).cloned().unwrap_or_default())
                                        .collect()
                                })
                                .collect();
                            return Ok((names, data));
                        }
                    }
                    if let Some(ys) = yields {
                        for (_, a) in ys {
                            scope.push(a.clone());
                        }
                    }
                    rows = out;
                }
            }
        }
        Ok((Vec::new(), Vec::new()))
    }

    // ------------------------------------------------------------- projection

    fn project(
        &mut self,
        p: &Projection,
        rows: &[Row],
        scope: &[String],
    ) -> R<(Vec<String>, Vec<Vec<Val>>)> {
        let (cols, rows) = self.project_rows(p, rows, scope)?;
        Ok((cols, rows.into_iter().map(|(v, _)| v).collect()))
    }

    /// Projects rows; each output row comes with the index of its input row when it has exactly
    /// one (no aggregation).
    #[allow(clippy::type_complexity)]
    fn project_rows(
        &mut self,
        p: &Projection,
        rows: &[Row],
        scope: &[String],
    ) -> R<(Vec<String>, Vec<(Vec<Val>, Option<usize>)>)> {
        let mut items: Vec<Item> = Vec::new();
        if p.star {
            let mut vars: Vec<String> = scope.to_vec();
            vars.sort();
            vars.dedup();
            for v in vars {
                items.push(Item {
                    expr: Expr::Var(v.clone(), p.pos),
                    text: v.clone(),
                    name: v,
                    aliased: true,
                    pos: p.pos,
                });
            }
        }
        items.extend(p.items.iter().cloned());
        let cols: Vec<String> = items.iter().map(|i| i.name.clone()).collect();
        let aggregating = items.iter().any(|i| i.expr.has_aggregate());

        // rows of (output values, order keys)
        let mut out: Vec<(Vec<Val>, Vec<Val>, Option<usize>)> = Vec::new();
        if aggregating {
            let mut agg = Aggregator::with_items(p, items);
            for row in rows {
                agg.add(self, row)?;
            }
            out = agg.finish(self)?;
        } else {
            for (ri, row) in rows.iter().enumerate() {
                self.tick()?;
                let (vals, okeys) = self.project_row(p, &items, &cols, row)?;
                out.push((vals, okeys, Some(ri)));
            }
        }
        let rows = self.order_and_slice(p, out)?;
        Ok((cols, rows))
    }

    /// One row of a non-aggregating projection: the items' values and the ORDER BY keys
    /// (which may name an item or use the variables before the projection).
    fn project_row(
        &self,
        p: &Projection,
        items: &[Item],
        cols: &[String],
        row: &Row,
    ) -> R<(Vec<Val>, Vec<Val>)> {
        let vals = items
            .iter()
            .map(|i| self.eval(&i.expr, row))
            .collect::<R<Vec<_>>>()?;
        let okeys = if p.order.is_empty() {
            Vec::new()
        } else {
            let mut merged = if p.distinct {
                Row::default()
            } else {
                row.clone()
            };
            for (c, v) in cols.iter().zip(&vals) {
                merged.set(c, v.clone());
            }
            p.order
                .iter()
                .map(|(e, _, text)| {
                    match items.iter().find(|i| &i.text == text || &i.name == text) {
                        Some(i) => Ok(merged.get(&i.name).cloned().unwrap_or_default()),
                        None => self.eval(e, &merged),
                    }
                })
                .collect::<R<Vec<_>>>()?
        };
        Ok((vals, okeys))
    }

    /// DISTINCT, ORDER BY, SKIP and LIMIT of a projection's rows (values, order keys, source
    /// row).
    #[allow(clippy::type_complexity)]
    fn order_and_slice(
        &self,
        p: &Projection,
        mut out: Vec<(Vec<Val>, Vec<Val>, Option<usize>)>,
    ) -> R<Vec<(Vec<Val>, Option<usize>)>> {
        if p.distinct {
            let mut seen = std::collections::BTreeSet::new();
            out.retain(|(v, _, _)| seen.insert(Key(v.clone())));
        }
        if !p.order.is_empty() {
            let asc: Vec<bool> = p.order.iter().map(|(_, a, _)| *a).collect();
            out.sort_by(|a, b| sort_key_cmp(&a.1, &b.1, &asc));
        }
        let skip = self.count_arg(p.skip.as_ref(), "SKIP")?.unwrap_or(0);
        let limit = self.count_arg(p.limit.as_ref(), "LIMIT")?;
        let rows: Vec<(Vec<Val>, Option<usize>)> = out
            .into_iter()
            .skip(skip)
            .take(limit.unwrap_or(usize::MAX))
            .map(|(v, _, src)| (v, src))
            .collect();
        Ok(rows)
    }

    pub(crate) fn count_arg(&self, e: Option<&Expr>, what: &str) -> R<Option<usize>> {
        let Some(e) = e else { return Ok(None) };
        match self.eval(e, &Row::default()) {
            Ok(Val::Int(i)) if i >= 0 => Ok(Some(i as usize)),
            Ok(Val::Int(_)) => Err(QueryError::new(
                ErrorKind::Syntax,
                "NegativeIntegerArgument",
                format!("{what} must not be negative"),
                None,
            )),
            Ok(other) => Err(QueryError::new(
                ErrorKind::Syntax,
                "InvalidArgumentType",
                format!("{what} takes an integer, got {}", other.type_name()),
                None,
            )),
            Err(e) if e.code == "UndefinedVariable" => Err(QueryError::new(
                ErrorKind::Syntax,
                "NonConstantExpression",
                format!("{what} must be a constant expression"),
                e.pos,
            )),
            Err(e) => Err(e),
        }
    }

    // --------------------------------------------------------------- matching

    /// All ways to match `pats` extending `row` (relationships unique across the patterns),
    /// filtered by `where_`; at most `limit` rows.
    pub(crate) fn match_paths(
        &self,
        row: &Row,
        pats: &[PathPattern],
        where_: Option<&Expr>,
        limit: Option<usize>,
    ) -> R<Vec<Row>> {
        let mut out = Collect {
            rows: Vec::new(),
            limit,
        };
        self.match_into(row, pats, where_, &mut out)?;
        Ok(out.rows)
    }

    /// How many ways `pats` match extending `row`, filtered by `where_` (`COUNT { }`),
    /// without holding the rows.
    pub(crate) fn count_matches(
        &self,
        row: &Row,
        pats: &[PathPattern],
        where_: Option<&Expr>,
    ) -> R<u64> {
        struct Count(u64);
        impl RowSink for Count {
            fn push(&mut self, _: &Ctx<'_, '_>, _: Row) -> R<bool> {
                self.0 += 1;
                Ok(false)
            }
        }
        let mut c = Count(0);
        self.match_into(row, pats, where_, &mut c)?;
        Ok(c.0)
    }

    /// Like [`Ctx::match_paths`], each match handed to `out` as it is found (so an
    /// aggregation over a pattern holds its groups, not every row).
    pub(crate) fn match_into(
        &self,
        row: &Row,
        pats: &[PathPattern],
        where_: Option<&Expr>,
        out: &mut dyn RowSink,
    ) -> R<()> {
        let mut used = Vec::new();
        let conj = where_.map(conjuncts).unwrap_or_default();
        self.match_from(row.clone(), pats, 0, where_, &conj, &mut used, out)?;
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn match_from(
        &self,
        row: Row,
        pats: &[PathPattern],
        i: usize,
        where_: Option<&Expr>,
        conj: &[&Expr],
        used: &mut Vec<u64>,
        out: &mut dyn RowSink,
    ) -> R<bool> {
        self.tick()?;
        if i == pats.len() {
            if let Some(w) = where_
                && !matches!(self.eval(w, &row)?, Val::Bool(true))
            {
                return Ok(false);
            }
            return out.push(self, row);
        }
        let p = &pats[i];
        if let Some(kind) = p.shortest {
            return self.match_shortest(row, pats, i, kind, where_, conj, used, out);
        }
        let g = self.g();
        let anchor = choose_anchor(
            p,
            conj,
            &|v| row.get(v).is_some(),
            &|e| expr_bound(e, &row),
            &|l, k| g.has_property_index(l, k),
            &|l| self.label_count(l),
        );
        let candidates = self.candidates(&anchor, &row)?;
        let k = p.steps.len();
        let mut moves: Vec<(usize, bool)> = (anchor.index..k).map(|j| (j, true)).collect();
        moves.extend((0..anchor.index).rev().map(|j| (j, false)));
        // a label scan's candidates carry its label: only the pattern's other labels are checked
        let anchor_pat = node_pat(p, anchor.index);
        let trimmed;
        let np = match &anchor.source {
            Source::Label(l) => {
                trimmed = NodePat {
                    labels: anchor_pat
                        .labels
                        .iter()
                        .filter(|x| *x != l)
                        .cloned()
                        .collect(),
                    ..anchor_pat.clone()
                };
                &trimmed
            }
            _ => anchor_pat,
        };
        for cand in candidates {
            self.tick()?;
            let mut r = row.clone();
            if !self.node_ok(cand, np, &mut r)? {
                continue;
            }
            let mut st = PathState {
                nodes: vec![u64::MAX; k + 1],
                segs: vec![Vec::new(); k],
            };
            st.nodes[anchor.index] = cand;
            let stop = self.expand(p, &moves, 0, r, &mut st, used, &mut |ctx, row, st, used| {
                let mut row = row;
                if let Some(pv) = &p.var {
                    row.set(pv, st.path());
                }
                ctx.match_from(row, pats, i + 1, where_, conj, used, out)
            })?;
            if stop {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// `shortestPath` / `allShortestPaths` over pattern `i` (one relationship pattern): for
    /// each start and end node the pattern allows, a breadth-first search from the start over
    /// the relationships it allows (type, direction, properties, not used elsewhere in the
    /// MATCH) gives the shortest paths to the end, within the pattern's hop range; then the
    /// rest of the patterns. Predicates in WHERE filter the paths found; they do not steer the
    /// search (put conditions on the relationships in the pattern's property map).
    #[allow(clippy::too_many_arguments)]
    fn match_shortest(
        &self,
        row: Row,
        pats: &[PathPattern],
        i: usize,
        kind: Shortest,
        where_: Option<&Expr>,
        conj: &[&Expr],
        used: &mut Vec<u64>,
        out: &mut dyn RowSink,
    ) -> R<bool> {
        let p = &pats[i];
        let (rp, end) = &p.steps[0];
        let (lo, hi) = match rp.range {
            None => (1, 1),
            Some((lo, hi)) => (
                lo.unwrap_or(1) as usize,
                hi.map_or(usize::MAX, |h| h as usize),
            ),
        };
        if let Some(v) = &rp.var
            && row.get(v).is_some()
        {
            return Err(sem(
                "VariableAlreadyBound",
                format!("the relationship variable `{v}` of a shortest path must be new"),
            ));
        }
        let ends = |np: &NodePat, row: &Row| -> R<Vec<u64>> {
            let single = PathPattern {
                var: None,
                start: np.clone(),
                steps: Vec::new(),
                shortest: None,
                pos: p.pos,
            };
            let anchor = choose_anchor(
                &single,
                conj,
                &|v| row.get(v).is_some(),
                &|e| expr_bound(e, row),
                &|l, k| self.g().has_property_index(l, k),
                &|l| self.label_count(l),
            );
            self.candidates(&anchor, row)
        };
        let types = self.type_filter(rp);
        for s in ends(&p.start, &row)? {
            self.tick()?;
            let mut r1 = row.clone();
            if !self.node_ok(s, &p.start, &mut r1)? {
                continue;
            }
            let mut targets: Vec<(u64, Row)> = Vec::new();
            for t in ends(end, &r1)? {
                let mut r2 = r1.clone();
                if self.node_ok(t, end, &mut r2)? {
                    targets.push((t, r2));
                }
            }
            if targets.is_empty() {
                continue;
            }
            // breadth-first from s: each node's depth and the hops that reach it at that depth
            // (the first only, for shortestPath)
            let mut depth: HashMap<u64, usize> = HashMap::new();
            let mut parents: HashMap<u64, Vec<(u64, u64)>> = HashMap::new();
            depth.insert(s, 0);
            let mut frontier = vec![s];
            let mut d = 0;
            let wanted: HashSet<u64> = targets
                .iter()
                .map(|(t, _)| *t)
                .filter(|t| lo == 0 || *t != s)
                .collect();
            let mut found = usize::from(wanted.contains(&s) && lo == 0);
            while !frontier.is_empty() && d < hi && found < wanted.len() {
                let mut next = Vec::new();
                for &u in &frontier {
                    for (rid, v) in self.hops(u, rp, true, &types)? {
                        self.tick()?;
                        if used.contains(&rid) || !self.rel_ok(rid, rp, &r1)? {
                            continue;
                        }
                        match depth.get(&v) {
                            None => {
                                depth.insert(v, d + 1);
                                parents.insert(v, vec![(rid, u)]);
                                next.push(v);
                                if wanted.contains(&v) && d + 1 >= lo {
                                    found += 1;
                                }
                            }
                            Some(&dv) if dv == d + 1 && kind == Shortest::All => {
                                parents.entry(v).or_default().push((rid, u));
                            }
                            Some(_) => {}
                        }
                    }
                }
                self.reserve(depth.len() as u64 * 64, "a shortest-path search")?;
                frontier = next;
                d += 1;
            }
            for (t, r2) in targets {
                let Some(&dt) = depth.get(&t) else {
                    continue;
                };
                if dt < lo || (dt == 0 && s != t) {
                    continue;
                }
                for hops in self.paths_back(s, t, &parents, kind)? {
                    let mut r = r2.clone();
                    let rels: Vec<u64> = hops.iter().map(|(rid, _)| *rid).collect();
                    let mut nodes = vec![s];
                    nodes.extend(hops.iter().map(|(_, n)| *n));
                    if let Some(v) = &rp.var {
                        let val = match rp.range {
                            None => Val::Rel(rels[0]),
                            Some(_) => Val::List(rels.iter().map(|x| Val::Rel(*x)).collect()),
                        };
                        r.set(v, val);
                    }
                    if let Some(pv) = &p.var {
                        r.set(
                            pv,
                            Val::Path {
                                nodes,
                                rels: rels.clone(),
                            },
                        );
                    }
                    let n_used = rels.len();
                    used.extend(rels);
                    let stop = self.match_from(r, pats, i + 1, where_, conj, used, out)?;
                    used.truncate(used.len() - n_used);
                    if stop {
                        return Ok(true);
                    }
                }
            }
        }
        Ok(false)
    }

    /// The shortest paths from `s` to `t` read back from a breadth-first search's `parents`,
    /// each as hops `(relationship, node reached)` from `s`: one path for
    /// [`Shortest::One`], every one for [`Shortest::All`] (in a deterministic order).
    fn paths_back(
        &self,
        s: u64,
        t: u64,
        parents: &HashMap<u64, Vec<(u64, u64)>>,
        kind: Shortest,
    ) -> R<Vec<Vec<(u64, u64)>>> {
        if s == t {
            return Ok(vec![Vec::new()]);
        }
        let mut out = Vec::new();
        // depth-first over parent choices, from t back to s: (node, choice index) frames
        let mut back: Vec<(u64, u64)> = Vec::new(); // (rel, node it reaches), t first
        let mut stack: Vec<(u64, usize)> = vec![(t, 0)];
        while let Some((node, choice)) = stack.last_mut() {
            self.tick()?;
            let node = *node;
            if node == s {
                let mut hops = back.clone();
                hops.reverse();
                out.push(hops);
                if kind == Shortest::One {
                    break;
                }
                stack.pop();
                back.pop();
                continue;
            }
            let ps = parents.get(&node).map(Vec::as_slice).unwrap_or(&[]);
            if *choice >= ps.len() {
                stack.pop();
                back.pop();
                continue;
            }
            let (rid, prev) = ps[*choice];
            *choice += 1;
            back.push((rid, node));
            stack.push((prev, 0));
            self.room(out.len())?;
        }
        Ok(out)
    }

    fn candidates(&self, a: &Anchor<'_>, row: &Row) -> R<Vec<u64>> {
        let g = self.g();
        Ok(match &a.source {
            Source::Bound(v) => match row.get(v) {
                Some(Val::Node(id)) if !self.deleted_node(*id) => vec![*id],
                Some(Val::Null) | None => Vec::new(),
                Some(Val::Node(_)) => Vec::new(),
                Some(other) => {
                    return Err(type_err(format!(
                        "`{v}` is a {}, not a node",
                        other.type_name()
                    )));
                }
            },
            Source::IndexEq { label, key, value } => {
                let v = self.eval(value, row)?;
                match v.to_value() {
                    Some(Value::Null) | None => Vec::new(),
                    Some(val) => g.find_nodes(label, key, &val)?,
                }
            }
            Source::IndexRange {
                label,
                key,
                lower,
                upper,
            } => {
                let b = |x: &Option<(&Expr, bool)>| -> R<Option<crate::ValueBound>> {
                    Ok(match x {
                        None => Some(crate::ValueBound::Unbounded),
                        Some((e, incl)) => match self.eval(e, row)?.to_value() {
                            Some(Value::Int(i)) => Some(bound(Value::Int(i), *incl)),
                            Some(Value::Float(f)) if f.is_finite() => {
                                Some(bound(Value::Float(f), *incl))
                            }
                            Some(Value::String(s)) => Some(bound(Value::String(s), *incl)),
                            _ => None,
                        },
                    })
                };
                match (b(lower)?, b(upper)?) {
                    (Some(lo), Some(hi)) => g.find_range(label, key, lo, hi)?,
                    _ => Vec::new(),
                }
            }
            Source::Label(l) => g.nodes_with_label(l)?,
            Source::All => g.all_node_ids()?,
        })
    }

    /// Whether node `id` fits the node pattern; binds its variable into `row`.
    fn node_ok(&self, id: u64, np: &NodePat, row: &mut Row) -> R<bool> {
        if self.deleted_node(id) {
            return Ok(false);
        }
        if let Some(v) = &np.var {
            match row.get(v) {
                Some(Val::Node(b)) if *b != id => return Ok(false),
                Some(Val::Node(_)) => {}
                Some(Val::Null) => return Ok(false),
                Some(_) => return Ok(false),
                None => {}
            }
        }
        if !np.labels.is_empty() || np.props.is_some() {
            let g = self.g();
            let mut record = None;
            let mut node = |ctx: &Self| -> R<Option<Rc<crate::Node>>> {
                if record.is_none() {
                    record = Some(ctx.node_cached(id)?);
                }
                Ok(record.clone().flatten())
            };
            for l in &np.labels {
                let Some(lid) = g.label(l) else {
                    return Ok(false);
                };
                let set = match self.tx {
                    Tx::Read(_) => self.label_sets.members(lid.0, || g.label_scan(lid))?,
                    Tx::Write(_) => None,
                };
                let has = match set {
                    Some(set) => set.contains(id),
                    None => node(self)?.is_some_and(|n| n.has_label(lid)),
                };
                if !has {
                    return Ok(false);
                }
            }
            if let Some(pe) = &np.props {
                let Some(node) = node(self)? else {
                    return Ok(false);
                };
                let want = self.eval(pe, row)?;
                if !self.props_match(&want, |k| {
                    g.prop_key(k).and_then(|pk| node.get(pk).cloned())
                })? {
                    return Ok(false);
                }
            }
        }
        if let Some(v) = &np.var {
            row.set(v, Val::Node(id));
        }
        Ok(true)
    }

    fn props_match(&self, want: &Val, get: impl Fn(&str) -> Option<Value>) -> R<bool> {
        match want {
            Val::Null => Ok(true),
            Val::Map(m) => {
                for (k, v) in m {
                    let have = get(k).map(Val::from).unwrap_or(Val::Null);
                    if equals(&have, v) != Some(true) {
                        return Ok(false);
                    }
                }
                Ok(true)
            }
            o => Err(type_err(format!(
                "a pattern's properties must be a map, got {}",
                o.type_name()
            ))),
        }
    }

    fn rel_ok(&self, rid: u64, rp: &RelPat, row: &Row) -> R<bool> {
        if self.deleted_rel(rid) {
            return Ok(false);
        }
        if let Some(pe) = &rp.props {
            let g = self.g();
            let Some(rel) = g.rel(rid)? else {
                return Ok(false);
            };
            let want = self.eval(pe, row)?;
            if !self.props_match(&want, |k| g.prop_key(k).and_then(|pk| rel.get(pk).cloned()))? {
                return Ok(false);
            }
        }
        Ok(true)
    }

    fn type_filter(&self, rp: &RelPat) -> Option<Vec<crate::RelType>> {
        let g = self.g();
        if rp.types.is_empty() {
            return None;
        }
        Some(rp.types.iter().filter_map(|t| g.rel_type(t)).collect())
    }

    /// Relationships from `from` matching `rp` taken in direction `forward`: (rel, other end).
    fn hops(
        &self,
        from: u64,
        rp: &RelPat,
        forward: bool,
        types: &Option<Vec<crate::RelType>>,
    ) -> R<Vec<(u64, u64)>> {
        let dir = match (rp.dir, forward) {
            (Dir::Out, true) | (Dir::In, false) => Dir::Out,
            (Dir::In, true) | (Dir::Out, false) => Dir::In,
            (Dir::Both, _) => Dir::Both,
        };
        let g = self.g();
        let mut out = Vec::new();
        match types {
            Some(ts) if ts.is_empty() => {}
            Some(ts) if ts.len() == 1 => {
                for a in g.neighbours(from, dir_of(dir), Some(ts[0]))? {
                    out.push((a.rel, a.other));
                }
            }
            Some(ts) => {
                for a in g.neighbours(from, dir_of(dir), None)? {
                    if ts.contains(&a.ty) {
                        out.push((a.rel, a.other));
                    }
                }
            }
            None => {
                for a in g.neighbours(from, dir_of(dir), None)? {
                    out.push((a.rel, a.other));
                }
            }
        }
        Ok(out)
    }

    #[allow(clippy::too_many_arguments)]
    fn expand(
        &self,
        p: &PathPattern,
        moves: &[(usize, bool)],
        mi: usize,
        row: Row,
        st: &mut PathState,
        used: &mut Vec<u64>,
        k: &mut OnMatch<'_, 'a, 'b>,
    ) -> R<bool> {
        if mi == moves.len() {
            return k(self, row, st, used);
        }
        let (j, forward) = moves[mi];
        let (rp, _) = &p.steps[j];
        let (from, to_idx) = if forward {
            (st.nodes[j], j + 1)
        } else {
            (st.nodes[j + 1], j)
        };
        let target = node_pat(p, to_idx);
        let types = self.type_filter(rp);
        match rp.range {
            None => {
                for (rid, other) in self.hops(from, rp, forward, &types)? {
                    self.tick()?;
                    if used.contains(&rid) || !self.rel_ok(rid, rp, &row)? {
                        continue;
                    }
                    let mut r = row.clone();
                    if let Some(v) = &rp.var {
                        match r.get(v) {
                            Some(Val::Rel(b)) if *b != rid => continue,
                            Some(Val::Rel(_)) | None => r.set(v, Val::Rel(rid)),
                            Some(_) => continue,
                        }
                    }
                    if !self.node_ok(other, target, &mut r)? {
                        continue;
                    }
                    st.nodes[to_idx] = other;
                    st.segs[j] = vec![(rid, other)];
                    if !forward {
                        st.segs[j] = vec![(rid, from)];
                    }
                    used.push(rid);
                    let stop = self.expand(p, moves, mi + 1, r, st, used, k)?;
                    used.pop();
                    if stop {
                        return Ok(true);
                    }
                }
                Ok(false)
            }
            Some((lo, hi)) => {
                let lo = lo.unwrap_or(1) as usize;
                let hi = hi.map_or(usize::MAX, |h| h as usize);
                let mut trail: Vec<(u64, u64)> = Vec::new();
                self.var_len(
                    p, moves, mi, &row, st, used, k, from, lo, hi, &types, &mut trail,
                )
            }
        }
    }

    /// Emits one variable-length hop sequence `trail` ending at `at` if it is long enough and
    /// its end fits; true stops the search.
    #[allow(clippy::too_many_arguments)]
    fn var_len_emit(
        &self,
        p: &PathPattern,
        moves: &[(usize, bool)],
        mi: usize,
        row: &Row,
        st: &mut PathState,
        used: &mut Vec<u64>,
        k: &mut OnMatch<'_, 'a, 'b>,
        at: u64,
        lo: usize,
        trail: &[(u64, u64)],
    ) -> R<bool> {
        let (j, forward) = moves[mi];
        let (rp, _) = &p.steps[j];
        let to_idx = if forward { j + 1 } else { j };
        if trail.len() >= lo {
            let target = node_pat(p, to_idx);
            let mut r = row.clone();
            let rels_fwd: Vec<u64> = if forward {
                trail.iter().map(|(r, _)| *r).collect()
            } else {
                trail.iter().rev().map(|(r, _)| *r).collect()
            };
            let ok_var = match &rp.var {
                None => true,
                Some(v) => match r.get(v) {
                    None => {
                        r.set(
                            v,
                            Val::List(rels_fwd.iter().map(|x| Val::Rel(*x)).collect()),
                        );
                        true
                    }
                    Some(Val::List(l)) => {
                        l.len() == rels_fwd.len()
                            && l.iter()
                                .zip(&rels_fwd)
                                .all(|(a, b)| matches!(a, Val::Rel(x) if x == b))
                    }
                    Some(_) => false,
                },
            };
            if ok_var && self.node_ok(at, target, &mut r)? {
                st.nodes[to_idx] = at;
                st.segs[j] = if forward {
                    trail.to_vec()
                } else {
                    // walking back from node j+1 to node j; store hops in forward order
                    let start = st.nodes[j + 1];
                    let mut nodes_back: Vec<u64> = trail.iter().map(|(_, n)| *n).collect();
                    nodes_back.pop();
                    nodes_back.reverse();
                    nodes_back.push(start);
                    trail
                        .iter()
                        .rev()
                        .map(|(r, _)| *r)
                        .zip(nodes_back)
                        .collect()
                };
                let n_used = trail.len();
                used.extend(trail.iter().map(|(r, _)| *r));
                let stop = self.expand(p, moves, mi + 1, r, st, used, k)?;
                used.truncate(used.len() - n_used);
                if stop {
                    return Ok(true);
                }
            }
        }
        Ok(false)
    }

    /// Depth-first search over variable-length hops with an explicit stack, so that long paths
    /// cannot overflow the call stack.
    #[allow(clippy::too_many_arguments)]
    fn var_len(
        &self,
        p: &PathPattern,
        moves: &[(usize, bool)],
        mi: usize,
        row: &Row,
        st: &mut PathState,
        used: &mut Vec<u64>,
        k: &mut OnMatch<'_, 'a, 'b>,
        from: u64,
        lo: usize,
        hi: usize,
        types: &Option<Vec<crate::RelType>>,
        trail: &mut Vec<(u64, u64)>,
    ) -> R<bool> {
        let (j, forward) = moves[mi];
        let (rp, _) = &p.steps[j];
        if self.var_len_emit(p, moves, mi, row, st, used, k, from, lo, trail)? {
            return Ok(true);
        }
        // frames of (hops out of a node, next hop to try)
        let mut stack: Vec<(Vec<(u64, u64)>, usize)> = Vec::new();
        if hi > 0 {
            stack.push((self.hops(from, rp, forward, types)?, 0));
        }
        while let Some((hops, next)) = stack.last_mut() {
            self.tick()?;
            if *next >= hops.len() {
                stack.pop();
                trail.pop();
                continue;
            }
            let (rid, other) = hops[*next];
            *next += 1;
            if used.contains(&rid)
                || trail.iter().any(|(r, _)| *r == rid)
                || !self.rel_ok(rid, rp, row)?
            {
                continue;
            }
            trail.push((rid, other));
            if self.var_len_emit(p, moves, mi, row, st, used, k, other, lo, trail)? {
                return Ok(true);
            }
            if trail.len() < hi {
                let h = self.hops(other, rp, forward, types)?;
                stack.push((h, 0));
            } else {
                trail.pop();
            }
        }
        Ok(false)
    }

    // ------------------------------------------------------------------ writes

    fn prop_value(v: Val, key: &str) -> R<Value> {
        let bad = |t: &str| {
            QueryError::new(
                ErrorKind::Type,
                "InvalidPropertyType",
                format!("property `{key}` cannot hold a {t}"),
                None,
            )
        };
        match &v {
            Val::Map(_) => return Err(bad("map")),
            Val::Node(_) | Val::Rel(_) | Val::Path { .. } => return Err(bad(v.type_name())),
            Val::List(l)
                if l.iter().any(|x| {
                    matches!(
                        x,
                        Val::Map(_) | Val::Node(_) | Val::Rel(_) | Val::Path { .. } | Val::List(_)
                    )
                }) =>
            {
                return Err(bad("list of maps, lists or graph elements"));
            }
            Val::Float(f) if !f.is_finite() => {
                return Err(QueryError::new(
                    ErrorKind::Argument,
                    "InvalidArgumentValue",
                    format!("property `{key}` cannot be {}", super::eval::fmt_float(*f)),
                    None,
                ));
            }
            _ => {}
        }
        v.to_value().ok_or_else(|| bad("value"))
    }

    fn eval_props(&self, e: &Option<Expr>, row: &Row) -> R<Vec<(String, Value)>> {
        let Some(e) = e else { return Ok(Vec::new()) };
        match self.eval(e, row)? {
            Val::Null => Ok(Vec::new()),
            Val::Map(m) => {
                let mut out = Vec::new();
                for (k, v) in m {
                    if v.is_null() {
                        continue;
                    }
                    out.push((k.clone(), Self::prop_value(v, &k)?));
                }
                Ok(out)
            }
            o => Err(type_err(format!(
                "properties must be a map, got {}",
                o.type_name()
            ))),
        }
    }

    fn check_merge_props(&self, row: &Row, p: &PathPattern) -> R<()> {
        let check = |e: &Option<Expr>| -> R<()> {
            if let Some(e) = e
                && let Val::Map(m) = self.eval(e, row)?
                && let Some((k, _)) = m.iter().find(|(_, v)| v.is_null())
            {
                return Err(sem(
                    "MergeReadOwnWrites",
                    format!("cannot MERGE with a null value for property `{k}`"),
                ));
            }
            Ok(())
        };
        check(&p.start.props)?;
        for (r, n) in &p.steps {
            check(&r.props)?;
            check(&n.props)?;
        }
        Ok(())
    }

    /// A list of numbers becomes a vector where the schema declares `key` a vector for one of
    /// the node's labels (so Cypher can write `Instance.feature`). The labels are only looked
    /// up for such lists.
    fn schema_vector(
        &self,
        labels: impl FnOnce() -> R<Vec<String>>,
        key: &str,
        v: Value,
    ) -> R<Value> {
        let Value::List(items) = &v else {
            return Ok(v);
        };
        if items.is_empty()
            || !items
                .iter()
                .all(|x| matches!(x, Value::Int(_) | Value::Float(_)))
        {
            return Ok(v);
        }
        let labels = labels()?;
        let schema = &self.g().view().raw.base().schema.schema;
        let wants = labels.iter().any(|l| {
            schema.labels.get(l).is_some_and(|r| {
                r.properties
                    .iter()
                    .any(|p| p.key == key && p.ty == crate::ValueType::Vector)
            }) || schema
                .vector_indexes
                .iter()
                .any(|x| &x.label == l && x.key == key)
        });
        if !wants {
            return Ok(v);
        }
        Ok(Value::Vector(
            items
                .iter()
                .map(|x| x.as_f64().unwrap_or(0.0) as f32)
                .collect(),
        ))
    }

    fn create_node(&mut self, row: &mut Row, np: &NodePat) -> R<u64> {
        if let Some(v) = &np.var
            && let Some(b) = row.get(v)
        {
            return match b {
                Val::Node(id) => Ok(*id),
                Val::Null => Err(sem(
                    "CreateNullNode",
                    format!("cannot create a relationship to `{v}`, which is null"),
                )),
                o => Err(type_err(format!(
                    "`{v}` is a {}, not a node",
                    o.type_name()
                ))),
            };
        }
        let props: Vec<(String, Value)> = self
            .eval_props(&np.props, row)?
            .into_iter()
            .map(|(k, v)| {
                let v = self.schema_vector(|| Ok(np.labels.clone()), &k, v)?;
                Ok((k, v))
            })
            .collect::<R<_>>()?;
        let w = self.w()?;
        let mut labels = Vec::new();
        for l in &np.labels {
            labels.push(w.label_id(l)?);
        }
        labels.sort();
        labels.dedup();
        let mut ps = Vec::new();
        for (k, v) in props {
            ps.push((w.prop_key_id(&k)?, v));
        }
        let n_props = ps.len();
        let id = w.create_node(&labels, ps)?;
        self.stats.nodes_created += 1;
        self.stats.labels_added += labels.len() as u64;
        self.stats.properties_set += n_props as u64;
        if let Some(v) = &np.var {
            row.set(v, Val::Node(id));
        }
        Ok(id)
    }

    fn create_path(&mut self, row: &mut Row, p: &PathPattern) -> R<()> {
        let mut prev = self.create_node(row, &p.start)?;
        let mut nodes = vec![prev];
        let mut rels = Vec::new();
        for (rp, np) in &p.steps {
            let next = self.create_node(row, np)?;
            if rp.types.len() != 1 {
                return Err(QueryError::new(
                    ErrorKind::Syntax,
                    "NoSingleRelationshipType",
                    "a created relationship needs exactly one type",
                    Some(rp.pos),
                ));
            }
            let (s, e) = match rp.dir {
                // MERGE may leave the direction open; it then creates the relationship left to right
                Dir::Out | Dir::Both => (prev, next),
                Dir::In => (next, prev),
            };
            let props = self.eval_props(&rp.props, row)?;
            let w = self.w()?;
            let ty = w.rel_type_id(&rp.types[0])?;
            let mut ps = Vec::new();
            for (k, v) in props {
                ps.push((w.prop_key_id(&k)?, v));
            }
            let n_props = ps.len();
            let rid = w.create_rel(s, ty, e, ps)?;
            self.stats.relationships_created += 1;
            self.stats.properties_set += n_props as u64;
            if let Some(v) = &rp.var {
                row.set(v, Val::Rel(rid));
            }
            nodes.push(next);
            rels.push(rid);
            prev = next;
        }
        if let Some(v) = &p.var {
            row.set(v, Val::Path { nodes, rels });
        }
        Ok(())
    }

    fn set_prop(&mut self, target: &Val, key: &str, v: Val) -> R<()> {
        let value = if v.is_null() {
            Value::Null
        } else {
            Self::prop_value(v, key)?
        };
        let null = value.is_null();
        match target {
            Val::Null => return Ok(()),
            Val::Node(id) => {
                let id = *id;
                let value = self.schema_vector(|| self.labels_of(id), key, value)?;
                let w = self.w()?;
                let k = w.prop_key_id(key)?;
                w.set_node_prop(id, k, value)?;
            }
            Val::Rel(id) => {
                let id = *id;
                let w = self.w()?;
                let k = w.prop_key_id(key)?;
                w.set_rel_prop(id, k, value)?;
            }
            o => {
                return Err(type_err(format!(
                    "cannot set property `{key}` on a {}",
                    o.type_name()
                )));
            }
        }
        if !null {
            self.stats.properties_set += 1;
        }
        Ok(())
    }

    fn set_item(&mut self, row: &mut Row, it: &SetItem) -> R<()> {
        match it {
            SetItem::Prop { target, key, value } => {
                let t = self.eval(target, row)?;
                let v = self.eval(value, row)?;
                self.set_prop(&t, key, v)
            }
            SetItem::Replace { var, value, pos } | SetItem::Merge { var, value, pos } => {
                let replace = matches!(it, SetItem::Replace { .. });
                let t = Self::var_of(row, var, *pos)?;
                if t.is_null() {
                    return Ok(());
                }
                let v = self.eval(value, row)?;
                let map = match &v {
                    Val::Map(m) => m.clone(),
                    Val::Node(_) | Val::Rel(_) => match self.properties(&v)? {
                        Val::Map(m) => m,
                        _ => BTreeMap::new(),
                    },
                    Val::Null if replace => BTreeMap::new(),
                    o => {
                        return Err(type_err(format!(
                            "SET {var} {} needs a map, got {}",
                            if replace { "=" } else { "+=" },
                            o.type_name()
                        )));
                    }
                };
                if replace && let Val::Map(old) = self.properties(&t)? {
                    for k in old.keys() {
                        if !map.contains_key(k) {
                            self.set_prop(&t, k, Val::Null)?;
                        }
                    }
                }
                for (k, x) in map {
                    self.set_prop(&t, &k, x)?;
                }
                Ok(())
            }
            SetItem::Labels { var, labels, pos } => {
                self.change_labels(row, var, labels, *pos, true)
            }
        }
    }

    fn remove_item(&mut self, row: &Row, it: &RemoveItem) -> R<()> {
        match it {
            RemoveItem::Prop { target, key } => {
                let t = self.eval(target, row)?;
                if t.is_null() {
                    return Ok(());
                }
                let had = !self.property(&t, key)?.is_null();
                self.set_prop(&t, key, Val::Null)?;
                if had {
                    self.stats.properties_removed += 1;
                }
                Ok(())
            }
            RemoveItem::Labels { var, labels, pos } => {
                self.change_labels(row, var, labels, *pos, false)
            }
        }
    }

    /// The value of a variable a write clause names.
    fn var_of(row: &Row, var: &str, pos: super::Pos) -> R<Val> {
        row.get(var).cloned().ok_or_else(|| {
            QueryError::new(
                ErrorKind::Semantic,
                "UndefinedVariable",
                format!("variable `{var}` is not defined"),
                Some(pos),
            )
        })
    }

    /// `SET n:A:B` (add) or `REMOVE n:A:B`; a null target is skipped.
    fn change_labels(
        &mut self,
        row: &Row,
        var: &str,
        labels: &[String],
        pos: super::Pos,
        add: bool,
    ) -> R<()> {
        let id = match Self::var_of(row, var, pos)? {
            Val::Null => return Ok(()),
            Val::Node(id) => id,
            o => {
                return Err(type_err(format!(
                    "cannot change the labels of a {}",
                    o.type_name()
                )));
            }
        };
        let have = self.labels_of(id)?;
        let w = self.w()?;
        let mut changed = 0;
        for l in labels {
            if add && !have.contains(l) {
                let lid = w.label_id(l)?;
                w.add_label(id, lid)?;
                changed += 1;
            } else if !add
                && have.contains(l)
                && let Some(lid) = GraphRead::label(&*w, l)
            {
                w.remove_label(id, lid)?;
                changed += 1;
            }
        }
        if add {
            self.stats.labels_added += changed;
        } else {
            self.stats.labels_removed += changed;
        }
        Ok(())
    }

    fn delete(&mut self, mut nodes: Vec<u64>, mut rels: Vec<u64>, detach: bool) -> R<()> {
        rels.sort_unstable();
        rels.dedup();
        nodes.sort_unstable();
        nodes.dedup();
        for r in rels {
            if self.deleted_rels.contains(&r) {
                continue;
            }
            self.remember_type(r)?;
            self.w()?.delete_rel(r)?;
            self.deleted_rels.insert(r);
            self.stats.relationships_deleted += 1;
        }
        for n in nodes {
            if self.deleted_nodes.contains(&n) {
                continue;
            }
            if detach {
                let attached: Vec<u64> = self
                    .g()
                    .neighbours(n, crate::Direction::Both, None)?
                    .into_iter()
                    .map(|a| a.rel)
                    .collect();
                for r in &attached {
                    self.remember_type(*r)?;
                    if self.deleted_rels.insert(*r) {
                        self.stats.relationships_deleted += 1;
                    }
                }
                self.w()?.detach_delete_node(n)?;
            } else {
                match self.w()?.delete_node(n) {
                    Ok(()) => {}
                    Err(crate::Error::NodeHasRelationships { node, count }) => {
                        return Err(QueryError::new(
                            ErrorKind::Constraint,
                            "DeleteConnectedNode",
                            format!(
                                "node {node} still has {count} relationship(s); use DETACH DELETE"
                            ),
                            None,
                        ));
                    }
                    Err(e) => return Err(e.into()),
                }
            }
            self.deleted_nodes.insert(n);
            self.stats.nodes_deleted += 1;
        }
        Ok(())
    }

    // -------------------------------------------------------------- procedures

    fn procedure(&self, name: &str, a: Vec<Val>) -> R<(Vec<&'static str>, Vec<Vec<Val>>)> {
        let g = self.g();
        let s = |v: &Val, what: &str| -> R<String> {
            match v {
                Val::Str(s) => Ok(s.clone()),
                o => Err(type_err(format!(
                    "{name}: {what} must be a string, got {}",
                    o.type_name()
                ))),
            }
        };
        let int = |v: &Val, what: &str| -> R<usize> {
            match v {
                Val::Int(i) if *i >= 0 => Ok(*i as usize),
                o => Err(type_err(format!(
                    "{name}: {what} must be a non-negative integer, got {}",
                    o.type_name()
                ))),
            }
        };
        let pt = |v: &Val, what: &str| -> R<[f64; 3]> {
            match v {
                Val::Point2D([x, y]) => Ok([*x, *y, 0.0]),
                Val::Point3D(p) => Ok(*p),
                Val::List(l) if l.len() == 3 || l.len() == 2 => {
                    let c: Option<Vec<f64>> = l.iter().map(Val::as_f64).collect();
                    let c = c.ok_or_else(|| type_err(format!("{name}: {what} must be a point")))?;
                    Ok([c[0], c[1], c.get(2).copied().unwrap_or(0.0)])
                }
                o => Err(type_err(format!(
                    "{name}: {what} must be a point, got {}",
                    o.type_name()
                ))),
            }
        };
        let axis_names = |axes: [usize; 2]| {
            let n = ["x", "y", "z"];
            format!("{}, {}", n[axes[0]], n[axes[1]])
        };
        // a 2-D point has no height: on a map with a ground plane it would be read as (x, y)
        // with z = 0, which is no place on the ground of a kitti_cam map
        let pt3 = |v: &Val, what: &str| -> R<[f64; 3]> {
            if let (Some(axes), Val::Point2D(_) | Val::List(_)) = (self.ground_axes, v)
                && !matches!(v, Val::List(l) if l.len() == 3)
            {
                return Err(type_err(format!(
                    "{name}: {what} is a 2-D point, which has no height; for ground coordinates ({}) use \
                     db.index.spatial.withinGroundDistance or db.index.spatial.nearestOnGround",
                    axis_names(axes)
                )));
            }
            pt(v, what)
        };
        // a ground point: two coordinates along the ground axes, or a 3-D point whose height
        // is dropped
        let ground = |v: &Val, what: &str| -> R<([f64; 2], [usize; 2])> {
            let axes = self.ground_axes.ok_or_else(|| {
                QueryError::new(
                    ErrorKind::Procedure,
                    "NoGroundPlane",
                    format!("{name}: this session declares no ground plane (QueryOptions::ground_axes); use withinDistance or nearest"),
                    None,
                )
            })?;
            let g = match v {
                Val::Point3D(p) => [p[axes[0]], p[axes[1]]],
                Val::Point2D(p) => *p,
                Val::List(l) if l.len() == 2 || l.len() == 3 => {
                    let c: Option<Vec<f64>> = l.iter().map(Val::as_f64).collect();
                    let c = c.ok_or_else(|| type_err(format!("{name}: {what} must be a point")))?;
                    if c.len() == 2 {
                        [c[0], c[1]]
                    } else {
                        [c[axes[0]], c[axes[1]]]
                    }
                }
                o => {
                    return Err(type_err(format!(
                        "{name}: {what} must be a point (ground coordinates {} as a 2-D point or list, or a 3-D point), got {}",
                        axis_names(axes),
                        o.type_name()
                    )));
                }
            };
            Ok((g, axes))
        };
        let arity = |n: usize, sig: &str| -> R<()> {
            if a.len() == n {
                Ok(())
            } else {
                Err(QueryError::new(
                    ErrorKind::Syntax,
                    "InvalidNumberOfArguments",
                    format!("{name} takes {n} argument(s): {sig}"),
                    None,
                ))
            }
        };
        match name.to_ascii_lowercase().as_str() {
            "db.index.vector.querynodes" => {
                arity(3, "(indexName, k, vector)")?;
                let idx = s(&a[0], "indexName")?;
                let k = int(&a[1], "k")?;
                let q = a[2]
                    .as_f32s()
                    .ok_or_else(|| type_err(format!("{name}: vector must be a list of numbers")))?;
                if !q.iter().any(|x| *x != 0.0) || q.iter().any(|x| !x.is_finite()) {
                    return Err(arg_err(
                        "InvalidArgumentValue",
                        format!(
                            "{name}: the query vector must be finite and not all zeros (it has no direction)"
                        ),
                    ));
                }
                // Neo4j reports cosine similarity as (1 + cos) / 2, in [0, 1] (f32 rounding can
                // put a cosine a hair outside [-1, 1])
                Ok(scored(g.vector_top_k(&idx, &q, k)?, "score", |c| {
                    ((1.0 + c) / 2.0).clamp(0.0, 1.0)
                }))
            }
            "db.index.fulltext.querynodes" => {
                if a.len() != 2 && a.len() != 3 {
                    arity(2, "(indexName, queryString[, k])")?;
                }
                let idx = s(&a[0], "indexName")?;
                let q = s(&a[1], "queryString")?;
                let k = if a.len() == 3 { int(&a[2], "k")? } else { 100 };
                Ok(scored(g.text_search(&idx, &q, k)?, "score", |b| b))
            }
            "db.index.spatial.withingrounddistance" => {
                arity(3, "(indexName, point, radiusMetres)")?;
                let idx = s(&a[0], "indexName")?;
                let (c, axes) = ground(&a[1], "point")?;
                let r = a[2]
                    .as_f64()
                    .ok_or_else(|| type_err(format!("{name}: radius must be a number")))?;
                Ok(scored(
                    g.spatial_within_ground(&idx, c, axes, r)?,
                    "distance",
                    |d| d,
                ))
            }
            "db.index.spatial.nearestonground" => {
                arity(3, "(indexName, point, k)")?;
                let idx = s(&a[0], "indexName")?;
                let (c, axes) = ground(&a[1], "point")?;
                let k = int(&a[2], "k")?;
                Ok(scored(
                    g.spatial_nearest_ground(&idx, c, axes, k)?,
                    "distance",
                    |d| d,
                ))
            }
            "db.index.spatial.withindistance" => {
                arity(3, "(indexName, point, radiusMetres)")?;
                let idx = s(&a[0], "indexName")?;
                let c = pt3(&a[1], "point")?;
                let r = a[2]
                    .as_f64()
                    .ok_or_else(|| type_err(format!("{name}: radius must be a number")))?;
                Ok(scored(g.spatial_within(&idx, c, r)?, "distance", |d| d))
            }
            "db.index.spatial.nearest" => {
                arity(3, "(indexName, point, k)")?;
                let idx = s(&a[0], "indexName")?;
                let c = pt3(&a[1], "point")?;
                let k = int(&a[2], "k")?;
                Ok(scored(g.spatial_nearest(&idx, c, k)?, "distance", |d| d))
            }
            "db.index.spatial.inbox" => {
                arity(3, "(indexName, minPoint, maxPoint)")?;
                let idx = s(&a[0], "indexName")?;
                let lo = pt(&a[1], "minPoint")?;
                let hi = pt(&a[2], "maxPoint")?;
                let ids = g.spatial_in_box(&idx, lo, hi)?;
                Ok((
                    vec!["node"],
                    ids.into_iter().map(|n| vec![Val::Node(n)]).collect(),
                ))
            }
            "db.labels" | "db.relationshiptypes" => {
                arity(0, "()")?;
                let c = g.counts()?;
                let labels = name.eq_ignore_ascii_case("db.labels");
                let m = if labels { c.nodes } else { c.relationships };
                let col = if labels { "label" } else { "relationshipType" };
                Ok((
                    vec![col, "count"],
                    m.into_iter()
                        .filter(|(_, n)| *n > 0)
                        .map(|(l, n)| vec![Val::Str(l), Val::Int(n as i64)])
                        .collect(),
                ))
            }
            _ => Err(QueryError::new(
                ErrorKind::Procedure,
                "ProcedureNotFound",
                format!(
                    "unknown procedure {name}; known: db.index.vector.queryNodes, db.index.fulltext.queryNodes, \
                     db.index.spatial.withinDistance, db.index.spatial.nearest, db.index.spatial.withinGroundDistance, \
                     db.index.spatial.nearestOnGround, db.index.spatial.inBox, db.labels, db.relationshipTypes"
                ),
                None,
            )),
        }
    }
}

/// Index hits as procedure rows `(node, <score column>)`.
fn scored(
    hits: Vec<crate::Hit>,
    column: &'static str,
    scale: fn(f64) -> f64,
) -> (Vec<&'static str>, Vec<Vec<Val>>) {
    let rows = hits
        .into_iter()
        .map(|h| vec![Val::Node(h.node), Val::Float(scale(h.score))])
        .collect();
    (vec!["node", column], rows)
}

fn bound(v: Value, inclusive: bool) -> crate::ValueBound {
    if inclusive {
        crate::ValueBound::Inclusive(v)
    } else {
        crate::ValueBound::Exclusive(v)
    }
}

/// Whether every variable `e` reads is bound in `row` (so it can be evaluated before matching).
fn expr_bound(e: &Expr, row: &Row) -> bool {
    expr_bound_by(e, &|v| row.get(v).is_some())
}

/// Whether `e` reads only variables `bound` says are bound, and nothing that depends on more
/// than them (patterns, comprehensions, subqueries, aggregates, `rand()`).
pub(crate) fn expr_bound_by(e: &Expr, bound: &dyn Fn(&str) -> bool) -> bool {
    let mut ok = true;
    e.walk(&mut |x| match x {
        Expr::Var(v, _) if !bound(v) => ok = false,
        Expr::Pattern(_)
        | Expr::PatternComp { .. }
        | Expr::Subquery { .. }
        | Expr::ListComp { .. }
        | Expr::Quantified { .. }
        | Expr::Reduce { .. }
        | Expr::CountStar
        | Expr::AggRef(_) => ok = false,
        Expr::Func { name, .. }
            if super::ast::AGGREGATES.contains(&name.to_ascii_lowercase().as_str())
                || name.eq_ignore_ascii_case("rand") =>
        {
            ok = false
        }
        _ => {}
    });
    ok
}

pub(crate) fn node_pat(p: &PathPattern, i: usize) -> &NodePat {
    if i == 0 { &p.start } else { &p.steps[i - 1].1 }
}

/// What to do with each complete match of a path pattern; true stops the search.
type OnMatch<'k, 'a, 'b> = dyn FnMut(&Ctx<'a, 'b>, Row, &PathState, &mut Vec<u64>) -> R<bool> + 'k;

pub(crate) struct PathState {
    nodes: Vec<u64>,
    /// Per relationship pattern, the hops `(rel, node after)` in the pattern's left-to-right order.
    segs: Vec<Vec<(u64, u64)>>,
}

impl PathState {
    fn path(&self) -> Val {
        let mut nodes = vec![self.nodes[0]];
        let mut rels = Vec::new();
        for seg in &self.segs {
            for (r, n) in seg {
                rels.push(*r);
                nodes.push(*n);
            }
        }
        Val::Path { nodes, rels }
    }
}

fn collect_deletes(v: &Val, nodes: &mut Vec<u64>, rels: &mut Vec<u64>) -> R<()> {
    match v {
        Val::Null => Ok(()),
        Val::Node(n) => {
            nodes.push(*n);
            Ok(())
        }
        Val::Rel(r) => {
            rels.push(*r);
            Ok(())
        }
        Val::Path {
            nodes: ns,
            rels: rs,
        } => {
            nodes.extend(ns);
            rels.extend(rs);
            Ok(())
        }
        Val::List(l) => l.iter().try_for_each(|x| collect_deletes(x, nodes, rels)),
        o => Err(type_err(format!(
            "DELETE takes nodes, relationships or paths, got {}",
            o.type_name()
        ))),
    }
}

/// Replaces aggregate calls by slots, recording `(name, distinct, args)` for each.
pub(crate) fn rewrite_aggs(e: &Expr, specs: &mut Vec<(String, bool, Vec<Expr>)>) -> Expr {
    match e {
        Expr::CountStar => {
            specs.push(("count*".into(), false, Vec::new()));
            Expr::AggRef(specs.len() - 1)
        }
        Expr::Func {
            name,
            distinct,
            args,
            ..
        } if super::ast::AGGREGATES.contains(&name.to_ascii_lowercase().as_str()) => {
            specs.push((name.to_ascii_lowercase(), *distinct, args.clone()));
            Expr::AggRef(specs.len() - 1)
        }
        other => other.map_children(&mut |c| rewrite_aggs(c, specs)),
    }
}

pub(crate) fn aggregate(name: &str, distinct: bool, mut vals: Vec<Val>) -> R<Val> {
    if name == "count*" {
        return Ok(Val::Int(vals.len() as i64));
    }
    // percentiles carry (value, percentile) pairs
    let (vals, pct) = if name.starts_with("percentile") {
        let mut p = None;
        let mut v = Vec::new();
        for x in vals.drain(..) {
            if let Val::List(mut pair) = x
                && pair.len() == 2
            {
                let q = pair.pop().unwrap_or_default();
                p = Some(q);
                v.push(pair.pop().unwrap_or_default());
            }
        }
        (v, p)
    } else {
        (vals, None)
    };
    let mut vals: Vec<Val> = vals.into_iter().filter(|v| !v.is_null()).collect();
    if distinct {
        let mut seen = std::collections::BTreeSet::new();
        vals.retain(|v| seen.insert(Key(vec![v.clone()])));
    }
    let nums = |vals: &[Val]| -> R<Vec<f64>> {
        vals.iter()
            .map(|v| {
                v.as_f64().ok_or_else(|| {
                    type_err(format!("{name}() needs numbers, got {}", v.type_name()))
                })
            })
            .collect()
    };
    Ok(match name {
        "count" => Val::Int(vals.len() as i64),
        "collect" => Val::List(vals),
        "sum" => {
            if vals.iter().all(|v| matches!(v, Val::Int(_))) {
                let mut s: i64 = 0;
                for v in &vals {
                    if let Val::Int(i) = v {
                        s = s
                            .checked_add(*i)
                            .ok_or_else(|| arg_err("NumberOutOfRange", "sum() overflowed"))?;
                    }
                }
                Val::Int(s)
            } else {
                Val::Float(nums(&vals)?.iter().sum())
            }
        }
        "avg" => {
            if vals.is_empty() {
                Val::Null
            } else {
                let n = nums(&vals)?;
                Val::Float(n.iter().sum::<f64>() / n.len() as f64)
            }
        }
        "min" | "max" => {
            let mut best: Option<Val> = None;
            for v in vals {
                best = Some(match best {
                    None => v,
                    Some(b) => {
                        let o = super::value::order(&v, &b);
                        if (name == "min" && o.is_lt()) || (name == "max" && o.is_gt()) {
                            v
                        } else {
                            b
                        }
                    }
                });
            }
            best.unwrap_or(Val::Null)
        }
        "stdev" | "stdevp" => {
            let n = nums(&vals)?;
            let k = n.len() as f64;
            if n.len() < 2 && name == "stdev" || n.is_empty() {
                Val::Float(0.0)
            } else {
                let mean = n.iter().sum::<f64>() / k;
                let ss: f64 = n.iter().map(|x| (x - mean).powi(2)).sum();
                Val::Float((ss / if name == "stdev" { k - 1.0 } else { k }).sqrt())
            }
        }
        "percentiledisc" | "percentilecont" => {
            let p = pct.and_then(|p| p.as_f64()).unwrap_or(0.5);
            if !(0.0..=1.0).contains(&p) {
                return Err(arg_err(
                    "NumberOutOfRange",
                    format!("percentile {p} is not between 0 and 1"),
                ));
            }
            let mut n = nums(&vals)?;
            if n.is_empty() {
                return Ok(Val::Null);
            }
            n.sort_by(|a, b| a.total_cmp(b));
            if name == "percentiledisc" {
                let idx = ((p * n.len() as f64).ceil() as usize)
                    .saturating_sub(1)
                    .min(n.len() - 1);
                let x = n[idx];
                if vals.iter().all(|v| matches!(v, Val::Int(_))) {
                    Val::Int(x as i64)
                } else {
                    Val::Float(x)
                }
            } else {
                let pos = p * (n.len() - 1) as f64;
                let lo = pos.floor() as usize;
                let hi = pos.ceil() as usize;
                Val::Float(n[lo] + (n[hi] - n[lo]) * (pos - lo as f64))
            }
        }
        _ => {
            return Err(sem(
                "UnknownFunction",
                format!("unknown aggregate {name}()"),
            ));
        }
    })
}
