//! Moving traffic and walking people: cars drive to and fro along a road in its right-hand
//! lane, people walk to and fro along a sidewalk. Each is a box whose pose is a function of
//! time; the LiDAR labels their points with SemanticKITTI's moving classes (252 moving-car,
//! 254 moving-person) and their own instance ids, and the camera sees and detects them like
//! any object.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value as Json, json};

use super::roads::RoadNetwork;
use super::scene::{Attributes, Kind, PARKING_M, RoadSides, SIDEWALK_M};

/// Instance ids of movers start here (static objects are numbered from 1; ids are 16 bits).
pub const MOVER_ID_BASE: u32 = 60_000;

/// How many movers, and how fast.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, schemars::JsonSchema)]
pub struct MoverConfig {
    /// Cars driving along roads.
    pub cars: usize,
    /// People walking along sidewalks.
    pub walkers: usize,
}

/// One moving object.
#[derive(Debug, Clone, PartialEq)]
pub struct Mover {
    /// Instance id in `labels/*.label` (from [`MOVER_ID_BASE`]).
    pub id: u32,
    /// `Car` or `Person`.
    pub kind: Kind,
    /// Its attributes (captions as for a parked car or a standing person).
    pub attributes: Attributes,
    /// Box size: width, height, length, metres.
    pub size: [f64; 3],
    /// The ground path it goes to and fro along (KITTI ground: x, z).
    pub path: Vec<[f64; 2]>,
    /// Which side of the path it keeps to: +1 right of the path's direction, -1 left; for
    /// cars the side flips with the direction of travel (they keep right).
    pub side: f64,
    /// Lateral offset from the path, metres.
    pub offset_m: f64,
    /// Speed, metres per second.
    pub speed_mps: f64,
    /// Arc length at time 0, metres.
    pub start_m: f64,
}

fn seg_len(a: [f64; 2], b: [f64; 2]) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}

impl Mover {
    fn length(&self) -> f64 {
        self.path.windows(2).map(|w| seg_len(w[0], w[1])).sum()
    }

    /// Ground position of the box centre and its heading (unit vector of travel) at
    /// `t_secs`: it goes along the path and back, forever.
    pub fn pose_at(&self, t_secs: f64) -> ([f64; 2], [f64; 2]) {
        let len = self.length().max(1e-6);
        let s = (self.start_m + self.speed_mps * t_secs).rem_euclid(2.0 * len);
        let (along, back) = if s <= len {
            (s, false)
        } else {
            (2.0 * len - s, true)
        };
        let mut rest = along;
        let mut at = (self.path[0], [1.0, 0.0]);
        for w in self.path.windows(2) {
            let l = seg_len(w[0], w[1]);
            if l <= 0.0 {
                continue;
            }
            let d = [(w[1][0] - w[0][0]) / l, (w[1][1] - w[0][1]) / l];
            let k = rest.min(l);
            at = ([w[0][0] + d[0] * k, w[0][1] + d[1] * k], d);
            if rest <= l {
                break;
            }
            rest -= l;
        }
        let (p, d) = at;
        let heading = if back { [-d[0], -d[1]] } else { d };
        // right of a direction d in KITTI's ground plane is (d.z, -d.x)
        let side = if self.kind == Kind::Car {
            heading
        } else {
            // walkers keep to one sidewalk whichever way they go
            d
        };
        let right = [side[1], -side[0]];
        let o = self.offset_m * self.side;
        ([p[0] + right[0] * o, p[1] + right[1] * o], heading)
    }

    /// SemanticKITTI's moving class of the mover.
    pub fn semantic(&self) -> u16 {
        if self.kind == Kind::Car { 252 } else { 254 }
    }

