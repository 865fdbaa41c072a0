//! Where a statement's single queries meet the pipeline: a read-only single query that the
//! logical plan covers runs as physical operators over a [`StoreSource`]; anything else runs
//! on the clause interpreter. The interpreter's [`Ctx`] is the pipeline's [`Host`]: the
//! statement's parameters, its time, row and memory limits, its seeded `rand()`, the function
//! library and the evaluator of the expressions the compiled form leaves to it.

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::{Arc, Weak};

use super::ast::{Expr, SingleQuery};
use super::exec::{Ctx, Row};
use super::physical::{Exec, Host, Plan};
use super::source::{HandleKeys, StoreSource};
use super::value::Val;
use super::{R, count, logical, physical};
use crate::ReadTxn;
use crate::layout::Committed;

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

/// The physical plans of one statement's parts, each kept for the commit it was built on:
/// a service asks the same anchored statements again and again, and for those building the
/// plan cost as much as running it. A plan is reused only on the commit it was built on (its
/// label, type and key ids, the indexes it uses and the statistics it was costed with are that
/// commit's), only when every operator could be reset ([`Plan::reset`]), never for PROFILE,
/// and with the property handles it was built with ([`StoreSource::primed`]).
#[derive(Debug, Default)]
pub(crate) struct PlanCache {
    parts: RefCell<Vec<Option<CachedPlan>>>,
}

#[derive(Debug)]
struct CachedPlan {
    /// The commit it was built on (a `Weak` keeps the allocation, so no other commit can
    /// take its address while this is held).
    commit: Weak<Committed>,
    plan: Plan,
    handles: HandleKeys,
}

impl PlanCache {
    /// Part `part`'s plan for `commit`, taken out of the cache (a plan for another commit is
    /// dropped).
    fn take(&self, part: usize, commit: &Arc<Committed>) -> Option<CachedPlan> {
        let cached = self.parts.borrow_mut().get_mut(part)?.take()?;
        Weak::ptr_eq(&cached.commit, &Arc::downgrade(commit)).then_some(cached)
    }

    fn put(&self, part: usize, cached: CachedPlan) {
        let mut parts = self.parts.borrow_mut();
        if parts.len() <= part {
            parts.resize_with(part + 1, || None);
        }
        parts[part] = Some(cached);
    }
}

/// Runs `q` on the pipeline if it can (None: the interpreter must run it). `cache`: where the
/// statement keeps its plans, and which part `q` is.
pub(crate) fn try_run(
    ctx: &Ctx<'_, '_>,
    q: &SingleQuery,
    profile: bool,
    cache: Option<(&PlanCache, usize)>,
) -> Option<R<Ran>> {
    let txn: &ReadTxn = ctx.read_txn()?;
    let cache = cache.filter(|_| !profile);
    let hit = cache.and_then(|(c, part)| c.take(part, txn.base()));
    // a reused plan keeps its handle keys; a new one's are read off its source when kept
    let (src, mut plan, handles) = match hit {
        Some(c) => (
            StoreSource::primed(txn, &c.handles),
            c.plan,
            Some(c.handles),
        ),
        None => {
            let src = StoreSource::new(txn);
            let plan = plan_for(q, &src)?;
            #[cfg(test)]
            PLANS_BUILT.with(|n| n.set(n.get() + 1));
            (src, plan, None)
        }
    };
    if profile {
        plan = plan.profiled();
    }
    let ex = Exec {
        src: &src,
        host: ctx,
    };
    let ran = plan.run(&ex).map(|rows| {
        let text = profile.then(|| {
            let mut t = plan.explain();
            t.push_str(&plan.profile_text());
            t
        });
        (plan.columns.clone(), rows, text)
    });
    if let Some((c, part)) = cache
        && ran.is_ok()
        && plan.reset()
    {
        c.put(
            part,
            CachedPlan {
                commit: Arc::downgrade(txn.base()),
                plan,
                // handles made while running are found again by key, so these serve
                handles: handles.unwrap_or_else(|| src.handle_keys()),
            },
        );
    }
    Some(ran)
}

/// EXPLAIN's text of `q` on the pipeline, if it runs there.
pub(crate) fn explain(q: &SingleQuery, txn: &ReadTxn) -> Option<String> {
    let src = StoreSource::new(txn);
    plan_for(q, &src).map(|p| p.explain())
}

