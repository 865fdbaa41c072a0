//! Writes the hierarchy (environment, segments, lane graph, instance links) into a store, in
//! one transaction. Re-running replaces the previous hierarchy and geometric relations.

use std::collections::BTreeMap;

use graphstore::{GraphRead, Store, Value, WriteTxn};

use super::drivable::DrivableConfig;
use super::lanes::{LaneConfig, LaneGraph, LaneNodeKind, extract_lanes};
use super::relations::{RelationConfig, infer_relations, read_instance_box};
use super::segments::{SegmentConfig, Segments, build_segments};
use crate::cluster::Grid2;
use crate::error::{Error, Result};
use scene::GroundFrame;
use scene::area::{Drivable, SegmentArea};
use scene::records::{
    EnvironmentRecord, GEOMETRIC, InSegmentRecord, LaneEdgeRecord, LaneNodeRecord, RelationRecord,
    SegmentRecord, SegmentShape,
};

/// All hierarchy parameters.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HierarchyConfig {
    /// Lane graph.
    pub lanes: LaneConfig,
    /// Segments.
    pub segments: SegmentConfig,
    /// Instance relations.
    pub relations: RelationConfig,
    /// Road areas measured from the map.
    pub drivable: DrivableConfig,
}

impl HierarchyConfig {
    /// Checks every number (finite, in range) so that a bad `[hierarchy.*]` value is reported
    /// when the configuration is read, before any mapping; the message names the key.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the first bad key.
    pub fn validate(&self) -> Result<()> {
        let l = &self.lanes;
        let s = &self.segments;
        let r = &self.relations;
        let positive = [
            ("lanes.radius_m", l.radius_m),
            ("lanes.disfluency_rad", l.disfluency_rad),
            ("lanes.dbscan_eps_m", l.dbscan_eps_m),
            ("lanes.association_m", l.association_m),
            ("lanes.resample_m", l.resample_m),
            ("lanes.edge_merge_m", l.edge_merge_m),
            ("segments.junction_radius_m", s.junction_radius_m),
            ("segments.road_half_width_m", s.road_half_width_m),
            ("relations.candidate_m", r.candidate_m),
            ("relations.near_m", r.near_m),
            ("relations.inside_fraction", r.inside_fraction),
            ("drivable.cell_m", self.drivable.cell_m),
            ("drivable.alpha_m", self.drivable.alpha_m),
        ];
        for (k, v) in positive {
            if !(v.is_finite() && v > 0.0 && v < 1e6) {
                return Err(Error::Invalid(format!(
                    "[hierarchy] {k} must be a positive number below 1e6, got {v}"
                )));
            }
        }
        for (k, v) in [
            ("relations.next_to_m", r.next_to_m),
            ("relations.on_tolerance_m", r.on_tolerance_m),
            ("drivable.max_gap_m", self.drivable.max_gap_m),
        ] {
            if !(v.is_finite() && (0.0..1e6).contains(&v)) {
                return Err(Error::Invalid(format!(
                    "[hierarchy] {k} must be a non-negative number below 1e6, got {v}"
                )));
            }
        }
        for (k, v) in [
            ("lanes.l_turn_min_deg", l.l_turn_min_deg),
            ("lanes.l_turn_max_deg", l.l_turn_max_deg),
            ("lanes.way_merge_deg", l.way_merge_deg),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 180.0) {
                return Err(Error::Invalid(format!(
                    "[hierarchy] {k} must be an angle in (0, 180] degrees, got {v}"
                )));
            }
        }
        let d = &self.drivable;
        if d.enabled && d.classes.is_empty() {
            return Err(Error::Invalid(
                "[hierarchy.drivable] classes is empty: name the drivable classes (road, parking) or set enabled = false".into(),
            ));
        }
        if let Some(c) = d
            .classes
            .iter()
            .find(|c| scene::classes::class_id(c).is_none())
        {
            return Err(Error::Invalid(format!(
                "[hierarchy.drivable] classes: {c:?} is not one of the 19 classes ({})",
                scene::classes::CLASSES.join(", ")
            )));
        }
        if l.l_turn_min_deg >= l.l_turn_max_deg {
            return Err(Error::Invalid(format!(
                "[hierarchy] lanes.l_turn_min_deg ({}) must be below lanes.l_turn_max_deg ({})",
                l.l_turn_min_deg, l.l_turn_max_deg
            )));
        }
        if let Some(g) = l.gap_m
            && !(g.is_finite() && g > 0.0 && g < 1e6)
        {
            return Err(Error::Invalid(format!(
                "[hierarchy] lanes.gap_m must be a positive number below 1e6, got {g}"
            )));
        }
        if l.dbscan_min_samples == 0 {
            return Err(Error::Invalid(
                "[hierarchy] lanes.dbscan_min_samples must be at least 1".into(),
            ));
        }
        if r.inside_fraction > 1.0 {
            return Err(Error::Invalid(format!(
                "[hierarchy] relations.inside_fraction must be at most 1, got {}",
                r.inside_fraction
            )));
        }
        if r.next_to_m > r.near_m {
            return Err(Error::Invalid(format!(
                "[hierarchy] relations.next_to_m ({}) must not exceed relations.near_m ({})",
                r.next_to_m, r.near_m
            )));
        }
        Ok(())
    }
}

