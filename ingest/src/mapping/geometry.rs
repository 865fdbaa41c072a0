//! Point-set geometry for mapping: voxel down-sampling, 3D DBSCAN, axis-aligned boxes.

/// Integer voxel coordinates of a point.
pub type VoxelKey = [i32; 3];

/// The voxel of `p` for cells of `voxel_m` metres.
pub fn voxel_key(p: [f32; 3], voxel_m: f32) -> VoxelKey {
    p.map(|c| (c / voxel_m).floor() as i32)
}

/// Voxel down-sampling: one point per occupied voxel, the mean of the points in it (Open3D's
/// `voxel_down_sample`). Output is ordered by voxel key, so it does not depend on input order.
pub fn voxel_downsample(points: &[[f32; 3]], voxel_m: f32) -> Vec<[f32; 3]> {
    voxel_downsample_flagged(points, &[], voxel_m).0
}

/// [`voxel_downsample`] of points that each carry a flag (`flags[i]` for `points[i]`; a
/// missing flag is false): a voxel's flag is set when at least half of its points have it.
pub fn voxel_downsample_flagged(
    points: &[[f32; 3]],
    flags: &[bool],
    voxel_m: f32,
) -> (Vec<[f32; 3]>, Vec<bool>) {
    // sorted by voxel, then by input index, so each voxel's points are summed in input order
    let keyed = sorted_by_voxel(points, voxel_m);
    let mut out = Vec::new();
    let mut out_flags = Vec::new();
    for run in keyed.chunk_by(|a, b| a.0 == b.0) {
        let mut s = [0.0f64; 3];
        let mut f = 0u32;
        for (_, i) in run {
            let p = points[*i as usize];
            for (s, c) in s.iter_mut().zip(p) {
                *s += f64::from(c);
            }
            f += u32::from(flags.get(*i as usize).copied().unwrap_or(false));
        }
        let n = run.len() as u32;
        out.push(s.map(|c| (c / f64::from(n)) as f32));
        out_flags.push(2 * f >= n);
    }
    (out, out_flags)
}

/// Each point's voxel with its index, sorted by voxel then index.
fn sorted_by_voxel(points: &[[f32; 3]], voxel_m: f32) -> Vec<(VoxelKey, u32)> {
    sort_keyed(
        points
            .iter()
            .enumerate()
            .map(|(i, p)| (voxel_key(*p, voxel_m), i as u32))
            .collect(),
    )
}

/// Sorts keys with their indices, by key then index. When the keys span under 2²¹ on each
/// axis (200 km at 0.1 m) they are sorted packed into one `u64` each.
fn sort_keyed(mut keyed: Vec<(VoxelKey, u32)>) -> Vec<(VoxelKey, u32)> {
    let mut lo = [i32::MAX; 3];
    let mut hi = [i32::MIN; 3];
    for (k, _) in &keyed {
        for a in 0..3 {
            lo[a] = lo[a].min(k[a]);
            hi[a] = hi[a].max(k[a]);
        }
    }
    const BITS: u32 = 21;
    const MASK: u64 = (1 << BITS) - 1;
    if (0..3).any(|a| i64::from(hi[a]) - i64::from(lo[a]) > MASK as i64) {
        keyed.sort_unstable();
        return keyed;
    }
    let mut packed: Vec<(u64, u32)> = keyed
        .iter()
        .map(|(k, i)| {
            let key = (0..3).fold(0u64, |acc, a| {
                (acc << BITS) | (i64::from(k[a]) - i64::from(lo[a])) as u64
            });
            (key, *i)
        })
        .collect();
    packed.sort_unstable();
    for (slot, (key, i)) in keyed.iter_mut().zip(packed) {
        let k = [2, 1, 0].map(|shift| ((key >> (shift * BITS)) & MASK) as i64);
        *slot = ([0, 1, 2].map(|a| (k[a] + i64::from(lo[a])) as i32), i);
    }
    keyed
}

/// Points of a DBSCAN run in cubic cells, sorted by cell: coordinates in struct-of-arrays
/// form, each cell's range, and a look-up from a cell key to its cell.
struct Cells {
    keys: Vec<VoxelKey>,
    /// `starts[c]..starts[c + 1]` are cell `c`'s positions.
    starts: Vec<u32>,
    /// The input index at each position.
    index: Vec<u32>,
    /// The position of each input index.
    position: Vec<u32>,
    xyz: [Vec<f32>; 3],
    /// Columns of cells (one x, y; cells sorted by z): `columns[k]..columns[k + 1]` are
    /// column `k`'s cells ...
    columns: Vec<u32>,
    /// ... and each column's (x, y) hashed to its index (linear probing; `u32::MAX` marks an
    /// empty slot).
    table: Vec<([i32; 2], u32)>,
}

