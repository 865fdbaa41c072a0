//! A columnar kernel for whole-graph chains: a label scan, expansions over single
//! relationship types, predicates on properties, ending in an aggregation or a top-k.
//!
//! The generic operators pay for a row in dynamic calls, slot writes and value copies (tens
//! of nanoseconds a row); over 200,000 nodes and a million relationships that is what makes a
//! scan slow. Once the commit holds the columns, the in-memory adjacency and the label sets
//! ([`crate::columns`], [`crate::hot`]), this operator runs the same chain as typed loops:
//! node ids from the label list, neighbours from adjacency slices, label checks as bit tests,
//! properties as column reads, predicates on borrowed column cells, groups keyed by
//! dictionary codes, running typed accumulators, and a bounded heap for a top-k. The planner
//! builds it in place of the operators it fuses and keeps those operators as its fallback:
//! when the source has no columns (or a property's column holds values the kernel does not
//! type), the fallback runs, row by row, and gives the same answer. The kernel's answers are
//! the generic operators' answers: the same rows in the same order, the same sums added in
//! the same order, the same null and type rules (checked against the interpreter by
//! `tests/pipeline.rs`).

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::hash::BuildHasher;
use std::sync::Arc;

use hashbrown::{DefaultHashBuilder, HashTable};

use super::super::R;
use super::super::ast::{BinOp, Expr};
use super::super::eval::{arg_err, cmp_op, sort_key_cmp};
use super::super::source::{Way, cell_val};
use super::super::value::{Val, order};
use super::aggregate::AggKind;
use super::expr::CExpr;
use super::{Exec, Flow, Next, Operator, Slots, finish_into, push_into};
use crate::columns::{Cell, Column, LabelMembers};
use crate::hot::AdjMem;

/// A value of the chain: a node (by position, 0 the scanned one) or a relationship (by hop).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Elem {
    Node(usize),
    Rel(usize),
}

/// A property of a chain element, through a read handle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct ColRef {
    pub elem: Elem,
    pub handle: usize,
}

/// One hop: from node `from`, relationships of type `ty` taken `way`, to a node that carries
/// `to_label` (if any); relationships of the hops in `unique` may not be taken again.
#[derive(Debug, Clone)]
pub(crate) struct Hop {
    pub from: usize,
    pub way: Way,
    pub ty: u32,
    pub to_label: Option<u32>,
    pub unique: Vec<usize>,
}

/// A predicate on one property: a comparison with a value fixed for the statement, or a
/// null test.
#[derive(Debug, Clone)]
pub(crate) enum PredOp {
    /// `prop OP value` (`flipped`: the value was on the left).
    Cmp {
        op: BinOp,
        value: CExpr,
        flipped: bool,
    },
    /// `prop IS NULL` (true) or `IS NOT NULL` (false).
    IsNull(bool),
}

/// A predicate of the chain, checked once its element is bound.
#[derive(Debug, Clone)]
pub(crate) struct Pred {
    pub col: ColRef,
    pub op: PredOp,
}

/// What the chain ends in.
#[derive(Debug, Clone)]
pub(crate) enum Sink {
    /// Grouping: keys and aggregate arguments are properties of chain elements; outputs are
    /// expressions over the aggregates only.
    Aggregate {
        keys: Vec<(ColRef, usize)>,
        aggs: Vec<(AggKind, String, Option<ColRef>)>,
        outputs: Vec<(CExpr, usize)>,
    },
    /// The first `SKIP + LIMIT` rows by one property: only those rows are handed on, in the
    /// order they came (the sort after this operator orders them).
    Top {
        key: ColRef,
        asc: bool,
        skip: Option<Expr>,
        limit: Expr,
    },
}

/// The chain's shape, as the planner found it.
#[derive(Debug, Clone)]
pub(crate) struct ChainSpec {
    pub label: u32,
    /// Slot of each node position and of each hop's relationship.
    pub node_slots: Vec<usize>,
    pub rel_slots: Vec<usize>,
    pub hops: Vec<Hop>,
    pub preds: Vec<Pred>,
    pub sink: Sink,
    /// Row width.
    pub slots: usize,
}

/// Which way the operator runs, decided at its first row.
#[derive(Debug)]
enum Mode {
    Kernel(Box<Kernel>),
    Fallback,
}

/// What a fallback operator stands for in the kernel, for PROFILE's figures.
#[derive(Debug, Clone, Copy)]
enum Role {
    Scan,
    Pred(usize),
    Hop(usize),
    Sink,
}

/// Rows the kernel handed from stage to stage: scanned, passing each predicate, found by
/// each hop, and out of the sink.
#[derive(Debug, Clone, Default)]
struct Stats {
    /// The chain was counted from degrees ([`Kernel::factored_count`]).
    factored: bool,
    scanned: u64,
    passed: Vec<u64>,
    hopped: Vec<u64>,
    out: u64,
}

/// The fused operator.
#[derive(Debug)]
pub(crate) struct Columnar {
    pub spec: ChainSpec,
    /// The operators it stands for, run when the kernel cannot be.
    pub fallback: Vec<Box<dyn Operator>>,
    pub text: String,
    mode: Option<Mode>,
    roles: Vec<Role>,
    /// After the kernel ran: its figures.
    stats: Option<Stats>,
}

impl Columnar {
    /// `fallback`: the scan, then the filters and expansions in the order of the spec's
    /// predicates and hops, then (for an aggregation) the aggregate.
    pub(crate) fn new(spec: ChainSpec, fallback: Vec<Box<dyn Operator>>, text: String) -> Self {
        let (mut p, mut h) = (0, 0);
        let roles = fallback
            .iter()
            .enumerate()
            .map(|(i, op)| {
                let any = op.as_any();
                if i == 0 {
                    Role::Scan
                } else if any.is::<super::filter::Filter>() {
                    p += 1;
                    Role::Pred(p - 1)
                } else if any.is::<super::expand::Expand>() {
                    h += 1;
                    Role::Hop(h - 1)
                } else {
                    Role::Sink
                }
            })
            .collect();
        Columnar {
            spec,
            fallback,
            text,
            mode: None,
            roles,
            stats: None,
        }
    }
}

