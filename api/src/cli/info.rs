//! `opengraph info`.

use api::info;

use super::args::*;
use super::common::*;

/// `opengraph info`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Info { db, json } = cmd else {
        unreachable!("run dispatches only Command::Info here")
    };
    let store = open_read(&db)?;
    let text = if json {
        info::json(&store)?
    } else {
        info::table(&store)?
    };
    out!("{text}");
    Ok(())
}
