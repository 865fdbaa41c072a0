//! Physical operators that stream rows, one per file, and the pipeline that runs them.
//!
//! A physical plan is a chain of operators over fixed-width rows of slots ([`Slots`]). Rows
//! are pushed: an operator takes one input row and hands each row it makes to the rest of the
//! chain (`next`), so a pattern streams straight into an aggregation, a top-k sort or the
//! result without holding its matches. Operators that need all their input before they can
//! answer (aggregation, sort) hold it and hand their rows on in [`Operator::finish`]. `LIMIT`
//! answers [`Flow::Stop`] once it has its rows, and every operator before it stops producing.
//!
//! The operators read the graph only through [`super::source::Source`] and reach the
//! statement (its parameters, time, row and memory limits, and the interpreter's evaluator
//! for the few expressions the compiled form leaves to it) only through [`Host`], so they run
//! and are tested without a store.
//!
//! Files: `scan.rs` (label, all-nodes and index scans, bound nodes), `expand.rs`,
//! `node_check.rs` (labels, properties and identity of a pattern node), `filter.rs`,
//! `project.rs` (projection, path values), `unwind.rs`, `optional.rs`, `aggregate.rs`,
//! `distinct.rs`, `sort.rs`, `limit.rs` (skip and limit), `produce.rs` (the result),
//! `expr.rs` (compiled expressions), `planner.rs` (logical plan → operators).

pub(crate) mod aggregate;
pub(crate) mod columnar;
pub(crate) mod distinct;
pub(crate) mod expand;
pub(crate) mod expr;
pub(crate) mod filter;
pub(crate) mod fuse;
pub(crate) mod limit;
pub(crate) mod node_check;
pub(crate) mod optional;
pub(crate) mod planner;
pub(crate) mod produce;
pub(crate) mod project;
pub(crate) mod scan;
pub(crate) mod sort;
pub(crate) mod unwind;

#[cfg(test)]
mod tests;

use std::fmt::Write as _;
use std::time::Instant;

use super::ast::Expr;
use super::source::Source;
use super::value::Val;
use super::{Pos, QueryError, R};

/// A row: one value per slot of the plan.
pub(crate) type Slots = Vec<Val>;

/// Whether the operators before should keep producing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Flow {
    Go,
    Stop,
}

/// Where an operator hands its rows.
pub(crate) type Next<'n> = dyn FnMut(&mut Slots) -> R<Flow> + 'n;

/// What the operators need of the statement they run in.
pub(crate) trait Host {
    /// Counts one unit of work; fails past the statement's time or memory limit.
    fn tick(&self) -> R<()>;
    /// Fails when an operator would hold more than the statement's intermediate row cap.
    fn room(&self, rows: usize) -> R<()>;
    /// Checks that `bytes` more may be held before building a large value.
    fn reserve(&self, bytes: u64, what: &str) -> R<()>;
    /// A parameter's value.
    fn param(&self, name: &str) -> Option<&Val>;
    /// A scalar function on evaluated arguments (`lower` is the name in lower case).
    fn call(&self, lower: &str, name: &str, args: Vec<Val>) -> R<Val>;
    /// An expression the compiled form leaves to the interpreter (pattern predicates,
    /// comprehensions, subqueries), over the named variables visible to it.
    fn eval_fallback(&self, e: &Expr, vars: &[(std::rc::Rc<str>, Val)]) -> R<Val>;
    /// A `SKIP` or `LIMIT` count.
    fn count_arg(&self, e: &Expr, what: &str) -> R<Option<usize>>;
}

/// What every operator gets: the graph and the statement.
pub(crate) struct Exec<'x> {
    pub src: &'x dyn Source,
    pub host: &'x dyn Host,
}

impl std::fmt::Debug for Exec<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Exec")
    }
}

