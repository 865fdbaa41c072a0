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
    let words = match &text {
        Some(t) => Some(llm_tools::request::parse_route(t)?),
        None => None,
    };
    let from = from.or_else(|| words.as_ref().and_then(|w| w.from.clone()));
    let to = to.or_else(|| words.as_ref().map(|w| w.to.clone()));
    let (Some(from), Some(to)) = (from, to) else {
        return Err(UsageError(
            "say where to start and where to go: \"from A to B\" in the text, or --from and --to (words or specs such as lane:ID)".into(),
        )
        .into());
    };
    let store = open_read(&db)?;
    let r = store.read()?;
    let parser = parser_of(&parser);
    let mut finder = finder_for(&r, None, parser == api::find::ParserKind::Llm, &llm)?;
    let (a, start) = api::plan::resolve_end(&mut finder, &r, &from, parser)?;
    let (b, goal) = api::plan::resolve_end(&mut finder, &r, &to, parser)?;
    let p = api::plan::plan(&r, &a, &b, &opts.options())?;
    if json {
        let v = api::plan::NavigateAnswer {
            start,
            goal,
            plan: p,
        };
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print_plan(&p, false, Some((&start, &goal)))?;
    }
    Ok(())
}