/// A column read borrowed for the statement, with what it may hold.
#[derive(Debug)]
struct Col {
    col: Arc<Column>,
}

impl Col {
    #[inline]
    fn get(&self, id: u64) -> Cell<'_> {
        self.col.get(id)
    }
}

/// Grouping values of one row, typed (a string column's dictionary code, an integer, a
/// float's canonical bits), so a row's key is found without building a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum KeyPart {
    Null,
    Code(u32),
    Int(i64),
    Float(u64),
}

/// A float's grouping identity: -0.0 is 0.0, every NaN is one.
fn float_key(f: f64) -> u64 {
    if f.is_nan() {
        f64::NAN.to_bits()
    } else if f == 0.0 {
        0
    } else {
        f.to_bits()
    }
}

/// A typed running aggregate (the generic [`super::aggregate`] rules on typed inputs).
#[derive(Debug, Clone)]
enum TAcc {
    Count(i64),
    SumInt(Option<i64>),
    /// A float sum and how many values went in (a sum of none is the integer 0).
    SumFloat(f64, u64),
    Avg {
        sum: f64,
        n: u64,
    },
    BestInt(Option<i64>),
    BestFloat(Option<f64>),
    BestStr(Option<u32>),
}

/// Float order as [`order`] has it: NaN above every number, -0.0 equal to 0.0.
#[inline]
fn float_order(a: f64, b: f64) -> Ordering {
    match (a.is_nan(), b.is_nan()) {
        (true, true) => Ordering::Equal,
        (true, false) => Ordering::Greater,
        (false, true) => Ordering::Less,
        _ => a.partial_cmp(&b).unwrap_or(Ordering::Equal),
    }
}

#[derive(Debug)]
struct Group {
    /// The key as typed parts (what rows are matched by) and as values (the first row's).
    parts: Vec<KeyPart>,
    keys: Vec<Val>,
    accs: Vec<TAcc>,
}

/// A top-k candidate: its key, arrival, and the row it came from.
#[derive(Debug)]
struct Cand {
    key: Val,
    seq: u64,
    asc: bool,
    input: usize,
    nodes: Vec<u64>,
    rels: Vec<u64>,
}

