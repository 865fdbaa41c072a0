//! Segment and environment layers: a junction area (disc) around every intersection and
//! bend node, a road corridor (buffered centreline) for every stretch of lane between them,
//! `CONNECTS` between segments that join. Containment and distance go through parry2d.

use super::lanes::{LaneGraph, LaneNodeKind};
use scene::geom::{dist, polyline_length};

/// Segment parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SegmentConfig {
    /// Radius of a junction area.
    pub junction_radius_m: f64,
    /// Half-width of a road corridor.
    pub road_half_width_m: f64,
}

impl Default for SegmentConfig {
    fn default() -> Self {
        SegmentConfig {
            junction_radius_m: 12.0,
            road_half_width_m: 8.0,
        }
    }
}

/// Segment types.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SegmentKind {
    /// 4+ way junction area.
    Intersection,
    /// T-junction area.
    TIntersection,
    /// Bend area.
    LIntersection,
    /// Road between junction areas.
    StraightRoadway,
}

impl SegmentKind {
    /// The name used in the graph.
    pub fn as_str(self) -> &'static str {
        match self {
            SegmentKind::Intersection => "intersection",
            SegmentKind::TIntersection => "t_intersection",
            SegmentKind::LIntersection => "l_intersection",
            SegmentKind::StraightRoadway => "straight_roadway",
        }
    }
}

use scene::area::SegmentArea;

/// One segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Segment {
    /// Index in [`Segments::segments`].
    pub id: usize,
    /// Its type.
    pub kind: SegmentKind,
    /// Centroid on the ground plane.
    pub centroid: [f64; 2],
    /// Its area.
    pub area: SegmentArea,
    /// Lane nodes inside it.
    pub lane_nodes: Vec<usize>,
}

/// The segment layer.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Segments {
    /// Junction areas first (in lane-node order), then roads (in lane-edge order).
    pub segments: Vec<Segment>,
    /// Pairs of joining segments (smaller id first), sorted.
    pub connects: Vec<(usize, usize)>,
}

impl Segments {
    /// The segment nearest to `p` and the distance to it.
    pub fn nearest(&self, p: [f64; 2]) -> Option<(usize, f64)> {
        self.segments
            .iter()
            .map(|s| (s.id, s.area.distance(p)))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
    }

    /// A grid over the segments' bounds for [`SegmentGrid::nearest_within`], with cells of
    /// `cell_m` metres.
    pub fn grid(&self, cell_m: f64) -> SegmentGrid {
        let cell_m = if cell_m.is_finite() && cell_m > 0.0 {
            cell_m
        } else {
            50.0
        };
        let mut cells: std::collections::HashMap<(i64, i64), Vec<usize>> =
            std::collections::HashMap::new();
        let bounds: Vec<[[f64; 2]; 2]> = self.segments.iter().map(|s| s.area.bounds()).collect();
        for (i, b) in bounds.iter().enumerate() {
            let (lo, hi) = (cell_of(b[0], cell_m), cell_of(b[1], cell_m));
            // a huge area (a corrupt centreline) would fill millions of cells: keep it aside
            if (hi.0 - lo.0 + 1).saturating_mul(hi.1 - lo.1 + 1) > 100_000 {
                cells.entry((i64::MAX, i64::MAX)).or_default().push(i);
                continue;
            }
            for x in lo.0..=hi.0 {
                for y in lo.1..=hi.1 {
                    cells.entry((x, y)).or_default().push(i);
                }
            }
        }
        SegmentGrid {
            cell_m,
            cells,
            bounds,
        }
    }
}

fn cell_of(p: [f64; 2], cell_m: f64) -> (i64, i64) {
    // saturating casts: NaN goes to 0, far points to the ends
    (
        (p[0] / cell_m).floor() as i64,
        (p[1] / cell_m).floor() as i64,
    )
}

/// Segments bucketed by their bounds on a square grid, so that the segment nearest to a
/// point within a distance is found among the few whose bounds come that close, not by a
/// scan of every segment (which made measuring a city's drivable areas take minutes: one
/// scan per triangle).
#[derive(Debug, Clone)]
pub struct SegmentGrid {
    cell_m: f64,
    cells: std::collections::HashMap<(i64, i64), Vec<usize>>,
    bounds: Vec<[[f64; 2]; 2]>,
}

