//! Instance layer: a minimum spanning tree over instance boxes (close or overlapping pairs
//! preferred) plus every pair within `near_m`, each labelled with geometric relations from
//! the boxes (distances through parry3d) and the local road direction.

use parry3d::math::{Pose, Vector};
use parry3d::shape::Cuboid;

use scene::GroundFrame;

/// Relation parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RelationConfig {
    /// Pairs farther apart than this are not candidates for the spanning tree.
    pub candidate_m: f64,
    /// Pairs within this distance are always related.
    pub near_m: f64,
    /// Boxes within this distance are `next_to` each other.
    pub next_to_m: f64,
    /// Vertical tolerance for `on` / `under`.
    pub on_tolerance_m: f64,
    /// Fraction of a box inside another for `inside`.
    pub inside_fraction: f64,
}

impl Default for RelationConfig {
    fn default() -> Self {
        RelationConfig {
            candidate_m: 15.0,
            near_m: 3.0,
            next_to_m: 1.0,
            on_tolerance_m: 0.3,
            inside_fraction: 0.9,
        }
    }
}

/// An instance's axis-aligned box in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstanceBox {
    /// Min corner.
    pub min: [f64; 3],
    /// Max corner.
    pub max: [f64; 3],
}

impl InstanceBox {
    pub(crate) fn centre(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| (self.min[i] + self.max[i]) / 2.0)
    }
    fn volume(&self) -> f64 {
        (0..3)
            .map(|i| (self.max[i] - self.min[i]).max(0.0))
            .product()
    }
    fn overlap_volume(&self, o: &InstanceBox) -> f64 {
        (0..3)
            .map(|i| (self.max[i].min(o.max[i]) - self.min[i].max(o.min[i])).max(0.0))
            .product()
    }
}

/// One labelled relation: `a <relation> b`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Relation {
    /// Index of the subject box.
    pub a: usize,
    /// Index of the object box.
    pub b: usize,
    /// on, under, next_to, near, in_front_of, behind, left_of, right_of or inside.
    pub relation: &'static str,
    /// Distance between the boxes (0 when they touch or overlap).
    pub distance_m: f64,
    /// How clearly the geometry supports the label, 0..1.
    pub confidence: f64,
}

/// Distance between two boxes, computed by parry3d.
pub fn box_distance(a: &InstanceBox, b: &InstanceBox) -> f64 {
    let shape = |x: &InstanceBox| {
        let h = [0, 1, 2].map(|i| ((x.max[i] - x.min[i]) / 2.0).max(1e-3) as f32);
        let c = x.centre();
        (
            Cuboid::new(Vector::new(h[0], h[1], h[2])),
            Pose::from_translation(Vector::new(c[0] as f32, c[1] as f32, c[2] as f32)),
        )
    };
    let (sa, pa) = shape(a);
    let (sb, pb) = shape(b);
    parry3d::query::distance(&pa, &sa, &pb, &sb)
        .map(|d| f64::from(d.distance.max(0.0)))
        .unwrap_or(f64::INFINITY)
}

fn find(parent: &mut [usize], x: usize) -> usize {
    let mut r = x;
    while parent[r] != r {
        r = parent[r];
    }
    let mut y = x;
    while parent[y] != r {
        let n = parent[y];
        parent[y] = r;
        y = n;
    }
    r
}

/// Minimum spanning forest over candidate pairs, weighted by box distance minus the overlap
/// fraction (so overlapping and close pairs win). Returns pairs `(i, j)`, `i < j`.
pub fn spanning_tree(
    boxes: &[InstanceBox],
    frame: GroundFrame,
    cfg: &RelationConfig,
) -> Vec<(usize, usize, f64)> {
    let mut weighted: Vec<(f64, usize, usize, f64)> =
        candidate_pairs(boxes, frame, cfg.candidate_m)
            .into_iter()
            .map(|(i, j, d)| {
                let ov = boxes[i].overlap_volume(&boxes[j])
                    / boxes[i].volume().min(boxes[j].volume()).max(1e-9);
                (d - ov, i, j, d)
            })
            .collect();
    weighted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut parent: Vec<usize> = (0..boxes.len()).collect();
    let mut out = Vec::new();
    for (_, i, j, d) in weighted {
        let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
        if ri != rj {
            parent[ri] = rj;
            out.push((i, j, d));
        }
    }
    out
}

