//! `opengraph plan`.

use super::args::*;
use super::common::*;

/// `opengraph plan`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Plan {
        db,
        av2_map,
        from,
        to,
        opts,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Plan here")
    };
    if let Some(map) = av2_map {
        let p = api::plan::plan_on_av2(&map, &from, &to, &opts.options())?;
        print_plan(&p, json, None)?;
        return Ok(());
    }
    let Some(db) = db else {
        unreachable!("clap requires --db without --av2-map")
    };
    let store = open_read(&db)?;
    // its obstacles come from the spatial index: built now (opening builds none), so the answer's timings are the
    // work of the request alone, as when served
    store.warm_indexes()?;
    let r = store.read()?;
    let (a, b) = (from.parse::<planner::Spec>()?, to.parse::<planner::Spec>()?);
    let p = api::plan::plan(&r, &a, &b, &opts.options())?;
    print_plan(&p, json, None)?;
    Ok(())
}
