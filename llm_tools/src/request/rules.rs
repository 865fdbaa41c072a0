//! The deterministic rule parser for common English: lead-ins, segment words, spatial
//! relations, functions ("somewhere I can post a letter") and attributes.

use super::*;

pub(super) fn normalise(text: &str) -> String {
    let t = text
        .to_lowercase()
        .replace(['’', '‘'], "'")
        .replace(['?', '!', '.', ',', ';', '"'], " ");
    t.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Words that open a request without naming anything.
pub(super) const LEAD_INS: [&str; 27] = [
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
pub(super) const SEGMENTS: [(&str, SegmentConstraint); 22] = [
    ("straight stretch of road", SegmentConstraint::StraightRoad),
    ("four-way crossing", SegmentConstraint::Crossroads),
    ("three-way junction", SegmentConstraint::TJunction),
    ("three-way intersection", SegmentConstraint::TJunction),
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
    ("four-way", SegmentConstraint::Crossroads),
    ("l-junction", SegmentConstraint::Bend),
    ("bend", SegmentConstraint::Bend),
    ("straight road", SegmentConstraint::StraightRoad),
    ("straight stretch", SegmentConstraint::StraightRoad),
    ("straight street", SegmentConstraint::StraightRoad),
    ("corner", SegmentConstraint::Junction),
];

/// Relation phrases, longest first.
pub(super) const RELATIONS: [(&str, Relation); 45] = [
    // a short distance said in steps or a walk is near
    ("within walking distance of", Relation::Near),
    ("a couple of steps from", Relation::Near),
    ("a few steps away from", Relation::Near),
    ("a stone's throw from", Relation::Near),
    ("a few metres from", Relation::Near),
    ("a few meters from", Relation::Near),
    ("a short walk from", Relation::Near),
    ("a few paces from", Relation::Near),
    ("a few steps from", Relation::Near),
    ("a few yards from", Relation::Near),
    ("steps away from", Relation::Near),
    ("steps from", Relation::Near),
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

/// Degree words that sharpen a relation that follows them ("right next to", "just by").
pub(super) const INTENSIFIERS: [&str; 6] =
    ["right", "just", "directly", "immediately", "very", "really"];

/// What things in a street are for: trigger phrases (whole words) and the object that
/// serves them. Common sense written for street scenes, used by the rule parser for requests
/// given by function; a language model parser covers what it misses.
pub(super) const AFFORDANCES: [(&[&str], &str); 22] = [
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
            "controls the traffic",
            "traffic signal",
        ],
        "a traffic light",
    ),
    (
        &[
            "rules of the road",
            "road rules",
            "speed limit",
            "give way",
            "one way",
            "road sign",
        ],
        "a traffic sign",
    ),
    (
        &[
            "freight",
            "haul",
            "move house",
            "goods by road",
            "transport goods",
            "carries goods",
        ],
        "a truck",
    ),
    (
        &[
            "passengers",
            "a lift",
            "a ride",
            "carries people",
            "carries a few people",
        ],
        "a car",
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
    // the crown gives the shade, not the trunk
    (&["shade", "shady"], "a tree canopy"),
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
pub(super) const ATTRIBUTE_WORDS: [&str; 30] = [
    "red", "green", "blue", "yellow", "white", "black", "grey", "gray", "silver", "brown",
    "orange", "beige", "dark", "light", "bright", "wooden", "wood", "metal", "steel", "glass",
    "stone", "concrete", "brick", "plastic", "iron", "tall", "small", "large", "long", "old",
];

/// Whether `phrase` occurs in `text` at word boundaries; the byte offset of the first one.
pub(super) fn find_words(text: &str, phrase: &str) -> Option<usize> {
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
pub(super) const NEEDS_DETERMINER: [&str; 5] = ["on", "at", "by", "around", "near"];

/// The first occurrence of a relation phrase in `t` at or after `from`, at word boundaries,
/// honouring [`NEEDS_DETERMINER`].
pub(super) fn find_relation(t: &str, from: usize, phrase: &str) -> Option<usize> {
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

/// Head nouns that make a function word before them part of an object's name ("speed limit
/// sign", "rubbish bin", "bus stop shelter" name things, not what they are for).
const OBJECT_HEADS: [&str; 22] = [
    "sign", "signs", "bin", "bins", "can", "cans", "box", "boxes", "shelter", "shelters", "light",
    "lights", "pole", "poles", "post", "posts", "truck", "trucks", "rack", "racks", "stand",
    "stands",
];

/// The objects that serve the functions named in `phrase` (see [`AFFORDANCES`]), in table
/// order, without repeats. A trigger that is part of an object's name (followed by one of
/// [`OBJECT_HEADS`]) names no function.
pub fn objects_for_function(phrase: &str) -> Vec<String> {
    let t = normalise(phrase);
    let mut out: Vec<String> = Vec::new();
    let said = |tr: &str| {
        let mut from = 0;
        while let Some(i) = t.get(from..).and_then(|rest| find_words(rest, tr)) {
            let end = from + i + tr.len();
            let next = t[end..].split_whitespace().next().unwrap_or("");
            if !OBJECT_HEADS.contains(&next) {
                return true;
            }
            from = end;
        }
        false
    };
    for (triggers, object) in AFFORDANCES {
        if triggers.iter().any(|tr| said(tr)) && !out.iter().any(|o| o == object) {
            out.push((*object).to_string());
        }
    }
    out
}

pub(super) fn strip_articles(s: &str) -> &str {
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
    // "<target> nearest (to) <place>", "<target> that is closest to <place>": a superlative
    // after the target names the place to measure from (an anchor, before any other)
    let mut place: Option<Anchor> = None;
    for w in ["nearest", "closest"] {
        let Some(i) = find_words(&t, w) else {
            continue;
        };
        let mut before = t[..i].trim();
        for lead in [" that is", " which is", " that's", " is"] {
            if let Some(b) = before.strip_suffix(lead) {
                before = b.trim();
                break;
            }
        }
        // "which bin is nearest …": the question word is not part of the target
        for q in ["which ", "what "] {
            if let Some(b) = before.strip_prefix(q) {
                before = b.trim();
            }
        }
        let after = t[i + w.len()..].trim();
        let after = after.strip_prefix("to ").unwrap_or(after).trim();
        if !strip_articles(before).is_empty() && !strip_articles(after).is_empty() {
            place = Some(Anchor {
                phrase: after.to_string(),
                relation: Relation::Near,
                distance_m: None,
            });
            t = before.to_string();
            req.ordinal = Some(1);
            req.nearest = true;
        }
        break;
    }
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
        let Some((mut i, e, rel)) = best else { break };
        // a degree word before the relation belongs to it ("right beside", "just behind")
        if let Some(w) = t[..i].trim_end().rsplit(' ').next()
            && INTENSIFIERS.contains(&w)
            && i > w.len()
        {
            i -= w.len() + 1;
        }
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
    if let Some(p) = place {
        req.anchors.insert(0, p);
    }
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
