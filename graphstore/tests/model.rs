//! Random sequences of store operations, grouped into committed or aborted transactions,
//! checked against a plain in-memory reference model: node and relationship contents,
//! constraint errors, counts, and what every index returns. The store is reopened at the end
//! and checked again (indexes rebuilt from the file).

use std::collections::{BTreeMap, BTreeSet};

use graphstore::{
    Direction, Error, GraphRead, LabelRule, PropertyIndexSpec, PropertyRule, Schema,
    SpatialIndexSpec, Store, TextIndexSpec, Value, ValueBound, ValueType, VectorIndexSpec,
    tokenize,
};
use proptest::prelude::*;

const LABELS: [&str; 2] = ["A", "B"];
const KEYS: [&str; 6] = ["k", "u", "pos", "vec", "txt", "other"];
const WORDS: [&str; 6] = ["red", "bench", "car", "tree", "stone", "lamp"];

fn schema() -> Schema {
    let mut s = Schema::default();
    s.labels.insert(
        "A".into(),
        LabelRule {
            properties: vec![PropertyRule {
                key: "k".into(),
                ty: ValueType::Int,
                required: true,
            }],
            unique: vec!["u".into()],
            description: String::new(),
        },
    );
    s.property_indexes.push(PropertyIndexSpec {
        name: None,
        label: "A".into(),
        key: "k".into(),
    });
    s.spatial_indexes.push(SpatialIndexSpec {
        name: "space".into(),
        label: "A".into(),
        position_key: "pos".into(),
        box_key: None,
    });
    s.vector_indexes.push(VectorIndexSpec {
        name: "vec".into(),
        label: "A".into(),
        key: "vec".into(),
        dim: 4,
        int8: false,
        method: Default::default(),
    });
    s.text_indexes.push(TextIndexSpec {
        name: "txt".into(),
        label: "A".into(),
        key: "txt".into(),
    });
    s
}

#[derive(Debug, Clone)]
enum Op {
    CreateNode {
        labels: Vec<usize>,
        props: Vec<(usize, Value)>,
    },
    SetProp {
        node: usize,
        key: usize,
        value: Value,
    },
    AddLabel {
        node: usize,
        label: usize,
    },
    RemoveLabel {
        node: usize,
        label: usize,
    },
    CreateRel {
        a: usize,
        b: usize,
        ty: usize,
    },
    DeleteRel {
        rel: usize,
    },
    DeleteNode {
        node: usize,
        detach: bool,
    },
}

fn value_for(key: usize) -> BoxedStrategy<Value> {
    match key {
        0 => prop_oneof![
            (-5i64..5).prop_map(Value::Int),
            Just(Value::Float(1.5)),
            Just(Value::Null)
        ]
        .boxed(),
        1 => prop_oneof![
            prop::sample::select(vec!["x", "y", "z"]).prop_map(Value::from),
            Just(Value::Int(3))
        ]
        .boxed(),
        2 => prop_oneof![
            prop::array::uniform3(-3i8..3).prop_map(|p| Value::Point3D([
                p[0] as f64,
                p[1] as f64,
                p[2] as f64
            ])),
            Just(Value::from("nowhere")),
        ]
        .boxed(),
        3 => prop_oneof![
            prop::array::uniform4(-2i8..3)
                .prop_map(|v| Value::Vector(v.iter().map(|x| *x as f32).collect())),
            Just(Value::Vector(vec![1.0, 2.0])),
        ]
        .boxed(),
        4 => prop::collection::vec(prop::sample::select(WORDS.to_vec()), 1..4)
            .prop_map(|w| Value::from(w.join(" ")))
            .boxed(),
        _ => prop_oneof![any::<bool>().prop_map(Value::Bool), Just(Value::Null)].boxed(),
    }
}

fn op() -> impl Strategy<Value = Op> {
    let any_prop = (0usize..6).prop_flat_map(|k| value_for(k).prop_map(move |v| (k, v)));
    prop_oneof![
        3 => (prop::collection::vec(0usize..2, 0..3), prop::collection::vec(any_prop.clone(), 0..6))
            .prop_map(|(labels, props)| Op::CreateNode { labels, props }),
        3 => (0usize..16, any_prop).prop_map(|(node, (key, value))| Op::SetProp { node, key, value }),
        1 => (0usize..16, 0usize..2).prop_map(|(node, label)| Op::AddLabel { node, label }),
        1 => (0usize..16, 0usize..2).prop_map(|(node, label)| Op::RemoveLabel { node, label }),
        2 => (0usize..16, 0usize..16, 0usize..2).prop_map(|(a, b, ty)| Op::CreateRel { a, b, ty }),
        1 => (0usize..16).prop_map(|rel| Op::DeleteRel { rel }),
        1 => (0usize..16, any::<bool>()).prop_map(|(node, detach)| Op::DeleteNode { node, detach }),
    ]
}

