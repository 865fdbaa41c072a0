//! The map build driver: reads a KITTI-layout sequence and its detections (a directory of
//! detections files, or the label oracle), integrates key frames into the object map, commits
//! to the store every `commit_every` key frames, post-processes, and finally writes the
//! hierarchy over the whole trajectory. A killed build continues with `resume`.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use graphstore::{Direction, GraphRead, PointCloud, Store, Value};
use llm_tools::Embedder;

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
use scene::classes;
use scene::key;
use scene::records::InstanceRecord;

mod describe;
mod labels;
mod live;
mod resume;
mod sources;
use describe::*;
pub use labels::LabelReport;
pub use live::{LiveBuild, MapEvent, MapEventKind, run_live};
use resume::*;
pub use sources::*;

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
    /// Live ingest (`[live]`: topics, frames, calibration, timing), for `serve --zenoh`. Not
    /// part of a batch build's resume arguments.
    pub live: crate::sources::live::LiveConfig,
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
            .and_then(|()| cfg.live.validate())
            .map_err(|e| Error::File {
                path: path.to_path_buf(),
                detail: e.to_string(),
            })?;
        Ok(cfg)
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
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, schemars::JsonSchema)]
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
    /// The labelling pass at the end.
    pub labels: Option<LabelReport>,
    /// The hierarchy written at the end.
    pub hierarchy: Option<HierarchyReport>,
    /// Commits made by this run.
    pub commits: usize,
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
    /// WordNet for labels (empty when it is not installed).
    lexicon: llm_tools::labels::Lexicon,
    producer: String,
    checkpoint_node: u64,
    /// More checkpoint values for the next commit (a live build's stamp and poses).
    checkpoint_extra: Vec<(&'static str, Value)>,
    /// Objects whose instance another writer changed or deleted while a live build ran (a
    /// map edit, a Cypher write): their change stands, and this run no longer writes them.
    pinned: std::collections::BTreeSet<u64>,
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
        for o in self
            .mapper
            .objects()
            .values()
            .filter(|o| o.dirty && !self.pinned.contains(&o.instance_id))
        {
            let d = describe(
                o,
                &cfg,
                &mut self.emb,
                self.merger,
                &self.prompts,
                &self.lexicon,
            )?;
            let bytes = PointCloud {
                xyz: o.points.clone(),
                rgb: Vec::new(),
            }
            .encode()?;
            let decoded = PointCloud::decode(&bytes)?.xyz;
            let props = instance_record(o, &d, &self.producer, self.mapper.ground()).props();
            let obs: Vec<(u32, u32)> = o.observations.iter().map(|(f, n)| (*f, *n)).collect();
            writes.push((o.instance_id, props, bytes, decoded, obs));
        }
        let next_id = self.mapper.next_id();
        let known = &self.nodes;
        // a pinned object's instance keeps what another writer made of it, also when the
        // post-processing drops or merges the object
        let pinned = &self.pinned;
        let deleted_nodes: Vec<u64> = deleted
            .iter()
            .filter(|i| !pinned.contains(i))
            .filter_map(|i| known.get(i).copied())
            .collect();
        let merged_nodes: Vec<(u64, u64)> = merged
            .iter()
            .filter(|(k, g)| !pinned.contains(k) && !pinned.contains(g))
            .filter_map(|(k, g)| Some((*known.get(k)?, *known.get(g)?)))
            .collect();
        let checkpoint = self.checkpoint_node;
        let extra = &self.checkpoint_extra;
        let (created, vanished) = self.store.write(|tx| {
            // a node another writer deleted meanwhile is neither deleted again nor written
            let gone = |tx: &graphstore::WriteTxn<'_>, n: u64| -> graphstore::Result<bool> {
                Ok(tx.node(n)?.is_none())
            };
            // an absorbed object's observations move to the object that absorbed it
            if !merged_nodes.is_empty() {
                let obs_ty = tx.rel_type_id(scene::rel::OBSERVED_IN)?;
                let det_key = tx.prop_key_id(key::DETECTIONS)?;
                let count = |tx: &graphstore::WriteTxn<'_>, rel: u64| -> graphstore::Result<i64> {
                    Ok(tx
                        .rel(rel)?
                        .and_then(|r| r.get(det_key).and_then(Value::as_int))
                        .unwrap_or(1))
                };
                for (keep, absorbed) in &merged_nodes {
                    if gone(tx, *keep)? || gone(tx, *absorbed)? {
                        continue;
                    }
                    let existing = tx.neighbours(*keep, Direction::Outgoing, Some(obs_ty))?;
                    for a in tx.neighbours(*absorbed, Direction::Outgoing, Some(obs_ty))? {
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
                if !gone(tx, *n)? {
                    tx.detach_delete_node(*n)?;
                }
            }
            let mut frame_nodes: BTreeMap<u32, u64> = BTreeMap::new();
            for f in frames {
                let mut props = vec![
                    (key::INDEX, Value::Int(i64::from(f.index))),
                    (
                        key::WORLD_FROM_VELO,
                        Value::List(
                            scene::pose::row_major(&f.world_from_velo)
                                .into_iter()
                                .map(Value::Float)
                                .collect(),
                        ),
                    ),
                ];
                if let Some(t) = f.timestamp_secs {
                    props.push((key::TIMESTAMP_SECS, Value::Float(t)));
                }
                frame_nodes.insert(
                    f.index,
                    tx.create_node_named(&[scene::label::FRAME], &props)?,
                );
            }
            let mut created = Vec::new();
            let mut vanished = Vec::new();
            for (iid, props, bytes, _, obs) in &writes {
                let node = match known.get(iid) {
                    Some(n) if gone(tx, *n)? => {
                        vanished.push(*iid);
                        continue;
                    }
                    Some(n) => {
                        let mut kv = Vec::with_capacity(props.len());
                        for (k, v) in props {
                            kv.push((tx.prop_key_id(k)?, v.clone()));
                        }
                        tx.replace_node_props(*n, kv)?;
                        *n
                    }
                    None => {
                        let n = tx.create_node_named(&[scene::label::INSTANCE], props)?;
                        created.push((*iid, n));
                        n
                    }
                };
                tx.put_payload(node, PAYLOAD_KEY, bytes)?;
                for (f, count) in obs {
                    let fnode = match frame_nodes.get(f) {
                        Some(n) => *n,
                        None => match tx
                            .find_nodes(
                                scene::label::FRAME,
                                key::INDEX,
                                &Value::Int(i64::from(*f)),
                            )?
                            .first()
                        {
                            Some(n) => *n,
                            None => continue,
                        },
                    };
                    tx.create_rel_named(
                        node,
                        scene::rel::OBSERVED_IN,
                        fnode,
                        &[(key::DETECTIONS, Value::Int(i64::from(*count)))],
                    )?;
                }
            }
            let ty = tx.prop_key_id(key::NEXT_FRAME)?;
            tx.set_node_prop(checkpoint, ty, Value::Int(next_frame))?;
            let k = tx.prop_key_id(key::NEXT_INSTANCE_ID)?;
            tx.set_node_prop(checkpoint, k, Value::Int(next_id as i64))?;
            let k = tx.prop_key_id(key::FINISHED)?;
            tx.set_node_prop(checkpoint, k, Value::Bool(finished))?;
            for (name, v) in extra {
                let k = tx.prop_key_id(name)?;
                tx.set_node_prop(checkpoint, k, v.clone())?;
            }
            Ok((created, vanished))
        })?;
        for (iid, n) in created {
            self.nodes.insert(iid, n);
        }
        for iid in vanished {
            if let Some(n) = self.nodes.remove(&iid) {
                tracing::warn!(
                    target: "opengraph::live",
                    "instance {n} was deleted by another writer while mapping (a map edit or a Cypher write): the deletion stands, and the mapper no longer writes that object"
                );
            }
            self.pinned.insert(iid);
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

/// One key frame, ready for mapping.
struct KeyFrame<'f> {
    index: u32,
    world_from_velo: Rigid3,
    timestamp_secs: Option<f64>,
    /// Its points (velodyne frame), non-finite ones dropped, accumulated scans included.
    points: &'f [[f32; 4]],
    /// The points the dynamic filter took out.
    removed: &'f [[f32; 4]],
    camera: &'f Camera,
    detections: &'f DetectionFrame,
}

impl Run<'_> {
    /// Integrates one key frame (captions embedded, detections classed, objects associated
    /// and fused); counts go to `report`, stage times to `times` and `t_embed`. Returns the
    /// frame's record for the next commit.
    fn map_key_frame(
        &mut self,
        cfg: &BuildConfig,
        kf: KeyFrame<'_>,
        report: &mut BuildReport,
        times: &mut StageTimes,
        t_embed: &mut f64,
    ) -> Result<FrameRecord> {
        let dets = kf.detections;
        if self.producer.is_empty() {
            self.producer = dets.producer.as_str().to_string();
        }
        let t = Instant::now();
        let captions: Vec<&str> = dets.detections.iter().map(|d| d.caption.as_str()).collect();
        let cap_emb = self.emb.get_all(&captions)?;
        let tagged: Vec<(&[String], &str)> = dets
            .detections
            .iter()
            .map(|d| (d.tags.as_slice(), d.caption.as_str()))
            .collect();
        let det_classes = classify(&tagged, &mut self.emb, &self.prompts)?;
        let features: Vec<Vec<f32>> = dets
            .detections
            .iter()
            .zip(cap_emb)
            .map(|(d, e)| d.feature.clone().unwrap_or(e))
            .collect();
        *t_embed += t.elapsed().as_secs_f64() * 1e3;
        let stats = self.mapper.integrate(&FrameInput {
            index: kf.index,
            world_from_velo: kf.world_from_velo,
            points: kf.points,
            camera: kf.camera,
            detections: dets,
            features: &features,
            moving: cfg.dynamic.enabled.then_some(crate::mapping::MovingPoints {
                points: kf.removed,
                detection_share: cfg.dynamic.moving_detection_share,
            }),
            classes: &det_classes,
        });
        times.add(&stats.times);
        report.detections += stats.detections;
        report.detections_dropped += stats.dropped;
        report.detections_moving += stats.moving;
        report.frames_run += 1;
        Ok(FrameRecord {
            index: kf.index,
            world_from_velo: kf.world_from_velo,
            timestamp_secs: kf.timestamp_secs,
        })
    }

    /// Each object's kind, for joining its parts: the map-wide label of the noun phrase its
    /// captions name it by ([`llm_tools::labels::normalise`]: "bus shelter" and "shelter" are
    /// one kind), where a label that opens another with two or more words names the same
    /// kind ("bus stop" and "bus stop shelter": what stands at a bus stop is its shelter).
    /// Objects without a phrase, and background tiles, have none.
    fn object_kinds(&mut self) -> Result<Vec<(u64, String)>> {
        let mut phrase_of: Vec<(u64, String)> = Vec::new();
        for (id, o) in self.mapper.objects() {
            if o.tile.is_none()
                && let Some(p) = llm_tools::labels::object_phrase(&o.captions, &self.lexicon)
            {
                phrase_of.push((*id, p));
            }
        }
        let label_of = labels::labels_of(
            phrase_of.iter().map(|(_, p)| p.as_str()),
            &self.lexicon,
            &mut self.emb,
        )?;
        let labels: BTreeSet<&str> = label_of.values().map(String::as_str).collect();
        Ok(phrase_of
            .into_iter()
            .map(|(id, p)| {
                let label = label_of.get(&p).cloned().unwrap_or(p);
                (id, kind_of_label(&label, &labels))
            })
            .collect())
    }

    /// Post-processing over the whole map (small and duplicate objects, then touching
    /// buildings, fences and vegetation joined, then touching objects of one kind)
    /// committed as the finished state, with the checkpoint's next frame `next_frame`.
    fn finish_objects(&mut self, cfg: &BuildConfig, next_frame: i64) -> Result<PostReport> {
        let mut post = self.mapper.post_process();
        // buildings, fences and vegetation: objects that touch are one object. The class is
        // the one the object's label gets (other-object when none of the 19 fits: a bench
        // captioned near "fence" is not joined to the railing behind it), else its captions'
        let mut by_class: BTreeMap<u8, Vec<u64>> = BTreeMap::new();
        for (id, o) in self.mapper.objects() {
            if o.tile.is_none() {
                let c = match llm_tools::labels::object_phrase(&o.captions, &self.lexicon) {
                    Some(p) => thing_class(
                        &p,
                        &mut self.emb,
                        &self.prompts,
                        cfg.mapping.other_object_below,
                    )?,
                    None => object_class(o, &cfg.mapping, &mut self.emb, &self.prompts)?,
                };
                by_class.entry(c).or_default().push(*id);
            }
        }
        for class in JOINED_CLASSES {
            if let Some(ids) = by_class.get(&class) {
                let joined = self.mapper.join_touching(ids, cfg.mapping.join_eps_m);
                post.merged.extend(joined);
            }
        }
        // parts of one object (a shelter's walls, a billboard's legs, seen apart): objects
        // of one kind whose points touch are one
        let mut by_kind: BTreeMap<String, Vec<u64>> = BTreeMap::new();
        for (id, kind) in self.object_kinds()? {
            by_kind.entry(kind).or_default().push(id);
        }
        for ids in by_kind.values().filter(|ids| ids.len() > 1) {
            let joined = self.mapper.join_touching(ids, cfg.mapping.join_eps_m);
            post.merged.extend(joined);
        }
        // parts of one thing farther apart (a shelter's two ends seen from either side, its
        // middle never in view): joined when together they are no larger than a whole one;
        // stuff (buildings, fences, vegetation) has no such size
        let stuff: BTreeSet<u64> = JOINED_CLASSES
            .iter()
            .filter_map(|c| by_class.get(c))
            .flatten()
            .copied()
            .collect();
        for ids in by_kind.values() {
            let things: Vec<u64> = ids
                .iter()
                .copied()
                .filter(|id| !stuff.contains(id))
                .collect();
            let joined = self.mapper.join_parts(
                &things,
                JOIN_PARTS_QUANTILE,
                JOIN_PARTS_SLACK,
                JOIN_PARTS_MIN_OBJECTS,
            );
            post.merged.extend(joined);
        }
        let removed: Vec<u64> = post
            .dropped
            .iter()
            .copied()
            .chain(post.merged.iter().map(|m| m.1))
            .collect();
        // observations of absorbed objects move to the survivor with the rest of its state
        let merged = post.merged.clone();
        self.commit(&[], next_frame, &removed, &merged, true)?;
        Ok(post)
    }
}

