//! Localisation from a description of the surroundings (the paper's "structured top-down
//! query"): "I'm at a T-junction, there's a bus stop on my left and a red car parked
//! opposite" names a segment kind and landmarks; every road segment of the map is scored by
//! whether its kind fits and whether each landmark has a matching instance at it, and the
//! position is estimated from the matched landmarks.
//!
//! Each landmark `L` has candidates `b` with a similarity gate `g_L(b)` (1 within 0.1 of the best
//! cosine, 0 at 0.3 below it; [`crate::graph_find::similarity_gates`]). For a segment `s`, the
//! speaker may stand at any well-matched candidate (`g ≥ 0.3`) within 10 m of its area; at such
//! a spot `p`, each landmark scores `max_b g_L(b) · together(|b − p|) · near(b, s)` (1 within
//! 15 m of `p` and within 10 m of the area, fading as `exp(-(d − limit) / 5)`), weighted by
//! how rare the landmark is (`1.1 −` the share of segments with a good match). The segment's
//! score is its best spot's weighted mean, plus 0.5 when its kind is the said one. The position
//! is the mean of that spot's matched landmarks, weighted by their scores.

use graphstore::{GraphRead, Value};

use crate::chat::ChatModel;
use crate::embed::Embedder;
use crate::error::{Error, Result};
use crate::graph_find::{Scene, SceneObject, similarity_gates};
use crate::request::{self, SegmentConstraint};
use crate::vocab::names_surface;

/// A landmark's match at a spot: (object index, value, similarity gate).
type Pick = (usize, f64, f64);

/// A landmark counts for a segment when it lies within this distance of the segment's area.
const SEGMENT_SLACK_M: f64 = 10.0;

/// Landmarks of one description stand within this distance of the speaker's spot.
const TOGETHER_M: f64 = 15.0;

pub use planner::area::SegmentArea;

/// A road segment of the map.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentInfo {
    /// Node id.
    pub id: u64,
    /// `Segment.kind`.
    pub kind: String,
    /// Ground-plane centroid.
    pub centroid: [f64; 2],
    /// Its area.
    pub area: SegmentArea,
}

/// Reads the map's segments with their areas.
///
/// # Errors
/// The store fails or has no ground frame.
pub fn load_segments(r: &impl GraphRead, g: planner::Ground) -> Result<Vec<SegmentInfo>> {
    let mut out = Vec::new();
    for id in r.nodes_with_label("Segment")? {
        let kind = r
            .node_prop(id, "kind")?
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        let Some(c) = r.node_prop(id, "centroid")?.and_then(|v| v.as_point3()) else {
            continue;
        };
        let centroid = g.of(c);
        let area = match (
            r.node_prop(id, "radius_m")?,
            r.node_prop(id, "centerline")?,
            r.node_prop(id, "half_width_m")?,
        ) {
            (Some(Value::Float(radius_m)), _, _) => SegmentArea::Disc {
                centre: centroid,
                radius_m,
            },
            (_, Some(Value::List(line)), Some(Value::Float(half_width_m))) => {
                SegmentArea::Corridor {
                    centreline: line
                        .iter()
                        .filter_map(Value::as_point3)
                        .map(|p| g.of(p))
                        .collect(),
                    half_width_m,
                }
            }
            _ => SegmentArea::Disc {
                centre: centroid,
                radius_m: 12.0,
            },
        };
        out.push(SegmentInfo {
            id,
            kind,
            centroid,
            area,
        });
    }
    Ok(out)
}

/// What a description says: the segment kind and the landmarks.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct Description {
    /// The segment kind said.
    pub segment: Option<SegmentConstraint>,
    /// Landmark phrases ("a bus stop", "a red car parked").
    pub landmarks: Vec<String>,
}

/// Clause openers that say nothing about the place.
const OPENERS: [&str; 22] = [
    "i'm standing at",
    "i am standing at",
    "i'm standing by",
    "i'm standing",
    "i am standing",
    "i'm at",
    "i am at",
    "i'm by",
    "i'm near",
    "i'm next to",
    "i'm on",
    "i'm",
    "i am",
    "there's",
    "there is",
    "there are",
    "i can see",
    "i see",
    "with",
    "and",
    "at",
    "by",
];

/// Clause endings that only place the landmark relative to the speaker.
const ENDINGS: [&str; 20] = [
    "on my left",
    "on my right",
    "to my left",
    "to my right",
    "on the left",
    "on the right",
    "in front of me",
    "behind me",
    "next to me",
    "beside me",
    "near me",
    "nearby",
    "close by",
    "opposite",
    "across the road",
    "across the street",
    "on the other side",
    "on the corner",
    "here",
    "too",
];

/// Words that split a description into clauses, each naming at most one landmark.
const SPLITTERS: [&str; 12] = [
    " and ",
    " with ",
    " there's ",
    " there is ",
    " i see ",
    " i can see ",
    " next to ",
    " near ",
    " beside ",
    " opposite ",
    " across from ",
    " behind ",
];

