//! In-memory secondary indexes (spatial R-tree, vector top-k, BM25 text) kept as a stack of
//! immutable layers, like an LSM tree.
//!
//! The data in redb is the source of truth; these structures are rebuilt from it on open.
//! A committed snapshot is a list of `Arc` layers, so a reader keeps exactly the index state
//! that matches its redb snapshot while a writer commits new layers. A write transaction
//! records its changes in a private [`Pending`] overlay, visible only to itself; commit
//! freezes it into a new top layer and merges layers of similar size (a binary counter), so
//! there are O(log n) layers and each entry is rewritten O(log n) times.

pub(crate) mod spatial;
pub(crate) mod text;
pub(crate) mod vector;

use std::collections::{BTreeMap, HashSet};
use std::sync::Arc;

/// One layer's data structure.
pub(crate) trait LayerData: Send + Sync + Sized + 'static {
    /// What is stored per node.
    type Entry: Clone + Send + Sync + PartialEq + std::fmt::Debug;
    /// Build parameters (dimension and the like).
    type Params: Clone + Send + Sync + std::fmt::Debug;
    fn build(params: &Self::Params, entries: Vec<(u64, Self::Entry)>) -> Self;
    fn entries(&self) -> Vec<(u64, Self::Entry)>;
    fn len(&self) -> usize;
}

/// A frozen layer and the nodes whose entries in lower layers it hides.
#[derive(Debug)]
pub(crate) struct Frozen<L> {
    pub(crate) data: L,
    pub(crate) hidden: HashSet<u64>,
}

/// A transaction's private changes to one index.
#[derive(Debug)]
pub(crate) struct Pending<E> {
    pub(crate) entries: BTreeMap<u64, E>,
    pub(crate) hidden: HashSet<u64>,
}

impl<E> Default for Pending<E> {
    fn default() -> Self {
        Pending {
            entries: BTreeMap::new(),
            hidden: HashSet::new(),
        }
    }
}

impl<E> Pending<E> {
    /// Replaces whatever the node had in this index.
    pub(crate) fn set(&mut self, node: u64, entry: Option<E>) {
        self.hidden.insert(node);
        self.entries.remove(&node);
        if let Some(e) = entry {
            self.entries.insert(node, e);
        }
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.entries.is_empty() && self.hidden.is_empty()
    }
}

/// Which entries of one frozen layer are still visible.
pub(crate) struct Visibility<'a> {
    above: Vec<&'a HashSet<u64>>,
}

impl Visibility<'_> {
    #[inline]
    pub(crate) fn visible(&self, node: u64) -> bool {
        !self.above.iter().any(|h| h.contains(&node))
    }

    /// True when nothing above can hide anything (the common case: a fast path).
    pub(crate) fn all_visible(&self) -> bool {
        self.above.iter().all(|h| h.is_empty())
    }

    pub(crate) fn hidden_sets(&self) -> &[&HashSet<u64>] {
        &self.above
    }
}

/// A committed index: layers bottom to top.
#[derive(Debug)]
pub(crate) struct Stack<L: LayerData> {
    pub(crate) params: L::Params,
    pub(crate) layers: Vec<Arc<Frozen<L>>>,
}

impl<L: LayerData> Clone for Stack<L> {
    fn clone(&self) -> Self {
        Stack {
            params: self.params.clone(),
            layers: self.layers.clone(),
        }
    }
}

impl<L: LayerData> Stack<L> {
    pub(crate) fn new(params: L::Params, entries: Vec<(u64, L::Entry)>) -> Self {
        let layers = if entries.is_empty() {
            Vec::new()
        } else {
            vec![Arc::new(Frozen {
                data: L::build(&params, entries),
                hidden: HashSet::new(),
            })]
        };
        Stack { params, layers }
    }