impl Cells {
    fn new(points: &[[f32; 3]], cell_m: f32) -> Cells {
        // keys from the cloud's least corner, in f64: a cell is a cell to within rounding
        // far from the origin too
        let mut least = [f64::INFINITY; 3];
        for p in points {
            for a in 0..3 {
                least[a] = least[a].min(f64::from(p[a]));
            }
        }
        let keyed = sort_keyed(
            points
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let k = [0, 1, 2]
                        .map(|a| ((f64::from(p[a]) - least[a]) / f64::from(cell_m)).floor() as i32);
                    (k, i as u32)
                })
                .collect(),
        );
        let mut keys = Vec::new();
        let mut starts = Vec::new();
        for (k, (key, _)) in keyed.iter().enumerate() {
            if keys.last() != Some(key) {
                keys.push(*key);
                starts.push(k as u32);
            }
        }
        starts.push(keyed.len() as u32);
        let index: Vec<u32> = keyed.iter().map(|k| k.1).collect();
        let mut position = vec![0u32; points.len()];
        for (k, i) in index.iter().enumerate() {
            position[*i as usize] = k as u32;
        }
        let xyz = [0, 1, 2].map(|a| index.iter().map(|i| points[*i as usize][a]).collect());
        let mut columns = Vec::new();
        for (c, k) in keys.iter().enumerate() {
            if c == 0 || keys[c - 1][..2] != k[..2] {
                columns.push(c as u32);
            }
        }
        let n_columns = columns.len();
        columns.push(keys.len() as u32);
        // open addressing, at most half full
        let size = (2 * n_columns).next_power_of_two().max(16);
        let mut table = vec![([0i32; 2], u32::MAX); size];
        for (k, first) in columns[..n_columns].iter().enumerate() {
            let xy = [keys[*first as usize][0], keys[*first as usize][1]];
            let mut at = hash_column(xy) & (size - 1);
            while table[at].1 != u32::MAX {
                at = (at + 1) & (size - 1);
            }
            table[at] = (xy, k as u32);
        }
        Cells {
            keys,
            starts,
            index,
            position,
            xyz,
            columns,
            table,
        }
    }

    /// The cells whose keys differ from cell `c`'s by at most 2 on each axis (the 124 around
    /// it), `c` left out, nearer columns first (pushed onto `out`).
    fn around(&self, c: usize, out: &mut Vec<u32>) {
        let k = self.keys[c];
        let mask = self.table.len() - 1;
        for [dx, dy] in COLUMN_OFFSETS.iter() {
            let (Some(x), Some(y)) = (k[0].checked_add(*dx), k[1].checked_add(*dy)) else {
                continue;
            };
            let mut at = hash_column([x, y]) & mask;
            let column = loop {
                let (xy, col) = self.table[at];
                if col == u32::MAX {
                    break None;
                }
                if xy == [x, y] {
                    break Some(col as usize);
                }
                at = (at + 1) & mask;
            };
            let Some(col) = column else {
                continue;
            };
            let cells = self.columns[col] as usize..self.columns[col + 1] as usize;
            let z = i64::from(k[2]);
            let from =
                cells.start + self.keys[cells.clone()].partition_point(|q| i64::from(q[2]) < z - 2);
            for d in from..cells.end {
                if i64::from(self.keys[d][2]) > z + 2 {
                    break;
                }
                if d != c {
                    out.push(d as u32);
                }
            }
        }
    }

    fn range(&self, c: usize) -> std::ops::Range<usize> {
        self.starts[c] as usize..self.starts[c + 1] as usize
    }

    /// Squared distance between two positions, summed as DBSCAN has always summed it.
    #[inline]
    fn d2(&self, a: usize, b: usize) -> f32 {
        let [x, y, z] = &self.xyz;
        (x[b] - x[a]).powi(2) + (y[b] - y[a]).powi(2) + (z[b] - z[a]).powi(2)
    }
}

