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