impl PartialEq for Cand {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Cand {}
impl PartialOrd for Cand {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Cand {
    /// The sort's order, ties by arrival: the heap's top is the worst candidate kept.
    fn cmp(&self, o: &Self) -> Ordering {
        sort_key_cmp(
            std::slice::from_ref(&self.key),
            std::slice::from_ref(&o.key),
            &[self.asc],
        )
        .then(self.seq.cmp(&o.seq))
    }
}

/// Per hop, each direction's rows of the hop's type by node ([`AdjMem::typed`]).
type HopRows = Vec<Option<Arc<Vec<[u32; 2]>>>>;

/// One partial match: the nodes bound (start, then one per hop), the relationships taken and
/// their adjacency rows (where the relationship's columns are read).
#[derive(Debug)]
struct Bound {
    nodes: Vec<u64>,
    rels: Vec<u64>,
    rows: Vec<u64>,
}

/// The kernel's state for one statement.
#[derive(Debug)]
struct Kernel {
    starts: Arc<LabelMembers>,
    adj: Option<Arc<AdjMem>>,
    /// Per hop, its target label's members.
    to_sets: Vec<Option<Arc<LabelMembers>>>,
    /// Per hop and direction taken ([`dirs_of`]), where each node's rows of the hop's type lie.
    hop_rows: Vec<HopRows>,
    /// For a last hop only counted, per direction: each node's count of its rows to the
    /// target label (a count of matches without walking the rows).
    last_degrees: Vec<Option<Arc<Vec<u32>>>>,
    /// Whether `last_degrees` holds a table for every direction of the last hop.
    degrees_all: bool,
    /// Per hop, the direction its relationship was found in (0 out of, 1 into the hop's
    /// `from` node).
    rdir: Vec<u8>,
    /// Columns of the predicates, keys, arguments and top key, in `spec` order.
    pred_cols: Vec<Col>,
    /// The predicates' values, fixed when the statement starts.
    pred_vals: Vec<Option<Val>>,
    /// Per predicate, a numeric comparison decided on f64 when both sides are exact in it
    /// ([`numeric_pred`]).
    pred_num: Vec<Option<(Ordering, bool, f64)>>,
    /// Per stage (0: the scanned node; h: after hop h), the predicates it checks.
    pred_stage: Vec<Vec<usize>>,
    key_cols: Vec<Col>,
    arg_cols: Vec<Option<Col>>,
    top_col: Option<Col>,
    groups: HashTable<usize>,
    /// Grouping by one string column: the group of each dictionary code (entry 0: no
    /// string), `u32::MAX` for none yet, instead of hashing.
    by_code: Option<Vec<u32>>,
    hasher: DefaultHashBuilder,
    list: Vec<Group>,
    keybuf: Vec<KeyPart>,
    /// Only `count(*)`, no keys: a count.
    count_only: bool,
    count: i64,
    heap: BinaryHeap<Cand>,
    keep: usize,
    seq: u64,
    inputs: Vec<Slots>,
    stats: Stats,
}

/// How an element's value reaches a stage: nodes at their position, relationships after
/// their hop.
fn stage_of(e: Elem) -> usize {
    match e {
        Elem::Node(p) => p,
        Elem::Rel(h) => h + 1,
    }
}

/// Whether a hop may take row (`rel`, `other`) from `from`: not a self-loop where loops are
/// left out, to a node of the target label (`to`), and not a relationship an earlier hop of
/// `unique` took (`taken`: the relationship of each hop bound so far).
#[inline(always)]
fn admits(
    rel: u64,
    other: u64,
    from: u64,
    skip_loops: bool,
    to: Option<&crate::columns::IdSet>,
    unique: &[usize],
    taken: &[u64],
) -> bool {
    !(skip_loops && other == from)
        && to.is_none_or(|set| set.contains(other))
        && !unique.iter().any(|&u| taken[u] == rel)
}

/// The directions a hop reads its `from` node's rows in, and whether self-loops are left out
/// of that direction (an undirected hop meets a self-loop in both; it is taken once).
fn dirs_of(way: Way) -> &'static [(u8, bool)] {
    match way {
        Way::Out => &[(0, false)],
        Way::In => &[(1, false)],
        Way::Both => &[(0, false), (1, true)],
    }
}

impl Columnar {
    /// The kernel, when the source has everything it reads in columns of types it handles.
    fn kernel(&self, ex: &Exec<'_>, row: &Slots) -> R<Option<Kernel>> {
        let s = &self.spec;
        let starts = ex.src.label_nodes(s.label)?;
        // the columns and the adjacency are built now when the chain reads a large part of
        // the graph anyway (a scan of an eighth of the nodes or more); else the kernel runs
        // only once earlier reads of this commit built them
        let force = starts.ids.len() as u64 * 8 >= ex.src.node_count();
        let adj = if s.hops.is_empty() {
            None
        } else {
            match ex.src.adjacency(force) {
                Some(a) => Some(a),
                None => return Ok(None),
            }
        };
        // relationship properties are read by adjacency row, in the order the hops read them
        let col = |c: &ColRef| -> Option<Col> {
            let col = match c.elem {
                Elem::Node(_) => ex.src.node_column(c.handle, force)?,
                Elem::Rel(_) => adj.as_ref()?.aligned(&ex.src.rel_column(c.handle, force)?),
            };
            Some(Col { col })
        };
        let mut pred_cols = Vec::new();
        let mut pred_vals = Vec::new();
        let mut pred_num = Vec::new();
        let mut pred_stage = vec![Vec::new(); s.hops.len() + 1];
        for (i, p) in s.preds.iter().enumerate() {
            let Some(c) = col(&p.col) else {
                return Ok(None);
            };
            pred_cols.push(c);
            let v = match &p.op {
                PredOp::Cmp { value, .. } => Some(value.eval(ex, row, &[])?),
                PredOp::IsNull(_) => None,
            };
            pred_num.push(v.as_ref().and_then(|v| numeric_pred(&p.op, v)));
            pred_vals.push(v);
            pred_stage[stage_of(p.col.elem)].push(i);
        }
        let (mut key_cols, mut arg_cols, mut top_col) = (Vec::new(), Vec::new(), None);
        let mut count_only = false;
        let mut keep = 0;
        match &s.sink {
            Sink::Aggregate { keys, aggs, .. } => {
                for (k, _) in keys {
                    let Some(c) = col(k) else { return Ok(None) };
                    if matches!(&*c.col, Column::Any(_)) {
                        return Ok(None);
                    }
                    key_cols.push(c);
                }
                for (kind, _, a) in aggs {
                    match a {
                        None => arg_cols.push(None),
                        Some(a) => {
                            let Some(c) = col(a) else { return Ok(None) };
                            let typed = matches!(
                                (&*c.col, kind),
                                (_, AggKind::Count)
                                    | (Column::Int { .. } | Column::Float { .. }, _)
                                    | (Column::Str { .. }, AggKind::Min | AggKind::Max)
                            );
                            if !typed {
                                return Ok(None);
                            }
                            arg_cols.push(Some(c));
                        }
                    }
                }
                count_only =
                    keys.is_empty() && aggs.iter().all(|(k, _, _)| *k == AggKind::CountStar);
            }
            Sink::Top {
                key, skip, limit, ..
            } => {
                let Some(c) = col(key) else { return Ok(None) };
                top_col = Some(c);
                let sk = match skip {
                    Some(e) => ex.host.count_arg(e, "SKIP")?.unwrap_or(0),
                    None => 0,
                };
                let l = ex.host.count_arg(limit, "LIMIT")?.unwrap_or(usize::MAX);
                keep = sk.saturating_add(l);
            }
        }
        let by_code = match &key_cols[..] {
            [c] => match &*c.col {
                Column::Str { dict, .. } if dict.len() < 1 << 20 => {
                    Some(vec![u32::MAX; dict.len() + 1])
                }
                _ => None,
            },
            _ => None,
        };
        let mut to_sets = Vec::new();
        for h in &s.hops {
            to_sets.push(match h.to_label {
                Some(l) => Some(ex.src.label_nodes(l)?),
                None => None,
            });
        }
        let (mut hop_rows, mut last_degrees) = (Vec::new(), Vec::new());
        if let Some(adj) = &adj {
            for h in &s.hops {
                hop_rows.push(
                    dirs_of(h.way)
                        .iter()
                        .map(|&(d, _)| adj.typed(d, h.ty))
                        .collect::<Vec<_>>(),
                );
            }
            let last = s.hops.len() - 1;
            if count_only && pred_stage[s.hops.len()].is_empty() {
                let h = &s.hops[last];
                let to = h.to_label.zip(to_sets[last].as_ref().map(|m| &m.set));
                last_degrees = dirs_of(h.way)
                    .iter()
                    .map(|&(d, skip)| adj.degrees(d, h.ty, to, skip))
                    .collect();
            }
        }
        let degrees_all = !last_degrees.is_empty() && last_degrees.iter().all(Option::is_some);
        Ok(Some(Kernel {
            starts,
            adj,
            to_sets,
            hop_rows,
            last_degrees,
            degrees_all,
            rdir: vec![0; s.hops.len()],
            pred_cols,
            pred_vals,
            pred_num,
            pred_stage,
            key_cols,
            arg_cols,
            top_col,
            groups: HashTable::new(),
            by_code,
            hasher: DefaultHashBuilder::default(),
            list: Vec::new(),
            keybuf: Vec::new(),
            count_only,
            count: 0,
            heap: BinaryHeap::new(),
            keep,
            seq: 0,
            inputs: Vec::new(),
            stats: Stats {
                passed: vec![0; s.preds.len()],
                hopped: vec![0; s.hops.len()],
                ..Stats::default()
            },
        }))
    }
}

/// Whether a predicate holds of a column cell, as `cmp_op` / `IS NULL` decide on its value.
#[inline]
fn pred_holds(op: &PredOp, cell: Cell<'_>, value: Option<&Val>) -> bool {
    match op {
        PredOp::IsNull(is) => matches!(cell, Cell::Absent) == *is,
        PredOp::Cmp { op, flipped, .. } => {
            let Some(v) = value else { return false };
            let r = match cell {
                Cell::Absent => return false,
                Cell::Int(i) => cmp_sided(*op, &Val::Int(i), v, *flipped),
                Cell::Float(f) => cmp_sided(*op, &Val::Float(f), v, *flipped),
                Cell::Str(s) => match v {
                    Val::Str(t) => {
                        let o = if *flipped {
                            t.as_str().cmp(s)
                        } else {
                            s.cmp(t.as_str())
                        };
                        Val::Bool(match op {
                            BinOp::Eq => o.is_eq(),
                            BinOp::Ne => o.is_ne(),
                            BinOp::Lt => o.is_lt(),
                            BinOp::Le => o.is_le(),
                            BinOp::Gt => o.is_gt(),
                            BinOp::Ge => o.is_ge(),
                            _ => return false,
                        })
                    }
                    // against a value of another type the string's text does not matter
                    other => cmp_sided(*op, &Val::Str(String::new()), other, *flipped),
                },
                Cell::Other(x) => cmp_sided(*op, &Val::from(x.clone()), v, *flipped),
            };
            matches!(r, Val::Bool(true))
        }
    }
}

/// Integers up to this magnitude are exact as f64.
const EXACT: u64 = 1 << 53;

/// `prop OP value` as "the ordering of prop against `x` is `want`" (negated when the bool is
/// true): for a numeric value exact as f64 (not NaN) and an ordering operator, with the sides
/// put back in order when the value was on the left. None: decided by [`pred_holds`].
fn numeric_pred(op: &PredOp, value: &Val) -> Option<(Ordering, bool, f64)> {
    let PredOp::Cmp { op, flipped, .. } = op else {
        return None;
    };
    let x = match *value {
        Val::Float(f) if !f.is_nan() => f,
        Val::Int(n) if n.unsigned_abs() <= EXACT => n as f64,
        _ => return None,
    };
    // `value OP prop` is `prop OP' value`, OP' the mirror of OP
    let op = match (op, flipped) {
        (BinOp::Lt, true) => BinOp::Gt,
        (BinOp::Gt, true) => BinOp::Lt,
        (BinOp::Le, true) => BinOp::Ge,
        (BinOp::Ge, true) => BinOp::Le,
        (op, _) => *op,
    };
    Some(match op {
        BinOp::Lt => (Ordering::Less, false),
        BinOp::Ge => (Ordering::Less, true),
        BinOp::Gt => (Ordering::Greater, false),
        BinOp::Le => (Ordering::Greater, true),
        BinOp::Eq => (Ordering::Equal, false),
        BinOp::Ne => (Ordering::Equal, true),
        _ => return None,
    })
    .map(|(o, neg)| (o, neg, x))
}

/// [`numeric_pred`]'s test on a property value `f` (neither side NaN).
#[inline(always)]
fn num_holds((want, negated, x): (Ordering, bool, f64), f: f64) -> bool {
    (f.partial_cmp(&x) == Some(want)) != negated
}

#[inline]
fn cmp_sided(op: BinOp, prop: &Val, value: &Val, flipped: bool) -> Val {
    if flipped {
        cmp_op(op, value, prop)
    } else {
        cmp_op(op, prop, value)
    }
}

impl Kernel {
    /// A counted two-hop pattern with no predicates and each hop one way, counted without
    /// walking it (factorised, as Kùzu and the factorised-database literature count joins:
    /// Olteanu and Schleich, "Factorized Databases", SIGMOD Record 2016). Around its middle
    /// node `m` (the chain `(a:L)-[r]-(m)-[s]-(c)`, or the star `(x)-[r]-(m:L)-[s]-(y)` when
    /// both hops start at the scanned node), the count is the sum over `m` of (`m`'s rows of
    /// the first hop) × (`m`'s rows of the second), both read from per-node degree tables, less
    /// the pairs where `r` and `s` would be one relationship (relationship uniqueness, when the
    /// hops have one type): when both hops leave `m` the same way, every row of the first hop
    /// (counted only when its far ends fit the second: the same far label, or none on the
    /// second); when they leave it opposite ways, each self-loop at `m` that fits both.
    /// None: not of this shape; [`Kernel::walk`] counts it.
    fn factored_count(&mut self, spec: &ChainSpec, ex: &Exec<'_>) -> R<Option<i64>> {
        let [h0, h1] = &spec.hops[..] else {
            return Ok(None);
        };
        let one_way = |w: Way| match w {
            Way::Out => Some(0u8),
            Way::In => Some(1u8),
            Way::Both => None,
        };
        let (Some(d0), Some(d1)) = (one_way(h0.way), one_way(h1.way)) else {
            return Ok(None);
        };
        let chain = match (h0.from, h1.from) {
            (0, 1) => true,
            (0, 0) => false,
            _ => return Ok(None),
        };
        if !self.count_only || !self.degrees_all || self.pred_stage.iter().any(|p| !p.is_empty()) {
            return Ok(None);
        }
        let (Some(adj), Some(Some(deg1))) = (self.adj.clone(), self.last_degrees.first().cloned())
        else {
            return Ok(None);
        };
        let scanned = (spec.label, self.starts.clone());
        let label_of = |h: usize| spec.hops[h].to_label.zip(self.to_sets[h].clone());
        // around m: the first hop's way out of m, its far label, and m's own label
        let (m_dir0, far0, m_label) = if chain {
            (1 - d0, Some(scanned), label_of(0))
        } else {
            (d0, label_of(0), Some(scanned))
        };
        let far1 = label_of(1);
        let Some(deg0) = adj.degrees(
            m_dir0,
            h0.ty,
            far0.as_ref().map(|(l, m)| (*l, &m.set)),
            false,
        ) else {
            return Ok(None);
        };
        let same = h0.ty == h1.ty && h1.unique.contains(&0);
        let same_way = m_dir0 == d1;
        // with both hops leaving m the same way, the rows counted twice are the first hop's
        // when they fit the second too (far labels alike, or none on the second)
        let first_fits_both = match (&far0, &far1) {
            (_, None) => true,
            (Some((l0, _)), Some((l1, _))) => l0 == l1,
            (None, Some(_)) => false,
        };
        if same && same_way && !first_fits_both {
            return Ok(None);
        }
        // self-loops of the type at each node: its out-rows less those that are not loops
        let loops = if same && !same_way {
            match (
                adj.degrees(0, h0.ty, None, false),
                adj.degrees(0, h0.ty, None, true),
            ) {
                (Some(all), Some(no_loops)) => Some((all, no_loops)),
                _ => return Ok(None),
            }
        } else {
            None
        };
        let inside = |set: &Option<(u32, Arc<LabelMembers>)>, id: u64| {
            set.as_ref().is_none_or(|(_, m)| m.set.contains(id))
        };
        let (mut total, mut first) = (0i64, 0u64);
        for (m, (&n0, &n1)) in deg0.iter().zip(deg1.iter()).enumerate() {
            if m % 4096 == 0 {
                ex.host.tick()?;
            }
            let id = m as u64;
            if n0 == 0 || !inside(&m_label, id) {
                continue;
            }
            first += u64::from(n0);
            let mut n = i64::from(n0) * i64::from(n1);
            if same {
                n -= if same_way {
                    i64::from(n0)
                } else if inside(&far0, id) && inside(&far1, id) {
                    let (all, no_loops) = loops.as_ref().expect("loops for opposite ways");
                    let at = |d: &[u32]| i64::from(d.get(m).copied().unwrap_or(0));
                    at(all) - at(no_loops)
                } else {
                    0
                };
            }
            total += n;
        }
        self.stats.factored = true;
        self.stats.hopped[0] += first;
        self.stats.hopped[1] += total as u64;
        Ok(Some(total))
    }

