//! Object-centric map construction (the paper's second module): projection of LiDAR points
//! into detection masks, per-object denoising, association, fusion and post-processing.
//! The build driver ([`crate::build`]) feeds it frames and writes it into the store.

pub mod associate;
pub mod dynamic;
mod fusion;
pub mod geometry;
pub mod project;

pub use fusion::{
    CaptionMerger, FrameInput, FrameStats, MapObject, Mapper, MedoidMerger, MovingPoints,
    PostReport, StageTimes,
};

/// Every mapping parameter, with the reference implementation's defaults. Loadable from the
/// `[mapping]` table of a TOML file (see [`crate::build::BuildConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MappingConfig {
    /// Voxel size of the per-detection down-sample and of object point sets.
    pub voxel_m: f32,
    /// DBSCAN radius of the per-object denoising.
    pub dbscan_eps_m: f32,
    /// DBSCAN minimum neighbourhood (the point included).
    pub dbscan_min_points: usize,
    /// A detection's points are the foreground DBSCAN cluster of its mask's points: the
    /// nearest among the clusters with at least this share of the largest one's points
    /// ([`geometry::foreground_cluster`]; 1 keeps the largest).
    pub foreground_min_share: f64,
    /// A point lies in its mask's core when every pixel within this many pixels of its own is
    /// in the mask. Besides the foreground cluster, a detection keeps each other large
    /// cluster that lies mostly in the core and no farther behind than the object is wide
    /// ([`geometry::object_points`]): the parts of a many-parted object, not what stands
    /// behind it. 0 puts every point in the core.
    pub mask_core_px: u32,
    /// Weight of the 3D IoU in φ.
    pub w_geo: f64,
    /// The 3D IoU of φ is that of the detection's and the object's oriented boxes, each
    /// footprint side widened to at least this (metres): a partial view of a small or thin
    /// object gives a box too tight to overlap its next view.
    pub iou_min_side_m: f64,
    /// Weight of the caption TF-IDF cosine in φ.
    pub w_cap: f64,
    /// Weight of the feature cosine in φ.
    pub w_fea: f64,
    /// δ_sim: a detection joins an object only when φ exceeds this.
    pub sim_threshold: f64,
    /// How many of the latest captions are merged into the object's caption (and compared
    /// with new detections).
    pub merge_captions: usize,
    /// Post-processing: objects with fewer points are dropped ...
    pub min_object_points: usize,
    /// ... unless at least this many detections were fused into them ...
    pub tracked_detections: u32,
    /// ... and they keep at least this many points: a small thing (a hydrant, a post box, a
    /// sign) seen again and again is real even when its points are under
    /// `min_object_points`.
    pub tracked_min_points: usize,
    /// Post-processing: a point cluster of an object other than its largest becomes an
    /// object of its own when it holds at least this share of the object's points (and
    /// `min_object_points`); smaller ones are dropped as noise.
    pub split_min_share: f64,
    /// Post-processing: buildings, fences and vegetation, and objects of one kind (one
    /// map-wide label), whose points come within this distance of each other (DBSCAN over
    /// the pooled points) become one object.
    pub join_eps_m: f32,
    /// Post-processing: merge when the shared-voxel ratio exceeds this ...
    pub merge_overlap: f64,
    /// ... and the feature cosine exceeds this.
    pub merge_feature_cos: f64,
    /// Surface classes (road, parking, sidewalk, other-ground, terrain) are fused per class
    /// within square ground tiles of this size.
    pub background_tile_m: f64,
    /// Scans accumulated into each key frame (1 = the key frame alone): the key frame and the
    /// `accumulate - 1` scans before it, moved into the key frame's velodyne frame.
    pub accumulate: usize,
    /// Commit to the store after this many key frames.
    pub commit_every: usize,
    /// Image size used when a sequence has no `image_2/` images: `[width, height]`.
    pub image_size: [u32; 2],
    /// An object's SemanticKITTI class is `other-object` when its label's best class score
    /// (the cosine of the label's embedding with a class prompt, averaged with its head
    /// word's for a compound) is below this: none of the 19 classes fits well enough.
    pub other_object_below: f64,
}

