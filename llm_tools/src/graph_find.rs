//! Graph-aware retrieval: a parsed [`Request`] is answered over the map's instance layer.
//! Candidates for the target and for each anchor come from embedding similarity; each
//! target candidate is then scored with its anchors by relation fit (footprint gaps and
//! heights on the ground plane, `RELATED` edges) and its road segment (`IN_SEGMENT`):
//!
//! `score = g_t · attr(t) · (1 + mean_a max_b g_a(b) · fit_a(t, b)) · seg(t) + 0.1 · cos_t / cos_best`
//!
//! where `g_t` gates the target cosine against the best candidate's (1 within 0.25 of it, then
//! falling linearly to 0 over 0.2, so paraphrases of the same thing count alike), `attr(t)` is
//! 1 + 0.3 × the share of the request's attribute words that the caption says, `g_a(b)` the
//! same gate for anchor `a` and candidate `b` (plateau 0.2, fall-off 0.15), `fit_a` in [0, 1] how well the pair matches the asked relation (and distance;
//! a `RELATED` edge between them counts at least 0.8; a target whose own caption places it by
//! the anchor, "a post box on a short post" for "on a short post", counts 1 with itself as
//! the evidence, see [`caption_places_by`]), and `seg(t)` 1 when the target's
//! segment satisfies the asked segment constraint, else `0.5 + 0.5 · near(d)` with `d` its
//! distance to the nearest segment of that kind (`near` 1 within 10 m, `exp(-(d − 10) / 10)`
//! beyond).
//! other-ground) are never answers unless the target names a surface. Every result carries
//! its evidence. [`rerank_llm`] lets a language model pick the best three of the top N
//! (OpenGraph-LLM).

use std::collections::HashMap;

use graphstore::{Direction, GraphRead};

use crate::chat::{ChatModel, ChatRequest, Message};
use crate::embed::{Embedder, cosine_normed};
use crate::error::{Error, Result};
use crate::request::{Relation, Request};
use crate::vocab::{colour_agreement, names_surface, says_colour, words};

/// Cosine taken off a candidate per unit of colour disagreement ([`colour_agreement`]).
pub const COLOUR_PENALTY: f64 = 0.25;

pub use scene::view::{MapView, SceneObject};

/// How well a pair (target `t`, anchor `b`) fits a relation, in [0, 1]. Distances are
/// footprint gaps; "in front of", "behind", "left of" and "right of" count as near (the
/// map has no viewpoint); "opposite" and "across the road from" want 4–25 m.
pub fn relation_fit(
    rel: Relation,
    distance_m: Option<f64>,
    t: &SceneObject,
    b: &SceneObject,
) -> f64 {
    let d = MapView::gap_m(t, b);
    let within = |limit: f64, fall: f64| {
        if d <= limit {
            1.0
        } else {
            (-(d - limit) / fall).exp()
        }
    };
    if let Some(dist) = distance_m {
        return within(dist, 2.0);
    }
    match rel {
        Relation::Near
        | Relation::InFrontOf
        | Relation::Behind
        | Relation::LeftOf
        | Relation::RightOf => within(5.0, 3.0),
        Relation::NextTo => within(1.5, 1.5),
        Relation::On | Relation::Under => {
            let (above, below) = if rel == Relation::On { (t, b) } else { (b, t) };
            if d > 0.0 {
                0.5 * (-d).exp()
            } else if above.heights.0 >= below.heights.1 - 0.3
                || above.heights.1 > below.heights.1 + 0.2
            {
                1.0
            } else {
                0.5
            }
        }
        Relation::Inside => {
            let c = [
                (t.ground_min[0] + t.ground_max[0]) / 2.0,
                (t.ground_min[1] + t.ground_max[1]) / 2.0,
            ];
            let inside = (b.ground_min[0]..=b.ground_max[0]).contains(&c[0])
                && (b.ground_min[1]..=b.ground_max[1]).contains(&c[1]);
            if inside { 1.0 } else { 0.5 * (-d).exp() }
        }
        Relation::Opposite | Relation::AcrossTheRoadFrom => {
            if d < 4.0 {
                0.4
            } else if d <= 25.0 {
                1.0
            } else {
                (-(d - 25.0) / 5.0).exp()
            }
        }
    }
}

/// Sizes and weights of a graph-aware query.
#[derive(Debug, Clone, PartialEq)]
pub struct GraphFindOptions {
    /// How many results.
    pub k: usize,
    /// Target candidates taken by similarity before the graph scoring.
    pub target_candidates: usize,
    /// Candidates per anchor.
    pub anchor_candidates: usize,
    /// Factor for a target outside the asked segment kind.
    pub segment_miss: f64,
    /// Target cosines within this much of the best candidate's count fully ...
    pub target_plateau: f64,
    /// ... and fade to nothing over this much more.
    pub target_falloff: f64,
    /// Anchor cosines within this much of the best anchor candidate's count fully ...
    pub anchor_plateau: f64,
    /// ... and fade to nothing over this much more.
    pub anchor_falloff: f64,
    /// Weight of the raw target cosine (over the best), which orders otherwise tied results.
    pub cosine_weight: f64,
    /// Bonus factor when the caption says every attribute of the request.
    pub attribute_weight: f64,
    /// Only targets of this class.
    pub class: Option<String>,
    /// Only targets whose centroid is within `radius_m` of this ground point.
    pub near: Option<([f64; 2], f64)>,
}

