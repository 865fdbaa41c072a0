//! End-to-end: the OpenGraph schema under concurrent readers and a writer, and export
//! round-trips.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use graphstore::export::{ExportFormat, export};
use graphstore::{Error, GraphRead, Store, Value, VectorSearch};
use scene::opengraph_schema;

fn instance(i: i64, x: f64) -> Vec<(&'static str, Value)> {
    vec![
        ("instance_id", Value::Int(i)),
        ("caption", format!("object number {i} near the road").into()),
        (
            "semantic_class",
            if i % 2 == 0 { "car" } else { "bench" }.into(),
        ),
        ("centroid", Value::Point3D([x, 0.0, 0.0])),
        (
            "bbox",
            Value::box3d([x - 0.5, -0.5, -0.5], [x + 0.5, 0.5, 0.5]),
        ),
        (
            "feature",
            Value::Vector(
                (0..384)
                    .map(|d| ((d as i64 * 31 + i) % 17) as f32 - 8.0)
                    .collect(),
            ),
        ),
    ]
}

/// Readers started at any point see a whole committed transaction or none of it: the
/// instance count, label index, property index, spatial, vector and text indexes agree.
#[test]
fn readers_see_consistent_snapshots_while_a_writer_commits() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("s.og")).unwrap();
    store.set_schema(opengraph_schema()).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let writer = {
        let store = store.clone();
        std::thread::spawn(move || {
            for t in 0..60i64 {
                store
                    .write(|tx| {
                        for j in 0..10 {
                            let i = t * 10 + j;
                            tx.create_node_named(&["Instance"], &instance(i, i as f64))?;
                        }
                        Ok(())
                    })
                    .unwrap();
            }
        })
    };
    let readers: Vec<_> = (0..2)
        .map(|_| {
            let store = store.clone();
            let stop = stop.clone();
            std::thread::spawn(move || {
                let mut checks = 0;
                while !stop.load(Ordering::Relaxed) {
                    let r = store.read().unwrap();
                    let n = r.nodes_with_label("Instance").unwrap().len();
                    assert_eq!(n % 10, 0, "a reader saw half a transaction");
                    std::thread::sleep(Duration::from_millis(1));
                    // the same snapshot answers the same after the writer moved on
                    assert_eq!(r.nodes_with_label("Instance").unwrap().len(), n);
                    assert_eq!(
                        r.find_nodes("Instance", "semantic_class", &"car".into())
                            .unwrap()
                            .len(),
                        n / 2
                    );
                    assert_eq!(
                        r.spatial_within("instance_space", [0.0; 3], 1e9)
                            .unwrap()
                            .len(),
                        n
                    );
                    assert_eq!(
                        r.vector_top_k("instance_feature", &[1.0; 384], 100_000)
                            .unwrap()
                            .len(),
                        n
                    );
                    assert_eq!(
                        r.text_search("instance_caption", "object road", 100_000)
                            .unwrap()
                            .len(),
                        n
                    );
                    assert_eq!(r.counts().unwrap().total_nodes as usize, n);
                    checks += 1;
                }
                checks
            })
        })
        .collect();
    writer.join().unwrap();
    stop.store(true, Ordering::Relaxed);
    let checks: usize = readers.into_iter().map(|h| h.join().unwrap()).sum();
    assert!(checks > 0);
    assert_eq!(store.counts().unwrap().nodes["Instance"], 600);
    assert!(store.check_consistency().unwrap().is_empty());
    // the vector index behind the trait
    let r = store.read().unwrap();
    let idx = r.vector_index("instance_feature").unwrap();
    assert!(idx.is_exact());
    assert_eq!(idx.dim(), 384);
    let q: Vec<f32> = (0..384)
        .map(|d| ((d as i64 * 31 + 7) % 17) as f32 - 8.0)
        .collect();
    let hits = idx.top_k(&q, 3).unwrap();
    assert_eq!(
        r.node_prop(hits[0].node, "instance_id").unwrap(),
        Some(Value::Int(7))
    );
    assert!((hits[0].score - 1.0).abs() < 1e-5);
    assert!(matches!(
        idx.top_k(&[1.0; 3], 3),
        Err(Error::InvalidValue(_))
    ));
    assert!(matches!(
        r.vector_index("nope"),
        Err(Error::NoSuchIndex { .. })
    ));
}

