//! Questions about a map as one task: "How many post boxes are there?", "What is the nearest
//! bench to the start of the drive?", "How far is the bus shelter from the post box?", "How
//! long is the route from A to B?", "Which segment is the fire hydrant in?", "What colour is
//! the car by the T-junction?". [`parse_question`] is the rule parser; a language model fills
//! the same [`Task`] (its JSON Schema, [`task_schema`], is the model's grammar).

use super::{SegmentConstraint, parse_route, take_segment};

/// One question as a task the service answers with its tools.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(tag = "task", rename_all = "snake_case", deny_unknown_fields)]
pub enum Task {
    /// How many objects of a kind: on the map, in a segment (`within`) or near a place.
    Count {
        /// The kind ("post box", "trees").
        kind: String,
        /// A road segment in words ("the T-junction").
        #[serde(default, skip_serializing_if = "Option::is_none")]
        within: Option<String>,
        /// A place the count is around.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        near: Option<String>,
        /// The radius around `near`, metres.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        radius_m: Option<f64>,
    },
    /// How many road segments of a kind (crossroads, t_junction, bend, straight_road,
    /// junction), or all segments without one.
    CountSegments {
        /// The kind, as [`SegmentConstraint`] names it; None for every segment.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        segment_kind: Option<SegmentConstraint>,
    },
    /// The object of a kind nearest a place.
    Nearest {
        /// The kind.
        kind: String,
        /// The place, in words.
        near: String,
    },
    /// The ground-plane distance between two places.
    Distance {
        /// One place.
        from: String,
        /// The other.
        to: String,
    },
    /// The length of the route between two places.
    RouteLength {
        /// The start.
        from: String,
        /// The goal.
        to: String,
    },
    /// The road segment an object is in (its id and kind).
    Segment {
        /// The object, in words.
        object: String,
    },
    /// An object's colour.
    Colour {
        /// The object, in words.
        object: String,
    },
    /// What stands around an object.
    Neighbours {
        /// The object, in words.
        object: String,
    },
    /// Where someone is, from a description of the surroundings.
    Locate {
        /// The description.
        text: String,
    },
    /// An object in words ("where is the red car?").
    Find {
        /// The request.
        text: String,
    },
}

/// The flat form a language model fills (keys in the grammar's order, every key present):
/// `action` names the task, the other keys its arguments ([`TaskForm::into_task`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TaskForm {
    /// The task's name (`count`, `nearest`, ...).
    pub action: String,
    /// The kind of object ("" when none).
    pub kind: String,
    /// The (first) place or the object ("" when none).
    pub place: String,
    /// A radius in metres.
    pub radius_m: Option<f64>,
    /// A segment kind for `count_segments`.
    pub segment_kind: Option<SegmentConstraint>,
    /// The second place ("" when none).
    pub to: String,
}

/// The JSON Schema of [`TaskForm`], the model's grammar.
pub fn task_form_schema() -> serde_json::Value {
    let segments = super::segment_enum();
    serde_json::json!({
        "type": "object",
        "properties": {
            "action": {"enum": ["count", "count_segments", "nearest", "distance", "route_length",
                "segment", "colour", "neighbours", "locate", "find"]},
            "kind": {"type": "string", "maxLength": 80},
            "place": {"type": "string", "maxLength": 200},
            "radius_m": {"type": ["number", "null"]},
            "segment_kind": {"enum": segments},
            "to": {"type": "string", "maxLength": 200}
        },
        "required": ["action", "kind", "place", "radius_m", "segment_kind", "to"],
        "additionalProperties": false
    })
}

