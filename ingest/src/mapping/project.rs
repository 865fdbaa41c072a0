//! Projection of LiDAR points into the camera (`K·T·l`): `image_from_velo = P2 × Tr`.

use crate::sources::kitti::{Calib, Projection};

/// A point that lands in the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projected {
    /// Index of the point in the scan.
    pub point: u32,
    /// Column-major pixel index `x * height + y` (COCO RLE order).
    pub pixel: u32,
    /// Depth along the optical axis in metres.
    pub depth_m: f32,
}

/// The camera used for projection: a 3×4 matrix and the image size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// `P2 × Tr`: pixels (homogeneous) from velodyne coordinates.
    pub image_from_velo: Projection,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// Points nearer than this to the camera plane are dropped with the ones behind it.
pub const MIN_DEPTH_M: f64 = 0.5;

impl Camera {
    /// KITTI's left colour camera (P2) of a calibration.
    pub fn kitti_p2(calib: &Calib, width: u32, height: u32) -> Camera {
        Camera {
            image_from_velo: calib.p[2] * calib.cam0_from_velo.to_homogeneous(),
            width,
            height,
        }
    }

    /// Projects one point: `(x, y, depth)` in pixels, or `None` behind the camera or
    /// outside the image.
    pub fn project(&self, p: [f32; 3]) -> Option<(u32, u32, f32)> {
        let q = nalgebra::Vector4::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]), 1.0);
        let h = self.image_from_velo * q;
        let w = h.z;
        // also refuses NaN
        if w.is_nan() || w < MIN_DEPTH_M {
            return None;
        }
        let (u, v) = (h.x / w, h.y / w);
        if !(u >= 0.0 && v >= 0.0 && u < f64::from(self.width) && v < f64::from(self.height)) {
            return None;
        }
        Some((u as u32, v as u32, w as f32))
    }

    /// Projects every finite point of a scan; the others are skipped.
    pub fn project_all(&self, points: &[[f32; 4]]) -> Vec<Projected> {
        let mut out = Vec::with_capacity(points.len() / 3);
        for (i, p) in points.iter().enumerate() {
            if let Some((x, y, d)) = self.project([p[0], p[1], p[2]]) {
                out.push(Projected {
                    point: i as u32,
                    pixel: x * self.height + y,
                    depth_m: d,
                });
            }
        }
        out
    }
}

/// The points whose pixel lies inside an RLE mask. `by_pixel` must be sorted by pixel; runs
/// and points are walked together, so this costs O(runs + points).
pub fn points_in_mask(by_pixel: &[Projected], counts: &[u32]) -> Vec<u32> {
    let mut out = Vec::new();
    let mut start = 0u64;
    let mut k = 0usize;
    for (i, run) in counts.iter().enumerate() {
        let end = start + u64::from(*run);
        if i % 2 == 1 && *run > 0 {
            // skip points before the run
            k += by_pixel[k..].partition_point(|p| u64::from(p.pixel) < start);
            while k < by_pixel.len() && u64::from(by_pixel[k].pixel) < end {
                out.push(by_pixel[k].point);
                k += 1;
            }
        }
        start = end;
    }
    out
}

/// A 100×50 camera looking along velodyne x (fx = fy = 100, cx = 50, cy = 25; KITTI axes:
/// cam x = -velo y, cam y = -velo z, cam z = velo x), for tests.
#[cfg(test)]
pub(crate) fn test_camera() -> Camera {
    Camera {
        image_from_velo: Projection::new(
            50.0, -100.0, 0.0, 0.0, //
            25.0, 0.0, -100.0, 0.0, //
            1.0, 0.0, 0.0, 0.0,
        ),
        width: 100,
        height: 50,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sources::rle::Rle;

    #[test]
    fn projection_drops_points_behind_and_outside() {
        let cam = test_camera();
        let (x, y, d) = cam.project([10.0, 0.0, 0.0]).unwrap();
        assert_eq!((x, y), (50, 25));
        assert!((d - 10.0).abs() < 1e-6);
        assert_eq!(cam.project([-10.0, 0.0, 0.0]), None);
        assert_eq!(cam.project([10.0, 20.0, 0.0]), None);
        assert_eq!(cam.project([f32::NAN, 0.0, 0.0]), None);
        let (x, y, _) = cam.project([10.0, 1.0, 1.0]).unwrap();
        assert_eq!((x, y), (40, 15));
    }

    #[test]
    fn mask_lookup_matches_a_dense_check() {
        let cam = test_camera();
        let pts: Vec<[f32; 4]> = (0..400)
            .map(|i| {
                [
                    10.0,
                    (i % 20) as f32 * 0.2 - 2.0,
                    (i / 20) as f32 * 0.1 - 1.0,
                    0.0,
                ]
            })
            .collect();
        let mut proj = cam.project_all(&pts);
        proj.sort_by_key(|p| p.pixel);
        let mut mask = vec![false; 100 * 50];
        for y in 10..30 {
            for x in 30..60 {
                mask[y * 100 + x] = (x + y) % 3 != 0;
            }
        }
        let rle = Rle::from_mask(50, 100, &mask).unwrap();
        let mut got = points_in_mask(&proj, &rle.counts);
        got.sort_unstable();
        let mut want: Vec<u32> = proj
            .iter()
            .filter(|p| {
                let (x, y) = (p.pixel / 50, p.pixel % 50);
                mask[(y * 100 + x) as usize]
            })
            .map(|p| p.point)
            .collect();
        want.sort_unstable();
        assert!(!want.is_empty());
        assert_eq!(got, want);
    }
}
