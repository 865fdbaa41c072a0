//! Understanding a request: one structured form ([`Request`]) for what a natural-language
//! request about the map asks (the target and its attributes, anchors with a spatial relation,
//! a road-segment constraint, an ordinal), filled by a deterministic rule parser for common
//! English ([`parse_rules`]) or by a language model under a JSON Schema ([`parse_llm`]).

use crate::chat::{ChatModel, ChatRequest, Message};
use crate::error::{Error, Result};

mod llm;
mod places;
pub mod question;
mod route;
mod rules;
pub use llm::*;
pub use places::*;
pub use route::*;
pub use rules::*;

/// A spatial relation between the target and an anchor.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
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
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
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
#[derive(
    Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
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

/// The values a model may give for a segment constraint: every [`SegmentConstraint`] by
/// name, and null.
pub(crate) fn segment_enum() -> Vec<serde_json::Value> {
    SegmentConstraint::ALL
        .iter()
        .map(|s| serde_json::Value::from(s.as_str()))
        .chain([serde_json::Value::Null])
        .collect()
}

/// The JSON Schema of [`Request`] (draft 2020-12), as the language model fills it.
pub fn request_schema() -> serde_json::Value {
    let relations: Vec<&str> = Relation::ALL.iter().map(|r| r.as_str()).collect();
    let segments = segment_enum();
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
        assert!(r.anchors.is_empty());
        // a superlative after the target names the place to measure from
        for (text, target, place) in [
            (
                "the fire hydrant nearest the start of the drive",
                "the fire hydrant",
                "the start of the drive",
            ),
            (
                "the bench that is closest to the bus shelter",
                "the bench",
                "the bus shelter",
            ),
            (
                "which bin is nearest to the post box",
                "bin",
                "the post box",
            ),
        ] {
            let r = parse_rules(text).unwrap();
            assert_eq!((r.ordinal, r.nearest), (Some(1), true), "{text}");
            assert_eq!(r.target, target, "{text}");
            assert_eq!(anchors(&r), vec![(place, Relation::Near, None)], "{text}");
        }
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
    fn degree_words_and_distances_in_steps_belong_to_the_relation() {
        let r = parse_rules("the trash can right beside a city bike").unwrap();
        assert_eq!(r.target, "the trash can");
        assert_eq!(r.anchors[0].phrase, "a city bike");
        assert_eq!(r.anchors[0].relation, Relation::NextTo);
        let r = parse_rules("a lamp post a few steps from the covered bus stop").unwrap();
        assert_eq!(r.target, "a lamp post");
        assert_eq!(r.anchors[0].phrase, "the covered bus stop");
        assert_eq!(r.anchors[0].relation, Relation::Near);
        // "right" alone is not a degree word of a relation
        let r = parse_rules("the bench to the right of the bin").unwrap();
        assert_eq!(r.anchors[0].relation, Relation::RightOf);
        // the crown gives shade; goods go by truck
        assert_eq!(
            parse_rules("something that gives shade").unwrap().objects,
            vec!["a tree canopy"]
        );
        assert_eq!(
            parse_rules("something that carries goods by road")
                .unwrap()
                .objects,
            vec!["a truck"]
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
    fn a_function_word_inside_an_objects_name_names_no_function() {
        let objects = |t: &str| parse_rules(t).unwrap().objects;
        assert!(objects("the round red-and-white speed limit sign facing the traffic").is_empty());
        assert!(objects("the green rubbish bin").is_empty());
        assert_eq!(objects("somewhere I can post a letter"), ["a mailbox"]);
        assert_eq!(objects("somewhere to throw away rubbish"), ["a trash can"]);
        assert_eq!(
            objects("a sign that shows the speed limit"),
            ["a traffic sign"]
        );
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
