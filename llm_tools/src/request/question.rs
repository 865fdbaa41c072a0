//! Questions about a map as one task: "How many post boxes are there?", "What is the nearest
//! bench to the start of the drive?", "How far is the bus shelter from the post box?", "How
//! long is the route from A to B?", "Which segment is the fire hydrant in?", "What colour is
//! the car by the T-junction?". [`parse_question`] is the rule parser; a language model fills
//! the same [`Task`] (its JSON Schema, [`task_schema`], is the model's grammar).

use super::{SegmentConstraint, take_segment};

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
        /// More kinds counted with `segment_kind` ("crossroads or T-junctions": a segment
        /// counts when it is of any of them).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        or_kinds: Vec<SegmentConstraint>,
        /// Only the segments holding at least one object of this kind, in words ("how many
        /// segments have a fire hydrant"; an object is in the segment its `IN_SEGMENT` names).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        holding: Option<String>,
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

impl Task {
    /// A count of the road segments of `kind` (every segment with `None`), nothing more said.
    pub fn count_segments(kind: Option<SegmentConstraint>) -> Task {
        Task::count_segments_of(kind.into_iter().collect(), None)
    }

    /// A count of the road segments of any of `kinds` (every segment when empty), only those
    /// holding an object of the kind `holding` when given.
    pub fn count_segments_of(kinds: Vec<SegmentConstraint>, holding: Option<String>) -> Task {
        let mut kinds = kinds.into_iter();
        Task::CountSegments {
            segment_kind: kinds.next(),
            or_kinds: kinds.collect(),
            holding,
        }
    }
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
            // a kind that is no kind of road is what the segments hold ("segments with a
            // hydrant"); the form has one segment kind, so a union comes from the rules
            "count_segments" => Task::CountSegments {
                segment_kind: self.segment_kind,
                or_kinds: Vec::new(),
                holding: opt(&self.kind).filter(|k| !names_segments(k)),
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
const POLITE: [&str; 50] = [
    "please ",
    "confirm ",
    "verify ",
    "double-check ",
    "determine ",
    "state ",
    "identify ",
    "calculate ",
    "work out ",
    "find out ",
    "establish ",
    "given ",
    "roughly ",
    "approximately ",
    "about ",
    "would you happen to know ",
    "do you happen to know ",
    "happen to know ",
    "return ",
    "output ",
    "compute ",
    "report ",
    "give me ",
    "the node id of ",
    "the object id of ",
    "the instance id of ",
    "okay ",
    "ok ",
    "so ",
    "well ",
    "alright ",
    "right ",
    "can you tell me ",
    "could you tell me ",
    "can you please tell me ",
    "could you please tell me ",
    "would you tell me ",
    "tell me ",
    "do you know ",
    "i'd like to know ",
    "i would like to know ",
    "i want to know ",
    "i wonder ",
    "can you please ",
    "could you please ",
    "can you ",
    "could you ",
    "would you ",
    "kindly ",
    "hey ",
];

/// Lower case, straight quotes, no question marks, one space between words; commas and
/// points stay (they are in specs such as "12.5,-3").
fn clean(text: &str) -> String {
    let t = text
        .to_lowercase()
        .replace(['’', '‘'], "'")
        .replace(['?', '!', ';', '"'], " ");
    let t = t
        .split_whitespace()
        .map(|w| {
            // a texting form of a function word, with any comma kept
            let (word, comma) = w.strip_suffix(',').map_or((w, ""), |x| (x, ","));
            match TEXTING.iter().find(|(short, _)| *short == word) {
                Some((_, full)) => format!("{full}{comma}"),
                None => w.to_string(),
            }
        })
        .collect::<Vec<_>>()
        .join(" ");
    t.trim_end_matches(['.', ',']).trim().to_string()
}

/// Texting forms and slips of function words, read as the words they stand for: a person
/// typing on a phone writes "hw many r there", "wat kind", "teh map". Only words that are
/// never a name, a kind or a place on a map are here.
const TEXTING: [(&str, &str); 14] = [
    ("teh", "the"),
    ("hw", "how"),
    ("wat", "what"),
    ("wht", "what"),
    ("u", "you"),
    ("ur", "your"),
    ("r", "are"),
    ("pls", "please"),
    ("plz", "please"),
    ("rn", "right now"),
    ("thx", "thanks"),
    ("abt", "about"),
    ("flys", "flies"),
    ("thru", "through"),
];

/// The position of `phrase` in `t` at word boundaries (a word is anything between spaces,
/// commas and the ends).
fn at_words(t: &str, phrase: &str) -> Option<usize> {
    let bytes = t.as_bytes();
    let mut from = 0;
    while let Some(i) = t[from..].find(phrase).map(|i| i + from) {
        let end = i + phrase.len();
        let left = i == 0 || matches!(bytes[i - 1], b' ' | b',' | b'(' | b'-');
        let right = end == t.len() || matches!(bytes[end], b' ' | b',' | b')' | b':' | b'.');
        if left && right {
            return Some(i);
        }
        from = i + 1;
    }
    None
}

fn has(t: &str, phrase: &str) -> bool {
    at_words(t, phrase).is_some()
}

fn has_any(t: &str, phrases: &[&str]) -> bool {
    phrases.iter().any(|p| has(t, p))
}

/// Words off both ends of a phrase while they are in `front` / `back` or [`FILLER`].
fn trim_words(s: &str, front: &[&str], back: &[&str]) -> String {
    trim_with(s, front, back, true)
}

/// [`trim_words`], but an article in `front` goes only with the cue word after it ("what
/// is the distance between ..." loses "the", "the bench" keeps it).
fn trim_keep(s: &str, front: &[&str], back: &[&str]) -> String {
    trim_with(s, front, back, false)
}

fn trim_with(s: &str, front: &[&str], back: &[&str], articles_free: bool) -> String {
    // words keep their commas (a comma ends a place); they are compared without them
    let s = s.replace(" ,", ",");
    let mut w: Vec<&str> = s
        .split(' ')
        .filter(|w| !w.is_empty() && !matches!(*w, "-" | ":" | ","))
        .collect();
    let key = |x: &str| x.trim_matches(',').to_string();
    let article = |x: &str| matches!(x, "the" | "a" | "an");
    loop {
        let n = w.len();
        while let Some(x) = w.first().map(|x| key(x)) {
            let drop = if article(&x) && !articles_free {
                front.contains(&x.as_str())
                    && w.get(1).is_some_and(|y| {
                        let y = key(y);
                        front.contains(&y.as_str()) && !article(&y)
                    })
            } else {
                front.contains(&x.as_str()) || FILLER.contains(&x.as_str())
            };
            if !drop {
                break;
            }
            w.remove(0);
        }
        while let Some(x) = w.last().map(|x| key(x)) {
            if !(back.contains(&x.as_str()) || FILLER.contains(&x.as_str())) {
                break;
            }
            w.pop();
        }
        if w.len() == n {
            break;
        }
    }
    w.join(" ").trim_end_matches(',').to_string()
}

/// Words at either end of a phrase that never belong to what it names.
const FILLER: [&str; 24] = [
    "please",
    "mapped",
    "recorded",
    "detected",
    "visible",
    "shown",
    "seen",
    "listed",
    "total",
    "altogether",
    "overall",
    "exactly",
    "currently",
    "now",
    "so",
    "if",
    "then",
    "and",
    "well",
    "also",
    "again",
    "for",
    "me",
    "us",
];

/// Verbs and auxiliaries that end the phrase a question counts or asks about ("how many
/// cars are parked ...", "which segment does X belong to").
const VERBS: [&str; 38] = [
    "are",
    "is",
    "was",
    "were",
    "be",
    "does",
    "do",
    "did",
    "has",
    "have",
    "had",
    "got",
    "can",
    "could",
    "will",
    "would",
    "lie",
    "lies",
    "stand",
    "stands",
    "standing",
    "sit",
    "sits",
    "sitting",
    "exist",
    "exists",
    "appear",
    "appears",
    "parked",
    "located",
    "situated",
    "placed",
    "positioned",
    "found",
    "contain",
    "contains",
    "belong",
    "belongs",
];

/// Prepositions that open the place part of a question.
const PLACE_PREPS: [&str; 14] = [
    "in",
    "on",
    "at",
    "inside",
    "within",
    "along",
    "across",
    "around",
    "near",
    "by",
    "beside",
    "throughout",
    "over",
    "of",
];

/// Places that mean the whole map.
const WHOLE_MAP: [&str; 20] = [
    "map",
    "neighbourhood",
    "neighborhood",
    "district",
    "mapped",
    "city",
    "town",
    "area",
    "world",
    "network",
    "road network",
    "roads",
    "streets",
    "everywhere",
    "dataset",
    "scene",
    "region",
    "graph",
    "drive",
    "survey",
];

/// Whether a place phrase means the whole map ("the map", "this city", "the whole town",
/// "the roads of this city").
fn whole_map(place: &str) -> bool {
    let p = trim_words(
        place,
        &[
            "the",
            "this",
            "our",
            "my",
            "your",
            "whole",
            "entire",
            "full",
            "complete",
            "all",
            "of",
            "in",
            "on",
            "across",
            "around",
            "throughout",
            "over",
        ],
        &[],
    );
    if p.is_empty() {
        return true;
    }
    let words: Vec<&str> = p.split(' ').collect();
    words.iter().all(|w| {
        WHOLE_MAP.contains(w)
            || matches!(
                *w,
                "the"
                    | "this"
                    | "of"
                    | "whole"
                    | "entire"
                    | "all"
                    | "in"
                    | "road"
                    | "contains"
                    | "contain"
                    | "has"
                    | "have"
                    | "got"
                    | "shows"
                    | "holds"
                    | "its"
                    | "entirety"
                    | "altogether"
                    | "overall"
                    | "as"
                    | "a"
                    | "told"
                    | "extent"
                    | "study"
            )
    })
}

/// A question made ready for the rules: its question sentence with references to the
/// sentences around it filled in, and the whole text.
struct Prepared {
    /// The sentence that asks, its "it", "that truck" or "that segment" replaced by what the
    /// other sentences said (or a bare follow-up, "if so, how many", joined with them).
    question: String,
    /// Every sentence, the question first.
    whole: String,
    /// The sentences around the question (empty for one sentence).
    context: String,
}

/// Whom a radio or phone call is addressed to ("control, how many ...").
const CALLED: [&str; 9] = [
    "control", "base", "dispatch", "hq", "ops", "operator", "team", "robot", "computer",
];

/// Short forms people type ("seg 12", "dist", "@ the corner").
const SHORT_FORMS: [(&str, &str); 31] = [
    ("lil", "little"),
    // texting: apostrophes left out, words run together
    ("im", "i am"),
    ("theres", "there is"),
    ("wheres", "where is"),
    ("whats", "what is"),
    ("gimme", "give me"),
    // field notes
    ("excl.", "excluding"),
    ("incl.", "including"),
    ("dist.", "distance"),
    ("ref.", "reference"),
    ("seg", "segment"),
    ("hw", "how"),
    ("r", "are"),
    ("u", "you"),
    ("pls", "please"),
    ("plz", "please"),
    ("w/in", "within"),
    ("rd", "road"),
    ("obj", "object"),
    ("4-way", "four-way"),
    ("segs", "segments"),
    ("dist", "distance"),
    ("len", "length"),
    ("pos", "position"),
    ("@", "at"),
    ("w/", "with"),
    ("approx", "approximately"),
    ("nr", "number"),
    ("no.", "number"),
    ("qty", "number"),
    ("num", "number"),
];

/// The question with what says nothing of its task taken off: polite openings, remarks in
/// parentheses, short forms spelt out, and several sentences read as one question
/// ([`Prepared`]: "Are there any pedestrians in segment 4? If so, how many?"; "There's one
/// hydrant at a bend. What colour is it?": "it" is the hydrant at a bend; "operator query:
/// ..." is a sentence that asks nothing).
/// Radio procedure says who is talking to whom and when a turn ends, never what is asked:
/// a sentence made only of call signs and procedure words ("Rover Three to Base.", "Base,
/// this is Unit 7.", "Unit 4 to Base:", "Over.") is dropped, and so is a last clause of
/// "over" or "over and out" after a comma. A sentence with any other word stays whole.
/// The text without the discourse markers that open a sentence ("okay, so in segment 12, how
/// many bins?", "Well, which segment is it in? Alright, and how far ..."): they say nothing,
/// and a place said first must start its sentence to be read as the question's place.
/// "right" and "now" count only with a comma after them ("right next to", "now at lane 3").
fn drop_leading_markers(t: &str) -> String {
    let mut out: Vec<&str> = Vec::new();
    let mut at_start = true;
    for w in t.split(' ') {
        let bare = w.trim_end_matches([',', '.', '?', '!']);
        let marker = matches!(
            bare,
            "okay" | "ok" | "so" | "well" | "alright" | "oh" | "anyway" | "and" | "also"
        ) || (matches!(bare, "right" | "now") && w.ends_with(','));
        if at_start && marker && !w.ends_with(['.', '?', '!']) {
            continue;
        }
        at_start = w.ends_with(['.', '?', '!']) || w.is_empty() && at_start;
        out.push(w);
    }
    out.join(" ")
}

fn drop_radio_procedure(t: &str) -> String {
    const PROCEDURE: &[&str] = &[
        "base", "control", "dispatch", "hq", "ops", "command", "unit", "rover", "team", "this",
        "is", "to", "again", "here", "over", "out", "roger", "copy", "calling", "and", "one",
        "two", "three", "four", "five", "six", "seven", "eight", "nine", "niner", "ten", "zero",
    ];
    let procedural = |sentence: &str| {
        let words: Vec<&str> = sentence
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|w| !w.is_empty())
            .collect();
        // a sentence of radio words that names a station ("base", "unit"), or is "over"
        words.iter().any(|w| {
            matches!(
                *w,
                "base" | "control" | "dispatch" | "hq" | "unit" | "rover" | "over" | "roger"
            )
        }) && words
            .iter()
            .all(|w| PROCEDURE.contains(w) || w.chars().all(|c| c.is_ascii_digit()))
    };
    // sentences end at . : ! ? followed by a space or the end (not inside "2.5" or "no.5")
    let mut out = String::new();
    let mut start = 0;
    let b = t.as_bytes();
    for i in 0..b.len() {
        let end =
            matches!(b[i], b'.' | b':' | b'!' | b'?') && b.get(i + 1).is_none_or(|c| *c == b' ');
        if end || i + 1 == b.len() {
            let piece = &t[start..=i];
            let body = piece.trim().trim_end_matches(['.', ':', '!', '?']);
            if !procedural(body) {
                out.push_str(piece);
            }
            start = i + 1;
        }
    }
    // a call at the head of the first sentence, before a comma ("rover three to base,
    // request ...", "unit 7 to base, the letter box ...")
    let head = out.trim_start();
    if let Some((call, rest)) = head.split_once(", ")
        && procedural(call)
        && (call.contains(" to ") || call.starts_with("this is "))
    {
        out = rest.to_string();
    }
    // "..., segment 2329, over." / "..., over and out"
    let trimmed = out.trim();
    let core = trimmed.trim_end_matches(['.', '!', '?']);
    let stop = &trimmed[core.len()..];
    for tail in [", over and out", ", over", ", out"] {
        if let Some(head) = core.strip_suffix(tail) {
            return format!("{head}{}", if stop.is_empty() { "?" } else { stop });
        }
    }
    out.trim().to_string()
}

fn prepare(text: &str) -> Prepared {
    let mut t = text.to_lowercase().replace(['’', '‘'], "'");
    // remarks in parentheses qualify; they name nothing asked
    while let (Some(a), Some(b)) = (t.find('('), t.find(')')) {
        if b < a {
            break;
        }
        t.replace_range(a..=b, " ");
    }
    t = t
        .replace("->", " to ")
        // "spawn point = lane node 12": a definition, as after a colon
        .replace(" = ", ": ")
        .replace(" – ", " - ")
        .replace(" — ", " - ");
    t = drop_radio_procedure(&t);
    // spoken fillers ("okay so uh how many ...") say nothing
    t = t
        .split(' ')
        .filter(|w| {
            !matches!(
                w.trim_end_matches([',', '.', '?']),
                "uh" | "um"
                    | "umm"
                    | "uhm"
                    | "er"
                    | "erm"
                    | "hmm"
                    | "mm"
                    | "bro"
                    | "bruh"
                    | "lol"
                    | "lmao"
                    | "ngl"
                    | "tbh"
                    | "dude"
            )
        })
        .collect::<Vec<_>>()
        .join(" ");
    t = drop_leading_markers(&t);
    // a GIS analyst's words: map objects are "features", a count is a "feature count", and a
    // feature is "contained in" or "assigned to" a segment
    t = format!(" {t} ")
        .replace(" feature count ", " count ")
        .replace(" features contained in ", " in ")
        .replace(" features assigned to ", " in ")
        .replace(" contained in ", " in ")
        .replace(" assigned to ", " in ")
        .trim()
        .to_string();
    // "bins/trash cans": the first of the names; "bend / corner": either
    let words: Vec<&str> = t.split(' ').collect();
    let mut kept: Vec<&str> = Vec::new();
    let mut k = 0;
    while k < words.len() {
        let w = words[k];
        let short = SHORT_FORMS
            .iter()
            .any(|(s, _)| *s == w.trim_end_matches(['?', ',']));
        match w.split_once('/') {
            Some((a, b))
                if !short
                    && !a.is_empty()
                    && !b.is_empty()
                    && a.chars().all(|c| c.is_alphabetic() || c == '-')
                    && b.chars().next().is_some_and(char::is_alphabetic) =>
            {
                kept.push(a);
                // the second name's other words ("bins/trash cans in ..."), up to a stop
                k += 1;
                let mut n = 0;
                while k < words.len()
                    && n < 2
                    && !w.ends_with([',', '?', '.'])
                    && !ends_np(words[k].trim_end_matches(['?', ',', '.']))
                    && words[k]
                        .chars()
                        .all(|c| c.is_alphabetic() || c == '?' || c == ',')
                    && !words[k - 1].ends_with([',', '?', '.'])
                {
                    if words[k].ends_with(['?', ',', '.']) {
                        let tail = &words[k][words[k].trim_end_matches(['?', ',', '.']).len()..];
                        kept.push(tail);
                        k += 1;
                        break;
                    }
                    k += 1;
                    n += 1;
                }
                continue;
            }
            _ => kept.push(w),
        }
        k += 1;
    }
    t = kept.join(" ").replace(" / ", " or ");
    // phrasings that say a common word another way
    for (said, meant) in [
        (" segment no. ", " segment "),
        (" segment number ", " segment "),
        (" segment nr ", " segment "),
        (" seg no. ", " segment "),
        (" would you say ", " "),
        (" do you think ", " "),
        (" do you reckon ", " "),
        (", as the crow flies,", ""),
        (" as the crow flies", ""),
        (", in a straight line over the ground,", ""),
        (", in a straight line,", ""),
        (" in a straight line over the ground", ""),
        (", over the ground,", ""),
        (" over the ground", ""),
        (" ground-plane ", " "),
        (" most near ", " nearest "),
        (" most close ", " closest "),
        (" more near ", " nearer "),
        (" is having ", " has "),
        (" are having ", " have "),
        (" is existing ", " is "),
        (" are existing ", " are "),
        (" until ", " to "),
        (" like in total", " in total"),
        (" like a ", " a "),
        (" like an ", " an "),
        (" in straight line", " in a straight line"),
        (". in a straight line, ", ". "),
        ("? in a straight line, ", "? "),
        (" in a straight line, how ", " how "),
        // what the map records is what is asked ("what colour is it recorded as", "what
        // colour does the map record it as", "that SUV on record")
        (", in m ", " "),
        (", in m?", "?"),
        (", in m.", "."),
        (", straight line:", ":"),
        (", straight line,", ","),
        (", straight line?", "?"),
        (", straight line", ""),
        (" straight line not driving", ""),
        (" really ", " "),
        (" actually ", " "),
        (" does the map record ", " is "),
        (" does the map have ", " is "),
        (" does the map show ", " is "),
        (" is recorded as ", " is "),
        (" are recorded as ", " are "),
        (" is recorded as?", " is?"),
        (" are recorded as?", " are?"),
        (" recorded as ", " "),
        (" it's recorded as", " it is"),
        (" they're recorded as", " they are"),
        (" is it as?", " is it?"),
        (" is it as ", " is it "),
        (" on record", ""),
        (" on the record", ""),
    ] {
        t = format!(" {t} ").replace(said, meant).trim().to_string();
    }
    // radio talk: "over" and "over and out" end a turn, "control, ..." calls someone
    for (said, meant) in [
        (", over and out", ""),
        (" over and out", ""),
        (", over?", "?"),
        (", over.", "."),
        (". over.", "."),
        ("? over.", "?"),
        ("? over", "?"),
        (". over", "."),
    ] {
        t = t.replace(said, meant);
    }
    for end in [", over", " over"] {
        if let Some(r) = t.trim_end().strip_suffix(end) {
            t = r.to_string();
        }
    }
    for who in CALLED {
        if let Some(r) = t.strip_prefix(&format!("{who}, ")) {
            t = r.to_string();
        }
        for at in [". ", "? "] {
            t = t.replace(&format!("{at}{who}, "), at);
        }
    }
    // what a removed phrase leaves: "be., how far" -> "be. how far"
    for (left, tidy) in [
        (".,", "."),
        ("?,", "?"),
        ("!,", "!"),
        (" ,", ","),
        (",,", ","),
    ] {
        t = t.replace(left, tidy);
    }
    // contractions that hide a verb
    for (short, long) in [
        ("what's ", "what is "),
        ("where's ", "where is "),
        ("who's ", "who is "),
        ("how's ", "how is "),
        ("that's ", "that is "),
        ("there's ", "there is "),
        ("it's ", "it is "),
        ("colour's ", "colour is "),
        ("color's ", "color is "),
    ] {
        t = t.replace(short, long);
    }
    let t: String = t
        .split(' ')
        .map(|w| {
            let (core, tail) = match w.strip_suffix(['?', ',', '.', '!', ';']) {
                Some(c) => (c, &w[c.len()..]),
                None => (w, ""),
            };
            // the word as written ("no."), else without its punctuation ("seg,")
            if let Some((_, l)) = SHORT_FORMS.iter().find(|(s, _)| *s == w) {
                return (*l).to_string();
            }
            SHORT_FORMS
                .iter()
                .find(|(s, _)| *s == core && !s.ends_with('.'))
                .map_or_else(|| w.to_string(), |(_, l)| format!("{l}{tail}"))
        })
        .collect::<Vec<_>>()
        .join(" ");
    // sentences: split at ". ", "? ", "! ", ": ", "; " and " - " (not in numbers or specs)
    let mut sentences: Vec<String> = Vec::new();
    // whether each sentence ended with a question mark
    let mut asked: Vec<bool> = Vec::new();
    let mut cur = String::new();
    let chars: Vec<char> = t.chars().collect();
    for (i, c) in chars.iter().enumerate() {
        let next_space = chars.get(i + 1).is_none_or(|n| n.is_whitespace());
        let splits = matches!(c, '?' | '!')
            || (matches!(c, '.' | ':' | ';') && next_space)
            || (*c == '-'
                && i > 0
                && chars[i - 1].is_whitespace()
                && chars.get(i + 1).is_some_and(|n| n.is_whitespace()));
        if splits {
            if !cur.trim().is_empty() {
                asked.push(*c == '?');
                sentences.push(clean(&cur));
            }
            cur.clear();
        } else {
            cur.push(*c);
        }
    }
    if !cur.trim().is_empty() {
        asked.push(false);
        sentences.push(clean(&cur));
    }
    // a thing said before its question ("the bench in segment 4, what colour is it", "object
    // 12 what kind of road is it on") is a sentence of its own
    let mut split_up: Vec<(String, bool)> = Vec::new();
    for (s, q) in sentences.iter().zip(&asked) {
        match question_inside(s) {
            Some(i) => {
                split_up.push((clean(&s[..i]), false));
                split_up.push((clean(&s[i..]), *q));
            }
            None => split_up.push((s.clone(), *q)),
        }
    }
    let (sentences, asked): (Vec<String>, Vec<bool>) = split_up.into_iter().unzip();
    let strip_polite = |s: &str| {
        let mut s = s.to_string();
        loop {
            let before = s.len();
            for p in POLITE {
                if let Some(r) = s.strip_prefix(p) {
                    s = r.to_string();
                }
            }
            if s.len() == before {
                // a lead cut off from its question ("could you confirm | what colour ...")
                if POLITE.iter().any(|p| p.trim_end() == s.trim()) {
                    return String::new();
                }
                return s;
            }
        }
    };
    let (sentences, asked): (Vec<String>, Vec<bool>) = sentences
        .iter()
        .zip(asked)
        .map(|(s, q)| (strip_polite(&drop_purpose(s)), q))
        .filter(|(s, _)| !s.is_empty())
        .map(|(s, q)| {
            // "white SUV by the kerb - straight road, bend, T or crossroads?": the choices
            // alone ask what kind of road the thing said before is on
            if q && cut_segment_choices(&s).trim().is_empty() {
                ("what kind of road is it on".to_string(), q)
            } else {
                (s, q)
            }
        })
        .unzip();
    match sentences.len() {
        0 => Prepared {
            question: String::new(),
            whole: String::new(),
            context: String::new(),
        },
        1 => {
            // "if i'm camping at lane node 12, how many bins are within 45 m of me": the
            // clause before the first comma says where the asker is
            let q = &sentences[0];
            let question = match q.split_once(", ") {
                Some((clause, rest))
                    if has_any(
                        rest,
                        &["me", "us", "my position", "my location", "our position"],
                    ) =>
                {
                    match asker_at(clause) {
                        Some(here) => put_asker(rest, &here),
                        None => q.clone(),
                    }
                }
                _ => q.clone(),
            };
            Prepared {
                question,
                whole: q.clone(),
                context: String::new(),
            }
        }
        _ => merge_sentences(&sentences, &asked),
    }
}

/// A sentence without the phrase that says what the answer is for ("for the photo log, what
/// colour is ...", "colour, for visual confirmation from the air"): at the sentence's start
/// up to its first comma, or after its last comma to its end, up to seven words without a
/// number or a question word. The purpose names nothing asked about.
fn drop_purpose(s: &str) -> String {
    let plain = |p: &str| {
        let words: Vec<&str> = p.split(' ').filter(|w| !w.is_empty()).collect();
        words.len() <= 7
            && !p.chars().any(|c| c.is_ascii_digit())
            && !words.iter().any(|w| {
                matches!(
                    w.trim_end_matches(','),
                    "what"
                        | "which"
                        | "how"
                        | "where"
                        | "who"
                        | "is"
                        | "are"
                        | "example"
                        | "instance"
                )
            })
    };
    let mut s = s.trim().to_string();
    if let Some(rest) = s.strip_prefix("for ")
        && let Some((purpose, after)) = rest.split_once(", ")
        && plain(purpose)
        && !after.trim().is_empty()
    {
        s = after.trim().to_string();
    }
    if let Some(i) = s.rfind(", for ")
        && plain(&s[i + 6..])
        && i > 0
    {
        s.truncate(i);
    }
    s
}

/// Where a question opens inside a sentence after what it asks about: after ", " at a
/// question word ("the bench in segment 4, what colour is it", "the object 13, on which
/// kind of road it stands"), or at a question's cue after two words or more ("object 12
/// what kind of road is it on").
fn question_inside(s: &str) -> Option<usize> {
    const OPENS: [&str; 20] = [
        "state",
        "determine",
        "compute",
        "calculate",
        "identify",
        "work out",
        "find",
        "give",
        "report",
        "tell me",
        "what",
        "which",
        "how",
        "where",
        "on which",
        "in which",
        "at which",
        "is it",
        "is there",
        "are there",
    ];
    const CUES: [&str; 14] = [
        "what colour",
        "what color",
        "what kind",
        "what type",
        "what sort",
        "which kind",
        "which type",
        "which segment",
        "what segment",
        "how many",
        "how far",
        "how long",
        "how much",
        "where is",
    ];
    // after a thing, not a place ("within 60 m of the start, how many ...")
    let thing_first = !matches!(
        s.split(' ').next().unwrap_or(""),
        "within"
            | "in"
            | "at"
            | "on"
            | "near"
            | "around"
            | "from"
            | "between"
            | "inside"
            | "for"
            | "of"
            | "by"
            | "to"
            | "along"
            | "if"
            | "when"
            | "as"
            | "via"
            | "keeping"
            | "sticking"
            | "staying"
            | "following"
            | "using"
            | "driving"
            | "going"
            | "travelling"
            | "traveling"
            | "taking"
    );
    // "from the start of the drive, which bin is nearest": the place a nearest is measured
    // from, said first, is what the question is about
    let from_place = s.starts_with("from ");
    let mut from = 0;
    while let Some(i) = s[from..].find(", ").map(|i| i + from) {
        let rest = &s[i + 2..];
        let nearest_from = from_place && has_any(rest, &["nearest", "closest"]);
        if OPENS.iter().any(|o| rest.starts_with(&format!("{o} ")))
            && s[..i].split(' ').count() >= 2
            && (thing_first || nearest_from)
        {
            return Some(i + 2);
        }
        from = i + 2;
    }
    let first = CUES.iter().filter_map(|c| at_words(s, c)).min()?;
    let before: Vec<&str> = s[..first].split_whitespace().collect();
    // not after words that lead into the question ("tell me how many", "I need to know")
    let leads = matches!(
        before.last().copied(),
        Some(
            "know"
                | "me"
                | "us"
                | "tell"
                | "ask"
                | "asking"
                | "wonder"
                | "wondering"
                | "and"
                | "or"
                | "out"
                | "see"
                | "check"
                | "say"
        )
    );
    (before.len() >= 2 && !leads && thing_first).then_some(first)
}

/// Words that say what a sentence asks for: a count, a distance, a route, the nearest, a
/// colour, a segment or kind of road, a place.
fn has_cue(s: &str) -> bool {
    has_any(
        s,
        &[
            "how many",
            "number of",
            "count",
            "total",
            "how far",
            "how long",
            "distance",
            "route",
            "nearest",
            "closest",
            "colour",
            "color",
            "which segment",
            "what segment",
            "segment id",
            "kind of",
            "type of",
            "sort of",
            "road type",
            "where is",
            "where are",
            "where am i",
            "apart",
            "separate",
        ],
    )
}

/// Question words that make a sentence a question.
fn asks(s: &str) -> bool {
    let first = s.split(' ').next().unwrap_or("");
    matches!(
        first,
        "how" | "what" | "which" | "where" | "who" | "is" | "are" | "does" | "do" | "can"
    ) || has_cue(s)
}

/// What the sentences around a question name, in order: road segments and lane nodes by
/// id, ends of the drive, and things ("a white box truck", "the blue speed limit sign").
#[derive(Debug, Clone, PartialEq)]
enum Named {
    /// A segment or lane node by id, as said ("the road segment with id 2421").
    Road(String),
    /// An end of the drive, as said ("where the drive started").
    Place(String),
    /// A thing: its words after the determiner, its head word (stemmed), and whether it is
    /// its sentence's subject ("the red truck needs a tow", "there is a hedge ...").
    Thing(String, String, bool),
}

/// Words that end a noun phrase in a sentence around the question.
const NP_STOP: [&str; 47] = [
    "along",
    "across",
    "opposite",
    "outside",
    "past",
    "around",
    "between",
    "against",
    "into",
    "onto",
    "inside",
    "under",
    "behind",
    "beside",
    "over",
    "that",
    "which",
    "who",
    "whose",
    "where",
    "when",
    "somewhere",
    "in",
    "on",
    "at",
    "near",
    "by",
    "with",
    "from",
    "to",
    "and",
    "or",
    "but",
    "i",
    "we",
    "you",
    "they",
    "he",
    "she",
    "out",
    "there",
    "here",
    "because",
    "for",
    "of",
    "apparently",
    "about",
];

/// Verbs that end a noun phrase in a sentence around the question ("a small grey sedan
/// shows up in ...").
const MORE_VERBS: [&str; 20] = [
    "shows", "seems", "looks", "keeps", "gets", "goes", "says", "needs", "wants", "blocks",
    "leans", "waits", "faces", "stays", "remains", "sticks", "keep", "love", "loves", "say",
];

/// Words for a time, which name no thing ("kids' party delivery today").
const TIME_WORDS: [&str; 4] = ["today", "tonight", "yesterday", "tomorrow"];

/// Heads of noun phrases that name no thing in the map.
const NOT_THINGS: [&str; 59] = [
    "point",
    "line",
    "metres",
    "meters",
    "sidewalk",
    "pavement",
    "curb",
    "kerb",
    "side",
    "drive",
    "map",
    "city",
    "town",
    "kid",
    "crew",
    "morning",
    "note",
    "shift",
    "complaint",
    "way",
    "driver",
    "vehicle",
    "robot",
    "van",
    "time",
    "day",
    "one",
    "lot",
    "bit",
    "people",
    "someone",
    "somebody",
    "query",
    "question",
    "operator",
    "place",
    "spot",
    "week",
    "roadside",
    // who or what reports ("the piece says the hedge is on a straight road"): sources of
    // words, not things on the map
    "piece",
    "article",
    "story",
    "draft",
    "caption",
    "statement",
    "claim",
    "witness",
    "source",
    "reader",
    "form",
    "file",
    "log",
    "footage",
    "reporter",
    "claimant",
    "incident",
    "scene",
    // what is asked of a thing, not a thing ("the colour of the motorbike")
    "colour",
    "color",
];

/// Heads in [`NOT_THINGS`] that name a thing when more words say which ("our van" is the
/// asker's, "the silver camper van" is in the map).
const THINGS_WHEN_SAID_WHICH: [&str; 4] = ["van", "vehicle", "robot", "side"];

/// Whether a noun phrase of `n` words with head `head` names something in the map.
fn names_thing(head: &str, n: usize) -> bool {
    (!NOT_THINGS.contains(&head) || (n > 1 && THINGS_WHEN_SAID_WHICH.contains(&head)))
        && !TIME_WORDS.contains(&head)
        && !super::places::is_road_word(head)
}

/// A word that cannot be inside a noun phrase.
fn ends_np(x: &str) -> bool {
    NP_STOP.contains(&x) || VERBS.contains(&x) || MORE_VERBS.contains(&x) || x == ","
}

fn named_in(context: &str) -> Vec<Named> {
    // words with a comma kept as its own word (a comma ends a phrase)
    let spaced = context.replace(',', " , ");
    let w: Vec<&str> = spaced.split(' ').filter(|x| !x.is_empty()).collect();
    // (position, what)
    let mut found: Vec<(usize, Named)> = Vec::new();
    let mut taken = vec![false; w.len()];
    // where each segment or lane node named by id is (start, end)
    let mut roads: Vec<(usize, usize)> = Vec::new();
    // ids with the words before them
    for i in 0..w.len() {
        if w[i].trim_start_matches('#').parse::<u64>().is_err() {
            continue;
        }
        // the fewest words that name a segment or lane node, and the road words before them
        // ("the road segment with id 2421", not "is booked for segment 2416")
        let road_spec = |from: usize| {
            let span = w[from..=i].join(" ");
            (!w[from..=i].contains(&","))
                .then(|| super::spec_in_words(&span))
                .flatten()
                .filter(|sp| sp.starts_with("segment:") || sp.starts_with("lane:"))
                .map(|_| span)
        };
        let span = (0..=i)
            .rev()
            .take(5)
            .find_map(|a| road_spec(a).map(|sp| (a, sp)));
        let span = span.map(|(mut a, mut sp)| {
            while a > 0
                && matches!(
                    w[a - 1],
                    "the" | "road" | "lane" | "with" | "id" | "node" | "segment" | "street"
                )
                && let Some(longer) = road_spec(a - 1)
            {
                a -= 1;
                sp = longer;
            }
            (a, sp)
        });
        if let Some((at, span)) = span {
            taken[at..=i].iter_mut().for_each(|t| *t = true);
            roads.push((at, i + 1));
            found.push((at, Named::Road(span)));
            continue;
        }
        // the second of two ids said once ("lane nodes 2430 and 2434")
        if i >= 2
            && matches!(w[i - 1], "and" | "&" | "or")
            && let Some(&(at, end)) = roads.last()
            && end == i - 1
        {
            let said = w[at..end - 1].join(" ");
            taken[i] = true;
            roads.push((i, i + 1));
            found.push((i, Named::Road(format!("{said} {}", w[i]))));
            continue;
        }
        // an object by id ("object 86", "traffic light 623")
        let span = (2..=4.min(i + 1)).rev().find_map(|n| {
            let words = &w[i + 1 - n..=i];
            if words.contains(&",")
                || words.iter().any(|x| ends_np(x))
                || matches!(words[0], "the" | "a" | "an")
            {
                return None;
            }
            let span = words.join(" ");
            super::spec_in_words(&span)
                .filter(|sp| sp.starts_with("instance:") || sp.starts_with("node:"))
                .map(|_| (i + 1 - n, span))
        });
        if let Some((at, span)) = span {
            taken[at..=i].iter_mut().for_each(|t| *t = true);
            let head = stem(w[at]);
            found.push((at, Named::Thing(span, head, true)));
        }
    }
    // ends of the drive
    let mut i = 0;
    while i < w.len() {
        if let Some(n) = (2..=5).rev().find(|n| {
            i + n <= w.len()
                && !taken[i..i + n].iter().any(|t| *t)
                && w[i..i + n]
                    .iter()
                    .any(|x| super::places::says_the_drive(x.trim_end_matches([',', '.'])))
                && super::drive_end_of(&w[i..i + n].join(" ")).is_some()
        }) {
            taken[i..i + n].iter_mut().for_each(|t| *t = true);
            found.push((i, Named::Place(w[i..i + n].join(" "))));
            i += n;
        } else {
            i += 1;
        }
    }
    // things after a determiner
    let ends = |x: &str| {
        NP_STOP.contains(&x)
            || matches!(x, "a" | "an" | "the")
            || VERBS.contains(&x)
            || MORE_VERBS.contains(&x)
            || PARTICIPLES.contains(&x)
            || x == ","
            || x.parse::<f64>().is_ok()
    };
    let mut i = 0;
    while i < w.len() {
        // a demonstrative opens a thing at the start of a sentence ("that heavy blue scooter
        // up on its kickstand, which bin is closest to it")
        let opens = matches!(w[i], "a" | "an" | "the" | "one")
            || (i == 0 && matches!(w[i], "that" | "this"));
        if taken[i] || !opens || (w[i] == "one" && w.get(i + 1) == Some(&"of")) {
            i += 1;
            continue;
        }
        let mut j = i + 1;
        while j < w.len() && matches!(w[j], "only" | "single" | "same" | "little") {
            j += 1;
        }
        let start = j;
        while j < w.len() && !taken[j] && !ends(w[j]) {
            j += 1;
        }
        if j == start {
            i += 1;
            continue;
        }
        let head = stem(w[j - 1]);
        // where it stands, said after it ("standing at a bend", "parked in a parking
        // lane"): a participle, a preposition, a determiner and a noun
        let mut end = j;
        if j + 2 < w.len()
            && PARTICIPLES.contains(&w[j])
            && matches!(w[j + 1], "at" | "on" | "in" | "near" | "by" | "beside")
            && matches!(w[j + 2], "a" | "an" | "the")
        {
            end = j + 3;
            while end < w.len() && !taken[end] && !ends(w[end]) {
                end += 1;
            }
        } else if j + 1 < w.len()
            && matches!(w[j], "in" | "at" | "on")
            && let Some(&(_, road_end)) = roads.iter().find(|r| r.0 == j + 1)
        {
            // "the litter bin in segment 2416": the segment says which
            end = road_end;
        } else if w.get(j) == Some(&"with") {
            // "a large SUV with dusty windows": what it has says which (up to three words,
            // an article allowed first)
            let mut k = j + 1;
            if w.get(k).is_some_and(|x| matches!(*x, "a" | "an" | "the")) {
                k += 1;
            }
            let from = k;
            while k < w.len() && k < from + 3 && !taken[k] && !ends(w[k]) {
                k += 1;
            }
            if k > from {
                end = k;
            }
        }
        // the subject of what someone reports ("the piece says the hedge along a garden
        // is ..."): the one talked about, not the one who talks
        let reported = {
            let k = if i > 0 && w[i - 1] == "that" {
                i - 1
            } else {
                i
            };
            (2..=5).contains(&k)
                && matches!(
                    w[k - 1],
                    "says"
                        | "said"
                        | "claims"
                        | "claimed"
                        | "states"
                        | "stated"
                        | "reports"
                        | "mentions"
                        | "mentioned"
                        | "insists"
                        | "insisted"
                        | "notes"
                        | "noted"
                        | "suggests"
                        | "believes"
                        | "thinks"
                        | "writes"
                        | "wrote"
                        | "alleges"
                )
        };
        // the sentence's subject, and where it is ("there is a hedge along a garden")
        let subject = i == 0
            || reported
            || matches!(
                &w[..i],
                ["there", "is" | "are" | "was" | "were"]
                    | ["i", "see" | "saw" | "spotted" | "noticed" | "found"]
                    | ["we", "have" | "found" | "spotted"]
            );
        if subject && end == j {
            let prep = match (w.get(j).copied(), w.get(j + 1).copied()) {
                (Some("next" | "close"), Some("to")) => 2,
                (Some("in"), Some("front")) if w.get(j + 2) == Some(&"of") => 3,
                (
                    Some(
                        "along" | "beside" | "by" | "near" | "opposite" | "outside" | "behind"
                        | "under" | "against",
                    ),
                    _,
                ) => 1,
                _ => 0,
            };
            if prep > 0
                && w.get(j + prep)
                    .is_some_and(|x| matches!(*x, "a" | "an" | "the"))
            {
                let mut k = j + prep + 1;
                while k < w.len() && !taken[k] && !ends(w[k]) {
                    k += 1;
                }
                if k > j + prep + 1 {
                    end = k;
                }
            }
        }
        if names_thing(&head, j - start) {
            found.push((i, Named::Thing(w[start..end].join(" "), head, subject)));
        }
        i = end.max(i + 1);
    }
    // a sentence that is only a noun phrase ("heavy red motorcycle - what kind of road is
    // it at?"), or opens with one and has no verb ("red cast-iron hydrant on the sidewalk")
    if found.is_empty() && w.len() <= 5 && !w.iter().any(|x| ends(x)) && !w.is_empty() {
        let head = stem(w[w.len() - 1]);
        // a heading that names a spot ("hover point: lane node 12") is no thing
        if names_thing(&head, w.len()) {
            found.push((0, Named::Thing(w.join(" "), head, true)));
        }
    } else if !w.is_empty()
        && !taken[0]
        && !ends(w[0])
        && !matches!(
            w[0],
            "a" | "an" | "the" | "one" | "it" | "this" | "there" | "here"
        )
        && !w
            .iter()
            .any(|x| (VERBS.contains(x) || MORE_VERBS.contains(x)) && !PARTICIPLES.contains(x))
    {
        let n = (1..w.len()).find(|&k| ends(w[k])).unwrap_or(w.len());
        if n <= 5 {
            let head = stem(w[n - 1]);
            // "white SUV parked in the parking lane": where it stands says which
            let words = if PARTICIPLES.contains(&w.get(n).copied().unwrap_or("")) {
                w.join(" ")
            } else {
                w[..n].join(" ")
            };
            // a heading ("excavation permit near the silver camper van") is not the subject
            if names_thing(&head, n) && take_segment(&words).0.is_none() {
                found.push((0, Named::Thing(words, head, false)));
            }
        }
    }
    found.sort_by_key(|f| f.0);
    found.into_iter().map(|f| f.1).collect()
}

/// Participles that end a noun phrase and may open where it stands ("a sedan parked in a
/// parking lane").
const PARTICIPLES: [&str; 18] = [
    "parked",
    "standing",
    "located",
    "sitting",
    "lying",
    "placed",
    "positioned",
    "unloading",
    "waiting",
    "showing",
    "leaning",
    "mounted",
    "installed",
    "painted",
    "reported",
    "left",
    "stopped",
    "situated",
];

/// Words for a road segment after "that" ("that stretch", "that segment").
const ROAD_WORDS: [&str; 12] = [
    "segment",
    "crossing",
    "intersection",
    "roundabout",
    "stretch",
    "road",
    "section",
    "junction",
    "street",
    "crossroads",
    "bend",
    "corner",
];
/// Words for a spot after "that" ("that starting point", "that spot").
const PLACE_WORDS: [&str; 6] = ["point", "spot", "place", "position", "location", "pose"];

/// The question with its references to other sentences filled in: "it", "them" (the last
/// thing named), "that X" / "this X" / "the same X" (the last thing whose head is X, the
/// last segment for a road word, the last end of the drive for a spot).
fn fill_references(question: &str, named: &[Named], context: &str) -> String {
    // how often each word is said: "it" is the thing talked about most (the last of those)
    let said: Vec<String> = format!("{context} {question}")
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|w| !w.is_empty())
        .map(stem)
        .collect();
    let mentions = |h: &str| said.iter().filter(|w| *w == h).count();
    let thing = |head: Option<&str>| {
        // a reference is never the speaker or another pronoun ("i'd rather cross", "it")
        let pronoun = |words: &str| {
            words.split(' ').next().is_none_or(|f| {
                f.is_empty()
                    || matches!(
                        f.trim_end_matches(','),
                        "i" | "i'd"
                            | "i'm"
                            | "i'll"
                            | "me"
                            | "my"
                            | "we"
                            | "you"
                            | "it"
                            | "its"
                            | "they"
                            | "he"
                            | "she"
                            | "that"
                            | "this"
                    )
            })
        };
        let things = named.iter().filter_map(|n| match n {
            Named::Thing(words, h, subject)
                if head.is_none_or(|x| stem(x) == *h) && !pronoun(words) =>
            {
                Some((words, h, *subject))
            }
            _ => None,
        });
        // the most said, then a subject, then the last
        let mut best: Option<(&String, (usize, bool))> = None;
        for (words, h, subject) in things {
            let m = (mentions(h), subject);
            if best.is_none_or(|(_, b)| m >= b) {
                best = Some((words, m));
            }
        }
        best.map(|(words, _)| format!("the {words}"))
    };
    let road = || {
        named.iter().rev().find_map(|n| match n {
            Named::Road(s) => Some(s.clone()),
            _ => None,
        })
    };
    let place = || {
        named.iter().rev().find_map(|n| match n {
            Named::Place(s) => Some(s.clone()),
            _ => None,
        })
    };
    let lane_node = || {
        named.iter().rev().find_map(|n| match n {
            Named::Road(s) if super::spec_in_words(s).is_some_and(|sp| sp.starts_with("lane:")) => {
                Some(s.clone())
            }
            _ => None,
        })
    };
    // "the trailer" after "the long cargo trailer parked by the curb" was named: the one
    // fuller phrase with that head (none when two differ)
    let fuller = |noun: &str| {
        let h = stem(noun);
        let mut phrases: Vec<&String> = named
            .iter()
            .filter_map(|n| match n {
                Named::Thing(words, head, _) if *head == h && words.contains(' ') => Some(words),
                _ => None,
            })
            .collect();
        phrases.sort();
        phrases.dedup();
        match phrases.as_slice() {
            [one] => Some(format!("the {one}")),
            _ => None,
        }
    };
    let w: Vec<&str> = question.split(' ').collect();
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < w.len() {
        let word = w[i].trim_end_matches(',');
        let comma = if w[i].ends_with(',') { "," } else { "" };
        let demonstrative = matches!(word, "that" | "this" | "those" | "these")
            || (word == "the" && w.get(i + 1) == Some(&"same"));
        if demonstrative {
            let k = if word == "the" { i + 2 } else { i + 1 };
            // "that starting point": the noun is the last of up to two words
            for n in [2usize, 1] {
                let Some(span) = w.get(k..k + n) else {
                    continue;
                };
                let noun = span[n - 1].trim_end_matches([',', '?']);
                let tail = if span[n - 1].ends_with(',') { "," } else { "" };
                // "that segment's centre": the segment itself (a segment's place is its centre)
                let (noun, possessive) = match noun.strip_suffix("'s") {
                    Some(b) if ROAD_WORDS.contains(&b) || matches!(b, "node" | "waypoint") => {
                        (b, true)
                    }
                    _ => (noun, false),
                };
                let got = if matches!(noun, "node" | "waypoint") && (n == 1 || span[0] == "lane") {
                    // "that lane node": the last lane node said, else the last road
                    lane_node().or_else(road)
                } else if n == 1 && matches!(noun, "one" | "thing" | "object") {
                    thing(None).or_else(road).or_else(place)
                } else if ROAD_WORDS.contains(&noun) {
                    // "the segment 4": a determiner still opens the place
                    road().map(|r| {
                        if r.starts_with("the ") {
                            r
                        } else {
                            format!("the {r}")
                        }
                    })
                } else if PLACE_WORDS.contains(&noun) {
                    place().or_else(|| thing(None))
                } else if n == 1 && !VERBS.contains(&noun) && !NP_STOP.contains(&noun) {
                    thing(Some(noun))
                } else {
                    None
                };
                if let Some(g) = got {
                    out.push(format!("{g}{tail}"));
                    i = k + n;
                    if possessive
                        && w.get(i).is_some_and(|x| {
                            matches!(
                                x.trim_end_matches([',', '?']),
                                "centre" | "center" | "middle" | "midpoint"
                            )
                        })
                    {
                        if w[i].ends_with(',') {
                            out.push(",".into());
                        }
                        i += 1;
                    }
                    break;
                }
            }
            if i >= k {
                continue;
            }
            // a bare "that" as the thing ("which segment is that in", "that sits on")
            let next = w.get(i + 1).map(|x| x.trim_end_matches([',', '?']));
            if matches!(word, "that" | "this")
                && i > 0
                && matches!(
                    w[i - 1],
                    "is" | "was" | "does" | "of" | "to" | "near" | "would" | "will" | "could"
                )
                && next.is_none_or(|x| {
                    matches!(
                        x,
                        "in" | "on" | "at" | "sit" | "stand" | "have" | "has" | "by" | "be"
                    )
                })
                && let Some(g) = thing(None).or_else(road).or_else(place)
            {
                out.push(format!("{g}{comma}"));
                i += 1;
                continue;
            }
        }
        // "was the trailer standing on a bend": "the X" alone, where another sentence said
        // which X in full
        if word == "the"
            && let Some(next) = w.get(i + 1)
        {
            let noun = next.trim_end_matches([',', '?']);
            let after = w.get(i + 2).map(|x| x.trim_end_matches([',', '?']));
            let alone = next.ends_with(',')
                || after.is_none_or(|x| {
                    VERBS.contains(&x) || MORE_VERBS.contains(&x) || PARTICIPLES.contains(&x)
                });
            if alone
                && !ROAD_WORDS.contains(&noun)
                && !PLACE_WORDS.contains(&noun)
                && names_thing(&stem(noun), 1)
                && let Some(g) = fuller(noun)
            {
                let tail = if next.ends_with(',') { "," } else { "" };
                out.push(format!("{g}{tail}"));
                i += 2;
                continue;
            }
        }
        // "how many hatchbacks in there", "bins within 25 m of there": the segment or lane
        // node said before, as the place itself
        if word == "there"
            && i > 0
            && matches!(
                w[i - 1],
                "in" | "at" | "on" | "of" | "near" | "around" | "by" | "from" | "to"
            )
            && let Some(r) = road()
        {
            out.push(format!("{r}{comma}"));
            i += 1;
            continue;
        }
        // "what colour is the traffic light there": there, not "is there" or "there is"
        if word == "there"
            && i > 0
            && !matches!(
                w[i - 1],
                "is" | "are" | "was" | "were" | "be" | "been" | "get" | "go" | "from" | "to"
            )
            && !w.get(i + 1).is_some_and(|x| {
                matches!(
                    x.trim_end_matches([',', '?']),
                    "is" | "are" | "was" | "were" | "be" | "any" | "a" | "an"
                )
            })
            && let Some(r) = road()
        {
            out.push(format!("in {r}{comma}"));
            i += 1;
            continue;
        }
        // "hydrants in segment", "nearest bin to segment centre": the segment said before
        if word == "segment"
            && i > 0
            && matches!(
                w[i - 1],
                "in" | "on" | "at" | "to" | "of" | "from" | "near" | "the" | "this" | "that"
            )
            && !w.get(i + 1).is_some_and(|x| {
                x.starts_with(|c: char| c.is_ascii_digit() || c == '#' || c == ':')
                    || matches!(*x, "id" | "kind" | "type" | "number")
            })
            && let Some(r) = road()
        {
            if matches!(w[i - 1], "the" | "this" | "that") {
                out.pop();
            }
            out.push(format!("{r}{comma}"));
            i += 1;
            continue;
        }
        // "within 50 m of its centre": the segment or thing itself
        if word == "its"
            && w.get(i + 1).is_some_and(|x| {
                matches!(
                    x.trim_end_matches([',', '?']),
                    "centre" | "center" | "middle" | "midpoint" | "centroid"
                )
            })
            && let Some(g) = road().or_else(|| thing(None))
        {
            let tail = if w[i + 1].ends_with(',') { "," } else { "" };
            out.push(format!("{g}{tail}"));
            i += 2;
            continue;
        }
        // "the route between them": the last two things or places said
        if matches!(word, "them" | "both") && i > 0 && w[i - 1] == "between" {
            let two: Vec<String> = named
                .iter()
                .rev()
                .map(|n| match n {
                    Named::Road(s) | Named::Place(s) => s.clone(),
                    Named::Thing(words, _, _) => format!("the {words}"),
                })
                .take(2)
                .collect();
            if let [b, a] = two.as_slice() {
                out.push(format!("{a} and {b}{comma}"));
                i += 1;
                continue;
            }
        }
        // "how far is it to X", "is it from A to B": "it" stands for no thing ("how far is
        // it from X" alone asks of the thing said before)
        let dummy = word == "it"
            && i > 0
            && matches!(w[i - 1], "is" | "was")
            && match w.get(i + 1).copied() {
                Some("to") => true,
                Some("from") => w[i + 2..].contains(&"to"),
                _ => false,
            };
        // "the scooter on its kickstand": its own, said in the same sentence
        let own = word == "its"
            && w[..i]
                .iter()
                .any(|x| matches!(*x, "the" | "a" | "an" | "that" | "this"));
        if matches!(word, "it" | "its" | "them" | "they")
            && !dummy
            && !own
            && let Some(g) = thing(None).or_else(road)
        {
            out.push(format!("{g}{comma}"));
            i += 1;
            continue;
        }
        out.push(w[i].to_string());
        i += 1;
    }
    out.join(" ")
}

