//! From the logical plan to physical operators.
//!
//! A MATCH becomes, per pattern in order, a scan of its anchor node (the cheapest source the
//! statistics give: a node bound earlier, an index seek, an index range, the smallest label,
//! every node; `plan::choose_anchor`), then one expansion per relationship, out from the
//! anchor to the pattern's end and then back to its start: the order the interpreter matches
//! in, so both give the same rows in the same order. Each conjunct of the WHERE is checked as
//! soon as the variables it reads are bound (before the expansions that would multiply the
//! rows it drops), unless it reads something that needs the whole match (patterns,
//! subqueries, comprehensions) or calls `rand()`, which keep the interpreter's place at the
//! end. A sort followed by LIMIT keeps only the rows the LIMIT can hand on.

use std::collections::HashSet;

use super::super::ast::{Dir, Expr, NodePat, PathPattern, RelPat};
use super::super::exec::{expr_bound_by, node_pat};
use super::super::logical::{LOp, LogicalPlan, MatchOp, Scope};
use super::super::plan::{
    Source as AnchorSource, choose_anchor, conjuncts, node_text, rel_text, show,
};
use super::super::source::{Source, Types, Way};
use super::aggregate::{AggKind, AggSpec, Aggregate};
use super::distinct::Distinct;
use super::expand::Expand;
use super::expr::{CExpr, Compiler};
use super::filter::Filter;
use super::limit::{Limit, Skip};
use super::node_check::{NodeCheck, PropsCheck};
use super::optional::Optional;
use super::produce::Produce;
use super::project::{Project, SetPath};
use super::scan::{NodeScan, ScanSource};
use super::sort::Sort;
use super::unwind::Unwind;
use super::{Operator, Plan};

