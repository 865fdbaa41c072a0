//! `opengraph sim`.

use anyhow::Context;

use super::args::*;
use super::common::*;

/// `opengraph sim`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Sim {
        out,
        seed,
        size,
        frames,
        miss_rate,
        false_positives,
        paraphrase_rate,
        wrong_attribute_rate,
        mask_noise_px,
        no_noise,
        moving_cars,
        walkers,
        threads,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Sim here")
    };
    use ingest::sources::sim::{SimConfig, generate, roads::SimSize, sensors::DetectionNoise};
    let size = match size.as_str() {
        "medium" => SimSize::Medium,
        "city" => SimSize::City,
        _ => SimSize::Small,
    };
    let mut cfg = SimConfig {
        seed,
        size,
        frames: frames.map(|f| f as usize),
        noise: if no_noise {
            DetectionNoise::none()
        } else {
            DetectionNoise {
                miss_rate,
                false_positives_per_frame: false_positives,
                paraphrase_rate,
                wrong_attribute_rate,
                mask_noise_px,
            }
        },
        movers: ingest::sources::sim::movers::MoverConfig {
            cars: moving_cars as usize,
            walkers: walkers as usize,
        },
        ..SimConfig::default()
    };
    if let Some(t) = threads {
        cfg.threads = t.max(1);
    }
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} sensor frames",
        )
        .expect("valid template"),
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let r = generate(&out, &cfg, &progress)?;
    bar.finish_and_clear();
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        out!("{}", sim_summary(&r));
    }
    Ok(())
}
