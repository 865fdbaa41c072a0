//! `opengraph navigate`.

use super::args::*;
use super::common::*;

/// `opengraph navigate`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Navigate {
        db,
        text,
        from,
        to,
        parser,
        llm,
        opts,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Navigate here")
    };
    let store = open_read(&db)?;
    let r = store.read()?;
    let parser = parser_of(&parser);
    let mut finder = finder_for(&r, None, parser == api::find::ParserKind::Llm, &llm)?;
    let v = api::plan::navigate(
        &mut finder,
        &r,
        &api::plan::NavigateRequest {
            text,
            from,
            to,
            parser,
            options: opts.options(),
        },
    )?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print_plan(&v.plan, false, Some((&v.start, &v.goal)))?;
    }
    Ok(())
}