impl Default for GraphFindOptions {
    fn default() -> Self {
        GraphFindOptions {
            k: 10,
            target_candidates: 100,
            anchor_candidates: 300,
            segment_miss: 0.5,
            target_plateau: 0.2,
            target_falloff: 0.2,
            anchor_plateau: 0.2,
            anchor_falloff: 0.15,
            cosine_weight: 0.1,
            attribute_weight: 0.3,
            class: None,
            near: None,
        }
    }
}

/// Why an anchor supports a result.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Evidence {
    /// The anchor phrase of the request.
    pub anchor: String,
    /// The asked relation.
    pub relation: String,
    /// The instance that plays the anchor (node id).
    pub anchor_id: u64,
    /// Its caption.
    pub anchor_caption: String,
    /// Footprint gap between the two, metres.
    pub distance_m: f64,
    /// The anchor gate of this candidate.
    pub similarity: f64,
    /// Relation fit in [0, 1].
    pub fit: f64,
    /// A `RELATED` edge between them (`relation (source)`), when the map has one.
    pub related: Option<String>,
}

/// One graph-aware result.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct GraphFound {
    /// Node id.
    pub id: u64,
    /// What it is: its open-vocabulary label ("post box"); empty on maps built without
    /// labels.
    pub label: String,
    /// Caption.
    pub caption: String,
    /// Its SemanticKITTI class (`Instance.semantic_class`, or `other-object`).
    pub semantic_class: String,
    /// The combined score (see the module docs).
    pub score: f64,
    /// The target gate (times the attribute factor): relative to the best candidate, so the
    /// best has about 1 even when nothing matches well; see `cosine` for that.
    pub similarity: f64,
    /// The raw cosine of the target phrase with this instance's feature (colour-checked): low
    /// for every result when the map holds nothing like the request.
    pub cosine: f64,
    /// Centroid, world frame.
    pub centroid: [f64; 3],
    /// Its segment: node id and kind.
    pub segment: Option<(u64, String)>,
    /// Whether its segment satisfies the asked constraint (None when none was asked).
    pub segment_match: Option<bool>,
    /// One entry per anchor, the best-supporting instance.
    pub evidence: Vec<Evidence>,
    /// For a request for the nearest to a place ("the fire hydrant nearest the start of the
    /// drive"): the ground-plane distance from the place to this object's centroid, metres;
    /// null otherwise.
    pub place_distance_m: Option<f64>,
}

/// Cosines of every object with the best of `phrases`, and the best cosine over `allowed`.
fn similarities(
    scene: &MapView,
    embedder: &mut dyn Embedder,
    phrases: &[&str],
    allowed: impl Fn(&SceneObject) -> bool,
) -> Result<Vec<Option<f64>>> {
    let qs = embedder.embed(phrases)?;
    let q_norms: Vec<f64> = qs.iter().map(|q| scene::view::feature_dot(q, q)).collect();
    let mut out = Vec::with_capacity(scene.objects.len());
    for o in &scene.objects {
        if !allowed(o) {
            out.push(None);
            continue;
        }
        let mut best = f64::NEG_INFINITY;
        for (q, &q_norm) in qs.iter().zip(&q_norms) {
            if q.len() != o.feature.len() {
                return Err(Error::Invalid(format!(
                    "instance {} has a {}-dimensional feature, the embedder gives {}",
                    o.id,
                    o.feature.len(),
                    q.len()
                )));
            }
            best = best.max(cosine_normed(q, q_norm, &o.feature, o.feature_sq_norm));
        }
        out.push(Some(best));
    }
    Ok(out)
}

/// [`similarities`] with colours checked: a colour said in the phrases and only another one
/// in the caption takes up to [`COLOUR_PENALTY`] off the cosine ([`colour_agreement`], the best
/// over the phrases). Anchors and landmarks are matched with it.
fn colour_checked_similarities(
    scene: &MapView,
    embedder: &mut dyn Embedder,
    phrases: &[&str],
    allowed: impl Fn(&SceneObject) -> bool,
) -> Result<Vec<Option<f64>>> {
    let sims = similarities(scene, embedder, phrases, allowed)?;
    // a phrase that names no colour agrees with every caption (1), and the best over the
    // phrases is then 1: no caption needs reading
    if !phrases.iter().all(|p| says_colour(p)) {
        return Ok(sims);
    }
    Ok(sims
        .into_iter()
        .zip(&scene.objects)
        .map(|(s, o)| {
            s.map(|s| {
                let agree = phrases
                    .iter()
                    .map(|p| colour_agreement(p, &o.caption))
                    .fold(0.0, f64::max);
                s - (1.0 - agree) * COLOUR_PENALTY
            })
        })
        .collect())
}

/// The similarity gate of every object for the best of `phrases` (None where `allowed`
/// says no): 1 within `plateau` of the best cosine, falling to 0 over the next `falloff`
/// ([`find_graph`] uses 0.2 and 0.15 for anchors), times `0.9 + 0.1 · cos / cos_best` so that
/// the closer caption wins a tie. A colour said in the phrase and another in the caption takes
/// [`COLOUR_PENALTY`] off the cosine first.
///
/// # Errors
/// The embedder fails or disagrees with the map's features.
pub fn similarity_gates(
    scene: &MapView,
    embedder: &mut dyn Embedder,
    phrases: &[&str],
    allowed: impl Fn(&SceneObject) -> bool,
    plateau: f64,
    falloff: f64,
) -> Result<Vec<Option<f64>>> {
    Ok(similarity_gates_relative(scene, embedder, phrases, allowed, plateau, falloff, None)?.0)
}

