//! Understanding a request: one structured form ([`Request`]) for what a natural-language
//! request about the map asks (the target and its attributes, anchors with a spatial relation,
//! a road-segment constraint, an ordinal), filled by a deterministic rule parser for common
//! English ([`parse_rules`]) or by a language model under a JSON Schema ([`parse_llm`]).

use crate::chat::{ChatModel, ChatRequest, Message};
use crate::error::{Error, Result};

/// A spatial relation between the target and an anchor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Relation {
    /// Within a few metres.
    Near,
    /// Touching or within about two metres.
    NextTo,
    /// Resting on top of the anchor.
    On,
    /// Below the anchor.
    Under,
    /// Inside the anchor's footprint.
    Inside,
    /// In front of the anchor (treated as near: the map has no viewpoint).
    InFrontOf,
    /// Behind the anchor (treated as near).
    Behind,
    /// Left of the anchor (treated as near).
    LeftOf,
    /// Right of the anchor (treated as near).
    RightOf,
    /// Facing the anchor across some open space.
    Opposite,
    /// On the other side of the road from the anchor.
    AcrossTheRoadFrom,
}

impl Relation {
    /// Every relation, in schema order.
    pub const ALL: [Relation; 11] = [
        Relation::Near,
        Relation::NextTo,
        Relation::On,
        Relation::Under,
        Relation::Inside,
        Relation::InFrontOf,
        Relation::Behind,
        Relation::LeftOf,
        Relation::RightOf,
        Relation::Opposite,
        Relation::AcrossTheRoadFrom,
    ];

    /// The snake_case name (as in the JSON form and in `RELATED.relation`).
    pub fn as_str(self) -> &'static str {
        match self {
            Relation::Near => "near",
            Relation::NextTo => "next_to",
            Relation::On => "on",
            Relation::Under => "under",
            Relation::Inside => "inside",
            Relation::InFrontOf => "in_front_of",
            Relation::Behind => "behind",
            Relation::LeftOf => "left_of",
            Relation::RightOf => "right_of",
            Relation::Opposite => "opposite",
            Relation::AcrossTheRoadFrom => "across_the_road_from",
        }
    }
}

/// A road-segment constraint ("at the crossroads").
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SegmentConstraint {
    /// A four-way crossroads (`Segment.kind = intersection`).
    Crossroads,
    /// A T-junction (`t_intersection`).
    TJunction,
    /// An L-shaped bend (`l_intersection`).
    Bend,
    /// A straight road (`straight_roadway`).
    StraightRoad,
    /// Any junction ("at the corner").
    Junction,
}

impl SegmentConstraint {
    /// Every constraint, in schema order.
    pub const ALL: [SegmentConstraint; 5] = [
        SegmentConstraint::Crossroads,
        SegmentConstraint::TJunction,
        SegmentConstraint::Bend,
        SegmentConstraint::StraightRoad,
        SegmentConstraint::Junction,
    ];

    /// The snake_case name.
    pub fn as_str(self) -> &'static str {
        match self {
            SegmentConstraint::Crossroads => "crossroads",
            SegmentConstraint::TJunction => "t_junction",
            SegmentConstraint::Bend => "bend",
            SegmentConstraint::StraightRoad => "straight_road",
            SegmentConstraint::Junction => "junction",
        }
    }

    /// Whether a `Segment.kind` of the map satisfies the constraint.
    pub fn admits(self, segment_kind: &str) -> bool {
        match self {
            SegmentConstraint::Crossroads => segment_kind == "intersection",
            SegmentConstraint::TJunction => segment_kind == "t_intersection",
            SegmentConstraint::Bend => segment_kind == "l_intersection",
            SegmentConstraint::StraightRoad => segment_kind == "straight_roadway",
            SegmentConstraint::Junction => matches!(
                segment_kind,
                "intersection" | "t_intersection" | "l_intersection"
            ),
        }
    }
}

/// An anchor: another object the target stands in some relation to.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Anchor {
    /// The anchor's phrase ("the bus stop").
    pub phrase: String,
    /// How the target relates to it.
    pub relation: Relation,
    /// An explicit distance ("within 10 m of"), metres.
    #[serde(default)]
    pub distance_m: Option<f64>,
}

