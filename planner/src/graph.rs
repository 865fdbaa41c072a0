//! The road graph the planner searches: nodes with ground-plane positions and edges with
//! metric polylines, one-way or two-way. Loaded from an OpenGraph store (the lane-graph
//! layer) or from an Argoverse 2 HD map.

use std::collections::HashMap;
use std::path::Path;

use graphstore::{Direction, GraphRead};

use crate::error::{Error, Result};

/// A graph vertex.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RoadNode {
    /// Stable name: `lane:ID` with the store's node id, or `av2:N` (map junction point).
    pub key: String,
    /// Ground-plane position.
    pub xy: [f64; 2],
}

/// A graph edge.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RoadEdge {
    /// Start node index.
    pub from: usize,
    /// End node index.
    pub to: usize,
    /// Path from `from` to `to`.
    pub polyline: Vec<[f64; 2]>,
    /// Length of the polyline.
    pub length_m: f64,
    /// Whether it may only be driven from `from` to `to`.
    pub directed: bool,
}

/// A road graph with adjacency.
#[derive(Debug, Clone, Default)]
pub struct RoadGraph {
    /// Vertices.
    pub nodes: Vec<RoadNode>,
    /// Edges.
    pub edges: Vec<RoadEdge>,
    /// Per node: (edge, other node, forward along the edge's polyline).
    adjacency: Vec<Vec<(usize, usize, bool)>>,
    by_key: HashMap<String, usize>,
}

pub(crate) use scene::geom::{dist, polyline_length};

impl RoadGraph {
    /// Builds adjacency over `nodes` and `edges`.
    pub fn new(nodes: Vec<RoadNode>, edges: Vec<RoadEdge>) -> Result<RoadGraph> {
        let mut adjacency = vec![Vec::new(); nodes.len()];
        for (i, e) in edges.iter().enumerate() {
            if e.from >= nodes.len() || e.to >= nodes.len() {
                return Err(Error::Invalid(format!("edge {i} refers to a missing node")));
            }
            if !(e.length_m.is_finite() && e.length_m >= 0.0) || e.polyline.len() < 2 {
                return Err(Error::Invalid(format!(
                    "edge {i} has no usable polyline or length"
                )));
            }
            adjacency[e.from].push((i, e.to, true));
            if !e.directed {
                adjacency[e.to].push((i, e.from, false));
            }
        }
        let by_key = nodes
            .iter()
            .enumerate()
            .map(|(i, n)| (n.key.clone(), i))
            .collect();
        Ok(RoadGraph {
            nodes,
            edges,
            adjacency,
            by_key,
        })
    }

    /// Edges leaving a node: (edge, other node, forward).
    pub fn out(&self, node: usize) -> &[(usize, usize, bool)] {
        &self.adjacency[node]
    }

    /// A node by key.
    pub fn node_by_key(&self, key: &str) -> Option<usize> {
        self.by_key.get(key).copied()
    }

    /// Loads the lane-graph layer of a store (`LaneNode` + `LANE`). Lanes are two-way unless
    /// their `directed` property is true.
    pub fn from_store(r: &impl GraphRead) -> Result<RoadGraph> {
        let lane_ids = r.nodes_with_label(scene::label::LANE_NODE)?;
        if lane_ids.is_empty() {
            return Err(Error::NoLaneGraph);
        }
        let ground = scene::records::ground_frame(r)?;
        let mut nodes = Vec::with_capacity(lane_ids.len());
        let mut index = HashMap::new();
        for id in &lane_ids {
            let p = scene::records::LaneNodeRecord::read(r, *id)
                .ok()
                .flatten()
                .ok_or(Error::NoLaneGraph)?
                .position;
            index.insert(*id, nodes.len());
            nodes.push(RoadNode {
                key: format!("lane:{id}"),
                xy: ground.ground(p),
            });
        }
        let lane = r.rel_type(scene::rel::LANE).ok_or(Error::NoLaneGraph)?;
        let mut edges = Vec::new();
        for id in &lane_ids {
            for adj in r.neighbours(*id, Direction::Outgoing, Some(lane))? {
                let rel = r
                    .rel(adj.rel)?
                    .ok_or(graphstore::Error::RelNotFound(adj.rel))?;
                let rec = scene::records::LaneEdgeRecord::read(r, adj.rel)?;
                let polyline: Vec<[f64; 2]> =
                    rec.polyline.iter().map(|p| ground.ground(*p)).collect();
                let (from, to) = (index[&rel.start], index[&rel.end]);
                let polyline = if polyline.len() >= 2 {
                    polyline
                } else {
                    vec![nodes[from].xy, nodes[to].xy]
                };
                let (length_m, directed) = (rec.length_m, rec.directed);
                edges.push(RoadEdge {
                    from,
                    to,
                    polyline,
                    length_m,
                    directed,
                });
            }
        }
        RoadGraph::new(nodes, edges)
    }

