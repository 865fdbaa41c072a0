//! Open-vocabulary retrieval: rank a map's `Instance` nodes by the cosine between an embedded
//! text and their fused feature (0.5 × caption embedding + 0.5 × mean detection feature, as
//! ingest writes it), optionally filtered by class and by distance from a ground point.

use graphstore::{GraphRead, PropKey, Value, VectorSearch};

use crate::embed::{Embedder, cosine};
use crate::error::{Error, Result};

/// Filters and size of a query.
#[derive(Debug, Clone, PartialEq)]
pub struct FindOptions {
    /// How many results.
    pub k: usize,
    /// Only instances of this class.
    pub class: Option<String>,
    /// Only instances whose centroid is within `radius_m` of `[x, z]` on the ground plane
    /// (KITTI's camera world: x right, z forward).
    pub near: Option<([f64; 2], f64)>,
}

impl Default for FindOptions {
    fn default() -> FindOptions {
        FindOptions {
            k: 10,
            class: None,
            near: None,
        }
    }
}

/// One result.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Found {
    /// Node id.
    pub id: u64,
    /// Open-vocabulary label (empty on maps built without labels).
    pub label: String,
    /// Fused caption.
    pub caption: String,
    /// Its SemanticKITTI class (`Instance.semantic_class`).
    pub semantic_class: String,
    /// Cosine similarity to the query.
    pub score: f64,
    /// Centroid in the world frame.
    pub centroid: [f64; 3],
}

/// Timings of one query.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct FindTimings {
    /// Embedding the text, milliseconds.
    pub embed_ms: f64,
    /// Ranking the instances, milliseconds.
    pub rank_ms: f64,
}

/// The embedder the map was built with (`"minilm"`, `"hash"`), from its `Build` node, if
/// the map records one.
pub fn map_embedder<R: GraphRead>(r: &R) -> Result<Option<String>> {
    for id in r.nodes_with_label(scene::label::BUILD)? {
        if let Some(Value::String(args)) = r.node_prop(id, scene::key::ARGS)?
            && let Ok(v) = serde_json::from_str::<serde_json::Value>(&args)
            && let Some(e) = v.get("embedder").and_then(|e| e.as_str())
        {
            return Ok(Some(e.to_string()));
        }
    }
    Ok(None)
}

/// Ranks the instances for `text`, best first (ties by id). Fails when the map was built
/// with another embedder than `embedder`.
pub fn find<R: GraphRead>(
    r: &R,
    embedder: &mut dyn Embedder,
    text: &str,
    opts: &FindOptions,
) -> Result<(Vec<Found>, FindTimings)> {
    if text.trim().is_empty() {
        return Err(Error::Invalid("the query text is empty".into()));
    }
    if let Some(built) = map_embedder(r)?
        && built != embedder.name()
    {
        return Err(Error::Invalid(format!(
            "the map was built with the {built} embedder; query it with the same one (--embedder {built})"
        )));
    }
    let t0 = std::time::Instant::now();
    let q = embedder
        .embed(&[text])?
        .pop()
        .ok_or_else(|| Error::Invalid("the embedder returned nothing".into()))?;
    let embed_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = std::time::Instant::now();
    let mut scored = match r.vector_index(INDEX) {
        // the in-memory vector index: exact top-k, filtered from a growing ranked prefix
        Ok(ix) if ix.dim() == q.len() => ranked_by_index(r, &ix, &q, opts)?,
        _ => scan(r, &q, opts)?,
    };
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    scored.truncate(opts.k);
    let mut out = Vec::with_capacity(scored.len());
    for (score, id) in scored {
        // one read of the winner's record for all three properties
        let node = r.node(id)?;
        let get = |k: &str| {
            let key = r.prop_key(k)?;
            node.as_ref()?.get(key)
        };
        let text = |k: &str| {
            get(k)
                .and_then(Value::as_str)
                .unwrap_or_default()
                .to_string()
        };
        out.push(Found {
            id,
            label: text(scene::key::LABEL),
            caption: text(scene::key::CAPTION),
            semantic_class: text(scene::key::SEMANTIC_CLASS),
            score,
            centroid: get(scene::key::CENTROID)
                .and_then(Value::as_point3)
                .unwrap_or([f64::NAN; 3]),
        });
    }
    let rank_ms = t1.elapsed().as_secs_f64() * 1e3;
    Ok((out, FindTimings { embed_ms, rank_ms }))
}

