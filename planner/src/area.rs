//! Road-segment areas on the ground plane: a junction's disc or a road's corridor (its centre
//! line buffered by a half width), with distances for membership. One type for the hierarchy
//! that writes segments (ingest) and for retrieval and localisation that read them (llm_tools).

use parry2d::math::{Pose, Vector};
use parry2d::query::PointQuery;
use parry2d::shape::Ball;

use crate::route::closest_on_segment;

/// The area a segment covers.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub enum SegmentArea {
    /// A junction: a disc.
    Disc {
        /// Centre on the ground plane.
        centre: [f64; 2],
        /// Radius.
        radius_m: f64,
    },
    /// A road: the centreline buffered by a half-width.
    Corridor {
        /// Centreline on the ground plane.
        centreline: Vec<[f64; 2]>,
        /// Half-width.
        half_width_m: f64,
    },
}

fn v(p: [f64; 2]) -> Vector {
    Vector::new(p[0] as f32, p[1] as f32)
}

impl SegmentArea {
    /// Distance from `p` to the area (0 inside), computed with parry2d.
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        match self {
            SegmentArea::Disc { centre, radius_m } => {
                let ball = Ball::new(*radius_m as f32);
                f64::from(ball.distance_to_point(&Pose::from_translation(v(*centre)), v(p), true))
            }
            SegmentArea::Corridor {
                centreline,
                half_width_m,
            } => {
                // a direct scan over the segments: building a parry Polyline (and its BVH)
                // per query cost far more than the scan, and this is called per instance
                let d = if centreline.len() < 2 {
                    let c = centreline.first().copied().unwrap_or([0.0, 0.0]);
                    ((c[0] - p[0]).powi(2) + (c[1] - p[1]).powi(2)).sqrt()
                } else {
                    centreline
                        .windows(2)
                        .map(|w| {
                            let (_, q) = closest_on_segment(p, w[0], w[1]);
                            (p[0] - q[0]).hypot(p[1] - q[1])
                        })
                        .fold(f64::INFINITY, f64::min)
                };
                (d - half_width_m).max(0.0)
            }
        }
    }

    /// Whether `p` lies in the area.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        self.distance(p) <= 0.0
    }

    /// A closed ring approximating the outline of a disc (`n` vertices), or the centreline of a
    /// corridor (for display; containment uses [`Self::distance`]).
    pub fn outline(&self, n: usize) -> Vec<[f64; 2]> {
        match self {
            SegmentArea::Disc { centre, radius_m } => (0..=n)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / n as f64;
                    [
                        centre[0] + radius_m * a.cos(),
                        centre[1] + radius_m * a.sin(),
                    ]
                })
                .collect(),
            SegmentArea::Corridor { centreline, .. } => centreline.clone(),
        }
    }

    /// Where someone standing on the segment may be: for a disc its centre and six points
    /// at half its radius; for a corridor points along the centreline every `step_m` metres
    /// (its ends included). Ground plane, metres. `step_m` is clamped to at least 0.5 m.
    pub fn standing_spots(&self, step_m: f64) -> Vec<[f64; 2]> {
        match self {
            SegmentArea::Disc { centre, radius_m } => {
                let mut out = vec![*centre];
                for k in 0..6 {
                    let a = std::f64::consts::TAU * f64::from(k) / 6.0;
                    out.push([
                        centre[0] + 0.5 * radius_m * a.cos(),
                        centre[1] + 0.5 * radius_m * a.sin(),
                    ]);
                }
                out
            }
            SegmentArea::Corridor { centreline, .. } => {
                let step = if step_m.is_finite() {
                    step_m.max(0.5)
                } else {
                    5.0
                };
                let mut out: Vec<[f64; 2]> = centreline.first().copied().into_iter().collect();
                for w in centreline.windows(2) {
                    let len = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
                    let n = (len / step).ceil().max(1.0) as usize;
                    for k in 1..=n {
                        let t = k as f64 / n as f64;
                        out.push([
                            w[0][0] + t * (w[1][0] - w[0][0]),
                            w[0][1] + t * (w[1][1] - w[0][1]),
                        ]);
                    }
                }
                out
            }
        }
    }

    /// The road direction at the point of the area nearest to `p` (unit vector), for
    /// corridors; None for discs.
    pub fn direction_near(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        let SegmentArea::Corridor { centreline, .. } = self else {
            return None;
        };
        let gap = |a: [f64; 2], b: [f64; 2]| {
            let (_, q) = closest_on_segment(p, a, b);
            (p[0] - q[0]).hypot(p[1] - q[1])
        };
        let best = centreline
            .windows(2)
            .min_by(|a, b| gap(a[0], a[1]).total_cmp(&gap(b[0], b[1])))?;
        let d = [best[1][0] - best[0][0], best[1][1] - best[0][1]];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
        (l > 0.0).then(|| [d[0] / l, d[1] / l])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standing_spots_lie_on_the_area() {
        let disc = SegmentArea::Disc {
            centre: [10.0, -4.0],
            radius_m: 12.0,
        };
        let spots = disc.standing_spots(5.0);
        assert_eq!(spots.len(), 7);
        for p in &spots {
            assert!(disc.contains(*p), "{p:?}");
        }
        let road = SegmentArea::Corridor {
            centreline: vec![[0.0, 0.0], [100.0, 0.0], [100.0, 12.0]],
            half_width_m: 8.0,
        };
        let spots = road.standing_spots(5.0);
        // 20 steps along the first piece, 3 along the second, and the start
        assert_eq!(spots.len(), 24);
        for w in spots.windows(2) {
            let step = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
            assert!(step <= 5.0 + 1e-9 && step > 0.0, "{step}");
        }
        assert!((spots[23][1] - 12.0).abs() < 1e-9);
        // a NaN or tiny step is clamped, never an endless loop
        assert_eq!(road.standing_spots(f64::NAN).len(), 24);
        assert_eq!(road.standing_spots(0.0).len(), 225);
    }
}
