//! R-tree layers (rstar) over node boxes; points are degenerate boxes.

use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{AABB, PointDistance, RTree, RTreeObject};

use super::{LayerData, Pending, Stack};

/// An axis-aligned box `(min, max)` in metres.
pub(crate) type Aabb = ([f64; 3], [f64; 3]);

type Item = GeomWithData<Rectangle<[f64; 3]>, u64>;

#[derive(Debug)]
pub(crate) struct SpatialLayer {
    tree: RTree<Item>,
}

impl LayerData for SpatialLayer {
    type Entry = Aabb;
    type Params = ();

    fn build(_: &(), entries: Vec<(u64, Aabb)>) -> Self {
        let items = entries
            .into_iter()
            .map(|(n, (lo, hi))| GeomWithData::new(Rectangle::from_corners(lo, hi), n))
            .collect();
        SpatialLayer {
            tree: RTree::bulk_load(items),
        }
    }

    fn entries(&self) -> Vec<(u64, Aabb)> {
        self.tree
            .iter()
            .map(|g| {
                let env = g.geom().envelope();
                (g.data, (env.lower(), env.upper()))
            })
            .collect()
    }

    fn len(&self) -> usize {
        self.tree.size()
    }
}

/// Squared distance from a point to a box (0 inside).
pub(crate) fn dist2_point_box(p: [f64; 3], b: &Aabb) -> f64 {
    (0..3)
        .map(|i| {
            let d = if p[i] < b.0[i] {
                b.0[i] - p[i]
            } else if p[i] > b.1[i] {
                p[i] - b.1[i]
            } else {
                0.0
            };
            d * d
        })
        .sum()
}

fn boxes_intersect(a: &Aabb, b: &Aabb) -> bool {
    (0..3).all(|i| a.0[i] <= b.1[i] && b.0[i] <= a.1[i])
}

/// Nodes whose box intersects `query`, sorted by id.
pub(crate) fn in_box(
    stack: &Stack<SpatialLayer>,
    pending: Option<&Pending<Aabb>>,
    query: Aabb,
) -> Vec<u64> {
    let env = AABB::from_corners(query.0, query.1);
    let mut out = Vec::new();
    for (layer, vis) in stack.view(pending) {
        out.extend(
            layer
                .tree
                .locate_in_envelope_intersecting(env)
                .map(|g| g.data)
                .filter(|n| vis.visible(*n)),
        );
    }
    if let Some(p) = pending {
        out.extend(
            p.entries
                .iter()
                .filter(|(_, b)| boxes_intersect(b, &query))
                .map(|(n, _)| *n),
        );
    }
    out.sort_unstable();
    out
}

/// Nodes whose box lies within `radius_m` of `center`, with distances, nearest first
/// (ties by id).
pub(crate) fn within(
    stack: &Stack<SpatialLayer>,
    pending: Option<&Pending<Aabb>>,
    center: [f64; 3],
    radius_m: f64,
) -> Vec<(u64, f64)> {
    let r2 = radius_m * radius_m;
    let mut out = Vec::new();
    for (layer, vis) in stack.view(pending) {
        out.extend(
            layer
                .tree
                .locate_within_distance(center, r2)
                .filter(|g| vis.visible(g.data))
                .map(|g| (g.data, g.geom().distance_2(&center).sqrt())),
        );
    }
    if let Some(p) = pending {
        out.extend(
            p.entries
                .iter()
                .map(|(n, b)| (*n, dist2_point_box(center, b)))
                .filter(|(_, d2)| *d2 <= r2)
                .map(|(n, d2)| (n, d2.sqrt())),
        );
    }
    sort_by_distance(&mut out);
    out
}

/// The `k` nodes nearest to `center` (distance to their box), nearest first.
pub(crate) fn nearest(
    stack: &Stack<SpatialLayer>,
    pending: Option<&Pending<Aabb>>,
    center: [f64; 3],
    k: usize,
) -> Vec<(u64, f64)> {
    let mut out = Vec::new();
    for (layer, vis) in stack.view(pending) {
        out.extend(
            layer
                .tree
                .nearest_neighbor_iter_with_distance_2(center)
                .filter(|(g, _)| vis.visible(g.data))
                .take(k)
                .map(|(g, d2)| (g.data, d2.sqrt())),
        );
    }
    if let Some(p) = pending {
        out.extend(
            p.entries
                .iter()
                .map(|(n, b)| (*n, dist2_point_box(center, b).sqrt())),
        );
    }
    sort_by_distance(&mut out);
    out.truncate(k);
    out
}

fn sort_by_distance(v: &mut [(u64, f64)]) {
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn queries_agree_with_brute_force_across_layers() {
        let mut stack: Stack<SpatialLayer> = Stack::new((), vec![]);
        let mut all = std::collections::BTreeMap::new();
        for batch in 0..5u64 {
            let mut p = Pending::default();
            for i in 0..50u64 {
                let n = batch * 50 + i;
                let c = [(n % 17) as f64 * 3.0, (n % 11) as f64 * 2.0, 0.0];
                let b = (c, [c[0] + 1.0, c[1] + 0.5, 1.0]);
                p.set(n, Some(b));
                all.insert(n, b);
            }
            if batch == 3 {
                p.set(7, None);
                all.remove(&7);
            }
            stack = stack.commit(p);
        }
        let center = [10.0, 5.0, 0.5];
        let got = within(&stack, None, center, 6.0);
        let mut want: Vec<(u64, f64)> = all
            .iter()
            .map(|(n, b)| (*n, dist2_point_box(center, b).sqrt()))
            .filter(|(_, d)| *d <= 6.0)
            .collect();
        sort_by_distance(&mut want);
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(g.0, w.0);
            assert!((g.1 - w.1).abs() < 1e-9);
        }
        let k = nearest(&stack, None, center, 5);
        assert_eq!(
            k.iter().map(|x| x.0).collect::<Vec<_>>(),
            want.iter().take(5).map(|x| x.0).collect::<Vec<_>>()
        );
        let bx = in_box(&stack, None, ([0.0, 0.0, 0.0], [4.0, 4.0, 0.0]));
        let want_box: Vec<u64> = all
            .iter()
            .filter(|(_, b)| boxes_intersect(b, &([0.0, 0.0, 0.0], [4.0, 4.0, 0.0])))
            .map(|(n, _)| *n)
            .collect();
        assert_eq!(bx, want_box);
    }
}
