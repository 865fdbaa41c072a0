//! The map-update operation (`opengraph update`, the `update_map` tool, `POST /api/update`):
//! a described change ("the bush under the street sign at the crossing is gone") is parsed
//! ([`llm_tools::edit`]), its object resolved with graph-aware `find` (anchors and all), and
//! turned into a proposed edit that is shown first; with `apply` it is committed as one
//! transaction ([`ingest::map_edit`]) and recorded as a `MapEdit` node that `undo` reverts.
//!
//! A description that fits several objects about equally well (the best two scores within
//! [`AMBIGUITY_MARGIN`]) lists them and changes nothing.

use graphstore::{GraphRead, Store};
use ingest::map_edit::{Applied, Change};
use llm_tools::edit::{EditKind, EditRequest, parse_edit_rules, recaption};
use llm_tools::graph_find::GraphFound;
use serde::Serialize;

use crate::error::{ToolError, ToolResult};
use crate::find::{FindRequest, Finder, ParserKind, Ranking};

/// Who parses change descriptions with rules, recorded with every edit.
pub const PARSED_BY: &str = "rules (edit_rules@v1)";

/// Two candidates whose scores differ by less than this are too close to choose between.
pub const AMBIGUITY_MARGIN: f64 = 0.05;

/// The default size of an added object: ground extent (two axes) and height, metres.
pub const ADDED_SIZE_M: [f64; 3] = [0.8, 0.8, 1.0];

/// A map-update request.
#[derive(Debug, Clone, PartialEq)]
pub struct UpdateRequest {
    /// The described change.
    pub text: String,
    /// Commit the proposed edit (otherwise only show it).
    pub apply: bool,
    /// Who parses the description: rules, or the finder's language model (`parse_edit@v1`).
    pub parser: ParserKind,
}

/// An object the change refers to, resolved.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Resolved {
    /// The phrase.
    pub phrase: String,
    /// Candidates best first (the first is chosen unless `ambiguous`).
    pub candidates: Vec<GraphFound>,
    /// Whether the best two are too close to choose.
    pub ambiguous: bool,
    /// Whether even the best is a weak match (the map holds nothing like the phrase).
    pub weak: bool,
}

/// The answer: what was understood, the proposed edit, and what was applied.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct UpdateAnswer {
    /// The parsed change.
    pub request: EditRequest,
    /// Who parsed it.
    pub parsed_by: String,
    /// The object changed (remove, move, change).
    pub target: Option<Resolved>,
    /// The object it is placed by (move, add).
    pub anchor: Option<Resolved>,
    /// The edit in words, or why there is none.
    pub proposal: String,
    /// Whether the description is ambiguous (nothing is changed then).
    pub ambiguous: bool,
    /// Whether the map holds nothing that matches the description well (nothing is changed
    /// then either).
    pub no_match: bool,
    /// The new ground position (move, add), metres in the map's ground frame.
    pub position: Option<[f64; 2]>,
    /// The new caption (change, add).
    pub caption: Option<String>,
    /// What was committed (with `apply`).
    pub applied: Option<Applied>,
}

/// The instance id a phrase names outright: "instance 444", "instance:444", "object 444", "#444".
fn named_id(phrase: &str) -> Option<u64> {
    let p = phrase.trim().to_lowercase();
    let p = p.strip_prefix("the ").unwrap_or(&p);
    let rest = ["instance", "object", "node"]
        .iter()
        .find_map(|w| p.strip_prefix(w))
        .or_else(|| p.strip_prefix('#'))?;
    rest.trim_start_matches([' ', ':', '#']).parse().ok()
}

