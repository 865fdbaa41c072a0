//! The simulated sensors: an HDL-64E-like LiDAR and KITTI's left colour camera (P2), both
//! cast against the scene's BVH, and the detections the camera's instance image yields, with
//! noise knobs.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::scene::{Attributes, City, Hit, Kind, Surface};
use crate::sources::detections::{Detection, DetectionFrame, Producer};
use crate::sources::kitti::{Calib, Projection, Rigid3};
use crate::sources::rle::Rle;
use scene::pose::{matrix_row_major, row_major};

/// The spinning LiDAR.
#[derive(Debug, Clone, PartialEq)]
pub struct LidarConfig {
    /// Number of beams.
    pub beams: u32,
    /// Elevation of the top beam, degrees.
    pub top_deg: f64,
    /// Elevation of the bottom beam, degrees.
    pub bottom_deg: f64,
    /// Azimuth step, degrees.
    pub azimuth_step_deg: f64,
    /// Maximum range, metres.
    pub max_range_m: f64,
    /// Standard deviation of the Gaussian range noise, metres.
    pub range_noise_m: f64,
}

impl Default for LidarConfig {
    /// Velodyne HDL-64E as on KITTI.
    fn default() -> LidarConfig {
        LidarConfig {
            beams: 64,
            top_deg: 2.0,
            bottom_deg: -24.9,
            azimuth_step_deg: 0.17,
            max_range_m: 120.0,
            range_noise_m: 0.02,
        }
    }
}

/// Detection noise knobs.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DetectionNoise {
    /// Probability that a visible object is not detected.
    pub miss_rate: f64,
    /// Mean number of false positives per frame (blobs with the caption of something else).
    pub false_positives_per_frame: f64,
    /// Probability that a caption uses another phrasing than the ground truth's.
    pub paraphrase_rate: f64,
    /// Probability that a caption names a wrong colour.
    pub wrong_attribute_rate: f64,
    /// Masks are eroded or dilated by up to this many pixels (uniform in `-k..=k`).
    pub mask_noise_px: u32,
}

impl Default for DetectionNoise {
    fn default() -> DetectionNoise {
        DetectionNoise {
            miss_rate: 0.05,
            false_positives_per_frame: 0.2,
            paraphrase_rate: 0.5,
            wrong_attribute_rate: 0.05,
            mask_noise_px: 1,
        }
    }
}

impl DetectionNoise {
    /// No noise at all.
    pub fn none() -> DetectionNoise {
        DetectionNoise {
            miss_rate: 0.0,
            false_positives_per_frame: 0.0,
            paraphrase_rate: 0.0,
            wrong_attribute_rate: 0.0,
            mask_noise_px: 0,
        }
    }
}

/// The camera and what is detected.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraConfig {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The instance image is ray cast at `1/downsample` resolution and upsampled.
    pub downsample: u32,
    /// Objects farther than this are not detected.
    pub max_detection_m: f32,
    /// Objects covering fewer full-resolution pixels are not detected.
    pub min_pixels: u32,
}

impl Default for CameraConfig {
    fn default() -> CameraConfig {
        CameraConfig {
            width: 1242,
            height: 375,
            downsample: 3,
            max_detection_m: 50.0,
            min_pixels: 60,
        }
    }
}

/// KITTI odometry calibration with KITTI's P0-P3 intrinsics and an ideal `Tr` (velodyne
/// 0.08 m above and 0.27 m behind cam0, axes exactly aligned).
pub fn kitti_calib() -> Calib {
    let (f, cx, cy) = (718.856, 607.1928, 185.2157);
    let p = |tx: f64, ty: f64, tz: f64| {
        Projection::new(f, 0.0, cx, tx, 0.0, f, cy, ty, 0.0, 0.0, 1.0, tz)
    };
    Calib {
        p: [
            p(0.0, 0.0, 0.0),
            p(-386.1448, 0.0, 0.0),
            p(45.38225, -0.1130887, 0.003779761),
            p(-337.2877, 2.369057, 0.004915215),
        ],
        // cam x = -velo y, cam y = -velo z, cam z = velo x
        cam0_from_velo: scene::pose::rigid_from_row_major(&[
            0.0, -1.0, 0.0, 0.0, //
            0.0, 0.0, -1.0, -0.08, //
            1.0, 0.0, 0.0, -0.27,
        ])
        .expect("12 values"),
    }
}

