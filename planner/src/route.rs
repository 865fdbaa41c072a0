//! Routing: A* over the road graph with metric edge lengths, from and to points snapped onto
//! lanes, lane nodes, segments or instances.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use graphstore::GraphRead;

use crate::error::{Error, Result};
use crate::graph::{RoadGraph, dist, point_at};
use scene::GroundFrame;

/// A start or goal as the user gives it.
///
/// Every id is a **node id**: the one `find` prints, Cypher's `id(n)` returns, `info`, exports,
/// HTTP and MCP use. The kind prefix says which label the node must have, so a mistyped id
/// fails ("node 7 is a Segment, not an Instance") instead of naming another object.
#[derive(Debug, Clone, PartialEq)]
pub enum Spec {
    /// A ground-plane point, snapped to the nearest lane within the snap limit.
    Point([f64; 2]),
    /// A lane-graph node (`LaneNode`), by node id.
    Lane(u64),
    /// A segment (`Segment`), by node id: its centroid, snapped to the nearest lane.
    Segment(u64),
    /// An instance (`Instance`), by node id: the nearest lane point to its centroid.
    Instance(u64),
    /// Any node with a position: a `LaneNode`, a `Segment` or an `Instance`, by node id.
    Node(u64),
}

/// The labels a spec kind accepts, by kind name.
fn labels_of(kind: &str) -> &'static [&'static str] {
    match kind {
        "lane" => &[scene::label::LANE_NODE],
        "segment" => &[scene::label::SEGMENT],
        "instance" => &[scene::label::INSTANCE],
        _ => &[
            scene::label::LANE_NODE,
            scene::label::SEGMENT,
            scene::label::INSTANCE,
        ],
    }
}

/// A spec resolved to a place on the ground plane, before snapping to the road graph.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Target {
    /// The spec as given (`instance:1233`, `3.5,-2`).
    pub spec: String,
    /// The node it names (None for a point).
    pub node: Option<u64>,
    /// The node's label that matched (`Instance`, `Segment`, `LaneNode`), or `point`.
    pub kind: String,
    /// The ground-plane position the route goes to (for an instance or segment, its centroid).
    pub xy: [f64; 2],
}

impl std::str::FromStr for Spec {
    type Err = Error;
    fn from_str(s: &str) -> Result<Spec> {
        let bad = |d: &str| Error::BadSpec {
            spec: s.to_string(),
            detail: d.to_string(),
        };
        if let Some((kind, id)) = s.split_once(':') {
            let id: u64 = id
                .trim()
                .parse()
                .map_err(|_| bad("the id is not a node id (a non-negative integer)"))?;
            return match kind.trim() {
                "lane" => Ok(Spec::Lane(id)),
                "segment" => Ok(Spec::Segment(id)),
                "instance" => Ok(Spec::Instance(id)),
                "node" => Ok(Spec::Node(id)),
                _ => Err(bad("unknown kind")),
            };
        }
        let parts: Vec<&str> = s.split(',').collect();
        if parts.len() != 2 {
            return Err(bad("expected two coordinates"));
        }
        let x: f64 = parts[0]
            .trim()
            .parse()
            .map_err(|_| bad("x is not a number"))?;
        let y: f64 = parts[1]
            .trim()
            .parse()
            .map_err(|_| bad("y is not a number"))?;
        if !x.is_finite() || !y.is_finite() {
            return Err(bad("coordinates must be finite"));
        }
        Ok(Spec::Point([x, y]))
    }
}

/// Where a route starts or ends on the graph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    /// At a node.
    Node(usize),
    /// On an edge, `s` metres along its polyline from its start.
    OnEdge {
        /// The edge.
        edge: usize,
        /// Arc length from the edge's start.
        s: f64,
        /// The snapped point.
        xy: [f64; 2],
    },
}

/// A route over the graph.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Route {
    /// Node keys in order (`start` / `goal` for points on edges).
    pub nodes: Vec<String>,
    /// The path on the ground plane.
    pub polyline: Vec<[f64; 2]>,
    /// Its length.
    pub length_m: f64,
}

use scene::geom::closest_on_segment;

/// Projection of `p` on a polyline: (arc length, point, distance).
fn project(poly: &[[f64; 2]], p: [f64; 2]) -> (f64, [f64; 2], f64) {
    let mut best = (0.0, poly[0], f64::INFINITY);
    let mut acc = 0.0;
    for w in poly.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = dist(a, b);
        let (t, q) = closest_on_segment(p, a, b);
        let dq = dist(p, q);
        if dq < best.2 {
            best = (acc + t * len, q, dq);
        }
        acc += len;
    }
    best
}

