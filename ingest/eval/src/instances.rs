//! Instance-level evaluation of a map built from the simulator: does one real object become
//! one instance? Map instances (not surface tiles) are matched one-to-one with the
//! simulator's ground-truth objects (`ground_truth/objects.json`) by ground-plane footprint
//! IoU, greedily from the highest IoU, a match needing IoU ≥ [`MATCH_IOU`]. Recall is given
//! per true class (the simulator's class, e.g. `building` or `bench`), precision per map class
//! (one of the 19 SemanticKITTI classes).
//!
//! An instance's footprint is its oriented box (`obb`; maps built before oriented boxes: the
//! axis-aligned box) on the ground plane (KITTI world x, z); a true footprint is the
//! simulator's oriented box. Both are widened to at least
//! [`MIN_SIDE_M`] per side, so that thin objects (a 0.1 m fence, a pole) can match at all.
//! Polygon overlap is parry2d's convex-polygon intersection.

use std::collections::BTreeMap;
use std::path::Path;

use graphstore::GraphRead;
use scene::records::InstanceRecord;
use scene::{GroundFrame, OrientedBox};

use crate::Result;
use ingest::sources::sim::truth::{TruthObject, mover_lines, read_truth};

/// Footprint IoU a match needs.
pub const MATCH_IOU: f64 = 0.5;

/// Footprint sides shorter than this (metres) are widened to it, about their centre.
pub const MIN_SIDE_M: f64 = 1.0;

/// A rectangle (corners in order) with each side widened to at least `min_side_m`, about
/// its centre.
fn widen(r: &[[f64; 2]; 4], min_side_m: f64) -> [[f64; 2]; 4] {
    OrientedBox::from_rectangle(r, [0.0, 0.0])
        .widened(min_side_m)
        .corners()
}

/// Counts and shares of one class.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ClassCounts {
    /// Objects (true classes) or instances (map classes) of the class.
    pub total: usize,
    /// Of those, matched one-to-one.
    pub matched: usize,
    /// `matched / total` (recall for true classes, precision for map classes).
    pub share: f64,
}

/// The result of [`eval_instances`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct InstanceEval {
    /// Map instances evaluated (surface tiles excluded).
    pub instances: usize,
    /// Ground-truth objects.
    pub objects: usize,
    /// One-to-one matches with footprint IoU ≥ 0.5.
    pub matched: usize,
    /// `matched / instances`.
    pub precision: f64,
    /// `matched / objects`.
    pub recall: f64,
    /// Recall per true class.
    pub recall_per_class: BTreeMap<String, ClassCounts>,
    /// Precision per map class.
    pub precision_per_class: BTreeMap<String, ClassCounts>,
    /// Surface tiles in the map (not evaluated).
    pub surface_tiles: usize,
    /// Label accuracy over matched pairs: the instance's label names the object's kind (the
    /// kind's name, or the noun phrase of a noun the simulator gives that kind anywhere on
    /// the map, e.g. "post box" for a mailbox), per true class.
    pub label_accuracy_per_class: BTreeMap<String, ClassCounts>,
    /// Label accuracy over all matched pairs.
    pub label_accuracy: f64,
    /// Distinct labels on the matched instances of each true class (1 when one kind has one
    /// label), with how many instances carry each.
    pub labels_per_class: BTreeMap<String, BTreeMap<String, usize>>,
    /// SemanticKITTI class accuracy over matched pairs against the class of the object's
    /// LiDAR points (the simulator's raw label through `learning_map`; `other-object` for
    /// what the 19 classes leave unlabelled), per true class.
    pub semantic_class_accuracy_per_class: BTreeMap<String, ClassCounts>,
    /// Semantic class accuracy over all matched pairs.
    pub semantic_class_accuracy: f64,
    /// With moving objects in the simulation (`ground_truth/movers.json`): unmatched
    /// instances whose footprint centre lies within [`GHOST_M`] of a line a mover drives or
    /// walks: the trails moving objects leave in a map. `None` without movers.
    pub ghosts: Option<usize>,
    /// The same map scored by the points each object was seen with
    /// ([`crate::instance_points`]); `None` when the simulation has no `labels/`.
    pub by_points: Option<crate::instance_points::PointInstanceEval>,
}

