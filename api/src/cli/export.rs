//! `opengraph export`.

use anyhow::Context;

use super::args::*;
use super::common::*;

/// `opengraph export`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Export {
        db,
        format,
        out,
        edges_key,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Export here")
    };
    let store = open_read(&db)?;
    let fmt: graphstore::export::ExportFormat = format.parse()?;
    // `-` is stdout
    let sink: Box<dyn std::io::Write> = if out.as_os_str() == "-" {
        Box::new(std::io::stdout().lock())
    } else {
        Box::new(
            std::fs::File::create(&out).with_context(|| format!("creating {}", out.display()))?,
        )
    };
    let mut w = std::io::BufWriter::new(sink);
    let r = store.read()?;
    let (n, m) = match fmt {
        graphstore::export::ExportFormat::NodeLink => {
            graphstore::export::export_node_link(&r, &edges_key, &mut w)?
        }
        other => graphstore::export::export(&r, other, &mut w)?,
    };
    use std::io::Write;
    w.flush()
        .with_context(|| format!("writing {}", out.display()))?;
    errln!(
        "exported {n} nodes and {m} relationships to {}",
        out.display()
    );
    Ok(())
}
