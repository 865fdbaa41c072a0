//! KITTI odometry text files: `poses.txt` (cam0-to-world, 3×4 row-major per line) and
//! `calib.txt` (`P0`..`P3`, `Tr` velodyne-to-cam0, each 3×4 row-major).
//!
//! `world_from_velo = world_from_cam0 × cam0_from_velo`, i.e. `pose × Tr`. KITTI's world frame
//! is cam0's first frame: x right, y down, z forward, so the ground plane is (x, z).

use std::path::Path;

use crate::error::{Error, Result, read_text};

pub use scene::pose::{Projection, Rigid3};
use scene::pose::{projection_from_row_major, rigid_from_row_major};

fn parse_floats(path: &Path, line_no: usize, text: &str, want: usize) -> Result<Vec<f64>> {
    let mut out = Vec::with_capacity(want);
    for tok in text.split_whitespace() {
        let v: f64 = tok.parse().map_err(|_| Error::Parse {
            path: path.to_path_buf(),
            line: line_no,
            detail: format!("{tok:?} is not a number"),
        })?;
        if !v.is_finite() {
            return Err(Error::Parse {
                path: path.to_path_buf(),
                line: line_no,
                detail: format!("{tok} is not finite"),
            });
        }
        out.push(v);
    }
    if out.len() != want {
        return Err(Error::Parse {
            path: path.to_path_buf(),
            line: line_no,
            detail: format!("expected {want} numbers, found {}", out.len()),
        });
    }
    Ok(out)
}

/// Reads `poses.txt`: one 3×4 world-from-cam0 matrix per non-empty line.
pub fn read_poses(path: &Path) -> Result<Vec<Rigid3>> {
    let text = read_text(path)?;
    let mut poses = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let v = parse_floats(path, i + 1, line, 12)?;
        poses.push(rigid_from_row_major(&v).expect("12 values"));
    }
    if poses.is_empty() {
        return Err(Error::File {
            path: path.to_path_buf(),
            detail: "no poses".into(),
        });
    }
    Ok(poses)
}

/// Reads `times.txt`: one timestamp in seconds per non-empty line.
pub fn read_times(path: &Path) -> Result<Vec<f64>> {
    let text = read_text(path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        out.push(parse_floats(path, i + 1, line, 1)?[0]);
    }
    Ok(out)
}

/// Width and height of a PNG, from its header (the pixels are not decoded).
pub fn png_size(path: &Path) -> Result<(u32, u32)> {
    use std::io::Read;
    let mut head = [0u8; 24];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .map_err(|error| Error::Io {
            path: path.to_path_buf(),
            error,
        })?;
    if &head[..8] != b"\x89PNG\r\n\x1a\n" || &head[12..16] != b"IHDR" {
        return Err(Error::File {
            path: path.to_path_buf(),
            detail: "not a PNG image".into(),
        });
    }
    let be = |o: usize| u32::from_be_bytes([head[o], head[o + 1], head[o + 2], head[o + 3]]);
    Ok((be(16), be(20)))
}

/// KITTI calibration: the rectified cameras' projections and the velodyne's pose in
/// rectified cam0.
#[derive(Debug, Clone, PartialEq)]
pub struct Calib {
    /// Projection matrices P0..P3 (rectified cameras).
    pub p: [Projection; 4],
    /// Rectified cam0 from velodyne: the odometry layout's `Tr`, or `R0_rect ·
    /// Tr_velo_to_cam` from the object and raw layouts.
    pub cam0_from_velo: Rigid3,
}

