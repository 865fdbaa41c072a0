//! graphstore benchmarks, printed as a table (run with `cargo bench -p graphstore --bench store`).
//!
//! 1. bulk insert of N nodes + 2N relationships in one transaction: nodes/s, rels/s, file size
//! 2. 2-hop outgoing expansion from 1,000 random start nodes on that graph
//! 3. exact vector top-10 over M 384-d vectors: p50/p99, with and without the int8 pre-scan,
//!    on uniform random vectors and on clustered ones (closer to sentence embeddings)
//! 4. spatial radius query over M nodes: p50
//!
//! Everything runs on one thread. Scale with OG_BENCH_NODES (default 1,000,000) and
//! OG_BENCH_VECTORS (default 100,000).

mod common;

use std::time::{Duration, Instant};

use common::{env_usize, pct};

use graphstore::{Direction, GraphRead, Schema, SpatialIndexSpec, Store, Value, VectorIndexSpec};
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn bulk(n: usize, dir: &std::path::Path) -> anyhow::Result<()> {
    let path = dir.join("bulk.og");
    let store = Store::create(&path)?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let t0 = Instant::now();
    store.write(|tx| {
        let l = tx.label_id("Node")?;
        let (k_id, k_x, k_name) = (
            tx.prop_key_id("id")?,
            tx.prop_key_id("x")?,
            tx.prop_key_id("name")?,
        );
        for i in 0..n {
            tx.create_node(
                &[l],
                vec![
                    (k_id, Value::Int(i as i64)),
                    (k_x, Value::Float(i as f64 * 0.5)),
                    (k_name, Value::String(format!("node {i}"))),
                ],
            )?;
        }
        Ok(())
    })?;
    let t_nodes = t0.elapsed();
    let t1 = Instant::now();
    store.write(|tx| {
        let t = tx.rel_type_id("LINK")?;
        let w = tx.prop_key_id("w")?;
        for i in 0..2 * n {
            let a = rng.random_range(0..n as u64);
            let b = rng.random_range(0..n as u64);
            tx.create_rel(a, t, b, vec![(w, Value::Int(i as i64))])?;
        }
        Ok(())
    })?;
    let t_rels = t1.elapsed();
    let size = std::fs::metadata(&path)?.len();
    println!(
        "bulk insert ({n} nodes, {} relationships, one transaction each, durable commit)",
        2 * n
    );
    println!(
        "  nodes:          {:>12.0} /s  ({:.2} s)",
        n as f64 / t_nodes.as_secs_f64(),
        t_nodes.as_secs_f64()
    );
    println!(
        "  relationships:  {:>12.0} /s  ({:.2} s)",
        2.0 * n as f64 / t_rels.as_secs_f64(),
        t_rels.as_secs_f64()
    );
    println!(
        "  file size:      {:>12.1} MiB ({:.0} bytes per node+2 rels)",
        size as f64 / 1048576.0,
        size as f64 / n as f64
    );

    // 2-hop expansion
    let t_open = Instant::now();
    let store = {
        drop(store);
        Store::open(&path)?
    };
    println!("  reopen:         {:>12.1} ms", ms(t_open.elapsed()));
    let r = store.read()?;
    let mut times = Vec::with_capacity(1000);
    let mut reached = 0usize;
    let t_all = Instant::now();
    for _ in 0..1000 {
        let s = rng.random_range(0..n as u64);
        let t = Instant::now();
        let mut seen = std::collections::HashSet::new();
        for a in r.neighbours(s, Direction::Outgoing, None)? {
            for b in r.neighbours(a.other, Direction::Outgoing, None)? {
                seen.insert(b.other);
            }
        }
        reached += seen.len();
        times.push(t.elapsed());
    }
    let total = t_all.elapsed();
    println!("2-hop outgoing expansion from 1,000 random nodes (avg out-degree 2)");
    println!(
        "  total {:.1} ms, per start p50 {:.3} ms, p99 {:.3} ms, {:.1} distinct 2-hop nodes on average",
        ms(total),
        ms(pct(times.clone(), 0.5)),
        ms(pct(times, 0.99)),
        reached as f64 / 1000.0
    );
    Ok(())
}

fn random_vec(rng: &mut impl Rng, dim: usize) -> Vec<f32> {
    (0..dim).map(|_| rng.random_range(-1.0f32..1.0)).collect()
}

