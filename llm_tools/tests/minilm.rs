//! The MiniLM embedder against references computed with the Python tokenizers and
//! onnxruntime packages on the same model files. Skips when `scripts/setup.sh` has not run.

use llm_tools::{Embedder, MiniLm};

fn model() -> Option<MiniLm> {
    let dir = llm_tools::embed::default_models_dir();
    match MiniLm::from_dir(&dir) {
        Ok(m) => Some(m),
        Err(e) => {
            eprintln!("skipping: {e}");
            None
        }
    }
}

#[test]
fn tokenizer_matches_hugging_face() {
    let Some(m) = model() else { return };
    assert_eq!(
        m.tokenize("a car parked on the road"),
        vec![101, 1037, 2482, 9083, 2006, 1996, 2346, 102]
    );
    assert_eq!(
        m.tokenize("Héllo, wörld!! It's a CAR-park (x2)."),
        vec![
            101, 7592, 1010, 2088, 999, 999, 2009, 1005, 1055, 1037, 2482, 1011, 2380, 1006, 1060,
            2475, 1007, 1012, 102
        ]
    );
}

#[test]
fn embedding_matches_references() {
    let Some(mut m) = model() else { return };
    let v = &m.embed(&["a car parked on the road"]).unwrap()[0];
    assert_eq!(v.len(), 384);
    let norm: f32 = v.iter().map(|x| x * x).sum::<f32>().sqrt();
    assert!((norm - 1.0).abs() < 1e-5);
    // onnxruntime 1.32 (Python) on the same int8 model and token ids
    let ort_py = [
        -0.042_405_05f32,
        0.061_106_35,
        -0.026_496_11,
        0.041_095_04,
        -0.014_114_37,
    ];
    for (a, b) in v.iter().zip(ort_py) {
        assert!((a - b).abs() < 1e-4, "{:?}", &v[..5]);
    }
    // the full fp32 embedding (scripts/minilm_fp32_reference.py: numpy forward pass over the
    // fp32 weights); it starts with the reference values
    let fp32: Vec<f32> = serde_json::from_str(include_str!(
        "data/minilm_fp32_a_car_parked_on_the_road.json"
    ))
    .unwrap();
    assert_eq!(fp32.len(), 384);
    for (a, b) in fp32
        .iter()
        .zip([-0.03904f32, 0.06032, -0.02803, 0.04636, -0.01353])
    {
        assert!((a - b).abs() < 1e-5);
    }
    let cos: f32 = v.iter().zip(&fp32).map(|(a, b)| a * b).sum();
    assert!(cos >= 0.999, "cosine to the fp32 reference is {cos}");
}

#[test]
fn batches_equal_single_texts() {
    let Some(mut m) = model() else { return };
    let texts = [
        "a wooden bench",
        "a red stop sign on a grey pole next to the crossing",
        "tree",
    ];
    let batch = m.embed(&texts).unwrap();
    for (t, b) in texts.iter().zip(&batch) {
        let one = &m.embed(&[t]).unwrap()[0];
        let cos: f32 = one.iter().zip(b).map(|(x, y)| x * y).sum();
        assert!(cos > 0.99999, "{t}: {cos}");
    }
    // similar sentences are closer than unrelated ones
    let v = m
        .embed(&[
            "a bench to sit on",
            "a wooden bench in the park",
            "a truck on the highway",
        ])
        .unwrap();
    let dot = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f32>();
    assert!(dot(&v[0], &v[1]) > dot(&v[0], &v[2]) + 0.2);
    assert!(m.embed(&[]).unwrap().is_empty());
}

#[test]
fn missing_files_say_how_to_get_them() {
    let dir = tempfile::tempdir().unwrap();
    let e = MiniLm::new(
        &dir.path().join("m.onnx"),
        &dir.path().join("t.json"),
        &dir.path().join("libonnxruntime.so"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("scripts/setup.sh") && e.contains("onnxruntime==1.32.0"),
        "{e}"
    );
}
