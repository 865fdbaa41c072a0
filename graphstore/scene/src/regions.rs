//! Regions of a map, for spreading it over several servers (region shards): the ground plane
//! is cut into `parts` bands across its longer side, at quantiles of the road segments'
//! centroids so that each band holds about as many segments. A segment belongs to the band
//! of its centroid, an instance to its segment's band (by `IN_SEGMENT`; by its own centroid
//! when it has none), a lane-graph node to the band of its position. Everything else (the
//! environment, frames, the build record) belongs to every region.

use std::collections::BTreeSet;

use graphstore::GraphRead;

use crate::records::LaneNodeRecord;
use crate::view::MapView;
use crate::{Result, label};

/// The cut of a map into regions.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionPlan {
    /// The map's ground frame, which the axis is of.
    pub ground: crate::GroundFrame,
    /// The ground-plane axis the bands run across (0 or 1 of [`crate::GroundFrame::ground`]).
    pub axis: usize,
    /// The `parts - 1` cuts along it, metres, ascending; band `i` is between cut `i - 1`
    /// and cut `i` (unbounded at the ends).
    pub cuts_m: Vec<f64>,
    /// Per region, the node ids that belong to it alone (segments, instances, lane nodes).
    pub owned: Vec<BTreeSet<u64>>,
}

impl RegionPlan {
    /// The band of ground coordinate `x` along the axis.
    pub fn band(&self, x: f64) -> usize {
        self.cuts_m.iter().take_while(|c| x >= **c).count()
    }

    /// Node ids region `i` does not hold: the other regions' own nodes.
    pub fn not_in(&self, i: usize) -> Vec<u64> {
        self.owned
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .flat_map(|(_, s)| s.iter().copied())
            .collect()
    }
}

/// Cuts the map read through `r` into `parts` regions (see the module docs). With fewer
/// segments than parts, some regions hold no segment.
///
/// # Errors
/// The store fails or has no ground frame; `parts` is 0.
pub fn plan_regions(r: &impl GraphRead, parts: usize) -> Result<RegionPlan> {
    if parts == 0 {
        return Err(crate::Error::Invalid(
            "a map is cut into one region or more".into(),
        ));
    }
    let view = MapView::load(r)?;
    let g = view.ground;
    let mut lanes = Vec::new();
    for id in r.nodes_with_label(label::LANE_NODE)? {
        if let Some(l) = LaneNodeRecord::read(r, id)? {
            lanes.push((id, g.ground(l.position)));
        }
    }
    // the longer side of everything's extent
    let pts: Vec<[f64; 2]> = view
        .segments
        .iter()
        .map(|s| s.centroid)
        .chain(view.objects.iter().map(|o| g.ground(o.centroid)))
        .chain(lanes.iter().map(|l| l.1))
        .collect();
    let extent = |a: usize| {
        let (lo, hi) = pts
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[a]), hi.max(p[a]))
            });
        hi - lo
    };
    let axis = usize::from(extent(1) > extent(0));
    let mut along: Vec<f64> = view.segments.iter().map(|s| s.centroid[axis]).collect();
    if along.is_empty() {
        along = pts.iter().map(|p| p[axis]).collect();
    }
    along.sort_by(f64::total_cmp);
    if parts > along.len().max(1) {
        return Err(crate::Error::Invalid(format!(
            "the map has {} road segments: cut it into at most {} regions",
            view.segments.len(),
            along.len().max(1)
        )));
    }
    // cut half-way between neighbours at each quantile, so no centroid sits on a cut
    let cuts_m: Vec<f64> = (1..parts)
        .filter_map(|i| {
            let at = i * along.len() / parts;
            (at > 0 && at < along.len()).then(|| (along[at - 1] + along[at]) / 2.0)
        })
        .collect();
    let mut plan = RegionPlan {
        ground: g,
        axis,
        cuts_m,
        owned: vec![BTreeSet::new(); parts],
    };
    for s in &view.segments {
        let b = plan.band(s.centroid[axis]);
        plan.owned[b].insert(s.id);
    }
    for o in &view.objects {
        let b = match &o.segment {
            Some((sid, _)) => view
                .segments
                .iter()
                .find(|s| s.id == *sid)
                .map(|s| plan.band(s.centroid[axis])),
            None => None,
        }
        .unwrap_or_else(|| plan.band(g.ground(o.centroid)[axis]));
        plan.owned[b].insert(o.id);
    }
    for (id, p) in lanes {
        let b = plan.band(p[axis]);
        plan.owned[b].insert(id);
    }
    Ok(plan)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_are_between_the_cuts() {
        let p = RegionPlan {
            ground: crate::GroundFrame::KittiCam,
            axis: 0,
            cuts_m: vec![-10.0, 5.0],
            owned: vec![BTreeSet::from([1]), BTreeSet::from([2, 3]), BTreeSet::new()],
        };
        assert_eq!(p.band(-100.0), 0);
        assert_eq!(p.band(-10.0), 1);
        assert_eq!(p.band(4.9), 1);
        assert_eq!(p.band(5.0), 2);
        assert_eq!(p.not_in(0), vec![2, 3]);
        assert_eq!(p.not_in(1), vec![1]);
    }
}