/// A column's hash for [`Cells`]' table (Teschner et al.'s spatial hash, mixed).
#[inline]
fn hash_column(k: [i32; 2]) -> usize {
    let h = (k[0] as u32).wrapping_mul(73_856_093) ^ (k[1] as u32).wrapping_mul(19_349_663);
    (h ^ (h >> 15)).wrapping_mul(0x2c1b_3c6d) as usize
}

/// The 25 column offsets within two columns on x and y, nearest first, so that counting
/// neighbours stops early.
static COLUMN_OFFSETS: std::sync::LazyLock<Vec<[i32; 2]>> = std::sync::LazyLock::new(|| {
    let mut v = Vec::new();
    for dx in -2i32..=2 {
        for dy in -2i32..=2 {
            v.push([dx, dy]);
        }
    }
    v.sort_by_key(|o| (o[0].abs().max(o[1].abs()), o[0].abs() + o[1].abs(), *o));
    v
});

fn find_root(parent: &mut [u32], mut c: usize) -> usize {
    while parent[c] as usize != c {
        parent[c] = parent[parent[c] as usize];
        c = parent[c] as usize;
    }
    c
}

/// DBSCAN over 3D points (`min_samples` counts the point itself, as scikit-learn does).
/// Returns each point's cluster, `None` for noise; clusters are numbered in order of their
/// first core point (in input order), and a border point belongs to the lowest-numbered
/// cluster with a core point within `eps_m`: the labels of expanding clusters one at a
/// time in that order.
///
/// Ester et al., "A density-based algorithm for discovering clusters", KDD 1996, computed
/// on a grid as in Gunawan, "A faster algorithm for DBSCAN" (2013): points go into cells of
/// side just under `eps_m / √3`, so any two points in a cell are neighbours; a cell with
/// `min_samples` points holds only core points, other points count their neighbours in the
/// 124 cells around theirs until they have enough; cells are joined (union-find) when two of
/// their core points are neighbours; border points take the lowest cluster among the cells
/// around them.
pub fn dbscan3(points: &[[f32; 3]], eps_m: f32, min_samples: usize) -> Vec<Option<usize>> {
    let n = points.len();
    let min_samples = min_samples.max(1);
    // 0.99: two points in one cell are at most 0.98 eps apart, so float rounding of the
    // keys and of the distance cannot make them more than eps apart
    let cells = Cells::new(points, eps_m.max(1e-6) / 3f32.sqrt() * 0.99);
    let eps2 = eps_m * eps_m;
    let nc = cells.keys.len();
    // the occupied cells among the 124 around each cell (offsets -2..=2 on each axis: a
    // cell three away is more than eps away), nearest first
    let mut around_start = Vec::with_capacity(nc + 1);
    let mut around: Vec<u32> = Vec::new();
    for c in 0..nc {
        around_start.push(around.len());
        cells.around(c, &mut around);
    }
    around_start.push(around.len());
    let around_of = |c: usize| &around[around_start[c]..around_start[c + 1]];
    // core points
    let mut core = vec![false; n];
    let mut cell_has_core = vec![false; nc];
    for (c, has_core) in cell_has_core.iter_mut().enumerate() {
        let own = cells.range(c);
        if own.len() >= min_samples {
            core[own.clone()].fill(true);
            *has_core = true;
            continue;
        }
        for a in own.clone() {
            let mut count = own.len();
            'count: for d in around_of(c) {
                for b in cells.range(*d as usize) {
                    if cells.d2(a, b) <= eps2 {
                        count += 1;
                        if count >= min_samples {
                            break 'count;
                        }
                    }
                }
            }
            if count >= min_samples {
                core[a] = true;
                *has_core = true;
            }
        }
    }
    // cells joined by a pair of neighbouring core points
    let mut parent: Vec<u32> = (0..nc as u32).collect();
    for c in 0..nc {
        if !cell_has_core[c] {
            continue;
        }
        for d in around_of(c) {
            let d = *d as usize;
            if d < c || !cell_has_core[d] {
                continue;
            }
            let (rc, rd) = (find_root(&mut parent, c), find_root(&mut parent, d));
            if rc == rd {
                continue;
            }
            let joined = cells
                .range(c)
                .filter(|&a| core[a])
                .any(|a| cells.range(d).any(|b| core[b] && cells.d2(a, b) <= eps2));
            if joined {
                parent[rc.max(rd)] = rc.min(rd) as u32;
            }
        }
    }
    // clusters numbered by their first core point in input order
    let mut number = vec![usize::MAX; nc];
    let mut n_clusters = 0;
    let mut label: Vec<Option<usize>> = vec![None; n];
    let mut cell_of = vec![0u32; n];
    for c in 0..nc {
        cell_of[cells.range(c)].fill(c as u32);
    }
    for (pos, slot) in cells.position.iter().zip(label.iter_mut()) {
        let pos = *pos as usize;
        if !core[pos] {
            continue;
        }
        let r = find_root(&mut parent, cell_of[pos] as usize);
        if number[r] == usize::MAX {
            number[r] = n_clusters;
            n_clusters += 1;
        }
        *slot = Some(number[r]);
    }
    // border points: the lowest cluster with a core point within eps
    for c in 0..nc {
        let own = cells.range(c);
        let own_cluster = cell_has_core[c].then(|| number[find_root(&mut parent, c)]);
        for a in own.clone() {
            if core[a] {
                continue;
            }
            // every point of the cell is within eps: a core point in it reaches this one
            let mut best = own_cluster.unwrap_or(usize::MAX);
            for d in around_of(c) {
                let d = *d as usize;
                if !cell_has_core[d] {
                    continue;
                }
                let k = number[find_root(&mut parent, d)];
                if k < best && cells.range(d).any(|b| core[b] && cells.d2(a, b) <= eps2) {
                    best = k;
                }
            }
            if best != usize::MAX {
                label[cells.index[a] as usize] = Some(best);
            }
        }
    }
    label
}

