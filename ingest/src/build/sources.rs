//! What a build reads: where the detections come from, and a KITTI odometry sequence on disk
//! (scans, poses, calibration, labels), the key frames a build integrates, and the points of a
//! scan with the moving ones taken out.

use super::*;

/// Where the detections come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// The SemanticKITTI label oracle (needs `labels/`).
    Oracle,
    /// A directory of detections files `NNNNNN.json`.
    Detections(PathBuf),
}

impl Source {
    /// `oracle` or `detections` (the `source` of the eval report).
    pub fn kind(&self) -> &'static str {
        match self {
            Source::Oracle => "oracle",
            Source::Detections(_) => "detections",
        }
    }
}

/// A KITTI odometry sequence on disk.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// The sequence directory.
    pub dir: PathBuf,
    /// Frame numbers that have a scan, ascending.
    pub scans: Vec<u32>,
    /// cam0-to-world poses.
    pub poses: Vec<Rigid3>,
    /// Where the poses came from.
    pub poses_path: PathBuf,
    /// Calibration.
    pub calib: Calib,
    /// Timestamps, when `times.txt` exists.
    pub times: Option<Vec<f64>>,
}

pub(super) fn frame_number(path: &Path, ext: &str) -> Option<u32> {
    let name = path.file_name()?.to_str()?;
    let stem = name.strip_suffix(ext)?;
    (stem.len() == 6 && stem.bytes().all(|b| b.is_ascii_digit()))
        .then(|| stem.parse().ok())
        .flatten()
}

pub(super) fn list_frames(dir: &Path, ext: &str) -> Result<Vec<u32>> {
    let rd = match std::fs::read_dir(dir) {
        Ok(rd) => rd,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(error) => {
            return Err(Error::Io {
                path: dir.to_path_buf(),
                error,
            });
        }
    };
    let mut out = Vec::new();
    for e in rd {
        let e = e.map_err(|error| Error::Io {
            path: dir.to_path_buf(),
            error,
        })?;
        if let Some(n) = frame_number(&e.path(), ext) {
            out.push(n);
        }
    }
    out.sort_unstable();
    Ok(out)
}

impl Sequence {
    /// Opens `dir` (with `velodyne/`, `calib.txt`, `poses.txt` unless `poses` is given, and
    /// optionally `labels/`, `image_2/`, `times.txt`).
    pub fn open(dir: &Path, poses: Option<&Path>) -> Result<Sequence> {
        let scans = list_frames(&dir.join("velodyne"), ".bin")?;
        if scans.is_empty() {
            return Err(Error::File {
                path: dir.join("velodyne"),
                detail: "no scans (NNNNNN.bin) found".into(),
            });
        }
        let calib = kitti::read_calib(&dir.join("calib.txt"))?;
        let poses_path = poses.map_or_else(|| dir.join("poses.txt"), Path::to_path_buf);
        let poses = kitti::read_poses(&poses_path)?;
        let last = *scans.last().expect("non-empty");
        if poses.len() <= last as usize {
            return Err(Error::File {
                path: poses_path,
                detail: format!(
                    "{} poses, but velodyne/ has scans up to {last:06}.bin (fewer poses than scans)",
                    poses.len()
                ),
            });
        }
        let times_path = dir.join("times.txt");
        let times = if times_path.exists() {
            Some(kitti::read_times(&times_path)?)
        } else {
            None
        };
        Ok(Sequence {
            dir: dir.to_path_buf(),
            scans,
            poses,
            poses_path,
            calib,
            times,
        })
    }

    /// `velodyne/NNNNNN.bin`.
    pub fn scan_path(&self, i: u32) -> PathBuf {
        self.dir.join("velodyne").join(format!("{i:06}.bin"))
    }

    /// `labels/NNNNNN.label`.
    pub fn label_path(&self, i: u32) -> PathBuf {
        self.dir.join("labels").join(format!("{i:06}.label"))
    }

    /// `image_2/NNNNNN.png`.
    pub fn image_path(&self, i: u32) -> PathBuf {
        self.dir.join("image_2").join(format!("{i:06}.png"))
    }

