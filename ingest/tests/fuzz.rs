//! Time-boxed fuzz targets (`og-fuzz`; `OG_FUZZ_SECS=600 cargo test -p ingest --test fuzz --
//! --nocapture` runs each for ten minutes) for every reader of user files: KITTI calibration,
//! poses, times, scans and labels, the detections JSON, COCO RLE strings and the build's
//! TOML configuration. Each must answer an error or a value, never panic; a panicking input
//! is saved under `tests/fuzz-regressions/TARGET/` and replayed on every run once committed.

use std::path::{Path, PathBuf};

use ingest::sources::detections::read_detections;
use ingest::sources::kitti::{read_calib, read_labels, read_poses, read_scan, read_times};
use ingest::sources::rle::Rle;

fn regressions() -> &'static Path {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fuzz-regressions"
    ))
}

/// Runs `read` on each input written to one scratch file.
fn file_target(name: &str, seeds: &[&[u8]], read: impl Fn(&Path)) {
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = dir.path().join(name);
    let seeds: Vec<Vec<u8>> = seeds.iter().map(|s| s.to_vec()).collect();
    og_fuzz::fuzz(name, &seeds, regressions(), |bytes| {
        std::fs::write(&path, bytes).unwrap();
        read(&path);
    });
}

const P: &str = "P0: 7.1e2 0 6.0e2 0 0 7.1e2 1.8e2 0 0 0 1 0\nP1: 7.1e2 0 6.0e2 -3.8e2 0 7.1e2 1.8e2 0 0 0 1 0\nP2: 7.1e2 0 6.0e2 4.5e1 0 7.1e2 1.8e2 -3.4e-1 0 0 1 4.9e-3\nP3: 7.1e2 0 6.0e2 -3.3e2 0 7.1e2 1.8e2 2.3 0 0 1 3.3e-3\n";

#[test]
fn fuzz_kitti_calibration() {
    let odometry = format!(
        "{P}Tr: 4.2e-4 -9.9e-1 -7.2e-3 -1.1e-2 -7.2e-3 8.1e-3 -9.9e-1 -5.4e-2 9.9e-1 4.7e-4 -7.2e-3 -2.9e-1\n"
    );
    let object = format!(
        "{P}R0_rect: 1 0.01 0 -0.01 1 0 0 0 1\nTr_velo_to_cam: 0 -1 0 0 0 0 -1 -0.08 1 0 0 -0.27\nTr_imu_to_velo: 1 0 0 -0.8 0 1 0 0.3 0 0 1 -0.7\n"
    );
    file_target("calib", &[odometry.as_bytes(), object.as_bytes()], |p| {
        let _ = read_calib(p);
    });
}

#[test]
fn fuzz_kitti_poses_and_times() {
    let poses = b"1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0.5 0 1 0 -0.01 0 0 1 1.2\n9.99e-1 1e-3 0 2 0 1 0 0 -1e-3 0 9.99e-1 2.4\n";
    file_target("poses", &[poses], |p| {
        let _ = read_poses(p);
    });
    file_target(
        "times",
        &[b"0.000000e+00\n1.036400e-01\n2.072700e-01\n"],
        |p| {
            let _ = read_times(p);
        },
    );
}

#[test]
fn fuzz_kitti_scans_and_labels() {
    let points: Vec<u8> = [
        [1.5f32, -2.0, 0.3, 0.9],
        [10.0, 4.0, -1.7, 0.1],
        [f32::NAN, 0.0, 0.0, 0.0],
    ]
    .iter()
    .flatten()
    .flat_map(|f| f.to_le_bytes())
    .collect();
    file_target("scan", &[&points], |p| {
        let _ = read_scan(p);
    });
    let labels: Vec<u8> = [40u32, 10 | (3 << 16), 252]
        .iter()
        .flat_map(|l| l.to_le_bytes())
        .collect();
    file_target("labels", &[&labels], |p| {
        // the number of points the labels must match: 3, or what the bytes say
        let _ = read_labels(p, 3);
        let n = std::fs::metadata(p)
            .map(|m| m.len() as usize / 4)
            .unwrap_or(0);
        let _ = read_labels(p, n);
    });
}

#[test]
fn fuzz_detections_json() {
    let frame = br#"{"format": "opengraph-detections", "version": 1, "frame": 3,
  "image": {"width": 8, "height": 4}, "producer": "detector",
  "detections": [
    {"mask": {"size": [4, 8], "counts": [5, 3, 24]}, "bbox": [1, 1, 1, 3], "score": 0.9,
     "tags": ["bench"], "caption": "a green bench", "feature": [0.1, -0.2]},
    {"mask": {"size": [4, 8], "counts": "52`0"}, "bbox": [0, 0, 2, 2], "score": 0.5, "caption": "a car"}
  ]}"#;
    file_target("detections", &[frame], |p| {
        let _ = read_detections(p);
    });
}

#[test]
fn fuzz_coco_rle_strings() {
    let seeds: Vec<Vec<u8>> = [&b"52`0"[..], b"hn]3T3c8", b"0", b"", b"o1O1000"]
        .iter()
        .map(|s| s.to_vec())
        .collect();
    og_fuzz::fuzz("rle", &seeds, regressions(), |bytes| {
        let text = String::from_utf8_lossy(bytes);
        for (h, w) in [(4, 8), (375, 1242), (1, 1)] {
            if let Ok(r) = Rle::from_coco_string(h, w, &text) {
                // what decodes validates and round-trips
                assert!(r.validate().is_ok(), "{text:?}");
            }
        }
    });
}

#[test]
fn fuzz_build_config_toml() {
    let toml = br#"[mapping]
voxel_m = 0.1
dbscan_eps_m = 0.5
accumulate = 3

[oracle]
component_eps_m = 0.8

[hierarchy.lanes]
radius_m = 20.0
association_m = 20.0
gap_m = 40.0

[hierarchy.relations]
near_m = 3.0
next_to_m = 1.0

[llm]
timeout_secs = 30
"#;
    file_target("config.toml", &[toml], |p| {
        let _ = ingest::build::BuildConfig::from_toml_file(p);
    });
}
