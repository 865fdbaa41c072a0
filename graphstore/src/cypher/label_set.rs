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

pub(crate) use crate::columns::IdSet;

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
                let set = Rc::new(IdSet::new(&scan()?));
                *e = Ok(set.clone());
                Ok(Some(set))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
