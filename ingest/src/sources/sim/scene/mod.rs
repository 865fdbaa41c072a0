//! The simulated city's scene: ground surfaces, objects placed along the roads with their
//! ground-truth class, caption and purpose, and the parry shapes (in one BVH) that the
//! sensors cast rays against.
//!
//! Coordinates are KITTI's camera world: x right, y down, z forward; the ground is `y = 0`,
//! so heights are negative y. An object's yaw turns its local +z (its "forward") to the world
//! direction `[sin yaw, cos yaw]` in `[x, z]`.

use parry3d::bounding_volume::Aabb;
use parry3d::math::{Pose, Rotation, Vector};
use parry3d::partitioning::{Bvh, BvhBuildStrategy};
use parry3d::query::{Ray, RayCast};
use parry3d::shape::{Ball, Cuboid, Cylinder, Shape};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value as Json, json};

use super::roads::RoadNetwork;
use crate::sources::oracle::capitalise;
use scene::geom::dist;

mod kinds;
mod place;
mod shapes;
pub use kinds::*;
use place::*;
pub use shapes::*;

/// Width of the sidewalk beside every road.
pub const SIDEWALK_M: f64 = 3.0;
/// Width of a parking lane, where a road side has one.
pub const PARKING_M: f64 = 2.5;

/// One object of the scene.
#[derive(Debug, Clone)]
pub struct SimObject {
    /// Instance id in `labels/*.label` (1-based, unique in the scene).
    pub id: u32,
    /// What it is.
    pub kind: Kind,
    /// Its attributes.
    pub attributes: Attributes,
    /// Ground-truth caption.
    pub caption: String,
    /// Box centre in the world.
    pub center: [f64; 3],
    /// Box size: width (local x), height, length (local z), metres.
    pub size: [f64; 3],
    /// Heading of the local +z axis.
    pub yaw_rad: f64,
}

/// Extra per-road facts of the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadSides {
    /// Parking lane on the right / left of the road's `a → b` direction.
    pub parking: [bool; 2],
}

/// The hit of a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Hit {
    /// The ground.
    Ground(Surface),
    /// An object (index into [`City::objects`]).
    Object(u32),
    /// A moving object (index into [`City::movers`]).
    Mover(u32),
}

/// The scene: roads, surfaces, objects and their BVH.
#[derive(Debug)]
pub struct City {
    /// The road network.
    pub net: RoadNetwork,
    /// Parking lanes per road.
    pub sides: Vec<RoadSides>,
    /// Objects; `objects[i].id == i + 1`.
    pub objects: Vec<SimObject>,
    /// Moving objects (not in the BVH: their boxes move).
    pub movers: Vec<super::movers::Mover>,
    /// Every primitive (BVH leaf `i` is `prims[i]`).
    pub prims: Vec<Prim>,
    bvh: Bvh,
    grid: SegmentGrid,
}

const GRID_CELL_M: f64 = 16.0;
/// How far from a centre line surfaces other than terrain reach, at most.
const REACH_M: f64 = 4.5 + PARKING_M + SIDEWALK_M + 1.0;

/// Road centre-line segments bucketed by 2D cell (each segment is in every cell within
/// `REACH_M` of it), so the nearest road of a point is found in its own cell.
#[derive(Debug)]
struct SegmentGrid {
    origin: [f64; 2],
    cols: usize,
    rows: usize,
    cells: Vec<Vec<(u32, u32)>>,
}

impl SegmentGrid {
    fn new(net: &RoadNetwork) -> SegmentGrid {
        let [lo, hi] = scene::geom::bounds(net.roads.iter().flat_map(|r| &r.centerline));
        let origin = [lo[0] - REACH_M - 1.0, lo[1] - REACH_M - 1.0];
        let cols = (((hi[0] - origin[0]) + REACH_M + 1.0) / GRID_CELL_M).ceil() as usize + 1;
        let rows = (((hi[1] - origin[1]) + REACH_M + 1.0) / GRID_CELL_M).ceil() as usize + 1;
        let mut cells = vec![Vec::new(); cols * rows];
        for (ri, r) in net.roads.iter().enumerate() {
            for s in 0..r.centerline.len() - 1 {
                let (a, b) = (r.centerline[s], r.centerline[s + 1]);
                let c0 = ((a[0].min(b[0]) - REACH_M - origin[0]) / GRID_CELL_M).floor() as usize;
                let c1 = ((a[0].max(b[0]) + REACH_M - origin[0]) / GRID_CELL_M).floor() as usize;
                let r0 = ((a[1].min(b[1]) - REACH_M - origin[1]) / GRID_CELL_M).floor() as usize;
                let r1 = ((a[1].max(b[1]) + REACH_M - origin[1]) / GRID_CELL_M).floor() as usize;
                for row in r0..=r1.min(rows - 1) {
                    for col in c0..=c1.min(cols - 1) {
                        cells[row * cols + col].push((ri as u32, s as u32));
                    }
                }
            }
        }
        SegmentGrid {
            origin,
            cols,
            rows,
            cells,
        }
    }

