//! The `plan` and `navigate` operations, transport-free. `plan` routes between two specs
//! (`lane:ID`, `segment:ID`, `instance:ID`, `node:ID` or a ground point) on the lane graph
//! (A*) and refines the route with OMPL; `navigate` first resolves each end from words
//! ("from the bus stop by the crossroads to somewhere I can post a letter") with `find` or
//! `locate`, then plans.

use std::path::PathBuf;
use std::time::Instant;

use graphstore::GraphRead;
use llm_tools::graph_find::GraphFound;
use llm_tools::locate::Located;
use planner::{MotionPath, Route, Spec, Target};

use crate::error::{ToolError, ToolResult};
use crate::find::{FindRequest, Finder, LocateRequest, ParserKind, Ranking};

/// Planner settings of one request.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOptions {
    /// Minimum turning radius, metres.
    pub turning_radius_m: f64,
    /// OMPL time budget, milliseconds.
    pub budget_ms: f64,
    /// Half width of the corridor around the route, metres.
    pub corridor_m: f64,
    /// How far a point may be snapped to the lane graph, metres.
    pub snap_m: f64,
    /// Write a bird's-eye PNG here (start green, goal red, route blue).
    pub png: Option<PathBuf>,
}

impl PlanOptions {
    /// The defaults every front end uses (the CLI's flag defaults, the `plan_route` tool):
    /// 5 m turning radius, 200 ms of OMPL, a 6 m corridor, points snapped within 15 m, no PNG.
    pub const DEFAULT: PlanOptions = PlanOptions {
        turning_radius_m: 5.0,
        budget_ms: 200.0,
        corridor_m: 6.0,
        snap_m: 15.0,
        png: None,
    };

    /// The OMPL refinement's settings from these options.
    fn motion(&self) -> planner::MotionConfig {
        planner::MotionConfig {
            turning_radius_m: self.turning_radius_m,
            budget_ms: self.budget_ms,
            corridor_half_width_m: self.corridor_m,
            ..planner::MotionConfig::default()
        }
    }
}

impl Default for PlanOptions {
    fn default() -> PlanOptions {
        PlanOptions::DEFAULT
    }
}

/// A planned route.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct PlanAnswer {
    /// The start as resolved.
    pub from: Target,
    /// The goal as resolved.
    pub to: Target,
    /// The lane-graph route.
    pub route: Route,
    /// The refined path.
    pub path: MotionPath,
    /// Instances whose boxes block the corridor.
    pub blocking: usize,
    /// Segments whose drivable area (measured from the map) reaches the corridor and the
    /// path was kept on; 0 when the corridor alone bounded it (the map has no areas, or they
    /// have gaps along the route: then `path.warning` says so).
    pub drivable_segments: usize,
    /// Milliseconds: routing, and everything.
    pub timings_ms: [f64; 2],
}

