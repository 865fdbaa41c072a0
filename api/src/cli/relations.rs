//! `opengraph relations`.

use super::args::*;
use super::common::*;

/// `opengraph relations`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Relations {
        db,
        experimental,
        llm,
        budget_secs,
        max_pairs,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Relations here")
    };
    if !experimental {
        return Err(UsageError(
            "opengraph relations is an experiment, not a feature: on the default city the local \
             models' relation labels agree with the simulator's truth less often than the map's \
             geometric labels (strict 0.40 against 0.86, docs/llm.md), and find and the tools \
             ignore them; pass --experimental to run it anyway"
                .into(),
        )
        .into());
    }
    let cfg = llm.config(llm_tools::LlmConfig::default(), "local");
    let mut m = open_llm(&cfg, "relations")?;
    let store = open_store(&db, true)?;
    let opts = ingest::llm::PassOptions {
        budget: budget_secs.map(std::time::Duration::from_secs_f64),
        max_items: max_pairs.map(|n| n as usize),
        ..ingest::llm::PassOptions::default()
    };
    let r = ingest::llm::infer_relations(
        &store,
        m.as_mut(),
        &ingest::hierarchy::relations::RelationConfig::default(),
        &opts,
    )?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print_pass("relations", &r)?;
    }
    Ok(())
}
