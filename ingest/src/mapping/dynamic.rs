//! Moving objects: a dynamic-point filter before projection (the paper removes dynamic points
//! with 4DMOS; no such network runs here).
//!
//! Free-space carving over a sliding window of scans: a point of the key scan is where
//! something stood at that time. If, in a neighbouring scan of the window, the LiDAR's beams
//! towards that place all went clearly *past* it (the nearest return in that direction is
//! farther than the point by more than a margin), the place was empty then, so what stood
//! there moved; the point is removed when enough neighbours see through it. This is the
//! visibility test of map-cleaning methods such as Pomerleau et al., "Long-term 3D map
//! maintenance in dynamic environments" (ICRA 2014) and Kim and Kim, "Remove, then Revert"
//! (IROS 2020), applied scan to scan. Each neighbour becomes a range image (azimuth ×
//! elevation bins holding the *nearest* return), so a bin that mixes an edge and the
//! background never votes "free".

use crate::sources::kitti::Rigid3;

/// Filter parameters (`[dynamic]` in the build configuration).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DynamicConfig {
    /// Remove dynamic points at all.
    pub enabled: bool,
    /// Neighbouring scans on each side of the key scan (in the sequence, not key frames).
    pub window: u32,
    /// Neighbours that must see through a point for it to go.
    pub min_votes: u32,
    /// Angular size of a range-image bin, degrees.
    pub bin_deg: f64,
    /// A bin holds the nearest return of the bins up to this many away in each direction
    /// too, so that a beam passing just beside a thin or edge point never vouches for the
    /// place being empty.
    pub spread_bins: u32,
    /// A return must lie this much beyond the point, metres ...
    pub margin_m: f64,
    /// ... plus this share of the point's range.
    pub margin_frac: f64,
    /// Points nearer to the sensor than this are kept (the car's own body, noise).
    pub min_range_m: f64,
    /// A thing's detection is of a moving thing, and is not mapped, when at least this share
    /// of the points in its mask were removed: the filter catches only part of a moving
    /// object, and what it leaves would become a ghost (1 maps every detection).
    pub moving_detection_share: f64,
}

impl Default for DynamicConfig {
    fn default() -> Self {
        DynamicConfig {
            enabled: true,
            window: 2,
            min_votes: 1,
            bin_deg: 0.5,
            spread_bins: 1,
            margin_m: 0.5,
            margin_frac: 0.05,
            min_range_m: 2.0,
            moving_detection_share: 0.3,
        }
    }
}

impl DynamicConfig {
    /// Checks ranges; the message names the key.
    pub fn validate(&self) -> crate::Result<()> {
        let bad = |m: &str| Err(crate::Error::Invalid(format!("[dynamic] {m}")));
        if self.window == 0 || self.window > 20 {
            return bad("window must be in 1..=20 scans");
        }
        if self.min_votes == 0 || self.min_votes > 2 * self.window {
            return bad("min_votes must be in 1..=2 × window");
        }
        if !(self.bin_deg.is_finite() && self.bin_deg >= 0.05 && self.bin_deg <= 10.0) {
            return bad("bin_deg must be in [0.05, 10] degrees");
        }
        if self.spread_bins > 10 {
            return bad("spread_bins must be at most 10");
        }
        if !(self.moving_detection_share.is_finite()
            && (0.0..=1.0).contains(&self.moving_detection_share))
        {
            return bad("moving_detection_share must be a number in [0, 1]");
        }
        for (k, v) in [
            ("margin_m", self.margin_m),
            ("margin_frac", self.margin_frac),
            ("min_range_m", self.min_range_m),
        ] {
            if !(v.is_finite() && (0.0..1e6).contains(&v)) {
                return bad(&format!("{k} must be a non-negative number below 1e6"));
            }
        }
        Ok(())
    }
}

