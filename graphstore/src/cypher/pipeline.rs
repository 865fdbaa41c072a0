//! Where a statement's single queries meet the pipeline: a read-only single query that the
//! logical plan covers runs as physical operators over a [`StoreSource`]; anything else runs
//! on the clause interpreter. The interpreter's [`Ctx`] is the pipeline's [`Host`]: the
//! statement's parameters, its time, row and memory limits, its seeded `rand()`, the function
//! library and the evaluator of the expressions the compiled form leaves to it.

use std::rc::Rc;

use super::ast::{Expr, SingleQuery};
use super::exec::{Ctx, Row};
use super::physical::{Exec, Host, Plan};
use super::source::StoreSource;
use super::value::Val;
use super::{R, count, logical, physical};
use crate::ReadTxn;

impl Host for Ctx<'_, '_> {
    fn tick(&self) -> R<()> {
        Ctx::tick(self)
    }
    fn room(&self, rows: usize) -> R<()> {
        Ctx::room(self, rows)
    }
    fn reserve(&self, bytes: u64, what: &str) -> R<()> {
        Ctx::reserve(self, bytes, what)
    }
    fn param(&self, name: &str) -> Option<&Val> {
        self.params.get(name)
    }
    fn call(&self, lower: &str, name: &str, args: Vec<Val>) -> R<Val> {
        self.call_function(lower, name, args)
    }
    fn eval_fallback(&self, e: &Expr, vars: &[(Rc<str>, Val)]) -> R<Val> {
        self.eval(e, &Row(vars.to_vec()))
    }
    fn count_arg(&self, e: &Expr, what: &str) -> R<Option<usize>> {
        Ctx::count_arg(self, Some(e), what)
    }
}

/// The physical plan of `q` over `src`, when the pipeline runs it: read-only, not a count the
/// store's counts answer, and inside what [`logical::build`] covers.
pub(crate) fn plan_for(q: &SingleQuery, src: &StoreSource<'_>) -> Option<Plan> {
    if count::store_count(q).is_some() {
        return None;
    }
    let lp = logical::build(q)?;
    physical::planner::plan(&lp, src)
}

/// What a single query gave on the pipeline: columns, rows and, for PROFILE, the plan with
/// each operator's rows and time.
pub(crate) type Ran = (Vec<String>, Vec<Vec<Val>>, Option<String>);

/// Runs `q` on the pipeline if it can (None: the interpreter must run it).
pub(crate) fn try_run(ctx: &Ctx<'_, '_>, q: &SingleQuery, profile: bool) -> Option<R<Ran>> {
    let txn: &ReadTxn = ctx.read_txn()?;
    let src = StoreSource::new(txn);
    let plan = plan_for(q, &src)?;
    let mut plan = if profile { plan.profiled() } else { plan };
    let ex = Exec {
        src: &src,
        host: ctx,
    };
    Some(plan.run(&ex).map(|rows| {
        let text = profile.then(|| {
            let mut t = plan.explain();
            t.push_str(&plan.profile_text());
            t
        });
        (plan.columns.clone(), rows, text)
    }))
}

/// EXPLAIN's text of `q` on the pipeline, if it runs there.
pub(crate) fn explain(q: &SingleQuery, txn: &ReadTxn) -> Option<String> {
    let src = StoreSource::new(txn);
    plan_for(q, &src).map(|p| p.explain())
}