/// `calib.txt` text of a calibration.
pub fn calib_text(c: &Calib) -> String {
    let row = |m: &[f64; 12]| {
        m.iter()
            .map(|v| format!("{v:.12e}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    format!(
        "P0: {}\nP1: {}\nP2: {}\nP3: {}\nTr: {}\n",
        row(&matrix_row_major(&c.p[0])),
        row(&matrix_row_major(&c.p[1])),
        row(&matrix_row_major(&c.p[2])),
        row(&matrix_row_major(&c.p[3])),
        row(&row_major(&c.cam0_from_velo))
    )
}

fn f32x3(v: [f64; 3]) -> [f32; 3] {
    [v[0] as f32, v[1] as f32, v[2] as f32]
}

/// A standard normal draw (Box-Muller).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Remission (reflectance) per semantic label, roughly as KITTI's.
fn remission(label: u16) -> f64 {
    match label {
        40 | 44 => 0.25,
        48 => 0.3,
        72 => 0.35,
        70 | 71 => 0.2,
        50..=52 => 0.3,
        80 => 0.4,
        81 => 0.9,
        10 | 18 | 20 => 0.5,
        _ => 0.3,
    }
}

/// One LiDAR scan: points `[x, y, z, remission]` in the velodyne frame and SemanticKITTI
/// labels (`instance << 16 | semantic`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LidarScan {
    /// Points.
    pub points: Vec<[f32; 4]>,
    /// One label per point.
    pub labels: Vec<u32>,
}

/// Casts every beam at every azimuth from `world_from_velo`.
pub fn lidar_scan(
    scene: &City,
    movers: &[super::movers::MoverBox],
    world_from_velo: &Rigid3,
    cfg: &LidarConfig,
    rng: &mut ChaCha8Rng,
) -> LidarScan {
    let origin = f32x3(world_from_velo.translation.vector.into());
    let columns = (360.0 / cfg.azimuth_step_deg).round() as u32;
    let mut scan = LidarScan::default();
    let beams = cfg.beams.max(1);
    for b in 0..beams {
        let frac = if beams > 1 {
            f64::from(b) / f64::from(beams - 1)
        } else {
            0.0
        };
        let el = (cfg.top_deg + (cfg.bottom_deg - cfg.top_deg) * frac).to_radians();
        let (se, ce) = el.sin_cos();
        for c in 0..columns {
            let az = (f64::from(c) * cfg.azimuth_step_deg).to_radians();
            let (sa, ca) = az.sin_cos();
            let d_velo = [ce * ca, ce * sa, se];
            let d_world =
                f32x3((world_from_velo.rotation * nalgebra::Vector3::from(d_velo)).into());
            let Some((t, hit)) = scene.cast_among(origin, d_world, cfg.max_range_m as f32, movers)
            else {
                continue;
            };
            let r = (f64::from(t) + gaussian(rng) * cfg.range_noise_m).max(0.0);
            let label = match hit {
                Hit::Ground(s) => u32::from(s.semantic()),
                Hit::Object(i) => {
                    let o = &scene.objects[i as usize];
                    (o.id << 16) | u32::from(o.kind.semantic())
                }
                Hit::Mover(i) => {
                    let m = &scene.movers[i as usize];
                    (m.id << 16) | u32::from(m.semantic())
                }
            };
            let refl = (remission((label & 0xFFFF) as u16) + gaussian(rng) * 0.05).clamp(0.0, 1.0);
            scan.points.push([
                (d_velo[0] * r) as f32,
                (d_velo[1] * r) as f32,
                (d_velo[2] * r) as f32,
                refl as f32,
            ]);
            scan.labels.push(label);
        }
    }
    scan
}

/// What a pixel of the instance image shows.
pub const SKY: u32 = 0;
/// Ground pixels are `GROUND | semantic label`; objects are their instance id.
pub const GROUND: u32 = 0x8000_0000;

/// The camera's low-resolution instance image (row-major, `width/ds × height/ds`): for each
/// pixel the object id, `GROUND | label`, or `SKY`, and the hit distance.
#[derive(Debug)]
pub struct InstanceImage {
    /// Width in low-resolution pixels.
    pub width: u32,
    /// Height in low-resolution pixels.
    pub height: u32,
    /// What each pixel shows.
    pub ids: Vec<u32>,
    /// Distance along the ray, metres (infinite for sky).
    pub depth_m: Vec<f32>,
}

/// Ray casts the instance image of camera P2 at `world_from_cam0`.
pub fn render(
    scene: &City,
    movers: &[super::movers::MoverBox],
    calib: &Calib,
    world_from_cam0: &Rigid3,
    cfg: &CameraConfig,
) -> InstanceImage {
    let p = &calib.p[2];
    let (fx, fy, cx, cy) = (p[(0, 0)], p[(1, 1)], p[(0, 2)], p[(1, 2)]);
    // P2 = K [I | t]: the camera centre in cam0 is -K⁻¹ p4
    let tz = p[(2, 3)];
    let k_inv_p4 = [(p[(0, 3)] - cx * tz) / fx, (p[(1, 3)] - cy * tz) / fy, tz];
    let centre_cam0 = [-k_inv_p4[0], -k_inv_p4[1], -k_inv_p4[2]];
    let origin = f32x3(scene::pose::apply(world_from_cam0, centre_cam0));
    let ds = cfg.downsample.max(1);
    let (w, h) = (cfg.width / ds, cfg.height / ds);
    let mut ids = vec![SKY; (w * h) as usize];
    let mut depth_m = vec![f32::INFINITY; (w * h) as usize];
    for v in 0..h {
        for u in 0..w {
            let (fu, fv) = (
                (f64::from(u) + 0.5) * f64::from(ds),
                (f64::from(v) + 0.5) * f64::from(ds),
            );
            let d = [(fu - cx) / fx, (fv - cy) / fy, 1.0];
            let n = (d[0] * d[0] + d[1] * d[1] + 1.0).sqrt();
            let dw = f32x3(
                (world_from_cam0.rotation * nalgebra::Vector3::new(d[0] / n, d[1] / n, 1.0 / n))
                    .into(),
            );
            if let Some((t, hit)) = scene.cast_among(origin, dw, 150.0, movers) {
                let i = (v * w + u) as usize;
                ids[i] = match hit {
                    Hit::Ground(s) => GROUND | u32::from(s.semantic()),
                    Hit::Object(o) => scene.objects[o as usize].id,
                    Hit::Mover(m) => scene.movers[m as usize].id,
                };
                depth_m[i] = t;
            }
        }
    }
    InstanceImage {
        width: w,
        height: h,
        ids,
        depth_m,
    }
}

/// What produced each detection of a frame (the simulator's record, for evaluation).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DetectionTruth {
    /// The object's instance id, if it is one.
    pub object: Option<u32>,
    /// The surface, if it is one.
    pub surface: Option<&'static str>,
    /// A false positive (its caption names `caption_of`).
    pub false_positive: bool,
    /// The class whose caption bank a false positive's caption came from.
    pub caption_of: Option<&'static str>,
    /// Caption phrasing (0 is the ground truth's).
    pub phrasing: u8,
    /// The caption names a wrong colour.
    pub wrong_colour: bool,
    /// Erosion (negative) or dilation (positive) of the mask, pixels.
    pub mask_noise_px: i32,
}

