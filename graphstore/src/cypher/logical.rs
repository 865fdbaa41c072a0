//! The logical plan: a checked single query as a sequence of relational operators over
//! numbered slots, independent of the store.
//!
//! Every variable a query binds gets a slot in a fixed-width row (anonymous pattern nodes and
//! relationships get hidden slots), so the operators address values by index, never by name.
//! Scoping is resolved here once: a `WITH` maps its items to new slots (or keeps the slot of
//! a variable passed through under its own name), and each operator that evaluates
//! expressions carries the [`Scope`] they see. What becomes physical (anchors, index seeks,
//! expansion order, where each predicate is checked) is decided by
//! [`super::physical::planner`] from the store's statistics.
//!
//! [`build`] covers read-only queries made of `MATCH` / `OPTIONAL MATCH` (fixed-length
//! patterns), `WHERE`, `UNWIND`, `WITH` and `RETURN` with aggregation, `DISTINCT`, `ORDER BY`,
//! `SKIP` and `LIMIT`. For anything else (writes, procedures, variable-length and shortest
//! paths) it returns `None` and the statement runs on the clause interpreter
//! ([`super::exec`]).

use std::fmt::Write as _;

use super::ast::*;

/// What a slot holds, as far as the plan knows (it steers property reads).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A node (or null, after OPTIONAL MATCH).
    Node,
    /// A relationship (or null).
    Rel,
    /// A path (or null).
    Path,
    /// Any value.
    Value,
}

/// The variables visible at a point of the query: name → slot. Later bindings of a name hide
/// earlier ones.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Scope {
    vars: Vec<(String, usize, Kind)>,
}

impl Scope {
    /// The slot and kind of a visible variable.
    pub(crate) fn get(&self, name: &str) -> Option<(usize, Kind)> {
        self.vars
            .iter()
            .rev()
            .find(|(n, _, _)| n == name)
            .map(|(_, s, k)| (*s, *k))
    }

    fn bind(&mut self, name: &str, slot: usize, kind: Kind) {
        self.vars.retain(|(n, _, _)| n != name);
        self.vars.push((name.to_string(), slot, kind));
    }

    /// The visible names with their slots, sorted by name.
    pub(crate) fn sorted(&self) -> Vec<(String, usize)> {
        let mut v: Vec<(String, usize)> =
            self.vars.iter().map(|(n, s, _)| (n.clone(), *s)).collect();
        v.sort();
        v
    }

    /// This scope with `over`'s names added on top (they win).
    fn merged(&self, over: &Scope) -> Scope {
        let mut s = self.clone();
        for (n, slot, k) in &over.vars {
            s.bind(n, *slot, *k);
        }
        s
    }
}

/// One path pattern of a MATCH with the slot of each of its elements.
#[derive(Debug, Clone)]
pub(crate) struct PatternSlots {
    pub pattern: PathPattern,
    /// Per node of the pattern, in order.
    pub nodes: Vec<usize>,
    /// Per relationship of the pattern, in order.
    pub rels: Vec<usize>,
    /// The path variable's slot.
    pub path: Option<usize>,
}

/// A `MATCH` or `OPTIONAL MATCH`.
#[derive(Debug, Clone)]
pub(crate) struct MatchOp {
    pub optional: bool,
    pub patterns: Vec<PatternSlots>,
    pub where_: Option<Expr>,
    /// What is bound before the clause.
    pub before: Scope,
    /// What is bound after it (what WHERE sees).
    pub after: Scope,
    /// The slots the clause binds (an OPTIONAL MATCH without a match sets them to null).
    pub new_slots: Vec<usize>,
}

/// One aggregate call of a grouping projection.
#[derive(Debug, Clone)]
pub(crate) struct AggCall {
    /// Lower-case name; `count*` for `count(*)`.
    pub name: String,
    pub distinct: bool,
    pub args: Vec<Expr>,
}