/// Reads a KITTI `calib.txt` in one of the two layouts it supports, each line `KEY: numbers`:
///
/// - odometry (`P0`..`P3`, `Tr`): `Tr` maps velodyne to rectified cam0;
/// - 3D object / raw-data per-frame (`P0`..`P3`, `R0_rect` with 9 numbers, `Tr_velo_to_cam`,
///   `Tr_imu_to_velo`): `Tr_velo_to_cam` maps to the *unrectified* cam0, so the velodyne's
///   pose in rectified cam0 is `R0_rect · Tr_velo_to_cam`, and the left colour camera projects
///   with `P2 · R0_rect · Tr_velo_to_cam` (the devkits' formula).
///
/// # Errors
/// A key of another layout (the raw data's `calib_cam_to_cam.txt` / `calib_velo_to_cam.txt`
/// keys such as `R`, `T`, `K_00`, `P_rect_02`), a layout mixed or incomplete (`Tr_velo_to_cam`
/// without `R0_rect`, both `Tr` and `Tr_velo_to_cam`), a missing `P` line, or a bad number:
/// each names the file and line.
pub fn read_calib(path: &Path) -> Result<Calib> {
    let text = read_text(path)?;
    let mut p: [Option<Projection>; 4] = [None; 4];
    let (mut tr, mut velo_to_cam, mut r0) = (None, None, None);
    let mut tr_line = 0;
    for (i, line) in text.lines().enumerate() {
        let Some((key, rest)) = line.split_once(':') else {
            if line.trim().is_empty() {
                continue;
            }
            return Err(Error::Parse {
                path: path.to_path_buf(),
                line: i + 1,
                detail: "expected `KEY: numbers`".into(),
            });
        };
        let key = key.trim();
        match key {
            "P0" | "P1" | "P2" | "P3" => {
                let k = usize::from(key.as_bytes()[1] - b'0');
                p[k] = projection_from_row_major(&parse_floats(path, i + 1, rest, 12)?);
            }
            "Tr" => {
                tr = rigid_from_row_major(&parse_floats(path, i + 1, rest, 12)?);
                tr_line = i + 1;
            }
            "Tr_velo_to_cam" => {
                velo_to_cam = rigid_from_row_major(&parse_floats(path, i + 1, rest, 12)?);
                tr_line = i + 1;
            }
            "R0_rect" => {
                let v = parse_floats(path, i + 1, rest, 9)?;
                r0 = rigid_from_row_major(&[
                    v[0], v[1], v[2], 0.0, v[3], v[4], v[5], 0.0, v[6], v[7], v[8], 0.0,
                ]);
            }
            // the object layout's IMU pose is not used
            "Tr_imu_to_velo" => {
                parse_floats(path, i + 1, rest, 12)?;
            }
            other => {
                return Err(Error::Parse {
                    path: path.to_path_buf(),
                    line: i + 1,
                    detail: format!(
                        "unsupported calibration key {other:?}: the odometry layout (P0..P3, Tr) and the 3D object / raw per-frame layout (P0..P3, R0_rect, Tr_velo_to_cam, Tr_imu_to_velo) are read; the raw data's calib_cam_to_cam.txt / calib_velo_to_cam.txt are not"
                    ),
                });
            }
        }
    }
    let missing = |k: &str| Error::File {
        path: path.to_path_buf(),
        detail: format!("calibration has no {k} line"),
    };
    let layout_err = |d: &str| Error::Parse {
        path: path.to_path_buf(),
        line: tr_line,
        detail: d.to_string(),
    };
    let cam0_from_velo = match (tr, velo_to_cam, r0) {
        (Some(t), None, None) => t,
        (None, Some(t), Some(r)) => r * t,
        (None, Some(_), None) => {
            return Err(layout_err(
                "Tr_velo_to_cam maps to the unrectified camera, and the R0_rect line that rectifies it is missing",
            ));
        }
        (Some(_), Some(_), _) => {
            return Err(layout_err(
                "both Tr (odometry layout) and Tr_velo_to_cam (object layout): one layout per file",
            ));
        }
        (Some(_), None, Some(_)) => {
            return Err(layout_err(
                "R0_rect with the odometry layout's Tr: Tr is already rectified; use Tr_velo_to_cam with R0_rect",
            ));
        }
        (None, None, _) => return Err(missing("Tr (or Tr_velo_to_cam)")),
    };
    let get = |i: usize| p[i].ok_or_else(|| missing(&format!("P{i}")));
    Ok(Calib {
        p: [get(0)?, get(1)?, get(2)?, get(3)?],
        cam0_from_velo,
    })
}

