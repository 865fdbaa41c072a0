//! Lane-graph layer from a driven trajectory (the paper's "local disfluency").
//!
//! 1. The ground-plane trajectory is resampled every `resample_m` metres of travel.
//! 2. For each sample, its neighbourhood is every sample within `radius_m`; the disfluency λ
//!    is the mean, over all pairs of the neighbourhood's heading vectors, of
//!    `min(|θ|, |θ − π|)` (θ the angle between the pair). Headings fold by π, so a road driven
//!    in both directions stays fluent; crossings and bends are disfluent.
//! 3. A sample with fewer than 3 neighbours, or whose neighbours all lie on one side of it
//!    (the start, the end, the tip of a dead end), is a breakpoint candidate. Samples with
//!    λ > `disfluency_rad` are clustered with DBSCAN (`dbscan_eps_m`, `dbscan_min_samples`);
//!    each local peak of λ in a cluster (the highest within `association_m / 2`, with at
//!    least half the cluster's peak) is a junction at the medoid of its plateau (samples
//!    within 90 % of its λ), so two junctions chained by a bending road stay two. Junctions
//!    closer than `association_m` merge.
//! 4. The kind of a junction comes from the number of distinct ways the trajectory enters or
//!    leaves it: 4+ is an intersection, 3 a T-junction, 2 an L-bend when the turn (deviation
//!    from straight) is at least `l_turn_min_deg` and the peak disfluency is at most
//!    `l_turn_max_deg` degrees; other 2-way and 1-way clusters are dropped.
//! 5. Walking the trajectory, each visit to a node (passing within `association_m / 2` of it)
//!    is recorded at the point of closest approach; consecutive visits give an edge whose
//!    polyline is the driven path between the two closest approaches, trimmed to the node
//!    positions. Edges between the same nodes whose polylines lie within `edge_merge_m` of each
//!    other (the same street driven again, in either direction) merge, keeping the frames of
//!    every pass, so revisits do not make parallel lanes.

use crate::cluster::{Grid2, dbscan};
use crate::error::{Error, Result};

/// Parameters, with the reference implementation's defaults.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LaneConfig {
    /// Neighbourhood radius R.
    pub radius_m: f64,
    /// δ_dis: samples above this disfluency are junction candidates.
    pub disfluency_rad: f64,
    /// DBSCAN eps for junction candidates.
    pub dbscan_eps_m: f64,
    /// DBSCAN min samples (the point itself included).
    pub dbscan_min_samples: usize,
    /// Node association distance: junctions closer than this merge; a visit must pass within
    /// half of it.
    pub association_m: f64,
    /// Smallest turn for an L-bend.
    pub l_turn_min_deg: f64,
    /// Largest peak disfluency (degrees) for an L-bend.
    pub l_turn_max_deg: f64,
    /// Resampling step along the trajectory.
    pub resample_m: f64,
    /// Directions within this angle are the same way out of a junction.
    pub way_merge_deg: f64,
    /// Edges between the same nodes closer than this (Hausdorff) are one road.
    pub edge_merge_m: f64,
    /// Consecutive poses farther apart than this are a gap in the recording: the trajectory
    /// splits there and no lane edge crosses it. None (the default): 20 times the median
    /// distance between consecutive moving poses, and at least 10 m.
    pub gap_m: Option<f64>,
}

impl Default for LaneConfig {
    fn default() -> Self {
        LaneConfig {
            radius_m: 20.0,
            disfluency_rad: 0.15,
            dbscan_eps_m: 20.0,
            dbscan_min_samples: 3,
            association_m: 20.0,
            l_turn_min_deg: 10.0,
            l_turn_max_deg: 50.0,
            resample_m: 2.0,
            way_merge_deg: 35.0,
            edge_merge_m: 8.0,
            gap_m: None,
        }
    }
}

/// The kind of a lane-graph node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LaneNodeKind {
    /// Four or more ways.
    Intersection,
    /// Three ways.
    TIntersection,
    /// A bend between two ways.
    LIntersection,
    /// A dead end or an end of the drive.
    Breakpoint,
}