/// The rule parser for descriptions: the segment phrase (as in [`request::parse_rules`]),
/// then clauses split at commas and joining words, each stripped of openers ("there's", "I'm
/// at") and of endings that place it relative to the speaker ("on my left", "opposite"); what
/// is left and names a thing (not a surface, not the speaker) is a landmark.
///
/// # Errors
/// The text is empty.
pub fn parse_description_rules(text: &str) -> Result<Description> {
    if text.trim().is_empty() {
        return Err(Error::Invalid("the description is empty".into()));
    }
    let mut t = text.to_lowercase().replace(['’', '‘'], "'");
    t = t.replace(['.', ';', '!', '?', ':'], ",");
    // commas as words, so that phrases end at them
    t = t.replace(',', " , ");
    let (segment, rest) = request::take_segment(&t);
    t = rest;
    for s in SPLITTERS {
        t = t.replace(s, ",");
    }
    let mut landmarks = Vec::new();
    for clause in t.split(',') {
        let mut c = clause.split_whitespace().collect::<Vec<_>>().join(" ");
        loop {
            let before = c.len();
            for o in OPENERS {
                if c == o {
                    c.clear();
                } else if let Some(rest) = c.strip_prefix(&format!("{o} ")) {
                    c = rest.to_string();
                }
            }
            for e in ENDINGS {
                if c == e {
                    c.clear();
                } else if let Some(rest) = c.strip_suffix(&format!(" {e}")) {
                    c = rest.to_string();
                }
            }
            if c.len() == before {
                break;
            }
        }
        let bare = c
            .trim_start_matches("the ")
            .trim_start_matches("a ")
            .trim_start_matches("an ")
            .trim();
        if bare.is_empty()
            || bare.starts_with("of ")
            || matches!(
                bare,
                "me" | "i" | "it" | "here" | "left" | "right" | "corner"
            )
            || names_surface(&[], &c)
        {
            continue;
        }
        landmarks.push(c);
    }
    Ok(Description { segment, landmarks })
}

/// The same with a language model: its request parse ([`request::parse_llm`]) gives the
/// segment, and its target and anchors are the landmarks.
///
/// # Errors
/// The model fails or answers no request.
pub fn parse_description_llm(model: &mut dyn ChatModel, text: &str) -> Result<Description> {
    let r = request::parse_llm(model, text)?;
    let mut landmarks: Vec<String> = Vec::new();
    for p in std::iter::once(r.target.as_str()).chain(r.anchors.iter().map(|a| a.phrase.as_str())) {
        let p = p.trim().to_lowercase();
        if !p.is_empty() && !names_surface(&[], &p) && !landmarks.contains(&p) {
            landmarks.push(p);
        }
    }
    Ok(Description {
        segment: r.segment,
        landmarks,
    })
}

/// Why a landmark supports a segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LandmarkEvidence {
    /// The landmark phrase.
    pub landmark: String,
    /// The instance that matches it (node id).
    pub instance_id: u64,
    /// Its caption.
    pub caption: String,
    /// Its distance from the segment's area, metres.
    pub distance_m: f64,
    /// Its similarity gate in [0, 1].
    pub similarity: f64,
}

/// One ranked segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Located {
    /// Segment node id.
    pub segment: u64,
    /// Its kind.
    pub kind: String,
    /// Score (see the module docs).
    pub score: f64,
    /// Whether the kind fits the said one (None when none was said).
    pub kind_match: Option<bool>,
    /// Estimated ground-plane position: the score-weighted mean of the matched landmarks,
    /// or the segment's centroid when none matched.
    pub position: [f64; 2],
    /// The best instance per landmark.
    pub evidence: Vec<LandmarkEvidence>,
}

