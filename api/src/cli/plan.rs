//! `opengraph plan`.

use super::args::*;
use super::common::*;

/// `opengraph plan`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Plan {
        db,
        from,
        to,
        opts,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Plan here")
    };
    let store = open_read(&db)?;
    let r = store.read()?;
    let (a, b) = (from.parse::<planner::Spec>()?, to.parse::<planner::Spec>()?);
    let p = api::plan::plan(&r, &a, &b, &opts.options())?;
    print_plan(&p, json, None)?;
    Ok(())
}
