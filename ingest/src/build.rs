//! The map build driver: reads a KITTI-layout sequence and its detections (a directory of
//! detections files, or the label oracle), integrates key frames into the object map, commits
//! to the store every `commit_every` key frames, post-processes, and finally writes the
//! hierarchy over the whole trajectory. A killed build continues with `resume`.

use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use graphstore::{Direction, GraphRead, PointCloud, Store, Value};
use llm_tools::Embedder;

use crate::classes;
use crate::error::{Error, Result};
use crate::hierarchy::{HierarchyConfig, HierarchyReport, build_hierarchy};
use crate::mapping::project::Camera;
use crate::mapping::{
    CaptionMerger, FrameInput, MapObject, Mapper, MappingConfig, PostReport, StageTimes,
};
use crate::sources::detections::{DetectionFrame, read_detections};
use crate::sources::kitti::{self, Calib, Rigid3, Scan};
use crate::sources::oracle::{OracleConfig, oracle_detections};
use scene::GroundFrame;

/// All build parameters: the `[mapping]`, `[oracle]` and `[hierarchy]` tables of a TOML file.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BuildConfig {
    /// Mapping.
    pub mapping: MappingConfig,
    /// The label oracle.
    pub oracle: OracleConfig,
    /// Hierarchy (lanes, segments, relations).
    pub hierarchy: HierarchyConfig,
    /// The dynamic-point filter before projection.
    pub dynamic: crate::mapping::dynamic::DynamicConfig,
    /// The language model for the caption merge after mapping (`[llm]`: backend `local`,
    /// `openai` or `none`, the default). Not part of the build's resume arguments: the merge
    /// is its own resumable pass ([`crate::llm::merge_captions`]).
    pub llm: llm_tools::LlmConfig,
}

impl BuildConfig {
    /// Reads a TOML file; unknown keys and bad values are errors naming the file and line.
    pub fn from_toml_file(path: &Path) -> Result<BuildConfig> {
        let text = crate::error::read_text(path)?;
        let cfg: BuildConfig = toml::from_str(&text).map_err(|e| {
            let line = e.span().map_or(0, |s| {
                // 1-based: newlines before the error, plus one
                text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|b| **b == b'\n')
                    .count()
                    + 1
            });
            Error::Parse {
                path: path.to_path_buf(),
                line,
                detail: e.message().to_string(),
            }
        })?;
        cfg.mapping
            .validate()
            .and_then(|()| cfg.hierarchy.validate())
            .and_then(|()| cfg.oracle.validate())
            .and_then(|()| cfg.dynamic.validate())
            .map_err(|e| Error::File {
                path: path.to_path_buf(),
                detail: e.to_string(),
            })?;
        Ok(cfg)
    }
}

/// Where the detections come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// The SemanticKITTI label oracle (needs `labels/`).
    Oracle,
    /// A directory of detections files `NNNNNN.json`.
    Detections(PathBuf),
}

impl Source {
    /// `oracle` or `detections` (the `source` of the eval report).
    pub fn kind(&self) -> &'static str {
        match self {
            Source::Oracle => "oracle",
            Source::Detections(_) => "detections",
        }
    }
}

/// A KITTI odometry sequence on disk.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// The sequence directory.
    pub dir: PathBuf,
    /// Frame numbers that have a scan, ascending.
    pub scans: Vec<u32>,
    /// cam0-to-world poses.
    pub poses: Vec<Rigid3>,
    /// Where the poses came from.
    pub poses_path: PathBuf,
    /// Calibration.
    pub calib: Calib,
    /// Timestamps, when `times.txt` exists.
    pub times: Option<Vec<f64>>,
}

fn frame_number(path: &Path, ext: &str) -> Option<u32> {
    let name = path.file_name()?.to_str()?;
    let stem = name.strip_suffix(ext)?;
    (stem.len() == 6 && stem.bytes().all(|b| b.is_ascii_digit()))
        .then(|| stem.parse().ok())
        .flatten()
}

fn list_frames(dir: &Path, ext: &str) -> Result<Vec<u32>> {
    let rd = match std::fs::read_dir(dir) {
        Ok(rd) => rd,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(error) => {
            return Err(Error::Io {
                path: dir.to_path_buf(),
                error,
            });
        }
    };
    let mut out = Vec::new();
    for e in rd {
        let e = e.map_err(|error| Error::Io {
            path: dir.to_path_buf(),
            error,
        })?;
        if let Some(n) = frame_number(&e.path(), ext) {
            out.push(n);
        }
    }
    out.sort_unstable();
    Ok(out)
}

impl Sequence {
    /// Opens `dir` (with `velodyne/`, `calib.txt`, `poses.txt` unless `poses` is given, and
    /// optionally `labels/`, `image_2/`, `times.txt`).
    pub fn open(dir: &Path, poses: Option<&Path>) -> Result<Sequence> {
        let scans = list_frames(&dir.join("velodyne"), ".bin")?;
        if scans.is_empty() {
            return Err(Error::File {
                path: dir.join("velodyne"),
                detail: "no scans (NNNNNN.bin) found".into(),
            });
        }
        let calib = kitti::read_calib(&dir.join("calib.txt"))?;
        let poses_path = poses.map_or_else(|| dir.join("poses.txt"), Path::to_path_buf);
        let poses = kitti::read_poses(&poses_path)?;
        let last = *scans.last().expect("non-empty");
        if poses.len() <= last as usize {
            return Err(Error::File {
                path: poses_path,
                detail: format!(
                    "{} poses, but velodyne/ has scans up to {last:06}.bin (fewer poses than scans)",
                    poses.len()
                ),
            });
        }
        let times_path = dir.join("times.txt");
        let times = if times_path.exists() {
            Some(kitti::read_times(&times_path)?)
        } else {
            None
        };
        Ok(Sequence {
            dir: dir.to_path_buf(),
            scans,
            poses,
            poses_path,
            calib,
            times,
        })
    }

    /// `velodyne/NNNNNN.bin`.
    pub fn scan_path(&self, i: u32) -> PathBuf {
        self.dir.join("velodyne").join(format!("{i:06}.bin"))
    }

    /// `labels/NNNNNN.label`.
    pub fn label_path(&self, i: u32) -> PathBuf {
        self.dir.join("labels").join(format!("{i:06}.label"))
    }

    /// `image_2/NNNNNN.png`.
    pub fn image_path(&self, i: u32) -> PathBuf {
        self.dir.join("image_2").join(format!("{i:06}.png"))
    }

