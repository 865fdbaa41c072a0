//! Localisation from a description of the surroundings (the paper's "structured top-down
//! query"): "I'm at a T-junction, there's a bus stop on my left and a red car parked
//! opposite" names a segment kind and landmarks; every road segment of the map is scored by
//! whether its kind fits and whether each landmark has a matching instance at it, and the
//! position is estimated from the matched landmarks.
//!
//! Each landmark `L` has candidates `b` with a similarity gate `g_L(b)`: what the thing is
//! is matched without its colour words (1 within 0.1 of the best cosine, 0 at 0.3 below it;
//! [`crate::graph_find::similarity_gates`]), times the colour agreement of the caption
//! ([`crate::vocab::colour_agreement`]: 1, 0.8 when the caption says no colour, 0.4 for
//! another colour). The speaker stands somewhere on the segment: at the disc's centre or
//! half-way out, or every 5 m along the road's centreline. At such a spot `p`, each landmark
//! takes its own instance (two landmarks are two things; a greedy assignment) and scores
//! `g_L(b) · together(|b − p|)` (1 at the spot, 0.9 at 15 m, fading as `exp(-(d − 15) / 5)`
//! beyond), weighted by how rare the landmark is (`1.1 −` the share of segments with a good
//! match within 15 m of a spot). The segment's score is its best spot's weighted mean, plus
//! 0.5 when its kind is the said one. The position on a returned segment is the mean of its
//! places weighted by the same `together` of every matched landmark, with its spread as the
//! uncertainty ([`estimate_position`]).

use crate::chat::ChatModel;
use crate::embed::Embedder;
use crate::error::{Error, Result};
use crate::graph_find::{MapView, SceneObject, similarity_gates_relative};
use crate::request::{self, SegmentConstraint};
use crate::vocab::{colour_agreement, names_surface, without_colours};
use scene::area::SegmentArea;

/// A landmark's match at a spot: (object index, value, similarity gate).
type Pick = (usize, f64, f64);

/// Landmarks of one description stand within this distance of the speaker's spot.
const TOGETHER_M: f64 = 15.0;

pub use scene::view::{SegmentInfo, load_segments};

/// What a description says: the segment kind and the landmarks.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, schemars::JsonSchema)]
pub struct Description {
    /// The segment kind said.
    pub segment: Option<SegmentConstraint>,
    /// Landmark phrases ("a bus stop", "a red car parked").
    pub landmarks: Vec<String>,
    /// Those of `landmarks` said to stand right by the speaker ("a bench next to me", "I'm
    /// standing by a post box"): the position estimate weighs them as standing within
    /// [`BESIDE_M`] of the speaker (instead of 15 m).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub beside: Vec<String>,
}

/// A landmark said to stand right by the speaker is weighed as standing within this distance
/// of the speaker, metres.
pub const BESIDE_M: f64 = 5.0;

/// Says that the landmark next to it stands right by the speaker, whichever side of it the
/// words are on; replaced by [`BESIDE_MARK`] before clauses are split, since "next to" also
/// splits two landmarks ("a bench next to a bus stop"). "Next to" with no thing before it (at
/// the start or after a comma: "I'm at a T-junction next to a bus stop", "..., right by a
/// post box") has the speaker as its subject.
const BESIDE_WORDS: [&str; 25] = [
    ", right next to",
    ", next to",
    ", right beside",
    ", beside",
    ", right by",
    ", standing right next to",
    ", standing next to",
    ", standing beside",
    ", standing by",
    "i'm beside",
    "i'm right beside",
    "i'm right by",
    "right next to me",
    "right beside me",
    "right by me",
    "next to me",
    "beside me",
    "by my side",
    "at my feet",
    "i'm standing right next to",
    "i'm standing next to",
    "i'm standing beside",
    "i'm standing by",
    "i'm right next to",
    "i'm next to",
];

