//! Road areas against the simulator's road geometry: per segment, the area IoU of its
//! trajectory area (disc or corridor: "before") and of its drivable polygon measured from the
//! map ("after") with the true drivable ground that belongs to it.
//!
//! The true drivable ground is each road's carriageway (`width_m` about its centre line) and
//! its parking lanes (`parking_width_m` beyond the carriageway on the sides `parking` says),
//! from `ground_truth/roads.json`, rasterised at [`CELL_M`]. A true cell belongs to the map
//! segment whose trajectory area is nearest (the rule that assigns the polygon's triangles,
//! within the same `max_gap_m`); true cells farther from every segment (roads the drive
//! did not take) belong to none.

use std::path::Path;

use graphstore::GraphRead;
use ingest::sources::sim::truth::read_roads;
use llm_tools::locate::SegmentInfo;
use scene::GroundFrame;
use scene::area::SegmentArea;

use crate::{Error, Result};

/// Raster cell, metres.
pub const CELL_M: f64 = 0.25;

/// Scores of one segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SegmentRoadScore {
    /// The Segment's node id (the id the CLI prints and takes).
    pub node: u64,
    /// `Segment.segment_id`.
    pub segment_id: i64,
    /// `Segment.kind`.
    pub kind: String,
    /// True drivable area that belongs to the segment, m².
    pub truth_m2: f64,
    /// IoU of the disc or corridor with it.
    pub iou_before: f64,
    /// IoU of the measured polygon with it (0 without a polygon).
    pub iou_after: f64,
    /// Area of the polygon, m².
    pub polygon_m2: f64,
}

/// The result of [`eval_roads`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RoadEval {
    /// Per segment, in `segment_id` order.
    pub segments: Vec<SegmentRoadScore>,
    /// Mean IoU before over segments with true area.
    pub mean_iou_before: f64,
    /// Mean IoU after over the same segments.
    pub mean_iou_after: f64,
    /// IoU of the union of the trajectory areas with all true drivable ground the segments
    /// own.
    pub total_iou_before: f64,
    /// IoU of the union of the polygons with it.
    pub total_iou_after: f64,
}

/// A raster over the ground plane.
struct Raster {
    lo: [f64; 2],
    n: [usize; 2],
}

impl Raster {
    fn centre(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.lo[0] + (i as f64 + 0.5) * CELL_M,
            self.lo[1] + (j as f64 + 0.5) * CELL_M,
        ]
    }
    /// Cells whose centres lie in the box `lo..hi`.
    fn cells_in(&self, lo: [f64; 2], hi: [f64; 2]) -> impl Iterator<Item = (usize, usize)> {
        let idx = |v: f64, k: usize| {
            (((v - self.lo[k]) / CELL_M).floor().max(0.0) as usize).min(self.n[k])
        };
        let (i0, i1) = (idx(lo[0], 0), (idx(hi[0], 0) + 1).min(self.n[0]));
        let (j0, j1) = (idx(lo[1], 1), (idx(hi[1], 1) + 1).min(self.n[1]));
        (i0..i1).flat_map(move |i| (j0..j1).map(move |j| (i, j)))
    }
    fn at(&self, i: usize, j: usize) -> usize {
        i * self.n[1] + j
    }
}

/// Bounds of an area, grown by `m`.
fn area_bounds(a: &SegmentArea, m: f64) -> ([f64; 2], [f64; 2]) {
    match a {
        SegmentArea::Disc { centre, radius_m } => (
            [centre[0] - radius_m - m, centre[1] - radius_m - m],
            [centre[0] + radius_m + m, centre[1] + radius_m + m],
        ),
        SegmentArea::Corridor {
            centreline,
            half_width_m,
        } => {
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in centreline {
                for k in 0..2 {
                    lo[k] = lo[k].min(p[k] - half_width_m - m);
                    hi[k] = hi[k].max(p[k] + half_width_m + m);
                }
            }
            (lo, hi)
        }
    }
}

