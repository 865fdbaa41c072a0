//! `opengraph find`.

use super::args::*;
use super::common::*;

/// `opengraph find`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Find {
        db,
        text,
        k,
        class,
        near,
        embedder,
        rank,
        llm,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Find here")
    };
    let store = open_read(&db)?;
    let ranking = rank.ranking();
    let rerank_n = rank.rerank_n;
    let mut finder = open_finder(&store, embedder, needs_llm(ranking), &llm)?;
    let r = store.read()?;
    let req = api::find::FindRequest {
        text,
        k: k as usize,
        class,
        near,
        ranking,
        rerank_n: rerank_n as usize,
    };
    let (a, nearest_to) = api::tasks::find_near_places(&mut finder, &r, &req)?;
    if let Some(p) = &a.request {
        errln!("request: {}", serde_json::to_string(p)?);
    }
    if let Some(place) = &nearest_to {
        errln!(
            "nearest to: {} (results by ground distance from it)",
            serde_json::to_string(place)?
        );
    }
    for (what, by) in [("parsed", &a.parsed_by), ("re-ranked", &a.reranked_by)] {
        if let Some(m) = by {
            errln!("{what} by {m}");
        }
    }
    if json {
        outln!("{}", serde_json::to_string_pretty(&a.results)?);
    } else {
        outln!(
            "{:>8}  {:>6}  {:<18} {:<16} {:>26}  caption",
            "id",
            "score",
            "label",
            "semantic class",
            "centroid [x, y, z] m"
        );
        for h in &a.results {
            outln!(
                "{:>8}  {:>6.3}  {:<18} {:<16} {:>26}  {}",
                h.id,
                h.score,
                h.label,
                h.semantic_class,
                format!(
                    "[{:.1}, {:.1}, {:.1}]",
                    h.centroid[0], h.centroid[1], h.centroid[2]
                ),
                h.caption
            );
            if let Some((sid, kind)) = &h.segment
                && a.request.as_ref().is_some_and(|r| r.segment.is_some())
            {
                outln!("{:>18}in segment {sid} ({kind})", "");
            }
            for e in &h.evidence {
                outln!(
                    "{:>18}{} '{}': node {} at {:.1} m ({}){}",
                    "",
                    e.relation.replace('_', " "),
                    e.anchor,
                    e.anchor_id,
                    e.distance_m,
                    e.anchor_caption,
                    e.related
                        .as_ref()
                        .map_or(String::new(), |x| format!(", RELATED {x}"))
                );
            }
        }
        errln!(
            "{} results; parse {:.1} ms, rank {:.1} ms{}",
            a.results.len(),
            a.timings_ms[0],
            a.timings_ms[1],
            if a.reranked_by.is_some() {
                format!(", re-rank {:.0} ms", a.timings_ms[2])
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