/// Pairs `(i, j, distance)` with `i < j` whose boxes are within `max_m`, found through a
/// ground-plane grid over box centres and measured exactly with parry3d.
pub fn candidate_pairs(
    boxes: &[InstanceBox],
    frame: GroundFrame,
    max_m: f64,
) -> Vec<(usize, usize, f64)> {
    let centres: Vec<[f64; 2]> = boxes.iter().map(|b| frame.ground(b.centre())).collect();
    let largest = boxes
        .iter()
        .map(|b| (0..3).map(|i| b.max[i] - b.min[i]).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    // two boxes within max_m have centres within max_m + both half-diagonals
    let reach = max_m + largest * 3f64.sqrt();
    let grid = crate::cluster::Grid2::new(&centres, reach.max(1e-6));
    let mut out = Vec::new();
    for i in 0..boxes.len() {
        for j in grid.within(&centres, centres[i], reach) {
            if j <= i {
                continue;
            }
            let d = box_distance(&boxes[i], &boxes[j]);
            if d <= max_m {
                out.push((i, j, d));
            }
        }
    }
    out
}
/// Labels the relations of one pair. `road_dir` is the local road direction on the ground.
pub fn label_pair(
    boxes: &[InstanceBox],
    a: usize,
    b: usize,
    frame: GroundFrame,
    road_dir: Option<[f64; 2]>,
    cfg: &RelationConfig,
) -> Vec<Relation> {
    let (ba, bb) = (&boxes[a], &boxes[b]);
    let d = box_distance(ba, bb);
    let mut out = Vec::new();
    let rel = |x: usize, y: usize, r: &'static str, conf: f64| Relation {
        a: x,
        b: y,
        relation: r,
        distance_m: d,
        confidence: conf.clamp(0.0, 1.0),
    };
    let ov = ba.overlap_volume(bb);
    if ov >= cfg.inside_fraction * ba.volume() && ba.volume() < bb.volume() {
        out.push(rel(a, b, "inside", ov / ba.volume().max(1e-9)));
        return out;
    }
    if ov >= cfg.inside_fraction * bb.volume() && bb.volume() < ba.volume() {
        out.push(rel(b, a, "inside", ov / bb.volume().max(1e-9)));
        return out;
    }
    // vertical stacking: ground footprints overlap and one rests on the other
    let (ga0, ga1) = (frame.ground(ba.min), frame.ground(ba.max));
    let (gb0, gb1) = (frame.ground(bb.min), frame.ground(bb.max));
    let foot = (0..2).all(|i| {
        ga0[i].min(ga1[i]).max(gb0[i].min(gb1[i])) < ga0[i].max(ga1[i]).min(gb0[i].max(gb1[i]))
    });
    let (ha, hb) = (height_range(frame, ba), height_range(frame, bb));
    if foot {
        let gap_ab = (ha.0 - hb.1).abs(); // a's bottom on b's top
        let gap_ba = (hb.0 - ha.1).abs();
        if gap_ab <= cfg.on_tolerance_m && ha.0 >= hb.0 {
            let c = 1.0 - gap_ab / cfg.on_tolerance_m.max(1e-9) * 0.5;
            out.push(rel(a, b, "on", c));
            out.push(rel(b, a, "under", c));
            return out;
        }
        if gap_ba <= cfg.on_tolerance_m && hb.0 >= ha.0 {
            let c = 1.0 - gap_ba / cfg.on_tolerance_m.max(1e-9) * 0.5;
            out.push(rel(b, a, "on", c));
            out.push(rel(a, b, "under", c));
            return out;
        }
    }
    if d <= cfg.next_to_m {
        out.push(rel(
            a,
            b,
            "next_to",
            1.0 - d / cfg.next_to_m.max(1e-9) * 0.5,
        ));
    } else if d <= cfg.near_m {
        out.push(rel(
            a,
            b,
            "near",
            1.0 - (d - cfg.next_to_m) / (cfg.near_m - cfg.next_to_m).max(1e-9) * 0.5,
        ));
    }
    // direction along and across the road
    if let Some(dir) = road_dir {
        let (ca, cb) = (frame.ground(ba.centre()), frame.ground(bb.centre()));
        let v = [cb[0] - ca[0], cb[1] - ca[1]];
        let along = v[0] * dir[0] + v[1] * dir[1];
        let left = frame.left_of(dir);
        let across = v[0] * left[0] + v[1] * left[1];
        let total = along.abs() + across.abs();
        if total > 0.5 {
            if along.abs() >= across.abs() {
                let c = along.abs() / total;
                let (front, back) = if along > 0.0 { (b, a) } else { (a, b) };
                out.push(rel(front, back, "in_front_of", c));
                out.push(rel(back, front, "behind", c));
            } else {
                let c = across.abs() / total;
                let (l, r) = if across > 0.0 { (b, a) } else { (a, b) };
                out.push(rel(l, r, "left_of", c));
                out.push(rel(r, l, "right_of", c));
            }
        }
    }
    out
}

fn height_range(frame: GroundFrame, b: &InstanceBox) -> (f64, f64) {
    let (h0, h1) = (frame.height(b.min), frame.height(b.max));
    (h0.min(h1), h0.max(h1))
}

