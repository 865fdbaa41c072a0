//! The mapping back end's steps side by side with Open3D (PyPI `open3d` 0.20) on the exact
//! per-object inputs of real KITTI sequence-00 key frames, in one run, ratio printed.
//!
//! The reference implementation (ConceptGraphs-style, Python on Open3D and numpy) maps each
//! key frame's detections in four steps: voxel down-sample of the detection's points, DBSCAN
//! keeping the largest cluster (then the transform to the world), association to the map's
//! objects by 3D IoU of axis-aligned boxes plus feature cosine, greedy one-to-one (the caption
//! term of opengraph's φ left out, since the reference has none), and fusion
//! (the object's points plus the detection's, voxel down-sampled again; the feature a running
//! mean). This bench
//!
//! 1. runs the SemanticKITTI label oracle on frames 0-2 (the labelled ones) and writes every
//!    object detection's points inside its mask (velodyne frame), its feature (the hash
//!    embedder over its caption), the poses and the parameters to a folder;
//! 2. runs those four steps with this crate's code (`voxel_downsample`, `dbscan3`, `Aabb`,
//!    `phi`, `greedy_assign`) over that input, `--reps` times into a fresh map, and writes
//!    its outputs and times;
//! 3. runs `scripts/bench_open3d.py` (the same steps through Open3D and numpy, on one thread),
//!    which checks that the outputs agree and prints both times and the ratio.
//!
//! Open3D's voxel grid starts half a voxel below the cloud's minimum, ours at the origin; so
//! that both put the same points in the same voxels, our side shifts each cloud to Open3D's
//! grid before down-sampling and back after. Surfaces (road, sidewalk, terrain, ...) are
//! fused per ground tile by opengraph and are not among the objects here.
//!
//! `cargo bench -p ingest --bench open3d` (100 repetitions; without `--bench`, 3). Skips when
//! ../shared/data is absent; the Python side installs `open3d==0.20.0` into the project's venv
//! (`OPENGRAPH_VENV`, default `~/.cache/opengraph/venv`) when it is missing, and says so and
//! stops when it cannot. Set `OPENGRAPH_OPEN3D_DIR` to keep the exchanged files.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use ingest::mapping::MappingConfig;
use ingest::mapping::associate::{Weights, greedy_assign, phi};
use ingest::mapping::geometry::{Aabb, dbscan3, voxel_downsample};
use ingest::mapping::project::points_in_mask;
use llm_tools::embed::cosine;
use scene::classes;

mod common;

/// One object detection of one key frame: its points inside the mask (velodyne frame) and
/// its caption feature.
struct Det {
    points: Vec<[f32; 3]>,
    feature: Vec<f32>,
    class: u8,
}

struct Frame {
    index: u32,
    /// Row-major 4 × 4 world_from_velo.
    world_from_velo: [f64; 16],
    dets: Vec<Det>,
}

/// A map object of the reference steps.
struct Obj {
    points: Vec<[f32; 3]>,
    bbox: Aabb,
    feature: Vec<f32>,
    detections: u32,
}

/// Per-stage milliseconds of one key frame.
#[derive(Default, Clone, Copy)]
struct Times {
    voxel: f64,
    dbscan: f64,
    transform: f64,
    associate: f64,
    fuse: f64,
}

impl Times {
    fn total(&self) -> f64 {
        self.voxel + self.dbscan + self.transform + self.associate + self.fuse
    }
}

/// What one detection became in a run: voxels after the down-sample, points in its largest
/// cluster, and the object (index in creation order) it was fused into.
#[derive(Clone, serde::Serialize)]
struct DetOut {
    frame: u32,
    det: usize,
    voxels: usize,
    kept: usize,
    object: Option<usize>,
    matched: bool,
}