/// How near a mover's line an unmatched instance counts as its ghost, metres.
pub const GHOST_M: f64 = 1.5;

/// IoU of two rectangles (corners in order, either winding) on the ground plane; 0 for
/// degenerate ones.
pub fn footprint_iou(a: &[[f64; 2]; 4], b: &[[f64; 2]; 4]) -> f64 {
    let r = |c: &[[f64; 2]; 4]| OrientedBox::from_rectangle(c, [0.0, 0.0]);
    r(a).footprint_iou(&r(b))
}

/// Footprint of an instance: its oriented box (`obb`) or, without one, its axis-aligned
/// `bbox`, widened to [`MIN_SIDE_M`].
fn instance_footprint(inst: &InstanceRecord, frame: GroundFrame) -> [[f64; 2]; 4] {
    let (min, max) = inst.bbox;
    ingest::hierarchy::relations::InstanceBox::new(frame, min, max, inst.obb)
        .obb
        .widened(MIN_SIDE_M)
        .corners()
}

/// Greedy one-to-one matching by IoU: pairs `(instance index, truth index)`.
fn match_greedy(inst: &[[[f64; 2]; 4]], truth: &[TruthObject]) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for (i, f) in inst.iter().enumerate() {
        let (lo, hi) = bounds(f);
        for (j, t) in truth.iter().enumerate() {
            let (tlo, thi) = bounds(&t.footprint);
            if lo[0] > thi[0] || tlo[0] > hi[0] || lo[1] > thi[1] || tlo[1] > hi[1] {
                continue;
            }
            let iou = footprint_iou(f, &t.footprint);
            if iou >= MATCH_IOU {
                pairs.push((iou, i, j));
            }
        }
    }
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut used_i, mut used_j) = (vec![false; inst.len()], vec![false; truth.len()]);
    let mut out = Vec::new();
    for (_, i, j) in pairs {
        if !used_i[i] && !used_j[j] {
            used_i[i] = true;
            used_j[j] = true;
            out.push((i, j));
        }
    }
    out
}

fn bounds(p: &[[f64; 2]; 4]) -> ([f64; 2], [f64; 2]) {
    let [lo, hi] = scene::geom::bounds(p);
    (lo, hi)
}

/// Sets `share` to `matched / total` (0 for an empty class).
pub(crate) fn share(c: &mut ClassCounts) {
    c.share = if c.total == 0 {
        0.0
    } else {
        c.matched as f64 / c.total as f64
    };
}

