//! Label membership for a read-only statement without decoding node records.
//!
//! A pattern checks its node labels once per candidate, and the store answers "does node
//! `id` carry label `l`" by reading and decoding the node's whole record. For the first
//! [`SET_AFTER`] checks of a label that is what happens (an anchored pattern checks a few
//! nodes and must stay cheap); after that the label's nodes are read once from the label
//! index into an [`IdSet`], and every later check is a bit test. Only read-only statements
//! use it: a writing statement may change labels while it runs.

use std::cell::RefCell;
use std::rc::Rc;

use crate::Result;

/// Checks of one label answered from node records before its set is built.
pub(crate) const SET_AFTER: u32 = 2048;

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
    pub(crate) fn new(ids: Vec<u64>) -> IdSet {
        let max = ids.last().copied().unwrap_or(0);
        // a bitmap costs max/8 bytes, the list 8 bytes a member: take the bitmap while it is
        // at most twice the list's size
        let words = max / 64 + 1;
        if words <= 2 * ids.len() as u64 + 16 {
            let mut bits = vec![0u64; words as usize];
            for id in ids {
                bits[(id / 64) as usize] |= 1 << (id % 64);
            }
            IdSet::Bits(bits)
        } else {
            IdSet::Sorted(ids)
        }
    }

    pub(crate) fn contains(&self, id: u64) -> bool {
        match self {
            IdSet::Bits(b) => b
                .get((id / 64) as usize)
                .is_some_and(|w| w & (1 << (id % 64)) != 0),
            IdSet::Sorted(v) => v.binary_search(&id).is_ok(),
        }
    }
}

/// One label's state: its members once built, else the checks so far.
type Members = Result<Rc<IdSet>, u32>;

/// Per label id, its [`Members`] (a statement names a few labels, so a list beats a hash map).
#[derive(Debug, Default)]
pub(crate) struct LabelSets(RefCell<Vec<(u32, Members)>>);

impl LabelSets {
    /// The members of `label` if its set is built or due (this check is past
    /// [`SET_AFTER`]); `None` means: answer this check from the node record. `scan` lists the
    /// label's nodes ascending.
    pub(crate) fn members(
        &self,
        label: u32,
        scan: impl FnOnce() -> Result<Vec<u64>>,
    ) -> Result<Option<Rc<IdSet>>> {
        let mut m = self.0.borrow_mut();
        let i = match m.iter().position(|(l, _)| *l == label) {
            Some(i) => i,
            None => {
                m.push((label, Err(0)));
                m.len() - 1
            }
        };
        let e = &mut m[i].1;
        match e {
            Ok(set) => Ok(Some(set.clone())),
            Err(n) if *n < SET_AFTER => {
                *n += 1;
                Ok(None)
            }
            Err(_) => {
                let set = Rc::new(IdSet::new(scan()?));
                *e = Ok(set.clone());
                Ok(Some(set))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
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
            let set = IdSet::new(ids.clone());
            if sparse && ids.len() > 1 {
                prop_assert!(matches!(set, IdSet::Sorted(_)));
            }
            for p in probes.iter().copied().chain(ids.iter().copied()).chain([u64::MAX]) {
                prop_assert_eq!(set.contains(p), ids.binary_search(&p).is_ok(), "id {}", p);
            }
        }
    }

    #[test]
    fn a_label_set_is_built_only_after_many_checks() {
        let sets = LabelSets::default();
        let mut scans = 0;
        for _ in 0..SET_AFTER {
            assert!(sets.members(3, || unreachable!()).unwrap().is_none());
        }
        let s = sets
            .members(3, || {
                scans += 1;
                Ok(vec![1, 5])
            })
            .unwrap()
            .unwrap();
        assert!(s.contains(5) && !s.contains(4));
        assert!(sets.members(3, || unreachable!()).unwrap().is_some());
        assert_eq!(scans, 1);
        assert!(sets.members(4, || unreachable!()).unwrap().is_none());
    }
}
