//! The labelled LiDAR points of a KITTI-layout sequence, scan by scan, in the world frame: the
//! one reading loop the point-level evaluations (`semseg`, `instance_points`) share.

use std::ops::Range;

use ingest::build::Sequence;
use ingest::mapping::project::Camera;
use ingest::sources::kitti::{self, PointLabel};
use scene::pose::Rigid3;

use crate::{Error, Result};

/// One finite, labelled point of a scan. Its world position and whether the camera sees it
/// are computed on request, so a caller that discards the point on its label pays for neither.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LabelledPoint<'a> {
    /// In the velodyne frame, metres.
    pub velo: [f32; 3],
    /// Its SemanticKITTI label (raw semantic id and instance id).
    pub label: PointLabel,
    world_from_velo: &'a Rigid3,
    camera: &'a Camera,
}

impl LabelledPoint<'_> {
    /// In the sequence's world frame (KITTI camera 0 of the first pose), metres.
    pub fn world(&self) -> [f32; 3] {
        scene::pose::apply(self.world_from_velo, self.velo.map(f64::from)).map(|c| c as f32)
    }

    /// Whether it projects into the scan's camera image.
    pub fn in_view(&self) -> bool {
        self.camera.project(self.velo).is_some()
    }
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
    mut each: impl FnMut(&LabelledPoint<'_>),
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
            each(&LabelledPoint {
                velo,
                label,
                world_from_velo: &world_from_velo,
                camera: &camera,
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
