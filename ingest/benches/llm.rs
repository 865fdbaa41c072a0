//! Local language models on this machine (run with `cargo bench -p ingest --bench llm`):
//! prompt-processing and generation tokens/s, and milliseconds per caption merge and per
//! relation label, for every GGUF model that `scripts/setup.sh` fetched (SmolLM2-135M,
//! Qwen2.5-Coder-0.5B, and Qwen2.5-Coder-1.5B with OPENGRAPH_LLM_LARGE=1). `OG_BENCH_REPS`
//! (default 5) questions of each kind; threads = available cores (`OG_BENCH_THREADS`).

use std::time::Instant;

use ingest::hierarchy::relations::InstanceBox;
use ingest::llm::{merge_input, relation_input};
use llm_tools::chat::local::LocalGguf;
use llm_tools::prompts;
use llm_tools::{ChatModel, ChatRequest, Message};
use scene::GroundFrame;

const MODELS: [&str; 3] = [
    "SmolLM2-135M-Instruct.Q4_1.gguf",
    "qwen2.5-coder-0.5b-instruct-q4_k_m.gguf",
    "qwen2.5-coder-1.5b-instruct-q4_k_m.gguf",
];

fn env_usize(k: &str, d: usize) -> usize {
    std::env::var(k)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(d)
}

fn main() -> anyhow::Result<()> {
    let reps = env_usize("OG_BENCH_REPS", 5).max(1);
    let threads = env_usize(
        "OG_BENCH_THREADS",
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(2),
    ) as u32;
    let dir = llm_tools::embed::default_models_dir();
    let captions: Vec<String> = [
        "a grey small SUV, large, with dusty windows",
        "With dusty windows: a small SUV that is grey",
        "a red small SUV with dusty windows",
        "a large grey small SUV parked by the curb",
    ]
    .map(String::from)
    .to_vec();
    let merge = merge_input(&captions, 4);
    let shelter = InstanceBox::new(
        GroundFrame::KittiCam,
        [0.0, -2.6, 0.0],
        [4.0, 0.0, 1.6],
        None,
    );
    let bench = InstanceBox::new(
        GroundFrame::KittiCam,
        [1.0, -0.5, 0.3],
        [2.6, 0.0, 0.8],
        None,
    );
    let relation = relation_input(
        GroundFrame::KittiCam,
        ("a wooden bench with a metal frame", &bench),
        ("a small grey metal bus shelter at the curb", &shelter),
    );
    let long_prompt = "Describe the street scene. ".repeat(60);
    println!(
        "{:<42} {:>10} {:>10} {:>10} {:>12}",
        "model (threads)", "pp tok/s", "tg tok/s", "ms/merge", "ms/relation"
    );
    for name in MODELS {
        let path = dir.join(name);
        if !path.exists() {
            println!("{name:<42} (not fetched: {})", path.display());
            continue;
        }
        let mut m = LocalGguf::open(&path, threads)?;
        // prompt processing and free generation
        let (mut pp, mut tg) = ((0u64, 0.0f64), (0u64, 0.0f64));
        for _ in 0..reps {
            let r = m.chat(
                &ChatRequest::new(vec![Message::user(long_prompt.clone())]).with_max_tokens(64),
            )?;
            pp.0 += u64::from(r.usage.prompt_tokens);
            pp.1 += r.usage.prompt_ms;
            tg.0 += u64::from(r.usage.completion_tokens);
            tg.1 += r.usage.completion_ms;
        }
        let time = |m: &mut LocalGguf, sys: &str, q: &str, schema: serde_json::Value, n: u32| {
            let t = Instant::now();
            for _ in 0..reps {
                m.chat(
                    &ChatRequest::new(vec![Message::system(sys), Message::user(q)])
                        .with_schema(schema.clone())
                        .with_max_tokens(n),
                )?;
            }
            anyhow::Ok(t.elapsed().as_secs_f64() * 1e3 / reps as f64)
        };
        let ms_merge = time(
            &mut m,
            prompts::MERGE_CAPTIONS.text,
            &merge,
            prompts::merge_captions_schema(),
            64,
        )?;
        let ms_rel = time(
            &mut m,
            prompts::RELATION.text,
            &relation,
            prompts::relation_schema(),
            40,
        )?;
        println!(
            "{:<42} {:>10.1} {:>10.1} {:>10.0} {:>12.0}",
            format!("{name} ({threads})"),
            pp.0 as f64 / (pp.1 / 1e3),
            tg.0 as f64 / (tg.1 / 1e3),
            ms_merge,
            ms_rel
        );
    }
    Ok(())
}
