//! `opengraph eval`.

use super::args::*;
use super::common::*;

/// `opengraph eval semseg`.
pub(crate) fn semseg(cmd: Command) -> anyhow::Result<()> {
    let Command::Eval {
        what:
            EvalCommand::Semseg {
                db,
                kitti,
                frames,
                poses,
                max_dist_m,
                json,
            },
    } = cmd
    else {
        unreachable!("run dispatches only Command::Eval here")
    };
    let store = open_read(&db)?;
    let r = og_eval::semseg::eval_semseg(
        &store,
        &kitti,
        poses.as_deref(),
        frames,
        max_dist_m as f32,
        ingest::mapping::MappingConfig::default().image_size,
    )?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        outln!(
            "semseg on {} scans, {} labelled points ({} missed), detections from {}",
            r.scans,
            r.points,
            r.missed,
            r.source
        );
        outln!("{:<14} {:>7} {:>7} {:>9}", "class", "IoU", "F1", "points");
        for (c, s) in &r.per_class {
            outln!("{c:<14} {:>7.3} {:>7.3} {:>9}", s.iou, s.f1, s.support);
        }
        outln!("mIoU {:.3}   macro F1 {:.3}", r.miou, r.f1);
        outln!(
            "in camera view: {} points ({} missed), mIoU {:.3}, macro F1 {:.3}",
            r.in_view.points,
            r.in_view.missed,
            r.in_view.miou,
            r.in_view.f1
        );
    }
    Ok(())
}

/// `opengraph eval relations`.
pub(crate) fn relations(cmd: Command) -> anyhow::Result<()> {
    let Command::Eval {
        what: EvalCommand::Relations { db, sim, json },
    } = cmd
    else {
        unreachable!("run dispatches only Command::Eval here")
    };
    let store = open_read(&db)?;
    let r = og_eval::relations::eval_relations(&store.read()?, &sim)?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        outln!(
            "{} LLM-labelled pairs, {} with a relation that follows from the ground truth; models: {}",
            r.llm_pairs,
            r.judged,
            r.models
        );
        for (name, a) in [("llm", &r.llm), ("geometric", &r.geometric)] {
            let per: Vec<String> = a
                .per_truth
                .iter()
                .map(|(t, (n, s))| format!("{t} {s:.2} (n={n})"))
                .collect();
            outln!(
                "{name:<10} agreement {:.3} (strict {:.3}) over {} pairs; {}",
                a.agreement,
                a.strict_agreement,
                a.pairs,
                per.join(", ")
            );
        }
    }
    Ok(())
}

/// `opengraph eval retrieval`.
pub(crate) fn retrieval(cmd: Command) -> anyhow::Result<()> {
    let Command::Eval {
        what:
            EvalCommand::Retrieval {
                db,
                sim,
                queries,
                rank,
                llm,
                verbose,
                json,
            },
    } = cmd
    else {
        unreachable!("run dispatches only Command::Eval here")
    };
    let qs = og_eval::retrieval::read_queries(&queries)?;
    let store = open_read(&db)?;
    let r = store.read()?;
    let ranking = rank.ranking();
    let rerank_n = rank.rerank_n;
    let mut finder = finder_for(&r, None, needs_llm(ranking), &llm)?;
    let mut latencies = Vec::new();
    let report = og_eval::retrieval::eval_retrieval(&sim, &qs, |text| {
        let t = std::time::Instant::now();
        let a = finder
            .find(
                &r,
                &api::find::FindRequest {
                    text: text.to_string(),
                    k: 3,
                    class: None,
                    near: None,
                    ranking,
                    rerank_n: rerank_n as usize,
                },
            )
            .map_err(|e| ingest::Error::Invalid(format!("{text:?}: {e}")))?;
        latencies.push(t.elapsed().as_secs_f64() * 1e3);
        Ok(a.results
            .into_iter()
            .map(|g| (g.id, g.caption, g.centroid))
            .collect())
    })?;
    let p50 = median(&mut latencies);
    if json {
        let mut v = serde_json::to_value(&report)?;
        v["p50_ms"] = serde_json::json!(p50);
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        let how = match ranking {
            api::find::Ranking::Plain => "plain embedding ranking".to_string(),
            api::find::Ranking::Graph { parser, rerank } => format!(
                "graph-aware, {} parser{}",
                if parser == api::find::ParserKind::Llm {
                    "LLM"
                } else {
                    "rule"
                },
                if rerank { ", LLM re-ranking" } else { "" }
            ),
        };
        outln!(
            "retrieval on {} ({how}), p50 {p50:.1} ms per query",
            queries.display()
        );
        outln!(
            "{:<12} {:>7} {:>6} {:>6} {:>6}",
            "type",
            "queries",
            "R@1",
            "R@2",
            "R@3"
        );
        for t in og_eval::retrieval::QUERY_TYPES {
            if let Some(s) = report.per_type.get(t) {
                outln!(
                    "{t:<12} {:>7} {:>6.3} {:>6.3} {:>6.3}",
                    s.queries,
                    s.r_at_1,
                    s.r_at_2,
                    s.r_at_3
                );
            }
        }
        for u in &report.unanswerable {
            outln!("not scored (no true object satisfies it): {u}");
        }
        if verbose {
            for q in &report.queries {
                outln!(
                    "{} [{}] {:?}",
                    q.first_hit
                        .map_or("MISS".to_string(), |h| format!("hit@{h}")),
                    q.kind,
                    q.text
                );
                for (id, cap, under) in &q.returned {
                    outln!(
                        "      {id:>6} {:<18} {cap}",
                        under.as_deref().unwrap_or("(nothing)")
                    );
                }
            }
        }
    }
    Ok(())
}

