//! Map objects, per-frame integration (projection → denoise → world → associate → fuse) and
//! post-processing.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::time::Instant;

use super::MappingConfig;
use super::associate::{TfIdf, Weights, cosine, greedy_assign, phi, words};
use super::geometry::{
    Aabb, VoxelKey, clusters, object_points, voxel_downsample_flagged, voxel_key,
};
use super::project::{Camera, Projected, core_of_mask, points_in_mask, projected_in_mask};
use crate::sources::detections::DetectionFrame;
use crate::sources::kitti::Rigid3;
use scene::GroundFrame;
use scene::OrientedBox;
use scene::classes;

mod post;
pub use post::PostReport;

/// One object of the map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapObject {
    /// Stable id (the `Instance.instance_id`).
    pub instance_id: u64,
    /// For background objects: the class and the ground-plane tile.
    pub tile: Option<(u8, [i64; 2])>,
    /// World points, one per occupied voxel.
    pub points: Vec<[f32; 3]>,
    voxels: HashSet<VoxelKey>,
    /// Bounds of `points`.
    pub bbox: Aabb,
    /// The oriented box of `points` in the mapper's ground frame, fitted when first asked
    /// for after the points change ([`MapObject::obb`]).
    obb: std::cell::OnceCell<Option<OrientedBox>>,
    /// Running mean of the detection features, weighted by detection count.
    pub feature: Vec<f32>,
    /// Every caption, in the order seen.
    pub captions: Vec<String>,
    /// Detections fused into the object.
    pub detection_count: u32,
    /// First key frame it was seen in.
    pub first_frame: u32,
    /// Last key frame it was seen in.
    pub last_frame: u32,
    /// Detections per frame since the last commit.
    pub observations: BTreeMap<u32, u32>,
    /// Changed since the last commit.
    pub dirty: bool,
}

impl MapObject {
    /// An object restored from stored state.
    #[allow(clippy::too_many_arguments)]
    pub fn restore(
        instance_id: u64,
        tile: Option<(u8, [i64; 2])>,
        points: Vec<[f32; 3]>,
        feature: Vec<f32>,
        captions: Vec<String>,
        detection_count: u32,
        first_frame: u32,
        last_frame: u32,
        voxel_m: f32,
    ) -> MapObject {
        let mut o = MapObject {
            instance_id,
            tile,
            points: Vec::new(),
            voxels: HashSet::new(),
            bbox: Aabb {
                min: [0.0; 3],
                max: [0.0; 3],
            },
            obb: std::cell::OnceCell::new(),
            feature,
            captions,
            detection_count,
            first_frame,
            last_frame,
            observations: BTreeMap::new(),
            dirty: false,
        };
        o.set_points(points, voxel_m);
        o
    }

    /// Replaces the points (recomputing voxels and bounds).
    pub fn set_points(&mut self, points: Vec<[f32; 3]>, voxel_m: f32) {
        self.voxels = points.iter().map(|p| voxel_key(*p, voxel_m)).collect();
        self.bbox = Aabb::of(&points).unwrap_or(Aabb {
            min: [0.0; 3],
            max: [0.0; 3],
        });
        self.points = points;
        self.obb = std::cell::OnceCell::new();
    }

    /// The minimum-area oriented box of the points in `ground` ([`OrientedBox::fit`]);
    /// `None` without points. Cached until the points change: pass the mapper's frame.
    pub fn obb(&self, ground: GroundFrame) -> Option<OrientedBox> {
        *self
            .obb
            .get_or_init(|| OrientedBox::fit(ground, &self.points))
    }

    /// The latest `n` captions joined, for caption comparison.
    pub fn recent_captions(&self, n: usize) -> &[String] {
        &self.captions[self.captions.len().saturating_sub(n)..]
    }

    fn absorb_points(&mut self, pts: &[[f32; 3]], voxel_m: f32) {
        for p in pts {
            if self.voxels.insert(voxel_key(*p, voxel_m)) {
                self.obb.take();
                if self.points.is_empty() {
                    // an empty object's box is a placeholder at the origin: start afresh
                    self.bbox = Aabb { min: *p, max: *p };
                }
                self.points.push(*p);
                for (i, c) in p.iter().enumerate() {
                    self.bbox.min[i] = self.bbox.min[i].min(*c);
                    self.bbox.max[i] = self.bbox.max[i].max(*c);
                }
            }
        }
    }

    /// Folds `f`, worth `weight` detections, into the mean of `detection_count` detections
    /// (call before adding `weight` to the count). Features of another dimension are ignored.
    fn add_feature(&mut self, f: &[f32], weight: u32) {
        if self.feature.len() != f.len() {
            if self.feature.is_empty() {
                self.feature = vec![0.0; f.len()];
            } else {
                return;
            }
        }
        let n = self.detection_count as f32;
        let w = weight as f32;
        for (a, b) in self.feature.iter_mut().zip(f) {
            *a = (*a * n + b * w) / (n + w).max(1.0);
        }
    }
}

/// Turns an object's latest captions into its caption (the paper merges them with an LLM).
pub trait CaptionMerger {
    /// One caption for `recent` (never empty).
    fn merge(&mut self, recent: &[String]) -> String;
}

