//! `opengraph mcp`.

use super::args::*;
use super::common::*;

/// `opengraph mcp`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Mcp { db, allow_writes } = cmd else {
        unreachable!("run dispatches only Command::Mcp here")
    };
    let tb = open_toolbox(&db, allow_writes)?;
    errln!(
        "opengraph MCP server on stdio over {} ({})",
        db.display(),
        if allow_writes {
            "writes allowed"
        } else {
            "read-only"
        }
    );
    api::mcp::serve_stdio(tb)?;
    Ok(())
}
