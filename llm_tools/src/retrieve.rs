//! Open-vocabulary retrieval: rank a map's `Instance` nodes by the cosine between an embedded
//! text and their fused feature (0.5 × caption embedding + 0.5 × mean detection feature, as
//! ingest writes it), optionally filtered by class and by distance from a ground point.

use graphstore::{GraphRead, PropKey, Value};

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
    /// Fused caption.
    pub caption: String,
    /// Class.
    pub class: String,
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
    for id in r.nodes_with_label("Build")? {
        if let Some(Value::String(args)) = r.node_prop(id, "args")?
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
    let (k_feature, k_class, k_centroid) = (
        r.prop_key("feature"),
        r.prop_key("class"),
        r.prop_key("centroid"),
    );
    // only the scores are kept while scanning; the k winners are read again afterwards
    let mut scored: Vec<(f64, u64)> = Vec::new();
    for id in r.nodes_with_label("Instance")? {
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
        if let Some(c) = &opts.class
            && get(k_class).and_then(Value::as_str) != Some(c.as_str())
        {
            continue;
        }
        if let Some((g, radius_m)) = opts.near {
            let Some(p) = get(k_centroid).and_then(Value::as_point3) else {
                continue;
            };
            if (p[0] - g[0]).hypot(p[2] - g[1]) > radius_m {
                continue;
            }
        }
        scored.push((cosine(&q, f), id));
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    scored.truncate(opts.k);
    let mut out = Vec::with_capacity(scored.len());
    for (score, id) in scored {
        let text = |k: &str| -> Result<String> {
            Ok(r.node_prop(id, k)?
                .as_ref()
                .and_then(Value::as_str)
                .unwrap_or_default()
                .to_string())
        };
        out.push(Found {
            id,
            caption: text("caption")?,
            class: text("class")?,
            score,
            centroid: r
                .node_prop(id, "centroid")?
                .as_ref()
                .and_then(Value::as_point3)
                .unwrap_or([f64::NAN; 3]),
        });
    }
    let rank_ms = t1.elapsed().as_secs_f64() * 1e3;
    Ok((out, FindTimings { embed_ms, rank_ms }))
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
                        &["Instance"],
                        &[
                            ("caption", Value::String(cap.to_string())),
                            ("class", Value::String(class.to_string())),
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
        assert_eq!(hits[0].class, "bench");
        assert!(hits[0].score >= hits[1].score && hits[1].score >= hits[2].score);
        assert_eq!(hits[2].class, "car");
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
}
