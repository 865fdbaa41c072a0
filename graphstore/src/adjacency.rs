//! The adjacency table: each node's relationship ends, per direction, packed into chunks.
//!
//! Key `(node, direction 0 out / 1 in, first relationship id of the chunk)`; value: the chunk's
//! entries `(relationship, type, other end)` in ascending relationship id, each as three LEB128
//! varints: the relationship id's gap from the entry before (from the key's id for the first
//! entry, so 0), the type token and the other end's node id. A node's chunks in one direction
//! partition its relationship ids: every id of a chunk lies at or after its key and before the
//! next chunk's key. A chunk holds at most [`CHUNK_MAX`] entries, so one change rewrites at most
//! that many.
//!
//! One B-tree row per chunk instead of one per relationship end (store format 1 had
//! `(node, direction, type, rel) -> other`, 29 bytes a row): on a graph of 200k nodes and 1M
//! relationships the table takes about a third of the space. Readers get the rows of format 1
//! back, in its key order ([`read`], [`Rows`]).

use redb::{ReadableTable, ReadableTableMetadata, Table};

use crate::codec::{Reader, put_varint};
use crate::error::{Result, corrupt, storage};

/// Key of a chunk: `(node, direction, first relationship id in the chunk)`.
pub(crate) type ChunkKey = (u64, u8, u64);
/// One end of a relationship as readers see it: `(node, direction, type, rel)` and the other end.
pub(crate) type AdjRow = ((u64, u8, u32, u64), u64);
/// The table's definition (format 2).
pub(crate) const ADJ: redb::TableDefinition<'static, ChunkKey, &[u8]> =
    redb::TableDefinition::new("og_adj_chunks");
/// Store format 1's table, one row per relationship end (read once, to convert it).
pub(crate) const ADJ_V1: redb::TableDefinition<'static, (u64, u8, u32, u64), u64> =
    redb::TableDefinition::new("og_adj");

/// Most entries in one chunk.
pub(crate) const CHUNK_MAX: usize = 128;

/// An entry: (relationship, type, other end).
pub(crate) type Entry = (u64, u32, u64);

/// A chunk's bytes; `entries` ascending by relationship id, the first at `entries[0].0`.
fn encode(entries: &[Entry]) -> Vec<u8> {
    let mut out = Vec::with_capacity(entries.len() * 7);
    let mut prev = entries.first().map_or(0, |e| e.0);
    for &(rel, ty, other) in entries {
        put_varint(&mut out, rel - prev);
        put_varint(&mut out, u64::from(ty));
        put_varint(&mut out, other);
        prev = rel;
    }
    out
}

/// Appends a chunk's entries to `out`, checking that it is well formed: not empty, its first
/// entry at the key's id, ids strictly ascending, no bytes left over.
fn decode(key: ChunkKey, bytes: &[u8], out: &mut Vec<Entry>) -> Result<()> {
    let bad = |detail: &str| {
        corrupt(
            "adjacency",
            format!(
                "chunk of node {} ({}) at relationship {}: {detail}",
                key.0,
                if key.1 == 0 { "out" } else { "in" },
                key.2
            ),
        )
    };
    if bytes.is_empty() {
        return Err(bad("empty"));
    }
    let mut r = Reader::new(bytes, "adjacency chunk");
    let mut rel = key.2;
    let mut first = true;
    while !r.is_empty() {
        let gap = r.varint().map_err(|e| bad(&e.to_string()))?;
        let ty = r.u32_varint().map_err(|e| bad(&e.to_string()))?;
        let other = r.varint().map_err(|e| bad(&e.to_string()))?;
        if first != (gap == 0) {
            return Err(bad("relationship ids out of order"));
        }
        first = false;
        rel = rel
            .checked_add(gap)
            .ok_or_else(|| bad("relationship id overflows"))?;
        out.push((rel, ty, other));
    }
    Ok(())
}

