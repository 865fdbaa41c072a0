//! Index-aware planning of pattern matches, and EXPLAIN.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use super::ast::*;
use super::exec::node_pat;
use crate::GraphRead;

/// Where the first node of a pattern match comes from.
#[derive(Debug)]
pub(crate) enum Source<'e> {
    /// Already bound by an earlier clause.
    Bound(String),
    /// A property index lookup `label.key = value`.
    IndexEq {
        label: String,
        key: String,
        value: &'e Expr,
    },
    /// A property index range scan.
    IndexRange {
        label: String,
        key: String,
        lower: Option<(&'e Expr, bool)>,
        upper: Option<(&'e Expr, bool)>,
    },
    /// All nodes with a label.
    Label(String),
    /// Every node.
    All,
}

#[derive(Debug)]
pub(crate) struct Anchor<'e> {
    /// Index of the anchor node in the pattern (0 = first node).
    pub index: usize,
    pub source: Source<'e>,
}

/// Splits a predicate into its AND-ed parts.
pub(crate) fn conjuncts(e: &Expr) -> Vec<&Expr> {
    match e {
        Expr::Bin(BinOp::And, a, b) => {
            let mut v = conjuncts(a);
            v.extend(conjuncts(b));
            v
        }
        other => vec![other],
    }
}

fn prop_of_var<'a>(e: &'a Expr, var: &str) -> Option<&'a str> {
    match e {
        Expr::Prop(b, k) if matches!(b.as_ref(), Expr::Var(v, _) if v == var) => Some(k),
        _ => None,
    }
}

/// Picks the cheapest node to start matching `p` from.
pub(crate) fn choose_anchor<'e>(
    p: &'e PathPattern,
    conj: &[&'e Expr],
    is_bound: &dyn Fn(&str) -> bool,
    can_eval: &dyn Fn(&Expr) -> bool,
    has_index: &dyn Fn(&str, &str) -> bool,
    label_count: &dyn Fn(&str) -> u64,
) -> Anchor<'e> {
    // (score, anchor): lower scores are cheaper; ties go to the earlier node
    let mut cands: Vec<(u8, Anchor<'e>)> = Vec::new();
    for i in 0..=p.steps.len() {
        let np = node_pat(p, i);
        let mut push =
            |score: u8, source: Source<'e>| cands.push((score, Anchor { index: i, source }));
        if let Some(v) = &np.var
            && is_bound(v)
        {
            push(0, Source::Bound(v.clone()));
            continue;
        }
        for l in &np.labels {
            if let Some(Expr::Map(entries)) = &np.props {
                for (k, e) in entries {
                    if has_index(l, k) && can_eval(e) {
                        push(
                            1,
                            Source::IndexEq {
                                label: l.clone(),
                                key: k.clone(),
                                value: e,
                            },
                        );
                    }
                }
            }
            if let Some(var) = &np.var {
                let mut lower = None;
                let mut upper = None;
                let mut range_key: Option<&str> = None;
                for c in conj {
                    let Expr::Bin(op, a, b) = c else { continue };
                    // normalise to `var.key OP value`
                    let (key, op, value) = match (prop_of_var(a, var), prop_of_var(b, var)) {
                        (Some(k), None) => (k, *op, b.as_ref()),
                        (None, Some(k)) => (
                            k,
                            match op {
                                BinOp::Lt => BinOp::Gt,
                                BinOp::Le => BinOp::Ge,
                                BinOp::Gt => BinOp::Lt,
                                BinOp::Ge => BinOp::Le,
                                o => *o,
                            },
                            a.as_ref(),
                        ),
                        _ => continue,
                    };
                    if !has_index(l, key) || !can_eval(value) {
                        continue;
                    }
                    match op {
                        BinOp::Eq => push(
                            1,
                            Source::IndexEq {
                                label: l.clone(),
                                key: key.to_string(),
                                value,
                            },
                        ),
                        BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => {
                            if range_key.is_some_and(|k| k != key) {
                                continue;
                            }
                            range_key = Some(key);
                            let incl = matches!(op, BinOp::Le | BinOp::Ge);
                            if matches!(op, BinOp::Gt | BinOp::Ge) {
                                lower = Some((value, incl));
                            } else {
                                upper = Some((value, incl));
                            }
                        }
                        _ => {}
                    }
                }
                if let Some(k) = range_key {
                    push(
                        2,
                        Source::IndexRange {
                            label: l.clone(),
                            key: k.to_string(),
                            lower,
                            upper,
                        },
                    );
                }
            }
            push(3, Source::Label(l.clone()));
        }
        push(4, Source::All);
    }
    let best = cands.iter().map(|(s, _)| *s).min().unwrap_or(4);
    let mut winners = cands
        .into_iter()
        .filter(|(s, _)| *s == best)
        .map(|(_, a)| a);
    let first = winners.next().unwrap_or(Anchor {
        index: 0,
        source: Source::All,
    });
    if best != 3 {
        return first;
    }
    // several label scans: the smallest label wins (sizes are read only here)
    let size = |a: &Anchor<'_>| match &a.source {
        Source::Label(l) => label_count(l),
        _ => u64::MAX,
    };
    let mut pick = (size(&first), first);
    for a in winners {
        let n = size(&a);
        if n < pick.0 {
            pick = (n, a);
        }
    }
    pick.1
}