/// Scores the map's instances against `SIM_DIR/ground_truth/objects.json`.
///
/// # Errors
/// The truth file is missing or malformed; the store cannot be read.
pub fn eval_instances(r: &impl GraphRead, sim_dir: &Path) -> Result<InstanceEval> {
    // the simulator writes KITTI-style sequences
    let frame = GroundFrame::KittiCam;
    let mut truth = read_truth(sim_dir)?;
    for t in &mut truth {
        t.footprint = widen(&t.footprint, MIN_SIDE_M);
    }
    let mut out = InstanceEval {
        objects: truth.len(),
        ..InstanceEval::default()
    };
    let mut feet = Vec::new();
    let mut classes = Vec::new();
    let mut labels: Vec<String> = Vec::new();
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let Some(inst) = InstanceRecord::read(r, id)? else {
            continue;
        };
        if !ingest::llm::is_object_record(&inst) {
            out.surface_tiles += 1;
            continue;
        }
        feet.push(instance_footprint(&inst, frame));
        labels.push(inst.label.clone().unwrap_or_default());
        classes.push(inst.semantic_class);
    }
    out.instances = feet.len();
    let matches = match_greedy(&feet, &truth);
    out.matched = matches.len();
    if let Some(lines) = mover_lines(sim_dir)? {
        let mut matched = vec![false; feet.len()];
        for (i, _) in &matches {
            matched[*i] = true;
        }
        let near_line = |c: [f64; 2]| {
            lines.iter().any(|l| {
                l.windows(2).any(|w| {
                    let (_, q) = scene::geom::closest_on_segment(c, w[0], w[1]);
                    (c[0] - q[0]).hypot(c[1] - q[1]) <= GHOST_M
                })
            })
        };
        out.ghosts = Some(
            feet.iter()
                .zip(&matched)
                .filter(|(f, m)| {
                    let c = [(f[0][0] + f[2][0]) / 2.0, (f[0][1] + f[2][1]) / 2.0];
                    !**m && near_line(c)
                })
                .count(),
        );
    }
    for t in &truth {
        out.recall_per_class
            .entry(t.class.clone())
            .or_default()
            .total += 1;
    }
    for c in &classes {
        out.precision_per_class.entry(c.clone()).or_default().total += 1;
    }
    for (i, j) in &matches {
        out.recall_per_class
            .get_mut(&truth[*j].class)
            .expect("counted")
            .matched += 1;
        out.precision_per_class
            .get_mut(&classes[*i])
            .expect("counted")
            .matched += 1;
    }
    // the names of each kind: its class and the noun phrases of the nouns it is given
    let lexicon = llm_tools::labels::Lexicon::load_default().unwrap_or_default();
    let mut names: BTreeMap<&str, std::collections::BTreeSet<String>> = BTreeMap::new();
    for t in &truth {
        let n = names.entry(t.class.as_str()).or_default();
        n.insert(t.class.clone());
        n.insert(llm_tools::labels::noun_phrase(&t.noun, &lexicon));
    }
    let tally = |m: &mut BTreeMap<String, ClassCounts>, class: &str, ok: bool| {
        let c = m.entry(class.to_string()).or_default();
        c.total += 1;
        c.matched += usize::from(ok);
    };
    for (i, j) in &matches {
        let t = &truth[*j];
        let ok = names[t.class.as_str()].contains(&labels[*i]);
        tally(&mut out.label_accuracy_per_class, &t.class, ok);
        *out.labels_per_class
            .entry(t.class.clone())
            .or_default()
            .entry(labels[*i].clone())
            .or_insert(0) += 1;
        let ok = semantic_class_of(&t.class).is_some_and(|w| w == classes[*i]);
        tally(&mut out.semantic_class_accuracy_per_class, &t.class, ok);
    }
    out.recall_per_class.values_mut().for_each(share);
    out.precision_per_class.values_mut().for_each(share);
    out.label_accuracy_per_class.values_mut().for_each(share);
    out.semantic_class_accuracy_per_class
        .values_mut()
        .for_each(share);
    let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    out.precision = ratio(out.matched, out.instances);
    out.recall = ratio(out.matched, out.objects);
    let right = |m: &BTreeMap<String, ClassCounts>| m.values().map(|c| c.matched).sum();
    out.label_accuracy = ratio(right(&out.label_accuracy_per_class), out.matched);
    out.semantic_class_accuracy = ratio(right(&out.semantic_class_accuracy_per_class), out.matched);
    if sim_dir.join("labels").is_dir() {
        let image_size = ingest::mapping::MappingConfig::default().image_size;
        out.by_points = Some(crate::instance_points::eval_instance_points(
            r, sim_dir, image_size,
        )?);
    }
    Ok(out)
}

