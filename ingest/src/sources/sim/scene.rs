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
use crate::hierarchy::lanes::dist;
use crate::sources::oracle::capitalise;

/// Width of the sidewalk beside every road.
pub const SIDEWALK_M: f64 = 3.0;
/// Width of a parking lane, where a road side has one.
pub const PARKING_M: f64 = 2.5;

/// What the ground is at a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Surface {
    /// Carriageway.
    Road,
    /// Parking lane beside the carriageway.
    Parking,
    /// Sidewalk.
    Sidewalk,
    /// Everything else (grass, soil).
    Terrain,
}

impl Surface {
    /// All surfaces.
    pub const ALL: [Surface; 4] = [
        Surface::Road,
        Surface::Parking,
        Surface::Sidewalk,
        Surface::Terrain,
    ];

    /// The SemanticKITTI label.
    pub fn semantic(self) -> u16 {
        match self {
            Surface::Road => 40,
            Surface::Parking => 44,
            Surface::Sidewalk => 48,
            Surface::Terrain => 72,
        }
    }

    /// Name (the SemanticKITTI class).
    pub fn name(self) -> &'static str {
        match self {
            Surface::Road => "road",
            Surface::Parking => "parking",
            Surface::Sidewalk => "sidewalk",
            Surface::Terrain => "terrain",
        }
    }

    /// Caption variants (the sensors pick one per frame).
    pub fn captions(self) -> &'static [&'static str] {
        match self {
            Surface::Road => &[
                "the asphalt road",
                "a grey asphalt street",
                "the road surface with lane markings",
            ],
            Surface::Parking => &[
                "a parking lane beside the road",
                "a paved parking area along the street",
            ],
            Surface::Sidewalk => &[
                "a concrete sidewalk",
                "the paved sidewalk along the street",
                "a pavement for pedestrians",
            ],
            Surface::Terrain => &["a strip of grass", "grass and bare soil", "a patch of lawn"],
        }
    }
}

/// What an object is: the SemanticKITTI classes that make sense in a street scene, and
/// open-vocabulary extras that the 19 classes lack.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[allow(missing_docs)]
pub enum Kind {
    Car,
    Truck,
    OtherVehicle,
    Bicycle,
    Motorcycle,
    Person,
    Building,
    Fence,
    /// A tree's crown (its trunk is a separate `Trunk` object).
    TreeCrown,
    /// A hedge or bush (vegetation).
    Hedge,
    Trunk,
    Pole,
    TrafficSign,
    Bench,
    BusStopShelter,
    FireHydrant,
    TrashCan,
    StreetLamp,
    TrafficLight,
    Mailbox,
    Billboard,
    Playground,
    ParkedTrailer,
}

impl Kind {
    /// Every kind.
    pub const ALL: [Kind; 23] = [
        Kind::Car,
        Kind::Truck,
        Kind::OtherVehicle,
        Kind::Bicycle,
        Kind::Motorcycle,
        Kind::Person,
        Kind::Building,
        Kind::Fence,
        Kind::TreeCrown,
        Kind::Hedge,
        Kind::Trunk,
        Kind::Pole,
        Kind::TrafficSign,
        Kind::Bench,
        Kind::BusStopShelter,
        Kind::FireHydrant,
        Kind::TrashCan,
        Kind::StreetLamp,
        Kind::TrafficLight,
        Kind::Mailbox,
        Kind::Billboard,
        Kind::Playground,
        Kind::ParkedTrailer,
    ];

