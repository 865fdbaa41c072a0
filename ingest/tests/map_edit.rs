//! Map edits on a small hand-made map: each kind of edit changes what it should (points,
//! relations, segment, indexes), and undo gives back exactly the store before it.

use graphstore::{GraphRead, PointCloud, Store, Value};
use ingest::map_edit::{Change, apply, list, undo};

/// Everything but the MapEdit records, as sorted text, plus the consistency report.
fn snapshot(store: &Store) -> (String, Vec<String>) {
    let r = store
        .query(
            "MATCH (n) WHERE NOT n:MapEdit OPTIONAL MATCH (n)-[r]->(m) \
             RETURN id(n) AS n, labels(n) AS l, properties(n) AS p, id(r) AS r, type(r) AS t, \
             properties(r) AS rp, id(m) AS m ORDER BY n, r",
            &graphstore::cypher::QueryOptions::default(),
        )
        .unwrap();
    let mut text = serde_json::to_string(&r.rows_json()).unwrap();
    // payloads too
    let rd = store.read().unwrap();
    for id in rd.nodes_with_label("Instance").unwrap() {
        if let Some(b) = rd.payload(id, "points").unwrap() {
            text.push_str(&format!("|{id}:{}", b.len()));
            text.push_str(&format!("{:?}", &b[..b.len().min(64)]));
        }
    }
    (text, store.check_consistency().unwrap())
}

/// A 384-dimensional feature (the schema's dimension) pointing mostly along axis `i`.
fn feat(i: usize) -> Vec<f32> {
    let mut v = vec![0.01; 384];
    v[i] = 1.0;
    v
}

fn bx(c: [f64; 3], half: f64) -> Value {
    Value::box3d(
        [c[0] - half, c[1] - half, c[2] - half],
        [c[0] + half, c[1] + half, c[2] + half],
    )
}

/// A straight road along z from 0 to 100 (KITTI camera frame: ground x, z; y down), and four
/// objects beside it: a bench and a bin next to each other at z = 20, a sign at z = 60, a
/// tree at z = 90.
fn small_map() -> (tempfile::TempDir, Store, Vec<u64>) {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("m.og")).unwrap();
    store.set_schema(scene::opengraph_schema()).unwrap();
    let ids = store
        .write(|tx| {
            let env = tx.create_node_named(
                &["Environment"],
                &[
                    ("name", "test".into()),
                    ("ground_frame", "kitti_cam".into()),
                ],
            )?;
            let seg = tx.create_node_named(
                &["Segment"],
                &[
                    ("segment_id", Value::Int(0)),
                    ("kind", "straight_roadway".into()),
                    ("centroid", Value::Point3D([0.0, 0.0, 50.0])),
                    (
                        "centerline",
                        Value::List(vec![
                            Value::Point3D([0.0, 0.0, 0.0]),
                            Value::Point3D([0.0, 0.0, 100.0]),
                        ]),
                    ),
                    ("half_width_m", Value::Float(6.0)),
                    ("bbox", Value::box3d([-6.0, -3.0, 0.0], [6.0, 3.0, 100.0])),
                ],
            )?;
            tx.create_rel_named(env, "CONTAINS", seg, &[])?;
            let mut ids = Vec::new();
            for (i, (caption, class, c)) in [
                ("a brown bench", "fence", [4.0, 0.5, 20.0]),
                ("a green bin", "pole", [4.0, 0.5, 21.6]),
                ("a street sign", "traffic-sign", [4.0, -1.0, 60.0]),
                ("a bush", "vegetation", [5.0, 0.5, 90.0]),
            ]
            .into_iter()
            .enumerate()
            {
                let id = tx.create_node_named(
                    &["Instance"],
                    &[
                        ("instance_id", Value::Int(i as i64)),
                        ("caption", caption.into()),
                        ("semantic_class", class.into()),
                        ("centroid", Value::Point3D(c)),
                        ("bbox", bx(c, 0.5)),
                        ("feature", Value::Vector(feat(i))),
                        ("point_count", Value::Int(3)),
                    ],
                )?;
                tx.put_point_cloud(
                    id,
                    "points",
                    &PointCloud {
                        xyz: vec![
                            [c[0] as f32, c[1] as f32, c[2] as f32],
                            [c[0] as f32 + 0.25, c[1] as f32, c[2] as f32],
                            [c[0] as f32, c[1] as f32, c[2] as f32 - 0.25],
                        ],
                        rgb: vec![],
                    },
                )?;
                tx.create_rel_named(id, "IN_SEGMENT", seg, &[("distance_m", Value::Float(0.0))])?;
                ids.push(id);
            }
            tx.create_rel_named(
                ids[0],
                "RELATED",
                ids[1],
                &[
                    ("relation", "next_to".into()),
                    ("distance_m", Value::Float(0.6)),
                    ("source", "geometric".into()),
                    ("confidence", Value::Float(0.9)),
                ],
            )?;
            Ok(ids)
        })
        .unwrap();
    (dir, store, ids)
}

fn related(store: &Store, id: u64) -> Vec<u64> {
    let v = store
        .query(
            &format!(
                "MATCH (a)-[:RELATED]-(b) WHERE id(a) = {id} RETURN DISTINCT id(b) AS b ORDER BY b"
            ),
            &graphstore::cypher::QueryOptions::default(),
        )
        .unwrap()
        .rows_json();
    v.as_array()
        .unwrap()
        .iter()
        .map(|r| r["b"].as_u64().unwrap())
        .collect()
}