/// [`similarity_gates`] relative to `best` when given (the whole map's best, for one part
/// of it), else to this map's best; also returns this map's best (colour-checked) cosine:
/// low when the map holds nothing like the phrases.
///
/// # Errors
/// The embedder fails or disagrees with the map's features.
pub fn similarity_gates_relative(
    scene: &MapView,
    embedder: &mut dyn Embedder,
    phrases: &[&str],
    allowed: impl Fn(&SceneObject) -> bool,
    plateau: f64,
    falloff: f64,
    best: Option<f64>,
) -> Result<(Vec<Option<f64>>, f64)> {
    let sims = colour_checked_similarities(scene, embedder, phrases, allowed)?;
    let own = sims
        .iter()
        .flatten()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let best = best.unwrap_or(own);
    let gates = sims
        .into_iter()
        // the raw cosine orders candidates that the gate leaves tied
        .map(|s| {
            s.map(|s| gate(s, best, plateau, falloff) * (0.9 + 0.1 * (s / best).clamp(0.0, 1.0)))
        })
        .collect();
    Ok((gates, own))
}

/// Indices of the `n` best, best first (ties by index), and the best value.
fn top(sims: &[Option<f64>], n: usize) -> (Vec<usize>, f64) {
    let mut idx: Vec<usize> = (0..sims.len()).filter(|i| sims[*i].is_some()).collect();
    idx.sort_by(|a, b| {
        sims[*b]
            .unwrap_or(f64::NEG_INFINITY)
            .total_cmp(&sims[*a].unwrap_or(f64::NEG_INFINITY))
            .then(a.cmp(b))
    });
    idx.truncate(n);
    let best = idx.first().and_then(|i| sims[*i]).unwrap_or(1.0);
    (idx, best)
}

/// Whether a cosine counts as a match, relative to the best candidate's: 1 within
/// `plateau` of the best (paraphrases of the same thing score alike), falling linearly to 0
/// over the next `falloff`, so that weak matches add nothing.
fn gate(s: f64, best: f64, plateau: f64, falloff: f64) -> f64 {
    ((s - (best - plateau - falloff)) / falloff).clamp(0.0, 1.0)
}

/// Whether `caption` has `word` as a whole word (case-insensitive).
fn has_word(caption: &str, word: &str) -> bool {
    let c = caption.to_lowercase();
    c.split(|ch: char| !ch.is_alphanumeric() && ch != '-')
        .any(|w| w == word || w.split('-').any(|p| p == word))
}

/// Words a caption places its object with ("… on the sidewalk", "… next to a bus stop").
const PLACE_WORDS: &[&str] = &[
    "on", "atop", "over", "above", "next", "near", "by", "beside", "at", "along", "against",
    "behind", "in", "inside", "within", "under", "beneath", "below", "opposite", "across",
    "facing",
];

/// The place words of a caption that face its anchor (opposite and across the road from).
const FACING_WORDS: [&str; 3] = ["opposite", "across", "facing"];

/// Words of an anchor phrase that name nothing.
const ARTICLES: &[&str] = &["a", "an", "the", "this", "that", "some", "one", "its"];

/// Whether `caption` itself places its object by the anchor `phrase` under `rel`: its first
/// place word ("on", "next", "near", …) agrees with the relation (on: on, atop, over, above;
/// under: under, beneath, below; inside: in, inside, within; opposite and across the road
/// from: opposite, across, facing; the rest: any but those three) and every word of the phrase but its
/// article follows it. "a small yellow metal post box on a short post" places itself on "a
/// short post"; "a brown bench, long, facing the street" places itself by nothing.
pub fn caption_places_by(caption: &str, rel: Relation, phrase: &str) -> bool {
    let cap = words(caption);
    let Some(at) = cap.iter().position(|w| PLACE_WORDS.contains(&w.as_str())) else {
        return false;
    };
    let place = cap[at].as_str();
    let agrees = match rel {
        Relation::On => ["on", "atop", "over", "above"].contains(&place),
        Relation::Under => ["under", "beneath", "below"].contains(&place),
        Relation::Inside => ["in", "inside", "within"].contains(&place),
        Relation::Opposite | Relation::AcrossTheRoadFrom => FACING_WORDS.contains(&place),
        _ => !FACING_WORDS.contains(&place),
    };
    let content: Vec<String> = words(phrase)
        .into_iter()
        .filter(|w| !ARTICLES.contains(&w.as_str()))
        .collect();
    agrees && !content.is_empty() && content.iter().all(|w| cap[at + 1..].contains(w))
}

/// The candidate cosines one part of a map (a region shard) holds for a request, best first:
/// the first pass of a find fanned out over shards. [`FindCuts::merge`] of every shard's
/// gives the [`FindNorms`] that make each shard score as the union of them would.
#[derive(
    Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct FindCuts {
    /// How many target candidates a map takes.
    pub target_n: usize,
    /// The target's candidate cosines, best first (at most `target_n`).
    pub target: Vec<f64>,
    /// How many candidates per anchor a map takes.
    pub anchor_n: usize,
    /// Per anchor of the request, its candidate cosines (colour-checked), best first.
    pub anchors: Vec<Vec<f64>>,
}