/// Parts of a thing are joined when their pooled box is no larger than this quantile of the
/// kind's boxes (each side) ...
const JOIN_PARTS_QUANTILE: f64 = 0.9;
/// ... times this ...
const JOIN_PARTS_SLACK: f64 = 1.1;
/// ... for kinds with at least this many objects.
const JOIN_PARTS_MIN_OBJECTS: usize = 5;

/// The kind a map label names, for joining parts: the shortest of `labels` with two or more
/// words that opens `label` ("bus stop" for "bus stop shelter"), else `label` itself. A
/// one-word opening is not enough ("tree" does not make a "tree trunk" a tree).
fn kind_of_label(label: &str, labels: &BTreeSet<&str>) -> String {
    let words: Vec<&str> = label.split(' ').collect();
    (2..words.len())
        .map(|n| words[..n].join(" "))
        .find(|prefix| labels.contains(prefix.as_str()))
        .unwrap_or_else(|| label.to_string())
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
        store.set_schema(scene::opengraph_schema())?;
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
            let node =
                create_checkpoint(store, &args_json, i64::from(frames[0]), args.source.kind())?;
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
    let (lexicon, lexicon_missing) = labels::lexicon();
    let mut run = Run {
        store,
        mapper: Mapper::restore(cfg.mapping.clone(), ground, objects, next_id),
        nodes,
        emb,
        merger,
        prompts,
        lexicon,
        producer,
        checkpoint_node,
        checkpoint_extra: Vec::new(),
        pinned: std::collections::BTreeSet::new(),
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
        let record = run.map_key_frame(
            cfg,
            KeyFrame {
                index: i,
                world_from_velo,
                timestamp_secs: seq.times.as_ref().and_then(|t| t.get(i as usize).copied()),
                points: &points,
                removed: &removed,
                camera: &camera,
                detections: &dets,
            },
            &mut report,
            &mut times,
            &mut t_embed,
        )?;
        pending.push(record);
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
        let last = frames.last().map_or(0, |f| i64::from(*f) + 1);
        report.post = run.finish_objects(cfg, last)?;
        report.commits += 1;
    }
    let mut l = labels::label_instances(store, &mut run.emb, &run.lexicon)?;
    l.lexicon_missing = lexicon_missing;
    report.labels = Some(l);
    if !hierarchy_done {
        let traj = seq.trajectory();
        let (_, _, h) = build_hierarchy(store, &traj, ground, &args.environment, &cfg.hierarchy)?;
        store.write(|tx| {
            let k = tx.prop_key_id(key::HIERARCHY_DONE)?;
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
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        if let Some(Value::String(c)) = r.node_prop(id, key::SEMANTIC_CLASS)? {
            *report.instances_per_class.entry(c).or_insert(0) += 1;
        }
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_label_opened_by_another_of_two_words_is_its_kind() {
        let labels: BTreeSet<&str> = [
            "bus stop",
            "bus stop shelter",
            "tree",
            "tree trunk",
            "bench",
        ]
        .into();
        assert_eq!(kind_of_label("bus stop shelter", &labels), "bus stop");
        assert_eq!(kind_of_label("bus stop", &labels), "bus stop");
        // one word is not enough
        assert_eq!(kind_of_label("tree trunk", &labels), "tree trunk");
        assert_eq!(kind_of_label("bench", &labels), "bench");
    }

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