/// A caption or phrase as compared word for word: lower case, articles dropped.
fn plain_words(s: &str) -> String {
    s.to_lowercase()
        .split(|c: char| !c.is_alphanumeric())
        .filter(|w| !w.is_empty() && !matches!(*w, "the" | "a" | "an"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn resolve(finder: &mut Finder, r: &impl GraphRead, phrase: &str) -> ToolResult<Resolved> {
    // an instance named by its id is that instance
    if let Some(id) = named_id(phrase) {
        let scene = finder.scene(r).map_err(failed)?;
        let o = scene.objects.iter().find(|o| o.id == id).ok_or_else(|| {
            ToolError::NotFound(format!("{phrase:?}: the map has no instance {id}"))
        })?;
        return Ok(Resolved {
            phrase: phrase.to_string(),
            candidates: vec![GraphFound {
                id,
                label: o.label.clone(),
                caption: o.caption.clone(),
                semantic_class: o.semantic_class.clone(),
                score: 1.0,
                similarity: 1.0,
                cosine: 1.0,
                centroid: o.centroid,
                segment: o.segment.clone(),
                segment_match: None,
                evidence: Vec::new(),
                place_distance_m: None,
            }],
            ambiguous: false,
            weak: false,
        });
    }
    let (a, nearest_to) = crate::tasks::find_near_places(
        finder,
        r,
        &FindRequest {
            text: phrase.to_string(),
            k: 5,
            class: None,
            near: None,
            ranking: Ranking::Graph {
                parser: ParserKind::Rules,
                rerank: false,
            },
            rerank_n: 10,
        },
    )
    .map_err(|e| ToolError::BadArguments(e.to_string()))?;
    let mut a = a;
    if a.results.is_empty() {
        return Err(ToolError::NotFound(format!(
            "nothing in the map matches {phrase:?}"
        )));
    }
    // the one candidate whose caption is the phrase word for word is the one meant
    let want = plain_words(phrase);
    let exact: Vec<usize> = (0..a.results.len())
        .filter(|&i| plain_words(&a.results[i].caption) == want)
        .collect();
    let named_exactly = if let [i] = exact[..] {
        let hit = a.results.remove(i);
        a.results.insert(0, hit);
        true
    } else {
        false
    };
    // the nearest to a place is one object unless the next is about as near
    let ambiguous = !named_exactly
        && a.results.len() > 1
        && match (
            nearest_to,
            a.results[0].place_distance_m,
            a.results[1].place_distance_m,
        ) {
            (Some(_), Some(d0), Some(d1)) => d1 - d0 < crate::tasks::NEAREST_TIE_M,
            _ => a.results[0].score - a.results[1].score < AMBIGUITY_MARGIN,
        };
    let weak = a.results[0].cosine < finder.weak_match_cosine();
    Ok(Resolved {
        phrase: phrase.to_string(),
        candidates: a.results.into_iter().take(3).collect(),
        ambiguous,
        weak,
    })
}

fn failed(e: impl std::fmt::Display) -> ToolError {
    ToolError::Failed(e.to_string())
}

/// Ground box (min, max) and base height of an instance.
fn ground_box(
    r: &impl GraphRead,
    frame: scene::GroundFrame,
    id: u64,
) -> ToolResult<([f64; 2], [f64; 2], f64, f64)> {
    let (min, max) = scene::records::InstanceRecord::read(r, id)
        .map_err(failed)?
        .ok_or_else(|| ToolError::Failed(format!("instance {id} has no box")))?
        .bbox;
    let (a, b) = (frame.ground(min), frame.ground(max));
    let (ha, hb) = (frame.height(min), frame.height(max));
    Ok((
        [a[0].min(b[0]), a[1].min(b[1])],
        [a[0].max(b[0]), a[1].max(b[1])],
        ha.min(hb),
        ha.max(hb),
    ))
}

/// The unit ground direction from `p` toward the nearest road (segment centreline or centre).
fn toward_road(p: [f64; 2], segments: &[llm_tools::locate::SegmentInfo]) -> [f64; 2] {
    let mut best: Option<(f64, [f64; 2])> = None;
    for s in segments {
        let q = match &s.area {
            scene::area::SegmentArea::Disc { centre, .. } => *centre,
            scene::area::SegmentArea::Corridor { centreline, .. } => centreline
                .windows(2)
                .map(|w| scene::geom::closest_on_segment(p, w[0], w[1]).1)
                .min_by(|a, b| {
                    (a[0] - p[0])
                        .hypot(a[1] - p[1])
                        .total_cmp(&(b[0] - p[0]).hypot(b[1] - p[1]))
                })
                .unwrap_or(s.centroid),
        };
        let d = (q[0] - p[0]).hypot(q[1] - p[1]);
        if best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, q));
        }
    }
    unit(best.map_or([1.0, 0.0], |(_, q)| [q[0] - p[0], q[1] - p[1]]))
}

