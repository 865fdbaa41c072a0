//! `opengraph oracle`.

use anyhow::Context;

use super::args::*;

/// `opengraph oracle`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Oracle { kitti, out, frames } = cmd else {
        unreachable!("run dispatches only Command::Oracle here")
    };
    use ingest::build::{Sequence, Source, key_frames};
    let seq = Sequence::open(&kitti, None)?;
    let list = key_frames(&seq, &Source::Oracle, frames.as_ref(), 1)?;
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let cfg = ingest::sources::oracle::OracleConfig::default();
    let mut n = 0;
    let image_size = ingest::mapping::MappingConfig::default().image_size;
    for i in &list {
        let scan = ingest::sources::kitti::read_scan(&seq.scan_path(*i))?;
        let cam = seq.camera(*i, image_size)?;
        let d = seq.oracle(*i, &scan, &cam, &cfg)?;
        n += d.detections.len();
        ingest::sources::detections::write_detections(&out.join(format!("{i:06}.json")), &d)?;
    }
    outln!(
        "wrote {} oracle detections for {} frames to {}",
        n,
        list.len(),
        out.display()
    );
    Ok(())
}
