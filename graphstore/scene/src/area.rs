//! Road-segment areas on the ground plane: a junction's disc or a road's corridor (its centre
//! line buffered by a half width), with distances for membership. One type for the hierarchy
//! that writes segments (ingest) and for retrieval and localisation that read them (llm_tools).

use parry2d::math::{Pose, Vector};
use parry2d::query::PointQuery;
use parry2d::shape::Ball;

use crate::geom::{bounds, point_segment_distance_sq, polyline_distance};

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
                    polyline_distance(p, centreline)
                };
                (d - half_width_m).max(0.0)
            }
        }
    }

    /// Whether `p` lies in the area.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        self.distance(p) <= 0.0
    }

    /// The axis-aligned bounds `[min, max]` of the area on the ground plane, metres; every
    /// point of the area lies inside, so the distance to the bounds is a lower bound of
    /// [`SegmentArea::distance`].
    pub fn bounds(&self) -> [[f64; 2]; 2] {
        match self {
            SegmentArea::Disc { centre, radius_m } => [
                [centre[0] - radius_m, centre[1] - radius_m],
                [centre[0] + radius_m, centre[1] + radius_m],
            ],
            SegmentArea::Corridor {
                centreline,
                half_width_m,
            } => {
                // with no centreline, distance() measures from the origin
                let [lo, hi] = if centreline.is_empty() {
                    [[0.0, 0.0]; 2]
                } else {
                    bounds(centreline)
                };
                [
                    [lo[0] - half_width_m, lo[1] - half_width_m],
                    [hi[0] + half_width_m, hi[1] + half_width_m],
                ]
            }
        }
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
        let gap = |a: [f64; 2], b: [f64; 2]| point_segment_distance_sq(p, a, b);
        let best = centreline
            .windows(2)
            .min_by(|a, b| gap(a[0], a[1]).total_cmp(&gap(b[0], b[1])))?;
        let d = [best[1][0] - best[0][0], best[1][1] - best[0][1]];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
        (l > 0.0).then(|| [d[0] / l, d[1] / l])
    }
}

/// The nearest of many areas to `p` (ground metres), given each one's bounds (`[min, max]`,
/// every point of the area inside) and its distance: areas are measured nearest-bound first
/// ([`box_gap`] is a lower bound of the distance) and the search stops once a bound is past
/// the best distance found. Returns the index and distance of the least distance, ties to
/// the smaller index: the same as measuring every one. `None` when there are none.
pub fn nearest_by_bounds(
    bounds: &[[[f64; 2]; 2]],
    p: [f64; 2],
    mut distance: impl FnMut(usize) -> f64,
) -> Option<(usize, f64)> {
    let mut order: Vec<(f64, usize)> = bounds
        .iter()
        .enumerate()
        .map(|(i, b)| (box_gap(b, p), i))
        .collect();
    order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut best: Option<(usize, f64)> = None;
    for (lower, i) in order {
        if best.is_some_and(|(_, d)| lower > d) {
            break;
        }
        let d = distance(i);
        if best.is_none_or(|(bi, bd)| d.total_cmp(&bd).then(i.cmp(&bi)).is_lt()) {
            best = Some((i, d));
        }
    }
    best
}

/// The road direction near many points (one per pair of instances when the hierarchy labels
/// relations): the direction of the corridor nearest each point ([`nearest_by_bounds`]; the
/// same corridor as measuring every one, ties to the first given).
#[derive(Debug, Clone)]
pub struct RoadDirections<'a> {
    corridors: Vec<&'a SegmentArea>,
    bounds: Vec<[[f64; 2]; 2]>,
}

impl<'a> RoadDirections<'a> {
    /// The corridors among `areas` (discs have no direction), in the order given.
    pub fn new(areas: impl IntoIterator<Item = &'a SegmentArea>) -> Self {
        let corridors: Vec<&SegmentArea> = areas
            .into_iter()
            .filter(|a| matches!(a, SegmentArea::Corridor { .. }))
            .collect();
        let bounds = corridors.iter().map(|a| a.bounds()).collect();
        Self { corridors, bounds }
    }

    /// The corridor nearest `p` (ground metres); `None` without corridors.
    pub fn nearest(&self, p: [f64; 2]) -> Option<&'a SegmentArea> {
        nearest_by_bounds(&self.bounds, p, |i| self.corridors[i].distance(p))
            .map(|(i, _)| self.corridors[i])
    }

    /// The road direction (unit vector) at the nearest corridor's point nearest `p`
    /// ([`SegmentArea::direction_near`]); `None` without corridors.
    pub fn direction_near(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        self.nearest(p)?.direction_near(p)
    }
}