/// A grouping projection: one output row per distinct value of the grouping keys.
#[derive(Debug, Clone)]
pub(crate) struct AggregateOp {
    /// Grouping keys and their output slots.
    pub keys: Vec<(Expr, usize)>,
    /// The aggregate calls, referenced by `Expr::AggRef(i)` in `outputs`.
    pub aggs: Vec<AggCall>,
    /// Items holding aggregates: the expression over `AggRef`s (and, through the group's first
    /// row, grouping keys) and its output slot.
    pub outputs: Vec<(Expr, usize)>,
    /// What the keys, the aggregates' arguments and the outputs see.
    pub scope: Scope,
}

/// One logical operator.
#[derive(Debug, Clone)]
pub(crate) enum LOp {
    Match(MatchOp),
    Unwind {
        expr: Expr,
        scope: Scope,
        slot: usize,
    },
    /// Non-grouping projection: each expression into its slot.
    Project {
        items: Vec<(Expr, usize)>,
        scope: Scope,
    },
    Aggregate(AggregateOp),
    /// Keeps the first row of each distinct combination of the slots.
    Distinct {
        slots: Vec<usize>,
    },
    /// Stable sort by the keys (ascending when true).
    Sort {
        keys: Vec<(Expr, bool, String)>,
        scope: Scope,
    },
    Skip(Expr),
    Limit(Expr),
    Filter {
        pred: Expr,
        scope: Scope,
    },
    /// The result: these slots, as the columns.
    Return {
        slots: Vec<usize>,
    },
}

/// A single query as logical operators over `slots` row slots.
#[derive(Debug, Clone)]
pub(crate) struct LogicalPlan {
    pub ops: Vec<LOp>,
    /// Where the clause of each operator starts (for errors without a place of their own).
    pub positions: Vec<Option<super::Pos>>,
    pub columns: Vec<String>,
    pub slots: usize,
}

struct Builder {
    slots: usize,
}

impl Builder {
    fn slot(&mut self) -> usize {
        self.slots += 1;
        self.slots - 1
    }
}

/// The logical plan of a checked single query, or None when it uses what the pipeline does
/// not run (see the module's documentation).
pub(crate) fn build(q: &SingleQuery) -> Option<LogicalPlan> {
    let mut b = Builder { slots: 0 };
    let mut scope = Scope::default();
    let mut ops = Vec::new();
    let mut positions = Vec::new();
    let mut columns = None;
    for (i, clause) in q.clauses.iter().enumerate() {
        match clause {
            Clause::Match {
                optional,
                patterns,
                where_,
            } => {
                let before = scope.clone();
                let mut new_slots = Vec::new();
                let mut pats = Vec::new();
                for p in patterns {
                    if p.shortest.is_some() || p.steps.iter().any(|(r, _)| r.range.is_some()) {
                        return None;
                    }
                    let path = match &p.var {
                        Some(v) => {
                            if scope.get(v).is_some() {
                                return None;
                            }
                            let s = b.slot();
                            new_slots.push(s);
                            scope.bind(v, s, Kind::Path);
                            Some(s)
                        }
                        None => None,
                    };
                    fn node(
                        np: &NodePat,
                        scope: &mut Scope,
                        b: &mut Builder,
                        new_slots: &mut Vec<usize>,
                    ) -> usize {
                        match &np.var {
                            Some(v) => match scope.get(v) {
                                Some((s, _)) => s,
                                None => {
                                    let s = b.slot();
                                    new_slots.push(s);
                                    scope.bind(v, s, Kind::Node);
                                    s
                                }
                            },
                            None => b.slot(),
                        }
                    }
                    let mut nodes = vec![node(&p.start, &mut scope, &mut b, &mut new_slots)];
                    let mut rels = Vec::new();
                    for (rp, np) in &p.steps {
                        let r = match &rp.var {
                            Some(v) => match scope.get(v) {
                                Some((s, _)) => s,
                                None => {
                                    let s = b.slot();
                                    new_slots.push(s);
                                    scope.bind(v, s, Kind::Rel);
                                    s
                                }
                            },
                            None => b.slot(),
                        };
                        rels.push(r);
                        nodes.push(node(np, &mut scope, &mut b, &mut new_slots));
                    }
                    pats.push(PatternSlots {
                        pattern: p.clone(),
                        nodes,
                        rels,
                        path,
                    });
                }
                // anonymous slots an OPTIONAL MATCH bound are cleared too (no one reads them)
                ops.push(LOp::Match(MatchOp {
                    optional: *optional,
                    patterns: pats,
                    where_: where_.clone(),
                    before,
                    after: scope.clone(),
                    new_slots,
                }));
            }
            Clause::Unwind { expr, var } => {
                let slot = b.slot();
                ops.push(LOp::Unwind {
                    expr: expr.clone(),
                    scope: scope.clone(),
                    slot,
                });
                scope.bind(var, slot, Kind::Value);
            }
            Clause::With(p) | Clause::Return(p) => {
                let is_return = matches!(clause, Clause::Return(_));
                if is_return && i + 1 != q.clauses.len() {
                    return None;
                }
                let (next, slots) = projection(&mut b, p, &scope, &mut ops)?;
                if is_return {
                    columns = Some(items_of(p, &scope).into_iter().map(|i| i.name).collect());
                    ops.push(LOp::Return { slots });
                }
                scope = next;
            }
            Clause::Create(_)
            | Clause::Merge { .. }
            | Clause::Set(_)
            | Clause::Remove(_)
            | Clause::Delete { .. }
            | Clause::Call { .. } => return None,
        }
        positions.resize(ops.len(), q.positions.get(i).copied());
    }
    Some(LogicalPlan {
        ops,
        positions,
        columns: columns?,
        slots: b.slots,
    })
}

