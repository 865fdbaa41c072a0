//! Motion planning: a kinematically feasible SE(2) path for a car-like robot along a route,
//! planned by OMPL (RRT* in a Reeds-Shepp or Dubins space) with a Rust validity checker:
//! inside the corridor around the route (parry2d distance to the route polyline), clear of
//! blocking boxes, inside the planning bounds.
//!
//! Long routes are planned in consecutive chunks of about `chunk_m` metres between waypoints
//! on the route; the pieces join at the waypoints with matching headings. Each chunk is first
//! followed deterministically (poses along the route joined by the car's curves, checked
//! state by state; a few milliseconds), and planned with RRT* in its share of the time budget
//! only where that fails. When OMPL finds no solution in time, the route polyline itself is
//! returned, marked as a fallback, with a warning.

use parry2d::math::{Pose, Vector};
use parry2d::query::PointQuery;
use parry2d::shape::{Cuboid, Polyline};

use crate::error::{Error, Result};
use crate::ffi::{Checker, bridge};
use crate::graph::{dist, point_at, polyline_length};
use crate::route::Route;
use scene::OrientedBox;
use scene::area::{Drivable, DrivableIndex};
use scene::records::{InstanceRecord, SegmentRecord};

/// The drivable areas of the store's segments (`Segment.polygon`), in node order; segments
/// without one are left out.
///
/// # Errors
/// The store fails.
pub fn drivable_of_store(
    r: &impl graphstore::GraphRead,
    ground: scene::GroundFrame,
) -> Result<Vec<Drivable>> {
    let mut out = Vec::new();
    for id in r.nodes_with_label(scene::label::SEGMENT)? {
        out.extend(SegmentRecord::read(r, id)?.and_then(|s| s.drivable(ground)));
    }
    Ok(out)
}

/// Motion-planning parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct MotionConfig {
    /// Minimum turning radius.
    pub turning_radius_m: f64,
    /// Half-width of the corridor around the route.
    pub corridor_half_width_m: f64,
    /// Total time budget for OMPL.
    pub budget_ms: f64,
    /// Length of one planning chunk.
    pub chunk_m: f64,
    /// Reeds-Shepp (reverse allowed) instead of Dubins.
    pub reverse_allowed: bool,
    /// Clearance kept from blocking boxes.
    pub obstacle_margin_m: f64,
    /// Spacing of the returned poses.
    pub sample_step_m: f64,
    /// RRT* stops optimizing a chunk once its path is at most this many times the route's
    /// length for that chunk (or when the chunk's share of the budget is spent).
    pub good_enough_ratio: f64,
    /// OMPL's random seed (set once per process).
    pub seed: u32,
    /// With drivable areas given ([`plan_path_on`]), a state may be this far outside them
    /// (the measured areas have small gaps where the LiDAR saw no road).
    pub drivable_tolerance_m: f64,
    /// How each chunk is refined: followed deterministically, planned with RRT*, or both
    /// (the default: RRT* only where following fails).
    pub refinement: Refinement,
}

/// How [`plan_path_on`] refines each chunk of a route.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Refinement {
    /// Follow the route deterministically: poses every [`FOLLOW_STEP_M`] along it and at
    /// [`FOLLOW_OFFSETS_M`] to either side, joined by the car's curves (OMPL's Reeds-Shepp or
    /// Dubins) from each pose to one at the farthest station within [`FOLLOW_REACH_M`] that a
    /// curve reaches through valid states, depth first (a dead end is backed out of; a few
    /// milliseconds a chunk, at most its share of the budget); RRT* plans only the chunks
    /// this cannot (a lane blocked wall to wall, a turn tighter than the radius allows within
    /// the corridor), sharing what is left of the budget by length.
    #[default]
    FollowThenRrt,
    /// Follow only: a chunk that cannot be followed makes the route fall back at once,
    /// without spending the budget (a quick test of whether the valid region is continuous
    /// along the route).
    FollowOnly,
    /// RRT* on every chunk, each with its share of the budget by length.
    RrtOnly,
}

