//! The SemanticKITTI label oracle: ground-truth labels projected into the camera as if a
//! perfect open-vocabulary detector had run. For tests and evaluation without vision models;
//! everything it produces is marked [`Producer::Oracle`].
//!
//! Each labelled instance (vehicles, people) is one detection; each surface class (road,
//! parking, sidewalk, other-ground, terrain) is one detection per frame; buildings, fences,
//! vegetation, poles, trunks and traffic signs are split into connected components on the
//! ground plane, one detection each. Points are splatted into the image with a
//! z-buffer (a small rectangle per point, sized to the HDL-64E's beam spacing) and each
//! object's pixels become its mask. Captions come from a per-class bank with varied attributes;
//! the attributes are seeded by the instance, the phrasing by the instance and the frame.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::detections::{Detection, DetectionFrame, Producer};
use super::kitti::{PointLabel, Rigid3};
use super::rle::Rle;
use crate::cluster::dbscan;
use crate::error::{Error, Result};
use crate::mapping::project::Camera;
use scene::classes::{self, class_name};

/// Oracle parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OracleConfig {
    /// Half-width of each point's splat, in pixels (azimuth spacing ≈ 0.17° ≈ 2 px).
    pub splat_half_width_px: u32,
    /// Half-height of each point's splat, in pixels (beam spacing ≈ 0.4° ≈ 5 px).
    pub splat_half_height_px: u32,
    /// Masks smaller than this are dropped.
    pub min_mask_px: u64,
    /// Objects with fewer projected points than this are dropped.
    pub min_points: usize,
    /// Points of a building, fence, vegetation, trunk, pole or sign closer than this (metres,
    /// ground plane) belong to one object.
    pub component_eps_m: f64,
}

impl Default for OracleConfig {
    fn default() -> Self {
        OracleConfig {
            splat_half_width_px: 1,
            splat_half_height_px: 3,
            min_mask_px: 40,
            min_points: 8,
            component_eps_m: 0.8,
        }
    }
}

impl OracleConfig {
    /// Checks the numbers (the message names the key).
    ///
    /// # Errors
    /// [`Error::Invalid`] for a non-finite or non-positive `component_eps_m`, or a splat over
    /// 64 px.
    pub fn validate(&self) -> Result<()> {
        let e = self.component_eps_m;
        if !(e.is_finite() && e > 0.0 && e < 1e3) {
            return Err(Error::Invalid(format!(
                "[oracle] component_eps_m must be a positive number below 1000, got {e}"
            )));
        }
        if self.splat_half_width_px > 64 || self.splat_half_height_px > 64 {
            return Err(Error::Invalid(
                "[oracle] splat_half_width_px and splat_half_height_px must be at most 64".into(),
            ));
        }
        Ok(())
    }
}

/// Classes without SemanticKITTI instance ids that are still objects: split into connected
/// components (buildings, fences, vegetation, trunks, poles, traffic signs).
fn is_component_class(class: u8) -> bool {
    !classes::is_thing(class) && !classes::is_surface(class)
}