impl SegmentGrid {
    /// The segment nearest to `p` and its distance, when that distance is at most `max_m`;
    /// the same answer as [`Segments::nearest`] in that case (ties to the smaller id), None
    /// otherwise. `segs` must be the segments the grid was built from.
    pub fn nearest_within(&self, segs: &Segments, p: [f64; 2], max_m: f64) -> Option<(usize, f64)> {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return None;
        }
        let r = max_m.max(0.0);
        let lo = cell_of([p[0] - r, p[1] - r], self.cell_m);
        let hi = cell_of([p[0] + r, p[1] + r], self.cell_m);
        let mut cand: Vec<usize> = Vec::new();
        if (hi.0 - lo.0 + 1).saturating_mul(hi.1 - lo.1 + 1) > 10_000 {
            cand.extend(0..segs.segments.len());
        } else {
            for x in lo.0..=hi.0 {
                for y in lo.1..=hi.1 {
                    if let Some(v) = self.cells.get(&(x, y)) {
                        cand.extend_from_slice(v);
                    }
                }
            }
            if let Some(v) = self.cells.get(&(i64::MAX, i64::MAX)) {
                cand.extend_from_slice(v);
            }
            cand.sort_unstable();
            cand.dedup();
        }
        cand.into_iter()
            .filter(|&i| scene::area::box_gap(&self.bounds[i], p) <= r)
            .map(|i| {
                let s = &segs.segments[i];
                (s.id, s.area.distance(p))
            })
            .filter(|(_, d)| *d <= max_m)
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
    }
}

