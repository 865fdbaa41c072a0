//! `find` over many instances: embedding time and ranking time, separately
//! (run with `cargo bench -p llm_tools --bench find`).
//!
//! Builds a store with OG_BENCH_INSTANCES (default 100,000) `Instance` nodes with the
//! OpenGraph schema: unit 384-d features drawn around 200 random cluster centres (closer to
//! sentence embeddings than uniform noise), 10 classes, captions. Then runs 20 queries with
//! k = 10 and prints p50/p99 of the embedding and of the ranking. Uses the ONNX MiniLM when
//! its files are present (`./run setup` fetches them), else says so and uses the hash embedder.

use std::time::Instant;

use graphstore::{Store, Value};
use llm_tools::HashEmbedder;
use llm_tools::embed::{Embedder, MiniLm, default_models_dir};
use llm_tools::retrieve::{FindOptions, find};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use scene::{FEATURE_DIM, opengraph_schema};

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() as f64 - 1.0) * p).round() as usize]
}

fn unit(mut v: Vec<f32>) -> Vec<f32> {
    let n = v.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
    v.iter_mut().for_each(|x| *x /= n);
    v
}

const QUERIES: &[&str] = &[
    "somewhere to sit while waiting for the bus",
    "a red car parked at the kerb",
    "a tall tree next to the road",
    "something to throw rubbish into",
    "a street lamp",
];

fn main() -> anyhow::Result<()> {
    let n: usize = std::env::var("OG_BENCH_INSTANCES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000);
    let mut embedder: Box<dyn Embedder> = match MiniLm::from_dir(&default_models_dir()) {
        Ok(m) => Box::new(m),
        Err(e) => {
            println!("MiniLM not available ({e}); using the hash embedder");
            Box::new(HashEmbedder::new(FEATURE_DIM))
        }
    };
    let dir = tempfile::tempdir()?;
    let store = Store::create(dir.path().join("find.og"))?;
    store.set_schema(opengraph_schema())?;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let centres: Vec<Vec<f32>> = (0..200)
        .map(|_| {
            unit(
                (0..FEATURE_DIM)
                    .map(|_| rng.random_range(-1.0f32..1.0))
                    .collect(),
            )
        })
        .collect();
    let classes = [
        "bench",
        "car",
        "tree",
        "pole",
        "building",
        "trash can",
        "bus shelter",
        "person",
        "fence",
        "lamp",
    ];
    let t0 = Instant::now();
    for chunk in (0..n).collect::<Vec<_>>().chunks(20_000) {
        store.write(|tx| {
            for i in chunk {
                let c = &centres[rng.random_range(0..centres.len())];
                let f = unit(
                    c.iter()
                        .map(|x| x + rng.random_range(-0.3f32..0.3) / (FEATURE_DIM as f32).sqrt())
                        .collect(),
                );
                let class = classes[i % classes.len()];
                let (x, z) = (
                    rng.random_range(-500.0..500.0),
                    rng.random_range(-500.0..500.0),
                );
                tx.create_node_named(
                    &["Instance"],
                    &[
                        ("instance_id", Value::Int(*i as i64)),
                        ("caption", Value::from(format!("a {class} number {i}"))),
                        ("semantic_class", Value::from(class)),
                        ("centroid", Value::Point3D([x, -1.0, z])),
                        (
                            "bbox",
                            Value::box3d([x - 0.5, -2.0, z - 0.5], [x + 0.5, 0.0, z + 0.5]),
                        ),
                        ("feature", Value::Vector(f)),
                    ],
                )?;
            }
            Ok(())
        })?;
    }
    println!(
        "{n} instances loaded in {:.1} s; embedder: {}",
        t0.elapsed().as_secs_f64(),
        embedder.name()
    );
    let r = store.read()?;
    let opts = FindOptions {
        k: 10,
        class: None,
        near: None,
    };
    // warm-up
    find(&r, embedder.as_mut(), QUERIES[0], &opts)?;
    let (mut embed, mut rank) = (Vec::new(), Vec::new());
    for i in 0..20 {
        let (hits, t) = find(&r, embedder.as_mut(), QUERIES[i % QUERIES.len()], &opts)?;
        assert_eq!(hits.len(), 10);
        embed.push(t.embed_ms);
        rank.push(t.rank_ms);
    }
    println!("find top-10 over {n} instances, 20 queries:");
    println!(
        "  embedding ({}): p50 {:.2} ms, p99 {:.2} ms",
        embedder.name(),
        pct(&mut embed, 0.5),
        pct(&mut embed, 0.99)
    );
    println!(
        "  ranking (exact top-k through the in-memory vector index): p50 {:.2} ms, p99 {:.2} ms",
        pct(&mut rank, 0.5),
        pct(&mut rank, 0.99)
    );
    Ok(())
}