    #[inline]
    /// Whether the predicates of `stage` hold; `rows`: the adjacency row of each hop's
    /// relationship (relationship columns are in row order).
    fn preds_ok(&mut self, spec: &ChainSpec, stage: usize, nodes: &[u64], rows: &[u64]) -> bool {
        for &i in &self.pred_stage[stage] {
            let p = &spec.preds[i];
            let id = match p.col.elem {
                Elem::Node(n) => nodes[n],
                Elem::Rel(h) => rows[h],
            };
            let cell = self.pred_cols[i].get(id);
            let holds = match (self.pred_num[i], cell) {
                (Some(num), Cell::Float(f)) if !f.is_nan() => num_holds(num, f),
                (Some(num), Cell::Int(n)) if n.unsigned_abs() <= EXACT => num_holds(num, n as f64),
                _ => pred_holds(&p.op, cell, self.pred_vals[i].as_ref()),
            };
            if !holds {
                return false;
            }
            self.stats.passed[i] += 1;
        }
        true
    }

    /// The last hop's matches from `from` in direction `di` of [`dirs_of`] (`d`, `skip_loops`):
    /// its count of rows to the target label ([`AdjMem::degrees`]), less the relationships
    /// earlier hops of the same type took that are among them (relationship uniqueness).
    /// Needs [`Kernel::degrees_all`].
    #[inline(always)]
    fn last_count(
        &self,
        spec: &ChainSpec,
        b: &Bound,
        from: u64,
        di: usize,
        d: u8,
        skip_loops: bool,
    ) -> i64 {
        let stage = spec.hops.len() - 1;
        let hop = &spec.hops[stage];
        let Some(Some(deg)) = self.last_degrees.get(di) else {
            return 0;
        };
        let mut n = i64::from(deg.get(from as usize).copied().unwrap_or(0));
        for &u in &hop.unique {
            if spec.hops[u].ty != hop.ty {
                continue;
            }
            let (x, y) = (b.nodes[spec.hops[u].from], b.nodes[u + 1]);
            let (start, end) = if self.rdir[u] == 0 { (x, y) } else { (y, x) };
            let (near, far) = if d == 0 { (start, end) } else { (end, start) };
            if near != from || (skip_loops && far == from) {
                continue;
            }
            if self.to_sets[stage]
                .as_ref()
                .is_none_or(|m| m.set.contains(far))
            {
                n -= 1;
            }
        }
        n
    }

