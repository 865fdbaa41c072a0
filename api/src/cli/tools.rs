//! `opengraph tools`.

use super::args::*;

/// `opengraph tools`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Tools { writes } = cmd else {
        unreachable!("run dispatches only Command::Tools here")
    };
    outln!(
        "{}",
        serde_json::to_string_pretty(&api::tools::tools(writes))?
    );
    Ok(())
}