    /// The ground-truth class: the SemanticKITTI class name, or the open-vocabulary name of
    /// an extra.
    pub fn class(self) -> &'static str {
        match self {
            Kind::Car => "car",
            Kind::Truck => "truck",
            Kind::OtherVehicle => "other-vehicle",
            Kind::Bicycle => "bicycle",
            Kind::Motorcycle => "motorcycle",
            Kind::Person => "person",
            Kind::Building => "building",
            Kind::Fence => "fence",
            Kind::TreeCrown | Kind::Hedge => "vegetation",
            Kind::Trunk => "trunk",
            Kind::Pole => "pole",
            Kind::TrafficSign => "traffic-sign",
            Kind::Bench => "bench",
            Kind::BusStopShelter => "bus stop shelter",
            Kind::FireHydrant => "fire hydrant",
            Kind::TrashCan => "trash can",
            Kind::StreetLamp => "street lamp",
            Kind::TrafficLight => "traffic light",
            Kind::Mailbox => "mailbox",
            Kind::Billboard => "billboard",
            Kind::Playground => "playground",
            Kind::ParkedTrailer => "parked trailer",
        }
    }

    /// The raw SemanticKITTI label written to `labels/*.label`. Extras take the label that
    /// SemanticKITTI's annotation guide gives such things: lamps are poles, traffic lights
    /// traffic signs, trailers other vehicles, shelters/billboards/playgrounds other
    /// structures (52) and street furniture other objects (99); 52 and 99 are unlabelled
    /// in the 19-class evaluation.
    pub fn semantic(self) -> u16 {
        match self {
            Kind::Car => 10,
            Kind::Bicycle => 11,
            Kind::Motorcycle => 15,
            Kind::Truck => 18,
            Kind::OtherVehicle | Kind::ParkedTrailer => 20,
            Kind::Person => 30,
            Kind::Building => 50,
            Kind::Fence => 51,
            Kind::BusStopShelter | Kind::Billboard | Kind::Playground => 52,
            Kind::TreeCrown | Kind::Hedge => 70,
            Kind::Trunk => 71,
            Kind::Pole | Kind::StreetLamp => 80,
            Kind::TrafficSign | Kind::TrafficLight => 81,
            Kind::Bench | Kind::FireHydrant | Kind::TrashCan | Kind::Mailbox => 99,
        }
    }

    /// What the object is for (the ground truth of functional queries).
    pub fn purpose(self) -> &'static str {
        match self {
            Kind::Car => "carries a few people by road",
            Kind::Truck => "carries goods by road",
            Kind::OtherVehicle => "carries people or goods by road",
            Kind::Bicycle => "a way to ride around the city under your own power",
            Kind::Motorcycle => "a fast way for one or two people to ride around",
            Kind::Person => "a pedestrian walking in the city",
            Kind::Building => "a place where people live or work",
            Kind::Fence => "marks and protects the edge of a property",
            Kind::TreeCrown => "gives shade",
            Kind::Hedge => "a green border that screens a garden",
            Kind::Trunk => "holds up a tree",
            Kind::Pole => "carries overhead cables",
            Kind::TrafficSign => "tells drivers the rules of the road",
            Kind::Bench => "a place to sit and rest",
            Kind::BusStopShelter => "a place to sit while waiting for a bus, out of the rain",
            Kind::FireHydrant => "a water supply for firefighters",
            Kind::TrashCan => "a place to throw away rubbish",
            Kind::StreetLamp => "lights the street at night",
            Kind::TrafficLight => "tells vehicles when to stop and go",
            Kind::Mailbox => "a place to post letters",
            Kind::Billboard => "shows advertisements to passers-by",
            Kind::Playground => "a place for children to play",
            Kind::ParkedTrailer => "carries cargo when towed by a vehicle",
        }
    }

    fn bank(self) -> Bank {
        const PAINT: &[&str] = &[
            "red",
            "blue",
            "white",
            "black",
            "silver",
            "grey",
            "green",
            "yellow",
            "dark blue",
        ];
        let b = |nouns, colours, sizes, materials, states| Bank {
            nouns,
            colours,
            sizes,
            materials,
            states,
        };
        match self {
            Kind::Car => b(
                &["car", "sedan", "hatchback", "small SUV"],
                PAINT,
                &["small", "compact", "mid-size", "large"],
                &[],
                &[
                    "parked by the curb",
                    "parked in the parking lane",
                    "with dusty windows",
                ],
            ),
            Kind::Truck => b(
                &["truck", "delivery truck", "box truck"],
                &["white", "red", "blue", "grey"],
                &["large", "heavy", "long"],
                &[],
                &["parked by the curb", "unloading at the roadside"],
            ),
            Kind::OtherVehicle => b(
                &["van", "camper van", "minibus"],
                &["white", "silver", "blue", "beige"],
                &["large", "boxy", "high"],
                &[],
                &["parked by the curb", "parked in the parking lane"],
            ),
            Kind::Bicycle => b(
                &["bicycle", "bike", "city bike"],
                PAINT,
                &["small", "old", "new"],
                &["steel", "aluminium"],
                &[
                    "leaning on its stand",
                    "locked to a rack",
                    "parked on the sidewalk",
                ],
            ),
            Kind::Motorcycle => b(
                &["motorcycle", "motorbike", "scooter"],
                &["black", "red", "silver", "blue"],
                &["small", "heavy", "sporty"],
                &[],
                &["parked at the roadside", "standing on its kickstand"],
            ),
            Kind::Person => b(
                &["person", "pedestrian", "man", "woman"],
                &[
                    "in a red jacket",
                    "in a dark coat",
                    "in a yellow raincoat",
                    "in a white shirt",
                ],
                &["tall", "short", "young", "elderly"],
                &[],
                &[
                    "walking on the sidewalk",
                    "standing on the sidewalk",
                    "waiting at the curb",
                ],
            ),
            Kind::Building => b(
                &["building", "house", "apartment block", "office building"],
                &["white", "grey", "beige", "red-brick", "yellow"],
                &["low", "two-storey", "tall", "wide"],
                &["brick", "concrete", "glass", "plaster"],
                &[
                    "with many windows",
                    "with a flat roof",
                    "with shops on the ground floor",
                ],
            ),
            Kind::Fence => b(
                &["fence", "railing", "garden fence"],
                &["green", "white", "grey", "brown"],
                &["low", "high", "long"],
                &["wooden", "metal", "wire"],
                &["along the sidewalk", "in front of a garden", "with a gate"],
            ),
            Kind::TreeCrown => b(
                &["tree crown", "leafy tree top", "tree canopy"],
                &["green", "dark green", "yellowing"],
                &["small", "large", "dense", "sparse"],
                &[],
                &["over the sidewalk", "casting shade on the street"],
            ),
            Kind::Hedge => b(
                &["hedge", "row of bushes", "bush"],
                &["green", "dark green"],
                &["low", "trimmed", "overgrown"],
                &[],
                &["along a garden", "beside the sidewalk"],
            ),
            Kind::Trunk => b(
                &["tree trunk", "trunk of a tree"],
                &["brown", "grey", "dark"],
                &["thin", "thick", "old"],
                &[],
                &["beside the sidewalk", "in a small planting bed"],
            ),
            Kind::Pole => b(
                &["pole", "utility pole", "post"],
                &["grey", "brown", "green", "black"],
                &["tall", "thin", "slender"],
                &["metal", "wooden", "concrete"],
                &["beside the road", "carrying cables"],
            ),
            Kind::TrafficSign => b(
                &["traffic sign", "road sign", "stop sign", "speed limit sign"],
                &["red and white", "blue", "yellow", "white"],
                &["small", "round", "square"],
                &["metal"],
                &["on a post at the roadside", "facing the traffic"],
            ),
            Kind::Bench => b(
                &["bench", "park bench", "wooden bench"],
                &["green", "brown", "grey", "black"],
                &["long", "short", "old"],
                &["wooden", "metal", "stone"],
                &["on the sidewalk", "facing the street", "empty"],
            ),
            Kind::BusStopShelter => b(
                &["bus stop shelter", "bus shelter", "covered bus stop"],
                &["green", "blue", "grey"],
                &["small", "long"],
                &["glass and steel", "metal"],
                &["with a bench inside", "with a timetable", "at the curb"],
            ),
            Kind::FireHydrant => b(
                &["fire hydrant", "hydrant"],
                &["red", "yellow", "silver"],
                &["small", "squat", "short"],
                &["cast-iron", "metal"],
                &["on the sidewalk", "by the curb"],
            ),
            Kind::TrashCan => b(
                &["trash can", "rubbish bin", "litter bin"],
                &["green", "black", "grey", "orange"],
                &["small", "large", "round"],
                &["metal", "plastic"],
                &["on the sidewalk", "full of rubbish", "by a lamp post"],
            ),
            Kind::StreetLamp => b(
                &["street lamp", "street light", "lamp post"],
                &["grey", "black", "dark green"],
                &["tall", "old-fashioned", "modern"],
                &["metal", "steel"],
                &["over the road", "at the edge of the sidewalk"],
            ),
            Kind::TrafficLight => b(
                &["traffic light", "traffic signal"],
                &["black", "yellow", "grey"],
                &["small", "tall"],
                &["metal"],
                &["showing red", "showing green", "at the junction"],
            ),
            Kind::Mailbox => b(
                &["mailbox", "post box", "letter box"],
                &["red", "yellow", "blue"],
                &["small", "squat"],
                &["metal"],
                &["on the sidewalk", "on a short post"],
            ),
            Kind::Billboard => b(
                &["billboard", "advertising board", "large poster board"],
                &["colourful", "white", "bright"],
                &["large", "huge", "wide"],
                &["metal", "wooden"],
                &["beside the road", "on two posts"],
            ),
            Kind::Playground => b(
                &["playground", "children's play area", "climbing frame"],
                &["colourful", "red and yellow", "green"],
                &["small", "large"],
                &["wooden", "plastic and metal"],
                &["beside the street", "with a slide and swings"],
            ),
            Kind::ParkedTrailer => b(
                &["trailer", "cargo trailer", "box trailer"],
                &["white", "grey", "silver"],
                &["small", "long", "flat"],
                &["metal"],
                &["parked by the curb", "unhitched at the roadside"],
            ),
        }
    }
}