impl TaskForm {
    /// The task the form names; the question fills a locate's text.
    ///
    /// # Errors
    /// A task without the arguments it needs (a count without a kind, a distance without
    /// two places), as a message.
    pub fn into_task(self, question: &str) -> std::result::Result<Task, String> {
        let need = |v: &str, what: &str| {
            if v.trim().is_empty() {
                Err(format!("{} needs {what}", self.action))
            } else {
                Ok(v.trim().to_string())
            }
        };
        let opt = |v: &str| (!v.trim().is_empty()).then(|| v.trim().to_string());
        Ok(match self.action.as_str() {
            "count" => {
                let place = opt(&self.place);
                let radius = self.radius_m.filter(|r| r.is_finite() && *r >= 0.0);
                let (within, near) = if radius.is_some() {
                    (None, place)
                } else {
                    (place, None)
                };
                Task::Count {
                    kind: need(&self.kind, "a kind")?,
                    within,
                    near,
                    radius_m: radius,
                }
            }
            "count_segments" => Task::CountSegments {
                segment_kind: self.segment_kind,
            },
            "nearest" => Task::Nearest {
                kind: need(&self.kind, "a kind")?,
                near: need(&self.place, "a place")?,
            },
            "distance" => Task::Distance {
                from: need(&self.place, "a place")?,
                to: need(&self.to, "a second place")?,
            },
            "route_length" => Task::RouteLength {
                from: need(&self.place, "a start")?,
                to: need(&self.to, "a goal")?,
            },
            "segment" => Task::Segment {
                object: need(&self.place, "an object")?,
            },
            "colour" => Task::Colour {
                object: need(&self.place, "an object")?,
            },
            "neighbours" => Task::Neighbours {
                object: need(&self.place, "an object")?,
            },
            "locate" => Task::Locate {
                text: question.trim().to_string(),
            },
            "find" => Task::Find {
                text: need(&self.place, "an object")?,
            },
            other => return Err(format!("unknown action {other:?}")),
        })
    }
}

/// The JSON Schema of [`Task`] (draft 2020-12), a model's grammar.
pub fn task_schema() -> serde_json::Value {
    serde_json::to_value(schemars::schema_for!(Task)).unwrap_or_default()
}

/// Words that open a question and say nothing of its task.
const POLITE: [&str; 8] = [
    "please ",
    "can you tell me ",
    "could you tell me ",
    "tell me ",
    "do you know ",
    "i'd like to know ",
    "i want to know ",
    "quick question: ",
];

/// Lower case, straight quotes, no question marks, one space between words; commas and
/// points stay (they are in specs such as "12.5,-3").
fn clean(text: &str) -> String {
    let t = text
        .to_lowercase()
        .replace(['’', '‘'], "'")
        .replace(['?', '!', ';', '"'], " ");
    let t = t.split_whitespace().collect::<Vec<_>>().join(" ");
    t.trim_end_matches(['.', ',']).trim().to_string()
}

/// Words around a segment kind in a count that say nothing more ("how many crossroads does
/// the map have").
const COUNT_FILLER: [&str; 16] = [
    "are", "is", "there", "does", "do", "the", "map", "have", "has", "in", "on", "exist", "we",
    "it", "city", "total",
];

/// Trims articles and filler from the ends of a phrase.
fn phrase(s: &str) -> String {
    let mut t = s
        .trim()
        .trim_matches(|c: char| c == ',' || c == '?' || c == '.')
        .trim();
    loop {
        let before = t.len();
        for lead in ["is ", "are ", "there ", "located "] {
            t = t.strip_prefix(lead).unwrap_or(t).trim();
        }
        for tail in [
            " located",
            " situated",
            " standing",
            " placed",
            " in total",
            " altogether",
            " on the map",
            " in the map",
            " does the map have",
            " does the city have",
            " do we have",
            " have",
            " is",
            " are",
            " there",
        ] {
            t = t.strip_suffix(tail).unwrap_or(t).trim();
        }
        if t.len() == before {
            return t.to_string();
        }
    }
}

/// Splits at the first of `seps` (word-bounded; the longest of those at one place); (before,
/// after).
fn split_at<'a>(t: &'a str, seps: &[&str]) -> Option<(&'a str, &'a str)> {
    seps.iter()
        .filter_map(|s| {
            let pat = format!(" {s} ");
            t.find(&pat).map(|i| (i, std::cmp::Reverse(pat.len())))
        })
        .min()
        .map(|(i, n)| (&t[..i], &t[i + n.0..]))
}

