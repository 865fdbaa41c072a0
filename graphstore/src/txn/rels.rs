//! Relationship and payload writes: create, restore, set, replace, delete; payloads and point
//! clouds beside a node.

use super::*;
use crate::adjacency::{self, AdjRow};

/// Ends above the dense table whose labels [`WriteTxn::create_rels`] keeps at once.
const MAX_CACHED_ENDS: usize = 1 << 20;

/// Node ids below this have their label set in a table indexed by id (4 bytes each, grown to
/// the largest id seen; at most 64 MB).
const DENSE_ENDS: u64 = 1 << 24;

/// The labels of relationship ends, read once and kept across the batches (transactions) of a
/// bulk load: valid only while every commit to the store is the load's own, so each batch
/// checks that its base is the commit the previous batch made, and starts afresh otherwise.
/// Label sets are interned: a node maps to its set's index.
#[derive(Debug, Default)]
pub(crate) struct EndLabels {
    /// The commit the labels are valid for: the one the last batch made.
    seq: Option<u64>,
    sets: Vec<Vec<u32>>,
    interned: hashbrown::HashMap<Vec<u32>, u32>,
    /// By node id below [`DENSE_ENDS`]: 1 + the set's index, 0 when not read yet.
    dense: Vec<u32>,
    sparse: hashbrown::HashMap<u64, u32>,
}

impl EndLabels {
    fn clear(&mut self) {
        self.sets.clear();
        self.interned.clear();
        self.dense.clear();
        self.sparse.clear();
    }

    /// The index of node `id`'s label set, read with `read` the first time.
    fn set_of(&mut self, id: u64, read: impl FnOnce() -> Result<Vec<u32>>) -> Result<u32> {
        let known = if id < DENSE_ENDS {
            self.dense
                .get(id as usize)
                .copied()
                .unwrap_or(0)
                .checked_sub(1)
        } else {
            self.sparse.get(&id).copied()
        };
        if let Some(k) = known {
            return Ok(k);
        }
        let labels = read()?;
        if self.sets.len() >= MAX_CACHED_ENDS {
            self.clear();
        }
        let k = match self.interned.get(&labels) {
            Some(&k) => k,
            None => {
                let k = self.sets.len() as u32;
                self.sets.push(labels.clone());
                self.interned.insert(labels, k);
                k
            }
        };
        if id < DENSE_ENDS {
            if self.dense.len() <= id as usize {
                self.dense.resize(id as usize + 1, 0);
            }
            self.dense[id as usize] = k + 1;
        } else {
            if self.sparse.len() >= MAX_CACHED_ENDS {
                self.sparse.clear();
            }
            self.sparse.insert(id, k);
        }
        Ok(k)
    }
}

