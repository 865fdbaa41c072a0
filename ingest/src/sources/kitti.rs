//! KITTI odometry text files: `poses.txt` (cam0-to-world, 3×4 row-major per line) and
//! `calib.txt` (`P0`..`P3`, `Tr` velodyne-to-cam0, each 3×4 row-major).
//!
//! `world_from_velo = world_from_cam0 × cam0_from_velo`, i.e. `pose × Tr`. KITTI's world frame
//! is cam0's first frame: x right, y down, z forward, so the ground plane is (x, z).

use std::path::Path;

use crate::error::{Error, Result, read_text};

/// A rigid transform as a 3×4 row-major matrix `[R | t]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mat34(pub [[f64; 4]; 3]);

impl Mat34 {
    /// The identity.
    pub const IDENTITY: Mat34 = Mat34([
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ]);

    /// From 12 row-major values.
    pub fn from_row_major(v: &[f64]) -> Option<Mat34> {
        if v.len() != 12 {
            return None;
        }
        let mut m = [[0.0; 4]; 3];
        for (i, x) in v.iter().enumerate() {
            m[i / 4][i % 4] = *x;
        }
        Some(Mat34(m))
    }

    /// `self × other` (both as 4×4 with a last row 0 0 0 1).
    pub fn compose(&self, other: &Mat34) -> Mat34 {
        let (a, b) = (&self.0, &other.0);
        let mut m = [[0.0; 4]; 3];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, cell) in row.iter_mut().enumerate() {
                let mut s = (0..3).map(|k| a[r][k] * b[k][c]).sum::<f64>();
                if c == 3 {
                    s += a[r][3];
                }
                *cell = s;
            }
        }
        Mat34(m)
    }

    /// The translation column.
    pub fn translation(&self) -> [f64; 3] {
        [self.0[0][3], self.0[1][3], self.0[2][3]]
    }

    /// Applies the transform to a point.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.0;
        [0, 1, 2].map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
    }

    /// Applies the rotation part only (to a direction).
    pub fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        let m = &self.0;
        [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
    }

    /// The inverse of a rigid transform (`Rᵀ`, `-Rᵀ·t`).
    pub fn inverse_rigid(&self) -> Mat34 {
        let m = &self.0;
        let mut out = [[0.0; 4]; 3];
        for r in 0..3 {
            for c in 0..3 {
                out[r][c] = m[c][r];
            }
            out[r][3] = -(0..3).map(|k| m[k][r] * m[k][3]).sum::<f64>();
        }
        Mat34(out)
    }

    /// The 12 row-major values.
    pub fn to_row_major(&self) -> Vec<f64> {
        self.0.iter().flat_map(|r| r.iter().copied()).collect()
    }
}

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
pub fn read_poses(path: &Path) -> Result<Vec<Mat34>> {
    let text = read_text(path)?;
    let mut poses = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let v = parse_floats(path, i + 1, line, 12)?;
        poses.push(Mat34::from_row_major(&v).expect("12 values"));
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

/// KITTI odometry calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Calib {
    /// Projection matrices P0..P3 (rectified cameras).
    pub p: [Mat34; 4],
    /// `Tr`: cam0 from velodyne.
    pub cam0_from_velo: Mat34,
}

/// Reads `calib.txt`; `Tr` and `P0`..`P3` must all be present.
pub fn read_calib(path: &Path) -> Result<Calib> {
    let text = read_text(path)?;
    let mut p: [Option<Mat34>; 4] = [None; 4];
    let mut tr = None;
    for (i, line) in text.lines().enumerate() {
        let Some((key, rest)) = line.split_once(':') else {
            if line.trim().is_empty() {
                continue;
            }
            return Err(Error::Parse {
                path: path.to_path_buf(),
                line: i + 1,
                detail: "expected `KEY: 12 numbers`".into(),
            });
        };
        let key = key.trim();
        let slot = match key {
            "P0" => &mut p[0],
            "P1" => &mut p[1],
            "P2" => &mut p[2],
            "P3" => &mut p[3],
            "Tr" | "Tr_velo_to_cam" => &mut tr,
            _ => continue,
        };
        let v = parse_floats(path, i + 1, rest, 12)?;
        *slot = Mat34::from_row_major(&v);
    }
    let missing = |k: &str| Error::File {
        path: path.to_path_buf(),
        detail: format!("calibration has no {k} line"),
    };
    let cam0_from_velo = tr.ok_or_else(|| missing("Tr"))?;
    let get = |i: usize| p[i].ok_or_else(|| missing(&format!("P{i}")));
    Ok(Calib {
        p: [get(0)?, get(1)?, get(2)?, get(3)?],
        cam0_from_velo,
    })
}

/// World positions of the sensor for each pose: cam0's, or the velodyne's when `calib` is
/// given (`world_from_velo = pose × Tr`).
pub fn positions(poses: &[Mat34], calib: Option<&Calib>) -> Vec<[f64; 3]> {
    poses
        .iter()
        .map(|pose| match calib {
            Some(c) => pose.compose(&c.cam0_from_velo).translation(),
            None => pose.translation(),
        })
        .collect()
}

/// Ground-plane trajectory from KITTI poses: the (x, z) of each of [`positions`].
pub fn ground_trajectory(poses: &[Mat34], calib: Option<&Calib>) -> Vec<[f64; 2]> {
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
    fn compose_matches_hand_computation() {
        let a = Mat34([
            [0.0, -1.0, 0.0, 1.0],
            [1.0, 0.0, 0.0, 2.0],
            [0.0, 0.0, 1.0, 3.0],
        ]);
        let b = Mat34([
            [1.0, 0.0, 0.0, 5.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ]);
        let c = a.compose(&b);
        let p = c.apply([0.0, 0.0, 0.0]);
        let q = a.apply(b.apply([0.0, 0.0, 0.0]));
        for i in 0..3 {
            assert!((p[i] - q[i]).abs() < 1e-12);
        }
        assert!((p[0] - 1.0).abs() < 1e-12 && (p[1] - 7.0).abs() < 1e-12);
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
                .contains("no Tr line")
        );
    }
}