struct Bank {
    nouns: &'static [&'static str],
    colours: &'static [&'static str],
    sizes: &'static [&'static str],
    materials: &'static [&'static str],
    states: &'static [&'static str],
}

/// An object's attributes, drawn once when it is placed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Attributes {
    /// The head noun ("sedan").
    pub noun: &'static str,
    /// Colour (for people, their clothes).
    pub colour: &'static str,
    /// Size or age.
    pub size: &'static str,
    /// Material, when the kind has one.
    pub material: Option<&'static str>,
    /// State or context.
    pub state: &'static str,
}

impl Attributes {
    /// Draws attributes from the kind's caption bank.
    pub fn draw(kind: Kind, rng: &mut ChaCha8Rng) -> Attributes {
        let b = kind.bank();
        let pick =
            |rng: &mut ChaCha8Rng, v: &'static [&'static str]| v[rng.random_range(0..v.len())];
        let noun = pick(rng, b.nouns);
        let colour = pick(rng, b.colours);
        let size = pick(rng, b.sizes);
        let material = (!b.materials.is_empty()).then(|| pick(rng, b.materials));
        // a noun that says the material ("wooden bench") is made of it: no "stone wooden
        // bench"; a colour that says it ("red-brick") takes no other besides
        let implied = |w: &str| {
            b.materials.iter().copied().find(|m| {
                m.split(' ')
                    .filter(|x| *x != "and")
                    .any(|x| w.contains(x.trim_end_matches("en")))
            })
        };
        let material = match (implied(noun), implied(colour)) {
            (Some(m), _) => Some(m),
            (None, Some(_)) => None,
            (None, None) => material,
        };
        Attributes {
            noun,
            colour,
            size,
            material,
            state: pick(rng, b.states),
        }
    }

    /// A caption in one of three phrasings (0 is the ground-truth one). `colour` overrides
    /// the colour (for wrong-attribute noise).
    pub fn caption(&self, kind: Kind, phrasing: u8, colour: Option<&str>) -> String {
        let colour = colour.unwrap_or(self.colour);
        let worn = kind == Kind::Person;
        // a colour that says the material ("red-brick") says it once
        let material = self
            .material
            .filter(|m| !m.split(' ').any(|x| x != "and" && colour.contains(x)))
            .map(|m| format!("{m} "))
            .unwrap_or_default();
        let text = match (phrasing % 3, worn) {
            (0, false) => format!(
                "a {} {colour} {material}{} {}",
                self.size, self.noun, self.state
            ),
            (1, false) => format!("a {colour} {}, {}, {}", self.noun, self.size, self.state),
            (_, false) => format!(
                "{}: a {material}{} that is {colour}",
                capitalise(self.state),
                self.noun
            ),
            (0, true) => format!("a {} {} {colour} {}", self.size, self.noun, self.state),
            (1, true) => format!("a {} {colour}, {}", self.noun, self.state),
            (_, true) => format!(
                "{}: a {} {} {colour}",
                capitalise(self.state),
                self.size,
                self.noun
            ),
        };
        tidy_caption(&text)
    }
}