/// What was written.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct HierarchyReport {
    /// Lane nodes per kind.
    pub lane_nodes: BTreeMap<String, usize>,
    /// Lane edges.
    pub lane_edges: usize,
    /// Gaps in the recording where the trajectory was split (no lane edge crosses one).
    pub trajectory_gaps: Vec<crate::hierarchy::lanes::TrajectoryGap>,
    /// Segments per kind.
    pub segments: BTreeMap<String, usize>,
    /// Instances linked to a segment.
    pub instances_linked: usize,
    /// Drivable area measured over all segments, square metres.
    pub drivable_m2: f64,
    /// Segments with a drivable polygon.
    pub drivable_segments: usize,
    /// Geometric relations per label.
    pub relations: BTreeMap<String, usize>,
}

/// The world trajectory, ready for height look-ups.
struct Heights {
    ground: Vec<[f64; 2]>,
    height: Vec<f64>,
    grid: Grid2,
}

const HEIGHT_CELL_M: f64 = 25.0;

impl Heights {
    fn new(traj: &[[f64; 3]], frame: GroundFrame) -> Heights {
        let ground: Vec<[f64; 2]> = traj.iter().map(|p| frame.ground(*p)).collect();
        let height = traj.iter().map(|p| frame.height(*p)).collect();
        let grid = Grid2::new(&ground, HEIGHT_CELL_M);
        Heights {
            ground,
            height,
            grid,
        }
    }

    /// Height of the nearest pose (the sensor height above the world origin).
    fn at(&self, g: [f64; 2]) -> f64 {
        let d2 = |i: usize| (self.ground[i][0] - g[0]).powi(2) + (self.ground[i][1] - g[1]).powi(2);
        let near = self.grid.within(&self.ground, g, HEIGHT_CELL_M);
        let pick =
            |it: &mut dyn Iterator<Item = usize>| it.min_by(|a, b| d2(*a).total_cmp(&d2(*b)));
        let best = pick(&mut near.into_iter()).or_else(|| pick(&mut (0..self.ground.len())));
        best.map_or(0.0, |i| self.height[i])
    }
}

fn world_box(
    frame: GroundFrame,
    lo: [f64; 2],
    hi: [f64; 2],
    h0: f64,
    h1: f64,
) -> ([f64; 3], [f64; 3]) {
    let a = frame.world(lo, h0);
    let b = frame.world(hi, h1);
    let min = [0, 1, 2].map(|i| a[i].min(b[i]));
    let max = [0, 1, 2].map(|i| a[i].max(b[i]));
    (min, max)
}

fn bounds(pts: &[[f64; 2]], pad: f64) -> ([f64; 2], [f64; 2]) {
    let [lo, hi] = scene::geom::bounds(pts);
    ([lo[0] - pad, lo[1] - pad], [hi[0] + pad, hi[1] + pad])
}

