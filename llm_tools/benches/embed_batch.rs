//! MiniLM's cost per text by batch size: is embedding many requests' texts in one batch
//! cheaper per text than one at a time? (`cargo bench -p llm_tools --bench embed_batch`;
//! needs the model files from `./run setup`.) Prints, for batch sizes 1, 2, 4, 8, 16 and 32,
//! the median milliseconds per batch and per text over 30 batches of short street requests,
//! and how far a text's vector moves when it is embedded in a batch with others instead of
//! alone (padding and the int8 model's per-tensor activation ranges could move it; a server
//! that batched different requests together must not answer one request differently
//! depending on what else arrived with it).

use std::time::Instant;

use llm_tools::embed::{Embedder, MiniLm, default_models_dir};

const TEXTS: &[&str] = &[
    "the bench near the bus stop",
    "somewhere to sit while waiting for the bus",
    "a red car at the T-junction",
    "the post box by the crossroads",
    "a tree next to a lamp post",
    "who could I ask for directions",
    "a bin I can throw rubbish into",
    "the street sign at the crossing",
];

fn main() -> anyhow::Result<()> {
    let mut m = match MiniLm::from_dir(&default_models_dir()) {
        Ok(m) => m,
        Err(e) => {
            println!("MiniLM not available ({e}); nothing to measure");
            return Ok(());
        }
    };
    println!("{:>6} {:>12} {:>12}", "batch", "ms/batch", "ms/text");
    let mut n_req = 0usize;
    for b in [1usize, 2, 4, 8, 16, 32] {
        let mut ms = Vec::new();
        for rep in 0..31 {
            // new texts every time (a request number), as for unique requests
            let texts: Vec<String> = (0..b)
                .map(|i| {
                    n_req += 1;
                    format!("{} {n_req}", TEXTS[(rep + i) % TEXTS.len()])
                })
                .collect();
            let refs: Vec<&str> = texts.iter().map(String::as_str).collect();
            let t = Instant::now();
            let out = m.embed(&refs)?;
            anyhow::ensure!(out.len() == b);
            if rep > 0 {
                ms.push(t.elapsed().as_secs_f64() * 1e3);
            }
        }
        ms.sort_by(f64::total_cmp);
        let med = ms[ms.len() / 2];
        println!("{b:>6} {med:>12.2} {:>12.2}", med / b as f64);
    }
    // the same text alone and in a batch of the others
    let alone = m.embed(&[TEXTS[0]])?.remove(0);
    let batched = m.embed(TEXTS)?.remove(0);
    let max_diff = alone
        .iter()
        .zip(&batched)
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    let cos: f32 = alone.iter().zip(&batched).map(|(a, b)| a * b).sum();
    println!(
        "{:?} alone vs in a batch of {}: max |difference| {max_diff:.2e}, cosine {cos:.6}",
        TEXTS[0],
        TEXTS.len()
    );
    Ok(())
}
