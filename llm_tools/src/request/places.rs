//! Places named without a description: a node by its id in words ("segment 2412", "lane
//! node 7", "object #86") and the ends of the drive ("the start of the drive", "the drive's
//! starting point"). Every tool that takes a place in words reads these first.

/// Words that name a road segment when they come before its id.
const SEGMENT_WORDS: [&str; 13] = [
    "segment",
    "segments",
    "junction",
    "crossroads",
    "crossroad",
    "intersection",
    "t-junction",
    "bend",
    "road",
    "section",
    "corner",
    "stretch",
    "roadway",
];

/// Whether a (stemmed) word names a road segment ("segment", "junction", "bend").
pub(crate) fn is_road_word(w: &str) -> bool {
    SEGMENT_WORDS.contains(&w) || matches!(w, "lane" | "street" | "roadside" | "kerb" | "curb")
}

/// Words that name a map object when they come before its id.
const OBJECT_WORDS: [&str; 5] = ["object", "instance", "item", "thing", "objects"];

/// Words between a kind and the id that say nothing more ("segment id 12", "node no. 4",
/// "the crossroads with node id 2404").
const ID_FILLER: [&str; 7] = ["id", "no", "no.", "number", "with", "#", "node id"];

/// Phrases before a place that mean the place itself ("the centre of segment 12").
const CENTRE_OF: [&str; 8] = [
    "centre of",
    "center of",
    "centroid of",
    "middle of",
    "midpoint of",
    "position of",
    "location of",
    "site of",
];

fn words_of(text: &str) -> Vec<String> {
    let t = text
        .to_lowercase()
        .replace(['’', '‘'], "'")
        .replace(['(', ')', ',', '?', '!', ';', '"'], " ");
    t.split_whitespace()
        .map(|w| w.trim_end_matches('.').to_string())
        .filter(|w| !w.is_empty())
        .collect()
}

/// A node named by its id in words, as a spec (`segment:ID`, `lane:ID`, `instance:ID`,
/// `node:ID`): "segment 2412", "road segment #2416", "the centre of segment 2421", "the
/// crossroads with node id 2404", "segment:2406 (its centroid)", "lane node 2425", "node
/// 1481", "object #86", "instance 275", "traffic light 653" (a kind of object before an id is
/// the node with that id; the spec's kind is checked against the node's label where it is
/// resolved). The id must end the phrase (a trailing "(its centroid)" aside), with at most
/// four words before it; `None` otherwise ("the bench 3 m from the kerb").
pub fn spec_in_words(text: &str) -> Option<String> {
    let mut w = words_of(text);
    // "(its centroid)", "its centre" after the id
    while matches!(
        w.last().map(String::as_str),
        Some("centroid" | "centre" | "center" | "its" | "itself" | "please")
    ) {
        w.pop();
    }
    // a clause after the id ("segment 2345, giving its node id")
    if let Some(k) = w
        .iter()
        .rposition(|x| x.trim_start_matches('#').parse::<u64>().is_ok())
        && w.get(k + 1).is_some_and(|x| x.ends_with("ing"))
    {
        w.truncate(k + 1);
    }
    // "segment:12" and "segment: 12" as written
    let joined = w.join(" ");
    if let Some((kind, id)) = joined.rsplit_once(':') {
        let kind = kind.split_whitespace().last().unwrap_or("");
        let id = id.trim().trim_start_matches('#');
        if matches!(kind, "segment" | "lane" | "instance" | "node") && id.parse::<u64>().is_ok() {
            return Some(format!("{kind}:{id}"));
        }
        return None;
    }
    let last = w.last()?;
    let id: u64 = last.trim_start_matches('#').parse().ok()?;
    let mut before: Vec<&str> = w[..w.len() - 1].iter().map(String::as_str).collect();
    // articles and "the centre of"
    loop {
        let n = before.len();
        if matches!(
            before.first(),
            Some(&("the" | "a" | "an" | "at" | "to" | "from"))
        ) {
            before.remove(0);
        }
        for c in CENTRE_OF {
            let cw: Vec<&str> = c.split(' ').collect();
            if before.starts_with(&cw) {
                before.drain(..cw.len());
            }
        }
        if before.len() == n {
            break;
        }
    }
    while let Some(l) = before.last() {
        if ID_FILLER.contains(l) || (*l == "node" && before.len() >= 2) {
            // "with node id": node stays a filler only after another kind word
            if *l == "node" && !before[..before.len() - 1].contains(&"with") {
                break;
            }
            before.pop();
        } else {
            break;
        }
    }
    // "the minibus in segment 12" is a thing placed by a segment, not the segment
    let placed = before.iter().any(|x| {
        matches!(
            *x,
            "in" | "at"
                | "on"
                | "near"
                | "by"
                | "inside"
                | "within"
                | "along"
                | "beside"
                | "next"
                | "close"
                | "from"
                | "to"
                | "behind"
                | "opposite"
                | "for"
                | "is"
                | "are"
                | "was"
        )
    });
    if before.len() > 4 || placed || before.iter().any(|x| x.parse::<f64>().is_ok()) {
        return None;
    }
    let has = |set: &[&str]| before.iter().any(|x| set.contains(x));
    let kind = if before.contains(&"lane") {
        "lane"
    } else if has(&SEGMENT_WORDS) {
        "segment"
    } else if has(&OBJECT_WORDS) {
        "instance"
    } else {
        "node"
    };
    Some(format!("{kind}:{id}"))
}