/// The detections of a frame and what produced each, plus the visible objects missed.
#[derive(Debug)]
pub struct FrameDetections {
    /// In the detections format.
    pub frame: DetectionFrame,
    /// One per detection.
    pub truth: Vec<DetectionTruth>,
    /// Visible, detectable objects dropped by `miss_rate`.
    pub missed: Vec<u32>,
}

/// Dilates (`r > 0`) or erodes (`r < 0`) a row-major mask by `|r|` pixels (square element).
pub fn morph(mask: &[bool], width: usize, height: usize, r: i32) -> Vec<bool> {
    if r == 0 {
        return mask.to_vec();
    }
    let k = r.unsigned_abs() as usize;
    let dilate = r > 0;
    // separable: rows then columns; erosion is dilation of the complement
    let pass = |src: &[bool], horizontal: bool| -> Vec<bool> {
        let mut out = vec![!dilate; src.len()];
        for y in 0..height {
            for x in 0..width {
                let (lo, hi, at): (usize, usize, &dyn Fn(usize) -> usize) = if horizontal {
                    (x.saturating_sub(k), (x + k).min(width - 1), &|i| {
                        y * width + i
                    })
                } else {
                    (y.saturating_sub(k), (y + k).min(height - 1), &|i| {
                        i * width + x
                    })
                };
                let any = (lo..=hi).any(|i| src[at(i)] == dilate);
                out[y * width + x] = if any { dilate } else { !dilate };
            }
        }
        out
    };
    let h = pass(mask, true);
    pass(&h, false)
}