/// A number of metres in "within 50 m of", "in 30 metres of"; (radius, place).
fn radius_of(t: &str) -> Option<(f64, String)> {
    let w: Vec<&str> = t.split_whitespace().collect();
    for i in 0..w.len() {
        if !matches!(w[i], "within" | "in") {
            continue;
        }
        let num = w.get(i + 1)?;
        let (n, unit_next) = match num.strip_suffix('m') {
            Some(n) if !n.is_empty() => (n, false),
            _ => (*num, true),
        };
        let Ok(r) = n.parse::<f64>() else { continue };
        let mut j = i + 2;
        if unit_next {
            if !matches!(
                w.get(j).copied(),
                Some("m" | "metres" | "meters" | "metre" | "meter")
            ) {
                continue;
            }
            j += 1;
        }
        if matches!(w.get(j).copied(), Some("of" | "from" | "around")) {
            j += 1;
        }
        let place = w[j..].join(" ");
        if r.is_finite() && r >= 0.0 && !place.is_empty() {
            return Some((r, phrase(&place)));
        }
    }
    None
}

/// What a "how many" question counts: segments of a kind, or objects of a kind with an area.
fn count_task(rest: &str) -> Option<Task> {
    let rest = rest.trim();
    // "how many road segments", "how many T-junctions are there": segment words in the
    // singular the segment phrases are written in
    let mut singular = format!(" {rest} ");
    for (plural, one) in [
        (" t-junctions ", " t-junction "),
        (" t junctions ", " t-junction "),
        (" t-intersections ", " t-intersection "),
        (" l-bends ", " bend "),
        (" bends ", " bend "),
        (" intersections ", " intersection "),
        (" straight roads ", " straight road "),
        (" junctions ", " corner "),
        (" crossings ", " crossing "),
    ] {
        singular = singular.replace(plural, one);
    }
    let (seg, left) = take_segment(singular.trim());
    let left_words = phrase(&left);
    let segmentish = |w: &str| {
        matches!(
            w,
            "" | "s" | "es" | "road segments" | "segments" | "segment" | "corner" | "four-way"
        )
    };
    let only_filler = left_words
        .split_whitespace()
        .all(|w| COUNT_FILLER.contains(&w) || segmentish(w));
    if let Some(kind) = seg
        && (segmentish(&left_words) || only_filler)
    {
        return Some(Task::CountSegments {
            segment_kind: Some(kind),
        });
    }
    if matches!(
        phrase(rest).as_str(),
        "road segments" | "segments" | "segments of road" | "parts of road"
    ) {
        return Some(Task::CountSegments { segment_kind: None });
    }
    if let Some((r, place)) = radius_of(rest) {
        let kind = rest.split(" within ").next().unwrap_or(rest);
        let kind = kind.split(" in ").next().unwrap_or(kind);
        return Some(Task::Count {
            kind: phrase(kind),
            within: None,
            near: Some(place),
            radius_m: Some(r),
        });
    }
    if let Some((kind, place)) = split_at(
        rest,
        &[
            "are there in",
            "are there at",
            "are there on",
            "are in",
            "are at",
            "are on",
            "in",
            "at",
            "on",
        ],
    ) {
        let place = phrase(place);
        if !matches!(
            place.as_str(),
            "the map" | "map" | "total" | "the city" | "all"
        ) {
            return Some(Task::Count {
                kind: phrase(kind),
                within: Some(place),
                near: None,
                radius_m: None,
            });
        }
        return Some(Task::Count {
            kind: phrase(kind),
            within: None,
            near: None,
            radius_m: None,
        });
    }
    if let Some((kind, place)) = split_at(rest, &["are there near", "are near", "near", "around"]) {
        return Some(Task::Count {
            kind: phrase(kind),
            within: None,
            near: Some(phrase(place)),
            radius_m: None,
        });
    }
    let kind = phrase(rest);
    (!kind.is_empty()).then_some(Task::Count {
        kind,
        within: None,
        near: None,
        radius_m: None,
    })
}

