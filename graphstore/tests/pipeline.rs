//! The pipeline of physical operators against the clause interpreter: random graphs, random
//! read queries of the shapes the pipeline runs, the same rows in the same order (or the same
//! error) from both engines, before and after the commit's columns, label sets and in-memory
//! adjacency are built.

use graphstore::cypher::{Engine, QueryOptions, QueryResult, Val};
use graphstore::{Error, Store, Value};
use proptest::prelude::*;

/// A node: labels (subset of A, B, C), `x` (int, float or absent), `name` (or absent).
type NodeSpec = (u8, Option<i64>, bool, Option<u8>);
/// A relationship: start, end, type (R or S), `w`.
type RelSpec = (usize, usize, bool, Option<i64>);

fn build(nodes: &[NodeSpec], rels: &[RelSpec]) -> (tempfile::TempDir, Store) {
    let dir = tempfile::tempdir().expect("tempdir");
    let s = Store::create(dir.path().join("g.og")).expect("store");
    s.write(|tx| {
        let mut ids = Vec::new();
        for (labels, x, float, name) in nodes {
            let ls: Vec<&str> = ["A", "B", "C"]
                .iter()
                .enumerate()
                .filter(|(i, _)| labels & (1 << i) != 0)
                .map(|(_, l)| *l)
                .collect();
            let mut props: Vec<(&str, Value)> = Vec::new();
            if let Some(x) = x {
                props.push((
                    "x",
                    if *float {
                        Value::Float(*x as f64 + 0.5)
                    } else {
                        Value::Int(*x)
                    },
                ));
            }
            let n;
            if let Some(k) = name {
                n = format!("n{k}");
                props.push(("name", Value::String(n.clone())));
            }
            ids.push(tx.create_node_named(&ls, &props)?);
        }
        if !ids.is_empty() {
            for (a, b, r, w) in rels {
                let props: Vec<(&str, Value)> = w.iter().map(|w| ("w", Value::Int(*w))).collect();
                tx.create_rel_named(
                    ids[a % ids.len()],
                    if *r { "R" } else { "S" },
                    ids[b % ids.len()],
                    &props,
                )?;
            }
        }
        Ok(())
    })
    .expect("fill");
    (dir, s)
}

const PATTERNS: &[&str] = &[
    "(a:A)",
    "(a)",
    "(a:A)-[r:R]->(b)",
    "(a)-[r]->(b:B)",
    "(a:A)-[r:R|S]-(b)",
    "(a)<-[r:S]-(b:A:B)",
    "(a)-[r:R]->(b)-[s:R]->(c)",
    "(a:B)-[r]-(b)-[s]-(c:A)",
    "(a)-[r:R]->(a)",
    "(a:A), (b:C)",
    "(a {name: 'n1'})-[r]->(b)",
    "(a)-[r:R {w: 2}]->(b)",
    "p = (a:A)-[r]->(b)",
    "(a:C)-[r]->(b), (b)-[s]->(c)",
    // chains the columnar kernel runs: a label scan, typed hops, target labels
    "(a:A)-[r:R]->(b:B)-[s:R]->(c)",
    "(a:A)-[r:R]-(b)-[s:R]-(c:A)",
    "(a:B)-[r:S]->(b)<-[s:S]-(c:C)",
    "(a:A)<-[r:R]-(b:A)-[s:R]->(c:A)-[t:R]-(d)",
];

const PREDICATES: &[&str] = &[
    "",
    "WHERE a.x > 2",
    "WHERE a.x = 3 OR a.name = 'n2'",
    "WHERE a.x IS NULL",
    "WHERE NOT a:B",
    "WHERE a.x IN [1, 2, 4]",
    "WHERE a.name STARTS WITH 'n'",
    "WHERE a.x < 3 AND a.x >= 0",
    "WHERE id(a) % 2 = 0",
    "WHERE size([v IN [1, 2, 3] WHERE v > coalesce(a.x, 0)]) > 1",
    // numeric comparisons the kernel decides on f64: a float constant, the constant on the
    // left, not-equal, an integer equal to a float
    "WHERE 2.5 <= a.x AND a.x <> 4",
    "WHERE a.x = 3.0 OR 1 > a.x",
];

