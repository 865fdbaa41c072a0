//! Oriented bounding boxes standing on the ground plane.
//!
//! A box is a rectangle in ground coordinates (see [`GroundFrame`]) turned by a yaw, plus a
//! height range. It is fitted to points as the minimum-area enclosing rectangle of their
//! ground-plane convex hull: one side of that rectangle lies on a hull edge (Freeman and
//! Shapira, "Determining the minimum-area encasing rectangle for an arbitrary closed curve",
//! CACM 18(7), 1975), so trying every hull edge finds it. The hull and the intersection of two
//! hull comes from parry2d; footprints are intersected by
//! Sutherland–Hodgman clipping.

use nalgebra::{Rotation2, Vector2};
use parry2d::math::Vector as PVector;
use parry2d::transformation::convex_hull;

use crate::GroundFrame;

/// An oriented box: a ground-plane rectangle and a height range, metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OrientedBox {
    /// Centre of the footprint, ground coordinates.
    pub center: [f64; 2],
    /// Half the length (along the box's first axis) and half the width (along its second),
    /// `half_extents[0] >= half_extents[1] >= 0`.
    pub half_extents: [f64; 2],
    /// Angle of the first axis from ground axis 0 towards ground axis 1, radians, in
    /// `(-π/2, π/2]`.
    pub yaw_rad: f64,
    /// Bottom and top heights (positive up, see [`GroundFrame::height`]).
    pub height_m: [f64; 2],
}

/// Number of values in [`OrientedBox::to_values`].
pub const OBB_VALUES: usize = 7;

impl OrientedBox {
    /// The minimum-area oriented box of `points` (world frame). `None` without a finite
    /// point; non-finite points are skipped. One point (or all at one spot) gives a box of
    /// zero extent; collinear points give one of zero width.
    pub fn fit(ground: GroundFrame, points: &[[f32; 3]]) -> Option<OrientedBox> {
        let world: Vec<[f64; 3]> = points
            .iter()
            .filter(|p| p.iter().all(|c| c.is_finite()))
            .map(|p| p.map(f64::from))
            .collect();
        Self::fit_f64(ground, &world)
    }

    /// [`OrientedBox::fit`] for `f64` points.
    pub fn fit_f64(ground: GroundFrame, points: &[[f64; 3]]) -> Option<OrientedBox> {
        let pts: Vec<&[f64; 3]> = points
            .iter()
            .filter(|p| p.iter().all(|c| c.is_finite()))
            .collect();
        let first = **pts.first()?;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in &pts {
            let h = ground.height(**p);
            lo = lo.min(h);
            hi = hi.max(h);
        }
        // hull in f32 relative to the first point (objects are far smaller than f32's range)
        let origin = ground.ground(first);
        let rel: Vec<PVector> = pts
            .iter()
            .map(|p| {
                let g = ground.ground(**p);
                PVector::new((g[0] - origin[0]) as f32, (g[1] - origin[1]) as f32)
            })
            .collect();
        let distinct = rel.iter().any(|p| *p != rel[0]);
        let hull: Vec<Vector2<f64>> = if distinct {
            convex_hull(&rel)
                .into_iter()
                .map(|p| Vector2::new(f64::from(p.x), f64::from(p.y)))
                .collect()
        } else {
            vec![Vector2::zeros()]
        };
        let (center, half_extents, yaw_rad) = min_area_rectangle(&hull);
        Some(OrientedBox {
            center: [center.x + origin[0], center.y + origin[1]],
            half_extents,
            yaw_rad,
            height_m: [lo, hi],
        })
    }

    /// The box of a ground-plane rectangle given by its corners in order (either winding;
    /// only the first three are read) and a height range.
    pub fn from_rectangle(corners: &[[f64; 2]; 4], height_m: [f64; 2]) -> OrientedBox {
        let p = corners.map(|c| Vector2::new(c[0], c[1]));
        let (u, v) = ((p[1] - p[0]) / 2.0, (p[2] - p[1]) / 2.0);
        let c = (p[0] + p[2]) / 2.0;
        let (long, short) = if u.norm() >= v.norm() { (u, v) } else { (v, u) };
        OrientedBox {
            center: [c.x, c.y],
            half_extents: [long.norm(), short.norm()],
            yaw_rad: normal_yaw(long.y.atan2(long.x)),
            height_m,
        }
    }