/// All relations: spanning-tree edges plus every pair within `near_m`, labelled.
pub fn infer_relations(
    boxes: &[InstanceBox],
    frame: GroundFrame,
    road_dir: impl Fn([f64; 2]) -> Option<[f64; 2]>,
    cfg: &RelationConfig,
) -> Vec<Relation> {
    let mut pairs: std::collections::BTreeSet<(usize, usize)> = spanning_tree(boxes, frame, cfg)
        .into_iter()
        .map(|(i, j, _)| (i, j))
        .collect();
    pairs.extend(
        candidate_pairs(boxes, frame, cfg.near_m)
            .into_iter()
            .map(|(i, j, _)| (i, j)),
    );
    let mut out = Vec::new();
    for (i, j) in pairs {
        let mid = {
            let (ci, cj) = (
                frame.ground(boxes[i].centre()),
                frame.ground(boxes[j].centre()),
            );
            [(ci[0] + cj[0]) / 2.0, (ci[1] + cj[1]) / 2.0]
        };
        out.extend(label_pair(boxes, i, j, frame, road_dir(mid), cfg));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bx(min: [f64; 3], max: [f64; 3]) -> InstanceBox {
        InstanceBox { min, max }
    }

    const F: GroundFrame = GroundFrame::Enu;

    fn labels(r: &[Relation]) -> Vec<(usize, usize, &'static str)> {
        let mut v: Vec<_> = r.iter().map(|r| (r.a, r.b, r.relation)).collect();
        v.sort();
        v
    }

    #[test]
    fn parry_box_distance() {
        let a = bx([0.0; 3], [1.0; 3]);
        let b = bx([3.0, 0.0, 0.0], [4.0, 1.0, 1.0]);
        assert!((box_distance(&a, &b) - 2.0).abs() < 1e-4);
        assert!(box_distance(&a, &bx([0.5; 3], [2.0; 3])) < 1e-6);
    }

    #[test]
    fn on_under_inside_next_to_and_road_directions() {
        let cfg = RelationConfig::default();
        // a box resting on a table, in ENU (z up)
        let boxes = [
            bx([0.0, 0.0, 0.0], [2.0, 1.0, 1.0]),
            bx([0.5, 0.2, 1.0], [0.9, 0.6, 1.3]),
        ];
        assert_eq!(
            labels(&label_pair(&boxes, 1, 0, F, None, &cfg)),
            vec![(0, 1, "under"), (1, 0, "on")]
        );
        // a small box inside a big one
        let boxes = [bx([0.0; 3], [4.0; 3]), bx([1.0; 3], [2.0; 3])];
        assert_eq!(
            labels(&label_pair(&boxes, 0, 1, F, None, &cfg)),
            vec![(1, 0, "inside")]
        );
        // two cars one behind the other along a road heading +x, 0.5 m apart
        let boxes = [
            bx([0.0, 0.0, 0.0], [4.0, 2.0, 1.5]),
            bx([4.5, 0.0, 0.0], [8.5, 2.0, 1.5]),
        ];
        let l = labels(&label_pair(&boxes, 0, 1, F, Some([1.0, 0.0]), &cfg));
        assert_eq!(
            l,
            vec![(0, 1, "behind"), (0, 1, "next_to"), (1, 0, "in_front_of")]
        );
        // a bench to the left (+y when heading +x in ENU) of a lamp, 2 m apart
        let boxes = [
            bx([0.0, 0.0, 0.0], [0.3, 0.3, 4.0]),
            bx([0.0, 2.3, 0.0], [1.5, 2.8, 0.8]),
        ];
        let l = labels(&label_pair(&boxes, 0, 1, F, Some([1.0, 0.0]), &cfg));
        assert_eq!(
            l,
            vec![(0, 1, "near"), (0, 1, "right_of"), (1, 0, "left_of")]
        );
    }

    #[test]
    fn spanning_tree_prefers_close_pairs() {
        // three boxes on a line: 0 -1m- 1 -1m- 2; the tree must not link 0 and 2 directly
        let boxes = [
            bx([0.0; 3], [1.0; 3]),
            bx([2.0, 0.0, 0.0], [3.0, 1.0, 1.0]),
            bx([4.0, 0.0, 0.0], [5.0, 1.0, 1.0]),
        ];
        let t = spanning_tree(&boxes, F, &RelationConfig::default());
        let pairs: Vec<(usize, usize)> = t.iter().map(|(i, j, _)| (*i, *j)).collect();
        assert_eq!(pairs, vec![(0, 1), (1, 2)]);
        // overlapping pairs beat touching ones
        let boxes = [
            bx([0.0; 3], [2.0; 3]),
            bx([1.0; 3], [3.0; 3]),
            bx([2.0, 0.0, 0.0], [4.0, 2.0, 2.0]),
        ];
        let t = spanning_tree(&boxes, F, &RelationConfig::default());
        assert_eq!(t[0].0, 0);
        assert_eq!(t[0].1, 1);
    }
}
