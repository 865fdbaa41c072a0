//! `opengraph locate`.

use super::args::*;
use super::common::*;

/// `opengraph locate`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Locate {
        db,
        text,
        k,
        parser,
        llm,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Locate here")
    };
    let store = open_read(&db)?;
    let parser = parser_of(&parser);
    let mut finder = open_finder(&store, None, parser == api::find::ParserKind::Llm, &llm)?;
    let r = store.read()?;
    let a = finder.locate(
        &r,
        &api::find::LocateRequest {
            text,
            k: k as usize,
            parser,
        },
    )?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&a)?);
    } else {
        errln!("description: {}", serde_json::to_string(&a.description)?);
        if let Some(m) = &a.parsed_by {
            errln!("parsed by {m}");
        }
        for u in &a.unmatched {
            errln!(
                "nothing in the map matches '{}' well (best cosine {:.2}); it was left out",
                u.landmark,
                u.best_cosine
            );
        }
        if a.results.is_empty() {
            errln!(
                "no segment to rank: the description names no road kind and nothing the map holds"
            );
        }
        for (i, l) in a.results.iter().enumerate() {
            outln!(
                "{}. segment {} ({}), score {:.3}, position [{:.1}, {:.1}] ± {:.1} m{}",
                i + 1,
                l.segment,
                l.kind,
                l.score,
                l.position[0],
                l.position[1],
                l.position_uncertainty_m,
                match l.kind_match {
                    Some(false) => ", kind differs from the description",
                    _ => "",
                }
            );
            for e in &l.evidence {
                outln!(
                    "     '{}': node {} {:.1} m from the segment ({})",
                    e.landmark,
                    e.id,
                    e.distance_m,
                    e.caption
                );
            }
        }
        errln!(
            "parse {:.1} ms, rank {:.1} ms",
            a.timings_ms[0],
            a.timings_ms[1]
        );
    }
    Ok(())
}