fn vectors(m: usize, dir: &std::path::Path, clustered: bool) -> anyhow::Result<()> {
    let dim = 384;
    let store = Store::create(dir.join(if clustered { "vec_c.og" } else { "vec_u.og" }))?;
    let mut s = Schema::default();
    for int8 in [true, false] {
        s.vector_indexes.push(VectorIndexSpec {
            name: if int8 { "int8".into() } else { "f32".into() },
            label: "V".into(),
            key: "v".into(),
            dim,
            int8,
            method: Default::default(),
        });
    }
    s.spatial_indexes.push(SpatialIndexSpec {
        name: "pos".into(),
        label: "V".into(),
        position_key: "p".into(),
        box_key: None,
    });
    store.set_schema(s)?;
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let centres: Vec<Vec<f32>> = (0..200).map(|_| random_vec(&mut rng, dim)).collect();
    let sample = |rng: &mut ChaCha8Rng| -> Vec<f32> {
        if clustered {
            let c = &centres[rng.random_range(0..centres.len())];
            c.iter()
                .map(|x| x + 0.35 * rng.random_range(-1.0f32..1.0))
                .collect()
        } else {
            random_vec(rng, dim)
        }
    };
    let t0 = Instant::now();
    store.write(|tx| {
        let l = tx.label_id("V")?;
        let (kv, kp) = (tx.prop_key_id("v")?, tx.prop_key_id("p")?);
        for _ in 0..m {
            let v = sample(&mut rng);
            let p = [
                rng.random_range(0.0..1000.0),
                rng.random_range(0.0..1000.0),
                rng.random_range(0.0..5.0),
            ];
            tx.create_node(&[l], vec![(kv, Value::Vector(v)), (kp, Value::Point3D(p))])?;
        }
        Ok(())
    })?;
    let kind = if clustered {
        "clustered (200 centres + noise)"
    } else {
        "uniform random"
    };
    println!(
        "vector top-10 over {m} x {dim}-d {kind} vectors (insert {:.1} s)",
        t0.elapsed().as_secs_f64()
    );
    let r = store.read()?;
    let queries: Vec<Vec<f32>> = (0..300).map(|_| sample(&mut rng)).collect();
    for name in ["f32", "int8"] {
        for q in queries.iter().take(10) {
            r.vector_top_k(name, q, 10)?; // warm-up
        }
        let mut times = Vec::new();
        for q in &queries {
            let t = Instant::now();
            let hits = r.vector_top_k(name, q, 10)?;
            times.push(t.elapsed());
            assert_eq!(hits.len(), 10);
        }
        println!(
            "  {name:>4} scan: p50 {:.3} ms, p99 {:.3} ms",
            ms(pct(times.clone(), 0.5)),
            ms(pct(times, 0.99))
        );
    }
    // both paths give the same answer
    for q in queries.iter().take(50) {
        let a: Vec<u64> = r
            .vector_top_k("f32", q, 10)?
            .iter()
            .map(|h| h.node)
            .collect();
        let b: Vec<u64> = r
            .vector_top_k("int8", q, 10)?
            .iter()
            .map(|h| h.node)
            .collect();
        assert_eq!(a, b, "int8 pre-scan changed the result");
    }
    if !clustered {
        let mut times = Vec::new();
        let mut found = 0;
        for _ in 0..1000 {
            let c = [
                rng.random_range(0.0..1000.0),
                rng.random_range(0.0..1000.0),
                2.5,
            ];
            let t = Instant::now();
            found += r.spatial_within("pos", c, 10.0)?.len();
            times.push(t.elapsed());
        }
        println!("spatial radius 10 m over {m} nodes in 1 km x 1 km");
        println!(
            "  p50 {:.4} ms, p99 {:.4} ms, {:.1} hits on average",
            ms(pct(times.clone(), 0.5)),
            ms(pct(times, 0.99)),
            found as f64 / 1000.0
        );
        let mut times = Vec::new();
        for _ in 0..1000 {
            let c = [
                rng.random_range(0.0..1000.0),
                rng.random_range(0.0..1000.0),
                2.5,
            ];
            let t = Instant::now();
            r.spatial_nearest("pos", c, 10)?;
            times.push(t.elapsed());
        }
        println!("  k-nearest (k=10): p50 {:.4} ms", ms(pct(times, 0.5)));
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    // `cargo bench` passes --bench; `cargo test --benches` passes nothing and wants it quick
    let quick = !std::env::args().any(|a| a == "--bench");
    let n = if quick {
        2_000
    } else {
        env_usize("OG_BENCH_NODES", 1_000_000)
    };
    let m = if quick {
        2_000
    } else {
        env_usize("OG_BENCH_VECTORS", 100_000)
    };
    let dir = tempfile::tempdir()?;
    bulk(n, dir.path())?;
    vectors(m, dir.path(), false)?;
    vectors(m, dir.path(), true)?;
    Ok(())
}
