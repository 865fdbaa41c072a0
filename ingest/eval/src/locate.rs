//! Localisation evaluation on the simulator: descriptions of the surroundings are generated
//! from its ground truth (the true junction kind and the true objects near a spot, with
//! paraphrases and some omissions), and `locate` must rank the map segment that holds the
//! spot first (top-1) or among the first three (top-3).
//!
//! Spots are the true junctions (dead ends excepted) and the middle of every true road. A
//! description names the segment kind in one of several wordings (left out one time in five)
//! and two or three objects within 15 m that a passer-by would mention (not trees, trunks,
//! poles, signs, fences or people), drawn from the four most distinctive there (the rarest
//! classes in the city first, then the nearest: people name the post box, not the fifth lamp
//! post), each as "a {colour} {noun}" (the colour left out three times in ten) with a position
//! word ("on my left", "opposite", ...). Generation is seeded.

use std::path::Path;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use llm_tools::locate::SegmentInfo;

use crate::{Error, Result};

/// One generated description.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LocateCase {
    /// The description.
    pub text: String,
    /// The true spot on the ground plane (KITTI x, z), metres.
    pub spot: [f64; 2],
    /// The true kind: `crossroads`, `t_junction`, `l_bend` or `straight`.
    pub kind: String,
}

/// Classes a passer-by would not name as a landmark (too common or not seen).
const UNREMARKABLE: [&str; 6] = [
    "vegetation",
    "trunk",
    "pole",
    "traffic-sign",
    "person",
    "fence",
];

fn segment_phrases(kind: &str) -> &'static [&'static str] {
    match kind {
        "crossroads" => &["a crossroads", "an intersection", "a four-way junction"],
        "t_junction" => &["a T-junction", "a T-intersection", "a T junction"],
        "l_bend" => &["a bend in the road", "a corner", "an L-shaped bend"],
        _ => &[
            "a straight road",
            "a straight stretch of road",
            "a straight street",
        ],
    }
}

const POSITIONS: [&str; 6] = [
    "on my left",
    "on my right",
    "nearby",
    "opposite",
    "behind me",
    "in front of me",
];

fn article(phrase: &str) -> &'static str {
    match phrase.chars().next() {
        Some('a' | 'e' | 'i' | 'o' | 'u') => "an",
        _ => "a",
    }
}

/// Generates `per_spot` descriptions for every spot of `SIM_DIR/ground_truth` (roads.json,
/// objects.json), seeded by `seed`.
///
/// # Errors
/// The truth files are missing or malformed.
pub fn generate_cases(sim_dir: &Path, per_spot: usize, seed: u64) -> Result<Vec<LocateCase>> {
    let path = sim_dir.join("ground_truth/roads.json");
    let v = ingest::sources::sim::truth::read_json(&path)?;
    let bad = |d: &str| Error::File {
        path: path.clone(),
        detail: d.to_string(),
    };
    let xy = ingest::sources::sim::truth::json_xy;
    let mut spots: Vec<([f64; 2], String)> = Vec::new();
    for j in v["junctions"]
        .as_array()
        .ok_or_else(|| bad("no \"junctions\" array"))?
    {
        let kind = j["kind"].as_str().unwrap_or_default();
        if kind == "dead_end" {
            continue;
        }
        let p = xy(&j["position"]).ok_or_else(|| bad("a junction without a position"))?;
        spots.push((p, kind.to_string()));
    }
    for r in v["roads"]
        .as_array()
        .ok_or_else(|| bad("no \"roads\" array"))?
    {
        let line: Vec<[f64; 2]> = r["centerline"]
            .as_array()
            .map(|a| a.iter().filter_map(xy).collect())
            .unwrap_or_default();
        if line.len() >= 2 {
            spots.push((line[line.len() / 2], "straight".into()));
        }
    }
    // objects, with the fields a description uses
    let opath = sim_dir.join("ground_truth/objects.json");
    let ov = ingest::sources::sim::truth::read_json(&opath)?;
    let objects: Vec<([f64; 2], String, String, String)> = ov["objects"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|o| {
                    let c = o["box"]["center"].as_array()?;
                    Some((
                        [c.first()?.as_f64()?, c.get(2)?.as_f64()?],
                        o["class"].as_str()?.to_string(),
                        o["attributes"]["colour"]
                            .as_str()
                            .unwrap_or_default()
                            .to_string(),
                        o["attributes"]["noun"]
                            .as_str()
                            .unwrap_or_default()
                            .to_string(),
                    ))
                })
                .collect()
        })
        .unwrap_or_default();
    let mut class_count: std::collections::BTreeMap<String, usize> = Default::default();
    for o in &objects {
        *class_count.entry(o.1.clone()).or_insert(0) += 1;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    for (spot, kind) in &spots {
        let mut near: Vec<(f64, usize)> = objects
            .iter()
            .enumerate()
            .filter(|(_, o)| !UNREMARKABLE.contains(&o.1.as_str()) && !o.3.is_empty())
            .map(|(i, o)| ((o.0[0] - spot[0]).hypot(o.0[1] - spot[1]), i))
            .filter(|(d, _)| *d <= 15.0)
            .collect();
        // people name what is distinctive: the rarest classes in the city first, then the
        // nearest
        near.sort_by(|a, b| {
            let (ca, cb) = (class_count[&objects[a.1].1], class_count[&objects[b.1].1]);
            ca.cmp(&cb).then(a.0.total_cmp(&b.0)).then(a.1.cmp(&b.1))
        });
        near.truncate(4);
        for _ in 0..per_spot {
            let mut parts: Vec<String> = Vec::new();
            let n = if near.len() >= 3 && rng.random_range(0.0..1.0) < 0.5 {
                3
            } else {
                2.min(near.len())
            };
            let mut pool: Vec<usize> = near.iter().map(|x| x.1).collect();
            for _ in 0..n {
                let k = rng.random_range(0..pool.len());
                let o = &objects[pool.remove(k)];
                let colour = if !o.2.is_empty()
                    && !o.2.starts_with("in ")
                    && rng.random_range(0.0..1.0) < 0.7
                {
                    format!("{} ", o.2)
                } else {
                    String::new()
                };
                let phrase = format!("{colour}{}", o.3);
                let pos = POSITIONS[rng.random_range(0..POSITIONS.len())];
                parts.push(format!("{} {phrase} {pos}", article(&phrase)));
            }
            let seg = if rng.random_range(0.0..1.0) < 0.2 {
                None
            } else {
                let p = segment_phrases(kind);
                Some(p[rng.random_range(0..p.len())])
            };
            let text = match (seg, parts.as_slice()) {
                (Some(s), []) => format!("I'm at {s}."),
                (None, []) => continue,
                (Some(s), [first, rest @ ..]) => {
                    if rng.random_range(0.0..1.0) < 0.5 {
                        format!("I'm at {s}, there's {first}{}.", join_rest(rest))
                    } else {
                        format!("There's {first}{}, and I'm at {s}.", join_rest(rest))
                    }
                }
                (None, [first, rest @ ..]) => format!("I can see {first}{}.", join_rest(rest)),
            };
            out.push(LocateCase {
                text,
                spot: *spot,
                kind: kind.clone(),
            });
        }
    }
    Ok(out)
}