    /// Walks the hops from `stage` (nodes bound up to `stage`), handing each full match to
    /// `sink`.
    fn walk(
        &mut self,
        spec: &ChainSpec,
        ex: &Exec<'_>,
        stage: usize,
        b: &mut Bound,
        input: usize,
    ) -> R<()> {
        if stage == spec.hops.len() {
            return self.take(spec, ex, b, input);
        }
        let hop = &spec.hops[stage];
        let adj = self.adj.clone().expect("adjacency for hops");
        let from = b.nodes[hop.from];
        let last = stage + 1 == spec.hops.len();
        let simple_last = last && self.count_only && self.pred_stage[stage + 1].is_empty();
        let before_last = stage + 2 == spec.hops.len()
            && self.count_only
            && self.degrees_all
            && self.pred_stage[stage + 1].is_empty()
            && self.pred_stage[stage + 2].is_empty();
        for (di, &(d, skip_loops)) in dirs_of(hop.way).iter().enumerate() {
            ex.host.tick()?;
            if simple_last && self.degrees_all {
                let n = self.last_count(spec, b, from, di, d, skip_loops);
                self.count += n;
                self.stats.hopped[stage] += n as u64;
                continue;
            }
            let a = match self.hop_rows[stage].get(di) {
                Some(Some(at)) => adj.rows(at.get(from as usize).copied().unwrap_or([0, 0])),
                _ => adj.slice(from, d, Some(hop.ty)),
            };
            let mut n = 0i64;
            if before_last {
                // the next hop is only counted from degrees: its count is summed here, row by
                // row, in a loop without a call per row
                let next = &spec.hops[stage + 1];
                for i in 0..a.rels.len() {
                    let (r, o) = (a.rels[i], a.others[i]);
                    if !admits(
                        r,
                        o,
                        from,
                        skip_loops,
                        self.to_sets[stage].as_ref().map(|m| &m.set),
                        &hop.unique,
                        &b.rels,
                    ) {
                        continue;
                    }
                    self.stats.hopped[stage] += 1;
                    b.rels[stage] = r;
                    b.nodes[stage + 1] = o;
                    self.rdir[stage] = d;
                    let nfrom = b.nodes[next.from];
                    for (ni, &(nd, nskip)) in dirs_of(next.way).iter().enumerate() {
                        let k = self.last_count(spec, b, nfrom, ni, nd, nskip);
                        self.stats.hopped[stage + 1] += k as u64;
                        n += k;
                    }
                }
                self.count += n;
                continue;
            }
            for i in 0..a.rels.len() {
                let (r, o) = (a.rels[i], a.others[i]);
                if !admits(
                    r,
                    o,
                    from,
                    skip_loops,
                    self.to_sets[stage].as_ref().map(|m| &m.set),
                    &hop.unique,
                    &b.rels,
                ) {
                    continue;
                }
                self.stats.hopped[stage] += 1;
                if simple_last {
                    // a last hop only counted: rows counted, not bound
                    n += 1;
                    continue;
                }
                b.rels[stage] = r;
                b.rows[stage] = (a.start + i) as u64;
                b.nodes[stage + 1] = o;
                self.rdir[stage] = d;
                if !self.preds_ok(spec, stage + 1, &b.nodes, &b.rows) {
                    continue;
                }
                self.walk(spec, ex, stage + 1, b, input)?;
            }
            self.count += n;
        }
        Ok(())
    }