/// How far `p` is from a segment, for membership (`IN_SEGMENT`): from its drivable area
/// measured from the map when it has one, else from its trajectory `area`. Metres, 0 inside.
pub fn membership_distance(area: &SegmentArea, drivable: Option<&Drivable>, p: [f64; 2]) -> f64 {
    match drivable {
        Some(d) if !d.is_empty() => d.distance(p),
        _ => area.distance(p),
    }
}

/// The bounds `[min, max]` of what [`membership_distance`] measures from (the drivable area
/// when it has one, else the trajectory area): the distance from `p` to them is a lower bound
/// of the membership distance.
pub fn membership_bounds(area: &SegmentArea, drivable: Option<&Drivable>) -> [[f64; 2]; 2] {
    match drivable {
        Some(d) if !d.is_empty() => d.bounds(),
        _ => area.bounds(),
    }
}

/// Distance from `p` to the box `b` (`[min, max]`), metres; 0 inside.
pub fn box_gap(b: &[[f64; 2]; 2], p: [f64; 2]) -> f64 {
    let dx = (b[0][0] - p[0]).max(p[0] - b[1][0]).max(0.0);
    let dy = (b[0][1] - p[1]).max(p[1] - b[1][1]).max(0.0);
    (dx * dx + dy * dy).sqrt()
}

/// A segment's drivable area measured from the map: closed rings on the ground plane whose
/// even-odd interior is the area (outer boundaries counter-clockwise, holes clockwise), as
/// [`Drivable::from_triangles`] traces them around a set of triangles.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Drivable {
    /// The rings, each closed implicitly (last vertex joins the first), ground metres.
    pub rings: Vec<Vec<[f64; 2]>>,
}

impl Drivable {
    /// The axis-aligned bounds `[min, max]` of the rings, ground metres (infinite, min above
    /// max, when there are none): every point of the area lies inside, so the distance to the
    /// bounds ([`box_gap`]) is a lower bound of [`Drivable::distance`].
    pub fn bounds(&self) -> [[f64; 2]; 2] {
        bounds(self.rings.iter().flatten())
    }

    /// The outline of the union of `triangles` (each given counter-clockwise, sharing exact
    /// vertex coordinates where they touch, as a triangulation's faces do): every directed
    /// edge whose reverse is not an edge of another triangle is on the boundary, and the
    /// boundary edges are chained into rings. Where rings touch at a vertex the chaining
    /// may split or join them differently; the even-odd interior is the same.
    pub fn from_triangles(triangles: &[[[f64; 2]; 3]]) -> Drivable {
        use std::collections::{BTreeMap, BTreeSet};
        let key = |p: [f64; 2]| (p[0].to_bits(), p[1].to_bits());
        let mut edges: BTreeSet<((u64, u64), (u64, u64))> = BTreeSet::new();
        let mut pos: BTreeMap<(u64, u64), [f64; 2]> = BTreeMap::new();
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                pos.insert(key(a), a);
                edges.insert((key(a), key(b)));
            }
        }
        // boundary: no twin
        let mut next: BTreeMap<(u64, u64), Vec<(u64, u64)>> = BTreeMap::new();
        for (a, b) in &edges {
            if !edges.contains(&(*b, *a)) {
                next.entry(*a).or_default().push(*b);
            }
        }
        let mut rings = Vec::new();
        let starts: Vec<(u64, u64)> = next.keys().copied().collect();
        for start in starts {
            while next.get(&start).is_some_and(|v| !v.is_empty()) {
                let mut ring = vec![pos[&start]];
                let mut at = start;
                while let Some(b) = next.get_mut(&at).and_then(Vec::pop) {
                    if b == start {
                        break;
                    }
                    ring.push(pos[&b]);
                    at = b;
                }
                if ring.len() >= 3 {
                    rings.push(ring);
                }
            }
        }
        Drivable { rings }
    }

    /// Area in square metres (the signed ring areas summed: holes subtract).
    pub fn area_m2(&self) -> f64 {
        self.rings
            .iter()
            .map(|r| {
                (0..r.len())
                    .map(|i| {
                        let (a, b) = (r[i], r[(i + 1) % r.len()]);
                        a[0] * b[1] - b[0] * a[1]
                    })
                    .sum::<f64>()
                    / 2.0
            })
            .sum::<f64>()
            .max(0.0)
    }

    /// Every ring edge `(from, to)`, the closing ones included.
    fn edges(&self) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
        self.rings
            .iter()
            .flat_map(|r| (0..r.len()).map(move |i| (r[i], r[(i + 1) % r.len()])))
    }

    /// Whether `p` lies inside (even-odd rule over all rings).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        even_odd(self.edges(), p)
    }

    /// Distance from `p` to the area, metres (0 inside; infinite for an empty area).
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        if self.contains(p) {
            return 0.0;
        }
        self.edges()
            .map(|(a, b)| point_segment_distance_sq(p, a, b))
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    }

    /// The drivable area of Segment node `id` (its `polygon` property); `None` when it has
    /// none, or an empty or malformed one.
    ///
    /// # Errors
    /// The store fails.
    pub fn of_segment(
        r: &impl graphstore::GraphRead,
        id: u64,
        frame: crate::GroundFrame,
    ) -> graphstore::Result<Option<Drivable>> {
        Ok(r.node_prop(id, crate::key::POLYGON)?
            .and_then(|v| Drivable::from_property(&v, frame))
            .filter(|d| !d.is_empty()))
    }

    /// The area of a `Segment.polygon` property (a list of rings, each a list of world
    /// points); `None` for anything else.
    fn from_property(v: &graphstore::Value, frame: crate::GroundFrame) -> Option<Drivable> {
        use graphstore::Value;
        let Value::List(rings) = v else { return None };
        let rings: Option<Vec<Vec<[f64; 2]>>> = rings
            .iter()
            .map(|r| match r {
                Value::List(pts) => pts
                    .iter()
                    .map(|p| p.as_point3().map(|w| frame.ground(w)))
                    .collect(),
                _ => None,
            })
            .collect();
        rings.map(|rings| Drivable { rings })
    }

    /// Whether there is no ring.
    pub fn is_empty(&self) -> bool {
        self.rings.is_empty()
    }
}