/// The word [`BESIDE_WORDS`] become while a description is read.
const BESIDE_MARK: &str = "besideme";

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
const ENDINGS: [&str; 25] = [
    "is close to me",
    "close to me",
    "immediately",
    "is",
    "right here",
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
    // the start is a clause's start, like a comma
    t = format!(" , {rest} ");
    for w in BESIDE_WORDS {
        for w in [w.to_string(), w.replace("i'm", "i am")] {
            t = t.replace(&format!(" {w} "), &format!(" {BESIDE_MARK} "));
        }
    }
    for s in SPLITTERS {
        t = t.replace(s, ",");
    }
    let mut landmarks = Vec::new();
    let mut beside = Vec::new();
    for clause in t.split(',') {
        let words: Vec<&str> = clause.split_whitespace().collect();
        let is_beside = words.contains(&BESIDE_MARK);
        let mut c = words
            .into_iter()
            .filter(|w| *w != BESIDE_MARK)
            .collect::<Vec<_>>()
            .join(" ");
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
                "me" | "i" | "it" | "here" | "left" | "right" | "corner" | "a" | "an" | "the"
            )
            || names_surface(&[], &c)
        {
            continue;
        }
        if is_beside {
            beside.push(c.clone());
        }
        landmarks.push(c);
    }
    Ok(Description {
        segment,
        landmarks,
        beside,
    })
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
        beside: Vec::new(),
    })
}

/// Why a landmark supports a segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct LandmarkEvidence {
    /// The landmark phrase.
    pub landmark: String,
    /// The instance that matches it: its node id, as `find`, `query` and `plan` take it (not
    /// the `Instance.instance_id` property).
    pub id: u64,
    /// Its caption.
    pub caption: String,
    /// Its distance from the segment's area, metres.
    pub distance_m: f64,
    /// Its similarity gate in [0, 1].
    pub similarity: f64,
}

/// One ranked segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Located {
    /// Segment node id.
    pub segment: u64,
    /// Its kind.
    pub kind: String,
    /// Score (see the module docs).
    pub score: f64,
    /// Whether the kind fits the said one (None when none was said).
    pub kind_match: Option<bool>,
    /// Estimated ground-plane position of the speaker (map ground axes, metres): the mean of
    /// the places on the segment weighted by how well each fits the matched landmarks
    /// (`llm_tools::locate::estimate_position`); the segment's centroid when none matched.
    pub position: [f64; 2],
    /// Uncertainty of `position`: the root-mean-square distance of those weighted places
    /// from it, widened by how far the landmarks stand beyond where they were said to be,
    /// metres (about the radius within which the speaker stands, if the segment is right).
    pub position_uncertainty_m: f64,
    /// The best instance per landmark.
    pub evidence: Vec<LandmarkEvidence>,
}

/// A landmark that nothing in the map matches well: it is left out of the scoring.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct UnmatchedLandmark {
    /// The landmark phrase.
    pub landmark: String,
    /// The best cosine any instance reached (below the floor).
    pub best_cosine: f64,
}

/// Ranks the map's segments for a description, best first (ties by id); `k` of them.
///
/// # Errors
/// The embedder fails or disagrees with the map's features.
pub fn locate(
    scene: &MapView,
    segments: &[SegmentInfo],
    embedder: &mut dyn Embedder,
    desc: &Description,
    k: usize,
) -> Result<Vec<Located>> {
    Ok(locate_with_floor(scene, segments, embedder, desc, k, f64::NEG_INFINITY)?.0)
}

/// [`locate`], leaving out every landmark whose best cosine is below `floor` (nothing in the
/// map is like it: "a dead end", "a purple elephant"); those are returned apart. When no
/// landmark is left and no segment kind was said, nothing is ranked.
///
/// # Errors
/// The embedder fails or disagrees with the map's features.
pub fn locate_with_floor(
    scene: &MapView,
    segments: &[SegmentInfo],
    embedder: &mut dyn Embedder,
    desc: &Description,
    k: usize,
    floor: f64,
) -> Result<(Vec<Located>, Vec<UnmatchedLandmark>)> {
    let (located, unmatched, _) = locate_normed(
        scene,
        segments,
        embedder,
        desc,
        k,
        floor,
        &LocateNorms::default(),
    )?;
    Ok((located, unmatched))
}

