//! Consistency checks between the data and every index and count.

use std::collections::{BTreeMap, BTreeSet};

use crate::error::Result;
use crate::layout::{EntryLists, Mem};
use crate::read::{GraphRead, Raw};
use crate::txn::ReadTxn;

/// Returns a list of problems (empty when the store is consistent).
pub(crate) fn check(r: &ReadTxn) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    let base = r.base().clone();
    let schema = &base.schema;
    let nodes = r.all_nodes()?;
    let node_set: BTreeSet<u64> = nodes.iter().copied().collect();
    let (next_node, next_rel) = r.next_ids()?;
    let mut label_rows = BTreeSet::new();
    let mut label_counts: BTreeMap<u32, u64> = BTreeMap::new();
    let mut pidx = BTreeSet::new();
    let mut lists = EntryLists::new(schema);
    for &id in &nodes {
        if id >= next_node {
            problems.push(format!(
                "node {id} is not below the next node id {next_node}"
            ));
        }
        let Some(rec) = r.load_rec(id)? else { continue };
        for l in &rec.labels {
            label_rows.insert((*l, id));
            *label_counts.entry(*l).or_default() += 1;
        }
        for (i, pi) in schema.prop_indexes.iter().enumerate() {
            if rec.has_label(pi.label)
                && let Some(sk) = rec.get(pi.key).and_then(crate::codec::sort_key)
            {
                let mut k = (i as u32).to_be_bytes().to_vec();
                k.extend_from_slice(&sk);
                k.extend_from_slice(&id.to_be_bytes());
                pidx.insert(k);
            }
        }
        lists.add(schema, id, &rec);
    }
    let stored_labels: BTreeSet<(u32, u64)> = r.raw_label_rows()?.into_iter().collect();
    if stored_labels != label_rows {
        problems.push(format!(
            "label index has {} rows, the nodes say {}",
            stored_labels.len(),
            label_rows.len()
        ));
    }
    let stored_pidx: BTreeSet<Vec<u8>> = r.raw_propidx_rows()?.into_iter().collect();
    if stored_pidx != pidx {
        problems.push(format!(
            "property index has {} rows, the nodes say {}",
            stored_pidx.len(),
            pidx.len()
        ));
    }
    // relationships and adjacency
    let mut adj_rows = BTreeSet::new();
    let mut type_counts: BTreeMap<u32, u64> = BTreeMap::new();
    let rels = r.all_rels()?;
    for &id in &rels {
        if id >= next_rel {
            problems.push(format!(
                "relationship {id} is not below the next id {next_rel}"
            ));
        }
        let Some(rel) = r.rel(id)? else { continue };
        for end in [rel.start, rel.end] {
            if !node_set.contains(&end) {
                problems.push(format!(
                    "relationship {id} dangles: node {end} does not exist"
                ));
            }
        }
        adj_rows.insert(((rel.start, 0u8, rel.ty.0, id), rel.end));
        adj_rows.insert(((rel.end, 1u8, rel.ty.0, id), rel.start));
        *type_counts.entry(rel.ty.0).or_default() += 1;
    }
    let stored_adj: BTreeSet<_> = r.raw_adjacency_rows()?.into_iter().collect();
    if stored_adj != adj_rows {
        problems.push(format!(
            "adjacency has {} rows, the relationships say {}",
            stored_adj.len(),
            adj_rows.len()
        ));
    }
    // counts
    let mut want_counts: BTreeMap<(u8, u32), u64> = BTreeMap::new();
    for (l, n) in label_counts {
        want_counts.insert((0, l), n);
    }
    for (t, n) in type_counts {
        want_counts.insert((1, t), n);
    }
    if !nodes.is_empty() {
        want_counts.insert((2, 0), nodes.len() as u64);
    }
    if !rels.is_empty() {
        want_counts.insert((2, 1), rels.len() as u64);
    }
    let stored_counts: BTreeMap<(u8, u32), u64> = r.count_rows()?.into_iter().collect();
    if stored_counts != want_counts {
        problems.push(format!(
            "counts disagree: stored {stored_counts:?}, data says {want_counts:?}"
        ));
    }
    // in-memory indexes
    let mem: &Mem = r.mem()?;
    for (i, want) in lists.spatial.into_iter().enumerate() {
        if mem.spatial[i].visible_entries(None) != want {
            problems.push(format!("spatial index {i} disagrees with the data"));
        }
    }
    for (i, want) in lists.vector.into_iter().enumerate() {
        if mem.vector[i].visible_entries(None) != want {
            problems.push(format!("vector index {i} disagrees with the data"));
        }
    }
    for (i, want) in lists.text.into_iter().enumerate() {
        if mem.text[i].visible_entries(None) != want {
            problems.push(format!("text index {i} disagrees with the data"));
        }
    }
    Ok(problems)
}