/// Writes `entries` (ascending by relationship id, not empty) as chunks of at most
/// [`CHUNK_MAX`], in even parts.
fn put_chunks(
    t: &mut Table<'_, ChunkKey, &'static [u8]>,
    node: u64,
    dir: u8,
    entries: &[Entry],
) -> Result<()> {
    for part in chunk_parts(entries) {
        t.insert((node, dir, part[0].0), encode(part).as_slice())
            .map_err(storage)?;
    }
    Ok(())
}

/// `entries` cut into the fewest chunks of at most [`CHUNK_MAX`], of even sizes.
fn chunk_parts(entries: &[Entry]) -> std::slice::Chunks<'_, Entry> {
    let parts = entries.len().div_ceil(CHUNK_MAX).max(1);
    let per = entries.len().div_ceil(parts);
    entries.chunks(per.max(1))
}

/// The relationships at `node` in direction `dir` (0 out, 1 in), of type `ty` or of every
/// type, as (rel, type, other), sorted by (type, rel).
pub(crate) fn read<T: ReadableTable<ChunkKey, &'static [u8]>>(
    t: &T,
    node: u64,
    dir: u8,
    ty: Option<u32>,
) -> Result<Vec<Entry>> {
    let mut all = Vec::new();
    for row in t
        .range((node, dir, 0u64)..=(node, dir, u64::MAX))
        .map_err(storage)?
    {
        let (k, v) = row.map_err(storage)?;
        decode(k.value(), v.value(), &mut all)?;
    }
    match ty {
        Some(want) => all.retain(|e| e.1 == want),
        None => all.sort_unstable_by_key(|e| (e.1, e.0)),
    }
    Ok(all)
}

/// A row of the table as its key and its entries, decoded and checked ([`decode`]).
type ChunkRow<'a> = std::result::Result<
    (
        redb::AccessGuard<'a, ChunkKey>,
        redb::AccessGuard<'a, &'static [u8]>,
    ),
    redb::StorageError,
>;

fn decoded(row: ChunkRow<'_>) -> Result<(ChunkKey, Vec<Entry>)> {
    let (k, v) = row.map_err(storage)?;
    let key = k.value();
    let mut entries = Vec::new();
    decode(key, v.value(), &mut entries)?;
    Ok((key, entries))
}

/// The chunk holding `rel` if it is there: the chunk with the greatest key at or before it.
fn chunk_at(
    t: &Table<'_, ChunkKey, &'static [u8]>,
    node: u64,
    dir: u8,
    rel: u64,
) -> Result<Option<(ChunkKey, Vec<Entry>)>> {
    t.range((node, dir, 0u64)..=(node, dir, rel))
        .map_err(storage)?
        .next_back()
        .map(decoded)
        .transpose()
}

/// Adds one end: relationship `rel` of type `ty` at `node`, direction `dir`, `other` at the far
/// end. An id already there is replaced.
pub(crate) fn insert(
    t: &mut Table<'_, ChunkKey, &'static [u8]>,
    node: u64,
    dir: u8,
    (rel, ty, other): Entry,
) -> Result<()> {
    let (old_key, mut entries) = match chunk_at(t, node, dir, rel)? {
        Some(found) => found,
        None => {
            // before every chunk: join the first one, if any (its key changes)
            let first = t
                .range((node, dir, rel)..=(node, dir, u64::MAX))
                .map_err(storage)?
                .next()
                .map(decoded)
                .transpose()?;
            match first {
                Some(found) => found,
                None => ((node, dir, rel), Vec::new()),
            }
        }
    };
    match entries.binary_search_by_key(&rel, |e| e.0) {
        Ok(i) => entries[i] = (rel, ty, other),
        Err(i) => entries.insert(i, (rel, ty, other)),
    }
    if old_key.2 != entries[0].0 {
        t.remove(old_key).map_err(storage)?;
    }
    put_chunks(t, node, dir, &entries)
}

/// Removes relationship `rel`'s end at `node`, direction `dir`; whether it was there.
pub(crate) fn remove(
    t: &mut Table<'_, ChunkKey, &'static [u8]>,
    node: u64,
    dir: u8,
    rel: u64,
) -> Result<bool> {
    let Some((key, mut entries)) = chunk_at(t, node, dir, rel)? else {
        return Ok(false);
    };
    let Ok(i) = entries.binary_search_by_key(&rel, |e| e.0) else {
        return Ok(false);
    };
    entries.remove(i);
    if entries.first().is_none_or(|e| e.0 != key.2) {
        t.remove(key).map_err(storage)?;
    }
    if !entries.is_empty() {
        t.insert((node, dir, entries[0].0), encode(&entries).as_slice())
            .map_err(storage)?;
    }
    Ok(true)
}