/// Several sentences as one question: the first sentence with a task's cue (else the last
/// that asks), its references filled from the others; a bare follow-up ("if so, how many",
/// "what kind", "road type") is joined with them instead.
fn merge_sentences(sentences: &[String], asked: &[bool]) -> Prepared {
    // a sentence that asks (a question mark, a question word) over one that only has a cue
    // ("We're redrawing the route cards. I need to know how many T-junctions there are.")
    let interrogative = |i: usize| {
        asked.get(i).copied().unwrap_or(false)
            || sentences[i].split(' ').next().is_some_and(|w| {
                matches!(w, "how" | "what" | "which" | "where" | "who" | "is" | "are")
            })
            || has_any(
                &sentences[i],
                &[
                    "how many", "how far", "how long", "how much", "which", "what",
                ],
            )
    };
    let qi = (0..sentences.len())
        .find(|&i| has_cue(&sentences[i]) && interrogative(i))
        .or_else(|| sentences.iter().position(|s| has_cue(s)))
        .or_else(|| sentences.iter().rposition(|s| asks(s)))
        .unwrap_or(sentences.len() - 1);
    let question = &sentences[qi];
    let context = sentences
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != qi)
        .map(|(_, s)| s.as_str())
        .collect::<Vec<_>>()
        .join(" ");
    let whole = clean(&format!("{question} {context}"));
    let bare = trim_words(
        question,
        &["if", "so", "then", "and", "ok", "okay", "also"],
        // "how many in total", "count altogether": a bare follow-up still
        &["please", "total", "in", "altogether", "overall"],
    );
    let nearest_asked = has_any(question, &["nearest", "closest"]);
    if bare.split(' ').count() <= 3 && !nearest_asked {
        // "how many" after "are there any pedestrians in segment 4": the sentence before
        // it, its references filled from the others
        let (said, others): (String, Vec<Named>) = if qi > 0 && sentences.len() > 2 {
            let others = sentences
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != qi && *i != qi - 1)
                .flat_map(|(_, s)| named_in(s))
                .collect();
            (sentences[qi - 1].clone(), others)
        } else {
            (context.clone(), Vec::new())
        };
        let said = fill_references(&said, &others, &context);
        let question = clean(&format!(
            "{bare} {}",
            trim_words(&said, &["are", "is", "there", "any", "some"], &[])
        ));
        return Prepared {
            question,
            whole,
            context,
        };
    }
    // each sentence apart (a sentence that is only a noun phrase names a thing); a reference
    // points back to what the sentences before the question name, and only when they name
    // nothing it fits, forward to what a later sentence adds ("which segment is it in? I
    // need it for the form" is not about the form)
    // a heading that a road or lane node defines ("plot: seg 12", "spawn point = lane node
    // 4") names that place: no thing of its own, and "the plot" / "that plot" is the place
    let spec_only = |s: &str| {
        s.split(' ').count() <= 4
            && super::spec_in_words(s)
                .is_some_and(|sp| sp.starts_with("segment:") || sp.starts_with("lane:"))
    };
    let headings: Vec<(usize, String)> = (0..sentences.len().saturating_sub(1))
        .filter(|&i| {
            i != qi
                && i + 1 != qi
                && sentences[i].split(' ').count() <= 3
                && spec_only(&sentences[i + 1])
        })
        .map(|i| (i, sentences[i + 1].clone()))
        .collect();
    let mut question = question.clone();
    for (i, spec) in &headings {
        let h = &sentences[*i];
        for det in ["the", "that", "this"] {
            question = format!(" {question} ")
                .replace(&format!(" {det} {h} "), &format!(" {spec} "))
                .trim()
                .to_string();
        }
    }
    let question = &question;
    let named_in_range = |range: std::ops::Range<usize>| -> Vec<Named> {
        range
            .filter(|k| !headings.iter().any(|(i, _)| i == k))
            .flat_map(|k| named_in(&sentences[k]))
            .collect()
    };
    let mut named = named_in_range(0..qi);
    let before = fill_references(question, &named, &context);
    named.extend(named_in_range(qi + 1..sentences.len()));
    let filled = if before == *question && qi + 1 < sentences.len() {
        fill_references(question, &named, &context)
    } else {
        before
    };
    let mut question = clean(&filled);
    // "which bin is nearest so I can throw this away", "closest hydrant?": from where the
    // asker is, or the one place the other sentences name
    if nearest_asked {
        for why in [
            " so i ",
            " so we ",
            " so that ",
            " because ",
            " in order to ",
            " for me to ",
        ] {
            if let Some(k) = format!("{question} ").find(why) {
                question.truncate(k);
            }
        }
        let cue = ["nearest", "closest"]
            .iter()
            .filter_map(|c| at_words(&question, c).map(|i| i + c.len()))
            .min()
            .unwrap_or(0);
        let after = format!(" {} ", &question[cue..]);
        if ![" to ", " from ", " near ", " of ", " me ", " us "]
            .iter()
            .any(|p| after.contains(p))
        {
            question.push_str(" to me");
        }
    }
    let said_place = || {
        named.iter().rev().find_map(|n| match n {
            Named::Road(s) | Named::Place(s) => Some(s.clone()),
            Named::Thing(..) => None,
        })
    };
    // "the nearest to me": where the asker said they are
    if let Some(here) = asker_at(&context).or_else(|| said_place().filter(|_| nearest_asked)) {
        question = put_asker(&question, &here);
    }
    Prepared {
        question,
        whole,
        context,
    }
}