/// The best candidate cosine, which gates are relative to, and the lowest one that is still
/// a candidate.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct Cut {
    /// The best cosine.
    pub best: f64,
    /// The last candidate's cosine (lower ones are not candidates).
    pub last: f64,
}

/// What the whole map's candidates are, for scoring one part of it ([`FindCuts::merge`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub struct FindNorms {
    /// The target's cut; None when no part holds a candidate.
    pub target: Option<Cut>,
    /// Each anchor's cut, in the request's order.
    pub anchors: Vec<Option<Cut>>,
}

fn merged_cut(lists: &[&[f64]], n: usize) -> Option<Cut> {
    let mut all: Vec<f64> = lists.iter().flat_map(|l| l.iter().copied()).collect();
    all.sort_by(|a, b| b.total_cmp(a));
    all.truncate(n);
    Some(Cut {
        best: *all.first()?,
        last: *all.last()?,
    })
}

impl FindCuts {
    /// The norms of the union of the parts whose cuts are `parts`: the best and the n-th
    /// best cosine over all of them.
    pub fn merge(parts: &[FindCuts]) -> FindNorms {
        let target_n = parts.iter().map(|p| p.target_n).max().unwrap_or(0);
        let anchor_n = parts.iter().map(|p| p.anchor_n).max().unwrap_or(0);
        let lists: Vec<&[f64]> = parts.iter().map(|p| p.target.as_slice()).collect();
        let n_anchors = parts.iter().map(|p| p.anchors.len()).max().unwrap_or(0);
        FindNorms {
            target: merged_cut(&lists, target_n),
            anchors: (0..n_anchors)
                .map(|a| {
                    let lists: Vec<&[f64]> = parts
                        .iter()
                        .filter_map(|p| p.anchors.get(a).map(Vec::as_slice))
                        .collect();
                    merged_cut(&lists, anchor_n)
                })
                .collect(),
        }
    }
}

/// The candidates of `sims` under `cut` (best first, ties by index) and the best they are
/// gated against; without a cut, the `n` best of this map ([`top`]). Also this map's own `n`
/// best cosines, best first (its part of [`FindCuts`]), from the same ranking.
fn candidates(
    sims: &[Option<f64>],
    n: usize,
    cut: Option<Option<Cut>>,
) -> (Vec<usize>, f64, Vec<f64>) {
    let (own, own_best) = top(sims, n);
    let cosines = own.iter().filter_map(|&i| sims[i]).collect();
    let (idx, best) = match cut {
        None => (own, own_best),
        Some(None) => (Vec::new(), 1.0),
        Some(Some(c)) => {
            let (mut idx, _) = top(sims, sims.len());
            idx.retain(|&i| sims[i].is_some_and(|s| s >= c.last));
            (idx, c.best)
        }
    };
    (idx, best, cosines)
}

/// Answers `req` over `scene` (see the module docs). `r` is read for `RELATED` edges.
///
/// # Errors
/// The request names no target, the embedder fails or disagrees with the map's features.
pub fn find_graph(
    r: &impl GraphRead,
    scene: &MapView,
    embedder: &mut dyn Embedder,
    req: &Request,
    opts: &GraphFindOptions,
) -> Result<Vec<GraphFound>> {
    Ok(find_graph_normed(r, scene, embedder, req, opts, None)?.0)
}