/// What the oracle knows about each detection it made (ground truth, for tests).
#[derive(Debug, Clone, PartialEq)]
pub struct OracleTruth {
    /// Evaluation class id (1..=19).
    pub class: u8,
    /// SemanticKITTI instance id (things), component number (poles...), or 0.
    pub instance: u32,
    /// Projected points of the object.
    pub points: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
struct Key {
    class: u8,
    instance: u32,
}

/// Runs the oracle on one scan: detections in the camera's image, and the truth behind each.
/// `world_from_velo` (optional) seeds the captions of poles, trunks and signs by their place
/// in the world, so the same pole gets the same attributes in every frame.
pub fn oracle_detections(
    frame: u32,
    points: &[[f32; 4]],
    labels: &[PointLabel],
    camera: &Camera,
    world_from_velo: Option<&Rigid3>,
    cfg: &OracleConfig,
) -> Result<(DetectionFrame, Vec<OracleTruth>)> {
    if points.len() != labels.len() {
        return Err(Error::Invalid(format!(
            "frame {frame}: {} labels for {} points",
            labels.len(),
            points.len()
        )));
    }
    let (w, h) = (camera.width as usize, camera.height as usize);
    let projected = camera.project_all(points);
    // object key of every projected point
    let mut keys: Vec<Option<Key>> = Vec::with_capacity(projected.len());
    let mut split: Vec<(usize, [f64; 2])> = Vec::new();
    for (j, p) in projected.iter().enumerate() {
        let l = labels[p.point as usize];
        let class = classes::learning_class(l.semantic);
        if class == 0 {
            keys.push(None);
            continue;
        }
        let instance = if classes::is_thing(class) {
            u32::from(l.instance)
        } else {
            0
        };
        if is_component_class(class) {
            let q = points[p.point as usize];
            split.push((j, [f64::from(q[0]), f64::from(q[1])]));
        }
        keys.push(Some(Key { class, instance }));
    }
    // connected components of the non-surface classes without instance ids (per class)
    let mut centroid_of: std::collections::BTreeMap<Key, ([f64; 3], usize)> = Default::default();
    for class in (1..=19u8).filter(|c| is_component_class(*c)) {
        let (idx, xy): (Vec<usize>, Vec<[f64; 2]>) = split
            .iter()
            .filter(|(j, _)| keys[*j].is_some_and(|k| k.class == class))
            .copied()
            .unzip();
        let comp = dbscan(&xy, cfg.component_eps_m, 1);
        for (j, c) in idx.iter().zip(comp) {
            keys[*j] = c.map(|c| Key {
                class,
                instance: c as u32 + 1,
            });
        }
    }
    // z-buffer splatting
    let mut depth = vec![f32::INFINITY; w * h];
    let mut owner = vec![u32::MAX; w * h];
    let mut key_ids: std::collections::BTreeMap<Key, u32> = Default::default();
    let mut key_list: Vec<Key> = Vec::new();
    let mut n_points: Vec<usize> = Vec::new();
    let (hw, hh) = (
        cfg.splat_half_width_px as i64,
        cfg.splat_half_height_px as i64,
    );
    for (p, k) in projected.iter().zip(&keys) {
        let Some(k) = k else { continue };
        let id = *key_ids.entry(*k).or_insert_with(|| {
            key_list.push(*k);
            n_points.push(0);
            key_list.len() as u32 - 1
        });
        n_points[id as usize] += 1;
        let q = points[p.point as usize];
        let e = centroid_of.entry(*k).or_insert(([0.0; 3], 0));
        for (s, c) in e.0.iter_mut().zip(q) {
            *s += f64::from(c);
        }
        e.1 += 1;
        let (x0, y0) = ((p.pixel as usize / h) as i64, (p.pixel as usize % h) as i64);
        for x in (x0 - hw).max(0)..=(x0 + hw).min(w as i64 - 1) {
            for y in (y0 - hh).max(0)..=(y0 + hh).min(h as i64 - 1) {
                let c = x as usize * h + y as usize;
                if p.depth_m < depth[c] {
                    depth[c] = p.depth_m;
                    owner[c] = id;
                }
            }
        }
    }
    // column-major runs per owner
    let mut runs: Vec<Vec<u32>> = vec![Vec::new(); key_list.len()];
    let mut cursor: Vec<u32> = vec![0; key_list.len()];
    let mut area: Vec<u64> = vec![0; key_list.len()];
    let total = (w * h) as u32;
    let mut c = 0usize;
    while c < owner.len() {
        let o = owner[c];
        let start = c;
        while c < owner.len() && owner[c] == o {
            c += 1;
        }
        if o == u32::MAX {
            continue;
        }
        let o = o as usize;
        runs[o].push(start as u32 - cursor[o]);
        runs[o].push((c - start) as u32);
        cursor[o] = c as u32;
        area[o] += (c - start) as u64;
    }
    let mut detections = Vec::new();
    let mut truth = Vec::new();
    for (id, key) in key_list.iter().enumerate() {
        if area[id] < cfg.min_mask_px || n_points[id] < cfg.min_points {
            continue;
        }
        let mut counts = std::mem::take(&mut runs[id]);
        counts.push(total - cursor[id]);
        let mask = Rle {
            height: camera.height,
            width: camera.width,
            counts,
        };
        let bbox = mask.bbox().unwrap_or([0.0; 4]);
        let seed_instance = match (classes::is_thing(key.class), key.instance) {
            (true, i) => u64::from(i),
            (false, 0) => 0,
            (false, _) => {
                // place-based seed: the component's world position on a 4 m grid
                let (s, n) = centroid_of[key];
                let c = s.map(|v| v / n as f64);
                let c = world_from_velo.map_or(c, |m| scene::pose::apply(m, c));
                let cell = |v: f64| ((v / 4.0).floor() as i64) as u64;
                cell(c[0]).wrapping_mul(0x9E37_79B9) ^ cell(c[2]).wrapping_mul(0x85EB_CA6B)
            }
        };
        let name = class_name(key.class).unwrap_or("object");
        detections.push(Detection {
            mask,
            bbox,
            score: 1.0,
            tags: vec![name.to_string()],
            caption: caption(key.class, seed_instance, frame),
            feature: None,
        });
        truth.push(OracleTruth {
            class: key.class,
            instance: key.instance,
            points: n_points[id],
        });
    }
    Ok((
        DetectionFrame {
            frame,
            width: camera.width,
            height: camera.height,
            producer: Producer::Oracle,
            detections,
        },
        truth,
    ))
}

struct Bank {
    nouns: &'static [&'static str],
    looks: &'static [&'static str],
    sizes: &'static [&'static str],
    states: &'static [&'static str],
}