#[test]
fn schema_violations_are_refused_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("s.og")).unwrap();
    store.set_schema(opengraph_schema()).unwrap();
    store
        .write(|tx| tx.create_node_named(&["Instance"], &instance(1, 0.0)))
        .unwrap();
    let before = store.counts().unwrap();
    // missing required caption
    let mut p = instance(2, 1.0);
    p.retain(|(k, _)| *k != "caption");
    let e = store
        .write(|tx| tx.create_node_named(&["Instance"], &p))
        .unwrap_err();
    assert!(
        e.to_string()
            .contains("missing required property `caption`"),
        "{e}"
    );
    // duplicate unique key, after other successful writes in the same transaction
    let e = store
        .write(|tx| {
            tx.create_node_named(&["Instance"], &instance(3, 2.0))?;
            tx.create_node_named(&["Instance"], &instance(1, 3.0))
        })
        .unwrap_err();
    assert!(
        matches!(e, Error::Constraint { .. }) && e.to_string().contains("already used by node 0"),
        "{e}"
    );
    // wrong type, wrong vector dimension, wrong relationship endpoints
    let mut p = instance(4, 1.0);
    p[3] = ("centroid", Value::from("here"));
    assert!(
        store
            .write(|tx| tx.create_node_named(&["Instance"], &p))
            .is_err()
    );
    let mut p = instance(5, 1.0);
    p[5] = ("feature", Value::Vector(vec![1.0; 3]));
    assert!(
        store
            .write(|tx| tx.create_node_named(&["Instance"], &p))
            .unwrap_err()
            .to_string()
            .contains("dimension 384")
    );
    let e = store
        .write(|tx| {
            let seg = tx.create_node_named(
                &["Frame"],
                &[
                    ("index", Value::Int(0)),
                    ("world_from_velo", Value::List(vec![])),
                ],
            )?;
            tx.create_rel_named(0, "CONTAINS", seg, &[])
        })
        .unwrap_err();
    assert!(
        e.to_string()
            .contains("start node must be labelled Environment"),
        "{e}"
    );
    assert_eq!(
        store.counts().unwrap(),
        before,
        "failed transactions left traces"
    );
    assert!(store.check_consistency().unwrap().is_empty());
    // a schema that existing data breaks is refused as a whole
    let mut s = opengraph_schema();
    s.labels
        .get_mut("Instance")
        .unwrap()
        .properties
        .push(graphstore::PropertyRule {
            key: "owner".into(),
            ty: graphstore::ValueType::String,
            required: true,
        });
    let e = store.set_schema(s).unwrap_err();
    assert!(
        e.to_string()
            .contains("existing node 0 breaks the new schema"),
        "{e}"
    );
    assert_eq!(store.schema(), opengraph_schema());
}

#[test]
fn exports_carry_every_node_and_relationship() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("s.og")).unwrap();
    store.set_schema(opengraph_schema()).unwrap();
    store
        .write(|tx| {
            let a = tx.create_node_named(&["Instance"], &instance(1, 0.0))?;
            let b = tx.create_node_named(&["Instance", "Custom"], &instance(2, 1.0))?;
            tx.create_rel_named(
                a,
                "RELATED",
                b,
                &[
                    ("relation", "next_to".into()),
                    ("distance_m", Value::Float(1.0)),
                    ("source", "geometric".into()),
                    ("confidence", Value::Float(0.9)),
                    ("type", "clashes with a reserved name".into()),
                ],
            )?;
            Ok(())
        })
        .unwrap();
    let r = store.read().unwrap();
    let mut buf = Vec::new();
    assert_eq!(
        export(&r, ExportFormat::NodeLink, &mut buf).unwrap(),
        (2, 1)
    );
    let v: serde_json::Value = serde_json::from_slice(&buf).unwrap();
    assert_eq!(
        v["nodes"][1]["labels"],
        serde_json::json!(["Custom", "Instance"])
    );
    assert_eq!(v["nodes"][0]["caption"], "object number 1 near the road");
    assert_eq!(v["nodes"][0]["feature"].as_array().unwrap().len(), 384);
    assert_eq!(v["edges"][0]["type"], "RELATED");
    assert_eq!(v["edges"][0]["_type"], "clashes with a reserved name");
    assert_eq!(v["edges"][0]["confidence"], 0.9);
    let mut xml = Vec::new();
    assert_eq!(export(&r, ExportFormat::GraphMl, &mut xml).unwrap(), (2, 1));
    let xml = String::from_utf8(xml).unwrap();
    assert!(xml.contains("<data key=\"labels\">:Custom:Instance</data>"));
}

#[test]
fn shared_data_is_located_or_skipped() {
    match opengraph_tests::shared_data() {
        Some(p) => assert!(
            p.join("README.md").is_file(),
            "{} has no README",
            p.display()
        ),
        None => eprintln!("skipping: ../shared/data is absent"),
    }
}