impl Default for MappingConfig {
    fn default() -> Self {
        MappingConfig {
            voxel_m: 0.1,
            dbscan_eps_m: 0.5,
            dbscan_min_points: 5,
            foreground_min_share: 0.3,
            mask_core_px: 3,
            w_geo: 1.0,
            iou_min_side_m: 0.5,
            w_cap: 0.2,
            w_fea: 0.4,
            sim_threshold: 0.6,
            merge_captions: 4,
            min_object_points: 50,
            tracked_detections: 2,
            tracked_min_points: 15,
            split_min_share: 0.2,
            join_eps_m: 1.0,
            merge_overlap: 0.1,
            merge_feature_cos: 0.3,
            background_tile_m: 20.0,
            accumulate: 1,
            commit_every: 10,
            image_size: [1242, 375],
            other_object_below: 0.45,
        }
    }
}

impl MappingConfig {
    /// True when a detection and an object whose boxes do not overlap can never pass the
    /// similarity threshold: with IoU 0, φ is at most `w_cap + w_fea`, and a pair must score
    /// above `sim_threshold`. Then association looks only at objects near the detection's
    /// box (the box grid), so its cost per key frame does not grow with the map. The sum is
    /// compared with a tolerance: in binary 0.2 + 0.4 is 0.6000000000000001, above 0.6, and
    /// an exact test once turned the grid off for the defaults.
    pub fn needs_overlap(&self) -> bool {
        self.w_cap + self.w_fea <= self.sim_threshold + 1e-9
    }

    /// Checks ranges; the message names the field.
    pub fn validate(&self) -> crate::Result<()> {
        let bad = |m: &str| Err(crate::Error::Invalid(format!("mapping config: {m}")));
        // lengths in metres and weights: finite, and below a sane magnitude
        let pos = |x: f64| x.is_finite() && x > 0.0 && x < 1e6;
        if !pos(f64::from(self.voxel_m)) {
            return bad("voxel_m must be a positive number below 1e6");
        }
        if !pos(f64::from(self.dbscan_eps_m)) {
            return bad("dbscan_eps_m must be a positive number below 1e6");
        }
        if !pos(f64::from(self.join_eps_m)) {
            return bad("join_eps_m must be a positive number below 1e6");
        }
        if !(self.iou_min_side_m.is_finite() && (0.0..1e6).contains(&self.iou_min_side_m)) {
            return bad("iou_min_side_m must be a non-negative number below 1e6");
        }
        if !pos(self.background_tile_m) {
            return bad("background_tile_m must be a positive number below 1e6");
        }
        for (n, w) in [
            ("w_geo", self.w_geo),
            ("w_cap", self.w_cap),
            ("w_fea", self.w_fea),
            ("sim_threshold", self.sim_threshold),
            ("merge_overlap", self.merge_overlap),
            ("split_min_share", self.split_min_share),
        ] {
            if !(w.is_finite() && (0.0..1e6).contains(&w)) {
                return bad(&format!("{n} must be a non-negative number below 1e6"));
            }
        }
        if !(self.foreground_min_share.is_finite()
            && (0.0..=1.0).contains(&self.foreground_min_share))
        {
            return bad("foreground_min_share must be a number in [0, 1]");
        }
        if self.mask_core_px > 1_000 {
            return bad("mask_core_px must be at most 1000 pixels");
        }
        if !self.merge_feature_cos.is_finite() {
            return bad("merge_feature_cos must be finite");
        }
        if !(0.0..=1.0).contains(&self.other_object_below) {
            return bad("other_object_below must be a cosine between 0 and 1");
        }
        if self.merge_captions == 0 || self.accumulate == 0 || self.commit_every == 0 {
            return bad("merge_captions, accumulate and commit_every must be at least 1");
        }
        // a DBSCAN neighbourhood holds the point itself; more than a scan's points is a typo
        for (n, v) in [
            ("dbscan_min_points", self.dbscan_min_points),
            ("tracked_detections", self.tracked_detections as usize),
            ("min_object_points", self.min_object_points),
            ("tracked_min_points", self.tracked_min_points),
        ] {
            if v == 0 || v > 1_000_000 {
                return bad(&format!("{n} must be between 1 and 1000000"));
            }
        }
        if self.image_size[0] == 0 || self.image_size[1] == 0 {
            return bad("image_size must be positive");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_weights_need_box_overlap() {
        // 0.2 + 0.4 > 0.6 in binary: the test must still say true, or association scans
        // every object in the map for every detection
        let c = MappingConfig::default();
        assert!(
            c.w_cap + c.w_fea > c.sim_threshold,
            "the case the tolerance is for"
        );
        assert!(c.needs_overlap());
        let loose = MappingConfig {
            sim_threshold: 0.5,
            ..MappingConfig::default()
        };
        assert!(!loose.needs_overlap());
    }
}