/// Snaps `p` to the nearest edge within `limit_m`.
pub fn snap(g: &RoadGraph, p: [f64; 2], limit_m: f64) -> Result<Anchor> {
    let best = g
        .edges
        .iter()
        .enumerate()
        .map(|(i, e)| (i, project(&e.polyline, p)))
        .min_by(|a, b| a.1.2.total_cmp(&b.1.2).then(a.0.cmp(&b.0)))
        .ok_or(Error::NoLaneGraph)?;
    let (edge, (s, xy, d)) = best;
    if d > limit_m {
        return Err(Error::TooFar {
            x: p[0],
            y: p[1],
            distance_m: d,
            limit_m,
        });
    }
    let total = g.edges[edge]
        .polyline
        .windows(2)
        .map(|w| dist(w[0], w[1]))
        .sum::<f64>();
    // scale the polyline arc length to the edge's metric length
    let s = if total > 0.0 {
        s * g.edges[edge].length_m / total
    } else {
        0.0
    };
    Ok(Anchor::OnEdge { edge, s, xy })
}

/// Resolves a spec to its node (checking the label) and ground-plane position.
///
/// Errors: [`Error::UnknownId`] when no node has the id, [`Error::WrongKind`] when the node has
/// none of the labels the spec's kind accepts, [`Error::Invalid`] when it has no position.
pub fn target(r: &impl GraphRead, ground: GroundFrame, spec: &Spec) -> Result<Target> {
    let (kind, id) = match spec {
        Spec::Point(p) => {
            return Ok(Target {
                spec: format!("{},{}", p[0], p[1]),
                node: None,
                kind: "point".into(),
                xy: *p,
            });
        }
        Spec::Lane(id) => ("lane", *id),
        Spec::Segment(id) => ("segment", *id),
        Spec::Instance(id) => ("instance", *id),
        Spec::Node(id) => ("node", *id),
    };
    let node = r.node(id)?.ok_or(Error::UnknownId { kind, id })?;
    let names: Vec<String> = node.labels.iter().filter_map(|l| r.name_of(l.0)).collect();
    let label = labels_of(kind)
        .iter()
        .find(|l| names.iter().any(|n| n == *l))
        .ok_or_else(|| Error::WrongKind {
            id,
            kind,
            wanted: match kind {
                "lane" => "a LaneNode",
                "segment" => "a Segment",
                "instance" => "an Instance",
                _ => "a LaneNode, Segment or Instance",
            },
            labels: if names.is_empty() {
                "no label".into()
            } else {
                names.join(":")
            },
        })?;
    let key = if *label == scene::label::LANE_NODE {
        scene::key::POSITION
    } else {
        scene::key::CENTROID
    };
    let p = r
        .node_prop(id, key)?
        .and_then(|v| v.as_point3())
        .ok_or_else(|| Error::Invalid(format!("node {id} ({label}) has no {key}")))?;
    Ok(Target {
        spec: format!("{kind}:{id}"),
        node: Some(id),
        kind: (*label).to_string(),
        xy: ground.ground(p),
    })
}

/// Resolves a spec against a store-backed graph: a lane node is that graph node; a point is
/// snapped within `snap_limit_m`; an instance or segment goes to the lane point nearest to its
/// centroid. Returns the anchor and the resolved [`Target`].
pub fn resolve(
    g: &RoadGraph,
    r: &impl GraphRead,
    ground: GroundFrame,
    spec: &Spec,
    snap_limit_m: f64,
) -> Result<(Anchor, Target)> {
    let t = target(r, ground, spec)?;
    let anchor = match (t.node, t.kind.as_str()) {
        (None, _) => snap(g, t.xy, snap_limit_m)?,
        (Some(id), scene::label::LANE_NODE) => g
            .node_by_key(&format!("lane:{id}"))
            .map(Anchor::Node)
            .ok_or(Error::UnknownId { kind: "lane", id })?,
        _ => snap(g, t.xy, f64::INFINITY)?,
    };
    Ok((anchor, t))
}

#[derive(PartialEq)]
struct Entry(f64, usize);
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}

/// Part of a polyline between arc lengths `a` and `b` (reversed when `b < a`).
pub(crate) fn sub_polyline(poly: &[[f64; 2]], a: f64, b: f64) -> Vec<[f64; 2]> {
    let (lo, hi) = (a.min(b), a.max(b));
    let mut out = vec![point_at(poly, lo)];
    let mut acc = 0.0;
    for w in poly.windows(2) {
        acc += dist(w[0], w[1]);
        if acc > lo && acc < hi {
            out.push(w[1]);
        }
    }
    out.push(point_at(poly, hi));
    if b < a {
        out.reverse();
    }
    out
}