/// The foreground DBSCAN cluster of a detection's points, given in the sensor's frame: among
/// the clusters holding at least `min_share` of the largest one's points, the one with the
/// nearest median range. An object occludes what stands behind it, so the points of its
/// mask that lie on it are the nearest ones; a wall or hedge behind a thin pole, caught at
/// the mask's edge, can hold more points than the pole. With no cluster, returns nothing.
pub fn foreground_cluster(
    points: &[[f32; 3]],
    eps_m: f32,
    min_samples: usize,
    min_share: f64,
) -> Vec<[f32; 3]> {
    object_points(points, &[], eps_m, min_samples, min_share, 0.0)
}

/// The points of a detection that lie on its object, given in the sensor's frame: the
/// foreground cluster ([`foreground_cluster`]) and every other DBSCAN cluster that
/// 1. holds at least `min_share` of the largest cluster's points,
/// 2. lies mostly in the mask's core (`core[i]` for `points[i]`, from
///    [`super::project::core_of_mask`]): what stands behind an object shows in its mask only
///    where the mask overshoots the object's outline, at the mask's edge, while the object's
///    own parts fill the mask, and
/// 3. lies no farther behind the foreground cluster than the object is wide:
///    `angular_width_rad` (the mask's larger side over the focal length) times the
///    foreground's median range.
///
/// So a many-parted object keeps its parts (a bus shelter's near wall, seen end-on, and the
/// back wall and bench seen past it; a billboard's two legs), and a wall behind a pole stays
/// out. Without core flags (an empty `core`) only the foreground cluster is kept.
pub fn object_points(
    points: &[[f32; 3]],
    core: &[bool],
    eps_m: f32,
    min_samples: usize,
    min_share: f64,
    angular_width_rad: f64,
) -> Vec<[f32; 3]> {
    let labels = dbscan3(points, eps_m, min_samples);
    let n = labels.iter().flatten().map(|c| c + 1).max().unwrap_or(0);
    let mut parts: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (i, l) in labels.iter().enumerate() {
        if let Some(c) = l {
            parts[*c].push(i);
        }
    }
    // largest first; ties keep the cluster found first
    parts.sort_by_key(|c| std::cmp::Reverse(c.len()));
    let Some(largest) = parts.first().map(Vec::len) else {
        return Vec::new();
    };
    let median_range = |c: &[usize]| {
        let mut r: Vec<f32> = c
            .iter()
            .map(|&i| {
                let p = points[i];
                (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
            })
            .collect();
        r.sort_by(f32::total_cmp);
        r[r.len() / 2]
    };
    let big: Vec<(f32, &Vec<usize>)> = parts
        .iter()
        .filter(|c| c.len() as f64 >= min_share * largest as f64)
        .map(|c| (median_range(c), c))
        .collect();
    // the nearest; ties keep the larger cluster, which comes first
    let Some(fg) = big
        .iter()
        .enumerate()
        .reduce(|a, b| if b.1.0 < a.1.0 { b } else { a })
        .map(|(k, _)| k)
    else {
        return Vec::new();
    };
    let behind_max = angular_width_rad.max(0.0) * f64::from(big[fg].0);
    let mut keep: Vec<usize> = big[fg].1.clone();
    if !core.is_empty() {
        for (k, (range, c)) in big.iter().enumerate() {
            let in_core = c
                .iter()
                .filter(|&&i| core.get(i).copied().unwrap_or(false))
                .count();
            if k != fg && 2 * in_core >= c.len() && f64::from(*range - big[fg].0) <= behind_max {
                keep.extend_from_slice(c);
            }
        }
        keep.sort_unstable();
    }
    keep.into_iter().map(|i| points[i]).collect()
}

/// The DBSCAN clusters of `points` ([`dbscan3`]), largest first (ties: the cluster found
/// first); noise points are left out.
pub fn clusters(points: &[[f32; 3]], eps_m: f32, min_samples: usize) -> Vec<Vec<[f32; 3]>> {
    let labels = dbscan3(points, eps_m, min_samples);
    let n = labels.iter().flatten().map(|c| c + 1).max().unwrap_or(0);
    let mut out: Vec<Vec<[f32; 3]>> = vec![Vec::new(); n];
    for (p, l) in points.iter().zip(&labels) {
        if let Some(c) = l {
            out[*c].push(*p);
        }
    }
    // stable: equal sizes keep the order in which DBSCAN found them
    out.sort_by_key(|c| std::cmp::Reverse(c.len()));
    out
}

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Aabb {
    /// The bounds of a non-empty point set.
    pub fn of(points: &[[f32; 3]]) -> Option<Aabb> {
        let first = *points.first()?;
        let mut b = Aabb {
            min: first,
            max: first,
        };
        for p in &points[1..] {
            for (i, c) in p.iter().enumerate() {
                b.min[i] = b.min[i].min(*c);
                b.max[i] = b.max[i].max(*c);
            }
        }
        Some(b)
    }

    /// Volume in cubic metres.
    pub fn volume(&self) -> f64 {
        (0..3)
            .map(|i| f64::from(self.max[i] - self.min[i]).max(0.0))
            .product()
    }

    /// Whether the boxes overlap (touching counts).
    pub fn intersects(&self, o: &Aabb) -> bool {
        (0..3).all(|i| self.min[i] <= o.max[i] && o.min[i] <= self.max[i])
    }

    /// Intersection over union of the volumes; 0 for disjoint or degenerate boxes.
    pub fn iou(&self, o: &Aabb) -> f64 {
        let inter: f64 = (0..3)
            .map(|i| f64::from(self.max[i].min(o.max[i]) - self.min[i].max(o.min[i])).max(0.0))
            .product();
        let union = self.volume() + o.volume() - inter;
        if union > 0.0 { inter / union } else { 0.0 }
    }

    /// The centre.
    pub fn center(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| (f64::from(self.min[i]) + f64::from(self.max[i])) / 2.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const EPS: f64 = 1e-9;

    #[test]
    fn voxel_means_and_order() {
        let pts = [
            [0.01, 0.01, 0.01],
            [0.09, 0.03, 0.05],
            [0.15, 0.0, 0.0],
            [-0.05, 0.0, 0.0],
        ];
        let v = voxel_downsample(&pts, 0.1);
        assert_eq!(v.len(), 3);
        assert!((v[1][0] - 0.05).abs() < 1e-6 && (v[1][1] - 0.02).abs() < 1e-6);
        assert!((v[0][0] + 0.05).abs() < 1e-6);
        let mut rev = pts;
        rev.reverse();
        assert_eq!(voxel_downsample(&rev, 0.1), v);
    }

    #[test]
    fn dbscan_keeps_the_big_blob_and_drops_outliers() {
        let mut pts = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                pts.push([i as f32 * 0.1, j as f32 * 0.1, 0.0]);
            }
        }
        for i in 0..5 {
            for j in 0..6 {
                pts.push([20.0 + i as f32 * 0.1, j as f32 * 0.1, 0.0]);
            }
        }
        pts.push([50.0, 50.0, 50.0]);
        let labels = dbscan3(&pts, 0.5, 20);
        assert!(labels[..100].iter().all(|l| *l == Some(0)));
        assert!(labels[100..130].iter().all(|l| *l == Some(1)));
        assert_eq!(labels[130], None);
        let parts = clusters(&pts, 0.5, 20);
        assert_eq!(parts[0].len(), 100, "largest first");
        assert!(clusters(&pts[..5], 0.5, 20).is_empty());
    }

    /// A thin pole 10 m out with a wall 3 m behind it, both in one mask: the wall holds more
    /// points, the pole is nearer.
    #[test]
    fn the_foreground_cluster_is_the_nearer_one() {
        let mut pts = Vec::new();
        for j in 0..30 {
            pts.push([10.0, 0.0, j as f32 * 0.1]);
        }
        for i in 0..20 {
            for j in 0..10 {
                pts.push([13.0, i as f32 * 0.1 - 1.0, j as f32 * 0.1]);
            }
        }
        let pole = foreground_cluster(&pts, 0.5, 5, 0.1);
        assert_eq!(pole.len(), 30);
        assert!(pole.iter().all(|p| (p[0] - 10.0).abs() < 1e-6));
        // a share above the pole's (30 of 200 points) keeps the wall
        assert_eq!(foreground_cluster(&pts, 0.5, 5, 0.2).len(), 200);
        assert_eq!(foreground_cluster(&pts, 0.5, 5, 1.0).len(), 200);
        assert!(foreground_cluster(&pts[..3], 0.5, 5, 0.3).is_empty());
    }

    /// A bus shelter seen end-on: its near wall, and 2.5 m behind it the back wall seen past
    /// it, both in the mask's core, are one object; a wall 10 m behind, or one only at the
    /// mask's edge, is not.
    #[test]
    fn an_object_keeps_its_parts_in_the_mask_core() {
        let mut pts = Vec::new();
        let mut core = Vec::new();
        // near wall at 15 m: 40 points, all in the core
        for j in 0..40 {
            pts.push([15.0, 2.0, j as f32 * 0.06]);
            core.push(true);
        }
        // the rest of the shelter 2.5 m behind: 100 points, 80 in the core
        for i in 0..20 {
            for j in 0..5 {
                pts.push([17.5, 2.0 - i as f32 * 0.1, j as f32 * 0.1]);
                core.push(i >= 4);
            }
        }
        // a 4.4 m wide mask at 15 m: 0.29 rad
        let kept = object_points(&pts, &core, 0.5, 5, 0.3, 0.29);
        assert_eq!(kept.len(), 140);
        // the old rule keeps the near wall alone
        assert_eq!(foreground_cluster(&pts, 0.5, 5, 0.3).len(), 40);
        // a narrow mask (a pole, 0.02 rad): 2.5 m behind is too far
        assert_eq!(object_points(&pts, &core, 0.5, 5, 0.3, 0.02).len(), 40);
        // the part behind only at the mask's edge: a thing behind the object
        let edge: Vec<bool> = (0..pts.len()).map(|i| i < 40).collect();
        assert_eq!(object_points(&pts, &edge, 0.5, 5, 0.3, 0.29).len(), 40);
        // no core flags: the foreground cluster
        assert_eq!(object_points(&pts, &[], 0.5, 5, 0.3, 0.29).len(), 40);
    }

    #[test]
    fn flags_follow_their_voxels() {
        let pts = [
            [0.01, 0.0, 0.0],
            [0.02, 0.0, 0.0],
            [0.03, 0.0, 0.0],
            [0.5, 0.0, 0.0],
        ];
        let (v, f) = voxel_downsample_flagged(&pts, &[true, true, false, false], 0.1);
        assert_eq!(v.len(), 2);
        assert_eq!(f, vec![true, false]);
        let (_, f) = voxel_downsample_flagged(&pts, &[true, false, false, true], 0.1);
        assert_eq!(f, vec![false, true]);
        assert_eq!(
            voxel_downsample_flagged(&pts, &[], 0.1).0,
            voxel_downsample(&pts, 0.1)
        );
    }

    #[test]
    fn iou_of_known_boxes() {
        let a = Aabb {
            min: [0.0; 3],
            max: [2.0, 2.0, 2.0],
        };
        let b = Aabb {
            min: [1.0, 0.0, 0.0],
            max: [3.0, 2.0, 2.0],
        };
        assert!((a.iou(&b) - 4.0 / 12.0).abs() < EPS);
        assert!((a.iou(&a) - 1.0).abs() < EPS);
        let c = Aabb {
            min: [5.0; 3],
            max: [6.0; 3],
        };
        assert!(a.iou(&c).abs() < EPS && !a.intersects(&c));
    }

    /// DBSCAN against a brute-force reference: same core points and the same partition of
    /// core points into clusters.
    fn brute_core(pts: &[[f32; 3]], eps: f32, min: usize) -> Vec<bool> {
        pts.iter()
            .map(|p| {
                pts.iter()
                    .filter(|q| {
                        (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)
                            <= eps * eps
                    })
                    .count()
                    >= min
            })
            .collect()
    }

    /// DBSCAN as Ester et al. give it (and scikit-learn and Open3D compute it): every point's
    /// region by a scan of all points, seeds in input order, clusters expanded one at a time,
    /// a border point labelled by the first cluster that reaches it even when it was tried as
    /// a seed before (the version before the grid pushed only unvisited points, so such a
    /// point stayed noise).
    fn dbscan_reference(pts: &[[f32; 3]], eps: f32, min: usize) -> Vec<Option<usize>> {
        let region = |i: usize| -> Vec<usize> {
            (0..pts.len())
                .filter(|&j| {
                    (pts[j][0] - pts[i][0]).powi(2)
                        + (pts[j][1] - pts[i][1]).powi(2)
                        + (pts[j][2] - pts[i][2]).powi(2)
                        <= eps * eps
                })
                .collect()
        };
        let mut label = vec![None; pts.len()];
        let mut visited = vec![false; pts.len()];
        let mut n = 0;
        for i in 0..pts.len() {
            if visited[i] {
                continue;
            }
            visited[i] = true;
            let r = region(i);
            if r.len() < min {
                continue;
            }
            label[i] = Some(n);
            let mut queue = r;
            while let Some(j) = queue.pop() {
                if label[j].is_none() {
                    label[j] = Some(n);
                }
                if visited[j] {
                    continue;
                }
                visited[j] = true;
                let r = region(j);
                if r.len() >= min {
                    queue.extend(r);
                }
            }
            n += 1;
        }
        label
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// The same labels as the reference on lattice points (many exactly eps apart), on
        /// scattered ones spread thin or packed into dense cells, negative coordinates
        /// included, and with a third moved 10 or 1,000 km away (keys that do not pack).
        #[test]
        fn dbscan_equals_the_region_scan(
            lattice in proptest::collection::vec((-20i32..20, -20i32..20, -3i32..3), 0..150),
            scattered in proptest::collection::vec((-3.0f32..3.0, -3.0f32..3.0, -1.0f32..1.0), 0..150),
            spread in prop_oneof![Just(0.1f32), Just(1.0f32)],
            far in prop_oneof![Just(0.0f32), Just(1.0e4), Just(1.0e6)],
            min in 0usize..9,
        ) {
            let eps = 0.3f32;
            let mut pts: Vec<[f32; 3]> = lattice
                .iter()
                .map(|(x, y, z)| [*x as f32 * 0.15, *y as f32 * 0.15, *z as f32 * 0.3])
                .collect();
            pts.extend(scattered.iter().map(|(x, y, z)| [*x * spread, *y * spread, *z * spread]));
            for p in pts.iter_mut().step_by(3) {
                p[0] += far;
            }
            let want = dbscan_reference(&pts, eps, min);
            prop_assert_eq!(&dbscan3(&pts, eps, min), &want);
        }

        #[test]
        fn dbscan_matches_brute_force(pts in proptest::collection::vec(
            (0i32..40, 0i32..40, 0i32..4).prop_map(|(x, y, z)| [x as f32 * 0.13, y as f32 * 0.13, z as f32 * 0.13]), 1..120)) {
            let (eps, min) = (0.3f32, 4usize);
            let labels = dbscan3(&pts, eps, min);
            let core = brute_core(&pts, eps, min);
            for i in 0..pts.len() {
                if core[i] {
                    prop_assert!(labels[i].is_some());
                }
                for j in 0..pts.len() {
                    let d2 = (0..3).map(|k| (pts[i][k] - pts[j][k]).powi(2)).sum::<f32>();
                    if core[i] && core[j] && d2 <= eps * eps {
                        prop_assert_eq!(labels[i], labels[j]);
                    }
                }
                if labels[i].is_some() && !core[i] {
                    // a border point is within eps of some core point of its cluster
                    prop_assert!((0..pts.len()).any(|j| core[j] && labels[j] == labels[i]
                        && (0..3).map(|k| (pts[i][k] - pts[j][k]).powi(2)).sum::<f32>() <= eps * eps));
                }
            }
        }
    }
}