const COLOURS: &[&str] = &[
    "red",
    "white",
    "black",
    "silver",
    "blue",
    "grey",
    "dark green",
    "yellow",
    "beige",
];

fn bank(class: u8) -> Bank {
    let b = |nouns, looks, sizes, states| Bank {
        nouns,
        looks,
        sizes,
        states,
    };
    match class {
        1 => b(
            &[
                "car",
                "hatchback car",
                "sedan car",
                "estate car",
                "small SUV car",
            ],
            COLOURS,
            &["small", "compact", "mid-size", "large"],
            &[
                "parked by the curb",
                "parked on the street",
                "waiting at the roadside",
                "parked in a row of cars",
            ],
        ),
        2 => b(
            &["bicycle", "bike"],
            COLOURS,
            &["small", "old", "new"],
            &[
                "leaning against a wall",
                "parked on the sidewalk",
                "locked to a rack",
            ],
        ),
        3 => b(
            &["motorcycle", "motorbike", "scooter"],
            COLOURS,
            &["small", "heavy", "sporty"],
            &["parked at the roadside", "standing on its kickstand"],
        ),
        4 => b(
            &["truck", "delivery truck", "lorry"],
            COLOURS,
            &["large", "heavy", "box"],
            &["parked on the street", "unloading at the curb"],
        ),
        5 => b(
            &["bus", "tram", "trailer", "caravan"],
            COLOURS,
            &["large", "long", "small"],
            &["standing on the road", "parked at the roadside"],
        ),
        6 => b(
            &["person", "pedestrian", "man", "woman"],
            &[
                "in a dark coat",
                "in a red jacket",
                "in a white shirt",
                "with a backpack",
            ],
            &["tall", "short", "young", "elderly"],
            &[
                "walking on the sidewalk",
                "standing at the corner",
                "crossing the street",
            ],
        ),
        7 => b(
            &["cyclist riding a bicycle", "person riding a bike"],
            &["in a helmet", "in a yellow vest", "in dark clothes"],
            &["fast", "slow"],
            &["on the road", "in the bike lane"],
        ),
        8 => b(
            &[
                "motorcyclist riding a motorcycle",
                "person riding a motorbike",
            ],
            &["in a black helmet", "in a leather jacket"],
            &["fast", "slow"],
            &["on the road", "at the junction"],
        ),
        9 => b(
            &["road", "asphalt road", "street"],
            &["grey", "dark", "patched"],
            &["wide", "narrow", "two-lane"],
            &["with lane markings", "with cracks", "freshly paved"],
        ),
        10 => b(
            &["parking area", "parking lot", "parking bay"],
            &["grey", "paved", "gravel"],
            &["small", "large"],
            &["with painted bays", "next to the road"],
        ),
        11 => b(
            &["sidewalk", "pavement", "footpath"],
            &["grey", "paved", "brick"],
            &["narrow", "wide"],
            &["along the road", "with a curb"],
        ),
        12 => b(
            &["traffic island", "median strip", "paved ground"],
            &["grey", "concrete", "cobbled"],
            &["small", "long"],
            &["between the lanes", "at the roadside"],
        ),
        13 => b(
            &["building", "house", "apartment block", "shop front"],
            &[
                "brick",
                "white plaster",
                "glass",
                "grey concrete",
                "red brick",
            ],
            &["tall", "two-storey", "low", "large"],
            &["along the street", "with many windows", "with a flat roof"],
        ),
        14 => b(
            &["fence", "railing", "fence panel"],
            &["metal", "wooden", "wire", "low stone"],
            &["long", "short", "low", "high"],
            &["along the sidewalk", "around a garden"],
        ),
        15 => b(
            &["bushes", "hedge", "shrubs", "tree crowns"],
            &["green", "leafy", "dense"],
            &["tall", "low", "overgrown"],
            &["along the road", "in a garden", "beside the sidewalk"],
        ),
        16 => b(
            &["tree trunk", "trunk of a tree"],
            &["brown", "thick", "thin"],
            &["tall", "young", "old"],
            &["next to the sidewalk", "beside the road"],
        ),
        17 => b(
            &["terrain", "grass", "patch of soil", "lawn"],
            &["green", "dry", "muddy"],
            &["flat", "sloped"],
            &["beside the road", "next to the sidewalk"],
        ),
        18 => b(
            &["pole", "street lamp pole", "utility pole", "sign pole"],
            &["metal", "grey", "wooden", "green"],
            &["tall", "thin", "short"],
            &["at the roadside", "on the sidewalk", "at the corner"],
        ),
        _ => b(
            &["traffic sign", "road sign", "stop sign", "speed limit sign"],
            &["red", "blue", "white", "yellow"],
            &["small", "round", "square"],
            &["on a pole", "at the junction", "by the road"],
        ),
    }
}

