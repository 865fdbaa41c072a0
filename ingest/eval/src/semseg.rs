//! Semantic-segmentation evaluation of a map against SemanticKITTI labels: each labelled scan
//! point (in the world frame) takes the class of the nearest map point within `max_dist_m`
//! (0.3 m); with none it is a miss. Per-class IoU over the 19 classes, mean IoU and macro F1
//! over the classes present in the ground truth.

use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use std::path::Path;

use graphstore::{GraphRead, Store, Value};

use crate::labelled::for_each_labelled_point;
use crate::{Error, Result};
use ingest::build::Sequence;
use ingest::mapping::geometry::voxel_key;
use scene::classes::{self, CLASSES};

/// Counts: `m[gt][pred]` with gt in 1..=19 and pred in 0..=19 (0 = no map point near).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Confusion {
    /// The matrix, 20×20 (row 0 unused).
    pub m: [[u64; 20]; 20],
}

/// Scores of one class.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ClassScore {
    /// TP / (TP + FP + FN).
    pub iou: f64,
    /// 2·TP / (2·TP + FP + FN).
    pub f1: f64,
    /// Ground-truth points of the class.
    pub support: u64,
}

/// The evaluation result.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SemsegReport {
    /// Mean IoU over classes present in the ground truth.
    pub miou: f64,
    /// Macro F1 over the same classes.
    pub f1: f64,
    /// Per class (present classes only).
    pub per_class: BTreeMap<String, ClassScore>,
    /// Labelled points evaluated.
    pub points: u64,
    /// Of those, points with no map point within the radius.
    pub missed: u64,
    /// Scans evaluated.
    pub scans: usize,
    /// Where the map's detections came from (`oracle` or `detections`).
    pub source: String,
    /// The same scores over the points that project into the camera image (the only part
    /// of a scan the detections can cover).
    pub in_view: ViewScores,
}

/// Scores over a subset of the points.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ViewScores {
    /// Mean IoU over classes present in the subset.
    pub miou: f64,
    /// Macro F1.
    pub f1: f64,
    /// Points in the subset.
    pub points: u64,
    /// Of those, points with no map point within the radius.
    pub missed: u64,
}

impl Confusion {
    /// Adds one labelled point.
    pub fn add(&mut self, gt: u8, pred: u8) {
        if (1..=19).contains(&gt) && pred <= 19 {
            self.m[gt as usize][pred as usize] += 1;
        }
    }

    /// Per-class scores, mean IoU and macro F1 (over classes with ground-truth points).
    pub fn scores(&self) -> (f64, f64, BTreeMap<String, ClassScore>) {
        let mut per = BTreeMap::new();
        for c in 1..=19usize {
            let support: u64 = self.m[c].iter().sum();
            if support == 0 {
                continue;
            }
            let tp = self.m[c][c];
            let fn_ = support - tp;
            let fp: u64 = (1..=19).filter(|g| *g != c).map(|g| self.m[g][c]).sum();
            let (tp, fp, fn_) = (tp as f64, fp as f64, fn_ as f64);
            per.insert(
                CLASSES[c - 1].to_string(),
                ClassScore {
                    iou: tp / (tp + fp + fn_),
                    f1: 2.0 * tp / (2.0 * tp + fp + fn_),
                    support,
                },
            );
        }
        let n = per.len().max(1) as f64;
        let miou = per.values().map(|s| s.iou).sum::<f64>() / n;
        let f1 = per.values().map(|s| s.f1).sum::<f64>() / n;
        (miou, f1, per)
    }
}

/// The map's points with their class, hashed for radius look-ups.
struct MapIndex {
    cell_m: f32,
    cells: HashMap<[i32; 3], Vec<([f32; 3], u8)>>,
}

impl MapIndex {
    fn from_store(r: &impl GraphRead, cell_m: f32) -> Result<MapIndex> {
        let mut cells: HashMap<[i32; 3], Vec<([f32; 3], u8)>> = HashMap::new();
        for id in r.nodes_with_label(scene::label::INSTANCE)? {
            let class = scene::records::InstanceRecord::read(r, id)?
                .map_or(0, |i| classes::class_id(&i.semantic_class).unwrap_or(0));
            if class == 0 {
                continue;
            }
            if let Some(pc) = r.point_cloud(id, scene::payload::POINTS)? {
                for p in pc.xyz {
                    cells
                        .entry(voxel_key(p, cell_m))
                        .or_default()
                        .push((p, class));
                }
            }
        }
        Ok(MapIndex { cell_m, cells })
    }