    fn cell(&self, p: [f64; 2]) -> &[(u32, u32)] {
        let c = (p[0] - self.origin[0]) / GRID_CELL_M;
        let r = (p[1] - self.origin[1]) / GRID_CELL_M;
        if !(c >= 0.0 && r >= 0.0) {
            return &[];
        }
        let (c, r) = (c as usize, r as usize);
        if c >= self.cols || r >= self.rows {
            return &[];
        }
        &self.cells[r * self.cols + c]
    }
}

/// Distance from `p` to segment `ab` and which side of `a → b` it is on (0 right, 1 left).
fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> (f64, usize) {
    let (_, q) = scene::geom::closest_on_segment(p, a, b);
    let d = [b[0] - a[0], b[1] - a[1]];
    // right of d in KITTI's ground plane is (d.z, -d.x)
    let right = (p[0] - a[0]) * d[1] - (p[1] - a[1]) * d[0];
    ((p[0] - q[0]).hypot(p[1] - q[1]), usize::from(right < 0.0))
}

/// A footprint: centre, half extents (local x, local z) and yaw.
#[derive(Debug, Clone, Copy)]
struct Footprint {
    c: [f64; 2],
    half: [f64; 2],
    yaw: f64,
}

impl Footprint {
    fn axes(&self) -> ([f64; 2], [f64; 2]) {
        let (s, c) = self.yaw.sin_cos();
        // local z -> (sin, cos); local x -> (cos, -sin)
        ([c, -s], [s, c])
    }

    fn at_local(self, lx: f64, lz: f64) -> [f64; 2] {
        let (ax, az) = self.axes();
        [
            self.c[0] + ax[0] * lx + az[0] * lz,
            self.c[1] + ax[1] * lx + az[1] * lz,
        ]
    }

    /// Points every 2 m or so over the footprint, its edges included.
    fn samples(&self) -> Vec<[f64; 2]> {
        let nx = ((2.0 * self.half[0]) / 2.0).ceil().max(1.0) as usize;
        let nz = ((2.0 * self.half[1]) / 2.0).ceil().max(1.0) as usize;
        let mut v = Vec::with_capacity((nx + 1) * (nz + 1));
        for i in 0..=nx {
            for j in 0..=nz {
                let lx = -self.half[0] + 2.0 * self.half[0] * i as f64 / nx as f64;
                let lz = -self.half[1] + 2.0 * self.half[1] * j as f64 / nz as f64;
                v.push(self.at_local(lx, lz));
            }
        }
        v
    }

    fn radius(&self) -> f64 {
        self.half[0].hypot(self.half[1])
    }

    /// Separating-axis overlap test of two rectangles.
    fn overlaps(&self, o: &Footprint) -> bool {
        if (self.c[0] - o.c[0]).hypot(self.c[1] - o.c[1]) > self.radius() + o.radius() {
            return false;
        }
        let (a1, a2) = self.axes();
        let (b1, b2) = o.axes();
        let d = [o.c[0] - self.c[0], o.c[1] - self.c[1]];
        let dot = |u: [f64; 2], v: [f64; 2]| u[0] * v[0] + u[1] * v[1];
        for axis in [a1, a2, b1, b2] {
            let ra = self.half[0] * dot(a1, axis).abs() + self.half[1] * dot(a2, axis).abs();
            let rb = o.half[0] * dot(b1, axis).abs() + o.half[1] * dot(b2, axis).abs();
            if dot(d, axis).abs() > ra + rb {
                return false;
            }
        }
        true
    }
}

/// Footprints already placed, bucketed by 2D cell.
struct Occupancy {
    cell_m: f64,
    cells: std::collections::BTreeMap<(i64, i64), Vec<usize>>,
    prints: Vec<Footprint>,
}

impl Occupancy {
    fn new() -> Occupancy {
        Occupancy {
            cell_m: 10.0,
            cells: std::collections::BTreeMap::new(),
            prints: Vec::new(),
        }
    }

    fn range(&self, f: &Footprint) -> (i64, i64, i64, i64) {
        let r = f.radius();
        let k = |v: f64| (v / self.cell_m).floor() as i64;
        (k(f.c[0] - r), k(f.c[0] + r), k(f.c[1] - r), k(f.c[1] + r))
    }