    /// The camera of frame `i`: P2 with the size of `image_2/NNNNNN.png`, or `default_size`
    /// (`[width, height]`) when there is no image.
    pub fn camera(&self, i: u32, default_size: [u32; 2]) -> Result<Camera> {
        let image = self.image_path(i);
        let (w, h) = if image.exists() {
            kitti::png_size(&image)?
        } else {
            (default_size[0], default_size[1])
        };
        Ok(Camera::kitti_p2(&self.calib, w, h))
    }

    /// The label oracle's detections for frame `i`, whose scan is `scan`.
    pub fn oracle(
        &self,
        i: u32,
        scan: &Scan,
        camera: &Camera,
        cfg: &OracleConfig,
    ) -> Result<DetectionFrame> {
        let labels = kitti::read_labels(&self.label_path(i), scan.points.len())?;
        let world_from_velo = self.world_from_velo(i);
        let (d, _) = oracle_detections(
            i,
            &scan.points,
            &labels,
            camera,
            Some(&world_from_velo),
            cfg,
        )?;
        Ok(d)
    }

    /// `world_from_velo = pose × Tr`.
    pub fn world_from_velo(&self, i: u32) -> Rigid3 {
        self.poses[i as usize] * self.calib.cam0_from_velo
    }

    /// The velodyne's world position at every pose (the whole trajectory).
    pub fn trajectory(&self) -> Vec<[f64; 3]> {
        kitti::positions(&self.poses, Some(&self.calib))
    }
}

/// What to build.
#[derive(Debug, Clone)]
pub struct BuildArgs {
    /// The sequence directory.
    pub sequence: PathBuf,
    /// poses.txt from another path.
    pub poses: Option<PathBuf>,
    /// Detections source.
    pub source: Source,
    /// Key frames to use (half-open); all available ones when `None`.
    pub frames: Option<Range<u32>>,
    /// Use every N-th frame.
    pub stride: u32,
    /// Parameters.
    pub config: BuildConfig,
    /// Name of the environment node.
    pub environment: String,
}

/// A progress event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// The build starts; `done` key frames of `total` are already in the store.
    Start {
        /// Already committed.
        done: usize,
        /// All key frames.
        total: usize,
    },
    /// A key frame was integrated.
    Frame {
        /// The frame number.
        frame: u32,
    },
    /// Everything up to and including `frame` is committed.
    Committed {
        /// The last committed frame.
        frame: u32,
    },
    /// Post-processing and the hierarchy.
    Finishing,
}

/// What a build did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct BuildReport {
    /// `oracle` or `detections`.
    pub source: String,
    /// Key frames of the build.
    pub frames_total: usize,
    /// Key frames integrated by this run.
    pub frames_run: usize,
    /// Scans of the sequence (in `--frames`, when given) that were not mapped because they
    /// have no detections file or labels.
    pub scans_without_input: usize,
    /// Where this run started, when it resumed.
    pub resumed_at: Option<u32>,
    /// Detections read by this run.
    pub detections: usize,
    /// Detections dropped (no points, or none after denoising).
    pub detections_dropped: usize,
    /// Thing detections not mapped because their masks were largely points the dynamic
    /// filter removed (`[dynamic] moving_detection_share`).
    pub detections_moving: usize,
    /// NaN/inf points dropped from scans by this run.
    pub nonfinite_points: u64,
    /// The dynamic-point filter of this run.
    pub dynamic: crate::mapping::dynamic::DynamicReport,
    /// Instances per class in the final map.
    pub instances_per_class: BTreeMap<String, usize>,
    /// Mean milliseconds per key frame for each stage of this run.
    pub ms_per_frame: BTreeMap<String, f64>,
    /// Post-processing.
    pub post: PostReport,
    /// The hierarchy written at the end.
    pub hierarchy: Option<HierarchyReport>,
    /// Commits made by this run.
    pub commits: usize,
}

/// The key frames of a build.
pub fn key_frames(
    seq: &Sequence,
    source: &Source,
    frames: Option<&Range<u32>>,
    stride: u32,
) -> Result<Vec<u32>> {
    let stride = stride.max(1);
    let needs = |i: u32| -> PathBuf {
        match source {
            Source::Oracle => seq.label_path(i),
            Source::Detections(d) => d.join(format!("{i:06}.json")),
        }
    };
    let picked: Vec<u32> = match frames {
        Some(r) => {
            if r.is_empty() {
                return Err(Error::Invalid(format!(
                    "--frames {}..{} is empty",
                    r.start, r.end
                )));
            }
            // the scans the sequence has in the range (a simulated drive numbers its scans
            // sparsely), every stride-th of them; each needs its labels or detections
            let in_range: Vec<u32> = seq
                .scans
                .iter()
                .copied()
                .filter(|i| r.contains(i))
                .step_by(stride as usize)
                .collect();
            if in_range.is_empty() {
                return Err(Error::Invalid(format!(
                    "--frames {}..{} holds none of the sequence's {} scans (they run from {} to {})",
                    r.start,
                    r.end,
                    seq.scans.len(),
                    seq.scans.first().copied().unwrap_or(0),
                    seq.scans.last().copied().unwrap_or(0)
                )));
            }
            for &i in &in_range {
                let p = needs(i);
                if !p.exists() {
                    return Err(Error::File {
                        path: p,
                        detail: format!(
                            "frame {i} has a scan in --frames but this file is missing"
                        ),
                    });
                }
            }
            in_range
        }
        None => {
            let avail: Vec<u32> = seq
                .scans
                .iter()
                .copied()
                .filter(|i| needs(*i).exists())
                .collect();
            let first = *avail.first().ok_or_else(|| Error::File {
                path: needs(seq.scans[0]),
                detail: format!(
                    "no frame has both a scan and {} (checked {} scans)",
                    match source {
                        Source::Oracle => "labels",
                        Source::Detections(_) => "a detections file",
                    },
                    seq.scans.len()
                ),
            })?;
            avail
                .into_iter()
                .filter(|i| (i - first) % stride == 0)
                .collect()
        }
    };
    Ok(picked)
}

const BUILD_ID: i64 = 0;
const PAYLOAD_KEY: &str = "points";

struct Checkpoint {
    node: u64,
    args: String,
    next_frame: i64,
    next_instance_id: u64,
    finished: bool,
    hierarchy_done: bool,
}

