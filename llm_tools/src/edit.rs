//! Understanding a described change to the map ("the bush under the street sign at the
//! crossing is gone", "the bench by the bus stop is now red", "there is a new bin next to
//! the post box"): which kind of edit, which object (a phrase `find` resolves, anchors and
//! all), and where it went or what it is now. The paper's interactive map update (OpenGraph,
//! Sec. V-D): a person reports a change, the system identifies the object from the
//! description and updates the map.
//!
//! The rule parser covers common English; what it does not recognise is an error that says
//! which forms it takes.

use std::sync::LazyLock;

use regex::Regex;

use crate::chat::{ChatModel, ChatRequest, Message};
use crate::{Error, Result};

/// What kind of change.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum EditKind {
    /// The object is gone.
    Remove,
    /// The object now stands somewhere else.
    Move,
    /// The object looks different, or was replaced by another kind of object.
    Change,
    /// A new object stands somewhere.
    Add,
}

/// A described change, parsed.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub struct EditRequest {
    /// The kind of change.
    pub kind: EditKind,
    /// The object changed, as a phrase for `find` (with its anchors: "the bush under the street
    /// sign at the crossing"); `None` for [`EditKind::Add`].
    pub target: Option<String>,
    /// Where it is now (move, add): the relation ("next_to", "near", "on", ...) and the phrase
    /// of the object it is placed by.
    pub place: Option<(String, String)>,
    /// What it is now (change): an attribute ("red") or, with `replaced`, a new object
    /// ("a metal bin"); for add, the new object.
    pub new_description: Option<String>,
    /// Whether the object was replaced by another (its caption is then the new description).
    pub replaced: bool,
}

const REL: &str = r"(?P<rel>next to|beside|near|by|in front of|behind|opposite|across the road from|at|on|under|to)";

fn re(p: &str) -> Regex {
    Regex::new(&p.replace("{REL}", REL)).expect("a valid pattern")
}

static LEAD: LazyLock<Regex> = LazyLock::new(|| {
    re(
        r"^(?:(?:i (?:just )?(?:saw|see|noticed|notice)|note|fyi|please note|update:?)(?: that)?,? )+",
    )
});
static ADD: LazyLock<Vec<Regex>> = LazyLock::new(|| {
    vec![
        re(
            r"^(?:there(?:'s| is) (?:now )?|someone (?:has )?(?:put|installed|placed|built) )(?:a|an) (?:new )?(?P<obj>.+?) (?:(?:was|has been|is|got) (?:installed|put|placed|built|added|set up) )?{REL} (?P<anchor>.+)$",
        ),
        re(
            r"^(?:a|an) new (?P<obj>.+?) (?:(?:was|has been|is|got) (?:installed|put|placed|built|added|set up) |stands |is )?{REL} (?P<anchor>.+)$",
        ),
        re(r"^(?:add|put|place|install) (?:a|an) (?:new )?(?P<obj>.+?) {REL} (?P<anchor>.+)$"),
    ]
});
static REPLACE: LazyLock<Regex> = LazyLock::new(|| {
    re(
        r"^(?P<target>.+?) (?:was|has been|got|is) replaced (?:by|with) (?:a|an|some) (?:new )?(?P<obj>.+)$",
    )
});
static MOVE: LazyLock<Vec<Regex>> = LazyLock::new(|| {
    vec![
        re(r"^(?P<target>.+?) (?:was|has been|got|is|were|have been) moved {REL} (?P<anchor>.+)$"),
        re(r"^move (?P<target>.+?) {REL} (?P<anchor>.+)$"),
        re(
            r"^(?P<target>.+?) (?:is|are) now (?:standing |placed |parked )?(?P<rel>next to|beside|near|by|in front of|behind|opposite|across the road from|at|on|under) (?P<anchor>.+)$",
        ),
    ]
});
static CHANGE: LazyLock<Vec<Regex>> = LazyLock::new(|| {
    vec![
        re(
            r"^(?P<target>.+?) (?:was|has been|got|were|have been) (?:painted|repainted|coloured|colored) (?P<attr>.+)$",
        ),
        re(r"^(?P<target>.+?) (?:is|are) now (?P<attr>.+)$"),
    ]
});
static REMOVE: LazyLock<Vec<Regex>> = LazyLock::new(|| {
    vec![
        re(r"^(?:remove|delete|take away|take out) (?P<target>.+)$"),
        re(
            r"^(?P<target>.+?) (?:is|are|was|were|has been|have been|got) (?:now )?(?:gone|removed|missing|taken away|cut down|chopped down|demolished|torn down|knocked down|cleared|uprooted)\b.*$",
        ),
        re(r"^(?P<target>.+?) (?:is|are) (?:no longer|not) there\b.*$"),
        re(r"^(?P<target>.+?) (?:has |have )?(?:disappeared|vanished)\b.*$"),
        re(
            r"^(?:someone|they|the city) (?:has |have )?(?:removed|took away|cut down|demolished|tore down) (?P<target>.+)$",
        ),
    ]
});

