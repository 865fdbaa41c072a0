//! One conformance suite for every [`Embedder`]: the deterministic hash embedder always, and
//! MiniLM when its files are installed (skips with a message otherwise).

use llm_tools::{CachedEmbedder, Embedder, EmbeddingCache, HashEmbedder, MiniLm};

fn cos(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn conformance(e: &mut dyn Embedder) {
    let texts = [
        "a red car parked on the street",
        "a red car parked on the street",
        "a wooden bench next to a bus stop",
        "",
    ];
    assert!(e.embed(&[]).unwrap().is_empty());
    let batch = e.embed(&texts).unwrap();
    assert_eq!(batch.len(), texts.len());
    for (t, v) in texts.iter().zip(&batch) {
        assert_eq!(v.len(), e.dim());
        assert!(v.iter().all(|x| x.is_finite()));
        let n = cos(v, v).sqrt();
        if !t.is_empty() {
            assert!((n - 1.0).abs() < 1e-4, "{t:?} has norm {n}");
        }
    }
    // deterministic, and batching does not change results
    assert!((cos(&batch[0], &batch[1]) - 1.0).abs() < 1e-5);
    let single = e.embed(&[texts[2]]).unwrap();
    assert!((cos(&single[0], &batch[2]) - 1.0).abs() < 1e-4);
    // related texts are closer than unrelated ones
    let v = e
        .embed(&["a car parked on the road", "a parked car", "a wooden bench"])
        .unwrap();
    assert!(cos(&v[0], &v[1]) > cos(&v[0], &v[2]));
}

#[test]
fn hash_embedder_conforms() {
    conformance(&mut HashEmbedder::new(384));
}

#[test]
fn cached_embedder_conforms() {
    // twice over one cache: the second run reads every text back
    let cache = EmbeddingCache::new(64);
    for _ in 0..2 {
        conformance(&mut CachedEmbedder::new(
            Box::new(HashEmbedder::new(384)),
            cache.clone(),
        ));
    }
    assert!(cache.stats().0 > 0);
}

#[test]
fn minilm_conforms() {
    let dir = llm_tools::embed::default_models_dir();
    match MiniLm::from_dir(&dir) {
        Ok(mut m) => conformance(&mut m),
        Err(e) => eprintln!("skipping MiniLM conformance: {e}"),
    }
}