/// What the whole map says of a description's landmarks, for ranking one part of it (a
/// region shard) as the union of the parts would be ranked. Fanned out, locate takes three
/// passes: without norms each part gives its best cosines ([`LocateStats::bests`]); with the
/// bests (the maximum over the parts) each gives its segments with a good match
/// ([`LocateStats::hits`]); with the bests and the summed hits and segments, the ranking.
#[derive(
    Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct LocateNorms {
    /// Per landmark of the description, the best cosine over the whole map (None: no
    /// instance to match). Empty: this map's own.
    pub bests: Vec<Option<f64>>,
    /// Per landmark, the segments of the whole map with a good match in reach.
    pub hits: Option<Vec<usize>>,
    /// The whole map's segments.
    pub segments: Option<usize>,
}

/// What one map (or part) says of a description's landmarks ([`LocateNorms`]).
#[derive(
    Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct LocateStats {
    /// Per landmark, this map's best cosine (None: no instance to match).
    pub bests: Vec<Option<f64>>,
    /// Per landmark, this map's segments with a good match in reach (0 for a landmark left
    /// out under the floor).
    pub hits: Vec<usize>,
    /// This map's segments.
    pub segments: usize,
}

/// [`locate_with_floor`] under `norms` (see [`LocateNorms`]); also returns this map's
/// [`LocateStats`].
///
/// # Errors
/// The embedder fails or disagrees with the map's features.
pub fn locate_normed(
    scene: &MapView,
    segments: &[SegmentInfo],
    embedder: &mut dyn Embedder,
    desc: &Description,
    k: usize,
    floor: f64,
    norms: &LocateNorms,
) -> Result<(Vec<Located>, Vec<UnmatchedLandmark>, LocateStats)> {
    // per landmark: (object index, gate) of every candidate with a positive gate; what the
    // thing is is matched without its colour, and the colour is checked apart
    let mut kept = desc.clone();
    kept.landmarks.clear();
    let mut kept_at: Vec<usize> = Vec::new();
    let mut unmatched = Vec::new();
    let mut cands: Vec<Vec<(usize, f64)>> = Vec::new();
    let mut stats = LocateStats {
        bests: Vec::new(),
        hits: vec![0; desc.landmarks.len()],
        segments: segments.len(),
    };
    for (li, l) in desc.landmarks.iter().enumerate() {
        let kind_phrase = without_colours(l);
        let given = norms.bests.get(li).copied();
        let (gates, own) = similarity_gates_relative(
            scene,
            embedder,
            &[kind_phrase.as_str()],
            |o: &SceneObject| !o.surface,
            0.1,
            0.2,
            given.flatten(),
        )?;
        stats.bests.push(own.is_finite().then_some(own));
        let best = match given {
            Some(g) => g.unwrap_or(f64::NEG_INFINITY),
            None => own,
        };
        if best < floor {
            unmatched.push(UnmatchedLandmark {
                landmark: l.clone(),
                best_cosine: (best * 1000.0).round() / 1000.0,
            });
            continue;
        }
        kept.landmarks.push(l.clone());
        kept_at.push(li);
        cands.push(
            gates
                .into_iter()
                .enumerate()
                .filter_map(|(i, g)| {
                    // the agreement is at most 1: a gate at or below 0.05 stays there
                    g.filter(|g| *g > 0.05)
                        .map(|g| (i, g * colour_agreement(l, &scene.objects[i].caption)))
                        .filter(|(_, g)| *g > 0.05)
                })
                .collect(),
        );
    }
    if kept.landmarks.is_empty() && desc.segment.is_none() {
        // nothing said that the map holds: no ranking to give
        return Ok((Vec::new(), unmatched, stats));
    }
    let ground: Vec<[f64; 2]> = scene
        .objects
        .iter()
        .map(|o| scene.ground.ground(o.centroid))
        .collect();
    let spots: Vec<Vec<[f64; 2]>> = segments
        .iter()
        .map(|s| s.area.standing_spots(SPOT_STEP_M))
        .collect();
    // each segment's spots' bounds: a candidate farther than TOGETHER_M from them is
    // farther from every spot, and most of a city's candidates are (box_gap is a lower bound)
    let spot_bounds: Vec<[[f64; 2]; 2]> = spots.iter().map(scene::geom::bounds).collect();
    let near_spots = |spots: &[[f64; 2]], q: [f64; 2]| {
        spots
            .iter()
            .map(|p| (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2))
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    };
    // how common each landmark is: the share of segments with a good match in reach
    let n_segments = norms.segments.unwrap_or(segments.len());
    let weights: Vec<f64> = cands
        .iter()
        .zip(&kept_at)
        .map(|(cs, &li)| {
            let own = spots
                .iter()
                .zip(&spot_bounds)
                .filter(|(sp, b)| {
                    cs.iter().any(|&(i, g)| {
                        g > 0.5
                            && scene::area::box_gap(b, ground[i]) <= TOGETHER_M
                            && near_spots(sp, ground[i]) <= TOGETHER_M
                    })
                })
                .count();
            stats.hits[li] = own;
            let hit = norms
                .hits
                .as_ref()
                .and_then(|h| h.get(li).copied())
                .unwrap_or(own);
            // information content, as in IDF: a landmark found at few segments tells more
            ((n_segments as f64 + 1.0) / (hit as f64 + 0.5))
                .ln()
                .max(0.05)
        })
        .collect();
    let total_w: f64 = weights.iter().sum::<f64>().max(1e-9);
    let mut out = Vec::with_capacity(segments.len());
    for (s, spots) in segments.iter().zip(&spots) {
        let kind_match = desc.segment.map(|c| c.admits(&s.kind));
        // only candidates in reach of the segment can count (at 25 m beyond the 15 m a
        // landmark keeps under 0.01 of its value)
        // (the area's bounds first: the gap to them is a lower bound of the distance, and
        // 1 cm of slack covers the f32 of a disc's distance)
        let reach = s.area.bounds();
        let local: Vec<Vec<(usize, f64)>> = cands
            .iter()
            .map(|cs| {
                cs.iter()
                    .copied()
                    .filter(|&(i, _)| {
                        scene::area::box_gap(&reach, ground[i]) <= TOGETHER_M + 25.01
                            && s.area.distance(ground[i]) <= TOGETHER_M + 25.0
                    })
                    .collect()
            })
            .collect();
        // the best place to stand on the segment, with its landmark picks
        let mut best: Option<(f64, Vec<Option<Pick>>)> = None;
        for &p in spots {
            let (sum, picks) = assign(&local, &weights, |i| {
                let q = ground[i];
                together((q[0] - p[0]).hypot(q[1] - p[1]))
            });
            if best.as_ref().is_none_or(|b| sum > b.0 + 1e-12) {
                best = Some((sum, picks));
            }
        }
        let mut evidence = Vec::new();
        let mut support = 0.0;
        let mut seen_at = Vec::new();
        if let Some((sum, picks)) = best
            && sum > 0.0
        {
            support = sum / total_w;
            for (l, pick) in kept.landmarks.iter().zip(picks) {
                if let Some((i, v, g)) = pick
                    && v > 0.05
                {
                    let reach = if desc.beside.contains(l) {
                        BESIDE_M
                    } else {
                        TOGETHER_M
                    };
                    seen_at.push((ground[i], reach));
                    let o = &scene.objects[i];
                    evidence.push(LandmarkEvidence {
                        landmark: l.clone(),
                        id: o.id,
                        caption: o.caption.clone(),
                        distance_m: (s.area.distance(ground[i]) * 100.0).round() / 100.0,
                        similarity: g,
                    });
                }
            }
        }
        out.push((
            Located {
                segment: s.id,
                kind: s.kind.clone(),
                score: if kind_match == Some(true) { 0.5 } else { 0.0 } + support,
                kind_match,
                position: s.centroid,
                position_uncertainty_m: 0.0,
                evidence,
            },
            &s.area,
            seen_at,
        ));
    }
    out.sort_by(|a, b| {
        (b.0.score)
            .total_cmp(&a.0.score)
            .then(a.0.segment.cmp(&b.0.segment))
    });
    out.truncate(k);
    // where on each returned segment the speaker stands
    let out = out
        .into_iter()
        .map(|(mut l, area, seen_at)| {
            if let Some((p, u)) = estimate_position(area, &seen_at) {
                l.position = p;
                l.position_uncertainty_m = u;
            }
            l
        })
        .collect();
    Ok((out, unmatched, stats))
}

