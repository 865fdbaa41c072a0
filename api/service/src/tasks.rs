//! Task tools: the questions a robot operator asks of a map, each answered with how it was
//! measured. `nearest_objects` (the objects of a kind nearest a place), `count_objects` (the
//! objects of a kind in a segment, a circle or the whole map), `measure_distance` (between two
//! places) and `neighbours` (what stands around an object).
//!
//! A **kind** is matched against the objects' labels ([`llm_tools::kinds`]: same, a kind of
//! it, a part of it, or similar), and every answer lists the labels it took and how. A
//! **place** is words or a spec, resolved as `plan_route` resolves its ends
//! ([`crate::plan::resolve_end`]): a spec, the start or end of the drive, a road segment by
//! `locate`, or an object by `find`. Distances are on the ground plane (the map's two
//! horizontal axes; height ignored), metres.

use std::collections::BTreeMap;

use graphstore::{Direction, GraphRead, Value};
use llm_tools::kinds::{KindMatch, Kinds, SIMILAR_MIN_COSINE, kind_phrase, wordnet};
use llm_tools::labels::noun_phrase;
use planner::{Spec, Target};
use scene::view::{MapView, SceneObject};
use serde::Serialize;

use crate::error::{ToolError, ToolResult, failed};
use crate::find::{FindAnswer, FindRequest, Finder, ParserKind, Ranking};
use crate::ops::{
    CountObjectsRequest, DistanceRequest, Measure, NearestObjectsRequest, NeighboursRequest,
    SegmentRef,
};
use crate::plan::{Resolved, resolve_end};
use crate::toolbox::Toolbox;

/// What [`Measure::Centroid`] measures.
pub const CENTROID_MEASURE: &str = "ground-plane distance between centroids (height ignored), metres; a segment's centroid, a lane node's position, a point as given";
/// What [`Measure::BoxGap`] measures.
pub const BOX_GAP_MEASURE: &str = "ground-plane gap between footprints (0 when they overlap), metres: box to box for an object, box to the segment's area for a segment, box to the point otherwise";
/// The default radius of `count_objects` around `near`, metres.
pub const DEFAULT_RADIUS_M: f64 = 20.0;

/// A place as resolved.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Place {
    /// How the words or spec were resolved.
    pub resolved: Resolved,
    /// The node it names (if any) and its ground-plane position.
    pub target: Target,
}

/// One label the kind took, and how.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct LabelMatch {
    /// The objects' label.
    pub label: String,
    /// How it matches the kind.
    pub how: KindMatch,
    /// How many objects of the map have it.
    pub objects: u64,
}

/// The kind as understood.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct KindAnswer {
    /// As asked.
    pub asked: String,
    /// As a singular phrase.
    pub phrase: String,
    /// The labels it took, most objects first.
    pub labels: Vec<LabelMatch>,
    /// Whether WordNet was there to match synonyms, kinds and parts (else phrases only).
    pub wordnet: bool,
}

/// One object with its distance.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ObjectAt {
    /// The Instance node id.
    pub id: u64,
    /// Its label.
    pub label: String,
    /// How its label matches the kind (None where no kind was asked).
    pub how: Option<KindMatch>,
    /// Its caption.
    pub caption: String,
    /// Its SemanticKITTI class (`Instance.semantic_class`).
    pub semantic_class: String,
    /// Its centroid on the ground plane, metres.
    pub ground_xy: [f64; 2],
    /// The distance the answer's `measure` says, metres.
    pub distance_m: f64,
    /// Its segment (`IN_SEGMENT`: the nearest segment).
    pub segment: Option<SegmentRef>,
}

/// The answer of `nearest_objects`.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct NearestAnswer {
    /// The kind.
    pub kind: KindAnswer,
    /// The place.
    pub near: Place,
    /// How distances were measured.
    pub measure: String,
    /// The objects, nearest first (ties: lower id).
    pub results: Vec<ObjectAt>,
}

/// The area `count_objects` counted in.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
#[serde(tag = "by", rename_all = "snake_case")]
pub enum CountArea {
    /// The whole map.
    Map,
    /// The objects whose `IN_SEGMENT` is this segment (each object belongs to its nearest
    /// segment; `distance_m` says how far outside the segment's area it lies, 0 inside).
    Segment {
        /// The place.
        place: Box<Place>,
        /// The Segment node id.
        segment_id: u64,
    },
    /// The objects whose centroid lies within `radius_m` of the place (centroid distance).
    Circle {
        /// The place.
        place: Box<Place>,
        /// The radius, metres.
        radius_m: f64,
    },
}

