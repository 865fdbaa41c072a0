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

/// Ground-plane distance from `g` to the footprint of box `b` (0 inside); `axes` are the two
/// world axes that span the ground, in the order of `g`'s coordinates.
pub(crate) fn ground_dist(g: [f64; 2], axes: [usize; 2], b: &Aabb) -> f64 {
    let gap = |c: f64, lo: f64, hi: f64| (lo - c).max(c - hi).max(0.0);
    let d0 = gap(g[0], b.0[axes[0]], b.1[axes[0]]);
    let d1 = gap(g[1], b.0[axes[1]], b.1[axes[1]]);
    d0.hypot(d1)
}

/// Nodes whose footprint lies within `radius_m` of ground point `g` on the ground plane
/// spanned by `axes` (height ignored), with ground distances, nearest first (ties by id).
pub(crate) fn within_ground(
    stack: &Stack<SpatialLayer>,
    pending: Option<&Pending<Aabb>>,
    g: [f64; 2],
    axes: [usize; 2],
    radius_m: f64,
) -> Vec<(u64, f64)> {
    // every height: a column over the disc's square, then the exact footprint distance
    let mut lo = [f64::MIN; 3];
    let mut hi = [f64::MAX; 3];
    for (i, &a) in axes.iter().enumerate() {
        lo[a] = g[i] - radius_m;
        hi[a] = g[i] + radius_m;
    }
    let env = AABB::from_corners(lo, hi);
    let mut out = Vec::new();
    let mut keep = |n: u64, b: &Aabb| {
        let d = ground_dist(g, axes, b);
        if d <= radius_m {
            out.push((n, d));
        }
    };
    for (layer, vis) in stack.view(pending) {
        for item in layer.tree.locate_in_envelope_intersecting(env) {
            if vis.visible(item.data) {
                let e = item.geom().envelope();
                keep(item.data, &(e.lower(), e.upper()));
            }
        }
    }
    if let Some(p) = pending {
        for (n, b) in &p.entries {
            keep(*n, b);
        }
    }
    sort_by_distance(&mut out);
    out
}

/// The `k` nodes whose footprints are nearest ground point `g` (see [`within_ground`]),
/// nearest first: the radius doubles from 16 m until `k` are within it or it covers every
/// entry.
pub(crate) fn nearest_ground(
    stack: &Stack<SpatialLayer>,
    pending: Option<&Pending<Aabb>>,
    g: [f64; 2],
    axes: [usize; 2],
    k: usize,
) -> Vec<(u64, f64)> {
    if k == 0 {
        return Vec::new();
    }
    // the farthest any entry can be: from g to the far corner of all boxes
    let mut reach: f64 = 0.0;
    let mut far = |b: &Aabb| {
        for (i, &a) in axes.iter().enumerate() {
            reach = reach.max((g[i] - b.0[a]).abs()).max((g[i] - b.1[a]).abs());
        }
    };
    for (layer, _) in stack.view(pending) {
        if layer.tree.size() > 0 {
            let e = layer.tree.root().envelope();
            far(&(e.lower(), e.upper()));
        }
    }
    if let Some(p) = pending {
        p.entries.iter().for_each(|(_, b)| far(b));
    }
    let reach = reach * std::f64::consts::SQRT_2;
    let mut r: f64 = 16.0;
    loop {
        let mut out = within_ground(stack, pending, g, axes, r);
        if out.len() >= k || r >= reach || !r.is_finite() {
            out.truncate(k);
            return out;
        }
        r *= 2.0;
    }
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

    proptest::proptest! {
        /// The ground queries against a brute-force scan, over boxes in several committed
        /// layers and a pending one, at any height (height must not matter).
        #[test]
        fn ground_queries_agree_with_brute_force(
            boxes in proptest::collection::vec(
                ((-50.0f64..50.0, -30.0f64..30.0, -50.0f64..50.0), (0.0f64..8.0, 0.0f64..20.0, 0.0f64..8.0)),
                1..60,
            ),
            g in (-60.0f64..60.0, -60.0f64..60.0),
            radius in 0.0f64..40.0,
            k in 0usize..12,
            kitti in proptest::bool::ANY,
        ) {
            let axes = if kitti { [0, 2] } else { [0, 1] };
            let g = [g.0, g.1];
            let mut stack: Stack<SpatialLayer> = Stack::new((), vec![]);
            let mut all = Vec::new();
            let mut pending = Pending::default();
            for (n, ((x, y, z), (dx, dy, dz))) in boxes.iter().enumerate() {
                let b = ([*x, *y, *z], [x + dx, y + dy, z + dz]);
                all.push((n as u64, b));
                if n % 3 == 2 {
                    pending.set(n as u64, Some(b));
                } else {
                    let mut p = Pending::default();
                    p.set(n as u64, Some(b));
                    stack = stack.commit(p);
                }
            }
            let mut want: Vec<(u64, f64)> = all
                .iter()
                .map(|(n, b)| (*n, ground_dist(g, axes, b)))
                .collect();
            sort_by_distance(&mut want);
            let got = within_ground(&stack, Some(&pending), g, axes, radius);
            let inside: Vec<(u64, f64)> = want.iter().copied().filter(|x| x.1 <= radius).collect();
            proptest::prop_assert_eq!(got.len(), inside.len());
            for (a, b) in got.iter().zip(&inside) {
                proptest::prop_assert_eq!(a.0, b.0);
                proptest::prop_assert!((a.1 - b.1).abs() < 1e-9);
            }
            let near = nearest_ground(&stack, Some(&pending), g, axes, k);
            let top: Vec<u64> = want.iter().take(k).map(|x| x.0).collect();
            proptest::prop_assert_eq!(near.iter().map(|x| x.0).collect::<Vec<_>>(), top);
        }
    }

    #[test]
    fn ground_distance_ignores_height_and_is_zero_over_the_footprint() {
        let b = ([0.0, -10.0, 0.0], [2.0, -8.0, 4.0]);
        // kitti_cam: ground is x, z; a point far above or below the box is over it
        assert!(ground_dist([1.0, 2.0], [0, 2], &b).abs() < 1e-12);
        assert!((ground_dist([5.0, 8.0], [0, 2], &b) - 5.0).abs() < 1e-12);
        // enu: ground is x, y
        assert!((ground_dist([1.0, -5.0], [0, 1], &b) - 3.0).abs() < 1e-12);
    }
}