/// Adds many ends at once (`((node, dir, type, rel), other)`; sorted here by node, direction and
/// relationship). Into an empty table each node's ends are written as fresh chunks in key order;
/// otherwise ends with ids after a node's last chunk are appended to it, and the rest go in one by
/// one as [`insert`] does.
pub(crate) fn insert_many(
    t: &mut Table<'_, ChunkKey, &'static [u8]>,
    rows: &mut [AdjRow],
) -> Result<()> {
    sort_rows(rows);
    if t.is_empty().map_err(storage)? {
        // appended in key order through one cursor, which packs the chunks into full leaves
        // instead of descending the tree per chunk
        let mut cursor = t
            .upper_bound_mut(std::ops::Bound::<ChunkKey>::Unbounded)
            .map_err(storage)?;
        for_each_group(rows, |node, dir, group| {
            for part in chunk_parts(group) {
                cursor
                    .insert_before((node, dir, part[0].0), encode(part).as_slice())
                    .map_err(storage)?;
            }
            Ok(())
        })?;
        return cursor.close().map_err(storage);
    }
    for_each_group(rows, |node, dir, group| {
        match chunk_at(t, node, dir, u64::MAX)? {
            None => put_chunks(t, node, dir, group),
            Some((key, mut entries)) if entries.last().is_some_and(|e| e.0 < group[0].0) => {
                entries.extend_from_slice(group);
                // the first part keeps the old key; the rest get new ones
                debug_assert_eq!(entries[0].0, key.2);
                put_chunks(t, node, dir, &entries)
            }
            Some(_) => group.iter().try_for_each(|&e| insert(t, node, dir, e)),
        }
    })
}

/// Sorts adjacency rows by (node, direction, relationship). Rows in relationship order (as a
/// load makes them) over node ids not much larger than their number are sorted by counting,
/// stably by (node, direction), in two linear passes; others by comparison.
fn sort_rows(rows: &mut [AdjRow]) {
    let in_rel_order = rows.windows(2).all(|w| (w[0].0).3 <= (w[1].0).3);
    let max_node = rows.iter().map(|((n, ..), _)| *n).max().unwrap_or(0);
    let two_directions = rows.iter().all(|((_, d, ..), _)| *d <= 1);
    if !in_rel_order || !two_directions || max_node > 4 * rows.len() as u64 + 1024 {
        rows.sort_unstable_by_key(|((n, d, _, r), _)| (*n, *d, *r));
        return;
    }
    let bucket = |((n, d, _, _), _): &AdjRow| (2 * *n + u64::from(*d)) as usize;
    let mut start = vec![0usize; 2 * max_node as usize + 3];
    for r in rows.iter() {
        start[bucket(r) + 1] += 1;
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let unsorted = rows.to_vec();
    for r in unsorted {
        let b = bucket(&r);
        rows[start[b]] = r;
        start[b] += 1;
    }
}

/// Calls `f(node, direction, ends)` for each (node, direction) of `rows` (sorted), its ends
/// ascending by relationship id, without repeats.
fn for_each_group(
    rows: &[AdjRow],
    mut f: impl FnMut(u64, u8, &[Entry]) -> Result<()>,
) -> Result<()> {
    let mut i = 0;
    let mut group: Vec<Entry> = Vec::new();
    while i < rows.len() {
        let ((node, dir, _, _), _) = rows[i];
        let j = i + rows[i..].partition_point(|((n, d, _, _), _)| (*n, *d) == (node, dir));
        group.clear();
        group.extend(
            rows[i..j]
                .iter()
                .map(|((_, _, ty, rel), other)| (*rel, *ty, *other)),
        );
        group.dedup_by_key(|e| e.0);
        f(node, dir, &group)?;
        i = j;
    }
    Ok(())
}

/// Every end in the table, in format 1's key order `(node, direction, type, rel)`, checking each
/// chunk and that a node's chunks do not overlap.
pub(crate) struct Rows<'a> {
    range: redb::Range<'a, ChunkKey, &'static [u8]>,
    /// The next row's chunk, read ahead to see where a (node, direction) ends.
    ahead: Option<(ChunkKey, Vec<Entry>)>,
    /// The current (node, direction)'s rows, reversed (popped from the end).
    buf: Vec<AdjRow>,
    done: bool,
}