    /// Adds one match to group `gi`'s aggregates; `at`: where the match's columns are read.
    #[inline]
    fn accumulate(
        &mut self,
        aggs: &[(AggKind, String, Option<ColRef>)],
        gi: usize,
        at: &impl Fn(Elem) -> u64,
    ) -> R<()> {
        let g = &mut self.list[gi];
        for (((kind, _, a), c), acc) in aggs.iter().zip(&self.arg_cols).zip(&mut g.accs) {
            let cell = match (a, c) {
                (Some(a), Some(c)) => c.get(at(a.elem)),
                _ => {
                    // count(*)
                    if let TAcc::Count(n) = acc {
                        *n += 1;
                    }
                    continue;
                }
            };
            let id = a.map(|a| at(a.elem)).unwrap_or(0);
            add(acc, *kind, cell, id, c.as_ref());
        }
        Ok(())
    }

    /// One full match into the sink.
    fn take(&mut self, spec: &ChainSpec, ex: &Exec<'_>, b: &Bound, input: usize) -> R<()> {
        // where a column is read: a node by id, a relationship by its adjacency row
        let at = |e: Elem| match e {
            Elem::Node(n) => b.nodes[n],
            Elem::Rel(h) => b.rows[h],
        };
        match &spec.sink {
            Sink::Aggregate { keys, aggs, .. } => {
                if self.count_only {
                    self.count += 1;
                    return Ok(());
                }
                let dense = match (&self.by_code, keys.first()) {
                    (Some(by), Some((k, _))) => {
                        let slot = self.key_cols[0]
                            .col
                            .code(at(k.elem))
                            .map_or(0, |c| c as usize + 1);
                        Some((slot, by[slot]))
                    }
                    _ => None,
                };
                if let Some((_, g)) = dense
                    && g != u32::MAX
                {
                    return self.accumulate(aggs, g as usize, &at);
                }
                let mut kb = std::mem::take(&mut self.keybuf);
                kb.clear();
                for ((k, _), c) in keys.iter().zip(&self.key_cols) {
                    let id = at(k.elem);
                    kb.push(match c.get(id) {
                        Cell::Absent | Cell::Other(_) => KeyPart::Null,
                        Cell::Int(i) => KeyPart::Int(i),
                        Cell::Float(f) => KeyPart::Float(float_key(f)),
                        Cell::Str(_) => KeyPart::Code(c.col.code(id).unwrap_or(u32::MAX)),
                    });
                }
                let h = self.hasher.hash_one(&kb);
                let list = &self.list;
                let gi = match self.groups.find(h, |&g| list[g].parts == kb) {
                    Some(&g) => g,
                    None => {
                        let vals = keys
                            .iter()
                            .zip(&self.key_cols)
                            .map(|((k, _), c)| cell_val(c.get(at(k.elem))))
                            .collect();
                        let accs = aggs
                            .iter()
                            .zip(&self.arg_cols)
                            .map(|((kind, _, _), c)| fresh(*kind, c.as_ref()))
                            .collect();
                        self.list.push(Group {
                            parts: kb.clone(),
                            keys: vals,
                            accs,
                        });
                        let gi = self.list.len() - 1;
                        ex.host.room(self.list.len())?;
                        if let (Some(by), Some((slot, _))) = (&mut self.by_code, dense) {
                            by[slot] = gi as u32;
                        } else {
                            let (list, hasher) = (&self.list, &self.hasher);
                            self.groups
                                .insert_unique(h, gi, |&g| hasher.hash_one(&list[g].parts));
                        }
                        gi
                    }
                };
                self.keybuf = kb;
                self.accumulate(aggs, gi, &at)
            }
            Sink::Top { key, asc, .. } => {
                if self.keep == 0 {
                    return Ok(());
                }
                let c = self.top_col.as_ref().expect("top column");
                let cell = c.get(at(key.elem));
                self.seq += 1;
                // a candidate that cannot beat the worst kept is not built
                if self.heap.len() >= self.keep
                    && let Some(worst) = self.heap.peek()
                {
                    let o = order_cell(cell, &worst.key);
                    let o = if *asc { o } else { o.reverse() };
                    if o.is_ge() {
                        return Ok(());
                    }
                }
                let cand = Cand {
                    key: cell_val(cell),
                    seq: self.seq,
                    asc: *asc,
                    input,
                    nodes: b.nodes.clone(),
                    rels: b.rels.clone(),
                };
                self.heap.push(cand);
                if self.heap.len() > self.keep {
                    self.heap.pop();
                } else {
                    ex.host.room(self.heap.len())?;
                }
                Ok(())
            }
        }
    }
}

/// [`order`] of a column cell against a value, without building the cell's value where it
/// is a number or a string.
fn order_cell(cell: Cell<'_>, v: &Val) -> Ordering {
    match (cell, v) {
        (Cell::Float(a), Val::Float(b)) => float_order(a, *b),
        (Cell::Int(a), Val::Int(b)) => a.cmp(b),
        (Cell::Str(a), Val::Str(b)) => a.cmp(b.as_str()),
        (c, v) => order(&cell_val(c), v),
    }
}

/// A fresh typed accumulator for an aggregate over a column (`None`: `count(*)`).
fn fresh(kind: AggKind, col: Option<&Col>) -> TAcc {
    let c = col.map(|c| &*c.col);
    match (kind, c) {
        (AggKind::CountStar | AggKind::Count, _) => TAcc::Count(0),
        (AggKind::Sum, Some(Column::Int { .. })) => TAcc::SumInt(Some(0)),
        // a float sum starts from -0.0, as Rust's `Sum` of floats does
        (AggKind::Sum, _) => TAcc::SumFloat(-0.0, 0),
        (AggKind::Avg, _) => TAcc::Avg { sum: -0.0, n: 0 },
        (_, Some(Column::Int { .. })) => TAcc::BestInt(None),
        (_, Some(Column::Str { .. })) => TAcc::BestStr(None),
        _ => TAcc::BestFloat(None),
    }
}

/// Adds one cell (absent cells are nulls: skipped, as the generic aggregates skip nulls).
#[inline]
fn add(acc: &mut TAcc, kind: AggKind, cell: Cell<'_>, id: u64, col: Option<&Col>) {
    let min = kind == AggKind::Min;
    match (acc, cell) {
        (_, Cell::Absent) => {}
        (TAcc::Count(n), _) => *n += 1,
        (TAcc::SumInt(s), Cell::Int(i)) => *s = s.and_then(|s| s.checked_add(i)),
        (TAcc::SumFloat(s, n), Cell::Float(f)) => {
            *s += f;
            *n += 1;
        }
        (TAcc::Avg { sum, n }, Cell::Int(i)) => {
            *sum += i as f64;
            *n += 1;
        }
        (TAcc::Avg { sum, n }, Cell::Float(f)) => {
            *sum += f;
            *n += 1;
        }
        (TAcc::BestInt(b), Cell::Int(i)) if b.is_none_or(|b| if min { i < b } else { i > b }) => {
            *b = Some(i);
        }
        // ties keep the first (-0.0 and 0.0 are equal)
        (TAcc::BestFloat(b), Cell::Float(f))
            if b.is_none_or(|b| {
                let o = float_order(f, b);
                if min { o.is_lt() } else { o.is_gt() }
            }) =>
        {
            *b = Some(f);
        }
        (TAcc::BestStr(b), Cell::Str(s)) => {
            let Some(Column::Str { dict, .. }) = col.map(|c| &*c.col) else {
                return;
            };
            let better = match b {
                None => true,
                Some(code) => {
                    let o = s.cmp(dict[*code as usize].as_str());
                    if min { o.is_lt() } else { o.is_gt() }
                }
            };
            if better {
                *b = col.and_then(|c| c.col.code(id));
            }
        }
        _ => {}
    }
}

/// The value of a typed accumulator.
fn value(acc: TAcc, col: Option<&Col>) -> R<Val> {
    Ok(match acc {
        TAcc::Count(n) => Val::Int(n),
        TAcc::SumInt(s) => {
            Val::Int(s.ok_or_else(|| arg_err("NumberOutOfRange", "sum() overflowed"))?)
        }
        // no values (all null): the integer 0, as the generic `sum` gives
        TAcc::SumFloat(_, 0) => Val::Int(0),
        TAcc::SumFloat(s, _) => Val::Float(s),
        TAcc::Avg { n: 0, .. } => Val::Null,
        TAcc::Avg { sum, n } => Val::Float(sum / n as f64),
        TAcc::BestInt(b) => b.map_or(Val::Null, Val::Int),
        TAcc::BestFloat(b) => b.map_or(Val::Null, Val::Float),
        TAcc::BestStr(b) => match (b, col.map(|c| &*c.col)) {
            (Some(code), Some(Column::Str { dict, .. })) => Val::Str(dict[code as usize].clone()),
            _ => Val::Null,
        },
    })
}

impl Operator for Columnar {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        if self.mode.is_none() {
            self.mode = Some(match self.kernel(ex, row)? {
                Some(k) => Mode::Kernel(Box::new(k)),
                None => Mode::Fallback,
            });
        }
        let spec = &self.spec;
        match self.mode.as_mut() {
            Some(Mode::Kernel(k)) => {
                let input = k.inputs.len();
                if matches!(spec.sink, Sink::Top { .. }) {
                    k.inputs.push(row.clone());
                }
                let starts = k.starts.clone();
                let mut b = Bound {
                    nodes: vec![0u64; spec.hops.len() + 1],
                    rels: vec![0u64; spec.hops.len()],
                    rows: vec![0u64; spec.hops.len()],
                };
                k.stats.scanned += starts.ids.len() as u64;
                if let Some(n) = k.factored_count(spec, ex)? {
                    k.count += n;
                    return Ok(Flow::Go);
                }
                for &a in &starts.ids {
                    ex.host.tick()?;
                    b.nodes[0] = a;
                    if !k.preds_ok(spec, 0, &b.nodes, &b.rows) {
                        continue;
                    }
                    k.walk(spec, ex, 0, &mut b, input)?;
                }
                Ok(Flow::Go)
            }
            _ => push_into(&mut self.fallback, ex, row, next),
        }
    }

