//! The LLM passes over a small hand-made map with a scripted model: what they write, that a
//! repeated run asks nothing (done items are skipped), that a fresh run over the same inputs
//! answers from the map's cache, that budgets and limits leave the rest for later, that
//! surfaces are never related, and that a model failure leaves the store as it was.

use graphstore::{GraphRead, Store, Value};
use ingest::hierarchy::relations::RelationConfig;
use ingest::hierarchy::{HierarchyConfig, build_hierarchy};
use ingest::llm::{PassOptions, infer_relations, merge_captions};
use llm_tools::chat::scripted::{Reply, Scripted};
use llm_tools::{Embedder, HashEmbedder};
use scene::GroundFrame;
use scene::opengraph_schema;

fn object(
    tx: &mut graphstore::WriteTxn<'_>,
    id: i64,
    class: &str,
    captions: &[&str],
    min: [f64; 3],
    max: [f64; 3],
) {
    let c = [0, 1, 2].map(|i| (min[i] + max[i]) / 2.0);
    tx.create_node_named(
        &["Instance"],
        &[
            ("instance_id", Value::Int(id)),
            ("caption", Value::String(captions[0].to_string())),
            (
                "captions",
                Value::List(
                    captions
                        .iter()
                        .map(|c| Value::String(c.to_string()))
                        .collect(),
                ),
            ),
            ("semantic_class", class.into()),
            ("centroid", Value::Point3D(c)),
            ("bbox", Value::box3d(min, max)),
        ],
    )
    .unwrap();
}

/// A straight 200 m road in ENU with a bus shelter, a bench inside it, a lamp post beside it,
/// a car 40 m on, and the road surface itself.
fn map(dir: &std::path::Path) -> Store {
    let store = Store::create(dir.join("m.og")).unwrap();
    store.set_schema(opengraph_schema()).unwrap();
    store
        .write(|tx| {
            object(
                tx,
                0,
                "other-structure",
                &[
                    "a grey bus shelter",
                    "a blue bus shelter",
                    "a grey metal bus shelter",
                ],
                [10.0, 5.0, 0.0],
                [14.0, 7.0, 2.6],
            );
            object(
                tx,
                1,
                "other-object",
                &["a wooden bench", "a red wooden bench", "a wooden bench"],
                [11.0, 5.5, 0.0],
                [12.5, 6.0, 0.5],
            );
            object(
                tx,
                2,
                "pole",
                &["a lamp post", "a tall lamp post"],
                [15.0, 5.0, 0.0],
                [15.3, 5.3, 5.0],
            );
            object(
                tx,
                3,
                "car",
                &["a red car", "a red car parked"],
                [50.0, 5.0, 0.0],
                [54.0, 7.0, 1.5],
            );
            object(
                tx,
                4,
                "road",
                &["asphalt road", "asphalt road"],
                [0.0, -4.0, -0.1],
                [200.0, 4.0, 0.0],
            );
            object(
                tx,
                5,
                "car",
                &["a lone car"],
                [120.0, 5.0, 0.0],
                [124.0, 7.0, 1.5],
            );
            Ok(())
        })
        .unwrap();
    let traj: Vec<[f64; 3]> = (0..=200).map(|x| [f64::from(x), 0.0, 1.7]).collect();
    build_hierarchy(
        &store,
        &traj,
        GroundFrame::Enu,
        "test",
        &HierarchyConfig::default(),
    )
    .unwrap();
    store
}