/// Whether `p` is inside the closed curves made of `edges` by the even-odd rule: a ray from
/// `p` along +x crosses an odd number of them.
fn even_odd(edges: impl IntoIterator<Item = ([f64; 2], [f64; 2])>, p: [f64; 2]) -> bool {
    let mut inside = false;
    for (a, b) in edges {
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Several drivable areas with disjoint interiors (the segments' polygons) behind one
/// index for many point queries: every ring edge is filed under the 1 m bands of the second
/// ground axis it spans, so a query reads only the edges of its band. Even-odd over all the
/// rings is their union, as the interiors do not overlap (an edge two areas share is crossed
/// twice).
#[derive(Debug, Clone, Default)]
pub struct DrivableIndex {
    y0: f64,
    bands: Vec<Vec<([f64; 2], [f64; 2])>>,
}

const BAND_M: f64 = 1.0;

impl DrivableIndex {
    /// The index of `areas`.
    pub fn new(areas: &[Drivable]) -> DrivableIndex {
        let edges: Vec<([f64; 2], [f64; 2])> = areas
            .iter()
            .flat_map(Drivable::edges)
            .filter(|(a, b)| a.iter().chain(b).all(|c| c.is_finite()))
            .collect();
        let y0 = edges
            .iter()
            .map(|(a, b)| a[1].min(b[1]))
            .fold(f64::INFINITY, f64::min);
        if !y0.is_finite() {
            return DrivableIndex::default();
        }
        let band = |y: f64| ((y - y0) / BAND_M).floor().max(0.0) as usize;
        let n = edges
            .iter()
            .map(|(a, b)| band(a[1].max(b[1])) + 1)
            .max()
            .unwrap_or(0);
        let mut bands = vec![Vec::new(); n];
        for (a, b) in edges {
            let (lo, hi) = (band(a[1].min(b[1])), band(a[1].max(b[1])));
            for edges in &mut bands[lo..=hi] {
                edges.push((a, b));
            }
        }
        DrivableIndex { y0, bands }
    }

    fn band(&self, y: f64) -> Option<&Vec<([f64; 2], [f64; 2])>> {
        let k = (y - self.y0) / BAND_M;
        (k >= 0.0)
            .then(|| self.bands.get(k.floor() as usize))
            .flatten()
    }

    /// Whether there is no area.
    pub fn is_empty(&self) -> bool {
        self.bands.is_empty()
    }

    /// Whether `p` lies in one of the areas.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        self.band(p[1])
            .is_some_and(|edges| even_odd(edges.iter().copied(), p))
    }

    /// Whether `p` lies in one of the areas or within `tolerance_m` of one.
    pub fn within(&self, p: [f64; 2], tolerance_m: f64) -> bool {
        if self.contains(p) {
            return true;
        }
        // a negative or NaN tolerance admits nothing outside (its square would)
        if tolerance_m.is_nan() || tolerance_m < 0.0 {
            return false;
        }
        let lo = ((p[1] - tolerance_m - self.y0) / BAND_M).floor().max(0.0) as usize;
        let hi = ((p[1] + tolerance_m - self.y0) / BAND_M).floor();
        if hi < 0.0 {
            return false;
        }
        let hi = (hi as usize).min(self.bands.len().saturating_sub(1));
        let tolerance_sq = tolerance_m * tolerance_m;
        (lo..=hi).any(|k| {
            self.bands.get(k).is_some_and(|edges| {
                edges
                    .iter()
                    .any(|(a, b)| point_segment_distance_sq(p, *a, *b) <= tolerance_sq)
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// The pruned search finds the corridor a scan of every corridor finds (the first of
        /// the least distance), discs skipped.
        #[test]
        fn road_directions_match_the_scan(
            lines in proptest::collection::vec(
                (proptest::collection::vec((-50.0f64..50.0, -50.0f64..50.0), 1..5), 0.5f64..8.0, proptest::bool::ANY),
                0..12,
            ),
            p in (-80.0f64..80.0, -80.0f64..80.0),
        ) {
            let areas: Vec<SegmentArea> = lines
                .into_iter()
                .map(|(pts, w, disc)| {
                    if disc {
                        SegmentArea::Disc { centre: [pts[0].0, pts[0].1], radius_m: w }
                    } else {
                        SegmentArea::Corridor {
                            centreline: pts.into_iter().map(|(x, y)| [x, y]).collect(),
                            half_width_m: w,
                        }
                    }
                })
                .collect();
            let p = [p.0, p.1];
            let scan = areas
                .iter()
                .filter(|a| matches!(a, SegmentArea::Corridor { .. }))
                .min_by(|a, b| a.distance(p).total_cmp(&b.distance(p)));
            let got = RoadDirections::new(&areas).nearest(p);
            proptest::prop_assert_eq!(got.map(|a| a as *const _), scan.map(|a| a as *const _));
        }
    }

    #[test]
    fn drivable_outline_of_triangles_with_a_hole() {
        // a 3 × 3 grid of unit squares, two triangles each, without the middle square
        let mut tris = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                if (i, j) == (1, 1) {
                    continue;
                }
                let (x, y) = (f64::from(i), f64::from(j));
                tris.push([[x, y], [x + 1.0, y], [x + 1.0, y + 1.0]]);
                tris.push([[x, y], [x + 1.0, y + 1.0], [x, y + 1.0]]);
            }
        }
        let d = Drivable::from_triangles(&tris);
        assert_eq!(d.rings.len(), 2, "{:?}", d.rings);
        assert!((d.area_m2() - 8.0).abs() < 1e-9);
        assert!(d.contains([0.5, 0.5]) && d.contains([2.5, 1.5]));
        assert!(!d.contains([1.5, 1.5]), "the hole");
        assert!(!d.contains([3.5, 1.5]));
        assert!((d.distance([1.5, 1.5]) - 0.5).abs() < 1e-9);
        assert!((d.distance([5.0, 1.5]) - 2.0).abs() < 1e-9);
        assert!(d.distance([2.0, 2.0]).abs() < 1e-12);
        assert!(Drivable::default().distance([0.0, 0.0]).is_infinite());
        // the index agrees, also over two areas that share an edge
        let right: Vec<[[f64; 2]; 3]> =
            tris.iter().map(|t| t.map(|p| [p[0] + 3.0, p[1]])).collect();
        let both = [d.clone(), Drivable::from_triangles(&right)];
        let idx = DrivableIndex::new(&both);
        for k in 0..600 {
            let p = [
                f64::from(k % 30) * 0.23 - 0.4,
                f64::from(k / 30) * 0.19 - 0.3,
            ];
            let want = both.iter().any(|a| a.contains(p));
            assert_eq!(idx.contains(p), want, "{p:?}");
            let near = both.iter().any(|a| a.distance(p) <= 0.3);
            assert_eq!(idx.within(p, 0.3), near, "{p:?}");
            // a negative or NaN tolerance admits only points inside
            assert_eq!(idx.within(p, -0.3), want, "{p:?}");
            assert_eq!(idx.within(p, f64::NAN), want, "{p:?}");
        }
        assert!(
            DrivableIndex::new(&[]).is_empty() && !DrivableIndex::new(&[]).within([0.0, 0.0], 1.0)
        );
    }

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