/// What a request asks, in one structured form.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Request {
    /// The target phrase as said ("the green bench").
    pub target: String,
    /// Physical objects that would satisfy a request given by function ("somewhere I can
    /// post a letter" → `["a mailbox"]`); empty when the target names the object itself.
    #[serde(default)]
    pub objects: Vec<String>,
    /// Attribute words of the target (colours, materials, sizes).
    #[serde(default)]
    pub attributes: Vec<String>,
    /// Anchors.
    #[serde(default)]
    pub anchors: Vec<Anchor>,
    /// A road-segment constraint.
    #[serde(default)]
    pub segment: Option<SegmentConstraint>,
    /// "The second" → 2; "the nearest" / "the closest" → 1 with `nearest` set.
    #[serde(default)]
    pub ordinal: Option<u32>,
    /// Whether the request asks for the nearest one.
    #[serde(default)]
    pub nearest: bool,
}

/// The JSON Schema of [`Request`] (draft 2020-12), as the language model fills it.
pub fn request_schema() -> serde_json::Value {
    let relations: Vec<&str> = Relation::ALL.iter().map(|r| r.as_str()).collect();
    let segments: Vec<serde_json::Value> = SegmentConstraint::ALL
        .iter()
        .map(|s| serde_json::Value::from(s.as_str()))
        .chain([serde_json::Value::Null])
        .collect();
    serde_json::json!({
        "type": "object",
        "properties": {
            "target": {"type": "string", "description": "the thing asked for, as said"},
            "objects": {"type": "array", "items": {"type": "string"}, "maxItems": 3,
                "description": "physical objects on a street that would satisfy the request, e.g. 'a mailbox'"},
            "attributes": {"type": "array", "items": {"type": "string"}, "maxItems": 4},
            "anchors": {"type": "array", "maxItems": 3, "items": {
                "type": "object",
                "properties": {
                    "phrase": {"type": "string"},
                    "relation": {"enum": relations},
                    "distance_m": {"type": ["number", "null"]}
                },
                "required": ["phrase", "relation", "distance_m"],
                "additionalProperties": false
            }},
            "segment": {"enum": segments},
            "ordinal": {"type": ["integer", "null"], "minimum": 1, "maximum": 20},
            "nearest": {"type": "boolean"}
        },
        "required": ["target", "objects", "attributes", "anchors", "segment", "ordinal", "nearest"],
        "additionalProperties": false
    })
}

