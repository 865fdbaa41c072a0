//! Instance evaluation by the points each object was seen with (panoptic-style): a map
//! instance and a ground-truth object match when their point sets, as voxels of
//! [`VOXEL_M`] in the world frame, have IoU ≥ [`MATCH_IOU`] (one-to-one, greedily from the
//! highest IoU). A true object's points are the LiDAR points its instance id labels in every
//! scan (`labels/*.label`) that the camera sees within the detector's range (`sim.json`
//! `camera.max_detection_m`, measured from the LiDAR): what the perception front end gave
//! the mapping to see.
//!
//! This complements the footprint evaluation ([`crate::instances`]), which compares boxes
//! with the simulator's whole (amodal) boxes: a building seen only from the street is a
//! facade in the LiDAR, however well it is mapped, and a street lamp's arm is above the
//! LiDAR's top beam. Here those count as right when the map made one instance of what was
//! seen. Unmatched true objects are sorted into how they failed.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;

use graphstore::GraphRead;
use ingest::build::Sequence;
use ingest::mapping::geometry::{VoxelKey, voxel_key};
use ingest::sources::sim::truth::read_truth;
use scene::records::InstanceRecord;

use crate::Result;
use crate::instances::{ClassCounts, share};
use crate::labelled::for_each_labelled_point;

/// Voxel size of the point sets compared, metres.
pub const VOXEL_M: f32 = 0.2;
/// Voxel IoU a match needs.
pub const MATCH_IOU: f64 = 0.5;
/// True objects seen in fewer voxels than this are not evaluated (a few stray returns).
pub const MIN_VOXELS: usize = 5;

/// How the unmatched true objects of a class failed.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Failures {
    /// No instance holds a fifth of its voxels.
    pub missed: usize,
    /// Two or more instances, each mostly made of it, share it: seen in pieces.
    pub split: usize,
    /// The instance holding most of it holds most of another true object too: fused.
    pub fused: usize,
    /// The rest: one instance holds part of it (or it is mixed with unlabelled points).
    pub partial: usize,
}

/// The result of [`eval_instance_points`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct PointInstanceEval {
    /// Labelled scans read.
    pub scans: usize,
    /// True objects seen in at least [`MIN_VOXELS`] voxels (the ones evaluated).
    pub objects: usize,
    /// True objects the camera never saw in that many voxels (not evaluated).
    pub unseen: usize,
    /// Map instances (surface tiles excluded).
    pub instances: usize,
    /// One-to-one matches with voxel IoU ≥ [`MATCH_IOU`].
    pub matched: usize,
    /// `matched / instances`.
    pub precision: f64,
    /// `matched / objects`.
    pub recall: f64,
    /// Recall per true class.
    pub recall_per_class: BTreeMap<String, ClassCounts>,
    /// Precision per map label (the open-vocabulary label; `class` when it has none).
    pub precision_per_label: BTreeMap<String, ClassCounts>,
    /// How the unmatched true objects failed, per true class.
    pub failures_per_class: BTreeMap<String, Failures>,
}

