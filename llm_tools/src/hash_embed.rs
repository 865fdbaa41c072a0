//! A deterministic bag-of-words embedder: no model, no randomness. Tests and tools that need
//! an [`Embedder`] without the MiniLM files use it; it only captures shared words, not meaning.

use crate::embed::Embedder;
use crate::error::Result;

/// Hashes lower-cased words (and word bigrams, at half weight) into `dim` signed buckets, then
/// L2-normalises. Texts with no words map to the zero vector.
#[derive(Debug, Clone)]
pub struct HashEmbedder {
    dim: usize,
}

impl HashEmbedder {
    /// An embedder with `dim` outputs (at least 1).
    pub fn new(dim: usize) -> HashEmbedder {
        HashEmbedder { dim: dim.max(1) }
    }

    fn bucket(&self, token: &str) -> (usize, f32) {
        // FNV-1a, 64 bit
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in token.bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        let sign = if h >> 63 == 0 { 1.0 } else { -1.0 };
        ((h % self.dim as u64) as usize, sign)
    }

    fn one(&self, text: &str) -> Vec<f32> {
        let words: Vec<String> = text
            .split(|c: char| !c.is_alphanumeric())
            .filter(|w| !w.is_empty())
            .map(str::to_lowercase)
            .collect();
        let mut v = vec![0f32; self.dim];
        for w in &words {
            let (i, s) = self.bucket(w);
            v[i] += s;
        }
        for pair in words.windows(2) {
            let (i, s) = self.bucket(&format!("{} {}", pair[0], pair[1]));
            v[i] += 0.5 * s;
        }
        let n = v.iter().map(|x| x * x).sum::<f32>().sqrt();
        if n > 0.0 {
            v.iter_mut().for_each(|x| *x /= n);
        }
        v
    }
}

impl Embedder for HashEmbedder {
    fn name(&self) -> String {
        "hash".into()
    }

    fn dim(&self) -> usize {
        self.dim
    }

    fn embed(&mut self, texts: &[&str]) -> Result<Vec<Vec<f32>>> {
        Ok(texts.iter().map(|t| self.one(t)).collect())
    }
}