/// The rule parser: one task for the common question forms, or `None`.
pub fn parse_question(text: &str) -> Option<Task> {
    let mut t = clean(text);
    for p in POLITE {
        if let Some(r) = t.strip_prefix(p) {
            t = r.to_string();
        }
    }
    let t = t.trim();
    if t.is_empty() {
        return None;
    }
    // where am I
    if t.starts_with("where am i") || t.starts_with("i'm at") || t.starts_with("i am at") {
        return Some(Task::Locate {
            text: text.trim().to_string(),
        });
    }
    // counts
    for lead in [
        "how many ",
        "count the ",
        "count ",
        "number of ",
        "what is the number of ",
    ] {
        if let Some(rest) = t.strip_prefix(lead) {
            return count_task(rest);
        }
    }
    // route lengths
    for lead in [
        "how long is the route ",
        "how long is the drive ",
        "how long is the way ",
        "how far is it to drive ",
        "how far do i drive ",
        "how far would i drive ",
        "what is the route length ",
        "what is the length of the route ",
        "what is the driving distance ",
        "route length ",
        "driving distance ",
    ] {
        if let Some(rest) = t.strip_prefix(lead) {
            let rest = rest
                .strip_prefix("between ")
                .map_or_else(|| rest.to_string(), |r| r.replacen(" and ", " to ", 1));
            let rest = if rest.starts_with("from ") || rest.starts_with("to ") {
                rest
            } else {
                format!("from {rest}")
            };
            let w = parse_route(&rest).ok()?;
            return Some(Task::RouteLength {
                from: phrase(&w.from?),
                to: phrase(&w.to),
            });
        }
    }
    // distances
    for lead in [
        "what is the distance between ",
        "what's the distance between ",
        "distance between ",
        "how far apart are ",
    ] {
        if let Some(rest) = t.strip_prefix(lead)
            && let Some((a, b)) = split_at(rest, &["and"])
        {
            return Some(Task::Distance {
                from: phrase(a),
                to: phrase(b),
            });
        }
    }
    for lead in ["how far is ", "how far away is ", "how far are "] {
        if let Some(rest) = t.strip_prefix(lead)
            && let Some((a, b)) = split_at(rest, &["from", "away from", "to"])
        {
            return Some(Task::Distance {
                from: phrase(a),
                to: phrase(b),
            });
        }
    }
    // nearest
    for lead in [
        "what is the nearest ",
        "what's the nearest ",
        "which is the nearest ",
        "where is the nearest ",
        "where's the nearest ",
        "find the nearest ",
        "the nearest ",
        "nearest ",
        "what is the closest ",
        "what's the closest ",
        "which is the closest ",
        "where is the closest ",
        "find the closest ",
        "the closest ",
        "closest ",
        "which ",
        "what ",
    ] {
        let Some(rest) = t.strip_prefix(lead) else {
            continue;
        };
        let seps = [
            "is nearest to",
            "is closest to",
            "is nearest",
            "is closest",
            "to",
            "from",
            "near",
        ];
        // "which bench is nearest to X" needs the superlative
        let superlative = rest.contains(" nearest") || rest.contains(" closest");
        if matches!(lead, "which " | "what ") && !superlative {
            continue;
        }
        if let Some((kind, place)) = split_at(rest, &seps) {
            return Some(Task::Nearest {
                kind: phrase(kind),
                near: phrase(place),
            });
        }
    }
    // the segment an object is in
    for lead in [
        "which segment is ",
        "which road segment is ",
        "what segment is ",
        "which segment contains ",
        "what kind of junction is ",
        "what kind of road segment is ",
        "what kind of segment is ",
        "what type of junction is ",
        "what type of segment is ",
        "what kind of place is ",
        "which junction is ",
    ] {
        if let Some(rest) = t.strip_prefix(lead) {
            let rest = rest
                .trim_end_matches(" in")
                .trim_end_matches(" at")
                .trim_end_matches(" on");
            return Some(Task::Segment {
                object: phrase(rest),
            });
        }
    }
    for lead in [
        "what colour is ",
        "what color is ",
        "what colour are ",
        "what color are ",
    ] {
        if let Some(rest) = t.strip_prefix(lead) {
            return Some(Task::Colour {
                object: phrase(rest),
            });
        }
    }
    for lead in [
        "what is next to ",
        "what's next to ",
        "what is around ",
        "what's around ",
        "what stands around ",
        "what is near ",
        "what's near ",
        "what is beside ",
    ] {
        if let Some(rest) = t.strip_prefix(lead) {
            return Some(Task::Neighbours {
                object: phrase(rest),
            });
        }
    }
    for lead in ["where is ", "where's ", "where are ", "find ", "show me "] {
        if let Some(rest) = t.strip_prefix(lead) {
            return Some(Task::Find { text: phrase(rest) });
        }
    }
    if let Some((a, b)) = t
        .split_once(" is ")
        .filter(|(a, _)| a.starts_with("in which segment") || a.starts_with("in what segment"))
    {
        let _ = a;
        return Some(Task::Segment { object: phrase(b) });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(kind: &str, within: Option<&str>, near: Option<&str>, r: Option<f64>) -> Task {
        Task::Count {
            kind: kind.into(),
            within: within.map(Into::into),
            near: near.map(Into::into),
            radius_m: r,
        }
    }

    #[test]
    fn common_question_forms_are_one_task_each() {
        let cases: Vec<(&str, Task)> = vec![
            (
                "How many post boxes are there?",
                count("post boxes", None, None, None),
            ),
            (
                "How many trees are on the map?",
                count("trees", None, None, None),
            ),
            (
                "How many benches are there at the T-junction?",
                count("benches", Some("the t-junction"), None, None),
            ),
            (
                "How many cars are within 30 m of the start of the drive?",
                count("cars", None, Some("the start of the drive"), Some(30.0)),
            ),
            (
                "How many T-junctions are there?",
                Task::CountSegments {
                    segment_kind: Some(SegmentConstraint::TJunction),
                },
            ),
            (
                "How many crossroads does the map have?",
                Task::CountSegments {
                    segment_kind: Some(SegmentConstraint::Crossroads),
                },
            ),
            (
                "What is the nearest bench to the start of the drive?",
                Task::Nearest {
                    kind: "bench".into(),
                    near: "the start of the drive".into(),
                },
            ),
            (
                "Which fire hydrant is closest to the bus shelter?",
                Task::Nearest {
                    kind: "fire hydrant".into(),
                    near: "the bus shelter".into(),
                },
            ),
            (
                "How far is the post box from the bus shelter?",
                Task::Distance {
                    from: "the post box".into(),
                    to: "the bus shelter".into(),
                },
            ),
            (
                "What is the distance between instance:12 and segment:40?",
                Task::Distance {
                    from: "instance:12".into(),
                    to: "segment:40".into(),
                },
            ),
            (
                "How long is the route from the start of the drive to the T-junction?",
                Task::RouteLength {
                    from: "the start of the drive".into(),
                    to: "the t-junction".into(),
                },
            ),
            (
                "Which segment is the fire hydrant in?",
                Task::Segment {
                    object: "the fire hydrant".into(),
                },
            ),
            (
                "What colour is the car near the bus stop?",
                Task::Colour {
                    object: "the car near the bus stop".into(),
                },
            ),
            (
                "What is next to the post box?",
                Task::Neighbours {
                    object: "the post box".into(),
                },
            ),
        ];
        for (q, want) in cases {
            assert_eq!(parse_question(q), Some(want), "{q}");
        }
        assert_eq!(parse_question("  "), None);
        assert_eq!(parse_question("Tell me a joke"), None);
    }

    #[test]
    fn the_task_schema_names_every_task() {
        let s = task_schema().to_string();
        for t in [
            "count",
            "count_segments",
            "nearest",
            "distance",
            "route_length",
            "segment",
            "colour",
            "neighbours",
            "locate",
            "find",
        ] {
            assert!(s.contains(&format!("\"{t}\"")), "{t}");
        }
    }
}
