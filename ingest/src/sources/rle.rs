//! COCO run-length encoded masks, bit-compatible with pycocotools: runs over the mask in
//! column-major order, starting with a run of zeros; serialised either as a list of run
//! lengths or as pycocotools' compressed string.

use crate::error::{Error, Result};

/// A binary mask as COCO RLE.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rle {
    /// Image height.
    pub height: u32,
    /// Image width.
    pub width: u32,
    /// Alternating run lengths, zeros first, column-major.
    pub counts: Vec<u32>,
}

impl Rle {
    /// Encodes a row-major mask of `height * width` values.
    pub fn from_mask(height: u32, width: u32, mask: &[bool]) -> Result<Rle> {
        let (h, w) = (height as usize, width as usize);
        if mask.len() != h * w {
            return Err(Error::Invalid(format!(
                "mask has {} values, {height}x{width} needs {}",
                mask.len(),
                h * w
            )));
        }
        let mut counts = Vec::new();
        let mut current = false;
        let mut run = 0u32;
        for x in 0..w {
            for y in 0..h {
                let v = mask[y * w + x];
                if v != current {
                    counts.push(run);
                    run = 0;
                    current = v;
                }
                run += 1;
            }
        }
        counts.push(run);
        Ok(Rle {
            height,
            width,
            counts,
        })
    }

    /// Checks that the runs cover the image exactly.
    pub fn validate(&self) -> Result<()> {
        let total: u64 = self.counts.iter().map(|c| u64::from(*c)).sum();
        let want = u64::from(self.height) * u64::from(self.width);
        if total != want {
            return Err(Error::Invalid(format!(
                "RLE runs cover {total} pixels, a {}x{} mask has {want}",
                self.height, self.width
            )));
        }
        Ok(())
    }

    /// The row-major mask.
    pub fn to_mask(&self) -> Result<Vec<bool>> {
        self.validate()?;
        let (h, w) = (self.height as usize, self.width as usize);
        let mut mask = vec![false; h * w];
        let mut i = 0usize;
        for (k, run) in self.counts.iter().enumerate() {
            if k % 2 == 1 {
                for j in i..i + *run as usize {
                    let (x, y) = (j / h, j % h);
                    mask[y * w + x] = true;
                }
            }
            i += *run as usize;
        }
        Ok(mask)
    }

    /// Number of pixels set.
    pub fn area(&self) -> u64 {
        self.counts
            .iter()
            .skip(1)
            .step_by(2)
            .map(|c| u64::from(*c))
            .sum()
    }

    /// pycocotools' compressed string.
    pub fn to_coco_string(&self) -> String {
        let mut s = String::new();
        for (i, &c) in self.counts.iter().enumerate() {
            let mut x = i64::from(c);
            if i > 2 {
                x -= i64::from(self.counts[i - 2]);
            }
            loop {
                let mut ch = (x & 0x1f) as u8;
                x >>= 5;
                let more = if ch & 0x10 != 0 { x != -1 } else { x != 0 };
                if more {
                    ch |= 0x20;
                }
                s.push(char::from(ch + 48));
                if !more {
                    break;
                }
            }
        }
        s
    }

    /// Parses pycocotools' compressed string; `height` and `width` come from `size`.
    pub fn from_coco_string(height: u32, width: u32, s: &str) -> Result<Rle> {
        let bytes = s.as_bytes();
        let mut counts: Vec<u32> = Vec::new();
        let mut p = 0usize;
        while p < bytes.len() {
            let mut x: i64 = 0;
            let mut k = 0u32;
            loop {
                let b = *bytes.get(p).ok_or_else(|| {
                    Error::Invalid(format!("RLE string ends inside a run at character {p}"))
                })?;
                if !(48..48 + 64).contains(&b) {
                    return Err(Error::Invalid(format!(
                        "RLE string has an invalid character {:?} at {p}",
                        char::from(b)
                    )));
                }
                let c = i64::from(b - 48);
                if k >= 12 {
                    return Err(Error::Invalid(format!("RLE run too long at character {p}")));
                }
                x |= (c & 0x1f) << (5 * k);
                p += 1;
                k += 1;
                if c & 0x20 == 0 {
                    if c & 0x10 != 0 {
                        x |= -1i64 << (5 * k);
                    }
                    break;
                }
            }
            let m = counts.len();
            if m > 2 {
                x += i64::from(counts[m - 2]);
            }
            let run = u32::try_from(x).map_err(|_| {
                Error::Invalid(format!("RLE run {m} is negative or too large ({x})"))
            })?;
            counts.push(run);
        }
        let rle = Rle {
            height,
            width,
            counts,
        };
        rle.validate()?;
        Ok(rle)
    }