/// Drops the parts of `line` inside the disc (`c`, `r`) at its start, ending the cut exactly
/// on the circle.
fn clip_start(line: &[[f64; 2]], c: [f64; 2], r: f64) -> Vec<[f64; 2]> {
    let Some(k) = line.iter().position(|p| dist(*p, c) > r) else {
        return Vec::new();
    };
    let mut out = Vec::with_capacity(line.len() - k + 1);
    if k > 0 {
        // the crossing on [line[k-1], line[k]]: |a + t(b - a) - c| = r
        let (a, b) = (line[k - 1], line[k]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let f = [a[0] - c[0], a[1] - c[1]];
        let qa = d[0] * d[0] + d[1] * d[1];
        let qb = 2.0 * (f[0] * d[0] + f[1] * d[1]);
        let qc = f[0] * f[0] + f[1] * f[1] - r * r;
        let disc = (qb * qb - 4.0 * qa * qc).max(0.0);
        let t = if qa > 0.0 {
            ((-qb + disc.sqrt()) / (2.0 * qa)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push([a[0] + t * d[0], a[1] + t * d[1]]);
    }
    out.extend_from_slice(&line[k..]);
    out
}

/// Builds the segment layer from a lane graph.
pub fn build_segments(lanes: &LaneGraph, cfg: &SegmentConfig) -> Segments {
    let mut segs = Segments::default();
    let mut junction_of = vec![None; lanes.nodes.len()];
    for n in &lanes.nodes {
        let kind = match n.kind {
            LaneNodeKind::Intersection => SegmentKind::Intersection,
            LaneNodeKind::TIntersection => SegmentKind::TIntersection,
            LaneNodeKind::LIntersection => SegmentKind::LIntersection,
            LaneNodeKind::Breakpoint => continue,
        };
        let id = segs.segments.len();
        junction_of[n.id] = Some(id);
        segs.segments.push(Segment {
            id,
            kind,
            centroid: n.xy,
            area: SegmentArea::Disc {
                centre: n.xy,
                radius_m: cfg.junction_radius_m,
            },
            lane_nodes: vec![n.id],
        });
    }
    let mut connects = std::collections::BTreeSet::new();
    for e in &lanes.edges {
        let mut line = e.polyline.clone();
        if junction_of[e.from].is_some() {
            line = clip_start(&line, lanes.nodes[e.from].xy, cfg.junction_radius_m);
        }
        if junction_of[e.to].is_some() {
            line.reverse();
            line = clip_start(&line, lanes.nodes[e.to].xy, cfg.junction_radius_m);
            line.reverse();
        }
        let ends: Vec<usize> = [junction_of[e.from], junction_of[e.to]]
            .into_iter()
            .flatten()
            .collect();
        if polyline_length(&line) < 1.0 {
            // junction areas touch: connect them directly
            if let [a, b] = ends[..]
                && a != b
            {
                connects.insert((a.min(b), a.max(b)));
            }
            continue;
        }
        let id = segs.segments.len();
        let lane_nodes = [e.from, e.to]
            .into_iter()
            .filter(|n| junction_of[*n].is_none())
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        segs.segments.push(Segment {
            id,
            kind: SegmentKind::StraightRoadway,
            centroid: centroid(&line),
            area: SegmentArea::Corridor {
                centreline: line,
                half_width_m: cfg.road_half_width_m,
            },
            lane_nodes,
        });
        for j in ends {
            connects.insert((j.min(id), j.max(id)));
        }
    }
    segs.connects = connects.into_iter().collect();
    segs
}

/// The point halfway along a polyline.
fn centroid(line: &[[f64; 2]]) -> [f64; 2] {
    let half = polyline_length(line) / 2.0;
    let mut acc = 0.0;
    for w in line.windows(2) {
        let l = dist(w[0], w[1]);
        if acc + l >= half && l > 0.0 {
            let t = (half - acc) / l;
            return [
                w[0][0] + t * (w[1][0] - w[0][0]),
                w[0][1] + t * (w[1][1] - w[0][1]),
            ];
        }
        acc += l;
    }
    line[0]
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    fn some_segments(spec: &[(bool, [f64; 2], f64)]) -> Segments {
        let segments = spec
            .iter()
            .enumerate()
            .map(|(id, (disc, c, r))| Segment {
                id,
                kind: SegmentKind::StraightRoadway,
                centroid: *c,
                area: if *disc {
                    SegmentArea::Disc {
                        centre: *c,
                        radius_m: *r,
                    }
                } else {
                    SegmentArea::Corridor {
                        centreline: vec![
                            *c,
                            [c[0] + 40.0 * r, c[1] - 7.0 * r],
                            [c[0] + 3.0, c[1] + 60.0],
                        ],
                        half_width_m: *r,
                    }
                },
                lane_nodes: Vec::new(),
            })
            .collect();
        Segments {
            segments,
            connects: Vec::new(),
        }
    }

    proptest! {
        /// The grid's nearest segment within a distance is the scan's, or none when the
        /// scan's nearest is farther.
        #[test]
        fn the_grid_finds_what_the_scan_finds(
            spec in proptest::collection::vec(
                (any::<bool>(), [-500.0f64..500.0, -500.0f64..500.0], 0.5f64..20.0),
                1..40,
            ),
            pts in proptest::collection::vec([-700.0f64..700.0, -700.0f64..700.0], 1..60),
            max_m in 0.0f64..80.0,
            cell_m in 5.0f64..120.0,
        ) {
            let segs = some_segments(&spec);
            let grid = segs.grid(cell_m);
            for p in pts {
                let scan = segs.nearest(p).filter(|(_, d)| *d <= max_m);
                let got = grid.nearest_within(&segs, p, max_m);
                prop_assert_eq!(got.map(|g| g.0), scan.map(|s| s.0));
                if let (Some(g), Some(s)) = (got, scan) {
                    prop_assert!((g.1 - s.1).abs() <= 1e-9);
                }
            }
        }
    }

    use super::*;
    use crate::hierarchy::lanes::{LaneConfig, extract_lanes, tests::drive};

    #[test]
    fn t_junction_gives_one_junction_area_and_three_roads() {
        let t = drive(&[
            [-200.0, 0.0],
            [0.0, 0.0],
            [0.0, 200.0],
            [0.0, 0.0],
            [200.0, 0.0],
        ]);
        let lanes = extract_lanes(&t, &LaneConfig::default()).unwrap();
        let s = build_segments(&lanes, &SegmentConfig::default());
        let kinds: Vec<SegmentKind> = s.segments.iter().map(|s| s.kind).collect();
        assert_eq!(
            kinds
                .iter()
                .filter(|k| **k == SegmentKind::TIntersection)
                .count(),
            1
        );
        assert_eq!(
            kinds
                .iter()
                .filter(|k| **k == SegmentKind::StraightRoadway)
                .count(),
            3
        );
        assert_eq!(s.connects.len(), 3);
        assert!(s.connects.iter().all(|(a, _)| *a == 0));
        // containment and distance through parry
        let junction = &s.segments[0];
        let c = junction.centroid;
        assert!(dist(c, [0.0, 0.0]) < 5.0, "{c:?}");
        assert!(junction.area.contains([c[0] + 3.0, c[1] + 4.0]));
        assert!((junction.area.distance([c[0], c[1] - 20.0]) - 8.0).abs() < 1e-3);
        let (near, d) = s.nearest([-100.0, 5.0]).unwrap();
        assert_eq!(s.segments[near].kind, SegmentKind::StraightRoadway);
        assert!(d.abs() < 1e-3);
        let (_, d) = s.nearest([-100.0, 30.0]).unwrap();
        assert!((d - 22.0).abs() < 1e-3, "{d}");
        // the road segment starts on the junction circle
        let SegmentArea::Corridor { centreline, .. } = &s.segments[1].area else {
            panic!()
        };
        let ends = [centreline[0], *centreline.last().unwrap()];
        assert!(
            ends.iter().any(|p| (dist(*p, c) - 12.0).abs() < 1e-6),
            "{ends:?}"
        );
    }
}
