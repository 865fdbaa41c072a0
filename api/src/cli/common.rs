//! What the commands share: opening stores, models and toolboxes, the error kinds and exit
//! codes, printing.

use std::path::PathBuf;

use anyhow::Context;

use super::args::*;

/// Opens the language model `cfg` names; a usage error when it names none.
pub(crate) fn open_llm(
    cfg: &llm_tools::LlmConfig,
    what: &str,
) -> anyhow::Result<Box<dyn llm_tools::ChatModel>> {
    match llm_tools::chat::open(cfg)? {
        Some(m) => {
            errln!("language model: {}", m.model_id());
            Ok(m)
        }
        None => Err(UsageError(format!(
            "{what} needs a language model: pass --llm local (or openai with --llm-url)"
        ))
        .into()),
    }
}

pub(crate) fn print_pass(name: &str, r: &ingest::llm::PassReport) -> anyhow::Result<()> {
    outln!(
        "{name}: {} done in this run ({} from the cache), {} done before, {} left of {}; {:.0} ms per question, {:.1} s in all\nmodel {}, prompt {}",
        r.done,
        r.cached,
        r.already_done,
        r.left,
        r.total,
        r.ms_per_item,
        r.secs,
        r.model,
        r.prompt
    );
    for (label, n) in &r.labels {
        outln!("  {label:<24} {n}");
    }
    if !r.rejected.is_empty() {
        errln!(
            "{} answers broke the answer schema and were skipped (a later run asks again):",
            r.rejected.len()
        );
        for why in r.rejected.iter().take(5) {
            errln!("  {why}");
        }
    }
    Ok(())
}