impl<'a> Rows<'a> {
    pub(crate) fn new<T: ReadableTable<ChunkKey, &'static [u8]>>(t: &'a T) -> Result<Rows<'a>> {
        Ok(Rows {
            range: t.iter().map_err(storage)?,
            ahead: None,
            buf: Vec::new(),
            done: false,
        })
    }

    fn next_chunk(&mut self) -> Result<Option<(ChunkKey, Vec<Entry>)>> {
        if let Some(c) = self.ahead.take() {
            return Ok(Some(c));
        }
        self.range.next().map(decoded).transpose()
    }

    /// Reads the next (node, direction)'s chunks into `buf`; false at the end.
    fn fill(&mut self) -> Result<bool> {
        let Some((key, mut all)) = self.next_chunk()? else {
            return Ok(false);
        };
        while let Some((k, entries)) = self.next_chunk()? {
            if (k.0, k.1) != (key.0, key.1) {
                self.ahead = Some((k, entries));
                break;
            }
            if all.last().is_some_and(|e| e.0 >= k.2) {
                return Err(corrupt(
                    "adjacency",
                    format!("chunks of node {} overlap at relationship {}", k.0, k.2),
                ));
            }
            all.extend(entries);
        }
        all.sort_unstable_by_key(|e| std::cmp::Reverse((e.1, e.0)));
        self.buf.extend(
            all.into_iter()
                .map(|(rel, ty, other)| ((key.0, key.1, ty, rel), other)),
        );
        Ok(true)
    }
}

impl Iterator for Rows<'_> {
    type Item = Result<AdjRow>;

    fn next(&mut self) -> Option<Result<AdjRow>> {
        if self.done {
            return None;
        }
        if self.buf.is_empty() {
            match self.fill() {
                Ok(true) => {}
                Ok(false) => {
                    self.done = true;
                    return None;
                }
                Err(e) => {
                    self.done = true;
                    return Some(Err(e));
                }
            }
        }
        self.buf.pop().map(Ok)
    }
}

/// The adjacency as a reader sees it, whatever the table's format.
pub(crate) trait AdjRead {
    /// As [`read`].
    fn adj_read(&self, node: u64, dir: u8, ty: Option<u32>) -> Result<Vec<Entry>>;
    /// Every end, in format 1's key order, as [`Rows`] gives them.
    fn adj_rows(&self) -> Result<Box<dyn Iterator<Item = Result<AdjRow>> + '_>>;
}

impl AdjRead for Table<'_, ChunkKey, &'static [u8]> {
    fn adj_read(&self, node: u64, dir: u8, ty: Option<u32>) -> Result<Vec<Entry>> {
        read(self, node, dir, ty)
    }
    fn adj_rows(&self) -> Result<Box<dyn Iterator<Item = Result<AdjRow>> + '_>> {
        Ok(Box::new(Rows::new(self)?))
    }
}

