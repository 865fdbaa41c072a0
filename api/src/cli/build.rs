//! `opengraph build`.

use anyhow::Context;

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
    use ingest::build::{BuildArgs, BuildConfig, Progress, Source};
    let mut cfg = match &config {
        Some(p) => BuildConfig::from_toml_file(p)?,
        None => BuildConfig::default(),
    };
    // the language model is opened before any mapping, so a bad [llm] or --llm fails
    // at once instead of after the whole build
    let llm_cfg = llm.config(cfg.llm.clone(), "none");
    let mut chat = llm_tools::chat::open(&llm_cfg)?;
    if let Some(m) = &chat {
        errln!("language model for the caption merge: {}", m.model_id());
    }
    if let Some(a) = accumulate {
        cfg.mapping.accumulate = a as usize;
    }
    let source = match (detections, oracle_labels) {
        (Some(d), false) => Source::Detections(d),
        (None, true) => Source::Oracle,
        _ => {
            return Err(
                UsageError("give either --detections DIR or --oracle-labels".into()).into(),
            );
        }
    };
    let mut emb = make_embedder(&embedder)?;
    let store =
        graphstore::Store::create(&db).with_context(|| format!("opening {}", db.display()))?;
    let args = BuildArgs {
        sequence: kitti,
        poses,
        source,
        frames,
        stride,
        config: cfg,
        environment: name,
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
    let mut merger = ingest::mapping::MedoidMerger;
    let report = ingest::build::build(
        &store,
        &args,
        emb.as_mut(),
        &mut merger,
        resume,
        &mut on_progress,
    )?;
    bar.finish_and_clear();
    let merge = match chat.as_mut() {
        Some(m) => Some(ingest::llm::merge_captions(
            &store,
            m.as_mut(),
            emb.as_mut(),
            args.config.mapping.merge_captions.max(2),
            &ingest::llm::PassOptions::default(),
        )?),
        None => None,
    };
    let rss = peak_rss_mib();
    if json {
        let mut v = serde_json::to_value(&report)?;
        v["peak_rss_mib"] = serde_json::json!(rss);
        v["caption_merge"] = match &merge {
            Some(m) => serde_json::to_value(m)?,
            None => serde_json::json!({"model": "none", "method": "medoid"}),
        };
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        out!("{}", build_summary(&report, rss));
        match &merge {
            Some(m) => print_pass("caption merge", m)?,
            None => {
                outln!("captions: medoid of each object's latest captions (no --llm)")
            }
        }
    }
    Ok(())
}
