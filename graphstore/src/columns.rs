//! Columnar copies of what whole-graph reads touch, one commit at a time: each label's nodes
//! (ascending, and as a membership set) and one property of every node or relationship as a
//! typed column indexed by id.
//!
//! A record holds all of a node's properties encoded together, so a scan that reads
//! `n.class` and `n.score` of 200,000 nodes decodes 200,000 records. A column holds one
//! property of every record, typed (integers, floats, dictionary-coded strings, or any
//! values), so the same scan is two slice lookups per node. Columns are built on demand by
//! [`crate::hot::Hot`] (once reads of that property in one commit pass the same threshold as
//! the record copies) and belong to the commit, like the other hot copies: never stale, shared
//! by every reader of the commit, freed with it. This is the layout column stores use (Kùzu,
//! DuckDB); here it is a cache over the row-oriented redb tables, not the storage format.

use crate::value::Value;

/// A set of node ids: a bitmap when the ids are dense enough, else a sorted list.
#[derive(Debug)]
pub(crate) enum IdSet {
    /// Bit `id` of the words is set for each member.
    Bits(Vec<u64>),
    /// Members ascending.
    Sorted(Vec<u64>),
}

impl IdSet {
    /// The set of `ids` (ascending, as the label index gives them).
    pub(crate) fn new(ids: &[u64]) -> IdSet {
        let max = ids.last().copied().unwrap_or(0);
        // a bitmap costs max/8 bytes, the list 8 bytes a member: take the bitmap while it is
        // at most twice the list's size
        let words = max / 64 + 1;
        if words <= 2 * ids.len() as u64 + 16 {
            let mut bits = vec![0u64; words as usize];
            for &id in ids {
                bits[(id / 64) as usize] |= 1 << (id % 64);
            }
            IdSet::Bits(bits)
        } else {
            IdSet::Sorted(ids.to_vec())
        }
    }

    /// Whether `id` is a member.
    #[inline]
    pub(crate) fn contains(&self, id: u64) -> bool {
        match self {
            IdSet::Bits(b) => b
                .get((id / 64) as usize)
                .is_some_and(|w| w & (1 << (id % 64)) != 0),
            IdSet::Sorted(v) => v.binary_search(&id).is_ok(),
        }
    }
}

/// The nodes of one label in one commit.
#[derive(Debug)]
pub(crate) struct LabelMembers {
    /// Ascending.
    pub(crate) ids: Vec<u64>,
    /// The same ids as a set.
    pub(crate) set: IdSet,
}

impl LabelMembers {
    pub(crate) fn new(ids: Vec<u64>) -> LabelMembers {
        let set = IdSet::new(&ids);
        LabelMembers { ids, set }
    }

    /// These members with each node of `changed` (ascending) in or out as `member` says now.
    pub(crate) fn patched(
        &self,
        changed: &[u64],
        member: impl Fn(u64) -> crate::Result<bool>,
    ) -> crate::Result<LabelMembers> {
        let mut ids = Vec::with_capacity(self.ids.len() + changed.len());
        let mut kept = self.ids.iter().copied().peekable();
        for &c in changed {
            while let Some(id) = kept.next_if(|id| *id < c) {
                ids.push(id);
            }
            kept.next_if(|id| *id == c);
            if member(c)? {
                ids.push(c);
            }
        }
        ids.extend(kept);
        Ok(LabelMembers::new(ids))
    }
}

/// Most ids a column covers (it is indexed by id: larger or sparser tables are not copied).
pub(crate) const COLUMN_MAX_IDS: u64 = 64 << 20;

/// One property of every node (or every relationship) of a commit, indexed by id.
#[derive(Debug)]
pub(crate) enum Column {
    /// Every present value is an integer; bit `id` of `present` says whether `id` has one.
    Int { vals: Vec<i64>, present: Vec<u64> },
    /// Every present value is a float.
    Float { vals: Vec<f64>, present: Vec<u64> },
    /// Every present value is a string: `codes[id]` indexes `dict` (`u32::MAX`: absent).
    Str { codes: Vec<u32>, dict: Vec<String> },
    /// Values of several types, lists, points...: `Value::Null` where absent.
    Any(Vec<Value>),
}

