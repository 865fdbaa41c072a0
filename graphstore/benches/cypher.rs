//! Cypher engine benchmark against SQLite (run with `cargo bench -p graphstore --bench cypher`).
//!
//! A random graph of N nodes (`:N {id, score}`) and 2N relationships (`:R`) is loaded into a
//! store and, with the same edges, into SQLite (rusqlite, bundled; an index on `edges(src)`).
//! Then the same question is asked of both, from random start nodes:
//!
//! * Cypher: `MATCH (a:N {id: $id})-[:R]->(b)-[:R]->(c) WHERE c.score > 0.5 RETURN c.id`
//! * SQLite: a recursive CTE that walks two hops from `$id` and filters on `score`
//!   (`CROSS JOIN` fixes SQLite's join order to hop-then-lookup; without it SQLite scans
//!   every node and is about 80 times slower, which would not be a fair comparison)
//!
//! It prints p50 and p99 latency of each and their ratio twice: for the first queries after
//! opening, and after OG_BENCH_WARM_QUERIES more (default N/2, at least 10,000), when the store
//! answers from the commit's in-memory copies as a long-running server does. It checks both
//! return the same number of rows. Scale with OG_BENCH_NODES (default 1,000,000) and
//! OG_BENCH_QUERIES (default 2,000). One thread.

mod common;

use std::time::{Duration, Instant};

use common::{env_usize, pct};

