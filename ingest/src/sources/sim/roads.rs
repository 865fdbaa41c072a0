//! Procedural road networks and drives. Coordinates are ground-plane metres `[x, z]` in
//! KITTI's camera world (x right, y down, z forward), the frame `opengraph build` expects.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value as Json, json};

use crate::sources::kitti::Rigid3;
use scene::geom::{dist, polyline_length};

/// How big a city to generate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SimSize {
    /// About 1 km of road.
    Small,
    /// About 5 km of road.
    Medium,
    /// 20 km of road or more.
    City,
}

impl SimSize {
    fn grid(self) -> usize {
        match self {
            SimSize::Small => 3,
            SimSize::Medium => 6,
            SimSize::City => 15,
        }
    }
}

/// What a road node is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JunctionKind {
    /// Four or more roads.
    Crossroads,
    /// Three roads.
    TJunction,
    /// Two roads meeting at a turn of 30° or more.
    LBend,
    /// Two roads in (nearly) a straight line.
    Straight,
    /// One road.
    DeadEnd,
}

impl JunctionKind {
    /// The name in `roads.json`.
    pub fn as_str(self) -> &'static str {
        match self {
            JunctionKind::Crossroads => "crossroads",
            JunctionKind::TJunction => "t_junction",
            JunctionKind::LBend => "l_bend",
            JunctionKind::Straight => "straight",
            JunctionKind::DeadEnd => "dead_end",
        }
    }
}

/// A road node.
#[derive(Debug, Clone, PartialEq)]
pub struct RoadNode {
    /// Position.
    pub pos: [f64; 2],
    /// Kind, from the roads that meet there.
    pub kind: JunctionKind,
}

/// A road between two nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Road {
    /// Start node.
    pub a: usize,
    /// End node.
    pub b: usize,
    /// Centre line from `a` to `b`, a point every metre or so.
    pub centerline: Vec<[f64; 2]>,
    /// Carriageway width.
    pub width_m: f64,
    /// Whether it bends between its ends.
    pub curved: bool,
}

/// A road network.
#[derive(Debug, Clone, PartialEq)]
pub struct RoadNetwork {
    /// Nodes.
    pub nodes: Vec<RoadNode>,
    /// Roads.
    pub roads: Vec<Road>,
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}

fn unit(a: [f64; 2]) -> [f64; 2] {
    let n = norm(a).max(1e-12);
    [a[0] / n, a[1] / n]
}

impl RoadNetwork {
    /// Total road length.
    pub fn length_m(&self) -> f64 {
        self.roads
            .iter()
            .map(|r| polyline_length(&r.centerline))
            .sum()
    }

    /// Roads at node `n`: (road index, whether the road starts there).
    pub fn roads_at(&self, n: usize) -> Vec<(usize, bool)> {
        let mut v = Vec::new();
        for (i, r) in self.roads.iter().enumerate() {
            if r.a == n {
                v.push((i, true));
            }
            if r.b == n {
                v.push((i, false));
            }
        }
        v
    }

    /// Direction in which road `r` leaves node `n` (from its first ~10 m).
    fn way_out(&self, r: usize, from_start: bool) -> [f64; 2] {
        let c = &self.roads[r].centerline;
        let k = c.len().min(11) - 1;
        if from_start {
            unit(sub(c[k], c[0]))
        } else {
            unit(sub(c[c.len() - 1 - k], c[c.len() - 1]))
        }
    }

    fn classify(&mut self) {
        for n in 0..self.nodes.len() {
            let at = self.roads_at(n);
            self.nodes[n].kind = match at.len() {
                0 | 1 => JunctionKind::DeadEnd,
                2 => {
                    let (u, v) = (
                        self.way_out(at[0].0, at[0].1),
                        self.way_out(at[1].0, at[1].1),
                    );
                    // straight through: the ways out point in opposite directions
                    let dot = (u[0] * v[0] + u[1] * v[1]).clamp(-1.0, 1.0);
                    let turn = std::f64::consts::PI - dot.acos();
                    if turn >= 30f64.to_radians() {
                        JunctionKind::LBend
                    } else {
                        JunctionKind::Straight
                    }
                }
                3 => JunctionKind::TJunction,
                _ => JunctionKind::Crossroads,
            };
        }
    }