fn normalise(text: &str) -> String {
    let t = text
        .to_lowercase()
        .replace(['’', '‘'], "'")
        .replace(['?', '!', '.', ',', ';', '"'], " ");
    t.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Words that open a request without naming anything.
const LEAD_INS: [&str; 27] = [
    "please ",
    "can you ",
    "could you ",
    "find me ",
    "find ",
    "show me ",
    "where is ",
    "where's ",
    "where are ",
    "take me to ",
    "navigate to ",
    "go to ",
    "get me to ",
    "i'm looking for ",
    "i am looking for ",
    "looking for ",
    "look for ",
    "search for ",
    "i want ",
    "i need ",
    "is there ",
    "are there ",
    "there is ",
    "there's ",
    "i'm at ",
    "i am at ",
    "locate ",
];

/// Segment phrases, longest first, with the prepositions that may precede them.
const SEGMENTS: [(&str, SegmentConstraint); 18] = [
    ("straight stretch of road", SegmentConstraint::StraightRoad),
    (
        "straight stretch of street",
        SegmentConstraint::StraightRoad,
    ),
    ("bend in the road", SegmentConstraint::Bend),
    ("l-shaped bend", SegmentConstraint::Bend),
    ("four-way junction", SegmentConstraint::Crossroads),
    ("four-way intersection", SegmentConstraint::Crossroads),
    ("crossroads", SegmentConstraint::Crossroads),
    ("intersection", SegmentConstraint::Crossroads),
    ("crossing", SegmentConstraint::Crossroads),
    ("t-junction", SegmentConstraint::TJunction),
    ("t junction", SegmentConstraint::TJunction),
    ("t-intersection", SegmentConstraint::TJunction),
    ("l-junction", SegmentConstraint::Bend),
    ("bend", SegmentConstraint::Bend),
    ("straight road", SegmentConstraint::StraightRoad),
    ("straight stretch", SegmentConstraint::StraightRoad),
    ("straight street", SegmentConstraint::StraightRoad),
    ("corner", SegmentConstraint::Junction),
];

/// Relation phrases, longest first.
const RELATIONS: [(&str, Relation); 33] = [
    (
        "on the other side of the road from",
        Relation::AcrossTheRoadFrom,
    ),
    (
        "on the other side of the street from",
        Relation::AcrossTheRoadFrom,
    ),
    ("across the road from", Relation::AcrossTheRoadFrom),
    ("across the street from", Relation::AcrossTheRoadFrom),
    ("to the left of", Relation::LeftOf),
    ("to the right of", Relation::RightOf),
    ("on the left of", Relation::LeftOf),
    ("on the right of", Relation::RightOf),
    ("in front of", Relation::InFrontOf),
    ("not far from", Relation::Near),
    ("adjacent to", Relation::NextTo),
    ("on top of", Relation::On),
    ("opposite to", Relation::Opposite),
    ("close to", Relation::Near),
    ("near to", Relation::Near),
    ("next to", Relation::NextTo),
    ("left of", Relation::LeftOf),
    ("right of", Relation::RightOf),
    ("alongside", Relation::NextTo),
    ("underneath", Relation::Under),
    ("opposite", Relation::Opposite),
    ("beneath", Relation::Under),
    ("beside", Relation::NextTo),
    ("behind", Relation::Behind),
    ("inside", Relation::Inside),
    ("facing", Relation::Opposite),
    ("around", Relation::Near),
    ("below", Relation::Under),
    ("under", Relation::Under),
    ("near", Relation::Near),
    ("by", Relation::NextTo),
    ("at", Relation::Near),
    ("on", Relation::On),
];

/// What things in a street are for: trigger phrases (whole words) and the object that
/// serves them. Common sense written for street scenes, used by the rule parser for requests
/// given by function; a language model parser covers what it misses.
const AFFORDANCES: [(&[&str], &str); 19] = [
    (
        &[
            "sit",
            "seat",
            "sit down",
            "rest my legs",
            "take a rest",
            "have a rest",
        ],
        "a bench",
    ),
    (
        &[
            "catch a bus",
            "catch the bus",
            "take the bus",
            "take a bus",
            "wait for the bus",
            "waiting for the bus",
            "wait for a bus",
            "public transport",
            "bus stop",
        ],
        "a bus stop shelter",
    ),
    (
        &[
            "post a letter",
            "send a letter",
            "post a parcel",
            "send a parcel",
            "postcard",
            "mail a",
            "post something",
            "letters",
        ],
        "a mailbox",
    ),
    (
        &[
            "throw away",
            "rubbish",
            "trash",
            "litter",
            "garbage",
            "get rid of",
            "dispose",
            "wrapper",
            "empty bottle",
            "waste",
        ],
        "a trash can",
    ),
    (
        &[
            "firefighter",
            "firefighters",
            "fire brigade",
            "fire hose",
            "put out a fire",
        ],
        "a fire hydrant",
    ),
    (
        &[
            "ask for directions",
            "ask someone",
            "ask somebody",
            "who could i ask",
            "someone to ask",
            "talk to",
            "a person to",
        ],
        "a person",
    ),
    (
        &[
            "when to stop",
            "stop and go",
            "tells drivers",
            "controls the traffic",
            "traffic signal",
        ],
        "a traffic light",
    ),
    (
        &["without a motor", "pedal", "cycle to", "ride a bike"],
        "a bicycle",
    ),
    (
        &["two-wheeled motor", "motorbike", "motor bike"],
        "a motorcycle",
    ),
    (
        &["sleep in", "camping", "on holiday", "caravan"],
        "a camper van",
    ),
    (
        &["tows", "towed", "tow ", "carry goods behind"],
        "a cargo trailer",
    ),
    (&["delivers", "delivery", "deliver"], "a delivery truck"),
    (
        &[
            "power lines",
            "phone lines",
            "power line",
            "cables",
            "electricity",
        ],
        "a utility pole",
    ),
    (
        &[
            "people live",
            "place to live",
            "a home",
            "apartments",
            "offices",
            "work in",
        ],
        "a building",
    ),
    (
        &[
            "keeps people out",
            "keep people out",
            "keeps out",
            "boundary of a garden",
        ],
        "a fence",
    ),
    (
        &[
            "lights the street",
            "light at night",
            "street lighting",
            "at night",
        ],
        "a street lamp",
    ),
    (&["shade", "shady"], "a tree"),
    (
        &[
            "children play",
            "kids play",
            "kids can play",
            "children can play",
            "play",
        ],
        "a playground",
    ),
    (&["advert", "advertising", "advertisement"], "a billboard"),
];

/// Colour and material words recognised as attributes.
const ATTRIBUTE_WORDS: [&str; 30] = [
    "red", "green", "blue", "yellow", "white", "black", "grey", "gray", "silver", "brown",
    "orange", "beige", "dark", "light", "bright", "wooden", "wood", "metal", "steel", "glass",
    "stone", "concrete", "brick", "plastic", "iron", "tall", "small", "large", "long", "old",
];

/// Whether `phrase` occurs in `text` at word boundaries; the byte offset of the first one.
fn find_words(text: &str, phrase: &str) -> Option<usize> {
    let phrase = phrase.trim_end();
    let bytes = text.as_bytes();
    let mut from = 0;
    while let Some(i) = text[from..].find(phrase).map(|i| i + from) {
        let end = i + phrase.len();
        let left_ok = i == 0 || bytes[i - 1] == b' ';
        let right_ok = end == text.len() || bytes[end] == b' ';
        if left_ok && right_ok {
            return Some(i);
        }
        from = i + 1;
    }
    None
}

/// Short relation words that are relations only before a determiner ("at the bus stop",
/// not "at night"; "on a bench", not "on holiday").
const NEEDS_DETERMINER: [&str; 5] = ["on", "at", "by", "around", "near"];

/// The first occurrence of a relation phrase in `t` at or after `from`, at word boundaries,
/// honouring [`NEEDS_DETERMINER`].
fn find_relation(t: &str, from: usize, phrase: &str) -> Option<usize> {
    let mut from = from;
    while from < t.len() {
        let i = find_words(&t[from..], phrase)? + from;
        let next = t[i + phrase.len()..].split_whitespace().next();
        let ok = !NEEDS_DETERMINER.contains(&phrase)
            || next.is_some_and(|w| {
                matches!(
                    w,
                    "the" | "a" | "an" | "this" | "that" | "some" | "my" | "your" | "one"
                )
            });
        if ok {
            return Some(i);
        }
        from = i + phrase.len();
    }
    None
}

/// The objects that serve the functions named in `phrase` (see [`AFFORDANCES`]), in table
/// order, without repeats.
pub fn objects_for_function(phrase: &str) -> Vec<String> {
    let t = normalise(phrase);
    let mut out: Vec<String> = Vec::new();
    for (triggers, object) in AFFORDANCES {
        if triggers.iter().any(|tr| find_words(&t, tr).is_some())
            && !out.iter().any(|o| o == object)
        {
            out.push((*object).to_string());
        }
    }
    out
}

fn strip_articles(s: &str) -> &str {
    let s = s.trim();
    if matches!(s, "the" | "a" | "an" | "some" | "any") {
        return "";
    }
    for a in ["the ", "a ", "an ", "some ", "any "] {
        if let Some(rest) = s.strip_prefix(a) {
            return rest.trim();
        }
    }
    s
}

/// The two ends of a navigation request, as words.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct RouteWords {
    /// Where to start (None when the request does not say).
    pub from: Option<String>,
    /// Where to go.
    pub to: String,
}

