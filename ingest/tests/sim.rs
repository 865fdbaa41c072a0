//! The simulator's output: determinism, LiDAR sanity, labels against the ground-truth boxes,
//! camera masks against LiDAR labels, and the junctions lane extraction finds on its drive.

use std::collections::BTreeMap;
use std::path::Path;

use ingest::build::Sequence;
use ingest::hierarchy::lanes::{LaneConfig, LaneNodeKind, extract_lanes};
use ingest::mapping::project::Camera;
use ingest::sources::detections::read_detections;
use ingest::sources::kitti::{read_labels, read_scan};
use ingest::sources::sim::roads::SimSize;
use ingest::sources::sim::sensors::DetectionNoise;
use ingest::sources::sim::{SimConfig, generate};
use serde_json::Value as Json;

fn sim(dir: &Path, frames: usize, threads: usize, noise: DetectionNoise) {
    let cfg = SimConfig {
        seed: 7,
        size: SimSize::Small,
        frames: Some(frames),
        noise,
        threads,
        ..SimConfig::default()
    };
    generate(dir, &cfg, &|_, _| {}).expect("sim");
}

fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

#[test]
fn output_is_byte_identical_for_a_seed_whatever_the_thread_count() {
    let (a, b, c) = (
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
    );
    sim(a.path(), 4, 1, DetectionNoise::default());
    sim(b.path(), 4, 2, DetectionNoise::default());
    let (fa, fb) = (files(a.path()), files(b.path()));
    assert!(fa.len() >= 4 * 3 + 7, "{:?}", fa.keys().collect::<Vec<_>>());
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>());
    for (k, v) in &fa {
        assert!(v == &fb[k], "{k} differs");
    }
    // another seed gives another city
    let cfg = SimConfig {
        seed: 8,
        frames: Some(1),
        ..SimConfig::default()
    };
    generate(c.path(), &cfg, &|_, _| {}).unwrap();
    assert_ne!(
        std::fs::read(a.path().join("ground_truth/roads.json")).unwrap(),
        std::fs::read(c.path().join("ground_truth/roads.json")).unwrap()
    );
    // generating into a directory that already holds a sequence is refused
    let err = generate(a.path(), &cfg, &|_, _| {}).unwrap_err();
    assert!(
        err.to_string().contains("already holds a sequence"),
        "{err}"
    );
}

struct GtBox {
    center: [f64; 3],
    size: [f64; 3],
    yaw: f64,
    class: String,
}

fn gt_objects(dir: &Path) -> BTreeMap<u32, GtBox> {
    let v: Json =
        serde_json::from_slice(&std::fs::read(dir.join("ground_truth/objects.json")).unwrap())
            .unwrap();
    let f = |x: &Json| x.as_f64().unwrap();
    v["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| {
            let b = &o["box"];
            let c = b["center"].as_array().unwrap();
            let s = b["size"].as_array().unwrap();
            (
                o["id"].as_u64().unwrap() as u32,
                GtBox {
                    center: [f(&c[0]), f(&c[1]), f(&c[2])],
                    size: [f(&s[0]), f(&s[1]), f(&s[2])],
                    yaw: f(&b["yaw_rad"]),
                    class: o["class"].as_str().unwrap().to_string(),
                },
            )
        })
        .collect()
}

impl GtBox {
    /// Whether world point `p` is inside the box grown by `margin_m`.
    fn contains(&self, p: [f64; 3], margin_m: f64) -> bool {
        let d = [
            p[0] - self.center[0],
            p[1] - self.center[1],
            p[2] - self.center[2],
        ];
        let (s, c) = self.yaw.sin_cos();
        // local x = (cos, -sin), local z = (sin, cos) in [x, z]
        let lx = d[0] * c - d[2] * s;
        let lz = d[0] * s + d[2] * c;
        lx.abs() <= self.size[0] / 2.0 + margin_m
            && d[1].abs() <= self.size[1] / 2.0 + margin_m
            && lz.abs() <= self.size[2] / 2.0 + margin_m
    }
}

#[test]
fn lidar_scans_look_like_an_hdl64_and_labels_match_what_each_ray_hit() {
    let dir = tempfile::tempdir().unwrap();
    sim(dir.path(), 3, 2, DetectionNoise::default());
    let seq = Sequence::open(dir.path(), None).unwrap();
    assert_eq!(seq.scans.len(), 3);
    let gt = gt_objects(dir.path());
    for &f in &seq.scans {
        let scan = read_scan(&seq.scan_path(f)).unwrap();
        let labels = read_labels(&seq.label_path(f), scan.points.len()).unwrap();
        let n = scan.points.len();
        // 64 beams x 2118 columns = 135,552 rays; in a city nearly all of them hit
        assert!((90_000..=135_552).contains(&n), "frame {f}: {n} points");
        let mut ranges: Vec<f32> = scan
            .points
            .iter()
            .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
            .collect();
        ranges.sort_by(f32::total_cmp);
        let q = |x: f64| ranges[((ranges.len() - 1) as f64 * x) as usize];
        eprintln!(
            "frame {f}: {n} points, range p5 {:.1} m, median {:.1} m, p95 {:.1} m",
            q(0.05),
            q(0.5),
            q(0.95)
        );
        assert!(q(0.0) > 1.0 && q(1.0) <= 120.2, "{} {}", q(0.0), q(1.0));
        assert!(q(0.5) > 4.0 && q(0.5) < 40.0, "median {}", q(0.5));
        let world_from_velo = seq.world_from_velo(f);
        let (mut ground, mut ground_ok, mut obj, mut obj_ok) = (0, 0, 0, 0);
        for (p, l) in scan.points.iter().zip(&labels) {
            let w = scene::pose::apply(
                &world_from_velo,
                [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])],
            );
            if l.instance == 0 {
                assert!(matches!(l.semantic, 40 | 44 | 48 | 72), "{}", l.semantic);
                ground += 1;
                // the ground is y = 0 (2 cm range noise)
                if w[1].abs() < 0.1 {
                    ground_ok += 1;
                }
            } else {
                obj += 1;
                let b = &gt[&u32::from(l.instance)];
                if b.contains(w, 0.1) {
                    obj_ok += 1;
                }
            }
        }
        assert!(
            ground > n / 5 && obj > n / 10,
            "{ground} ground, {obj} object points"
        );
        assert!(
            ground_ok as f64 > 0.99 * ground as f64,
            "{ground_ok}/{ground}"
        );
        assert!(obj_ok as f64 > 0.99 * obj as f64, "{obj_ok}/{obj}");
    }
    // every ground-truth class of the 19 that the city has shows up in the labels
    assert!(gt.values().any(|b| b.class == "bus stop shelter"));
}