/// Extracts the lane graph and segments from `traj` (world positions, one per pose) and
/// writes the environment, segment and lane layers, and links existing `Instance` nodes
/// (`IN_SEGMENT`, geometric `RELATED`). Returns what was written.
pub fn build_hierarchy(
    store: &Store,
    traj: &[[f64; 3]],
    frame: GroundFrame,
    environment: &str,
    cfg: &HierarchyConfig,
) -> Result<(LaneGraph, Segments, HierarchyReport)> {
    let ground: Vec<[f64; 2]> = traj.iter().map(|p| frame.ground(*p)).collect();
    let lanes = extract_lanes(&ground, &cfg.lanes)?;
    let segs = build_segments(&lanes, &cfg.segments);
    let heights = Heights::new(traj, frame);
    let report = store.write(|tx| {
        write_all(tx, &lanes, &segs, &heights, frame, environment, cfg).map_err(into_store)
    })?;
    Ok((lanes, segs, report))
}

/// A drivable area's rings as world points (`Segment.polygon`), lifted by `world`.
pub fn polygon_points(area: &Drivable, world: impl Fn([f64; 2]) -> [f64; 3]) -> Vec<Vec<[f64; 3]>> {
    area.rings
        .iter()
        .map(|r| r.iter().map(|g| world(*g)).collect())
        .collect()
}

fn into_store(e: Error) -> graphstore::Error {
    match e {
        Error::Store(s) => s,
        other => graphstore::Error::InvalidValue(other.to_string()),
    }
}