    /// The camera of frame `i`: P2 with the size of `image_2/NNNNNN.png`, or `default_size`
    /// (`[width, height]`) when there is no image.
    pub fn camera(&self, i: u32, default_size: [u32; 2]) -> Result<Camera> {
        let image = self.image_path(i);
        let (w, h) = if image.exists() {
            kitti::png_size(&image)?
        } else {
            (default_size[0], default_size[1])
        };
        Ok(Camera::kitti_p2(&self.calib, w, h))
    }

    /// The label oracle's detections for frame `i`, whose scan is `scan`.
    pub fn oracle(
        &self,
        i: u32,
        scan: &Scan,
        camera: &Camera,
        cfg: &OracleConfig,
    ) -> Result<DetectionFrame> {
        let labels = kitti::read_labels(&self.label_path(i), scan.points.len())?;
        let world_from_velo = self.world_from_velo(i);
        let (d, _) = oracle_detections(
            i,
            &scan.points,
            &labels,
            camera,
            Some(&world_from_velo),
            cfg,
        )?;
        Ok(d)
    }

    /// `world_from_velo = pose × Tr`.
    pub fn world_from_velo(&self, i: u32) -> Rigid3 {
        self.poses[i as usize] * self.calib.cam0_from_velo
    }

    /// The velodyne's world position at every pose (the whole trajectory).
    pub fn trajectory(&self) -> Vec<[f64; 3]> {
        kitti::positions(&self.poses, Some(&self.calib))
    }
}

/// The key frames of a build.
pub fn key_frames(
    seq: &Sequence,
    source: &Source,
    frames: Option<&Range<u32>>,
    stride: u32,
) -> Result<Vec<u32>> {
    let stride = stride.max(1);
    let needs = |i: u32| -> PathBuf {
        match source {
            Source::Oracle => seq.label_path(i),
            Source::Detections(d) => d.join(format!("{i:06}.json")),
        }
    };
    let picked: Vec<u32> = match frames {
        Some(r) => {
            if r.is_empty() {
                return Err(Error::Invalid(format!(
                    "--frames {}..{} is empty",
                    r.start, r.end
                )));
            }
            // the scans the sequence has in the range (a simulated drive numbers its scans
            // sparsely), every stride-th of them; each needs its labels or detections
            let in_range: Vec<u32> = seq
                .scans
                .iter()
                .copied()
                .filter(|i| r.contains(i))
                .step_by(stride as usize)
                .collect();
            if in_range.is_empty() {
                return Err(Error::Invalid(format!(
                    "--frames {}..{} holds none of the sequence's {} scans (they run from {} to {})",
                    r.start,
                    r.end,
                    seq.scans.len(),
                    seq.scans.first().copied().unwrap_or(0),
                    seq.scans.last().copied().unwrap_or(0)
                )));
            }
            for &i in &in_range {
                let p = needs(i);
                if !p.exists() {
                    return Err(Error::File {
                        path: p,
                        detail: format!(
                            "frame {i} has a scan in --frames but this file is missing"
                        ),
                    });
                }
            }
            in_range
        }
        None => {
            let avail: Vec<u32> = seq
                .scans
                .iter()
                .copied()
                .filter(|i| needs(*i).exists())
                .collect();
            let first = *avail.first().ok_or_else(|| Error::File {
                path: needs(seq.scans[0]),
                detail: format!(
                    "no frame has both a scan and {} (checked {} scans)",
                    match source {
                        Source::Oracle => "labels",
                        Source::Detections(_) => "a detections file",
                    },
                    seq.scans.len()
                ),
            })?;
            avail
                .into_iter()
                .filter(|i| (i - first) % stride == 0)
                .collect()
        }
    };
    Ok(picked)
}