/// Returns for patterns binding `a` only, then ones that also use `r` and `b`.
const RETURNS_A: &[&str] = &[
    "RETURN a.x AS x, a.name AS n",
    "RETURN a",
    "RETURN count(*) AS n",
    "RETURN a.name AS n, count(*) AS k, sum(a.x) AS s ORDER BY n",
    "RETURN DISTINCT a.x AS x ORDER BY x DESC",
    "RETURN a.x AS x ORDER BY x, a.name SKIP 1 LIMIT 3",
    "RETURN avg(a.x) AS m, min(a.x) AS lo, max(a.name) AS hi, collect(a.x) AS all",
    "RETURN count(DISTINCT a.x) AS d, count(a.name) AS c",
    "WITH a, a.x * 2 AS y WHERE y > 2 RETURN a.name AS n, y",
    "WITH a.name AS n, count(*) AS c WHERE c > 0 RETURN n, c ORDER BY c DESC, n",
    "RETURN labels(a) AS l, a.x + 1 AS y LIMIT 5",
    "OPTIONAL MATCH (a)-[q:S]->(z) RETURN a.name AS n, z.x AS zx",
    "UNWIND [1, 2] AS i RETURN a.x AS x, i ORDER BY i, x",
    "RETURN CASE WHEN a.x > 2 THEN 'big' ELSE 'small' END AS size, count(*) AS n ORDER BY size",
    "RETURN stdev(a.x) AS sd, percentileDisc(a.x, 0.5) AS p",
];

const RETURNS_AB: &[&str] = &[
    "RETURN a.x AS ax, b.x AS bx",
    "RETURN type(r) AS t, r.w AS w",
    "RETURN a, r, b",
    "RETURN b.name AS n, count(*) AS k ORDER BY k DESC, n",
    "RETURN count(*) AS n",
    "RETURN a.x AS x, collect(DISTINCT b.name) AS names ORDER BY x",
    "WITH b, count(a) AS deg RETURN b.x AS x, deg ORDER BY deg DESC, x LIMIT 4",
    "RETURN sum(r.w) AS s, avg(b.x) AS m",
];

fn run(s: &Store, text: &str, engine: Engine) -> Result<QueryResult, String> {
    s.query(
        text,
        &QueryOptions {
            engine,
            ..QueryOptions::default()
        },
    )
    .map_err(|e| match e {
        Error::Query(q) => q.code.to_string(),
        other => other.to_string(),
    })
}

/// Floats compared to 12 significant digits: the engines add in the same order, but a
/// mismatch in the last bit would say nothing about the plan.
fn norm(v: &Val) -> String {
    match v {
        Val::Float(f) => format!("F{f:.12e}"),
        Val::List(l) => format!("[{}]", l.iter().map(norm).collect::<Vec<_>>().join(",")),
        other => format!("{other:?}"),
    }
}

fn rows(r: &QueryResult) -> Vec<Vec<String>> {
    r.rows
        .iter()
        .map(|row| row.iter().map(norm).collect())
        .collect()
}

/// Enough reads of every property, label and relationship in one commit that the commit's
/// columns, label sets and in-memory adjacency are built.
fn warm(s: &Store) {
    for _ in 0..80 {
        run(
            s,
            "MATCH (a)-[r]->(b) WHERE a:A OR a:B OR a:C OR b:A OR b:B OR b:C \
             RETURN count(a.x), count(a.name), count(r.w), count(b.x), count(b.name)",
            Engine::Auto,
        )
        .expect("warm-up");
        run(
            s,
            "MATCH (a) WHERE a:A OR a:B OR a:C RETURN count(a.x), count(a.name)",
            Engine::Auto,
        )
        .expect("warm-up");
    }
}