/// A caption as a person would write it: "an" before a vowel sound ("an old bench", "an
/// orange bin"), and no word twice in a row.
fn tidy_caption(text: &str) -> String {
    let words: Vec<&str> = text.split(' ').filter(|w| !w.is_empty()).collect();
    let mut out: Vec<String> = Vec::with_capacity(words.len());
    for (i, w) in words.iter().enumerate() {
        if out
            .last()
            .is_some_and(|p: &String| p.eq_ignore_ascii_case(w) && !w.ends_with([',', ':']))
        {
            continue;
        }
        let next = words.get(i + 1).copied().unwrap_or("");
        let article = match *w {
            "a" | "an" => Some(if vowel_sound(next) { "an" } else { "a" }),
            "A" | "An" => Some(if vowel_sound(next) { "An" } else { "A" }),
            _ => None,
        };
        out.push(article.map_or_else(|| (*w).to_string(), str::to_string));
    }
    out.join(" ")
}

/// Whether a word begins with a vowel sound (by its spelling; "one", "uni-", "use-" and "eu-"
/// begin with a consonant sound).
fn vowel_sound(word: &str) -> bool {
    let w = word.to_lowercase();
    let consonant_sound = ["one", "uni", "use", "usu", "eu"];
    w.starts_with(['a', 'e', 'i', 'o', 'u']) && !consonant_sound.iter().any(|p| w.starts_with(p))
}

/// A primitive shape of an object.
#[derive(Debug, Clone, Copy)]
pub enum PrimShape {
    /// Box with half extents.
    Cuboid(Cuboid),
    /// Vertical cylinder.
    Cylinder(Cylinder),
    /// Sphere.
    Ball(Ball),
}

impl PrimShape {
    fn as_shape(&self) -> &dyn Shape {
        match self {
            PrimShape::Cuboid(s) => s,
            PrimShape::Cylinder(s) => s,
            PrimShape::Ball(s) => s,
        }
    }

    fn cast(&self, pose: &Pose, ray: &Ray, max: f32) -> Option<f32> {
        match self {
            PrimShape::Cuboid(s) => s.cast_ray(pose, ray, max, true),
            PrimShape::Cylinder(s) => s.cast_ray(pose, ray, max, true),
            PrimShape::Ball(s) => s.cast_ray(pose, ray, max, true),
        }
    }
}

/// A primitive placed in the world.
#[derive(Debug, Clone, Copy)]
pub struct Prim {
    /// The shape.
    pub shape: PrimShape,
    /// Its world pose.
    pub pose: Pose,
    /// Index of its object in [`Scene::objects`].
    pub object: u32,
}

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
    /// An object (index into [`Scene::objects`]).
    Object(u32),
    /// A moving object (index into [`Scene::movers`]).
    Mover(u32),
}

