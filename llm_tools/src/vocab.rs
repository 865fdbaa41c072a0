//! Street-scene vocabulary shared by mapping and retrieval: the subject phrase of a caption
//! and whether a phrase names a ground surface or a thing.

/// The part of a caption that names the object, without the context after it: the text
/// after a leading "Context: " and before the first context preposition or comma, so that
/// "a grey pole next to the sidewalk" is classified as a pole, not a sidewalk.
pub fn subject_phrase(caption: &str) -> &str {
    let s = caption
        .rsplit_once(':')
        .map_or(caption, |(_, rest)| rest)
        .trim();
    const CUTS: [&str; 16] = [
        ",",
        " on ",
        " next to ",
        " beside ",
        " along ",
        " at ",
        " by ",
        " in ",
        " with ",
        " around ",
        " near ",
        " behind ",
        " between ",
        " under ",
        " parked ",
        " standing ",
    ];
    // never cut inside the first two words
    let min = s.match_indices(' ').nth(1).map_or(s.len(), |(i, _)| i);
    let end = CUTS
        .iter()
        .filter_map(|c| s[min.min(s.len())..].find(c).map(|i| i + min))
        .min()
        .unwrap_or(s.len());
    let out = s[..end].trim();
    if out.is_empty() { caption } else { out }
}

/// Head nouns that name a ground surface.
const SURFACE_HEADS: [&str; 29] = [
    "road",
    "roads",
    "street",
    "streets",
    "asphalt",
    "roadway",
    "carriageway",
    "highway",
    "lane",
    "sidewalk",
    "sidewalks",
    "pavement",
    "footpath",
    "footway",
    "walkway",
    "parking",
    "lot",
    "terrain",
    "grass",
    "lawn",
    "turf",
    "soil",
    "dirt",
    "gravel",
    "ground",
    "earth",
    "meadow",
    "field",
    "verge",
];

/// Nouns that name a part of something else ("a strip of grass", "the road surface"): the
/// phrase is a surface when one of its other words is.
const EXTENT_WORDS: [&str; 9] = [
    "strip", "patch", "stretch", "area", "surface", "section", "expanse", "piece", "bit",
];

/// Whether a detection shows a ground surface (road, sidewalk, parking, terrain, other
/// ground) rather than a thing, decided by what the detection says it is, not by the nearest
/// of the 19 classes, so that an object the classes do not name (a bench, a mailbox) stays
/// an object.
///
/// With tags, the first tag decides: it names a surface when it, or its last word, is a
/// surface noun (`road`, `parking lot`, `other-ground`). Without tags, the caption's subject
/// phrase ([`subject_phrase`]) decides the same way by its head noun (the last word before
/// `of`, `for` or `and`, or after `of` when the head is an extent word such as `strip`).
pub fn names_surface(tags: &[String], caption: &str) -> bool {
    let words = |s: &str| -> Vec<String> {
        s.to_lowercase()
            .split(|c: char| !c.is_alphanumeric())
            .filter(|w| !w.is_empty())
            .map(str::to_string)
            .collect()
    };
    let is_head = |w: &str| SURFACE_HEADS.contains(&w);
    if let Some(tag) = tags.first().filter(|t| !t.trim().is_empty()) {
        return words(tag).last().is_some_and(|w| is_head(w));
    }
    let phrase = words(subject_phrase(caption));
    // the noun phrase before "of" / "for" / "and"; after "of" when it only names an extent
    let cut = |ws: &[String]| -> usize {
        ws.iter()
            .position(|w| matches!(w.as_str(), "of" | "for" | "and" | "with"))
            .unwrap_or(ws.len())
    };
    let mut np: &[String] = &phrase[..cut(&phrase)];
    if np
        .last()
        .is_some_and(|w| EXTENT_WORDS.contains(&w.as_str()))
        && phrase.get(np.len()).is_some_and(|w| w == "of")
    {
        let rest = &phrase[np.len() + 1..];
        np = &rest[..cut(rest)];
    }
    match np.last() {
        Some(h) if is_head(h) => true,
        Some(h) if EXTENT_WORDS.contains(&h.as_str()) => np.iter().any(|w| is_head(w)),
        _ => false,
    }
}

/// The words of a text, lower-cased: runs of letters, digits and hyphens ("other-ground"
/// is one word).
pub(crate) fn words(text: &str) -> Vec<String> {
    text.to_lowercase()
        .split(|c: char| !c.is_alphanumeric() && c != '-')
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect()
}

/// Colour words.
pub(crate) const COLOURS: [&str; 16] = [
    "red", "green", "blue", "yellow", "white", "black", "grey", "gray", "silver", "brown",
    "orange", "beige", "pink", "purple", "gold", "cream",
];

/// The colour words in a text, sorted, without repeats ("gray" counts as "grey").
pub fn colours(text: &str) -> Vec<&'static str> {
    colours_of(text)
}

/// Whether `text` names a colour ([`colour_agreement`] of a phrase that does not is 1 for
/// every caption).
pub fn says_colour(text: &str) -> bool {
    !colours_of(text).is_empty()
}

fn colours_of(text: &str) -> Vec<&'static str> {
    let t = text.to_lowercase();
    let mut out: Vec<&'static str> = t
        .split(|c: char| !c.is_alphanumeric())
        .filter_map(|w| COLOURS.iter().find(|c| **c == w).copied())
        .map(|c| if c == "gray" { "grey" } else { c })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// A phrase without its colour words and their shade words ("a dark blue bike" → "a