/// Spacing of the route poses the deterministic pass follows.
pub const FOLLOW_STEP_M: f64 = 2.0;
/// How far along the route one curve of the deterministic pass may reach.
pub const FOLLOW_REACH_M: f64 = 30.0;
/// Lateral offsets (left positive) of the deterministic pass's poses beside the route, in
/// the order they are tried; only those at least 1 m inside the corridor are used.
pub const FOLLOW_OFFSETS_M: [f64; 4] = [-1.5, 1.5, -3.0, 3.0];

impl Default for MotionConfig {
    fn default() -> Self {
        MotionConfig {
            turning_radius_m: 5.0,
            corridor_half_width_m: 6.0,
            budget_ms: 200.0,
            chunk_m: 100.0,
            reverse_allowed: true,
            obstacle_margin_m: 0.3,
            sample_step_m: 0.5,
            good_enough_ratio: 1.25,
            seed: 42,
            drivable_tolerance_m: 0.5,
            refinement: Refinement::FollowThenRrt,
        }
    }
}

/// A box on the ground plane that the path must avoid: an instance's oriented footprint.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Obstacle {
    /// Min corner of the footprint's bounds, ground coordinates.
    pub min: [f64; 2],
    /// Max corner of the footprint's bounds.
    pub max: [f64; 2],
    /// The footprint.
    pub footprint: OrientedBox,
}

impl Obstacle {
    /// The obstacle of an oriented footprint.
    pub fn oriented(footprint: OrientedBox) -> Obstacle {
        let [min, max] = scene::geom::bounds(footprint.corners());
        Obstacle {
            min,
            max,
            footprint,
        }
    }

    /// An axis-aligned obstacle `min`..`max` (ground coordinates).
    pub fn axis_aligned(min: [f64; 2], max: [f64; 2]) -> Obstacle {
        Obstacle {
            min,
            max,
            footprint: OrientedBox::from_ground_bounds(min, max, [0.0, 0.0]),
        }
    }
}

/// A planned path.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct MotionPath {
    /// Poses (x, y, yaw in radians).
    pub poses: Vec<[f64; 3]>,
    /// Path length.
    pub length_m: f64,
    /// Which planner produced it (`fallback:route` when OMPL did not).
    pub planner: String,
    /// Whether this is the route polyline because OMPL found nothing in time.
    pub fallback: bool,
    /// Why, when it is a fallback.
    pub warning: Option<String>,
}

fn v(p: [f64; 2]) -> Vector {
    Vector::new(p[0] as f32, p[1] as f32)
}

/// The state validity test, shared by OMPL's checker and by tests.
pub struct Validity {
    corridor: Polyline,
    half_width_m: f64,
    boxes: Vec<(Cuboid, Pose)>,
    bounds: ([f64; 2], [f64; 2]),
    drivable: DrivableIndex,
    drivable_tolerance_m: f64,
}

impl std::fmt::Debug for Validity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Validity")
            .field("boxes", &self.boxes.len())
            .finish_non_exhaustive()
    }
}

impl Validity {
    /// A corridor of `half_width_m` around `route`, minus `obstacles` grown by `margin_m`.
    pub fn new(
        route: &[[f64; 2]],
        half_width_m: f64,
        obstacles: &[Obstacle],
        margin_m: f64,
    ) -> Validity {
        let [lo, hi] = scene::geom::bounds(route);
        let boxes = obstacles
            .iter()
            .map(|o| {
                let f = &o.footprint;
                let h = [f.half_extents[0] + margin_m, f.half_extents[1] + margin_m];
                (Cuboid::new(v(h)), Pose::new(v(f.center), f.yaw_rad as f32))
            })
            .collect();
        Validity {
            corridor: Polyline::new(route.iter().map(|p| v(*p)).collect(), None),
            half_width_m,
            boxes,
            bounds: (
                [lo[0] - half_width_m, lo[1] - half_width_m],
                [hi[0] + half_width_m, hi[1] + half_width_m],
            ),
            drivable: DrivableIndex::default(),
            drivable_tolerance_m: 0.0,
        }
    }

    /// The same test, also requiring a state to lie within `tolerance_m` of one of the
    /// `drivable` areas (the segments' road areas measured from the map, their interiors
    /// disjoint).
    pub fn within(mut self, drivable: &[Drivable], tolerance_m: f64) -> Validity {
        self.drivable = DrivableIndex::new(drivable);
        self.drivable_tolerance_m = tolerance_m;
        self
    }