/// `opengraph eval locate`.
pub(crate) fn locate(cmd: Command) -> anyhow::Result<()> {
    let Command::Eval {
        what:
            EvalCommand::Locate {
                db,
                sim,
                per_spot,
                seed,
                parser,
                llm,
                verbose,
                json,
            },
    } = cmd
    else {
        unreachable!("run dispatches only Command::Eval here")
    };
    let cases = og_eval::locate::generate_cases(&sim, per_spot as usize, seed)?;
    let store = open_read(&db)?;
    let r = store.read()?;
    let parser = parser_of(&parser);
    let mut finder = finder_for(&r, None, parser == api::find::ParserKind::Llm, &llm)?;
    let scene = finder.scene(&r)?;
    let mut latencies = Vec::new();
    let report = og_eval::locate::eval_locate(&cases, &scene.segments, |text| {
        let t = std::time::Instant::now();
        let a = finder
            .locate(
                &r,
                &api::find::LocateRequest {
                    text: text.to_string(),
                    k: 3,
                    parser,
                },
            )
            .map_err(|e| ingest::Error::Invalid(format!("{text:?}: {e}")))?;
        latencies.push(t.elapsed().as_secs_f64() * 1e3);
        let pos = a
            .results
            .first()
            .map(|l| (l.position, l.position_uncertainty_m));
        Ok((a.results.into_iter().map(|l| l.segment).collect(), pos))
    })?;
    let p50 = median(&mut latencies);
    if json {
        let mut v = serde_json::to_value(&report)?;
        v["p50_ms"] = serde_json::json!(p50);
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        outln!(
            "locate on {} descriptions ({} parser; {} spots in no map segment not scored), p50 {p50:.1} ms",
            report.all.cases,
            if parser == api::find::ParserKind::Llm {
                "LLM"
            } else {
                "rule"
            },
            report.unmatched
        );
        outln!(
            "{:<12} {:>6} {:>6} {:>6}",
            "kind",
            "cases",
            "top-1",
            "top-3"
        );
        for (k, a) in report
            .per_kind
            .iter()
            .chain(std::iter::once((&"all".to_string(), &report.all)))
        {
            outln!("{k:<12} {:>6} {:>6.3} {:>6.3}", a.cases, a.top1, a.top3);
        }
        if let Some(e) = report.median_position_error_m {
            outln!(
                "position of the first answer: median error {e:.1} m, within 5 m {:.3}, within 10 m {:.3}, truth within 2x its uncertainty {:.3}",
                report.within_5m,
                report.within_10m,
                report.within_2_sigma
            );
        }
        if verbose {
            for o in &report.outcomes {
                outln!(
                    "{} truth {} got {:?}: {}",
                    if o.returned.first() == Some(&o.truth) {
                        "ok  "
                    } else {
                        "MISS"
                    },
                    o.truth,
                    o.returned,
                    o.text
                );
            }
        }
    }
    Ok(())
}