/// One entry of a [`Column`], borrowed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Cell<'a> {
    /// The record has no such property (or there is no such record).
    Absent,
    Int(i64),
    Float(f64),
    Str(&'a str),
    /// Any other value.
    Other(&'a Value),
}

#[inline]
fn bit(bits: &[u64], i: usize) -> bool {
    bits.get(i / 64).is_some_and(|w| w & (1 << (i % 64)) != 0)
}

impl Column {
    /// The column of `vals` (index = id; `None` where the record lacks the property).
    pub(crate) fn from_values(vals: Vec<Option<Value>>) -> Column {
        let present_bits = |vals: &[Option<Value>]| {
            let mut bits = vec![0u64; vals.len().div_ceil(64)];
            for (i, v) in vals.iter().enumerate() {
                if v.is_some() {
                    bits[i / 64] |= 1 << (i % 64);
                }
            }
            bits
        };
        let all = |f: fn(&Value) -> bool| vals.iter().flatten().all(f);
        if all(|v| matches!(v, Value::Int(_))) {
            let present = present_bits(&vals);
            let vals = vals
                .iter()
                .map(|v| match v {
                    Some(Value::Int(i)) => *i,
                    _ => 0,
                })
                .collect();
            return Column::Int { vals, present };
        }
        if all(|v| matches!(v, Value::Float(_))) {
            let present = present_bits(&vals);
            let vals = vals
                .iter()
                .map(|v| match v {
                    Some(Value::Float(f)) => *f,
                    _ => 0.0,
                })
                .collect();
            return Column::Float { vals, present };
        }
        if all(|v| matches!(v, Value::String(_))) {
            let mut dict: Vec<String> = Vec::new();
            let mut index: std::collections::HashMap<String, u32> = Default::default();
            let mut codes = Vec::with_capacity(vals.len());
            for v in vals {
                codes.push(match v {
                    Some(Value::String(s)) => match index.get(&s) {
                        Some(c) => *c,
                        None => {
                            let c = dict.len() as u32;
                            dict.push(s.clone());
                            index.insert(s, c);
                            c
                        }
                    },
                    _ => u32::MAX,
                });
            }
            return Column::Str { codes, dict };
        }
        Column::Any(vals.into_iter().map(|v| v.unwrap_or(Value::Null)).collect())
    }

    /// This column with the entries of `changed` (ascending) set to `value`'s (`None`: no such
    /// record or property); equal, entry by entry, to a column read afresh where those are
    /// the only changes. `None` past [`COLUMN_MAX_IDS`].
    pub(crate) fn patched(
        &self,
        changed: &[u64],
        value: impl Fn(u64) -> crate::Result<Option<Value>>,
    ) -> crate::Result<Option<Column>> {
        let len = match self {
            Column::Int { vals, .. } => vals.len(),
            Column::Float { vals, .. } => vals.len(),
            Column::Str { codes, .. } => codes.len(),
            Column::Any(vals) => vals.len(),
        };
        let top = changed.last().map_or(0, |&c| c + 1).max(len as u64);
        if top > COLUMN_MAX_IDS {
            return Ok(None);
        }
        let mut vals: Vec<Option<Value>> = (0..len as u64)
            .map(|id| match self.get(id) {
                Cell::Absent => None,
                Cell::Int(v) => Some(Value::Int(v)),
                Cell::Float(v) => Some(Value::Float(v)),
                Cell::Str(v) => Some(Value::String(v.to_string())),
                Cell::Other(v) => Some(v.clone()),
            })
            .collect();
        vals.resize(top as usize, None);
        for &c in changed {
            vals[c as usize] = value(c)?;
        }
        Ok(Some(Column::from_values(vals)))
    }

    /// The column whose entry `i` is this column's entry `ids[i]` (the same kind of column;
    /// a string column keeps its dictionary): a relationship property in the order of the
    /// adjacency rows, read sequentially by a traversal instead of by random relationship id.
    pub(crate) fn gather(&self, ids: &[u64]) -> Column {
        let present_of = |present: &[u64]| {
            let mut bits = vec![0u64; ids.len().div_ceil(64)];
            for (i, &id) in ids.iter().enumerate() {
                if bit(present, id as usize) {
                    bits[i / 64] |= 1 << (i % 64);
                }
            }
            bits
        };
        // entry `ids[i]` of `vals` at `i`, `absent` past its end
        fn pick<T: Clone>(vals: &[T], ids: &[u64], absent: T) -> Vec<T> {
            ids.iter()
                .map(|&id| {
                    vals.get(id as usize)
                        .cloned()
                        .unwrap_or_else(|| absent.clone())
                })
                .collect()
        }
        match self {
            Column::Int { vals, present } => Column::Int {
                vals: pick(vals, ids, 0),
                present: present_of(present),
            },
            Column::Float { vals, present } => Column::Float {
                vals: pick(vals, ids, 0.0),
                present: present_of(present),
            },
            Column::Str { codes, dict } => Column::Str {
                codes: pick(codes, ids, u32::MAX),
                dict: dict.clone(),
            },
            Column::Any(vals) => Column::Any(pick(vals, ids, Value::Null)),
        }
    }

    /// The dictionary code of `id`'s string in a [`Column::Str`] (None: absent, or not a
    /// string column).
    #[inline]
    pub(crate) fn code(&self, id: u64) -> Option<u32> {
        match self {
            Column::Str { codes, .. } => codes.get(id as usize).copied().filter(|c| *c != u32::MAX),
            _ => None,
        }
    }

    /// The entry of `id`.
    #[inline]
    pub(crate) fn get(&self, id: u64) -> Cell<'_> {
        let i = id as usize;
        match self {
            Column::Int { vals, present } => match vals.get(i) {
                Some(v) if bit(present, i) => Cell::Int(*v),
                _ => Cell::Absent,
            },
            Column::Float { vals, present } => match vals.get(i) {
                Some(v) if bit(present, i) => Cell::Float(*v),
                _ => Cell::Absent,
            },
            Column::Str { codes, dict } => match codes.get(i) {
                Some(&c) if c != u32::MAX => Cell::Str(&dict[c as usize]),
                _ => Cell::Absent,
            },
            Column::Any(vals) => match vals.get(i) {
                None | Some(Value::Null) => Cell::Absent,
                Some(v) => Cell::Other(v),
            },
        }
    }
}