/// The scene: roads, surfaces, objects and their BVH.
#[derive(Debug)]
pub struct Scene {
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
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for r in &net.roads {
            for p in &r.centerline {
                for k in 0..2 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
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
    let (_, q) = planner::closest_on_segment(p, a, b);
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

/// Local-frame parts of an object: (shape, local centre [x, y, z]).
type Parts = Vec<(PrimShape, [f64; 3])>;

fn cuboid(w: f64, h: f64, l: f64) -> PrimShape {
    PrimShape::Cuboid(Cuboid::new(Vector::new(
        (w / 2.0) as f32,
        (h / 2.0) as f32,
        (l / 2.0) as f32,
    )))
}

fn cylinder(radius: f64, h: f64) -> PrimShape {
    PrimShape::Cylinder(Cylinder::new((h / 2.0) as f32, radius as f32))
}

fn ball(radius: f64) -> PrimShape {
    PrimShape::Ball(Ball::new(radius as f32))
}

/// Shapes of an object standing on the ground (y up is negative), footprint `[w, l]`.
fn parts(kind: Kind, rng: &mut ChaCha8Rng) -> (Parts, [f64; 2]) {
    let r = |rng: &mut ChaCha8Rng, a: f64, b: f64| rng.random_range(a..b);
    match kind {
        Kind::Car => {
            let (w, l, h) = (r(rng, 1.7, 1.9), r(rng, 3.9, 4.8), r(rng, 1.4, 1.6));
            let body = 0.6;
            let cab = h - 0.2 - body;
            (
                vec![
                    (cuboid(w, body, l), [0.0, -(0.2 + body / 2.0), 0.0]),
                    (
                        cuboid(w * 0.9, cab, l * 0.55),
                        [0.0, -(0.2 + body + cab / 2.0), -l * 0.05],
                    ),
                ],
                [w, l],
            )
        }
        Kind::Truck => {
            let (w, l, h) = (2.4, r(rng, 6.5, 9.0), r(rng, 3.0, 3.6));
            (
                vec![
                    (
                        cuboid(w, h - 0.5, l - 2.2),
                        [0.0, -(0.5 + (h - 0.5) / 2.0), -1.1],
                    ),
                    (cuboid(w, 2.4, 2.0), [0.0, -(0.5 + 1.2), l / 2.0 - 1.0]),
                ],
                [w, l],
            )
        }
        Kind::OtherVehicle => {
            let (w, l, h) = (2.0, r(rng, 5.0, 6.2), r(rng, 2.1, 2.7));
            (
                vec![(
                    cuboid(w, h - 0.25, l),
                    [0.0, -(0.25 + (h - 0.25) / 2.0), 0.0],
                )],
                [w, l],
            )
        }
        Kind::ParkedTrailer => {
            let (w, l, h) = (r(rng, 1.6, 2.1), r(rng, 2.5, 4.5), r(rng, 1.2, 2.4));
            (
                vec![
                    (
                        cuboid(w, h - 0.45, l),
                        [0.0, -(0.45 + (h - 0.45) / 2.0), 0.0],
                    ),
                    (cuboid(0.15, 0.15, 1.2), [0.0, -0.5, l / 2.0 + 0.6]),
                ],
                [w, l + 1.2],
            )
        }
        Kind::Bicycle => (
            vec![
                (cuboid(0.08, 0.66, 0.66), [0.0, -0.33, 0.52]),
                (cuboid(0.08, 0.66, 0.66), [0.0, -0.33, -0.52]),
                (cuboid(0.1, 0.35, 1.0), [0.0, -0.8, 0.0]),
                (cuboid(0.55, 0.05, 0.05), [0.0, -1.0, 0.45]),
            ],
            [0.55, 1.75],
        ),
        Kind::Motorcycle => (
            vec![
                (cuboid(0.15, 0.6, 0.6), [0.0, -0.3, 0.7]),
                (cuboid(0.15, 0.6, 0.6), [0.0, -0.3, -0.7]),
                (cuboid(0.5, 0.5, 1.3), [0.0, -0.8, 0.0]),
                (cuboid(0.75, 0.06, 0.06), [0.0, -1.15, 0.55]),
            ],
            [0.75, 2.0],
        ),
        Kind::Person => {
            let h = r(rng, 1.55, 1.9);
            let head = 0.11;
            let body = h - 2.0 * head;
            (
                vec![
                    (cylinder(0.2, body), [0.0, -body / 2.0, 0.0]),
                    (ball(head), [0.0, -(body + head), 0.0]),
                ],
                [0.45, 0.45],
            )
        }
        Kind::Building => {
            let (w, l, h) = (r(rng, 10.0, 24.0), r(rng, 9.0, 18.0), r(rng, 6.0, 24.0));
            let mut v = vec![(cuboid(w, h, l), [0.0, -h / 2.0, 0.0])];
            if rng.random_range(0.0..1.0) < 0.4 {
                // a penthouse or roof structure
                let (rw, rl, rh) = (w * 0.4, l * 0.4, r(rng, 2.0, 4.0));
                v.push((cuboid(rw, rh, rl), [0.0, -(h + rh / 2.0), 0.0]));
            }
            (v, [w, l])
        }
        Kind::Fence => {
            let (l, h) = (r(rng, 8.0, 20.0), r(rng, 1.0, 1.9));
            (vec![(cuboid(l, h, 0.08), [0.0, -h / 2.0, 0.0])], [l, 0.3])
        }
        Kind::Hedge => {
            let (l, h, w) = (r(rng, 3.0, 9.0), r(rng, 0.8, 1.6), r(rng, 0.7, 1.3));
            (vec![(cuboid(l, h, w), [0.0, -h / 2.0, 0.0])], [l, w])
        }
        Kind::Trunk => {
            // the height is stored for the crown: see `place_tree`
            let (rad, h) = (r(rng, 0.12, 0.28), r(rng, 2.2, 3.6));
            (vec![(cylinder(rad, h), [0.0, -h / 2.0, 0.0])], [0.6, 0.6])
        }
        Kind::TreeCrown => {
            // normally placed with its trunk, see `place_tree`
            let rad = r(rng, 1.4, 2.8);
            (vec![(ball(rad), [0.0, -rad, 0.0])], [2.0 * rad, 2.0 * rad])
        }
        Kind::Pole => {
            let h = r(rng, 6.0, 9.0);
            (vec![(cylinder(0.12, h), [0.0, -h / 2.0, 0.0])], [0.4, 0.4])
        }
        Kind::TrafficSign => {
            // normally placed on its post, see `place_sign`
            (
                vec![(cuboid(0.65, 0.65, 0.04), [0.0, -0.33, 0.0])],
                [0.65, 0.1],
            )
        }
        Kind::StreetLamp => {
            let h = r(rng, 6.5, 9.0);
            (
                vec![
                    (cylinder(0.1, h), [0.0, -h / 2.0, 0.0]),
                    // the arm reaches over the road: local -x
                    (cuboid(1.6, 0.08, 0.08), [-0.8, -(h - 0.1), 0.0]),
                    (cuboid(0.6, 0.15, 0.3), [-1.5, -(h - 0.25), 0.0]),
                ],
                [0.5, 0.5],
            )
        }
        Kind::TrafficLight => (
            vec![
                (cylinder(0.09, 3.2), [0.0, -1.6, 0.0]),
                (cuboid(0.35, 0.95, 0.3), [0.0, -(3.2 + 0.475), 0.0]),
            ],
            [0.45, 0.45],
        ),
        Kind::Bench => {
            let l = r(rng, 1.5, 2.2);
            (
                vec![
                    (cuboid(l, 0.45, 0.5), [0.0, -0.225, 0.0]),
                    (cuboid(l, 0.45, 0.06), [0.0, -0.67, -0.22]),
                ],
                [l, 0.6],
            )
        }
        Kind::BusStopShelter => {
            let l = r(rng, 3.5, 5.0);
            (
                vec![
                    (cuboid(l, 0.1, 1.6), [0.0, -2.45, 0.0]),
                    (cuboid(l, 2.3, 0.05), [0.0, -1.25, -0.75]),
                    (cuboid(0.05, 2.3, 1.4), [-l / 2.0, -1.25, 0.0]),
                    (cuboid(0.05, 2.3, 1.4), [l / 2.0, -1.25, 0.0]),
                    (cuboid(l * 0.7, 0.45, 0.4), [0.0, -0.225, -0.45]),
                ],
                [l, 1.6],
            )
        }
        Kind::FireHydrant => (
            vec![
                (cylinder(0.15, 0.65), [0.0, -0.325, 0.0]),
                (ball(0.14), [0.0, -0.7, 0.0]),
            ],
            [0.4, 0.4],
        ),
        Kind::TrashCan => {
            let h = r(rng, 0.8, 1.1);
            (vec![(cylinder(0.3, h), [0.0, -h / 2.0, 0.0])], [0.6, 0.6])
        }
        Kind::Mailbox => (
            vec![
                (cylinder(0.06, 0.9), [0.0, -0.45, 0.0]),
                (cuboid(0.45, 0.6, 0.4), [0.0, -1.2, 0.0]),
            ],
            [0.45, 0.4],
        ),
        Kind::Billboard => {
            let (w, h, lift) = (r(rng, 5.0, 8.0), r(rng, 2.5, 3.5), r(rng, 2.5, 4.5));
            (
                vec![
                    (cuboid(w, h, 0.25), [0.0, -(lift + h / 2.0), 0.0]),
                    (cylinder(0.18, lift), [-w / 3.0, -lift / 2.0, 0.0]),
                    (cylinder(0.18, lift), [w / 3.0, -lift / 2.0, 0.0]),
                ],
                [w, 0.6],
            )
        }
        Kind::Playground => (
            vec![
                (cuboid(3.0, 2.6, 3.0), [-2.5, -1.3, 0.0]),
                (cuboid(0.7, 1.6, 3.5), [0.0, -0.8, 1.0]),
                (cuboid(3.5, 0.15, 0.15), [2.8, -2.3, -1.0]),
                (cylinder(0.08, 2.3), [1.1, -1.15, -1.0]),
                (cylinder(0.08, 2.3), [4.5, -1.15, -1.0]),
            ],
            [10.0, 7.0],
        ),
    }
}

/// Scene generation parameters.
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

struct Placer<'a> {
    grid: &'a SegmentGrid,
    net: &'a RoadNetwork,
    sides: &'a [RoadSides],
    occ: Occupancy,
    objects: Vec<SimObject>,
    prims: Vec<Prim>,
    max_objects: usize,
}

impl Placer<'_> {
    fn surface(&self, p: [f64; 2]) -> Surface {
        surface_at(self.grid, self.net, self.sides, p)
    }

    /// Places `kind` at ground position `c` facing `yaw` if its footprint is on `on` and free.
    fn try_place(
        &mut self,
        kind: Kind,
        c: [f64; 2],
        yaw: f64,
        on: &[Surface],
        rng: &mut ChaCha8Rng,
    ) -> Option<usize> {
        let (parts, fp) = parts(kind, rng);
        self.place_parts(kind, c, yaw, on, parts, fp, 0.0, rng)
    }

    #[allow(clippy::too_many_arguments)]
    fn place_parts(
        &mut self,
        kind: Kind,
        c: [f64; 2],
        yaw: f64,
        on: &[Surface],
        parts: Parts,
        fp: [f64; 2],
        lift: f64,
        rng: &mut ChaCha8Rng,
    ) -> Option<usize> {
        if self.objects.len() >= self.max_objects {
            return None;
        }
        let print = Footprint {
            c,
            half: [fp[0] / 2.0, fp[1] / 2.0],
            yaw,
        };
        if !on.is_empty()
            && !print
                .samples()
                .iter()
                .all(|p| on.contains(&self.surface(*p)))
        {
            return None;
        }
        // things lifted off the ground (tree crowns) may overhang others
        if lift <= 0.0 {
            if !self.occ.free(&print) {
                return None;
            }
            self.occ.insert(print);
        }
        let pose = Pose::from_parts(
            Vector::new(c[0] as f32, 0.0, c[1] as f32),
            Rotation::from_rotation_y(yaw as f32),
        );
        let index = self.objects.len() as u32;
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (shape, at) in &parts {
            let local = Pose::from_translation(Vector::new(
                at[0] as f32,
                (at[1] - lift) as f32,
                at[2] as f32,
            ));
            let la = shape.as_shape().compute_aabb(&local);
            for k in 0..3 {
                lo[k] = lo[k].min(f64::from(la.mins[k]));
                hi[k] = hi[k].max(f64::from(la.maxs[k]));
            }
            self.prims.push(Prim {
                shape: *shape,
                pose: pose * local,
                object: index,
            });
        }
        let mid = [
            (lo[0] + hi[0]) / 2.0,
            (lo[1] + hi[1]) / 2.0,
            (lo[2] + hi[2]) / 2.0,
        ];
        let (s, co) = yaw.sin_cos();
        let attributes = Attributes::draw(kind, rng);
        let caption = attributes.caption(kind, 0, None);
        self.objects.push(SimObject {
            id: index + 1,
            kind,
            caption,
            attributes,
            center: [
                c[0] + co * mid[0] + s * mid[2],
                mid[1],
                c[1] - s * mid[0] + co * mid[2],
            ],
            size: [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]],
            yaw_rad: yaw,
        });
        Some(index as usize)
    }