fn unit(v: [f64; 2]) -> [f64; 2] {
    let n = v[0].hypot(v[1]);
    if n < 1e-9 {
        [1.0, 0.0]
    } else {
        [v[0] / n, v[1] / n]
    }
}

/// Where an object of half-extent `half_m` goes when placed `relation` the anchor: beside
/// it (next_to and the like: boxes 0.3 m apart; near: 2 m apart) along `dir`, or on it.
fn place(anchor: ([f64; 2], [f64; 2]), relation: &str, half_m: f64, dir: [f64; 2]) -> [f64; 2] {
    let c = [
        (anchor.0[0] + anchor.1[0]) / 2.0,
        (anchor.0[1] + anchor.1[1]) / 2.0,
    ];
    if matches!(relation, "on" | "under") {
        return c;
    }
    let anchor_half = ((anchor.1[0] - anchor.0[0]).abs() * dir[0].abs()
        + (anchor.1[1] - anchor.0[1]).abs() * dir[1].abs())
        / 2.0;
    let gap = if relation == "near" { 2.0 } else { 0.3 };
    let d = anchor_half + half_m + gap;
    [c[0] + dir[0] * d, c[1] + dir[1] * d]
}

/// Moves `pos` further along `dir` in 0.3 m steps (6 m at most) until a square of half-side
/// `half_m` around it overlaps no object's footprint (ground surfaces and `exclude` aside), so an
/// edit never puts one box inside another.
fn clear_spot(
    mut pos: [f64; 2],
    half_m: f64,
    dir: [f64; 2],
    objects: &[llm_tools::graph_find::SceneObject],
    exclude: Option<u64>,
) -> [f64; 2] {
    let overlaps = |p: [f64; 2]| {
        objects.iter().any(|o| {
            !o.surface
                && Some(o.id) != exclude
                && p[0] - half_m < o.ground_max[0]
                && p[0] + half_m > o.ground_min[0]
                && p[1] - half_m < o.ground_max[1]
                && p[1] + half_m > o.ground_min[1]
        })
    };
    for _ in 0..20 {
        if !overlaps(pos) {
            break;
        }
        pos = [pos[0] + dir[0] * 0.3, pos[1] + dir[1] * 0.3];
    }
    pos
}

/// The SemanticKITTI class whose prompts are nearest to `caption` (as the build assigns).
fn class_for(finder: &mut Finder, caption: &str) -> ToolResult<String> {
    let prompts = scene::classes::prompts();
    let mut texts: Vec<&str> = prompts.iter().map(|p| p.1).collect();
    texts.push(caption);
    let v = finder.embed(&texts).map_err(failed)?;
    let (me, rest) = v.split_last().ok_or_else(|| failed("no embedding"))?;
    let best = rest
        .iter()
        .zip(&prompts)
        .map(|(e, p)| (llm_tools::embed::cosine(e, me), p.0))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|x| x.1)
        .unwrap_or(0);
    Ok(scene::classes::class_name(best)
        .unwrap_or("unlabeled")
        .to_string())
}