/// `question` with "me" / "us" / "my position" after a preposition ("within 45 m of me")
/// as `here`, where the asker said they are.
fn put_asker(question: &str, here: &str) -> String {
    let mut question = question.to_string();
    for me in [
        "me",
        "us",
        "my position",
        "my current position",
        "my location",
        "our position",
    ] {
        for prep in ["to", "from", "near", "nearest", "closest", "of", "around"] {
            let said = format!(" {prep} {me}");
            let padded = format!("{question} ");
            if let Some(i) = padded.find(&format!("{said} ")) {
                question = format!(
                    "{} {prep} {here}{}",
                    &padded[..i],
                    &padded[i + said.len()..]
                )
                .trim()
                .to_string();
            }
        }
    }
    question
}

/// Takes out a list of road kinds offered as choices ("at a crossroads, a T-junction, a
/// bend or on a straight road", "at a junction or along a straight road"): what is left is
/// the object asked about.
fn cut_segment_choices(t: &str) -> String {
    let kinds = [
        "crossroads",
        "four-way",
        "three-way",
        "crossing",
        "straight section",
        "straight bit",
        "junction",
        "t-junction",
        "t junction",
        "bend",
        "straight road",
        "straight stretch",
        "intersection",
        "corner",
        "roundabout",
        "l-bend",
        // bare, only among choices: "straight, bend, T or crossroads"
        "straight",
        "t",
    ];
    let mut first: Option<usize> = None;
    for k in kinds {
        if let Some(i) = at_words(t, k) {
            first = Some(first.map_or(i, |f: usize| f.min(i)));
        }
    }
    let Some(i) = first else { return t.to_string() };
    // the choices count only when they are choices ("or") or the object comes before them
    if !has(&t[i..], "or") {
        return t.to_string();
    }
    // back to the preposition and article that open the first choice
    let head = t[..i].trim_end();
    let mut words: Vec<&str> = head.split(' ').collect();
    while words.last().is_some_and(|w| {
        matches!(
            *w,
            "a" | "an" | "the" | "at" | "on" | "in" | "along" | "by" | "near"
        )
    }) {
        words.pop();
    }
    words.join(" ")
}