/// Plans from `from` to `to` over the map `r`.
///
/// # Errors
/// Unknown or wrong-kind ids, a store without a lane graph or ground frame, no route, a PNG
/// that cannot be written.
pub fn plan(
    r: &impl GraphRead,
    from: &Spec,
    to: &Spec,
    opts: &PlanOptions,
) -> planner::Result<PlanAnswer> {
    let t0 = Instant::now();
    let g = planner::RoadGraph::from_store(r)?;
    let ground = scene::records::ground_frame(r)?;
    let ((a, from_t), (b, to_t)) = (
        planner::resolve(&g, r, ground, from, opts.snap_m)?,
        planner::resolve(&g, r, ground, to, opts.snap_m)?,
    );
    let route = planner::astar(&g, a, b)?;
    let t_route = t0.elapsed().as_secs_f64() * 1e3;
    let cfg = opts.motion();
    let obstacles = planner::motion::blocking_instances(r, ground, &route, opts.corridor_m)?;
    // the drivable areas the corridor reaches; where they have gaps across the road (sparse
    // scans), OMPL cannot stay on them, and the corridor alone bounds the path
    let corridor = planner::Validity::new(&route.polyline, opts.corridor_m, &[], 0.0);
    // the bounds first: most of a city's areas are nowhere near the route, and an area can
    // reach the corridor only if its bounds meet the corridor's
    let reach = corridor.bounds();
    let drivable: Vec<scene::area::Drivable> = planner::motion::drivable_of_store(r, ground)?
        .into_iter()
        .filter(|d| {
            let b = d.bounds();
            (0..2).all(|k| b[0][k] <= reach[1][k] && b[1][k] >= reach[0][k])
                && (route
                    .polyline
                    .iter()
                    .any(|q| scene::area::box_gap(&b, *q) == 0.0 && d.contains(*q))
                    || d.rings
                        .iter()
                        .flatten()
                        .any(|p| corridor.corridor_distance(*p) <= opts.corridor_m))
        })
        .collect();
    // on the drivable areas, the route is only followed (milliseconds; where the areas have
    // a gap across the road no search would get across it, and RRT* would spend its whole
    // budget finding that out); if that fails, the corridor alone has the whole budget
    let t_first = Instant::now();
    let first_cfg = planner::MotionConfig {
        refinement: if drivable.is_empty() {
            cfg.refinement
        } else {
            planner::Refinement::FollowOnly
        },
        ..cfg.clone()
    };
    let mut path = planner::motion::plan_path_on(&route, &obstacles, &drivable, &first_cfg)?;
    let mut drivable_segments = drivable.len();
    let left_ms = cfg.budget_ms - t_first.elapsed().as_secs_f64() * 1e3;
    if path.fallback && !drivable.is_empty() {
        if left_ms >= 1.0 {
            let loose_cfg = planner::MotionConfig {
                budget_ms: left_ms,
                ..cfg.clone()
            };
            let mut loose = planner::plan_path(&route, &obstacles, &loose_cfg)?;
            loose.warning = Some(if loose.fallback {
                // both failed: say why each did (the corridor alone is what was tried last)
                format!(
                    "on the drivable areas measured from the map: {}; in the {} m corridor alone: {}",
                    path.warning.as_deref().unwrap_or("no path"),
                    opts.corridor_m,
                    loose.warning.as_deref().unwrap_or("no path")
                )
            } else {
                format!(
                    "the drivable areas measured from the map have gaps along the route; planned in the {} m corridor alone",
                    opts.corridor_m
                )
            });
            path = loose;
            drivable_segments = 0;
        } else {
            path.warning = Some(format!(
                "on the drivable areas measured from the map: {}; no budget left to try the {} m corridor alone",
                path.warning.as_deref().unwrap_or("no path"),
                opts.corridor_m
            ));
        }
    }
    if path.fallback {
        // the route polyline: nothing kept it anywhere
        drivable_segments = 0;
    }
    if let Some(p) = &opts.png {
        let all = planner::render::instance_footprints(r, ground)?;
        let markers = [(from_t.xy, (20, 170, 40)), (to_t.xy, (220, 30, 30))];
        planner::render::write_map_png(p, &g, &route, &path, &obstacles, &all, &markers)?;
    }
    Ok(PlanAnswer {
        from: from_t,
        to: to_t,
        route,
        path,
        blocking: obstacles.len(),
        drivable_segments,
        timings_ms: [t_route, t0.elapsed().as_secs_f64() * 1e3],
    })
}

/// Plans between two ground points over an Argoverse 2 HD map (`log_map_archive_*.json`,
/// the city frame's x and y in metres): both ends are snapped to the nearest lane segment
/// within `opts.snap_m`, routed along successor links with A*, and refined with OMPL. The map
/// has no objects, so nothing blocks the corridor.
///
/// # Errors
/// The map cannot be read, an end is not a point (`X,Y`), no lane is near an end, no route.
pub fn plan_on_av2(
    map: &std::path::Path,
    from: &str,
    to: &str,
    opts: &PlanOptions,
) -> planner::Result<PlanAnswer> {
    let t0 = Instant::now();
    let (g, _) = planner::RoadGraph::from_av2(map)?;
    if g.edges.is_empty() {
        return Err(planner::Error::Map {
            path: map.to_path_buf(),
            detail: "the Argoverse 2 map has no lane segments to route on".into(),
        });
    }
    let point = |text: &str| -> planner::Result<planner::Target> {
        match text.parse::<Spec>()? {
            Spec::Point(xy) => Ok(planner::Target {
                spec: text.to_string(),
                node: None,
                kind: "point".into(),
                xy,
            }),
            _ => Err(planner::Error::BadSpec {
                spec: text.to_string(),
                detail: "an Argoverse 2 map has no node ids: give X,Y in the map's city frame"
                    .into(),
            }),
        }
    };
    let (from_t, to_t) = (point(from)?, point(to)?);
    let a = planner::snap(&g, from_t.xy, opts.snap_m)?;
    let b = planner::snap(&g, to_t.xy, opts.snap_m)?;
    let route = planner::astar(&g, a, b)?;
    let t_route = t0.elapsed().as_secs_f64() * 1e3;
    let cfg = opts.motion();
    let path = planner::plan_path(&route, &[], &cfg)?;
    if let Some(p) = &opts.png {
        let markers = [(from_t.xy, (20, 170, 40)), (to_t.xy, (220, 30, 30))];
        planner::render::write_map_png(p, &g, &route, &path, &[], &[], &markers)?;
    }
    Ok(PlanAnswer {
        from: from_t,
        to: to_t,
        route,
        path,
        blocking: 0,
        drivable_segments: 0,
        timings_ms: [t_route, t0.elapsed().as_secs_f64() * 1e3],
    })
}

