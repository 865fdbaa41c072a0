//! Geometry on the ground plane: points in ground metres (a [`GroundFrame`](crate::GroundFrame)'s
//! two ground axes: KITTI's (x, z), or ENU's (x, y)), distances and polylines.

/// A point on the ground plane, metres, in the map's ground frame.
pub type GroundPoint = [f64; 2];

/// Euclidean distance between two ground points, metres.
pub fn dist(a: GroundPoint, b: GroundPoint) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// The axis-aligned bounds `[min, max]` of `points`, metres; for no points, min is +inf and
/// max is -inf (a box that meets nothing).
pub fn bounds<P: std::borrow::Borrow<GroundPoint>>(
    points: impl IntoIterator<Item = P>,
) -> [GroundPoint; 2] {
    let mut b = [[f64::INFINITY; 2], [f64::NEG_INFINITY; 2]];
    for q in points {
        let q = q.borrow();
        for k in 0..2 {
            b[0][k] = b[0][k].min(q[k]);
            b[1][k] = b[1][k].max(q[k]);
        }
    }
    b
}

/// Length of a polyline, metres (0 for fewer than two points).
pub fn polyline_length(p: &[GroundPoint]) -> f64 {
    p.windows(2).map(|w| dist(w[0], w[1])).sum()
}

/// The point of the segment `a`–`b` closest to `p`: (its parameter t in \[0, 1\] from `a`,
/// the point). A degenerate segment gives (0, `a`).
pub fn closest_on_segment(p: GroundPoint, a: GroundPoint, b: GroundPoint) -> (f64, GroundPoint) {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (t, [a[0] + t * d[0], a[1] + t * d[1]])
}

/// Distance from `p` to the segment `a`–`b`, metres.
pub fn point_segment_distance(p: GroundPoint, a: GroundPoint, b: GroundPoint) -> f64 {
    point_segment_distance_sq(p, a, b).sqrt()
}

/// The square of [`point_segment_distance`], m²: for taking the least over many segments
/// with one square root at the end.
pub fn point_segment_distance_sq(p: GroundPoint, a: GroundPoint, b: GroundPoint) -> f64 {
    let q = closest_on_segment(p, a, b).1;
    (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)
}

/// Distance from `p` to a polyline, metres (infinite for fewer than two points).
pub fn polyline_distance(p: GroundPoint, poly: &[GroundPoint]) -> f64 {
    poly.windows(2)
        .map(|w| point_segment_distance_sq(p, w[0], w[1]))
        .fold(f64::INFINITY, f64::min)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const EPS: f64 = 1e-9;

    #[test]
    fn closest_point_of_a_segment() {
        let (t, q) = closest_on_segment([5.0, 3.0], [0.0, 0.0], [10.0, 0.0]);
        assert!((t - 0.5).abs() < EPS && dist(q, [5.0, 0.0]) < EPS);
        let (t, q) = closest_on_segment([-4.0, 3.0], [0.0, 0.0], [10.0, 0.0]);
        assert!(t.abs() < EPS && dist(q, [0.0, 0.0]) < EPS);
        assert_eq!(
            closest_on_segment([1.0, 1.0], [2.0, 2.0], [2.0, 2.0]),
            (0.0, [2.0, 2.0])
        );
        assert!((polyline_length(&[[0.0, 0.0], [3.0, 4.0], [3.0, 10.0]]) - 11.0).abs() < EPS);
        assert!(polyline_distance([0.0, 0.0], &[[1.0, 1.0]]).is_infinite());
    }

    proptest! {
        /// The closest point is no farther than either end, and lies on the segment.
        #[test]
        fn closest_is_closest(p in prop::array::uniform2(-100.0..100.0f64),
                              a in prop::array::uniform2(-100.0..100.0f64),
                              b in prop::array::uniform2(-100.0..100.0f64)) {
            let (t, q) = closest_on_segment(p, a, b);
            prop_assert!((0.0..=1.0).contains(&t));
            let d = point_segment_distance(p, a, b);
            prop_assert!(d <= dist(p, a) + EPS && d <= dist(p, b) + EPS);
            prop_assert!((dist(a, q) + dist(q, b) - dist(a, b)).abs() < 1e-6);
        }
    }
}