/// The answer of `count_objects`.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct CountAnswer {
    /// The kind.
    pub kind: KindAnswer,
    /// Where it counted.
    pub area: CountArea,
    /// How many objects.
    pub count: u64,
    /// How many of them by how they match the kind (`same`, `kind_of`, `part_of`, `similar`).
    pub by_match: BTreeMap<String, u64>,
    /// What `distance_m` of a listed object is.
    pub measure: String,
    /// The first `list` of them, nearest first (by id for the whole map).
    pub objects: Vec<ObjectAt>,
}

/// The answer of `measure_distance`.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct DistanceAnswer {
    /// One place.
    pub from: Place,
    /// The other.
    pub to: Place,
    /// The distance, metres.
    pub distance_m: f64,
    /// How it was measured.
    pub measure: String,
}

/// One neighbour of an object.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Neighbour {
    /// The Instance node id.
    pub id: u64,
    /// Its label.
    pub label: String,
    /// Its caption.
    pub caption: String,
    /// Ground-plane gap between the footprints, metres (0 when they overlap).
    pub gap_m: f64,
    /// Ground-plane distance between the centroids, metres.
    pub centroid_distance_m: f64,
    /// The geometric `RELATED` relation between them (`next_to`, `on`, ...), if the map
    /// stores one.
    pub relation: Option<String>,
}

/// The answer of `neighbours`.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct NeighboursAnswer {
    /// The object.
    pub id: u64,
    /// Its label.
    pub label: String,
    /// Its caption.
    pub caption: String,
    /// The objects whose footprint gap is within the radius, nearest first.
    pub neighbours: Vec<Neighbour>,
}

/// An object's label: `Instance.label`, else the noun phrase of its caption.
fn label_of(o: &SceneObject) -> String {
    if o.label.is_empty() {
        noun_phrase(&o.caption, &wordnet().0)
    } else {
        o.label.clone()
    }
}

fn ground_dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Ground-plane distance from a point to a footprint (0 inside).
fn point_box_gap(p: [f64; 2], o: &SceneObject) -> f64 {
    let dx = (o.ground_min[0] - p[0])
        .max(p[0] - o.ground_max[0])
        .max(0.0);
    let dz = (o.ground_min[1] - p[1])
        .max(p[1] - o.ground_max[1])
        .max(0.0);
    dx.hypot(dz)
}

/// A resolved place with what distances to it need.
struct At {
    place: Place,
    /// The object it names, when it names one.
    object: Option<SceneObject>,
    /// The segment it names, when it names one.
    segment: Option<scene::view::SegmentInfo>,
}

impl At {
    fn xy(&self) -> [f64; 2] {
        self.place.target.xy
    }

    /// The distance from this place to `o` by `m`.
    fn distance(&self, view: &MapView, o: &SceneObject, m: Measure) -> f64 {
        let c = view.ground.ground(o.centroid);
        match m {
            Measure::Centroid => ground_dist(self.xy(), c),
            Measure::BoxGap => match (&self.object, &self.segment) {
                (Some(a), _) => MapView::gap_m(a, o),
                (None, Some(s)) => {
                    // the footprint's nearest point to the area: its corners and centroid
                    let corners = [
                        o.ground_min,
                        o.ground_max,
                        [o.ground_min[0], o.ground_max[1]],
                        [o.ground_max[0], o.ground_min[1]],
                        c,
                    ];
                    corners
                        .iter()
                        .map(|p| s.distance(*p))
                        .fold(f64::INFINITY, f64::min)
                }
                (None, None) => point_box_gap(self.xy(), o),
            },
        }
    }
}

fn measure_text(m: Measure) -> String {
    match m {
        Measure::Centroid => CENTROID_MEASURE,
        Measure::BoxGap => BOX_GAP_MEASURE,
    }
    .to_string()
}

fn segment_ref(o: &SceneObject) -> Option<SegmentRef> {
    o.segment.as_ref().map(|(id, kind)| SegmentRef {
        id: *id,
        kind: Some(kind.clone()),
    })
}

fn object_at(view: &MapView, o: &SceneObject, how: Option<KindMatch>, d: f64) -> ObjectAt {
    ObjectAt {
        id: o.id,
        label: label_of(o),
        how,
        caption: o.caption.clone(),
        semantic_class: o.semantic_class.clone(),
        ground_xy: view.ground.ground(o.centroid),
        distance_m: d,
        segment: segment_ref(o),
    }
}