/// Ranks the map's segments for a description, best first (ties by id); `k` of them.
///
/// # Errors
/// The embedder fails or disagrees with the map's features.
pub fn locate(
    scene: &Scene,
    segments: &[SegmentInfo],
    embedder: &mut dyn Embedder,
    desc: &Description,
    k: usize,
) -> Result<Vec<Located>> {
    // per landmark: (object index, gate) of every candidate with a positive gate
    let mut cands: Vec<Vec<(usize, f64)>> = Vec::new();
    for l in &desc.landmarks {
        let gates = similarity_gates(
            scene,
            embedder,
            &[l.as_str()],
            |o: &SceneObject| !o.surface,
            0.1,
            0.2,
        )?;
        cands.push(
            gates
                .into_iter()
                .enumerate()
                .filter_map(|(i, g)| g.filter(|g| *g > 0.0).map(|g| (i, g)))
                .collect(),
        );
    }
    let ground = |i: usize| scene.ground.of(scene.objects[i].centroid);
    let near_area = |d: f64| {
        if d <= SEGMENT_SLACK_M {
            1.0
        } else {
            (-(d - SEGMENT_SLACK_M) / 5.0).exp()
        }
    };
    let together = |d: f64| {
        if d <= TOGETHER_M {
            1.0
        } else {
            (-(d - TOGETHER_M) / 5.0).exp()
        }
    };
    // how common each landmark is: the share of segments with a good match at them
    let weights: Vec<f64> = cands
        .iter()
        .map(|cs| {
            let hit = segments
                .iter()
                .filter(|s| {
                    cs.iter()
                        .any(|&(i, g)| g * near_area(s.area.distance(ground(i))) > 0.5)
                })
                .count();
            1.1 - hit as f64 / segments.len().max(1) as f64
        })
        .collect();
    let total_w: f64 = weights.iter().sum::<f64>().max(1e-9);
    let mut out = Vec::with_capacity(segments.len());
    for s in segments {
        let kind_match = desc.segment.map(|c| c.admits(&s.kind));
        // where the speaker may stand: at a well-matched landmark near the segment
        let mut spots: Vec<[f64; 2]> = Vec::new();
        for cs in &cands {
            for &(i, g) in cs {
                let p = ground(i);
                if g >= 0.3 && s.area.distance(p) <= SEGMENT_SLACK_M {
                    spots.push(p);
                }
            }
        }
        // the best spot: every landmark matched close to it, weighted by rarity
        let mut best: Option<(f64, Vec<Option<Pick>>)> = None;
        for p in &spots {
            let mut sum = 0.0;
            let mut picks = Vec::with_capacity(cands.len());
            for (cs, w) in cands.iter().zip(&weights) {
                let mut pick: Option<Pick> = None;
                for &(i, g) in cs {
                    let q = ground(i);
                    let v = g
                        * together((q[0] - p[0]).hypot(q[1] - p[1]))
                        * near_area(s.area.distance(q));
                    if pick.is_none_or(|x| v > x.1) {
                        pick = Some((i, v, g));
                    }
                }
                sum += w * pick.map_or(0.0, |x| x.1);
                picks.push(pick);
            }
            if best.as_ref().is_none_or(|b| sum > b.0) {
                best = Some((sum, picks));
            }
        }
        let mut evidence = Vec::new();
        let (mut wx, mut wz, mut w) = (0.0, 0.0, 0.0);
        let mut support = 0.0;
        if let Some((sum, picks)) = best {
            support = sum / total_w;
            for (l, pick) in desc.landmarks.iter().zip(picks) {
                if let Some((i, v, g)) = pick
                    && v > 0.05
                {
                    let o = &scene.objects[i];
                    let q = ground(i);
                    wx += v * q[0];
                    wz += v * q[1];
                    w += v;
                    evidence.push(LandmarkEvidence {
                        landmark: l.clone(),
                        instance_id: o.id,
                        caption: o.caption.clone(),
                        distance_m: (s.area.distance(q) * 100.0).round() / 100.0,
                        similarity: g,
                    });
                }
            }
        }
        out.push(Located {
            segment: s.id,
            kind: s.kind.clone(),
            score: if kind_match == Some(true) { 0.5 } else { 0.0 } + support,
            kind_match,
            position: if w > 0.0 {
                [wx / w, wz / w]
            } else {
                s.centroid
            },
            evidence,
        });
    }
    out.sort_by(|a, b| b.score.total_cmp(&a.score).then(a.segment.cmp(&b.segment)));
    out.truncate(k);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptions_become_a_segment_and_landmarks() {
        let d = parse_description_rules(
            "I'm at a T-junction, there's a bus stop on my left and a red car parked opposite.",
        )
        .unwrap();
        assert_eq!(d.segment, Some(SegmentConstraint::TJunction));
        assert_eq!(d.landmarks, vec!["a bus stop", "a red car parked"]);
        let d = parse_description_rules(
            "standing on the sidewalk next to a green bench with a mailbox nearby",
        )
        .unwrap();
        assert_eq!(d.segment, None);
        assert_eq!(d.landmarks, vec!["a green bench", "a mailbox"]);
        let d = parse_description_rules(
            "There's a grey park bench in front of me, and I'm at a straight stretch of road.",
        )
        .unwrap();
        assert_eq!(d.segment, Some(SegmentConstraint::StraightRoad));
        assert_eq!(d.landmarks, vec!["a grey park bench"]);
        let d = parse_description_rules("I'm at the crossroads").unwrap();
        assert_eq!(d.segment, Some(SegmentConstraint::Crossroads));
        assert!(d.landmarks.is_empty());
        assert!(parse_description_rules(" ").is_err());
    }

    #[test]
    fn distances_to_areas() {
        let disc = SegmentArea::Disc {
            centre: [0.0, 0.0],
            radius_m: 10.0,
        };
        assert!(disc.distance([5.0, 0.0]).abs() < 1e-12);
        // parry computes in f32
        assert!((disc.distance([13.0, 4.0]) - (185f64.sqrt() - 10.0)).abs() < 1e-4);
        let road = SegmentArea::Corridor {
            centreline: vec![[0.0, 0.0], [100.0, 0.0]],
            half_width_m: 8.0,
        };
        assert!(road.distance([50.0, 7.0]).abs() < 1e-12);
        assert!((road.distance([50.0, 20.0]) - 12.0).abs() < 1e-9);
        assert!((road.distance([110.0, 0.0]) - 2.0).abs() < 1e-9);
    }
}