/// How one end of a navigation was resolved.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
#[serde(tag = "by", rename_all = "snake_case")]
pub enum Resolved {
    /// Given as a spec.
    Spec {
        /// The spec.
        spec: String,
    },
    /// Retrieved with `find`: the best instance and its evidence.
    Find {
        /// The words.
        text: String,
        /// The instance.
        result: Box<GraphFound>,
    },
    /// Located with `locate`: the best segment and its evidence.
    Locate {
        /// The words.
        text: String,
        /// The segment.
        result: Box<Located>,
    },
    /// Where the drive the map was built from starts or ends (its first or last frame's
    /// position).
    Drive {
        /// The words.
        text: String,
        /// `start` or `end`.
        end: String,
        /// The position, world frame, metres.
        position: [f64; 3],
    },
}

/// A navigation answer: both ends with how they were resolved, and the plan.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct NavigateAnswer {
    /// The start.
    pub start: Resolved,
    /// The goal.
    pub goal: Resolved,
    /// The route's length: along the lane graph from the start to the goal, metres
    /// (`plan.route.length_m`; `plan.path.length_m` is the smoothed path a robot would drive).
    pub route_length_m: f64,
    /// The route and path.
    pub plan: PlanAnswer,
}

/// A navigation request: free text ("from the bus stop by the crossroads to somewhere I can
/// post a letter") or two ends, each in words or as a spec; an end given on its own wins over
/// the text's.
#[derive(Debug, Clone, PartialEq)]
pub struct NavigateRequest {
    /// "from A to B" (or "to B" with `from` given).
    pub text: Option<String>,
    /// The start, in words or as a spec.
    pub from: Option<String>,
    /// The goal, in words or as a spec.
    pub to: Option<String>,
    /// How words are understood.
    pub parser: ParserKind,
    /// The planner's settings.
    pub options: PlanOptions,
}

/// Navigates: both ends resolved from words or specs ([`resolve_end`]), then [`plan`].
///
/// # Errors
/// [`ToolError::BadArguments`] when an end is missing or cannot be resolved or routed;
/// [`ToolError::Failed`] when the store or a model fails.
pub fn navigate(
    finder: &mut Finder,
    r: &impl GraphRead,
    req: &NavigateRequest,
) -> ToolResult<NavigateAnswer> {
    let words = match &req.text {
        Some(t) => Some(llm_tools::request::parse_route(t)?),
        None => None,
    };
    let from = req
        .from
        .clone()
        .or_else(|| words.as_ref().and_then(|w| w.from.clone()));
    let to = req
        .to
        .clone()
        .or_else(|| words.as_ref().map(|w| w.to.clone()));
    let (Some(from), Some(to)) = (from, to) else {
        return Err(ToolError::BadArguments(
            "say where to start and where to go: \"from A to B\" in the text, or both ends (from and to; --from and --to on the command line), each in words or as a spec such as lane:ID".into(),
        ));
    };
    // what cannot be resolved or routed comes from the arguments
    let bad = |e: &dyn std::fmt::Display| ToolError::BadArguments(e.to_string());
    let (a, start) = resolve_end(finder, r, &from, req.parser).map_err(|e| bad(&e))?;
    let (b, goal) = resolve_end(finder, r, &to, req.parser).map_err(|e| bad(&e))?;
    let plan = plan(r, &a, &b, &req.options).map_err(|e| match e {
        planner::Error::Render(_) => ToolError::Failed(e.to_string()),
        other => bad(&other),
    })?;
    Ok(NavigateAnswer {
        start,
        goal,
        route_length_m: plan.route.length_m,
        plan,
    })
}

/// Whether `text` is only a place on the road network ("the crossroads", "a T-junction") or
/// a description of the surroundings ("I'm at ..."): then it is located, not found.
fn is_place(text: &str) -> bool {
    let t = text.trim().to_lowercase();
    if t.starts_with("i'm ") || t.starts_with("i am ") || t.starts_with("im ") {
        return true;
    }
    let (seg, rest) = llm_tools::request::take_segment(&t);
    let rest = rest.trim();
    seg.is_some() && matches!(rest, "" | "the" | "a" | "an")
}