/// An object said with the segment it stands in by id: "the post box in segment 2411",
/// "the bench at segment:12" → `("the post box", 2411)`. `None` when the words after the
/// last such preposition are not a segment by id.
pub fn object_in_segment(text: &str) -> Option<(String, u64)> {
    let t = text.trim().to_lowercase();
    let mut best: Option<(usize, usize)> = None;
    for prep in [
        " in ", " at ", " on ", " inside ", " within ", " along ", " of ",
    ] {
        if let Some(i) = t.rfind(prep)
            && best.is_none_or(|(j, _)| i > j)
        {
            best = Some((i, prep.len()));
        }
    }
    let (i, n) = best?;
    let object = t[..i].trim();
    let spec = spec_in_words(&t[i + n..])?;
    let id = spec.strip_prefix("segment:")?.parse().ok()?;
    (!object.is_empty()).then(|| (object.to_string(), id))
}

/// Words for the drive itself ("the start of the trajectory", "where the survey began").
const DRIVE_WORDS: [&str; 8] = [
    "drive",
    "trajectory",
    "route",
    "recording",
    "run",
    "map",
    "journey",
    "survey",
];

/// Whether a word says the drive ("drive", "survey"; not "map", which says more often
/// the whole map) or an end of it as a noun ("start", "beginning"), not only a verb of
/// starting or ending ("finished a snack").
pub(super) fn says_the_drive(word: &str) -> bool {
    (DRIVE_WORDS.contains(&word) && word != "map")
        || matches!(word, "start" | "end" | "beginning" | "starting" | "ending")
}