/// A caption for an object of `class`: attributes fixed by `instance`, phrasing varied by
/// `frame`. Deterministic.
pub fn caption(class: u8, instance: u64, frame: u32) -> String {
    let b = bank(class);
    let mut attr = ChaCha8Rng::seed_from_u64(u64::from(class) << 48 ^ instance);
    let noun = b.nouns[attr.random_range(0..b.nouns.len())];
    let look = b.looks[attr.random_range(0..b.looks.len())];
    let size = b.sizes[attr.random_range(0..b.sizes.len())];
    let state = b.states[attr.random_range(0..b.states.len())];
    let mut phrasing =
        ChaCha8Rng::seed_from_u64((u64::from(class) << 48 ^ instance) ^ (u64::from(frame) << 20));
    let look_first = !look.starts_with("in ") && !look.starts_with("with ");
    match (phrasing.random_range(0..3u8), look_first) {
        (0, true) => format!("a {size} {look} {noun} {state}"),
        (1, true) => format!("a {look} {noun}, {size}, {state}"),
        (_, true) => {
            format!("{state}: a {size} {look} {noun}").replacen(state, &capitalise(state), 1)
        }
        (0, false) => format!("a {size} {noun} {look} {state}"),
        (_, false) => format!("a {noun} {look}, {size}, {state}"),
    }
}

/// `s` with its first letter in upper case.
pub(crate) fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::project::test_camera;

    #[test]
    fn captions_are_deterministic_and_varied() {
        assert_eq!(caption(1, 7, 3), caption(1, 7, 3));
        let cars: std::collections::BTreeSet<String> = (0..50).map(|i| caption(1, i, 0)).collect();
        assert!(cars.len() > 30, "{cars:?}");
        // attributes stay with the instance across frames
        let a = caption(1, 7, 0);
        let b = caption(1, 7, 9);
        let words = |s: &str| -> std::collections::BTreeSet<String> {
            s.split(|c: char| !c.is_alphanumeric())
                .filter(|w| !w.is_empty())
                .map(str::to_lowercase)
                .collect()
        };
        assert_eq!(words(&a), words(&b), "{a} / {b}");
        for class in 1..=19 {
            assert!(!caption(class, 1, 1).is_empty());
        }
    }

    /// A near car in front of a far building: the car's mask wins where they overlap, the
    /// masks are disjoint, and everything is marked as oracle output.
    #[test]
    fn masks_follow_the_zbuffer() {
        let mut pts = Vec::new();
        let mut labels = Vec::new();
        for i in 0..20 {
            for j in 0..10 {
                pts.push([5.0, i as f32 * 0.05 - 0.5, j as f32 * 0.05 - 0.25, 0.0]);
                labels.push(PointLabel {
                    semantic: 10,
                    instance: 3,
                });
            }
        }
        for i in 0..60 {
            for j in 0..30 {
                pts.push([20.0, i as f32 * 0.15 - 4.5, j as f32 * 0.15 - 2.25, 0.0]);
                labels.push(PointLabel {
                    semantic: 50,
                    instance: 0,
                });
            }
        }
        let (f, truth) = oracle_detections(
            4,
            &pts,
            &labels,
            &test_camera(),
            None,
            &OracleConfig::default(),
        )
        .unwrap();
        assert_eq!(f.producer, Producer::Oracle);
        assert_eq!(
            truth.iter().map(|t| t.class).collect::<Vec<_>>(),
            vec![1, 13]
        );
        let car = f.detections[0].mask.to_mask().unwrap();
        let building = f.detections[1].mask.to_mask().unwrap();
        assert!(car.iter().zip(&building).all(|(a, b)| !(*a && *b)));
        // the car spans 1 m at 5 m: 20 px wide around the centre column 50
        let car_bbox = f.detections[0].bbox;
        assert!(
            (car_bbox[0] - 39.0).abs() <= 2.0 && car_bbox[2] >= 18.0,
            "{car_bbox:?}"
        );
        assert!(building[25 * 100 + 30]);
        assert!(!building[25 * 100 + 50]);
        assert_eq!(f.detections[0].tags, vec!["car".to_string()]);
        let err = oracle_detections(
            4,
            &pts,
            &labels[1..],
            &test_camera(),
            None,
            &OracleConfig::default(),
        )
        .unwrap_err();
        assert!(err.to_string().contains("labels for"), "{err}");
    }
}