#[derive(Debug, Clone, Default, PartialEq)]
struct MNode {
    labels: BTreeSet<String>,
    props: BTreeMap<String, Value>,
}

#[derive(Debug, Clone, Default)]
struct Model {
    nodes: BTreeMap<u64, MNode>,
    rels: BTreeMap<u64, (String, u64, u64)>,
    next_node: u64,
    next_rel: u64,
}

fn pick<T: Copy>(keys: impl Iterator<Item = T>, i: usize) -> Option<T> {
    let v: Vec<T> = keys.collect();
    (!v.is_empty()).then(|| v[i % v.len()])
}

impl Model {
    /// The relationships touching `id`, with their types and ends.
    fn incident(&self, id: u64) -> Vec<(u64, &(String, u64, u64))> {
        self.rels
            .iter()
            .filter(|(_, (_, a, b))| *a == id || *b == id)
            .map(|(r, v)| (*r, v))
            .collect()
    }

    /// Would a node with this content be accepted?
    fn valid(&self, id: Option<u64>, n: &MNode) -> bool {
        if !n.labels.contains("A") {
            return true;
        }
        if !matches!(n.props.get("k"), Some(Value::Int(_))) {
            return false;
        }
        if let Some(u) = n.props.get("u") {
            if !matches!(u, Value::String(_) | Value::Int(_)) {
                return false;
            }
            let clash = self.nodes.iter().any(|(oid, o)| {
                Some(*oid) != id && o.labels.contains("A") && o.props.get("u") == Some(u)
            });
            if clash {
                return false;
            }
        }
        if let Some(p) = n.props.get("pos")
            && !matches!(p, Value::Point3D(_))
        {
            return false;
        }
        if let Some(v) = n.props.get("vec") {
            match v {
                Value::Vector(x) if x.len() == 4 && x.iter().any(|c| *c != 0.0) => {}
                _ => return false,
            }
        }
        true
    }

    fn degree(&self, id: u64) -> usize {
        self.rels
            .values()
            .filter(|(_, s, e)| *s == id || *e == id)
            .count()
    }
}

