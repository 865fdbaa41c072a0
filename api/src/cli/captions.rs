//! `opengraph captions`.

use super::args::*;
use super::common::*;

/// `opengraph captions`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Captions {
        db,
        llm,
        recent,
        budget_secs,
        max_items,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Captions here")
    };
    let cfg = llm.config(llm_tools::LlmConfig::default(), "local");
    let mut m = open_llm(&cfg, "captions")?;
    let store = open_store(&db, true)?;
    let name =
        llm_tools::retrieve::map_embedder(&store.read()?)?.unwrap_or_else(|| "minilm".into());
    let mut emb = make_embedder(&name)?;
    let opts = ingest::llm::PassOptions {
        budget: budget_secs.map(std::time::Duration::from_secs_f64),
        max_items: max_items.map(|n| n as usize),
        ..ingest::llm::PassOptions::default()
    };
    let r = ingest::llm::merge_captions(&store, m.as_mut(), emb.as_mut(), recent as usize, &opts)?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print_pass("caption merge", &r)?;
    }
    Ok(())
}
