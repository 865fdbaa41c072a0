//! The labelled LiDAR points of a KITTI-layout sequence, scan by scan, in the world frame: the
//! one reading loop the point-level evaluations (`semseg`, `instance_points`) share.

use std::ops::Range;

use ingest::build::Sequence;
use ingest::sources::kitti::{self, PointLabel};

use crate::{Error, Result};

/// One finite, labelled point of a scan.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LabelledPoint {
    /// In the velodyne frame, metres.
    pub velo: [f32; 3],
    /// In the sequence's world frame (KITTI camera 0 of the first pose), metres.
    pub world: [f32; 3],
    /// Its SemanticKITTI label (raw semantic id and instance id).
    pub label: PointLabel,
    /// Whether it projects into the scan's camera image.
    pub in_view: bool,
}

/// Calls `each` for every finite point of every labelled scan of `seq` whose index is in
/// `frames` (every scan when `None`); `image_size` is the camera image size where `image_2/`
/// has no image. Returns the number of scans read.
///
/// # Errors
/// A scan, its labels (wrong length included) or its image cannot be read; no scan in range is
/// labelled (naming the `labels/` folder).
pub(crate) fn for_each_labelled_point(
    seq: &Sequence,
    frames: Option<&Range<u32>>,
    image_size: [u32; 2],
    mut each: impl FnMut(&LabelledPoint),
) -> Result<usize> {
    let mut scans = 0;
    for &i in &seq.scans {
        if frames.is_some_and(|f| !f.contains(&i)) {
            continue;
        }
        let lp = seq.label_path(i);
        if !lp.exists() {
            continue;
        }
        let scan = kitti::read_scan(&seq.scan_path(i))?;
        let labels = kitti::read_labels(&lp, scan.points.len())?;
        let world_from_velo = seq.world_from_velo(i);
        let camera = seq.camera(i, image_size)?;
        for (p, &label) in scan.points.iter().zip(&labels) {
            let velo = [p[0], p[1], p[2]];
            if !velo.iter().all(|c| c.is_finite()) {
                continue;
            }
            let world = scene::pose::apply(&world_from_velo, velo.map(f64::from)).map(|c| c as f32);
            let in_view = camera.project(velo).is_some();
            each(&LabelledPoint {
                velo,
                world,
                label,
                in_view,
            });
        }
        scans += 1;
    }
    if scans == 0 {
        return Err(Error::File {
            path: seq.dir.join("labels"),
            detail: "no labelled scan to evaluate".into(),
        });
    }
    Ok(scans)
}