    /// The bounds `[min, max]` of the corridor: the route's, grown by the half-width.
    pub fn bounds(&self) -> [[f64; 2]; 2] {
        [self.bounds.0, self.bounds.1]
    }

    /// Distance from `p` to the route's centreline.
    pub fn corridor_distance(&self, p: [f64; 2]) -> f64 {
        f64::from(self.corridor.distance_to_local_point(v(p), false))
    }

    /// Whether a position is a valid state.
    pub fn is_valid(&self, p: [f64; 2]) -> bool {
        let (lo, hi) = self.bounds;
        if !(p[0].is_finite() && p[1].is_finite())
            || p[0] < lo[0]
            || p[1] < lo[1]
            || p[0] > hi[0]
            || p[1] > hi[1]
        {
            return false;
        }
        if self.corridor_distance(p) > self.half_width_m {
            return false;
        }
        if !self.drivable.is_empty() && !self.drivable.within(p, self.drivable_tolerance_m) {
            return false;
        }
        !self
            .boxes
            .iter()
            .any(|(b, pose)| b.contains_point(pose, v(p)))
    }
}

/// Spacing of OMPL's validity checks along a motion.
const CHECK_STEP_M: f64 = 0.5;

fn heading(poly: &[[f64; 2]], s: f64) -> f64 {
    let total = polyline_length(poly);
    let a = point_at(poly, (s - 1.0).max(0.0));
    let b = point_at(poly, (s + 1.0).min(total));
    // OMPL's SO(2) range is [-pi, pi): atan2 may return pi itself
    let yaw = (b[1] - a[1]).atan2(b[0] - a[0]);
    (yaw + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

fn fallback(route: &Route, reason: String) -> MotionPath {
    let poly = &route.polyline;
    let total = polyline_length(poly);
    let mut poses = Vec::new();
    let mut s = 0.0;
    while s < total {
        let p = point_at(poly, s);
        poses.push([p[0], p[1], heading(poly, s)]);
        s += 1.0;
    }
    let end = *poly.last().expect("route polyline");
    poses.push([end[0], end[1], heading(poly, total)]);
    MotionPath {
        poses,
        length_m: total,
        planner: "fallback:route".into(),
        fallback: true,
        warning: Some(reason),
    }
}

/// Plans a drivable path along `route`, avoiding `obstacles`.
pub fn plan_path(route: &Route, obstacles: &[Obstacle], cfg: &MotionConfig) -> Result<MotionPath> {
    plan_path_on(route, obstacles, &[], cfg)
}

/// [`plan_path`], keeping every state on the `drivable` areas (within
/// `cfg.drivable_tolerance_m`); none given: the corridor alone.
pub fn plan_path_on(
    route: &Route,
    obstacles: &[Obstacle],
    drivable: &[Drivable],
    cfg: &MotionConfig,
) -> Result<MotionPath> {
    if !(cfg.turning_radius_m > 0.0
        && cfg.corridor_half_width_m > 0.0
        && cfg.chunk_m > 0.0
        && cfg.sample_step_m > 0.0)
    {
        return Err(Error::Invalid(
            "turning radius, corridor width, chunk and sample step must be positive".into(),
        ));
    }
    if !(cfg.budget_ms >= 0.0 && cfg.budget_ms.is_finite()) {
        return Err(Error::Invalid(format!(
            "budget {} ms must be a non-negative number",
            cfg.budget_ms
        )));
    }
    let poly = &route.polyline;
    let total = polyline_length(poly);
    if cfg.budget_ms == 0.0 {
        return Ok(fallback(
            route,
            "no time budget for OMPL (--budget-ms 0); returning the route polyline".into(),
        ));
    }
    if total < 1e-6 {
        let p = poly[0];
        return Ok(MotionPath {
            poses: vec![[p[0], p[1], 0.0]],
            length_m: 0.0,
            planner: "none (start is the goal)".into(),
            fallback: false,
            warning: None,
        });
    }
    // OMPL checks states every CHECK_STEP_M along a motion; a point between two checks is at
    // most half a step (plus a negligible arc sagitta) from a checked one, so checking against a
    // corridor narrowed, and obstacles grown, by that much keeps every point of the path valid
    let slack = CHECK_STEP_M / 2.0 + 0.01;
    if cfg.corridor_half_width_m <= slack {
        return Err(Error::Invalid(format!(
            "the corridor half-width must exceed {slack} m"
        )));
    }
    if !(cfg.drivable_tolerance_m.is_finite() && cfg.drivable_tolerance_m >= 0.0) {
        return Err(Error::Invalid(format!(
            "drivable tolerance {} m must be a non-negative number",
            cfg.drivable_tolerance_m
        )));
    }
    let validity = std::rc::Rc::new(
        Validity::new(
            poly,
            cfg.corridor_half_width_m - slack,
            obstacles,
            cfg.obstacle_margin_m + slack,
        )
        // the tolerance shrinks by the same slack, as far as it goes
        .within(drivable, (cfg.drivable_tolerance_m - slack).max(0.0)),
    );
    // waypoints every chunk_m, moved forward along the route while they are not valid states
    let n_chunks = (total / cfg.chunk_m).ceil().max(1.0) as usize;
    let mut marks = vec![0.0];
    for k in 1..n_chunks {
        let mut s = total * k as f64 / n_chunks as f64;
        while s < total && !validity.is_valid(point_at(poly, s)) {
            s += 0.5;
        }
        if s < total - 1.0 && s > marks.last().copied().unwrap_or(0.0) + 1.0 {
            marks.push(s);
        }
    }
    marks.push(total);
    for &s in [marks[0], total].iter() {
        if !validity.is_valid(point_at(poly, s)) {
            return Ok(fallback(
                route,
                format!(
                    "the {} of the route is blocked; returning the route polyline",
                    if s == 0.0 { "start" } else { "goal" }
                ),
            ));
        }
    }
    let n_chunks = marks.len() - 1;
    // each chunk's problem: its ends on the route with the route's headings, its bounds
    let requests: Vec<(f64, bridge::PlanRequest)> = marks
        .windows(2)
        .map(|w| {
            let (s0, s1) = (w[0], w[1]);
            let (a, b) = (point_at(poly, s0), point_at(poly, s1));
            let piece = crate::route::sub_polyline(poly, s0, s1);
            let [lo, hi] = scene::geom::bounds(&piece);
            let pad = cfg.corridor_half_width_m;
            let req = bridge::PlanRequest {
                space: bridge::CarSpace {
                    min_x: lo[0] - pad,
                    min_y: lo[1] - pad,
                    max_x: hi[0] + pad,
                    max_y: hi[1] + pad,
                    turning_radius: cfg.turning_radius_m,
                    reverse_allowed: cfg.reverse_allowed,
                    check_step_m: CHECK_STEP_M,
                    sample_step: cfg.sample_step_m,
                    seed: cfg.seed,
                },
                start_x: a[0],
                start_y: a[1],
                start_yaw: heading(poly, s0),
                goal_x: b[0],
                goal_y: b[1],
                goal_yaw: heading(poly, s1),
                budget_secs: 0.0,
                // tight, so consecutive chunks join without a jump
                goal_tolerance: 0.05,
                range: (s1 - s0).clamp(5.0, 25.0),
                cost_threshold: cfg.good_enough_ratio * (s1 - s0),
            };
            (s1 - s0, req)
        })
        .collect();
    let checker = |space: &bridge::CarSpace| {
        let bounds = (space.min_x, space.min_y, space.max_x, space.max_y);
        let val = validity.clone();
        Checker {
            f: Box::new(move |x, y, _yaw| {
                x >= bounds.0
                    && y >= bounds.1
                    && x <= bounds.2
                    && y <= bounds.3
                    && val.is_valid([x, y])
            }),
        }
    };
    let started = std::time::Instant::now();
    // first every chunk deterministically (milliseconds), then RRT* on the chunks that failed,
    // the whole budget shared among them by length
    let mut found: Vec<Option<bridge::PlanResult>> = (0..n_chunks).map(|_| None).collect();
    let mut follow_name = String::new();
    if cfg.refinement != Refinement::RrtOnly {
        for (k, w) in marks.windows(2).enumerate() {
            let req = &requests[k].1;
            // at most the chunk's share of the whole budget, by length
            let limit_ms = cfg.budget_ms * requests[k].0 / total.max(1e-9);
            let follow = follow_request(
                poly,
                w[0],
                w[1],
                cfg.corridor_half_width_m,
                limit_ms,
                &req.space,
            );
            let res = bridge::follow_se2(&follow, &checker(&req.space));
            follow_name.clone_from(&res.planner);
            if res.solved {
                found[k] = Some(res);
            }
        }
    }
    let followed = found.iter().flatten().count();
    if cfg.refinement == Refinement::FollowOnly && followed < n_chunks {
        let k = found.iter().position(Option::is_none).unwrap_or(0);
        return Ok(fallback(
            route,
            format!(
                "the route could not be followed at chunk {} of {} ({followed} of {n_chunks} followed); returning the route polyline",
                k + 1,
                n_chunks
            ),
        ));
    }
    let mut rrt_name = String::new();
    let mut left_len: f64 = (0..n_chunks)
        .filter(|&k| found[k].is_none())
        .map(|k| requests[k].0)
        .sum();
    for k in 0..n_chunks {
        if found[k].is_some() {
            continue;
        }
        let (len, req) = &requests[k];
        let left_ms = cfg.budget_ms - started.elapsed().as_secs_f64() * 1e3;
        // this chunk's share of what is left, by length
        let share = left_ms * len / left_len.max(1e-9);
        left_len -= len;
        if share <= 0.0 {
            return Ok(fallback(
                route,
                format!(
                    "OMPL ran out of the {} ms budget at chunk {} of {}; returning the route polyline",
                    cfg.budget_ms,
                    k + 1,
                    n_chunks
                ),
            ));
        }
        let req = bridge::PlanRequest {
            budget_secs: share / 1e3,
            ..*req
        };
        let res = bridge::plan_se2(&req, &checker(&req.space));
        if !res.solved {
            return Ok(fallback(
                route,
                format!(
                    "OMPL found no solution for chunk {} of {} within {share:.0} ms ({}; {followed} of {n_chunks} chunks followed the route); returning the route polyline",
                    k + 1,
                    n_chunks,
                    res.planner
                ),
            ));
        }
        rrt_name.clone_from(&res.planner);
        found[k] = Some(res);
    }
    let by_rrt = n_chunks - followed;
    let mut poses: Vec<[f64; 3]> = Vec::new();
    let mut length = 0.0;
    for res in found.iter().flatten() {
        length += res.length;
        for t in res.poses.chunks_exact(3) {
            let p = [t[0], t[1], t[2]];
            if poses
                .last()
                .is_none_or(|l| dist([l[0], l[1]], [p[0], p[1]]) > 1e-6)
            {
                poses.push(p);
            }
        }
    }
    Ok(MotionPath {
        poses,
        length_m: length,
        planner: match (followed, by_rrt) {
            (_, 0) => format!("{follow_name} ({followed} chunk{})", plural(followed)),
            (0, _) => format!("{rrt_name} ({by_rrt} chunk{}, simplified)", plural(by_rrt)),
            _ => format!(
                "{follow_name} ({followed} chunk{}) + {rrt_name} ({by_rrt} chunk{}, simplified)",
                plural(followed),
                plural(by_rrt)
            ),
        },
        fallback: false,
        warning: None,
    })
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// The deterministic pass's request for the chunk `s0..s1` of `poly`: stations every
/// [`FOLLOW_STEP_M`] (the chunk's ends exactly), at each the route's pose and its lateral
/// offsets within `half_width_m - 1`, in the RRT* request's car `space`; at most
/// `limit_ms` of search.
fn follow_request(
    poly: &[[f64; 2]],
    s0: f64,
    s1: f64,
    half_width_m: f64,
    limit_ms: f64,
    space: &bridge::CarSpace,
) -> bridge::FollowRequest {
    let n = ((s1 - s0) / FOLLOW_STEP_M).ceil().max(1.0) as usize;
    let offsets: Vec<f64> = std::iter::once(0.0)
        .chain(
            FOLLOW_OFFSETS_M
                .into_iter()
                .filter(|o| o.abs() <= half_width_m - 1.0),
        )
        .collect();
    let mut poses = Vec::with_capacity(3 * (n + 1) * offsets.len());
    for i in 0..=n {
        let s = s0 + (s1 - s0) * i as f64 / n as f64;
        let p = point_at(poly, s);
        let h = heading(poly, s);
        for o in &offsets {
            poses.extend([p[0] - o * h.sin(), p[1] + o * h.cos(), h]);
        }
    }
    bridge::FollowRequest {
        space: *space,
        poses,
        lanes: offsets.len() as u32,
        limit_secs: limit_ms.max(0.0) / 1e3,
        max_skip: (FOLLOW_REACH_M / ((s1 - s0) / n as f64)).floor().max(1.0) as u32,
    }
}

/// Consecutive pieces of `poly` of about `length_m` each (sharing their ends), every vertex
/// in at least one.
fn route_pieces(poly: &[[f64; 2]], length_m: f64) -> Vec<&[[f64; 2]]> {
    let mut out = Vec::new();
    let (mut start, mut len) = (0, 0.0);
    for i in 1..poly.len() {
        len += dist(poly[i - 1], poly[i]);
        if len >= length_m || i + 1 == poly.len() {
            out.push(&poly[start..=i]);
            (start, len) = (i, 0.0);
        }
    }
    if out.is_empty() {
        out.push(poly);
    }
    out
}

/// How far [`blocking_instances`] looks beyond the corridor for instances whose oriented
/// box stands out of their points' axis-aligned box (what the spatial index holds), metres.
pub const OBB_OVERHANG_M: f64 = 20.0;

/// Classes of instances that are ground surfaces; they never block a path.
pub const GROUND_CLASSES: [&str; 5] = ["road", "parking", "sidewalk", "other-ground", "terrain"];

/// Ground-plane boxes of the store's `Instance` nodes that reach into the corridor of
/// `half_width_m` around the route (they block the road), sorted by position.
pub fn blocking_instances(
    r: &impl graphstore::GraphRead,
    ground: scene::GroundFrame,
    route: &Route,
    half_width_m: f64,
) -> Result<Vec<Obstacle>> {
    let corridor = Validity::new(&route.polyline, half_width_m, &[], 0.0);
    // candidates from the instances' spatial index: boxes meeting the padded bounds of
    // consecutive ~50 m pieces of the route; most of a city is nowhere near the route. The
    // index holds the points' axis-aligned boxes, and an oriented box's corners can stand
    // out of that (the box of an L-shaped building: by up to 9.8 m on the city, 1 m or more
    // for a fifth of its instances), so the pad is the corridor and OBB_OVERHANG_M
    let pad = half_width_m + OBB_OVERHANG_M;
    let mut candidates = std::collections::BTreeSet::new();
    for piece in route_pieces(&route.polyline, 50.0) {
        let [lo, hi] = scene::geom::bounds(piece);
        let (a, b) = (
            ground.world([lo[0] - pad, lo[1] - pad], -1e6),
            ground.world([hi[0] + pad, hi[1] + pad], 1e6),
        );
        let (min, max) = (
            [a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2])],
            [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])],
        );
        candidates.extend(r.spatial_in_box(scene::index::INSTANCE_SPACE, min, max)?);
    }
    blocking_among(r, ground, &corridor, half_width_m, candidates)
}