/// Spacing of the places on a segment where [`estimate_position`] weighs the speaker.
const ESTIMATE_STEP_M: f64 = 1.0;

/// Where on a segment the speaker stands, given the ground positions of the landmarks the
/// description matched there, each with the distance from the speaker it was said to stand
/// within (metres: [`TOGETHER_M`], or [`BESIDE_M`] for "next to me"): the places the
/// speaker may stand (a junction's disc on a 1 m grid, a road's centreline every 1 m, as in
/// [`SegmentArea::standing_spots`]) are weighted by `∏ within(|landmark − place|, reach)`
/// (the model of the score: each landmark stands within its reach of the speaker, nearer ones
/// a little likelier, fading beyond as `exp(-3 (d − reach) / reach)`), and the
/// estimate is the weighted mean (the posterior mean under a uniform prior over the segment,
/// which minimises the expected squared error). The uncertainty is the weighted root-mean-
/// square distance from it, combined (root of the sum of squares) with the largest distance
/// by which a landmark stands beyond its reach of the estimate: when the landmarks cannot
/// all be where they were said to be, the spread alone would be falsely small. With no
/// landmark the weights are uniform: the segment's middle and its spread. None when the area
/// has no place (an empty centreline).
pub fn estimate_position(
    area: &SegmentArea,
    landmarks: &[([f64; 2], f64)],
) -> Option<([f64; 2], f64)> {
    let places: Vec<[f64; 2]> = match area {
        SegmentArea::Disc { centre, radius_m } => {
            let r = radius_m.max(0.0);
            let n = (r / ESTIMATE_STEP_M).floor() as i64;
            let mut v = Vec::new();
            for i in -n..=n {
                for j in -n..=n {
                    let (dx, dy) = (i as f64 * ESTIMATE_STEP_M, j as f64 * ESTIMATE_STEP_M);
                    if dx.hypot(dy) <= r {
                        v.push([centre[0] + dx, centre[1] + dy]);
                    }
                }
            }
            v
        }
        SegmentArea::Corridor { .. } => area.standing_spots(ESTIMATE_STEP_M),
    };
    // weights in logs: a dozen far landmarks must not underflow to a 0/0 mean
    let logw: Vec<f64> = places
        .iter()
        .map(|p| {
            landmarks
                .iter()
                .map(|(q, reach)| within((q[0] - p[0]).hypot(q[1] - p[1]), *reach).ln())
                .sum()
        })
        .collect();
    let top = logw.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !top.is_finite() {
        return None;
    }
    let w: Vec<f64> = logw.iter().map(|l| (l - top).exp()).collect();
    let total: f64 = w.iter().sum();
    let mean = places.iter().zip(&w).fold([0.0, 0.0], |m, (p, w)| {
        [m[0] + w * p[0] / total, m[1] + w * p[1] / total]
    });
    let var: f64 = places
        .iter()
        .zip(&w)
        .map(|(p, w)| w * ((p[0] - mean[0]).powi(2) + (p[1] - mean[1]).powi(2)))
        .sum::<f64>()
        / total;
    let miss = landmarks
        .iter()
        .map(|(q, reach)| ((q[0] - mean[0]).hypot(q[1] - mean[1]) - reach).max(0.0))
        .fold(0.0, f64::max);
    Some((mean, (var + miss * miss).sqrt()))
}