    /// Generates a network: a jittered grid of blocks of varied sizes, some roads removed
    /// (for larger sizes), some curved, and dead-end stubs off the edge. Deterministic for a
    /// seed; every size has crossroads, T-junctions, L-bends and dead ends.
    pub fn generate(seed: u64, size: SimSize) -> RoadNetwork {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5157_0AD5);
        let g = size.grid();
        // block sizes differ per row and column
        let mut xs = vec![0.0];
        let mut zs = vec![0.0];
        for _ in 1..g {
            xs.push(xs.last().unwrap() + rng.random_range(70.0..130.0));
            zs.push(zs.last().unwrap() + rng.random_range(70.0..130.0));
        }
        let mut nodes = Vec::new();
        for z in &zs {
            for x in &xs {
                nodes.push(RoadNode {
                    pos: [
                        x + rng.random_range(-4.0..4.0),
                        z + rng.random_range(-4.0..4.0),
                    ],
                    kind: JunctionKind::Straight,
                });
            }
        }
        let id = |i: usize, j: usize| j * g + i;
        let mut edges: Vec<(usize, usize)> = Vec::new();
        for j in 0..g {
            for i in 0..g {
                if i + 1 < g {
                    edges.push((id(i, j), id(i + 1, j)));
                }
                if j + 1 < g {
                    edges.push((id(i, j), id(i, j + 1)));
                }
            }
        }
        // larger cities lose some interior roads (more T-junctions and irregular blocks),
        // never disconnecting the network or isolating a node
        if g > 3 {
            let target = edges.len() / 7;
            let mut removed = 0;
            let mut tries = 0;
            while removed < target && tries < edges.len() * 10 {
                tries += 1;
                let k = rng.random_range(0..edges.len());
                let (a, b) = edges[k];
                let deg = |n: usize, e: &[(usize, usize)]| {
                    e.iter().filter(|(x, y)| *x == n || *y == n).count()
                };
                if deg(a, &edges) <= 2 || deg(b, &edges) <= 2 {
                    continue;
                }
                let mut trial = edges.clone();
                trial.swap_remove(k);
                if connected(nodes.len(), &trial) {
                    edges = trial;
                    removed += 1;
                }
            }
            edges.sort_unstable();
        }
        let mut roads = Vec::new();
        for (a, b) in edges {
            let curved = rng.random_range(0.0..1.0) < 0.25;
            let bulge = if curved {
                rng.random_range(6.0..12.0)
                    * if rng.random_range(0..2) == 0 {
                        1.0
                    } else {
                        -1.0
                    }
            } else {
                0.0
            };
            roads.push(Road {
                a,
                b,
                centerline: centerline(nodes[a].pos, nodes[b].pos, bulge),
                width_m: rng.random_range(6.5..9.0),
                curved,
            });
        }
        // dead-end stubs leaving the grid: one per side for small, more for larger sizes
        let stubs = match size {
            SimSize::Small => 2,
            SimSize::Medium => 4,
            SimSize::City => 12,
        };
        for s in 0..stubs {
            let side = s % 4;
            let k = rng.random_range(1..g - 1);
            let (n, dir) = match side {
                0 => (id(k, 0), [0.0, -1.0]),
                1 => (id(g - 1, k), [1.0, 0.0]),
                2 => (id(k, g - 1), [0.0, 1.0]),
                _ => (id(0, k), [-1.0, 0.0]),
            };
            if roads.iter().any(|r| {
                (r.a == n || r.b == n) && {
                    let other = if r.a == n { r.b } else { r.a };
                    other >= g * g
                }
            }) {
                continue;
            }
            let len = rng.random_range(50.0..80.0);
            let p = nodes[n].pos;
            nodes.push(RoadNode {
                pos: [p[0] + dir[0] * len, p[1] + dir[1] * len],
                kind: JunctionKind::DeadEnd,
            });
            let m = nodes.len() - 1;
            roads.push(Road {
                a: n,
                b: m,
                centerline: centerline(p, nodes[m].pos, 0.0),
                width_m: 6.0,
                curved: false,
            });
        }
        let mut net = RoadNetwork { nodes, roads };
        net.classify();
        net
    }

    /// `ground_truth/roads.json`: junctions with their kind and position, road centre lines.
    pub fn to_json(&self) -> Json {
        json!({
            "frame": "kitti_cam ground plane: [x, z] in metres",
            "junctions": self.nodes.iter().enumerate().map(|(i, n)| json!({
                "id": i, "kind": n.kind.as_str(), "position": n.pos,
            })).collect::<Vec<_>>(),
            "roads": self.roads.iter().enumerate().map(|(i, r)| json!({
                "id": i, "from": r.a, "to": r.b, "width_m": r.width_m, "curved": r.curved,
                "length_m": polyline_length(&r.centerline),
                "centerline": r.centerline,
            })).collect::<Vec<_>>(),
        })
    }

    /// A drive over every road twice (once each way, as an Euler circuit of the network
    /// with each road doubled), starting and ending at the first T-junction or crossroads. At
    /// each node it prefers a road other than the one it came by, so it turns through bends
    /// and junctions and makes U-turns only at dead ends. Returns the node sequence.
    pub fn exploration_route(&self) -> Vec<usize> {
        let start = self
            .nodes
            .iter()
            .position(|n| matches!(n.kind, JunctionKind::TJunction | JunctionKind::Crossroads))
            .unwrap_or(0);
        let mut used = vec![0u8; self.roads.len()];
        let at: Vec<Vec<usize>> = (0..self.nodes.len())
            .map(|n| self.roads_at(n).into_iter().map(|(r, _)| r).collect())
            .collect();
        let other = |r: usize, n: usize| {
            if self.roads[r].a == n {
                self.roads[r].b
            } else {
                self.roads[r].a
            }
        };
        // Hierholzer's algorithm over the doubled roads
        let mut stack: Vec<(usize, Option<usize>)> = vec![(start, None)];
        let mut circuit = Vec::new();
        while let Some(&(v, via)) = stack.last() {
            let free = |r: &&usize| used[**r] < 2;
            let pick = at[v]
                .iter()
                .filter(free)
                .find(|r| Some(**r) != via)
                .or_else(|| at[v].iter().find(free))
                .copied();
            match pick {
                Some(r) => {
                    used[r] += 1;
                    stack.push((other(r, v), Some(r)));
                }
                None => {
                    circuit.push(v);
                    stack.pop();
                }
            }
        }
        circuit.reverse();
        circuit
    }

    /// The vehicle's path along a node route: centre lines driven on the right-hand lane
    /// (`lane_offset_m` right of the centre), corners rounded, U-turns at dead ends.
    pub fn drive_path(&self, route: &[usize], lane_offset_m: f64) -> Vec<[f64; 2]> {
        let mut path: Vec<[f64; 2]> = Vec::new();
        for w in route.windows(2) {
            let (n, m) = (w[0], w[1]);
            let Some(r) = self
                .roads
                .iter()
                .find(|r| (r.a == n && r.b == m) || (r.a == m && r.b == n))
            else {
                continue;
            };
            let mut c = r.centerline.clone();
            if r.a != n {
                c.reverse();
            }
            // offset to the right of travel (KITTI ground: right of d is (d.z, -d.x))
            let k = c.len();
            for i in 0..k {
                let d = unit(sub(c[(i + 1).min(k - 1)], c[i.saturating_sub(1)]));
                let right = [d[1], -d[0]];
                path.push([
                    c[i][0] + right[0] * lane_offset_m,
                    c[i][1] + right[1] * lane_offset_m,
                ]);
            }
        }
        smooth(&path, 6)
    }
}