/// The physical plan of a logical plan, or None when a part of it is left to the
/// interpreter (an expression that names what its scope lacks, a pattern property that reads
/// a variable bound later in the pattern).
pub(crate) fn plan(lp: &LogicalPlan, src: &dyn Source) -> Option<Plan> {
    let out = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    let mut ops: Vec<Box<dyn Operator>> = Vec::new();
    let mut pos = Vec::new();
    for (i, op) in lp.ops.iter().enumerate() {
        pos.resize(
            ops.len(),
            lp.positions.get(i.wrapping_sub(1)).copied().flatten(),
        );
        match op {
            LOp::Match(m) => {
                let inner = match_ops(m, src)?;
                if m.optional {
                    ops.push(Box::new(Optional {
                        inner,
                        new_slots: m.new_slots.clone(),
                    }));
                } else {
                    ops.extend(inner);
                }
            }
            LOp::Unwind { expr, scope, slot } => {
                let c = compiler(src, scope);
                ops.push(Box::new(Unwind {
                    expr: c.compile(expr)?,
                    slot: *slot,
                    text: show(expr),
                }));
            }
            LOp::Project { items, scope } => {
                let c = compiler(src, scope);
                ops.push(Box::new(Project {
                    items: items
                        .iter()
                        .map(|(e, s)| Some((c.compile(e)?, *s)))
                        .collect::<Option<_>>()?,
                    text: items
                        .iter()
                        .map(|(e, _)| show(e))
                        .collect::<Vec<_>>()
                        .join(", "),
                    vals: Vec::new(),
                }));
            }
            LOp::Aggregate(a) => {
                let c = compiler(src, &a.scope);
                let keys = a
                    .keys
                    .iter()
                    .map(|(e, s)| Some((c.compile(e)?, *s)))
                    .collect::<Option<Vec<_>>>()?;
                let aggs = a
                    .aggs
                    .iter()
                    .map(|call| {
                        Some(AggSpec {
                            kind: AggKind::of(&call.name),
                            name: call.name.clone(),
                            distinct: call.distinct,
                            args: call
                                .args
                                .iter()
                                .map(|x| c.compile(x))
                                .collect::<Option<_>>()?,
                        })
                    })
                    .collect::<Option<Vec<_>>>()?;
                let oc = Compiler {
                    src,
                    scope: &a.scope,
                    aggs: true,
                };
                let outputs = a
                    .outputs
                    .iter()
                    .map(|(e, s)| Some((oc.compile(e)?, *s)))
                    .collect::<Option<Vec<_>>>()?;
                let needs_first = a.outputs.iter().any(|(e, _)| {
                    let mut v = false;
                    e.walk(&mut |x| v |= matches!(x, Expr::Var(..)));
                    v
                });
                let text = format!(
                    "Aggregate (grouping keys: {}) {}",
                    if a.keys.is_empty() {
                        "none".to_string()
                    } else {
                        a.keys
                            .iter()
                            .map(|(e, _)| show(e))
                            .collect::<Vec<_>>()
                            .join(", ")
                    },
                    a.aggs
                        .iter()
                        .map(|c| c.name.replace("count*", "count(*)"))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
                ops.push(Box::new(Aggregate::new(
                    keys,
                    aggs,
                    outputs,
                    needs_first,
                    lp.slots,
                    text,
                )));
            }
            LOp::Distinct { slots } => ops.push(Box::new(Distinct {
                slots: slots.clone(),
                seen: Default::default(),
            })),
            LOp::Sort { keys, scope } => {
                let c = compiler(src, scope);
                // a LIMIT right after (SKIP between allowed) bounds the rows to keep
                let top = match (lp.ops.get(i + 1), lp.ops.get(i + 2)) {
                    (Some(LOp::Limit(l)), _) => Some((None, l.clone())),
                    (Some(LOp::Skip(s)), Some(LOp::Limit(l))) => Some((Some(s.clone()), l.clone())),
                    _ => None,
                };
                ops.push(Box::new(Sort {
                    keys: keys
                        .iter()
                        .map(|(e, _, _)| c.compile(e))
                        .collect::<Option<_>>()?,
                    asc: keys.iter().map(|(_, a, _)| *a).collect(),
                    text: keys
                        .iter()
                        .map(|(_, asc, t)| format!("{t}{}", if *asc { "" } else { " DESC" }))
                        .collect::<Vec<_>>()
                        .join(", "),
                    top,
                    keep: None,
                    rows: Vec::new(),
                }));
            }
            LOp::Skip(e) => ops.push(Box::new(Skip {
                count: e.clone(),
                text: show(e),
                left: None,
            })),
            LOp::Limit(e) => ops.push(Box::new(Limit {
                count: e.clone(),
                text: show(e),
                left: None,
            })),
            LOp::Filter { pred, scope } => {
                let c = compiler(src, scope);
                ops.push(Box::new(Filter {
                    pred: c.compile(pred)?,
                    text: show(pred),
                }));
            }
            LOp::Return { slots } => ops.push(Box::new(Produce {
                slots: slots.clone(),
                rows: out.clone(),
                columns: lp.columns.clone(),
            })),
        }
    }
    pos.resize(ops.len(), lp.positions.last().copied().flatten());
    let (ops, pos) = super::fuse::fuse(ops, pos, lp.slots);
    let mut logical = String::new();
    lp.explain(&mut logical);
    Some(Plan {
        ops,
        pos,
        columns: lp.columns.clone(),
        slots: lp.slots,
        out,
        logical,
    })
}

fn compiler<'c>(src: &'c dyn Source, scope: &'c Scope) -> Compiler<'c> {
    Compiler {
        src,
        scope,
        aggs: false,
    }
}

/// Whether a conjunct may be checked before the whole match is bound.
fn pushable(e: &Expr) -> bool {
    expr_bound_by(e, &|_| true)
}

fn has_rand(e: &Expr) -> bool {
    let mut r = false;
    e.walk(&mut |x| {
        if let Expr::Func { name, .. } = x
            && name.eq_ignore_ascii_case("rand")
        {
            r = true;
        }
    });
    r
}

/// The variables an expression reads (without nested scopes: see [`pushable`]).
fn reads(e: &Expr) -> Vec<String> {
    let mut v = Vec::new();
    e.walk(&mut |x| {
        if let Expr::Var(n, _) = x {
            v.push(n.clone());
        }
    });
    v
}

/// The state of one MATCH's planning: what is bound so far and the conjuncts still to place.
struct MatchPlan<'m> {
    src: &'m dyn Source,
    scope: &'m Scope,
    bound_names: HashSet<String>,
    bound_slots: HashSet<usize>,
    /// Relationship slots this MATCH bound so far (each relationship once).
    rels: Vec<usize>,
    /// Conjuncts not placed yet: (expression, checkable early).
    pending: Vec<(&'m Expr, bool)>,
    ops: Vec<Box<dyn Operator>>,
}

impl<'m> MatchPlan<'m> {
    fn compiler(&self) -> Compiler<'_> {
        compiler(self.src, self.scope)
    }

    /// Places every pending early conjunct whose variables are all bound now.
    fn place(&mut self) -> Option<()> {
        let mut i = 0;
        while i < self.pending.len() {
            let (e, early) = self.pending[i];
            if early && reads(e).iter().all(|v| self.bound_names.contains(v)) {
                let pred = self.compiler().compile(e)?;
                self.ops.push(Box::new(Filter {
                    pred,
                    text: show(e),
                }));
                self.pending.remove(i);
            } else {
                i += 1;
            }
        }
        Some(())
    }

    /// A property map's check; None when it reads a variable not bound yet.
    fn props(&self, e: &Option<Expr>, nodes: bool) -> Option<Option<PropsCheck>> {
        let Some(e) = e else { return Some(None) };
        if !reads(e).iter().all(|v| self.bound_names.contains(v)) || !pushable(e) {
            return None;
        }
        let c = self.compiler();
        Some(Some(match e {
            Expr::Map(entries) => PropsCheck::Keys(
                entries
                    .iter()
                    .map(|(k, x)| {
                        let id = self.src.key_id(k);
                        let h = if nodes {
                            self.src.node_prop_handle(id)
                        } else {
                            self.src.rel_prop_handle(id)
                        };
                        Some((k.clone(), h, c.compile(x)?))
                    })
                    .collect::<Option<_>>()?,
            ),
            other => PropsCheck::Dynamic(c.compile(other)?),
        }))
    }

    fn node_check(&self, np: &NodePat, slot: usize, skip_label: Option<&str>) -> Option<NodeCheck> {
        Some(NodeCheck {
            slot,
            labels: np
                .labels
                .iter()
                .filter(|l| Some(l.as_str()) != skip_label)
                .map(|l| self.src.label_id(l))
                .collect(),
            props: self.props(&np.props, true)?,
            bound: self.bound_slots.contains(&slot),
        })
    }

    fn bind_node(&mut self, np: &NodePat, slot: usize) {
        if let Some(v) = &np.var {
            self.bound_names.insert(v.clone());
        }
        self.bound_slots.insert(slot);
    }

    fn types(&self, rp: &RelPat) -> Types {
        if rp.types.is_empty() {
            return Types::Any;
        }
        let mut ts: Vec<u32> = rp
            .types
            .iter()
            .filter_map(|t| self.src.type_id(t))
            .collect();
        ts.sort_unstable();
        ts.dedup();
        Types::Only(ts)
    }

    /// One pattern: its anchor's scan, its expansions and its path value.
    fn pattern(&mut self, ps: &super::super::logical::PatternSlots, conj: &[&Expr]) -> Option<()> {
        let p: &PathPattern = &ps.pattern;
        let names = self.bound_names.clone();
        let anchor = choose_anchor(
            p,
            conj,
            &|v| names.contains(v),
            &|e| expr_bound_by(e, &|v| names.contains(v)),
            &|l, k| self.src.has_index(l, k),
            &|l| self.src.label_count(l),
        );
        let j = anchor.index;
        let np = node_pat(p, j);
        let slot = ps.nodes[j];
        let var = np.var.clone().unwrap_or_else(|| "_".to_string());
        let c = self.compiler();
        let (source, skip) = match &anchor.source {
            AnchorSource::Bound(v) => (ScanSource::Argument { name: v.clone() }, None),
            AnchorSource::IndexEq { label, key, value } => (
                ScanSource::IndexEq {
                    label: label.clone(),
                    key: key.clone(),
                    value: c.compile(value)?,
                    shown: show(value),
                },
                // the label's index holds only nodes that carry the label
                Some(label.clone()),
            ),
            AnchorSource::IndexRange {
                label,
                key,
                lower,
                upper,
            } => {
                let b = |x: &Option<(&Expr, bool)>| -> Option<Option<(CExpr, bool)>> {
                    match x {
                        None => Some(None),
                        Some((e, incl)) => Some(Some((c.compile(e)?, *incl))),
                    }
                };
                let shown = format!(
                    "{}{}",
                    lower
                        .map(|(e, i)| format!(" {} {}", if i { ">=" } else { ">" }, show(e)))
                        .unwrap_or_default(),
                    upper
                        .map(|(e, i)| format!(" {} {}", if i { "<=" } else { "<" }, show(e)))
                        .unwrap_or_default()
                );
                (
                    ScanSource::IndexRange {
                        label: label.clone(),
                        key: key.clone(),
                        lower: b(lower)?,
                        upper: b(upper)?,
                        shown,
                    },
                    Some(label.clone()),
                )
            }
            AnchorSource::Label(l) => (
                ScanSource::Label {
                    id: self.src.label_id(l),
                    name: l.clone(),
                },
                Some(l.clone()),
            ),
            AnchorSource::All => (ScanSource::All, None),
        };
        let check = self.node_check(np, slot, skip.as_deref())?;
        let labels: Vec<String> = np
            .labels
            .iter()
            .filter(|l| Some(l.as_str()) != skip.as_deref())
            .cloned()
            .collect();
        self.ops.push(Box::new(NodeScan {
            source,
            check,
            var,
            labels,
        }));
        self.bind_node(np, slot);
        self.place()?;
        // out from the anchor to the end, then back from it to the start
        let k = p.steps.len();
        let moves: Vec<(usize, bool)> = (j..k)
            .map(|s| (s, true))
            .chain((0..j).rev().map(|s| (s, false)))
            .collect();
        for (s, forward) in moves {
            let (rp, _) = &p.steps[s];
            let (from_i, to_i) = if forward { (s, s + 1) } else { (s + 1, s) };
            let to_np = node_pat(p, to_i);
            let rel = ps.rels[s];
            let rel_props = self.props(&rp.props, false)?;
            let to = self.node_check(to_np, ps.nodes[to_i], None)?;
            let way = match (rp.dir, forward) {
                (Dir::Out, true) | (Dir::In, false) => Way::Out,
                (Dir::In, true) | (Dir::Out, false) => Way::In,
                (Dir::Both, _) => Way::Both,
            };
            self.ops.push(Box::new(Expand {
                from: ps.nodes[from_i],
                rel,
                rel_bound: self.bound_slots.contains(&rel),
                way,
                types: self.types(rp),
                rel_props,
                unique: self.rels.clone(),
                to,
                text: format!(
                    "Expand {}{}{}",
                    node_text(node_pat(p, from_i)),
                    rel_text(rp, forward),
                    node_text(to_np)
                ),
                buf: Vec::new(),
            }));
            self.rels.push(rel);
            if let Some(v) = &rp.var {
                self.bound_names.insert(v.clone());
            }
            self.bound_slots.insert(rel);
            self.bind_node(to_np, ps.nodes[to_i]);
            self.place()?;
        }
        if let Some(slot) = ps.path {
            self.ops.push(Box::new(SetPath {
                slot,
                nodes: ps.nodes.clone(),
                rels: ps.rels.clone(),
                name: p.var.clone().unwrap_or_default(),
            }));
            if let Some(v) = &p.var {
                self.bound_names.insert(v.clone());
            }
            self.bound_slots.insert(slot);
            self.place()?;
        }
        Some(())
    }
}