/// A number of metres in "within 50 m of", "in 30 metres of", "less than 20 m from";
/// (radius, place, the text without that phrase).
fn radius_of(t: &str) -> Option<(f64, String, String)> {
    // "(X) whose (ground) distance to P is at most R m"
    for cue in [" distance to ", " distance from "] {
        let Some(i) = t.find(cue) else { continue };
        let rest = &t[i + cue.len()..];
        let Some(j) = rest.find(" is ") else { continue };
        let bound = rest[j + 4..].trim();
        let Some(num) = [
            "at most ",
            "no more than ",
            "not more than ",
            "up to ",
            "less than ",
            "under ",
            "below ",
            "within ",
            "<= ",
            "< ",
        ]
        .iter()
        .find_map(|b| bound.strip_prefix(b)) else {
            continue;
        };
        let mut nw = num.split_whitespace();
        let first = nw.next().unwrap_or("");
        let (n, unit_next) = match first.strip_suffix('m') {
            Some(n) if n.parse::<f64>().is_ok() => (n, false),
            _ => (first, true),
        };
        let Ok(r) = n.parse::<f64>() else { continue };
        let mut after: Vec<&str> = nw.collect();
        if unit_next {
            if !matches!(
                after.first().map(|u| u.trim_end_matches([',', '.'])),
                Some("m" | "metres" | "meters" | "metre" | "meter")
            ) {
                continue;
            }
            after.remove(0);
        }
        // what is counted stands before "whose"/"with"/"at"
        let head = t[..i]
            .trim_end_matches(" ground")
            .trim_end_matches(" ground-plane")
            .trim_end_matches(" straight-line");
        let head = ["whose", "with a", "with", "that have a", "having a"]
            .iter()
            .find_map(|c| head.strip_suffix(c))
            .unwrap_or(head);
        let place = phrase(&rest[..j]);
        if r.is_finite() && r >= 0.0 && !place.is_empty() {
            return Some((r, place, clean(&format!("{head} {}", after.join(" ")))));
        }
    }
    let w: Vec<&str> = t.split_whitespace().collect();
    for i in 0..w.len() {
        let n_at = match w[i] {
            // "within a 30 m radius of"
            "within" | "in" | "inside" if w.get(i + 1) == Some(&"a") => i + 2,
            "within" | "in" | "inside" => i + 1,
            "than" if i > 0 && matches!(w[i - 1], "less" | "closer" | "nearer") => i + 1,
            _ => continue,
        };
        let Some(num) = w.get(n_at) else { continue };
        let (n, unit_next) = match num.strip_suffix('m') {
            Some(n) if !n.is_empty() && n.parse::<f64>().is_ok() => (n, false),
            _ => (*num, true),
        };
        let Ok(r) = n.parse::<f64>() else { continue };
        let mut j = n_at + 1;
        if unit_next {
            if !matches!(
                w.get(j).copied(),
                Some(
                    "m" | "metres"
                        | "meters"
                        | "metre"
                        | "meter"
                        | "m,"
                        | "metres,"
                        | "meters,"
                        | "metre,"
                        | "meter,"
                )
            ) {
                continue;
            }
            j += 1;
        }
        if w.get(j).copied() == Some("radius") {
            j += 1;
        }
        let start = if i > 0 && w[i] == "than" { i - 1 } else { i };
        if matches!(
            w.get(j).copied(),
            Some("of" | "from" | "around" | "away" | "to")
        ) {
            j += 1;
        } else if let Some(k) = (0..start)
            .rev()
            .find(|&k| matches!(w[k], "around" | "near" | "from" | "of"))
        {
            // the place said first: "around the centre of segment 4, inside 25 m, how many"
            let k = if w[k] == "of" && k > 0 && matches!(w[k - 1], "centre" | "center") {
                (0..k)
                    .rev()
                    .find(|&m| w[m] == "around" || w[m] == "near")
                    .unwrap_or(k)
            } else {
                k
            };
            let place = trim_words(&w[k + 1..start].join(" "), &[], &[]);
            let place = if w[k] == "of" {
                place
            } else {
                place.trim_end_matches(',').to_string()
            };
            let before = w[..k].join(" ");
            let after = w[j..].join(" ");
            if r.is_finite() && r >= 0.0 && !place.is_empty() {
                return Some((r, phrase(&place), clean(&format!("{before} {after}"))));
            }
        }
        if w.get(j).copied() == Some("from") {
            j += 1;
        }
        // the place runs to a comma or the end
        let rest = w[j..].join(" ");
        let (place, after) = match rest.split_once(',') {
            Some((p, a)) => (p.to_string(), a.to_string()),
            None => (rest, String::new()),
        };
        let before = w[..start].join(" ");
        let place = trim_words(&place, &[], &["is", "are", "there", "how", "many"]);
        if r.is_finite() && r >= 0.0 && !place.is_empty() {
            return Some((r, phrase(&place), clean(&format!("{before} {after}"))));
        }
    }
    None
}

/// Trims articles and filler from the ends of a phrase; keeps "the".
fn phrase(s: &str) -> String {
    // "lane node 4 and has to get": a place ends where "and" opens a verb
    let mut s = s.to_string();
    let words: Vec<&str> = s.split(' ').collect();
    if let Some(k) = (0..words.len().saturating_sub(1)).find(|&k| {
        words[k] == "and"
            && (VERBS.contains(&words[k + 1])
                || MORE_VERBS.contains(&words[k + 1])
                || matches!(
                    words[k + 1],
                    "then" | "must" | "needs" | "wants" | "has" | "have"
                ))
    }) {
        s = words[..k].join(" ");
    }
    let t = trim_words(
        &s,
        &["is", "are", "there", "located", "of"],
        &[
            "located", "situated", "standing", "placed", "parked", "is", "are", "there", "have",
            "has", "does", "do", "exist", "exists", "in", "at", "on", "to", "from", "the", "over",
            "back", "across",
        ],
    );
    let t = t.trim();
    // "in metres" and "on the map" after a place
    let mut t = t.to_string();
    for tail in [
        " in metres",
        " in meters",
        " on the map",
        " in the map",
        " on the lane graph",
        " along the lanes",
        " by road",
        " shortest path",
        " on the road",
        " please",
        " in a straight line",
        " in straight line",
        " straight line",
        " as the crow flies",
        " over the ground",
        ", id",
        " its id",
        " the id",
        " node id",
        " id",
        ", dear",
        " dear",
    ] {
        if let Some(r) = t.strip_suffix(tail) {
            t = r.trim().to_string();
        }
    }
    // a place never holds a question ("lane node 4 how long is the shortest route")
    if let Some(i) = [" how ", " what "]
        .iter()
        .filter_map(|q| format!("{t} ").find(q))
        .min()
    {
        t = t[..i].trim().to_string();
    }
    // "the crossroads that is segment 2404": the node named
    for sep in [" that is ", " which is ", " i.e. ", ", "] {
        if let Some((_, tail)) = t.rsplit_once(sep)
            && super::spec_in_words(tail).is_some()
        {
            t = tail.trim().to_string();
        }
    }
    // words run on after a node's id ("object 1481 straight line"): the node
    if t.chars().any(|c| c.is_ascii_digit()) && super::spec_in_words(&t).is_none() {
        let w: Vec<&str> = t.split(' ').collect();
        if let Some(k) = (1..w.len()).find(|&k| {
            w[k - 1].trim_start_matches('#').parse::<u64>().is_ok()
                && super::spec_in_words(&w[..k].join(" ")).is_some()
        }) {
            t = w[..k].join(" ");
        }
    }
    t
}

/// A phrase's segment kind when it names segments: `Some(None)` for segments of every
/// kind, `Some(Some(k))` for a kind, `None` when it names something else.
fn segments_named(kind: &str) -> Option<Option<SegmentConstraint>> {
    // "segments of straight road" names straight roads
    for lead in [
        "segments of ",
        "segment of ",
        "road segments of ",
        "sections of ",
        "pieces of ",
    ] {
        if let Some(rest) = kind.strip_prefix(lead)
            && let Some(Some(k)) = segments_named(rest)
        {
            return Some(Some(k));
        }
    }
    // "segments classified as straight road sections"
    for sep in [
        " classified as ",
        " categorised as ",
        " categorized as ",
        " labelled as ",
        " labeled as ",
        " marked as ",
        " tagged as ",
        " typed as ",
        " of the type ",
        " of the kind ",
    ] {
        if let Some((a, b)) = kind.split_once(sep)
            && segments_named(a) == Some(None)
            && let Some(Some(k)) = segments_named(b)
        {
            return Some(Some(k));
        }
    }
    // "bends or corners": one kind said two ways; a corner (any junction) gives way to a
    // kind of junction
    if let Some((a, b)) = kind.split_once(" or ") {
        return match (segments_named(a)?, segments_named(b)?) {
            (Some(x), Some(y)) if x == y => Some(Some(x)),
            (Some(SegmentConstraint::Junction), Some(x))
            | (Some(x), Some(SegmentConstraint::Junction))
                if x != SegmentConstraint::StraightRoad =>
            {
                Some(Some(x))
            }
            _ => None,
        };
    }
    let k = trim_words(
        kind,
        &["the", "all", "any", "of", "road", "distinct", "different"],
        &[],
    );
    let k = format!(" {k} ");
    let mut k = k;
    for (plural, one) in [
        (" t-junctions ", " t-junction "),
        (" t junctions ", " t-junction "),
        (" t-intersections ", " t-intersection "),
        (" three-way junctions ", " t-junction "),
        (" three-way intersections ", " t-junction "),
        (" l-bends ", " bend "),
        (" l-shaped bends ", " bend "),
        (" bends ", " bend "),
        (" corners ", " corner "),
        (" intersections ", " intersection "),
        (" four-way intersections ", " four-way intersection "),
        (" four-way junctions ", " four-way junction "),
        (" crossings ", " crossing "),
        (" straight roads ", " straight road "),
        (" straight streets ", " straight street "),
        (" straight stretches of road ", " straight stretch of road "),
        (" straight stretches ", " straight stretch "),
        (" straight sections ", " straight road "),
        (" straight road sections ", " straight road "),
        (" straight road section ", " straight road "),
        (" straight road segments ", " straight road "),
        (" straight segments ", " straight road "),
        (" junctions ", " junction "),
    ] {
        k = k.replace(plural, one);
    }
    let k = k.trim();
    if matches!(
        k,
        "segments"
            | "segment"
            | "road segments"
            | "sections"
            | "road sections"
            | "parts of road"
            | "segments of road"
            | "sections of road"
            | "pieces of road"
    ) {
        return Some(None);
    }
    if matches!(k, "junction" | "junctions" | "junction segments") {
        return Some(Some(SegmentConstraint::Junction));
    }
    let (seg, rest) = take_segment(k);
    let rest = trim_words(
        &rest,
        &["s", "four-way", "three-way", "proper"],
        &["segments", "segment", "s", "es", "roads"],
    );
    match seg {
        Some(s) if rest.is_empty() => Some(Some(s)),
        _ => None,
    }
}