/// Open3D's `VoxelDownSample` with this crate's `voxel_downsample`: the grid starts half a
/// voxel below the cloud's minimum (Open3D's `voxel_min_bound`), so the cloud is shifted onto
/// our origin-based grid and back.
fn voxel_like_open3d(points: &[[f32; 3]], voxel_m: f32) -> Vec<[f32; 3]> {
    let Some(b) = Aabb::of(points) else {
        return Vec::new();
    };
    let o: [f64; 3] = b.min.map(|c| f64::from(c) - f64::from(voxel_m) / 2.0);
    let shifted: Vec<[f32; 3]> = points
        .iter()
        .map(|p| [0, 1, 2].map(|i| (f64::from(p[i]) - o[i]) as f32))
        .collect();
    voxel_downsample(&shifted, voxel_m)
        .into_iter()
        .map(|p| [0, 1, 2].map(|i| (f64::from(p[i]) + o[i]) as f32))
        .collect()
}

/// The largest DBSCAN cluster; ties go to the cluster holding the lexicographically smallest
/// point (an order both sides can compute whatever order their points come in).
fn largest_cluster(points: &[[f32; 3]], eps_m: f32, min_points: usize) -> Vec<[f32; 3]> {
    let labels = dbscan3(points, eps_m, min_points);
    let n = labels.iter().flatten().map(|c| c + 1).max().unwrap_or(0);
    let mut size = vec![0usize; n];
    let mut least: Vec<Option<[f32; 3]>> = vec![None; n];
    for (p, l) in points.iter().zip(&labels) {
        if let Some(c) = l {
            size[*c] += 1;
            let lex_less = |a: &[f32; 3], b: &[f32; 3]| {
                a.iter()
                    .zip(b)
                    .map(|(x, y)| x.total_cmp(y))
                    .find(|o| o.is_ne())
                    .is_some_and(|o| o.is_lt())
            };
            if least[*c].is_none_or(|q| lex_less(p, &q)) {
                least[*c] = Some(*p);
            }
        }
    }
    let best = (0..n).max_by(|&a, &b| {
        size[a].cmp(&size[b]).then_with(|| {
            let (pa, pb) = (least[a].unwrap_or_default(), least[b].unwrap_or_default());
            // smaller point wins the tie: compare reversed
            pb.iter()
                .zip(&pa)
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    });
    match best {
        Some(c) => points
            .iter()
            .zip(&labels)
            .filter(|(_, l)| **l == Some(c))
            .map(|(p, _)| *p)
            .collect(),
        None => Vec::new(),
    }
}

/// Maps the frames in order into a fresh map with the four reference steps; returns each
/// frame's stage times, what each detection became, and the objects.
fn run(frames: &[Frame], cfg: &MappingConfig) -> (Vec<Times>, Vec<DetOut>, Vec<Obj>) {
    let w = Weights {
        geo: cfg.w_geo,
        cap: 0.0,
        fea: cfg.w_fea,
    };
    let mut objects: Vec<Obj> = Vec::new();
    let mut times = Vec::new();
    let mut outs = Vec::new();
    for f in frames {
        let mut t = Times::default();
        let mut kept: Vec<(usize, Vec<[f32; 3]>, Aabb)> = Vec::new();
        for (k, d) in f.dets.iter().enumerate() {
            let s = Instant::now();
            let down = voxel_like_open3d(&d.points, cfg.voxel_m);
            t.voxel += ms(s);
            let s = Instant::now();
            let pts = largest_cluster(&down, cfg.dbscan_eps_m, cfg.dbscan_min_points);
            t.dbscan += ms(s);
            let s = Instant::now();
            let m = &f.world_from_velo;
            let world: Vec<[f32; 3]> = pts
                .iter()
                .map(|p| {
                    let [x, y, z] = p.map(f64::from);
                    [0, 4, 8].map(|r| (m[r] * x + m[r + 1] * y + m[r + 2] * z + m[r + 3]) as f32)
                })
                .collect();
            t.transform += ms(s);
            outs.push(DetOut {
                frame: f.index,
                det: k,
                voxels: down.len(),
                kept: world.len(),
                object: None,
                matched: false,
            });
            if let Some(b) = Aabb::of(&world) {
                kept.push((k, world, b));
            }
        }
        let s = Instant::now();
        let mut pairs = Vec::new();
        // as the mapper does: when φ cannot pass without overlap (w_fea <= δ_sim), a pair of
        // disjoint boxes is not scored
        let need_overlap = cfg.w_fea <= cfg.sim_threshold + 1e-9;
        for (slot, (k, _, b)) in kept.iter().enumerate() {
            for (j, o) in objects.iter().enumerate() {
                let iou = if o.bbox.intersects(b) {
                    o.bbox.iou(b)
                } else {
                    0.0
                };
                if iou <= 0.0 && need_overlap {
                    continue;
                }
                let fc = cosine(&f.dets[*k].feature, &o.feature);
                pairs.push((slot, j, phi(w, iou, 0.0, fc)));
            }
        }
        let assignment = greedy_assign(kept.len(), pairs, cfg.sim_threshold);
        t.associate += ms(s);
        let s = Instant::now();
        let base = outs.len() - f.dets.len();
        for ((k, world, b), a) in kept.into_iter().zip(assignment) {
            let feature = &f.dets[k].feature;
            let j = match a {
                Some(j) => {
                    let o = &mut objects[j];
                    let mut all = std::mem::take(&mut o.points);
                    all.extend_from_slice(&world);
                    o.points = voxel_like_open3d(&all, cfg.voxel_m);
                    o.bbox = Aabb::of(&o.points).unwrap_or(b);
                    let n = o.detections as f32;
                    for (x, y) in o.feature.iter_mut().zip(feature) {
                        *x = (*x * n + y) / (n + 1.0);
                    }
                    o.detections += 1;
                    j
                }
                None => {
                    objects.push(Obj {
                        points: world,
                        bbox: b,
                        feature: feature.clone(),
                        detections: 1,
                    });
                    objects.len() - 1
                }
            };
            outs[base + k].object = Some(j);
            outs[base + k].matched = a.is_some();
        }
        t.fuse += ms(s);
        times.push(t);
    }
    (times, outs, objects)
}

fn ms(s: Instant) -> f64 {
    s.elapsed().as_secs_f64() * 1e3
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn write_inputs(dir: &Path, frames: &[Frame], cfg: &MappingConfig) -> anyhow::Result<()> {
    let mut pts = std::io::BufWriter::new(std::fs::File::create(dir.join("points.f32"))?);
    let mut feats = std::io::BufWriter::new(std::fs::File::create(dir.join("features.f32"))?);
    let mut offset = 0usize;
    let mut jframes = Vec::new();
    for f in frames {
        let mut dets = Vec::new();
        for d in &f.dets {
            for p in &d.points {
                for c in p {
                    pts.write_all(&c.to_le_bytes())?;
                }
            }
            for c in &d.feature {
                feats.write_all(&c.to_le_bytes())?;
            }
            dets.push(serde_json::json!({
                "offset": offset, "count": d.points.len(), "class": d.class,
            }));
            offset += d.points.len();
        }
        jframes.push(serde_json::json!({
            "index": f.index, "world_from_velo": f.world_from_velo, "detections": dets,
        }));
    }
    pts.flush()?;
    feats.flush()?;
    let dim = frames
        .iter()
        .flat_map(|f| f.dets.first())
        .map(|d| d.feature.len())
        .next()
        .unwrap_or(0);
    let j = serde_json::json!({
        "voxel_m": cfg.voxel_m, "dbscan_eps_m": cfg.dbscan_eps_m,
        "dbscan_min_points": cfg.dbscan_min_points, "w_geo": cfg.w_geo, "w_fea": cfg.w_fea,
        "sim_threshold": cfg.sim_threshold, "feature_dim": dim, "frames": jframes,
    });
    std::fs::write(dir.join("inputs.json"), serde_json::to_vec_pretty(&j)?)?;
    Ok(())
}

fn venv_python() -> PathBuf {
    let venv = std::env::var_os("OPENGRAPH_VENV")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cache/opengraph/venv")));
    match venv.map(|v| v.join("bin/python")) {
        Some(p) if p.is_file() => p,
        _ => PathBuf::from("python3"),
    }
}

fn main() -> anyhow::Result<()> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let quick = !std::env::args().any(|a| a == "--bench");
    let reps = if quick { 3 } else { 100 };
    let cfg = MappingConfig::default();
    let Some((camera, oracle)) = common::seq00_oracle_frames(&cfg)? else {
        return Ok(());
    };
    let oracle_ms = oracle.iter().map(|f| f.oracle_ms).sum::<f64>() / oracle.len() as f64;
    let mut frames = Vec::new();
    for f in oracle {
        let mut projected = camera.project_all(&f.points);
        projected.sort_unstable_by_key(|p| (p.pixel, p.point));
        let mut out = Vec::new();
        for ((d, t), feature) in f.detections.detections.iter().zip(&f.truth).zip(f.features) {
            if classes::is_surface(t.class) {
                continue;
            }
            let points: Vec<[f32; 3]> = points_in_mask(&projected, &d.mask.counts)
                .into_iter()
                .map(|k| {
                    let p = f.points[k as usize];
                    [p[0], p[1], p[2]]
                })
                .collect();
            if !points.is_empty() {
                out.push(Det {
                    points,
                    feature,
                    class: t.class,
                });
            }
        }
        let h = f.world_from_velo.to_homogeneous();
        let mut m = [0.0; 16];
        for r in 0..4 {
            for c in 0..4 {
                m[4 * r + c] = h[(r, c)];
            }
        }
        frames.push(Frame {
            index: f.index,
            world_from_velo: m,
            dets: out,
        });
    }
    let keep = std::env::var_os("OPENGRAPH_OPEN3D_DIR").map(PathBuf::from);
    let tmp;
    let dir = match &keep {
        Some(d) => {
            std::fs::create_dir_all(d)?;
            d.clone()
        }
        None => {
            tmp = tempfile::tempdir()?;
            tmp.path().to_path_buf()
        }
    };
    write_inputs(&dir, &frames, &cfg)?;
    let n_dets: usize = frames.iter().map(|f| f.dets.len()).sum();
    let n_pts: usize = frames
        .iter()
        .flat_map(|f| &f.dets)
        .map(|d| d.points.len())
        .sum();
    println!(
        "seq 00 frames 0-2 (SemanticKITTI label oracle, {oracle_ms:.1} ms/frame): {n_dets} object detections, {n_pts} points in their masks"
    );

    let mut per_frame: Vec<Vec<f64>> = vec![Vec::new(); frames.len()];
    let mut stage = vec![Times::default(); frames.len()];
    let mut last = None;
    for _ in 0..reps {
        let (times, outs, objects) = run(&frames, &cfg);
        for (k, t) in times.iter().enumerate() {
            per_frame[k].push(t.total());
            stage[k].voxel += t.voxel / reps as f64;
            stage[k].dbscan += t.dbscan / reps as f64;
            stage[k].transform += t.transform / reps as f64;
            stage[k].associate += t.associate / reps as f64;
            stage[k].fuse += t.fuse / reps as f64;
        }
        last = Some((outs, objects));
    }
    let (outs, objects) = last.context("no repetition ran")?;
    let medians: Vec<f64> = per_frame.iter_mut().map(|v| median(v)).collect();
    let j = serde_json::json!({
        "reps": reps,
        "frame_ms_p50": medians,
        "stage_ms_mean": stage.iter().map(|t| serde_json::json!({
            "voxel": t.voxel, "dbscan": t.dbscan, "transform": t.transform,
            "associate": t.associate, "fuse": t.fuse,
        })).collect::<Vec<_>>(),
        "detections": outs,
        "objects": objects.iter().map(|o| serde_json::json!({
            "points": o.points.len(), "min": o.bbox.min, "max": o.bbox.max,
            "detections": o.detections,
        })).collect::<Vec<_>>(),
    });
    std::fs::write(dir.join("ours.json"), serde_json::to_vec_pretty(&j)?)?;
    let script = root.join("scripts/bench_open3d.py");
    let py = venv_python();
    let status = std::process::Command::new(&py)
        .arg(&script)
        .arg("--dir")
        .arg(&dir)
        .arg("--reps")
        .arg(reps.to_string())
        .env("OMP_NUM_THREADS", "1")
        .status()
        .with_context(|| format!("running {} {}", py.display(), script.display()))?;
    anyhow::ensure!(status.success(), "{} failed: {status}", script.display());
    Ok(())
}