/// Scores the object instances of the map in `r` against the simulator run in `sim_dir`
/// (a KITTI-layout sequence with `labels/` and `ground_truth/objects.json`), with the image
/// size the build assumed when the sequence has no images.
///
/// # Errors
/// The sequence, a scan, its labels or the truth file cannot be read; no scan is labelled;
/// the store fails.
pub fn eval_instance_points(
    r: &impl GraphRead,
    sim_dir: &Path,
    image_size: [u32; 2],
) -> Result<PointInstanceEval> {
    let truth = read_truth(sim_dir)?;
    let class_of: HashMap<i64, &str> = truth.iter().map(|t| (t.id, t.class.as_str())).collect();
    let seq = Sequence::open(sim_dir, None)?;
    let max_range_m = detection_range_m(sim_dir);
    let mut out = PointInstanceEval::default();
    // true voxels: voxel → object (the first one seen there keeps it)
    let mut owner: HashMap<VoxelKey, u16> = HashMap::new();
    out.scans = for_each_labelled_point(&seq, None, image_size, |p| {
        let [x, y, z] = p.velo;
        if p.label.instance == 0
            || !class_of.contains_key(&i64::from(p.label.instance))
            || f64::from(x.hypot(y).hypot(z)) > max_range_m
            || !p.in_view()
        {
            return;
        }
        owner
            .entry(voxel_key(p.world(), VOXEL_M))
            .or_insert(p.label.instance);
    })?;
    let mut truth_size: BTreeMap<u16, usize> = BTreeMap::new();
    for t in owner.values() {
        *truth_size.entry(*t).or_insert(0) += 1;
    }
    for (t, n) in &truth_size {
        if *n >= MIN_VOXELS {
            out.objects += 1;
            let c = class_of[&i64::from(*t)];
            out.recall_per_class.entry(c.to_string()).or_default().total += 1;
        } else {
            out.unseen += 1;
        }
    }
    out.unseen += truth.len().saturating_sub(truth_size.len());
    // map instances: their voxels, and how many of them each true object owns
    let mut inst_size = Vec::new();
    let mut inst_label = Vec::new();
    let mut inter: BTreeMap<(usize, u16), usize> = BTreeMap::new();
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let Some(inst) = InstanceRecord::read(r, id)? else {
            continue;
        };
        if !ingest::llm::is_object_record(&inst) {
            continue;
        }
        let Some(pc) = r.point_cloud(id, scene::payload::POINTS)? else {
            continue;
        };
        let voxels: HashSet<VoxelKey> = pc.xyz.iter().map(|p| voxel_key(*p, VOXEL_M)).collect();
        let k = inst_size.len();
        for v in &voxels {
            if let Some(t) = owner.get(v) {
                *inter.entry((k, *t)).or_insert(0) += 1;
            }
        }
        inst_size.push(voxels.len());
        inst_label.push(
            inst.label
                .clone()
                .unwrap_or_else(|| inst.semantic_class.clone()),
        );
    }
    out.instances = inst_size.len();
    for l in &inst_label {
        out.precision_per_label.entry(l.clone()).or_default().total += 1;
    }
    // one-to-one, best IoU first
    let mut pairs: Vec<(f64, usize, u16)> = inter
        .iter()
        .filter(|((_, t), _)| truth_size[t] >= MIN_VOXELS)
        .map(|(&(k, t), &n)| {
            let iou = n as f64 / (inst_size[k] + truth_size[&t] - n) as f64;
            (iou, k, t)
        })
        .filter(|p| p.0 >= MATCH_IOU)
        .collect();
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut used_i, mut used_t) = (HashSet::new(), HashSet::new());
    for (_, k, t) in pairs {
        if used_i.contains(&k) || used_t.contains(&t) {
            continue;
        }
        used_i.insert(k);
        used_t.insert(t);
        out.matched += 1;
        let c = class_of[&i64::from(t)];
        out.recall_per_class.get_mut(c).expect("counted").matched += 1;
        out.precision_per_label
            .get_mut(&inst_label[k])
            .expect("counted")
            .matched += 1;
    }
    // how the unmatched ones failed
    let mut by_truth: BTreeMap<u16, Vec<(usize, usize)>> = BTreeMap::new();
    let mut by_inst: BTreeMap<usize, Vec<(u16, usize)>> = BTreeMap::new();
    for (&(k, t), &n) in &inter {
        by_truth.entry(t).or_default().push((k, n));
        by_inst.entry(k).or_default().push((t, n));
    }
    for (t, n_t) in &truth_size {
        if *n_t < MIN_VOXELS || used_t.contains(t) {
            continue;
        }
        let c = class_of[&i64::from(*t)];
        let f = out.failures_per_class.entry(c.to_string()).or_default();
        let held = by_truth.get(t).cloned().unwrap_or_default();
        let Some(&(best, n_best)) = held.iter().max_by_key(|(k, n)| (*n, std::cmp::Reverse(*k)))
        else {
            f.missed += 1;
            continue;
        };
        if (n_best as f64) < 0.2 * *n_t as f64 {
            f.missed += 1;
            continue;
        }
        let mostly_t = held
            .iter()
            .filter(|(k, n)| {
                *n as f64 >= 0.5 * inst_size[*k] as f64 && *n as f64 >= 0.1 * *n_t as f64
            })
            .count();
        let other_in_best = by_inst[&best].iter().any(|(u, n)| {
            u != t && truth_size[u] >= MIN_VOXELS && *n as f64 >= 0.5 * truth_size[u] as f64
        });
        if n_best as f64 >= 0.5 * *n_t as f64 && other_in_best {
            f.fused += 1;
        } else if mostly_t >= 2 {
            f.split += 1;
        } else {
            f.partial += 1;
        }
    }
    out.recall_per_class.values_mut().for_each(share);
    out.precision_per_label.values_mut().for_each(share);
    let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    out.precision = ratio(out.matched, out.instances);
    out.recall = ratio(out.matched, out.objects);
    Ok(out)
}

/// The simulated detector's range (`sim.json` `camera.max_detection_m`), metres; unbounded
/// when the file or the key is missing.
fn detection_range_m(sim_dir: &Path) -> f64 {
    std::fs::read(sim_dir.join("sim.json"))
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|v| v["camera"]["max_detection_m"].as_f64())
        .unwrap_or(f64::INFINITY)
}