/// Gathers one property of records handed in ascending id order into a column; gives up
/// (`None`) when the ids are too sparse for an id-indexed column or pass
/// [`COLUMN_MAX_IDS`].
#[derive(Debug, Default)]
pub(crate) struct ColumnBuilder {
    vals: Vec<Option<Value>>,
    records: u64,
    failed: bool,
}

impl ColumnBuilder {
    /// Adds record `id`'s value; false once the column is given up.
    pub(crate) fn push(&mut self, id: u64, v: Option<Value>) -> bool {
        self.records += 1;
        let slots = 4 * self.records + 4096;
        if self.failed || id >= slots || id >= COLUMN_MAX_IDS || (id as usize) < self.vals.len() {
            self.failed = true;
            return false;
        }
        self.vals.resize(id as usize, None);
        self.vals.push(v);
        true
    }

    pub(crate) fn finish(self) -> Option<Column> {
        (!self.failed).then(|| Column::from_values(self.vals))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A gathered column reads at `i` what the column reads at `ids[i]`.
        #[test]
        fn a_gathered_column_reads_the_gathered_ids(
            vals in proptest::collection::vec(proptest::option::of(0i64..5), 0..80),
            kind in 0u8..4,
            ids in proptest::collection::vec(0u64..100, 0..120),
        ) {
            let vals: Vec<Option<Value>> = vals
                .into_iter()
                .map(|v| v.map(|v| match kind {
                    0 => Value::Int(v),
                    1 => Value::Float(v as f64 / 2.0),
                    2 => Value::String(format!("s{v}")),
                    _ if v % 2 == 0 => Value::Int(v),
                    _ => Value::String(format!("s{v}")),
                }))
                .collect();
            let col = Column::from_values(vals);
            let g = col.gather(&ids);
            for (i, &id) in ids.iter().enumerate() {
                prop_assert_eq!(g.get(i as u64), col.get(id));
                prop_assert_eq!(g.code(i as u64), col.code(id));
            }
            prop_assert_eq!(g.get(ids.len() as u64), Cell::Absent);
        }

        #[test]
        fn an_id_set_holds_exactly_its_members(
            mut ids in proptest::collection::vec(0u64..5000, 0..300),
            sparse in any::<bool>(),
            probes in proptest::collection::vec(0u64..6000, 0..100),
        ) {
            if sparse {
                for id in &mut ids {
                    *id = id.wrapping_mul(1 << 40);
                }
            }
            ids.sort_unstable();
            ids.dedup();
            let set = IdSet::new(&ids);
            if sparse && ids.len() > 1 {
                prop_assert!(matches!(set, IdSet::Sorted(_)));
            }
            for p in probes.iter().copied().chain(ids.iter().copied()).chain([u64::MAX]) {
                prop_assert_eq!(set.contains(p), ids.binary_search(&p).is_ok(), "id {}", p);
            }
        }

        /// Every id reads back the value it was given, typed as the column's kind, and ids
        /// without a value (or past the end) read as absent.
        #[test]
        fn a_column_reads_back_its_values(
            raw in proptest::collection::btree_map(0u64..400, prop_oneof![
                any::<i64>().prop_map(Value::Int),
                (-1e6f64..1e6).prop_map(Value::Float),
                "[a-c]{0,2}".prop_map(Value::String),
                any::<bool>().prop_map(Value::Bool),
            ], 0..80),
            kind in 0u8..4,
        ) {
            // one kind only, or mixed
            let vals: std::collections::BTreeMap<u64, Value> = raw
                .into_iter()
                .filter(|(_, v)| kind == 3 || matches!((kind, v), (0, Value::Int(_)) | (1, Value::Float(_)) | (2, Value::String(_))))
                .collect();
            let mut b = ColumnBuilder::default();
            for id in 0..400u64 {
                prop_assert!(b.push(id, vals.get(&id).cloned()));
            }
            let col = b.finish().unwrap();
            for id in 0..410u64 {
                let want = vals.get(&id);
                let got = col.get(id);
                match (want, got) {
                    (None, Cell::Absent) => {}
                    (Some(Value::Int(a)), Cell::Int(b)) => prop_assert_eq!(*a, b),
                    (Some(Value::Float(a)), Cell::Float(b)) => prop_assert_eq!(a.to_bits(), b.to_bits()),
                    (Some(Value::String(a)), Cell::Str(b)) => prop_assert_eq!(a.as_str(), b),
                    (Some(v), Cell::Other(w)) => prop_assert_eq!(v, w),
                    (w, g) => prop_assert!(false, "id {id}: want {w:?}, got {g:?}"),
                }
            }
        }
    }

    #[test]
    fn sparse_or_unordered_ids_are_not_made_columns() {
        let mut b = ColumnBuilder::default();
        assert!(!b.push(1 << 40, None));
        assert!(b.finish().is_none());
        let mut b = ColumnBuilder::default();
        assert!(b.push(5, Some(Value::Int(1))));
        assert!(!b.push(3, None));
        assert!(b.finish().is_none());
    }
}
