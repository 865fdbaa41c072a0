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
    let mut keyed: Vec<(VoxelKey, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| (voxel_key(*p, voxel_m), i as u32))
        .collect();
    keyed.sort_unstable();
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

/// Points of a DBSCAN run in cells of `eps` metres, sorted by cell: coordinates in struct-of-
/// arrays form and each cell's range, for neighbourhood queries without hashing.
struct EpsCells {
    keys: Vec<VoxelKey>,
    /// `starts[c]..starts[c + 1]` are cell `c`'s positions.
    starts: Vec<u32>,
    /// The input index at each position.
    index: Vec<u32>,
    /// The position of each input index.
    position: Vec<u32>,
    xyz: [Vec<f32>; 3],
}

impl EpsCells {
    fn new(points: &[[f32; 3]], cell_m: f32) -> EpsCells {
        let mut keyed: Vec<(VoxelKey, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (voxel_key(*p, cell_m), i as u32))
            .collect();
        keyed.sort_unstable();
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
        EpsCells {
            keys,
            starts,
            index,
            position,
            xyz,
        }
    }

    /// The cell at `key + offset`, if it holds points.
    fn neighbour(&self, c: usize, offset: [i32; 3]) -> Option<usize> {
        let k = self.keys[c];
        let key = [
            k[0].checked_add(offset[0])?,
            k[1].checked_add(offset[1])?,
            k[2].checked_add(offset[2])?,
        ];
        self.keys.binary_search(&key).ok()
    }

    fn range(&self, c: usize) -> std::ops::Range<usize> {
        self.starts[c] as usize..self.starts[c + 1] as usize
    }

    /// Squared distance between two positions, summed as `dbscan3` has always summed it.
    #[inline]
    fn d2(&self, a: usize, b: usize) -> f32 {
        let [x, y, z] = &self.xyz;
        (x[b] - x[a]).powi(2) + (y[b] - y[a]).powi(2) + (z[b] - z[a]).powi(2)
    }
}

/// The 13 cell offsets after `[0, 0, 0]` in lexicographic order: each pair of neighbouring
/// cells is visited once, from the first.
const FORWARD: [[i32; 3]; 13] = [
    [0, 0, 1],
    [0, 1, -1],
    [0, 1, 0],
    [0, 1, 1],
    [1, -1, -1],
    [1, -1, 0],
    [1, -1, 1],
    [1, 0, -1],
    [1, 0, 0],
    [1, 0, 1],
    [1, 1, -1],
    [1, 1, 0],
    [1, 1, 1],
];

/// Above this many neighbour pairs DBSCAN does not keep them but asks each core point's
/// neighbourhood again while it expands a cluster (8M pairs are 64 MB).
const DBSCAN_MAX_PAIRS: usize = 8 << 20;

/// DBSCAN over 3D points (`min_samples` counts the point itself, as scikit-learn does).
/// Returns each point's cluster, `None` for noise; clusters are numbered in order of their
/// first core point (in input order), and a border point belongs to the first cluster that
/// reaches it, so the result does not depend on how neighbourhoods are searched.
///
/// Ester et al., "A density-based algorithm for discovering clusters", KDD 1996. Points go
/// into cells of `eps_m` sorted by cell; each pair of points in neighbouring cells is
/// measured once (13 forward cells and the cell itself), which counts every point's
/// neighbours and, up to [`DBSCAN_MAX_PAIRS`], keeps the pairs for the expansion.
pub fn dbscan3(points: &[[f32; 3]], eps_m: f32, min_samples: usize) -> Vec<Option<usize>> {
    dbscan3_capped(points, eps_m, min_samples, DBSCAN_MAX_PAIRS)
}