    /// Loads an Argoverse 2 HD map (`log_map_archive_*.json`): each vehicle lane segment is a
    /// one-way edge along its centreline (the mean of its left and right boundaries), and
    /// `successors` join the end of a segment to the start of the next.
    pub fn from_av2(path: &Path) -> Result<(RoadGraph, HashMap<i64, usize>)> {
        let bad = |d: String| Error::Map {
            path: path.to_path_buf(),
            detail: d,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
        let v: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| bad(format!("invalid JSON: {e}")))?;
        let segs = v
            .get("lane_segments")
            .and_then(|s| s.as_object())
            .ok_or_else(|| bad("no lane_segments object".into()))?;
        let mut ids: Vec<i64> = Vec::new();
        let mut centre: Vec<Vec<[f64; 2]>> = Vec::new();
        let mut succ: Vec<Vec<i64>> = Vec::new();
        let mut keys: Vec<&String> = segs.keys().collect();
        keys.sort_by_key(|k| k.parse::<i64>().unwrap_or(i64::MAX));
        for k in keys {
            let s = &segs[k];
            let id = s
                .get("id")
                .and_then(|x| x.as_i64())
                .ok_or_else(|| bad(format!("lane segment {k} has no id")))?;
            if s.get("lane_type")
                .and_then(|t| t.as_str())
                .is_some_and(|t| t != "VEHICLE" && t != "BUS")
            {
                continue;
            }
            let boundary = |name: &str| -> Result<Vec<[f64; 2]>> {
                let pts = s
                    .get(name)
                    .and_then(|b| b.as_array())
                    .ok_or_else(|| bad(format!("lane segment {id} has no {name}")))?;
                pts.iter()
                    .map(|p| {
                        match (
                            p.get("x").and_then(|x| x.as_f64()),
                            p.get("y").and_then(|y| y.as_f64()),
                        ) {
                            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Ok([x, y]),
                            _ => Err(bad(format!("lane segment {id}: bad point in {name}"))),
                        }
                    })
                    .collect()
            };
            let (l, r) = (
                boundary("left_lane_boundary")?,
                boundary("right_lane_boundary")?,
            );
            if l.len() < 2 || r.len() < 2 {
                return Err(bad(format!(
                    "lane segment {id}: a boundary has fewer than 2 points"
                )));
            }
            let n = l.len().max(r.len()).max(2);
            let (lr, rr) = (resample(&l, n), resample(&r, n));
            centre.push(
                lr.iter()
                    .zip(&rr)
                    .map(|(a, b)| [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0])
                    .collect(),
            );
            succ.push(
                s.get("successors")
                    .and_then(|x| x.as_array())
                    .map(|a| a.iter().filter_map(|x| x.as_i64()).collect())
                    .unwrap_or_default(),
            );
            ids.push(id);
        }
        let pos: HashMap<i64, usize> = ids.iter().enumerate().map(|(i, id)| (*id, i)).collect();
        // union-find over segment ends: 2i = start of i, 2i+1 = end of i
        let mut parent: Vec<usize> = (0..2 * ids.len()).collect();
        fn find(p: &mut [usize], x: usize) -> usize {
            let mut r = x;
            while p[r] != r {
                r = p[r];
            }
            p[x] = r;
            r
        }
        for (i, ss) in succ.iter().enumerate() {
            for s in ss {
                if let Some(&j) = pos.get(s) {
                    let (a, b) = (find(&mut parent, 2 * i + 1), find(&mut parent, 2 * j));
                    if a != b {
                        parent[a.max(b)] = a.min(b);
                    }
                }
            }
        }
        let mut node_of: HashMap<usize, usize> = HashMap::new();
        let mut sums: Vec<([f64; 2], usize)> = Vec::new();
        for end in 0..2 * ids.len() {
            let root = find(&mut parent, end);
            let seg = &centre[end / 2];
            let p = if end % 2 == 0 {
                seg[0]
            } else {
                *seg.last().expect("2+ points")
            };
            let k = *node_of.entry(root).or_insert_with(|| {
                sums.push(([0.0, 0.0], 0));
                sums.len() - 1
            });
            sums[k].0[0] += p[0];
            sums[k].0[1] += p[1];
            sums[k].1 += 1;
        }
        let nodes: Vec<RoadNode> = sums
            .iter()
            .enumerate()
            .map(|(k, (s, n))| RoadNode {
                key: format!("av2:{k}"),
                xy: [s[0] / *n as f64, s[1] / *n as f64],
            })
            .collect();
        let mut start_node = HashMap::new();
        let mut edges = Vec::with_capacity(ids.len());
        for (i, id) in ids.iter().enumerate() {
            let from = node_of[&find(&mut parent, 2 * i)];
            let to = node_of[&find(&mut parent, 2 * i + 1)];
            let mut poly = centre[i].clone();
            poly[0] = nodes[from].xy;
            *poly.last_mut().expect("2+ points") = nodes[to].xy;
            start_node.insert(*id, from);
            edges.push(RoadEdge {
                from,
                to,
                length_m: polyline_length(&poly),
                polyline: poly,
                directed: true,
            });
        }
        Ok((RoadGraph::new(nodes, edges)?, start_node))
    }
}

/// Resamples a polyline to `n` points evenly spaced by arc length.
fn resample(p: &[[f64; 2]], n: usize) -> Vec<[f64; 2]> {
    let total = polyline_length(p);
    if total <= 0.0 {
        return vec![p[0]; n];
    }
    (0..n)
        .map(|k| point_at(p, total * k as f64 / (n - 1) as f64))
        .collect()
}

/// The point at arc length `s` along a polyline (clamped).
pub(crate) fn point_at(p: &[[f64; 2]], s: f64) -> [f64; 2] {
    let mut acc = 0.0;
    for w in p.windows(2) {
        let l = dist(w[0], w[1]);
        if acc + l >= s && l > 0.0 {
            let t = ((s - acc) / l).clamp(0.0, 1.0);
            return [
                w[0][0] + t * (w[1][0] - w[0][0]),
                w[0][1] + t * (w[1][1] - w[0][1]),
            ];
        }
        acc += l;
    }
    *p.last().expect("non-empty polyline")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resample_keeps_ends_and_spacing() {
        let r = resample(&[[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]], 5);
        assert_eq!(r.len(), 5);
        assert!(dist(r[2], [10.0, 0.0]) < 1e-9);
        assert!(dist(r[4], [10.0, 10.0]) < 1e-9);
    }
}
