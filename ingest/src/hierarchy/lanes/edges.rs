//! Step 5 of the lane graph: the trajectory's visits to the nodes, the driven paths between
//! consecutive visits, and the edges they make, merged where the same street was driven again.

use super::*;

pub(super) struct Visit {
    pub(super) node: usize,
    pub(super) at: usize,
}

pub(super) fn visits(pts: &[[f64; 2]], nodes: &[Candidate], cfg: &LaneConfig) -> Vec<Visit> {
    let label: Vec<Option<usize>> = pts
        .iter()
        .map(|p| {
            nodes
                .iter()
                .enumerate()
                .map(|(k, n)| (k, dist(n.xy, *p)))
                .filter(|(_, d)| *d <= cfg.association_m)
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| k)
        })
        .collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < pts.len() {
        let Some(node) = label[i] else {
            i += 1;
            continue;
        };
        let start = i;
        while i < pts.len() && label[i] == Some(node) {
            i += 1;
        }
        let (at, d) = (start..i)
            .map(|k| (k, dist(pts[k], nodes[node].xy)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("non-empty run");
        let limit = if nodes[node].kind == LaneNodeKind::Breakpoint {
            cfg.association_m
        } else {
            cfg.association_m / 2.0
        };
        if d <= limit {
            out.push(Visit { node, at });
        }
    }
    out
}

/// A driven path between two node visits: sample indices, and poses before or after it that
/// belong to it (the start or end of a piece of the drive short of a node).
pub(super) struct DrivenPath {
    pub(super) a: usize,
    pub(super) b: usize,
    pub(super) idx: Vec<usize>,
    pub(super) extra: Vec<u32>,
}

/// Splits a path that starts and ends at the same node into laps: it is cut each time it
/// comes back within `2 · resample_m` (at least 3 m) of its start after at least
/// `association_m` of driving, so a loop driven three times is one loop driven three times,
/// not one edge of three times its length.
pub(super) fn laps(pts: &[[f64; 2]], idx: &[usize], cfg: &LaneConfig) -> Vec<Vec<usize>> {
    let Some(&first) = idx.first() else {
        return Vec::new();
    };
    let start = pts[first];
    let near = (2.0 * cfg.resample_m).max(3.0);
    let mut out = Vec::new();
    let mut cur = vec![first];
    let mut travelled = 0.0;
    for w in idx.windows(2) {
        travelled += dist(pts[w[0]], pts[w[1]]);
        cur.push(w[1]);
        if travelled >= cfg.association_m && dist(pts[w[1]], start) < near {
            out.push(std::mem::take(&mut cur));
            cur.push(w[1]);
            travelled = 0.0;
        }
    }
    if cur.len() > 1 {
        match out.last_mut() {
            // a short tail after the last return belongs to the last lap
            Some(l)
                if polyline_length(&cur.iter().map(|&i| pts[i]).collect::<Vec<_>>())
                    < cfg.association_m =>
            {
                l.extend(cur.into_iter().skip(1));
            }
            _ => out.push(cur),
        }
    }
    out
}

/// The driven path from node `a` to node `b` over samples `idx`: one path, or its laps when
/// it starts and ends at the same node ([`laps`]).
pub(super) fn driven_paths(
    pts: &[[f64; 2]],
    a: usize,
    b: usize,
    idx: Vec<usize>,
    cfg: &LaneConfig,
) -> Vec<DrivenPath> {
    let pieces = if a == b {
        laps(pts, &idx, cfg)
    } else {
        vec![idx]
    };
    pieces
        .into_iter()
        .map(|idx| DrivenPath {
            a,
            b,
            idx,
            extra: Vec::new(),
        })
        .collect()
}

/// The paths between node visits along one piece of the drive (sample range `piece`).
pub(super) fn piece_paths(
    samples: &[Sample],
    pts: &[[f64; 2]],
    piece: std::ops::Range<usize>,
    nodes: &mut Vec<Candidate>,
    cfg: &LaneConfig,
) -> Vec<DrivenPath> {
    let (p0, last) = (piece.start, piece.end - 1);
    let mut paths: Vec<DrivenPath> = Vec::new();
    let breakpoint = |xy: [f64; 2]| Candidate {
        xy,
        kind: LaneNodeKind::Breakpoint,
        ways: 1,
        lambda: 0.0,
    };
    let mut vs: Vec<Visit> = visits(&pts[piece.clone()], nodes, cfg)
        .into_iter()
        .map(|v| Visit {
            node: v.node,
            at: v.at + p0,
        })
        .collect();
    let length = polyline_length(&pts[piece.clone()]);
    let closes = dist(pts[p0], pts[last]) < cfg.association_m && length > 2.0 * cfg.association_m;
    if vs.is_empty() {
        if closes {
            // a loop with no junction: one node where the drive starts, the laps between
            nodes.push(breakpoint(pts[p0]));
            let n = nodes.len() - 1;
            return driven_paths(pts, n, n, (p0..=last).collect(), cfg);
        }
        if last == p0 {
            return paths;
        }
        // no junction and no detected end: make the two ends breakpoints
        for i in [p0, last] {
            nodes.push(breakpoint(pts[i]));
            vs.push(Visit {
                node: nodes.len() - 1,
                at: i,
            });
        }
    }
    let head_gap = polyline_length(&pts[p0..=vs[0].at]);
    let tail_gap = polyline_length(&pts[vs[vs.len() - 1].at..=last]);
    if closes && head_gap + tail_gap > cfg.association_m {
        // a closed drive: the stretch across the start joins the last visit to the first
        let (a, b) = (&vs[vs.len() - 1], &vs[0]);
        let idx: Vec<usize> = (a.at..=last).chain(p0..=b.at).collect();
        paths.extend(driven_paths(pts, a.node, b.node, idx, cfg));
    } else {
        if head_gap > cfg.association_m / 2.0 {
            nodes.push(breakpoint(pts[p0]));
            vs.insert(
                0,
                Visit {
                    node: nodes.len() - 1,
                    at: p0,
                },
            );
        }
        if tail_gap > cfg.association_m / 2.0 {
            nodes.push(breakpoint(pts[last]));
            vs.push(Visit {
                node: nodes.len() - 1,
                at: last,
            });
        }
    }
    for w in vs.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        let idx: Vec<usize> = (a.at..=b.at).collect();
        let len = polyline_length(&idx.iter().map(|&i| pts[i]).collect::<Vec<_>>());
        if a.node == b.node && len < 2.0 * cfg.association_m {
            continue;
        }
        paths.extend(driven_paths(pts, a.node, b.node, idx, cfg));
    }
    // poses before the first visit and after the last one (a few metres at the ends of the
    // piece) belong to the first and last paths
    let (first_at, last_at) = (vs[0].at, vs[vs.len() - 1].at);
    let (src0, src1) = (samples[p0].src, samples[last].src);
    for path in &mut paths {
        if path.idx.first() == Some(&first_at) {
            path.extra.extend(src0..=samples[first_at].src);
        }
        if path.idx.last() == Some(&last_at) {
            path.extra.extend(samples[last_at].src..=src1);
        }
    }
    paths
}