    /// The mover's box at `t_secs`.
    pub fn box_at(&self, t_secs: f64) -> MoverBox {
        let (c, h) = self.pose_at(t_secs);
        // box axes in the world: length along the heading, up is -y (ground at y = 0)
        MoverBox {
            centre: [c[0], -self.size[1] / 2.0, c[1]],
            axes: [[h[1], 0.0, -h[0]], [0.0, 1.0, 0.0], [h[0], 0.0, h[1]]],
            half: [self.size[0] / 2.0, self.size[1] / 2.0, self.size[2] / 2.0],
        }
    }

    /// The mover as `ground_truth/movers.json` has it.
    pub fn to_json(&self) -> Json {
        let r3 = |v: f64| (v * 1000.0).round() / 1000.0;
        json!({
            "id": self.id,
            "class": self.kind.class(),
            "semantic": self.semantic(),
            "noun": self.attributes.noun,
            "colour": self.attributes.colour,
            "size": self.size.map(r3),
            "path": self.path.iter().map(|p| p.map(r3)).collect::<Vec<_>>(),
            "side": self.side,
            "offset_m": r3(self.offset_m),
            "speed_mps": r3(self.speed_mps),
            "start_m": r3(self.start_m),
        })
    }
}

/// A mover's box at one time: world centre, unit axes (width, height, length) and half
/// sizes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoverBox {
    /// Centre, world frame.
    pub centre: [f64; 3],
    /// Unit axes in the world.
    pub axes: [[f64; 3]; 3],
    /// Half sizes along the axes.
    pub half: [f64; 3],
}

impl MoverBox {
    /// The distance along the unit ray `origin + t·dir` to the box, if it is hit within
    /// `max_m` (slab test in the box's frame). A box that holds the origin is not hit.
    pub fn cast(&self, origin: [f32; 3], dir: [f32; 3], max_m: f32) -> Option<f32> {
        let (centre, axes, half) = (self.centre, self.axes, self.half);
        let o = [0, 1, 2].map(|k| f64::from(origin[k]) - centre[k]);
        // far boxes are passed over by their bounding sphere
        let reach = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt();
        let along =
            -(o[0] * f64::from(dir[0]) + o[1] * f64::from(dir[1]) + o[2] * f64::from(dir[2]));
        let d2 = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - along * along;
        if d2 > reach * reach || along + reach < 0.0 || along - reach > f64::from(max_m) {
            return None;
        }
        let d = [0, 1, 2].map(|k| f64::from(dir[k]));
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for k in 0..3 {
            let a = axes[k];
            let ol = o[0] * a[0] + o[1] * a[1] + o[2] * a[2];
            let dl = d[0] * a[0] + d[1] * a[1] + d[2] * a[2];
            if dl.abs() < 1e-12 {
                if ol.abs() > half[k] {
                    return None;
                }
                continue;
            }
            let (ta, tb) = ((-half[k] - ol) / dl, (half[k] - ol) / dl);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        (t0 <= t1 && t0 > 0.0 && t0 < f64::from(max_m)).then_some(t0 as f32)
    }
}

/// Places `cfg.cars` cars on random roads (keeping right, 4–10 m/s) and `cfg.walkers`
/// people on random sidewalks (1.0–1.6 m/s). Deterministic for a seed, and drawn from their
/// own stream so the static scene does not change.
pub fn place(net: &RoadNetwork, sides: &[RoadSides], cfg: &MoverConfig, seed: u64) -> Vec<Mover> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x4D0F_E125);
    let mut out = Vec::new();
    let roads: Vec<usize> = (0..net.roads.len())
        .filter(|&r| net.roads[r].centerline.len() >= 2)
        .collect();
    if roads.is_empty() {
        return out;
    }
    let total = cfg.cars + cfg.walkers;
    for k in 0..total.min((65_535 - MOVER_ID_BASE) as usize) {
        let car = k < cfg.cars;
        let r = roads[rng.random_range(0..roads.len())];
        let road = &net.roads[r];
        let kind = if car { Kind::Car } else { Kind::Person };
        let attributes = Attributes::draw(kind, &mut rng);
        let (size, offset_m, speed_mps, side) = if car {
            let size = [
                rng.random_range(1.7..1.95),
                rng.random_range(1.4..1.7),
                rng.random_range(3.9..4.8),
            ];
            (size, road.width_m / 4.0, rng.random_range(4.0..10.0), 1.0)
        } else {
            let side = if rng.random_range(0.0..1.0) < 0.5 {
                1.0
            } else {
                -1.0
            };
            let park = if sides[r].parking[usize::from(side < 0.0)] {
                PARKING_M
            } else {
                0.0
            };
            let size = [0.5, rng.random_range(1.55..1.9), 0.4];
            let off = road.width_m / 2.0 + park + SIDEWALK_M / 2.0;
            (size, off, rng.random_range(1.0..1.6), side)
        };
        let mut m = Mover {
            id: MOVER_ID_BASE + k as u32,
            kind,
            attributes,
            size,
            path: road.centerline.clone(),
            side,
            offset_m,
            speed_mps,
            start_m: 0.0,
        };
        m.start_m = rng.random_range(0.0..m.length().max(1.0) * 2.0);
        out.push(m);
    }
    out
}