#[test]
fn camera_masks_agree_with_lidar_labels() {
    let dir = tempfile::tempdir().unwrap();
    sim(dir.path(), 3, 2, DetectionNoise::none());
    let seq = Sequence::open(dir.path(), None).unwrap();
    let truth: Vec<Json> =
        std::fs::read_to_string(dir.path().join("ground_truth/detections.jsonl"))
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
    let (mut inside, mut agree, mut objects_checked, mut objects_ok) = (0u64, 0u64, 0, 0);
    for (k, &f) in seq.scans.iter().enumerate() {
        let det = read_detections(&dir.path().join(format!("detections/{f:06}.json"))).unwrap();
        assert_eq!(det.producer.as_str(), "simulator");
        let t = &truth[k];
        assert_eq!(t["frame"].as_u64(), Some(u64::from(f)));
        let scan = read_scan(&seq.scan_path(f)).unwrap();
        let labels = read_labels(&seq.label_path(f), scan.points.len()).unwrap();
        let cam = Camera::kitti_p2(&seq.calib, det.width, det.height);
        let masks: Vec<(Option<u64>, Vec<bool>)> = det
            .detections
            .iter()
            .zip(t["detections"].as_array().unwrap())
            .map(|(d, t)| (t["object"].as_u64(), d.mask.to_mask().unwrap()))
            .collect();
        let mut per_object: BTreeMap<u64, (u32, u32)> = BTreeMap::new();
        for (p, l) in scan.points.iter().zip(&labels) {
            let Some((x, y, _)) = cam.project([p[0], p[1], p[2]]) else {
                continue;
            };
            let px = (y * det.width + x) as usize;
            for (obj, m) in &masks {
                let Some(obj) = obj else { continue };
                if m[px] {
                    inside += 1;
                    if u64::from(l.instance) == *obj {
                        agree += 1;
                    }
                }
            }
            if l.instance != 0 {
                let e = per_object.entry(u64::from(l.instance)).or_default();
                e.0 += 1;
                if masks
                    .iter()
                    .any(|(o, m)| *o == Some(u64::from(l.instance)) && m[px])
                {
                    e.1 += 1;
                }
            }
        }
        // objects that were detected: most of their in-view LiDAR points fall in their mask
        for (obj, (n, hit)) in per_object {
            if n >= 30 && masks.iter().any(|(o, _)| *o == Some(obj)) {
                objects_checked += 1;
                if f64::from(hit) >= 0.7 * f64::from(n) {
                    objects_ok += 1;
                }
            }
        }
    }
    let rate = agree as f64 / inside as f64;
    eprintln!(
        "points in object masks with that object's label: {agree}/{inside} = {rate:.3}; \
         objects with >= 70% of their points in their mask: {objects_ok}/{objects_checked}"
    );
    assert!(inside > 1000, "{inside}");
    assert!(rate > 0.85, "{rate}");
    assert!(objects_checked > 10 && objects_ok as f64 >= 0.85 * objects_checked as f64);
}

#[test]
fn lane_extraction_on_the_written_poses_finds_the_true_junctions() {
    let dir = tempfile::tempdir().unwrap();
    sim(dir.path(), 1, 1, DetectionNoise::default());
    let seq = Sequence::open(dir.path(), None).unwrap();
    // the poses are 10 Hz over the whole drive even with one sensor frame
    assert!(seq.poses.len() > 1000, "{}", seq.poses.len());
    let traj: Vec<[f64; 2]> = seq.trajectory().iter().map(|p| [p[0], p[2]]).collect();
    let g = extract_lanes(&traj, &LaneConfig::default()).unwrap();
    let roads: Json =
        serde_json::from_slice(&std::fs::read(dir.path().join("ground_truth/roads.json")).unwrap())
            .unwrap();
    let (mut agree, mut total) = (0, 0);
    for j in roads["junctions"].as_array().unwrap() {
        let want = match j["kind"].as_str().unwrap() {
            "crossroads" => LaneNodeKind::Intersection,
            "t_junction" => LaneNodeKind::TIntersection,
            "l_bend" => LaneNodeKind::LIntersection,
            "dead_end" => LaneNodeKind::Breakpoint,
            _ => continue,
        };
        let pos = j["position"].as_array().unwrap();
        let p = [pos[0].as_f64().unwrap(), pos[1].as_f64().unwrap()];
        total += 1;
        let near = g
            .nodes
            .iter()
            .map(|m| ((m.xy[0] - p[0]).hypot(m.xy[1] - p[1]), m.kind))
            .filter(|(d, _)| *d < 15.0)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if near.map(|n| n.1) == Some(want) {
            agree += 1;
        }
    }
    eprintln!("junction agreement on the written poses: {agree}/{total}");
    assert!(
        total >= 8 && agree as f64 >= 0.75 * total as f64,
        "{agree}/{total}"
    );
}