/// Words before a relation's "to" that keep it from ending the start ("next to the bus stop").
const TO_TAKERS: [&str; 7] = ["next", "close", "adjacent", "near", "opposite", "up", "due"];

/// Splits a navigation request into its start and goal: "from A to B", "to B from A",
/// "take me to B", "how do I get from A to B". A "to" that belongs to a relation ("next to",
/// "close to") does not split.
///
/// # Errors
/// No goal can be found in the text.
pub fn parse_route(text: &str) -> Result<RouteWords> {
    let mut t = normalise(text);
    loop {
        let before = t.len();
        for l in [
            "please ",
            "can you ",
            "could you ",
            "take me ",
            "bring me ",
            "get me ",
            "guide me ",
            "navigate ",
            "drive ",
            "go ",
            "how do i get ",
            "how can i get ",
            "i want to go ",
            "i need to go ",
            "i'd like to go ",
            "route ",
            "plan a route ",
            "a route ",
            "find a way ",
            "the way ",
        ] {
            if let Some(rest) = t.strip_prefix(l) {
                t = rest.to_string();
            }
        }
        if t.len() == before {
            break;
        }
    }
    // the " to " that splits: not one that a relation word takes
    let split_to = |s: &str| -> Option<usize> {
        let mut from = 0;
        while let Some(i) = find_words(&s[from..], "to").map(|i| i + from) {
            let prev = s[..i].split_whitespace().last().unwrap_or("");
            if !TO_TAKERS.contains(&prev) {
                return Some(i);
            }
            from = i + 2;
        }
        None
    };
    let clean = |s: &str| -> Option<String> {
        let s = s.trim();
        (!strip_articles(s).is_empty()).then(|| s.to_string())
    };
    let bad = || {
        Error::Invalid(format!(
            "no destination in {text:?}: say where to go (\"to ...\")"
        ))
    };
    if let Some(rest) = t.strip_prefix("from ") {
        let i = split_to(rest).ok_or_else(bad)?;
        let to = clean(&rest[i + 2..]).ok_or_else(bad)?;
        return Ok(RouteWords {
            from: clean(&rest[..i]),
            to,
        });
    }
    let rest = t.strip_prefix("to ").unwrap_or(&t);
    // "B from A"
    if let Some(i) = find_words(rest, "from") {
        let to = clean(&rest[..i]).ok_or_else(bad)?;
        return Ok(RouteWords {
            from: clean(&rest[i + 4..]),
            to,
        });
    }
    Ok(RouteWords {
        from: None,
        to: clean(rest).ok_or_else(bad)?,
    })
}

