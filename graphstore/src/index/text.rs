//! BM25 full-text layers over captions.

use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

use super::{LayerData, Pending, Stack};

/// BM25 parameters (the usual defaults).
const K1: f64 = 1.2;
const B: f64 = 0.75;

const STOPWORDS: &[&str] = &[
    "a", "an", "and", "are", "as", "at", "be", "by", "for", "from", "in", "is", "it", "its", "of",
    "on", "or", "that", "the", "this", "to", "with",
];

/// Splits text into lower-case alphanumeric terms, drops stop words and folds a plural `s`
/// ("cars" -> "car"). Shared by indexing and querying so both see the same terms.
pub fn tokenize(text: &str) -> Vec<String> {
    text.split(|c: char| !c.is_alphanumeric())
        .filter(|t| !t.is_empty())
        .map(|t| {
            let mut t = t.to_lowercase();
            if t.len() > 3 && t.ends_with('s') && !t.ends_with("ss") {
                t.pop();
            }
            t
        })
        .filter(|t| !STOPWORDS.contains(&t.as_str()))
        .collect()
}

/// A document: its term frequencies (sorted by term) and length.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Doc {
    pub(crate) terms: Arc<Vec<(String, u32)>>,
    pub(crate) len: u32,
}

impl Doc {
    pub(crate) fn from_text(text: &str) -> Doc {
        let toks = tokenize(text);
        let len = toks.len() as u32;
        let mut tf: BTreeMap<String, u32> = BTreeMap::new();
        for t in toks {
            *tf.entry(t).or_default() += 1;
        }
        Doc {
            terms: Arc::new(tf.into_iter().collect()),
            len,
        }
    }

    fn tf(&self, term: &str) -> u32 {
        self.terms
            .binary_search_by(|(t, _)| t.as_str().cmp(term))
            .map(|i| self.terms[i].1)
            .unwrap_or(0)
    }
}

#[derive(Debug)]
pub(crate) struct TextLayer {
    docs: Vec<(u64, Doc)>,
    by_node: HashMap<u64, u32>,
    postings: HashMap<String, Vec<(u32, u32)>>,
    total_len: u64,
}

impl LayerData for TextLayer {
    type Entry = Doc;
    type Params = ();

    fn build(_: &(), mut entries: Vec<(u64, Doc)>) -> Self {
        entries.sort_by_key(|(n, _)| *n);
        let mut postings: HashMap<String, Vec<(u32, u32)>> = HashMap::new();
        let mut by_node = HashMap::with_capacity(entries.len());
        let mut total_len = 0;
        for (i, (n, d)) in entries.iter().enumerate() {
            by_node.insert(*n, i as u32);
            total_len += u64::from(d.len);
            for (t, f) in d.terms.iter() {
                postings.entry(t.clone()).or_default().push((i as u32, *f));
            }
        }
        TextLayer {
            docs: entries,
            by_node,
            postings,
            total_len,
        }
    }

    fn entries(&self) -> Vec<(u64, Doc)> {
        self.docs.clone()
    }

    fn len(&self) -> usize {
        self.docs.len()
    }
}

/// BM25 search: the `k` best nodes with their scores, best first (ties by id).
pub(crate) fn search(
    stack: &Stack<TextLayer>,
    pending: Option<&Pending<Doc>>,
    query: &str,
    k: usize,
) -> Vec<(u64, f64)> {
    let mut terms = tokenize(query);
    terms.sort();
    terms.dedup();
    if terms.is_empty() || k == 0 {
        return Vec::new();
    }
    let view = stack.view(pending);
    // corpus statistics over visible documents
    let (mut n_docs, mut total_len) = (0u64, 0u64);
    for (layer, vis) in &view {
        n_docs += layer.docs.len() as u64;
        total_len += layer.total_len;
        let mut seen = std::collections::HashSet::new();
        for h in vis.hidden_sets() {
            for n in h.iter() {
                if let Some(&i) = layer.by_node.get(n)
                    && seen.insert(i)
                {
                    n_docs -= 1;
                    total_len -= u64::from(layer.docs[i as usize].1.len);
                }
            }
        }
    }
    if let Some(p) = pending {
        for d in p.entries.values() {
            n_docs += 1;
            total_len += u64::from(d.len);
        }
    }
    if n_docs == 0 {
        return Vec::new();
    }
    let avgdl = (total_len as f64 / n_docs as f64).max(1e-9);
    let mut scores: HashMap<u64, f64> = HashMap::new();
    for term in &terms {
        let mut hits: Vec<(u64, u32, u32)> = Vec::new();
        for (layer, vis) in &view {
            if let Some(post) = layer.postings.get(term) {
                for &(i, tf) in post {
                    let (n, d) = &layer.docs[i as usize];
                    if vis.visible(*n) {
                        hits.push((*n, tf, d.len));
                    }
                }
            }
        }
        if let Some(p) = pending {
            for (n, d) in &p.entries {
                let tf = d.tf(term);
                if tf > 0 {
                    hits.push((*n, tf, d.len));
                }
            }
        }
        let df = hits.len() as f64;
        let idf = (1.0 + (n_docs as f64 - df + 0.5) / (df + 0.5)).ln();
        for (n, tf, dl) in hits {
            let tf = f64::from(tf);
            let s = idf * tf * (K1 + 1.0) / (tf + K1 * (1.0 - B + B * f64::from(dl) / avgdl));
            *scores.entry(n).or_default() += s;
        }
    }
    let mut out: Vec<(u64, f64)> = scores.into_iter().collect();
    out.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    out.truncate(k);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokenizer_folds_case_plurals_and_stopwords() {
        assert_eq!(
            tokenize("The red Cars, on a bench!"),
            vec!["red", "car", "bench"]
        );
        assert_eq!(tokenize("glass"), vec!["glass"]);
    }

    #[test]
    fn bm25_ranks_matching_docs_and_respects_hiding() {
        let docs = vec![
            (1, Doc::from_text("a red car parked on the road")),
            (2, Doc::from_text("a wooden bench next to a tree")),
            (
                3,
                Doc::from_text("a bench at the bus stop, bench painted green"),
            ),
        ];
        let stack: Stack<TextLayer> = Stack::new((), docs);
        let r = search(&stack, None, "bench", 10);
        assert_eq!(r.iter().map(|x| x.0).collect::<Vec<_>>(), vec![3, 2]);
        assert!(r[0].1 > r[1].1);
        let mut p = Pending::default();
        p.set(3, None);
        p.set(4, Some(Doc::from_text("stone bench")));
        let r = search(&stack, Some(&p), "bench", 10);
        assert_eq!(r.iter().map(|x| x.0).collect::<Vec<_>>(), vec![4, 2]);
        assert!(search(&stack, None, "the of", 10).is_empty());
    }
}