/// Prints a plan: JSON, or the ends (with how `navigate` resolved them), route and path.
pub(crate) fn print_plan(
    p: &api::plan::PlanAnswer,
    json: bool,
    resolved: Option<(&api::plan::Resolved, &api::plan::Resolved)>,
) -> anyhow::Result<()> {
    if let Some(w) = &p.path.warning {
        errln!("warning: {w}");
    }
    if json {
        let v = serde_json::json!({
            "from": p.from,
            "to": p.to,
            "route": {"nodes": p.route.nodes, "length_m": p.route.length_m},
            "path": {
                "poses": p.path.poses,
                "length_m": p.path.length_m,
                "planner": p.path.planner,
                "fallback": p.path.fallback,
                "warning": p.path.warning,
            },
            "blocking": p.blocking,
            "drivable_segments": p.drivable_segments,
            "timings_ms": p.timings_ms,
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    let end = |t: &planner::Target| match t.node {
        Some(n) => format!("{} node {n} at ({:.1}, {:.1})", t.kind, t.xy[0], t.xy[1]),
        None => format!("point ({:.1}, {:.1})", t.xy[0], t.xy[1]),
    };
    let how = |r: Option<&api::plan::Resolved>| match r {
        Some(api::plan::Resolved::Find { text, result }) => {
            format!("  <- find {text:?}: {}", result.caption)
        }
        Some(api::plan::Resolved::Locate { text, result }) => {
            format!("  <- locate {text:?}: {} segment", result.kind)
        }
        Some(api::plan::Resolved::Drive { text, end, .. }) => {
            format!("  <- {text:?}: the drive's {end}")
        }
        _ => String::new(),
    };
    outln!(
        "from: {}{}\nto:   {}{}",
        end(&p.from),
        how(resolved.map(|r| r.0)),
        end(&p.to),
        how(resolved.map(|r| r.1))
    );
    outln!(
        "route: {} nodes, {:.1} m ({:.1} ms)\npath: {} poses, {:.1} m by {} ({:.1} ms in all, {} blocking boxes, {})",
        p.route.nodes.len(),
        p.route.length_m,
        p.timings_ms[0],
        p.path.poses.len(),
        p.path.length_m,
        p.path.planner,
        p.timings_ms[1],
        p.blocking,
        if p.drivable_segments > 0 {
            format!(
                "kept on the drivable areas of {} segments",
                p.drivable_segments
            )
        } else {
            "bounded by the corridor alone".to_string()
        }
    );
    Ok(())
}

/// The ranking the find flags ask for.
pub(crate) fn ranking_of(plain: bool, parser: &str, rerank: bool) -> api::find::Ranking {
    if plain {
        api::find::Ranking::Plain
    } else {
        api::find::Ranking::Graph {
            parser: if parser == "llm" {
                api::find::ParserKind::Llm
            } else {
                api::find::ParserKind::Rules
            },
            rerank,
        }
    }
}

/// Opens a map for writing or read-only, naming the file in the error. When a server holds
/// the map (its marker file [`serving_marker`] exists), the error says where to reach it.
pub(crate) fn open_store(
    db: &std::path::Path,
    writable: bool,
) -> anyhow::Result<graphstore::Store> {
    let opened = if writable {
        graphstore::Store::open(db)
    } else {
        graphstore::Store::open_read_only(db)
    };
    if let Ok(Some(from)) = opened.as_ref().map(graphstore::Store::converted_from) {
        eprintln!(
            "note: converted {} from store format {from} to {} (once; builds before 2026-12-07 cannot open it now)",
            db.display(),
            graphstore::FORMAT_VERSION
        );
    }
    match opened {
        Err(e @ graphstore::Error::InUse { .. }) => {
            // a marker left by a killed server (its process is gone) says nothing
            let note = std::fs::read_to_string(serving_marker(db))
                .ok()
                .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                .filter(|v| {
                    v["pid"].as_u64().is_none_or(|pid| {
                        !cfg!(target_os = "linux")
                            || std::path::Path::new(&format!("/proc/{pid}")).exists()
                    })
                });
            let served = note
                .as_ref()
                .and_then(|v| v["url"].as_str().map(str::to_string));
            let server_writes = note.as_ref().is_some_and(|v| v["writes"] == true);
            let live = note.as_ref().is_some_and(|v| v["live"] == true);
            match served {
                Some(url) if !server_writes => {
                    drop(e);
                    Err(UsageError(format!(
                        "cannot open {} for writing: a read-only `opengraph serve` holds it ({url}); \
                         to read, open it read-only too (`opengraph query --read-only ...`, or POST {url}api/cypher); \
                         to write, stop it, or serve with --token-file and write through it (POST {url}api/update, {url}api/cypher/write)",
                        db.display()
                    ))
                    .into())
                }
                Some(url) => {
                    drop(e);
                    Err(UsageError(format!(
                        "cannot open {}: `opengraph serve`{} holds it for writing; reach the map through the server at {url} \
                         (POST {url}api/cypher with {{\"query\": ...}}, the routes are in {url}openapi.json, MCP at {url}mcp)",
                        db.display(),
                        if live { " (mapping live)" } else { "" }
                    ))
                    .into())
                }
                None => Err(anyhow::Error::new(e).context(format!("opening {}", db.display()))),
            }
        }
        other => other.with_context(|| format!("opening {}", db.display())),
    }
}

/// The file a server leaves beside the map (`MAP.serving.json`: url, pid, whether it writes)
/// while it holds it, so that other commands can say where to reach it.
pub(crate) fn serving_marker(db: &std::path::Path) -> PathBuf {
    let mut name = db.file_name().unwrap_or_default().to_os_string();
    name.push(".serving.json");
    db.with_file_name(name)
}

/// Opens a map read-only (several readers may share it), naming the file in the error.
pub(crate) fn open_read(db: &std::path::Path) -> anyhow::Result<graphstore::Store> {
    open_store(db, false)
}

/// The median of some latencies (0 for none); sorts them.
pub(crate) fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}

/// The toolbox over a map: read-only unless `writes`.
pub(crate) fn open_toolbox(
    db: &std::path::Path,
    writes: bool,
) -> anyhow::Result<api::tools::Toolbox> {
    open_toolbox_with(db, writes, None)
}

/// [`open_toolbox`] whose finder also holds the language model `llm` names.
pub(crate) fn open_toolbox_with(
    db: &std::path::Path,
    writes: bool,
    llm: Option<&LlmArgs>,
) -> anyhow::Result<api::tools::Toolbox> {
    let store = open_store(db, writes)?;
    let finder = {
        let r = store.read()?;
        finder_for(&r, None, llm.is_some(), llm.unwrap_or(&LlmArgs::default()))?
    };
    Ok(api::tools::Toolbox::new(store, finder, writes))
}

/// Whether a ranking needs a language model.
pub(crate) fn needs_llm(ranking: api::find::Ranking) -> bool {
    matches!(
        ranking,
        api::find::Ranking::Graph {
            parser: api::find::ParserKind::Llm,
            ..
        } | api::find::Ranking::Graph { rerank: true, .. }
    )
}

pub(crate) fn parser_of(name: &str) -> api::find::ParserKind {
    if name == "llm" {
        api::find::ParserKind::Llm
    } else {
        api::find::ParserKind::Rules
    }
}

/// A finder with the map's embedder (or the one asked for, if it agrees) and, when the
/// ranking needs one, the language model.
pub(crate) fn finder_for(
    r: &impl graphstore::GraphRead,
    embedder: Option<String>,
    needs_llm: bool,
    llm: &LlmArgs,
) -> anyhow::Result<api::find::Finder> {
    let model = if needs_llm {
        Some(open_llm(
            &llm.config(llm_tools::LlmConfig::default(), "local"),
            "--parser llm (or find's --rerank llm)",
        )?)
    } else {
        None
    };
    let choice = match embedder {
        Some(e) => Some(
            api::find::EmbedderChoice::from_name(&e)
                .ok_or_else(|| UsageError(format!("--embedder: unknown embedder {e:?}")))?,
        ),
        None => None,
    };
    Ok(api::find::Finder::for_map(r, choice, model)?)
}

/// Opens a finder for a one-shot command on a map opened read-only: the embedder (and the
/// model, if asked) on this thread while another builds the store's in-memory indexes and
/// loads the map's scene (instances and segments), which every `find` and `locate` reads.
/// So a command's answer times the request alone, as when served, and the two costs of
/// opening (about 0.3 s each on the city map) overlap on two cores.
pub(crate) fn open_finder(
    store: &graphstore::Store,
    embedder: Option<String>,
    needs_llm: bool,
    llm: &LlmArgs,
) -> anyhow::Result<api::find::Finder> {
    std::thread::scope(|s| {
        let loading = s.spawn(|| -> anyhow::Result<_> {
            store.warm_indexes()?;
            let r = store.read()?;
            // a map the scene cannot be read from fails later where the request needs it,
            // with the error it always gave
            let scene = scene::view::MapView::load(&r).ok();
            Ok((r, scene))
        });
        let r = store.read()?;
        let finder = finder_for(&r, embedder, needs_llm, llm);
        let (r2, scene) = loading
            .join()
            .map_err(|_| anyhow::anyhow!("loading the map's indexes and scene failed"))??;
        let mut finder = finder?;
        if let Some(scene) = scene {
            finder.keep_scene(&r2, std::sync::Arc::new(scene));
        }
        Ok(finder)
    })
}

pub(crate) fn make_embedder(name: &str) -> anyhow::Result<Box<dyn llm_tools::Embedder + Send>> {
    Ok(api::find::EmbedderChoice::from_name(name)
        .unwrap_or_default()
        .open()?)
}

/// Peak resident memory of this process in MiB (Linux), if known.
pub(crate) fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Whether an error is a write to a closed pipe.
pub(crate) fn is_closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Errors caused by what the user gave us (exit code 2), as opposed to internal failures (1):
/// the service's classification ([`api::error::is_caller_error`]) of each error in the chain,
/// and the CLI's own usage errors.
pub(crate) fn is_input_error(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<UsageError>().is_some() || api::error::is_caller_error(c) == Some(true)
    })
}