/// bike"), so that what a thing is can be matched apart from its colour; the phrase itself
/// when nothing but colours would be left.
pub fn without_colours(phrase: &str) -> String {
    let words: Vec<&str> = phrase.split_whitespace().collect();
    let is_colour = |w: &str| {
        let w = w.to_lowercase();
        let w = w.trim_matches(|c: char| !c.is_alphanumeric());
        COLOURS.contains(&w)
    };
    let mut kept = Vec::with_capacity(words.len());
    for (i, w) in words.iter().enumerate() {
        let shade = matches!(
            w.to_lowercase().as_str(),
            "dark" | "light" | "bright" | "pale" | "deep"
        ) && words.get(i + 1).is_some_and(|n| is_colour(n));
        // "black and white": the joining word goes with the colours
        let joins = matches!(w.to_lowercase().as_str(), "and" | "or")
            && i > 0
            && is_colour(words[i - 1])
            && words.get(i + 1).is_some_and(|n| is_colour(n));
        if !is_colour(w) && !shade && !joins {
            kept.push(*w);
        }
    }
    let content = kept.iter().any(|w| {
        !matches!(
            w.to_lowercase().as_str(),
            "a" | "an" | "the" | "and" | "one"
        )
    });
    if content {
        kept.join(" ")
    } else {
        phrase.to_string()
    }
}

/// How well a caption's colours agree with the colours a phrase asks for, in (0, 1]: 1 when
/// the phrase names none or the caption shares one, 0.8 when the caption names none, 0.4 when
/// it names only others ("a dark blue bike" against "a yellow bike").
pub fn colour_agreement(phrase: &str, caption: &str) -> f64 {
    let want = colours_of(phrase);
    if want.is_empty() {
        return 1.0;
    }
    let have = colours_of(caption);
    if have.is_empty() {
        0.8
    } else if have.iter().any(|c| want.contains(c)) {
        1.0
    } else {
        0.4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subject_phrases() {
        assert_eq!(
            subject_phrase("a grey pole next to the sidewalk"),
            "a grey pole"
        );
        assert_eq!(
            subject_phrase("Next to the sidewalk: a flat green lawn"),
            "a flat green lawn"
        );
        assert_eq!(
            subject_phrase("a red car, small, parked by the curb"),
            "a red car"
        );
        assert_eq!(subject_phrase("a man in a dark coat"), "a man");
        assert_eq!(subject_phrase("car"), "car");
        assert_eq!(subject_phrase(""), "");
        assert_eq!(
            subject_phrase("a cyclist riding a bicycle in the bike lane"),
            "a cyclist riding a bicycle"
        );
    }

    #[test]
    fn surfaces_are_told_from_things() {
        let t = |tags: &[&str], c: &str| {
            names_surface(&tags.iter().map(|s| s.to_string()).collect::<Vec<_>>(), c)
        };
        // the simulator's surface captions, without tags
        for c in [
            "the asphalt road",
            "a grey asphalt street",
            "the road surface with lane markings",
            "a parking lane beside the road",
            "a paved parking area along the street",
            "a concrete sidewalk",
            "the paved sidewalk along the street",
            "a pavement for pedestrians",
            "a strip of grass",
            "grass and bare soil",
            "a patch of lawn",
        ] {
            assert!(t(&[], c), "{c}");
        }
        // things, also those named after a surface or standing on one
        for c in [
            "a wooden bench",
            "a road sign",
            "a parking meter",
            "a street lamp",
            "a bench on the sidewalk",
            "a strip of lights",
            "a red car parked by the curb",
            "a tall hedge",
            "a brick building",
            "a bus stop shelter next to the road",
            "a mailbox",
            "",
        ] {
            assert!(!t(&[], c), "{c}");
        }
        // the first tag decides over the caption
        assert!(t(&["parking"], "a wooden bench"));
        assert!(t(&["other-ground"], "x"));
        assert!(t(&["Parking Lot"], "x"));
        assert!(!t(&["bench"], "the asphalt road"));
        assert!(!t(&["bus stop shelter", "road"], "x"));
        // an empty tag is no tag
        assert!(t(&[""], "a concrete sidewalk"));
    }

    #[test]
    fn colours_come_off_a_phrase() {
        assert_eq!(without_colours("a dark blue bike"), "a bike");
        assert_eq!(without_colours("a grey traffic light"), "a traffic light");
        assert_eq!(without_colours("a black and white bus"), "a bus");
        assert_eq!(without_colours("a dark alley"), "a dark alley");
        assert_eq!(without_colours("a red one"), "a red one");
        assert_eq!(without_colours("green"), "green");
        assert_eq!(without_colours("a bench"), "a bench");
    }

    #[test]
    fn colours_agree_or_not() {
        assert!((colour_agreement("a bench", "a red bench") - 1.0).abs() < 1e-12);
        assert!((colour_agreement("a dark blue bike", "a blue city bike") - 1.0).abs() < 1e-12);
        assert!((colour_agreement("a grey bin", "a gray bin") - 1.0).abs() < 1e-12);
        assert!((colour_agreement("a dark blue bike", "a yellow bike") - 0.4).abs() < 1e-12);
        assert!((colour_agreement("a red house", "a red-brick house") - 1.0).abs() < 1e-12);
        assert!((colour_agreement("a red house", "a brick house") - 0.8).abs() < 1e-12);
    }
}