fn normalise(text: &str) -> String {
    let t = text
        .trim()
        .trim_end_matches(['.', '!', '?'])
        .trim()
        .to_lowercase()
        .replace(['\u{2019}', '`'], "'");
    let t = t.split_whitespace().collect::<Vec<_>>().join(" ");
    LEAD.replace(&t, "").trim().to_string()
}

/// The relation words of the request schema (`next_to`, `near`, ...).
fn relation(word: &str) -> String {
    match word {
        "beside" | "by" | "at" | "to" => "next_to".into(),
        "across the road from" => "opposite".into(),
        other => other.replace(' ', "_"),
    }
}

fn phrase(s: &str) -> String {
    s.trim().trim_matches(',').trim().to_string()
}

/// Parses a described change with rules.
///
/// # Errors
/// [`Error::Invalid`] for empty text or a sentence none of the forms match; the message lists
/// the forms.
pub fn parse_edit_rules(text: &str) -> Result<EditRequest> {
    let t = normalise(text);
    if t.is_empty() {
        return Err(Error::Invalid("the change description is empty".into()));
    }
    for r in ADD.iter() {
        if let Some(c) = r.captures(&t) {
            return Ok(EditRequest {
                kind: EditKind::Add,
                target: None,
                place: Some((relation(&c["rel"]), phrase(&c["anchor"]))),
                new_description: Some(format!("a {}", phrase(&c["obj"]))),
                replaced: false,
            });
        }
    }
    if let Some(c) = REPLACE.captures(&t) {
        return Ok(EditRequest {
            kind: EditKind::Change,
            target: Some(phrase(&c["target"])),
            place: None,
            new_description: Some(format!("a {}", phrase(&c["obj"]))),
            replaced: true,
        });
    }
    for r in MOVE.iter() {
        if let Some(c) = r.captures(&t) {
            return Ok(EditRequest {
                kind: EditKind::Move,
                target: Some(phrase(&c["target"])),
                place: Some((relation(&c["rel"]), phrase(&c["anchor"]))),
                new_description: None,
                replaced: false,
            });
        }
    }
    for r in REMOVE.iter() {
        if let Some(c) = r.captures(&t) {
            return Ok(EditRequest {
                kind: EditKind::Remove,
                target: Some(phrase(&c["target"])),
                place: None,
                new_description: None,
                replaced: false,
            });
        }
    }
    for r in CHANGE.iter() {
        if let Some(c) = r.captures(&t) {
            return Ok(EditRequest {
                kind: EditKind::Change,
                target: Some(phrase(&c["target"])),
                place: None,
                new_description: Some(phrase(&c["attr"])),
                replaced: false,
            });
        }
    }
    Err(Error::Invalid(format!(
        "cannot tell what changed in {text:?}; say it like: \"the bush under the street sign is gone\", \
         \"the bench by the bus stop was moved next to the post box\", \"the bench by the bus stop is now red\", \
         \"the bin was replaced by a metal bin\", \"there is a new bin next to the post box\""
    )))
}