/// Spacing of the places along a road where the speaker may stand.
const SPOT_STEP_M: f64 = 5.0;

/// How much a landmark `d` metres from the speaker counts: from 1 at the spot to 0.9 at
/// [`TOGETHER_M`] (nearer things are the likelier ones to be named), fading as
/// `0.9 · exp(-(d − 15) / 5)` beyond.
fn together(d: f64) -> f64 {
    within(d, TOGETHER_M)
}

/// How much a landmark `d` metres away counts when it was said to stand within `reach_m`:
/// 1 at the speaker to 0.9 at the reach, fading as `0.9 · exp(-3 (d − reach) / reach)`
/// beyond (a reach of 15 m fades over 5 m).
fn within(d: f64, reach_m: f64) -> f64 {
    if d <= reach_m {
        1.0 - 0.1 * d / reach_m
    } else {
        0.9 * (-3.0 * (d - reach_m) / reach_m).exp()
    }
}

/// Gives each landmark its own instance (two landmarks said are two things), greedily by
/// weighted value `w_L · g_L(b) · place(b)`: the best pair first, then the best among what is
/// left. Returns the weighted sum and each landmark's pick (object, value, gate).
fn assign(
    cands: &[Vec<(usize, f64)>],
    weights: &[f64],
    place: impl Fn(usize) -> f64,
) -> (f64, Vec<Option<Pick>>) {
    // a landmark's few best candidates are enough for a greedy assignment of a handful
    const KEEP: usize = 4;
    let ranked: Vec<Vec<Pick>> = cands
        .iter()
        .map(|cs| {
            let mut v: Vec<Pick> = cs.iter().map(|&(i, g)| (i, g * place(i), g)).collect();
            // best value first, ties by object: a total order (one entry per object), so
            // selecting the first `keep` and sorting them gives the head of the full sort
            let order = |a: &Pick, b: &Pick| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0));
            let keep = KEEP + cands.len();
            if v.len() > keep {
                v.select_nth_unstable_by(keep - 1, order);
                v.truncate(keep);
            }
            v.sort_by(order);
            v
        })
        .collect();
    let mut picks: Vec<Option<Pick>> = vec![None; cands.len()];
    let mut used: Vec<usize> = Vec::with_capacity(cands.len());
    let mut sum = 0.0;
    for _ in 0..cands.len() {
        let mut best: Option<(usize, Pick, f64)> = None;
        for (l, r) in ranked.iter().enumerate() {
            if picks[l].is_some() {
                continue;
            }
            if let Some(p) = r.iter().find(|p| !used.contains(&p.0)) {
                let wv = weights[l] * p.1;
                if best.as_ref().is_none_or(|b| wv > b.2) {
                    best = Some((l, *p, wv));
                }
            }
        }
        let Some((l, p, wv)) = best else { break };
        picks[l] = Some(p);
        used.push(p.0);
        sum += wv;
    }
    (sum, picks)
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
        // the article of a segment phrase is no landmark
        for t in [
            "I'm at an L-shaped bend.",
            "I'm at an intersection",
            "at a T junction",
        ] {
            let d = parse_description_rules(t).unwrap();
            assert!(d.segment.is_some(), "{t}");
            assert!(d.landmarks.is_empty(), "{t}: {:?}", d.landmarks);
        }
        // what is said to stand right by the speaker, on either side of the words
        let d = parse_description_rules(
            "I'm at a crossroads with a red post box right next to me and a bench opposite.",
        )
        .unwrap();
        assert_eq!(d.landmarks, vec!["a red post box", "a bench"]);
        assert_eq!(d.beside, vec!["a red post box"]);
        let d =
            parse_description_rules("I'm standing next to a bus shelter, there's a hydrant nearby")
                .unwrap();
        assert_eq!(d.landmarks, vec!["a bus shelter", "a hydrant"]);
        assert_eq!(d.beside, vec!["a bus shelter"]);
        // "next to" between two things places them, not the speaker
        let d = parse_description_rules("I can see a bench next to a bus stop").unwrap();
        assert_eq!(d.landmarks, vec!["a bench", "a bus stop"]);
        assert!(d.beside.is_empty());
        // "next to" with the speaker as its subject, and endings that only place a thing
        for (text, landmarks, beside) in [
            (
                "I'm at a T-junction next to a bus stop",
                vec!["a bus stop"],
                vec!["a bus stop"],
            ),
            (
                "standing right next to a red post box at a crossroads",
                vec!["a red post box"],
                vec!["a red post box"],
            ),
            (
                "I'm at a crossroads, next to a red post box, and a bench is close to me",
                vec!["a red post box", "a bench"],
                vec!["a red post box"],
            ),
            (
                "I'm beside a bus stop at a T junction",
                vec!["a bus stop"],
                vec!["a bus stop"],
            ),
        ] {
            let d = parse_description_rules(text).unwrap();
            assert_eq!(d.landmarks, landmarks, "{text}");
            assert_eq!(d.beside, beside, "{text}");
        }
        let d = parse_description_rules("I'm at the crossroads").unwrap();
        assert_eq!(d.segment, Some(SegmentConstraint::Crossroads));
        assert!(d.landmarks.is_empty());
        assert!(parse_description_rules(" ").is_err());
    }

    /// A scene of captioned objects (hash-embedded) on the XY ground plane.
    fn scene_of(objects: &[(u64, &str, [f64; 2])]) -> (MapView, crate::hash_embed::HashEmbedder) {
        let mut emb = crate::hash_embed::HashEmbedder::new(256);
        let captions: Vec<&str> = objects.iter().map(|o| o.1).collect();
        let features = emb.embed(&captions).unwrap();
        let objects = objects
            .iter()
            .zip(features)
            .map(|(&(id, caption, p), feature)| SceneObject {
                id,
                semantic_class: "x".into(),
                label: String::new(),
                caption: caption.into(),
                centroid: [p[0], p[1], 0.5],
                ground_min: [p[0] - 0.3, p[1] - 0.3],
                ground_max: [p[0] + 0.3, p[1] + 0.3],
                heights: (0.0, 1.0),
                feature_sq_norm: scene::view::feature_dot(&feature, &feature),
                feature,
                surface: false,
                segment: None,
            })
            .collect();
        let scene = MapView {
            ground: scene::GroundFrame::Enu,
            objects,
            segments: Vec::new(),
        };
        (scene, emb)
    }

    fn junction(id: u64, centre: [f64; 2]) -> SegmentInfo {
        SegmentInfo {
            id,
            kind: "intersection".into(),
            centroid: centre,
            area: SegmentArea::Disc {
                centre,
                radius_m: 12.0,
            },
            drivable: None,
        }
    }

    fn ranked(
        scene: &MapView,
        emb: &mut dyn Embedder,
        segs: &[SegmentInfo],
        text: &str,
    ) -> Vec<u64> {
        let d = parse_description_rules(text).unwrap();
        locate(scene, segs, emb, &d, 3)
            .unwrap()
            .iter()
            .map(|l| l.segment)
            .collect()
    }

    #[test]
    fn two_landmarks_are_two_things_and_colours_are_checked_apart() {
        let segs = [junction(10, [0.0, 0.0]), junction(20, [200.0, 0.0])];
        let (scene, mut emb) = scene_of(&[
            // at 10: one grey traffic light, and a dark blue car
            (1, "a grey traffic light at the junction", [5.0, 3.0]),
            (2, "a dark blue car parked by the curb", [-4.0, 6.0]),
            // at 20: a grey and a black traffic light, and a red bike
            (3, "a grey traffic light at the junction", [205.0, 3.0]),
            (4, "a black traffic light at the junction", [196.0, -4.0]),
            (5, "a red bike parked on the sidewalk", [203.0, -6.0]),
        ]);
        // one grey light matches both places; two lights only the second
        assert_eq!(
            ranked(
                &scene,
                &mut emb,
                &segs,
                "I'm at a crossroads, there's a grey traffic light and a traffic light behind me"
            )[0],
            20
        );
        // a dark blue bike is a bike of another colour, not a dark blue car
        assert_eq!(
            ranked(&scene, &mut emb, &segs, "I can see a dark blue bike")[0],
            20
        );
        // the position estimate is a place on the segment
        let d = parse_description_rules("there's a black traffic light").unwrap();
        let best = &locate(&scene, &segs, &mut emb, &d, 1).unwrap()[0];
        assert_eq!(best.segment, 20);
        assert!(segs[1].area.contains(best.position), "{:?}", best.position);
        assert_eq!(best.evidence[0].id, 4);
    }

    #[test]
    fn landmarks_the_map_does_not_hold_are_left_out() {
        let segs = [junction(10, [0.0, 0.0]), junction(20, [200.0, 0.0])];
        let (scene, mut emb) = scene_of(&[
            (1, "a green bench on the sidewalk", [5.0, 3.0]),
            (2, "a red post box on a short post", [203.0, -6.0]),
        ]);
        let d = parse_description_rules("there's a purple elephant and a red post box").unwrap();
        let (ranked, unmatched) = locate_with_floor(&scene, &segs, &mut emb, &d, 3, 0.4).unwrap();
        assert_eq!(unmatched.len(), 1, "{unmatched:?}");
        assert_eq!(unmatched[0].landmark, "a purple elephant");
        assert!(unmatched[0].best_cosine < 0.4);
        assert_eq!(ranked[0].segment, 20);
        assert_eq!(ranked[0].evidence.len(), 1);
        // nothing left and no kind said: nothing to rank
        let d = parse_description_rules("I can see a purple elephant").unwrap();
        let (ranked, unmatched) = locate_with_floor(&scene, &segs, &mut emb, &d, 3, 0.4).unwrap();
        assert!(ranked.is_empty());
        assert_eq!(unmatched.len(), 1);
        // a kind said still ranks
        let d = parse_description_rules("I'm at a crossroads with a purple elephant").unwrap();
        let (ranked, _) = locate_with_floor(&scene, &segs, &mut emb, &d, 3, 0.4).unwrap();
        assert_eq!(ranked.len(), 2);
    }

    #[test]
    fn the_position_is_where_the_landmarks_are_in_reach() {
        const EPS: f64 = 1e-9;
        let disc = SegmentArea::Disc {
            centre: [10.0, 20.0],
            radius_m: 12.0,
        };
        // no landmark: the middle of the disc, spread about r / sqrt(2)
        let (p, u) = estimate_position(&disc, &[]).unwrap();
        assert!(
            (p[0] - 10.0).abs() < EPS && (p[1] - 20.0).abs() < EPS,
            "{p:?}"
        );
        assert!((u - 12.0 / 2f64.sqrt()).abs() < 0.3, "{u}");
        // landmarks placed symmetrically keep the middle
        let sym = [[-5.0, 20.0], [25.0, 20.0], [10.0, 5.0], [10.0, 35.0]].map(|p| (p, TOGETHER_M));
        let (p, _) = estimate_position(&disc, &sym).unwrap();
        assert!(
            (p[0] - 10.0).abs() < 1e-6 && (p[1] - 20.0).abs() < 1e-6,
            "{p:?}"
        );
        // a landmark 20 m east: the speaker stands on the east side, and is surer of it
        let (p, u1) = estimate_position(&disc, &[([30.0, 20.0], TOGETHER_M)]).unwrap();
        assert!(p[0] > 13.0 && (p[1] - 20.0).abs() < 1e-6, "{p:?}");
        assert!(u1 < u, "{u1} vs {u}");
        // and a second one north of that narrows it further
        let (_, u2) = estimate_position(
            &disc,
            &[([30.0, 20.0], TOGETHER_M), ([22.0, 36.0], TOGETHER_M)],
        )
        .unwrap();
        assert!(u2 < u1, "{u2} vs {u1}");
        // a road: along the centreline, between landmarks 100 m apart beside it
        let road = SegmentArea::Corridor {
            centreline: vec![[0.0, 0.0], [200.0, 0.0]],
            half_width_m: 6.0,
        };
        let (p, u) = estimate_position(
            &road,
            &[([90.0, 8.0], TOGETHER_M), ([110.0, -8.0], TOGETHER_M)],
        )
        .unwrap();
        assert!((p[0] - 100.0).abs() < 1e-6 && p[1].abs() < EPS, "{p:?}");
        assert!(u < 8.0, "{u}");
        // a landmark far beyond the road's end pulls to that end, without a 0/0
        let (p, _) = estimate_position(&road, &[([900.0, 0.0], TOGETHER_M); 12]).unwrap();
        assert!(p[0] > 190.0 && p[0].is_finite(), "{p:?}");
        // nowhere to stand
        let empty = SegmentArea::Corridor {
            centreline: vec![],
            half_width_m: 6.0,
        };
        assert!(estimate_position(&empty, &[([0.0, 0.0], TOGETHER_M)]).is_none());
        // a landmark said to stand right by the speaker holds the estimate near it, surer
        let far = [([60.0, 8.0], TOGETHER_M), ([75.0, -8.0], TOGETHER_M)];
        let (p, u) = estimate_position(&road, &far).unwrap();
        let (q, v) = estimate_position(
            &road,
            &[([60.0, 8.0], BESIDE_M), ([75.0, -8.0], TOGETHER_M)],
        )
        .unwrap();
        assert!((q[0] - 60.0).abs() < (p[0] - 60.0).abs(), "{q:?} vs {p:?}");
        assert!(v < u, "{v} vs {u}");
        // one said to be beside the speaker but 20 m off the road: the estimate cannot
        // honour it, and the uncertainty says so instead of shrinking
        let (p, u) = estimate_position(&road, &[([100.0, 20.0], BESIDE_M)]).unwrap();
        assert!((p[0] - 100.0).abs() < 1e-6, "{p:?}");
        assert!(u >= 20.0 - BESIDE_M, "{u}");
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