/// The scans nearest to `i` in the sequence, up to `window` on each side within 50 poses
/// (a simulator's sequence has scans at its sensor frames only).
pub(super) fn neighbour_scans(seq: &Sequence, i: u32, window: u32) -> Vec<u32> {
    const REACH: u32 = 50;
    let mut out = Vec::new();
    let before = (i.saturating_sub(REACH)..i)
        .rev()
        .filter(|j| seq.scan_path(*j).exists())
        .take(window as usize);
    out.extend(before);
    let last = (seq.poses.len() as u32).saturating_sub(1);
    let after = (i + 1..=(i + REACH).min(last))
        .filter(|j| seq.scan_path(*j).exists())
        .take(window as usize);
    out.extend(after);
    out.sort_unstable();
    out
}

/// The key scan `i` without its dynamic points ([`crate::mapping::dynamic`]), and those
/// points; range images of the neighbours are kept in `images` for the next key frames.
/// Counts go to `rep`, and, where the scan has SemanticKITTI labels, against its moving
/// classes.
pub(super) fn remove_dynamic(
    seq: &Sequence,
    i: u32,
    scan: &Scan,
    cfg: &crate::mapping::dynamic::DynamicConfig,
    images: &mut BTreeMap<u32, crate::mapping::dynamic::RangeImage>,
    rep: &mut crate::mapping::dynamic::DynamicReport,
) -> Result<(Scan, Vec<[f32; 4]>)> {
    use crate::mapping::dynamic::{RangeImage, dynamic_mask, is_moving_label};
    let near = neighbour_scans(seq, i, cfg.window);
    rep.neighbour_scans += near.len() as u64;
    rep.key_scans += 1;
    images.retain(|j, _| near.contains(j));
    for &j in &near {
        if let std::collections::btree_map::Entry::Vacant(e) = images.entry(j) {
            let s = kitti::read_scan(&seq.scan_path(j))?;
            e.insert(RangeImage::new(
                &s.points,
                &seq.world_from_velo(j),
                cfg.bin_deg,
                cfg.spread_bins,
            ));
        }
    }
    let refs: Vec<&RangeImage> = near.iter().filter_map(|j| images.get(j)).collect();
    let mask = dynamic_mask(&scan.points, &seq.world_from_velo(i), &refs, cfg);
    rep.points += scan.points.len() as u64;
    rep.removed += mask.iter().filter(|m| **m).count() as u64;
    let lp = seq.label_path(i);
    if lp.exists()
        && let Ok(labels) = kitti::read_labels(&lp, scan.points.len())
    {
        for (l, m) in labels.iter().zip(&mask) {
            if l.semantic == 0 {
                continue;
            }
            if is_moving_label(l.semantic) {
                rep.moving_points += 1;
                rep.moving_removed += u64::from(*m);
            } else {
                rep.static_points += 1;
                rep.static_removed += u64::from(*m);
            }
        }
    }
    let (mut kept, mut removed) = (Vec::new(), Vec::new());
    for (p, m) in scan.points.iter().zip(mask) {
        if m {
            removed.push(*p);
        } else {
            kept.push(*p);
        }
    }
    Ok((Scan { points: kept }, removed))
}

/// The key frame's points (`scan`, already read) with non-finite points dropped (counted), and
/// accumulates the `accumulate - 1`
/// previous scans moved into this scan's velodyne frame.
pub(super) fn load_points(
    seq: &Sequence,
    i: u32,
    scan: &Scan,
    accumulate: usize,
    nonfinite: &mut u64,
) -> Result<Vec<[f32; 4]>> {
    let mut pts = scan.points.clone();
    if accumulate > 1 {
        let velo_from_world = seq.world_from_velo(i).inverse();
        for j in (i.saturating_sub(accumulate as u32 - 1)..i).rev() {
            let p = seq.scan_path(j);
            if !p.exists() {
                continue;
            }
            let m = velo_from_world * seq.world_from_velo(j);
            for q in kitti::read_scan(&p)?.points {
                let w = scene::pose::apply(&m, [f64::from(q[0]), f64::from(q[1]), f64::from(q[2])]);
                pts.push([w[0] as f32, w[1] as f32, w[2] as f32, q[3]]);
            }
        }
    }
    let before = pts.len();
    pts.retain(|p| p[..3].iter().all(|c| c.is_finite()));
    *nonfinite += (before - pts.len()) as u64;
    Ok(pts)
}
