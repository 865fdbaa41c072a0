//! `opengraph demo`.

use anyhow::Context;

use api::{demo, info};

use super::args::*;
use super::common::*;

/// `opengraph demo`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Demo { db } = cmd else {
        unreachable!("run dispatches only Command::Demo here")
    };
    if db.exists() {
        return Err(UsageError(format!(
            "{} already exists; demo writes a new store",
            db.display()
        ))
        .into());
    }
    let store =
        graphstore::Store::create(&db).with_context(|| format!("creating {}", db.display()))?;
    demo::build(&store)?;
    out!("{}", info::table(&store)?);
    Ok(())
}