    /// A tree: a trunk object and a crown object above it.
    fn place_tree(&mut self, c: [f64; 2], on: &[Surface], rng: &mut ChaCha8Rng) {
        let (trunk, fp) = parts(Kind::Trunk, rng);
        let h = match trunk[0].0 {
            PrimShape::Cylinder(cy) => 2.0 * f64::from(cy.half_height),
            _ => 3.0,
        };
        let yaw = rng.random_range(0.0..std::f64::consts::TAU);
        if self
            .place_parts(Kind::Trunk, c, yaw, on, trunk, fp, 0.0, rng)
            .is_none()
        {
            return;
        }
        let rad = rng.random_range(1.4..2.8);
        let crown = vec![(ball(rad), [0.0, -rad * 0.8, 0.0])];
        self.place_parts(
            Kind::TreeCrown,
            c,
            yaw,
            &[],
            crown,
            [2.0 * rad, 2.0 * rad],
            h,
            rng,
        );
    }

    /// A traffic sign: its post (a pole) and the plate on top, facing `yaw`.
    fn place_sign(&mut self, c: [f64; 2], yaw: f64, on: &[Surface], rng: &mut ChaCha8Rng) {
        let post = vec![(cylinder(0.05, 2.4), [0.0, -1.2, 0.0])];
        if self
            .place_parts(Kind::Pole, c, yaw, on, post, [0.3, 0.3], 0.0, rng)
            .is_none()
        {
            return;
        }
        let plate = vec![(cuboid(0.65, 0.65, 0.04), [0.0, -0.33, 0.0])];
        self.place_parts(Kind::TrafficSign, c, yaw, &[], plate, [0.65, 0.1], 2.4, rng);
    }
}