/// A read transaction's adjacency table: format 2's chunks, or, in a store of format 1 opened
/// read-only (which is never converted: the file is not written), format 1's rows.
pub(crate) enum AdjTable {
    Chunks(redb::ReadOnlyTable<ChunkKey, &'static [u8]>),
    V1(redb::ReadOnlyTable<(u64, u8, u32, u64), u64>),
}

impl AdjRead for AdjTable {
    fn adj_read(&self, node: u64, dir: u8, ty: Option<u32>) -> Result<Vec<Entry>> {
        match self {
            AdjTable::Chunks(t) => read(t, node, dir, ty),
            AdjTable::V1(t) => {
                let (t0, t1) = ty.map_or((0, u32::MAX), |t| (t, t));
                let mut out = Vec::new();
                for row in t
                    .range((node, dir, t0, 0u64)..=(node, dir, t1, u64::MAX))
                    .map_err(storage)?
                {
                    let (k, v) = row.map_err(storage)?;
                    let (_, _, ty, rel) = k.value();
                    out.push((rel, ty, v.value()));
                }
                Ok(out)
            }
        }
    }
    fn adj_rows(&self) -> Result<Box<dyn Iterator<Item = Result<AdjRow>> + '_>> {
        match self {
            AdjTable::Chunks(t) => Ok(Box::new(Rows::new(t)?)),
            AdjTable::V1(t) => Ok(Box::new(t.iter().map_err(storage)?.map(|row| {
                let (k, v) = row.map_err(storage)?;
                Ok((k.value(), v.value()))
            }))),
        }
    }
}

