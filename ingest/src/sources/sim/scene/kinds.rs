//! What the simulated city is made of: ground surfaces, the kinds of objects with their
//! ground-truth class, purpose and attributes, and their captions.

use super::*;

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

    pub(super) fn bank(self) -> Bank {
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

pub(super) struct Bank {
    pub(super) nouns: &'static [&'static str],
    pub(super) colours: &'static [&'static str],
    pub(super) sizes: &'static [&'static str],
    pub(super) materials: &'static [&'static str],
    pub(super) states: &'static [&'static str],
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
pub(super) fn tidy_caption(text: &str) -> String {
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
pub(super) fn vowel_sound(word: &str) -> bool {
    let w = word.to_lowercase();
    let consonant_sound = ["one", "uni", "use", "usu", "eu"];
    w.starts_with(['a', 'e', 'i', 'o', 'u']) && !consonant_sound.iter().any(|p| w.starts_with(p))
}