#[cfg(test)]
thread_local! {
    /// Physical plans built on this thread (the tests tell a reused plan from a new one).
    static PLANS_BUILT: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

#[cfg(test)]
mod tests {
    use super::PLANS_BUILT;
    use crate::cypher::{Engine, QueryOptions, Val};
    use crate::{PropertyIndexSpec, Schema, Store};

    fn built() -> u64 {
        PLANS_BUILT.with(|n| n.get())
    }

    /// Nodes `:N {id: i, score: i / 10}` for i in 0..10, and `(i)-[:R]->(i+1)`, `(i)-[:R]->(i+2)`.
    fn store() -> (tempfile::TempDir, Store) {
        let dir = tempfile::tempdir().unwrap();
        let s = Store::create(dir.path().join("m.og")).unwrap();
        s.set_schema(Schema {
            property_indexes: vec![PropertyIndexSpec {
                name: None,
                label: "N".into(),
                key: "id".into(),
            }],
            ..Schema::default()
        })
        .unwrap();
        s.query(
            "UNWIND range(0, 9) AS i CREATE (:N {id: i, score: toFloat(i) / 10})",
            &QueryOptions::default(),
        )
        .unwrap();
        s.query(
            "MATCH (a:N), (b:N) WHERE b.id = a.id + 1 OR b.id = a.id + 2 CREATE (a)-[:R]->(b)",
            &QueryOptions::default(),
        )
        .unwrap();
        (dir, s)
    }

    fn run(s: &Store, q: &str, id: i64, engine: Engine) -> Vec<Vec<Val>> {
        let mut opts = QueryOptions {
            engine,
            ..QueryOptions::default()
        };
        opts.params.insert("id".into(), Val::Int(id));
        s.query(q, &opts).unwrap().rows
    }

    #[test]
    fn a_plan_is_reused_on_its_commit_with_its_handles_and_built_again_after_a_commit() {
        let (_d, s) = store();
        // two properties of two nodes: the reused plan's handles must read the same keys
        let q = "MATCH (a:N {id: $id})-[:R]->(b)-[:R]->(c) WHERE c.score > 0.3 \
                 RETURN b.score AS bs, c.id AS c, a.score AS s";
        assert_eq!(
            run(&s, q, 7, Engine::Auto),
            vec![vec![Val::Float(0.8), Val::Int(9), Val::Float(0.7)]]
        );
        let before = built();
        for id in [0, 3, 5, 0, 9] {
            let interp = run(&s, q, id, Engine::Interpreter);
            assert_eq!(run(&s, q, id, Engine::Auto), interp, "id {id}");
        }
        assert_eq!(
            built() - before,
            0,
            "the plan of the first run serves five more"
        );
        assert_eq!(
            run(&s, q, 0, Engine::Auto).len(),
            1,
            "only c = 4 scores above 0.3"
        );
        s.query(
            "MATCH (n:N {id: 9}) SET n.score = 0.0",
            &QueryOptions::default(),
        )
        .unwrap();
        let rows = run(&s, q, 7, Engine::Auto);
        assert_eq!(built() - before, 1, "a new commit plans again");
        assert_eq!(rows, run(&s, q, 7, Engine::Interpreter));
        assert!(
            rows.is_empty(),
            "node 9's new score fails the filter: {rows:?}"
        );
    }

    #[test]
    fn a_reused_plan_sees_what_its_commit_did_not_have_once_a_commit_adds_it() {
        let (_d, s) = store();
        let q = "MATCH (n:Later) RETURN n.x AS x";
        assert!(run(&s, q, 0, Engine::Auto).is_empty());
        assert!(run(&s, q, 0, Engine::Auto).is_empty());
        s.query("CREATE (:Later {x: 1})", &QueryOptions::default())
            .unwrap();
        assert_eq!(run(&s, q, 0, Engine::Auto), vec![vec![Val::Int(1)]]);
    }

    #[test]
    fn skip_and_limit_start_afresh_on_a_reused_plan() {
        let (_d, s) = store();
        let q = "MATCH (a:N {id: $id})-[:R]->(b)-[:R]->(c) RETURN c.id AS c SKIP 1 LIMIT 2";
        let first = run(&s, q, 0, Engine::Auto);
        assert_eq!(first.len(), 2, "{first:?}");
        let before = built();
        for _ in 0..3 {
            assert_eq!(run(&s, q, 0, Engine::Auto), first);
        }
        assert_eq!(built(), before, "the plan is reused");
        assert_eq!(first, run(&s, q, 0, Engine::Interpreter));
    }

    #[test]
    fn optional_match_and_unwind_plans_are_reused_with_the_same_answers() {
        let (_d, s) = store();
        let q = "MATCH (a:N {id: $id}) OPTIONAL MATCH (a)-[:R]->(b) \
                 UNWIND [1, 2] AS k RETURN b.id AS b, k";
        let _ = run(&s, q, 9, Engine::Auto);
        let before = built();
        for id in [9, 8, 9, 1] {
            assert_eq!(
                run(&s, q, id, Engine::Auto),
                run(&s, q, id, Engine::Interpreter),
                "id {id}"
            );
        }
        assert_eq!(built(), before, "the plan is reused");
    }

    #[test]
    fn profile_and_plans_with_operators_that_hold_rows_are_built_each_time() {
        let (_d, s) = store();
        for q in [
            "PROFILE MATCH (a:N {id: $id})-[:R]->(b) RETURN b.id AS b",
            "MATCH (a:N {id: $id})-[:R]->(b) RETURN b.id AS b ORDER BY b DESC",
            "MATCH (a:N {id: $id})-[:R]->(b) RETURN count(b.id) AS n",
        ] {
            let _ = run(&s, q, 1, Engine::Auto);
            let before = built();
            let again = run(&s, q, 1, Engine::Auto);
            assert_eq!(built(), before + 1, "{q}");
            assert!(!again.is_empty() || q.starts_with("PROFILE"), "{q}");
        }
    }

    #[test]
    fn large_records_are_read_in_place_and_small_ones_through_the_memo() {
        let (_d, s) = store();
        s.query(
            "MATCH (n:N) WHERE n.id % 2 = 0 \
             SET n.big = reduce(t = '', i IN range(1, 100) | t + 'abcdefghij')",
            &QueryOptions::default(),
        )
        .unwrap();
        let q = "MATCH (a:N {id: $id})-[:R]->(b) WHERE b.score > 0.0 \
                 RETURN b.id AS id, size(b.big) AS big, b.score AS s";
        let mut sizes = Vec::new();
        for id in 0..8 {
            let rows = run(&s, q, id, Engine::Auto);
            assert_eq!(rows, run(&s, q, id, Engine::Interpreter), "id {id}");
            sizes.extend(rows.into_iter().map(|r| r[1].clone()));
        }
        assert!(sizes.contains(&Val::Int(1000)) && sizes.contains(&Val::Null));
    }
}