fn join_rest(rest: &[String]) -> String {
    match rest {
        [] => String::new(),
        [one] => format!(" and {one}"),
        [a, b] => format!(", {a} and {b}"),
        more => format!(", {}", more.join(", ")),
    }
}

/// The map segment that holds a spot: among segments whose area is within 3 m of it, a
/// junction before a road, then the nearest; None when no segment is that close.
pub fn true_segment(segments: &[SegmentInfo], spot: [f64; 2]) -> Option<u64> {
    segments
        .iter()
        .map(|s| (s, s.area.distance(spot)))
        .filter(|(_, d)| *d <= 3.0)
        .min_by(|a, b| {
            let is_road = |s: &SegmentInfo| s.kind == "straight_roadway";
            is_road(a.0)
                .cmp(&is_road(b.0))
                .then(a.1.total_cmp(&b.1))
                .then(a.0.id.cmp(&b.0.id))
        })
        .map(|(s, _)| s.id)
}

/// Top-1 and top-3 accuracy over some cases.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Accuracy {
    /// Cases scored.
    pub cases: usize,
    /// Share with the true segment first.
    pub top1: f64,
    /// Share with it among the first three.
    pub top3: f64,
}

/// The outcome of one description.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LocateOutcome {
    /// The description.
    pub text: String,
    /// The true kind.
    pub kind: String,
    /// The true segment (node id).
    pub truth: u64,
    /// The first three segments returned.
    pub returned: Vec<u64>,
    /// Distance from the estimated position to the true spot, metres.
    pub position_error_m: Option<f64>,
    /// The uncertainty `locate` reported with the position, metres.
    pub position_uncertainty_m: Option<f64>,
}

/// The result of [`eval_locate`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct LocateEval {
    /// Over every scored case.
    pub all: Accuracy,
    /// Per true kind.
    pub per_kind: std::collections::BTreeMap<String, Accuracy>,
    /// Median distance from the estimated position to the true spot, metres.
    pub median_position_error_m: Option<f64>,
    /// Share of the scored cases whose first answer's position lies within 5 m of the true
    /// spot (a case without a position counts as outside).
    pub within_5m: f64,
    /// The same within 10 m.
    pub within_10m: f64,
    /// Share of the cases with a position whose true spot lies within twice the reported
    /// uncertainty of it (calibration: near 0.95 for a Gaussian-like spread).
    pub within_2_sigma: f64,
    /// Cases whose spot lies in no map segment (not scored).
    pub unmatched: usize,
    /// Every scored case.
    pub outcomes: Vec<LocateOutcome>,
}

