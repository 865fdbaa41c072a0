//! The KITTI 3D-object calibration layout (`P2`, `R0_rect`, `Tr_velo_to_cam`) projects like the
//! devkit: on frame 000008 of `../shared/data/kitti-object` (skipped with a message when it is
//! absent), every point of the scan lands on the pixel that the dataset's own `lidar2img2 =
//! P2 · R0_rect · Tr_velo_to_cam` gives. The calibration is written in KITTI's text layout
//! into a temporary folder at test time, from the JSON there.

use std::path::Path;

use ingest::mapping::project::Camera;
use ingest::sources::kitti::{read_calib, read_scan};

fn rows(v: &serde_json::Value, n_rows: usize, n_cols: usize) -> Vec<f64> {
    (0..n_rows)
        .flat_map(|r| (0..n_cols).map(move |c| (r, c)))
        .map(|(r, c)| v[r][c].as_f64().unwrap())
        .collect()
}

/// A velodyne point through a row-major 3x4 projection: (u, v) in pixels and the depth.
fn project(m: &[f64], p: &[f32; 4]) -> (f64, f64, f64) {
    let q = [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])];
    let row = |r: usize| m[4 * r] * q[0] + m[4 * r + 1] * q[1] + m[4 * r + 2] * q[2] + m[4 * r + 3];
    let depth = row(2);
    (row(0) / depth, row(1) / depth, depth)
}

fn line(key: &str, v: &[f64]) -> String {
    let nums: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
    format!("{key}: {}\n", nums.join(" "))
}

#[test]
fn object_calibration_projects_like_the_devkit() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/kitti-object");
    let Ok(text) = std::fs::read_to_string(dir.join("000008.calib.json")) else {
        eprintln!("skipping: ../shared/data/kitti-object is absent");
        return;
    };
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    let p2 = rows(&j["P2"], 3, 4);
    let r0 = rows(&j["R0_rect"], 3, 3);
    let tr = rows(&j["Tr_velo_to_cam"], 3, 4);
    let identity = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let tmp = tempfile::tempdir().unwrap();
    let calib = tmp.path().join("calib.txt");
    std::fs::write(
        &calib,
        [
            line("P0", &identity),
            line("P1", &identity),
            line("P2", &p2),
            line("P3", &identity),
            line("R0_rect", &r0),
            line("Tr_velo_to_cam", &tr),
            line("Tr_imu_to_velo", &identity),
        ]
        .concat(),
    )
    .unwrap();
    let k = read_calib(&calib).unwrap();
    let size = &j["image_size"];
    let (w, h) = (
        size[0].as_u64().unwrap() as u32,
        size[1].as_u64().unwrap() as u32,
    );
    let cam = Camera::kitti_p2(&k, w, h);
    let want = rows(&j["lidar2img2"], 3, 4);
    let scan = read_scan(&dir.join("000008.bin")).unwrap();
    let ours = scene::pose::matrix_row_major(&cam.image_from_velo);
    let mut worst: f64 = 0.0;
    let mut n = 0;
    for p in &scan.points {
        let (u0, v0, depth) = project(&want, p);
        if depth < 0.5 {
            continue;
        }
        let (u, v, _) = project(&ours, p);
        worst = worst.max((u - u0).hypot(v - v0));
        n += 1;
    }
    assert!(n > 17_000, "{n} points in front of the camera");
    // the JSON's matrices are float32: a hundredth of a pixel
    assert!(worst < 0.01, "worst pixel error {worst}");
    // reading Tr_velo_to_cam as if it were the odometry Tr (no R0_rect) is off by pixels
    let odometry_like = tmp.path().join("calib_odo.txt");
    std::fs::write(
        &odometry_like,
        [
            line("P0", &identity),
            line("P1", &identity),
            line("P2", &p2),
            line("P3", &identity),
            line("Tr", &tr),
        ]
        .concat(),
    )
    .unwrap();
    let wrong = Camera::kitti_p2(&read_calib(&odometry_like).unwrap(), w, h);
    let p = &scan.points[scan.points.len() / 2];
    let ((u, v, _), (u0, v0, _)) = (
        project(&scene::pose::matrix_row_major(&wrong.image_from_velo), p),
        project(&want, p),
    );
    let off = (u - u0).hypot(v - v0);
    assert!(off > 1.0, "without R0_rect a point is {off} px off");
}
