//! `opengraph import`: the service's import operation with a progress bar.

use opengraph_service::import::{ImportRequest, ImportSchema};

use super::args::*;

/// `opengraph import`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Import {
        db,
        folder,
        nodes,
        relationships,
        node_link,
        default_type,
        schema,
        batch_rows,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Import here")
    };
    let req = ImportRequest {
        db,
        folder,
        nodes,
        relationships,
        node_link,
        default_type,
        schema: if schema == "opengraph" {
            ImportSchema::Opengraph
        } else {
            ImportSchema::None
        },
        batch_rows,
    };
    let req_node_link = req.node_link.is_some();
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template(if req_node_link {
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} nodes and edges"
        } else {
            "{spinner} [{elapsed_precise}] {bar:40} {bytes}/{total_bytes} {bytes_per_sec}"
        })
        .expect("valid template"),
    );
    let answer = opengraph_service::import::import(&req, &mut |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    });
    bar.finish_and_clear();
    let a = answer?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&a)?);
    } else {
        outln!(
            "imported {} nodes and {} relationships into {} in {:.2} s ({} commits; node ids {}; store {:.1} MB from {:.1} MB of {})",
            a.nodes,
            a.relationships,
            a.db.display(),
            a.duration_secs,
            a.batches,
            if a.ids_kept { "kept" } else { "new" },
            a.store_bytes as f64 / 1e6,
            a.input_bytes as f64 / 1e6,
            if req_node_link {
                "node-link JSON"
            } else {
                "CSV"
            }
        );
    }
    Ok(())
}