/// A projection's items, `*` expanded to the visible variables sorted by name.
fn items_of(p: &Projection, scope: &Scope) -> Vec<Item> {
    let mut items = Vec::new();
    if p.star {
        for (v, _) in scope.sorted() {
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
    items
}

/// A WITH or RETURN: its operators, the scope after it and its items' slots.
fn projection(
    b: &mut Builder,
    p: &Projection,
    scope: &Scope,
    ops: &mut Vec<LOp>,
) -> Option<(Scope, Vec<usize>)> {
    let items = items_of(p, scope);
    let aggregating = items.iter().any(|i| i.expr.has_aggregate());
    let mut next = Scope::default();
    let mut slots = Vec::new();
    if aggregating {
        let mut keys = Vec::new();
        let mut specs: Vec<(String, bool, Vec<Expr>)> = Vec::new();
        let mut outputs = Vec::new();
        for it in &items {
            let slot = b.slot();
            slots.push(slot);
            if it.expr.has_aggregate() {
                outputs.push((super::exec::rewrite_aggs(&it.expr, &mut specs), slot));
                next.bind(&it.name, slot, Kind::Value);
            } else {
                let kind = match &it.expr {
                    Expr::Var(v, _) => scope.get(v).map_or(Kind::Value, |(_, k)| k),
                    _ => Kind::Value,
                };
                keys.push((it.expr.clone(), slot));
                next.bind(&it.name, slot, kind);
            }
        }
        ops.push(LOp::Aggregate(AggregateOp {
            keys,
            aggs: specs
                .into_iter()
                .map(|(name, distinct, args)| AggCall {
                    name,
                    distinct,
                    args,
                })
                .collect(),
            outputs,
            scope: scope.clone(),
        }));
    } else {
        let mut computed = Vec::new();
        for it in &items {
            match &it.expr {
                // a variable passed on under its own name keeps its slot
                Expr::Var(v, _) if *v == it.name && scope.get(v).is_some() => {
                    let (s, k) = scope.get(v)?;
                    slots.push(s);
                    next.bind(&it.name, s, k);
                }
                e => {
                    let kind = match e {
                        Expr::Var(v, _) => scope.get(v).map_or(Kind::Value, |(_, k)| k),
                        _ => Kind::Value,
                    };
                    let s = b.slot();
                    computed.push((e.clone(), s));
                    slots.push(s);
                    next.bind(&it.name, s, kind);
                }
            }
        }
        if !computed.is_empty() {
            ops.push(LOp::Project {
                items: computed,
                scope: scope.clone(),
            });
        }
    }
    if p.distinct {
        ops.push(LOp::Distinct {
            slots: slots.clone(),
        });
    }
    // ORDER BY sees the items, and (without DISTINCT or aggregation) the variables before them
    let order_scope = if aggregating || p.distinct {
        next.clone()
    } else {
        scope.merged(&next)
    };
    if !p.order.is_empty() {
        let mut keys = Vec::new();
        for (e, asc, text) in &p.order {
            let key = match items.iter().find(|i| &i.text == text || &i.name == text) {
                Some(i) => Expr::Var(i.name.clone(), i.pos),
                None if aggregating => {
                    let e = super::check::subst_keys(e, &items);
                    if e.has_aggregate() {
                        return None;
                    }
                    e
                }
                None => e.clone(),
            };
            keys.push((key, *asc, text.clone()));
        }
        ops.push(LOp::Sort {
            keys,
            scope: order_scope,
        });
    }
    if let Some(s) = &p.skip {
        ops.push(LOp::Skip(s.clone()));
    }
    if let Some(l) = &p.limit {
        ops.push(LOp::Limit(l.clone()));
    }
    if let Some(w) = &p.where_ {
        // WITH ... WHERE sees the variables before a non-aggregating WITH too
        let s = if aggregating {
            next.clone()
        } else {
            scope.merged(&next)
        };
        ops.push(LOp::Filter {
            pred: w.clone(),
            scope: s,
        });
    }
    Some((next, slots))
}

impl LogicalPlan {
    /// The plan as text, one operator a line, indented under `Logical plan`.
    pub(crate) fn explain(&self, out: &mut String) {
        let _ = writeln!(out, "Logical plan");
        for op in &self.ops {
            let line = match op {
                LOp::Match(m) => {
                    let pats: Vec<String> = m
                        .patterns
                        .iter()
                        .map(|p| super::plan::pattern_text(&p.pattern))
                        .collect();
                    format!(
                        "{} {}{}",
                        if m.optional { "OptionalMatch" } else { "Match" },
                        pats.join(", "),
                        m.where_
                            .as_ref()
                            .map(|w| format!(" WHERE {}", super::plan::show(w)))
                            .unwrap_or_default()
                    )
                }
                LOp::Unwind { expr, slot, .. } => {
                    format!("Unwind {} AS #{slot}", super::plan::show(expr))
                }
                LOp::Project { items, .. } => format!(
                    "Project {}",
                    items
                        .iter()
                        .map(|(e, s)| format!("{} AS #{s}", super::plan::show(e)))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                LOp::Aggregate(a) => format!(
                    "Aggregate keys [{}] aggregates [{}]",
                    a.keys
                        .iter()
                        .map(|(e, _)| super::plan::show(e))
                        .collect::<Vec<_>>()
                        .join(", "),
                    a.aggs
                        .iter()
                        .map(|c| if c.name == "count*" {
                            "count(*)".to_string()
                        } else {
                            format!(
                                "{}({}{})",
                                c.name,
                                if c.distinct { "DISTINCT " } else { "" },
                                c.args
                                    .iter()
                                    .map(super::plan::show)
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            )
                        })
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                LOp::Distinct { .. } => "Distinct".to_string(),
                LOp::Sort { keys, .. } => format!(
                    "Sort {}",
                    keys.iter()
                        .map(|(_, asc, t)| format!("{t}{}", if *asc { "" } else { " DESC" }))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                LOp::Skip(e) => format!("Skip {}", super::plan::show(e)),
                LOp::Limit(e) => format!("Limit {}", super::plan::show(e)),
                LOp::Filter { pred, .. } => format!("Filter {}", super::plan::show(pred)),
                LOp::Return { .. } => format!("Return {}", self.columns.join(", ")),
            };
            let _ = writeln!(out, "  {line}");
        }
    }
}