#[test]
fn remove_then_undo_is_exact() {
    let (_d, store, ids) = small_map();
    let before = snapshot(&store);
    let a = apply(
        &store,
        &Change::Remove { id: ids[0] },
        "the bench is gone",
        "rules",
    )
    .unwrap();
    assert_eq!(a.deleted_nodes, [ids[0]]);
    assert_eq!(a.deleted_relationships, 2); // IN_SEGMENT and RELATED
    let r = store.read().unwrap();
    assert!(r.node(ids[0]).unwrap().is_none());
    assert!(r.payload(ids[0], "points").unwrap().is_none());
    drop(r);
    assert!(related(&store, ids[1]).is_empty());
    // the vector and spatial indexes no longer return it
    let near = store
        .query(
            "CALL db.index.spatial.withinDistance('instance_space', point({x: 4.0, y: 0.5, z: 20.0}), 1.0) YIELD node RETURN id(node) AS id",
            &graphstore::cypher::QueryOptions::default(),
        )
        .unwrap()
        .rows_json();
    assert!(
        near.as_array()
            .unwrap()
            .iter()
            .all(|r| r["id"].as_u64() != Some(ids[0])),
        "{near:?}"
    );
    assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
    let u = undo(&store, a.edit_id).unwrap();
    assert!(u.undone);
    assert_eq!(snapshot(&store), before);
    // twice is refused
    assert!(
        undo(&store, a.edit_id)
            .unwrap_err()
            .to_string()
            .contains("undone already")
    );
    let edits = list(&store.read().unwrap()).unwrap();
    assert_eq!(edits.len(), 1);
    assert_eq!(edits[0].text, "the bench is gone");
}

#[test]
fn move_relinks_and_undo_is_exact() {
    let (_d, store, ids) = small_map();
    let before = snapshot(&store);
    // the bench goes next to the sign at z = 60
    let a = apply(
        &store,
        &Change::Move {
            id: ids[0],
            to_ground: [4.0, 61.3],
        },
        "the bench was moved next to the street sign",
        "rules",
    )
    .unwrap();
    assert_eq!(a.changed_nodes, [ids[0]]);
    let r = store.read().unwrap();
    let c = r
        .node_prop(ids[0], "centroid")
        .unwrap()
        .unwrap()
        .as_point3()
        .unwrap();
    assert!(
        (c[0] - 4.0).abs() < 1e-9 && (c[2] - 61.3).abs() < 1e-9,
        "{c:?}"
    );
    let pc = r.point_cloud(ids[0], "points").unwrap().unwrap();
    assert!(
        (f64::from(pc.xyz[0][2]) - 61.3).abs() < 1e-3,
        "{:?}",
        pc.xyz
    );
    drop(r);
    // related to the sign now, not to the bin
    assert_eq!(related(&store, ids[0]), [ids[2]]);
    assert!(related(&store, ids[1]).is_empty());
    assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
    undo(&store, a.edit_id).unwrap();
    assert_eq!(snapshot(&store), before);
}

#[test]
fn change_and_add_then_undo_in_order() {
    let (_d, store, ids) = small_map();
    let before = snapshot(&store);
    let c = apply(
        &store,
        &Change::Recaption {
            id: ids[0],
            caption: "a red bench".into(),
            feature: feat(9),
            class: None,
        },
        "the bench is now red",
        "rules",
    )
    .unwrap();
    let add = apply(
        &store,
        &Change::Add {
            caption: "a metal bin".into(),
            class: "pole".into(),
            feature: feat(10),
            centre_ground: [4.0, 18.8],
            base_height_m: -1.0,
            size_m: [0.6, 0.6, 1.0],
        },
        "there is a new bin next to the bench",
        "rules",
    )
    .unwrap();
    let new = add.created_nodes[0];
    let r = store.read().unwrap();
    assert_eq!(
        r.node_prop(ids[0], "caption").unwrap(),
        Some(Value::from("a red bench"))
    );
    assert_eq!(
        r.node_prop(new, "instance_id").unwrap(),
        Some(Value::Int(4))
    );
    drop(r);
    assert!(
        related(&store, new).contains(&ids[0]),
        "{:?}",
        related(&store, new)
    );
    // the change came first and the addition touched the bench too: undo the addition first
    let e = undo(&store, c.edit_id).unwrap_err().to_string();
    assert!(e.contains(&format!("undo {} first", add.edit_id)), "{e}");
    undo(&store, add.edit_id).unwrap();
    undo(&store, c.edit_id).unwrap();
    assert_eq!(snapshot(&store), before);
}

#[test]
fn bad_edits_change_nothing() {
    let (_d, store, ids) = small_map();
    let before = snapshot(&store);
    // a segment is not an instance; a node that does not exist
    let seg = store.read().unwrap().nodes_with_label("Segment").unwrap()[0];
    assert!(
        apply(&store, &Change::Remove { id: seg }, "x", "rules")
            .unwrap_err()
            .to_string()
            .contains("not an Instance")
    );
    assert!(apply(&store, &Change::Remove { id: 999_999 }, "x", "rules").is_err());
    assert!(
        undo(&store, ids[0])
            .unwrap_err()
            .to_string()
            .contains("not a MapEdit")
    );
    assert!(undo(&store, 999_999).is_err());
    assert_eq!(snapshot(&store), before);
    assert!(list(&store.read().unwrap()).unwrap().is_empty());
}