/// Applies `op` to both; asserts both agree on success.
fn apply(tx: &mut graphstore::WriteTxn<'_>, m: &mut Model, op: &Op) {
    match op {
        Op::CreateNode { labels, props } => {
            let mut n = MNode::default();
            for l in labels {
                n.labels.insert(LABELS[*l].to_string());
            }
            for (k, v) in props {
                if v.is_null() {
                    n.props.remove(KEYS[*k]);
                } else {
                    n.props.insert(KEYS[*k].to_string(), v.clone());
                }
            }
            let expect = m.valid(None, &n);
            let ls: Vec<&str> = labels.iter().map(|l| LABELS[*l]).collect();
            let ps: Vec<(&str, Value)> = props.iter().map(|(k, v)| (KEYS[*k], v.clone())).collect();
            let got = tx.create_node_named(&ls, &ps);
            assert_eq!(got.is_ok(), expect, "create {n:?}: {got:?}");
            if let Ok(id) = got {
                assert_eq!(id, m.next_node);
                m.nodes.insert(id, n);
                m.next_node += 1;
            } else {
                assert!(matches!(got, Err(Error::Constraint { .. })), "{got:?}");
            }
        }
        Op::SetProp { node, key, value } => {
            let Some(id) = pick(m.nodes.keys().copied(), *node) else {
                return;
            };
            let mut n = m.nodes[&id].clone();
            if value.is_null() {
                n.props.remove(KEYS[*key]);
            } else {
                n.props.insert(KEYS[*key].to_string(), value.clone());
            }
            let expect = m.valid(Some(id), &n);
            let k = tx.prop_key_id(KEYS[*key]).unwrap();
            let got = tx.set_node_prop(id, k, value.clone());
            assert_eq!(
                got.is_ok(),
                expect,
                "set {id} {} = {value:?}: {got:?}",
                KEYS[*key]
            );
            if got.is_ok() {
                m.nodes.insert(id, n);
            }
        }
        Op::AddLabel { node, label } | Op::RemoveLabel { node, label } => {
            let Some(id) = pick(m.nodes.keys().copied(), *node) else {
                return;
            };
            let add = matches!(op, Op::AddLabel { .. });
            let mut n = m.nodes[&id].clone();
            if add {
                n.labels.insert(LABELS[*label].into());
            } else {
                n.labels.remove(LABELS[*label]);
            }
            let expect = m.valid(Some(id), &n);
            let l = tx.label_id(LABELS[*label]).unwrap();
            let got = if add {
                tx.add_label(id, l)
            } else {
                tx.remove_label(id, l)
            };
            assert_eq!(got.is_ok(), expect, "{op:?}: {got:?}");
            if got.is_ok() {
                m.nodes.insert(id, n);
            }
        }
        Op::CreateRel { a, b, ty } => {
            let (Some(s), Some(e)) = (
                pick(m.nodes.keys().copied(), *a),
                pick(m.nodes.keys().copied(), *b),
            ) else {
                return;
            };
            let t = ["T1", "T2"][*ty];
            let id = tx
                .create_rel_named(s, t, e, &[("w", Value::Int(*a as i64))])
                .unwrap();
            assert_eq!(id, m.next_rel);
            m.rels.insert(id, (t.into(), s, e));
            m.next_rel += 1;
        }
        Op::DeleteRel { rel } => {
            let Some(id) = pick(m.rels.keys().copied(), *rel) else {
                return;
            };
            tx.delete_rel(id).unwrap();
            m.rels.remove(&id);
        }
        Op::DeleteNode { node, detach } => {
            let Some(id) = pick(m.nodes.keys().copied(), *node) else {
                return;
            };
            if *detach {
                tx.detach_delete_node(id).unwrap();
                m.rels.retain(|_, (_, s, e)| *s != id && *e != id);
                m.nodes.remove(&id);
            } else {
                let got = tx.delete_node(id);
                let expect = m.degree(id) == 0;
                assert_eq!(got.is_ok(), expect, "{got:?}");
                if got.is_ok() {
                    m.nodes.remove(&id);
                } else {
                    assert!(matches!(got, Err(Error::NodeHasRelationships { .. })));
                }
            }
        }
    }
}

fn cos(a: &[f32], b: &[f32]) -> f64 {
    let d: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| f64::from(*x) * f64::from(*y))
        .sum();
    let na: f64 = a.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>().sqrt();
    let nb: f64 = b.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>().sqrt();
    d / (na * nb)
}

fn bm25(m: &Model, query: &str) -> Vec<(u64, f64)> {
    let docs: Vec<(u64, Vec<String>)> = m
        .nodes
        .iter()
        .filter(|(_, n)| n.labels.contains("A"))
        .filter_map(|(id, n)| {
            n.props
                .get("txt")
                .and_then(Value::as_str)
                .map(|t| (*id, tokenize(t)))
        })
        .collect();
    let n = docs.len() as f64;
    if n == 0.0 {
        return vec![];
    }
    let avg = docs.iter().map(|d| d.1.len()).sum::<usize>() as f64 / n;
    let mut terms = tokenize(query);
    terms.sort();
    terms.dedup();
    let mut scores: BTreeMap<u64, f64> = BTreeMap::new();
    for t in &terms {
        let df = docs.iter().filter(|d| d.1.contains(t)).count() as f64;
        let idf = (1.0 + (n - df + 0.5) / (df + 0.5)).ln();
        for (id, d) in &docs {
            let tf = d.iter().filter(|x| *x == t).count() as f64;
            if tf > 0.0 {
                *scores.entry(*id).or_default() +=
                    idf * tf * 2.2 / (tf + 1.2 * (0.25 + 0.75 * d.len() as f64 / avg.max(1e-9)));
            }
        }
    }
    let mut v: Vec<(u64, f64)> = scores.into_iter().collect();
    v.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    v
}