/// [`find_graph`] over one part of a map (a region shard): with `norms` from
/// [`FindCuts::merge`] the candidates and gates are the whole map's, so each result scores as
/// it would in the union (support from an anchor in another part is not seen). Returns the
/// results and this part's [`FindCuts`] (the first pass: call it without norms).
///
/// # Errors
/// As [`find_graph`].
pub fn find_graph_normed(
    r: &impl GraphRead,
    scene: &MapView,
    embedder: &mut dyn Embedder,
    req: &Request,
    opts: &GraphFindOptions,
    norms: Option<&FindNorms>,
) -> Result<(Vec<GraphFound>, FindCuts)> {
    let target_phrases: Vec<&str> = if req.objects.is_empty() {
        vec![req.target.as_str()]
    } else {
        req.objects.iter().map(String::as_str).collect()
    };
    if target_phrases.iter().all(|p| p.trim().is_empty()) {
        return Err(Error::Invalid("the request names no target".into()));
    }
    // a surface is an answer only when what is looked for names one
    let wants_surface = target_phrases.iter().all(|p| names_surface(&[], p));
    let ground = scene.ground;
    let t_sims = similarities(scene, embedder, &target_phrases, |o| {
        o.surface == wants_surface
            && opts.class.as_ref().is_none_or(|c| *c == o.semantic_class)
            && opts.near.is_none_or(|(g, radius_m)| {
                let p = ground.ground(o.centroid);
                (p[0] - g[0]).hypot(p[1] - g[1]) <= radius_m
            })
    })?;
    let target_n = opts.target_candidates.max(opts.k);
    let (targets, t_best, own_target) = candidates(&t_sims, target_n, norms.map(|n| n.target));
    let mut cuts = FindCuts {
        target_n,
        target: own_target,
        anchor_n: opts.anchor_candidates,
        anchors: Vec::new(),
    };
    // anchors: candidates and similarities
    let mut anchors: Vec<(Vec<usize>, Vec<Option<f64>>, f64)> = Vec::new();
    for (ai, a) in req.anchors.iter().enumerate() {
        let surface = names_surface(&[], &a.phrase);
        let sims = colour_checked_similarities(scene, embedder, &[a.phrase.as_str()], |o| {
            o.surface == surface
        })?;
        let cut = norms.map(|n| n.anchors.get(ai).copied().flatten());
        let (idx, best, own) = candidates(&sims, opts.anchor_candidates, cut);
        cuts.anchors.push(own);
        anchors.push((idx, sims, best));
    }
    let related = r.rel_type(scene::rel::RELATED);
    let k_relation = r.prop_key(scene::key::RELATION);
    let k_source = r.prop_key(scene::key::SOURCE);
    // the segments of the asked kind with the bounds of what their distance measures from
    // (a lower bound of it: the nearest is found without measuring the far ones)
    let asked_segments: Vec<&scene::view::SegmentInfo> = match req.segment {
        Some(c) => scene
            .segments
            .iter()
            .filter(|s| c.admits(&s.kind))
            .collect(),
        None => Vec::new(),
    };
    let asked_bounds: Vec<[[f64; 2]; 2]> = asked_segments
        .iter()
        .map(|s| scene::area::membership_bounds(&s.area, s.drivable.as_ref()))
        .collect();
    let mut out = Vec::with_capacity(targets.len());
    for &ti in &targets {
        let t = &scene.objects[ti];
        // attributes said of the target ("a green bin") that the caption also says
        let said = req
            .attributes
            .iter()
            .filter(|a| has_word(&t.caption, a))
            .count();
        let attr = if req.attributes.is_empty() {
            1.0
        } else {
            1.0 + opts.attribute_weight * said as f64 / req.attributes.len() as f64
        };
        let cos_t = t_sims[ti].unwrap_or(0.0);
        let s_t = gate(cos_t, t_best, opts.target_plateau, opts.target_falloff) * attr;
        // RELATED edges of this target, by the other end: the first relationship to it (in
        // `neighbours` order) that the geometry made; only its `source` is read here, and its
        // label only for the evidence
        let str_prop = |rel: u64, k: Option<graphstore::PropKey>| -> Result<String> {
            Ok(match k {
                Some(k) => r
                    .rel_prop(rel, k)?
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_default(),
                None => String::new(),
            })
        };
        let mut edges: HashMap<u64, u64> = HashMap::new();
        if !req.anchors.is_empty()
            && let Some(ty) = related
        {
            for adj in r.neighbours(t.id, Direction::Both, Some(ty))? {
                if edges.contains_key(&adj.other) {
                    continue;
                }
                // only the map's geometric relations count: the LLM relation labels
                // (`opengraph relations --experimental`) agree with the simulator's truth
                // less often than the geometry (docs/llm.md)
                if str_prop(adj.rel, k_source)? == "llm" {
                    continue;
                }
                edges.insert(adj.other, adj.rel);
            }
        }
        let related_label = |other: u64| -> Result<Option<String>> {
            match edges.get(&other) {
                Some(&rel) => Ok(Some(format!(
                    "{} ({})",
                    str_prop(rel, k_relation)?,
                    str_prop(rel, k_source)?
                ))),
                None => Ok(None),
            }
        };
        let mut evidence = Vec::new();
        let mut support = 0.0;
        for (a, (idx, sims, best)) in req.anchors.iter().zip(&anchors) {
            // the target's own caption places it by the anchor: full support, itself the evidence
            if a.distance_m.is_none() && caption_places_by(&t.caption, a.relation, &a.phrase) {
                support += 1.0;
                evidence.push(Evidence {
                    anchor: a.phrase.clone(),
                    relation: a.relation.as_str().into(),
                    anchor_id: t.id,
                    anchor_caption: t.caption.clone(),
                    distance_m: 0.0,
                    similarity: 1.0,
                    fit: 1.0,
                    related: Some("said by its own caption".into()),
                });
                continue;
            }
            let gates = idx.iter().filter(|&&bi| bi != ti).map(|&bi| {
                let s_b = gate(
                    sims[bi].unwrap_or(0.0),
                    *best,
                    opts.anchor_plateau,
                    opts.anchor_falloff,
                );
                (bi, s_b)
            });
            let pick = best_anchor(gates, |bi| {
                let b = &scene.objects[bi];
                let fit = relation_fit(a.relation, a.distance_m, t, b);
                if edges.contains_key(&b.id) {
                    // the map already relates them: at least "near"
                    fit.max(0.8)
                } else {
                    fit
                }
            });
            if let Some((v, bi, s_b, fit)) = pick {
                support += v;
                let b = &scene.objects[bi];
                evidence.push(Evidence {
                    anchor: a.phrase.clone(),
                    relation: a.relation.as_str().into(),
                    anchor_id: b.id,
                    anchor_caption: b.caption.clone(),
                    distance_m: (MapView::gap_m(t, b) * 100.0).round() / 100.0,
                    similarity: s_b,
                    fit,
                    related: related_label(b.id)?,
                });
            }
        }
        let mean_support = if req.anchors.is_empty() {
            0.0
        } else {
            support / req.anchors.len() as f64
        };
        let segment_match = req
            .segment
            .map(|c| t.segment.as_ref().is_some_and(|(_, kind)| c.admits(kind)));
        // outside a segment of the asked kind: how far from the nearest one
        let seg = match (req.segment, segment_match) {
            (Some(_), Some(false)) => {
                let p = scene.ground.ground(t.centroid);
                let d = nearest_distance(&asked_segments, &asked_bounds, p);
                let near = if d <= 10.0 {
                    1.0
                } else {
                    (-(d - 10.0) / 10.0).exp()
                };
                opts.segment_miss + (1.0 - opts.segment_miss) * near
            }
            _ => 1.0,
        };
        out.push(GraphFound {
            id: t.id,
            label: t.label.clone(),
            caption: t.caption.clone(),
            semantic_class: t.semantic_class.clone(),
            // the raw cosine orders results the gate and support leave tied
            score: s_t * (1.0 + mean_support) * seg + opts.cosine_weight * cos_t / t_best.max(1e-9),
            similarity: s_t,
            cosine: (cos_t * 1000.0).round() / 1000.0,
            centroid: t.centroid,
            segment: t.segment.clone(),
            segment_match,
            evidence,
            place_distance_m: None,
        });
    }
    out.sort_by(|a, b| b.score.total_cmp(&a.score).then(a.id.cmp(&b.id)));
    out.truncate(opts.k);
    Ok((out, cuts))
}