/// Takes the first segment phrase ("at the T-junction", "on a bend") out of `t` (already
/// lower-case), with the preposition and article before it; returns the constraint and the
/// rest with its spaces collapsed.
pub fn take_segment(t: &str) -> (Option<SegmentConstraint>, String) {
    for (phrase, kind) in SEGMENTS {
        if let Some(i) = find_words(t, phrase) {
            let mut start = i;
            for prep in [
                "at the ",
                "on the ",
                "near the ",
                "by the ",
                "in the ",
                "at a ",
                "on a ",
                "near a ",
                "the ",
                "a ",
            ] {
                if t[..start].ends_with(prep) {
                    start -= prep.len();
                    break;
                }
            }
            let end = i + phrase.len();
            let rest = format!("{} {}", &t[..start], &t[end..]);
            return (
                Some(kind),
                rest.split_whitespace().collect::<Vec<_>>().join(" "),
            );
        }
    }
    (None, t.to_string())
}

/// The deterministic rule parser for common English.
///
/// Steps: lower-case; drop a lead-in ("take me to", "where is"); take out a segment phrase
/// ("at the T-junction") and an ordinal ("the second", "the nearest"); split the rest at
/// relation phrases ("near", "next to", "across the road from", "within 10 m of"), the
/// first part being the target and each later part an anchor (anchors joined by "and"
/// share the relation); "with a bench nearby" is an anchor too. A target given by function
/// ("somewhere I can post a letter") gets the objects that serve it
/// ([`objects_for_function`]).
///
/// # Errors
/// The text is empty or names nothing once the lead-in is removed.
pub fn parse_rules(text: &str) -> Result<Request> {
    let mut t = normalise(text);
    if t.is_empty() {
        return Err(Error::Invalid("the request text is empty".into()));
    }
    // lead-ins, repeatedly ("please take me to")
    loop {
        let before = t.len();
        for l in LEAD_INS {
            if let Some(rest) = t.strip_prefix(l) {
                t = rest.to_string();
            }
        }
        if t.len() == before {
            break;
        }
    }
    let mut req = Request::default();
    let (segment, rest) = take_segment(&t);
    req.segment = segment;
    t = rest;
    // ordinal / superlative
    for (w, n, nearest) in [
        ("the nearest ", 1, true),
        ("the closest ", 1, true),
        ("nearest ", 1, true),
        ("closest ", 1, true),
        ("the first ", 1, false),
        ("the second ", 2, false),
        ("the third ", 3, false),
        ("the fourth ", 4, false),
        ("the fifth ", 5, false),
    ] {
        if let Some(i) = find_words(&t, w) {
            t = format!("{}{}", &t[..i], &t[i + w.len()..]);
            req.ordinal = Some(n);
            req.nearest = nearest;
            break;
        }
    }
    // "with a bench nearby / next to it / beside it"
    let mut trailing: Vec<Anchor> = Vec::new();
    if let Some(i) = find_words(&t, "with") {
        let rest = t[i + 4..].trim().to_string();
        for (tail, rel) in [
            (" nearby", Relation::Near),
            (" next to it", Relation::NextTo),
            (" beside it", Relation::NextTo),
            (" in front of it", Relation::InFrontOf),
            (" behind it", Relation::Behind),
            (" close by", Relation::Near),
        ] {
            if let Some(p) = rest.strip_suffix(tail) {
                trailing.push(Anchor {
                    phrase: p.trim().to_string(),
                    relation: rel,
                    distance_m: None,
                });
                t = t[..i].trim().to_string();
                break;
            }
        }
    }
    // relation split: (start, end, relation, distance)
    let mut cuts: Vec<(usize, usize, Relation, Option<f64>)> = Vec::new();
    let words: Vec<&str> = t.split(' ').collect();
    // "within N m of" / "N metres from"
    let mut offset = 0;
    for (k, w) in words.iter().enumerate() {
        let num = |s: &str| -> Option<f64> {
            let s = s.trim_end_matches('m');
            s.parse::<f64>().ok().filter(|x| x.is_finite() && *x >= 0.0)
        };
        if let Some(d) = num(w) {
            let unit_ok = w.ends_with('m')
                || words
                    .get(k + 1)
                    .is_some_and(|u| matches!(*u, "m" | "metres" | "meters" | "metre" | "meter"));
            let of_at = words
                .iter()
                .enumerate()
                .skip(k + 1)
                .take(2)
                .find(|(_, u)| matches!(**u, "of" | "from"));
            if unit_ok && let Some((j, _)) = of_at {
                let start = if k > 0 && words[k - 1] == "within" {
                    offset - "within ".len()
                } else {
                    offset
                };
                let end: usize = words[..=j].iter().map(|w| w.len() + 1).sum::<usize>() - 1;
                cuts.push((start, end, Relation::Near, Some(d)));
            }
        }
        offset += w.len() + 1;
    }
    let mut pos = 0;
    while pos < t.len() {
        let mut best: Option<(usize, usize, Relation)> = None;
        for (phrase, rel) in RELATIONS {
            if let Some(i) = find_relation(&t, pos, phrase) {
                let better = match best {
                    None => true,
                    Some((bi, be, _)) => i < bi || (i == bi && i + phrase.len() > be),
                };
                if better {
                    best = Some((i, i + phrase.len(), rel));
                }
            }
        }
        let Some((i, e, rel)) = best else { break };
        if !cuts.iter().any(|c| i < c.1 && e > c.0) {
            cuts.push((i, e, rel, None));
        }
        pos = e;
    }
    cuts.sort_by_key(|c| c.0);
    // the target needs at least one word before the first cut
    cuts.retain(|c| !strip_articles(&t[..c.0]).is_empty());
    let target_end = cuts.first().map_or(t.len(), |c| c.0);
    req.target = t[..target_end].trim().to_string();
    for (k, c) in cuts.iter().enumerate() {
        let end = cuts.get(k + 1).map_or(t.len(), |n| n.0);
        let phrase = t[c.1..end].trim();
        for part in phrase.split(" and ") {
            let part = part.trim();
            if !strip_articles(part).is_empty() {
                req.anchors.push(Anchor {
                    phrase: part.to_string(),
                    relation: c.2,
                    distance_m: c.3,
                });
            }
        }
    }
    req.anchors.extend(trailing);
    if strip_articles(&req.target).is_empty() {
        return Err(Error::Invalid(format!(
            "the request {text:?} names nothing to look for"
        )));
    }
    req.objects = objects_for_function(&req.target);
    req.attributes = req
        .target
        .split(' ')
        .filter(|w| ATTRIBUTE_WORDS.contains(w))
        .map(str::to_string)
        .collect();
    Ok(req)
}

