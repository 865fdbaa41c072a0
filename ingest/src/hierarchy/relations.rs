//! Instance layer: a minimum spanning tree over instance boxes (close or overlapping pairs
//! preferred) plus every pair within `near_m`, each labelled with geometric relations from
//! the oriented boxes (distances between parry3d cuboids turned about the up axis,
//! overlaps of the footprints) and the local road direction.

use parry3d::math::{Pose, Vector};
use parry3d::shape::Cuboid;

use scene::{GroundFrame, OrientedBox, key};

/// Relation parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
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

/// An instance's box: its axis-aligned bounds in the world frame and its oriented box on
/// the ground plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstanceBox {
    /// Min corner, world frame.
    pub min: [f64; 3],
    /// Max corner, world frame.
    pub max: [f64; 3],
    /// The oriented box (the axis-aligned one, turned by nothing, when the instance has
    /// none).
    pub obb: OrientedBox,
}

impl InstanceBox {
    /// The box of an instance with bounds `min`..`max` and, if it has one, oriented box
    /// `obb` (the `Instance.obb` property).
    pub fn new(
        frame: GroundFrame,
        min: [f64; 3],
        max: [f64; 3],
        obb: Option<OrientedBox>,
    ) -> InstanceBox {
        InstanceBox {
            min,
            max,
            obb: obb.unwrap_or_else(|| OrientedBox::from_aabb(frame, min, max)),
        }
    }

    pub(crate) fn centre(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| (self.min[i] + self.max[i]) / 2.0)
    }
    fn volume(&self) -> f64 {
        self.obb.volume()
    }
    fn overlap_volume(&self, o: &InstanceBox) -> f64 {
        let (a, b) = (&self.obb, &o.obb);
        let dh = (a.height_m[1].min(b.height_m[1]) - a.height_m[0].max(b.height_m[0])).max(0.0);
        if dh <= 0.0 {
            return 0.0;
        }
        a.footprint_intersection_area(b) * dh
    }
}

/// The box of instance node `id` from its properties: `bbox` (or, without one, a point at
/// `centroid`) and `obb` when present. `None` when it has neither `bbox` nor `centroid`.
///
/// # Errors
/// The store fails.
pub fn read_instance_box(
    r: &impl graphstore::GraphRead,
    id: u64,
    frame: GroundFrame,
) -> graphstore::Result<Option<InstanceBox>> {
    let bbox = r.node_prop(id, key::BBOX)?.and_then(|v| v.as_box3d());
    let centroid = r.node_prop(id, key::CENTROID)?.and_then(|v| v.as_point3());
    let Some((min, max)) = bbox.or_else(|| centroid.map(|c| (c, c))) else {
        return Ok(None);
    };
    let obb = r
        .node_prop(id, key::OBB)?
        .and_then(|v| scene::records::obb_of(&v));
    Ok(Some(InstanceBox::new(frame, min, max, obb)))
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

/// Distance between two oriented boxes, metres, computed by parry3d. The boxes are placed
/// in (ground 0, ground 1, height) coordinates, an isometry of the world (up to a
/// reflection), so the distance is the world one; each is a cuboid turned by its yaw about
/// the height axis, relative to `a`'s centre to keep f32 precise.
pub fn box_distance(a: &InstanceBox, b: &InstanceBox) -> f64 {
    let origin = a.obb.center;
    let shape = |x: &InstanceBox| {
        let o = &x.obb;
        let h = [
            o.half_extents[0].max(1e-3) as f32,
            o.half_extents[1].max(1e-3) as f32,
            (o.height_span_m() / 2.0).max(1e-3) as f32,
        ];
        let c = [
            (o.center[0] - origin[0]) as f32,
            (o.center[1] - origin[1]) as f32,
            ((o.height_m[0] + o.height_m[1]) / 2.0) as f32,
        ];
        (
            Cuboid::new(Vector::new(h[0], h[1], h[2])),
            Pose::new(
                Vector::new(c[0], c[1], c[2]),
                Vector::new(0.0, 0.0, o.yaw_rad as f32),
            ),
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
    let foot = ba.obb.footprint_intersection_area(&bb.obb) > 0.0;
    let (ha, hb) = (
        (ba.obb.height_m[0], ba.obb.height_m[1]),
        (bb.obb.height_m[0], bb.obb.height_m[1]),
    );
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
        InstanceBox::new(F, min, max, None)
    }

    const F: GroundFrame = GroundFrame::Enu;

    fn labels(r: &[Relation]) -> Vec<(usize, usize, &'static str)> {
        let mut v: Vec<_> = r.iter().map(|r| (r.a, r.b, r.relation)).collect();
        v.sort();
        v
    }

    #[test]
    fn oriented_boxes_measure_what_axis_aligned_ones_hide() {
        // two parallel 10 m × 0.2 m walls along the diagonal, 2 m apart: their
        // axis-aligned boxes overlap, their oriented boxes do not
        let wall = |offset: f64| {
            let o = OrientedBox {
                center: [offset / 2f64.sqrt(), -offset / 2f64.sqrt()],
                half_extents: [5.0, 0.1],
                yaw_rad: std::f64::consts::FRAC_PI_4,
                height_m: [0.0, 2.0],
            };
            let k = o.corners();
            let lo = [0, 1].map(|i| k.iter().map(|c| c[i]).fold(f64::INFINITY, f64::min));
            let hi = [0, 1].map(|i| k.iter().map(|c| c[i]).fold(f64::NEG_INFINITY, f64::max));
            InstanceBox::new(F, [lo[0], lo[1], 0.0], [hi[0], hi[1], 2.0], Some(o))
        };
        let (a, b) = (wall(0.0), wall(2.0));
        assert!(
            (box_distance(&a, &b) - 1.8).abs() < 1e-3,
            "{}",
            box_distance(&a, &b)
        );
        assert!(a.overlap_volume(&b) < 1e-9);
        let (aa, ab) = (bx(a.min, a.max), bx(b.min, b.max));
        assert!(box_distance(&aa, &ab) < 1e-6 && aa.overlap_volume(&ab) > 1.0);
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