    fn finish(&mut self, ex: &Exec<'_>, next: &mut Next<'_>) -> R<Flow> {
        let k = match self.mode.take() {
            Some(Mode::Kernel(k)) => k,
            // no row came, or the fallback ran: the fallback ends the input
            _ => return finish_into(&mut self.fallback, ex, next),
        };
        let spec = &self.spec;
        let mut k = *k;
        match &spec.sink {
            Sink::Aggregate {
                keys,
                outputs,
                aggs,
            } => {
                if k.count_only {
                    k.list.push(Group {
                        parts: Vec::new(),
                        keys: Vec::new(),
                        accs: vec![TAcc::Count(k.count); aggs.len()],
                    });
                } else if k.list.is_empty() && keys.is_empty() {
                    let accs = aggs
                        .iter()
                        .zip(&k.arg_cols)
                        .map(|((kind, _, _), c)| fresh(*kind, c.as_ref()))
                        .collect();
                    k.list.push(Group {
                        parts: Vec::new(),
                        keys: Vec::new(),
                        accs,
                    });
                }
                k.stats.out = k.list.len() as u64;
                self.stats = Some(std::mem::take(&mut k.stats));
                let nulls = vec![Val::Null; spec.slots];
                for g in std::mem::take(&mut k.list) {
                    let vals = g
                        .accs
                        .into_iter()
                        .zip(&k.arg_cols)
                        .map(|(a, c)| value(a, c.as_ref()))
                        .collect::<R<Vec<_>>>()?;
                    let mut out = nulls.clone();
                    for (v, (_, s)) in g.keys.into_iter().zip(keys) {
                        out[*s] = v;
                    }
                    for (e, s) in outputs {
                        out[*s] = e.eval(ex, &nulls, &vals)?;
                    }
                    if next(&mut out)? == Flow::Stop {
                        return Ok(Flow::Stop);
                    }
                }
                Ok(Flow::Go)
            }
            Sink::Top { .. } => {
                let mut kept = std::mem::take(&mut k.heap).into_vec();
                kept.sort_by_key(|c| c.seq);
                k.stats.out = kept.len() as u64;
                self.stats = Some(std::mem::take(&mut k.stats));
                for c in kept {
                    let mut row = k.inputs[c.input].clone();
                    for (s, id) in spec.node_slots.iter().zip(&c.nodes) {
                        row[*s] = Val::Node(*id);
                    }
                    for (s, id) in spec.rel_slots.iter().zip(&c.rels) {
                        row[*s] = Val::Rel(*id);
                    }
                    if next(&mut row)? == Flow::Stop {
                        return Ok(Flow::Stop);
                    }
                }
                Ok(Flow::Go)
            }
        }
    }

