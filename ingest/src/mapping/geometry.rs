//! Point-set geometry for mapping: voxel down-sampling, 3D DBSCAN, axis-aligned boxes.

use std::collections::HashMap;

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
    let mut acc: HashMap<VoxelKey, ([f64; 3], u32, u32)> = HashMap::with_capacity(points.len() / 2);
    for (i, p) in points.iter().enumerate() {
        let e = acc
            .entry(voxel_key(*p, voxel_m))
            .or_insert(([0.0; 3], 0, 0));
        for (s, c) in e.0.iter_mut().zip(p) {
            *s += f64::from(*c);
        }
        e.1 += 1;
        e.2 += u32::from(flags.get(i).copied().unwrap_or(false));
    }
    let mut cells: Vec<(VoxelKey, [f32; 3], bool)> = acc
        .into_iter()
        .map(|(k, (s, n, f))| (k, s.map(|c| (c / f64::from(n)) as f32), 2 * f >= n))
        .collect();
    cells.sort_unstable_by_key(|c| c.0);
    cells.into_iter().map(|c| (c.1, c.2)).unzip()
}

/// DBSCAN over 3D points (`min_samples` counts the point itself, as scikit-learn does).
/// Returns each point's cluster, `None` for noise; clusters are numbered in order of their
/// first core point.
pub fn dbscan3(points: &[[f32; 3]], eps_m: f32, min_samples: usize) -> Vec<Option<usize>> {
    let cell = eps_m.max(1e-6);
    let mut grid: HashMap<VoxelKey, Vec<u32>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        grid.entry(voxel_key(*p, cell)).or_default().push(i as u32);
    }
    let eps2 = eps_m * eps_m;
    let region = |i: usize, out: &mut Vec<u32>| {
        out.clear();
        let p = points[i];
        let k = voxel_key(p, cell);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(v) = grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        out.extend(v.iter().copied().filter(|&j| {
                            let q = points[j as usize];
                            (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2)
                                <= eps2
                        }));
                    }
                }
            }
        }
    };
    let mut label: Vec<Option<usize>> = vec![None; points.len()];
    let mut visited = vec![false; points.len()];
    let mut n_clusters = 0;
    let mut buf = Vec::new();
    let mut queue = Vec::new();
    for i in 0..points.len() {
        if visited[i] {
            continue;
        }
        visited[i] = true;
        region(i, &mut buf);
        if buf.len() < min_samples {
            continue;
        }
        let c = n_clusters;
        n_clusters += 1;
        label[i] = Some(c);
        queue.clear();
        queue.extend_from_slice(&buf);
        while let Some(j) = queue.pop() {
            let j = j as usize;
            if label[j].is_none() {
                label[j] = Some(c);
            }
            if visited[j] {
                continue;
            }
            visited[j] = true;
            region(j, &mut buf);
            if buf.len() >= min_samples {
                queue.extend(buf.iter().copied().filter(|&q| !visited[q as usize]));
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

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
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