/// Resolves a place in words or as a spec.
fn place(finder: &mut Finder, r: &impl GraphRead, view: &MapView, text: &str) -> ToolResult<At> {
    let bad = |e: &dyn std::fmt::Display| ToolError::BadArguments(e.to_string());
    let (spec, resolved) =
        resolve_end(finder, r, text, ParserKind::Rules).map_err(|e| match e {
            llm_tools::Error::Invalid(m) => ToolError::BadArguments(m),
            other => ToolError::Failed(other.to_string()),
        })?;
    let target = planner::route::target(r, view.ground, &spec).map_err(|e| bad(&e))?;
    let node = match spec {
        Spec::Point(_) => None,
        _ => target.node,
    };
    let object = node.and_then(|n| view.objects.iter().find(|o| o.id == n).cloned());
    let segment = node.and_then(|n| view.segments.iter().find(|s| s.id == n).cloned());
    Ok(At {
        place: Place { resolved, target },
        object,
        segment,
    })
}

/// Matches a kind against every label of the map; returns the kind as understood and each
/// object's match.
fn kind_matches(
    finder: &mut Finder,
    view: &MapView,
    asked: &str,
    parts: bool,
) -> ToolResult<(KindAnswer, BTreeMap<u64, KindMatch>)> {
    let (lexicon, taxonomy) = wordnet();
    let kinds = Kinds { lexicon, taxonomy };
    let phrase = kind_phrase(asked, lexicon);
    if phrase.is_empty() {
        return Err(ToolError::BadArguments(format!(
            "kind {asked:?} names no kind of object"
        )));
    }
    let mut count: BTreeMap<String, u64> = BTreeMap::new();
    // per label: how many of its objects the detector classed as people
    let mut people: BTreeMap<String, u64> = BTreeMap::new();
    let labels: Vec<String> = view.objects.iter().map(label_of).collect();
    for (o, l) in view.objects.iter().zip(&labels) {
        *count.entry(l.clone()).or_default() += 1;
        if scene::classes::PEOPLE_CLASSES.contains(&o.semantic_class.as_str()) {
            *people.entry(l.clone()).or_default() += 1;
        }
    }
    let mut how: BTreeMap<String, KindMatch> = BTreeMap::new();
    // rule 4: pairs of phrases with the same head, one side unknown to WordNet
    let mut pairs: Vec<(String, Vec<(String, String)>)> = Vec::new();
    for l in count.keys() {
        match kinds.match_label(
            &phrase,
            l,
            2 * people.get(l).copied().unwrap_or(0) > count[l],
        ) {
            Some(m) => {
                how.insert(l.clone(), m);
            }
            None if !l.is_empty() => {
                let c = kinds.similar_candidates(&phrase, l);
                if !c.is_empty() {
                    pairs.push((l.clone(), c));
                }
            }
            None => {}
        }
    }
    if !pairs.is_empty() {
        let texts: std::collections::BTreeSet<&str> = pairs
            .iter()
            .flat_map(|(_, c)| c.iter().flat_map(|(a, b)| [a.as_str(), b.as_str()]))
            .collect();
        let texts: Vec<&str> = texts.into_iter().collect();
        let v = finder.embed(&texts)?;
        let of = |t: &str| texts.binary_search(&t).ok().map(|i| &v[i]);
        for (l, c) in &pairs {
            let best = c
                .iter()
                .filter_map(|(a, b)| Some(llm_tools::embed::cosine(of(a)?, of(b)?)))
                .fold(f64::NEG_INFINITY, f64::max);
            if best >= SIMILAR_MIN_COSINE {
                how.insert(l.clone(), KindMatch::Similar);
            }
        }
    }
    if !parts {
        how.retain(|_, m| *m != KindMatch::PartOf);
    }
    let mut list: Vec<LabelMatch> = how
        .iter()
        .map(|(l, m)| LabelMatch {
            label: l.clone(),
            how: *m,
            objects: count[l],
        })
        .collect();
    list.sort_by(|a, b| b.objects.cmp(&a.objects).then(a.label.cmp(&b.label)));
    let per_object = view
        .objects
        .iter()
        .zip(&labels)
        .filter_map(|(o, l)| how.get(l).map(|m| (o.id, *m)))
        .collect();
    Ok((
        KindAnswer {
            asked: asked.to_string(),
            phrase,
            labels: list,
            wordnet: !lexicon.is_empty() && !taxonomy.is_empty(),
        },
        per_object,
    ))
}

