//! DBSCAN over 2D points with a uniform grid for neighbour search.

use std::collections::HashMap;

/// A uniform grid over 2D points for radius queries.
#[derive(Debug)]
pub struct Grid2 {
    cell_m: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
}

impl Grid2 {
    /// Indexes `points` with cells of `cell_m` metres (use the query radius).
    pub fn new(points: &[[f64; 2]], cell_m: f64) -> Grid2 {
        let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            cells.entry(Self::key(p, cell_m)).or_default().push(i);
        }
        Grid2 { cell_m, cells }
    }

    fn key(p: &[f64; 2], cell_m: f64) -> (i64, i64) {
        (
            (p[0] / cell_m).floor() as i64,
            (p[1] / cell_m).floor() as i64,
        )
    }

    /// Indices of points within `radius_m` of `p` (radius must not exceed the cell size),
    /// in ascending order.
    pub fn within(&self, points: &[[f64; 2]], p: [f64; 2], radius_m: f64) -> Vec<usize> {
        let (cx, cy) = Self::key(&p, self.cell_m);
        let r2 = radius_m * radius_m;
        let mut out = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(v) = self.cells.get(&(cx + dx, cy + dy)) {
                    out.extend(v.iter().copied().filter(|&j| {
                        let q = points[j];
                        (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) <= r2
                    }));
                }
            }
        }
        out.sort_unstable();
        out
    }
}

/// DBSCAN: the cluster of each point (`None` for noise). `min_samples` counts the point
/// itself, as scikit-learn does. Clusters are numbered in order of their first point.
pub fn dbscan(points: &[[f64; 2]], eps_m: f64, min_samples: usize) -> Vec<Option<usize>> {
    let grid = Grid2::new(points, eps_m.max(1e-9));
    let neighbours: Vec<Vec<usize>> = points
        .iter()
        .map(|p| grid.within(points, *p, eps_m))
        .collect();
    let core: Vec<bool> = neighbours.iter().map(|n| n.len() >= min_samples).collect();
    let mut label: Vec<Option<usize>> = vec![None; points.len()];
    let mut next = 0;
    for start in 0..points.len() {
        if label[start].is_some() || !core[start] {
            continue;
        }
        let c = next;
        next += 1;
        label[start] = Some(c);
        let mut stack = vec![start];
        while let Some(i) = stack.pop() {
            for &j in &neighbours[i] {
                if label[j].is_none() {
                    label[j] = Some(c);
                    if core[j] {
                        stack.push(j);
                    }
                }
            }
        }
    }
    label
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_blobs_and_noise() {
        let mut pts = Vec::new();
        for i in 0..5 {
            pts.push([i as f64 * 0.5, 0.0]);
            pts.push([100.0 + i as f64 * 0.5, 0.0]);
        }
        pts.push([50.0, 50.0]);
        let l = dbscan(&pts, 1.0, 3);
        assert_eq!(l[0], Some(0));
        assert_eq!(l[1], Some(1));
        assert!(l.iter().step_by(2).take(5).all(|x| *x == Some(0)));
        assert_eq!(l[10], None);
    }
}