/// Which end of the drive `text` names, when it names only that: "the start of the drive",
/// "where the drive ended", "the beginning of the trajectory", "the drive's starting point",
/// "the starting position" → `Some("start" | "end")`.
pub fn drive_end_of(text: &str) -> Option<&'static str> {
    let t = text
        .trim()
        .trim_end_matches(['.', '?', '!'])
        .to_lowercase()
        .replace(['’', '‘'], "'")
        .replace("'s ", " ")
        .replace("set off", "started")
        .replace("setting off", "starting")
        .replace("sets off", "starts")
        .replace("kicked off", "started")
        .replace("came to a stop", "ended")
        .replace("wrapped up", "ended");
    let words: Vec<&str> = t
        .split_whitespace()
        .filter(|w| {
            !matches!(
                *w,
                "the"
                    | "a"
                    | "at"
                    | "from"
                    | "to"
                    | "of"
                    | "where"
                    | "our"
                    | "my"
                    | "its"
                    | "we"
                    | "i"
                    | "point"
                    | "position"
                    | "place"
                    | "location"
                    | "spot"
                    | "pose"
                    // the survey vehicle is the drive's ("where the survey vehicle
                    // commenced its recording")
                    | "which"
                    | "when"
                    | "that"
                    | "it"
                    | "vehicle"
                    | "car"
                    | "robot"
                    | "platform"
            )
        })
        .collect();
    let start = [
        "start",
        "starts",
        "started",
        "starting",
        "beginning",
        "begins",
        "began",
        "initial",
        "departed",
        "departure",
        "commenced",
    ];
    let end = [
        "end",
        "ends",
        "ended",
        "ending",
        "finish",
        "finished",
        "finishing",
        "final",
        "stopped",
        "terminated",
    ];
    // one word of starting or ending, and the rest words for the drive
    let starts = words.iter().filter(|w| start.contains(w)).count();
    let ends = words.iter().filter(|w| end.contains(w)).count();
    let rest_is_drive = words
        .iter()
        .all(|w| start.contains(w) || end.contains(w) || DRIVE_WORDS.contains(w));
    match (starts, ends) {
        (1, 0) if rest_is_drive && words.len() <= 3 => Some("start"),
        (0, 1) if rest_is_drive && words.len() <= 3 => Some("end"),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_in_words_are_specs() {
        for (text, want) in [
            ("segment 2412", Some("segment:2412")),
            ("segment #2416", Some("segment:2416")),
            ("road segment 2411", Some("segment:2411")),
            ("the centre of segment 2421", Some("segment:2421")),
            (
                "the centre of the crossroads segment 2404",
                Some("segment:2404"),
            ),
            ("the crossroads with node id 2404", Some("segment:2404")),
            (
                "crossroads segment 2406 (its centroid)",
                Some("segment:2406"),
            ),
            ("segment:2406", Some("segment:2406")),
            (
                "the centre of the segment 2345, giving its",
                Some("segment:2345"),
            ),
            ("segment 12 heading north", Some("segment:12")),
            ("segment: 12", Some("segment:12")),
            ("lane node 2425", Some("lane:2425")),
            ("lane:7", Some("lane:7")),
            ("node 1481", Some("node:1481")),
            ("node id 1481", Some("node:1481")),
            ("object #86", Some("instance:86")),
            ("instance 275", Some("instance:275")),
            ("traffic light 653", Some("node:653")),
            ("#12", Some("node:12")),
            ("the bench by the bus stop", None),
            ("the minibus in segment 2423", None),
            ("is booked for segment 2416", None),
            ("the bench 3 m from the kerb", None),
            ("within 30 m", None),
            ("12.5,-3", None),
            ("the big old red bench near the shelter 4", None),
        ] {
            assert_eq!(spec_in_words(text).as_deref(), want, "{text}");
        }
    }

    #[test]
    fn objects_in_a_segment_by_id() {
        assert_eq!(
            object_in_segment("the post box in segment 2411"),
            Some(("the post box".into(), 2411))
        );
        assert_eq!(
            object_in_segment("The bench at segment:12"),
            Some(("the bench".into(), 12))
        );
        assert_eq!(object_in_segment("the bench in the park"), None);
        assert_eq!(object_in_segment("the bench in lane node 4"), None);
        assert_eq!(object_in_segment("segment 4"), None);
    }

    #[test]
    fn ends_of_the_drive_in_words() {
        for (text, want) in [
            ("the start of the drive", Some("start")),
            ("where the drive ended", Some("end")),
            ("the drive's starting position", Some("start")),
            ("the starting point of the drive", Some("start")),
            ("the beginning of the trajectory", Some("start")),
            ("the final position of the drive", Some("end")),
            ("the starting point", Some("start")),
            ("the end", Some("end")),
            ("where the drive set off", Some("start")),
            (
                "the position at which the survey vehicle commenced its recording",
                Some("start"),
            ),
            (
                "the point at which the survey vehicle started recording",
                Some("start"),
            ),
            ("where the vehicle stopped", Some("end")),
            ("where the red truck started", None),
            ("the start and the end of the drive", None),
            ("where the run stopped", Some("end")),
            ("the bus stop", None),
            ("the end of the road", None),
            ("the start of the bus lane", None),
        ] {
            assert_eq!(drive_end_of(text), want, "{text}");
        }
    }
}
