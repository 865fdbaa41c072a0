//! Import of networkx's node-link JSON (`networkx.node_link_data`; the format
//! [`crate::export::export_node_link`] writes).
//!
//! `{"nodes": [{"id": .., ...}], "edges": [{"source": .., "target": .., ...}]}`, with the edge
//! list under `edges` (networkx ≥ 3.6) or `links` (older). Node attributes: `labels` (a list
//! of strings) becomes the node's labels, every other attribute a property. Edge attributes:
//! `type` (a string) becomes the relationship type, else `default_type`; `key` (networkx's
//! multigraph key, the relationship id in our export) is dropped, `source` and `target` name
//! the ends; every other attribute is a property. A property the export had to rename
//! (`_id`, `_labels`, `_type`, ...) gets its name back. Values: JSON numbers, strings,
//! booleans, lists and maps; `{x, y[, z]}` maps are points; a list of numbers is a vector
//! where the schema declares one, and an integer a float where it declares a float; `null`
//! is no property. When every node id is a non-negative integer (JSON number), nodes keep it
//! as their node id, so a map exported and imported again answers with the same ids;
//! otherwise nodes get new ids and each keeps its file id as the property `id` (unless it has
//! an `_id` attribute, the export's name for a property `id`).
//! The file is read whole (at most [`MAX_BYTES`]); errors name the file and, for bad JSON,
//! the line and column, else the node or edge by its index in the file.

use std::collections::HashMap;
use std::path::Path;

use crate::error::{Error, Result};
use crate::model::NewRel;
use crate::store::Store;
use crate::tokens::{LabelId, PropKey, RelType};
use crate::value::{Value, ValueType};

/// Largest node-link file read (the parsed document takes a few times its size in memory).
pub const MAX_BYTES: u64 = 2 << 30;

/// What a node-link import did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct NodeLinkImport {
    /// Nodes created.
    pub nodes: u64,
    /// Relationships created.
    pub relationships: u64,
    /// True when every node kept its integer id.
    pub ids_kept: bool,
    /// Transactions committed.
    pub batches: u64,
}

const NODE_RESERVED: &[&str] = &["id", "labels"];
const EDGE_RESERVED: &[&str] = &["source", "target", "key", "type"];

/// The property name an attribute stands for: the export prefixes `_` to a property named
/// like a reserved attribute.
fn property_name(attr: &str, reserved: &[&str]) -> String {
    match attr.strip_prefix('_') {
        Some(r) if reserved.contains(&r.trim_start_matches('_')) => r.to_string(),
        _ => attr.to_string(),
    }
}

/// A JSON attribute as the value the schema wants (see the module docs).
fn value(j: &serde_json::Value, want: Option<ValueType>) -> Value {
    let v = Value::from_json(j);
    match (want, &v) {
        (Some(ValueType::Vector), Value::List(items)) => {
            let xs: Option<Vec<f32>> = items
                .iter()
                .map(|x| match x {
                    Value::Int(i) => Some(*i as f32),
                    Value::Float(f) => Some(*f as f32),
                    _ => None,
                })
                .collect();
            xs.map_or(v, Value::Vector)
        }
        (Some(ValueType::Float), Value::Int(i)) => Value::Float(*i as f64),
        _ => v,
    }
}