fn compare(s: &Store, text: &str) -> Result<(), TestCaseError> {
    let p = run(s, text, Engine::Auto);
    let i = run(s, text, Engine::Interpreter);
    match (&p, &i) {
        (Ok(p), Ok(i)) => {
            prop_assert_eq!(&p.columns, &i.columns, "{}", text);
            prop_assert_eq!(rows(p), rows(i), "{}", text);
            prop_assert_eq!(p.nodes.len(), i.nodes.len(), "{}", text);
        }
        (Err(p), Err(i)) => prop_assert_eq!(p, i, "{}", text),
        _ => prop_assert!(false, "{text}: pipeline {p:?} vs interpreter {i:?}"),
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    #[test]
    fn the_pipeline_answers_as_the_interpreter(
        nodes in proptest::collection::vec(
            (0u8..8, proptest::option::of(0i64..6), proptest::bool::weighted(0.2), proptest::option::of(0u8..4)),
            0..24,
        ),
        rels in proptest::collection::vec(
            (0usize..24, 0usize..24, any::<bool>(), proptest::option::of(0i64..4)),
            0..48,
        ),
        picks in proptest::collection::vec((0usize..64, 0usize..64, 0usize..64), 6),
    ) {
        let (_d, s) = build(&nodes, &rels);
        let queries: Vec<String> = picks
            .iter()
            .map(|(p, w, r)| {
                let pat = PATTERNS[p % PATTERNS.len()];
                let binds_b = pat.contains("(b");
                let ret = if binds_b && r % 2 == 0 {
                    RETURNS_AB[r / 2 % RETURNS_AB.len()]
                } else {
                    RETURNS_A[r % RETURNS_A.len()]
                };
                format!("MATCH {pat} {} {ret}", PREDICATES[w % PREDICATES.len()])
            })
            .collect();
        for q in &queries {
            compare(&s, q)?;
        }
        warm(&s);
        for q in &queries {
            compare(&s, q)?;
        }
    }
}

/// The shapes the pipeline is meant to run do run on it (EXPLAIN shows its physical plan),
/// and the ones it leaves to the interpreter do not.
#[test]
fn the_pipeline_takes_the_read_shapes_it_covers() {
    let (_d, s) = build(&[(1, Some(1), false, Some(1))], &[]);
    let plan = |t: &str| s.explain(t).expect("explain");
    for p in PATTERNS {
        for r in RETURNS_A {
            let t = format!("MATCH {p} {r}");
            // a whole-label count is read from the store's counts, on neither engine
            let counted = s
                .query(&format!("PROFILE {t}"), &QueryOptions::default())
                .ok()
                .and_then(|r| r.plan)
                .is_some_and(|p| p.contains("CountFromStore"));
            assert!(
                counted || plan(&t).starts_with("Physical plan"),
                "{t}:\n{}",
                plan(&t)
            );
        }
    }
    for t in [
        "MATCH (a)-[:R*1..3]->(b) RETURN count(*)",
        "MATCH p = shortestPath((a)-[*]-(b)) RETURN p",
        "CREATE (n) RETURN n",
        "CALL db.labels() YIELD label RETURN label",
    ] {
        assert!(!plan(t).starts_with("Physical plan"), "{t}:\n{}", plan(t));
    }
}

/// Counted chains run in the columnar kernel, which counts a last hop from per-node degrees
/// less the relationships earlier hops took: on a graph of self-loops, parallel and opposed
/// relationships, in every direction, it counts what the interpreter counts.
#[test]
fn the_kernel_counts_chains_with_loops_as_the_interpreter() {
    let nodes: Vec<NodeSpec> = (0..12)
        .map(|i| ((i % 3 + 1) as u8 | 1, Some(i), false, Some((i % 4) as u8)))
        .collect();
    let mut rels: Vec<RelSpec> = Vec::new();
    for i in 0..12usize {
        rels.push((i, i, i % 2 == 0, None)); // self-loops of both types
        rels.push((i, (i + 1) % 12, true, Some(1)));
        rels.push((i, (i + 1) % 12, true, Some(2))); // parallel
        rels.push(((i + 1) % 12, i, true, None)); // opposed
        rels.push((i, (i * 5 + 3) % 12, i % 3 == 0, None));
    }
    let (_d, s) = build(&nodes, &rels);
    warm(&s);
    // (pattern, counted from degrees: two hops each one way, and a chain that turns back
    // with one type has no far label but the scanned one)
    let patterns = [
        ("(a:A)-[r:R]->(b)-[s:R]->(c)", true),
        ("(a:A)-[r:R]-(b)-[s:R]-(c)", false),
        ("(a:A)-[r:R]-(b:B)-[s:R]-(c:A)", false),
        ("(a:A)<-[r:R]-(b)-[s:R]->(c)", true),
        ("(a:A)-[r:R]->(b)<-[s:R]-(c:B)", false),
        ("(a:A)-[r:R]-(b)-[s:S]-(c)", false),
        ("(a:A)-[r:R]-(b)-[s:R]-(c)-[t:R]-(d)", false),
        ("(a:A)-[r:R]->(b)-[s:R]->(c)<-[t:R]-(d:A)", false),
        ("(a:A)-[r:R]->(b:B)-[s:R]->(c:A)", true),
        ("(a:A)<-[r:R]-(b)<-[s:R]-(c:A)", true),
        ("(a:A)-[r:R]->(b)<-[s:R]-(c:A)", true),
        ("(a:B)<-[r:S]-(b:A)-[s:S]->(c)", true),
        ("(a:A)-[r:R]->(b)-[s:S]->(c:B)", true),
        ("(a:A)-[r:R]->(b:B)<-[s:S]-(c:B)", true),
        ("(x)<-[r:R]-(m:B)-[s:R]->(y:A)", true),
        ("(x:A)<-[r:R]-(m:B)-[s:R]->(y)", false),
    ];
    for (p, factored) in patterns {
        let t = format!("MATCH {p} RETURN count(*) AS n");
        compare(&s, &t).expect("same count");
        let prof = s
            .query(&format!("PROFILE {t}"), &QueryOptions::default())
            .expect("profile")
            .plan
            .unwrap_or_default();
        assert!(prof.contains("(in the kernel"), "{t}:\n{prof}");
        assert_eq!(
            prof.contains("counted from degrees"),
            factored,
            "{t}:\n{prof}"
        );
        let n = run(&s, &t, Engine::Auto).expect("runs").rows[0][0].clone();
        assert!(matches!(n, Val::Int(k) if k > 0), "{t}: {n:?}");
    }
}

/// Numeric comparisons the kernel decides on f64 (a property against a constant, either side)
/// give the interpreter's answer on integers, floats, -0.0, NaN, integers past 2^53, strings,
/// booleans and nulls (stores refuse NaN; a NaN constant is left to the general test).
#[test]
fn the_kernel_compares_numbers_as_the_interpreter() {
    let d = tempfile::tempdir().expect("dir");
    let s = Store::create(d.path().join("n.og")).expect("store");
    // a column (one per property key) of floats (f), of integers (i), and of anything (x)
    for (key, values) in [
        (
            "f",
            "[-1.0, 0.0, -0.0, 2.0, 2.5, 3.0, 1e300, 9007199254740992.0, null]",
        ),
        (
            "i",
            "[-1, 0, 2, 3, 9007199254740993, 9007199254740992, -9007199254740993, null]",
        ),
        ("x", "[-1, 0, 0.0, -0.0, 2, 2.5, 3, 'x', true, null]"),
    ] {
        s.query(
            &format!("UNWIND {values} AS v CREATE (:A {{{key}: v}})"),
            &QueryOptions::default(),
        )
        .expect("create");
    }
    let probe = "MATCH (a:A) WHERE a.x > 1 RETURN count(*) AS n";
    let in_kernel = |t: &str| {
        s.query(&format!("PROFILE {t}"), &QueryOptions::default())
            .expect("profile")
            .plan
            .unwrap_or_default()
            .contains("(in the kernel)")
    };
    // enough reads in this commit that its columns are built
    let mut warmed = false;
    for _ in 0..2000 {
        run(
            &s,
            "MATCH (a) RETURN count(a.f), count(a.i), count(a.x)",
            Engine::Auto,
        )
        .expect("warm");
        if in_kernel(probe) {
            warmed = true;
            break;
        }
    }
    assert!(warmed, "the kernel never ran:\n{probe}");
    // constants as parameters, so negative ones are values too (a unary minus is an expression)
    let consts = [
        Val::Int(2),
        Val::Float(2.5),
        Val::Int(0),
        Val::Float(-0.0),
        Val::Float(9007199254740992.0),
        Val::Int(9007199254740993),
        Val::Float(1e300),
        Val::Float(-1.5),
        Val::Float(f64::NAN),
        Val::Str("x".into()),
    ];
    for c in consts {
        let opts = QueryOptions {
            params: [("c".to_string(), c.clone())].into_iter().collect(),
            ..QueryOptions::default()
        };
        for op in ["<", "<=", ">", ">=", "=", "<>"] {
            for t in ["f", "i", "x"].iter().flat_map(|k| {
                [
                    format!("MATCH (a:A) WHERE a.{k} {op} $c RETURN count(*) AS n"),
                    format!("MATCH (a:A) WHERE $c {op} a.{k} RETURN count(*) AS n"),
                ]
            }) {
                let fast = s.query(&t, &opts).expect("auto");
                let slow = s
                    .query(
                        &t,
                        &QueryOptions {
                            engine: Engine::Interpreter,
                            ..opts.clone()
                        },
                    )
                    .expect("interpreter");
                assert_eq!(rows(&fast), rows(&slow), "{t} with {c:?}");
                let prof = s
                    .query(&format!("PROFILE {t}"), &opts)
                    .expect("profile")
                    .plan
                    .unwrap_or_default();
                assert!(prof.contains("(in the kernel)"), "{t}:\n{prof}");
            }
        }
    }
}