    fn free(&self, f: &Footprint) -> bool {
        let (x0, x1, z0, z1) = self.range(f);
        for x in x0..=x1 {
            for z in z0..=z1 {
                if let Some(v) = self.cells.get(&(x, z))
                    && v.iter().any(|i| self.prints[*i].overlaps(f))
                {
                    return false;
                }
            }
        }
        true
    }

    fn insert(&mut self, f: Footprint) {
        let (x0, x1, z0, z1) = self.range(&f);
        let i = self.prints.len();
        self.prints.push(f);
        for x in x0..=x1 {
            for z in z0..=z1 {
                self.cells.entry((x, z)).or_default().push(i);
            }
        }
    }
}

/// City generation parameters.
#[derive(Debug, Clone)]
pub struct SceneConfig {
    /// Most objects placed (instance ids are 16 bits).
    pub max_objects: usize,
}

impl Default for SceneConfig {
    fn default() -> SceneConfig {
        SceneConfig {
            max_objects: 65_535,
        }
    }
}

impl City {
    /// `ground_truth/roads.json`: the network's junctions and roads
    /// ([`RoadNetwork::to_json`]), each road with its parking lanes, `parking`
    /// `[right, left]` of its `from → to` direction (right of a direction `d` in KITTI's
    /// ground plane is `(d.z, -d.x)`), each `parking_width_m` wide beyond the carriageway.
    pub fn roads_json(&self) -> serde_json::Value {
        let mut v = self.net.to_json();
        if let Some(roads) = v["roads"].as_array_mut() {
            for (r, s) in roads.iter_mut().zip(&self.sides) {
                r["parking"] = serde_json::json!(s.parking);
                r["parking_width_m"] = serde_json::json!(PARKING_M);
            }
        }
        v
    }