/// One physical operator.
pub(crate) trait Operator: std::fmt::Debug {
    /// The operator as `Any`, for the planner's fusion of operator sequences.
    fn as_any(&self) -> &dyn std::any::Any;
    /// Takes one input row and hands every row it makes to `next`.
    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow>;
    /// The input has ended: an operator that holds rows hands them on now.
    fn finish(&mut self, _ex: &Exec<'_>, _next: &mut Next<'_>) -> R<Flow> {
        Ok(Flow::Go)
    }
    /// Makes the operator ready to run again, on the same commit, in a plan kept for the
    /// statement's next run ([`super::pipeline::PlanCache`]): true when it is (it holds nothing
    /// of the last run but scratch space), false when it cannot be (an operator that holds
    /// rows or columns); the plan is then built afresh next time.
    fn reset(&mut self) -> bool {
        false
    }
    /// Its line in EXPLAIN.
    fn describe(&self) -> String;
    /// Operators nested inside it (OPTIONAL MATCH's), for EXPLAIN.
    fn inner(&self) -> &[Box<dyn Operator>] {
        &[]
    }
    /// For PROFILE: nested operators' measurements, as (depth below this one, line, rows,
    /// milliseconds).
    fn inner_profile(&self) -> Vec<(usize, String, u64, f64)> {
        let mut out = Vec::new();
        for op in self.inner() {
            let (rows, ms) = profiled_figures(op.as_ref());
            out.push((0, op.describe(), rows, ms));
            out.extend(
                op.inner_profile()
                    .into_iter()
                    .map(|(d, l, r, m)| (d + 1, l, r, m)),
            );
        }
        out
    }
    /// For PROFILE: wraps nested operators in [`Profiled`].
    fn profile_inner(&mut self) {}
    /// This operator as a [`Profiled`], if it is one.
    fn as_profiled(&self) -> Option<&Profiled> {
        None
    }
}

/// Pushes `row` through `ops` (the last one keeps what reaches it); an error without a place
/// of its own gets the place of the clause its operator came from (`pos`, one per operator).
pub(crate) fn push_chain(
    ops: &mut [Box<dyn Operator>],
    pos: &[Option<Pos>],
    ex: &Exec<'_>,
    row: &mut Slots,
) -> R<Flow> {
    match ops.split_first_mut() {
        None => Ok(Flow::Go),
        Some((op, rest)) => op
            .push(ex, row, &mut |r: &mut Slots| {
                push_chain(rest, &pos[1..], ex, r)
            })
            .map_err(|e| placed(e, pos[0])),
    }
}

fn placed(e: QueryError, pos: Option<Pos>) -> QueryError {
    match pos {
        Some(p) => e.at(p),
        None => e,
    }
}

/// Ends the input of `ops`: each operator in turn hands on what it holds.
pub(crate) fn finish_chain(
    ops: &mut [Box<dyn Operator>],
    pos: &[Option<Pos>],
    ex: &Exec<'_>,
) -> R<()> {
    if let Some((op, rest)) = ops.split_first_mut() {
        op.finish(ex, &mut |r: &mut Slots| push_chain(rest, &pos[1..], ex, r))
            .map_err(|e| placed(e, pos[0]))?;
        finish_chain(rest, &pos[1..], ex)?;
    }
    Ok(())
}

/// Pushes `row` through the nested chain `ops`, then into `tail`.
pub(crate) fn push_into(
    ops: &mut [Box<dyn Operator>],
    ex: &Exec<'_>,
    row: &mut Slots,
    tail: &mut Next<'_>,
) -> R<Flow> {
    match ops.split_first_mut() {
        None => tail(row),
        Some((op, rest)) => op.push(ex, row, &mut |r: &mut Slots| push_into(rest, ex, r, tail)),
    }
}

/// Ends the input of the nested chain `ops`, whose rows go on into `tail`.
pub(crate) fn finish_into(
    ops: &mut [Box<dyn Operator>],
    ex: &Exec<'_>,
    tail: &mut Next<'_>,
) -> R<Flow> {
    let mut flow = Flow::Go;
    for i in 0..ops.len() {
        let (head, rest) = ops[i..].split_first_mut().expect("in range");
        if head.finish(ex, &mut |r: &mut Slots| push_into(rest, ex, r, tail))? == Flow::Stop {
            flow = Flow::Stop;
        }
    }
    Ok(flow)
}

/// PROFILE's wrapper around an operator: rows it handed on and time inside it (its own
/// work, the operators after it excluded).
#[derive(Debug)]
pub(crate) struct Profiled {
    pub op: Box<dyn Operator>,
    pub rows: u64,
    /// Nanoseconds inside `push`/`finish`, the operators after it included.
    pub inclusive_ns: u128,
    /// Nanoseconds spent in the operators after it, called from inside it.
    pub downstream_ns: u128,
}

impl Profiled {
    fn wrap(
        &mut self,
        ex: &Exec<'_>,
        call: impl FnOnce(&mut dyn Operator, &Exec<'_>, &mut Next<'_>) -> R<Flow>,
        next: &mut Next<'_>,
    ) -> R<Flow> {
        let t0 = Instant::now();
        let mut rows = 0u64;
        let mut down = 0u128;
        let f = {
            let mut counted = |r: &mut Slots| {
                rows += 1;
                let t = Instant::now();
                let f = next(r);
                down += t.elapsed().as_nanos();
                f
            };
            call(&mut *self.op, ex, &mut counted)
        };
        self.rows += rows;
        self.downstream_ns += down;
        self.inclusive_ns += t0.elapsed().as_nanos();
        f
    }
}