    fn nearest_class(&self, p: [f32; 3], max_m: f32) -> u8 {
        let k = voxel_key(p, self.cell_m);
        let mut best = (max_m * max_m, 0u8);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(v) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        for (q, c) in v {
                            let d2 = (0..3).map(|i| (q[i] - p[i]).powi(2)).sum::<f32>();
                            if d2 <= best.0 {
                                best = (d2, *c);
                            }
                        }
                    }
                }
            }
        }
        best.1
    }
}

/// Evaluates the map in `store` against the labelled scans of `sequence` (all of them, or
/// those in `frames`). `image_size` is the camera image size where `image_2/` has no image.
pub fn eval_semseg(
    store: &Store,
    sequence: &Path,
    poses: Option<&Path>,
    frames: Option<Range<u32>>,
    max_dist_m: f32,
    image_size: [u32; 2],
) -> Result<SemsegReport> {
    let seq = Sequence::open(sequence, poses)?;
    let r = store.read()?;
    let source = r
        .find_nodes(scene::label::BUILD, scene::key::BUILD_ID, &Value::Int(0))?
        .first()
        .map(|n| r.node_prop(*n, scene::key::SOURCE))
        .transpose()?
        .flatten()
        .and_then(|v| v.as_str().map(str::to_string))
        .ok_or_else(|| {
            Error::Invalid(format!(
                "{} holds no map build (no Build node); run `opengraph build` first",
                store.path().display()
            ))
        })?;
    let index = MapIndex::from_store(&r, max_dist_m)?;
    let mut conf = Confusion::default();
    let mut view = Confusion::default();
    let (mut missed, mut view_missed) = (0u64, 0u64);
    let scans = for_each_labelled_point(&seq, frames.as_ref(), image_size, |p| {
        let gt = classes::learning_class(p.label.semantic);
        if gt == 0 {
            return;
        }
        let pred = index.nearest_class(p.world(), max_dist_m);
        missed += u64::from(pred == 0);
        conf.add(gt, pred);
        if p.in_view() {
            view.add(gt, pred);
            view_missed += u64::from(pred == 0);
        }
    })?;
    let (miou, f1, per_class) = conf.scores();
    let points = per_class.values().map(|s| s.support).sum();
    let (view_miou, view_f1, view_per) = view.scores();
    let in_view = ViewScores {
        miou: view_miou,
        f1: view_f1,
        points: view_per.values().map(|s| s.support).sum(),
        missed: view_missed,
    };
    Ok(SemsegReport {
        in_view,
        miou,
        f1,
        per_class,
        points,
        missed,
        scans,
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const EPS: f64 = 1e-12;

    /// Two classes, car (1) and road (9), worked by hand:
    /// gt car: 8 predicted car, 1 road, 1 miss; gt road: 2 predicted car, 18 road.
    /// car: TP 8, FP 2, FN 2 → IoU 8/12, F1 16/20; road: TP 18, FP 1, FN 2 → IoU 18/21,
    /// F1 36/39.
    #[test]
    fn hand_computed_two_classes() {
        let mut c = Confusion::default();
        for (gt, pred, n) in [(1, 1, 8), (1, 9, 1), (1, 0, 1), (9, 1, 2), (9, 9, 18)] {
            for _ in 0..n {
                c.add(gt, pred);
            }
        }
        let (miou, f1, per) = c.scores();
        assert_eq!(per.len(), 2);
        assert!((per["car"].iou - 8.0 / 12.0).abs() < EPS);
        assert!((per["car"].f1 - 16.0 / 20.0).abs() < EPS);
        assert!((per["road"].iou - 18.0 / 21.0).abs() < EPS);
        assert!((per["road"].f1 - 36.0 / 39.0).abs() < EPS);
        assert_eq!(per["car"].support, 10);
        assert!((miou - (8.0 / 12.0 + 18.0 / 21.0) / 2.0).abs() < EPS);
        assert!((f1 - (16.0 / 20.0 + 36.0 / 39.0) / 2.0).abs() < EPS);
    }

    /// Predictions of a class absent from the ground truth lower the IoU of the true class
    /// but do not add a class to the mean; ignored labels (0) are not counted.
    #[test]
    fn absent_classes_and_ignored_points() {
        let mut c = Confusion::default();
        for _ in 0..3 {
            c.add(13, 13);
        }
        c.add(13, 15);
        c.add(0, 13);
        c.add(13, 0);
        let (miou, f1, per) = c.scores();
        assert_eq!(per.keys().collect::<Vec<_>>(), vec!["building"]);
        assert!((miou - 3.0 / 5.0).abs() < EPS);
        assert!((f1 - 6.0 / 8.0).abs() < EPS);
        let perfect = {
            let mut c = Confusion::default();
            c.add(1, 1);
            c.scores()
        };
        assert!((perfect.0 - 1.0).abs() < EPS && (perfect.1 - 1.0).abs() < EPS);
        assert_eq!(Confusion::default().scores().2.len(), 0);
    }
}