fn connected(n: usize, edges: &[(usize, usize)]) -> bool {
    let mut seen = vec![false; n];
    let mut stack = vec![0];
    seen[0] = true;
    while let Some(x) = stack.pop() {
        for (a, b) in edges {
            let y = if *a == x {
                *b
            } else if *b == x {
                *a
            } else {
                continue;
            };
            if !seen[y] {
                seen[y] = true;
                stack.push(y);
            }
        }
    }
    seen.into_iter().all(|s| s)
}

/// A centre line from `a` to `b` bowed sideways by `bulge` metres at the middle (a half sine),
/// sampled about every metre.
fn centerline(a: [f64; 2], b: [f64; 2], bulge: f64) -> Vec<[f64; 2]> {
    let d = sub(b, a);
    let len = norm(d);
    let n = (len.ceil() as usize).max(2);
    let side = [-d[1] / len, d[0] / len];
    (0..=n)
        .map(|i| {
            let t = i as f64 / n as f64;
            let off = bulge * (std::f64::consts::PI * t).sin();
            [
                a[0] + d[0] * t + side[0] * off,
                a[1] + d[1] * t + side[1] * off,
            ]
        })
        .collect()
}

/// Moving average over `half` points each side (ends kept), which rounds corners.
fn smooth(p: &[[f64; 2]], half: usize) -> Vec<[f64; 2]> {
    // drop repeated points first
    let mut q: Vec<[f64; 2]> = Vec::with_capacity(p.len());
    for x in p {
        if q.last().is_none_or(|l| dist(*x, *l) > 0.05) {
            q.push(*x);
        }
    }
    (0..q.len())
        .map(|i| {
            let lo = i.saturating_sub(half);
            let hi = (i + half).min(q.len() - 1);
            let n = (hi - lo + 1) as f64;
            let s = q[lo..=hi]
                .iter()
                .fold([0.0, 0.0], |a, x| [a[0] + x[0], a[1] + x[1]]);
            [s[0] / n, s[1] / n]
        })
        .collect()
}