impl LaneNodeKind {
    /// The name used in the graph and in JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            LaneNodeKind::Intersection => "intersection",
            LaneNodeKind::TIntersection => "t_intersection",
            LaneNodeKind::LIntersection => "l_intersection",
            LaneNodeKind::Breakpoint => "breakpoint",
        }
    }
}

/// A lane-graph node.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LaneNode {
    /// Index in [`LaneGraph::nodes`].
    pub id: usize,
    /// Its kind.
    pub kind: LaneNodeKind,
    /// Ground-plane position (KITTI: x and z).
    pub xy: [f64; 2],
    /// Distinct ways in and out seen on the trajectory.
    pub ways: usize,
    /// Peak disfluency in radians (0 for breakpoints).
    pub disfluency_rad: f64,
}

/// A lane-graph edge (undirected: trajectory-derived lanes are two-way).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LaneEdge {
    /// Node id where the first drive along this edge started (edges are two-way; the
    /// orientation only fixes "along the road" for relations such as `in_front_of`).
    pub from: usize,
    /// Node id where that drive ended.
    pub to: usize,
    /// The driven path from `from` to `to`, in metres on the ground plane.
    pub polyline: Vec<[f64; 2]>,
    /// Length of the polyline.
    pub length_m: f64,
    /// Trajectory indices (frames) that drove this edge, ascending.
    pub frames: Vec<u32>,
}

/// The extracted lane graph.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct LaneGraph {
    /// Nodes, in order of first visit.
    pub nodes: Vec<LaneNode>,
    /// Edges, in order of first drive.
    pub edges: Vec<LaneEdge>,
    /// Where the trajectory was split: gaps between consecutive poses, in pose order.
    pub gaps: Vec<TrajectoryGap>,
}

/// A gap in the recording: two consecutive poses too far apart to have been driven between.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct TrajectoryGap {
    /// Index of the pose before the gap (the next one starts a new piece).
    pub after_pose: u32,
    /// Ground-plane distance between the two poses, metres.
    pub distance_m: f64,
}

/// The gap threshold for a trajectory: `cfg.gap_m`, else 20 times the median step between
/// consecutive moving poses (steps under 1 mm are standing still), at least 10 m.
pub fn gap_threshold_m(traj: &[[f64; 2]], cfg: &LaneConfig) -> f64 {
    if let Some(g) = cfg.gap_m {
        return g;
    }
    let mut steps: Vec<f64> = traj
        .windows(2)
        .map(|w| dist(w[0], w[1]))
        .filter(|d| *d > 1e-3)
        .collect();
    if steps.is_empty() {
        return 10.0;
    }
    let mid = steps.len() / 2;
    let median = *steps.select_nth_unstable_by(mid, f64::total_cmp).1;
    (20.0 * median).max(10.0)
}

impl LaneGraph {
    /// Node counts per kind.
    pub fn kind_counts(&self) -> std::collections::BTreeMap<LaneNodeKind, usize> {
        let mut m = std::collections::BTreeMap::new();
        for n in &self.nodes {
            *m.entry(n.kind).or_insert(0) += 1;
        }
        m
    }

    /// Whether every node is reachable from every other.
    pub fn is_connected(&self) -> bool {
        if self.nodes.is_empty() {
            return true;
        }
        let mut adj = vec![Vec::new(); self.nodes.len()];
        for e in &self.edges {
            adj[e.from].push(e.to);
            adj[e.to].push(e.from);
        }
        let mut seen = vec![false; self.nodes.len()];
        let mut stack = vec![0];
        seen[0] = true;
        while let Some(i) = stack.pop() {
            for &j in &adj[i] {
                if !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
        seen.into_iter().all(|s| s)
    }

    /// Distance from `p` to the nearest edge polyline.
    pub fn distance_to_edges(&self, p: [f64; 2]) -> f64 {
        self.edges
            .iter()
            .flat_map(|e| e.polyline.windows(2))
            .map(|w| point_segment_distance(p, w[0], w[1]))
            .fold(f64::INFINITY, f64::min)
    }
}

use scene::geom::{dist, point_segment_distance, polyline_length};

mod edges;
use edges::*;

/// A resampled trajectory point.
#[derive(Debug, Clone, Copy)]
struct Sample {
    xy: [f64; 2],
    /// Index of the source pose.
    src: u32,
}

fn resample(traj: &[[f64; 2]], step_m: f64) -> Vec<Sample> {
    let mut out = vec![Sample {
        xy: traj[0],
        src: 0,
    }];
    let mut since = 0.0;
    for i in 1..traj.len() {
        let (a, b) = (traj[i - 1], traj[i]);
        let seg = dist(a, b);
        if seg <= 0.0 {
            continue;
        }
        let mut t = step_m - since;
        while t <= seg {
            let f = t / seg;
            let src = if f < 0.5 { i - 1 } else { i } as u32;
            out.push(Sample {
                xy: [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])],
                src,
            });
            t += step_m;
        }
        since = seg - (t - step_m);
    }
    let last = *traj.last().expect("non-empty");
    if dist(out.last().expect("non-empty").xy, last) > 1e-6 {
        out.push(Sample {
            xy: last,
            src: (traj.len() - 1) as u32,
        });
    }
    out
}

