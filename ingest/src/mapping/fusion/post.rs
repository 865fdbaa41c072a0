//! Post-processing of the object map (the paper's last mapping step): touching objects of a
//! class joined, final denoising, objects with too few points dropped, overlapping ones
//! merged, and objects split into their large point clusters.

use super::*;

/// What post-processing did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct PostReport {
    /// Points removed by the final denoising.
    pub denoised_points: usize,
    /// Objects dropped for having too few points.
    pub dropped: Vec<u64>,
    /// Merges: (kept, absorbed).
    pub merged: Vec<(u64, u64)>,
    /// Splits: (object, new object made of one of its other point clusters).
    pub split: Vec<(u64, u64)>,
}

/// A length that orders totally (lengths here are finite).
#[derive(Debug, Clone, Copy, PartialEq)]
struct OrderedLong(f64);

impl Eq for OrderedLong {}

impl PartialOrd for OrderedLong {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for OrderedLong {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

impl Mapper {
    /// Joins objects of one class by the geometry of their points: the points of `ids`
    /// are pooled and clustered (DBSCAN, `eps_m`, `dbscan_min_points`); objects whose points
    /// share a cluster (at least `dbscan_min_points` points each in it) touch and become one,
    /// the lowest id surviving. For buildings, fences and vegetation, seen in parts from a
    /// moving car, one real object becomes one instance. Returns the merges (kept, absorbed).
    pub fn join_touching(&mut self, ids: &[u64], eps_m: f32) -> Vec<(u64, u64)> {
        let min = self.cfg.dbscan_min_points.max(1);
        let mut ids: Vec<u64> = ids
            .iter()
            .copied()
            .filter(|id| self.objects.get(id).is_some_and(|o| o.tile.is_none()))
            .collect();
        ids.sort_unstable();
        ids.dedup();
        let mut pool = Vec::new();
        let mut owner = Vec::new();
        for (k, id) in ids.iter().enumerate() {
            let o = &self.objects[id];
            pool.extend_from_slice(&o.points);
            owner.extend(std::iter::repeat_n(k, o.points.len()));
        }
        let labels = crate::mapping::geometry::dbscan3(&pool, eps_m, min);
        // points per (cluster, object)
        let mut counts: BTreeMap<(usize, usize), usize> = BTreeMap::new();
        for (l, k) in labels.iter().zip(&owner) {
            if let Some(c) = l {
                *counts.entry((*c, *k)).or_insert(0) += 1;
            }
        }
        // union-find over objects that share a cluster
        let mut parent: Vec<usize> = (0..ids.len()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let mut first_in: BTreeMap<usize, usize> = BTreeMap::new();
        for (&(c, k), &n) in &counts {
            if n < min {
                continue;
            }
            match first_in.get(&c) {
                None => {
                    first_in.insert(c, k);
                }
                Some(&j) => {
                    let (ra, rb) = (root(&mut parent, j), root(&mut parent, k));
                    if ra != rb {
                        // the lower index (lower id) stays the root
                        let (lo, hi) = (ra.min(rb), ra.max(rb));
                        parent[hi] = lo;
                    }
                }
            }
        }
        let mut merged = Vec::new();
        for k in 0..ids.len() {
            let r = root(&mut parent, k);
            if r != k {
                self.absorb(ids[r], ids[k]);
                merged.push((ids[r], ids[k]));
                let grown = self.objects[&ids[r]].bbox;
                self.grid.update(ids[r], &grown);
            }
        }
        merged
    }

    /// Joins the parts of one thing seen apart: among `ids` (objects of one kind of thing,
    /// such as the map's bus shelters; not stuff like buildings, fences or vegetation, whose
    /// size says nothing), two objects become one when the oriented box of their pooled
    /// points is no larger than a whole one of the kind: each side at most `slack` times the
    /// `quantile` of that side over the kind's objects. A shelter seen end-on from one side
    /// and then the other gives its two ends as two objects with the occluded middle between
    /// them, more than [`Mapper::join_touching`]'s gap apart; two benches, bikes or cars side
    /// by side make a box wider or longer than one. Kinds with fewer than `min_objects`
    /// objects are left alone (their size is not known). Closest pairs first (the smallest
    /// joined box), the lower id surviving; returns the merges (kept, absorbed).
    pub fn join_parts(
        &mut self,
        ids: &[u64],
        quantile: f64,
        slack: f64,
        min_objects: usize,
    ) -> Vec<(u64, u64)> {
        let ground = self.ground;
        let mut ids: Vec<u64> = ids
            .iter()
            .copied()
            .filter(|id| {
                self.objects
                    .get(id)
                    .is_some_and(|o| o.tile.is_none() && !o.points.is_empty())
            })
            .collect();
        ids.sort_unstable();
        ids.dedup();
        if ids.len() < min_objects.max(2) {
            return Vec::new();
        }
        // the sides of a whole one: the quantile of each side (long, short) over the kind
        let sides: Vec<[f64; 2]> = ids
            .iter()
            .filter_map(|id| self.objects[id].obb(ground))
            .map(|b| {
                let [a, c] = b.half_extents;
                [2.0 * a.max(c), 2.0 * a.min(c)]
            })
            .collect();
        let q = |k: usize| {
            let mut v: Vec<f64> = sides.iter().map(|s| s[k]).collect();
            v.sort_by(f64::total_cmp);
            v.get(((v.len() as f64 - 1.0) * quantile.clamp(0.0, 1.0)).round() as usize)
                .copied()
                .unwrap_or(0.0)
        };
        let (long_max, short_max) = (q(0) * slack, q(1) * slack);
        if long_max <= 0.0 {
            return Vec::new();
        }
        // the joined box of two objects when it is no larger than a whole one
        let fits = |m: &Mapper, a: u64, b: u64| -> Option<f64> {
            let (oa, ob) = (&m.objects[&a], &m.objects[&b]);
            let (ba, bb) = (oa.obb(ground)?, ob.obb(ground)?);
            let d = (ba.center[0] - bb.center[0]).hypot(ba.center[1] - bb.center[1]);
            if d > long_max {
                return None;
            }
            let mut pooled = oa.points.clone();
            pooled.extend_from_slice(&ob.points);
            let j = OrientedBox::fit(ground, &pooled)?;
            let [x, y] = j.half_extents;
            let (long, short) = (2.0 * x.max(y), 2.0 * x.min(y));
            (long <= long_max && short <= short_max).then_some(long)
        };
        // candidate pairs by their joined box's long side, smallest first; a pair whose
        // objects grew since it was measured is measured again
        let centre = |m: &Mapper, id: u64| m.objects[&id].obb(ground).map(|b| b.center);
        let mut version: BTreeMap<u64, u32> = ids.iter().map(|id| (*id, 0)).collect();
        type Pair = std::cmp::Reverse<(OrderedLong, u64, u64, u32, u32)>;
        let mut heap: std::collections::BinaryHeap<Pair> = std::collections::BinaryHeap::new();
        let push_pairs = |m: &Mapper,
                          heap: &mut std::collections::BinaryHeap<Pair>,
                          version: &BTreeMap<u64, u32>,
                          a: u64,
                          others: &mut dyn Iterator<Item = u64>| {
            let Some(ca) = centre(m, a) else { return };
            for b in others {
                if b == a {
                    continue;
                }
                let Some(cb) = centre(m, b) else { continue };
                if (ca[0] - cb[0]).hypot(ca[1] - cb[1]) > long_max {
                    continue;
                }
                if let Some(long) = fits(m, a, b) {
                    let (lo, hi) = (a.min(b), a.max(b));
                    heap.push(std::cmp::Reverse((
                        OrderedLong(long),
                        lo,
                        hi,
                        version[&lo],
                        version[&hi],
                    )));
                }
            }
        };
        // every pair once: by ground x, only those within long_max of each other
        let mut by_x: Vec<(f64, u64)> = ids
            .iter()
            .filter_map(|id| centre(self, *id).map(|c| (c[0], *id)))
            .collect();
        by_x.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
        for (i, &(x, a)) in by_x.iter().enumerate() {
            let mut near = by_x[i + 1..]
                .iter()
                .take_while(|(xb, _)| xb - x <= long_max)
                .map(|(_, b)| *b);
            push_pairs(self, &mut heap, &version, a, &mut near);
        }
        let mut merged = Vec::new();
        // an absorbed object's pairs are its absorber's now
        let mut into: BTreeMap<u64, u64> = BTreeMap::new();
        let root = |into: &BTreeMap<u64, u64>, mut id: u64| {
            while let Some(&next) = into.get(&id) {
                id = next;
            }
            id
        };
        while let Some(std::cmp::Reverse((_, a0, b0, va, vb))) = heap.pop() {
            let (a, b) = (root(&into, a0), root(&into, b0));
            if a == b {
                continue;
            }
            if (a, b) != (a0, b0) || (version[&a], version[&b]) != (va, vb) {
                // one of them grew or was absorbed: measure the pair again
                push_pairs(self, &mut heap, &version, a, &mut std::iter::once(b));
                continue;
            }
            self.absorb(a, b);
            let grown = self.objects[&a].bbox;
            self.grid.update(a, &grown);
            version.remove(&b);
            *version.get_mut(&a).expect("alive") += 1;
            into.insert(b, a);
            merged.push((a, b));
        }
        merged
    }

    /// Post-processing: cluster every object's points (not surface tiles; DBSCAN with
    /// `dbscan_eps_m`, `dbscan_min_points`): the largest cluster stays the object, every other
    /// cluster with at least `min_object_points` points and `split_min_share` of the object's
    /// points becomes a new object (with the same captions and feature), the rest is noise;
    /// drop objects under `min_object_points` (`tracked_min_points` for an object of at least
    /// `tracked_detections` detections), then merge pairs whose shared-voxel ratio (over the smaller one)
    /// exceeds `merge_overlap` and whose feature cosine exceeds `merge_feature_cos`. The
    /// lower id survives and absorbs the other's points, feature, captions and counts.
    pub fn post_process(&mut self) -> PostReport {
        let cfg = self.cfg.clone();
        let mut report = PostReport::default();
        let mut ids = self.object_ids();
        for id in ids.clone() {
            let o = self.objects.get_mut(&id).expect("listed");
            let mut parts = clusters(&o.points, cfg.dbscan_eps_m, cfg.dbscan_min_points);
            let total = o.points.len();
            // the largest cluster stays the object; other large ones become objects of their
            // own (one detection track that covered two hedges or houses), the rest is noise
            let big = |n: usize| {
                n >= cfg.min_object_points && n as f64 >= cfg.split_min_share * total as f64
            };
            let split_off: Vec<Vec<[f32; 3]>> = if parts.len() > 1 {
                parts.drain(1..).filter(|p| big(p.len())).collect()
            } else {
                Vec::new()
            };
            let kept = parts.pop().unwrap_or_default();
            let kept_total = kept.len() + split_off.iter().map(Vec::len).sum::<usize>();
            report.denoised_points += total - kept_total;
            if kept.len() != total {
                o.set_points(kept, cfg.voxel_m);
                o.dirty = true;
            }
            // the new objects copy the object's captions, feature and counts
            let template = (!split_off.is_empty()).then(|| o.clone());
            let min_points = if o.detection_count >= cfg.tracked_detections {
                cfg.tracked_min_points.min(cfg.min_object_points)
            } else {
                cfg.min_object_points
            };
            if o.points.len() < min_points {
                report.dropped.push(id);
                self.objects.remove(&id);
            }
            let Some(template) = template else { continue };
            for pts in split_off {
                let new_id = self.next_id;
                self.next_id += 1;
                let mut n = template.clone();
                n.instance_id = new_id;
                n.tile = None;
                n.set_points(pts, cfg.voxel_m);
                n.dirty = true;
                self.objects.insert(new_id, n);
                report.split.push((id, new_id));
                ids.push(new_id);
            }
        }
        // merging, in id order; a merged object can absorb more afterwards
        ids.retain(|id| self.objects.contains_key(id));
        // boxes shrank with denoising: rebuild the grid
        self.grid = BoxGrid::default();
        for id in &ids {
            self.grid.update(*id, &self.objects[id].bbox);
        }
        let mut gone: HashSet<u64> = HashSet::new();
        for a in &ids {
            if gone.contains(a) {
                continue;
            }
            // candidates are looked up again after each merge, as the box grows
            let mut checked: HashSet<u64> = HashSet::new();
            loop {
                let next = self
                    .grid
                    .candidates(&self.objects[a].bbox)
                    .into_iter()
                    .find(|b| b > a && !gone.contains(b) && !checked.contains(b));
                let Some(b) = next else { break };
                let b = &b;
                checked.insert(*b);
                let (oa, ob) = (&self.objects[a], &self.objects[b]);
                if !oa.bbox.intersects(&ob.bbox) {
                    continue;
                }
                let (small, big) = if oa.voxels.len() <= ob.voxels.len() {
                    (oa, ob)
                } else {
                    (ob, oa)
                };
                let shared = small
                    .voxels
                    .iter()
                    .filter(|k| big.voxels.contains(*k))
                    .count();
                let ratio = shared as f64 / small.voxels.len().max(1) as f64;
                if ratio > cfg.merge_overlap
                    && cosine(&oa.feature, &ob.feature) > cfg.merge_feature_cos
                {
                    self.absorb(*a, *b);
                    let grown = self.objects[a].bbox;
                    self.grid.update(*a, &grown);
                    gone.insert(*b);
                    report.merged.push((*a, *b));
                }
            }
        }
        report
    }
}