    /// The axis-aligned box `min`..`max` (world frame) as an oriented box with yaw 0 (π/2
    /// when it is longer along ground axis 1).
    pub fn from_aabb(ground: GroundFrame, min: [f64; 3], max: [f64; 3]) -> OrientedBox {
        let (ha, hb) = (ground.height(min), ground.height(max));
        OrientedBox::from_ground_bounds(
            ground.ground(min),
            ground.ground(max),
            [ha.min(hb), ha.max(hb)],
        )
    }

    /// The ground rectangle with opposite corners `a` and `b` and the height range
    /// `height_m` as an oriented box with yaw 0 (π/2 when it is longer along ground axis 1).
    pub fn from_ground_bounds(a: [f64; 2], b: [f64; 2], height_m: [f64; 2]) -> OrientedBox {
        let he = [(a[0] - b[0]).abs() / 2.0, (a[1] - b[1]).abs() / 2.0];
        let (half_extents, yaw_rad) = if he[1] > he[0] {
            ([he[1], he[0]], std::f64::consts::FRAC_PI_2)
        } else {
            (he, 0.0)
        };
        OrientedBox {
            center: [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0],
            half_extents,
            yaw_rad,
            height_m,
        }
    }

    /// The same box with each footprint side at least `min_side_m` long (about its centre),
    /// so that thin objects (a fence, a pole) keep an area.
    pub fn widened(&self, min_side_m: f64) -> OrientedBox {
        let h = min_side_m / 2.0;
        OrientedBox {
            half_extents: [self.half_extents[0].max(h), self.half_extents[1].max(h)],
            ..*self
        }
    }

    /// The unit first and second axes in ground coordinates.
    pub fn axes(&self) -> [Vector2<f64>; 2] {
        let r = Rotation2::new(self.yaw_rad);
        [r * Vector2::x(), r * Vector2::y()]
    }

    /// The footprint's corners, counter-clockwise (in ground coordinates), ground frame.
    pub fn corners(&self) -> [[f64; 2]; 4] {
        let [u, v] = self.axes();
        let c = Vector2::new(self.center[0], self.center[1]);
        let (a, b) = (u * self.half_extents[0], v * self.half_extents[1]);
        [c - a - b, c + a - b, c + a + b, c - a + b].map(|p| [p.x, p.y])
    }

    /// Footprint area, square metres.
    pub fn footprint_area(&self) -> f64 {
        4.0 * self.half_extents[0] * self.half_extents[1]
    }

    /// Height of the box, metres.
    pub fn height_span_m(&self) -> f64 {
        (self.height_m[1] - self.height_m[0]).max(0.0)
    }

    /// Volume, cubic metres.
    pub fn volume(&self) -> f64 {
        self.footprint_area() * self.height_span_m()
    }

    /// Area of the intersection of the two footprints, square metres (computed around this
    /// box's centre).
    pub fn footprint_intersection_area(&self, o: &OrientedBox) -> f64 {
        if self.footprint_area() <= 0.0 || o.footprint_area() <= 0.0 {
            return 0.0;
        }
        // a cheap rejection: circumscribed circles apart
        let d = Vector2::new(o.center[0] - self.center[0], o.center[1] - self.center[1]);
        let r = |b: &OrientedBox| b.half_extents[0].hypot(b.half_extents[1]);
        if d.norm() > r(self) + r(o) {
            return 0.0;
        }
        let rel = |b: &OrientedBox| -> Vec<Vector2<f64>> {
            b.corners()
                .iter()
                .map(|p| Vector2::new(p[0] - self.center[0], p[1] - self.center[1]))
                .collect()
        };
        polygon_area(&clip_convex(&rel(o), &rel(self)))
    }