/// A scan as seen from its own sensor: the nearest return per (azimuth, elevation) bin.
#[derive(Debug, Clone)]
pub struct RangeImage {
    velo_from_world: Rigid3,
    bin_rad: f64,
    columns: usize,
    rows: usize,
    /// Row-major `rows × columns`, infinite where no return fell.
    nearest_m: Vec<f32>,
}

impl RangeImage {
    /// The range image of `points` (velodyne frame) taken at `world_from_velo`, each bin
    /// holding the nearest return within `spread` bins of it (columns wrap around).
    pub fn new(
        points: &[[f32; 4]],
        world_from_velo: &Rigid3,
        bin_deg: f64,
        spread: u32,
    ) -> RangeImage {
        let bin_rad = bin_deg.to_radians();
        let columns = (std::f64::consts::TAU / bin_rad).ceil() as usize;
        let rows = (std::f64::consts::PI / bin_rad).ceil() as usize + 1;
        let mut img = RangeImage {
            velo_from_world: world_from_velo.inverse(),
            bin_rad,
            columns,
            rows,
            nearest_m: vec![f32::INFINITY; columns * rows],
        };
        for p in points {
            let q = [p[0], p[1], p[2]].map(f64::from);
            if let Some((k, r)) = img.bin(q) {
                let e = &mut img.nearest_m[k];
                *e = e.min(r as f32);
            }
        }
        // separable minimum filter: along each row (wrapping), then along each column
        let k = spread as usize;
        if k > 0 {
            let (w, h) = (columns, rows);
            let src = img.nearest_m.clone();
            let mut tmp = vec![f32::INFINITY; w * h];
            for y in 0..h {
                for x in 0..w {
                    let mut m = f32::INFINITY;
                    for dx in 0..=2 * k {
                        let xx = (x + w + dx - k) % w;
                        m = m.min(src[y * w + xx]);
                    }
                    tmp[y * w + x] = m;
                }
            }
            for y in 0..h {
                for x in 0..w {
                    let (lo, hi) = (y.saturating_sub(k), (y + k).min(h - 1));
                    img.nearest_m[y * w + x] = (lo..=hi)
                        .map(|yy| tmp[yy * w + x])
                        .fold(f32::INFINITY, f32::min);
                }
            }
        }
        img
    }

    /// The bin index of a velodyne-frame point and its range.
    fn bin(&self, q: [f64; 3]) -> Option<(usize, f64)> {
        let r = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        if !(r.is_finite() && r > 1e-6) {
            return None;
        }
        let az = q[1].atan2(q[0]).rem_euclid(std::f64::consts::TAU);
        let el = (q[2] / r).clamp(-1.0, 1.0).asin() + std::f64::consts::FRAC_PI_2;
        let col = ((az / self.bin_rad) as usize).min(self.columns - 1);
        let row = ((el / self.bin_rad) as usize).min(self.rows - 1);
        Some((row * self.columns + col, r))
    }

    /// Whether this scan's beams went clearly past the world point `w`: the nearest return
    /// in its direction is beyond it by more than `margin_m + margin_frac · range`. `false`
    /// where the scan has no return in that direction.
    pub fn sees_through(&self, w: [f64; 3], margin_m: f64, margin_frac: f64) -> bool {
        let q = scene::pose::apply(&self.velo_from_world, w);
        let Some((k, r)) = self.bin(q) else {
            return false;
        };
        let n = f64::from(self.nearest_m[k]);
        n.is_finite() && n > r + margin_m + margin_frac * r
    }
}

/// Which points of the key scan (velodyne frame, taken at `world_from_velo`) are dynamic:
/// `true` where at least `cfg.min_votes` of the `neighbours` see through them.
pub fn dynamic_mask(
    points: &[[f32; 4]],
    world_from_velo: &Rigid3,
    neighbours: &[&RangeImage],
    cfg: &DynamicConfig,
) -> Vec<bool> {
    points
        .iter()
        .map(|p| {
            let q = [p[0], p[1], p[2]].map(f64::from);
            let r = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
            if !(r.is_finite() && r >= cfg.min_range_m) {
                return false;
            }
            let w = scene::pose::apply(world_from_velo, q);
            let votes = neighbours
                .iter()
                .filter(|n| n.sees_through(w, cfg.margin_m, cfg.margin_frac))
                .count();
            votes >= cfg.min_votes as usize
        })
        .collect()
}