fn write_all(
    tx: &mut WriteTxn<'_>,
    lanes: &LaneGraph,
    segs: &Segments,
    heights: &Heights,
    frame: GroundFrame,
    environment: &str,
    cfg: &HierarchyConfig,
) -> Result<HierarchyReport> {
    // replace any previous hierarchy
    for label in [
        scene::label::ENVIRONMENT,
        scene::label::SEGMENT,
        scene::label::LANE_NODE,
    ] {
        for id in tx.nodes_with_label(label)? {
            tx.detach_delete_node(id)?;
        }
    }
    let related = tx.rel_type_id(scene::rel::RELATED)?;
    for inst in tx.nodes_with_label(scene::label::INSTANCE)? {
        for adj in tx.neighbours(inst, graphstore::Direction::Outgoing, Some(related))? {
            let rel = tx
                .rel(adj.rel)?
                .ok_or(graphstore::Error::RelNotFound(adj.rel))?;
            let source = tx
                .prop_key(scene::key::SOURCE)
                .and_then(|k| rel.get(k).cloned());
            if source == Some(Value::from(GEOMETRIC)) {
                tx.delete_rel(adj.rel)?;
            }
        }
    }
    let mut report = HierarchyReport::default();
    let w3 = |g: [f64; 2]| frame.world(g, heights.at(g));
    let env = EnvironmentRecord {
        name: environment.to_string(),
        source: Some("trajectory".into()),
        ground_frame: Some(frame),
    }
    .create(tx)?;
    let drivable = super::drivable::measure(&*tx, frame, segs, &cfg.drivable)?;
    let mut seg_ids = Vec::with_capacity(segs.segments.len());
    for (s, area) in segs.segments.iter().zip(&drivable) {
        let h = heights.at(s.centroid);
        let (shape, (lo, hi)) = match &s.area {
            SegmentArea::Disc { centre, radius_m } => (
                SegmentShape::Disc {
                    radius_m: *radius_m,
                    outline: s.area.outline(24).into_iter().map(w3).collect(),
                },
                bounds(&[*centre], *radius_m),
            ),
            SegmentArea::Corridor {
                centreline,
                half_width_m,
            } => (
                SegmentShape::Corridor {
                    half_width_m: *half_width_m,
                    centerline: centreline.iter().map(|g| w3(*g)).collect(),
                },
                bounds(centreline, *half_width_m),
            ),
        };
        let record = SegmentRecord {
            segment_id: s.id as i64,
            kind: s.kind.as_str().to_string(),
            centroid: w3(s.centroid),
            shape: Some(shape),
            bbox: Some(world_box(frame, lo, hi, h - 3.0, h + 3.0)),
            polygon: polygon_points(area, w3),
            drivable_area_m2: (!area.is_empty()).then(|| area.area_m2()),
        };
        if !area.is_empty() {
            report.drivable_m2 += area.area_m2();
            report.drivable_segments += 1;
        }
        let id = record.create(tx)?;
        tx.create_rel_named(env, scene::rel::CONTAINS, id, &[])?;
        seg_ids.push(id);
        *report
            .segments
            .entry(s.kind.as_str().to_string())
            .or_default() += 1;
    }
    for (a, b) in &segs.connects {
        tx.create_rel_named(seg_ids[*a], scene::rel::CONNECTS, seg_ids[*b], &[])?;
    }
    let mut lane_ids = Vec::with_capacity(lanes.nodes.len());
    for n in &lanes.nodes {
        let id = LaneNodeRecord {
            lane_id: n.id as i64,
            kind: n.kind.as_str().to_string(),
            position: w3(n.xy),
        }
        .create(tx)?;
        lane_ids.push(id);
        *report
            .lane_nodes
            .entry(n.kind.as_str().to_string())
            .or_default() += 1;
        let seg = segs
            .segments
            .iter()
            .find(|s| s.kind.as_str() == n.kind.as_str() && s.lane_nodes.contains(&n.id))
            .map(|s| (s.id, 0.0))
            .or_else(|| {
                (n.kind == LaneNodeKind::Breakpoint)
                    .then(|| segs.nearest(n.xy))
                    .flatten()
            });
        if let Some((sid, d)) = seg {
            InSegmentRecord { distance_m: d }.create(tx, id, seg_ids[sid])?;
        }
    }
    for e in &lanes.edges {
        LaneEdgeRecord {
            length_m: e.length_m,
            polyline: e.polyline.iter().map(|g| w3(*g)).collect(),
            frames: e.frames.iter().map(|f| i64::from(*f)).collect(),
            directed: false,
        }
        .create(tx, lane_ids[e.from], lane_ids[e.to])?;
    }
    report.lane_edges = lanes.edges.len();
    report.trajectory_gaps = lanes.gaps.clone();
    // instances
    let instances = tx.nodes_with_label(scene::label::INSTANCE)?;
    let mut boxes = Vec::with_capacity(instances.len());
    // each segment's bounds give a lower bound of an instance's distance to it, so the
    // nearest is found measuring few (scene::area::nearest_by_bounds; ties to the smaller id,
    // as a segment's id is its index)
    let seg_bounds: Vec<[[f64; 2]; 2]> = segs
        .segments
        .iter()
        .map(|s| scene::area::membership_bounds(&s.area, Some(&drivable[s.id])))
        .collect();
    for &id in &instances {
        let Some(b) = read_instance_box(&*tx, id, frame)? else {
            return Err(Error::Invalid(format!(
                "instance node {id} has neither bbox nor centroid"
            )));
        };
        boxes.push(b);
        let c = frame.ground(b.centre());
        let nearest = scene::area::nearest_by_bounds(&seg_bounds, c, |i| {
            let s = &segs.segments[i];
            scene::area::membership_distance(&s.area, Some(&drivable[s.id]), c)
        });
        if let Some((sid, d)) = nearest {
            InSegmentRecord { distance_m: d }.create(tx, id, seg_ids[sid])?;
            report.instances_linked += 1;
        }
    }
    let roads = scene::area::RoadDirections::new(segs.segments.iter().map(|s| &s.area));
    let road_dir = |g: [f64; 2]| roads.direction_near(g);
    for r in infer_relations(&boxes, frame, road_dir, &cfg.relations) {
        RelationRecord {
            relation: r.relation.to_string(),
            distance_m: r.distance_m,
            source: GEOMETRIC.into(),
            confidence: r.confidence,
        }
        .create(tx, instances[r.a], instances[r.b])?;
        *report.relations.entry(r.relation.to_string()).or_default() += 1;
    }
    Ok(report)
}