/// How many of `find`'s best candidates an object said with its segment ("the post box in
/// segment 12") is looked for among.
const IN_SEGMENT_CANDIDATES: usize = 200;

/// Resolves one end: a spec as given or in words ("segment 12", "lane node 7", "object #86":
/// [`llm_tools::request::spec_in_words`]), an end of the drive
/// ([`llm_tools::request::drive_end_of`]) as its frame's position, an object with its segment
/// by id ("the post box in segment 12": `find`'s best in that segment of the kind said,
/// [`llm_tools::kinds::first_of_kind`]), a place or
/// description by `locate`, anything else by graph-aware `find` (its best instance).
///
/// # Errors
/// Nothing found, or the operations fail.
pub fn resolve_end(
    finder: &mut Finder,
    r: &impl GraphRead,
    text: &str,
    parser: ParserKind,
) -> llm_tools::Result<(Spec, Resolved)> {
    if let Ok(spec) = text.trim().parse::<Spec>() {
        return Ok((
            spec,
            Resolved::Spec {
                spec: text.trim().to_string(),
            },
        ));
    }
    if let Some(words) = llm_tools::request::spec_in_words(text)
        && let Ok(spec) = words.parse::<Spec>()
    {
        return Ok((spec, Resolved::Spec { spec: words }));
    }
    if let Some(end) = llm_tools::request::drive_end_of(text) {
        let (first, last) = scene::records::drive_ends(r)?.ok_or_else(|| {
            llm_tools::Error::Invalid(format!(
                "{text:?} names an end of the drive, but the map has no frames with poses"
            ))
        })?;
        let position = if end == "start" { first } else { last };
        let xy = scene::records::ground_frame(r)?.ground(position);
        return Ok((
            Spec::Point(xy),
            Resolved::Drive {
                text: text.to_string(),
                end: end.to_string(),
                position,
            },
        ));
    }
    // "the post box in segment 12": the best match among the segment's objects
    if let Some((object, segment)) = llm_tools::request::object_in_segment(text) {
        let a = finder.find(
            r,
            &FindRequest {
                text: object.clone(),
                k: IN_SEGMENT_CANDIDATES,
                class: None,
                near: None,
                ranking: Ranking::Graph {
                    parser,
                    rerank: false,
                },
                rerank_n: 10,
            },
        )?;
        let weak = finder.weak_match_cosine();
        let there: Vec<GraphFound> = a
            .results
            .into_iter()
            .filter(|f| f.cosine >= weak && f.segment.as_ref().is_some_and(|s| s.0 == segment))
            .collect();
        let labels: Vec<&str> = there.iter().map(|f| f.label.as_str()).collect();
        let best = llm_tools::kinds::first_of_kind(&object, &labels)
            .map(|i| there[i].clone())
            .or_else(|| there.into_iter().next())
            .ok_or_else(|| {
                llm_tools::Error::Invalid(format!(
                    "nothing in segment {segment} matches {object:?} well"
                ))
            })?;
        return Ok((
            Spec::Instance(best.id),
            Resolved::Find {
                text: text.to_string(),
                result: Box::new(best),
            },
        ));
    }
    if is_place(text) {
        let a = finder.locate(
            r,
            &LocateRequest {
                text: text.to_string(),
                k: 1,
                parser,
            },
        )?;
        let best = a.results.into_iter().next().ok_or_else(|| {
            llm_tools::Error::Invalid(format!("no road segment in the map fits {text:?}"))
        })?;
        return Ok((
            Spec::Segment(best.segment),
            Resolved::Locate {
                text: text.to_string(),
                result: Box::new(best),
            },
        ));
    }
    let a = finder.find(
        r,
        &FindRequest {
            text: text.to_string(),
            k: 1,
            class: None,
            near: None,
            ranking: Ranking::Graph {
                parser,
                rerank: false,
            },
            rerank_n: 10,
        },
    )?;
    let best =
        a.results.into_iter().next().ok_or_else(|| {
            llm_tools::Error::Invalid(format!("nothing in the map matches {text:?}"))
        })?;
    let weak = finder.weak_match_cosine();
    if best.cosine < weak {
        return Err(llm_tools::Error::Invalid(format!(
            "nothing in the map matches {text:?} well: the closest is instance {} (\"{}\", cosine {:.2} < {weak})",
            best.id, best.caption, best.cosine
        )));
    }
    Ok((
        Spec::Instance(best.id),
        Resolved::Find {
            text: text.to_string(),
            result: Box::new(best),
        },
    ))
}
