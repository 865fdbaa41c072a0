//! The 19 SemanticKITTI evaluation classes and the raw-label mapping (`learning_map` in
//! `semantic-kitti.yaml`), which classes are ground surfaces, and SemanticKITTI's colour map.

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

/// The class of an object none of the 19 classes fits (SemanticKITTI's raw label 99, "other
/// object", which its 19-class evaluation leaves unlabelled).
pub const OTHER_OBJECT: &str = "other-object";

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

/// The ground-surface class names (the names of [`is_surface`]'s classes): road, sidewalk,
/// parking, terrain, other-ground. Retrieval, localisation and the viewer treat instances of
/// these classes as ground, not objects.
pub const SURFACE_CLASSES: [&str; 5] = ["road", "sidewalk", "parking", "terrain", "other-ground"];

/// The SemanticKITTI classes of people (on foot or riding).
pub const PEOPLE_CLASSES: [&str; 3] = ["person", "bicyclist", "motorcyclist"];

/// SemanticKITTI's colour (RGB, from its `color_map`) for a class name; grey for others.
pub fn class_colour(class: &str) -> (u8, u8, u8) {
    match class {
        "car" => (100, 150, 245),
        "bicycle" => (100, 230, 245),
        "motorcycle" => (30, 60, 150),
        "truck" => (80, 30, 180),
        "other-vehicle" => (100, 80, 250),
        "person" => (255, 30, 30),
        "bicyclist" => (255, 40, 200),
        "motorcyclist" => (150, 30, 90),
        "road" => (255, 0, 255),
        "parking" => (255, 150, 255),
        "sidewalk" => (75, 0, 75),
        "other-ground" => (175, 0, 75),
        "building" => (255, 200, 0),
        "fence" => (255, 120, 50),
        "vegetation" => (0, 175, 0),
        "trunk" => (135, 60, 0),
        "terrain" => (150, 240, 80),
        "pole" => (255, 240, 150),
        "traffic-sign" => (255, 0, 0),
        _ => (128, 128, 128),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn surface_names_are_the_surface_classes() {
        let mut by_id: Vec<&str> = (1..=19u8)
            .filter(|i| is_surface(*i))
            .filter_map(class_name)
            .collect();
        let mut names = SURFACE_CLASSES.to_vec();
        by_id.sort_unstable();
        names.sort_unstable();
        assert_eq!(by_id, names);
        assert_ne!(class_colour("road"), class_colour("no-such-class"));
    }
}