/// The JSON Schema of a parsed change for the language model (keys sorted by name: the
/// grammar follows that order).
pub fn edit_schema() -> serde_json::Value {
    let phrase = serde_json::json!({"type": ["string", "null"], "maxLength": 200});
    serde_json::json!({"type": "object", "properties": {
        "kind": {"enum": ["remove", "move", "change", "add"]},
        "new_description": phrase,
        "place_phrase": phrase,
        "place_relation": {"enum": ["near", "next_to", "on", "under", "in_front_of", "behind", "opposite", null]},
        "replaced": {"type": "boolean"},
        "target": phrase},
        "required": ["kind", "new_description", "place_phrase", "place_relation", "replaced", "target"],
        "additionalProperties": false})
}

/// Whether every word of `phrase` occurs in `text` (case and punctuation aside): what the
/// model says must come from the report.
fn grounded(phrase: &str, text: &str) -> bool {
    use crate::vocab::words;
    let have = words(text);
    let want = words(phrase);
    !want.is_empty()
        && want
            .iter()
            .all(|w| matches!(w.as_str(), "a" | "an" | "the") || have.contains(w))
}

/// Parses a report of a change with a language model under [`edit_schema`] (prompt
/// `parse_edit@v1`): phrases the report does not contain are dropped, what the model left
/// empty the rule parser fills when it reads the same kind of change, and the result must be
/// whole (an object for remove, move and change; a place for move and add; a new description
/// for change and add).
///
/// # Errors
/// Empty text; the model fails; its answer is not a whole change.
pub fn parse_edit_llm(model: &mut dyn ChatModel, text: &str) -> Result<EditRequest> {
    if text.trim().is_empty() {
        return Err(Error::Invalid("the change description is empty".into()));
    }
    let req = ChatRequest::new(vec![
        Message::system(crate::prompts::PARSE_EDIT.text),
        Message::user(format!("Report: {}", text.trim())),
    ])
    .with_schema(edit_schema())
    .with_max_tokens(200);
    let v = model
        .chat(&req)?
        .json
        .ok_or_else(|| Error::LlmAnswer("no structured answer".into()))?;
    let kind: EditKind = serde_json::from_value(v["kind"].clone())
        .map_err(|e| Error::LlmAnswer(format!("not a kind of change: {e}")))?;
    let keep = |k: &str| {
        v[k].as_str()
            .map(str::trim)
            .filter(|p| grounded(p, text))
            .map(str::to_string)
    };
    // a target that still carries the change ("the sedan is gone") is cut to the object
    let object_only = |t: String| match parse_edit_rules(&t) {
        Ok(EditRequest {
            target: Some(inner),
            ..
        }) => inner,
        _ => t.trim_end_matches(['.', '!', ',']).to_string(),
    };
    let mut r = EditRequest {
        kind,
        target: keep("target")
            .filter(|_| kind != EditKind::Add)
            .map(object_only),
        place: match (keep("place_phrase"), v["place_relation"].as_str()) {
            (Some(p), Some(rel)) if matches!(kind, EditKind::Move | EditKind::Add) => {
                Some((rel.to_string(), p))
            }
            _ => None,
        },
        new_description: keep("new_description")
            .filter(|_| matches!(kind, EditKind::Change | EditKind::Add)),
        replaced: kind == EditKind::Change && v["replaced"].as_bool().unwrap_or(false),
    };
    if let Ok(rules) = parse_edit_rules(text)
        && rules.kind == r.kind
    {
        r.target = r.target.or(rules.target);
        r.place = r.place.or(rules.place);
        r.new_description = r.new_description.or(rules.new_description);
        r.replaced |= rules.replaced;
    }
    let whole = match r.kind {
        EditKind::Remove => r.target.is_some(),
        EditKind::Move => r.target.is_some() && r.place.is_some(),
        EditKind::Change => r.target.is_some() && r.new_description.is_some(),
        EditKind::Add => r.place.is_some() && r.new_description.is_some(),
    };
    if !whole {
        return Err(Error::LlmAnswer(format!(
            "the model's reading of {text:?} is not a whole change: {v}"
        )));
    }
    if r.kind == EditKind::Add
        && let Some(d) = &r.new_description
        && !d.starts_with(['a', 'A'])
    {
        r.new_description = Some(format!("a {d}"));
    }
    Ok(r)
}