/// Shortens a rendered cell for the table view; line breaks, tabs and other control
/// characters are shown escaped (`\r`, `\n`, `\t`, `\u{1}`) so that a row stays one line.
pub(crate) fn cell(text: String) -> String {
    const MAX: usize = 60;
    let text = if text.chars().any(char::is_control) {
        text.chars()
            .map(|c| match c {
                '\r' => "\\r".to_string(),
                '\n' => "\\n".to_string(),
                '\t' => "\\t".to_string(),
                c if c.is_control() => c.escape_unicode().to_string(),
                c => c.to_string(),
            })
            .collect()
    } else {
        text
    };
    if text.chars().count() <= MAX {
        text
    } else {
        let mut t: String = text.chars().take(MAX - 1).collect();
        t.push('…');
        t
    }
}

/// A problem with the arguments that clap cannot see.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub(crate) struct UsageError(pub(crate) String);

pub(crate) fn sim_summary(r: &ingest::sources::sim::SimReport) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "city: {:.0} m of road; junctions: {}",
        r.road_length_m,
        r.junctions
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        s,
        "objects: {} ({})",
        r.object_count,
        r.objects
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    if r.movers.cars + r.movers.walkers > 0 {
        let _ = writeln!(
            s,
            "moving: {} cars, {} walkers (ground_truth/movers.json; LiDAR labels 252, 254)",
            r.movers.cars, r.movers.walkers
        );
    }
    let _ = writeln!(
        s,
        "drive: {} poses at 10 Hz over {:.0} m; {} sensor frames, {} LiDAR points, {} detections ({} visible objects missed on purpose)",
        r.poses, r.drive_length_m, r.frames, r.lidar_points, r.detections, r.missed
    );
    let _ = writeln!(
        s,
        "time: scene {:.2} s, sensors {:.1} s; written to {}",
        r.scene_secs,
        r.sensor_secs,
        r.out.display()
    );
    s
}