/// Keeps only what a model's parse can point to in the request: attributes and anchor
/// phrases that occur in the text, a segment constraint only when the text has a road word
/// (crossroads, intersection, crossing, junction, bend, corner, straight), an ordinal only
/// with an ordinal word. Small models copy values from the prompt's examples; this drops them.
/// The target and the function objects are kept as given.
pub fn ground_in_text(mut r: Request, text: &str) -> Request {
    let t = normalise(text);
    let said = |p: &str| {
        let p = normalise(p);
        !p.is_empty() && t.contains(&p)
    };
    r.attributes.retain(|a| said(a));
    r.anchors.retain(|a| said(&a.phrase));
    if r.segment.is_some()
        && ![
            "crossroads",
            "intersection",
            "crossing",
            "junction",
            "bend",
            "corner",
            "straight",
        ]
        .iter()
        .any(|w| t.contains(w))
    {
        r.segment = None;
    }
    if r.ordinal.is_some()
        && ![
            "first", "second", "third", "fourth", "fifth", "nearest", "closest", "1st", "2nd",
            "3rd",
        ]
        .iter()
        .any(|w| t.split(' ').any(|x| x == *w))
    {
        r.ordinal = None;
        r.nearest = false;
    }
    r
}

/// The model's parse `r` with the fields it left empty taken from the rule parser's `rules`:
/// function objects, attributes, anchors, segment and ordinal.
pub fn fill_from(mut r: Request, rules: Request) -> Request {
    if r.objects.is_empty() {
        r.objects = rules.objects;
    }
    if r.attributes.is_empty() {
        r.attributes = rules.attributes;
    }
    if r.anchors.is_empty() {
        r.anchors = rules.anchors;
    }
    if r.segment.is_none() {
        r.segment = rules.segment;
    }
    if r.ordinal.is_none() {
        r.ordinal = rules.ordinal;
        r.nearest = rules.nearest;
    }
    if r.target.trim().is_empty() {
        r.target = rules.target;
    }
    r
}