/// Understands a described change, proposes the edit, and applies it when asked.
///
/// # Errors
/// [`ToolError::BadArguments`] for a sentence that is no change the parser knows;
/// [`ToolError::NotFound`] when nothing matches; [`ToolError::Forbidden`]-free: the caller
/// gates writes. The store is unchanged on every error and when the description is ambiguous.
pub fn update(finder: &mut Finder, store: &Store, req: &UpdateRequest) -> ToolResult<UpdateAnswer> {
    let (request, parsed_by) = match req.parser {
        ParserKind::Rules => (
            parse_edit_rules(&req.text).map_err(|e| ToolError::BadArguments(e.to_string()))?,
            PARSED_BY.to_string(),
        ),
        ParserKind::Llm => {
            let model = finder
                .chat_model()
                .map_err(|e| ToolError::BadArguments(e.to_string()))?;
            let by = format!(
                "{} ({})",
                model.model_id(),
                llm_tools::prompts::PARSE_EDIT.id()
            );
            let r = llm_tools::edit::parse_edit_llm(model, &req.text)?;
            (r, by)
        }
    };
    let r = store.read().map_err(failed)?;
    let frame =
        ingest::map_edit::ground_frame(&r).map_err(|e| ToolError::BadArguments(e.to_string()))?;
    let target = match &request.target {
        Some(t) => Some(resolve(finder, &r, t)?),
        None => None,
    };
    let anchor = match &request.place {
        Some((_, a)) => Some(resolve(finder, &r, a)?),
        None => None,
    };
    let no_match =
        target.as_ref().is_some_and(|t| t.weak) || anchor.as_ref().is_some_and(|a| a.weak);
    let ambiguous = !no_match
        && (target.as_ref().is_some_and(|t| t.ambiguous)
            || anchor.as_ref().is_some_and(|a| a.ambiguous));
    let best = |x: &Option<Resolved>| x.as_ref().map(|x| x.candidates[0].clone());
    let (t, a) = (best(&target), best(&anchor));
    let scene = finder.scene(&r).map_err(failed)?;
    let segments = &scene.segments;
    let mut position = None;
    let mut caption = None;
    let (change, proposal) = match request.kind {
        EditKind::Remove => {
            let t = t.expect("a remove names its object");
            (
                Change::Remove { id: t.id },
                format!(
                    "remove instance {} ({}: \"{}\") with its points and relationships",
                    t.id,
                    if t.label.is_empty() {
                        &t.semantic_class
                    } else {
                        &t.label
                    },
                    t.caption
                ),
            )
        }
        EditKind::Move => {
            let (t, a) = (t.expect("a target"), a.expect("an anchor"));
            if t.id == a.id {
                return Err(ToolError::BadArguments(format!(
                    "the object and the place it moved to are the same instance ({})",
                    t.id
                )));
            }
            let relation = request
                .place
                .as_ref()
                .map(|p| p.0.clone())
                .unwrap_or_default();
            let (tmin, tmax, _, _) = ground_box(&r, frame, t.id)?;
            let amin_max = ground_box(&r, frame, a.id)?;
            let half = ((tmax[0] - tmin[0]).max(tmax[1] - tmin[1])) / 2.0;
            let ac = [
                (amin_max.0[0] + amin_max.1[0]) / 2.0,
                (amin_max.0[1] + amin_max.1[1]) / 2.0,
            ];
            let dir = toward_road(ac, segments);
            let to = place((amin_max.0, amin_max.1), &relation, half, dir);
            let to = if matches!(relation.as_str(), "on" | "under") {
                to
            } else {
                clear_spot(to, half, dir, &scene.objects, Some(t.id))
            };
            position = Some(to);
            (
                Change::Move {
                    id: t.id,
                    to_ground: to,
                },
                format!(
                    "move instance {} (\"{}\") {} instance {} (\"{}\"), to ({:.1}, {:.1}); its segment and relations are re-derived",
                    t.id,
                    t.caption,
                    relation.replace('_', " "),
                    a.id,
                    a.caption,
                    to[0],
                    to[1]
                ),
            )
        }
        EditKind::Change => {
            let t = t.expect("a target");
            let new_description = request.new_description.clone().unwrap_or_default();
            let new_caption = if request.replaced {
                new_description.clone()
            } else {
                recaption(&t.caption, &new_description)
            };
            let feature = finder
                .embed(&[new_caption.as_str()])
                .map_err(failed)?
                .pop()
                .ok_or_else(|| failed("no embedding"))?;
            let class = if request.replaced {
                Some(class_for(finder, &new_caption)?)
            } else {
                None
            };
            caption = Some(new_caption.clone());
            (
                Change::Recaption {
                    id: t.id,
                    caption: new_caption.clone(),
                    feature,
                    class: class.clone(),
                },
                format!(
                    "change instance {} from \"{}\" to \"{}\"{}",
                    t.id,
                    t.caption,
                    new_caption,
                    class.map(|c| format!(" (class {c})")).unwrap_or_default()
                ),
            )
        }
        EditKind::Add => {
            let a = a.expect("an anchor");
            let relation = request
                .place
                .as_ref()
                .map(|p| p.0.clone())
                .unwrap_or_default();
            let new_caption = request.new_description.clone().unwrap_or_default();
            let (amin, amax, abase, atop) = ground_box(&r, frame, a.id)?;
            let ac = [(amin[0] + amax[0]) / 2.0, (amin[1] + amax[1]) / 2.0];
            let dir = toward_road(ac, segments);
            let to = place((amin, amax), &relation, ADDED_SIZE_M[0] / 2.0, dir);
            let to = if matches!(relation.as_str(), "on" | "under") {
                to
            } else {
                clear_spot(to, ADDED_SIZE_M[0] / 2.0, dir, &scene.objects, None)
            };
            let base = if relation == "on" { atop } else { abase };
            let feature = finder
                .embed(&[new_caption.as_str()])
                .map_err(failed)?
                .pop()
                .ok_or_else(|| failed("no embedding"))?;
            let class = class_for(finder, &new_caption)?;
            position = Some(to);
            caption = Some(new_caption.clone());
            (
                Change::Add {
                    caption: new_caption.clone(),
                    class: class.clone(),
                    feature,
                    centre_ground: to,
                    base_height_m: base,
                    size_m: ADDED_SIZE_M,
                },
                format!(
                    "add \"{}\" (class {}, a {:.1} x {:.1} x {:.1} m box) {} instance {} (\"{}\"), at ({:.1}, {:.1})",
                    new_caption,
                    class,
                    ADDED_SIZE_M[0],
                    ADDED_SIZE_M[1],
                    ADDED_SIZE_M[2],
                    relation.replace('_', " "),
                    a.id,
                    a.caption,
                    to[0],
                    to[1]
                ),
            )
        }
    };
    drop(r);
    let proposal = if no_match {
        let which = [&target, &anchor]
            .into_iter()
            .flatten()
            .filter(|x| x.weak)
            .map(|x| {
                let c = &x.candidates[0];
                format!(
                    "for {:?} the best candidate is {} \"{}\" (cosine {:.2})",
                    x.phrase, c.id, c.caption, c.cosine
                )
            })
            .collect::<Vec<_>>()
            .join("; ");
        format!(
            "no good match, nothing changed: {which}; the map may not hold it, or say it differently"
        )
    } else if ambiguous {
        let which = |x: &Option<Resolved>| {
            x.as_ref().filter(|x| x.ambiguous).map(|x| {
                format!(
                    "{:?} fits {}",
                    x.phrase,
                    x.candidates
                        .iter()
                        .map(|c| format!("{} (\"{}\", score {:.2})", c.id, c.caption, c.score))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })
        };
        format!(
            "ambiguous, nothing changed: {}; say more (what stands next to it, which road segment)",
            [which(&target), which(&anchor)]
                .into_iter()
                .flatten()
                .collect::<Vec<_>>()
                .join("; ")
        )
    } else {
        proposal
    };
    let applied = if req.apply && !ambiguous && !no_match {
        Some(ingest::map_edit::apply(
            store, &change, &req.text, &parsed_by,
        )?)
    } else {
        None
    };
    Ok(UpdateAnswer {
        request,
        parsed_by,
        target,
        anchor,
        proposal,
        ambiguous,
        no_match,
        position,
        caption,
        applied,
    })
}

/// Reverts a map edit (see [`ingest::map_edit::undo`]).
///
/// # Errors
/// [`ToolError::BadArguments`] for an id that is no applied `MapEdit`, or one a later edit
/// depends on.
pub fn undo(store: &Store, edit_id: u64) -> ToolResult<ingest::map_edit::EditInfo> {
    {
        let r = store.read().map_err(failed)?;
        if r.node(edit_id).map_err(failed)?.is_none() {
            return Err(ToolError::NotFound(format!("no map edit {edit_id}")));
        }
    }
    Ok(ingest::map_edit::undo(store, edit_id)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use graphstore::Value;

    #[test]
    fn an_instance_is_named_by_its_id_and_captions_compare_word_for_word() {
        for (p, want) in [
            ("instance 444", Some(444)),
            ("the instance:444", Some(444)),
            ("Object #12", Some(12)),
            ("#7", Some(7)),
            ("node 3", Some(3)),
            ("the instance near the bench", None),
            ("instance 44a", None),
            ("a bench", None),
        ] {
            assert_eq!(named_id(p), want, "{p}");
        }
        assert_eq!(
            plain_words("The short, brown  park bench"),
            plain_words("short brown park bench")
        );
        assert_ne!(plain_words("a long bench"), plain_words("a short bench"));
    }
    use llm_tools::Embedder;
    use llm_tools::chat::scripted::{Reply, Scripted};

    /// A straight road along z (KITTI camera frame) with a bench and a bin beside it, their
    /// features the hash embedder's of their captions.
    fn small_map(dir: &std::path::Path) -> Store {
        let store = Store::create(dir.join("m.og")).unwrap();
        store.set_schema(scene::opengraph_schema()).unwrap();
        let mut hash = llm_tools::HashEmbedder::new(scene::FEATURE_DIM);
        store
            .write(|tx| {
                let env = tx.create_node_named(
                    &[scene::label::ENVIRONMENT],
                    &[("name", "t".into()), ("ground_frame", "kitti_cam".into())],
                )?;
                let seg = tx.create_node_named(
                    &[scene::label::SEGMENT],
                    &[
                        ("segment_id", Value::Int(0)),
                        ("kind", "straight_roadway".into()),
                        ("centroid", Value::Point3D([0.0, 0.0, 50.0])),
                        (
                            "centerline",
                            Value::List(vec![
                                Value::Point3D([0.0, 0.0, 0.0]),
                                Value::Point3D([0.0, 0.0, 100.0]),
                            ]),
                        ),
                        ("half_width_m", Value::Float(6.0)),
                        ("bbox", Value::box3d([-6.0, -3.0, 0.0], [6.0, 3.0, 100.0])),
                    ],
                )?;
                tx.create_rel_named(env, scene::rel::CONTAINS, seg, &[])?;
                for (i, caption, c) in [
                    (0, "a brown wooden bench", [4.0, 0.5, 20.0]),
                    (1, "a green litter bin", [4.0, 0.5, 60.0]),
                ] {
                    let feature = hash.embed(&[caption]).unwrap().remove(0);
                    let id = tx.create_node_named(
                        &[scene::label::INSTANCE],
                        &[
                            ("instance_id", Value::Int(i)),
                            ("caption", caption.into()),
                            ("semantic_class", "fence".into()),
                            ("centroid", Value::Point3D(c)),
                            (
                                "bbox",
                                Value::box3d(
                                    [c[0] - 0.5, c[1] - 0.5, c[2] - 0.5],
                                    [c[0] + 0.5, c[1] + 0.5, c[2] + 0.5],
                                ),
                            ),
                            ("feature", Value::Vector(feature)),
                        ],
                    )?;
                    tx.create_rel_named(id, scene::rel::IN_SEGMENT, seg, &[])?;
                }
                Ok(())
            })
            .unwrap();
        store
    }

    /// An edit read by the language model records that model and its prompt, in the answer
    /// and in the `MapEdit` node.
    #[test]
    fn an_llm_read_edit_records_the_model_and_prompt() {
        let dir = tempfile::tempdir().unwrap();
        let store = small_map(dir.path());
        let reading = serde_json::json!({"kind": "remove", "new_description": null,
            "place_phrase": null, "place_relation": null, "replaced": false,
            "target": "the brown wooden bench"});
        let model = Scripted::new("script", vec![Reply::Text(reading.to_string())]);
        let mut finder = Finder::new(
            Box::new(llm_tools::HashEmbedder::new(scene::FEATURE_DIM)),
            Some(Box::new(model)),
        );
        let a = update(
            &mut finder,
            &store,
            &UpdateRequest {
                text: "sadly the brown wooden bench got ripped out".into(),
                apply: true,
                parser: ParserKind::Llm,
            },
        )
        .unwrap();
        assert!(a.parsed_by.ends_with("(parse_edit@v1)"), "{}", a.parsed_by);
        let edit = a.applied.expect("applied").edit_id;
        let r = store.read().unwrap();
        let by = r.node_prop(edit, "parsed_by").unwrap();
        assert_eq!(by, Some(Value::String(a.parsed_by.clone())));
        assert_ne!(a.parsed_by, PARSED_BY);
    }
}