/// The kind a count asks for and the rest of the question: "how many X are in P" → ("X",
/// "are in P").
fn split_kind(t: &str) -> (String, String) {
    let spaced = t.replace(',', " , ");
    let words: Vec<&str> = spaced.split(' ').filter(|w| !w.is_empty()).collect();
    let mut end = words.len();
    for (i, w) in words.iter().enumerate() {
        let w = if *w == "," {
            ""
        } else {
            w.trim_end_matches(',')
        };
        // a second determiner opens another phrase ("trash cans the map contains")
        let determiner = i > 0 && matches!(w, "the" | "this" | "that" | "these" | "our" | "my");
        let stop = VERBS.contains(&w)
            || determiner
            || w.is_empty()
            || (PLACE_PREPS.contains(&w) && i > 0 && !(w == "of" && is_kind_of(&words, i)))
            || matches!(
                w,
                "does"
                    | "do"
                    | "there"
                    | "that"
                    | "which"
                    | "whose"
                    | "who"
                    | "counting"
                    | "am"
                    | "should"
                    | "would"
                    | "could"
                    | "can"
                    | "will"
                    | "might"
                    | "must"
                    | "shall"
                    | "including"
                    | "recorded"
                    | "logged"
                    | "listed"
                    | "captured"
                    | "anywhere"
                    | "excluding"
                    | "-"
            )
            || words[i].ends_with(',');
        if stop {
            end = if words[i] != ","
                && words[i].ends_with(',')
                && !VERBS.contains(&w)
                && !PLACE_PREPS.contains(&w)
            {
                i + 1
            } else {
                i
            };
            break;
        }
    }
    (
        words[..end]
            .join(" ")
            .trim_end_matches(',')
            .trim()
            .to_string(),
        words[end..].join(" ").replace(" , ", ", "),
    )
}

/// "of" inside a kind ("stretches of road", "pieces of street furniture") rather than
/// before a place ("within 20 m of").
fn is_kind_of(words: &[&str], i: usize) -> bool {
    matches!(
        words.get(i - 1).copied(),
        Some(
            "stretches"
                | "stretch"
                | "pieces"
                | "piece"
                | "sections"
                | "section"
                | "parts"
                | "part"
                | "segments"
                | "types"
                | "kinds"
                | "rows"
                | "row"
                | "pairs"
        )
    )
}

/// Words before a kind that are not part of it ("return the trailers", "all distinct
/// benches").
const KIND_FRONT: [&str; 23] = [
    "the",
    "proper",
    "actual",
    "real",
    "simply",
    "just",
    "either",
    "all",
    "any",
    "of",
    "distinct",
    "different",
    "individual",
    "identify",
    "find",
    "give",
    "return",
    "list",
    "show",
    "report",
    "get",
    "a",
    "an",
];
/// Words after a kind that name no kind ("trailer instances", "bench objects").
const KIND_BACK: [&str; 13] = [
    "you",
    "present",
    "existing",
    "would",
    "be",
    "instances",
    "instance",
    "objects",
    "items",
    "ones",
    "units",
    "nodes",
    "entries",
];

/// Whether `kind` names road segments (a kind of segment, segments in general, or several
/// kinds: "crossroads or T-junctions") rather than objects.
pub fn names_segments(kind: &str) -> bool {
    let k = trim_words(&clean(kind), &KIND_FRONT, &KIND_BACK);
    segments_named(&k).is_some() || segment_union(&k).is_some()
}

/// Several kinds of road segment said together ("crossroads or T-junctions", "bends and
/// straight roads", "crossroads, T-junctions and bends"), each once, in the order said; `None`
/// unless every part names a kind and there are two or more.
fn segment_union(kind: &str) -> Option<Vec<SegmentConstraint>> {
    let mut k = format!(" {kind} ");
    for sep in [
        " and/or ",
        " or ",
        " and ",
        " & ",
        ", ",
        " plus ",
        " as well as ",
    ] {
        k = k.replace(sep, "|");
    }
    let k = k.replace(['/', ','], "|");
    let mut kinds = Vec::new();
    for part in k.split('|') {
        let part = trim_words(part.trim(), &KIND_FRONT, &KIND_BACK);
        if part.is_empty() {
            continue;
        }
        match segments_named(&part) {
            Some(Some(x)) => {
                if !kinds.contains(&x) {
                    kinds.push(x)
                }
            }
            _ => return None,
        }
    }
    (kinds.len() >= 2).then_some(kinds)
}

/// A count of segments that hold something ("segments with at least one hydrant", "how many
/// crossroads have traffic lights", "in how many segments is there a bench"): the segments,
/// said before the cue, and the kind they hold, after it. `None` when the words before the
/// cue are not segments, or the words after it are a part of a road ("junctions with four
/// arms"), not an object.
fn segments_holding(after: &str) -> Option<Task> {
    const CUES: [&str; 22] = [
        " that have ",
        " which have ",
        " that has ",
        " which has ",
        " that contain ",
        " which contain ",
        " containing ",
        " contain ",
        " contains ",
        " having ",
        " have ",
        " has ",
        " holding ",
        " hold ",
        " where there is ",
        " where there are ",
        " is there ",
        " are there ",
        " with ",
        " feature ",
        " featuring ",
        " host ",
    ];
    // parts of a road, not objects on it
    const ROAD_PARTS: [&str; 16] = [
        "arm", "way", "leg", "exit", "branch", "side", "shape", "corner", "lane", "road", "street",
        "entrance", "approach", "turn", "end", "kind",
    ];
    let said = format!(" {after} ");
    let (i, cue) = CUES
        .iter()
        .filter_map(|c| said.find(c).map(|i| (i, *c)))
        .min_by_key(|(i, _)| *i)?;
    let mut head = said[..i].trim().to_string();
    for tail in [
        " are there",
        " is there",
        " there",
        " do",
        " does",
        " in total",
        " overall",
    ] {
        if let Some(h) = head.strip_suffix(tail) {
            head = h.trim().to_string();
        }
    }
    let head = trim_words(&head, &KIND_FRONT, &KIND_BACK);
    let kinds = match segments_named(&head) {
        Some(k) => k.into_iter().collect(),
        None => segment_union(&head)?,
    };
    let mut rest = said[i + cue.len()..].trim().to_string();
    // "is there a hydrant", "are there any benches": the verb's own "there"
    for lead in [
        "at least one ",
        "at least a ",
        "one or more ",
        "any ",
        "some ",
        "a ",
        "an ",
        "one ",
        "there ",
    ] {
        if let Some(r) = rest.strip_prefix(lead) {
            rest = r.to_string();
        }
    }
    let held = trim_words(&split_kind(&rest).0, &KIND_FRONT, &KIND_BACK);
    let words: Vec<String> = held.split(' ').map(stem).collect();
    if held.is_empty()
        || names_segments(&held)
        || matches!(
            held.as_str(),
            "it" | "them" | "this" | "that" | "they" | "map"
        )
        || words.iter().any(|w| ROAD_PARTS.contains(&w.as_str()))
    {
        return None;
    }
    Some(Task::count_segments_of(kinds, Some(held)))
}

/// What a count question counts, and where.
fn count_task(t: &str) -> Option<Task> {
    let (radius, t) = match radius_of(t) {
        Some((r, place, rest)) => (Some((r, place)), rest),
        None => (None, t.to_string()),
    };
    // the cue and what opens the counted phrase
    let mut rest = format!(" {t} ");
    for cue in [
        " what is the total number of ",
        " what's the total number of ",
        " what is the number of ",
        " what's the number of ",
        " the total number of ",
        " total number of ",
        " the number of ",
        " number of ",
        " total count of ",
        " the count of ",
        " count of ",
        " how many ",
        " how much ",
        " count all the ",
        " count all ",
        " count the ",
        " count ",
        " tally of ",
        " total ",
        " are there any ",
        " is there any ",
        " are there ",
    ] {
        rest = rest.replacen(cue, " # ", 1);
    }
    // the counted phrase follows the first cue; anything before it is a place or filler
    let (before, after) = match rest.split_once('#') {
        Some((b, a)) => (b.trim().to_string(), a.trim().to_string()),
        None => (String::new(), rest.trim().to_string()),
    };
    let after = after.replace('#', " ");
    let after = trim_words(&after, &["the", "all", "any", "of"], &[]);
    if radius.is_none()
        && let Some(t) = segments_holding(&after)
    {
        return Some(t);
    }
    let (kind, tail) = if after.is_empty() || after.starts_with("are ") || after == "are" {
        // "people in segment 4 - how many", "pedestrians in segment 4 if so how many"
        split_kind(&trim_words(&before, &["the", "all", "any"], &[]))
    } else {
        split_kind(&after)
    };
    let kind = trim_words(&kind, &KIND_FRONT, &KIND_BACK);
    if kind.is_empty() {
        return None;
    }
    // "segments of straight road"
    for lead in [
        "segments of ",
        "segment of ",
        "road segments of ",
        "sections of ",
        "stretches of ",
    ] {
        if let Some(rest) = after.strip_prefix(lead)
            && let Some(Some(k)) = segments_named(&split_kind(rest).0)
        {
            return Some(Task::count_segments(Some(k)));
        }
    }
    // a list of kinds runs past the first comma, where the kind phrase ends
    let listed = || {
        let said = format!(" {after} ");
        let end = [
            " are ", " is ", " on ", " in ", " does ", " do ", " there ", " exist", " have ",
            " has ", " within ", " across ",
        ]
        .iter()
        .filter_map(|c| said.find(c))
        .min()
        .unwrap_or(said.len());
        let head = said[..end].trim();
        segments_named(head)
            .is_none()
            .then(|| segment_union(head))
            .flatten()
    };
    // "junctions that are not full crossroads, meaning the T-junctions and the bends": a
    // restatement says which segments exactly
    if names_segments(&kind) {
        for marker in [
            ", meaning ",
            " meaning ",
            ", i.e. ",
            ", i.e ",
            ", ie ",
            ", namely ",
            ", that is ",
            ", in other words ",
        ] {
            let Some((_, def)) = after.split_once(marker) else {
                continue;
            };
            let def = def.split(',').next().unwrap_or("").trim();
            let mut def = def.to_string();
            for tail in [
                " taken together",
                " together",
                " combined",
                " in total",
                " altogether",
                " on the map",
            ] {
                if let Some(d) = def.strip_suffix(tail) {
                    def = d.trim().to_string();
                }
            }
            let def = trim_words(&def, &KIND_FRONT, &KIND_BACK);
            let kinds = match segments_named(&def) {
                Some(Some(k)) => Some(vec![k]),
                Some(None) => None,
                None => segment_union(&def),
            };
            if let Some(kinds) = kinds {
                return Some(Task::count_segments_of(kinds, None));
            }
        }
    }
    let union = if segments_named(&kind).is_none() {
        segment_union(&kind)
    } else {
        None
    };
    if let Some(kinds) = union.or_else(listed) {
        return Some(Task::count_segments_of(kinds, None));
    }
    if let Some(seg) = segments_named(&kind) {
        // "how many segments are junctions (of any type)": the kind follows "are"
        if seg.is_none() {
            let said = format!(" {after} ");
            if let Some((_, what)) = [
                " classified as ",
                " categorised as ",
                " categorized as ",
                " labelled as ",
                " labeled as ",
                " marked as ",
                " tagged as ",
                " that are ",
                " which are ",
                " whose kind is ",
                " whose type is ",
                " of kind ",
                " of type ",
                " being ",
                " are ",
            ]
            .iter()
            .find_map(|sep| said.split_once(sep))
            {
                let what = trim_words(
                    what.trim(),
                    &[
                        "simply", "just", "only", "either", "all", "purely", "proper",
                    ],
                    &[],
                );
                let what = what.as_str();
                // an aside ("junctions, i.e. crossroads, t-junctions and bends") adds nothing
                let what = [
                    ",",
                    " i.e",
                    " ie ",
                    " e.g",
                    " eg ",
                    " such as ",
                    " like ",
                    " that is ",
                ]
                .iter()
                .filter_map(|c| what.find(c))
                .min()
                .map_or(what, |i| &what[..i]);
                let mut what = what.trim().to_string();
                for tail in [
                    "of any type",
                    "of any kind",
                    "of any sort",
                    "in total",
                    "altogether",
                    "in the map",
                    "on the map",
                ] {
                    if let Some(r) = what.strip_suffix(tail) {
                        what = r.trim().to_string();
                    }
                }
                if let Some(Some(k)) = segments_named(&what) {
                    return Some(Task::count_segments(Some(k)));
                }
            }
        }
        return Some(Task::count_segments(seg));
    }
    if let Some((r, place)) = radius {
        return Some(Task::Count {
            kind,
            within: None,
            near: Some(place),
            radius_m: Some(r),
        });
    }
    // where: "in/at/on/along P", "does P have", "P contains"; the words after the kind
    // first, then those before its cue ("in segment 4, how many benches are there"), unless
    // the words after name the whole map ("... trailers recorded anywhere on the map")
    let (within, near) = match place_of_count(tail.trim()) {
        (None, None) if !after.is_empty() && !says_whole_map(&tail) => {
            place_of_count(format!("{tail} {before}").trim())
        }
        found => found,
    };
    Some(Task::Count {
        kind,
        within,
        near,
        radius_m: None,
    })
}

/// Whether the words after a count's kind name the whole map as its place ("on the map",
/// "anywhere", "in total").
fn says_whole_map(tail: &str) -> bool {
    let t = format!(" {tail} ");
    [
        " anywhere ",
        " in total ",
        " all told ",
        " altogether ",
        " overall ",
    ]
    .iter()
    .any(|c| t.contains(c))
        || {
            let words: Vec<&str> = t.split_whitespace().collect();
            words.iter().enumerate().any(|(i, w)| {
                matches!(*w, "on" | "in" | "across" | "throughout" | "over")
                    && whole_map(&words[i + 1..words.len().min(i + 7)].join(" "))
            })
        }
}

/// The place of a count from the words after its kind: `(within, near)`.
fn place_of_count(tail: &str) -> (Option<String>, Option<String>) {
    let t = format!(" {tail} ");
    // "does segment 4 have", "has segment 4 got"
    for (open, close) in [
        (" does ", [" have ", " contain ", " hold ", " include "]),
        (" do ", [" have ", " contain ", " hold ", " include "]),
        (" has ", [" got ", " in it ", " contain ", " hold "]),
    ] {
        if let Some(i) = t.find(open) {
            let after = &t[i + open.len() - 1..];
            if let Some(j) = close.iter().filter_map(|c| after.find(c)).min() {
                let place = phrase(&after[..j]);
                return (
                    (!place.is_empty() && !whole_map(&place)).then_some(place),
                    None,
                );
            }
        }
    }
    // "(how many hydrants) the segment 2416 has"
    for verb in [" has ", " have ", " contains ", " holds ", " includes "] {
        if let Some(place) = t.find(verb).map(|i| phrase(&t[..i]))
            && !place.is_empty()
        {
            if whole_map(&place) {
                return (None, None);
            }
            if super::spec_in_words(&place).is_some() || is_segment_place(&place) {
                return (Some(place), None);
            }
        }
    }
    // a place after a preposition
    let words: Vec<&str> = t.split_whitespace().collect();
    for (i, w) in words.iter().enumerate() {
        let near = matches!(*w, "near" | "around" | "by" | "beside")
            || (*w == "close" && words.get(i + 1) == Some(&"to"))
            || (*w == "next" && words.get(i + 1) == Some(&"to"));
        let inside = matches!(
            *w,
            "in" | "on" | "at" | "inside" | "within" | "along" | "across" | "throughout" | "over"
        );
        if !(near || inside) {
            continue;
        }
        let skip = if matches!(*w, "close" | "next") { 2 } else { 1 };
        let place = words[i + skip..].join(" ");
        let place = phrase(place.split(',').next().unwrap_or(""));
        if place.is_empty() || whole_map(&place) {
            return (None, None);
        }
        // a place that names the whole map by what it holds ("the map contains")
        return if near && !is_segment_place(&place) {
            (None, Some(place))
        } else {
            (Some(place), None)
        };
    }
    (None, None)
}

/// Whether a place is a road segment (by id or kind) rather than an object.
fn is_segment_place(place: &str) -> bool {
    super::spec_in_words(place).is_some_and(|s| s.starts_with("segment:"))
        || take_segment(place).0.is_some()
}

/// Two places joined by `and`, `to` or `from`, in the order asked: "between A and B", "from
/// A to B", "A from B", "A and B apart".
fn two_places(t: &str) -> Option<(String, String)> {
    let t = t.trim();
    // a place ends at a comma and a space ("from A to B, how many metres ..."); "x,z"
    // coordinates have no space
    let upto_comma = |s: &str| s.split(", ").next().unwrap_or("").to_string();
    // a place with a number must be a node by id ("lane node 4", not "lane node 4 and has")
    let place_ok = |x: &str| {
        !x.is_empty()
            && (!x.chars().any(|c| c.is_ascii_digit())
                || super::spec_in_words(x).is_some()
                || x.contains(','))
    };
    // at the first `sep` whose two sides are both places, else at the first `sep`
    let split = |s: &str, sep: &str| -> Option<(String, String)> {
        let mut first: Option<(String, String)> = None;
        let mut from = 0;
        while let Some(i) = at_words(&s[from..], sep).map(|i| i + from) {
            let (a, b) = (
                phrase(s[..i].rsplit(", ").next().unwrap_or("")),
                phrase(&upto_comma(&s[i + sep.len()..])),
            );
            if place_ok(&a) && place_ok(&b) {
                return Some((a, b));
            }
            if first.is_none() && !a.is_empty() && !b.is_empty() {
                first = Some((a, b));
            }
            from = i + sep.len();
        }
        first
    };
    // "lane nodes 4 and 9": each end takes the kind
    let plural_ids = |a: &str, b: &str| -> (String, String) {
        let aw: Vec<&str> = a.split(' ').collect();
        if aw.len() >= 2
            && aw
                .last()
                .is_some_and(|x| x.trim_start_matches('#').parse::<u64>().is_ok())
            && b.trim_start_matches('#').parse::<u64>().is_ok()
        {
            let kind = aw[..aw.len() - 1].join(" ");
            let one = kind.strip_suffix('s').map_or(kind.clone(), str::to_string);
            return (format!("{one} {}", aw[aw.len() - 1]), format!("{one} {b}"));
        }
        (a.to_string(), b.to_string())
    };
    if let Some(i) = at_words(t, "between") {
        let (a, b) = split(&t[i + 8..], "and")?;
        return Some(plural_ids(&a, &b));
    }
    if let Some(i) = at_words(t, "from") {
        let rest = &t[i + 5..];
        if let Some((a, b)) = split(rest, "to") {
            return Some(plural_ids(&a, &b));
        }
        // "A from B": A is the last phrase of its clause, after a verb that separates the
        // two ("the distance that separates A from B")
        let head = t[..i].rsplit(", ").next().unwrap_or("");
        // ("between" never reaches here: it is read above)
        let head = [" separates ", " separate "]
            .iter()
            .filter_map(|v| head.rfind(v).map(|j| &head[j + v.len()..]))
            .min_by_key(|h| h.len())
            .unwrap_or(head);
        let before = phrase(head);
        let after = phrase(rest);
        if !before.is_empty() && !after.is_empty() {
            return Some((before, after));
        }
    }
    if let Some(x) = split(t, "to") {
        return Some(plural_ids(&x.0, &x.1));
    }
    split(t, "and").map(|(a, b)| plural_ids(&a, &b))
}