/// What `locate` answered for one description: segment ids, best first, and the first's
/// estimated ground position and its uncertainty (metres).
pub type LocateAnswer = (Vec<u64>, Option<([f64; 2], f64)>);

/// Runs every case through `locate` and scores the answers against the segment that holds
/// the spot, and the positions against the spot.
///
/// # Errors
/// `locate` fails.
pub fn eval_locate(
    cases: &[LocateCase],
    segments: &[SegmentInfo],
    mut locate: impl FnMut(&str) -> Result<LocateAnswer>,
) -> Result<LocateEval> {
    let mut out = LocateEval::default();
    let mut tally: std::collections::BTreeMap<String, [usize; 3]> = Default::default();
    let mut errors = Vec::new();
    let mut covered = 0usize;
    for c in cases {
        let Some(truth) = true_segment(segments, c.spot) else {
            out.unmatched += 1;
            continue;
        };
        let (ranked, pos) = locate(&c.text)?;
        let rank = ranked.iter().position(|s| *s == truth);
        for key in [c.kind.clone(), "all".to_string()] {
            let t = tally.entry(key).or_default();
            t[0] += 1;
            t[1] += usize::from(rank == Some(0));
            t[2] += usize::from(rank.is_some_and(|r| r < 3));
        }
        let err = pos.map(|(p, _)| (p[0] - c.spot[0]).hypot(p[1] - c.spot[1]));
        if let Some(e) = err {
            errors.push(e);
        }
        if let (Some(e), Some((_, u))) = (err, pos) {
            covered += usize::from(e <= 2.0 * u);
        }
        out.outcomes.push(LocateOutcome {
            text: c.text.clone(),
            kind: c.kind.clone(),
            truth,
            returned: ranked.into_iter().take(3).collect(),
            position_error_m: err,
            position_uncertainty_m: pos.map(|p| p.1),
        });
    }
    for (k, t) in tally {
        let n = t[0].max(1) as f64;
        let a = Accuracy {
            cases: t[0],
            top1: t[1] as f64 / n,
            top3: t[2] as f64 / n,
        };
        if k == "all" {
            out.all = a;
        } else {
            out.per_kind.insert(k, a);
        }
    }
    let scored = out.outcomes.len().max(1) as f64;
    out.within_5m = errors.iter().filter(|e| **e <= 5.0).count() as f64 / scored;
    out.within_10m = errors.iter().filter(|e| **e <= 10.0).count() as f64 / scored;
    out.within_2_sigma = covered as f64 / errors.len().max(1) as f64;
    errors.sort_by(f64::total_cmp);
    out.median_position_error_m = errors.get(errors.len() / 2).copied();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cases_are_seeded_and_describe_near_objects() {
        let dir = tempfile::tempdir().unwrap();
        let gt = dir.path().join("ground_truth");
        std::fs::create_dir_all(&gt).unwrap();
        std::fs::write(
            gt.join("roads.json"),
            r#"{"junctions": [{"id": 0, "kind": "t_junction", "position": [0, 0]},
                {"id": 1, "kind": "dead_end", "position": [100, 0]}],
               "roads": [{"centerline": [[0, 0], [50, 0], [100, 0]]}]}"#,
        )
        .unwrap();
        std::fs::write(
            gt.join("objects.json"),
            r#"{"objects": [
              {"box": {"center": [3, 0, 2]}, "class": "bench", "attributes": {"colour": "green", "noun": "park bench"}},
              {"box": {"center": [-4, 0, 1]}, "class": "mailbox", "attributes": {"colour": "red", "noun": "post box"}},
              {"box": {"center": [2, 0, 1]}, "class": "vegetation", "attributes": {"colour": "green", "noun": "hedge"}},
              {"box": {"center": [52, 0, 3]}, "class": "trash can", "attributes": {"colour": "", "noun": "litter bin"}},
              {"box": {"center": [49, 0, -3]}, "class": "car", "attributes": {"colour": "white", "noun": "sedan"}}]}"#,
        )
        .unwrap();
        let a = generate_cases(dir.path(), 3, 7).unwrap();
        assert_eq!(a, generate_cases(dir.path(), 3, 7).unwrap());
        // the T-junction and the road's middle, three each; the dead end is no spot
        assert_eq!(a.iter().filter(|c| c.kind == "t_junction").count(), 3);
        assert_eq!(a.iter().filter(|c| c.kind == "straight").count(), 3);
        for c in &a {
            assert!(!c.text.contains("hedge"), "{}", c.text);
            if c.kind == "t_junction" {
                assert!(
                    c.text.contains("bench") && c.text.contains("post box"),
                    "{}",
                    c.text
                );
            } else {
                assert!(
                    c.text.contains("litter bin") && c.text.contains("sedan"),
                    "{}",
                    c.text
                );
            }
        }
    }
}