/// Samples a path at a constant speed: one ground position and heading per `step_m`.
pub fn sample_path(path: &[[f64; 2]], step_m: f64) -> Vec<([f64; 2], [f64; 2])> {
    let mut out = Vec::new();
    if path.len() < 2 {
        return out;
    }
    let mut seg = 0;
    let mut along = 0.0;
    let mut next = 0.0;
    while seg + 1 < path.len() {
        let (a, b) = (path[seg], path[seg + 1]);
        let l = dist(a, b);
        if l < 1e-9 {
            seg += 1;
            continue;
        }
        if next <= along + l {
            let t = (next - along) / l;
            // heading over a few metres for stability
            let ahead = path[(seg + 3).min(path.len() - 1)];
            let behind = path[seg.saturating_sub(2)];
            out.push((
                [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t],
                unit(sub(ahead, behind)),
            ));
            next += step_m;
        } else {
            along += l;
            seg += 1;
        }
    }
    out
}

/// Height of the camera above the ground, as on KITTI.
pub const CAMERA_HEIGHT_M: f64 = 1.65;

/// The KITTI cam0-to-world pose of a camera at ground position `g` looking along `heading`
/// (world y down; the ground is y = 0).
pub fn camera_pose(g: [f64; 2], heading: [f64; 2]) -> Rigid3 {
    let (hx, hz) = (heading[0], heading[1]);
    // columns: right, down, forward
    scene::pose::rigid_from_row_major(&[
        hz,
        0.0,
        hx,
        g[0], //
        0.0,
        1.0,
        0.0,
        -CAMERA_HEIGHT_M, //
        -hx,
        0.0,
        hz,
        g[1],
    ])
    .expect("12 values")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn networks_are_deterministic_and_have_every_junction_kind() {
        for size in [SimSize::Small, SimSize::Medium] {
            for seed in 0..5 {
                let a = RoadNetwork::generate(seed, size);
                assert_eq!(a, RoadNetwork::generate(seed, size));
                let kinds: std::collections::BTreeSet<JunctionKind> =
                    a.nodes.iter().map(|n| n.kind).collect();
                for k in [
                    JunctionKind::Crossroads,
                    JunctionKind::TJunction,
                    JunctionKind::LBend,
                    JunctionKind::DeadEnd,
                ] {
                    assert!(kinds.contains(&k), "{size:?} seed {seed}: no {k:?}");
                }
                assert!(a.roads.iter().any(|r| r.curved) || seed > 0);
            }
        }
        let small = RoadNetwork::generate(1, SimSize::Small).length_m();
        assert!((700.0..1700.0).contains(&small), "{small}");
        let city = RoadNetwork::generate(1, SimSize::City).length_m();
        assert!(city >= 20_000.0, "{city}");
    }

    #[test]
    fn the_route_drives_every_road_both_ways() {
        let net = RoadNetwork::generate(3, SimSize::Small);
        let route = net.exploration_route();
        assert_eq!(route.len(), 2 * net.roads.len() + 1);
        let mut count = vec![0; net.roads.len()];
        for w in route.windows(2) {
            let r = net
                .roads
                .iter()
                .position(|r| (r.a == w[0] && r.b == w[1]) || (r.a == w[1] && r.b == w[0]))
                .expect("consecutive nodes share a road");
            count[r] += 1;
        }
        assert!(count.iter().all(|c| *c == 2));
    }

    #[test]
    fn poses_follow_kitti_axes() {
        let p = camera_pose([10.0, 20.0], [0.0, 1.0]);
        // forward (cam z) maps to world +z, right (cam x) to world +x
        let f = scene::pose::apply(&p, [0.0, 0.0, 1.0]);
        assert!((f[0] - 10.0).abs() < 1e-12 && (f[2] - 21.0).abs() < 1e-12);
        let r = scene::pose::apply(&p, [1.0, 0.0, 0.0]);
        assert!((r[0] - 11.0).abs() < 1e-12 && (r[1] + CAMERA_HEIGHT_M).abs() < 1e-12);
        let p = camera_pose([0.0, 0.0], [1.0, 0.0]);
        let r = scene::pose::apply(&p, [1.0, 0.0, 0.0]);
        assert!((r[2] + 1.0).abs() < 1e-12, "driving +x, right is -z");
    }
}