/// Words that open a distance or route question and name no place.
const DISTANCE_FRONT: [&str; 40] = [
    "what",
    "what's",
    "whats",
    "is",
    "the",
    "straight-line",
    "straight",
    "line",
    "ground",
    "ground-plane",
    "euclidean",
    "direct",
    "distance",
    "how",
    "far",
    "many",
    "metres",
    "meters",
    "separate",
    "separates",
    "apart",
    "are",
    "away",
    "it",
    "in",
    "lane-graph",
    "lane",
    "graph",
    "driving",
    "drive",
    "shortest",
    "route",
    "length",
    "long",
    "would",
    "i",
    "have",
    "to",
    "get",
    "travel",
];

/// The task a question is: the rule parser for the common forms and many rephrasings.
///
/// The question is first freed of what names nothing ([`prepare`]: polite openings, a label
/// before a colon, remarks in parentheses, follow-up sentences merged and their pronouns
/// filled). Then its cue words decide the task, wherever they stand, most specific first:
/// where am I; a route length (a route, a drive, driving or lane-graph distance); a
/// distance ("distance", "how far", "metres separate", "apart"); a count ("how many",
/// "number of", "count"; of road segments when what it counts is a segment kind); the
/// nearest ("nearest", "closest"); a colour; which segment or what kind of road; what
/// stands around something; where something is. The places and kinds are the words around
/// the cues, with verbs, prepositions and filler trimmed.
pub fn parse_question(text: &str) -> Option<Task> {
    let p = prepare(text);
    // an end with a number that names no node is words run together, not a place
    let muddled = |x: &str| {
        (x.chars().any(|c| c.is_ascii_digit()) && super::spec_in_words(x).is_none())
            || has_any(
                x,
                &[
                    "the first",
                    "the second",
                    "the former",
                    "the latter",
                    "the other",
                    "there",
                    "how far",
                    "how long",
                    "how many",
                ],
            )
            || matches!(x, "it" | "is it" | "here")
    };
    // "as the crow flies" says a straight-line distance is asked, though the preparation
    // drops it to free the places: a question read as no distance is read again as one
    let straight = has_any(
        &text.to_lowercase(),
        &["as the crow flies", "in a straight line", "straight-line"],
    );
    let first = read_prepared(p.question.trim(), text);
    let first = match first {
        Some(Task::Distance { .. } | Task::RouteLength { .. }) => first,
        _ if straight => read_prepared(&format!("how far {}", p.question.trim()), text)
            .filter(|t| matches!(t, Task::Distance { .. }))
            .or(first),
        _ => first,
    };
    first
        .filter(|t| match t {
            Task::RouteLength { from, to } | Task::Distance { from, to } => {
                !(muddled(from) || muddled(to)) || ends_in_context(&p).is_none()
            }
            // a distance or route asked, read as something else
            Task::Count { .. } => true,
            _ => {
                let q = p.question.trim();
                !(route_asked(q) || distance_asked(q)) || ends_in_context(&p).is_none()
            }
        })
        .or_else(|| ends_in_context(&p))
        .or_else(|| {
            (p.whole != p.question)
                .then(|| read_prepared(p.whole.trim(), text))
                .flatten()
        })
}

/// A route or distance asked in one sentence between two nodes another sentence named by id
/// ("Our van sets off from lane node 2431 and has to get to lane node 2429. How long is the
/// shortest way there?"): the two ids in the order said.
fn ends_in_context(p: &Prepared) -> Option<Task> {
    let q = p.question.trim();
    let (route, distance) = (route_asked(q), distance_asked(q));
    if p.context.is_empty() || !(route || distance) {
        return None;
    }
    // "I'm standing where the drive started. ... How far is it to segment 4?": from where
    // the asker is to the one place the question names
    if let Some(here) = asker_at(&p.context)
        && let Some(i) = at_words(q, "to").filter(|_| !has(q, "from") && !has(q, "between"))
    {
        let to = phrase(&q[i + 2..]);
        if !to.is_empty() {
            return Some(if route {
                Task::RouteLength { from: here, to }
            } else {
                Task::Distance { from: here, to }
            });
        }
    }
    let w: Vec<&str> = p.context.split(' ').filter(|w| !w.is_empty()).collect();
    let mut ends: Vec<String> = Vec::new();
    for i in 0..w.len() {
        let core = w[i].trim_end_matches([',', '.']);
        if !core
            .trim_start_matches('#')
            .chars()
            .all(|c| c.is_ascii_digit())
            && !core.contains(':')
        {
            continue;
        }
        // the node words before the id ("lane node 2431", "segment #12", "object 86")
        let mut a = i;
        while a > 0
            && i - a < 4
            && matches!(
                w[a - 1],
                "lane" | "node" | "segment" | "road" | "object" | "instance" | "id" | "with"
            )
        {
            a -= 1;
        }
        let named = Some(w[a..=i].join(" ").trim_end_matches([',', '.']).to_string())
            .filter(|ph| a < i && super::spec_in_words(ph).is_some());
        if let Some(ph) = named
            && !ends.contains(&ph)
        {
            ends.push(ph);
        }
    }
    let [from, to] = <[String; 2]>::try_from(ends).ok()?;
    Some(if route {
        Task::RouteLength { from, to }
    } else {
        Task::Distance { from, to }
    })
}

/// Where the asker says they are: "I'm standing where the drive started", "I am at the
/// bus stop", "we're parked next to segment 4".
fn asker_at(context: &str) -> Option<String> {
    // "standing in the middle of segment 4. how many ...": the asker, unsaid
    let unsaid = ["standing ", "parked ", "sitting ", "waiting ", "stopped "]
        .iter()
        .any(|v| context.starts_with(v));
    let t = if unsaid {
        format!(" i'm {context} ")
    } else {
        format!(" {context} ")
    };
    for me in [
        " i'm ",
        " i am ",
        " we're ",
        " we are ",
        " were i ",
        " i were ",
        " if i stand ",
        " if i stood ",
        " my position is ",
        " my current position is ",
        " my location is ",
        " our position is ",
    ] {
        let Some(i) = t.find(me) else { continue };
        let mut rest = t[i + me.len()..].trim();
        for verb in [
            "standing",
            "parked",
            "waiting",
            "sitting",
            "stopped",
            "camping",
            "hanging out",
            "based",
            "located",
            "now",
            "right",
        ] {
            rest = rest.strip_prefix(verb).map_or(rest, str::trim);
        }
        for prep in [
            "next to", "close to", "at", "by", "near", "beside", "on", "in",
        ] {
            if let Some(r) = rest.strip_prefix(prep).filter(|r| r.starts_with(' ')) {
                rest = r.trim();
                break;
            }
        }
        // the longest run of words that names an end of the drive or a node, else a noun
        // phrase ("the bus stop")
        let words: Vec<&str> = rest
            .split([',', '.', ';'])
            .next()
            .unwrap_or("")
            .split_whitespace()
            .collect();
        if let Some(n) = (1..=words.len().min(8)).rev().find(|&n| {
            let cand = words[..n].join(" ");
            super::drive_end_of(&cand).is_some() || super::spec_in_words(&cand).is_some()
        }) {
            return Some(words[..n].join(" "));
        }
        if matches!(
            words.first().copied(),
            Some("the" | "a" | "an" | "that" | "this")
        ) {
            let n = (1..words.len())
                .find(|&k| ends_np(words[k]) || PARTICIPLES.contains(&words[k]))
                .unwrap_or(words.len());
            return Some(format!("the {}", words[1..n].join(" ")));
        }
    }
    // "I just finished a snack at the green climbing frame": where the asker did something
    if t.starts_with(" i ") || t.starts_with(" we ") {
        let at = [
            " at the ",
            " by the ",
            " next to the ",
            " beside the ",
            " near the ",
        ]
        .iter()
        .filter_map(|p| t.find(p).map(|k| k + p.len()))
        .min()?;
        let words: Vec<&str> = t[at..]
            .split([',', '.', ';'])
            .next()
            .unwrap_or("")
            .split_whitespace()
            .collect();
        let n = (1..words.len())
            .find(|&k| ends_np(words[k]) || PARTICIPLES.contains(&words[k]))
            .unwrap_or(words.len());
        if n > 0 {
            return Some(format!("the {}", words[..n].join(" ")));
        }
    }
    None
}

/// The words of a route length: a route, a drive, the lane graph.
fn route_asked(t: &str) -> bool {
    (has_any(
        t,
        &[
            "route",
            "routes",
            "drive from",
            "driving",
            "drive to get",
            "drive between",
            "lane graph",
            "lane-graph",
            "along the lanes",
            "along the lane graph",
            "by road",
            "shortest path",
            "path length",
            "travel distance",
            "travel from",
            "drives along",
            "shortest drive",
            "how far would i have to drive",
            "how far do i drive",
            "how far would i drive",
            "how long is the drive",
            "how far is it to drive",
            "lane network",
            "lane route",
            "following the lanes",
            "shortest way",
        ],
    ) || keeps_to_lanes(t))
        && !t.contains("start of the route")
        && !t.contains("end of the route")
}

/// "keeping to the lanes", "via the lanes", "staying on the roads": a way along the lane
/// graph (not "parked in the parking lanes").
fn keeps_to_lanes(t: &str) -> bool {
    let w: Vec<&str> = t
        .split(' ')
        .map(|x| x.trim_end_matches([',', '.']))
        .collect();
    (0..w.len()).any(|i| {
        let at = |k: usize| i.checked_sub(k).and_then(|j| w.get(j)).copied();
        let way = matches!(at(1), Some("via" | "using" | "following"));
        let after_the =
            |preps: &[&str]| at(1) == Some("the") && at(2).is_some_and(|x| preps.contains(&x));
        (match w[i] {
            "lanes" => {
                way || after_the(&[
                    "to",
                    "on",
                    "via",
                    "using",
                    "following",
                    "along",
                    "by",
                    "through",
                ])
            }
            "roads" => way || after_the(&["to", "via", "using", "following", "by"]),
            _ => false,
        }) && !(1..=4).any(|k| matches!(at(k), Some("not" | "than" | "instead")))
    })
}

/// A question asks for metres.
fn metres_asked(t: &str) -> bool {
    has_any(
        t,
        &[
            "how many metres",
            "how many meters",
            "how many m",
            "in metres",
            "in meters",
        ],
    )
}

/// The words of a straight-line distance ("distance", "how far", "apart"), but
/// not a distance said as an idiom ("spot it from a distance", "in the distance").
fn distance_asked(t: &str) -> bool {
    let mut t = format!(" {t} ");
    for idiom in [
        " from a distance ",
        " at a distance ",
        " in the distance ",
        " keep my distance ",
        " keep a distance ",
        " walking distance ",
    ] {
        t = t.replace(idiom, " ");
    }
    let t = t.trim();
    has_any(
        t,
        &[
            "distance",
            "how far",
            "separate",
            "separates",
            "apart",
            "far away",
        ],
    ) || (metres_asked(t) && has_any(t, &["from", "between"]))
}

/// "which X has the smallest (ground-plane) distance to P" → "which X is nearest to P".
fn smallest_distance_is_nearest(t: &str) -> String {
    let w: Vec<&str> = t.split(' ').collect();
    for i in 0..w.len() {
        if !matches!(
            w[i],
            "smallest" | "shortest" | "least" | "minimum" | "lowest" | "minimal"
        ) {
            continue;
        }
        let Some(j) = (i + 1..(i + 3).min(w.len())).find(|&j| w[j] == "distance") else {
            continue;
        };
        // to one place, asked of a kind ("which bin ..."), not between two
        if !matches!(w.get(j + 1).copied(), Some("to" | "from"))
            || !matches!(
                w.first().copied(),
                Some("which" | "what" | "identify" | "find" | "give" | "return" | "name")
            )
        {
            continue;
        }
        let mut start = i;
        while start > 0 && matches!(w[start - 1], "the" | "has" | "have" | "with" | "at") {
            start -= 1;
        }
        return format!(
            "{} is nearest {}",
            w[..start].join(" "),
            w[j + 1..].join(" ")
        )
        .trim()
        .to_string();
    }
    t.to_string()
}

/// [`parse_question`] on a prepared sentence; `text` is the question as asked (a locate
/// takes it whole).
fn read_prepared(t: &str, text: &str) -> Option<Task> {
    if t.is_empty() {
        return None;
    }
    // where am I
    if t.starts_with("where am i")
        || t.starts_with("i'm at")
        || t.starts_with("i am at")
        || t.starts_with("i'm standing")
        || t.starts_with("i am standing")
        || t.starts_with("i'm next to")
        || t.starts_with("i'm near")
        || t.starts_with("i'm on")
        || t.starts_with("i am on")
    {
        return Some(Task::Locate {
            text: text.trim().to_string(),
        });
    }
    // "which bin has the smallest distance to X" asks for the nearest
    let rewritten = smallest_distance_is_nearest(t);
    let t = rewritten.as_str();
    let metres_asked = metres_asked(t);
    let route_words = route_asked(t);
    let distance_words = distance_asked(t);
    // "the number of letter boxes whose distance to P is at most 25 m" counts
    if has_any(t, &["how many", "number of", "count"]) && radius_of(t).is_some() {
        return count_task(t);
    }
    if route_words {
        let body = trim_keep(
            t,
            &DISTANCE_FRONT,
            &["long", "is", "the", "route", "please"],
        );
        if let Some((from, to)) = two_places(&body) {
            return Some(Task::RouteLength { from, to });
        }
    }
    if distance_words {
        let body = trim_keep(t, &DISTANCE_FRONT, &["apart", "away", "is", "are"]);
        if let Some((from, to)) = two_places(&body) {
            return Some(Task::Distance { from, to });
        }
    }
    // counts
    if has_any(
        t,
        &[
            "how many",
            "number of",
            "count",
            "total",
            "tally",
            "how much",
        ],
    ) && !metres_asked
    {
        return count_task(t);
    }
    // nearest
    if let Some(cue) = ["nearest", "closest"].iter().find(|c| has(t, c)) {
        let i = at_words(t, cue).expect("found");
        let after = t[i + cue.len()..].trim();
        // "the nearest X to P" / "X nearest to P" / "which X is nearest to P"
        let (kind_after, place) = match ["to", "from", "near", "of"]
            .iter()
            .filter_map(|s| at_words(after, s).map(|j| (j, s.len())))
            .min()
        {
            Some((j, n)) => (
                after[..j].trim().to_string(),
                after[j + n..].trim().to_string(),
            ),
            None => (String::new(), after.to_string()),
        };
        let before = t[..i].trim();
        let kind_after = if matches!(kind_after.as_str(), "one" | "ones" | "the one") {
            String::new()
        } else {
            kind_after
        };
        let kind = if kind_after.is_empty() {
            let b = trim_keep(
                before,
                &[
                    "which", "what", "where", "is", "are", "the", "find", "show", "me", "give",
                    "who", "what's", "where's",
                ],
                &[
                    "is",
                    "are",
                    "the",
                    "one",
                    "that",
                    "which",
                    "stands",
                    "lies",
                    "sits",
                    "parked",
                    "standing",
                    "located",
                    "sitting",
                    "placed",
                    "lying",
                    "situated",
                    "positioned",
                    "found",
                    "stationed",
                ],
            );
            if b.is_empty() && before.starts_with("who") {
                "person".to_string()
            } else {
                b
            }
        } else if kind_after == "person" || before.starts_with("who") && kind_after.is_empty() {
            "person".to_string()
        } else {
            kind_after
        };
        let kind = trim_words(&kind, &KIND_FRONT, &KIND_BACK);
        let kind = if matches!(kind.as_str(), "one" | "ones") {
            String::new()
        } else {
            kind
        };
        let place = phrase(&place);
        if !kind.is_empty() && !place.is_empty() {
            return Some(Task::Nearest { kind, near: place });
        }
    }
    // colour
    if has_any(
        t,
        &[
            "colour", "color", "colours", "colors", "coloured", "colored",
        ],
    ) {
        let obj = trim_keep(
            &t.replace("'s ", " is ")
                .replace("colour's", "colour is")
                .replace("color's", "color is"),
            &[
                "what", "which", "colour", "color", "colours", "colors", "is", "are", "was", "the",
                "of", "tell", "me", "give", "say", "know", "paint", "painted", "does", "do",
                "have", "has", "in", "what's", "should", "would", "could", "will", "must", "might",
            ],
            &[
                "colour", "color", "painted", "is", "are", "have", "has", "in", "of", "what", "be",
            ],
        );
        let obj = if obj.starts_with("the ")
            || obj.contains(' ')
            || obj.contains(':')
            || obj.contains('#')
        {
            obj
        } else {
            format!("the {obj}")
        };
        if !obj.trim().is_empty() && obj != "the " {
            return Some(Task::Colour {
                object: phrase(&obj),
            });
        }
    }
    // "benches in segment 12", "bins within 20 m of the truck": the things asked for with
    // their place and no question word are counted (the count lists them too)
    let first = t.split(' ').next().unwrap_or("");
    if !matches!(
        first,
        "where" | "what" | "which" | "who" | "how" | "is" | "are" | "find" | "show" | "locate"
    ) {
        let (kind, tail) = split_kind(t);
        let plural = kind
            .split(' ')
            .next_back()
            .is_some_and(|h| h.len() > 3 && stem(h) != h);
        let placed = [
            "in ", "within ", "at ", "on ", "near ", "around ", "inside ",
        ]
        .iter()
        .any(|p| tail.starts_with(p));
        if plural && placed {
            return count_task(&format!("how many {t}"));
        }
    }
    // which segment, what kind of road
    let road_nouns = [
        "segment",
        "junction",
        "road",
        "road section",
        "section",
        "intersection",
        "place",
        "street",
        "crossing",
        "corner",
        "stretch",
        "spot",
        "roadway",
    ];
    let kind_asked = ["kind of", "type of", "sort of"]
        .iter()
        .any(|k| road_nouns.iter().any(|n| has(t, &format!("{k} {n}"))));
    let segment_asked = has(t, "segment") && !has(t, "how many")
        || kind_asked
        || has_any(
            t,
            &["road type", "segment kind", "junction type", "road kind"],
        )
        || (has(t, "or") && cut_segment_choices(t) != t);
    if segment_asked {
        let t2 = cut_segment_choices(t);
        let obj = trim_keep(
            &t2,
            &[
                "which",
                "what",
                "in",
                "on",
                "at",
                "kind",
                "type",
                "sort",
                "of",
                "segment",
                "segments",
                "road",
                "section",
                "junction",
                "intersection",
                "place",
                "street",
                "map",
                "would",
                "will",
                "could",
                "id",
                "is",
                "are",
                "does",
                "do",
                "did",
                "contains",
                "contain",
                "containing",
                "holding",
                "holds",
                "the",
                "where",
                "where's",
                "number",
                "crossing",
                "corner",
                "stretch",
                "spot",
                "roadway",
                "give",
                "me",
                "name",
                "belongs",
                "belong",
                "to",
                "find",
                "get",
            ],
            &[
                "in", "on", "at", "to", "belong", "belongs", "located", "situated", "standing",
                "parked", "stands", "sits", "lies", "is", "are", "placed", "found", "part", "of",
                "segment", "which", "kind", "what", "type", "sit", "stand", "lie", "be", "dear",
                "would",
            ],
        );
        if !obj.is_empty() {
            let obj = if obj.split(' ').count() == 1 && !obj.starts_with('#') {
                format!("the {obj}")
            } else {
                obj
            };
            return Some(Task::Segment { object: obj });
        }
    }
    // what stands around something
    for lead in [
        "what is next to ",
        "what's next to ",
        "what is around ",
        "what's around ",
        "what stands around ",
        "what stands near ",
        "what is near ",
        "what's near ",
        "what is beside ",
        "what's beside ",
        "what else is near ",
        "what else is around ",
        "what is close to ",
        "what's close to ",
        "what surrounds ",
        "what is by ",
    ] {
        if let Some(rest) = t.strip_prefix(lead) {
            return Some(Task::Neighbours {
                object: phrase(rest),
            });
        }
    }
    for lead in [
        "where is ",
        "where's ",
        "where are ",
        "find ",
        "show me ",
        "locate ",
        "where can i find ",
        "where do i find ",
    ] {
        if let Some(rest) = t.strip_prefix(lead) {
            return Some(Task::Find { text: phrase(rest) });
        }
    }
    None
}