/// The vector index over instance features (see the OpenGraph schema).
const INDEX: &str = "instance_feature";

/// Whether a node's class and centroid pass the filters; `class` and `centroid` are its
/// properties of those names.
fn fits(class: Option<&Value>, centroid: Option<&Value>, opts: &FindOptions) -> bool {
    if let Some(c) = &opts.class
        && class.and_then(Value::as_str) != Some(c.as_str())
    {
        return false;
    }
    if let Some((g, radius_m)) = opts.near {
        let Some(p) = centroid.and_then(Value::as_point3) else {
            return false;
        };
        if (p[0] - g[0]).hypot(p[2] - g[1]) > radius_m {
            return false;
        }
    }
    true
}

/// [`fits`] for a node id, reading the node once.
fn passes<R: GraphRead>(r: &R, id: u64, opts: &FindOptions) -> Result<bool> {
    let Some(node) = r.node(id)? else {
        return Ok(false);
    };
    let get = |k: &str| r.prop_key(k).and_then(|k| node.get(k));
    Ok(fits(
        get(scene::key::SEMANTIC_CLASS),
        get(scene::key::CENTROID),
        opts,
    ))
}

/// Top-k through the vector index. With filters it ranks a prefix of the whole ranking and
/// keeps the first k that pass, growing the prefix until k pass or the index is exhausted,
/// so the answer is the exact filtered top-k.
fn ranked_by_index<R: GraphRead>(
    r: &R,
    ix: &graphstore::FlatVectorIndex<'_>,
    q: &[f32],
    opts: &FindOptions,
) -> Result<Vec<(f64, u64)>> {
    let filtered = opts.class.is_some() || opts.near.is_some();
    let mut fetch = if filtered {
        (opts.k * 8).max(64)
    } else {
        opts.k
    };
    loop {
        let hits = ix.top_k(q, fetch)?;
        let mut out = Vec::with_capacity(opts.k);
        for h in &hits {
            if out.len() == opts.k {
                break;
            }
            if !filtered || passes(r, h.node, opts)? {
                out.push((h.score, h.node));
            }
        }
        if out.len() == opts.k || hits.len() < fetch {
            return Ok(out);
        }
        fetch = fetch.saturating_mul(4);
    }
}