/// How many of the best graph-aware candidates a nearest-to-a-place request measures at most.
const NEAREST_CANDIDATES: usize = 500;

/// Two objects whose distances to the place differ by less than this many metres are equally
/// near it: "the X nearest P" is then ambiguous (a map update changes nothing).
pub const NEAREST_TIE_M: f64 = 1.0;

/// `find`, with the nearest of something to a place.
///
/// A request that asks for the nearest ("the fire hydrant nearest the start of the drive",
/// "the bench closest to the bus shelter", "the nearest bin to segment:12") has its place,
/// its first `near` anchor, resolved as a route end is ([`resolve_end`]: a spec, an end of
/// the drive, a road segment in words, or an object). Its target is matched as a kind
/// against the objects' labels (as `nearest_objects` matches one; by the target's function
/// objects when it names a function), among the best [`NEAREST_CANDIDATES`] of graph-aware
/// `find` for the rest of the request (with attributes, other anchors or a segment asked,
/// those scoring at least half the best); on a map without labels, the candidates whose
/// target gate is at its highest. They are ranked by the ground distance from the place to
/// their centroids, nearest first, each with `place_distance_m` and the score
/// `1 / (1 + d / 100 m)`; the place's own object is left out, and the place comes
/// back with how it was resolved. Any other request, a place that cannot be resolved, or
/// plain ranking is [`Finder::find`]; no re-ranking model is asked on this path.
///
/// # Errors
/// As [`Finder::find`].
pub fn find_near_places(
    finder: &mut Finder,
    r: &impl GraphRead,
    req: &FindRequest,
) -> ToolResult<(FindAnswer, Option<Resolved>)> {
    let Ranking::Graph { parser, rerank } = req.ranking else {
        return Ok((finder.find(r, req)?, None));
    };
    finder.check_request(r, req)?;
    let t0 = std::time::Instant::now();
    let (parsed, parsed_by) = finder.parse_request(&req.text, parser)?;
    let parse_ms = t0.elapsed().as_secs_f64() * 1e3;
    let at = parsed
        .anchors
        .iter()
        .position(|a| a.relation == llm_tools::request::Relation::Near)
        .filter(|_| parsed.nearest);
    let place = match at {
        Some(i) => resolve_end(finder, r, &parsed.anchors[i].phrase, parser)
            .ok()
            .and_then(|(spec, resolved)| {
                let ground = scene::records::ground_frame(r).ok()?;
                let target = planner::route::target(r, ground, &spec).ok()?;
                Some((i, ground, target, resolved))
            }),
        None => None,
    };
    let Some((i, ground, target, resolved)) = place else {
        let (a, _) = finder.find_parsed(r, req, rerank, parsed, parsed_by, parse_ms, None)?;
        return Ok((a, None));
    };
    let mut rest = parsed.clone();
    rest.anchors.remove(i);
    let constrained =
        !rest.anchors.is_empty() || rest.segment.is_some() || !rest.attributes.is_empty();
    let wide = FindRequest {
        k: NEAREST_CANDIDATES,
        ..req.clone()
    };
    let kinds: Vec<String> = if rest.objects.is_empty() {
        vec![rest.target.clone()]
    } else {
        rest.objects.clone()
    };
    let (mut a, _) = finder.find_parsed(r, &wide, false, rest, parsed_by, parse_ms, None)?;
    // the target as a kind, by the objects' labels
    let view = finder.scene(r)?;
    let mut of_kind = std::collections::BTreeSet::new();
    for k in &kinds {
        if let Ok((_, m)) = kind_matches(finder, &view, k, true) {
            of_kind.extend(m.into_keys());
        }
    }
    if of_kind.is_empty() {
        let best = a
            .results
            .iter()
            .map(|g| g.similarity)
            .fold(f64::NEG_INFINITY, f64::max);
        a.results.retain(|g| g.similarity >= best - 1e-9);
    } else {
        a.results.retain(|g| of_kind.contains(&g.id));
    }
    if constrained {
        let best = a
            .results
            .iter()
            .map(|g| g.score)
            .fold(f64::NEG_INFINITY, f64::max);
        a.results.retain(|g| g.score >= 0.5 * best);
    }
    a.results.retain(|g| Some(g.id) != target.node);
    for g in &mut a.results {
        let d = ground_dist(ground.ground(g.centroid), target.xy);
        g.place_distance_m = Some(d);
        g.score = 1.0 / (1.0 + d / 100.0);
    }
    a.results.sort_by(|x, y| {
        x.place_distance_m
            .unwrap_or(f64::INFINITY)
            .total_cmp(&y.place_distance_m.unwrap_or(f64::INFINITY))
            .then(x.id.cmp(&y.id))
    });
    a.results.truncate(req.k);
    a.request = Some(parsed);
    Ok((a, Some(resolved)))
}