    /// Intersection over union of the footprints; 0 when either has no area.
    pub fn footprint_iou(&self, o: &OrientedBox) -> f64 {
        let inter = self.footprint_intersection_area(o);
        let union = self.footprint_area() + o.footprint_area() - inter;
        if union > 0.0 {
            (inter / union).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Intersection over union of the volumes (footprint intersection × height overlap);
    /// 0 when either has no volume.
    pub fn iou(&self, o: &OrientedBox) -> f64 {
        let dh =
            (self.height_m[1].min(o.height_m[1]) - self.height_m[0].max(o.height_m[0])).max(0.0);
        if dh <= 0.0 {
            return 0.0;
        }
        let inter = self.footprint_intersection_area(o) * dh;
        let union = self.volume() + o.volume() - inter;
        if union > 0.0 {
            (inter / union).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Whether the ground point `g` lies in the footprint (the rim counts).
    pub fn contains_ground(&self, g: [f64; 2]) -> bool {
        self.ground_distance(g) <= 0.0
    }

    /// Distance from the ground point `g` to the footprint, metres (0 inside).
    pub fn ground_distance(&self, g: [f64; 2]) -> f64 {
        let [u, v] = self.axes();
        let d = Vector2::new(g[0] - self.center[0], g[1] - self.center[1]);
        let out_u = (d.dot(&u).abs() - self.half_extents[0]).max(0.0);
        let out_v = (d.dot(&v).abs() - self.half_extents[1]).max(0.0);
        out_u.hypot(out_v)
    }

    /// The box as [`OBB_VALUES`] numbers, the `Instance.obb` property:
    /// `[center_0, center_1, half_length_m, half_width_m, yaw_rad, bottom_m, top_m]`.
    pub fn to_values(&self) -> [f64; OBB_VALUES] {
        [
            self.center[0],
            self.center[1],
            self.half_extents[0],
            self.half_extents[1],
            self.yaw_rad,
            self.height_m[0],
            self.height_m[1],
        ]
    }

    /// The inverse of [`OrientedBox::to_values`]; `None` unless there are exactly
    /// [`OBB_VALUES`] finite values with non-negative extents and bottom ≤ top.
    pub fn from_values(v: &[f64]) -> Option<OrientedBox> {
        let v: [f64; OBB_VALUES] = v.try_into().ok()?;
        let ok = v.iter().all(|x| x.is_finite()) && v[2] >= 0.0 && v[3] >= 0.0 && v[5] <= v[6];
        ok.then_some(OrientedBox {
            center: [v[0], v[1]],
            half_extents: [v[2], v[3]],
            yaw_rad: v[4],
            height_m: [v[5], v[6]],
        })
    }
}

/// Shoelace area of a polygon given in order (either winding), square metres.
fn polygon_area(p: &[Vector2<f64>]) -> f64 {
    if p.len() < 3 {
        return 0.0;
    }
    let mut s = 0.0;
    for (i, a) in p.iter().enumerate() {
        let b = p[(i + 1) % p.len()];
        s += a.x * b.y - b.x * a.y;
    }
    s.abs() / 2.0
}

/// `subject` clipped to the convex, counter-clockwise polygon `clip` (Sutherland and
/// Hodgman, "Reentrant polygon clipping", CACM 17(1), 1974). parry2d's convex polygon
/// intersection loses the overlap of two boxes that share edges (a box with itself gave
/// an empty polygon), which association meets whenever an object is seen again unchanged.
fn clip_convex(subject: &[Vector2<f64>], clip: &[Vector2<f64>]) -> Vec<Vector2<f64>> {
    let cross = |a: Vector2<f64>, b: Vector2<f64>| a.x * b.y - a.y * b.x;
    let mut out = subject.to_vec();
    for (i, a) in clip.iter().enumerate() {
        let b = clip[(i + 1) % clip.len()];
        let e = b - a;
        let side = |p: Vector2<f64>| cross(e, p - a);
        let input = std::mem::take(&mut out);
        for (j, p) in input.iter().enumerate() {
            let q = input[(j + 1) % input.len()];
            let (sp, sq) = (side(*p), side(q));
            if sp >= 0.0 {
                out.push(*p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                let t = sp / (sp - sq);
                out.push(p + (q - p) * t);
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

/// Centre, half extents (long side first) and yaw of the minimum-area rectangle around a
/// convex hull given counter-clockwise (one or two points allowed).
fn min_area_rectangle(hull: &[Vector2<f64>]) -> (Vector2<f64>, [f64; 2], f64) {
    let mut best: Option<(f64, Vector2<f64>, [f64; 2], f64)> = None;
    let n = hull.len();
    for i in 0..n.max(1) {
        let e = if n >= 2 {
            hull[(i + 1) % n] - hull[i]
        } else {
            Vector2::x()
        };
        let len = e.norm();
        if n >= 2 && len <= 0.0 {
            continue;
        }
        let u = if n >= 2 { e / len } else { e };
        let v = Vector2::new(-u.y, u.x);
        let (mut lu, mut hu, mut lv, mut hv) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for p in hull {
            let (a, b) = (p.dot(&u), p.dot(&v));
            lu = lu.min(a);
            hu = hu.max(a);
            lv = lv.min(b);
            hv = hv.max(b);
        }
        let area = (hu - lu) * (hv - lv);
        if best.as_ref().is_none_or(|b| area < b.0 - 1e-12) {
            let c = u * ((lu + hu) / 2.0) + v * ((lv + hv) / 2.0);
            let (mut he, mut axis) = ([(hu - lu) / 2.0, (hv - lv) / 2.0], u);
            if he[1] > he[0] {
                he = [he[1], he[0]];
                axis = v;
            }
            best = Some((area, c, he, normal_yaw(axis.y.atan2(axis.x))));
        }
    }
    let (_, c, he, yaw) = best.unwrap_or((0.0, Vector2::zeros(), [0.0, 0.0], 0.0));
    (c, he, yaw)
}

/// The same axis direction with yaw in `(-π/2, π/2]`.
fn normal_yaw(mut a: f64) -> f64 {
    use std::f64::consts::PI;
    while a > PI / 2.0 {
        a -= PI;
    }
    while a <= -PI / 2.0 {
        a += PI;
    }
    a
}

#[cfg(test)]
// exact values are expected: they are copied or computed from exact inputs
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    const EPS: f64 = 1e-4;

    /// Points filling a w × d rectangle turned by yaw around c, heights 0..2, ENU.
    fn rect_points(c: [f64; 2], w: f64, d: f64, yaw: f64) -> Vec<[f64; 3]> {
        let r = Rotation2::new(yaw);
        let mut out = Vec::new();
        for i in 0..=10 {
            for j in 0..=10 {
                let p = r * Vector2::new(
                    w * (f64::from(i) / 10.0 - 0.5),
                    d * (f64::from(j) / 10.0 - 0.5),
                );
                out.push([c[0] + p.x, c[1] + p.y, f64::from(i % 3)]);
            }
        }
        out
    }

    fn yaw_gap(a: f64, b: f64) -> f64 {
        let d = (a - b).rem_euclid(PI);
        d.min(PI - d)
    }

    #[test]
    fn a_turned_rectangle_is_recovered() {
        let b = OrientedBox::fit_f64(
            GroundFrame::Enu,
            &rect_points([100.0, -50.0], 4.0, 2.0, 0.5),
        )
        .unwrap();
        assert!((b.center[0] - 100.0).abs() < EPS && (b.center[1] + 50.0).abs() < EPS);
        assert!((b.half_extents[0] - 2.0).abs() < EPS && (b.half_extents[1] - 1.0).abs() < EPS);
        assert!(yaw_gap(b.yaw_rad, 0.5) < EPS, "{b:?}");
        assert_eq!(b.height_m, [0.0, 2.0]);
        // KITTI camera frame: ground (x, z), up is -y
        let kitti: Vec<[f64; 3]> = rect_points([3.0, 7.0], 4.0, 2.0, -0.3)
            .iter()
            .map(|p| [p[0], -p[2], p[1]])
            .collect();
        let k = OrientedBox::fit_f64(GroundFrame::KittiCam, &kitti).unwrap();
        assert!((k.center[0] - 3.0).abs() < EPS && (k.center[1] - 7.0).abs() < EPS);
        assert!(yaw_gap(k.yaw_rad, -0.3) < EPS && k.height_m == [0.0, 2.0]);
    }

    #[test]
    fn degenerate_point_sets_give_degenerate_boxes() {
        assert!(OrientedBox::fit(GroundFrame::Enu, &[]).is_none());
        assert!(OrientedBox::fit(GroundFrame::Enu, &[[f32::NAN, 0.0, 0.0]]).is_none());
        let one = OrientedBox::fit(GroundFrame::Enu, &[[1.0, 2.0, 3.0]; 4]).unwrap();
        assert_eq!(one.center, [1.0, 2.0]);
        assert_eq!(one.half_extents, [0.0, 0.0]);
        let line = OrientedBox::fit(
            GroundFrame::Enu,
            &[[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 1.0]],
        )
        .unwrap();
        assert!((line.half_extents[0] - 2f64.sqrt()).abs() < EPS);
        assert!(line.half_extents[1].abs() < EPS);
        assert!(yaw_gap(line.yaw_rad, PI / 4.0) < EPS);
        assert_eq!(line.iou(&line), 0.0, "no volume, no IoU");
    }

    fn line_box() -> OrientedBox {
        OrientedBox {
            center: [0.0, 0.0],
            half_extents: [2.0, 0.0],
            yaw_rad: 0.3,
            height_m: [0.0, 1.0],
        }
    }

    #[test]
    fn known_overlaps() {
        let a = OrientedBox {
            center: [0.0, 0.0],
            half_extents: [1.0, 1.0],
            yaw_rad: 0.0,
            height_m: [0.0, 1.0],
        };
        let b = OrientedBox {
            center: [1.0, 0.0],
            ..a
        };
        assert!((a.footprint_intersection_area(&b) - 2.0).abs() < EPS);
        assert!((a.iou(&b) - 2.0 / 6.0).abs() < EPS);
        // a square turned 45° inside a larger one
        let c = OrientedBox {
            half_extents: [0.5, 0.5],
            yaw_rad: PI / 4.0,
            ..a
        };
        assert!((a.footprint_intersection_area(&c) - 1.0).abs() < EPS);
        assert!((a.ground_distance([3.0, 0.0]) - 2.0).abs() < EPS);
        assert!(c.contains_ground([0.0, 0.7]) && !c.contains_ground([0.5, 0.5]));
        let far = OrientedBox {
            center: [10.0, 0.0],
            ..a
        };
        assert_eq!(a.iou(&far), 0.0);
        let above = OrientedBox {
            height_m: [2.0, 3.0],
            ..a
        };
        assert_eq!(a.iou(&above), 0.0);
        assert_eq!(OrientedBox::from_values(&a.to_values()), Some(a));
        // from corners, in either winding; from an axis-aligned box in both frames
        let r = OrientedBox::from_rectangle(&c.corners(), [0.0, 1.0]);
        assert!((r.half_extents[0] - 0.5).abs() < EPS && yaw_gap(r.yaw_rad, PI / 4.0) < EPS);
        let mut rev = c.corners();
        rev.reverse();
        assert!((OrientedBox::from_rectangle(&rev, [0.0, 1.0]).iou(&c) - 1.0).abs() < EPS);
        let k = OrientedBox::from_aabb(GroundFrame::KittiCam, [0.0, -2.0, 0.0], [1.0, 0.0, 3.0]);
        assert!((k.half_extents[0] - 1.5).abs() < EPS && (k.half_extents[1] - 0.5).abs() < EPS);
        assert!((k.yaw_rad - PI / 2.0).abs() < EPS && k.height_m == [0.0, 2.0]);
        assert!(k.contains_ground([0.9, 2.9]) && !k.contains_ground([1.1, 2.9]));
        let w = line_box().widened(1.0);
        assert!((w.half_extents[1] - 0.5).abs() < EPS && w.footprint_area() > 0.0);
        assert_eq!(OrientedBox::from_values(&[0.0; 6]), None);
        assert_eq!(
            OrientedBox::from_values(&[0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0]),
            None
        );
    }

    proptest! {
        /// Every point lies in the fitted box, the box is no larger than the axis-aligned
        /// one, and a box overlaps itself fully.
        #[test]
        fn the_fit_encloses_and_beats_the_axis_aligned_box(
            pts in prop::collection::vec((-50.0f64..50.0, -50.0f64..50.0, -3.0f64..3.0), 3..60)
        ) {
            let world: Vec<[f64; 3]> = pts.iter().map(|p| [p.0, p.1, p.2]).collect();
            let b = OrientedBox::fit_f64(GroundFrame::Enu, &world).unwrap();
            for p in &world {
                prop_assert!(b.ground_distance([p[0], p[1]]) < 1e-3, "{p:?} outside {b:?}");
                prop_assert!(p[2] >= b.height_m[0] && p[2] <= b.height_m[1]);
            }
            let ext = |k: usize| {
                let (lo, hi) = world.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p[k]), h.max(p[k])));
                hi - lo
            };
            prop_assert!(b.footprint_area() <= ext(0) * ext(1) + 1e-3);
            prop_assert!(b.half_extents[0] >= b.half_extents[1]);
            prop_assert!(b.yaw_rad > -PI / 2.0 - 1e-12 && b.yaw_rad <= PI / 2.0 + 1e-12);
            if b.volume() > 1e-3 {
                prop_assert!((b.iou(&b) - 1.0).abs() < 1e-3);
            }
        }

        /// IoU is symmetric and in [0, 1]; the intersection is no larger than either box.
        #[test]
        fn iou_is_symmetric_and_bounded(
            a in (-5.0f64..5.0, -5.0f64..5.0, 0.1f64..4.0, 0.1f64..4.0, -3.0f64..3.0),
            b in (-5.0f64..5.0, -5.0f64..5.0, 0.1f64..4.0, 0.1f64..4.0, -3.0f64..3.0),
        ) {
            let mk = |t: (f64, f64, f64, f64, f64)| OrientedBox {
                center: [t.0, t.1],
                half_extents: [t.2.max(t.3), t.2.min(t.3)],
                yaw_rad: normal_yaw(t.4),
                height_m: [0.0, 1.0],
            };
            let (a, b) = (mk(a), mk(b));
            let (ab, ba) = (a.iou(&b), b.iou(&a));
            prop_assert!((ab - ba).abs() < 1e-3, "{ab} vs {ba}");
            prop_assert!((0.0..=1.0).contains(&ab));
            let i = a.footprint_intersection_area(&b);
            prop_assert!(i <= a.footprint_area().min(b.footprint_area()) + 1e-3);
            // Monte Carlo reference for the intersection area on a grid over a
            let n = 40;
            let [u, v] = a.axes();
            let mut inside = 0;
            for s in 0..n {
                for t in 0..n {
                    let fs = (f64::from(s) + 0.5) / f64::from(n) * 2.0 - 1.0;
                    let ft = (f64::from(t) + 0.5) / f64::from(n) * 2.0 - 1.0;
                    let p = Vector2::new(a.center[0], a.center[1]) + u * (fs * a.half_extents[0]) + v * (ft * a.half_extents[1]);
                    if b.contains_ground([p.x, p.y]) { inside += 1; }
                }
            }
            let reference = a.footprint_area() * f64::from(inside) / f64::from(n * n);
            // the grid errs only in cells that b's outline crosses
            let cell_diag = (2.0 * a.half_extents[0] / f64::from(n)).hypot(2.0 * a.half_extents[1] / f64::from(n));
            let outline = 4.0 * (b.half_extents[0] + b.half_extents[1]);
            prop_assert!((i - reference).abs() <= outline * cell_diag + 1e-3, "{i} vs grid {reference}");
        }
    }
}
