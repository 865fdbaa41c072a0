//! The 19 SemanticKITTI evaluation classes and the raw-label mapping (`learning_map` in
//! `semantic-kitti.yaml`), plus which classes the mapper treats as background.

/// Class names in SemanticKITTI's training order (index + 1 is the class id; 0 is unlabelled).
pub const CLASSES: [&str; 19] = [
    "car",
    "bicycle",
    "motorcycle",
    "truck",
    "other-vehicle",
    "person",
    "bicyclist",
    "motorcyclist",
    "road",
    "parking",
    "sidewalk",
    "other-ground",
    "building",
    "fence",
    "vegetation",
    "trunk",
    "terrain",
    "pole",
    "traffic-sign",
];

/// Texts embedded to assign a class from a caption, per class in the order of [`CLASSES`]:
/// the class name and the things SemanticKITTI's class definitions put in it. A caption gets
/// the class of its most similar prompt.
pub const CLASS_PROMPTS: [&[&str]; 19] = [
    &["a car", "a van", "a jeep"],
    &["a bicycle", "a bike"],
    &["a motorcycle", "a scooter", "a motorbike"],
    &["a truck", "a lorry"],
    &["a bus", "a tram", "a trailer", "a caravan"],
    &["a person", "a pedestrian", "a man", "a woman"],
    &["a cyclist riding a bicycle", "a person riding a bike"],
    &[
        "a motorcyclist riding a motorcycle",
        "a person riding a motorbike",
    ],
    &["a road", "a street", "an asphalt road"],
    &["a parking area", "a parking lot"],
    &["a sidewalk", "a pavement", "a footpath"],
    &["a traffic island", "a median strip", "other ground"],
    &["a building", "a house", "a wall of a building"],
    &["a fence", "a railing", "a low garden wall"],
    &["vegetation", "bushes", "a hedge", "tree crowns"],
    &["a tree trunk"],
    &["terrain", "grass", "a lawn", "soil"],
    &["a pole", "a lamp post"],
    &["a traffic sign", "a road sign", "a stop sign"],
];

/// Every prompt with its class id (1..=19), flattened.
pub fn prompts() -> Vec<(u8, &'static str)> {
    CLASS_PROMPTS
        .iter()
        .enumerate()
        .flat_map(|(i, ps)| ps.iter().map(move |p| (i as u8 + 1, *p)))
        .collect()
}

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

/// Evaluation class id (1..=19) of a raw SemanticKITTI label, 0 for unlabelled/ignored.
pub fn learning_class(raw: u16) -> u8 {
    match raw {
        10 | 252 => 1,
        11 => 2,
        15 => 3,
        18 | 258 => 4,
        13 | 16 | 20 | 256 | 257 | 259 => 5,
        30 | 254 => 6,
        31 | 253 => 7,
        32 | 255 => 8,
        40 | 60 => 9,
        44 => 10,
        48 => 11,
        49 => 12,
        50 => 13,
        51 => 14,
        70 => 15,
        71 => 16,
        72 => 17,
        80 => 18,
        81 => 19,
        _ => 0,
    }
}

/// Name of an evaluation class id (1..=19).
pub fn class_name(id: u8) -> Option<&'static str> {
    CLASSES.get(usize::from(id).checked_sub(1)?).copied()
}

/// Class id (1..=19) of a name.
pub fn class_id(name: &str) -> Option<u8> {
    CLASSES.iter().position(|c| *c == name).map(|i| i as u8 + 1)
}

/// Classes with instance ids in SemanticKITTI (vehicles and people).
pub fn is_thing(id: u8) -> bool {
    (1..=8).contains(&id)
}

/// The ground-surface classes (road, parking, sidewalk, other-ground, terrain): fused per
/// class within ground tiles instead of as objects. Everything else, buildings, fences and
/// vegetation included, is mapped as objects.
pub fn is_surface(id: u8) -> bool {
    matches!(id, 9..=12 | 17)
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
    fn names_and_ids_roundtrip() {
        for (i, n) in CLASSES.iter().enumerate() {
            assert_eq!(class_id(n), Some(i as u8 + 1));
            assert_eq!(class_name(i as u8 + 1), Some(*n));
        }
        assert_eq!(class_name(0), None);
        assert_eq!(class_name(20), None);
        assert!(is_surface(9) && is_surface(17) && !is_surface(13) && !is_surface(15));
        assert!(!is_surface(18) && is_thing(1) && !is_thing(9));
    }

    /// The table above agrees with the `learning_map` of the real `semantic-kitti.yaml`.
    #[test]
    fn learning_map_matches_semantic_kitti_yaml() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/data/kitti/semantic-kitti.yaml");
        let Ok(text) = std::fs::read_to_string(&path) else {
            eprintln!("skipping: {} not found", path.display());
            return;
        };
        let section = |name: &str| -> Vec<(u16, u16)> {
            let start = text.find(&format!("\n{name}:")).expect("section");
            text[start + name.len() + 2..]
                .lines()
                .skip(1)
                .take_while(|l| l.starts_with(' '))
                .filter_map(|l| {
                    let (k, v) = l.split_once(':')?;
                    let v = v.split('#').next()?.trim();
                    Some((k.trim().parse().ok()?, v.parse().ok()?))
                })
                .collect()
        };
        let map = section("learning_map");
        assert!(map.len() > 30, "{map:?}");
        for (raw, class) in &map {
            assert_eq!(u16::from(learning_class(*raw)), *class, "raw label {raw}");
        }
        let inv = section("learning_map_inv");
        let labels: std::collections::BTreeMap<u16, String> = text
            [text.find("\nlabels:").unwrap() + 8..]
            .lines()
            .skip(1)
            .take_while(|l| l.starts_with(' '))
            .filter_map(|l| {
                let (k, v) = l.split_once(':')?;
                Some((
                    k.trim().parse().ok()?,
                    v.trim().trim_matches('"').to_string(),
                ))
            })
            .collect();
        for (class, raw) in inv.iter().filter(|(c, _)| *c > 0) {
            assert_eq!(class_name(*class as u8), Some(labels[raw].as_str()));
        }
    }
}