/// `opengraph eval instances`.
pub(crate) fn instances(cmd: Command) -> anyhow::Result<()> {
    let Command::Eval {
        what: EvalCommand::Instances { db, sim, json },
    } = cmd
    else {
        unreachable!("run dispatches only Command::Eval here")
    };
    let store = open_read(&db)?;
    let r = og_eval::instances::eval_instances(&store.read()?, &sim)?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        outln!(
            "{} instances ({} surface tiles not counted), {} true objects, {} matched (footprint IoU >= {}): precision {:.3}, recall {:.3}",
            r.instances,
            r.surface_tiles,
            r.objects,
            r.matched,
            og_eval::instances::MATCH_IOU,
            r.precision,
            r.recall
        );
        if let Some(g) = r.ghosts {
            outln!(
                "ghost instances (unmatched, within {} m of a mover's line): {g}",
                og_eval::instances::GHOST_M
            );
        }
        outln!("recall per true class:");
        for (c, k) in &r.recall_per_class {
            outln!("  {c:<18} {:>4}/{:<4} {:.3}", k.matched, k.total, k.share);
        }
        outln!("precision per map class:");
        for (c, k) in &r.precision_per_class {
            outln!("  {c:<18} {:>4}/{:<4} {:.3}", k.matched, k.total, k.share);
        }
        outln!(
            "matched objects: label accuracy {:.3}, semantic class accuracy {:.3}",
            r.label_accuracy,
            r.semantic_class_accuracy
        );
        outln!("per true class: label, semantic class, labels given (instances)");
        for (c, k) in &r.label_accuracy_per_class {
            let s = &r.semantic_class_accuracy_per_class[c];
            let given: Vec<String> = r.labels_per_class[c]
                .iter()
                .map(|(l, n)| format!("{l} ({n})"))
                .collect();
            outln!(
                "  {c:<18} {:>4}/{:<4} {:.3}   {:>4}/{:<4} {:.3}   {}",
                k.matched,
                k.total,
                k.share,
                s.matched,
                s.total,
                s.share,
                given.join(", ")
            );
        }
        if let Some(p) = &r.by_points {
            outln!(
                "by the points each object was seen with ({} scans; voxels of {} m, IoU >= {}): {} true objects seen ({} unseen), {} instances, {} matched: precision {:.3}, recall {:.3}",
                p.scans,
                og_eval::instance_points::VOXEL_M,
                og_eval::instance_points::MATCH_IOU,
                p.objects,
                p.unseen,
                p.instances,
                p.matched,
                p.precision,
                p.recall
            );
            outln!("recall per true class; the unmatched: missed / split / fused / partial");
            for (c, k) in &p.recall_per_class {
                let f = p.failures_per_class.get(c).cloned().unwrap_or_default();
                outln!(
                    "  {c:<18} {:>4}/{:<4} {:.3}   {} / {} / {} / {}",
                    k.matched,
                    k.total,
                    k.share,
                    f.missed,
                    f.split,
                    f.fused,
                    f.partial
                );
            }
            outln!("precision per map label (labels with at least 5 instances)");
            for (l, k) in p.precision_per_label.iter().filter(|(_, k)| k.total >= 5) {
                outln!("  {l:<18} {:>4}/{:<4} {:.3}", k.matched, k.total, k.share);
            }
        }
    }
    Ok(())
}

/// `opengraph eval roads`.
pub(crate) fn roads(cmd: Command) -> anyhow::Result<()> {
    let Command::Eval {
        what: EvalCommand::Roads { db, sim, json },
    } = cmd
    else {
        unreachable!("run dispatches only Command::Eval here")
    };
    let store = open_read(&db)?;
    let gap = ingest::hierarchy::drivable::DrivableConfig::default().max_gap_m;
    let r = og_eval::roads::eval_roads(&store.read()?, &sim, gap)?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        outln!(
            "road areas of {} segments against the simulator's roads ({} m raster)",
            r.segments.len(),
            og_eval::roads::CELL_M
        );
        outln!("segment node  kind               truth m²  IoU before  IoU after  polygon m²");
        for s in &r.segments {
            outln!(
                "{:>12}  {:<17} {:>9.0}  {:>10.3}  {:>9.3}  {:>10.0}",
                s.node,
                s.kind,
                s.truth_m2,
                s.iou_before,
                s.iou_after,
                s.polygon_m2
            );
        }
        outln!(
            "mean IoU over segments with true area: before {:.3}, after {:.3}",
            r.mean_iou_before,
            r.mean_iou_after
        );
        outln!(
            "IoU of all segments together: before {:.3}, after {:.3}",
            r.total_iou_before,
            r.total_iou_after
        );
    }
    Ok(())
}

/// `opengraph eval captions`.
pub(crate) fn captions(cmd: Command) -> anyhow::Result<()> {
    let Command::Eval {
        what: EvalCommand::Captions { db, sim, json },
    } = cmd
    else {
        unreachable!("run dispatches only Command::Eval here")
    };
    let store = open_read(&db)?;
    let r = og_eval::captions::eval_captions(&store.read()?, &sim)?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        outln!(
            "{} object instances, {} matched to a ground-truth object; captions by {}",
            r.object_instances,
            r.matched,
            r.caption_source
        );
        let row = |name: &str, c: &og_eval::captions::CaptionScores| {
            outln!(
                "{name:<8} colour {:.3} (wrong {:.3}, missing {:.3}, n={})  material {:.3} (wrong {:.3}, missing {:.3}, n={})  noun {:.3}  {:.1} words",
                c.colour.accuracy,
                c.colour.contradiction,
                c.colour.missing,
                c.colour.judged,
                c.material.accuracy,
                c.material.contradiction,
                c.material.missing,
                c.material.judged,
                c.noun_accuracy,
                c.mean_words
            );
            anyhow::Ok(())
        };
        row("all", &r.caption)?;
        if let Some(m) = &r.merged {
            outln!("the {} merged objects, side by side:", m.llm.instances);
            row("llm", &m.llm)?;
            row("medoid", &m.medoid)?;
        }
    }
    Ok(())
}