/// The deterministic merge: the caption with the highest summed word-overlap (bag-of-words
/// cosine) with the others, the most recent on ties.
#[derive(Debug, Clone, Copy, Default)]
pub struct MedoidMerger;

impl CaptionMerger for MedoidMerger {
    fn merge(&mut self, recent: &[String]) -> String {
        let bags: Vec<BTreeMap<String, f64>> = recent
            .iter()
            .map(|c| {
                let mut m = BTreeMap::new();
                for w in words(c) {
                    *m.entry(w).or_insert(0.0) += 1.0;
                }
                m
            })
            .collect();
        let cos = |a: &BTreeMap<String, f64>, b: &BTreeMap<String, f64>| {
            let dot: f64 = a.iter().map(|(k, x)| x * b.get(k).unwrap_or(&0.0)).sum();
            let n = |m: &BTreeMap<String, f64>| m.values().map(|x| x * x).sum::<f64>().sqrt();
            if dot > 0.0 { dot / (n(a) * n(b)) } else { 0.0 }
        };
        let mut best = (f64::NEG_INFINITY, 0);
        for i in 0..recent.len() {
            let s: f64 = (0..recent.len())
                .filter(|j| *j != i)
                .map(|j| cos(&bags[i], &bags[j]))
                .sum();
            if s >= best.0 {
                best = (s, i);
            }
        }
        recent.get(best.1).cloned().unwrap_or_default()
    }
}

/// One key frame, ready to integrate.
#[derive(Debug)]
pub struct FrameInput<'a> {
    /// Key frame index.
    pub index: u32,
    /// Pose of the key frame's velodyne.
    pub world_from_velo: Rigid3,
    /// Points in the key frame's velodyne frame (accumulated scans included); non-finite ones
    /// never project.
    pub points: &'a [[f32; 4]],
    /// The camera the masks are in.
    pub camera: &'a Camera,
    /// The frame's detections.
    pub detections: &'a DetectionFrame,
    /// Per detection: its feature (its own, or its caption's embedding).
    pub features: &'a [Vec<f32>],
    /// What the dynamic-point filter removed from the key scan, when it ran.
    pub moving: Option<MovingPoints<'a>>,
    /// Per detection: its class (1..=19). Surface classes ([`classes::is_surface`]) are
    /// fused into ground tiles, every other class into objects, so a detection that is a
    /// thing must never carry a surface class (see [`llm_tools::vocab::names_surface`]).
    pub classes: &'a [u8],
}

/// The points of a key scan that the dynamic-point filter removed
/// ([`crate::mapping::dynamic`]).
#[derive(Debug, Clone, Copy)]
pub struct MovingPoints<'a> {
    /// The removed points, in the key frame's velodyne frame.
    pub points: &'a [[f32; 4]],
    /// A thing's detection whose mask holds at least this share of removed points (among
    /// removed and kept), and at least [`MOVING_MIN_POINTS`], is of a moving thing and is not
    /// mapped.
    pub detection_share: f64,
}

/// A detection is of a moving thing only when at least this many of its mask's points were
/// removed: a few edge points of a small static thing must not make it move.
pub const MOVING_MIN_POINTS: usize = 5;

/// Milliseconds spent per stage.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct StageTimes {
    /// Projection of the scan and mask look-ups.
    pub project_ms: f64,
    /// Voxel down-sampling and DBSCAN.
    pub denoise_ms: f64,
    /// Velodyne → world.
    pub transform_ms: f64,
    /// φ and assignment.
    pub associate_ms: f64,
    /// Fusion into objects.
    pub fuse_ms: f64,
}

impl StageTimes {
    /// Adds another set of times.
    pub fn add(&mut self, o: &StageTimes) {
        self.project_ms += o.project_ms;
        self.denoise_ms += o.denoise_ms;
        self.transform_ms += o.transform_ms;
        self.associate_ms += o.associate_ms;
        self.fuse_ms += o.fuse_ms;
    }

    /// Sum of the stages.
    pub fn total_ms(&self) -> f64 {
        self.project_ms + self.denoise_ms + self.transform_ms + self.associate_ms + self.fuse_ms
    }
}

/// What integrating one frame did.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct FrameStats {
    /// Detections in the frame.
    pub detections: usize,
    /// Detections dropped: no points in the mask, or none left after denoising.
    pub dropped: usize,
    /// Detections fused into an existing object.
    pub matched: usize,
    /// New objects.
    pub created: usize,
    /// Background detections fused into tiles.
    pub background: usize,
    /// Thing detections of moving things, not mapped ([`MovingPoints`]).
    pub moving: usize,
    /// Time per stage.
    pub times: StageTimes,
}

/// Object boxes on a uniform 3D grid, for candidate look-ups. Boxes only grow between
/// rebuilds, so an object is only ever added to more cells.
#[derive(Debug, Clone, Default)]
struct BoxGrid {
    cells: HashMap<[i32; 3], Vec<u64>>,
    ranges: HashMap<u64, ([i32; 3], [i32; 3])>,
}

const GRID_CELL_M: f32 = 8.0;