/// Converts format 1's table (one row per end) into chunks, in the write transaction `wtx`, and
/// deletes it; the number of ends moved.
pub(crate) fn convert_v1(wtx: &redb::WriteTransaction) -> Result<u64> {
    let mut rows: Vec<AdjRow> = Vec::new();
    {
        let old = wtx.open_table(ADJ_V1).map_err(storage)?;
        for row in old.iter().map_err(storage)? {
            let (k, v) = row.map_err(storage)?;
            rows.push((k.value(), v.value()));
        }
    }
    wtx.delete_table(ADJ_V1).map_err(storage)?;
    let mut t = wtx.open_table(ADJ).map_err(storage)?;
    if !t.is_empty().map_err(storage)? {
        return Err(corrupt(
            "adjacency",
            "both the format 1 and format 2 tables hold rows",
        ));
    }
    insert_many(&mut t, &mut rows)?;
    Ok(rows.len() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::BTreeMap;

    fn with_table(f: impl FnOnce(&mut Table<'_, ChunkKey, &'static [u8]>)) {
        let dir = tempfile::tempdir().unwrap();
        let db = redb::Database::create(dir.path().join("a.redb")).unwrap();
        let w = db.begin_write().unwrap();
        {
            let mut t = w.open_table(ADJ).unwrap();
            f(&mut t);
        }
        w.commit().unwrap();
    }

    /// Every end as a sorted map, read back through `read` per node and direction and through
    /// `Rows`.
    fn check(t: &Table<'_, ChunkKey, &'static [u8]>, want: &BTreeMap<(u64, u8, u32, u64), u64>) {
        let rows: Vec<AdjRow> = Rows::new(t).unwrap().map(Result::unwrap).collect();
        let want_rows: Vec<AdjRow> = want.iter().map(|(k, v)| (*k, *v)).collect();
        assert_eq!(rows, want_rows);
        let mut nodes: Vec<(u64, u8)> = want.keys().map(|k| (k.0, k.1)).collect();
        nodes.dedup();
        for (node, dir) in nodes {
            let all = read(t, node, dir, None).unwrap();
            let expect: Vec<Entry> = want
                .range((node, dir, 0, 0)..=(node, dir, u32::MAX, u64::MAX))
                .map(|(k, v)| (k.3, k.2, *v))
                .collect();
            assert_eq!(all, expect);
            for ty in 0..3u32 {
                let typed = read(t, node, dir, Some(ty)).unwrap();
                let e: Vec<Entry> = expect.iter().copied().filter(|e| e.1 == ty).collect();
                assert_eq!(typed, e);
            }
        }
        // no chunk over the cap, none empty
        for row in t.iter().unwrap() {
            let (k, v) = row.unwrap();
            let mut e = Vec::new();
            decode(k.value(), v.value(), &mut e).unwrap();
            assert!(!e.is_empty() && e.len() <= CHUNK_MAX);
        }
    }

    #[derive(Debug, Clone)]
    enum Op {
        Insert(u64, u8, u32, u64, u64),
        Remove(u64, u8, u64),
        Many(Vec<(u64, u8, u32, u64, u64)>),
    }

    fn op() -> impl Strategy<Value = Op> {
        // few nodes and a small id space, so chunks fill, split and get hit in the middle
        let end = (0u64..2, 0u8..2, 0u32..3, 0u64..400, 0u64..1_000_000);
        prop_oneof![
            4 => end.clone().prop_map(|(n, d, t, r, o)| Op::Insert(n, d, t, r, o)),
            2 => (0u64..2, 0u8..2, 0u64..400).prop_map(|(n, d, r)| Op::Remove(n, d, r)),
            1 => proptest::collection::vec(end, 0..300).prop_map(Op::Many),
        ]
    }

    proptest! {
        /// Rows in relationship order (the counting sort) and in any order sort as a
        /// comparison sort does.
        #[test]
        fn rows_sort_by_node_direction_and_relationship(
            ends in proptest::collection::vec((0u64..50, 0u8..2, 0u32..3, 0u64..500, 0u64..9), 0..400),
            by_rel in any::<bool>(),
        ) {
            let mut seen = std::collections::BTreeSet::new();
            let mut rows: Vec<AdjRow> = ends
                .into_iter()
                .filter(|(n, d, _, r, _)| seen.insert((*n, *d, *r)))
                .map(|(n, d, ty, r, o)| ((n, d, ty, r), o))
                .collect();
            if by_rel {
                rows.sort_by_key(|((.., r), _)| *r);
            }
            let mut want = rows.clone();
            want.sort_unstable_by_key(|((n, d, _, r), _)| (*n, *d, *r));
            sort_rows(&mut rows);
            prop_assert_eq!(rows, want);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Inserts, removals and bulk inserts against a sorted map as the reference.
        #[test]
        fn chunks_agree_with_a_sorted_map(ops in proptest::collection::vec(op(), 1..40)) {
            with_table(|t| {
                let mut want: BTreeMap<(u64, u8, u32, u64), u64> = BTreeMap::new();
                // the reference keyed as format 1; an id is unique per (node, direction)
                let drop_id = |want: &mut BTreeMap<(u64, u8, u32, u64), u64>, n: u64, d: u8, r: u64| {
                    let k = want.keys().find(|k| (k.0, k.1, k.3) == (n, d, r)).copied();
                    k.map(|k| want.remove(&k)).is_some()
                };
                for op in ops {
                    match op {
                        Op::Insert(n, d, ty, r, o) => {
                            drop_id(&mut want, n, d, r);
                            want.insert((n, d, ty, r), o);
                            insert(t, n, d, (r, ty, o)).unwrap();
                        }
                        Op::Remove(n, d, r) => {
                            let had = drop_id(&mut want, n, d, r);
                            assert_eq!(remove(t, n, d, r).unwrap(), had);
                        }
                        Op::Many(ends) => {
                            // ids unique per (node, direction) within the batch, as callers give
                            let mut seen = std::collections::BTreeSet::new();
                            let mut rows = Vec::new();
                            for (n, d, ty, r, o) in ends {
                                if seen.insert((n, d, r)) {
                                    drop_id(&mut want, n, d, r);
                                    want.insert((n, d, ty, r), o);
                                    rows.push(((n, d, ty, r), o));
                                }
                            }
                            insert_many(t, &mut rows).unwrap();
                        }
                    }
                }
                check(t, &want);
            });
        }
    }

    /// A store of format 1 (one adjacency row per end) is read as it is when opened read-only
    /// (the file untouched), converted when opened for writing, and reads the same
    /// relationships each way.
    #[test]
    fn a_format_1_store_is_read_as_it_is_and_converted_on_a_writable_open() {
        use crate::{Direction, GraphRead, Store};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.og");
        let before = {
            let store = Store::create(&path).unwrap();
            store
                .write(|tx| {
                    let ids: Vec<u64> = (0..300)
                        .map(|i| tx.create_node_named(&["N"], &[("i", i.into())]).unwrap())
                        .collect();
                    for (k, &a) in ids.iter().enumerate() {
                        // a hub with more ends than a chunk holds, a self-loop, two types
                        tx.create_rel_named(ids[0], "HUB", a, &[])?;
                        tx.create_rel_named(a, "NEXT", ids[(k + 1) % ids.len()], &[])?;
                    }
                    tx.create_rel_named(ids[5], "NEXT", ids[5], &[])?;
                    Ok(())
                })
                .unwrap();
            let r = store.read().unwrap();
            (0..300u64)
                .map(|n| r.neighbours(n, Direction::Both, None).unwrap())
                .collect::<Vec<_>>()
        };
        {
            // rewrite the adjacency as format 1 did, with redb directly
            let db = redb::Database::open(&path).unwrap();
            let w = db.begin_write().unwrap();
            let rows: Vec<AdjRow> = {
                let t = w.open_table(ADJ).unwrap();
                Rows::new(&t).unwrap().map(Result::unwrap).collect()
            };
            assert_eq!(rows.len(), 2 * 601);
            w.delete_table(ADJ).unwrap();
            {
                let mut old = w.open_table(ADJ_V1).unwrap();
                for (k, v) in &rows {
                    old.insert(k, v).unwrap();
                }
                let mut meta = w.open_table(crate::layout::META).unwrap();
                meta.insert(crate::layout::K_VERSION, 1u32.to_le_bytes().as_slice())
                    .unwrap();
            }
            w.commit().unwrap();
        }
        // read-only: read as it is, the file not written
        let bytes = std::fs::read(&path).unwrap();
        {
            let store = Store::open_read_only(&path).unwrap();
            assert_eq!(store.format_version(), 1);
            assert_eq!(store.converted_from(), None);
            let r = store.read().unwrap();
            for (n, want) in before.iter().enumerate() {
                assert_eq!(
                    &r.neighbours(n as u64, Direction::Both, None).unwrap(),
                    want
                );
            }
            assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
        }
        assert!(
            std::fs::read(&path).unwrap() == bytes,
            "a read-only open wrote the file"
        );
        // writable: converted
        let store = Store::open(&path).unwrap();
        assert_eq!(store.converted_from(), Some(1));
        assert_eq!(store.format_version(), 2);
        assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
        let r = store.read().unwrap();
        for (n, want) in before.iter().enumerate() {
            assert_eq!(
                &r.neighbours(n as u64, Direction::Both, None).unwrap(),
                want
            );
        }
        drop(r);
        drop(store);
        // converted once
        let again = Store::open(&path).unwrap();
        assert_eq!(again.converted_from(), None);
        drop(again);
        assert_eq!(Store::open_read_only(&path).unwrap().format_version(), 2);
    }

    #[test]
    fn a_damaged_chunk_is_an_error() {
        let key = (7, 1, 40);
        let good = encode(&[(40, 2, 9), (45, 1, 300)]);
        let mut out = Vec::new();
        decode(key, &good, &mut out).unwrap();
        assert_eq!(out, vec![(40, 2, 9), (45, 1, 300)]);
        for bad in [
            &good[..good.len() - 1],
            &[][..],
            &[1, 0, 0][..],          // the first entry is not at the key's id
            &[0, 0, 0, 0, 0, 0][..], // a repeated id
            &[0xff; 12][..],
        ] {
            let e = decode(key, bad, &mut Vec::new()).unwrap_err();
            assert!(
                e.to_string().contains("node 7 (in) at relationship 40"),
                "{e}"
            );
        }
    }

    #[test]
    fn bulk_rows_fill_chunks_to_the_cap() {
        with_table(|t| {
            let mut rows: Vec<AdjRow> = (0..1000u64)
                .map(|r| ((5, 0, (r % 2) as u32, r), r + 1))
                .collect();
            insert_many(t, &mut rows).unwrap();
            assert_eq!(t.len().unwrap() as usize, 1000usize.div_ceil(CHUNK_MAX));
            // appended later, after the last chunk
            let mut more: Vec<AdjRow> = (1000..1010u64).map(|r| ((5, 0, 0, r), 1)).collect();
            insert_many(t, &mut more).unwrap();
            assert_eq!(read(t, 5, 0, None).unwrap().len(), 1010);
            assert_eq!(read(t, 5, 0, Some(1)).unwrap().len(), 500);
        });
    }
}