/// Everything observable must match the model.
fn check(r: &impl GraphRead, m: &Model, store: &Store) {
    assert_eq!(
        r.all_node_ids().unwrap(),
        m.nodes.keys().copied().collect::<Vec<_>>()
    );
    assert_eq!(
        r.all_rel_ids().unwrap(),
        m.rels.keys().copied().collect::<Vec<_>>()
    );
    for (id, n) in &m.nodes {
        let node = r.node(*id).unwrap().unwrap();
        let labels: BTreeSet<String> = node
            .labels
            .iter()
            .map(|l| r.name_of(l.0).unwrap())
            .collect();
        assert_eq!(labels, n.labels);
        let props: BTreeMap<String, Value> = node
            .props
            .iter()
            .map(|(k, v)| (r.name_of(k.0).unwrap(), v.clone()))
            .collect();
        assert_eq!(&props, &n.props);
        let out: BTreeSet<u64> = r
            .neighbours(*id, Direction::Outgoing, None)
            .unwrap()
            .iter()
            .map(|a| a.rel)
            .collect();
        let want: BTreeSet<u64> = m
            .rels
            .iter()
            .filter(|(_, (_, s, _))| s == id)
            .map(|(k, _)| *k)
            .collect();
        assert_eq!(out, want);
    }
    for (id, (t, s, e)) in &m.rels {
        let rel = r.rel(*id).unwrap().unwrap();
        assert_eq!(
            (r.name_of(rel.ty.0).unwrap(), rel.start, rel.end),
            (t.clone(), *s, *e)
        );
    }
    for l in LABELS {
        let want: Vec<u64> = m
            .nodes
            .iter()
            .filter(|(_, n)| n.labels.contains(l))
            .map(|(id, _)| *id)
            .collect();
        assert_eq!(r.nodes_with_label(l).unwrap(), want, "label {l}");
    }
    let a_nodes: Vec<(&u64, &MNode)> = m
        .nodes
        .iter()
        .filter(|(_, n)| n.labels.contains("A"))
        .collect();
    for k in -5..5i64 {
        let want: Vec<u64> = a_nodes
            .iter()
            .filter(|(_, n)| n.props.get("k") == Some(&Value::Int(k)))
            .map(|(i, _)| **i)
            .collect();
        assert_eq!(
            r.find_nodes("A", "k", &Value::Int(k)).unwrap(),
            want,
            "k = {k}"
        );
    }
    let mut want: Vec<(i64, u64)> = a_nodes
        .iter()
        .filter_map(|(i, n)| n.props.get("k").and_then(Value::as_int).map(|k| (k, **i)))
        .filter(|(k, _)| (-2..=3).contains(k))
        .collect();
    want.sort();
    let got = r
        .find_range(
            "A",
            "k",
            ValueBound::Inclusive(Value::Int(-2)),
            ValueBound::Exclusive(Value::Float(3.5)),
        )
        .unwrap();
    assert_eq!(got, want.iter().map(|x| x.1).collect::<Vec<_>>());
    // spatial
    let center = [0.5, -0.5, 0.0];
    let mut want: Vec<(u64, f64)> = a_nodes
        .iter()
        .filter_map(|(i, n)| match n.props.get("pos") {
            Some(Value::Point3D(p)) => {
                let d = ((p[0] - center[0]).powi(2)
                    + (p[1] - center[1]).powi(2)
                    + (p[2] - center[2]).powi(2))
                .sqrt();
                (d <= 2.5).then_some((**i, d))
            }
            _ => None,
        })
        .collect();
    want.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    let got = r.spatial_within("space", center, 2.5).unwrap();
    assert_eq!(
        got.iter().map(|h| h.node).collect::<Vec<_>>(),
        want.iter().map(|w| w.0).collect::<Vec<_>>()
    );
    let near = r.spatial_nearest("space", center, 3).unwrap();
    assert!(near.len() <= 3);
    // vector: every hit's score matches the model, and the score list is the model's best
    let q = [1.0f32, -0.5, 0.25, 2.0];
    let mut model_scores: Vec<(u64, f64)> = a_nodes
        .iter()
        .filter_map(|(i, n)| {
            n.props
                .get("vec")
                .and_then(Value::as_vector)
                .map(|v| (**i, cos(&q, v)))
        })
        .collect();
    model_scores.sort_by(|a, b| b.1.total_cmp(&a.1));
    let got = r.vector_top_k("vec", &q, 5).unwrap();
    assert_eq!(got.len(), model_scores.len().min(5));
    for (g, w) in got.iter().zip(&model_scores) {
        assert!((g.score - w.1).abs() < 1e-5, "{g:?} vs {w:?}");
        let own = model_scores.iter().find(|x| x.0 == g.node).unwrap().1;
        assert!((g.score - own).abs() < 1e-5);
    }
    // text
    let want = bm25(m, "red bench lamp");
    let got = r.text_search("txt", "red bench lamp", 100).unwrap();
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert!((g.score - w.1).abs() < 1e-9, "{g:?} vs {w:?}");
    }
    // counts
    let c = r.counts().unwrap();
    assert_eq!(c.total_nodes, m.nodes.len() as u64);
    assert_eq!(c.total_relationships, m.rels.len() as u64);
    for t in ["T1", "T2"] {
        let n = m.rels.values().filter(|r| r.0 == t).count() as u64;
        assert_eq!(c.relationships.get(t).copied().unwrap_or(0), n);
    }
    assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]
    #[test]
    fn store_matches_reference_model(txns in prop::collection::vec((prop::collection::vec(op(), 1..12), prop::bool::weighted(0.8)), 1..8)) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.og");
        let store = Store::create(&path).unwrap();
        store.set_schema(schema()).unwrap();
        let mut model = Model::default();
        for (ops, commit) in &txns {
            let mut next = model.clone();
            let seq_before = store.commit_seq();
            let res = store.write(|tx| {
                for op in ops {
                    apply(tx, &mut next, op);
                }
                // the transaction sees its own writes, indexes included
                check(tx, &next, &store_placeholder());
                if *commit { Ok(()) } else { Err(Error::RolledBack) }
            });
            if *commit {
                res.unwrap();
                // the change log lists every node whose record or relationships differ
                let listed = store.read().unwrap().nodes_changed_since(seq_before).unwrap();
                for id in model.nodes.keys().chain(next.nodes.keys()) {
                    if model.nodes.get(id) != next.nodes.get(id)
                        || model.incident(*id) != next.incident(*id)
                    {
                        prop_assert!(listed.contains(id), "node {id} changed but is not listed in {listed:?}");
                    }
                }
                model = next;
            } else {
                prop_assert!(matches!(res, Err(Error::RolledBack)));
                prop_assert_eq!(store.read().unwrap().nodes_changed_since(seq_before), Some(Vec::new()));
            }
            check(&store.read().unwrap(), &model, &store);
        }
        drop(store);
        let reopened = Store::open(&path).unwrap();
        check(&reopened.read().unwrap(), &model, &reopened);
        drop(reopened);
        // opening builds no in-memory index; a write straight after opening merges into
        // indexes built from the file, and so does a write after a read built them
        for read_first in [false, true] {
            let reopened = Store::open(&path).unwrap();
            if read_first {
                check(&reopened.read().unwrap(), &model, &reopened);
            }
            let (ops, _) = &txns[0];
            let mut next = model.clone();
            reopened
                .write(|tx| {
                    for op in ops {
                        apply(tx, &mut next, op);
                    }
                    Ok(())
                })
                .unwrap();
            check(&reopened.read().unwrap(), &next, &reopened);
            model = next;
            drop(reopened);
        }
    }
}

