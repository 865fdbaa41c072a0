//! Exact top-k cosine over contiguous, L2-normalised f32 rows, with an optional int8 copy
//! that is scanned first. The int8 pass keeps results exact: each row stores the L2 norm of
//! its quantisation error, which bounds |cos_f32 - cos_int8|, and every row whose upper bound
//! can still reach the k-th best lower bound is re-scored in f32.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::sync::Arc;

use super::{LayerData, Pending, Stack, Visibility};
use crate::simd::{dot_f32, dot_i8_rows};

/// Layers below this size are scanned in f32 only.
const QUANTIZE_MIN_ROWS: usize = 512;
/// Rows of int8 codes scored per kernel call in the quantised pass.
const SCAN_BLOCK_ROWS: usize = 2048;
/// Slack for f32 rounding in the bound.
const BOUND_EPS: f32 = 1e-4;

/// Dimension and whether to keep an int8 copy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct VectorParams {
    pub(crate) dim: usize,
    pub(crate) int8: bool,
}

/// A normalised vector.
pub(crate) type Unit = Arc<[f32]>;

#[derive(Debug)]
struct Quant {
    codes: Vec<i8>,
    scale: Vec<f32>,
    err: Vec<f32>,
}

#[derive(Debug)]
pub(crate) struct VectorLayer {
    dim: usize,
    ids: Vec<u64>,
    data: Vec<f32>,
    quant: Option<Quant>,
}

/// Normalises `v`; None for zero or non-finite vectors.
pub(crate) fn normalize(v: &[f32]) -> Option<Unit> {
    let n = dot_f32(v, v).sqrt();
    if !n.is_finite() || n <= f32::MIN_POSITIVE {
        return None;
    }
    Some(v.iter().map(|x| x / n).collect())
}

/// Symmetric per-vector int8 quantisation: codes, scale, and the L2 norm of the error.
fn quantize(v: &[f32], codes: &mut Vec<i8>) -> (f32, f32) {
    let max = v.iter().fold(0f32, |m, x| m.max(x.abs()));
    let scale = if max > 0.0 { max / 127.0 } else { 1.0 };
    let mut err2 = 0f32;
    for x in v {
        let q = (x / scale).round().clamp(-127.0, 127.0);
        let e = x - q * scale;
        err2 += e * e;
        codes.push(q as i8);
    }
    (scale, err2.sqrt())
}

impl LayerData for VectorLayer {
    type Entry = Unit;
    type Params = VectorParams;

    fn build(params: &VectorParams, entries: Vec<(u64, Unit)>) -> Self {
        let dim = params.dim;
        let mut ids = Vec::with_capacity(entries.len());
        let mut data = Vec::with_capacity(entries.len() * dim);
        for (n, v) in &entries {
            ids.push(*n);
            data.extend_from_slice(v);
        }
        let quant = (params.int8 && ids.len() >= QUANTIZE_MIN_ROWS).then(|| {
            let mut q = Quant {
                codes: Vec::with_capacity(data.len()),
                scale: Vec::with_capacity(ids.len()),
                err: Vec::with_capacity(ids.len()),
            };
            for row in data.chunks_exact(dim) {
                let (s, e) = quantize(row, &mut q.codes);
                q.scale.push(s);
                q.err.push(e);
            }
            q
        });
        VectorLayer {
            dim,
            ids,
            data,
            quant,
        }
    }

    fn entries(&self) -> Vec<(u64, Unit)> {
        self.ids
            .iter()
            .zip(self.data.chunks_exact(self.dim))
            .map(|(n, row)| (*n, Arc::from(row)))
            .collect()
    }