/// The operators of one MATCH (without the OPTIONAL wrapper).
fn match_ops(m: &MatchOp, src: &dyn Source) -> Option<Vec<Box<dyn Operator>>> {
    let conj: Vec<&Expr> = m.where_.as_ref().map(conjuncts).unwrap_or_default();
    let early_ok = !conj.iter().any(|e| has_rand(e));
    let before = m.before.sorted();
    let mut mp = MatchPlan {
        src,
        scope: &m.after,
        bound_names: before.iter().map(|(n, _)| n.clone()).collect(),
        bound_slots: before.iter().map(|(_, s)| *s).collect(),
        rels: Vec::new(),
        pending: if early_ok {
            conj.iter().map(|e| (*e, pushable(e))).collect()
        } else {
            Vec::new()
        },
        ops: Vec::new(),
    };
    // conjuncts that read nothing the match binds are checked first
    mp.place()?;
    for ps in &m.patterns {
        mp.pattern(ps, &conj)?;
    }
    let c = compiler(src, &m.after);
    if early_ok {
        for (e, _) in std::mem::take(&mut mp.pending) {
            mp.ops.push(Box::new(Filter {
                pred: c.compile(e)?,
                text: show(e),
            }));
        }
    } else if let Some(w) = &m.where_ {
        mp.ops.push(Box::new(Filter {
            pred: c.compile(w)?,
            text: show(w),
        }));
    }
    Some(mp.ops)
}