    /// Each frozen layer with its visibility under `pending`.
    pub(crate) fn view<'a>(
        &'a self,
        pending: Option<&'a Pending<L::Entry>>,
    ) -> Vec<(&'a L, Visibility<'a>)> {
        let n = self.layers.len();
        (0..n)
            .map(|i| {
                let mut above: Vec<&HashSet<u64>> = self.layers[i + 1..]
                    .iter()
                    .map(|l| &l.hidden)
                    .filter(|h| !h.is_empty())
                    .collect();
                if let Some(p) = pending.filter(|p| !p.hidden.is_empty()) {
                    above.push(&p.hidden);
                }
                (&self.layers[i].data, Visibility { above })
            })
            .collect()
    }

    /// The stack after committing `pending` on top of it.
    pub(crate) fn commit(&self, pending: Pending<L::Entry>) -> Self {
        if pending.is_empty() {
            return self.clone();
        }
        let mut layers = self.layers.clone();
        layers.push(Arc::new(Frozen {
            data: L::build(&self.params, pending.entries.into_iter().collect()),
            hidden: pending.hidden,
        }));
        let cost = |f: &Frozen<L>| f.data.len() + f.hidden.len();
        while layers.len() >= 2 {
            let n = layers.len();
            if cost(&layers[n - 2]) > 2 * cost(&layers[n - 1]) && n <= 16 {
                break;
            }
            let upper = layers.pop().expect("len >= 2");
            let lower = layers.pop().expect("len >= 2");
            let is_base = layers.is_empty();
            layers.push(Arc::new(merge(&self.params, &lower, &upper, is_base)));
        }
        if layers.len() == 1 && layers[0].data.len() == 0 {
            layers.clear();
        }
        Stack {
            params: self.params.clone(),
            layers,
        }
    }

    /// Number of visible entries.
    #[cfg(test)]
    pub(crate) fn count(&self) -> usize {
        self.view(None)
            .iter()
            .map(|(l, vis)| {
                if vis.all_visible() {
                    l.len()
                } else {
                    l.entries().iter().filter(|(n, _)| vis.visible(*n)).count()
                }
            })
            .sum()
    }

    /// All visible entries, sorted by node (used by integrity checks and tests).
    pub(crate) fn visible_entries(
        &self,
        pending: Option<&Pending<L::Entry>>,
    ) -> Vec<(u64, L::Entry)> {
        let mut out: Vec<(u64, L::Entry)> = Vec::new();
        for (l, vis) in self.view(pending) {
            out.extend(l.entries().into_iter().filter(|(n, _)| vis.visible(*n)));
        }
        if let Some(p) = pending {
            out.extend(p.entries.iter().map(|(n, e)| (*n, e.clone())));
        }
        out.sort_by_key(|(n, _)| *n);
        out
    }
}

fn merge<L: LayerData>(
    params: &L::Params,
    lower: &Frozen<L>,
    upper: &Frozen<L>,
    is_base: bool,
) -> Frozen<L> {
    let mut entries: Vec<(u64, L::Entry)> = lower
        .data
        .entries()
        .into_iter()
        .filter(|(n, _)| !upper.hidden.contains(n))
        .collect();
    entries.extend(upper.data.entries());
    let hidden = if is_base {
        HashSet::new()
    } else {
        lower.hidden.union(&upper.hidden).copied().collect()
    };
    Frozen {
        data: L::build(params, entries),
        hidden,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A trivial layer to test the stack mechanics against a BTreeMap.
    #[derive(Debug)]
    struct Plain(Vec<(u64, i32)>);
    impl LayerData for Plain {
        type Entry = i32;
        type Params = ();
        fn build(_: &(), mut entries: Vec<(u64, i32)>) -> Self {
            entries.sort();
            Plain(entries)
        }
        fn entries(&self) -> Vec<(u64, i32)> {
            self.0.clone()
        }
        fn len(&self) -> usize {
            self.0.len()
        }
    }

    #[test]
    fn stack_matches_reference_under_random_commits() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut stack: Stack<Plain> = Stack::new((), vec![]);
        let mut model = BTreeMap::new();
        for round in 0..300 {
            let mut p = Pending::default();
            let mut next = model.clone();
            for _ in 0..rng.random_range(0..6) {
                let node = rng.random_range(0..40u64);
                if rng.random_bool(0.3) {
                    p.set(node, None);
                    next.remove(&node);
                } else {
                    let v = rng.random_range(0..1000);
                    p.set(node, Some(v));
                    next.insert(node, v);
                }
            }
            // the transaction sees its own writes
            let seen: BTreeMap<u64, i32> = stack.visible_entries(Some(&p)).into_iter().collect();
            assert_eq!(seen, next, "round {round}");
            if rng.random_bool(0.2) {
                continue; // abort: the committed state stays as it was
            }
            stack = stack.commit(p);
            model = next;
            let got: BTreeMap<u64, i32> = stack.visible_entries(None).into_iter().collect();
            assert_eq!(got, model, "round {round}");
            assert_eq!(stack.count(), model.len());
            assert!(stack.layers.len() <= 17);
        }
    }
}