fn load_checkpoint(r: &impl GraphRead) -> Result<Option<Checkpoint>> {
    let Some(&node) = r
        .find_nodes("Build", "build_id", &Value::Int(BUILD_ID))?
        .first()
    else {
        return Ok(None);
    };
    let get = |k: &str| r.node_prop(node, k);
    Ok(Some(Checkpoint {
        node,
        args: get("args")?
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default(),
        next_frame: get("next_frame")?.and_then(|v| v.as_int()).unwrap_or(0),
        next_instance_id: get("next_instance_id")?
            .and_then(|v| v.as_int())
            .unwrap_or(0)
            .max(0) as u64,
        finished: matches!(get("finished")?, Some(Value::Bool(true))),
        hierarchy_done: matches!(get("hierarchy_done")?, Some(Value::Bool(true))),
    }))
}

/// Instance node ids by instance id, and the objects, from a store.
fn load_objects(r: &impl GraphRead, voxel_m: f32) -> Result<(Vec<MapObject>, BTreeMap<u64, u64>)> {
    let mut objects = Vec::new();
    let mut nodes = BTreeMap::new();
    for id in r.nodes_with_label("Instance")? {
        let p = |k: &str| r.node_prop(id, k);
        let int = |v: Option<Value>| v.and_then(|v| v.as_int()).unwrap_or(0);
        let instance_id = int(p("instance_id")?).max(0) as u64;
        let tile = match p("tile")? {
            Some(Value::List(v)) if v.len() == 3 => {
                let i = |k: usize| v[k].as_int().unwrap_or(0);
                Some((i(0) as u8, [i(1), i(2)]))
            }
            _ => None,
        };
        let feature = match p("detection_feature")? {
            Some(Value::Vector(v)) => v,
            _ => Vec::new(),
        };
        let captions = match p("captions")? {
            Some(Value::List(v)) => v
                .iter()
                .filter_map(|c| c.as_str().map(str::to_string))
                .collect(),
            _ => Vec::new(),
        };
        let points = r
            .point_cloud(id, PAYLOAD_KEY)?
            .map(|c| c.xyz)
            .unwrap_or_default();
        objects.push(MapObject::restore(
            instance_id,
            tile,
            points,
            feature,
            captions,
            int(p("detection_count")?) as u32,
            int(p("first_frame")?) as u32,
            int(p("last_frame")?) as u32,
            voxel_m,
        ));
        nodes.insert(instance_id, id);
    }
    Ok((objects, nodes))
}

/// Caption embeddings with a cache (captions repeat across frames).
struct EmbedCache<'a> {
    embedder: &'a mut dyn Embedder,
    cache: HashMap<String, Vec<f32>>,
}

impl EmbedCache<'_> {
    fn get_all(&mut self, texts: &[&str]) -> Result<Vec<Vec<f32>>> {
        let mut missing: Vec<&str> = texts
            .iter()
            .copied()
            .filter(|t| !self.cache.contains_key(*t))
            .collect();
        missing.sort_unstable();
        missing.dedup();
        if !missing.is_empty() {
            let v = self
                .embedder
                .embed(&missing)
                .map_err(|e| Error::Invalid(format!("embedding captions: {e}")))?;
            for (t, e) in missing.iter().zip(v) {
                self.cache.insert(t.to_string(), e);
            }
        }
        Ok(texts.iter().map(|t| self.cache[*t].clone()).collect())
    }
}

/// The class (1..=19) whose prompt is most similar to `v` (the embedding of a caption's
/// subject phrase).
/// The class whose prompt is closest to `v`, among surface classes when `surface`, else
/// among the others.
fn argmax_class(v: &[f32], prompts: &[(u8, Vec<f32>)], surface: bool) -> u8 {
    let mut best = (f64::NEG_INFINITY, 0u8);
    for (class, p) in prompts
        .iter()
        .filter(|(c, _)| classes::is_surface(*c) == surface)
    {
        let c = crate::mapping::associate::cosine(v, p);
        if c > best.0 {
            best = (c, *class);
        }
    }
    best.1
}

/// Classes whose objects are joined when their points touch (building, fence, vegetation):
/// extended things a passing car sees in parts.
const JOINED_CLASSES: [u8; 3] = [13, 14, 15];

/// The thing class of an object before its caption is merged: the most frequent class of
/// its recent captions (ties: the lower class id).
fn object_class(
    o: &MapObject,
    cfg: &MappingConfig,
    emb: &mut EmbedCache<'_>,
    prompts: &[(u8, Vec<f32>)],
) -> Result<u8> {
    let subjects: Vec<&str> = o
        .recent_captions(cfg.merge_captions)
        .iter()
        .map(|c| classes::subject_phrase(c))
        .collect();
    let mut votes: BTreeMap<u8, usize> = BTreeMap::new();
    for e in emb.get_all(&subjects)? {
        *votes.entry(argmax_class(&e, prompts, false)).or_insert(0) += 1;
    }
    Ok(votes
        .iter()
        .max_by_key(|(c, n)| (**n, std::cmp::Reverse(**c)))
        .map_or(0, |(c, _)| *c))
}

/// Class of each detection: whether it is a surface or a thing is decided by its tags or
/// caption ([`classes::names_surface`]); its class is then the closest class prompt of that
/// kind to the caption's embedded subject phrase. Inputs are `(tags, caption)` pairs.
fn classify(
    detections: &[(&[String], &str)],
    emb: &mut EmbedCache<'_>,
    prompts: &[(u8, Vec<f32>)],
) -> Result<Vec<u8>> {
    let subjects: Vec<&str> = detections
        .iter()
        .map(|(_, c)| classes::subject_phrase(c))
        .collect();
    Ok(emb
        .get_all(&subjects)?
        .iter()
        .zip(detections)
        .map(|(e, (tags, caption))| argmax_class(e, prompts, classes::names_surface(tags, caption)))
        .collect())
}

struct Description {
    caption: String,
    class: u8,
    feature: Vec<f32>,
}