pub(super) fn build_edges(
    samples: &[Sample],
    pts: &[[f64; 2]],
    pieces: &[std::ops::Range<usize>],
    mut nodes: Vec<Candidate>,
    cfg: &LaneConfig,
) -> Result<LaneGraph> {
    let mut paths: Vec<DrivenPath> = Vec::new();
    for piece in pieces {
        if !piece.is_empty() {
            paths.extend(piece_paths(samples, pts, piece.clone(), &mut nodes, cfg));
        }
    }
    paths.sort_by_key(|p| {
        if p.idx.first() > p.idx.last() {
            0
        } else {
            p.idx[0] + 1
        }
    });
    // merge repeated drives
    let mut edges: Vec<LaneEdge> = Vec::new();
    for DrivenPath { a, b, idx, extra } in paths {
        let mut poly: Vec<[f64; 2]> = Vec::with_capacity(idx.len() + 2);
        poly.push(nodes[a].xy);
        poly.extend(idx.iter().map(|&i| pts[i]));
        poly.push(nodes[b].xy);
        poly.dedup_by(|x, y| dist(*x, *y) < 1e-9);
        let (from, to) = (a, b);
        // every pose between consecutive samples of the path (not only the sampled ones)
        let mut frames: Vec<u32> = extra;
        for w in idx.windows(2) {
            let (x, y) = (samples[w[0]].src, samples[w[1]].src);
            if w[1] == w[0] + 1 && x <= y {
                frames.extend(x..=y);
            } else {
                frames.push(x);
                frames.push(y);
            }
        }
        frames.extend(idx.first().map(|&i| samples[i].src));
        frames.sort_unstable();
        frames.dedup();
        if let Some(e) = edges.iter_mut().find(|e| {
            (e.from.min(e.to), e.from.max(e.to)) == (from.min(to), from.max(to))
                && hausdorff(&e.polyline, &poly) <= cfg.edge_merge_m
        }) {
            e.frames.extend(frames);
            e.frames.sort_unstable();
            e.frames.dedup();
            continue;
        }
        let length_m = polyline_length(&poly);
        edges.push(LaneEdge {
            from,
            to,
            polyline: poly,
            length_m,
            frames,
        });
    }
    // keep nodes that carry edges, numbered by first appearance along the edges
    let mut order: Vec<usize> = Vec::new();
    for e in &edges {
        for n in [e.from, e.to] {
            if !order.contains(&n) {
                order.push(n);
            }
        }
    }
    let mut new_id = vec![usize::MAX; nodes.len()];
    for (k, &n) in order.iter().enumerate() {
        new_id[n] = k;
    }
    let out_nodes = order
        .iter()
        .enumerate()
        .map(|(k, &n)| LaneNode {
            id: k,
            kind: nodes[n].kind,
            xy: nodes[n].xy,
            ways: nodes[n].ways,
            disfluency_rad: nodes[n].lambda,
        })
        .collect();
    for e in &mut edges {
        e.from = new_id[e.from];
        e.to = new_id[e.to];
    }
    Ok(LaneGraph {
        nodes: out_nodes,
        edges,
        gaps: Vec::new(),
    })
}