/// Axial angle of each sample's heading, in [0, π).
fn headings(s: &[Sample]) -> Vec<f64> {
    let n = s.len();
    (0..n)
        .map(|i| {
            let a = s[i.saturating_sub(1)].xy;
            let b = s[(i + 1).min(n - 1)].xy;
            (b[1] - a[1])
                .atan2(b[0] - a[0])
                .rem_euclid(std::f64::consts::PI)
        })
        .collect()
}

fn axial_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).abs() % std::f64::consts::PI;
    d.min(std::f64::consts::PI - d)
}

/// Mean pairwise axial heading difference over a neighbourhood.
fn disfluency(hs: &[f64], nb: &[usize]) -> f64 {
    let m = nb.len();
    if m < 2 {
        return 0.0;
    }
    let mut sum = 0.0;
    for (k, &i) in nb.iter().enumerate() {
        let a = hs[i];
        for &j in &nb[k + 1..] {
            sum += axial_diff(a, hs[j]);
        }
    }
    sum / (m * (m - 1) / 2) as f64
}

/// Whether `p` is an end of the road: along the neighbourhood's mean road axis (the axial
/// mean of the headings), every neighbour lies on one side of `p`, give or take `margin_m`.
/// Only meaningful where the neighbourhood is fluent (one road axis).
fn one_sided(points: &[[f64; 2]], hs: &[f64], p: [f64; 2], nb: &[usize], margin_m: f64) -> bool {
    let (c, s) = nb.iter().fold((0.0, 0.0), |(c, s), &j| {
        (c + (2.0 * hs[j]).cos(), s + (2.0 * hs[j]).sin())
    });
    if c == 0.0 && s == 0.0 {
        return false;
    }
    let axis = s.atan2(c) / 2.0;
    let (ax, ay) = (axis.cos(), axis.sin());
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for &j in nb {
        let t = (points[j][0] - p[0]) * ax + (points[j][1] - p[1]) * ay;
        lo = lo.min(t);
        hi = hi.max(t);
    }
    lo >= -margin_m || hi <= margin_m
}

/// Distinct directions (unit vectors) after greedy merging within `tol_rad`.
fn distinct_ways(dirs: &[[f64; 2]], tol_rad: f64) -> Vec<[f64; 2]> {
    let mut ways: Vec<([f64; 2], usize)> = Vec::new();
    for d in dirs {
        let a = d[1].atan2(d[0]);
        if let Some(w) = ways.iter_mut().find(|(w, _)| {
            let b = w[1].atan2(w[0]);
            let diff = (a - b).rem_euclid(std::f64::consts::TAU);
            diff.min(std::f64::consts::TAU - diff) <= tol_rad
        }) {
            let n = w.1 as f64;
            let s = [w.0[0] * n + d[0], w.0[1] * n + d[1]];
            let l = (s[0] * s[0] + s[1] * s[1]).sqrt().max(1e-12);
            *w = ([s[0] / l, s[1] / l], w.1 + 1);
        } else {
            ways.push((*d, 1));
        }
    }
    ways.into_iter().map(|(w, _)| w).collect()
}