fn describe(
    o: &MapObject,
    cfg: &MappingConfig,
    emb: &mut EmbedCache<'_>,
    merger: &mut dyn CaptionMerger,
    prompts: &[(u8, Vec<f32>)],
) -> Result<Description> {
    let caption = merger.merge(o.recent_captions(cfg.merge_captions));
    let ce = emb.get_all(&[&caption])?.remove(0);
    let class = match o.tile {
        Some((c, _)) => c,
        // an object is a thing whatever its merged caption says
        None => {
            let subject = classes::subject_phrase(&caption);
            argmax_class(&emb.get_all(&[subject])?[0], prompts, false)
        }
    };
    let feature = if o.feature.len() == ce.len() {
        let n = |v: &[f32]| v.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
        let (na, nb) = (n(&ce), n(&o.feature));
        let mut f: Vec<f32> = ce
            .iter()
            .zip(&o.feature)
            .map(|(a, b)| 0.5 * a / na + 0.5 * b / nb)
            .collect();
        let nf = n(&f);
        f.iter_mut().for_each(|x| *x /= nf);
        f
    } else {
        ce
    };
    Ok(Description {
        caption,
        class,
        feature,
    })
}

fn instance_props(
    o: &MapObject,
    d: &Description,
    source: &str,
    ground: GroundFrame,
) -> Vec<(&'static str, Value)> {
    let c = o.bbox.center();
    let mut props = vec![
        ("instance_id", Value::Int(o.instance_id as i64)),
        ("caption", Value::String(d.caption.clone())),
        (
            "class",
            Value::String(classes::class_name(d.class).unwrap_or("unknown").into()),
        ),
        ("centroid", Value::Point3D(c)),
        (
            "bbox",
            Value::box3d(o.bbox.min.map(f64::from), o.bbox.max.map(f64::from)),
        ),
        (
            "captions",
            Value::List(o.captions.iter().cloned().map(Value::String).collect()),
        ),
        ("feature", Value::Vector(d.feature.clone())),
        ("point_count", Value::Int(o.points.len() as i64)),
        ("detection_count", Value::Int(i64::from(o.detection_count))),
        ("first_frame", Value::Int(i64::from(o.first_frame))),
        ("last_frame", Value::Int(i64::from(o.last_frame))),
        ("source", Value::String(source.into())),
    ];
    if !o.feature.is_empty() {
        props.push(("detection_feature", Value::Vector(o.feature.clone())));
    }
    if let Some(b) = o.obb(ground) {
        props.push(("obb", obb_value(&b)));
    }
    if let Some((class, [x, z])) = o.tile {
        props.push((
            "tile",
            Value::List(vec![
                Value::Int(i64::from(class)),
                Value::Int(x),
                Value::Int(z),
            ]),
        ));
    }
    props
}

/// The `Instance.obb` property of a box ([`OrientedBox::to_values`]).
pub fn obb_value(b: &scene::OrientedBox) -> Value {
    Value::List(b.to_values().into_iter().map(Value::Float).collect())
}

/// The scans nearest to `i` in the sequence, up to `window` on each side within 50 poses
/// (a simulator's sequence has scans at its sensor frames only).
fn neighbour_scans(seq: &Sequence, i: u32, window: u32) -> Vec<u32> {
    const REACH: u32 = 50;
    let mut out = Vec::new();
    let before = (i.saturating_sub(REACH)..i)
        .rev()
        .filter(|j| seq.scan_path(*j).exists())
        .take(window as usize);
    out.extend(before);
    let last = (seq.poses.len() as u32).saturating_sub(1);
    let after = (i + 1..=(i + REACH).min(last))
        .filter(|j| seq.scan_path(*j).exists())
        .take(window as usize);
    out.extend(after);
    out.sort_unstable();
    out
}

/// The key scan `i` without its dynamic points ([`crate::mapping::dynamic`]), and those
/// points; range images of the neighbours are kept in `images` for the next key frames.
/// Counts go to `rep`, and, where the scan has SemanticKITTI labels, against its moving
/// classes.
fn remove_dynamic(
    seq: &Sequence,
    i: u32,
    scan: &Scan,
    cfg: &crate::mapping::dynamic::DynamicConfig,
    images: &mut BTreeMap<u32, crate::mapping::dynamic::RangeImage>,
    rep: &mut crate::mapping::dynamic::DynamicReport,
) -> Result<(Scan, Vec<[f32; 4]>)> {
    use crate::mapping::dynamic::{RangeImage, dynamic_mask, is_moving_label};
    let near = neighbour_scans(seq, i, cfg.window);
    rep.neighbour_scans += near.len() as u64;
    rep.key_scans += 1;
    images.retain(|j, _| near.contains(j));
    for &j in &near {
        if let std::collections::btree_map::Entry::Vacant(e) = images.entry(j) {
            let s = kitti::read_scan(&seq.scan_path(j))?;
            e.insert(RangeImage::new(
                &s.points,
                &seq.world_from_velo(j),
                cfg.bin_deg,
                cfg.spread_bins,
            ));
        }
    }
    let refs: Vec<&RangeImage> = near.iter().filter_map(|j| images.get(j)).collect();
    let mask = dynamic_mask(&scan.points, &seq.world_from_velo(i), &refs, cfg);
    rep.points += scan.points.len() as u64;
    rep.removed += mask.iter().filter(|m| **m).count() as u64;
    let lp = seq.label_path(i);
    if lp.exists()
        && let Ok(labels) = kitti::read_labels(&lp, scan.points.len())
    {
        for (l, m) in labels.iter().zip(&mask) {
            if l.semantic == 0 {
                continue;
            }
            if is_moving_label(l.semantic) {
                rep.moving_points += 1;
                rep.moving_removed += u64::from(*m);
            } else {
                rep.static_points += 1;
                rep.static_removed += u64::from(*m);
            }
        }
    }
    let (mut kept, mut removed) = (Vec::new(), Vec::new());
    for (p, m) in scan.points.iter().zip(mask) {
        if m {
            removed.push(*p);
        } else {
            kept.push(*p);
        }
    }
    Ok((Scan { points: kept }, removed))
}

struct FrameRecord {
    index: u32,
    world_from_velo: Rigid3,
    timestamp_secs: Option<f64>,
}

/// The running build.
struct Run<'a> {
    store: &'a Store,
    mapper: Mapper,
    nodes: BTreeMap<u64, u64>,
    emb: EmbedCache<'a>,
    merger: &'a mut dyn CaptionMerger,
    prompts: Vec<(u8, Vec<f32>)>,
    producer: String,
    checkpoint_node: u64,
}