#[cfg(test)]
// exact values are expected: headings are copied from the path
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    fn car() -> Mover {
        Mover {
            id: MOVER_ID_BASE,
            kind: Kind::Car,
            attributes: Attributes::draw(Kind::Car, &mut ChaCha8Rng::seed_from_u64(1)),
            size: [2.0, 1.5, 4.0],
            path: vec![[0.0, 0.0], [0.0, 100.0]],
            side: 1.0,
            offset_m: 2.0,
            speed_mps: 10.0,
            start_m: 0.0,
        }
    }

    #[test]
    fn a_car_drives_to_and_fro_keeping_right() {
        let m = car();
        // going +z: right is (1, 0) · (d.z, -d.x) = +x
        let (p, h) = m.pose_at(5.0);
        assert!((p[0] - 2.0).abs() < 1e-9 && (p[1] - 50.0).abs() < 1e-9 && h == [0.0, 1.0]);
        // coming back after the end: heading -z, right is -x
        let (p, h) = m.pose_at(15.0);
        assert!((p[0] + 2.0).abs() < 1e-9 && (p[1] - 50.0).abs() < 1e-9 && h == [0.0, -1.0]);
        let (p, _) = m.pose_at(25.0);
        assert!(
            (p[1] - 50.0).abs() < 1e-9 && (p[0] - 2.0).abs() < 1e-9,
            "a full cycle"
        );
    }

    #[test]
    fn rays_hit_the_box_where_it_is_at_that_time() {
        let m = car();
        // at t = 5 the car is at (2, 50): a ray along +x at z = 50, 0.5 m above the ground
        let hit = m
            .box_at(5.0)
            .cast([-10.0, -0.5, 50.0], [1.0, 0.0, 0.0], 100.0)
            .unwrap();
        assert!((hit - 11.0).abs() < 1e-4, "{hit}");
        // at t = 0 it is at z = 0: the same ray misses
        assert!(
            m.box_at(0.0)
                .cast([-10.0, -0.5, 50.0], [1.0, 0.0, 0.0], 100.0)
                .is_none()
        );
        // above the roof, or out of range: no hit
        assert!(
            m.box_at(5.0)
                .cast([-10.0, -2.0, 50.0], [1.0, 0.0, 0.0], 100.0)
                .is_none()
        );
        assert!(
            m.box_at(5.0)
                .cast([-10.0, -0.5, 50.0], [1.0, 0.0, 0.0], 5.0)
                .is_none()
        );
        // from inside the box: not hit
        assert!(
            m.box_at(5.0)
                .cast([2.0, -0.5, 50.0], [1.0, 0.0, 0.0], 100.0)
                .is_none()
        );
        assert_eq!(m.semantic(), 252);
    }
}