    fn len(&self) -> usize {
        self.ids.len()
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Scored(f32, u64);
impl Eq for Scored {}
impl PartialOrd for Scored {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Scored {
    /// Reverse order so `BinaryHeap` is a min-heap on score (ties: larger id is "smaller").
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(self.1.cmp(&o.1))
    }
}

/// Keeps the best `k` (score, node), highest score first and lowest id on ties.
struct TopK {
    k: usize,
    heap: BinaryHeap<Scored>,
}

impl TopK {
    fn new(k: usize) -> Self {
        TopK {
            k,
            // the heap grows to at most the entries seen; `k` is the caller's and may be huge
            heap: BinaryHeap::with_capacity(k.min(1024) + 1),
        }
    }
    /// Whether (score, node) would enter.
    #[inline]
    fn admits(&self, s: f32, n: u64) -> bool {
        self.heap.len() < self.k || self.heap.peek().is_some_and(|w| Scored(s, n) < *w)
    }
    #[inline]
    fn push(&mut self, s: f32, n: u64) {
        if self.k == 0 {
            return;
        }
        self.heap.push(Scored(s, n));
        if self.heap.len() > self.k {
            self.heap.pop();
        }
    }
    fn into_sorted(self) -> Vec<(u64, f32)> {
        let mut v: Vec<Scored> = self.heap.into_vec();
        v.sort();
        v.into_iter().map(|Scored(s, n)| (n, s)).collect()
    }
    fn min_score(&self) -> Option<f32> {
        (self.heap.len() == self.k)
            .then(|| self.heap.peek().map(|s| s.0))
            .flatten()
    }
}

fn scan_exact(layer: &VectorLayer, vis: &Visibility<'_>, q: &[f32], top: &mut TopK) {
    let all = vis.all_visible();
    for (i, row) in layer.data.chunks_exact(layer.dim).enumerate() {
        let s = dot_f32(q, row);
        let n = layer.ids[i];
        if top.admits(s, n) && (all || vis.visible(n)) {
            top.push(s, n);
        }
    }
}

/// Exact top-k cosine similarity. `query` need not be normalised; a zero query gives nothing.
pub(crate) fn top_k(
    stack: &Stack<VectorLayer>,
    pending: Option<&Pending<Unit>>,
    query: &[f32],
    k: usize,
) -> Vec<(u64, f32)> {
    let Some(q) = normalize(query) else {
        return Vec::new();
    };
    let mut top = TopK::new(k);
    if let Some(p) = pending {
        for (n, v) in &p.entries {
            top.push(dot_f32(&q, v), *n);
        }
    }
    let view = stack.view(pending);
    // quantised layers: collect (layer, row) candidates with bounds first
    let mut qcodes = Vec::with_capacity(q.len());
    let (qscale, qerr) = quantize(&q, &mut qcodes);
    let mut lower_k = TopK::new(k);
    let mut cands: Vec<(usize, usize, f32)> = Vec::new();
    let mut threshold = f32::NEG_INFINITY;
    let mut approx = Vec::with_capacity(SCAN_BLOCK_ROWS);
    for (li, (layer, vis)) in view.iter().enumerate() {
        let Some(quant) = &layer.quant else {
            scan_exact(layer, vis, &q, &mut top);
            continue;
        };
        let all = vis.all_visible();
        // in blocks, so the scores stay in cache and no large buffer is allocated per query
        for (block, codes) in quant.codes.chunks(SCAN_BLOCK_ROWS * layer.dim).enumerate() {
            dot_i8_rows(&qcodes, codes, &mut approx);
            let first = block * SCAN_BLOCK_ROWS;
            let scales = &quant.scale[first..first + approx.len()];
            let errs = &quant.err[first..first + approx.len()];
            for (j, ((a, scale), err)) in approx.iter().zip(scales).zip(errs).enumerate() {
                let est = qscale * scale * (*a as f32);
                let bound = qerr + err + qerr * err + BOUND_EPS;
                let upper = est + bound;
                // the k-th best lower bound so far (minus infinity until k rows are in)
                if upper < threshold {
                    continue;
                }
                let i = first + j;
                let n = layer.ids[i];
                if !(all || vis.visible(n)) {
                    continue;
                }
                lower_k.push(est - bound, n);
                threshold = lower_k.min_score().unwrap_or(f32::NEG_INFINITY);
                cands.push((li, i, upper));
            }
        }
    }
    let kth_lower = lower_k.min_score();
    for (li, i, upper) in cands {
        if kth_lower.is_some_and(|t| upper < t) {
            continue;
        }
        let layer = view[li].0;
        let row = &layer.data[i * layer.dim..(i + 1) * layer.dim];
        top.push(dot_f32(&q, row), layer.ids[i]);
    }
    top.into_sorted()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn random_unit(rng: &mut impl rand::Rng, dim: usize) -> Vec<f32> {
        (0..dim).map(|_| rng.random_range(-1.0f32..1.0)).collect()
    }

    fn brute(all: &[(u64, Vec<f32>)], q: &[f32], k: usize) -> Vec<(u64, f32)> {
        let qn = normalize(q).unwrap();
        let mut v: Vec<(u64, f32)> = all
            .iter()
            .map(|(n, x)| (*n, dot_f32(&qn, &normalize(x).unwrap())))
            .collect();
        v.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        v.truncate(k);
        v
    }

    #[test]
    fn int8_path_is_exact() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let dim = 48;
        let all: Vec<(u64, Vec<f32>)> = (0..3000u64)
            .map(|n| (n, random_unit(&mut rng, dim)))
            .collect();
        let entries: Vec<(u64, Unit)> = all
            .iter()
            .map(|(n, v)| (*n, normalize(v).unwrap()))
            .collect();
        for int8 in [false, true] {
            let stack: Stack<VectorLayer> = Stack::new(VectorParams { dim, int8 }, entries.clone());
            assert_eq!(stack.layers[0].data.quant.is_some(), int8);
            for t in 0..20 {
                let q = random_unit(&mut rng, dim);
                let got = top_k(&stack, None, &q, 10);
                let want = brute(&all, &q, 10);
                let got_ids: Vec<u64> = got.iter().map(|x| x.0).collect();
                let want_ids: Vec<u64> = want.iter().map(|x| x.0).collect();
                assert_eq!(got_ids, want_ids, "int8={int8} query {t}");
                for (g, w) in got.iter().zip(&want) {
                    assert!((g.1 - w.1).abs() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn hidden_rows_are_skipped_and_zero_query_is_empty() {
        let dim = 4;
        let params = VectorParams { dim, int8: false };
        let entries = vec![
            (1, normalize(&[1.0, 0.0, 0.0, 0.0]).unwrap()),
            (2, normalize(&[0.9, 0.1, 0.0, 0.0]).unwrap()),
        ];
        let stack: Stack<VectorLayer> = Stack::new(params, entries);
        let mut p = Pending::default();
        p.set(1, None);
        let got = top_k(&stack, Some(&p), &[1.0, 0.0, 0.0, 0.0], 5);
        assert_eq!(got.iter().map(|x| x.0).collect::<Vec<_>>(), vec![2]);
        assert!(top_k(&stack, None, &[0.0; 4], 5).is_empty());
    }
}