/// Imports the node-link file at `path` into `store`, committing every `batch_rows` nodes
/// or edges; `progress(items done, items in all)` after each commit.
///
/// # Errors
/// [`Error::Import`] naming the file (and line and column for bad JSON, or `nodes[i]` /
/// `edges[i]`) for a file that is not node-link JSON, a node without an id, a duplicate id,
/// an edge whose end is no node's id, or a node or edge the schema refuses;
/// [`Error::Io`] for an unreadable file. Batches committed before the error stay (the
/// service's import writes into a new file it removes on error).
pub fn import_node_link(
    store: &Store,
    path: &Path,
    default_type: &str,
    batch_rows: usize,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<NodeLinkImport> {
    let err = |detail: String| Error::Import {
        path: path.to_path_buf(),
        line: 0,
        detail,
    };
    let io = |error| Error::Io {
        path: path.to_path_buf(),
        error,
    };
    let size = std::fs::metadata(path).map_err(io)?.len();
    if size > MAX_BYTES {
        return Err(err(format!(
            "{size} bytes: larger than the {MAX_BYTES} bytes a node-link file may have (use the Neo4j CSV import, which streams)"
        )));
    }
    let text = std::fs::read(path).map_err(io)?;
    let doc: serde_json::Value = serde_json::from_slice(&text).map_err(|e| Error::Import {
        path: path.to_path_buf(),
        line: e.line() as u64,
        detail: format!("not JSON: {e}"),
    })?;
    drop(text);
    let no_list = |k: &str| err(format!("no \"{k}\" list: not node-link JSON"));
    let nodes = doc
        .get("nodes")
        .and_then(|n| n.as_array())
        .ok_or_else(|| no_list("nodes"))?;
    let empty = Vec::new();
    let edges = match (doc.get("edges"), doc.get("links")) {
        (Some(_), Some(_)) => {
            return Err(err(
                "both \"edges\" and \"links\": give the edge list under one of them".into(),
            ));
        }
        (Some(e), _) | (None, Some(e)) => e.as_array().ok_or_else(|| no_list("edges"))?,
        (None, None) => &empty,
    };
    let batch_rows = batch_rows.max(1);
    let total = (nodes.len() + edges.len()) as u64;
    let schema = store.schema();
    let declared = |label: &str, key: &str| -> Option<ValueType> {
        schema
            .labels
            .get(label)
            .and_then(|r| r.properties.iter().find(|p| p.key == key))
            .map(|p| p.ty)
    };
    let declared_rel = |ty: &str, key: &str| -> Option<ValueType> {
        schema
            .relationships
            .get(ty)
            .and_then(|r| r.properties.iter().find(|p| p.key == key))
            .map(|p| p.ty)
    };
    // the ids: kept when all are non-negative integers and the store is empty
    let mut kept = store.counts()?.total_nodes == 0;
    let mut seen: HashMap<String, usize> = HashMap::with_capacity(nodes.len());
    for (i, n) in nodes.iter().enumerate() {
        let id = n
            .get("id")
            .filter(|v| !v.is_null())
            .ok_or_else(|| err(format!("nodes[{i}] has no \"id\"")))?;
        kept &= id.as_u64().is_some();
        if seen.insert(id.to_string(), i).is_some() {
            return Err(err(format!("nodes[{i}]: the id {id} appears twice")));
        }
    }
    drop(seen);
    let mut out = NodeLinkImport {
        ids_kept: kept,
        ..NodeLinkImport::default()
    };
    if kept {
        let next = nodes
            .iter()
            .filter_map(|n| n.get("id").and_then(|v| v.as_u64()))
            .max()
            .map_or(0, |m| m + 1);
        store.write(|tx| {
            tx.reserve_node_ids(next);
            Ok(())
        })?;
    }
    let mut node_id: HashMap<String, u64> = HashMap::with_capacity(nodes.len());
    for (b, chunk) in nodes.chunks(batch_rows).enumerate() {
        store.write(|tx| {
            for (j, n) in chunk.iter().enumerate() {
                let i = b * batch_rows + j;
                let at = |e: Error| err(format!("nodes[{i}]: {e}"));
                let obj = n
                    .as_object()
                    .ok_or_else(|| err(format!("nodes[{i}] is not an object")))?;
                let names: Vec<&str> = match obj.get("labels") {
                    None | Some(serde_json::Value::Null) => Vec::new(),
                    Some(serde_json::Value::Array(ls)) => ls
                        .iter()
                        .map(|l| {
                            l.as_str().ok_or_else(|| {
                                err(format!("nodes[{i}]: \"labels\" must be a list of strings"))
                            })
                        })
                        .collect::<Result<_>>()?,
                    Some(_) => {
                        return Err(err(format!(
                            "nodes[{i}]: \"labels\" must be a list of strings"
                        )));
                    }
                };
                let labels: Vec<LabelId> = names
                    .iter()
                    .map(|l| tx.label_id(l).map_err(at))
                    .collect::<Result<_>>()?;
                let mut props: Vec<(PropKey, Value)> = Vec::new();
                for (k, v) in obj {
                    if NODE_RESERVED.contains(&k.as_str()) || v.is_null() {
                        continue;
                    }
                    let key = property_name(k, NODE_RESERVED);
                    let want = names.iter().find_map(|l| declared(l, &key));
                    props.push((tx.prop_key_id(&key)?, value(v, want)));
                }
                let id_json = &obj["id"];
                // an id that cannot be the node id is kept as the `id` property (unless the
                // node has its own, exported as `_id`)
                if !kept && !obj.contains_key("_id") {
                    props.push((tx.prop_key_id("id")?, Value::from_json(id_json)));
                }
                let id = match id_json.as_u64().filter(|_| kept) {
                    Some(id) => {
                        tx.restore_node(id, &labels, props).map_err(at)?;
                        id
                    }
                    None => tx.create_node(&labels, props).map_err(at)?,
                };
                node_id.insert(id_json.to_string(), id);
            }
            Ok(())
        })?;
        out.nodes += chunk.len() as u64;
        out.batches += 1;
        progress(out.nodes, total);
    }
    let mut types: HashMap<String, RelType> = HashMap::new();
    // the ends' labels, read once for the whole load
    let mut end_labels = crate::txn::EndLabels::default();
    for (b, chunk) in edges.chunks(batch_rows).enumerate() {
        store.write(|tx| {
            let mut rows: Vec<NewRel> = Vec::with_capacity(chunk.len());
            for (j, e) in chunk.iter().enumerate() {
                let i = b * batch_rows + j;
                let obj = e
                    .as_object()
                    .ok_or_else(|| err(format!("edges[{i}] is not an object")))?;
                let end = |k: &str| -> Result<u64> {
                    let v = obj
                        .get(k)
                        .ok_or_else(|| err(format!("edges[{i}] has no \"{k}\"")))?;
                    node_id
                        .get(&v.to_string())
                        .copied()
                        .ok_or_else(|| err(format!("edges[{i}]: {k} {v} is no node's id")))
                };
                let (s, t) = (end("source")?, end("target")?);
                let tname = match obj.get("type") {
                    Some(serde_json::Value::String(t)) if !t.is_empty() => t.as_str(),
                    None | Some(serde_json::Value::Null) => default_type,
                    Some(_) => {
                        return Err(err(format!(
                            "edges[{i}]: \"type\" must be a non-empty string"
                        )));
                    }
                };
                let ty = match types.get(tname) {
                    Some(t) => *t,
                    None => {
                        let t = tx.rel_type_id(tname)?;
                        types.insert(tname.to_string(), t);
                        t
                    }
                };
                let mut props = Vec::new();
                for (k, v) in obj {
                    if EDGE_RESERVED.contains(&k.as_str()) || v.is_null() {
                        continue;
                    }
                    let key = property_name(k, EDGE_RESERVED);
                    let want = declared_rel(tname, &key);
                    props.push((tx.prop_key_id(&key)?, value(v, want)));
                }
                rows.push((s, ty, t, props));
            }
            tx.create_rels_into(rows, None, &mut end_labels)
                .map_err(|(j, e)| err(format!("edges[{}]: {e}", b * batch_rows + j)))?;
            Ok(())
        })?;
        out.relationships += chunk.len() as u64;
        out.batches += 1;
        progress(out.nodes + out.relationships, total);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reserved_names_come_back_and_values_follow_the_schema() {
        assert_eq!(property_name("_id", NODE_RESERVED), "id");
        assert_eq!(property_name("_type", NODE_RESERVED), "_type");
        assert_eq!(property_name("_type", EDGE_RESERVED), "type");
        assert_eq!(property_name("__id", NODE_RESERVED), "_id");
        for name in ["id", "_id", "__id", "idx", "_x"] {
            let attr = crate::export::attr_name(name.to_string(), NODE_RESERVED);
            assert_eq!(property_name(&attr, NODE_RESERVED), name);
        }
        let j = serde_json::json!([1, 2.5]);
        assert_eq!(
            value(&j, Some(ValueType::Vector)),
            Value::Vector(vec![1.0, 2.5])
        );
        assert!(matches!(value(&j, None), Value::List(_)));
        assert_eq!(
            value(&serde_json::json!(3), Some(ValueType::Float)),
            Value::Float(3.0)
        );
        assert_eq!(
            value(&serde_json::json!({"x": 1, "y": 2, "z": 3}), None),
            Value::Point3D([1.0, 2.0, 3.0])
        );
    }
}