/// The detections seen in an instance image: one per visible object (within range and
/// large enough), one per ground surface, and noise.
pub fn detect(
    scene: &City,
    frame: u32,
    img: &InstanceImage,
    cfg: &CameraConfig,
    noise: &DetectionNoise,
    rng: &mut ChaCha8Rng,
) -> crate::error::Result<FrameDetections> {
    let ds = cfg.downsample.max(1);
    let (fw, fh) = (img.width * ds, img.height * ds);
    // per id: low-res pixel count and nearest hit
    let mut seen: std::collections::BTreeMap<u32, (u32, f32)> = std::collections::BTreeMap::new();
    for (i, id) in img.ids.iter().enumerate() {
        if *id == SKY {
            continue;
        }
        let e = seen.entry(*id).or_insert((0, f32::INFINITY));
        e.0 += 1;
        e.1 = e.1.min(img.depth_m[i]);
    }
    let full_mask = |id: u32| -> Vec<bool> {
        let mut m = vec![false; (fw * fh) as usize];
        for v in 0..img.height {
            for u in 0..img.width {
                if img.ids[(v * img.width + u) as usize] == id {
                    for dv in 0..ds {
                        let row = ((v * ds + dv) * fw) as usize;
                        for du in 0..ds {
                            m[row + (u * ds + du) as usize] = true;
                        }
                    }
                }
            }
        }
        m
    };
    let mut dets = Vec::new();
    let mut truth = Vec::new();
    let mut missed = Vec::new();
    let min_low = cfg.min_pixels.div_ceil(ds * ds).max(1);
    let mut push = |mask: Vec<bool>,
                    caption: String,
                    tags: Vec<String>,
                    score: f64,
                    t: DetectionTruth|
     -> crate::error::Result<()> {
        let rle = Rle::from_mask(fh, fw, &mask)?;
        let Some(bbox) = rle.bbox() else {
            return Ok(());
        };
        dets.push(Detection {
            mask: rle,
            bbox,
            score,
            tags,
            caption,
            feature: None,
        });
        truth.push(t);
        Ok(())
    };
    let noisy = |rng: &mut ChaCha8Rng, m: Vec<bool>| -> (Vec<bool>, i32) {
        let k = noise.mask_noise_px as i32;
        let r = if k > 0 { rng.random_range(-k..=k) } else { 0 };
        (morph(&m, fw as usize, fh as usize, r), r)
    };
    for (&id, &(count, near)) in &seen {
        if id & GROUND != 0 || count < min_low || near > cfg.max_detection_m {
            continue;
        }
        let Some((kind, attributes)) = scene.describe(id) else {
            continue;
        };
        if rng.random_range(0.0..1.0) < noise.miss_rate {
            missed.push(id);
            continue;
        }
        let phrasing = if rng.random_range(0.0..1.0) < noise.paraphrase_rate {
            rng.random_range(1..3u8)
        } else {
            0
        };
        let wrong = rng.random_range(0.0..1.0) < noise.wrong_attribute_rate;
        let colour = wrong.then(|| {
            // another colour of the same bank, or the same one when the bank has one
            let mut r2 = ChaCha8Rng::seed_from_u64(u64::from(id) ^ 0xC010);
            let mut c = attributes.colour;
            for _ in 0..8 {
                let a = Attributes::draw(kind, &mut r2);
                if a.colour != attributes.colour {
                    c = a.colour;
                    break;
                }
            }
            c
        });
        let caption = attributes.caption(kind, phrasing, colour);
        let (mask, r) = noisy(rng, full_mask(id));
        push(
            mask,
            caption,
            vec![kind.class().to_string()],
            rng.random_range(0.6..0.99),
            DetectionTruth {
                object: Some(id),
                surface: None,
                false_positive: false,
                caption_of: None,
                phrasing,
                wrong_colour: colour.is_some_and(|c| c != attributes.colour),
                mask_noise_px: r,
            },
        )?;
    }
    for s in Surface::ALL {
        let id = GROUND | u32::from(s.semantic());
        let Some(&(count, _)) = seen.get(&id) else {
            continue;
        };
        if count < 100 || rng.random_range(0.0..1.0) < noise.miss_rate {
            continue;
        }
        let caps = s.captions();
        let caption = caps[rng.random_range(0..caps.len())].to_string();
        push(
            full_mask(id),
            caption,
            vec![s.name().to_string()],
            rng.random_range(0.7..0.99),
            DetectionTruth {
                object: None,
                surface: Some(s.name()),
                false_positive: false,
                caption_of: None,
                phrasing: 0,
                wrong_colour: false,
                mask_noise_px: 0,
            },
        )?;
    }
    // false positives: elliptic blobs captioned as something random
    let fp = noise.false_positives_per_frame.max(0.0);
    let n_fp = fp.floor() as u32 + u32::from(rng.random_range(0.0..1.0) < fp.fract());
    for _ in 0..n_fp {
        let kind = Kind::ALL[rng.random_range(0..Kind::ALL.len())];
        let a = Attributes::draw(kind, rng);
        let (cx, cy) = (
            rng.random_range(0.0..f64::from(fw)),
            rng.random_range(f64::from(fh) * 0.3..f64::from(fh)),
        );
        let (rx, ry) = (rng.random_range(10.0..60.0), rng.random_range(10.0..50.0));
        let mut m = vec![false; (fw * fh) as usize];
        for y in 0..fh {
            for x in 0..fw {
                let (dx, dy) = ((f64::from(x) - cx) / rx, (f64::from(y) - cy) / ry);
                if dx * dx + dy * dy <= 1.0 {
                    m[(y * fw + x) as usize] = true;
                }
            }
        }
        push(
            m,
            a.caption(kind, 0, None),
            vec![kind.class().to_string()],
            rng.random_range(0.3..0.6),
            DetectionTruth {
                object: None,
                surface: None,
                false_positive: true,
                caption_of: Some(kind.class()),
                phrasing: 0,
                wrong_colour: false,
                mask_noise_px: 0,
            },
        )?;
    }
    Ok(FrameDetections {
        frame: DetectionFrame {
            frame,
            width: fw,
            height: fh,
            producer: Producer::Simulator,
            detections: dets,
        },
        truth,
        missed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morphology_grows_and_shrinks_a_square() {
        let (w, h) = (12, 10);
        let mut m = vec![false; w * h];
        for y in 3..7 {
            for x in 4..8 {
                m[y * w + x] = true;
            }
        }
        let count = |m: &[bool]| m.iter().filter(|b| **b).count();
        assert_eq!(count(&morph(&m, w, h, 0)), 16);
        assert_eq!(count(&morph(&m, w, h, 1)), 36);
        assert_eq!(count(&morph(&m, w, h, -1)), 4);
        assert_eq!(count(&morph(&m, w, h, -2)), 0);
    }

    #[test]
    fn calib_round_trips_through_the_kitti_reader() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("calib.txt");
        std::fs::write(&p, calib_text(&kitti_calib())).unwrap();
        let c = crate::sources::kitti::read_calib(&p).unwrap();
        let want = kitti_calib();
        for (a, b) in c.p[2].iter().zip(want.p[2].iter()) {
            assert!((a - b).abs() < 1e-9);
        }
        // the velodyne sits 0.08 m above cam0: y is down
        assert!((c.cam0_from_velo.translation.y + 0.08).abs() < 1e-12);
    }
}