pub(crate) fn build_summary(r: &ingest::build::BuildReport, rss_mib: Option<f64>) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "key frames: {} ({} this run{}), detections from {}: {} ({} dropped: no points; {} more not mapped: mostly points the dynamic filter removed, a moving thing), non-finite points dropped: {}",
        r.frames_total,
        r.frames_run,
        r.resumed_at
            .map(|f| format!(", resumed at frame {f}"))
            .unwrap_or_default(),
        r.source,
        r.detections,
        r.detections_dropped,
        r.detections_moving,
        r.nonfinite_points
    );
    if r.scans_without_input > 0 {
        let _ = writeln!(
            s,
            "note: {} scan(s) have no {} and were not mapped",
            r.scans_without_input,
            if r.source == "oracle" {
                "labels"
            } else {
                "detections file"
            }
        );
    }
    let total: usize = r.instances_per_class.values().sum();
    let _ = writeln!(s, "instances: {total}");
    for (c, n) in &r.instances_per_class {
        let _ = writeln!(s, "  {c:<14} {n}");
    }
    let _ = writeln!(
        s,
        "post-processing: {} dropped, {} merged, {} points denoised",
        r.post.dropped.len(),
        r.post.merged.len(),
        r.post.denoised_points
    );
    let d = &r.dynamic;
    let mut line = format!("dynamic points: {}", d.filter);
    if d.key_scans > 0 {
        line.push_str(&format!(
            ", {:.1} neighbouring scans per key scan",
            d.neighbour_scans as f64 / d.key_scans as f64
        ));
    }
    if d.points > 0 {
        line.push_str(&format!(
            ": removed {} of {} key-scan points ({:.2} %)",
            d.removed,
            d.points,
            100.0 * d.removed as f64 / d.points as f64
        ));
    }
    if d.moving_points + d.static_points > 0 {
        line.push_str(&format!(
            "; against the labels: {:.1} % of {} moving points and {:.2} % of {} static points removed",
            100.0 * d.moving_share(),
            d.moving_points,
            100.0 * d.static_share(),
            d.static_points
        ));
    }
    let _ = writeln!(s, "{line}");
    let stages: Vec<String> = r
        .ms_per_frame
        .iter()
        .map(|(k, v)| format!("{k} {v:.1}"))
        .collect();
    let _ = writeln!(s, "ms per key frame: {}", stages.join(", "));
    if let Some(h) = &r.hierarchy {
        let lanes: Vec<String> = h
            .lane_nodes
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect();
        let _ = writeln!(
            s,
            "hierarchy: lane nodes {}, {} lane edges, {} instances linked to segments; drivable area measured from the map: {}",
            lanes.join(", "),
            h.lane_edges,
            h.instances_linked,
            if h.drivable_m2 > 0.0 {
                format!(
                    "{:.0} m² in {} segments",
                    h.drivable_m2, h.drivable_segments
                )
            } else {
                "none (no points of the drivable classes, or [hierarchy.drivable] off)".into()
            }
        );
        if let Some(g) = h
            .trajectory_gaps
            .iter()
            .max_by(|a, b| a.distance_m.total_cmp(&b.distance_m))
        {
            let _ = writeln!(
                s,
                "trajectory split at {} gap(s) in the recording (largest {:.0} m after pose {}); no lane edge crosses one",
                h.trajectory_gaps.len(),
                g.distance_m,
                g.after_pose
            );
        }
    }
    if let Some(m) = rss_mib {
        let _ = writeln!(s, "peak RSS: {m:.0} MiB");
    }
    s
}