impl Run<'_> {
    /// Writes the pending frames, every changed object and the checkpoint in one
    /// transaction; afterwards the in-memory points are exactly what the store holds.
    fn commit(
        &mut self,
        frames: &[FrameRecord],
        next_frame: i64,
        deleted: &[u64],
        merged: &[(u64, u64)],
        finished: bool,
    ) -> Result<()> {
        let cfg = self.mapper.config().clone();
        let mut writes = Vec::new();
        for o in self.mapper.objects().values().filter(|o| o.dirty) {
            let d = describe(o, &cfg, &mut self.emb, self.merger, &self.prompts)?;
            let bytes = PointCloud {
                xyz: o.points.clone(),
                rgb: Vec::new(),
            }
            .encode()?;
            let decoded = PointCloud::decode(&bytes)?.xyz;
            let props = instance_props(o, &d, &self.producer, self.mapper.ground());
            let obs: Vec<(u32, u32)> = o.observations.iter().map(|(f, n)| (*f, *n)).collect();
            writes.push((o.instance_id, props, bytes, decoded, obs));
        }
        let next_id = self.mapper.next_id();
        let known = &self.nodes;
        let deleted_nodes: Vec<u64> = deleted
            .iter()
            .filter_map(|i| known.get(i).copied())
            .collect();
        let merged_nodes: Vec<(u64, u64)> = merged
            .iter()
            .filter_map(|(k, g)| Some((*known.get(k)?, *known.get(g)?)))
            .collect();
        let checkpoint = self.checkpoint_node;
        let created = self.store.write(|tx| {
            // an absorbed object's observations move to the object that absorbed it
            if !merged_nodes.is_empty() {
                let obs_ty = tx.rel_type_id("OBSERVED_IN")?;
                let det_key = tx.prop_key_id("detections")?;
                let count = |tx: &graphstore::WriteTxn<'_>, rel: u64| -> graphstore::Result<i64> {
                    Ok(tx
                        .rel(rel)?
                        .and_then(|r| r.get(det_key).and_then(Value::as_int))
                        .unwrap_or(1))
                };
                for (keep, gone) in &merged_nodes {
                    let existing = tx.neighbours(*keep, Direction::Outgoing, Some(obs_ty))?;
                    for a in tx.neighbours(*gone, Direction::Outgoing, Some(obs_ty))? {
                        let n = count(tx, a.rel)?;
                        match existing.iter().find(|e| e.other == a.other) {
                            Some(e) => {
                                let total = count(tx, e.rel)? + n;
                                tx.set_rel_prop(e.rel, det_key, Value::Int(total))?;
                            }
                            None => {
                                tx.create_rel(
                                    *keep,
                                    obs_ty,
                                    a.other,
                                    vec![(det_key, Value::Int(n))],
                                )?;
                            }
                        }
                    }
                }
            }
            for n in &deleted_nodes {
                tx.detach_delete_node(*n)?;
            }
            let mut frame_nodes: BTreeMap<u32, u64> = BTreeMap::new();
            for f in frames {
                let mut props = vec![
                    ("index", Value::Int(i64::from(f.index))),
                    (
                        "world_from_velo",
                        Value::List(
                            scene::pose::row_major(&f.world_from_velo)
                                .into_iter()
                                .map(Value::Float)
                                .collect(),
                        ),
                    ),
                ];
                if let Some(t) = f.timestamp_secs {
                    props.push(("timestamp_secs", Value::Float(t)));
                }
                frame_nodes.insert(f.index, tx.create_node_named(&["Frame"], &props)?);
            }
            let mut created = Vec::new();
            for (iid, props, bytes, _, obs) in &writes {
                let node = match known.get(iid) {
                    Some(n) => {
                        let mut kv = Vec::with_capacity(props.len());
                        for (k, v) in props {
                            kv.push((tx.prop_key_id(k)?, v.clone()));
                        }
                        tx.replace_node_props(*n, kv)?;
                        *n
                    }
                    None => {
                        let n = tx.create_node_named(&["Instance"], props)?;
                        created.push((*iid, n));
                        n
                    }
                };
                tx.put_payload(node, PAYLOAD_KEY, bytes)?;
                for (f, count) in obs {
                    let fnode = match frame_nodes.get(f) {
                        Some(n) => *n,
                        None => match tx
                            .find_nodes("Frame", "index", &Value::Int(i64::from(*f)))?
                            .first()
                        {
                            Some(n) => *n,
                            None => continue,
                        },
                    };
                    tx.create_rel_named(
                        node,
                        "OBSERVED_IN",
                        fnode,
                        &[("detections", Value::Int(i64::from(*count)))],
                    )?;
                }
            }
            let ty = tx.prop_key_id("next_frame")?;
            tx.set_node_prop(checkpoint, ty, Value::Int(next_frame))?;
            let k = tx.prop_key_id("next_instance_id")?;
            tx.set_node_prop(checkpoint, k, Value::Int(next_id as i64))?;
            let k = tx.prop_key_id("finished")?;
            tx.set_node_prop(checkpoint, k, Value::Bool(finished))?;
            Ok(created)
        })?;
        for (iid, n) in created {
            self.nodes.insert(iid, n);
        }
        for d in deleted {
            self.nodes.remove(d);
        }
        let voxel_m = cfg.voxel_m;
        let objs = self.mapper.objects_mut();
        for (iid, _, _, decoded, _) in writes {
            if let Some(o) = objs.get_mut(&iid) {
                o.set_points(decoded, voxel_m);
                o.dirty = false;
                o.observations.clear();
            }
        }
        Ok(())
    }
}

/// The key frame's points (`scan`, already read) with non-finite points dropped (counted), and
/// accumulates the `accumulate - 1`
/// previous scans moved into this scan's velodyne frame.
fn load_points(
    seq: &Sequence,
    i: u32,
    scan: &Scan,
    accumulate: usize,
    nonfinite: &mut u64,
) -> Result<Vec<[f32; 4]>> {
    let mut pts = scan.points.clone();
    if accumulate > 1 {
        let velo_from_world = seq.world_from_velo(i).inverse();
        for j in (i.saturating_sub(accumulate as u32 - 1)..i).rev() {
            let p = seq.scan_path(j);
            if !p.exists() {
                continue;
            }
            let m = velo_from_world * seq.world_from_velo(j);
            for q in kitti::read_scan(&p)?.points {
                let w = scene::pose::apply(&m, [f64::from(q[0]), f64::from(q[1]), f64::from(q[2])]);
                pts.push([w[0] as f32, w[1] as f32, w[2] as f32, q[3]]);
            }
        }
    }
    let before = pts.len();
    pts.retain(|p| p[..3].iter().all(|c| c.is_finite()));
    *nonfinite += (before - pts.len()) as u64;
    Ok(pts)
}

