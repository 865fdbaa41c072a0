//! Nodes, relationships and the records behind them.

use crate::tokens::{LabelId, PropKey, RelType};
use crate::value::Value;

/// A node: labels and properties, both by interned id.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Stable id.
    pub id: u64,
    /// Labels, sorted by id.
    pub labels: Vec<LabelId>,
    /// Properties, sorted by key id.
    pub props: Vec<(PropKey, Value)>,
}

/// A relationship: one type, a start and an end node, and properties.
#[derive(Debug, Clone, PartialEq)]
pub struct Relationship {
    /// Stable id.
    pub id: u64,
    /// Its type.
    pub ty: RelType,
    /// Start node.
    pub start: u64,
    /// End node.
    pub end: u64,
    /// Properties, sorted by key id.
    pub props: Vec<(PropKey, Value)>,
}

fn lookup(props: &[(PropKey, Value)], key: PropKey) -> Option<&Value> {
    props
        .binary_search_by_key(&key, |(k, _)| *k)
        .ok()
        .map(|i| &props[i].1)
}

impl Node {
    /// A property by key.
    pub fn get(&self, key: PropKey) -> Option<&Value> {
        lookup(&self.props, key)
    }

    /// Whether the node has the label.
    pub fn has_label(&self, label: LabelId) -> bool {
        self.labels.binary_search(&label).is_ok()
    }
}

impl Relationship {
    /// A property by key.
    pub fn get(&self, key: PropKey) -> Option<&Value> {
        lookup(&self.props, key)
    }

    /// The node at the other end from `node`.
    pub fn other(&self, node: u64) -> u64 {
        if self.start == node {
            self.end
        } else {
            self.start
        }
    }
}

/// Which relationships of a node to follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// node -> other
    Outgoing,
    /// other -> node
    Incoming,
    /// Either; a self-loop is reported once.
    Both,
}

/// One entry of a node's adjacency.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Adjacent {
    /// The relationship.
    pub rel: u64,
    /// Its type.
    pub ty: RelType,
    /// The node at the other end.
    pub other: u64,
    /// Whether the relationship starts at the node asked about.
    pub outgoing: bool,
}

/// Normalises a property list: sorted by key, the last of duplicate keys wins, nulls dropped.
pub(crate) fn normalize_props(mut props: Vec<(PropKey, Value)>) -> Vec<(PropKey, Value)> {
    // stable sort keeps insertion order among equal keys; keep the last one
    props.sort_by_key(|(k, _)| *k);
    let mut out: Vec<(PropKey, Value)> = Vec::with_capacity(props.len());
    for (k, v) in props {
        if let Some(last) = out.last_mut()
            && last.0 == k
        {
            last.1 = v;
            continue;
        }
        out.push((k, v));
    }
    out.retain(|(_, v)| !v.is_null());
    out
}

/// [`normalize_props`] with raw keys, without copying when `props` is already sorted by
/// key, without repeats or nulls (a bulk load's usual row).
pub(crate) fn raw_normalized(mut props: Vec<(PropKey, Value)>) -> Vec<(u32, Value)> {
    let clean =
        props.windows(2).all(|w| w[0].0 < w[1].0) && props.iter().all(|(_, v)| !v.is_null());
    if !clean {
        props = normalize_props(props);
    }
    props.into_iter().map(|(k, v)| (k.0, v)).collect()
}

pub(crate) fn raw_props(props: &[(PropKey, Value)]) -> Vec<(u32, Value)> {
    props.iter().map(|(k, v)| (k.0, v.clone())).collect()
}

/// A relationship to create in bulk ([`crate::WriteTxn::create_rels`]): start node, type, end
/// node, properties.
pub type NewRel = (u64, RelType, u64, Vec<(PropKey, Value)>);

/// A node to re-create in bulk under its id ([`crate::WriteTxn::restore_node`], many at
/// once in an import): id, labels, properties.
pub(crate) type RestoredNode = (u64, Vec<LabelId>, Vec<(PropKey, Value)>);

pub(crate) fn typed_props(props: Vec<(u32, Value)>) -> Vec<(PropKey, Value)> {
    props.into_iter().map(|(k, v)| (PropKey(k), v)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalize_keeps_last_duplicate_and_drops_nulls() {
        let p = normalize_props(vec![
            (PropKey(2), Value::Int(1)),
            (PropKey(1), Value::Int(5)),
            (PropKey(2), Value::Int(9)),
            (PropKey(3), Value::Null),
        ]);
        assert_eq!(
            p,
            vec![(PropKey(1), Value::Int(5)), (PropKey(2), Value::Int(9))]
        );
    }
}