/// The anchor candidate of greatest value `gate · fit`, the first of equals: `(value, object
/// index, gate, fit)`. `gates` are `(object index, gate)` by gate, greatest first (the
/// candidates by cosine, and the gate does not fall as the cosine rises), each gate in [0, 1];
/// `fit` gives a fit in [0, 1] ([`relation_fit`]). A value is at most its gate, so once the
/// gates are no greater than the best value no later candidate can pass it: the rest are not
/// measured, and the pick is the one of measuring them all.
fn best_anchor(
    gates: impl Iterator<Item = (usize, f64)>,
    mut fit: impl FnMut(usize) -> f64,
) -> Option<(f64, usize, f64, f64)> {
    let mut pick: Option<(f64, usize, f64, f64)> = None;
    for (bi, s_b) in gates {
        if pick.is_some_and(|p| s_b <= p.0) {
            break;
        }
        let f = fit(bi);
        let v = s_b * f;
        if pick.is_none_or(|p| v > p.0) {
            pick = Some((v, bi, s_b, f));
        }
    }
    pick
}

/// The least [`scene::view::SegmentInfo::distance`] from `p` to `segments`, metres (infinite
/// when there are none, or every distance is NaN, as a fold of `f64::min` gives), measured
/// nearest `bounds` first ([`scene::area::nearest_by_bounds`]; each segment's
/// [`scene::area::membership_bounds`]): the same minimum as measuring every segment.
fn nearest_distance(
    segments: &[&scene::view::SegmentInfo],
    bounds: &[[[f64; 2]; 2]],
    p: [f64; 2],
) -> f64 {
    scene::area::nearest_by_bounds(bounds, p, |i| segments[i].distance(p))
        .map(|(_, d)| d)
        .filter(|d| !d.is_nan())
        .unwrap_or(f64::INFINITY)
}

/// The JSON Schema of a re-ranking answer: up to three candidate numbers, best first.
pub fn rerank_schema(n: usize) -> serde_json::Value {
    serde_json::json!({"type": "object",
        "properties": {"best": {"type": "array", "maxItems": 3, "minItems": 1,
            "items": {"type": "integer", "minimum": 1, "maximum": n.max(1)}}},
        "required": ["best"], "additionalProperties": false})
}