/// World positions of the sensor for each pose: cam0's, or the velodyne's when `calib` is
/// given (`world_from_velo = pose × Tr`).
pub fn positions(poses: &[Rigid3], calib: Option<&Calib>) -> Vec<[f64; 3]> {
    poses
        .iter()
        .map(|pose| match calib {
            Some(c) => (pose * c.cam0_from_velo).translation.vector.into(),
            None => pose.translation.vector.into(),
        })
        .collect()
}

/// Ground-plane trajectory from KITTI poses: the (x, z) of each of [`positions`].
pub fn ground_trajectory(poses: &[Rigid3], calib: Option<&Calib>) -> Vec<[f64; 2]> {
    positions(poses, calib)
        .into_iter()
        .map(|t| [t[0], t[2]])
        .collect()
}

/// Reads `poses.txt` (and `calib.txt`, if given) and returns the sensor's world positions.
pub fn load_trajectory(poses: &Path, calib: Option<&Path>) -> Result<Vec<[f64; 3]>> {
    let p = read_poses(poses)?;
    let c = calib.map(read_calib).transpose()?;
    Ok(positions(&p, c.as_ref()))
}

/// One Velodyne scan: x, y, z in metres (velodyne frame) and intensity.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scan {
    /// Points as stored, NaN or infinite ones included (see [`Scan::finite`]).
    pub points: Vec<[f32; 4]>,
}

impl Scan {
    /// Whether each point's coordinates are all finite. NaN/inf points are kept in
    /// `points` so labels stay aligned; mapping drops them and counts them.
    pub fn finite(&self) -> Vec<bool> {
        self.points
            .iter()
            .map(|p| p[..3].iter().all(|c| c.is_finite()))
            .collect()
    }
}

/// Reads `velodyne/NNNNNN.bin`: little-endian float32 x, y, z, intensity per point.
pub fn read_scan(path: &Path) -> Result<Scan> {
    let bytes = std::fs::read(path).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })?;
    if bytes.len() % 16 != 0 {
        return Err(Error::File {
            path: path.to_path_buf(),
            detail: format!(
                "scan size {} bytes is not a multiple of 16 (4 float32 per point); the file is truncated or not a KITTI scan (last whole point ends at byte {})",
                bytes.len(),
                bytes.len() / 16 * 16
            ),
        });
    }
    let points = bytes
        .chunks_exact(16)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
            [f(0), f(4), f(8), f(12)]
        })
        .collect();
    Ok(Scan { points })
}

/// A SemanticKITTI point label: semantic class id (low 16 bits) and instance id (high 16).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PointLabel {
    /// Raw semantic id (see semantic-kitti.yaml `labels`).
    pub semantic: u16,
    /// Instance id, 0 for none.
    pub instance: u16,
}