/// The SemanticKITTI class of a simulator class's LiDAR points: its raw label through
/// `learning_map`, or `other-object` when the 19 classes leave that label unlabelled;
/// `None` for a class the simulator does not have.
fn semantic_class_of(sim_class: &str) -> Option<&'static str> {
    use ingest::sources::sim::scene::Kind;
    let kind = Kind::ALL.iter().find(|k| k.class() == sim_class)?;
    let id = scene::classes::learning_class(kind.semantic());
    Some(scene::classes::class_name(id).unwrap_or(scene::classes::OTHER_OBJECT))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, z0: f64, x1: f64, z1: f64) -> [[f64; 2]; 4] {
        [[x0, z0], [x1, z0], [x1, z1], [x0, z1]]
    }

    #[test]
    fn iou_of_rectangles() {
        let a = rect(0.0, 0.0, 2.0, 2.0);
        assert!((footprint_iou(&a, &a) - 1.0).abs() < 1e-5);
        // half overlap: 2 / (4 + 4 - 2)
        let b = rect(1.0, 0.0, 3.0, 2.0);
        assert!((footprint_iou(&a, &b) - 1.0 / 3.0).abs() < 1e-5);
        // winding does not matter
        let mut rev = b;
        rev.reverse();
        assert!((footprint_iou(&a, &rev) - 1.0 / 3.0).abs() < 1e-5);
        assert!(footprint_iou(&a, &rect(5.0, 5.0, 6.0, 6.0)).abs() < 1e-12);
        assert!(footprint_iou(&a, &rect(1.0, 1.0, 1.0, 3.0)).abs() < 1e-12);
    }

    #[test]
    fn rotated_square_against_its_bounding_box() {
        // a unit square turned 45°: area 1 inside its bounding box of area 2
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let diamond = [[0.0, -h], [h, 0.0], [0.0, h], [-h, 0.0]];
        let bbox = rect(-h, -h, h, h);
        assert!((footprint_iou(&diamond, &bbox) - 0.5).abs() < 1e-4);
    }

    fn area(c: &[[f64; 2]; 4]) -> f64 {
        OrientedBox::from_rectangle(c, [0.0, 0.0]).footprint_area()
    }

    #[test]
    fn thin_footprints_are_widened_about_their_centre() {
        // a 0.1 m x 4 m fence turned 90° and a point-like pole
        let fence = widen(&rect(0.0, 0.0, 4.0, 0.1), 1.0);
        assert!((area(&fence) - 4.0).abs() < 1e-9);
        let c: [f64; 2] = [
            fence.iter().map(|p| p[0]).sum::<f64>() / 4.0,
            fence.iter().map(|p| p[1]).sum::<f64>() / 4.0,
        ];
        assert!((c[0] - 2.0).abs() < 1e-9 && (c[1] - 0.05).abs() < 1e-9);
        let pole = widen(&rect(3.0, 3.0, 3.0, 3.0), 1.0);
        assert!((area(&pole) - 1.0).abs() < 1e-9);
        let line = widen(&rect(0.0, 0.0, 2.0, 0.0), 1.0);
        assert!((area(&line) - 2.0).abs() < 1e-9);
        // large sides stay
        let big = rect(0.0, 0.0, 3.0, 2.0);
        assert!((footprint_iou(&widen(&big, 1.0), &big) - 1.0).abs() < 1e-9);
        assert!((area(&widen(&big, 1.0)) - 6.0).abs() < 1e-9);
    }

    #[test]
    fn matching_is_one_to_one_best_first() {
        let truth = |c: [f64; 2]| TruthObject {
            id: 0,
            centre_xz: c,
            radius_m: 1.0,
            class: "bench".into(),
            noun: String::new(),
            colour: String::new(),
            material: String::new(),
            footprint: rect(c[0] - 1.0, c[1] - 1.0, c[0] + 1.0, c[1] + 1.0),
            heights: (0.0, 1.0),
        };
        let t = vec![truth([0.0, 0.0]), truth([10.0, 0.0])];
        // two instances on the first object (one exact, one shifted), none on the second
        let inst = vec![rect(-0.8, -1.0, 1.2, 1.0), rect(-1.0, -1.0, 1.0, 1.0)];
        let m = match_greedy(&inst, &t);
        assert_eq!(m, vec![(1, 0)]);
    }
}