/// Scores the map's segment areas against `SIM_DIR/ground_truth/roads.json`. `max_gap_m`
/// is the hierarchy's `drivable.max_gap_m`.
///
/// # Errors
/// The truth file is missing or malformed; the store cannot be read.
pub fn eval_roads(r: &impl GraphRead, sim_dir: &Path, max_gap_m: f64) -> Result<RoadEval> {
    let roads = read_roads(sim_dir)?;
    // the simulator writes KITTI-style sequences
    let frame = GroundFrame::KittiCam;
    let segs: Vec<SegmentInfo> = llm_tools::locate::load_segments(r, frame)?;
    let mut ids = Vec::with_capacity(segs.len());
    for s in &segs {
        ids.push(match scene::records::SegmentRecord::read(r, s.id)? {
            Some(rec) => rec.segment_id,
            None => s.id as i64,
        });
    }
    // raster bounds: every road and every segment area
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let mut grow = |p: [f64; 2], m: f64| {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k] - m);
            hi[k] = hi[k].max(p[k] + m);
        }
    };
    for rd in &roads {
        let m = rd.half_width_m + rd.parking_m[0].max(rd.parking_m[1]);
        rd.centerline.iter().for_each(|p| grow(*p, m));
    }
    for s in &segs {
        let (a, b) = area_bounds(&s.area, max_gap_m);
        grow(a, 0.0);
        grow(b, 0.0);
    }
    if !(lo[0].is_finite() && hi[0].is_finite()) {
        return Ok(RoadEval::default());
    }
    let n = [0, 1].map(|k| ((hi[k] - lo[k]) / CELL_M).ceil() as usize + 1);
    if n[0].saturating_mul(n[1]) > 200_000_000 {
        return Err(Error::Invalid(format!(
            "the roads span {:.0} m × {:.0} m: too large to rasterise at {CELL_M} m",
            hi[0] - lo[0],
            hi[1] - lo[1]
        )));
    }
    let ras = Raster { lo, n };
    // truth mask
    let mut truth = vec![false; n[0] * n[1]];
    for rd in &roads {
        let reach = rd.half_width_m + rd.parking_m[0].max(rd.parking_m[1]);
        for w in rd.centerline.windows(2) {
            let (a, b) = (w[0], w[1]);
            let blo = [a[0].min(b[0]) - reach, a[1].min(b[1]) - reach];
            let bhi = [a[0].max(b[0]) + reach, a[1].max(b[1]) + reach];
            for (i, j) in ras.cells_in(blo, bhi) {
                let p = ras.centre(i, j);
                let (_, q) = scene::geom::closest_on_segment(p, a, b);
                let d = (p[0] - q[0]).hypot(p[1] - q[1]);
                let d_ = [b[0] - a[0], b[1] - a[1]];
                let right = (p[0] - a[0]) * d_[1] - (p[1] - a[1]) * d_[0];
                let side = usize::from(right < 0.0);
                if d < rd.half_width_m + rd.parking_m[side] {
                    truth[ras.at(i, j)] = true;
                }
            }
        }
    }
    // owner of each true cell: the nearest segment area within max_gap_m
    let bounds: Vec<([f64; 2], [f64; 2])> = segs
        .iter()
        .map(|s| area_bounds(&s.area, max_gap_m))
        .collect();
    let mut owner: Vec<Option<usize>> = vec![None; n[0] * n[1]];
    for i in 0..n[0] {
        for j in 0..n[1] {
            let k = ras.at(i, j);
            if !truth[k] {
                continue;
            }
            let p = ras.centre(i, j);
            let mut best: Option<(f64, usize)> = None;
            for (s, seg) in segs.iter().enumerate() {
                let (blo, bhi) = bounds[s];
                if p[0] < blo[0] || p[1] < blo[1] || p[0] > bhi[0] || p[1] > bhi[1] {
                    continue;
                }
                let d = seg.area.distance(p);
                if d <= max_gap_m && best.is_none_or(|b| d < b.0) {
                    best = Some((d, s));
                }
            }
            owner[k] = best.map(|b| b.1);
        }
    }
    let cell_m2 = CELL_M * CELL_M;
    let mut out = RoadEval::default();
    let (mut union_before, mut union_after) = (vec![false; n[0] * n[1]], vec![false; n[0] * n[1]]);
    for (s, seg) in segs.iter().enumerate() {
        let (blo, bhi) = bounds[s];
        let (plo, phi) = seg
            .drivable
            .as_ref()
            .map(|d| {
                let [a, b] = d.bounds();
                (a, b)
            })
            .unwrap_or((blo, bhi));
        let (lo2, hi2) = (
            [blo[0].min(plo[0]), blo[1].min(plo[1])],
            [bhi[0].max(phi[0]), bhi[1].max(phi[1])],
        );
        let (mut t, mut bf, mut af, mut ib, mut ia) = (0usize, 0usize, 0usize, 0usize, 0usize);
        for (i, j) in ras.cells_in(lo2, hi2) {
            let k = ras.at(i, j);
            let p = ras.centre(i, j);
            let mine = owner[k] == Some(s);
            let before = seg.area.contains(p);
            let after = seg.drivable.as_ref().is_some_and(|d| d.contains(p));
            t += usize::from(mine);
            bf += usize::from(before);
            af += usize::from(after);
            ib += usize::from(mine && before);
            ia += usize::from(mine && after);
            union_before[k] |= before;
            union_after[k] |= after;
        }
        let iou = |i: usize, a: usize| {
            let u = t + a - i;
            if u == 0 { 0.0 } else { i as f64 / u as f64 }
        };
        out.segments.push(SegmentRoadScore {
            node: seg.id,
            segment_id: ids[s],
            kind: seg.kind.clone(),
            truth_m2: t as f64 * cell_m2,
            iou_before: iou(ib, bf),
            iou_after: iou(ia, af),
            polygon_m2: seg.drivable.as_ref().map_or(0.0, |d| d.area_m2()),
        });
    }
    out.segments.sort_by_key(|s| s.segment_id);
    let scored: Vec<&SegmentRoadScore> = out.segments.iter().filter(|s| s.truth_m2 > 0.0).collect();
    if !scored.is_empty() {
        out.mean_iou_before =
            scored.iter().map(|s| s.iou_before).sum::<f64>() / scored.len() as f64;
        out.mean_iou_after = scored.iter().map(|s| s.iou_after).sum::<f64>() / scored.len() as f64;
    }
    let total = |u: &[bool]| {
        let (mut i, mut un) = (0usize, 0usize);
        for (k, x) in u.iter().enumerate() {
            let t = owner[k].is_some();
            i += usize::from(t && *x);
            un += usize::from(t || *x);
        }
        if un == 0 { 0.0 } else { i as f64 / un as f64 }
    };
    out.total_iou_before = total(&union_before);
    out.total_iou_after = total(&union_after);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parking_sides_follow_the_simulator() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("ground_truth")).unwrap();
        std::fs::write(
            dir.path().join("ground_truth/roads.json"),
            r#"{"roads": [{"centerline": [[0, 0], [0, 10]], "width_m": 6, "parking": [true, false], "parking_width_m": 2.5}]}"#,
        )
        .unwrap();
        let r = read_roads(dir.path()).unwrap();
        assert!((r[0].parking_m[0] - 2.5).abs() < 1e-12 && r[0].parking_m[1].abs() < 1e-12);
        assert!((r[0].half_width_m - 3.0).abs() < 1e-12);
        std::fs::write(
            dir.path().join("ground_truth/roads.json"),
            r#"{"roads": [{"width_m": 6}]}"#,
        )
        .unwrap();
        let e = read_roads(dir.path()).unwrap_err().to_string();
        assert!(e.contains("roads.json") && e.contains("road 0"), "{e}");
    }
}