fn merger() -> Scripted {
    Scripted::from_fn("merge", |req| {
        let q = &req.messages[1].content;
        let c = if q.contains("bench") {
            "a wooden bench"
        } else if q.contains("shelter") {
            "a grey metal bus shelter"
        } else {
            "a thing"
        };
        Reply::Text(format!(r#"{{"caption": "{c}"}}"#))
    })
}

fn labeller() -> Scripted {
    Scripted::from_fn("relate", |req| {
        let q = &req.messages[1].content;
        let r = if q.starts_with("Object A: a wooden bench") && q.contains("Object B: a grey") {
            "inside"
        } else {
            "near"
        };
        Reply::Text(format!(
            r#"{{"relation": "{r}", "relation_confidence": 0.8}}"#
        ))
    })
}

fn llm_edges(r: &impl GraphRead) -> Vec<(i64, i64, String, String)> {
    let t = r.rel_type("RELATED").unwrap();
    let iid = |n: u64| {
        r.node_prop(n, "instance_id")
            .unwrap()
            .unwrap()
            .as_int()
            .unwrap()
    };
    let mut out = Vec::new();
    for id in r.all_node_ids().unwrap() {
        for adj in r
            .neighbours(id, graphstore::Direction::Outgoing, Some(t))
            .unwrap()
        {
            let rel = r.rel(adj.rel).unwrap().unwrap();
            let p = |k: &str| rel.get(r.prop_key(k).unwrap()).cloned();
            if p("source") == Some(Value::from("llm")) {
                out.push((
                    iid(rel.start),
                    iid(rel.end),
                    p("relation").unwrap().as_str().unwrap().to_string(),
                    p("model").unwrap().as_str().unwrap().to_string(),
                ));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn caption_merge_writes_provenance_and_never_asks_twice() {
    let dir = tempfile::tempdir().unwrap();
    let store = map(dir.path());
    let mut emb = HashEmbedder::new(scene::FEATURE_DIM);
    let mut m = merger();
    let r = merge_captions(&store, &mut m, &mut emb, 4, &PassOptions::default()).unwrap();
    // objects with several captions: shelter, bench, lamp post, car 3 (not the road, not the lone car)
    assert_eq!((r.total, r.done, r.cached, r.left), (4, 4, 0, 0), "{r:?}");
    assert_eq!(m.calls(), 4);
    assert_eq!(r.prompt, "merge_captions@v1");
    {
        let rd = store.read().unwrap();
        let bench = rd
            .find_nodes("Instance", "instance_id", &Value::Int(1))
            .unwrap()[0];
        let s = |k: &str| {
            rd.node_prop(bench, k)
                .unwrap()
                .unwrap()
                .as_str()
                .unwrap()
                .to_string()
        };
        assert_eq!(s("caption"), "a wooden bench");
        assert_eq!(s("caption_medoid"), "a wooden bench");
        assert_eq!(s("caption_model"), "scripted:merge");
        assert_eq!(s("caption_prompt"), "merge_captions@v1");
        // the feature is the new caption's embedding (no detection feature here)
        let f = match rd.node_prop(bench, "feature").unwrap() {
            Some(Value::Vector(v)) => v,
            other => panic!("{other:?}"),
        };
        let e = emb.embed(&["a wooden bench"]).unwrap().remove(0);
        assert!(llm_tools::embed::cosine(&f, &e) > 0.999);
        let road = rd
            .find_nodes("Instance", "instance_id", &Value::Int(4))
            .unwrap()[0];
        assert!(rd.node_prop(road, "caption_model").unwrap().is_none());
        assert_eq!(rd.counts().unwrap().nodes.get("LlmAnswer"), Some(&4));
    }
    // again: all done, nothing asked
    let r = merge_captions(&store, &mut m, &mut emb, 4, &PassOptions::default()).unwrap();
    assert_eq!((r.already_done, r.done), (4, 0));
    assert_eq!(m.calls(), 4);
    // a fresh pass over the same inputs (provenance removed) answers from the cache
    store
        .write(|tx| {
            let k = tx.prop_key_id("caption_prompt")?;
            for id in tx.nodes_with_label("Instance")? {
                tx.remove_node_prop(id, k)?;
            }
            Ok(())
        })
        .unwrap();
    let r = merge_captions(&store, &mut m, &mut emb, 4, &PassOptions::default()).unwrap();
    assert_eq!((r.done, r.cached), (4, 4), "{r:?}");
    assert_eq!(m.calls(), 4);
}

#[test]
fn relation_pass_labels_object_pairs_resumes_and_caches() {
    let dir = tempfile::tempdir().unwrap();
    let store = map(dir.path());
    let geometric_before = store
        .read()
        .unwrap()
        .counts()
        .unwrap()
        .relationships
        .get("RELATED")
        .copied();
    let mut m = labeller();
    // one pair only: the rest is left for later
    let opts = PassOptions {
        max_items: Some(1),
        ..PassOptions::default()
    };
    let r = infer_relations(&store, &mut m, &RelationConfig::default(), &opts).unwrap();
    assert_eq!((r.done, r.left), (1, r.total - 1), "{r:?}");
    let r = infer_relations(
        &store,
        &mut m,
        &RelationConfig::default(),
        &PassOptions::default(),
    )
    .unwrap();
    assert_eq!(r.already_done, 1);
    assert_eq!(r.left, 0);
    let total = r.total;
    assert_eq!(m.calls() as usize, total);
    let edges = llm_edges(&store.read().unwrap());
    assert_eq!(edges.len(), total);
    // the bench is inside the shelter; the road (a surface) is never one side of a pair
    assert!(
        edges.contains(&(0, 1, "near".into(), "scripted:relate".into()))
            || edges.contains(&(1, 0, "inside".into(), "scripted:relate".into())),
        "{edges:?}"
    );
    assert!(edges.iter().all(|e| e.0 != 4 && e.1 != 4), "{edges:?}");
    // the lone car has no object within candidate_m (15 m), so it is in no pair
    assert!(edges.iter().all(|e| e.0 != 5 && e.1 != 5), "{edges:?}");
    // the geometric edges stay
    let after = store
        .read()
        .unwrap()
        .counts()
        .unwrap()
        .relationships
        .get("RELATED")
        .copied()
        .unwrap_or(0);
    assert_eq!(after, geometric_before.unwrap_or(0) + total as u64);
    // again: nothing asked
    let r = infer_relations(
        &store,
        &mut m,
        &RelationConfig::default(),
        &PassOptions::default(),
    )
    .unwrap();
    assert_eq!((r.already_done, r.done), (total, 0));
    assert_eq!(m.calls() as usize, total);
}

#[test]
fn a_failing_model_leaves_the_store_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let store = map(dir.path());
    let before = store.read().unwrap().counts().unwrap();
    // answers of the wrong shape: each item is rejected with the reason, none is done, and
    // nothing is written (a later run asks again)
    let mut bad = Scripted::from_fn("bad", |_| Reply::Text(r#"{"relation": 7}"#.into()));
    let r = infer_relations(
        &store,
        &mut bad,
        &RelationConfig::default(),
        &PassOptions::default(),
    )
    .unwrap();
    assert_eq!((r.done, r.rejected.len(), r.left), (0, r.total, r.total));
    assert!(
        r.rejected
            .iter()
            .all(|w| w.contains("does not follow the schema")),
        "{r:?}"
    );
    // a model that fails outright stops the pass
    let mut emb = HashEmbedder::new(scene::FEATURE_DIM);
    let mut bad = Scripted::new("empty", vec![]);
    assert!(merge_captions(&store, &mut bad, &mut emb, 4, &PassOptions::default()).is_err());
    assert_eq!(store.read().unwrap().counts().unwrap(), before);
}