impl WriteTxn<'_> {
    /// Creates a relationship `start -[ty]-> end`.
    pub fn create_rel(
        &mut self,
        start: u64,
        ty: RelType,
        end: u64,
        props: Vec<(PropKey, Value)>,
    ) -> Result<u64> {
        let s = self.rec(start)?;
        let e = if end == start {
            s.clone()
        } else {
            self.rec(end)?
        };
        let props = raw_normalized(props);
        self.check_rel(ty.0, &s.labels, &e.labels, &props)?;
        let id = self.next_rel;
        let bytes = codec::encode_rel(ty.0, start, end, &props);
        self.rels.insert(&id, bytes.as_slice()).map_err(storage)?;
        adjacency::insert(&mut self.adj, start, 0, (id, ty.0, end))?;
        adjacency::insert(&mut self.adj, end, 1, (id, ty.0, start))?;
        self.touched.add(start);
        self.touched.add(end);
        self.bump(1, ty.0, 1)?;
        self.bump(2, 1, 1)?;
        self.next_rel += 1;
        Ok(id)
    }

    /// Creates many relationships at once, for bulk loads: each row as
    /// [`WriteTxn::create_rel`] would (same ids, in row order; same checks), but every row is
    /// checked before any is written, each end's labels are read once per call (its properties
    /// are not decoded), and the
    /// adjacency rows are inserted in key order, which a B-tree takes far faster than the
    /// scattered order of the rows.
    ///
    /// # Errors
    /// `(row index, error)` for the first row that fails a check (a missing end, a schema
    /// rule); nothing is written then. Storage errors come as `(rows.len(), error)`.
    pub fn create_rels(
        &mut self,
        rows: Vec<crate::NewRel>,
    ) -> std::result::Result<Vec<u64>, (usize, Error)> {
        self.create_rels_into(rows, None, &mut EndLabels::default())
    }

    /// [`WriteTxn::create_rels`], with the adjacency rows appended to `deferred` instead of
    /// written when it is given: the caller writes them later with
    /// [`WriteTxn::insert_adjacency`] (a bulk import into an empty store, whose adjacency
    /// then goes in once, in key order).
    ///
    /// `cache`: the ends' labels, read once (only the labels are decoded) and kept for the
    /// next batch of the same load (see [`EndLabels`]).
    pub(crate) fn create_rels_into(
        &mut self,
        rows: Vec<crate::NewRel>,
        deferred: Option<&mut Vec<AdjRow>>,
        cache: &mut EndLabels,
    ) -> std::result::Result<Vec<u64>, (usize, Error)> {
        let n = rows.len();
        if cache.seq != Some(self.base.seq) {
            cache.clear();
        }
        // valid again only once this batch has gone in without an error
        cache.seq = None;
        // the records, one after another in `bytes`; each row keeps where its record ends
        let mut encoded = Vec::with_capacity(n);
        let mut bytes: Vec<u8> = Vec::with_capacity(n * 16);
        for (i, (start, ty, end, props)) in rows.into_iter().enumerate() {
            let mut set_of = |id: u64| {
                cache
                    .set_of(id, || {
                        self.node_labels(id)
                            .and_then(|l| l.ok_or(Error::NodeNotFound(id)))
                    })
                    .map_err(|e| (i, e))
            };
            let (s, e) = (set_of(start)?, set_of(end)?);
            let props = raw_normalized(props);
            self.check_rel(
                ty.0,
                &cache.sets[s as usize],
                &cache.sets[e as usize],
                &props,
            )
            .map_err(|e| (i, e))?;
            codec::encode_rel_into(&mut bytes, ty.0, start, end, &props);
            encoded.push((start, ty.0, end, bytes.len()));
        }
        let store = |e| (n, e);
        let first = self.next_rel;
        let mut adj = Vec::with_capacity(2 * n);
        let mut ids = Vec::with_capacity(n);
        // every id from `next_rel` on is above the table's keys: appended
        let ends = encoded.iter().enumerate();
        let ends = ends.map(|(k, &(_, _, _, to))| (first + k as u64, to));
        append_records(&mut self.rels, &bytes, ends).map_err(store)?;
        // relationships per type, counted here (a batch has few types) and added once
        let mut per_type: Vec<(u32, i64)> = Vec::new();
        for (k, (start, ty, end, _)) in encoded.into_iter().enumerate() {
            let id = first + k as u64;
            adj.push(((start, 0u8, ty, id), end));
            adj.push(((end, 1u8, ty, id), start));
            self.touched.add(start);
            self.touched.add(end);
            match per_type.iter_mut().find(|(t, _)| *t == ty) {
                Some((_, c)) => *c += 1,
                None => per_type.push((ty, 1)),
            }
            ids.push(id);
        }
        for (ty, c) in per_type {
            self.bump(1, ty, c).map_err(store)?;
        }
        match deferred {
            Some(out) => out.append(&mut adj),
            None => self.insert_adjacency(&mut adj).map_err(store)?,
        }
        self.bump(2, 1, n as i64).map_err(store)?;
        self.next_rel = first + n as u64;
        // the commit this transaction makes, if it commits
        cache.seq = Some(self.base.seq + 1);
        Ok(ids)
    }

    /// Writes adjacency rows, sorted here and packed into each node's chunks
    /// ([`adjacency::insert_many`]; into an empty table, fresh chunks in key order). `rows`
    /// keeps them: the caller clears it once the transaction has committed.
    pub(crate) fn insert_adjacency(&mut self, rows: &mut [AdjRow]) -> Result<()> {
        adjacency::insert_many(&mut self.adj, rows)
    }

    /// Re-creates a deleted relationship under its old id (for undoing an edit exactly).
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when the id was never used or a relationship has it; missing
    /// ends and schema errors as for [`WriteTxn::create_rel`].
    pub fn restore_rel(
        &mut self,
        id: u64,
        start: u64,
        ty: RelType,
        end: u64,
        props: Vec<(PropKey, Value)>,
    ) -> Result<()> {
        if id >= self.next_rel || Raw::load_rel(self, id)?.is_some() {
            return Err(Error::InvalidValue(format!(
                "cannot restore relationship {id}: the id is in use or was never handed out"
            )));
        }
        let s = self.rec(start)?;
        let e = if end == start {
            s.clone()
        } else {
            self.rec(end)?
        };
        let props = raw_normalized(props);
        self.check_rel(ty.0, &s.labels, &e.labels, &props)?;
        let bytes = codec::encode_rel(ty.0, start, end, &props);
        self.rels.insert(&id, bytes.as_slice()).map_err(storage)?;
        adjacency::insert(&mut self.adj, start, 0, (id, ty.0, end))?;
        adjacency::insert(&mut self.adj, end, 1, (id, ty.0, start))?;
        self.touched.add(start);
        self.touched.add(end);
        self.bump(1, ty.0, 1)?;
        self.bump(2, 1, 1)?;
        Ok(())
    }

    /// Creates a relationship from names.
    pub fn create_rel_named(
        &mut self,
        start: u64,
        ty: &str,
        end: u64,
        props: &[(&str, Value)],
    ) -> Result<u64> {
        let t = self.rel_type_id(ty)?;
        let ps = props
            .iter()
            .map(|(k, v)| Ok((self.prop_key_id(k)?, v.clone())))
            .collect::<Result<Vec<_>>>()?;
        self.create_rel(start, t, end, ps)
    }

    pub(super) fn write_rel_props(
        &mut self,
        rel: &Relationship,
        props: Vec<(u32, Value)>,
    ) -> Result<()> {
        let s = self.rec(rel.start)?;
        let e = self.rec(rel.end)?;
        self.check_rel(rel.ty.0, &s.labels, &e.labels, &props)?;
        let bytes = codec::encode_rel(rel.ty.0, rel.start, rel.end, &props);
        self.rels
            .insert(&rel.id, bytes.as_slice())
            .map_err(storage)?;
        self.touched.add(rel.start);
        self.touched.add(rel.end);
        Ok(())
    }

    /// Sets a relationship property; `Value::Null` removes it.
    pub fn set_rel_prop(&mut self, id: u64, key: PropKey, value: Value) -> Result<()> {
        let rel = Raw::load_rel(self, id)?.ok_or(Error::RelNotFound(id))?;
        let mut props = raw_props(&rel.props);
        match props.binary_search_by_key(&key.0, |(k, _)| *k) {
            Ok(i) if value.is_null() => {
                props.remove(i);
            }
            Ok(i) => props[i].1 = value,
            Err(_) if value.is_null() => return Ok(()),
            Err(i) => props.insert(i, (key.0, value)),
        }
        self.write_rel_props(&rel, props)
    }

    /// Replaces all properties of a relationship.
    pub fn replace_rel_props(&mut self, id: u64, props: Vec<(PropKey, Value)>) -> Result<()> {
        let rel = Raw::load_rel(self, id)?.ok_or(Error::RelNotFound(id))?;
        self.write_rel_props(&rel, raw_normalized(props))
    }

    /// Deletes a relationship.
    pub fn delete_rel(&mut self, id: u64) -> Result<()> {
        let rel = Raw::load_rel(self, id)?.ok_or(Error::RelNotFound(id))?;
        self.rels.remove(&id).map_err(storage)?;
        adjacency::remove(&mut self.adj, rel.start, 0, id)?;
        adjacency::remove(&mut self.adj, rel.end, 1, id)?;
        self.touched.add(rel.start);
        self.touched.add(rel.end);
        self.bump(1, rel.ty.0, -1)?;
        self.bump(2, 1, -1)?;
        Ok(())
    }

    /// Stores a payload beside a node (large data such as point clouds stays out of the
    /// node record so scans stay cheap).
    pub fn put_payload(&mut self, node: u64, key: &str, bytes: &[u8]) -> Result<()> {
        self.rec(node)?;
        self.payloads.insert(&(node, key), bytes).map_err(storage)?;
        self.touched.add(node);
        Ok(())
    }

    /// Removes a payload; returns whether it existed.
    pub fn delete_payload(&mut self, node: u64, key: &str) -> Result<bool> {
        let removed = self
            .payloads
            .remove(&(node, key))
            .map_err(storage)?
            .is_some();
        if removed {
            self.touched.add(node);
        }
        Ok(removed)
    }

    /// Stores a point cloud, compressed (see [`PointCloud::encode`]).
    pub fn put_point_cloud(&mut self, node: u64, key: &str, cloud: &PointCloud) -> Result<()> {
        let bytes = cloud.encode()?;
        self.put_payload(node, key, &bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{RelRule, Schema, Store};

    /// Label sets are read once per node, below and above the dense table, and interned.
    #[test]
    fn end_labels_read_each_node_once() {
        let mut cache = EndLabels::default();
        let reads = std::cell::Cell::new(0);
        let read = |labels: Vec<u32>| {
            let reads = &reads;
            move || {
                reads.set(reads.get() + 1);
                Ok(labels)
            }
        };
        let far = DENSE_ENDS + 5;
        assert_eq!(cache.set_of(3, read(vec![1])).unwrap(), 0);
        assert_eq!(cache.set_of(far, read(vec![2])).unwrap(), 1);
        assert_eq!(cache.set_of(7, read(vec![1])).unwrap(), 0);
        assert_eq!(reads.get(), 3);
        assert_eq!(cache.set_of(3, read(vec![9])).unwrap(), 0);
        assert_eq!(cache.set_of(far, read(vec![9])).unwrap(), 1);
        assert_eq!(reads.get(), 3);
        assert_eq!(cache.sets, vec![vec![1], vec![2]]);
        let e = cache.set_of(8, || Err(Error::NodeNotFound(8)));
        assert!(matches!(e, Err(Error::NodeNotFound(8))));
        assert_eq!(cache.set_of(8, read(vec![2])).unwrap(), 1);
    }

    /// The end labels kept across batches are used only while the batches' commits follow one
    /// another: a commit in between (here one that takes a label away) makes the next batch
    /// read them again, so the schema's rule still holds.
    #[test]
    fn end_labels_are_read_again_after_another_commit() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::create(dir.path().join("e.og")).unwrap();
        let mut schema = Schema::default();
        schema.relationships.insert(
            "R".into(),
            RelRule {
                from_labels: vec!["X".into()],
                ..RelRule::default()
            },
        );
        store.set_schema(schema).unwrap();
        let (a, b) = store
            .write(|tx| {
                Ok((
                    tx.create_node_named(&["X"], &[])?,
                    tx.create_node_named(&["X"], &[])?,
                ))
            })
            .unwrap();
        let mut cache = EndLabels::default();
        let batch = |tx: &mut WriteTxn<'_>, cache: &mut EndLabels| {
            let r = tx.rel_type_id("R")?;
            tx.create_rels_into(vec![(a, r, b, vec![])], None, cache)
                .map_err(|(_, e)| e)
        };
        store.write(|tx| batch(tx, &mut cache)).unwrap();
        assert_eq!(cache.seq, Some(store.commit_seq()));
        // the next batch right after: the labels are not read again
        store.write(|tx| batch(tx, &mut cache)).unwrap();
        assert_ne!(cache.dense.get(a as usize).copied().unwrap_or(0), 0);
        // another commit takes X away from `a`: the next batch must see it
        store
            .write(|tx| {
                let x = tx.label_id("X")?;
                tx.remove_label(a, x)
            })
            .unwrap();
        let e = store.write(|tx| batch(tx, &mut cache)).unwrap_err();
        assert!(e.to_string().contains('X'), "{e}");
        assert_eq!(store.counts().unwrap().total_relationships, 2);
    }
}
