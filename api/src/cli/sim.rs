//! `opengraph sim`.

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
    use opengraph_service::sim::{SimRequest, SimSize};
    let req = SimRequest {
        out,
        seed,
        size: match size.as_str() {
            "medium" => SimSize::Medium,
            "city" => SimSize::City,
            _ => SimSize::Small,
        },
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
    };
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
    let r = opengraph_service::sim::sim(&req, &progress);
    bar.finish_and_clear();
    let r = r?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        out!("{}", sim_summary(&r));
    }
    Ok(())
}