    /// The tight box `[x, y, w, h]` around the set pixels (COCO convention), None if empty.
    pub fn bbox(&self) -> Option<[f64; 4]> {
        let h = u64::from(self.height);
        let (mut x0, mut y0, mut x1, mut y1) = (u64::MAX, u64::MAX, 0u64, 0u64);
        let mut i = 0u64;
        for (k, run) in self.counts.iter().enumerate() {
            let run = u64::from(*run);
            if k % 2 == 1 && run > 0 {
                let (a, b) = (i, i + run - 1);
                let (xa, xb) = (a / h, b / h);
                x0 = x0.min(xa);
                x1 = x1.max(xb);
                if xa == xb {
                    y0 = y0.min(a % h);
                    y1 = y1.max(b % h);
                } else {
                    y0 = 0;
                    y1 = h - 1;
                }
            }
            i += run;
        }
        (x0 != u64::MAX).then(|| {
            [
                x0 as f64,
                y0 as f64,
                (x1 - x0 + 1) as f64,
                (y1 - y0 + 1) as f64,
            ]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The 5x7 mask pycocotools encodes as "4162L0004NN" (checked with pycocotools 2.0).
    fn reference_mask() -> Vec<bool> {
        let (h, w) = (5usize, 7usize);
        let mut m = vec![false; h * w];
        for y in 1..4 {
            for x in 2..5 {
                m[y * w + x] = true;
            }
        }
        m[6] = true; // (y 0, x 6)
        m[4 * w] = true; // (y 4, x 0)
        m
    }

    #[test]
    fn matches_pycocotools() {
        let rle = Rle::from_mask(5, 7, &reference_mask()).unwrap();
        assert_eq!(rle.to_coco_string(), "4162L0004NN");
        assert_eq!(Rle::from_coco_string(5, 7, "4162L0004NN").unwrap(), rle);
        assert_eq!(rle.area(), 11);
        // a large mask: pycocotools reports area 41000 and bbox [300, 100, 700, 100]
        let (h, w) = (375usize, 1242usize);
        let mut m = vec![false; h * w];
        for y in 100..200 {
            for x in 300..700 {
                m[y * w + x] = true;
            }
        }
        for y in 150..160 {
            for x in 900..1000 {
                m[y * w + x] = true;
            }
        }
        let rle = Rle::from_mask(375, 1242, &m).unwrap();
        let s = rle.to_coco_string();
        assert!(s.starts_with("hn]3T3c8") && s.ends_with("X_h2"), "{s}");
        assert_eq!(rle.area(), 41000);
        let b = rle.bbox().unwrap();
        assert!(
            b.iter()
                .zip([300.0, 100.0, 700.0, 100.0])
                .all(|(x, y)| (x - y).abs() < 1e-12),
            "{b:?}"
        );
    }

    #[test]
    fn invalid_rle_is_an_error() {
        assert!(
            Rle::from_coco_string(5, 7, "4162L0004N").is_err(),
            "runs do not cover the image"
        );
        assert!(
            Rle::from_coco_string(5, 7, "41 2").is_err(),
            "bad character"
        );
        assert!(
            Rle {
                height: 2,
                width: 2,
                counts: vec![1, 1]
            }
            .to_mask()
            .is_err()
        );
        assert!(Rle::from_mask(2, 2, &[true]).is_err());
    }

    proptest! {
        #[test]
        fn roundtrips(h in 1u32..20, w in 1u32..20, seed in any::<u64>()) {
            let n = (h * w) as usize;
            let mask: Vec<bool> = (0..n).map(|i| (seed.rotate_left((i % 64) as u32) ^ (i as u64 * 0x9e37)).is_multiple_of(3)).collect();
            let rle = Rle::from_mask(h, w, &mask).unwrap();
            prop_assert_eq!(rle.to_mask().unwrap(), mask.clone());
            let back = Rle::from_coco_string(h, w, &rle.to_coco_string()).unwrap();
            prop_assert_eq!(back, rle.clone());
            prop_assert_eq!(rle.area() as usize, mask.iter().filter(|b| **b).count());
        }

        #[test]
        fn garbage_strings_never_panic(s in "[0-9A-Za-z\\\\\\[\\]^_`]{0,30}") {
            let _ = Rle::from_coco_string(4, 4, &s);
        }
    }
}