/// Exact scan over every instance's stored feature (maps without the vector index).
fn scan<R: GraphRead>(r: &R, q: &[f32], opts: &FindOptions) -> Result<Vec<(f64, u64)>> {
    let (k_feature, k_class, k_centroid) = (
        r.prop_key(scene::key::FEATURE),
        r.prop_key(scene::key::SEMANTIC_CLASS),
        r.prop_key(scene::key::CENTROID),
    );
    // only the scores are kept while scanning; the k winners are read again afterwards
    let mut scored: Vec<(f64, u64)> = Vec::new();
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let Some(node) = r.node(id)? else { continue };
        let get = |k: Option<PropKey>| {
            let k = k?;
            node.props.iter().find(|(n, _)| *n == k).map(|(_, v)| v)
        };
        let Some(Value::Vector(f)) = get(k_feature) else {
            continue;
        };
        if f.len() != q.len() {
            return Err(Error::Invalid(format!(
                "instance {id} has a {}-dimensional feature, the embedder gives {}",
                f.len(),
                q.len()
            )));
        }
        if !fits(get(k_class), get(k_centroid), opts) {
            continue;
        }
        scored.push((cosine(q, f), id));
    }
    Ok(scored)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::HashEmbedder;
    use graphstore::Store;

    fn store_with(captions: &[(&str, &str, [f64; 3])]) -> (tempfile::TempDir, Store) {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::create(dir.path().join("m.og")).unwrap();
        let mut e = HashEmbedder::new(64);
        store
            .write(|tx| {
                for (cap, class, c) in captions {
                    let f = e.embed(&[cap]).unwrap().pop().unwrap();
                    tx.create_node_named(
                        &[scene::label::INSTANCE],
                        &[
                            ("caption", Value::String(cap.to_string())),
                            ("semantic_class", Value::String(class.to_string())),
                            ("centroid", Value::Point3D(*c)),
                            ("feature", Value::Vector(f)),
                        ],
                    )?;
                }
                Ok(())
            })
            .unwrap();
        (dir, store)
    }

    #[test]
    fn ranks_by_cosine_and_filters() {
        let (_d, store) = store_with(&[
            (
                "a green wooden bench on the sidewalk",
                "bench",
                [0.0, 0.0, 0.0],
            ),
            ("a red car parked by the curb", "car", [5.0, 0.0, 0.0]),
            (
                "a long bench facing the street",
                "bench",
                [100.0, 0.0, 100.0],
            ),
        ]);
        let r = store.read().unwrap();
        let mut e = HashEmbedder::new(64);
        let (hits, _) = find(&r, &mut e, "a bench", &FindOptions::default()).unwrap();
        assert_eq!(hits.len(), 3);
        assert_eq!(hits[0].semantic_class, "bench");
        assert!(hits[0].score >= hits[1].score && hits[1].score >= hits[2].score);
        assert_eq!(hits[2].semantic_class, "car");
        let near = FindOptions {
            near: Some(([0.0, 0.0], 10.0)),
            ..FindOptions::default()
        };
        let (hits, _) = find(&r, &mut e, "a bench", &near).unwrap();
        assert_eq!(hits.len(), 2);
        assert!(hits.iter().all(|h| h.centroid[0] < 10.0));
        let cars = FindOptions {
            class: Some("car".into()),
            k: 5,
            ..FindOptions::default()
        };
        let (hits, _) = find(&r, &mut e, "a bench", &cars).unwrap();
        assert_eq!(hits.len(), 1);
        assert!(find(&r, &mut e, "  ", &FindOptions::default()).is_err());
        // a query embedder of another dimension is refused
        let mut wrong = HashEmbedder::new(32);
        assert!(find(&r, &mut wrong, "a bench", &FindOptions::default()).is_err());
    }

    #[test]
    fn the_vector_index_path_ranks_exactly_like_the_full_scan() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::create(dir.path().join("ix.og")).unwrap();
        store.set_schema(scene::opengraph_schema()).unwrap();
        let mut e = HashEmbedder::new(scene::FEATURE_DIM);
        let words = [
            "bench", "car", "tree", "pole", "shelter", "lamp", "bin", "sign",
        ];
        store
            .write(|tx| {
                for i in 0..400i64 {
                    let caption = format!(
                        "a {} near the {} number {i}",
                        words[(i % 8) as usize],
                        words[(i % 5) as usize]
                    );
                    let f = e.embed(&[caption.as_str()]).unwrap().pop().unwrap();
                    let (x, z) = ((i % 20) as f64 * 5.0, (i / 20) as f64 * 5.0);
                    tx.create_node_named(
                        &[scene::label::INSTANCE],
                        &[
                            ("instance_id", Value::Int(i)),
                            ("caption", Value::String(caption)),
                            ("semantic_class", Value::from(words[(i % 8) as usize])),
                            ("centroid", Value::Point3D([x, 0.0, z])),
                            ("bbox", Value::box3d([x, 0.0, z], [x + 1.0, 1.0, z + 1.0])),
                            ("feature", Value::Vector(f)),
                        ],
                    )?;
                }
                Ok(())
            })
            .unwrap();
        let r = store.read().unwrap();
        let ix = r.vector_index(INDEX).unwrap();
        let q = e
            .embed(&["a shelter near the bench"])
            .unwrap()
            .pop()
            .unwrap();
        for opts in [
            FindOptions {
                k: 10,
                class: None,
                near: None,
            },
            FindOptions {
                k: 7,
                class: Some("lamp".into()),
                near: None,
            },
            FindOptions {
                k: 5,
                class: None,
                near: Some(([20.0, 20.0], 12.0)),
            },
            FindOptions {
                k: 3,
                class: Some("sign".into()),
                near: Some(([0.0, 0.0], 30.0)),
            },
            FindOptions {
                k: 10,
                class: Some("no such class".into()),
                near: None,
            },
        ] {
            let mut a = ranked_by_index(&r, &ix, &q, &opts).unwrap();
            let mut b = scan(&r, &q, &opts).unwrap();
            for v in [&mut a, &mut b] {
                v.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
                v.truncate(opts.k);
            }
            assert_eq!(a.len(), b.len(), "{opts:?}");
            for ((sa, ia), (sb, ib)) in a.iter().zip(&b) {
                assert!((sa - sb).abs() < 1e-5, "{opts:?}: {sa} vs {sb}");
                // equal scores may come in either order; otherwise the same node
                assert!(ia == ib || (sa - sb).abs() < 1e-6, "{opts:?}");
            }
        }
    }
}