/// What the ground is at `p`.
fn surface_at(grid: &SegmentGrid, net: &RoadNetwork, sides: &[RoadSides], p: [f64; 2]) -> Surface {
    let mut best = Surface::Terrain;
    for &(r, s) in grid.cell(p) {
        let road = &net.roads[r as usize];
        let (d, side) = segment_distance(
            p,
            road.centerline[s as usize],
            road.centerline[s as usize + 1],
        );
        let half = road.width_m / 2.0;
        let park = if sides[r as usize].parking[side] {
            PARKING_M
        } else {
            0.0
        };
        let here = if d < half {
            Surface::Road
        } else if d < half + park {
            Surface::Parking
        } else if d < half + park + SIDEWALK_M {
            Surface::Sidewalk
        } else {
            Surface::Terrain
        };
        best = best.min(here);
    }
    best
}

impl Scene {
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
    pub fn generate(net: RoadNetwork, seed: u64, cfg: &SceneConfig) -> Scene {
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
        Scene {
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
    pub fn with_movers(mut self, cfg: &super::movers::MoverConfig, seed: u64) -> Scene {
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

    /// The movers' boxes at `t_secs`, in mover order (for [`Scene::cast_among`]).
    pub fn movers_at(&self, t_secs: f64) -> Vec<super::movers::MoverBox> {
        self.movers.iter().map(|m| m.box_at(t_secs)).collect()
    }

    /// [`Scene::cast`] with the movers' boxes of one time ([`Scene::movers_at`]) too.
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

/// Arc length at every vertex of a polyline.
fn cumulative_lengths(c: &[[f64; 2]]) -> Vec<f64> {
    let mut cum = Vec::with_capacity(c.len());
    let mut acc = 0.0;
    cum.push(acc);
    for w in c.windows(2) {
        acc += dist(w[0], w[1]);
        cum.push(acc);
    }
    cum
}

/// Position and unit direction at arc length `t` along a polyline with cumulative lengths.
fn at_length(c: &[[f64; 2]], cum: &[f64], t: f64) -> ([f64; 2], [f64; 2]) {
    let i = cum.partition_point(|x| *x <= t).clamp(1, c.len() - 1) - 1;
    let (a, b) = (c[i], c[i + 1]);
    let l = (cum[i + 1] - cum[i]).max(1e-9);
    let f = ((t - cum[i]) / l).clamp(0.0, 1.0);
    let d = [(b[0] - a[0]) / l, (b[1] - a[1]) / l];
    ([a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f], d)
}

fn yaw_of(d: [f64; 2]) -> f64 {
    d[0].atan2(d[1])
}

/// Everything along one road: parked vehicles, street furniture, trees, people, fences,
/// hedges, buildings, billboards and playgrounds, on both sides.
fn place_along_road(p: &mut Placer<'_>, ri: usize, rng: &mut ChaCha8Rng) {
    let road = p.net.roads[ri].clone();
    let c = &road.centerline;
    let cum = cumulative_lengths(c);
    let len = *cum.last().unwrap_or(&0.0);
    let half = road.width_m / 2.0;
    let margin = 12.0;
    if len < 2.0 * margin {
        return;
    }
    for side in 0..2usize {
        // offset direction: right of travel is (d.z, -d.x); left is the opposite
        let sgn = if side == 0 { 1.0 } else { -1.0 };
        let park = if p.sides[ri].parking[side] {
            PARKING_M
        } else {
            0.0
        };
        let curb = half + park;
        let at = |t: f64, off: f64| {
            let (q, d) = at_length(c, &cum, t);
            let right = [d[1] * sgn, -d[0] * sgn];
            ([q[0] + right[0] * off, q[1] + right[1] * off], d, right)
        };
        // parked vehicles in the parking lane, nose in the direction of travel on that side
        if park > 0.0 {
            let mut t = margin + rng.random_range(0.0..4.0);
            while t < len - margin {
                let roll = rng.random_range(0.0..1.0);
                let kind = if roll < 0.68 {
                    Some(Kind::Car)
                } else if roll < 0.74 {
                    Some(Kind::OtherVehicle)
                } else if roll < 0.78 {
                    Some(Kind::Truck)
                } else if roll < 0.82 {
                    Some(Kind::ParkedTrailer)
                } else if roll < 0.86 {
                    Some(Kind::Motorcycle)
                } else {
                    None
                };
                let (q, d, _) = at(t, half + park / 2.0);
                let fwd = if side == 0 { d } else { [-d[0], -d[1]] };
                let mut step = 7.0;
                if let Some(k) = kind
                    && p.try_place(k, q, yaw_of(fwd), &[Surface::Parking], rng)
                        .is_some()
                {
                    step = p.objects.last().map_or(7.0, |o| o.size[2]) + rng.random_range(0.8..3.0);
                }
                t += step;
            }
        }
        // sidewalk, near the curb: lamps, trees, poles, signs, hydrants, bins, mailboxes
        let mut t = margin + rng.random_range(0.0..6.0);
        let mut since_lamp = 100.0;
        while t < len - margin {
            let (q, d, right) = at(t, curb + 0.6);
            let facing_road = yaw_of([-right[0], -right[1]]);
            let on = [Surface::Sidewalk];
            let roll = rng.random_range(0.0..1.0);
            if since_lamp > 28.0 {
                // the lamp's arm (local -x) reaches over the road: local +x, which is
                // (cos yaw, -sin yaw), points away from it
                let yaw = (-right[1]).atan2(right[0]);
                if p.try_place(Kind::StreetLamp, q, yaw, &on, rng).is_some() {
                    since_lamp = 0.0;
                }
            } else if roll < 0.45 {
                p.place_tree(q, &on, rng);
            } else if roll < 0.55 {
                p.try_place(Kind::Pole, q, 0.0, &on, rng);
            } else if roll < 0.63 {
                // the plate faces oncoming traffic on this side
                let toward = if side == 0 { [-d[0], -d[1]] } else { d };
                p.place_sign(q, yaw_of(toward), &on, rng);
            } else if roll < 0.70 {
                p.try_place(Kind::FireHydrant, q, facing_road, &on, rng);
            } else if roll < 0.80 {
                p.try_place(Kind::TrashCan, q, facing_road, &on, rng);
            } else if roll < 0.86 {
                p.try_place(Kind::Mailbox, q, facing_road, &on, rng);
            }
            let step = rng.random_range(5.0..9.0);
            since_lamp += step;
            t += step;
        }
        // sidewalk, back half: benches, bus stops, parked bicycles, people
        let mut t = margin + rng.random_range(0.0..10.0);
        while t < len - margin {
            let roll = rng.random_range(0.0..1.0);
            let on = [Surface::Sidewalk];
            let (q, d, right) = at(t, curb + 2.0);
            let facing_road = yaw_of([-right[0], -right[1]]);
            if roll < 0.10 {
                let (q, _, _) = at(t, curb + 2.1);
                p.try_place(Kind::BusStopShelter, q, facing_road, &on, rng);
            } else if roll < 0.30 {
                p.try_place(Kind::Bench, q, facing_road, &on, rng);
            } else if roll < 0.50 {
                p.try_place(
                    Kind::Bicycle,
                    q,
                    yaw_of(d) + rng.random_range(-0.3..0.3),
                    &on,
                    rng,
                );
            } else if roll < 0.85 {
                let (q, _, _) = at(t, curb + rng.random_range(0.8..2.4));
                let dir = if rng.random_range(0..2) == 0 {
                    d
                } else {
                    [-d[0], -d[1]]
                };
                p.try_place(Kind::Person, q, yaw_of(dir), &on, rng);
            }
            t += rng.random_range(6.0..16.0);
        }
        // beyond the sidewalk: fences or hedges at the property line, then buildings set
        // back from it, with the odd billboard or playground in a gap
        let line = curb + SIDEWALK_M + 0.5;
        let mut t = margin;
        while t < len - margin {
            let (q, d, _) = at(t, line);
            let roll = rng.random_range(0.0..1.0);
            if roll < 0.3 {
                // fence parallel to the road: its length is local x, so yaw = road heading
                p.try_place(
                    Kind::Fence,
                    q,
                    yaw_of(d) + std::f64::consts::FRAC_PI_2,
                    &[Surface::Terrain],
                    rng,
                );
            } else if roll < 0.5 {
                p.try_place(
                    Kind::Hedge,
                    q,
                    yaw_of(d) + std::f64::consts::FRAC_PI_2,
                    &[Surface::Terrain],
                    rng,
                );
            }
            t += rng.random_range(10.0..22.0);
        }
        let mut t = margin;
        while t < len - margin {
            let roll = rng.random_range(0.0..1.0);
            let setback = rng.random_range(2.5..8.0);
            let kind = if roll < 0.04 {
                Kind::Billboard
            } else if roll < 0.07 {
                Kind::Playground
            } else if roll < 0.85 {
                Kind::Building
            } else {
                // a garden: a tree set back from the road
                let (q, _, _) = at(t, line + setback + 2.0);
                p.place_tree(q, &[Surface::Terrain], rng);
                t += 8.0;
                continue;
            };
            let (parts_v, fp) = parts(kind, rng);
            let depth = fp[1];
            let (q, _, right) = at(t + fp[0] / 2.0, line + 1.0 + setback + depth / 2.0);
            let facing_road = yaw_of([-right[0], -right[1]]);
            // the front (local +z) faces the road; width runs along it
            let placed = p
                .place_parts(
                    kind,
                    q,
                    facing_road,
                    &[Surface::Terrain],
                    parts_v,
                    fp,
                    0.0,
                    rng,
                )
                .is_some();
            t += if placed {
                fp[0] + rng.random_range(1.0..6.0)
            } else {
                4.0
            };
        }
    }
}

/// A traffic light on the right-hand sidewalk of each road arriving at a crossroads or
/// T-junction, a little before the junction, facing the arriving traffic.
fn place_traffic_lights(p: &mut Placer<'_>, rng: &mut ChaCha8Rng) {
    use super::roads::JunctionKind;
    for ri in 0..p.net.roads.len() {
        let road = p.net.roads[ri].clone();
        let c = &road.centerline;
        let cum = cumulative_lengths(c);
        let len = *cum.last().unwrap_or(&0.0);
        for (node, toward_b) in [(road.b, true), (road.a, false)] {
            if !matches!(
                p.net.nodes[node].kind,
                JunctionKind::Crossroads | JunctionKind::TJunction
            ) || len < 30.0
            {
                continue;
            }
            let t = if toward_b { len - 9.0 } else { 9.0 };
            let (q, d) = at_length(c, &cum, t);
            let travel = if toward_b { d } else { [-d[0], -d[1]] };
            let side = if toward_b { 0 } else { 1 };
            let park = if p.sides[ri].parking[side] {
                PARKING_M
            } else {
                0.0
            };
            let off = road.width_m / 2.0 + park + 0.5;
            let right = [travel[1], -travel[0]];
            let pos = [q[0] + right[0] * off, q[1] + right[1] * off];
            let facing = yaw_of([-travel[0], -travel[1]]);
            p.try_place(Kind::TrafficLight, pos, facing, &[Surface::Sidewalk], rng);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sources::sim::roads::SimSize;

    fn small() -> Scene {
        Scene::generate(
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