/// The configuration as a resumed build must match it: everything but `[llm]`, whose caption
/// merge is a pass of its own.
fn resume_config(cfg: &BuildConfig) -> Result<serde_json::Value> {
    let mut v = serde_json::to_value(cfg).map_err(|e| Error::Invalid(e.to_string()))?;
    if let Some(o) = v.as_object_mut() {
        o.remove("llm");
    }
    Ok(v)
}

/// How a map names an input path: relative to `base` when it lies inside it, else by its
/// last component alone (a map never holds the build machine's absolute paths).
fn display_name(path: &Path, base: Option<&Path>) -> String {
    if let Some(rel) = base.and_then(|b| path.strip_prefix(b).ok())
        && !rel.as_os_str().is_empty()
    {
        return rel.display().to_string();
    }
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Runs (or, with `resume`, continues) a build into `store`.
pub fn build(
    store: &Store,
    args: &BuildArgs,
    embedder: &mut dyn Embedder,
    merger: &mut dyn CaptionMerger,
    resume: bool,
    progress: &mut dyn FnMut(Progress),
) -> Result<BuildReport> {
    let cfg = &args.config;
    cfg.mapping.validate()?;
    cfg.dynamic.validate()?;
    let seq = Sequence::open(&args.sequence, args.poses.as_deref())?;
    let frames = key_frames(&seq, &args.source, args.frames.as_ref(), args.stride)?;
    // the map is readable by anyone it is served to, and exported: it names its inputs
    // relative to the sequence directory (or by file name alone), never by absolute path; a
    // digest of the absolute paths tells a resume with other inputs apart
    let canonical = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let seq_dir = canonical(&seq.dir);
    let poses = canonical(&seq.poses_path);
    let detections = match &args.source {
        Source::Oracle => None,
        Source::Detections(d) => Some(canonical(d)),
    };
    let inputs_sha256 = {
        use sha2::Digest as _;
        let mut h = sha2::Sha256::new();
        for p in [Some(&seq_dir), Some(&poses), detections.as_ref()]
            .into_iter()
            .flatten()
        {
            h.update(p.as_os_str().as_encoded_bytes());
            h.update([0u8]);
        }
        h.finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    };
    let args_json = serde_json::json!({
        "sequence": display_name(&seq_dir, None),
        "poses": display_name(&poses, Some(&seq_dir)),
        "source": match &detections {
            None => "oracle".to_string(),
            Some(d) => format!("detections:{}", display_name(d, Some(&seq_dir))),
        },
        "inputs_sha256": inputs_sha256,
        "frames": frames,
        "config": resume_config(cfg)?,
        "environment": args.environment,
        "embedder": embedder.name(),
    })
    .to_string();
    if store.schema() == graphstore::Schema::default() {
        store.set_schema(graphstore::opengraph_schema())?;
    }
    let (checkpoint, objects, nodes) = {
        let r = store.read()?;
        let cp = load_checkpoint(&r)?;
        let (objects, nodes) = load_objects(&r, cfg.mapping.voxel_m)?;
        (cp, objects, nodes)
    };
    let path = store.path().to_path_buf();
    let (checkpoint_node, start_frame, next_id, finished, hierarchy_done) = match checkpoint {
        Some(cp) if !resume => {
            return Err(Error::Invalid(format!(
                "{} already holds a build (next frame {}{}); pass --resume to continue it, or use a new --db",
                path.display(),
                cp.next_frame,
                if cp.finished { ", finished" } else { "" }
            )));
        }
        Some(cp) => {
            if cp.args != args_json {
                return Err(Error::Invalid(format!(
                    "--resume with different arguments than the build in {}:\n  stored: {}\n  given:  {}",
                    path.display(),
                    cp.args,
                    args_json
                )));
            }
            (
                cp.node,
                cp.next_frame,
                cp.next_instance_id,
                cp.finished,
                cp.hierarchy_done,
            )
        }
        None => {
            if !objects.is_empty() {
                return Err(Error::Invalid(format!(
                    "{} has Instance nodes but no build checkpoint; build into a new --db",
                    path.display()
                )));
            }
            let node = store.write(|tx| {
                tx.create_node_named(
                    &["Build"],
                    &[
                        ("build_id", Value::Int(BUILD_ID)),
                        ("args", Value::String(args_json.clone())),
                        ("next_frame", Value::Int(i64::from(frames[0]))),
                        ("next_instance_id", Value::Int(0)),
                        ("finished", Value::Bool(false)),
                        ("source", Value::String(args.source.kind().into())),
                    ],
                )
            })?;
            (node, i64::from(frames[0]), 0, false, false)
        }
    };
    // what produced the detections: the first key frame's file says, in every run, so that a
    // resumed build that only has post-processing left still records it on each instance
    let producer = match &args.source {
        Source::Oracle => "oracle".to_string(),
        Source::Detections(dir) => match frames.first() {
            Some(f) => read_detections(&dir.join(format!("{f:06}.json")))?
                .producer
                .as_str()
                .to_string(),
            None => String::new(),
        },
    };
    let mut emb = EmbedCache {
        embedder,
        cache: HashMap::new(),
    };
    let list = classes::prompts();
    let texts: Vec<&str> = list.iter().map(|p| p.1).collect();
    let prompts: Vec<(u8, Vec<f32>)> = list.iter().map(|p| p.0).zip(emb.get_all(&texts)?).collect();
    let ground = GroundFrame::KittiCam;
    let mut run = Run {
        store,
        mapper: Mapper::restore(cfg.mapping.clone(), ground, objects, next_id),
        nodes,
        emb,
        merger,
        prompts,
        producer,
        checkpoint_node,
    };
    // frames are ascending: the ones still to do are a suffix
    let first = frames.partition_point(|f| i64::from(*f) < start_frame);
    let considered = seq
        .scans
        .iter()
        .filter(|i| args.frames.as_ref().is_none_or(|r| r.contains(i)))
        .count();
    let mut report = BuildReport {
        source: args.source.kind().into(),
        frames_total: frames.len(),
        // with a stride, the skipped scans are chosen, not missing
        scans_without_input: if args.stride <= 1 {
            considered.saturating_sub(frames.len())
        } else {
            0
        },
        resumed_at: (resume && first > 0)
            .then(|| frames.get(first).copied())
            .flatten(),
        ..BuildReport::default()
    };
    progress(Progress::Start {
        done: first,
        total: frames.len(),
    });
    let mut times = StageTimes::default();
    let (mut t_load, mut t_oracle, mut t_embed, mut t_commit) = (0.0, 0.0, 0.0, 0.0);
    let mut t_dynamic = 0.0;
    let mut images: BTreeMap<u32, crate::mapping::dynamic::RangeImage> = BTreeMap::new();
    report.dynamic.filter = if cfg.dynamic.enabled {
        format!(
            "free-space carving (window {}, votes {})",
            cfg.dynamic.window, cfg.dynamic.min_votes
        )
    } else {
        "off".into()
    };
    let mut pending: Vec<FrameRecord> = Vec::new();
    let since = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
    // commits fall on the same frames whether or not the build was interrupted
    for (pos, &i) in frames.iter().enumerate().skip(first) {
        let t = Instant::now();
        let scan = kitti::read_scan(&seq.scan_path(i))?;
        let t_dyn = Instant::now();
        let (filtered, removed);
        let kept = if cfg.dynamic.enabled {
            (filtered, removed) = remove_dynamic(
                &seq,
                i,
                &scan,
                &cfg.dynamic,
                &mut images,
                &mut report.dynamic,
            )?;
            &filtered
        } else {
            removed = Vec::new();
            &scan
        };
        let dyn_ms = since(t_dyn);
        t_dynamic += dyn_ms;
        let points = load_points(
            &seq,
            i,
            kept,
            cfg.mapping.accumulate,
            &mut report.nonfinite_points,
        )?;
        let world_from_velo = seq.world_from_velo(i);
        let camera = seq.camera(i, cfg.mapping.image_size)?;
        let (w, h) = (camera.width, camera.height);
        let (dets, load_ms) = match &args.source {
            Source::Detections(dir) => {
                let p = dir.join(format!("{i:06}.json"));
                let d = read_detections(&p)?;
                if (d.width, d.height) != (w, h) {
                    return Err(Error::File {
                        path: p,
                        detail: format!(
                            "masks are {}x{} (width x height) but the camera image is {w}x{h}{}",
                            d.width,
                            d.height,
                            if seq.image_path(i).exists() {
                                format!(" ({})", seq.image_path(i).display())
                            } else {
                                " (mapping.image_size)".into()
                            }
                        ),
                    });
                }
                if d.frame != i {
                    return Err(Error::File {
                        path: p,
                        detail: format!("\"frame\" is {} but the file is for frame {i}", d.frame),
                    });
                }
                (d, since(t))
            }
            Source::Oracle => {
                let load = since(t);
                let t = Instant::now();
                // label reading counts as oracle time
                let d = seq.oracle(i, &scan, &camera, &cfg.oracle)?;
                t_oracle += since(t);
                (d, load)
            }
        };
        // the filter ran inside the load's time span; it is counted on its own
        t_load += load_ms - dyn_ms;
        if run.producer.is_empty() {
            run.producer = dets.producer.as_str().to_string();
        }
        let t = Instant::now();
        let captions: Vec<&str> = dets.detections.iter().map(|d| d.caption.as_str()).collect();
        let cap_emb = run.emb.get_all(&captions)?;
        let tagged: Vec<(&[String], &str)> = dets
            .detections
            .iter()
            .map(|d| (d.tags.as_slice(), d.caption.as_str()))
            .collect();
        let det_classes = classify(&tagged, &mut run.emb, &run.prompts)?;
        let features: Vec<Vec<f32>> = dets
            .detections
            .iter()
            .zip(cap_emb)
            .map(|(d, e)| d.feature.clone().unwrap_or(e))
            .collect();
        t_embed += since(t);
        let stats = run.mapper.integrate(&FrameInput {
            index: i,
            world_from_velo,
            points: &points,
            camera: &camera,
            detections: &dets,
            features: &features,
            moving: cfg.dynamic.enabled.then_some(crate::mapping::MovingPoints {
                points: &removed,
                detection_share: cfg.dynamic.moving_detection_share,
            }),
            classes: &det_classes,
        });
        times.add(&stats.times);
        report.detections += stats.detections;
        report.detections_dropped += stats.dropped;
        report.detections_moving += stats.moving;
        report.frames_run += 1;
        pending.push(FrameRecord {
            index: i,
            world_from_velo,
            timestamp_secs: seq.times.as_ref().and_then(|t| t.get(i as usize).copied()),
        });
        progress(Progress::Frame { frame: i });
        if (pos + 1) % cfg.mapping.commit_every == 0 || pos + 1 == frames.len() {
            let t = Instant::now();
            let next = frames
                .get(pos + 1)
                .map_or(i64::from(i) + 1, |f| i64::from(*f));
            run.commit(&pending, next, &[], &[], false)?;
            t_commit += since(t);
            report.commits += 1;
            pending.clear();
            progress(Progress::Committed { frame: i });
        }
    }
    progress(Progress::Finishing);
    if !finished {
        report.post = run.mapper.post_process();
        // buildings, fences and vegetation: objects that touch are one object
        let mut by_class: BTreeMap<u8, Vec<u64>> = BTreeMap::new();
        for (id, o) in run.mapper.objects() {
            if o.tile.is_none() {
                let c = object_class(o, &cfg.mapping, &mut run.emb, &run.prompts)?;
                by_class.entry(c).or_default().push(*id);
            }
        }
        for class in JOINED_CLASSES {
            if let Some(ids) = by_class.get(&class) {
                let joined = run.mapper.join_touching(ids, cfg.mapping.join_eps_m);
                report.post.merged.extend(joined);
            }
        }
        let removed: Vec<u64> = report
            .post
            .dropped
            .iter()
            .copied()
            .chain(report.post.merged.iter().map(|m| m.1))
            .collect();
        // observations of absorbed objects move to the survivor with the rest of its state
        let last = frames.last().map_or(0, |f| i64::from(*f) + 1);
        let merged = report.post.merged.clone();
        run.commit(&[], last, &removed, &merged, true)?;
        report.commits += 1;
    }
    if !hierarchy_done {
        let traj = seq.trajectory();
        let (_, _, h) = build_hierarchy(store, &traj, ground, &args.environment, &cfg.hierarchy)?;
        store.write(|tx| {
            let k = tx.prop_key_id("hierarchy_done")?;
            tx.set_node_prop(checkpoint_node, k, Value::Bool(true))
        })?;
        report.hierarchy = Some(h);
    }
    let n = report.frames_run.max(1) as f64;
    for (k, v) in [
        ("load", t_load),
        ("oracle", t_oracle),
        ("dynamic", t_dynamic),
        ("embed", t_embed),
        ("project", times.project_ms),
        ("denoise", times.denoise_ms),
        ("transform", times.transform_ms),
        ("associate", times.associate_ms),
        ("fuse", times.fuse_ms),
        ("commit", t_commit),
    ] {
        report.ms_per_frame.insert(k.into(), v / n);
    }
    let r = store.read()?;
    for id in r.nodes_with_label("Instance")? {
        if let Some(Value::String(c)) = r.node_prop(id, "class")? {
            *report.instances_per_class.entry(c).or_insert(0) += 1;
        }
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every numeric key of the hierarchy and oracle tables is checked when the file is read
    /// (before any mapping): NaN, infinities, negative, zero where it must be positive, huge.
    #[test]
    fn bad_config_numbers_are_refused_when_read() {
        let dir = tempfile::tempdir().unwrap();
        let keys = [
            ("hierarchy.lanes", "radius_m"),
            ("hierarchy.lanes", "disfluency_rad"),
            ("hierarchy.lanes", "dbscan_eps_m"),
            ("hierarchy.lanes", "association_m"),
            ("hierarchy.lanes", "resample_m"),
            ("hierarchy.lanes", "edge_merge_m"),
            ("hierarchy.lanes", "gap_m"),
            ("hierarchy.lanes", "l_turn_min_deg"),
            ("hierarchy.lanes", "l_turn_max_deg"),
            ("hierarchy.lanes", "way_merge_deg"),
            ("hierarchy.segments", "junction_radius_m"),
            ("hierarchy.segments", "road_half_width_m"),
            ("hierarchy.relations", "candidate_m"),
            ("hierarchy.relations", "near_m"),
            ("hierarchy.relations", "next_to_m"),
            ("hierarchy.relations", "on_tolerance_m"),
            ("hierarchy.relations", "inside_fraction"),
            ("oracle", "component_eps_m"),
            ("mapping", "voxel_m"),
            ("mapping", "dbscan_eps_m"),
            ("mapping", "w_geo"),
            ("mapping", "iou_min_side_m"),
            ("mapping", "foreground_min_share"),
            ("hierarchy.drivable", "cell_m"),
            ("hierarchy.drivable", "alpha_m"),
            ("hierarchy.drivable", "max_gap_m"),
            ("dynamic", "bin_deg"),
            ("dynamic", "margin_m"),
            ("dynamic", "margin_frac"),
            ("dynamic", "min_range_m"),
            ("dynamic", "moving_detection_share"),
        ];
        for (table, key) in keys {
            for v in ["nan", "inf", "-inf", "-1.0", "1e300"] {
                let path = dir.path().join("bad.toml");
                std::fs::write(&path, format!("[{table}]\n{key} = {v}\n")).unwrap();
                let e = match BuildConfig::from_toml_file(&path) {
                    Ok(_) => panic!("[{table}] {key} = {v} was accepted"),
                    Err(e) => e.to_string(),
                };
                assert!(e.contains(key), "[{table}] {key} = {v}: {e}");
                assert!(e.contains("bad.toml"), "{e}");
            }
        }
        // relations between keys
        let path = dir.path().join("rel.toml");
        std::fs::write(
            &path,
            "[hierarchy.relations]\nnext_to_m = 5.0\nnear_m = 3.0\n",
        )
        .unwrap();
        assert!(
            BuildConfig::from_toml_file(&path)
                .unwrap_err()
                .to_string()
                .contains("next_to_m")
        );
        std::fs::write(
            &path,
            "[hierarchy.lanes]\nl_turn_min_deg = 90.0\nl_turn_max_deg = 60.0\n",
        )
        .unwrap();
        assert!(
            BuildConfig::from_toml_file(&path)
                .unwrap_err()
                .to_string()
                .contains("l_turn_min_deg")
        );
        // a misspelt key is an error in every table, with the file and line
        for table in [
            "mapping",
            "dynamic",
            "hierarchy",
            "hierarchy.drivable",
            "hierarchy.lanes",
            "hierarchy.segments",
            "hierarchy.relations",
            "oracle",
        ] {
            std::fs::write(&path, format!("[{table}]\nmin_vote = 2\n")).unwrap();
            let e = BuildConfig::from_toml_file(&path).unwrap_err().to_string();
            assert!(
                e.contains("rel.toml:2") && e.contains("unknown field `min_vote`"),
                "[{table}]: {e}"
            );
        }
        // the defaults pass
        std::fs::write(&path, "").unwrap();
        assert!(BuildConfig::from_toml_file(&path).is_ok());
    }

    /// docs/build.md shows the default configuration; it must parse to exactly the defaults.
    #[test]
    fn documented_defaults_are_the_defaults() {
        let doc =
            std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/build.md"))
                .unwrap();
        let start = doc.find("```toml\n").expect("a toml block") + 8;
        let end = start + doc[start..].find("```").unwrap();
        // every key is shown, with its default value
        fn keys(t: &toml::Table, prefix: &str, out: &mut Vec<String>) {
            for (k, v) in t {
                match v {
                    toml::Value::Table(sub) => keys(sub, &format!("{prefix}{k}."), out),
                    _ => out.push(format!("{prefix}{k}")),
                }
            }
            out.sort();
        }
        let text = &doc[start..end];
        let shown: toml::Table = toml::from_str(text).unwrap();
        let defaults = toml::Table::try_from(BuildConfig::default()).unwrap();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        keys(&shown, "", &mut a);
        keys(&defaults, "", &mut b);
        let parsed: BuildConfig = toml::from_str(text).unwrap();
        if a != b || parsed != BuildConfig::default() {
            panic!(
                "docs/build.md is out of date; the defaults are:\n{}",
                toml::to_string(&BuildConfig::default()).unwrap()
            );
        }
    }

    #[test]
    fn frame_numbers() {
        assert_eq!(frame_number(Path::new("a/000012.bin"), ".bin"), Some(12));
        assert_eq!(frame_number(Path::new("a/12.bin"), ".bin"), None);
        assert_eq!(frame_number(Path::new("a/000012.label"), ".bin"), None);
    }
}
