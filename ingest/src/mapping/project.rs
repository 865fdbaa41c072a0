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

    /// The focal length along the image's x axis, in pixels: `fx` of the intrinsics in
    /// `image_from_velo = K·[R|t]` (the first row is `fx·r₁ + cx·r₃`, the third `r₃`, a unit
    /// vector orthogonal to `r₁`). An object `w` metres wide at range `d` spans about
    /// `w·fx/d` pixels.
    pub fn focal_px(&self) -> f64 {
        let m = &self.image_from_velo;
        let (r0, r2) = (m.fixed_view::<1, 3>(0, 0), m.fixed_view::<1, 3>(2, 0));
        let n2 = r2.norm_squared();
        if n2 <= 0.0 || !n2.is_finite() {
            return 0.0;
        }
        let cx = r0.dot(&r2) / n2;
        (r0 - r2 * cx).norm()
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
    projected_in_mask(by_pixel, counts)
        .into_iter()
        .map(|p| p.point)
        .collect()
}

/// [`points_in_mask`] with each point's pixel and depth: the projected points inside the
/// mask, in pixel order.
pub fn projected_in_mask(by_pixel: &[Projected], counts: &[u32]) -> Vec<Projected> {
    let mut out = Vec::new();
    let mut start = 0u64;
    let mut k = 0usize;
    for (i, run) in counts.iter().enumerate() {
        let end = start + u64::from(*run);
        if i % 2 == 1 && *run > 0 {
            // skip points before the run
            k += by_pixel[k..].partition_point(|p| u64::from(p.pixel) < start);
            while k < by_pixel.len() && u64::from(by_pixel[k].pixel) < end {
                out.push(by_pixel[k]);
                k += 1;
            }
        }
        start = end;
    }
    out
}

/// Which of the points in a mask lie in its core: for each of `in_mask` (projected points
/// inside the mask, as [`points_in_mask`] finds them, by pixel), whether every pixel within
/// `r_px` of its pixel (a square window) is in the mask too. Pixels outside the image count as
/// in the mask: an object the image cuts off continues past the border, and nothing behind
/// it shows there. A thing behind an object shows in the object's mask only where the mask
/// overshoots the object's outline, within a few pixels of the mask's edge; the object's own
/// points also fill the core. `height` is the image height (the RLE's column length).
pub fn core_of_mask(in_mask: &[Projected], counts: &[u32], height: u32, r_px: u32) -> Vec<bool> {
    // the mask's runs as [start, end) of column-major pixel indexes
    let mut runs: Vec<(u64, u64)> = Vec::with_capacity(counts.len() / 2);
    let mut start = 0u64;
    for (i, run) in counts.iter().enumerate() {
        let end = start + u64::from(*run);
        if i % 2 == 1 && *run > 0 {
            runs.push((start, end));
        }
        start = end;
    }
    let total = start;
    let h = u64::from(height.max(1));
    let width = total / h;
    let r = u64::from(r_px);
    // [a, b] inside one run
    let covered = |a: u64, b: u64| -> bool {
        let k = runs.partition_point(|run| run.0 <= a);
        k > 0 && runs[k - 1].1 > b
    };
    in_mask
        .iter()
        .map(|p| {
            let (x, y) = (u64::from(p.pixel) / h, u64::from(p.pixel) % h);
            let (y0, y1) = (y.saturating_sub(r), (y + r).min(h - 1));
            (x.saturating_sub(r)..=x + r)
                .filter(|c| *c < width)
                .all(|c| covered(c * h + y0, c * h + y1))
        })
        .collect()
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
    fn the_focal_length_is_read_from_the_projection() {
        assert!((test_camera().focal_px() - 100.0).abs() < 1e-9);
        // the simulator's P2 (fx 718.856, a small tz) times its Tr: a rotation does not
        // change fx
        let cam = Camera::kitti_p2(&crate::sources::sim::sensors::kitti_calib(), 1242, 375);
        assert!(
            (cam.focal_px() - 718.856).abs() < 1e-2,
            "{}",
            cam.focal_px()
        );
    }

    /// The core of a mask: the points whose whole window lies in the mask, checked against a
    /// dense erosion; the image border counts as inside.
    #[test]
    fn the_core_of_a_mask_matches_a_dense_erosion() {
        let (w, h) = (40usize, 30usize);
        let mut mask = vec![false; w * h];
        for y in 5..25 {
            for x in 0..30 {
                // a rectangle cut by the left border, with a notch
                mask[y * w + x] = !(12..15).contains(&x) || y > 15;
            }
        }
        let rle = Rle::from_mask(h as u32, w as u32, &mask).unwrap();
        let all: Vec<Projected> = (0..(w * h) as u32)
            .map(|i| Projected {
                point: i,
                pixel: i,
                depth_m: 1.0,
            })
            .collect();
        let inside = projected_in_mask(&all, &rle.counts);
        for r in [0u32, 1, 2, 3] {
            let core = core_of_mask(&inside, &rle.counts, h as u32, r);
            for (p, c) in inside.iter().zip(&core) {
                let (x, y) = ((p.pixel as usize) / h, (p.pixel as usize) % h);
                let r = r as i64;
                let want = (-r..=r).all(|dx| {
                    (-r..=r).all(|dy| {
                        let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                        xx < 0
                            || yy < 0
                            || xx >= w as i64
                            || yy >= h as i64
                            || mask[yy as usize * w + xx as usize]
                    })
                });
                assert_eq!(*c, want, "pixel ({x}, {y}), r {r}");
            }
            if r == 0 {
                assert!(core.iter().all(|c| *c));
            }
        }
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
