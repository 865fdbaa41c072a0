//! How well the class assignment by caption embedding recovers the oracle's true class, with
//! the real MiniLM (skips when the model files are not installed).

use ingest::sources::oracle::caption;
use llm_tools::{Embedder, MiniLm};
use scene::classes::{CLASSES, prompts};

fn cos(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[test]
fn oracle_captions_map_back_to_their_class() {
    let mut m = match MiniLm::from_dir(&llm_tools::embed::default_models_dir()) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("skipping: {e}");
            return;
        }
    };
    let list = prompts();
    let texts: Vec<&str> = list.iter().map(|p| p.1).collect();
    let pe = m.embed(&texts).unwrap();
    let mut correct = 0;
    let mut total = 0;
    let mut worst: Vec<(f64, &str)> = Vec::new();
    for class in 1..=19u8 {
        let caps: Vec<String> = (0..20).map(|i| caption(class, i, i as u32)).collect();
        let refs: Vec<&str> = caps
            .iter()
            .map(|c| llm_tools::vocab::subject_phrase(c))
            .collect();
        let embs = m.embed(&refs).unwrap();
        let mut ok = 0;
        for (c, e) in caps.iter().zip(&embs) {
            let best = (0..list.len())
                .max_by(|a, b| cos(e, &pe[*a]).total_cmp(&cos(e, &pe[*b])))
                .map(|i| list[i].0 as usize - 1)
                .unwrap();
            if best + 1 == class as usize {
                ok += 1;
            } else {
                eprintln!(
                    "{}: {c:?} -> {}",
                    CLASSES[class as usize - 1],
                    CLASSES[best]
                );
            }
        }
        worst.push((ok as f64 / 20.0, CLASSES[class as usize - 1]));
        correct += ok;
        total += 20;
    }
    let acc = correct as f64 / total as f64;
    worst.sort_by(|a, b| a.0.total_cmp(&b.0));
    eprintln!(
        "caption -> class accuracy {acc:.3}; worst classes {:?}",
        &worst[..5]
    );
    assert!(acc >= 0.9, "accuracy {acc}");
}