/// Symmetric Hausdorff distance between two polylines (vertices against segments).
fn hausdorff(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    let one = |x: &[[f64; 2]], y: &[[f64; 2]]| {
        x.iter()
            .map(|p| {
                if y.len() == 1 {
                    return dist(*p, y[0]);
                }
                y.windows(2)
                    .map(|w| point_segment_distance(*p, w[0], w[1]))
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    };
    one(a, b).max(one(b, a))
}

/// Maximal runs of samples within `r` of `centre`: (first, last, closest approach).
fn passes(pts: &[[f64; 2]], centre: [f64; 2], r: f64) -> Vec<(usize, usize, f64)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < pts.len() {
        if dist(pts[i], centre) > r {
            i += 1;
            continue;
        }
        let start = i;
        while i < pts.len() && dist(pts[i], centre) <= r {
            i += 1;
        }
        let closest = (start..i)
            .map(|k| dist(pts[k], centre))
            .fold(f64::INFINITY, f64::min);
        out.push((start, i - 1, closest));
    }
    out
}

/// Moves a junction centre to the least-squares meeting point of the roads driven through it:
/// each pass contributes the line through its closest approach along its heading there. Kept
/// as is when the passes are near-parallel (a bend driven once, a road driven twice) or the
/// meeting point is farther than `r`.
fn recentre(pts: &[[f64; 2]], hs: &[f64], centre: [f64; 2], r: f64) -> [f64; 2] {
    let (mut a, mut b) = ([[0.0f64; 2]; 2], [0.0f64; 2]);
    for (start, end, _) in passes(pts, centre, r) {
        let k = (start..=end)
            .min_by(|x, y| dist(pts[*x], centre).total_cmp(&dist(pts[*y], centre)))
            .expect("non-empty pass");
        let n = [-(hs[k].sin()), hs[k].cos()];
        for i in 0..2 {
            for j in 0..2 {
                a[i][j] += n[i] * n[j];
            }
            b[i] += n[i] * (n[0] * pts[k][0] + n[1] * pts[k][1]);
        }
    }
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let trace = a[0][0] + a[1][1];
    // smallest eigenvalue relative to the trace: 0 for parallel lines, 0.5 for perpendicular
    let disc = (trace * trace / 4.0 - det).max(0.0).sqrt();
    let lmin = trace / 2.0 - disc;
    if trace <= 0.0 || lmin / trace < 0.1 {
        return centre;
    }
    let x = [
        (b[0] * a[1][1] - b[1] * a[0][1]) / det,
        (a[0][0] * b[1] - a[1][0] * b[0]) / det,
    ];
    if dist(x, centre) <= r { x } else { centre }
}

struct Candidate {
    xy: [f64; 2],
    kind: LaneNodeKind,
    ways: usize,
    lambda: f64,
}

/// Extracts the lane graph from a ground-plane trajectory (one point per pose).
pub fn extract_lanes(traj: &[[f64; 2]], cfg: &LaneConfig) -> Result<LaneGraph> {
    if traj.len() < 2 {
        return Err(Error::Invalid(format!(
            "a trajectory needs at least 2 poses, got {}",
            traj.len()
        )));
    }
    if let Some(i) = traj
        .iter()
        .position(|p| !p[0].is_finite() || !p[1].is_finite())
    {
        return Err(Error::Invalid(format!("pose {i} is not finite")));
    }
    if !(cfg.resample_m > 0.0 && cfg.radius_m > 0.0 && cfg.association_m > 0.0) {
        return Err(Error::Invalid("lane parameters must be positive".into()));
    }
    if cfg.gap_m.is_some_and(|g| !(g.is_finite() && g > 0.0)) {
        return Err(Error::Invalid(
            "gap_m must be a positive number of metres".into(),
        ));
    }
    // pieces of the drive between gaps in the recording, resampled apart
    let gap_m = gap_threshold_m(traj, cfg);
    let mut gaps = Vec::new();
    let mut piece_starts = vec![0usize];
    for (i, w) in traj.windows(2).enumerate() {
        let d = dist(w[0], w[1]);
        if d > gap_m {
            gaps.push(TrajectoryGap {
                after_pose: i as u32,
                distance_m: d,
            });
            piece_starts.push(i + 1);
        }
    }
    piece_starts.push(traj.len());
    let mut samples: Vec<Sample> = Vec::new();
    let mut hs: Vec<f64> = Vec::new();
    // sample index ranges of the pieces
    let mut pieces: Vec<std::ops::Range<usize>> = Vec::new();
    for w in piece_starts.windows(2) {
        let mut piece = resample(&traj[w[0]..w[1]], cfg.resample_m);
        for smp in &mut piece {
            smp.src += w[0] as u32;
        }
        hs.extend(headings(&piece));
        pieces.push(samples.len()..samples.len() + piece.len());
        samples.extend(piece);
    }
    let pts: Vec<[f64; 2]> = samples.iter().map(|s| s.xy).collect();
    let grid = Grid2::new(&pts, cfg.radius_m);
    let mut lambda = vec![0.0; pts.len()];
    let mut is_break = vec![false; pts.len()];
    // how far the neighbourhood's mean lies from the sample: largest at the very end of a road
    let mut off_centre = vec![0.0; pts.len()];
    for i in 0..pts.len() {
        let nb = grid.within(&pts, pts[i], cfg.radius_m);
        let m = nb.iter().fold([0.0, 0.0], |m, &j| {
            [m[0] + pts[j][0] - pts[i][0], m[1] + pts[j][1] - pts[i][1]]
        });
        off_centre[i] = (m[0] * m[0] + m[1] * m[1]).sqrt() / nb.len().max(1) as f64;
        lambda[i] = disfluency(&hs, &nb);
        // junctions take precedence: breakpoints near a kept junction are dropped below
        is_break[i] = nb.len() < 4 || one_sided(&pts, &hs, pts[i], &nb, 2.0 * cfg.resample_m);
    }
    // junctions
    let cand: Vec<usize> = (0..pts.len())
        .filter(|&i| lambda[i] > cfg.disfluency_rad)
        .collect();
    let cand_pts: Vec<[f64; 2]> = cand.iter().map(|&i| pts[i]).collect();
    let labels = dbscan(&cand_pts, cfg.dbscan_eps_m, cfg.dbscan_min_samples);
    let n_clusters = labels.iter().flatten().max().map_or(0, |m| m + 1);
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); n_clusters];
    for (k, l) in labels.iter().enumerate() {
        if let Some(c) = l {
            members[*c].push(cand[k]);
        }
    }
    // each cluster's centres. A bending road between two junctions is disfluent enough to
    // chain them into one cluster, so every local peak of λ (the highest within half the
    // association distance) holding at least half the cluster's peak is a junction; its
    // centre is the medoid of its plateau (the samples around it within 90 % of its λ), which
    // sits on the crossing point of the roads rather than anywhere on a flat plateau.
    let half_r = cfg.association_m / 2.0;
    let mut peaks: Vec<usize> = Vec::new();
    for m in members.iter().filter(|m| !m.is_empty()) {
        let peak = m.iter().map(|&i| lambda[i]).fold(0.0, f64::max);
        for &p in m {
            let around: Vec<usize> = m
                .iter()
                .copied()
                .filter(|&j| dist(pts[p], pts[j]) <= half_r)
                .collect();
            // ties: the lowest index is the peak
            let is_local_peak = around.iter().all(|&j| {
                lambda[j].total_cmp(&lambda[p]).then(p.cmp(&j)) != std::cmp::Ordering::Greater
            });
            if lambda[p] < 0.5 * peak || !is_local_peak {
                continue;
            }
            let plateau: Vec<usize> = around
                .into_iter()
                .filter(|&j| lambda[j] >= 0.9 * lambda[p])
                .collect();
            let medoid = plateau
                .iter()
                .min_by(|&&a, &&b| {
                    let sa: f64 = plateau.iter().map(|&j| dist(pts[a], pts[j])).sum();
                    let sb: f64 = plateau.iter().map(|&j| dist(pts[b], pts[j])).sum();
                    sa.total_cmp(&sb).then(a.cmp(&b))
                })
                .expect("the peak is on its plateau");
            peaks.push(*medoid);
        }
    }
    peaks.sort_by(|a, b| lambda[*b].total_cmp(&lambda[*a]).then(a.cmp(b)));
    let mut centres: Vec<usize> = Vec::new();
    for p in peaks {
        if centres
            .iter()
            .all(|&c| dist(pts[c], pts[p]) >= cfg.association_m)
        {
            centres.push(p);
        }
    }
    let mut nodes: Vec<Candidate> = Vec::new();
    for c in centres {
        let r = cfg.association_m;
        let centre = recentre(&pts, &hs, pts[c], r);
        let mut dirs = Vec::new();
        for (start, end, closest) in passes(&pts, centre, r) {
            if closest > r / 2.0 {
                continue;
            }
            for (k, at_edge) in [(start, start > 0), (end, end + 1 < pts.len())] {
                let v = [pts[k][0] - centre[0], pts[k][1] - centre[1]];
                let l = (v[0] * v[0] + v[1] * v[1]).sqrt();
                if at_edge && l > r / 2.0 {
                    dirs.push([v[0] / l, v[1] / l]);
                }
            }
        }
        let ways = distinct_ways(&dirs, cfg.way_merge_deg.to_radians());
        let kind = match ways.len() {
            n if n >= 4 => Some(LaneNodeKind::Intersection),
            3 => Some(LaneNodeKind::TIntersection),
            2 => {
                let cos = (ways[0][0] * ways[1][0] + ways[0][1] * ways[1][1]).clamp(-1.0, 1.0);
                let turn_deg = 180.0 - cos.acos().to_degrees();
                let peak_deg = lambda[c].to_degrees();
                (turn_deg >= cfg.l_turn_min_deg && peak_deg <= cfg.l_turn_max_deg)
                    .then_some(LaneNodeKind::LIntersection)
            }
            _ => None,
        };
        if let Some(kind) = kind {
            nodes.push(Candidate {
                xy: centre,
                kind,
                ways: ways.len(),
                lambda: lambda[c],
            });
        }
    }
    // breakpoints away from junctions
    let bidx: Vec<usize> = (0..pts.len())
        .filter(|&i| {
            is_break[i]
                && nodes
                    .iter()
                    .all(|n| dist(n.xy, pts[i]) >= cfg.association_m)
        })
        .collect();
    let bpts: Vec<[f64; 2]> = bidx.iter().map(|&i| pts[i]).collect();
    let blabels = dbscan(&bpts, cfg.association_m, 1);
    let mut extreme: std::collections::BTreeMap<usize, usize> = std::collections::BTreeMap::new();
    for (k, l) in blabels.iter().enumerate() {
        if let Some(c) = l {
            let e = extreme.entry(*c).or_insert(bidx[k]);
            if off_centre[bidx[k]] > off_centre[*e] {
                *e = bidx[k];
            }
        }
    }
    for i in extreme.into_values() {
        nodes.push(Candidate {
            xy: pts[i],
            kind: LaneNodeKind::Breakpoint,
            ways: 1,
            lambda: 0.0,
        });
    }
    let mut g = build_edges(&samples, &pts, &pieces, nodes, cfg)?;
    g.gaps = gaps;
    Ok(g)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A drive through `waypoints` at 1 m per pose.
    pub(crate) fn drive(waypoints: &[[f64; 2]]) -> Vec<[f64; 2]> {
        let mut out = vec![waypoints[0]];
        for w in waypoints.windows(2) {
            let n = dist(w[0], w[1]).round().max(1.0) as usize;
            for k in 1..=n {
                let f = k as f64 / n as f64;
                out.push([
                    w[0][0] + f * (w[1][0] - w[0][0]),
                    w[0][1] + f * (w[1][1] - w[0][1]),
                ]);
            }
        }
        out
    }

    fn kinds(g: &LaneGraph) -> Vec<(LaneNodeKind, usize)> {
        g.kind_counts().into_iter().collect()
    }

    fn check_cover(g: &LaneGraph, traj: &[[f64; 2]]) {
        assert!(g.is_connected(), "{g:#?}");
        for (i, p) in traj.iter().enumerate() {
            let d = g.distance_to_edges(*p);
            assert!(d <= 10.0, "pose {i} at {p:?} is {d:.1} m from every edge");
        }
    }

    use LaneNodeKind::*;

    #[test]
    fn straight_road_is_two_breakpoints_and_one_edge() {
        let t = drive(&[[0.0, 0.0], [300.0, 0.0]]);
        let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
        assert_eq!(kinds(&g), vec![(Breakpoint, 2)]);
        assert_eq!(g.edges.len(), 1);
        assert!(
            (g.edges[0].length_m - 300.0).abs() < 1.0,
            "{}",
            g.edges[0].length_m
        );
        check_cover(&g, &t);
    }

    #[test]
    fn one_l_bend() {
        let t = drive(&[[0.0, 0.0], [200.0, 0.0], [200.0, 150.0]]);
        let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
        assert_eq!(kinds(&g), vec![(LIntersection, 1), (Breakpoint, 2)]);
        assert_eq!(g.edges.len(), 2);
        let l = g.nodes.iter().find(|n| n.kind == LIntersection).unwrap();
        assert!(dist(l.xy, [200.0, 0.0]) < 5.0, "{:?}", l.xy);
        check_cover(&g, &t);
    }

    /// Two bends joined by a road that bows out: the bow is disfluent enough to chain both
    /// bends into one DBSCAN cluster, and each bend is still a junction of its own.
    #[test]
    fn two_bends_joined_by_a_bowed_road_are_two_bends() {
        // the second bend as sharp as the first (68°), then gentler (45°: its peak λ is two
        // thirds of the first's; the bow's own local peaks hold under two fifths)
        for last in [[0.0, 80.0], [8.0, 119.0]] {
            let t = drive(&[
                [0.0, 0.0],
                [100.0, 0.0],
                [108.0, 20.0],
                [112.0, 40.0],
                [108.0, 60.0],
                [100.0, 80.0],
                last,
            ]);
            let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
            assert_eq!(
                kinds(&g),
                vec![(LIntersection, 2), (Breakpoint, 2)],
                "{g:#?}"
            );
            for corner in [[100.0, 0.0], [100.0, 80.0]] {
                assert!(
                    g.nodes
                        .iter()
                        .any(|n| n.kind == LIntersection && dist(n.xy, corner) < 8.0),
                    "no bend at {corner:?}: {:?}",
                    g.nodes
                );
            }
            check_cover(&g, &t);
        }
    }

    #[test]
    fn one_t_junction() {
        // west end -> junction -> north end, U-turn, back -> east end
        let t = drive(&[
            [-200.0, 0.0],
            [0.0, 0.0],
            [0.0, 200.0],
            [0.0, 0.0],
            [200.0, 0.0],
        ]);
        let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
        assert_eq!(
            kinds(&g),
            vec![(TIntersection, 1), (Breakpoint, 3)],
            "{:#?}",
            g.nodes
        );
        assert_eq!(g.edges.len(), 3);
        check_cover(&g, &t);
    }

    #[test]
    fn a_four_way_crossing() {
        let t = drive(&[
            [-200.0, 0.0],
            [200.0, 0.0],
            [0.0, 0.0],
            [0.0, 200.0],
            [0.0, -200.0],
        ]);
        let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
        assert_eq!(
            kinds(&g),
            vec![(Intersection, 1), (Breakpoint, 4)],
            "{:#?}",
            g.nodes
        );
        assert_eq!(g.edges.len(), 4);
        check_cover(&g, &t);
    }

    #[test]
    fn a_small_loop_driven_three_times_is_one_loop() {
        let r = 8.0;
        let n = 50;
        let mut t = Vec::new();
        for _ in 0..3 {
            for k in 0..n {
                let a = std::f64::consts::TAU * f64::from(k) / f64::from(n);
                t.push([r * a.cos(), r * a.sin()]);
            }
        }
        t.push(t[0]);
        let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
        let lengths: Vec<f64> = g.edges.iter().map(|e| e.length_m).collect();
        assert_eq!(lengths.len(), 1, "{lengths:?}");
        // one lap, not three
        let lap = std::f64::consts::TAU * r;
        assert!((lengths[0] - lap).abs() < 0.1 * lap, "{lengths:?} vs {lap}");
        // every pose drove it
        assert_eq!(g.edges[0].frames.len(), t.len());
        assert!(g.gaps.is_empty());
    }

    #[test]
    fn a_gap_in_the_recording_splits_the_trajectory() {
        // 200 m along z at 1 m, then the next pose 2 km on, 200 m more
        let mut t: Vec<[f64; 2]> = (0..200).map(|z| [0.0, f64::from(z)]).collect();
        t.extend((0..200).map(|z| [0.0, 2200.0 + f64::from(z)]));
        let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
        assert_eq!(g.gaps.len(), 1, "{:?}", g.gaps);
        assert_eq!(g.gaps[0].after_pose, 199);
        assert!((g.gaps[0].distance_m - 2001.0).abs() < 1e-9);
        assert_eq!(g.edges.len(), 2, "{:#?}", g.edges);
        for e in &g.edges {
            assert!(e.length_m < 200.0, "{}", e.length_m);
            // no edge has a point in the gap
            assert!(e.polyline.iter().all(|p| p[1] < 200.0 || p[1] >= 2200.0));
        }
        // the threshold follows the data's rate, and a given one is used as given
        assert!((gap_threshold_m(&t, &LaneConfig::default()) - 20.0).abs() < 1e-9);
        let cfg = LaneConfig {
            gap_m: Some(5000.0),
            ..LaneConfig::default()
        };
        assert!(extract_lanes(&t, &cfg).unwrap().gaps.is_empty());
        let cfg = LaneConfig {
            gap_m: Some(f64::NAN),
            ..LaneConfig::default()
        };
        assert!(extract_lanes(&t, &cfg).is_err());
        // standing still is no gap and does not shrink the threshold
        let mut still = vec![[0.0, 0.0]; 50];
        still.extend((0..100).map(|z| [0.0, f64::from(z)]));
        assert!((gap_threshold_m(&still, &LaneConfig::default()) - 20.0).abs() < 1e-9);
        assert!(
            extract_lanes(&still, &LaneConfig::default())
                .unwrap()
                .gaps
                .is_empty()
        );
    }

    #[test]
    fn a_loop_driven_twice() {
        let sq = [
            [0.0, 0.0],
            [150.0, 0.0],
            [150.0, 100.0],
            [0.0, 100.0],
            [0.0, 0.0],
        ];
        let mut w: Vec<[f64; 2]> = vec![[60.0, 0.0]];
        for _ in 0..2 {
            w.extend_from_slice(&sq[1..]);
        }
        w.push([60.0, 0.0]);
        let t = drive(&w);
        let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
        assert_eq!(kinds(&g), vec![(LIntersection, 4)], "{:#?}", g.nodes);
        assert_eq!(
            g.edges.len(),
            4,
            "{:#?}",
            g.edges
                .iter()
                .map(|e| (e.from, e.to, e.length_m))
                .collect::<Vec<_>>()
        );
        check_cover(&g, &t);
        // every edge was driven twice
        for e in &g.edges {
            assert!(
                e.frames.len() as f64 > 1.5 * e.length_m,
                "{} frames on {:.0} m",
                e.frames.len(),
                e.length_m
            );
        }
    }

    #[test]
    fn a_road_driven_in_both_directions_is_one_lane() {
        // out along the road and back on the other lane, 3.5 m to the side
        let t = drive(&[[0.0, 0.0], [250.0, 0.0], [252.0, 3.5], [0.0, 3.5]]);
        let g = extract_lanes(&t, &LaneConfig::default()).unwrap();
        assert_eq!(
            g.edges.len(),
            1,
            "{:#?}",
            g.edges
                .iter()
                .map(|e| (e.from, e.to, e.length_m))
                .collect::<Vec<_>>()
        );
        assert_eq!(kinds(&g), vec![(Breakpoint, 2)], "{:#?}", g.nodes);
        check_cover(&g, &t);
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(extract_lanes(&[[0.0, 0.0]], &LaneConfig::default()).is_err());
        assert!(extract_lanes(&[[0.0, 0.0], [f64::NAN, 1.0]], &LaneConfig::default()).is_err());
        // a car that never moves
        let g = extract_lanes(&[[1.0, 1.0]; 50], &LaneConfig::default());
        assert!(g.is_err() || g.unwrap().edges.is_empty());
    }
}