    /// Places objects along every road of `net`. Deterministic for a seed.
    pub fn generate(net: RoadNetwork, seed: u64, cfg: &SceneConfig) -> City {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x00B1_EC75);
        let sides: Vec<RoadSides> = net
            .roads
            .iter()
            .map(|_| RoadSides {
                parking: [
                    rng.random_range(0.0..1.0) < 0.5,
                    rng.random_range(0.0..1.0) < 0.3,
                ],
            })
            .collect();
        let grid = SegmentGrid::new(&net);
        let mut p = Placer {
            grid: &grid,
            net: &net,
            sides: &sides,
            occ: Occupancy::new(),
            objects: Vec::new(),
            prims: Vec::new(),
            max_objects: cfg.max_objects,
        };
        for ri in 0..net.roads.len() {
            place_along_road(&mut p, ri, &mut rng);
        }
        place_traffic_lights(&mut p, &mut rng);
        let (objects, prims) = (p.objects, p.prims);
        let bvh = Bvh::from_iter(
            BvhBuildStrategy::Binned,
            prims
                .iter()
                .enumerate()
                .map(|(i, q)| (i, q.shape.as_shape().compute_aabb(&q.pose))),
        );
        City {
            net,
            sides,
            objects,
            movers: Vec::new(),
            prims,
            bvh,
            grid,
        }
    }

    /// The same scene with moving traffic and walking people ([`super::movers::place`]).
    pub fn with_movers(mut self, cfg: &super::movers::MoverConfig, seed: u64) -> City {
        self.movers = super::movers::place(&self.net, &self.sides, cfg, seed);
        self
    }

    /// What instance `id` is: its kind and attributes (static objects and movers).
    pub fn describe(&self, id: u32) -> Option<(Kind, &Attributes)> {
        if id >= super::movers::MOVER_ID_BASE {
            let m = self
                .movers
                .get((id - super::movers::MOVER_ID_BASE) as usize)?;
            Some((m.kind, &m.attributes))
        } else {
            let o = self.objects.get((id as usize).checked_sub(1)?)?;
            Some((o.kind, &o.attributes))
        }
    }

    /// The movers' boxes at `t_secs`, in mover order (for [`City::cast_among`]).
    pub fn movers_at(&self, t_secs: f64) -> Vec<super::movers::MoverBox> {
        self.movers.iter().map(|m| m.box_at(t_secs)).collect()
    }

    /// [`City::cast`] with the movers' boxes of one time ([`City::movers_at`]) too.
    pub fn cast_among(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        max_m: f32,
        movers: &[super::movers::MoverBox],
    ) -> Option<(f32, Hit)> {
        let mut best = self.cast(origin, dir, max_m);
        for (k, m) in movers.iter().enumerate() {
            let limit = best.map_or(max_m, |b| b.0);
            if let Some(t) = m.cast(origin, dir, limit) {
                best = Some((t, Hit::Mover(k as u32)));
            }
        }
        best
    }

    /// What the ground is at `[x, z]`.
    pub fn surface(&self, p: [f64; 2]) -> Surface {
        surface_at(&self.grid, &self.net, &self.sides, p)
    }

    /// The first thing a ray from `origin` along the unit vector `dir` hits within
    /// `max_m`: (distance, what).
    pub fn cast(&self, origin: [f32; 3], dir: [f32; 3], max_m: f32) -> Option<(f32, Hit)> {
        let mut best: Option<(f32, Hit)> = None;
        let mut limit = max_m;
        if dir[1] > 1e-6 && origin[1] < 0.0 {
            let t = -origin[1] / dir[1];
            if t < limit {
                let x = origin[0] + dir[0] * t;
                let z = origin[2] + dir[2] * t;
                best = Some((t, Hit::Ground(self.surface([f64::from(x), f64::from(z)]))));
                limit = t;
            }
        }
        let ray = Ray::new(Vector::from(origin), Vector::from(dir));
        if let Some((leaf, t)) = self.bvh.cast_ray(&ray, limit, |leaf, best_t| {
            let q = &self.prims[leaf as usize];
            q.shape.cast(&q.pose, &ray, best_t)
        }) && t < limit
        {
            best = Some((t, Hit::Object(self.prims[leaf as usize].object)));
        }
        best
    }

    /// Object counts per ground-truth class, sorted by class.
    pub fn class_counts(&self) -> std::collections::BTreeMap<&'static str, usize> {
        let mut m = std::collections::BTreeMap::new();
        for o in &self.objects {
            *m.entry(o.kind.class()).or_insert(0) += 1;
        }
        m
    }

    /// `ground_truth/objects.json`.
    pub fn objects_json(&self) -> Json {
        let r3 = |v: f64| (v * 1000.0).round() / 1000.0;
        json!({
            "frame": "kitti_cam world: x right, y down (ground at y = 0), z forward; metres",
            "box": "center [x, y, z], size [width, height, length], yaw_rad turns the box's length axis from +z towards +x",
            "objects": self.objects.iter().map(|o| json!({
                "id": o.id,
                "class": o.kind.class(),
                "semantic_kitti_label": o.kind.semantic(),
                "caption": o.caption,
                "purpose": o.kind.purpose(),
                "attributes": {
                    "noun": o.attributes.noun,
                    "colour": o.attributes.colour,
                    "size": o.attributes.size,
                    "material": o.attributes.material,
                    "state": o.attributes.state,
                },
                "box": {
                    "center": o.center.map(r3),
                    "size": o.size.map(r3),
                    "yaw_rad": r3(o.yaw_rad),
                },
            })).collect::<Vec<_>>(),
        })
    }

    /// The axis-aligned bounds of every object, `None` without objects.
    pub fn bounds(&self) -> Option<Aabb> {
        (!self.bvh.is_empty()).then(|| self.bvh.root_aabb())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sources::sim::roads::SimSize;

    fn small() -> City {
        City::generate(
            RoadNetwork::generate(1, SimSize::Small),
            1,
            &SceneConfig::default(),
        )
    }

    #[test]
    fn every_kind_is_placed_and_nothing_stands_on_the_road() {
        let s = small();
        let counts = s.class_counts();
        for k in Kind::ALL {
            assert!(counts.contains_key(k.class()), "no {:?}: {counts:?}", k);
        }
        for o in &s.objects {
            let g = [o.center[0], o.center[2]];
            if o.kind != Kind::TreeCrown && o.kind != Kind::StreetLamp {
                assert_ne!(
                    s.surface(g),
                    Surface::Road,
                    "{:?} {} on the road",
                    o.kind,
                    o.id
                );
            }
            assert_eq!(
                o.id as usize,
                s.objects.iter().position(|x| x.id == o.id).unwrap() + 1
            );
        }
        assert!(s.objects.len() > 400, "{}", s.objects.len());
    }

    #[test]
    fn surfaces_follow_the_distance_from_the_centre_line() {
        let s = small();
        let r = &s.net.roads[0];
        let mid = r.centerline[r.centerline.len() / 2];
        assert_eq!(s.surface(mid), Surface::Road);
        let far = [mid[0] + 500.0, mid[1] + 500.0];
        assert_eq!(s.surface(far), Surface::Terrain);
    }

    #[test]
    fn rays_hit_the_ground_and_the_nearest_object() {
        let s = small();
        let o = s
            .objects
            .iter()
            .find(|o| o.kind == Kind::Building)
            .expect("a building");
        // from 40 m above the building's centre straight down: its roof
        let top = [o.center[0] as f32, -60.0, o.center[2] as f32];
        let (t, hit) = s.cast(top, [0.0, 1.0, 0.0], 200.0).expect("hit");
        assert!(matches!(hit, Hit::Object(i) if s.objects[i as usize].kind == Kind::Building));
        assert!(t < 60.0 && t > 30.0, "{t}");
        // straight down over open ground far away: the ground at the right distance
        let (t, hit) = s
            .cast([5000.0, -1.73, 5000.0], [0.0, 1.0, 0.0], 120.0)
            .unwrap();
        assert!((t - 1.73).abs() < 1e-4, "{t}");
        assert_eq!(hit, Hit::Ground(Surface::Terrain));
        // upwards: nothing
        assert!(
            s.cast([5000.0, -1.73, 5000.0], [0.0, -1.0, 0.0], 120.0)
                .is_none()
        );
    }

    #[test]
    fn captions_read_like_a_captioners_for_every_kind_and_phrasing() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut all_materials: Vec<&str> = Kind::ALL
            .iter()
            .flat_map(|k| k.bank().materials.iter().copied())
            .collect();
        all_materials.sort_unstable();
        all_materials.dedup();
        for k in Kind::ALL {
            let b = k.bank();
            for _ in 0..200 {
                let a = Attributes::draw(k, &mut rng);
                // the wrong-colour noise uses the bank's other colours
                let colours = std::iter::once(None).chain(b.colours.iter().map(|c| Some(*c)));
                for colour in colours {
                    for ph in 0..3 {
                        let c = a.caption(k, ph, colour);
                        let words: Vec<&str> = c.split(' ').collect();
                        for w in words.windows(2) {
                            let (art, next) = (w[0].to_lowercase(), w[1]);
                            if art == "a" {
                                assert!(!vowel_sound(next), "{k:?} {ph}: {c}");
                            }
                            if art == "an" {
                                assert!(vowel_sound(next), "{k:?} {ph}: {c}");
                            }
                            assert!(!w[0].eq_ignore_ascii_case(w[1]), "{k:?} {ph}: {c}");
                            // "red-brick brick": a material the word before already says
                            assert!(
                                !(all_materials.contains(&w[1]) && w[0].contains(w[1])),
                                "{k:?} {ph}: {c}"
                            );
                        }
                        // one material at most, and none that the noun contradicts
                        let said: Vec<&&str> = all_materials
                            .iter()
                            .filter(|m| {
                                words
                                    .iter()
                                    .any(|w| w.trim_matches(|c: char| !c.is_alphanumeric()) == **m)
                                    || (m.contains(' ') && c.contains(**m))
                            })
                            .collect();
                        let own: Vec<&&str> =
                            said.iter().copied().filter(|m| !m.contains(' ')).collect();
                        assert!(
                            own.len() <= 1 || said.iter().any(|m| m.contains(' ')),
                            "{k:?} {ph}: {c}: {said:?}"
                        );
                        assert!(c.contains(a.noun), "{c}");
                    }
                }
            }
        }
        // the cases the map-quality issue names
        let bench = Attributes {
            noun: "wooden bench",
            colour: "green",
            size: "old",
            material: None,
            state: "empty",
        };
        assert_eq!(
            bench.caption(Kind::Bench, 0, None),
            "an old green wooden bench empty"
        );
        let house = Attributes {
            noun: "house",
            colour: "white",
            size: "low",
            material: Some("brick"),
            state: "with a flat roof",
        };
        assert_eq!(
            house.caption(Kind::Building, 0, Some("red-brick")),
            "a low red-brick house with a flat roof"
        );
        assert_eq!(
            tidy_caption("a elderly man in a dark coat"),
            "an elderly man in a dark coat"
        );
        assert_eq!(tidy_caption("A orange bin"), "An orange bin");
        assert_eq!(
            tidy_caption("a glass glass and steel shelter"),
            "a glass and steel shelter"
        );
        assert_eq!(
            tidy_caption("an unicycle and a one-way sign"),
            "a unicycle and a one-way sign"
        );
    }

    #[test]
    fn captions_and_purposes_exist_for_every_kind() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for k in Kind::ALL {
            let a = Attributes::draw(k, &mut rng);
            for ph in 0..3 {
                let c = a.caption(k, ph, None);
                assert!(c.contains(a.noun), "{c}");
            }
            assert!(!k.purpose().is_empty());
        }
    }
}