/// A short rendering of an expression for plans.
pub(crate) fn show(e: &Expr) -> String {
    match e {
        Expr::Lit(v) => match v {
            super::value::Val::Str(s) => format!("'{s}'"),
            super::value::Val::Null => "null".into(),
            other => super::eval::to_string(other).unwrap_or_else(|| "…".into()),
        },
        Expr::Param(p, _) => format!("${p}"),
        Expr::Var(v, _) => v.clone(),
        Expr::Prop(b, k) => format!("{}.{k}", show(b)),
        Expr::Func { name, args, .. } => format!(
            "{name}({})",
            args.iter().map(show).collect::<Vec<_>>().join(", ")
        ),
        Expr::CountStar => "count(*)".into(),
        Expr::List(l) => format!("[{}]", l.iter().map(show).collect::<Vec<_>>().join(", ")),
        Expr::Bin(op, a, b) => format!("{} {} {}", show(a), op_text(*op), show(b)),
        _ => "…".into(),
    }
}

fn op_text(op: BinOp) -> &'static str {
    match op {
        BinOp::Or => "OR",
        BinOp::Xor => "XOR",
        BinOp::And => "AND",
        BinOp::Eq => "=",
        BinOp::Ne => "<>",
        BinOp::Lt => "<",
        BinOp::Le => "<=",
        BinOp::Gt => ">",
        BinOp::Ge => ">=",
        BinOp::Add => "+",
        BinOp::Sub => "-",
        BinOp::Mul => "*",
        BinOp::Div => "/",
        BinOp::Mod => "%",
        BinOp::Pow => "^",
        BinOp::In => "IN",
        BinOp::StartsWith => "STARTS WITH",
        BinOp::EndsWith => "ENDS WITH",
        BinOp::Contains => "CONTAINS",
        BinOp::Regex => "=~",
    }
}

pub(crate) fn node_text(np: &NodePat) -> String {
    let mut s = format!("({}", np.var.as_deref().unwrap_or(""));
    for l in &np.labels {
        s.push(':');
        s.push_str(l);
    }
    s.push(')');
    s
}

pub(crate) fn rel_text(rp: &RelPat, forward: bool) -> String {
    let mut inner = rp.var.clone().unwrap_or_default();
    if !rp.types.is_empty() {
        inner.push(':');
        inner.push_str(&rp.types.join("|"));
    }
    if let Some((lo, hi)) = rp.range {
        inner.push('*');
        inner.push_str(&lo.map(|x| x.to_string()).unwrap_or_default());
        inner.push_str("..");
        inner.push_str(&hi.map(|x| x.to_string()).unwrap_or_default());
    }
    let dir = match (rp.dir, forward) {
        (Dir::Out, true) | (Dir::In, false) => ("-[", "]->"),
        (Dir::In, true) | (Dir::Out, false) => ("<-[", "]-"),
        (Dir::Both, _) => ("-[", "]-"),
    };
    format!("{}{inner}{}", dir.0, dir.1)
}