/// Arc length along the polyline, rescaled to metric length.
fn arc_scale(g: &RoadGraph, edge: usize) -> f64 {
    let e = &g.edges[edge];
    let total: f64 = e.polyline.windows(2).map(|w| dist(w[0], w[1])).sum();
    if e.length_m > 0.0 {
        total / e.length_m
    } else {
        1.0
    }
}

/// Shortest route by metric length (A* with a straight-line heuristic).
pub fn astar(g: &RoadGraph, from: Anchor, to: Anchor) -> Result<Route> {
    let n = g.nodes.len();
    let (start, goal) = (n, n + 1);
    let xy = |v: usize| -> [f64; 2] {
        match v {
            v if v < n => g.nodes[v].xy,
            v if v == start => anchor_xy(g, from),
            _ => anchor_xy(g, to),
        }
    };
    let goal_xy = xy(goal);
    // extra arcs from the virtual start and into the virtual goal
    let mut from_start: Vec<(usize, f64)> = Vec::new();
    let mut into_goal: Vec<(usize, f64)> = Vec::new();
    let mut direct: Option<f64> = None;
    match from {
        Anchor::Node(v) => from_start.push((v, 0.0)),
        Anchor::OnEdge { edge, s, .. } => {
            let e = &g.edges[edge];
            from_start.push((e.to, e.length_m - s));
            if !e.directed {
                from_start.push((e.from, s));
            }
        }
    }
    match to {
        Anchor::Node(v) => into_goal.push((v, 0.0)),
        Anchor::OnEdge { edge, s, .. } => {
            let e = &g.edges[edge];
            into_goal.push((e.from, s));
            if !e.directed {
                into_goal.push((e.to, e.length_m - s));
            }
        }
    }
    if let (Anchor::OnEdge { edge: a, s: sa, .. }, Anchor::OnEdge { edge: b, s: sb, .. }) =
        (from, to)
        && a == b
        && (sb >= sa || !g.edges[a].directed)
    {
        direct = Some((sb - sa).abs());
    }
    if let (Anchor::Node(a), Anchor::Node(b)) = (from, to)
        && a == b
    {
        direct = Some(0.0);
    }
    let mut best = vec![f64::INFINITY; n + 2];
    // how each vertex was reached: (previous vertex, edge or usize::MAX for virtual arcs, forward)
    let mut prev: Vec<Option<(usize, usize, bool)>> = vec![None; n + 2];
    let mut heap = BinaryHeap::new();
    best[start] = 0.0;
    heap.push(Entry(dist(xy(start), goal_xy), start));
    while let Some(Entry(_, v)) = heap.pop() {
        if v == goal {
            break;
        }
        let gv = best[v];
        let mut relax =
            |w: usize, cost: f64, via: (usize, usize, bool), heap: &mut BinaryHeap<Entry>| {
                let c = gv + cost;
                if c < best[w] {
                    best[w] = c;
                    prev[w] = Some(via);
                    heap.push(Entry(c + dist(xy(w), goal_xy), w));
                }
            };
        if v == start {
            for &(w, c) in &from_start {
                relax(w, c, (start, usize::MAX, true), &mut heap);
            }
            if let Some(c) = direct {
                relax(goal, c, (start, usize::MAX, true), &mut heap);
            }
            continue;
        }
        for &(edge, w, fwd) in g.out(v) {
            relax(w, g.edges[edge].length_m, (v, edge, fwd), &mut heap);
        }
        for &(u, c) in &into_goal {
            if u == v {
                relax(goal, c, (v, usize::MAX, true), &mut heap);
            }
        }
    }
    if !best[goal].is_finite() {
        return Err(Error::NoRoute(format!(
            "{} -> {}",
            describe(g, from),
            describe(g, to)
        )));
    }
    // walk back
    let mut hops = Vec::new();
    let mut v = goal;
    while let Some(p) = prev[v] {
        hops.push((p.0, v, p.1, p.2));
        v = p.0;
    }
    hops.reverse();
    let mut nodes = Vec::new();
    let mut poly: Vec<[f64; 2]> = Vec::new();
    let key = |v: usize| {
        if v < n {
            g.nodes[v].key.clone()
        } else if v == start {
            "start".into()
        } else {
            "goal".into()
        }
    };
    for (a, b, edge, fwd) in &hops {
        if nodes.is_empty() {
            nodes.push(key(*a));
        }
        nodes.push(key(*b));
        let piece: Vec<[f64; 2]> = if *edge != usize::MAX {
            let p = g.edges[*edge].polyline.clone();
            if *fwd {
                p
            } else {
                p.into_iter().rev().collect()
            }
        } else {
            virtual_piece(g, from, to, *a, *b, n)
        };
        for q in piece {
            if poly.last().is_none_or(|l| dist(*l, q) > 1e-9) {
                poly.push(q);
            }
        }
    }
    if poly.len() == 1 {
        poly.push(poly[0]);
    }
    // virtual endpoints are only named when they are points on edges
    if matches!(from, Anchor::Node(_)) && nodes.first().is_some_and(|k| k == "start") {
        nodes.remove(0);
    }
    if matches!(to, Anchor::Node(_)) && nodes.last().is_some_and(|k| k == "goal") {
        nodes.pop();
    }
    Ok(Route {
        nodes,
        polyline: poly,
        length_m: best[goal],
    })
}