fn cell_range(b: &Aabb) -> ([i32; 3], [i32; 3]) {
    (voxel_key(b.min, GRID_CELL_M), voxel_key(b.max, GRID_CELL_M))
}

impl BoxGrid {
    fn update(&mut self, id: u64, b: &Aabb) {
        let (lo, hi) = cell_range(b);
        let old = self.ranges.insert(id, (lo, hi));
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let inside_old = old.is_some_and(|(a, b)| {
                        (a[0]..=b[0]).contains(&x)
                            && (a[1]..=b[1]).contains(&y)
                            && (a[2]..=b[2]).contains(&z)
                    });
                    if !inside_old {
                        self.cells.entry([x, y, z]).or_default().push(id);
                    }
                }
            }
        }
    }

    /// Ids of objects whose cells overlap the box's cells, ascending.
    fn candidates(&self, b: &Aabb) -> Vec<u64> {
        let (lo, hi) = cell_range(b);
        let mut out = Vec::new();
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    if let Some(v) = self.cells.get(&[x, y, z]) {
                        out.extend_from_slice(v);
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// The object map under construction.
#[derive(Debug, Clone)]
pub struct Mapper {
    cfg: MappingConfig,
    ground: GroundFrame,
    objects: BTreeMap<u64, MapObject>,
    tiles: BTreeMap<(u8, [i64; 2]), u64>,
    tfidf: TfIdf,
    next_id: u64,
    grid: BoxGrid,
}

fn elapsed_ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

impl Mapper {
    /// An empty map.
    pub fn new(cfg: MappingConfig, ground: GroundFrame) -> Mapper {
        Mapper::restore(cfg, ground, Vec::new(), 0)
    }

    /// A map restored from stored objects; new ids start at `next_id`.
    pub fn restore(
        cfg: MappingConfig,
        ground: GroundFrame,
        objects: Vec<MapObject>,
        next_id: u64,
    ) -> Mapper {
        let mut m = Mapper {
            cfg,
            ground,
            objects: BTreeMap::new(),
            tiles: BTreeMap::new(),
            tfidf: TfIdf::default(),
            next_id,
            grid: BoxGrid::default(),
        };
        for o in objects {
            for c in &o.captions {
                m.tfidf.add(c);
            }
            if let Some(t) = o.tile {
                m.tiles.insert(t, o.instance_id);
            }
            m.next_id = m.next_id.max(o.instance_id + 1);
            if o.tile.is_none() && !o.points.is_empty() {
                m.grid.update(o.instance_id, &o.bbox);
            }
            m.objects.insert(o.instance_id, o);
        }
        m
    }

    /// The ground frame of the world the objects live in.
    pub fn ground(&self) -> GroundFrame {
        self.ground
    }

    /// The configuration.
    pub fn config(&self) -> &MappingConfig {
        &self.cfg
    }

    /// The objects, by id.
    pub fn objects(&self) -> &BTreeMap<u64, MapObject> {
        &self.objects
    }

    /// Mutable access (the store writer clears `dirty` and round-trips points).
    pub fn objects_mut(&mut self) -> &mut BTreeMap<u64, MapObject> {
        &mut self.objects
    }

    /// Ids of the objects that are not background tiles, ascending.
    fn object_ids(&self) -> Vec<u64> {
        self.objects
            .values()
            .filter(|o| o.tile.is_none())
            .map(|o| o.instance_id)
            .collect()
    }

    /// The id the next new object gets.
    pub fn next_id(&self) -> u64 {
        self.next_id
    }

    /// Integrates one key frame.
    pub fn integrate(&mut self, f: &FrameInput<'_>) -> FrameStats {
        let cfg = self.cfg.clone();
        let n = f.detections.detections.len();
        let mut st = FrameStats {
            detections: n,
            ..FrameStats::default()
        };
        // projection, once per frame, sorted by pixel for run-walking look-ups
        let t = Instant::now();
        let mut projected = f.camera.project_all(f.points);
        projected.sort_unstable_by_key(|p| (p.pixel, p.point));
        let in_mask: Vec<Vec<Projected>> = f
            .detections
            .detections
            .iter()
            .map(|d| projected_in_mask(&projected, &d.mask.counts))
            .collect();
        // detections of moving things: their masks are largely what the filter removed
        let mut moving = vec![false; n];
        if let Some(mv) = f.moving.filter(|mv| !mv.points.is_empty()) {
            let mut removed = f.camera.project_all(mv.points);
            removed.sort_unstable_by_key(|p| (p.pixel, p.point));
            for (i, d) in f.detections.detections.iter().enumerate() {
                if classes::is_surface(f.classes[i]) {
                    continue;
                }
                let gone = points_in_mask(&removed, &d.mask.counts).len();
                let total = gone + in_mask[i].len();
                moving[i] =
                    gone >= MOVING_MIN_POINTS && gone as f64 >= mv.detection_share * total as f64;
            }
        }
        st.times.project_ms += elapsed_ms(t);
        // per detection: voxel down-sample, DBSCAN (objects only: the clusters on the object,
        // by range and the mask's core), world transform; a moving thing's detection keeps no
        // points (it is neither associated nor fused)
        let focal_px = f.camera.focal_px();
        let mut det_points: Vec<Vec<[f32; 3]>> = Vec::with_capacity(n);
        for (i, inside) in in_mask.iter().enumerate() {
            if moving[i] {
                det_points.push(Vec::new());
                continue;
            }
            let t = Instant::now();
            let d = &f.detections.detections[i];
            let pts: Vec<[f32; 3]> = inside
                .iter()
                .map(|q| {
                    let p = f.points[q.point as usize];
                    [p[0], p[1], p[2]]
                })
                .collect();
            let surface = classes::is_surface(f.classes[i]);
            let core = if surface {
                Vec::new()
            } else {
                core_of_mask(inside, &d.mask.counts, d.mask.height, cfg.mask_core_px)
            };
            let (mut pts, core) = voxel_downsample_flagged(&pts, &core, cfg.voxel_m);
            if !surface {
                let side_px = d.bbox[2].max(d.bbox[3]);
                let angular_width_rad = if focal_px > 0.0 && side_px.is_finite() {
                    side_px.max(0.0) / focal_px
                } else {
                    0.0
                };
                pts = object_points(
                    &pts,
                    &core,
                    cfg.dbscan_eps_m,
                    cfg.dbscan_min_points,
                    cfg.foreground_min_share,
                    angular_width_rad,
                );
            }
            st.times.denoise_ms += elapsed_ms(t);
            let t = Instant::now();
            let world: Vec<[f32; 3]> = pts
                .iter()
                .map(|p| {
                    scene::pose::apply(
                        &f.world_from_velo,
                        [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])],
                    )
                    .map(|c| c as f32)
                })
                .collect();
            st.times.transform_ms += elapsed_ms(t);
            det_points.push(world);
        }
        // association of object detections
        let t = Instant::now();
        let w = Weights {
            geo: cfg.w_geo,
            cap: cfg.w_cap,
            fea: cfg.w_fea,
        };
        let mut pairs = Vec::new();
        // With no box overlap φ ≤ w_cap + w_fea; when that cannot pass δ_sim (the defaults:
        // 0.6 ≤ 0.6) only objects near the detection's box are candidates.
        let need_overlap = cfg.needs_overlap();
        let all_ids: Vec<u64> = if need_overlap {
            Vec::new()
        } else {
            self.object_ids()
        };
        let mut object_docs: BTreeMap<u64, Vec<(String, f64)>> = BTreeMap::new();
        for (i, pts) in det_points.iter().enumerate() {
            let (Some(b), false) = (Aabb::of(pts), classes::is_surface(f.classes[i])) else {
                continue;
            };
            let det_obb = OrientedBox::fit(self.ground, pts);
            let caption = self.tfidf.vector(&f.detections.detections[i].caption);
            let near;
            let candidates: &[u64] = if need_overlap {
                near = self.grid.candidates(&b);
                &near
            } else {
                &all_ids
            };
            for id in candidates {
                let Some(o) = self.objects.get(id) else {
                    continue;
                };
                // the axis-aligned boxes reject far pairs cheaply; the oriented boxes measure
                let iou = if o.bbox.intersects(&b) {
                    match (det_obb, o.obb(self.ground)) {
                        (Some(d), Some(ob)) => d
                            .widened(cfg.iou_min_side_m)
                            .iou(&ob.widened(cfg.iou_min_side_m)),
                        _ => o.bbox.iou(&b),
                    }
                } else {
                    0.0
                };
                if iou <= 0.0 && need_overlap {
                    continue;
                }
                let doc = object_docs.entry(*id).or_insert_with(|| {
                    self.tfidf
                        .vector(&o.recent_captions(cfg.merge_captions).join(" "))
                });
                let c = super::associate::sparse_dot(&caption, doc);
                let fc = cosine(&f.features[i], &o.feature);
                pairs.push((i, *id as usize, phi(w, iou, c, fc)));
            }
        }
        let assignment = greedy_assign(n, pairs, cfg.sim_threshold);
        st.times.associate_ms += elapsed_ms(t);
        // fusion
        let t = Instant::now();
        for (i, pts) in det_points.into_iter().enumerate() {
            let d = &f.detections.detections[i];
            if moving[i] {
                st.moving += 1;
                continue;
            }
            if pts.is_empty() {
                st.dropped += 1;
                continue;
            }
            let class = f.classes[i];
            if classes::is_surface(class) {
                st.background += 1;
                let mut by_tile: BTreeMap<[i64; 2], Vec<[f32; 3]>> = BTreeMap::new();
                for p in pts {
                    let g = self
                        .ground
                        .ground([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]);
                    let tile = g.map(|c| (c / cfg.background_tile_m).floor() as i64);
                    by_tile.entry(tile).or_default().push(p);
                }
                for (tile, tp) in by_tile {
                    let id = match self.tiles.get(&(class, tile)) {
                        Some(id) => *id,
                        None => {
                            let id = self.new_object(Some((class, tile)), f.index);
                            self.tiles.insert((class, tile), id);
                            id
                        }
                    };
                    self.fuse(id, &tp, &f.features[i], &d.caption, f.index);
                }
                continue;
            }
            let id = match assignment[i] {
                Some(id) => {
                    st.matched += 1;
                    id as u64
                }
                None => {
                    st.created += 1;
                    self.new_object(None, f.index)
                }
            };
            self.fuse(id, &pts, &f.features[i], &d.caption, f.index);
        }
        st.times.fuse_ms += elapsed_ms(t);
        st
    }

    fn new_object(&mut self, tile: Option<(u8, [i64; 2])>, frame: u32) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        let o = MapObject::restore(
            id,
            tile,
            Vec::new(),
            Vec::new(),
            Vec::new(),
            0,
            frame,
            frame,
            self.cfg.voxel_m,
        );
        self.objects.insert(id, o);
        id
    }

    fn fuse(&mut self, id: u64, pts: &[[f32; 3]], feature: &[f32], caption: &str, frame: u32) {
        let voxel_m = self.cfg.voxel_m;
        let o = self.objects.get_mut(&id).expect("object exists");
        o.absorb_points(pts, voxel_m);
        o.add_feature(feature, 1);
        o.captions.push(caption.to_string());
        o.detection_count += 1;
        o.first_frame = o.first_frame.min(frame);
        o.last_frame = o.last_frame.max(frame);
        *o.observations.entry(frame).or_insert(0) += 1;
        o.dirty = true;
        if o.tile.is_none() {
            self.grid.update(id, &o.bbox);
        }
        self.tfidf.add(caption);
    }

    /// Moves object `b` into object `a`: points, feature (weighted by detection counts),
    /// captions, counts, frames and observations; `b` is removed.
    fn absorb(&mut self, a: u64, b: u64) {
        let voxel_m = self.cfg.voxel_m;
        let Some(absorbed) = self.objects.remove(&b) else {
            return;
        };
        let keep = self.objects.get_mut(&a).expect("present");
        keep.absorb_points(&absorbed.points, voxel_m);
        keep.add_feature(&absorbed.feature, absorbed.detection_count);
        keep.captions.extend(absorbed.captions);
        keep.detection_count += absorbed.detection_count;
        keep.first_frame = keep.first_frame.min(absorbed.first_frame);
        keep.last_frame = keep.last_frame.max(absorbed.last_frame);
        for (fr, n) in absorbed.observations {
            *keep.observations.entry(fr).or_insert(0) += n;
        }
        keep.dirty = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::project::test_camera;
    use crate::sources::detections::{Detection, Producer};
    use crate::sources::rle::Rle;

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// Every box that intersects the query is among the grid's candidates, also after
        /// boxes grow.
        #[test]
        fn grid_candidates_cover_intersecting_boxes(
            boxes in proptest::collection::vec(
                (-40i32..40, -40i32..40, -5i32..5, 1i32..30, 1i32..30, 1i32..10), 1..40),
            grow in proptest::collection::vec((0usize..40, 0i32..20), 0..10),
            q in (-50i32..50, -50i32..50, -6i32..6, 0i32..20, 0i32..20, 0i32..10),
        ) {
            let mk = |(x, y, z, w, h, d): (i32, i32, i32, i32, i32, i32)| Aabb {
                min: [x as f32 * 0.7, y as f32 * 0.7, z as f32],
                max: [(x + w) as f32 * 0.7, (y + h) as f32 * 0.7, (z + d) as f32],
            };
            let mut grid = BoxGrid::default();
            let mut all: Vec<Aabb> = boxes.iter().map(|b| mk(*b)).collect();
            for (i, b) in all.iter().enumerate() {
                grid.update(i as u64, b);
            }
            for (i, g) in grow {
                if let Some(b) = all.get_mut(i) {
                    b.max[0] += g as f32;
                    b.min[1] -= g as f32;
                    grid.update(i as u64, b);
                }
            }
            let query = mk(q);
            let cands = grid.candidates(&query);
            for (i, b) in all.iter().enumerate() {
                if b.intersects(&query) {
                    proptest::prop_assert!(cands.contains(&(i as u64)), "box {i} missing");
                }
            }
        }
    }

    #[test]
    fn medoid_merge_picks_the_consensus_caption() {
        let caps: Vec<String> = [
            "a red car parked by the curb",
            "a red car parked on the street",
            "a blue bench",
            "a small red car parked by the curb",
        ]
        .map(String::from)
        .to_vec();
        // word-overlap cosines: 0.935 (first/last), 0.714 (first/second), 0.668 (second/last)
        assert_eq!(MedoidMerger.merge(&caps), "a red car parked by the curb");
        assert_eq!(MedoidMerger.merge(&caps[2..3]), "a blue bench");
    }

    /// A 1 m cube of points 10 m in front of the sensor, plus a few stray points.
    fn cube(offset_y: f32) -> Vec<[f32; 4]> {
        let mut pts = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                for k in 0..3 {
                    pts.push([
                        10.0 + k as f32 * 0.3,
                        offset_y + i as f32 * 0.05 - 0.5,
                        j as f32 * 0.05 - 0.5,
                        0.0,
                    ]);
                }
            }
        }
        pts
    }

    fn full_mask_detection(caption: &str) -> Detection {
        let mask = Rle::from_mask(50, 100, &vec![true; 5000]).unwrap();
        Detection {
            bbox: mask.bbox().unwrap(),
            mask,
            score: 1.0,
            tags: vec![],
            caption: caption.into(),
            feature: None,
        }
    }

    fn frame_of(d: Vec<Detection>) -> DetectionFrame {
        DetectionFrame {
            frame: 0,
            width: 100,
            height: 50,
            producer: Producer::Detector,
            detections: d,
        }
    }

    /// A detection whose mask holds many points that the dynamic filter removed is of a
    /// moving thing: it makes no object. A few removed points do not count, nor do surfaces.
    #[test]
    fn detections_of_moving_things_are_not_mapped() {
        let cam = test_camera();
        let kept = cube(0.0);
        let dets = frame_of(vec![full_mask_detection("a red car")]);
        let run = |removed: &[[f32; 4]], class: u8| {
            let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
            let s = m.integrate(&FrameInput {
                index: 0,
                world_from_velo: Rigid3::identity(),
                points: &kept,
                camera: &cam,
                detections: &dets,
                features: &[vec![1.0, 0.0]],
                moving: Some(MovingPoints {
                    points: removed,
                    detection_share: 0.3,
                }),
                classes: &[class],
            });
            (s.moving, m.objects().len())
        };
        // the car's other half was carved away: half of the mask's points are gone
        let half: Vec<[f32; 4]> = cube(0.0)
            .iter()
            .map(|p| [p[0] + 0.1, p[1], p[2], p[3]])
            .collect();
        assert_eq!(run(&half, 1), (1, 0));
        // four stray points: under MOVING_MIN_POINTS of 1,200
        assert_eq!(run(&half[..4], 1), (0, 1));
        assert_eq!(run(&[], 1), (0, 1));
        // a road's mask is never a moving thing (class 9: road; the cube spans two tiles)
        assert_eq!(run(&half, 9), (0, 2));
    }

    #[test]
    fn the_same_object_seen_twice_is_one_object() {
        let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
        let cam = test_camera();
        let pts = cube(0.0);
        let dets = frame_of(vec![full_mask_detection("a red car")]);
        let feats = vec![vec![1.0, 0.0, 0.0]];
        for (k, shift) in [0.0f64, 0.05].iter().enumerate() {
            let mut pose = Rigid3::identity();
            pose.translation.x = *shift;
            let s = m.integrate(&FrameInput {
                index: k as u32,
                world_from_velo: pose,
                points: &pts,
                camera: &cam,
                detections: &dets,
                features: &feats,
                classes: &[1],
                moving: None,
            });
            assert_eq!(s.dropped, 0, "{s:?}");
            assert_eq!((s.matched, s.created), if k == 0 { (0, 1) } else { (1, 0) });
        }
        assert_eq!(m.objects().len(), 1);
        let o = &m.objects()[&0];
        assert_eq!(o.detection_count, 2);
        assert_eq!(o.captions.len(), 2);
        assert_eq!((o.first_frame, o.last_frame), (0, 1));
        // 10 x 10 voxels x 3 layers; the 5 cm shift along x moves no point out of its voxel
        assert_eq!(o.points.len(), 300);
        // a dissimilar detection far away becomes a new object
        let far = cube(30.0);
        let s = m.integrate(&FrameInput {
            index: 2,
            world_from_velo: Rigid3::identity(),
            points: &far,
            camera: &cam,
            detections: &frame_of(vec![full_mask_detection("a red car")]),
            features: &feats,
            classes: &[1],
            moving: None,
        });
        // 30 m to the side is outside this 100 px camera: the detection has no points
        assert_eq!(s.dropped, 1);
        let post = m.post_process();
        assert!(
            post.dropped.is_empty() && post.merged.is_empty(),
            "{post:?}"
        );
    }

    #[test]
    fn surfaces_are_fused_per_class_and_tile_and_buildings_are_objects() {
        let cam = test_camera();
        // a wide strip 10..50 m ahead spanning several 20 m tiles along KITTI z (velo x here,
        // with an identity pose the world is the velodyne frame: ground = (x, z))
        let mut pts = Vec::new();
        for i in 0..400 {
            for j in 0..5 {
                pts.push([10.05 + i as f32 * 0.1, 0.05, j as f32 * 0.1 + 0.05, 0.0]);
            }
        }
        let integrate = |caption: &str, class: u8| {
            let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
            let dets = frame_of(vec![full_mask_detection(caption)]);
            let s = m.integrate(&FrameInput {
                index: 0,
                world_from_velo: Rigid3::identity(),
                points: &pts,
                camera: &cam,
                detections: &dets,
                features: &[vec![0.0, 1.0]],
                classes: &[class],
                moving: None,
            });
            (m, s)
        };
        let (m, s) = integrate("the asphalt road", 9);
        assert_eq!(s.background, 1);
        let tiles: Vec<_> = m.objects().values().map(|o| o.tile.unwrap()).collect();
        assert_eq!(tiles, vec![(9, [0, 0]), (9, [1, 0]), (9, [2, 0])]);
        let total: usize = m.objects().values().map(|o| o.points.len()).sum();
        assert_eq!(total, 2000);
        // each tile's box is that of its own points (regression: it used to include the
        // origin, the placeholder box of an empty object)
        for o in m.objects().values() {
            let want = Aabb::of(&o.points).unwrap();
            for k in 0..3 {
                assert!(
                    (o.bbox.min[k] - want.min[k]).abs() < 1e-6,
                    "{:?} {:?}",
                    o.bbox,
                    want
                );
                assert!(
                    (o.bbox.max[k] - want.max[k]).abs() < 1e-6,
                    "{:?} {:?}",
                    o.bbox,
                    want
                );
            }
        }
        // the same points as a building: one object, no tiles
        let (m, s) = integrate("a brick building", 13);
        assert_eq!((s.background, s.created), (0, 1));
        assert_eq!(m.objects().len(), 1);
        let o = m.objects().values().next().unwrap();
        assert!(o.tile.is_none() && o.points.len() == 2000);
    }

    /// A 2 m x 2 m x 0.5 m block of points on a 0.1 m grid starting at `x0`.
    fn block(x0: f32, n: usize) -> Vec<[f32; 3]> {
        let mut v = Vec::new();
        for i in 0..n {
            for j in 0..20 {
                for k in 0..5 {
                    v.push([
                        x0 + (i as f32 + 0.5) * 0.1,
                        (j as f32 + 0.5) * 0.1,
                        (k as f32 + 0.5) * 0.1,
                    ]);
                }
            }
        }
        v
    }

    fn object_with(m: &mut Mapper, pts: &[[f32; 3]], caption: &str) -> u64 {
        let id = m.new_object(None, 0);
        m.fuse(id, pts, &[1.0, 0.0], caption, 0);
        id
    }

    #[test]
    fn the_oriented_box_follows_the_points() {
        let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
        // a 4 m wall along the KITTI world diagonal (x = z), 1 m high (y down)
        let wall: Vec<[f32; 3]> = (0..40)
            .flat_map(|i| [0.0f32, -0.5, -1.0].map(|y| [i as f32 * 0.0707, y, i as f32 * 0.0707]))
            .collect();
        let id = object_with(&mut m, &wall, "a brick wall");
        let b = m.objects()[&id].obb(GroundFrame::KittiCam).unwrap();
        assert!(
            (b.yaw_rad - std::f64::consts::FRAC_PI_4).abs() < 1e-3,
            "{b:?}"
        );
        assert!(b.half_extents[1] < 1e-3 && (b.height_m[1] - 1.0).abs() < 1e-6);
        // the cached box is replaced when points are added
        let more: Vec<[f32; 3]> = (0..40)
            .map(|i| [i as f32 * 0.0707 + 1.0, 0.0, i as f32 * 0.0707])
            .collect();
        m.fuse(id, &more, &[1.0, 0.0], "a brick wall", 1);
        let c = m.objects()[&id].obb(GroundFrame::KittiCam).unwrap();
        assert!(c.half_extents[1] > 0.3, "{c:?}");
    }

    #[test]
    fn post_processing_splits_an_object_into_its_large_clusters() {
        let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
        // two hedges 3 m apart in one object, and a 60-point speck (under 20 % of them)
        let mut pts = block(0.0, 20);
        pts.extend(block(5.0, 20));
        pts.extend(block(12.0, 1).into_iter().take(60));
        let id = object_with(&mut m, &pts, "a green hedge");
        let r = m.post_process();
        assert_eq!(r.split.len(), 1, "{r:?}");
        assert_eq!(r.split[0].0, id);
        let new = r.split[0].1;
        let (a, b) = (&m.objects()[&id], &m.objects()[&new]);
        assert_eq!((a.points.len(), b.points.len()), (2000, 2000));
        assert!(a.bbox.max[0] < 2.5 && b.bbox.min[0] > 4.5);
        assert_eq!(b.captions, vec!["a green hedge".to_string()]);
        assert_eq!(r.denoised_points, 60);
    }

    #[test]
    fn touching_objects_of_a_class_are_joined_and_apart_ones_stay() {
        let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
        // two parts of one facade 0.6 m apart, and a third 5 m away
        let a = object_with(&mut m, &block(0.0, 20), "a brick building");
        let b = object_with(&mut m, &block(2.5, 20), "a red brick house");
        let c = object_with(&mut m, &block(10.0, 20), "a brick building");
        let merged = m.join_touching(&[c, b, a], 1.0);
        assert_eq!(merged, vec![(a, b)]);
        assert_eq!(m.objects()[&a].points.len(), 4000);
        assert_eq!(m.objects()[&a].captions.len(), 2);
        assert!(m.objects().contains_key(&c) && !m.objects().contains_key(&b));
        // with a smaller radius the gap keeps them apart
        let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
        let a = object_with(&mut m, &block(0.0, 20), "a brick building");
        let b = object_with(&mut m, &block(2.5, 20), "a brick building");
        assert!(m.join_touching(&[a, b], 0.5).is_empty());
    }

    /// A wall of `len_m` along KITTI x at `(x0, z0)`, 1.6 m deep in z with its two ends only
    /// (the ends of a shelter; `ends_only`) or whole, 0.1 m grid.
    fn shelter(x0: f32, z0: f32, len_m: f32, ends_only: bool) -> Vec<[f32; 3]> {
        let mut v = Vec::new();
        let n = (len_m / 0.1) as usize;
        for i in 0..n {
            let x = x0 + i as f32 * 0.1;
            if ends_only && i > 5 && i + 6 < n {
                continue;
            }
            for k in 0..16 {
                v.push([x, -1.0, z0 + k as f32 * 0.1]);
            }
        }
        v
    }

    /// Two ends of one shelter 3 m apart are one object when the kind's whole ones are that
    /// long; two shelters end to end, or one shelter beside another, make a box larger than
    /// one and stay two; too few of a kind and nothing is joined.
    #[test]
    fn the_parts_of_a_thing_are_joined_up_to_the_size_of_a_whole_one() {
        let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
        let mut whole = Vec::new();
        for k in 0..5 {
            whole.push(object_with(
                &mut m,
                &shelter(100.0 + 10.0 * k as f32, 0.0, 4.2, false),
                "a bus shelter",
            ));
        }
        // the two ends of one 4.2 m shelter: 0.6 m each, 3 m apart
        let ends = shelter(0.0, 0.0, 4.2, true);
        let (left, right): (Vec<[f32; 3]>, Vec<[f32; 3]>) = ends.iter().partition(|p| p[0] < 2.0);
        let a = object_with(&mut m, &left, "a bus shelter");
        let b = object_with(&mut m, &right, "a bus shelter");
        // two whole shelters end to end 1.5 m apart, and two side by side 0.5 m apart
        let c = object_with(&mut m, &shelter(20.0, 0.0, 4.2, false), "a bus shelter");
        let d = object_with(&mut m, &shelter(25.7, 0.0, 4.2, false), "a bus shelter");
        let e = object_with(&mut m, &shelter(40.0, 0.0, 4.2, false), "a bus shelter");
        let f = object_with(&mut m, &shelter(40.0, 2.1, 4.2, false), "a bus shelter");
        let mut ids = whole.clone();
        ids.extend([a, b, c, d, e, f]);
        let merged = m.join_parts(&ids, 0.9, 1.1, 5);
        assert_eq!(merged, vec![(a, b)]);
        assert_eq!(m.objects()[&a].points.len(), left.len() + right.len());
        // the kind's size is unknown with fewer objects than asked for
        let mut m = Mapper::new(MappingConfig::default(), GroundFrame::KittiCam);
        let a = object_with(&mut m, &left, "a bus shelter");
        let b = object_with(&mut m, &right, "a bus shelter");
        let c = object_with(&mut m, &shelter(20.0, 0.0, 4.2, false), "a bus shelter");
        assert!(m.join_parts(&[a, b, c], 0.9, 1.1, 5).is_empty());
        assert!(m.join_parts(&[a, b, c], 0.9, 1.1, 3).len() == 1);
    }

    #[test]
    fn post_processing_drops_small_and_merges_overlapping() {
        let cfg = MappingConfig::default();
        let grid = |x0: f32, n: usize| -> Vec<[f32; 3]> {
            let mut v = Vec::new();
            for i in 0..n {
                for j in 0..10 {
                    v.push([x0 + i as f32 * 0.1 + 0.05, j as f32 * 0.1 + 0.05, 0.05]);
                }
            }
            v
        };
        let mk_seen = |id, pts, f: Vec<f32>, seen| {
            MapObject::restore(id, None, pts, f, vec![format!("o{id}")], seen, 0, 0, 0.1)
        };
        let mk = |id, pts, f: Vec<f32>| mk_seen(id, pts, f, 1);
        let objects = vec![
            mk(0, grid(0.0, 10), vec![1.0, 0.0]),
            mk(1, grid(0.5, 10), vec![1.0, 0.1]), // half overlaps 0, similar
            mk(2, grid(0.5, 10), vec![-1.0, 0.0]), // overlaps, dissimilar
            mk(3, grid(20.0, 3), vec![1.0, 0.0]), // 30 points: too small
            // 30 points too, but seen twice: a small thing seen again is kept
            mk_seen(4, grid(30.0, 3), vec![0.0, 1.0], 2),
            // seen twice, 10 points: under tracked_min_points
            mk_seen(5, grid(40.0, 1), vec![0.0, 1.0], 2),
        ];
        assert_eq!((cfg.tracked_detections, cfg.tracked_min_points), (2, 15));
        let mut m = Mapper::restore(cfg, GroundFrame::KittiCam, objects, 6);
        let r = m.post_process();
        assert_eq!(r.dropped, vec![3, 5]);
        assert_eq!(m.objects()[&4].points.len(), 30);
        assert_eq!(r.merged, vec![(0, 1)]);
        let o = &m.objects()[&0];
        assert_eq!(o.points.len(), 150);
        assert_eq!(o.detection_count, 2);
        assert_eq!(o.captions, vec!["o0".to_string(), "o1".to_string()]);
        assert!(m.objects().contains_key(&2));
        assert_eq!(m.next_id(), 6);
    }
}