impl Toolbox {
    /// `nearest_objects`: the `k` objects of a kind nearest a place (the place itself left
    /// out), with their distances.
    ///
    /// # Errors
    /// [`ToolError::BadArguments`] when the place cannot be resolved or the kind is empty;
    /// [`ToolError::Failed`] when the store or the embedder fails.
    pub fn nearest_objects(&mut self, req: &NearestObjectsRequest) -> ToolResult<NearestAnswer> {
        let r = self.store.read().map_err(failed)?;
        let view = self.finder.scene(&r)?;
        let at = place(&mut self.finder, &r, &view, &req.near)?;
        let (kind, matches) = kind_matches(&mut self.finder, &view, &req.kind, req.parts)?;
        let mut found: Vec<(f64, &SceneObject)> = view
            .objects
            .iter()
            .filter(|o| matches.contains_key(&o.id) && Some(o.id) != at.place.target.node)
            .map(|o| (at.distance(&view, o, req.measure), o))
            .collect();
        found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.id.cmp(&b.1.id)));
        let results = found
            .into_iter()
            .take(req.k as usize)
            .map(|(d, o)| object_at(&view, o, matches.get(&o.id).copied(), d))
            .collect();
        Ok(NearestAnswer {
            kind,
            near: at.place,
            measure: measure_text(req.measure),
            results,
        })
    }

    /// `count_objects`: the objects of a kind in a segment (by `IN_SEGMENT`), within a radius
    /// of a place (centroid distance), or on the whole map.
    ///
    /// # Errors
    /// [`ToolError::BadArguments`] when `within` is not a road segment, both `within` and
    /// `near` are given, `radius_m` comes without `near`, or a place cannot be resolved.
    pub fn count_objects(&mut self, req: &CountObjectsRequest) -> ToolResult<CountAnswer> {
        if req.within.is_some() && req.near.is_some() {
            return Err(ToolError::BadArguments(
                "give within (a segment) or near with radius_m (a circle), not both".into(),
            ));
        }
        if req.radius_m.is_some() && req.near.is_none() {
            return Err(ToolError::BadArguments(
                "radius_m needs near: the place the circle is around".into(),
            ));
        }
        let r = self.store.read().map_err(failed)?;
        let view = self.finder.scene(&r)?;
        let (kind, matches) = kind_matches(&mut self.finder, &view, &req.kind, req.parts)?;
        let of_kind = view.objects.iter().filter(|o| matches.contains_key(&o.id));
        let (area, mut found, measure): (CountArea, Vec<(f64, &SceneObject)>, String) =
            if let Some(w) = &req.within {
                let at = place(&mut self.finder, &r, &view, w)?;
                let Some(seg) = at.segment.clone() else {
                    return Err(ToolError::BadArguments(format!(
                        "within must be a road segment: {w:?} resolved to {} {}",
                        at.place.target.kind,
                        at.place
                            .target
                            .node
                            .map_or(String::new(), |n| n.to_string())
                    )));
                };
                let found = of_kind
                    .filter(|o| o.segment.as_ref().is_some_and(|(s, _)| *s == seg.id))
                    .map(|o| (seg.distance(view.ground.ground(o.centroid)), o))
                    .collect();
                (
                    CountArea::Segment {
                        place: Box::new(at.place),
                        segment_id: seg.id,
                    },
                    found,
                    "how far the object's centroid lies outside the segment's area (0 inside), metres".into(),
                )
            } else if let Some(n) = &req.near {
                let at = place(&mut self.finder, &r, &view, n)?;
                let radius_m = req.radius_m.unwrap_or(DEFAULT_RADIUS_M);
                let found = of_kind
                    .filter(|o| Some(o.id) != at.place.target.node)
                    .map(|o| (at.distance(&view, o, Measure::Centroid), o))
                    .filter(|(d, _)| *d <= radius_m)
                    .collect();
                (
                    CountArea::Circle {
                        place: Box::new(at.place),
                        radius_m,
                    },
                    found,
                    CENTROID_MEASURE.into(),
                )
            } else {
                (
                    CountArea::Map,
                    of_kind.map(|o| (0.0, o)).collect(),
                    "0 (the whole map)".into(),
                )
            };
        found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.id.cmp(&b.1.id)));
        let mut by_match: BTreeMap<String, u64> = BTreeMap::new();
        for (_, o) in &found {
            let m = serde_json::to_value(matches[&o.id]).map_err(failed)?;
            *by_match
                .entry(m.as_str().unwrap_or_default().to_string())
                .or_default() += 1;
        }
        let count = found.len() as u64;
        let objects = found
            .into_iter()
            .take(req.list as usize)
            .map(|(d, o)| object_at(&view, o, matches.get(&o.id).copied(), d))
            .collect();
        Ok(CountAnswer {
            kind,
            area,
            count,
            by_match,
            measure,
            objects,
        })
    }

    /// `measure_distance`: the ground-plane distance between two places.
    ///
    /// # Errors
    /// [`ToolError::BadArguments`] when a place cannot be resolved.
    pub fn measure_distance(&mut self, req: &DistanceRequest) -> ToolResult<DistanceAnswer> {
        let r = self.store.read().map_err(failed)?;
        let view = self.finder.scene(&r)?;
        let a = place(&mut self.finder, &r, &view, &req.from)?;
        let b = place(&mut self.finder, &r, &view, &req.to)?;
        let distance_m = match (req.measure, &b.object) {
            (Measure::BoxGap, Some(o)) => a.distance(&view, o, Measure::BoxGap),
            (Measure::BoxGap, None) => match &a.object {
                Some(o) => b.distance(&view, o, Measure::BoxGap),
                None => match (&a.segment, &b.segment) {
                    (Some(s), _) => s.distance(b.xy()),
                    (None, Some(s)) => s.distance(a.xy()),
                    (None, None) => ground_dist(a.xy(), b.xy()),
                },
            },
            (Measure::Centroid, _) => ground_dist(a.xy(), b.xy()),
        };
        Ok(DistanceAnswer {
            from: a.place,
            to: b.place,
            distance_m,
            measure: measure_text(req.measure),
        })
    }

    /// `neighbours`: the objects whose footprints lie within `radius_m` of an object's,
    /// nearest first, with the map's geometric relation to each.
    ///
    /// # Errors
    /// [`ToolError::NotFound`] for no such node, [`ToolError::BadArguments`] for a node that
    /// is not an Instance.
    pub fn neighbours(&mut self, req: &NeighboursRequest) -> ToolResult<NeighboursAnswer> {
        let r = self.store.read().map_err(failed)?;
        crate::area::instance_node(&r, req.id)?;
        let view = self.finder.scene(&r)?;
        let Some(me) = view.objects.iter().find(|o| o.id == req.id) else {
            return Err(ToolError::BadArguments(format!(
                "instance {} has no feature or box and is not in the map's view",
                req.id
            )));
        };
        let mut relation: BTreeMap<u64, String> = BTreeMap::new();
        if let (Some(t), Some(k_rel)) = (
            r.rel_type(scene::rel::RELATED),
            r.prop_key(scene::key::RELATION),
        ) {
            let k_source = r.prop_key(scene::key::SOURCE);
            for a in r
                .neighbours(req.id, Direction::Both, Some(t))
                .map_err(failed)?
            {
                let source = match k_source {
                    Some(k) => r.rel_prop(a.rel, k).map_err(failed)?,
                    None => None,
                };
                if matches!(&source, Some(Value::String(s)) if s == "llm") {
                    continue;
                }
                if let Some(Value::String(rel)) = r.rel_prop(a.rel, k_rel).map_err(failed)? {
                    relation.entry(a.other).or_insert(rel);
                }
            }
        }
        let c = view.ground.ground(me.centroid);
        let mut near: Vec<Neighbour> = view
            .objects
            .iter()
            .filter(|o| o.id != me.id && !o.surface)
            .map(|o| (MapView::gap_m(me, o), o))
            .filter(|(g, _)| *g <= req.radius_m)
            .map(|(gap_m, o)| Neighbour {
                id: o.id,
                label: label_of(o),
                caption: o.caption.clone(),
                gap_m,
                centroid_distance_m: ground_dist(c, view.ground.ground(o.centroid)),
                relation: relation.get(&o.id).cloned(),
            })
            .collect();
        near.sort_by(|a, b| {
            a.gap_m
                .total_cmp(&b.gap_m)
                .then(a.centroid_distance_m.total_cmp(&b.centroid_distance_m))
                .then(a.id.cmp(&b.id))
        });
        near.truncate(req.k as usize);
        Ok(NeighboursAnswer {
            id: me.id,
            label: label_of(me),
            caption: me.caption.clone(),
            neighbours: near,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{demo_store_with_features, hash_finder};
    use serde_json::json;

    fn toolbox() -> (tempfile::TempDir, Toolbox) {
        let (dir, store) = demo_store_with_features();
        let mut tb = Toolbox::new(store, hash_finder(), true);
        // the demo's centroids are east-north-up: the ground is x, y
        tb.call(
            "write_cypher",
            &json!({"query": "MATCH (e:Environment) SET e.ground_frame = 'enu'"}),
        )
        .unwrap();
        (dir, tb)
    }

    fn id_of(tb: &mut Toolbox, q: &str) -> u64 {
        tb.call("read_cypher", &json!({ "query": q })).unwrap()["rows"][0]["id"]
            .as_u64()
            .unwrap()
    }

    /// Distances agree with the centroids Cypher returns, the place itself is left out, and
    /// the kind's labels are listed with how they matched.
    #[test]
    fn nearest_objects_measure_from_the_place() {
        let (_d, mut tb) = toolbox();
        let bench = id_of(
            &mut tb,
            "MATCH (n:Instance {instance_id: 1}) RETURN id(n) AS id",
        );
        let car = id_of(
            &mut tb,
            "MATCH (n:Instance) WHERE n.caption CONTAINS 'hatchback' RETURN id(n) AS id",
        );
        let rows = tb
            .call(
                "read_cypher",
                &json!({"query": "MATCH (a:Instance), (b:Instance) WHERE id(a) = $a AND id(b) = $b RETURN a.centroid AS a, b.centroid AS b", "params": {"a": bench, "b": car}}),
            )
            .unwrap();
        let p = |k: &str| {
            let v = &rows["rows"][0][k];
            [v["x"].as_f64().unwrap(), v["y"].as_f64().unwrap()]
        };
        let (a, b) = (p("a"), p("b"));
        let truth = (a[0] - b[0]).hypot(a[1] - b[1]);
        let ans = tb
            .nearest_objects(&NearestObjectsRequest {
                kind: "a car".into(),
                near: format!("instance:{bench}"),
                k: 5,
                measure: Measure::Centroid,
                parts: true,
            })
            .unwrap();
        assert_eq!(ans.results.len(), 1, "{ans:?}");
        assert_eq!(ans.results[0].id, car);
        assert!((ans.results[0].distance_m - truth).abs() < 1e-6);
        assert_eq!(ans.near.target.node, Some(bench));
        assert_eq!(ans.kind.labels[0].how, KindMatch::KindOf, "{:?}", ans.kind);
        // the place itself is not its own nearest bench
        let benches = tb
            .nearest_objects(&NearestObjectsRequest {
                kind: "bench".into(),
                near: format!("instance:{bench}"),
                k: 5,
                measure: Measure::BoxGap,
                parts: true,
            })
            .unwrap();
        assert!(benches.results.iter().all(|r| r.id != bench));
    }

    /// "The X nearest P" through find and map updates ranks the objects of kind X by their
    /// distance to P, as nearest_objects does, and names the place it measured from.
    #[test]
    fn find_and_updates_take_the_nearest_to_a_place() {
        let (_d, mut tb) = toolbox();
        let car = id_of(
            &mut tb,
            "MATCH (n:Instance) WHERE n.caption CONTAINS 'hatchback' RETURN id(n) AS id",
        );
        let text = format!("the bench nearest to instance:{car}");
        let found = tb
            .call("find_objects", &json!({"text": text, "k": 5}))
            .unwrap();
        assert_eq!(found["nearest_to"]["by"], "spec", "{found}");
        let want = tb
            .nearest_objects(&NearestObjectsRequest {
                kind: "bench".into(),
                near: format!("instance:{car}"),
                k: 5,
                measure: Measure::Centroid,
                parts: true,
            })
            .unwrap();
        let got: Vec<(u64, f64)> = found["results"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| {
                (
                    r["id"].as_u64().unwrap(),
                    r["place_distance_m"].as_f64().unwrap(),
                )
            })
            .collect();
        // (the demo has one bench; api/tests/tasks.rs checks an order of several)
        assert!(!got.is_empty(), "{found}");
        assert_eq!(got.len(), want.results.len());
        for ((id, d), w) in got.iter().zip(&want.results) {
            assert_eq!(*id, w.id);
            assert!((d - w.distance_m).abs() < 1e-9);
        }
        // without a superlative the request is ranked by relevance, with no place
        let plain = tb
            .call("find_objects", &json!({"text": "the bench", "k": 5}))
            .unwrap();
        assert!(plain["nearest_to"].is_null());
        assert!(plain["results"][0]["place_distance_m"].is_null());
        // a map update takes the nearest one, unless the next is about as near
        let up = tb
            .call(
                "update_map",
                &json!({"text": format!("the bench nearest to instance:{car} is now red")}),
            )
            .unwrap();
        let tie = got.len() > 1 && got[1].1 - got[0].1 < NEAREST_TIE_M;
        assert_eq!(up["target"]["ambiguous"], tie, "{up}");
        assert_eq!(up["target"]["candidates"][0]["id"], got[0].0, "{up}");
    }

    /// A circle counts what its radius reaches; `within` must be a segment; `radius_m` needs
    /// `near`; a blank kind is refused.
    #[test]
    fn count_objects_checks_its_area() {
        let (_d, mut tb) = toolbox();
        let bench = id_of(
            &mut tb,
            "MATCH (n:Instance {instance_id: 1}) RETURN id(n) AS id",
        );
        let all = tb
            .call("count_objects", &json!({"kind": "hedges"}))
            .unwrap();
        assert_eq!(all["count"], 1, "{all}");
        assert_eq!(all["area"]["by"], "map");
        let none = tb
            .call(
                "count_objects",
                &json!({"kind": "car", "near": format!("instance:{bench}"), "radius_m": 0.0}),
            )
            .unwrap();
        assert_eq!(none["count"], 0, "{none}");
        let some = tb
            .call(
                "count_objects",
                &json!({"kind": "car", "near": format!("instance:{bench}"), "radius_m": 1000.0}),
            )
            .unwrap();
        assert_eq!(some["count"], 1, "{some}");
        let e = tb
            .call(
                "count_objects",
                &json!({"kind": "car", "within": format!("instance:{bench}")}),
            )
            .unwrap_err();
        assert!(e.to_string().contains("must be a road segment"), "{e}");
        let e = tb
            .call("count_objects", &json!({"kind": "car", "radius_m": 5.0}))
            .unwrap_err();
        assert!(e.to_string().contains("needs near"), "{e}");
        assert!(tb.call("count_objects", &json!({"kind": "  "})).is_err());
    }

    /// Box gaps are never more than centroid distances; a neighbour list is sorted by gap
    /// and leaves out the object itself.
    #[test]
    fn gaps_and_neighbours_are_consistent() {
        let (_d, mut tb) = toolbox();
        let bench = id_of(
            &mut tb,
            "MATCH (n:Instance {instance_id: 1}) RETURN id(n) AS id",
        );
        let hydrant = id_of(
            &mut tb,
            "MATCH (n:Instance) WHERE n.caption CONTAINS 'hydrant' RETURN id(n) AS id",
        );
        let d = |tb: &mut Toolbox, m: &str| {
            tb.call(
                "measure_distance",
                &json!({"from": format!("instance:{bench}"), "to": format!("instance:{hydrant}"), "measure": m}),
            )
            .unwrap()["distance_m"]
                .as_f64()
                .unwrap()
        };
        let (c, g) = (d(&mut tb, "centroid"), d(&mut tb, "box_gap"));
        assert!(g <= c + 1e-9 && c > 0.0, "gap {g} centroid {c}");
        let n = tb
            .neighbours(&NeighboursRequest {
                id: bench,
                radius_m: 1000.0,
                k: 100,
            })
            .unwrap();
        assert!(n.neighbours.iter().all(|x| x.id != bench));
        assert!(n.neighbours.windows(2).all(|w| w[0].gap_m <= w[1].gap_m));
        let h = n.neighbours.iter().find(|x| x.id == hydrant).unwrap();
        assert!((h.gap_m - g).abs() < 1e-9 && (h.centroid_distance_m - c).abs() < 1e-9);
        let seg = id_of(&mut tb, "MATCH (s:Segment) RETURN id(s) AS id LIMIT 1");
        let e = tb.call("neighbours", &json!({ "id": seg })).unwrap_err();
        assert!(e.to_string().contains("not an Instance"), "{e}");
    }
}
