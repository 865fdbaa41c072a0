//! The real KITTI seq-00 scans and labels: sizes, label ids, and the pose chain
//! `world_from_velo = pose × Tr` (consecutive scans overlap in the world frame, as
//! ../shared/data/README.md states).

use ingest::cluster::Grid2;
use ingest::sources::kitti::{read_calib, read_labels, read_poses, read_scan};

#[test]
fn scans_labels_and_world_from_velo() {
    let Some(data) = opengraph_tests::shared_data() else {
        eprintln!("skipping: ../shared/data is absent");
        return;
    };
    let seq = data.join("kitti/sequences/00");
    let poses = read_poses(&seq.join("poses.txt")).unwrap();
    let calib = read_calib(&seq.join("calib.txt")).unwrap();
    let yaml = std::fs::read_to_string(data.join("kitti/semantic-kitti.yaml")).unwrap();
    // the raw ids under `labels:` (lines like "  10: \"car\"")
    let known: std::collections::BTreeSet<u16> = yaml
        .split("\ncolor_map:")
        .next()
        .unwrap()
        .lines()
        .filter_map(|l| {
            l.trim()
                .split_once(':')
                .and_then(|(k, _)| k.trim().parse().ok())
        })
        .collect();
    assert!(
        known.contains(&10) && known.contains(&40),
        "car and road are labelled classes"
    );
    let mut counts = Vec::new();
    for f in 0..3 {
        let scan = read_scan(&seq.join(format!("velodyne/{f:06}.bin"))).unwrap();
        let labels =
            read_labels(&seq.join(format!("labels/{f:06}.label")), scan.points.len()).unwrap();
        assert!(
            labels.iter().all(|l| known.contains(&l.semantic)),
            "frame {f}: unknown semantic id"
        );
        counts.push(scan.points.len());
    }
    assert_eq!(counts, vec![124668, 124605, 124478]);
    // world_from_velo = pose x Tr: scan 1's points land on scan 0's (median a few cm);
    // ground points (z < -1.4 m in the velodyne frame) are left out, as in the README's check
    let points = |f: usize| -> Vec<[f64; 3]> {
        read_scan(&seq.join(format!("velodyne/{f:06}.bin")))
            .unwrap()
            .points
            .iter()
            .filter(|p| p[2] > -1.4 && (p[0] * p[0] + p[1] * p[1]).sqrt() < 40.0)
            .map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])])
            .collect()
    };
    let world_from_velo = |f: usize| poses[f] * calib.cam0_from_velo;
    let a: Vec<[f64; 3]> = points(0)
        .iter()
        .map(|p| scene::pose::apply(&world_from_velo(0), *p))
        .collect();
    let a2: Vec<[f64; 2]> = a.iter().map(|p| [p[0], p[2]]).collect();
    let grid = Grid2::new(&a2, 2.0);
    let scan1 = points(1);
    // median distance from scan 1 (moved by `t`) to scan 0; 2 m when nothing is near
    let median_under = |t: &ingest::sources::kitti::Rigid3| -> f64 {
        let mut d: Vec<f64> = scan1
            .iter()
            .step_by(50)
            .map(|p| {
                let q = scene::pose::apply(t, *p);
                grid.within(&a2, [q[0], q[2]], 2.0)
                    .into_iter()
                    .map(|j| {
                        ((a[j][0] - q[0]).powi(2)
                            + (a[j][1] - q[1]).powi(2)
                            + (a[j][2] - q[2]).powi(2))
                        .sqrt()
                    })
                    .fold(2.0, f64::min)
            })
            .collect();
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    let right = median_under(&world_from_velo(1));
    let wrong = median_under(&(calib.cam0_from_velo * poses[1]));
    eprintln!(
        "scan 1 -> scan 0 in the world frame: median nearest distance {right:.3} m (pose x Tr), {wrong:.3} m (Tr x pose)"
    );
    assert!(
        right < 0.15,
        "median {right} m: pose x Tr does not align the scans"
    );
    // frames 0 and 1 are about a metre apart, so even the wrong chain lands nearby: it must
    // still be clearly worse for the check to mean anything
    assert!(
        wrong > 4.0 * right,
        "the reversed composition aligns as well ({wrong} m vs {right} m)"
    );
}
