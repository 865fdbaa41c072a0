//! `opengraph build`.

use super::args::*;
use super::common::*;

/// `opengraph build`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Build {
        kitti,
        detections,
        oracle_labels,
        frames,
        stride,
        accumulate,
        poses,
        config,
        db,
        resume,
        name,
        embedder,
        llm,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Build here")
    };
    use opengraph_service::build::{BuildRequest, CaptionMerge, EmbedderChoice, Progress};
    let req = BuildRequest {
        kitti,
        oracle_labels,
        detections,
        frames: frames.map(|r| [r.start, r.end]),
        stride,
        accumulate,
        poses,
        config,
        db,
        resume,
        name,
        embedder: if embedder == "hash" {
            EmbedderChoice::Hash
        } else {
            EmbedderChoice::Minilm
        },
        llm: llm.choice(),
    };
    // test hook: pause after each commit so a test can kill the build at a known point
    let pause_ms: u64 = std::env::var("OPENGRAPH_BUILD_PAUSE_AFTER_COMMIT_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} key frames {msg}",
        )
        .expect("valid template"),
    );
    let mut on_progress = |p: Progress| match p {
        Progress::Start { done, total } => {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
        Progress::Frame { frame } => {
            bar.inc(1);
            bar.set_message(format!("frame {frame}"));
        }
        Progress::Committed { frame } => {
            bar.suspend(|| errln!("committed through frame {frame}"));
            if pause_ms > 0 {
                std::thread::sleep(std::time::Duration::from_millis(pause_ms));
            }
        }
        Progress::Finishing => bar.set_message("post-processing and hierarchy"),
    };
    let answer = opengraph_service::build::build(&req, &mut on_progress);
    bar.finish_and_clear();
    let answer = answer?;
    let rss = peak_rss_mib();
    if json {
        let mut v = serde_json::to_value(&answer)?;
        v["peak_rss_mib"] = serde_json::json!(rss);
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        out!("{}", build_summary(&answer.report, rss));
        match &answer.caption_merge {
            CaptionMerge::Llm(m) => print_pass("caption merge", m)?,
            CaptionMerge::Medoid { .. } => {
                outln!("captions: medoid of each object's latest captions (no --llm)")
            }
        }
    }
    Ok(())
}