/// OpenGraph-LLM re-ranking: the model sees the request and the first `n` results
/// (captions, classes, segments, evidence) and picks the best three; they move to the front
/// in its order, the rest keep theirs. Returns the new order and the model id.
///
/// # Errors
/// The model fails or answers numbers outside the list.
pub fn rerank_llm(
    model: &mut dyn ChatModel,
    request_text: &str,
    results: Vec<GraphFound>,
    n: usize,
) -> Result<(Vec<GraphFound>, String)> {
    let n = n.min(results.len());
    if n < 2 {
        return Ok((results, model.model_id()));
    }
    let mut listing = String::new();
    for (i, g) in results.iter().take(n).enumerate() {
        let seg = g
            .segment
            .as_ref()
            .map_or("no segment".to_string(), |(_, k)| k.replace('_', " "));
        let ev: Vec<String> = g
            .evidence
            .iter()
            .map(|e| {
                format!(
                    "{} '{}' found {:.1} m away: {}",
                    e.relation.replace('_', " "),
                    e.anchor,
                    e.distance_m,
                    e.anchor_caption
                )
            })
            .collect();
        listing.push_str(&format!(
            "{}. {}: {} (class {}, {}){}\n",
            i + 1,
            g.label,
            g.caption,
            g.semantic_class,
            seg,
            if ev.is_empty() {
                String::new()
            } else {
                format!("; {}", ev.join("; "))
            }
        ));
    }
    let req = ChatRequest::new(vec![
        Message::system(crate::prompts::RERANK.text),
        Message::user(format!("Request: {request_text}\nCandidates:\n{listing}")),
    ])
    .with_schema(rerank_schema(n))
    .with_max_tokens(40);
    let answer = model.chat(&req)?;
    let v = answer
        .json
        .ok_or_else(|| Error::LlmAnswer("no structured answer".into()))?;
    let picks: Vec<usize> = v["best"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(serde_json::Value::as_u64)
                .map(|x| x as usize)
                .collect()
        })
        .unwrap_or_default();
    if picks.is_empty() || picks.iter().any(|p| *p == 0 || *p > n) {
        return Err(Error::LlmAnswer(format!(
            "re-ranking picked {picks:?}, not numbers in 1..={n}"
        )));
    }
    let mut order: Vec<usize> = Vec::new();
    for p in picks {
        if !order.contains(&(p - 1)) {
            order.push(p - 1);
        }
    }
    for i in 0..results.len() {
        if !order.contains(&i) {
            order.push(i);
        }
    }
    let mut slots: Vec<Option<GraphFound>> = results.into_iter().map(Some).collect();
    let out = order.into_iter().filter_map(|i| slots[i].take()).collect();
    Ok((out, answer.model))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_caption_places_its_object_only_by_what_follows_its_place_word() {
        let post_box = "a small yellow metal post box on a short post";
        assert!(caption_places_by(post_box, Relation::On, "a short post"));
        assert!(caption_places_by(
            post_box,
            Relation::Near,
            "the short post"
        ));
        // "post" is in the subject too, but "short" is not after "on" there
        assert!(!caption_places_by(post_box, Relation::On, "a short box"));
        assert!(!caption_places_by(post_box, Relation::On, "the sidewalk"));
        // the place word must agree with the relation
        assert!(!caption_places_by(
            post_box,
            Relation::Under,
            "a short post"
        ));
        assert!(!caption_places_by(
            post_box,
            Relation::Opposite,
            "a short post"
        ));
        let mailbox = "a small yellow metal mailbox on the sidewalk";
        assert!(caption_places_by(mailbox, Relation::On, "the sidewalk"));
        assert!(caption_places_by(
            "a grey bench next to the bus stop",
            Relation::NextTo,
            "a bus stop"
        ));
        assert!(caption_places_by(
            "a lamp across the road from the bus stop",
            Relation::AcrossTheRoadFrom,
            "the bus stop"
        ));
        // no place word, or a phrase of articles only
        assert!(!caption_places_by(
            "a brown bench, long, facing the street",
            Relation::Near,
            "the street"
        ));
        assert!(!caption_places_by(mailbox, Relation::On, "the"));
        // "facing the traffic" is how the sign stands, said by its caption
        assert!(caption_places_by(
            "a round red and white metal speed limit sign facing the traffic",
            Relation::Opposite,
            "the traffic"
        ));
    }

    #[test]
    fn merged_cuts_are_the_best_and_the_nth_best_of_every_part() {
        let a = FindCuts {
            target_n: 3,
            target: vec![0.9, 0.5, 0.1],
            anchor_n: 2,
            anchors: vec![vec![0.4, 0.3], vec![]],
        };
        let b = FindCuts {
            target_n: 3,
            target: vec![0.7, 0.6],
            anchor_n: 2,
            anchors: vec![vec![0.8], vec![]],
        };
        let n = FindCuts::merge(&[a, b]);
        assert_eq!(
            n.target,
            Some(Cut {
                best: 0.9,
                last: 0.6
            })
        );
        assert_eq!(
            n.anchors,
            vec![
                Some(Cut {
                    best: 0.8,
                    last: 0.4
                }),
                None
            ]
        );
        // under a cut, the candidates are those at or over it, best first
        let sims = [Some(0.2), None, Some(0.9), Some(0.6), Some(0.6)];
        let (idx, best, own) = candidates(
            &sims,
            1,
            Some(Some(Cut {
                best: 0.95,
                last: 0.6,
            })),
        );
        assert_eq!((idx, best, own), (vec![2, 3, 4], 0.95, vec![0.9]));
        assert_eq!(candidates(&sims, 2, None).0, vec![2, 3]);
        assert!(candidates(&sims, 2, Some(None)).0.is_empty());
    }

    fn obj(id: u64, lo: [f64; 2], hi: [f64; 2], h: (f64, f64)) -> SceneObject {
        SceneObject {
            id,
            semantic_class: "x".into(),
            label: String::new(),
            caption: String::new(),
            centroid: [0.0; 3],
            ground_min: lo,
            ground_max: hi,
            heights: h,
            feature: vec![1.0],
            feature_sq_norm: 1.0,
            surface: false,
            segment: None,
        }
    }

    #[test]
    fn best_anchor_equals_measuring_all() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for round in 0..400 {
            let n = round % 40;
            // gates by the plateau and fall-off: runs of 1, a slope, then zeros
            let mut gates: Vec<f64> = (0..n)
                .map(|_| match rng.random_range(0..4) {
                    0 => 1.0,
                    1 => 0.0,
                    _ => rng.random_range(0.0..1.0),
                })
                .collect();
            gates.sort_by(|a, b| b.total_cmp(a));
            let fits: Vec<f64> = (0..n)
                .map(|_| match rng.random_range(0..3) {
                    0 => 1.0,
                    1 => 0.8,
                    _ => rng.random_range(0.0..1.0f64).powi(3),
                })
                .collect();
            let all = {
                let mut pick: Option<(f64, usize, f64, f64)> = None;
                for (bi, &s_b) in gates.iter().enumerate() {
                    let v = s_b * fits[bi];
                    if pick.is_none_or(|p| v > p.0) {
                        pick = Some((v, bi, s_b, fits[bi]));
                    }
                }
                pick
            };
            let mut measured = 0;
            let got = best_anchor(gates.iter().copied().enumerate(), |bi| {
                measured += 1;
                fits[bi]
            });
            assert_eq!(got, all, "round {round}: {gates:?} {fits:?}");
            assert!(measured <= n);
        }
    }

    #[test]
    fn nearest_segment_distance_equals_measuring_all() {
        use rand::{RngExt, SeedableRng};
        use scene::area::{Drivable, SegmentArea};
        use scene::view::SegmentInfo;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut r = |lo: f64, hi: f64| rng.random_range(lo..hi);
        for round in 0..50 {
            let segments: Vec<SegmentInfo> = (0..(round % 12))
                .map(|i| {
                    let c = [r(-200.0, 200.0), r(-200.0, 200.0)];
                    let area = if i % 2 == 0 {
                        SegmentArea::Disc {
                            centre: c,
                            radius_m: r(2.0, 20.0),
                        }
                    } else {
                        SegmentArea::Corridor {
                            centreline: vec![c, [c[0] + r(-60.0, 60.0), c[1] + r(-60.0, 60.0)]],
                            half_width_m: r(1.0, 6.0),
                        }
                    };
                    // a third with a drivable polygon (a triangle), which the distance prefers
                    let drivable = (i % 3 == 0).then(|| Drivable {
                        rings: vec![vec![
                            c,
                            [c[0] + r(5.0, 30.0), c[1]],
                            [c[0], c[1] + r(5.0, 30.0)],
                        ]],
                    });
                    SegmentInfo {
                        id: i as u64,
                        kind: "t_intersection".into(),
                        centroid: c,
                        area,
                        drivable,
                    }
                })
                .collect();
            let refs: Vec<&SegmentInfo> = segments.iter().collect();
            let bounds: Vec<[[f64; 2]; 2]> = segments
                .iter()
                .map(|s| scene::area::membership_bounds(&s.area, s.drivable.as_ref()))
                .collect();
            for _ in 0..40 {
                let p = [r(-260.0, 260.0), r(-260.0, 260.0)];
                let all = segments
                    .iter()
                    .map(|s| s.distance(p))
                    .fold(f64::INFINITY, f64::min);
                let got = nearest_distance(&refs, &bounds, p);
                assert_eq!(got.to_bits(), all.to_bits(), "round {round}, {p:?}");
            }
        }
    }

    #[test]
    fn relation_fits_follow_the_geometry() {
        let shelter = obj(1, [0.0, 0.0], [4.0, 2.0], (0.0, 2.5));
        let bench_in = obj(2, [1.0, 0.5], [2.0, 1.0], (0.0, 0.5));
        let bench_near = obj(3, [5.0, 0.0], [6.0, 1.0], (0.0, 0.5));
        let bench_far = obj(4, [30.0, 0.0], [31.0, 1.0], (0.0, 0.5));
        let eps = 1e-9;
        assert!((MapView::gap_m(&bench_near, &shelter) - 1.0).abs() < eps);
        assert!((relation_fit(Relation::Near, None, &bench_near, &shelter) - 1.0).abs() < 1e-12);
        assert!(relation_fit(Relation::Near, None, &bench_far, &shelter) < 0.01);
        assert!((relation_fit(Relation::NextTo, None, &bench_near, &shelter) - 1.0).abs() < 1e-12);
        assert!((relation_fit(Relation::Inside, None, &bench_in, &shelter) - 1.0).abs() < 1e-12);
        assert!(relation_fit(Relation::Inside, None, &bench_near, &shelter) < 0.5);
        // an explicit distance overrides the relation's own
        assert!(
            (relation_fit(Relation::Near, Some(30.0), &bench_far, &shelter) - 1.0).abs() < 1e-12
        );
        // a sign above a bush: the bush is under the sign, the sign on top of the bush
        let bush = obj(5, [10.0, 10.0], [11.0, 11.0], (0.0, 1.0));
        let sign = obj(6, [10.2, 10.2], [10.8, 10.8], (1.5, 2.5));
        assert!((relation_fit(Relation::Under, None, &bush, &sign) - 1.0).abs() < 1e-12);
        assert!((relation_fit(Relation::On, None, &sign, &bush) - 1.0).abs() < 1e-12);
        assert!((relation_fit(Relation::On, None, &bush, &sign) - 0.5).abs() < 1e-12);
        // across the road: 4-25 m
        assert!(
            (relation_fit(Relation::AcrossTheRoadFrom, None, &bench_far, &bench_near) - 1.0).abs()
                < 1e-12
        );
        assert!(relation_fit(Relation::Opposite, None, &bench_near, &shelter) < 1.0);
    }

    #[test]
    fn rerank_schema_bounds_the_numbers() {
        let s = rerank_schema(5);
        assert!(crate::chat::validate(&serde_json::json!({"best": [2, 1]}), &s).is_ok());
        assert!(crate::chat::validate(&serde_json::json!({"best": [6]}), &s).is_err());
        assert!(crate::chat::validate(&serde_json::json!({"best": []}), &s).is_err());
    }
}
