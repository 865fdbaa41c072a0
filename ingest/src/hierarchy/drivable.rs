//! Road areas from the map: each segment's drivable area is measured from the fused road and
//! parking points instead of being a disc or a corridor.
//!
//! The points of the map's `road` and `parking` instances are thinned to one per
//! `cell_m` grid cell (the cell's mean), triangulated (Delaunay, with spade), and the
//! triangles whose circumradius is at most `alpha_m` are kept: the α-shape of the points
//! (Edelsbrunner, Kirkpatrick and Seidel, "On the shape of a set of points in the plane",
//! IEEE Trans. Inf. Theory 29(4), 1983). Each kept triangle goes to the segment whose
//! trajectory area (disc or corridor) is nearest its centroid, if within `max_gap_m`, and a
//! segment's triangles are outlined as its polygon ([`Drivable`]).

use std::collections::BTreeMap;

use graphstore::{GraphRead, Value};
use scene::GroundFrame;
use spade::{DelaunayTriangulation, Point2, Triangulation};

use super::segments::Segments;
use crate::error::Result;
use scene::area::Drivable;

/// Road-area parameters (`[hierarchy.drivable]`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DrivableConfig {
    /// Measure road areas at all (off: segments keep only their disc or corridor).
    pub enabled: bool,
    /// Instance classes whose points are drivable ground.
    pub classes: Vec<String>,
    /// Grid cell of the thinning, metres.
    pub cell_m: f64,
    /// α: triangles with a larger circumradius are gaps, metres.
    pub alpha_m: f64,
    /// Triangles farther than this from every segment's trajectory area belong to none
    /// (roads the drive did not take), metres.
    pub max_gap_m: f64,
}

impl Default for DrivableConfig {
    fn default() -> Self {
        DrivableConfig {
            enabled: true,
            classes: vec!["road".into(), "parking".into()],
            cell_m: 0.5,
            alpha_m: 1.0,
            max_gap_m: 2.0,
        }
    }
}

/// Ground points of the store's instances of `classes`, thinned to the mean of each
/// `cell_m` cell, in cell order.
///
/// # Errors
/// The store fails.
pub fn drivable_points(
    r: &impl GraphRead,
    frame: GroundFrame,
    classes: &[String],
    cell_m: f64,
) -> Result<Vec<[f64; 2]>> {
    let mut cells: BTreeMap<(i64, i64), ([f64; 2], u32)> = BTreeMap::new();
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let class = match r.node_prop(id, scene::key::SEMANTIC_CLASS)? {
            Some(Value::String(c)) => c,
            _ => continue,
        };
        if !classes.contains(&class) {
            continue;
        }
        let Some(pc) = r.point_cloud(id, scene::payload::POINTS)? else {
            continue;
        };
        for p in &pc.xyz {
            let g = frame.ground(p.map(f64::from));
            if !(g[0].is_finite() && g[1].is_finite()) {
                continue;
            }
            let k = (
                (g[0] / cell_m).floor() as i64,
                (g[1] / cell_m).floor() as i64,
            );
            let e = cells.entry(k).or_insert(([0.0, 0.0], 0));
            e.0[0] += g[0];
            e.0[1] += g[1];
            e.1 += 1;
        }
    }
    Ok(cells
        .into_values()
        .map(|(s, n)| [s[0] / f64::from(n), s[1] / f64::from(n)])
        .collect())
}

/// The α-shape triangles of `points` (each counter-clockwise): the Delaunay triangles whose
/// circumradius is at most `alpha_m`. Fewer than three points, or points spade refuses,
/// give none.
pub fn alpha_triangles(points: &[[f64; 2]], alpha_m: f64) -> Vec<[[f64; 2]; 3]> {
    let pts: Vec<Point2<f64>> = points.iter().map(|p| Point2::new(p[0], p[1])).collect();
    let Ok(t) = DelaunayTriangulation::<Point2<f64>>::bulk_load_stable(pts) else {
        return Vec::new();
    };
    let r2 = alpha_m * alpha_m;
    t.inner_faces()
        .filter(|f| f.circumcircle().1 <= r2)
        .map(|f| {
            f.vertices().map(|v| {
                let p = v.position();
                [p.x, p.y]
            })
        })
        .collect()
}

/// One drivable area per segment of `segs` (empty where no triangle fell to it): each
/// triangle goes to the segment whose trajectory area is nearest its centroid, when that is
/// within `max_gap_m`.
pub fn segment_areas(tris: &[[[f64; 2]; 3]], segs: &Segments, max_gap_m: f64) -> Vec<Drivable> {
    let mut per: Vec<Vec<[[f64; 2]; 3]>> = vec![Vec::new(); segs.segments.len()];
    // cells a few times the usual gap: a triangle looks at the segments near it only
    let grid = segs.grid((4.0 * max_gap_m).max(25.0));
    for t in tris {
        let c = [
            (t[0][0] + t[1][0] + t[2][0]) / 3.0,
            (t[0][1] + t[1][1] + t[2][1]) / 3.0,
        ];
        if let Some((s, _)) = grid.nearest_within(segs, c, max_gap_m) {
            per[s].push(*t);
        }
    }
    per.iter().map(|t| Drivable::from_triangles(t)).collect()
}

/// The drivable area of each segment of `segs`, measured from the store's instances.
///
/// # Errors
/// The store fails.
pub fn measure(
    r: &impl GraphRead,
    frame: GroundFrame,
    segs: &Segments,
    cfg: &DrivableConfig,
) -> Result<Vec<Drivable>> {
    if !cfg.enabled {
        return Ok(vec![Drivable::default(); segs.segments.len()]);
    }
    let pts = drivable_points(r, frame, &cfg.classes, cfg.cell_m)?;
    let tris = alpha_triangles(&pts, cfg.alpha_m);
    Ok(segment_areas(&tris, segs, cfg.max_gap_m))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_alpha_shape_of_a_grid_with_a_gap_keeps_the_gap() {
        // two 10 m × 4 m patches on a 0.5 m grid, 3 m apart along x
        let mut pts = Vec::new();
        for i in 0..=20 {
            for j in 0..=8 {
                let (x, y) = (f64::from(i) * 0.5, f64::from(j) * 0.5);
                pts.push([x, y]);
                pts.push([x + 13.0, y]);
            }
        }
        let tris = alpha_triangles(&pts, 1.0);
        let d = Drivable::from_triangles(&tris);
        assert_eq!(d.rings.len(), 2);
        assert!((d.area_m2() - 80.0).abs() < 1e-6, "{}", d.area_m2());
        assert!(d.contains([5.0, 2.0]) && d.contains([18.0, 2.0]) && !d.contains([11.5, 2.0]));
        // a larger α bridges the gap
        let wide = Drivable::from_triangles(&alpha_triangles(&pts, 2.0));
        assert!(wide.contains([11.5, 2.0]));
        assert!(alpha_triangles(&pts[..2], 1.0).is_empty());
        assert!(alpha_triangles(&[[f64::NAN, 0.0], [1.0, 0.0], [0.0, 1.0]], 1.0).is_empty());
    }
}