thread_local! {
    static EMPTY: Store = {
        let dir = tempfile::tempdir().unwrap();
        let s = Store::create(dir.path().join("e.og")).unwrap();
        std::mem::forget(dir);
        s
    };
}

/// Inside a write transaction the committed store is not the one to check for consistency;
/// an empty store stands in (its check passes trivially).
fn store_placeholder() -> Store {
    EMPTY.with(|s| s.clone())
}

/// A store opened with a page cache far smaller than what it writes keeps and reads back
/// every record (the cache only bounds memory), across a reopen with the default cache.
#[test]
fn a_small_page_cache_bounds_memory_not_data() {
    use graphstore::{GraphRead, Store, StoreOptions, Value};
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("c.og");
    let s = Store::create_with(&p, &StoreOptions::default().with_cache_bytes(64 << 10)).unwrap();
    let text = "x".repeat(2_000);
    for batch in 0..4 {
        s.write(|tx| {
            for i in 0..500 {
                tx.create_node_named(
                    &["Thing"],
                    &[
                        ("n", Value::Int(batch * 500 + i)),
                        ("t", Value::from(text.as_str())),
                    ],
                )?;
            }
            Ok(())
        })
        .unwrap();
    }
    assert_eq!(
        s.read().unwrap().nodes_with_label("Thing").unwrap().len(),
        2_000
    );
    drop(s);
    let s = Store::open(&p).unwrap();
    assert_eq!(
        s.read().unwrap().nodes_with_label("Thing").unwrap().len(),
        2_000
    );
    assert!(s.check_consistency().unwrap().is_empty());
}