/// [`dbscan3`] keeping at most `max_pairs` neighbour pairs.
fn dbscan3_capped(
    points: &[[f32; 3]],
    eps_m: f32,
    min_samples: usize,
    max_pairs: usize,
) -> Vec<Option<usize>> {
    let n = points.len();
    let cells = EpsCells::new(points, eps_m.max(1e-6));
    let eps2 = eps_m * eps_m;
    // neighbours per position, the point itself included
    let mut degree = vec![1u32; n];
    let mut pairs: Option<Vec<(u32, u32)>> = Some(Vec::new());
    for c in 0..cells.keys.len() {
        let own = cells.range(c);
        let mut others: Vec<std::ops::Range<usize>> = Vec::with_capacity(13);
        others.extend(
            FORWARD
                .iter()
                .filter_map(|o| cells.neighbour(c, *o).map(|d| cells.range(d))),
        );
        for a in own.clone() {
            let mut visit = |b: usize| {
                if cells.d2(a, b) <= eps2 {
                    degree[a] += 1;
                    degree[b] += 1;
                    if let Some(p) = &mut pairs {
                        if p.len() < max_pairs {
                            p.push((a as u32, b as u32));
                        } else {
                            pairs = None;
                        }
                    }
                }
            };
            for b in a + 1..own.end {
                visit(b);
            }
            for r in &others {
                for b in r.clone() {
                    visit(b);
                }
            }
        }
    }
    // the kept pairs as adjacency lists by position
    let adjacency = pairs.map(|pairs| {
        let mut offsets = vec![0u32; n + 1];
        for (a, b) in &pairs {
            offsets[*a as usize + 1] += 1;
            offsets[*b as usize + 1] += 1;
        }
        for k in 0..n {
            offsets[k + 1] += offsets[k];
        }
        let mut fill = offsets.clone();
        let mut list = vec![0u32; offsets[n] as usize];
        for (a, b) in pairs {
            list[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            list[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        (offsets, list)
    });
    // the positions within eps of position `a`, itself left out
    let region = |a: usize, out: &mut Vec<u32>| {
        out.clear();
        if let Some((offsets, list)) = &adjacency {
            out.extend_from_slice(&list[offsets[a] as usize..offsets[a + 1] as usize]);
            return;
        }
        let c = cells.starts.partition_point(|s| *s as usize <= a) - 1;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(d) = cells.neighbour(c, [dx, dy, dz]) {
                        out.extend(
                            cells
                                .range(d)
                                .filter(|&b| b != a && cells.d2(a, b) <= eps2)
                                .map(|b| b as u32),
                        );
                    }
                }
            }
        }
    };
    let is_core = |pos: usize| degree[pos] as usize >= min_samples;
    let mut label: Vec<Option<usize>> = vec![None; n];
    let mut visited = vec![false; n];
    let mut n_clusters = 0;
    let mut buf = Vec::new();
    let mut queue: Vec<u32> = Vec::new();
    for i in 0..n {
        if visited[i] {
            continue;
        }
        visited[i] = true;
        let p = cells.position[i] as usize;
        if !is_core(p) {
            continue;
        }
        let c = n_clusters;
        n_clusters += 1;
        label[i] = Some(c);
        region(p, &mut buf);
        queue.clear();
        queue.extend_from_slice(&buf);
        while let Some(q) = queue.pop() {
            let q = q as usize;
            let j = cells.index[q] as usize;
            if label[j].is_none() {
                label[j] = Some(c);
            }
            if visited[j] {
                continue;
            }
            visited[j] = true;
            if is_core(q) {
                region(q, &mut buf);
                queue.extend(
                    buf.iter()
                        .copied()
                        .filter(|&b| !visited[cells.index[b as usize] as usize]),
                );
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

    /// DBSCAN as written before the cell search: every point's region by a scan of all points,
    /// in input order, clusters expanded one at a time.
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
                    queue.extend(r.into_iter().filter(|&q| !visited[q]));
                }
            }
            n += 1;
        }
        label
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// The same labels as the reference, with the neighbour pairs kept and without
        /// (neighbourhoods asked again), on lattice points (many at exactly eps) and on
        /// scattered ones, negative coordinates included.
        #[test]
        fn dbscan_equals_the_region_scan(
            lattice in proptest::collection::vec((-20i32..20, -20i32..20, -3i32..3), 0..150),
            scattered in proptest::collection::vec((-3.0f32..3.0, -3.0f32..3.0, -1.0f32..1.0), 0..150),
            min in 1usize..7,
        ) {
            let eps = 0.3f32;
            let mut pts: Vec<[f32; 3]> = lattice
                .iter()
                .map(|(x, y, z)| [*x as f32 * 0.15, *y as f32 * 0.15, *z as f32 * 0.3])
                .collect();
            pts.extend(scattered.iter().map(|(x, y, z)| [*x, *y, *z]));
            let want = dbscan_reference(&pts, eps, min);
            prop_assert_eq!(&dbscan3(&pts, eps, min), &want);
            prop_assert_eq!(&dbscan3_capped(&pts, eps, min, 0), &want);
            prop_assert_eq!(&dbscan3_capped(&pts, eps, min, 7), &want);
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