/// A caption with a changed attribute: a colour replaces the caption's colours, any other
/// attribute goes before the head noun ("a brown bench, long" + "red" → "a red bench, long").
pub fn recaption(caption: &str, attribute: &str) -> String {
    let attr_colours = crate::vocab::colours(attribute);
    let mut words: Vec<String> = caption.split(' ').map(str::to_string).collect();
    if !attr_colours.is_empty() {
        let mut out: Vec<String> = Vec::with_capacity(words.len());
        let mut replaced = false;
        for w in &words {
            let bare = w
                .trim_matches(|c: char| !c.is_alphanumeric())
                .to_lowercase();
            if crate::vocab::colours(&bare).is_empty() {
                out.push(w.clone());
                continue;
            }
            let tail: String = w.chars().skip_while(|c| c.is_alphanumeric()).collect();
            if replaced {
                // a second colour goes, with the "and" before it ("blue and white" → "red")
                if out.last().is_some_and(|l| l == "and") {
                    out.pop();
                }
                if let Some(l) = out.last_mut() {
                    l.push_str(&tail);
                }
                continue;
            }
            replaced = true;
            out.push(format!("{attribute}{tail}"));
        }
        if replaced {
            return out.join(" ");
        }
    }
    // after a leading article, else at the front
    match words.first().map(|w| w.to_lowercase()) {
        Some(a) if a == "a" || a == "an" || a == "the" => {
            let article = if a == "the" {
                "the"
            } else if attribute.starts_with(['a', 'e', 'i', 'o', 'u']) {
                "an"
            } else {
                "a"
            };
            words[0] = article.to_string();
            words.insert(1, attribute.to_string());
            words.join(" ")
        }
        _ => format!("{attribute} {caption}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chat::scripted::{Reply, Scripted};

    fn p(t: &str) -> EditRequest {
        parse_edit_rules(t).unwrap()
    }

    /// A scripted model that answers `v` (as JSON text) once.
    fn answering(v: serde_json::Value) -> Scripted {
        Scripted::new("s", vec![Reply::Text(serde_json::to_string(&v).unwrap())])
    }

    #[test]
    fn removals() {
        let r = p("The bush under the street sign at the crossing is gone.");
        assert_eq!(r.kind, EditKind::Remove);
        assert_eq!(
            r.target.as_deref(),
            Some("the bush under the street sign at the crossing")
        );
        for t in [
            "I noticed that the red car by the lamp post has been removed",
            "remove the red car by the lamp post",
            "the red car by the lamp post is no longer there",
            "the red car by the lamp post disappeared",
            "someone took away the red car by the lamp post",
        ] {
            let r = p(t);
            assert_eq!(r.kind, EditKind::Remove, "{t}");
            assert_eq!(
                r.target.as_deref(),
                Some("the red car by the lamp post"),
                "{t}"
            );
        }
    }

    #[test]
    fn moves_changes_and_additions() {
        let r = p("the bench by the bus stop was moved next to the post box");
        assert_eq!(r.kind, EditKind::Move);
        assert_eq!(r.target.as_deref(), Some("the bench by the bus stop"));
        assert_eq!(r.place, Some(("next_to".into(), "the post box".into())));
        let r = p("the blue car is now parked in front of the bakery");
        assert_eq!(r.kind, EditKind::Move);
        assert_eq!(r.place, Some(("in_front_of".into(), "the bakery".into())));
        let r = p("The bench by the bus stop is now red");
        assert_eq!(r.kind, EditKind::Change);
        assert_eq!(r.new_description.as_deref(), Some("red"));
        assert!(!r.replaced);
        let r = p("the bench by the bus stop has been painted green");
        assert_eq!(
            (r.kind, r.new_description.as_deref()),
            (EditKind::Change, Some("green"))
        );
        let r = p("the bin near the shelter was replaced by a large metal bin");
        assert!(r.replaced);
        assert_eq!(r.new_description.as_deref(), Some("a large metal bin"));
        for t in [
            "there is a new bin next to the post box",
            "There's now a new bin next to the post box",
            "a new bin was installed next to the post box",
            "add a bin next to the post box",
        ] {
            let r = p(t);
            assert_eq!(r.kind, EditKind::Add, "{t}");
            assert_eq!(r.new_description.as_deref(), Some("a bin"), "{t}");
            assert_eq!(
                r.place,
                Some(("next_to".into(), "the post box".into())),
                "{t}"
            );
        }
    }

    #[test]
    fn what_is_not_a_change_is_an_error() {
        assert!(parse_edit_rules("").is_err());
        assert!(parse_edit_rules("   ").is_err());
        let e = parse_edit_rules("hello there").unwrap_err().to_string();
        assert!(e.contains("is gone"), "{e}");
    }

    #[test]
    fn the_llm_parser_keeps_what_the_report_says() {
        // a good answer
        let mut m = answering(
            serde_json::json!({"kind": "remove", "new_description": null,
                "place_phrase": null, "place_relation": null, "replaced": false,
                "target": "the hedge behind the bakery"}),
        );
        let r = parse_edit_llm(&mut m, "Sadly the hedge behind the bakery was ripped out").unwrap();
        assert_eq!(r.kind, EditKind::Remove);
        assert_eq!(r.target.as_deref(), Some("the hedge behind the bakery"));
        // an invented target is dropped, and the rules fill it from the text
        let mut m = answering(
            serde_json::json!({"kind": "remove", "new_description": null,
                "place_phrase": null, "place_relation": null, "replaced": false,
                "target": "the red car"}),
        );
        let r = parse_edit_llm(&mut m, "the bench near the bus stop is gone").unwrap();
        assert_eq!(r.target.as_deref(), Some("the bench near the bus stop"));
        // a target that carries the change is cut to the object
        let mut m = answering(
            serde_json::json!({"kind": "remove", "new_description": null,
                "place_phrase": null, "place_relation": null, "replaced": false,
                "target": "the sedan is gone."}),
        );
        let r = parse_edit_llm(&mut m, "the blue sedan is gone.").unwrap();
        assert_eq!(r.target.as_deref(), Some("the sedan"));
        // an add without a place is not whole
        let mut m = answering(
            serde_json::json!({"kind": "add", "new_description": "a bin",
                "place_phrase": null, "place_relation": null, "replaced": false, "target": null}),
        );
        assert!(parse_edit_llm(&mut m, "a bin appeared somewhere").is_err());
        // the schema is valid JSON Schema
        assert!(jsonschema::validator_for(&edit_schema()).is_ok());
    }

    #[test]
    fn recaptions() {
        assert_eq!(
            recaption("a brown bench, long, facing the street", "red"),
            "a red bench, long, facing the street"
        );
        assert_eq!(recaption("a wooden bench", "old"), "an old wooden bench");
        assert_eq!(recaption("bench", "broken"), "broken bench");
        assert_eq!(
            recaption("a dark blue and white car, parked", "red"),
            "a dark red car, parked"
        );
    }
}