/// Reads `labels/NNNNNN.label` (uint32 per point) and checks it matches a scan of
/// `n_points` points.
pub fn read_labels(path: &Path, n_points: usize) -> Result<Vec<PointLabel>> {
    let bytes = std::fs::read(path).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })?;
    if bytes.len() % 4 != 0 {
        return Err(Error::File {
            path: path.to_path_buf(),
            detail: format!(
                "label file size {} bytes is not a multiple of 4",
                bytes.len()
            ),
        });
    }
    if bytes.len() / 4 != n_points {
        return Err(Error::File {
            path: path.to_path_buf(),
            detail: format!("{} labels for a scan of {n_points} points", bytes.len() / 4),
        });
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|c| {
            let v = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            PointLabel {
                semantic: (v & 0xffff) as u16,
                instance: (v >> 16) as u16,
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_and_label_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let scan = dir.path().join("000000.bin");
        let mut bytes: Vec<u8> = [1.0f32, 2.0, 3.0, 0.5, f32::NAN, 0.0, 0.0, 0.1]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        std::fs::write(&scan, &bytes).unwrap();
        let s = read_scan(&scan).unwrap();
        assert_eq!(s.points.len(), 2);
        assert_eq!(s.finite(), vec![true, false]);
        bytes.truncate(20);
        std::fs::write(&scan, &bytes).unwrap();
        let e = read_scan(&scan).unwrap_err().to_string();
        assert!(
            e.contains("000000.bin") && e.contains("not a multiple of 16") && e.contains("byte 16"),
            "{e}"
        );
        let labels = dir.path().join("000000.label");
        std::fs::write(&labels, (0x0003_000au32).to_le_bytes()).unwrap();
        assert_eq!(
            read_labels(&labels, 1).unwrap(),
            vec![PointLabel {
                semantic: 10,
                instance: 3
            }]
        );
        let e = read_labels(&labels, 2).unwrap_err().to_string();
        assert!(
            e.contains("000000.label") && e.contains("1 labels for a scan of 2 points"),
            "{e}"
        );
    }

    #[test]
    fn bad_lines_name_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("poses.txt");
        std::fs::write(&f, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n").unwrap();
        let e = read_poses(&f).unwrap_err().to_string();
        assert!(
            e.contains("poses.txt:2: expected 12 numbers, found 11"),
            "{e}"
        );
        std::fs::write(&f, "1 0 0 nan 0 1 0 0 0 0 1 0\n").unwrap();
        assert!(read_poses(&f).unwrap_err().to_string().contains(":1:"));
        let c = dir.path().join("calib.txt");
        std::fs::write(&c, "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 0 0 1 0 0 0 0 1 0\nP2: 1 0 0 0 0 1 0 0 0 0 1 0\nP3: 1 0 0 0 0 1 0 0 0 0 1 0\n").unwrap();
        assert!(
            read_calib(&c)
                .unwrap_err()
                .to_string()
                .contains("no Tr (or Tr_velo_to_cam) line")
        );
    }

    #[test]
    fn object_layout_is_rectified_and_other_layouts_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let c = dir.path().join("calib.txt");
        let p = "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 0 0 1 0 0 0 0 1 0\nP2: 700 0 600 45 0 700 170 0.2 0 0 1 0.003\nP3: 1 0 0 0 0 1 0 0 0 0 1 0\n";
        // R0_rect: a rotation by 90 degrees about z; Tr_velo_to_cam: a translation
        std::fs::write(
            &c,
            format!("{p}R0_rect: 0 -1 0 1 0 0 0 0 1\nTr_velo_to_cam: 1 0 0 1 0 1 0 2 0 0 1 3\nTr_imu_to_velo: 1 0 0 0 0 1 0 0 0 0 1 0\n"),
        )
        .unwrap();
        let k = read_calib(&c).unwrap();
        // velodyne origin -> (1, 2, 3) unrectified -> (-2, 1, 3) rectified
        let o = scene::pose::apply(&k.cam0_from_velo, [0.0, 0.0, 0.0]);
        for (a, b) in o.iter().zip([-2.0, 1.0, 3.0]) {
            assert!((a - b).abs() < 1e-12, "{o:?}");
        }
        let refused = |text: String, want: &str| {
            std::fs::write(&c, text).unwrap();
            let e = read_calib(&c).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("calib.txt"), "{e}");
        };
        refused(
            format!("{p}Tr_velo_to_cam: 1 0 0 1 0 1 0 2 0 0 1 3\n"),
            "R0_rect line that rectifies it is missing",
        );
        refused(
            format!("{p}Tr: 1 0 0 0 0 1 0 0 0 0 1 0\nTr_velo_to_cam: 1 0 0 1 0 1 0 2 0 0 1 3\n"),
            "one layout per file",
        );
        refused(
            format!("{p}R0_rect: 1 0 0 0 1 0 0 0 1\nTr: 1 0 0 0 0 1 0 0 0 0 1 0\n"),
            "already rectified",
        );
        refused(
            "calib_time: 15-Mar-2012 11:37:16\nR: 1 0 0 0 1 0 0 0 1\nT: 0 0 0\n".into(),
            "unsupported calibration key \"calib_time\"",
        );
        refused(
            format!("{p}R0_rect: 1 0 0 0 1 0 0 0\nTr_velo_to_cam: 1 0 0 1 0 1 0 2 0 0 1 3\n"),
            "calib.txt:5: expected 9 numbers, found 8",
        );
    }
}