use graphstore::cypher::{QueryOptions, Val};
use graphstore::{PropertyIndexSpec, Schema, Store, Value};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn us(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

const CTE: &str = "WITH RECURSIVE hop(n, d) AS ( \
        SELECT ?1, 0 \
        UNION ALL \
        SELECT e.dst, hop.d + 1 FROM hop CROSS JOIN edges e ON e.src = hop.n WHERE hop.d < 2) \
    SELECT nodes.id FROM hop CROSS JOIN nodes ON nodes.id = hop.n WHERE hop.d = 2 AND nodes.score > 0.5";

const CYPHER: &str = "MATCH (a:N {id: $id})-[:R]->(b)-[:R]->(c) WHERE c.score > 0.5 RETURN c.id";

fn main() -> anyhow::Result<()> {
    let n = env_usize("OG_BENCH_NODES", 1_000_000);
    let queries = env_usize("OG_BENCH_QUERIES", 2_000);
    let dir = tempfile::tempdir()?;
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let scores: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
    // no self-loops, so a 2-hop walk never reuses a relationship in either engine
    let edges: Vec<(usize, usize)> = (0..2 * n)
        .map(|_| {
            let a = rng.random_range(0..n);
            let mut b = rng.random_range(0..n - 1);
            if b >= a {
                b += 1;
            }
            (a, b)
        })
        .collect();

    // ---- graphstore
    let t0 = Instant::now();
    let store = Store::create(dir.path().join("bench.og"))?;
    store.set_schema(Schema {
        property_indexes: vec![PropertyIndexSpec {
            name: None,
            label: "N".into(),
            key: "id".into(),
        }],
        ..Schema::default()
    })?;
    let mut ids = Vec::with_capacity(n);
    for chunk in (0..n).collect::<Vec<_>>().chunks(200_000) {
        let part = store.write(|tx| {
            let l = tx.label_id("N")?;
            let (k_id, k_score) = (tx.prop_key_id("id")?, tx.prop_key_id("score")?);
            chunk
                .iter()
                .map(|i| {
                    tx.create_node(
                        &[l],
                        vec![
                            (k_id, Value::Int(*i as i64)),
                            (k_score, Value::Float(scores[*i])),
                        ],
                    )
                })
                .collect::<graphstore::Result<Vec<u64>>>()
        })?;
        ids.extend(part);
    }
    for chunk in edges.chunks(400_000) {
        store.write(|tx| {
            let r = tx.rel_type_id("R")?;
            for (a, b) in chunk {
                tx.create_rel(ids[*a], r, ids[*b], Vec::new())?;
            }
            Ok(())
        })?;
    }
    let load_store = t0.elapsed();

    // ---- SQLite
    let t0 = Instant::now();
    let mut db = rusqlite::Connection::open(dir.path().join("bench.sqlite"))?;
    db.execute_batch(
        "PRAGMA journal_mode = WAL; PRAGMA synchronous = NORMAL;
         CREATE TABLE nodes (id INTEGER PRIMARY KEY, score REAL NOT NULL);
         CREATE TABLE edges (src INTEGER NOT NULL, dst INTEGER NOT NULL);",
    )?;
    {
        let tx = db.transaction()?;
        {
            let mut ins = tx.prepare("INSERT INTO nodes (id, score) VALUES (?1, ?2)")?;
            for (i, s) in scores.iter().enumerate() {
                ins.execute(rusqlite::params![i as i64, s])?;
            }
            let mut ins = tx.prepare("INSERT INTO edges (src, dst) VALUES (?1, ?2)")?;
            for (a, b) in &edges {
                ins.execute(rusqlite::params![*a as i64, *b as i64])?;
            }
        }
        tx.commit()?;
    }
    db.execute_batch("CREATE INDEX edges_src ON edges (src); ANALYZE;")?;
    let load_sqlite = t0.elapsed();
    println!(
        "graph: {n} nodes, {} relationships; load: graphstore {:.1} s, SQLite {:.1} s",
        edges.len(),
        load_store.as_secs_f64(),
        load_sqlite.as_secs_f64()
    );
    println!("cypher: {CYPHER}");
    println!("sqlite: {CTE}");
    let plan = store.explain(CYPHER)?;
    println!(
        "plan:\n{}",
        plan.lines()
            .map(|l| format!("  {l}"))
            .collect::<Vec<_>>()
            .join("\n")
    );

    {
        let mut explain = db.prepare(&format!("EXPLAIN QUERY PLAN {CTE}"))?;
        let steps: Vec<String> = explain
            .query_map([0i64], |r| r.get::<_, String>(3))?
            .collect::<Result<_, _>>()?;
        println!("sqlite plan: {}", steps.join("; "));
    }
    let mut stmt = db.prepare(CTE)?;
    let mut run =
        |count: usize, rng: &mut ChaCha8Rng| -> anyhow::Result<(Vec<Duration>, Vec<Duration>)> {
            let starts: Vec<i64> = (0..count).map(|_| rng.random_range(0..n) as i64).collect();
            let (mut t_store, mut t_sql) = (Vec::new(), Vec::new());
            let (mut rows_store, mut rows_sql) = (0usize, 0usize);
            for s in &starts {
                let mut opts = QueryOptions::default();
                opts.params.insert("id".into(), Val::Int(*s));
                let t = Instant::now();
                let r = store.query(CYPHER, &opts)?;
                t_store.push(t.elapsed());
                rows_store += r.rows.len();
                let t = Instant::now();
                let k = stmt.query_map([s], |r| r.get::<_, i64>(0))?.count();
                t_sql.push(t.elapsed());
                rows_sql += k;
            }
            anyhow::ensure!(
                rows_store == rows_sql,
                "both engines must return the same rows: {rows_store} vs {rows_sql}"
            );
            println!(
                "{count} queries, {:.1} result rows per query on average (same in both)",
                rows_store as f64 / count.max(1) as f64
            );
            Ok((t_store, t_sql))
        };
    let report = |title: &str, (t_store, t_sql): (Vec<Duration>, Vec<Duration>)| {
        let (p50a, p99a) = (pct(t_store.clone(), 0.5), pct(t_store.clone(), 0.99));
        let (p50b, p99b) = (pct(t_sql.clone(), 0.5), pct(t_sql.clone(), 0.99));
        println!("{title}");
        println!("{:<28} {:>10} {:>10}", "", "p50 µs", "p99 µs");
        println!(
            "{:<28} {:>10.1} {:>10.1}",
            "graphstore Cypher",
            us(p50a),
            us(p99a)
        );
        println!(
            "{:<28} {:>10.1} {:>10.1}",
            "SQLite recursive CTE",
            us(p50b),
            us(p99b)
        );
        println!(
            "ratio graphstore / SQLite:   p50 {:.2}x, p99 {:.2}x (below 1 means graphstore is faster)",
            us(p50a) / us(p50b),
            us(p99a) / us(p99b)
        );
    };
    // warm both up (each engine's page cache), then the first queries after opening: the
    // store answers them from redb's pages
    run(50, &mut rng)?;
    let first = run(queries, &mut rng)?;
    report(
        "== the first queries after opening (store reads its B-trees):",
        first,
    );
    // a long-running reader: once a commit's readers have asked a table often enough, the
    // store copies it into memory (see graphstore's hot.rs); both engines get the same queries
    let warm = env_usize("OG_BENCH_WARM_QUERIES", (n / 2).max(10_000));
    run(warm, &mut rng)?;
    let steady = run(queries, &mut rng)?;
    report(
        &format!("== after {warm} more queries (the commit's in-memory copies made):"),
        steady,
    );
    Ok(())
}
