//! Point clouds as compact, compressed payloads.
//!
//! Layout (little endian): magic `OGPC`, version u8, flags u8 (bit 0: has rgb), count u32,
//! origin 3×f64, resolution f64, then an LZ4 block of the byte-shuffled quantised
//! coordinates (3×u32 per point, `round((p - origin) / resolution)`) followed by rgb bytes.
//! Byte shuffling groups the slowly varying high bytes together so LZ4 finds them.

use crate::error::{Error, Result, corrupt};

const MAGIC: &[u8; 4] = b"OGPC";
const VERSION: u8 = 1;
const HEADER: usize = 4 + 1 + 1 + 4 + 24 + 8;
/// Default quantisation step: 1 mm, far below LiDAR noise.
pub const DEFAULT_RESOLUTION_M: f64 = 0.001;

/// Points in metres with optional colours.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointCloud {
    /// xyz in metres (world frame for instances).
    pub xyz: Vec<[f32; 3]>,
    /// Either empty or one colour per point.
    pub rgb: Vec<[u8; 3]>,
}

impl PointCloud {
    /// Encodes with the default 1 mm resolution.
    pub fn encode(&self) -> Result<Vec<u8>> {
        self.encode_with(DEFAULT_RESOLUTION_M)
    }

    /// Encodes with a given resolution in metres.
    pub fn encode_with(&self, resolution_m: f64) -> Result<Vec<u8>> {
        if !self.rgb.is_empty() && self.rgb.len() != self.xyz.len() {
            return Err(Error::InvalidValue(format!(
                "point cloud has {} points but {} colours",
                self.xyz.len(),
                self.rgb.len()
            )));
        }
        if !(resolution_m.is_finite() && resolution_m > 0.0) {
            return Err(Error::InvalidValue(format!(
                "resolution {resolution_m} m must be positive"
            )));
        }
        let n = u32::try_from(self.xyz.len())
            .map_err(|_| Error::InvalidValue("point cloud too large".into()))?;
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.xyz {
            for i in 0..3 {
                let c = f64::from(p[i]);
                if !c.is_finite() {
                    return Err(Error::InvalidValue(
                        "point cloud contains NaN or inf".into(),
                    ));
                }
                lo[i] = lo[i].min(c);
                hi[i] = hi[i].max(c);
            }
        }
        if n == 0 {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        for i in 0..3 {
            if (hi[i] - lo[i]) / resolution_m >= f64::from(u32::MAX) {
                return Err(Error::InvalidValue(format!(
                    "point cloud extent {:.1} m is too large for resolution {resolution_m} m",
                    hi[i] - lo[i]
                )));
            }
        }
        let count = self.xyz.len();
        let mut planes = vec![0u8; count * 12];
        for (j, p) in self.xyz.iter().enumerate() {
            for i in 0..3 {
                let q = ((f64::from(p[i]) - lo[i]) / resolution_m).round() as u32;
                for (b, byte) in q.to_le_bytes().iter().enumerate() {
                    // plane (axis, byte) holds that byte of every point
                    planes[(i * 4 + b) * count + j] = *byte;
                }
            }
        }
        for c in &self.rgb {
            planes.extend_from_slice(c);
        }
        let mut out = Vec::with_capacity(HEADER + planes.len() / 2);
        out.extend_from_slice(MAGIC);
        out.push(VERSION);
        out.push(u8::from(!self.rgb.is_empty()));
        out.extend_from_slice(&n.to_le_bytes());
        for c in lo {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out.extend_from_slice(&resolution_m.to_le_bytes());
        out.extend_from_slice(&lz4_flex::block::compress_prepend_size(&planes));
        Ok(out)
    }

    /// Decodes; malformed bytes give [`Error::Corrupt`].
    pub fn decode(bytes: &[u8]) -> Result<PointCloud> {
        let bad = |d: &str| corrupt("point cloud payload", d);
        if bytes.len() < HEADER || &bytes[..4] != MAGIC {
            return Err(bad("missing OGPC header"));
        }
        if bytes[4] != VERSION {
            return Err(bad(&format!("unknown version {}", bytes[4])));
        }
        let has_rgb = bytes[5] & 1 == 1;
        let n = u32::from_le_bytes([bytes[6], bytes[7], bytes[8], bytes[9]]) as usize;
        let f = |o: usize| {
            let mut a = [0u8; 8];
            a.copy_from_slice(&bytes[o..o + 8]);
            f64::from_le_bytes(a)
        };
        let lo = [f(10), f(18), f(26)];
        let res = f(34);
        let want = n * 12 + if has_rgb { n * 3 } else { 0 };
        // refuse absurd sizes before allocating
        if want > 64 * bytes.len() + 1024 {
            return Err(bad("declared size does not match the data"));
        }
        let planes = lz4_flex::block::decompress_size_prepended(&bytes[HEADER..])
            .map_err(|e| bad(&e.to_string()))?;
        if planes.len() != want {
            return Err(bad(&format!(
                "expected {want} bytes, found {}",
                planes.len()
            )));
        }
        let mut xyz = Vec::with_capacity(n);
        for j in 0..n {
            let mut p = [0f32; 3];
            for (i, c) in p.iter_mut().enumerate() {
                let mut q = [0u8; 4];
                for (b, byte) in q.iter_mut().enumerate() {
                    *byte = planes[(i * 4 + b) * n + j];
                }
                *c = (lo[i] + f64::from(u32::from_le_bytes(q)) * res) as f32;
            }
            xyz.push(p);
        }
        let rgb = if has_rgb {
            planes[n * 12..]
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect()
        } else {
            Vec::new()
        };
        Ok(PointCloud { xyz, rgb })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn roundtrip_within_half_resolution(pts in prop::collection::vec(prop::array::uniform3(-500f32..500.0), 0..200), rgb in any::<bool>()) {
            let cloud = PointCloud {
                rgb: if rgb { pts.iter().map(|p| [p[0] as u8, p[1] as u8, 7]).collect() } else { vec![] },
                xyz: pts,
            };
            let back = PointCloud::decode(&cloud.encode().unwrap()).unwrap();
            prop_assert_eq!(back.xyz.len(), cloud.xyz.len());
            prop_assert_eq!(&back.rgb, &cloud.rgb);
            for (a, b) in back.xyz.iter().zip(&cloud.xyz) {
                for i in 0..3 {
                    // 0.5 mm quantisation plus f32 rounding at |x| <= 500 m
                    prop_assert!((a[i] - b[i]).abs() <= 0.0005 + 1e-4, "{} vs {}", a[i], b[i]);
                }
            }
        }

        #[test]
        fn decode_garbage_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..120)) {
            let _ = PointCloud::decode(&bytes);
            let mut b = b"OGPC\x01\x00".to_vec();
            b.extend(bytes);
            let _ = PointCloud::decode(&b);
        }
    }

    #[test]
    fn compresses_a_dense_cloud() {
        let xyz: Vec<[f32; 3]> = (0..20_000)
            .map(|i| {
                let t = i as f32 * 0.01;
                [10.0 + t.sin(), 5.0 + 0.001 * i as f32, 1.5 + t.cos() * 0.2]
            })
            .collect();
        let cloud = PointCloud { xyz, rgb: vec![] };
        let bytes = cloud.encode().unwrap();
        assert!(bytes.len() < 20_000 * 12, "{} bytes", bytes.len());
        assert!(
            PointCloud {
                xyz: vec![[f32::NAN, 0.0, 0.0]],
                rgb: vec![]
            }
            .encode()
            .is_err()
        );
    }
}
