//! Deleting a node with its relationships and payloads, then restoring them under their old
//! ids, gives back the same store: records, adjacency, counts and every index.

use graphstore::{GraphRead, PointCloud, Store, Value};
use proptest::prelude::*;

fn snapshot(store: &Store) -> (String, Vec<String>) {
    let q = |cypher: &str| {
        let r = store
            .query(cypher, &graphstore::cypher::QueryOptions::default())
            .unwrap();
        serde_json::to_string(&r.rows_json()).unwrap()
    };
    let all = q(
        "MATCH (n) OPTIONAL MATCH (n)-[r]->(m) RETURN id(n) AS n, labels(n) AS l, properties(n) AS p, id(r) AS r, type(r) AS t, properties(r) AS rp, id(m) AS m ORDER BY n, r",
    );
    (all, store.check_consistency().unwrap())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn delete_then_restore_is_the_identity(n in 2usize..8, victim in 0usize..8, seed in 0u64..1000) {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::create(dir.path().join("t.og")).unwrap();
        let ids: Vec<u64> = store.write(|tx| {
            let mut ids = Vec::new();
            for i in 0..n {
                let x = (seed as f64 * 0.37 + i as f64 * 1.5) % 50.0;
                ids.push(tx.create_node_named(&["Instance"], &[
                    ("caption", Value::from(format!("thing {i}"))),
                    ("centroid", Value::Point3D([x, 0.0, -x])),
                    ("score", Value::Float(x / 7.0)),
                ])?);
            }
            for i in 0..n {
                let j = (i * 3 + seed as usize) % n;
                tx.create_rel_named(ids[i], "RELATED", ids[j], &[("distance_m", Value::Float(i as f64))])?;
            }
            tx.put_point_cloud(ids[0], "points", &PointCloud { xyz: vec![[1.0, 2.0, 3.0]], rgb: vec![] })?;
            Ok(ids)
        }).unwrap();
        let before = snapshot(&store);
        let victim = ids[victim % n];
        // what undo needs: the record, its relationships, its payloads
        let (labels, props, rels, payloads) = {
            let r = store.read().unwrap();
            let node = r.node(victim).unwrap().unwrap();
            let mut rels = Vec::new();
            for a in r.neighbours(victim, graphstore::Direction::Both, None).unwrap() {
                let rel = r.rel(a.rel).unwrap().unwrap();
                if !rels.iter().any(|x: &graphstore::Relationship| x.id == rel.id) {
                    rels.push(rel);
                }
            }
            let payloads: Vec<(String, Vec<u8>)> = r.payload_keys(victim).unwrap().into_iter()
                .map(|k| { let b = r.payload(victim, &k).unwrap().unwrap(); (k, b) }).collect();
            (node.labels.clone(), node.props.clone(), rels, payloads)
        };
        store.write(|tx| tx.detach_delete_node(victim)).unwrap();
        prop_assert_ne!(&snapshot(&store).0, &before.0);
        store.write(|tx| {
            tx.restore_node(victim, &labels, props.clone())?;
            for (k, b) in &payloads {
                tx.put_payload(victim, k, b)?;
            }
            for rel in &rels {
                tx.restore_rel(rel.id, rel.start, rel.ty, rel.end, rel.props.clone())?;
            }
            Ok(())
        }).unwrap();
        prop_assert_eq!(snapshot(&store), before);
        // a used id cannot be restored over, and an id never handed out cannot be made
        let err = store.write(|tx| tx.restore_node(victim, &labels, props.clone()));
        prop_assert!(err.is_err());
        let err = store.write(|tx| tx.restore_node(10_000, &labels, vec![]));
        prop_assert!(err.is_err());
    }

    #[test]
    fn values_roundtrip_through_bytes(f in any::<f64>(), i in any::<i64>(), s in ".{0,20}", v in prop::collection::vec(any::<f32>(), 0..8)) {
        let value = Value::List(vec![Value::Float(f), Value::Int(i), Value::String(s), Value::Vector(v), Value::Bytes(vec![0, 255])]);
        let back = Value::from_bytes(&value.to_bytes()).unwrap();
        // compare bit patterns: NaN != NaN
        prop_assert_eq!(back.to_bytes(), value.to_bytes());
    }
}

#[test]
fn bad_value_bytes_are_an_error() {
    assert!(Value::from_bytes(&[]).is_err());
    assert!(Value::from_bytes(&[0xff, 0x00]).is_err());
    let mut b = Value::Int(5).to_bytes();
    b.push(0);
    assert!(Value::from_bytes(&b).is_err());
}