/// Parses a request with a language model under [`request_schema`] (the answer is
/// validated against it), keeps what the text grounds ([`ground_in_text`]), fills what the
/// model left empty from the rule parser ([`fill_from`]), then checks it: a target is
/// required, distances are finite and non-negative.
///
/// # Errors
/// The model fails or answers something that is not a request.
pub fn parse_llm(model: &mut dyn ChatModel, text: &str) -> Result<Request> {
    if text.trim().is_empty() {
        return Err(Error::Invalid("the request text is empty".into()));
    }
    let req = ChatRequest::new(vec![
        Message::system(crate::prompts::PARSE_REQUEST.text),
        Message::user(text.trim()),
    ])
    .with_schema(request_schema())
    .with_max_tokens(300);
    let answer = model.chat(&req)?;
    let v = answer
        .json
        .ok_or_else(|| Error::LlmAnswer("no structured answer".into()))?;
    let r: Request =
        serde_json::from_value(v).map_err(|e| Error::LlmAnswer(format!("not a request: {e}")))?;
    let r = ground_in_text(r, text);
    // what the model left empty, the rule parser fills (when it can parse the text at all)
    let r = match parse_rules(text) {
        Ok(rules) => fill_from(r, rules),
        Err(_) => r,
    };
    if r.target.trim().is_empty() && r.objects.is_empty() {
        return Err(Error::LlmAnswer("the request names no target".into()));
    }
    if r.anchors
        .iter()
        .any(|a| a.distance_m.is_some_and(|d| !(d.is_finite() && d >= 0.0)))
    {
        return Err(Error::LlmAnswer(
            "an anchor distance is not a distance".into(),
        ));
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn anchors(r: &Request) -> Vec<(&str, Relation, Option<f64>)> {
        r.anchors
            .iter()
            .map(|a| (a.phrase.as_str(), a.relation, a.distance_m))
            .collect()
    }

    #[test]
    fn targets_anchors_and_relations() {
        let r = parse_rules("the bench near the bus stop").unwrap();
        assert_eq!(r.target, "the bench");
        assert_eq!(anchors(&r), vec![("the bus stop", Relation::Near, None)]);
        let r = parse_rules("Take me to a trash can next to a bench.").unwrap();
        assert_eq!(r.target, "a trash can");
        assert_eq!(anchors(&r), vec![("a bench", Relation::NextTo, None)]);
        let r = parse_rules("the bush under the street sign at the crossing").unwrap();
        assert_eq!(r.target, "the bush");
        assert_eq!(
            anchors(&r),
            vec![("the street sign", Relation::Under, None)]
        );
        assert_eq!(r.segment, Some(SegmentConstraint::Crossroads));
        let r = parse_rules("a car parked across the road from the bus shelter").unwrap();
        assert_eq!(r.target, "a car parked");
        assert_eq!(
            anchors(&r),
            vec![("the bus shelter", Relation::AcrossTheRoadFrom, None)]
        );
        let r = parse_rules("a bench next to a mailbox and a lamp post").unwrap();
        assert_eq!(
            anchors(&r),
            vec![
                ("a mailbox", Relation::NextTo, None),
                ("a lamp post", Relation::NextTo, None)
            ]
        );
        let r = parse_rules("a bus shelter with a bench nearby").unwrap();
        assert_eq!(r.target, "a bus shelter");
        assert_eq!(anchors(&r), vec![("a bench", Relation::Near, None)]);
        let r = parse_rules("a hydrant within 10 m of the bus stop").unwrap();
        assert_eq!(r.target, "a hydrant");
        assert_eq!(
            anchors(&r),
            vec![("the bus stop", Relation::Near, Some(10.0))]
        );
        let r = parse_rules("a tree 5 metres from the mailbox").unwrap();
        assert_eq!(
            anchors(&r),
            vec![("the mailbox", Relation::Near, Some(5.0))]
        );
    }

    #[test]
    fn segments_ordinals_attributes_and_functions() {
        let r = parse_rules("I'm at a T-junction next to a bus stop").unwrap();
        assert_eq!(r.segment, Some(SegmentConstraint::TJunction));
        let r = parse_rules("the second green wooden bench at the corner").unwrap();
        assert_eq!((r.ordinal, r.nearest), (Some(2), false));
        assert_eq!(r.segment, Some(SegmentConstraint::Junction));
        assert_eq!(r.target, "green wooden bench");
        assert_eq!(r.attributes, vec!["green", "wooden"]);
        let r = parse_rules("the nearest mailbox").unwrap();
        assert_eq!((r.ordinal, r.nearest), (Some(1), true));
        let r = parse_rules("take me to somewhere I can post a letter").unwrap();
        assert_eq!(r.objects, vec!["a mailbox"]);
        assert!(r.anchors.is_empty());
        let r = parse_rules("who could I ask for directions?").unwrap();
        assert_eq!(r.objects, vec!["a person"]);
        // a named object is not a function; a named thing keeps no objects
        assert!(parse_rules("a red car").unwrap().objects.is_empty());
        // short relation words need a determiner
        let r = parse_rules("a vehicle to sleep in on holiday").unwrap();
        assert!(r.anchors.is_empty() && r.objects == vec!["a camper van"]);
        let r = parse_rules("what lights the street at night").unwrap();
        assert!(r.anchors.is_empty() && r.objects == vec!["a street lamp"]);
        // a person in a raincoat is not an anchor
        assert!(
            parse_rules("a person in a yellow raincoat")
                .unwrap()
                .anchors
                .is_empty()
        );
    }

    #[test]
    fn empty_and_contentless_requests_are_refused() {
        assert!(parse_rules("").is_err());
        assert!(parse_rules("  ?! ").is_err());
        assert!(parse_rules("take me to the").is_err());
        // a relation word alone is a target, not an anchor with no target
        let r = parse_rules("near the bus stop").unwrap();
        assert_eq!(r.target, "near the bus stop");
    }

    #[test]
    fn model_parses_keep_only_what_the_text_says() {
        let r = Request {
            target: "the bench near the bus stop".into(),
            objects: vec![],
            attributes: vec!["green".into()],
            anchors: vec![
                Anchor {
                    phrase: "the bus stop".into(),
                    relation: Relation::Near,
                    distance_m: None,
                },
                Anchor {
                    phrase: "a tree".into(),
                    relation: Relation::Near,
                    distance_m: Some(10.0),
                },
            ],
            segment: Some(SegmentConstraint::Crossroads),
            ordinal: Some(2),
            nearest: true,
        };
        let g = ground_in_text(r.clone(), "The bench near the bus stop?");
        assert!(g.attributes.is_empty() && g.segment.is_none() && g.ordinal.is_none());
        assert_eq!(g.anchors.len(), 1);
        let g = ground_in_text(
            r,
            "the second green bench near the bus stop at the crossing",
        );
        assert_eq!(g.attributes, vec!["green"]);
        assert_eq!(
            (g.segment, g.ordinal),
            (Some(SegmentConstraint::Crossroads), Some(2))
        );
    }

    #[test]
    fn the_rule_parse_fills_what_a_model_left_empty() {
        let model = Request {
            target: "somewhere I can post a letter".into(),
            ..Request::default()
        };
        let rules = parse_rules("somewhere I can post a letter near the bus stop").unwrap();
        let r = fill_from(model, rules);
        assert_eq!(r.target, "somewhere I can post a letter");
        assert_eq!(r.objects, vec!["a mailbox"]);
        assert_eq!(r.anchors.len(), 1);
        // what the model said stays
        let model = Request {
            target: "a bench".into(),
            objects: vec!["a seat".into()],
            ..Request::default()
        };
        let r = fill_from(model, parse_rules("somewhere to sit").unwrap());
        assert_eq!(r.objects, vec!["a seat"]);
    }

    #[test]
    fn routes_split_into_start_and_goal() {
        let r = |t: &str| parse_route(t).unwrap();
        assert_eq!(
            r("From the bus stop by the crossroads to somewhere I can post a letter"),
            RouteWords {
                from: Some("the bus stop by the crossroads".into()),
                to: "somewhere i can post a letter".into()
            }
        );
        assert_eq!(
            r("take me from the bench next to the shelter to the mailbox"),
            RouteWords {
                from: Some("the bench next to the shelter".into()),
                to: "the mailbox".into()
            }
        );
        assert_eq!(
            r("take me to a bench close to a tree"),
            RouteWords {
                from: None,
                to: "a bench close to a tree".into()
            }
        );
        assert_eq!(
            r("how do I get to the T-junction from lane:3"),
            RouteWords {
                from: Some("lane:3".into()),
                to: "the t-junction".into()
            }
        );
        assert!(parse_route("from the bench").is_err());
        assert!(parse_route("take me to the").is_err());
        assert!(parse_route("").is_err());
    }

    #[test]
    fn the_schema_accepts_what_the_rule_parser_makes() {
        let schema = request_schema();
        for text in [
            "the bench near the bus stop",
            "the second bench at the T-junction within 5 m of a mailbox",
            "somewhere to sit",
        ] {
            let v = serde_json::to_value(parse_rules(text).unwrap()).unwrap();
            crate::chat::validate(&v, &schema).unwrap();
        }
    }
}