fn anchor_xy(g: &RoadGraph, a: Anchor) -> [f64; 2] {
    match a {
        Anchor::Node(v) => g.nodes[v].xy,
        Anchor::OnEdge { xy, .. } => xy,
    }
}

fn describe(g: &RoadGraph, a: Anchor) -> String {
    match a {
        Anchor::Node(v) => g.nodes[v].key.clone(),
        Anchor::OnEdge { xy, .. } => format!("({:.1}, {:.1})", xy[0], xy[1]),
    }
}

/// The polyline of a virtual arc (start -> node, node -> goal, start -> goal).
fn virtual_piece(
    g: &RoadGraph,
    from: Anchor,
    to: Anchor,
    a: usize,
    b: usize,
    n: usize,
) -> Vec<[f64; 2]> {
    let (start, goal) = (n, n + 1);
    let along = |anchor: Anchor, node: usize, towards_node: bool| -> Vec<[f64; 2]> {
        match anchor {
            Anchor::Node(v) => vec![g.nodes[v].xy],
            Anchor::OnEdge { edge, s, .. } => {
                let e = &g.edges[edge];
                let s_poly = s * arc_scale(g, edge);
                let total: f64 = e.polyline.windows(2).map(|w| dist(w[0], w[1])).sum();
                let end = if node == e.from { 0.0 } else { total };
                if towards_node {
                    sub_polyline(&e.polyline, s_poly, end)
                } else {
                    sub_polyline(&e.polyline, end, s_poly)
                }
            }
        }
    };
    match (a == start, b == goal) {
        (true, true) => match (from, to) {
            (Anchor::OnEdge { edge, s: sa, .. }, Anchor::OnEdge { s: sb, .. }) => {
                let k = arc_scale(g, edge);
                sub_polyline(&g.edges[edge].polyline, sa * k, sb * k)
            }
            _ => vec![anchor_xy(g, from), anchor_xy(g, to)],
        },
        (true, false) => along(from, b, true),
        (false, true) => along(to, a, false),
        _ => vec![g.nodes[a].xy, g.nodes[b].xy],
    }
}