impl Operator for Profiled {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        self.wrap(ex, |op, ex, n| op.push(ex, row, n), next)
    }
    fn finish(&mut self, ex: &Exec<'_>, next: &mut Next<'_>) -> R<Flow> {
        self.wrap(ex, |op, ex, n| op.finish(ex, n), next)
    }
    fn describe(&self) -> String {
        self.op.describe()
    }
    fn inner(&self) -> &[Box<dyn Operator>] {
        self.op.inner()
    }
    fn inner_profile(&self) -> Vec<(usize, String, u64, f64)> {
        self.op.inner_profile()
    }
    fn as_profiled(&self) -> Option<&Profiled> {
        Some(self)
    }
}

/// A single query's physical plan.
#[derive(Debug)]
pub(crate) struct Plan {
    pub ops: Vec<Box<dyn Operator>>,
    /// Per operator, where its clause starts.
    pub pos: Vec<Option<Pos>>,
    pub columns: Vec<String>,
    pub slots: usize,
    /// Where the rows end up (the last operator).
    pub out: std::rc::Rc<std::cell::RefCell<Vec<Vec<Val>>>>,
    /// The logical plan's text, for EXPLAIN.
    pub logical: String,
}

impl Plan {
    /// Runs the plan from one empty row: its result rows.
    pub(crate) fn run(&mut self, ex: &Exec<'_>) -> R<Vec<Vec<Val>>> {
        let mut row = vec![Val::Null; self.slots];
        push_chain(&mut self.ops, &self.pos, ex, &mut row)?;
        finish_chain(&mut self.ops, &self.pos, ex)?;
        Ok(std::mem::take(&mut *self.out.borrow_mut()))
    }

    /// Makes the plan ready to run again on the same commit: false when an operator cannot be
    /// (see [`Operator::reset`]).
    pub(crate) fn reset(&mut self) -> bool {
        self.out.borrow_mut().clear();
        self.ops.iter_mut().all(|op| op.reset())
    }

    /// Wraps every operator in a [`Profiled`], for PROFILE.
    pub(crate) fn profiled(mut self) -> Plan {
        self.ops = profile_ops(std::mem::take(&mut self.ops));
        self
    }

    /// The plan as text: the physical operators (nested ones indented), then the logical
    /// plan.
    pub(crate) fn explain(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "Physical plan (pipelined operators)");
        fn lines(ops: &[Box<dyn Operator>], depth: usize, out: &mut String) {
            for op in ops {
                let _ = writeln!(out, "{}{}", "  ".repeat(depth), op.describe());
                lines(op.inner(), depth + 1, out);
            }
        }
        lines(&self.ops, 1, &mut out);
        out.push_str(&self.logical);
        out
    }

    /// After a profiled run: per operator, the rows it handed on and its own time.
    pub(crate) fn profile_text(&self) -> String {
        let mut out = String::from("Profile (per operator: rows handed on, own time)\n");
        for op in &self.ops {
            let text = op.describe();
            let (rows, own) = profiled_figures(op.as_ref());
            let _ = writeln!(out, "  {text}: {rows} rows, {own:.3} ms");
            for (d, line, r, ms) in op.inner_profile() {
                let _ = writeln!(out, "{}{line}: {r} rows, {ms:.3} ms", "  ".repeat(d + 2));
            }
        }
        out
    }
}

/// Rows and own milliseconds of a [`Profiled`] operator (0 for others).
pub(crate) fn profiled_figures(op: &dyn Operator) -> (u64, f64) {
    match op.as_profiled() {
        Some(p) => (
            p.rows,
            p.inclusive_ns.saturating_sub(p.downstream_ns) as f64 / 1e6,
        ),
        None => (0, 0.0),
    }
}

/// Wraps each of `ops` in a [`Profiled`] (and their nested operators too).
pub(crate) fn profile_ops(ops: Vec<Box<dyn Operator>>) -> Vec<Box<dyn Operator>> {
    ops.into_iter()
        .map(|mut op| {
            op.profile_inner();
            Box::new(Profiled {
                op,
                rows: 0,
                inclusive_ns: 0,
                downstream_ns: 0,
            }) as Box<dyn Operator>
        })
        .collect()
}
