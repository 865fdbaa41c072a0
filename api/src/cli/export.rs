//! `opengraph export`: the service's export operation to a file, stdout or a folder.

use anyhow::Context;
use opengraph_service::export::{
    EdgesKey, ExportFormat, ExportRequest, ExportTarget, PlyColouring,
};

use super::args::*;
use super::common::*;

/// `opengraph export`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Export {
        db,
        format,
        out,
        edges_key,
        colour,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Export here")
    };
    let format: ExportFormat = format.parse()?;
    let to_stdout = out.as_os_str() == "-";
    // the output is checked before the map is opened, so a long export never fails at the end
    if out.is_dir() && !format.is_folder() {
        return Err(UsageError(format!(
            "--out: {} is a folder; {} writes one file",
            out.display(),
            format.name()
        ))
        .into());
    }
    let store = open_read(&db)?;
    let req = ExportRequest {
        format,
        edges_key: if edges_key == "links" {
            EdgesKey::Links
        } else {
            EdgesKey::Edges
        },
        colour: if colour == "instance" {
            PlyColouring::Instance
        } else {
            PlyColouring::Class
        },
    };
    let r = store.read()?;
    let answer = if format.is_folder() && !to_stdout {
        opengraph_service::export::export(&r, &req, ExportTarget::Folder(&out))?
    } else {
        // `-` is stdout
        let sink: Box<dyn std::io::Write> = if to_stdout {
            Box::new(std::io::stdout().lock())
        } else {
            Box::new(
                std::fs::File::create(&out)
                    .with_context(|| format!("creating {}", out.display()))?,
            )
        };
        let mut w = std::io::BufWriter::new(PipeWatch {
            inner: sink,
            broken: false,
        });
        let a = opengraph_service::export::export(&r, &req, ExportTarget::Writer(&mut w));
        use std::io::Write;
        let flushed = w.flush();
        // a reader that went away (`| head`) ends the export quietly, as for every command
        if w.get_ref().broken {
            return Err(std::io::Error::from(std::io::ErrorKind::BrokenPipe).into());
        }
        flushed.with_context(|| format!("writing {}", out.display()))?;
        a?
    };
    if json {
        outln!("{}", serde_json::to_string_pretty(&answer)?);
    }
    let what = match (format, answer.points) {
        (_, Some(p)) => format!("{p} points of {} instances", answer.nodes),
        (ExportFormat::Geojson, _) => format!("{} features", answer.nodes),
        _ => format!(
            "{} nodes and {} relationships",
            answer.nodes, answer.relationships
        ),
    };
    errln!(
        "exported {what} as {} to {} ({}; {:.0} ms)",
        format.name(),
        out.display(),
        answer.frame,
        answer.time_ms
    );
    Ok(())
}

/// A writer that notes whether its reader went away (a closed pipe).
struct PipeWatch<W> {
    inner: W,
    broken: bool,
}

impl<W: std::io::Write> std::io::Write for PipeWatch<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let r = self.inner.write(buf);
        self.broken |= r
            .as_ref()
            .is_err_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe);
        r
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let r = self.inner.flush();
        self.broken |= r
            .as_ref()
            .is_err_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe);
        r
    }
}
