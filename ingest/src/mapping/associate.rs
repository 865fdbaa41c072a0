//! Association of detections with map objects (the paper's φ):
//! `φ = w_geo·IoU3D + w_cap·TF-IDF-cosine(captions) + w_fea·cosine(features)`, then a greedy
//! one-to-one assignment by descending φ, keeping pairs with `φ > δ_sim`.

use std::collections::HashMap;

/// Words of a caption: lower-cased alphanumeric runs.
pub fn words(text: &str) -> impl Iterator<Item = String> + '_ {
    text.split(|c: char| !c.is_alphanumeric())
        .filter(|w| !w.is_empty())
        .map(str::to_lowercase)
}

/// Document frequencies over every caption in the map (each caption is one document), for
/// scikit-learn-style smoothed IDF: `idf(t) = ln((1 + N) / (1 + df(t))) + 1`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TfIdf {
    df: HashMap<String, u32>,
    docs: u32,
}

impl TfIdf {
    /// Adds one caption to the corpus.
    pub fn add(&mut self, caption: &str) {
        self.docs += 1;
        let mut seen: Vec<String> = words(caption).collect();
        seen.sort_unstable();
        seen.dedup();
        for w in seen {
            *self.df.entry(w).or_insert(0) += 1;
        }
    }

    fn idf(&self, w: &str) -> f64 {
        let df = self.df.get(w).copied().unwrap_or(0);
        ((1.0 + f64::from(self.docs)) / (1.0 + f64::from(df))).ln() + 1.0
    }

    /// The L2-normalised TF-IDF vector of a text, as sorted (word, weight) pairs.
    pub fn vector(&self, text: &str) -> Vec<(String, f64)> {
        let mut tf: Vec<(String, f64)> = Vec::new();
        let mut all: Vec<String> = words(text).collect();
        all.sort_unstable();
        for w in all {
            match tf.last_mut() {
                Some((last, n)) if *last == w => *n += 1.0,
                _ => tf.push((w, 1.0)),
            }
        }
        for (w, x) in &mut tf {
            *x *= self.idf(w);
        }
        let n = tf.iter().map(|(_, x)| x * x).sum::<f64>().sqrt();
        if n > 0.0 {
            tf.iter_mut().for_each(|(_, x)| *x /= n);
        }
        tf
    }

    /// Cosine between the TF-IDF vectors of two texts.
    pub fn cosine(&self, a: &str, b: &str) -> f64 {
        sparse_dot(&self.vector(a), &self.vector(b))
    }
}

/// Dot product of two sorted sparse vectors.
pub fn sparse_dot(a: &[(String, f64)], b: &[(String, f64)]) -> f64 {
    let (mut i, mut j, mut s) = (0, 0, 0.0);
    while i < a.len() && j < b.len() {
        match a[i].0.cmp(&b[j].0) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                s += a[i].1 * b[j].1;
                i += 1;
                j += 1;
            }
        }
    }
    s
}

pub use llm_tools::embed::cosine;

/// The weights of φ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weights {
    /// Weight of the 3D IoU.
    pub geo: f64,
    /// Weight of the caption TF-IDF cosine.
    pub cap: f64,
    /// Weight of the feature cosine.
    pub fea: f64,
}

/// φ for one pair.
pub fn phi(w: Weights, iou: f64, caption_cos: f64, feature_cos: f64) -> f64 {
    w.geo * iou + w.cap * caption_cos + w.fea * feature_cos
}

/// Greedy one-to-one assignment: repeatedly takes the highest φ among unassigned detections
/// and objects, as long as it is above `threshold`. `pairs` holds `(detection, object, φ)`;
/// ties go to the lower detection, then the lower object index. Returns the object for each
/// of `n_detections` detections.
pub fn greedy_assign(
    n_detections: usize,
    mut pairs: Vec<(usize, usize, f64)>,
    threshold: f64,
) -> Vec<Option<usize>> {
    pairs.retain(|p| p.2 > threshold);
    pairs.sort_by(|a, b| b.2.total_cmp(&a.2).then(a.0.cmp(&b.0)).then(a.1.cmp(&b.1)));
    let mut out = vec![None; n_detections];
    let mut used = std::collections::HashSet::new();
    for (d, o, _) in pairs {
        if out[d].is_none() && !used.contains(&o) {
            out[d] = Some(o);
            used.insert(o);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tfidf_matches_scikit_learn_smoothing() {
        // sklearn TfidfVectorizer(smooth_idf=True, norm='l2') on these three documents gives
        // idf(car) = ln(4/3) + 1 and idf(blue) = ln(4/2) + 1.
        let mut t = TfIdf::default();
        for d in ["a red car", "a blue car", "a red bench"] {
            t.add(d);
        }
        assert!((t.idf("car") - ((4.0f64 / 3.0).ln() + 1.0)).abs() < 1e-12);
        assert!((t.idf("blue") - (2.0f64.ln() + 1.0)).abs() < 1e-12);
        assert!((t.idf("unseen") - (4.0f64.ln() + 1.0)).abs() < 1e-12);
        assert!((t.cosine("a red car", "a red car") - 1.0).abs() < 1e-12);
        assert!(t.cosine("a red car", "A RED CAR!") > 0.999);
        assert!(t.cosine("a red car", "blue bench").abs() < 1e-12);
        let near = t.cosine("a red car", "a blue car");
        let far = t.cosine("a red car", "a red bench");
        assert!(near > 0.0 && far > 0.0);
    }

    #[test]
    fn greedy_is_one_to_one_and_respects_the_threshold() {
        let pairs = vec![
            (0, 0, 0.9),
            (1, 0, 1.2),
            (1, 1, 0.8),
            (0, 1, 0.7),
            (2, 2, 0.6),
        ];
        assert_eq!(greedy_assign(3, pairs, 0.6), vec![Some(1), Some(0), None]);
        assert_eq!(greedy_assign(2, vec![], 0.6), vec![None, None]);
    }

    #[test]
    fn phi_uses_the_weights() {
        let w = Weights {
            geo: 1.0,
            cap: 0.2,
            fea: 0.4,
        };
        assert!((phi(w, 0.5, 1.0, 0.5) - 0.9).abs() < 1e-12);
        assert!((cosine(&[1.0, 0.0], &[1.0, 1.0]) - 0.5f64.sqrt()).abs() < 1e-9);
        assert!(cosine(&[0.0, 0.0], &[1.0, 1.0]).abs() < 1e-12);
    }
}