/// What the filter did over a build.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct DynamicReport {
    /// `free-space carving (window W, votes V)` or `off`.
    pub filter: String,
    /// Key scans filtered.
    pub key_scans: u64,
    /// Neighbouring scans used, summed over the key scans (fewer than `2 × window` each
    /// where the sequence has no more scans within 50 poses).
    pub neighbour_scans: u64,
    /// Key-scan points looked at.
    pub points: u64,
    /// Of those, removed as dynamic.
    pub removed: u64,
    /// Against the scans' SemanticKITTI labels where they exist (moving classes 252–259):
    /// moving points, and how many were removed.
    pub moving_points: u64,
    /// Moving points removed.
    pub moving_removed: u64,
    /// Static (labelled, not moving) points.
    pub static_points: u64,
    /// Static points removed.
    pub static_removed: u64,
}

impl DynamicReport {
    /// Share of the moving points removed (0 without labels).
    pub fn moving_share(&self) -> f64 {
        if self.moving_points == 0 {
            0.0
        } else {
            self.moving_removed as f64 / self.moving_points as f64
        }
    }

    /// Share of the static points removed (0 without labels).
    pub fn static_share(&self) -> f64 {
        if self.static_points == 0 {
            0.0
        } else {
            self.static_removed as f64 / self.static_points as f64
        }
    }
}

/// Whether a raw SemanticKITTI label is a moving class (252 moving-car … 259
/// moving-other-vehicle).
pub fn is_moving_label(semantic: u16) -> bool {
    (252..=259).contains(&semantic)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ring of wall 20 m away around the sensor, sampled every 0.2° in azimuth at three
    /// elevations, plus (optionally) a box-shaped object 8 m ahead.
    fn scan(with_object: bool) -> Vec<[f32; 4]> {
        let mut out = Vec::new();
        for k in 0..1800 {
            let az = f64::from(k) * 0.2f64.to_radians();
            for el in [-0.02f64, 0.0, 0.02] {
                let ahead = az.cos() > 0.995 && with_object;
                let r = if ahead { 8.0 } else { 20.0 };
                out.push([
                    (r * el.cos() * az.cos()) as f32,
                    (r * el.cos() * az.sin()) as f32,
                    (r * el.sin()) as f32,
                    0.5,
                ]);
            }
        }
        out
    }

    #[test]
    fn a_thing_gone_in_the_next_scan_is_dynamic_and_the_walls_stay() {
        let id = Rigid3::identity();
        let now = scan(true);
        let later = RangeImage::new(&scan(false), &id, 0.5, 1);
        let cfg = DynamicConfig::default();
        let mask = dynamic_mask(&now, &id, &[&later], &cfg);
        let (mut moving, mut walls) = (0, 0);
        for (p, m) in now.iter().zip(&mask) {
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            if r < 10.0 {
                assert!(*m, "the object's point {p:?} is seen through");
                moving += 1;
            } else {
                assert!(!*m, "a wall point {p:?} was removed");
                walls += 1;
            }
        }
        assert!(moving > 0 && walls > 0);
        // the object still there: nothing goes
        let same = RangeImage::new(&scan(true), &id, 0.5, 1);
        assert!(dynamic_mask(&now, &id, &[&same], &cfg).iter().all(|m| !m));
        // two votes asked, one given: nothing goes
        let two = DynamicConfig {
            min_votes: 2,
            ..cfg.clone()
        };
        assert!(dynamic_mask(&now, &id, &[&later], &two).iter().all(|m| !m));
        assert!(DynamicConfig { window: 0, ..cfg }.validate().is_err());
    }
}