/// The obstacles among instance nodes `ids` that reach into `corridor` (see
/// [`blocking_instances`]), sorted by position.
fn blocking_among(
    r: &impl graphstore::GraphRead,
    ground: scene::GroundFrame,
    corridor: &Validity,
    half_width_m: f64,
    ids: impl IntoIterator<Item = u64>,
) -> Result<Vec<Obstacle>> {
    let mut out = Vec::new();
    for id in ids {
        let Some(inst) = InstanceRecord::read(r, id)? else {
            continue;
        };
        // ground surfaces are driven over, not around; background classes fused per ground
        // tile (`tile` set) have the box of a 20 m tile's worth of points, not an obstacle's
        if GROUND_CLASSES.contains(&inst.semantic_class.as_str()) || inst.tile.is_some() {
            continue;
        }
        let (lo, hi) = inst.bbox;
        let o = match inst.obb {
            Some(b) => Obstacle::oriented(b),
            None => {
                let (a, b) = (ground.ground(lo), ground.ground(hi));
                Obstacle::axis_aligned(
                    [a[0].min(b[0]), a[1].min(b[1])],
                    [a[0].max(b[0]), a[1].max(b[1])],
                )
            }
        };
        // a box reaches into the corridor if its nearest point to the route is inside it
        let f = &o.footprint;
        let c = f.center;
        let half_diag = f.half_extents[0].hypot(f.half_extents[1]);
        if corridor.corridor_distance(c) - half_diag <= half_width_m {
            let corners = f.corners();
            if corners
                .iter()
                .chain([&c])
                .any(|p| corridor.corridor_distance(*p) <= half_width_m)
            {
                out.push(o);
            }
        }
    }
    out.sort_by(|a, b| {
        a.min[0]
            .total_cmp(&b.min[0])
            .then(a.min[1].total_cmp(&b.min[1]))
    });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use graphstore::{GraphRead, Store};

    /// The spatial index prunes nothing that reaches the corridor: the same obstacles as
    /// checking every instance, for boxes of every size and orientation around a winding
    /// route, in both ground frames.
    #[test]
    fn blocking_instances_by_index_equal_a_full_scan() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for ground in [scene::GroundFrame::KittiCam, scene::GroundFrame::Enu] {
            let dir = tempfile::tempdir().unwrap();
            let store = Store::create(dir.path().join("m.og")).unwrap();
            store.set_schema(scene::opengraph_schema()).unwrap();
            let polyline: Vec<[f64; 2]> = (0..40)
                .map(|i| {
                    let t = f64::from(i) * 9.0;
                    [t, 40.0 * (t / 80.0).sin()]
                })
                .collect();
            let route = Route {
                nodes: vec![],
                length_m: polyline_length(&polyline),
                polyline,
            };
            store
                .write(|tx| {
                    for k in 0..600 {
                        let c = [rnd() * 400.0 - 20.0, rnd() * 140.0 - 70.0];
                        let (l, w) = (0.2 + rnd() * 8.0 * rnd(), 0.2 + rnd() * 3.0);
                        let obb = OrientedBox {
                            center: c,
                            half_extents: [l.max(w), l.min(w)],
                            yaw_rad: (rnd() - 0.5) * std::f64::consts::PI,
                            height_m: [0.0, 2.0],
                        };
                        // the points' box inside the oriented one (as for an L-shaped
                        // building), so corners stand out of it by up to 19 m
                        let [mut lo, mut hi] = scene::geom::bounds(obb.corners());
                        let shrink = (k % 4 == 0) as u8 as f64 * rnd() * 0.9;
                        for a in 0..2 {
                            let m = (hi[a] - lo[a]) * shrink / 2.0;
                            (lo[a], hi[a]) = (lo[a] + m.min(9.5), hi[a] - m.min(9.5));
                        }
                        let (a, b) = (ground.world(lo, 0.0), ground.world(hi, 2.0));
                        let bbox = (
                            [a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2])],
                            [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])],
                        );
                        InstanceRecord {
                            instance_id: k,
                            caption: "a box".into(),
                            semantic_class: "car".into(),
                            label: None,
                            colour: None,
                            material: None,
                            centroid: ground.world(c, 1.0),
                            bbox,
                            captions: None,
                            feature: None,
                            point_count: None,
                            detection_count: None,
                            first_frame: None,
                            last_frame: None,
                            source: None,
                            detection_feature: None,
                            obb: (k % 3 != 0).then_some(obb),
                            tile: None,
                        }
                        .create(tx)?;
                    }
                    Ok(())
                })
                .unwrap();
            let r = store.read().unwrap();
            for half_width_m in [2.0, 6.0, 15.0] {
                let by_index = blocking_instances(&r, ground, &route, half_width_m).unwrap();
                let corridor = Validity::new(&route.polyline, half_width_m, &[], 0.0);
                let all = r.nodes_with_label(scene::label::INSTANCE).unwrap();
                let scan = blocking_among(&r, ground, &corridor, half_width_m, all).unwrap();
                assert!(!scan.is_empty() && scan.len() < 600, "{}", scan.len());
                assert_eq!(by_index, scan, "{ground:?}, {half_width_m} m");
            }
        }
    }
}