/// A word as it is compared: lower case, without surrounding punctuation, and without a
/// plural ending ("benches" and "bench" compare equal).
fn stem(w: &str) -> String {
    let w = w
        .trim_matches(|c: char| !c.is_alphanumeric() && c != '-')
        .to_lowercase();
    for end in ["ches", "shes", "sses", "xes"] {
        if let Some(r) = w.strip_suffix(end) {
            return format!("{r}{}", &end[..end.len() - 2]);
        }
    }
    if let Some(r) = w.strip_suffix("ies")
        && r.len() > 2
    {
        return format!("{r}y");
    }
    if w.len() > 3 && w.ends_with('s') && !w.ends_with("ss") {
        return w[..w.len() - 1].to_string();
    }
    w
}

/// Words a reading's arguments may carry that the question need not say.
const FREE_WORDS: [&str; 14] = [
    "the", "a", "an", "of", "to", "segment", "instance", "lane", "node", "drive", "start", "end",
    "map", "id",
];

/// Whether a language model's reading of `question` is grounded in it: the task's cue is in
/// the question (a count needs "how many", "number" or "count"; a count of road segments a
/// road word; the nearest "nearest" or "closest"; a distance "distance", "far", "apart",
/// "separate" or metres; a route length a route, a drive or the lane graph; a colour
/// "colour"; a segment a segment or a kind of road), and every word of its kinds and places
/// is a word of the question (plurals aside; an id's number must be in the question). A
/// small model that fills a form from its examples or the tools' descriptions instead of the
/// question fails this; the rule parser's reading is then used.
///
/// # Errors
/// What is not grounded, as a message.
pub fn check_grounded(task: &Task, question: &str) -> std::result::Result<(), String> {
    let q = prepare(question).whole;
    let words: std::collections::BTreeSet<String> = q
        .split(|c: char| c.is_whitespace() || matches!(c, ',' | ':' | '#' | '/'))
        .filter(|w| !w.is_empty())
        .map(stem)
        .collect();
    let cue = |cues: &[&str]| cues.iter().any(|c| has(&q, c) || q.contains(c));
    let said = |arg: &str, what: &str| -> std::result::Result<(), String> {
        let missing: Vec<String> = arg
            .split(|c: char| c.is_whitespace() || matches!(c, ',' | ':' | '#' | '/' | '\''))
            .filter(|w| !w.is_empty())
            .map(stem)
            .filter(|w| !w.is_empty() && !FREE_WORDS.contains(&w.as_str()) && !words.contains(w))
            .collect();
        if missing.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "{what} {arg:?} has words the question does not say: {}",
                missing.join(", ")
            ))
        }
    };
    let counts = ["how many", "number", "count", "total", "tally"];
    let roads = [
        "segment",
        "junction",
        "crossroad",
        "intersection",
        "bend",
        "corner",
        "straight",
        "road",
        "crossing",
        "stretch",
    ];
    let need = |ok: bool, task: &str, cues: &str| {
        if ok {
            Ok(())
        } else {
            Err(format!("a {task} needs {cues} in the question"))
        }
    };
    // a thing asked about is not a road segment or lane node by id (a model that keeps only
    // "segment:12" of "the scooter in segment 12")
    let not_a_road = |object: &str| -> std::result::Result<(), String> {
        match super::spec_in_words(object) {
            Some(sp) if sp.starts_with("segment:") || sp.starts_with("lane:") => Err(format!(
                "the object {object:?} is a road segment or lane node, not a thing"
            )),
            _ => Ok(()),
        }
    };
    match task {
        Task::Count {
            kind, within, near, ..
        } => {
            need(
                cue(&counts),
                "count",
                "\"how many\", \"number\" or \"count\"",
            )?;
            said(kind, "the kind")?;
            if let Some(w) = within {
                said(w, "the place")?;
            }
            if let Some(n) = near {
                said(n, "the place")?;
            }
            Ok(())
        }
        Task::CountSegments { holding, .. } => {
            need(
                cue(&counts),
                "count",
                "\"how many\", \"number\" or \"count\"",
            )?;
            need(cue(&roads), "count of road segments", "a road word")?;
            if let Some(h) = holding {
                said(h, "the kind held")?;
            }
            // a count of objects in a segment is not a count of segments
            match parse_question(question) {
                Some(Task::Count { kind, .. }) => {
                    Err(format!("the question counts {kind:?}, not road segments"))
                }
                _ => Ok(()),
            }
        }
        Task::Nearest { kind, near } => {
            need(
                cue(&["nearest", "closest", "close"]),
                "nearest",
                "\"nearest\" or \"closest\"",
            )?;
            said(kind, "the kind")?;
            said(near, "the place")
        }
        Task::Distance { from, to } => {
            need(
                cue(&[
                    "distance",
                    "far",
                    "apart",
                    "separate",
                    "metres",
                    "meters",
                    "how many m",
                ]),
                "distance",
                "\"distance\", \"far\", \"apart\" or metres",
            )?;
            // along the lanes is a route's length, not a straight line
            if route_asked(&q) {
                return Err(
                    "the question asks for a route along the lanes, not a straight-line distance"
                        .into(),
                );
            }
            said(from, "the place")?;
            said(to, "the place")
        }
        Task::RouteLength { from, to } => {
            need(
                cue(&[
                    "route", "drive", "driving", "lane", "path", "travel", "by road",
                ]),
                "route length",
                "a route, a drive or the lane graph",
            )?;
            said(from, "the start")?;
            said(to, "the goal")
        }
        Task::Segment { object } => {
            need(
                cue(&roads) || cue(&["kind of", "type of", "sort of"]),
                "segment",
                "a segment or a kind of road",
            )?;
            not_a_road(object)?;
            said(object, "the object")
        }
        Task::Colour { object } => {
            need(cue(&["colour", "color"]), "colour", "\"colour\"")?;
            not_a_road(object)?;
            said(object, "the object")
        }
        Task::Neighbours { object } => said(object, "the object"),
        // where one is: said of oneself
        Task::Locate { .. } => need(
            cue(&[
                "i'm",
                "i am",
                "am i",
                "we're",
                "we are",
                "are we",
                "i'm standing",
                "my ",
                "i stand",
                "here",
            ]),
            "locate",
            "where the asker is (\"I'm at\", \"where am I\")",
        ),
        Task::Find { text } => said(text, "the object"),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn radio_procedure_is_dropped_and_nothing_else() {
        use super::drop_radio_procedure as d;
        assert_eq!(
            d("unit 4 to base: count of traffic lights, segment 2329, over."),
            "count of traffic lights, segment 2329."
        );
        assert_eq!(
            d("base, this is unit 7. what's the tally of trailers? over."),
            "what's the tally of trailers?"
        );
        assert_eq!(
            d("rover three to base. request the count. over and out"),
            "request the count."
        );
        // a route or a definition with a colon is not procedure
        assert_eq!(
            d("lane node 2352 to lane node 2360: how long is the route?"),
            "lane node 2352 to lane node 2360: how long is the route?"
        );
        assert_eq!(d("how far is it, 2.5 km?"), "how far is it, 2.5 km?");
        assert_eq!(
            d("unit 7 to base, the letter box in segment 2350: what colour is it? over."),
            "the letter box in segment 2350: what colour is it?"
        );
        // a clause that is not a call stays
        assert_eq!(
            d("from lane node 4 to base camp, how far?"),
            "from lane node 4 to base camp, how far?"
        );
        assert_eq!(
            d("is the bus over there red?"),
            "is the bus over there red?"
        );
    }

    use super::*;

    fn count(kind: &str, within: Option<&str>, near: Option<&str>, r: Option<f64>) -> Task {
        Task::Count {
            kind: kind.into(),
            within: within.map(Into::into),
            near: near.map(Into::into),
            radius_m: r,
        }
    }

    /// References across sentences point back before they point forward; "that lane node",
    /// "that segment's centre", a bare "the X" after "the X ..." said in full; purposes
    /// ("for the records") and reporters ("the article says") are not what is asked about.
    #[test]
    fn references_point_back_and_purposes_are_not_objects() {
        let seg = |o: &str| Task::Segment { object: o.into() };
        let colour = |o: &str| Task::Colour { object: o.into() };
        let cases: Vec<(&str, Task)> = vec![
            (
                "The blue van was towed yesterday. Which segment is it in? I need it for the insurance form.",
                seg("the blue van"),
            ),
            (
                "A bus pulled away from lane node 12. Which bench is closest to that lane node?",
                Task::Nearest {
                    kind: "bench".into(),
                    near: "lane node 12".into(),
                },
            ),
            (
                "Mark the middle of segment 7 on the plan. How many bins are within 20 metres of that segment's centre?",
                count("bins", None, Some("the segment 7"), Some(20.0)),
            ),
            (
                "For the inventory, what colour is the tall lamp by the kiosk?",
                colour("the tall lamp by the kiosk"),
            ),
            (
                "Black scooter parked on the pavement - crossroads, bend, T or straight road?",
                seg("the black scooter parked on the pavement"),
            ),
            (
                "The article says the old oak tree beside a school is at a bend. What kind of road is it really on?",
                seg("the old oak tree beside a school"),
            ),
            (
                "A witness saw a large van with tinted windows near the scene. What colour is that van?",
                colour("the large van with tinted windows"),
            ),
            (
                "How many benches are listed anywhere on the map?",
                count("benches", None, None, None),
            ),
            (
                "I'm building a report on the district, and I need the number of benches on the map.",
                count("benches", None, None, None),
            ),
            (
                "I doubt the colour of the scooter in segment 9. Could you confirm what colour it's recorded as?",
                colour("the scooter in segment 9"),
            ),
            (
                "How many junctions are there, meaning crossroads and bends taken together?",
                Task::CountSegments {
                    segment_kind: Some(SegmentConstraint::Crossroads),
                    or_kinds: vec![SegmentConstraint::Bend],
                    holding: None,
                },
            ),
        ];
        for (q, want) in cases {
            assert_eq!(parse_question(q), Some(want), "{q}");
        }
        // texting and field notes
        for (q, want) in [
            (
                "if im camping at lane node 12, how many bins r within 45 metres of me",
                count("bins", None, Some("lane node 12"), Some(45.0)),
            ),
            (
                "base = lane node 12 lol. how many benches within 60m of it??",
                count("benches", None, Some("lane node 12"), Some(60.0)),
            ),
        ] {
            assert_eq!(parse_question(q), Some(want), "{q}");
        }
        match parse_question(
            "theres a big van parked by the curb. how far is it from lane node 12 as the crow flies",
        ) {
            Some(Task::Distance { from, to }) => {
                assert!(
                    from.contains("big van") && to == "lane node 12",
                    "{from} / {to}"
                )
            }
            other => panic!("{other:?}"),
        }
        // "the lamp" after "the tall lamp by the kiosk" was said
        let q = "The tall lamp by the kiosk was hit by a lorry. Was the lamp standing at a bend or on a straight road?";
        match parse_question(q) {
            Some(Task::Segment { object }) => {
                assert!(object.contains("tall lamp by the kiosk"), "{object}")
            }
            other => panic!("{q}: {other:?}"),
        }
        // a purpose after the last comma goes, one with a number stays
        assert_eq!(drop_purpose("colour, for the records"), "colour");
        assert_eq!(
            drop_purpose("for the photo log, what colour is it"),
            "what colour is it"
        );
        assert_eq!(
            drop_purpose("how many benches, for example in segment 4"),
            "how many benches, for example in segment 4"
        );
    }

    #[test]
    fn unions_of_segment_kinds_and_segments_holding_a_kind_are_read() {
        use SegmentConstraint::*;
        let segs = |kinds: &[SegmentConstraint], holding: Option<&str>| Task::CountSegments {
            segment_kind: kinds.first().copied(),
            or_kinds: kinds.iter().skip(1).copied().collect(),
            holding: holding.map(Into::into),
        };
        let cases: Vec<(&str, Task)> = vec![
            (
                "How many crossroads or T-junctions are there?",
                segs(&[Crossroads, TJunction], None),
            ),
            (
                "Count the bends and straight roads on the map",
                segs(&[Bend, StraightRoad], None),
            ),
            (
                "number of crossroads, T-junctions and bends",
                segs(&[Crossroads, TJunction, Bend], None),
            ),
            (
                "How many segments have at least one fire hydrant?",
                segs(&[], Some("fire hydrant")),
            ),
            (
                "In how many segments is there a bench?",
                segs(&[], Some("bench")),
            ),
            (
                "how many crossroads have traffic lights",
                segs(&[Crossroads], Some("traffic lights")),
            ),
            (
                "How many road segments contain a post box?",
                segs(&[], Some("post box")),
            ),
            (
                "how many T-junctions or bends are there with a bus shelter",
                segs(&[TJunction, Bend], Some("bus shelter")),
            ),
            // a part of the road is not an object the segment holds
            (
                "How many junctions have four arms?",
                segs(&[Junction], None),
            ),
            ("How many segments does the map have?", segs(&[], None)),
            // one kind said two ways stays one kind
            ("How many bends or corners are there?", segs(&[Bend], None)),
        ];
        for (q, want) in cases {
            assert_eq!(parse_question(q), Some(want), "{q}");
        }
        // objects in segments that hold something are counted as objects
        assert!(
            matches!(
                parse_question("How many benches are there in segments with a hydrant?"),
                Some(Task::Count { .. })
            ),
            "{:?}",
            parse_question("How many benches are there in segments with a hydrant?")
        );
        assert!(names_segments("crossroads or T-junctions"));
        assert!(names_segments("the T-junctions"));
        assert!(!names_segments("fire hydrants"));
        // a model's form: a kind that is no road is what the segments hold
        let form = |kind: &str| TaskForm {
            action: "count_segments".into(),
            kind: kind.into(),
            place: String::new(),
            radius_m: None,
            segment_kind: None,
            to: String::new(),
        };
        assert_eq!(
            form("hydrant").into_task("q").unwrap(),
            segs(&[], Some("hydrant"))
        );
        assert_eq!(form("junctions").into_task("q").unwrap(), segs(&[], None));
        // the kind held must be said
        let q = "How many segments have a hydrant?";
        assert!(check_grounded(&segs(&[], Some("hydrant")), q).is_ok());
        assert!(check_grounded(&segs(&[], Some("bench")), q).is_err());
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
                Task::count_segments(Some(SegmentConstraint::TJunction)),
            ),
            (
                "How many crossroads does the map have?",
                Task::count_segments(Some(SegmentConstraint::Crossroads)),
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

    /// Idioms that name no task, the subject of "separates A from B", and the whole map in
    /// other words.
    #[test]
    fn idioms_straight_lines_and_the_whole_map() {
        // a GIS analyst's words for objects in a segment
        for (q, kind, within) in [
            (
                "Feature count of fences assigned to segment polygon 12?",
                "fences",
                "segment polygon 12",
            ),
            (
                "Give the number of fence features contained in segment 12.",
                "fence",
                "segment 12",
            ),
        ] {
            assert_eq!(
                parse_question(q),
                Some(count(kind, Some(within), None, None)),
                "{q}"
            );
        }
        // the place a nearest is measured from, said first
        let q = "From lane node 7, which bench is nearest?";
        assert_eq!(
            parse_question(q),
            Some(Task::Nearest {
                kind: "bench".into(),
                near: "lane node 7".into()
            }),
            "{q}"
        );
        // a place said first, after discourse markers
        let q = "Okay, um, so in segment 12, how many rubbish bins are there?";
        assert_eq!(
            parse_question(q),
            Some(count("rubbish bins", Some("segment 12"), None, None)),
            "{q}"
        );
        // texting forms of function words, and the whole map said as a study area or extent
        for (q, kind) in [
            ("hw many hydrants does teh map have", "hydrants"),
            ("how many benches r there on the map, thx", "benches"),
            ("Count the hydrants across the full map extent.", "hydrants"),
            ("How many benches are in the entire study area?", "benches"),
        ] {
            assert_eq!(
                parse_question(q),
                Some(count(kind, None, None, None)),
                "{q}"
            );
        }
        let q = "wat colour is the bench";
        assert!(
            matches!(parse_question(q), Some(Task::Colour { .. })),
            "{q}: {:?}",
            parse_question(q)
        );
        let q = "What colour is the bench, so I can find it from a distance?";
        assert!(
            matches!(parse_question(q), Some(Task::Colour { .. })),
            "{q}: {:?}",
            parse_question(q)
        );
        // a straight line said as the only cue of a distance
        let q = "Post box 12 to segment 40, as the crow flies, metres?";
        assert_eq!(
            parse_question(q),
            Some(Task::Distance {
                from: "post box 12".into(),
                to: "segment 40".into()
            }),
            "{q}"
        );
        // "there" after a preposition is the place said before
        let q = "Pulling in at lane node 7. Mailboxes inside 25 m of there - count?";
        assert_eq!(
            parse_question(q),
            Some(count("mailboxes", None, Some("lane node 7"), Some(25.0))),
            "{q}"
        );
        // a thing fronted with a demonstrative is what "it" means
        let q = "That heavy blue scooter up on its kickstand, which bin is closest to it?";
        match parse_question(q) {
            Some(Task::Nearest { kind, near }) => {
                assert_eq!(kind, "bin");
                assert!(near.starts_with("the heavy blue scooter"), "{near}");
            }
            other => panic!("{q}: {other:?}"),
        }
        let q = "Kindly state, for the record, the distance that separates the bench with node \
                 id 77 from segment 9.";
        match parse_question(q) {
            Some(Task::Distance { from, to }) => {
                assert_eq!(
                    super::super::spec_in_words(&from).as_deref(),
                    Some("node:77")
                );
                assert_eq!(
                    super::super::spec_in_words(&to).as_deref(),
                    Some("segment:9")
                );
            }
            other => panic!("{q}: {other:?}"),
        }
        let q = "How many benches are on the map in its entirety?";
        assert_eq!(
            parse_question(q),
            Some(count("benches", None, None, None)),
            "{q}"
        );
    }

    /// Questions written by someone who had not seen the parser (the tuning half of an
    /// independent set): each is one task with its arguments.
    #[test]
    fn rephrased_questions_are_read() {
        let seg = |k| Task::count_segments(Some(k));
        let cases: Vec<(&str, Task)> = vec![
            (
                "Could you tell me how many trash cans the map contains?",
                count("trash cans", None, None, None),
            ),
            (
                "okay so uh how many fire hydrants are there on the whole map",
                count("fire hydrants", None, None, None),
            ),
            (
                "How much trash cans the map is having in total?",
                count("trash cans", None, None, None),
            ),
            (
                "um traffic lights in segment 2401 how many are there",
                count("traffic lights", Some("segment 2401"), None, None),
            ),
            (
                "Fire safety inspection is booked for seg 2416 next week. The inspector asked \
                 me how many hydrants that segment has. Can you tell me?",
                count("hydrants", Some("the segment 2416"), None, None),
            ),
            (
                "How many four-way crossing the map have?",
                seg(SegmentConstraint::Crossroads),
            ),
            (
                "We're redrawing the route cards for the new drivers. I need to know how many \
                 T-intersections there are on the map.",
                seg(SegmentConstraint::TJunction),
            ),
            (
                "okay so how many bends or corners does the map have",
                seg(SegmentConstraint::Bend),
            ),
            (
                "How many segment of straight road is existing in the map?",
                seg(SegmentConstraint::StraightRoad),
            ),
            (
                "Around the centre of segment 2421, inside 25 metre, how many rubbish bin you \
                 can find?",
                count(
                    "rubbish bin",
                    None,
                    Some("the centre of segment 2421"),
                    Some(25.0),
                ),
            ),
            (
                "Which trash can is the most near to the start point of the drive?",
                Task::Nearest {
                    kind: "trash can".into(),
                    near: "the start point of the drive".into(),
                },
            ),
            (
                "The white billboard, which bench is the most close to it?",
                Task::Nearest {
                    kind: "bench".into(),
                    near: "the white billboard".into(),
                },
            ),
            (
                "okay so distance from object 86 to object 1481 straight line please",
                Task::Distance {
                    from: "object 86".into(),
                    to: "object 1481".into(),
                },
            ),
            (
                "From the end of the drive until the beige camper van, how many metres it is in \
                 straight line?",
                Task::Distance {
                    from: "the end of the drive".into(),
                    to: "the beige camper van".into(),
                },
            ),
            (
                "okay so uh if i drive along the lanes from lane node 2425 to lane node 2433 how \
                 long is the shortest route",
                Task::RouteLength {
                    from: "lane node 2425".into(),
                    to: "lane node 2433".into(),
                },
            ),
            (
                "How long is the shortest way on the lane graph from node 2434 until node 2432?",
                Task::RouteLength {
                    from: "node 2434".into(),
                    to: "node 2432".into(),
                },
            ),
            (
                "Two of our vans: one at lane node 2425, the other at lane node 2431. If the \
                 first drives over to the second along the lanes, what's the shortest route \
                 length?",
                Task::RouteLength {
                    from: "lane node 2425".into(),
                    to: "lane node 2431".into(),
                },
            ),
            (
                "There's a trailer we've been keeping an eye on, object 86. Which segment is \
                 that one in?",
                Task::Segment {
                    object: "the object 86".into(),
                },
            ),
            (
                "Kids' party delivery today. The drop point is at the green climbing frame. \
                 Which segment is that in?",
                Task::Segment {
                    object: "the green climbing frame".into(),
                },
            ),
            (
                "okay so object 1481 what kind of road is it on like a crossroads or a bend or \
                 what",
                Task::Segment {
                    object: "the object 1481".into(),
                },
            ),
            (
                "The object 1317, on which kind of road it stands? Four-way, T-intersection, \
                 corner or straight stretch?",
                Task::Segment {
                    object: "the object 1317".into(),
                },
            ),
            (
                "We've got traffic light 623 flagged as faulty. What type of road does that one \
                 sit on: a four-way crossroads, a T-junction, a bend, or a straight stretch?",
                Task::Segment {
                    object: "the traffic light 623".into(),
                },
            ),
            (
                "okay so the letter box in segment 2422 what colour is it",
                Task::Colour {
                    object: "the letter box in segment 2422".into(),
                },
            ),
            (
                "The bench in segment 2413, what colour it has?",
                Task::Colour {
                    object: "the bench in segment 2413".into(),
                },
            ),
            (
                "Someone dropped a bag into the litter bin in seg 2416 by mistake. I need to \
                 tell the cleaner which bin to look for. What colour is that one?",
                Task::Colour {
                    object: "the litter bin in segment 2416".into(),
                },
            ),
            (
                "I'm standing where the drive started. Segment 2406 is where I need to be. As \
                 the crow flies, how far is it to the centre of that one?",
                Task::Distance {
                    from: "where the drive started".into(),
                    to: "the centre of segment 2406".into(),
                },
            ),
            (
                "When the drive kicked off, the vehicle was next to a junction. How many traffic \
                 lights are there within 15 metres of the spot where the drive started?",
                count(
                    "traffic lights",
                    None,
                    Some("the spot where the drive started"),
                    Some(15.0),
                ),
            ),
            (
                "Return the number of letter boxes whose ground distance to the centroid of \
                 segment 2406 is at most 25 m.",
                count(
                    "letter boxes",
                    None,
                    Some("the centroid of segment 2406"),
                    Some(25.0),
                ),
            ),
            (
                "Were I standing beside that large red delivery truck, which hatchback would be \
                 the nearest to me? Do give me its id, if you would.",
                Task::Nearest {
                    kind: "hatchback".into(),
                    near: "the large red delivery truck".into(),
                },
            ),
            (
                "seg 2423 - how many hatchbacks in there?",
                count("hatchbacks", Some("segment 2423"), None, None),
            ),
            (
                "how many bins/trash cans in segment no. 2421?",
                count("bins", Some("segment 2421"), None, None),
            ),
            (
                "red cast-iron hydrant on the sidewalk - what kind of rd is it on? 4-way, T, \
                 corner or straight?",
                Task::Segment {
                    object: "the red cast-iron hydrant".into(),
                },
            ),
            (
                "benches in seg 2410?",
                count("benches", Some("segment 2410"), None, None),
            ),
            (
                "How many segments are junctions of any type, i.e. crossroads and bends?",
                seg(SegmentConstraint::Junction),
            ),
            (
                "Our van sets off from lane node 2431 and has to get to lane node 2429. How \
                 long is the shortest way there if it sticks to the lane network?",
                Task::RouteLength {
                    from: "lane node 2431".into(),
                    to: "lane node 2429".into(),
                },
            ),
            (
                "Total count of street lamps (lamp posts included), whole map.",
                count("street lamps", None, None, None),
            ),
            (
                "people in segment:2411 - how many?",
                count("people", Some("segment:2411"), None, None),
            ),
            (
                "How many litter bins does segment 2421 have?",
                count("litter bins", Some("segment 2421"), None, None),
            ),
            (
                "Are there any pedestrians in segment 2401? If so, how many?",
                count("pedestrians", Some("segment 2401"), None, None),
            ),
            (
                "Within 60 metres of the start of the drive, how many letter boxes are there?",
                count(
                    "letter boxes",
                    None,
                    Some("the start of the drive"),
                    Some(60.0),
                ),
            ),
            (
                "How many straight stretches of road has the map got?",
                seg(SegmentConstraint::StraightRoad),
            ),
            (
                "Could you count the four-way intersections for me?",
                seg(SegmentConstraint::Crossroads),
            ),
            (
                "Who is the closest person to the climbing frame?",
                Task::Nearest {
                    kind: "person".into(),
                    near: "the climbing frame".into(),
                },
            ),
            (
                "Operator query: closest hydrant to crossroads segment 2406 (its centroid).",
                Task::Nearest {
                    kind: "hydrant".into(),
                    near: "crossroads segment 2406".into(),
                },
            ),
            (
                "How many metres separate the silver fire hydrant from the white speed limit sign?",
                Task::Distance {
                    from: "the silver fire hydrant".into(),
                    to: "the white speed limit sign".into(),
                },
            ),
            (
                "If a robot drives along the lanes from node 2431 to node 2428, how many metres is the shortest route?",
                Task::RouteLength {
                    from: "node 2431".into(),
                    to: "node 2428".into(),
                },
            ),
            (
                "Could you work out the shortest driving distance between lane nodes 2428 and 2430?",
                Task::RouteLength {
                    from: "lane node 2428".into(),
                    to: "lane node 2430".into(),
                },
            ),
            (
                "In which road segment is the red delivery truck parked?",
                Task::Segment {
                    object: "the red delivery truck".into(),
                },
            ),
            (
                "Is object 1300 at a crossroads, a T-junction, a bend or on a straight road?",
                Task::Segment {
                    object: "object 1300".into(),
                },
            ),
            (
                "There's just one fire hydrant standing at a bend. What colour is it?",
                Task::Colour {
                    object: "the fire hydrant standing at a bend".into(),
                },
            ),
            (
                "what colour's the billboard",
                Task::Colour {
                    object: "the billboard".into(),
                },
            ),
        ];
        assert_all_read(cases);
    }

    /// Every case is read as its task; the failures are listed together.
    fn assert_all_read(cases: Vec<(&str, Task)>) {
        let wrong: Vec<String> = cases
            .into_iter()
            .filter_map(|(q, want)| {
                let got = parse_question(q);
                (got.as_ref() != Some(&want))
                    .then(|| format!("{q}\n  got {got:?}\n  want {want:?}"))
            })
            .collect();
        assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    }

    /// Exam-style leads ("Determine ...", "Given X, ..."), radio talk, work orders, and
    /// references across sentences (the subject for "it", "there", "its centre", "between
    /// them", where the asker is).
    #[test]
    fn exam_style_leads_and_references_across_sentences_are_read() {
        let seg = |k| Task::count_segments(Some(k));
        let cases: Vec<(&str, Task)> = vec![
            (
                "Determine the total number of trailers recorded in the map.",
                count("trailers", None, None, None),
            ),
            (
                "State the number of speed limit signs present across the entire mapped area.",
                count("speed limit signs", None, None, None),
            ),
            (
                "I'm rather curious - how many fire hydrants are there in the entire neighbourhood?",
                count("fire hydrants", None, None, None),
            ),
            (
                "Work out how many benches the whole district has.",
                count("benches", None, None, None),
            ),
            (
                "Determine the number of segments classified as straight road sections.",
                seg(SegmentConstraint::StraightRoad),
            ),
            (
                "How many road segments are categorised as T-junctions?",
                seg(SegmentConstraint::TJunction),
            ),
            (
                "Given the crossroads segment 2404, state how many speed limit signs lie within 50 m of its centre.",
                count("speed limit signs", None, Some("segment 2404"), Some(50.0)),
            ),
            (
                "The red delivery truck needs a tow. Which hatchback is parked nearest to it?",
                Task::Nearest {
                    kind: "hatchback".into(),
                    near: "the red delivery truck".into(),
                },
            ),
            (
                "Identify the minibus situated nearest to the beige camper van.",
                Task::Nearest {
                    kind: "minibus".into(),
                    near: "the beige camper van".into(),
                },
            ),
            (
                "Roughly how far is the silver fire hydrant from where the drive set off?",
                Task::Distance {
                    from: "the silver fire hydrant".into(),
                    to: "where the drive set off".into(),
                },
            ),
            (
                "Keeping to the lanes, how far is it from lane node #2431 over to lane node #2424?",
                Task::RouteLength {
                    from: "lane node #2431".into(),
                    to: "lane node #2424".into(),
                },
            ),
            (
                "Via the roads, how far is it from lane node 7 to lane node 9?",
                Task::RouteLength {
                    from: "lane node 7".into(),
                    to: "lane node 9".into(),
                },
            ),
            (
                "How far apart is segment 1 from segment 2 in a straight line, and not by the roads?",
                Task::Distance {
                    from: "segment 1".into(),
                    to: "segment 2".into(),
                },
            ),
            (
                "silver camper van - what segment is it in?",
                Task::Segment {
                    object: "the silver camper van".into(),
                },
            ),
            (
                "Given lane nodes 2430 and 2434, compute the length of the shortest lane-graph route between them.",
                Task::RouteLength {
                    from: "lane nodes 2430".into(),
                    to: "lane nodes 2434".into(),
                },
            ),
            (
                "There's a trimmed hedge along a garden somewhere - what type of road segment is it in?",
                Task::Segment {
                    object: "the trimmed hedge along a garden".into(),
                },
            ),
            (
                "State the road type of the segment containing the red-and-white speed limit sign that faces the traffic.",
                Task::Segment {
                    object: "the red-and-white speed limit sign that faces the traffic".into(),
                },
            ),
            (
                "Control, standing in the middle of segment 2412. How many post boxes are within 30 metres of me, over?",
                count(
                    "post boxes",
                    None,
                    Some("the middle of segment 2412"),
                    Some(30.0),
                ),
            ),
            (
                "I'm doing a check along segment 21. How many rubbish bins should I find in that segment, over?",
                count("rubbish bins", Some("the segment 21"), None, None),
            ),
            (
                "WO-207 hydrant flushing, segment 2414. No. of hydrants in segment?",
                count("hydrants", Some("segment 2414"), None, None),
            ),
            (
                "Base, checking the post box on segment 2422. What colour should it be?",
                Task::Colour {
                    object: "the post box on segment 2422".into(),
                },
            ),
            (
                "Excavation permit near the silver camper van. Hydrants within 50 m of it - how many?",
                count("hydrants", None, Some("the silver camper van"), Some(50.0)),
            ),
            (
                "Valve check at lane node 2429. Closest hydrant? Node id required.",
                Task::Nearest {
                    kind: "hydrant".into(),
                    near: "lane node 2429".into(),
                },
            ),
            (
                "I just finished a snack at the green climbing frame. Which bin is nearest so I can throw the wrapper away?",
                Task::Nearest {
                    kind: "bin".into(),
                    near: "the green climbing frame".into(),
                },
            ),
            (
                "Control, how far is it from that heavy scooter on its kickstand to the middle of segment 2401? Straight line, metres.",
                Task::Distance {
                    from: "that heavy scooter on its kickstand".into(),
                    to: "the middle of segment 2401".into(),
                },
            ),
            (
                "Camera check on seg 2412: what colour is the traffic light there?",
                Task::Colour {
                    object: "the traffic light in segment 2412".into(),
                },
            ),
        ];
        assert_all_read(cases);
    }

    /// A reading from the model's examples instead of the question fails the check; the
    /// question's own words pass it, plurals and ids included.
    #[test]
    fn a_reading_must_be_grounded_in_the_question() {
        // the colour of a segment, a locate nobody asked for
        let q = "uh what colour is the scooter in segment 2410";
        let e = check_grounded(
            &Task::Colour {
                object: "segment:2410".into(),
            },
            q,
        )
        .unwrap_err();
        assert!(e.contains("not a thing"), "{e}");
        let q = "In what segment is located the silver fire hydrant?";
        assert!(
            check_grounded(
                &Task::Locate {
                    text: q.to_string()
                },
                q
            )
            .is_err()
        );
        let q = "If one were to drive along the lanes, how far would it be from lane node 2426 \
                 to lane node 2429?";
        let e = check_grounded(
            &Task::Distance {
                from: "lane node 2426".into(),
                to: "lane node 2429".into(),
            },
            q,
        )
        .unwrap_err();
        assert!(e.contains("route"), "{e}");
        let q = "I'm at a T-junction next to a bus stop, where am I?";
        assert!(
            check_grounded(
                &Task::Locate {
                    text: q.to_string()
                },
                q
            )
            .is_ok()
        );
        let q = "How many benches are in segment 2412?";
        assert!(check_grounded(&count("bench", Some("segment:2412"), None, None), q).is_ok());
        assert!(check_grounded(&count("benches", Some("segment 2412"), None, None), q).is_ok());
        // a count of segments for a count of benches in a segment
        let e = check_grounded(&Task::count_segments(None), q).unwrap_err();
        assert!(e.contains("benches"), "{e}");
        // a place from the examples
        let e = check_grounded(
            &Task::Nearest {
                kind: "bench".into(),
                near: "the bus stop".into(),
            },
            "Which bench is closest to the fire hydrant?",
        )
        .unwrap_err();
        assert!(e.contains("bus"), "{e}");
        // an id the question does not give
        assert!(
            check_grounded(
                &Task::RouteLength {
                    from: "lane:12".into(),
                    to: "lane:12".into()
                },
                "route length 2434 -> 2432 on the lane graph"
            )
            .is_err()
        );
        assert!(
            check_grounded(
                &Task::RouteLength {
                    from: "lane:2434".into(),
                    to: "node 2432".into()
                },
                "route length 2434 -> 2432 on the lane graph"
            )
            .is_ok()
        );
        // the task's cue must be there
        assert!(
            check_grounded(
                &Task::Colour {
                    object: "the bench".into()
                },
                "Where is the bench?"
            )
            .is_err()
        );
        assert!(
            check_grounded(
                &Task::count_segments(Some(SegmentConstraint::TJunction)),
                "How many T-junctions are there?"
            )
            .is_ok()
        );
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