/// A pattern as text: `(a:A)-[:T]->(b)`.
pub(crate) fn pattern_text(p: &PathPattern) -> String {
    let mut s = String::new();
    if let Some(v) = &p.var {
        s.push_str(v);
        s.push_str(" = ");
    }
    s.push_str(&node_text(&p.start));
    for (r, n) in &p.steps {
        s.push_str(&rel_text(r, true));
        s.push_str(&node_text(n));
    }
    s
}

fn vars_of(e: &Expr) -> BTreeSet<String> {
    let mut s = BTreeSet::new();
    e.walk(&mut |x| {
        if let Expr::Var(v, _) = x {
            s.insert(v.clone());
        }
    });
    s
}

/// The plan of a statement as text: one block per clause, operators indented below it.
pub(crate) fn explain(stmt: &Statement, g: &dyn GraphRead) -> String {
    let counts = std::cell::OnceCell::new();
    let label_count = |l: &str| {
        let c = counts.get_or_init(|| g.counts().map(|c| c.nodes).unwrap_or_default());
        c.get(l).copied().unwrap_or(0)
    };
    let mut out = String::new();
    for (qi, q) in stmt.parts.iter().enumerate() {
        if qi > 0 {
            let all = stmt.union_all.get(qi - 1).copied().unwrap_or(false);
            let _ = writeln!(out, "{}", if all { "UnionAll" } else { "Union (distinct)" });
        }
        let mut scope: BTreeSet<String> = BTreeSet::new();
        for c in &q.clauses {
            match c {
                Clause::Match {
                    optional,
                    patterns,
                    where_,
                    ..
                } => {
                    let _ = writeln!(out, "{}", if *optional { "OptionalMatch" } else { "Match" });
                    let conj = where_.as_ref().map(conjuncts).unwrap_or_default();
                    for p in patterns {
                        let sc = scope.clone();
                        let a = choose_anchor(
                            p,
                            &conj,
                            &|v| sc.contains(v),
                            &|e| vars_of(e).iter().all(|v| sc.contains(v)),
                            &|l, k| g.has_property_index(l, k),
                            &label_count,
                        );
                        let np = node_pat(p, a.index);
                        let v = np.var.as_deref().unwrap_or("_");
                        let op = match &a.source {
                            Source::Bound(_) => format!("Argument {v} (bound earlier)"),
                            Source::IndexEq { label, key, value } => {
                                format!("NodeIndexSeek {v}:{label}({key} = {})", show(value))
                            }
                            Source::IndexRange {
                                label,
                                key,
                                lower,
                                upper,
                            } => format!(
                                "NodeIndexRangeScan {v}:{label}({}{key}{})",
                                lower
                                    .map(|(e, i)| format!(
                                        "{} {} ",
                                        show(e),
                                        if i { "<=" } else { "<" }
                                    ))
                                    .unwrap_or_default(),
                                upper
                                    .map(|(e, i)| format!(
                                        " {} {}",
                                        if i { "<=" } else { "<" },
                                        show(e)
                                    ))
                                    .unwrap_or_default()
                            ),
                            Source::Label(l) => format!("NodeByLabelScan {v}:{l}"),
                            Source::All => format!("AllNodesScan {v}"),
                        };
                        let _ = writeln!(out, "  {op}");
                        if let Some(kind) = p.shortest {
                            let (rp, end) = &p.steps[0];
                            let _ = writeln!(
                                out,
                                "  {} {}{}{} (breadth-first from each start)",
                                match kind {
                                    Shortest::One => "ShortestPath",
                                    Shortest::All => "AllShortestPaths",
                                },
                                node_text(&p.start),
                                rel_text(rp, true),
                                node_text(end)
                            );
                        } else {
                            for j in a.index..p.steps.len() {
                                let (rp, np2) = &p.steps[j];
                                let _ = writeln!(
                                    out,
                                    "  Expand {}{}{}",
                                    node_text(node_pat(p, j)),
                                    rel_text(rp, true),
                                    node_text(np2)
                                );
                            }
                            for j in (0..a.index).rev() {
                                let (rp, _) = &p.steps[j];
                                let _ = writeln!(
                                    out,
                                    "  Expand {}{}{}",
                                    node_text(node_pat(p, j + 1)),
                                    rel_text(rp, false),
                                    node_text(node_pat(p, j))
                                );
                            }
                        }
                        for (v, _, _) in p.vars() {
                            scope.insert(v.to_string());
                        }
                    }
                    if let Some(w) = where_ {
                        let _ = writeln!(out, "  Filter {}", show(w));
                    }
                }
                Clause::Unwind { expr, var } => {
                    let _ = writeln!(out, "Unwind {} AS {var}", show(expr));
                    scope.insert(var.clone());
                }
                Clause::With(p) | Clause::Return(p) => {
                    let what = if matches!(c, Clause::With(_)) {
                        "With"
                    } else {
                        "Return"
                    };
                    let agg = p.items.iter().any(|i| i.expr.has_aggregate());
                    let cols: Vec<&str> = p.items.iter().map(|i| i.name.as_str()).collect();
                    let _ = writeln!(
                        out,
                        "{what} {}{}",
                        if p.star { "*, " } else { "" },
                        cols.join(", ")
                    );
                    if agg {
                        let keys: Vec<&str> = p
                            .items
                            .iter()
                            .filter(|i| !i.expr.has_aggregate())
                            .map(|i| i.name.as_str())
                            .collect();
                        let _ = writeln!(
                            out,
                            "  Aggregate (grouping keys: {})",
                            if keys.is_empty() {
                                "none".into()
                            } else {
                                keys.join(", ")
                            }
                        );
                    }
                    if p.distinct {
                        let _ = writeln!(out, "  Distinct");
                    }
                    if !p.order.is_empty() {
                        let keys: Vec<String> = p
                            .order
                            .iter()
                            .map(|(_, asc, t)| format!("{t}{}", if *asc { "" } else { " DESC" }))
                            .collect();
                        let _ = writeln!(out, "  Sort {}", keys.join(", "));
                    }
                    if let Some(s) = &p.skip {
                        let _ = writeln!(out, "  Skip {}", show(s));
                    }
                    if let Some(l) = &p.limit {
                        let _ = writeln!(out, "  Limit {}", show(l));
                    }
                    if let Some(w) = &p.where_ {
                        let _ = writeln!(out, "  Filter {}", show(w));
                    }
                    let keep: BTreeSet<String> = p.items.iter().map(|i| i.name.clone()).collect();
                    if p.star {
                        scope.extend(keep);
                    } else {
                        scope = keep;
                    }
                }
                Clause::Create(ps) => {
                    let _ = writeln!(out, "Create ({} pattern(s))", ps.len());
                    for p in ps {
                        for (v, _, _) in p.vars() {
                            scope.insert(v.to_string());
                        }
                    }
                }
                Clause::Merge { pattern, .. } => {
                    let _ = writeln!(out, "Merge {}", node_text(&pattern.start));
                    for (v, _, _) in pattern.vars() {
                        scope.insert(v.to_string());
                    }
                }
                Clause::Set(items) => {
                    let _ = writeln!(out, "SetProperties ({} item(s))", items.len());
                }
                Clause::Remove(items) => {
                    let _ = writeln!(out, "Remove ({} item(s))", items.len());
                }
                Clause::Delete { detach, exprs } => {
                    let _ = writeln!(
                        out,
                        "{}Delete {}",
                        if *detach { "Detach" } else { "" },
                        exprs.iter().map(show).collect::<Vec<_>>().join(", ")
                    );
                }
                Clause::Call {
                    name, args, yields, ..
                } => {
                    let _ = writeln!(
                        out,
                        "ProcedureCall {name}({})",
                        args.iter().map(show).collect::<Vec<_>>().join(", ")
                    );
                    if let Some(ys) = yields {
                        for (_, a) in ys {
                            scope.insert(a.clone());
                        }
                    }
                }
            }
        }
    }
    out
}