/// The reference implementation's route: fewest hops (unit cost per edge), between nodes.
/// Returns the node path and its metric length.
pub fn unit_cost_route(g: &RoadGraph, from: usize, to: usize) -> Option<(Vec<usize>, f64)> {
    let mut prev: Vec<Option<(usize, usize)>> = vec![None; g.nodes.len()];
    let mut seen = vec![false; g.nodes.len()];
    let mut queue = std::collections::VecDeque::from([from]);
    seen[from] = true;
    while let Some(v) = queue.pop_front() {
        if v == to {
            break;
        }
        for &(edge, w, _) in g.out(v) {
            if !seen[w] {
                seen[w] = true;
                prev[w] = Some((v, edge));
                queue.push_back(w);
            }
        }
    }
    if !seen[to] {
        return None;
    }
    let (mut path, mut length) = (vec![to], 0.0);
    let mut v = to;
    while let Some((p, e)) = prev[v] {
        length += g.edges[e].length_m;
        path.push(p);
        v = p;
    }
    path.reverse();
    Some((path, length))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::{RoadEdge, RoadNode};

    fn graph(nodes: &[[f64; 2]], edges: &[(usize, usize, bool)]) -> RoadGraph {
        let ns = nodes
            .iter()
            .enumerate()
            .map(|(i, p)| RoadNode {
                key: format!("lane:{i}"),
                xy: *p,
            })
            .collect();
        let es = edges
            .iter()
            .map(|&(a, b, directed)| RoadEdge {
                from: a,
                to: b,
                polyline: vec![nodes[a], nodes[b]],
                length_m: dist(nodes[a], nodes[b]),
                directed,
            })
            .collect();
        RoadGraph::new(ns, es).unwrap()
    }

    #[test]
    fn fewest_hops_is_not_shortest() {
        // 0 -> 3 directly via a long detour edge (1 hop, 300 m) or via 1, 2 (3 hops, 30 m)
        let g = {
            let nodes = [[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [30.0, 0.0]];
            let mut es = vec![(0, 1, false), (1, 2, false), (2, 3, false)];
            es.push((0, 3, false));
            let mut g = graph(&nodes, &es);
            g.edges[3].polyline = vec![[0.0, 0.0], [15.0, 145.0], [30.0, 0.0]];
            g.edges[3].length_m = crate::graph::polyline_length(&g.edges[3].polyline);
            g
        };
        let r = astar(&g, Anchor::Node(0), Anchor::Node(3)).unwrap();
        assert_eq!(r.nodes, ["lane:0", "lane:1", "lane:2", "lane:3"]);
        assert!((r.length_m - 30.0).abs() < 1e-9);
        let (hops, len) = unit_cost_route(&g, 0, 3).unwrap();
        assert_eq!(hops, vec![0, 3]);
        assert!(len > 290.0);
    }

    #[test]
    fn directed_edges_are_honoured_and_points_snap() {
        // a one-way ring 0 -> 1 -> 2 -> 0
        let g = graph(
            &[[0.0, 0.0], [100.0, 0.0], [50.0, 80.0]],
            &[(0, 1, true), (1, 2, true), (2, 0, true)],
        );
        let r = astar(&g, Anchor::Node(1), Anchor::Node(0)).unwrap();
        assert_eq!(
            r.nodes,
            ["lane:1", "lane:2", "lane:0"],
            "must go round, not back along 0 -> 1"
        );
        // from a point on 0 -> 1 to a point on the same edge but behind it: all the way round
        let a = snap(&g, [60.0, 2.0], 5.0).unwrap();
        let b = snap(&g, [20.0, -1.0], 5.0).unwrap();
        let r = astar(&g, a, b).unwrap();
        let ring = 100.0 + 2.0 * 50f64.hypot(80.0);
        assert!((r.length_m - (ring - 40.0)).abs() < 1e-6, "{}", r.length_m);
        // forwards on the same edge is direct
        let r = astar(&g, b, a).unwrap();
        assert!((r.length_m - 40.0).abs() < 1e-6);
        assert_eq!(r.nodes, ["start", "goal"]);
        assert!(matches!(
            snap(&g, [50.0, 40.0], 5.0),
            Err(Error::TooFar { .. })
        ));
    }

    #[test]
    fn disconnected_and_specs() {
        let g = graph(
            &[[0.0, 0.0], [10.0, 0.0], [50.0, 0.0], [60.0, 0.0]],
            &[(0, 1, false), (2, 3, false)],
        );
        assert!(matches!(
            astar(&g, Anchor::Node(0), Anchor::Node(3)),
            Err(Error::NoRoute(_))
        ));
        assert_eq!("3.5, -2".parse::<Spec>().unwrap(), Spec::Point([3.5, -2.0]));
        assert_eq!("lane:7".parse::<Spec>().unwrap(), Spec::Lane(7));
        assert_eq!("instance:12".parse::<Spec>().unwrap(), Spec::Instance(12));
        assert_eq!("node:3".parse::<Spec>().unwrap(), Spec::Node(3));
        assert!("lane:x".parse::<Spec>().is_err());
        assert!("instance:-1".parse::<Spec>().is_err());
        assert!("1,2,3".parse::<Spec>().is_err());
        assert!("nan,1".parse::<Spec>().is_err());
    }

    #[test]
    fn route_polyline_follows_the_edges() {
        let g = graph(
            &[[0.0, 0.0], [100.0, 0.0], [100.0, 100.0]],
            &[(0, 1, false), (1, 2, false)],
        );
        let a = snap(&g, [30.0, 1.0], 5.0).unwrap();
        let b = snap(&g, [99.0, 60.0], 5.0).unwrap();
        let r = astar(&g, a, b).unwrap();
        assert!((r.length_m - 130.0).abs() < 1e-6);
        assert!(dist(r.polyline[0], [30.0, 0.0]) < 1e-9);
        assert!(dist(*r.polyline.last().unwrap(), [100.0, 60.0]) < 1e-9);
        assert!((crate::graph::polyline_length(&r.polyline) - 130.0).abs() < 1e-6);
    }
}
