//! `opengraph replay`: a KITTI-layout sequence published on rmw_zenoh keys
//! ([`og_zenoh::replay`]).

use super::args::*;
use super::common::*;

/// `opengraph replay`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Replay {
        kitti,
        detections,
        frames,
        rate,
        config,
        wait_secs,
        session,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Replay here")
    };
    let build = match &config {
        Some(p) => {
            ingest::build::BuildConfig::from_toml_file(p).map_err(|e| UsageError(e.to_string()))?
        }
        None => ingest::build::BuildConfig::default(),
    };
    let mut live = build.live.clone();
    if live.cam_from_velo.is_empty() {
        // the replay itself does not need the calibration; the server does (--calib)
        live.cam_from_velo = vec![1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    }
    if !kitti.join("velodyne").is_dir() {
        return Err(UsageError(format!(
            "{}: not a KITTI-layout sequence (no velodyne/ folder)",
            kitti.display()
        ))
        .into());
    }
    let args = og_zenoh::replay::ReplayArgs {
        sequence: kitti,
        detections,
        frames,
        rate,
        live,
        image_size: build.mapping.image_size,
        wait_secs,
    };
    let z = session.open_client()?;
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] frame {msg}")
            .expect("valid template"),
    );
    let r = og_zenoh::replay::replay(&z, &args, &mut |i| bar.set_message(i.to_string()));
    bar.finish_and_clear();
    let r = r.map_err(|e| match e {
        og_zenoh::Error::Ingest(i) => anyhow::Error::from(i),
        og_zenoh::Error::File { .. } | og_zenoh::Error::Config(_) => {
            UsageError(e.to_string()).into()
        }
        other => other.into(),
    })?;
    use zenoh::Wait;
    let _ = z.close().wait();
    if json {
        outln!("{}", serde_json::to_string(&r)?);
    } else {
        outln!(
            "published {} poses and {} clouds ({:.1} MB) in {:.1} s",
            r.poses,
            r.clouds,
            r.bytes as f64 / 1e6,
            r.secs
        );
    }
    Ok(())
}