    fn describe(&self) -> String {
        self.text.clone()
    }

    fn inner(&self) -> &[Box<dyn Operator>] {
        &self.fallback
    }

    fn profile_inner(&mut self) {
        self.fallback = super::profile_ops(std::mem::take(&mut self.fallback));
    }

    /// The fused operators' lines: their own figures when they ran as the fallback, the
    /// kernel's rows per stage (its time is the kernel's own) when it ran.
    fn inner_profile(&self) -> Vec<(usize, String, u64, f64)> {
        let Some(st) = &self.stats else {
            return self
                .fallback
                .iter()
                .map(|op| {
                    let (rows, ms) = super::profiled_figures(op.as_ref());
                    (0, op.describe(), rows, ms)
                })
                .collect();
        };
        self.fallback
            .iter()
            .zip(&self.roles)
            .map(|(op, role)| {
                let rows = match *role {
                    Role::Scan => st.scanned,
                    Role::Pred(i) => st.passed.get(i).copied().unwrap_or(0),
                    Role::Hop(h) => st.hopped.get(h).copied().unwrap_or(0),
                    Role::Sink => st.out,
                };
                let how = match role {
                    Role::Hop(_) if st.factored => "in the kernel, counted from degrees",
                    _ => "in the kernel",
                };
                (0, format!("{} ({how})", op.describe()), rows, 0.0)
            })
            .collect()
    }
}
