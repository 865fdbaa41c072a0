//! The build driver for live frames: the same mapping, commits, post-processing and
//! hierarchy as a batch [`build`], fed one assembled frame at a time
//! ([`crate::sources::live`]) inside a running server.
//!
//! - A frame is mapped once `[dynamic] window` later frames have arrived (its free-space
//!   carving needs scans on both sides, as in a batch build), or when the stream goes idle.
//! - A commit every `[mapping] commit_every` mapped frames writes the changed objects, the
//!   frames and the checkpoint (the last committed cloud stamp and the poses so far), so a
//!   server killed at any point restarts from its last commit; clouds stamped at or before it
//!   are then skipped.
//! - The hierarchy is rewritten from the poses so far at most every
//!   `[live] hierarchy_period_secs`, and after `[live] idle_finish_secs` without frames the
//!   map is finished as a batch build finishes it (post-processing, then the hierarchy).
//!
//! Each commit yields [`MapEvent`]s for the server to publish.

use std::collections::VecDeque;

use super::*;
use crate::mapping::dynamic::{RangeImage, dynamic_mask};
use crate::sources::live::{LiveConfig, LiveFrame, LiveStats};

/// What changed in the map, as a server publishes it.
#[derive(
    Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum MapEventKind {
    /// Instances created (node ids).
    InstanceAdded,
    /// Instances whose points, box, caption or feature changed.
    InstanceUpdated,
    /// Instances deleted (merged into another or dropped as noise).
    InstanceRemoved,
    /// The lanes, segments and relations were rewritten.
    HierarchyRefreshed,
    /// A map edit was applied (`update_map`).
    EditApplied,
    /// A map edit was undone.
    EditUndone,
    /// A Cypher write changed the map.
    CypherWrite,
}

/// One change of the map.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub struct MapEvent {
    /// The publisher's event number: consecutive from 1 for each server run, so a subscriber
    /// that sees a gap knows it missed events.
    pub seq: u64,
    /// The store's commit sequence after the change ([`graphstore::Store::commit_seq`]).
    pub commit: u64,
    /// What happened.
    pub kind: MapEventKind,
    /// The nodes concerned (node ids, ascending).
    pub ids: Vec<u64>,
}

/// How far in time a neighbouring scan of the dynamic filter may be: the batch build's 50
/// poses at KITTI's 10 Hz.
const NEIGHBOUR_REACH_NS: i64 = 5_000_000_000;

/// A frame waiting in the window, mapped or kept as a neighbour.
struct Buffered {
    frame: LiveFrame,
    mapped: bool,
    image: Option<RangeImage>,
}

/// The live build: see the module docs.
pub struct LiveBuild<'a> {
    store: &'a Store,
    run: Run<'a>,
    cfg: BuildConfig,
    live: LiveConfig,
    window: VecDeque<Buffered>,
    /// LiDAR world positions of every pose so far.
    trajectory: Vec<(i64, [f64; 3])>,
    /// Poses at or before this stamp came with the store (a restarted server): a stream
    /// that replays them is not added twice.
    resumed_through_ns: Option<i64>,
    pending: Vec<FrameRecord>,
    /// The stamp of the last frame in `pending`.
    pending_stamp: Option<i64>,
    /// When the frames in `pending` arrived (the input's clock).
    pending_arrivals: Vec<f64>,
    /// Arrivals of frames committed since [`LiveBuild::take_committed`].
    committed_arrivals: Vec<f64>,
    next_index: u32,
    last_stamp_ns: Option<i64>,
    last_hierarchy: Option<Instant>,
    /// How long the last refresh took: the next waits at least ten times as long, so the
    /// refreshes take at most a tenth of the mapping's time as the map grows.
    last_hierarchy_secs: f64,
    /// Frames were mapped since the last finish.
    unfinished: bool,
    /// The hierarchy is older than the poses.
    hierarchy_stale: bool,
    report: BuildReport,
    times: StageTimes,
    t_embed: f64,
    /// The store's commit after this build's last own write: later commits are another
    /// writer's (a map edit, a Cypher write) until the next own one.
    seen_seq: u64,
}

impl std::fmt::Debug for LiveBuild<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveBuild")
            .field("window", &self.window.len())
            .field("next_index", &self.next_index)
            .field("last_stamp_ns", &self.last_stamp_ns)
            .finish_non_exhaustive()
    }
}

fn live_args(cfg: &BuildConfig, live: &LiveConfig, embedder: &str) -> Result<String> {
    Ok(serde_json::json!({
        "source": "live",
        "config": resume_config(cfg)?,
        "environment": live.environment,
        "embedder": embedder,
    })
    .to_string())
}

impl<'a> LiveBuild<'a> {
    /// Opens the live build of `store`: a new one in an empty store, or the one a previous
    /// server left (its objects, frame numbers, last stamp and poses reloaded).
    ///
    /// # Errors
    /// [`Error::Invalid`] when the store holds a batch build or a live build made with
    /// another mapping configuration or embedder, or a bad configuration; store errors.
    pub fn open(
        store: &'a Store,
        cfg: &BuildConfig,
        live: &LiveConfig,
        embedder: &'a mut dyn Embedder,
        merger: &'a mut dyn CaptionMerger,
    ) -> Result<LiveBuild<'a>> {
        cfg.mapping.validate()?;
        cfg.dynamic.validate()?;
        cfg.hierarchy.validate()?;
        live.validate()?;
        let args_json = live_args(cfg, live, &embedder.name())?;
        if store.schema() == graphstore::Schema::default() {
            store.set_schema(scene::opengraph_schema())?;
        }
        let (checkpoint, objects, nodes, stamp, trajectory) = {
            let r = store.read()?;
            let cp = load_checkpoint(&r)?;
            let (objects, nodes) = load_objects(&r, cfg.mapping.voxel_m)?;
            let (stamp, traj) = match &cp {
                Some(cp) => (
                    r.node_prop(cp.node, key::LAST_STAMP_NS)?
                        .and_then(|v| v.as_int()),
                    match r.node_prop(cp.node, key::TRAJECTORY)? {
                        Some(Value::List(v)) => v
                            .chunks_exact(3)
                            .map(|c| {
                                let f = |i: usize| c[i].as_f64().unwrap_or(0.0);
                                [f(0), f(1), f(2)]
                            })
                            .collect(),
                        _ => Vec::new(),
                    },
                ),
                None => (None, Vec::new()),
            };
            (cp, objects, nodes, stamp, traj)
        };
        let path = store.path().to_path_buf();
        let (checkpoint_node, next_frame, next_id) = match checkpoint {
            Some(cp) => {
                if cp.args != args_json {
                    return Err(Error::Invalid(format!(
                        "{} holds {}; live ingest continues only a live build with the same mapping configuration and embedder:\n  stored: {}\n  given:  {}",
                        path.display(),
                        if cp.args.contains("\"source\":\"live\"") {
                            "a live build made with other settings"
                        } else {
                            "a batch build"
                        },
                        cp.args,
                        args_json
                    )));
                }
                (cp.node, cp.next_frame, cp.next_instance_id)
            }
            None => {
                if !objects.is_empty() {
                    return Err(Error::Invalid(format!(
                        "{} has Instance nodes but no build checkpoint; serve live ingest into a new --db",
                        path.display()
                    )));
                }
                let node = create_checkpoint(store, &args_json, 0, "live")?;
                (node, 0, 0)
            }
        };
        let mut emb = EmbedCache {
            embedder,
            cache: HashMap::new(),
        };
        let list = classes::prompts();
        let texts: Vec<&str> = list.iter().map(|p| p.1).collect();
        let prompts: Vec<(u8, Vec<f32>)> =
            list.iter().map(|p| p.0).zip(emb.get_all(&texts)?).collect();
        let run = Run {
            store,
            mapper: Mapper::restore(cfg.mapping.clone(), GroundFrame::KittiCam, objects, next_id),
            nodes,
            emb,
            merger,
            prompts,
            lexicon: super::labels::lexicon().0,
            producer: String::new(),
            checkpoint_node,
            checkpoint_extra: Vec::new(),
            pinned: std::collections::BTreeSet::new(),
        };
        Ok(LiveBuild {
            seen_seq: store.commit_seq(),
            store,
            run,
            cfg: cfg.clone(),
            live: live.clone(),
            window: VecDeque::new(),
            trajectory: trajectory.into_iter().map(|p| (i64::MIN, p)).collect(),
            resumed_through_ns: stamp,
            pending: Vec::new(),
            pending_stamp: None,
            pending_arrivals: Vec::new(),
            committed_arrivals: Vec::new(),
            next_index: u32::try_from(next_frame.max(0)).unwrap_or(u32::MAX),
            last_stamp_ns: stamp,
            last_hierarchy: None,
            last_hierarchy_secs: 0.0,
            unfinished: false,
            hierarchy_stale: false,
            report: BuildReport {
                source: "live".into(),
                ..BuildReport::default()
            },
            times: StageTimes::default(),
            t_embed: 0.0,
        })
    }

    /// The last committed cloud stamp: clouds at or before it are in the map.
    pub fn mapped_through_ns(&self) -> Option<i64> {
        self.last_stamp_ns
    }

    /// Adds a pose (its stamp, nanoseconds) to the trajectory the hierarchy is built from
    /// (the LiDAR's world position; poses come more often than frames). Poses a restarted
    /// server already has are skipped; a late pose goes in its place by stamp.
    pub fn add_pose(&mut self, stamp_ns: i64, world_from_velo: &Rigid3) {
        if self.resumed_through_ns.is_some_and(|r| stamp_ns <= r) {
            return;
        }
        let t = world_from_velo.translation.vector;
        let at = self.trajectory.partition_point(|(s, _)| *s <= stamp_ns);
        self.trajectory.insert(at, (stamp_ns, [t.x, t.y, t.z]));
        self.hierarchy_stale = true;
    }

    fn positions(&self) -> Vec<[f64; 3]> {
        self.trajectory.iter().map(|(_, p)| *p).collect()
    }

    /// Takes one frame; maps the frames that now have their neighbours, commits when due.
    /// Returns the events of any commit.
    ///
    /// # Errors
    /// Store or embedder failures (the frame's mapping is then lost, the store unchanged
    /// since its last commit).
    pub fn push(&mut self, frame: LiveFrame, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        self.window.push_back(Buffered {
            frame,
            mapped: false,
            image: None,
        });
        let w = self.cfg.dynamic.window as usize;
        let mut events = Vec::new();
        while let Some(k) = self.window.iter().position(|b| !b.mapped) {
            // its later neighbours are all in, or the newest frame is out of its reach
            let newest = self.window.back().map_or(0, |b| b.frame.stamp_ns);
            let out_of_reach = newest - self.window[k].frame.stamp_ns > NEIGHBOUR_REACH_NS;
            if self.window.len() - k - 1 < w && !out_of_reach {
                break;
            }
            events.extend(self.map_at(k, stats)?);
        }
        self.trim();
        Ok(events)
    }

    /// Maps every frame still waiting for neighbours and commits them.
    ///
    /// # Errors
    /// As [`LiveBuild::push`].
    pub fn flush(&mut self, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        let mut events = Vec::new();
        while let Some(k) = self.window.iter().position(|b| !b.mapped) {
            events.extend(self.map_at(k, stats)?);
        }
        if !self.pending.is_empty() {
            events.extend(self.commit(stats)?);
        }
        self.trim();
        Ok(events)
    }

    /// Keeps the mapped frames a later frame may still need as a neighbour.
    fn trim(&mut self) {
        let keep = (self.cfg.dynamic.window as usize).max(self.cfg.mapping.accumulate - 1);
        let first_unmapped = self
            .window
            .iter()
            .position(|b| !b.mapped)
            .unwrap_or(self.window.len());
        let drop = first_unmapped.saturating_sub(keep);
        self.window.drain(..drop);
    }

    fn map_at(&mut self, k: usize, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        let cfg = self.cfg.clone();
        let w = cfg.dynamic.window as usize;
        // up to `window` scans on each side, within the batch build's reach (50 poses at
        // 10 Hz): a scan seconds away saw another street
        let stamp_k = self.window[k].frame.stamp_ns;
        let near = |j: usize| (self.window[j].frame.stamp_ns - stamp_k).abs() <= NEIGHBOUR_REACH_NS;
        let mut lo = k;
        while lo > 0 && k - (lo - 1) <= w && near(lo - 1) {
            lo -= 1;
        }
        let mut hi = k;
        while hi + 1 < self.window.len() && hi + 1 - k <= w && near(hi + 1) {
            hi += 1;
        }
        let (kept, removed) = if cfg.dynamic.enabled {
            for j in (lo..=hi).filter(|j| *j != k) {
                let b = &mut self.window[j];
                if b.image.is_none() {
                    b.image = Some(RangeImage::new(
                        &b.frame.points,
                        &b.frame.world_from_velo,
                        cfg.dynamic.bin_deg,
                        cfg.dynamic.spread_bins,
                    ));
                }
            }
            let refs: Vec<&RangeImage> = (lo..=hi)
                .filter(|j| *j != k)
                .filter_map(|j| self.window[j].image.as_ref())
                .collect();
            let f = &self.window[k].frame;
            let mask = dynamic_mask(&f.points, &f.world_from_velo, &refs, &cfg.dynamic);
            let rep = &mut self.report.dynamic;
            rep.neighbour_scans += refs.len() as u64;
            rep.key_scans += 1;
            rep.points += f.points.len() as u64;
            rep.removed += mask.iter().filter(|m| **m).count() as u64;
            let (mut kept, mut removed) = (Vec::new(), Vec::new());
            for (p, m) in f.points.iter().zip(mask) {
                if m {
                    removed.push(*p);
                } else {
                    kept.push(*p);
                }
            }
            (kept, removed)
        } else {
            (self.window[k].frame.points.clone(), Vec::new())
        };
        // earlier scans moved into this one's frame (`[mapping] accumulate`)
        let mut points = kept;
        if cfg.mapping.accumulate > 1 {
            let f = &self.window[k].frame;
            let velo_from_world = f.world_from_velo.inverse();
            for j in (k.saturating_sub(cfg.mapping.accumulate - 1)..k).rev() {
                let o = &self.window[j].frame;
                let m = velo_from_world * o.world_from_velo;
                for q in &o.points {
                    let p =
                        scene::pose::apply(&m, [f64::from(q[0]), f64::from(q[1]), f64::from(q[2])]);
                    points.push([p[0] as f32, p[1] as f32, p[2] as f32, q[3]]);
                }
            }
        }
        let index = self.next_index;
        let f = &self.window[k].frame;
        let (stamp, world_from_velo) = (f.stamp_ns, f.world_from_velo);
        let record = self.run.map_key_frame(
            &cfg,
            KeyFrame {
                index,
                world_from_velo,
                timestamp_secs: Some(stamp as f64 * 1e-9),
                points: &points,
                removed: &removed,
                camera: &f.camera,
                detections: &f.detections,
            },
            &mut self.report,
            &mut self.times,
            &mut self.t_embed,
        )?;
        self.window[k].mapped = true;
        self.next_index = index.saturating_add(1);
        self.pending.push(record);
        self.pending_stamp = Some(stamp);
        self.pending_arrivals
            .push(self.window[k].frame.arrived_secs);
        self.unfinished = true;
        stats.frames_mapped += 1;
        // commits fall on the same frames whether or not the server was restarted (a
        // commit re-reads the points it wrote, so where commits fall shapes the map)
        if (self.next_index as usize).is_multiple_of(cfg.mapping.commit_every) {
            return self.commit(stats);
        }
        Ok(Vec::new())
    }

    /// The checkpoint values a live commit adds: the stamp it covers and the poses so far.
    fn checkpoint_extra(&self) -> Vec<(&'static str, Value)> {
        // the poses up to the last committed cloud: the later ones come again with the
        // clouds a restarted stream sends again
        let through = self.pending_stamp.or(self.last_stamp_ns);
        let mut out = vec![(
            key::TRAJECTORY,
            Value::List(
                self.trajectory
                    .iter()
                    .filter(|(s, _)| through.is_some_and(|t| *s <= t))
                    .flat_map(|(_, p)| p.iter().map(|c| Value::Float(*c)))
                    .collect(),
            ),
        )];
        if let Some(s) = through {
            out.push((key::LAST_STAMP_NS, Value::Int(s)));
        }
        out
    }

    fn event(&self, kind: MapEventKind, mut ids: Vec<u64>) -> MapEvent {
        ids.sort_unstable();
        MapEvent {
            seq: 0,
            commit: self.store.commit_seq(),
            kind,
            ids,
        }
    }

    /// Commits the mapped frames: the changed objects, the frames and the checkpoint in one
    /// transaction.
    fn commit(&mut self, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        self.note_others();
        let out = self.commit_own(stats);
        self.seen_seq = self.store.commit_seq();
        out
    }

    /// Pins the objects whose instances another writer changed since this build's last own
    /// write ([`LiveBuild::seen_seq`]): a map edit or a Cypher write stands, and this build no
    /// longer rewrites them (their deletion is also caught in the write itself).
    fn note_others(&mut self) {
        let now = self.store.commit_seq();
        if now == self.seen_seq {
            return;
        }
        let changed = self
            .store
            .read()
            .ok()
            .and_then(|r| graphstore::GraphRead::nodes_changed_since(&r, self.seen_seq));
        self.seen_seq = now;
        let Some(changed) = changed else {
            return;
        };
        let changed: std::collections::BTreeSet<u64> = changed.into_iter().collect();
        for (iid, node) in &self.run.nodes {
            if changed.contains(node) && self.run.pinned.insert(*iid) {
                tracing::warn!(
                    target: "opengraph::live",
                    "instance {node} was changed by another writer while mapping (a map edit or a Cypher write): the change stands, and the mapper no longer rewrites that object"
                );
            }
        }
    }

    fn commit_own(&mut self, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        let dirty: Vec<u64> = self
            .run
            .mapper
            .objects()
            .values()
            .filter(|o| o.dirty)
            .map(|o| o.instance_id)
            .collect();
        let updated: Vec<u64> = dirty
            .iter()
            .filter_map(|i| self.run.nodes.get(i).copied())
            .collect();
        self.run.checkpoint_extra = self.checkpoint_extra();
        let pending = std::mem::take(&mut self.pending);
        let out = self
            .run
            .commit(&pending, i64::from(self.next_index), &[], &[], false);
        self.run.checkpoint_extra.clear();
        let arrivals = std::mem::take(&mut self.pending_arrivals);
        if let Err(e) = out {
            // the store is as it was: these frames are lost, not half-written
            self.pending_stamp = None;
            return Err(e);
        }
        self.last_stamp_ns = self.pending_stamp.take().or(self.last_stamp_ns);
        self.committed_arrivals.extend(arrivals);
        self.report.commits += 1;
        stats.commits += 1;
        let added: Vec<u64> = dirty
            .iter()
            .filter_map(|i| self.run.nodes.get(i).copied())
            .filter(|n| !updated.contains(n))
            .collect();
        tracing::info!(
            target: "opengraph::live",
            "committed {} key frame(s): {} instance(s) added, {} updated ({} frames mapped of {} assembled, {} commits)",
            pending.len(),
            added.len(),
            updated.len(),
            stats.frames_mapped,
            stats.frames_assembled,
            stats.commits,
        );
        let mut events = Vec::new();
        if !added.is_empty() {
            events.push(self.event(MapEventKind::InstanceAdded, added));
        }
        if !updated.is_empty() {
            events.push(self.event(MapEventKind::InstanceUpdated, updated));
        }
        Ok(events)
    }

    /// Rewrites the lanes, segments and relations from the poses so far. Too few poses for
    /// a lane graph is not an error: the refresh waits for more.
    fn refresh_hierarchy(&mut self, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        self.note_others();
        let out = self.refresh_hierarchy_own(stats);
        self.seen_seq = self.store.commit_seq();
        out
    }

    fn refresh_hierarchy_own(&mut self, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        let started = Instant::now();
        self.last_hierarchy = Some(started);
        // labels are normalised over the whole map with the hierarchy
        let labels =
            super::labels::label_instances(self.store, &mut self.run.emb, &self.run.lexicon)?;
        self.report.labels = Some(labels);
        if self.trajectory.len() < 2 {
            return Ok(Vec::new());
        }
        let out = build_hierarchy(
            self.store,
            &self.positions(),
            GroundFrame::KittiCam,
            &self.live.environment,
            &self.cfg.hierarchy,
        );
        self.last_hierarchy_secs = started.elapsed().as_secs_f64();
        match out {
            Ok((_, _, h)) => {
                self.hierarchy_stale = false;
                stats.hierarchy_refreshes += 1;
                tracing::info!(
                    target: "opengraph::live",
                    "hierarchy refreshed in {:.2} s from {} poses",
                    self.last_hierarchy_secs,
                    self.trajectory.len(),
                );
                self.report.hierarchy = Some(h);
                Ok(vec![
                    self.event(MapEventKind::HierarchyRefreshed, Vec::new()),
                ])
            }
            Err(Error::Store(e)) => Err(Error::Store(e)),
            Err(e) => {
                tracing::warn!(target: "opengraph::live", "hierarchy not refreshed yet: {e}");
                Ok(Vec::new())
            }
        }
    }

    /// Maps and commits everything waiting, post-processes the whole map as a batch build
    /// does at its end, and rewrites the hierarchy.
    ///
    /// # Errors
    /// As [`LiveBuild::push`].
    pub fn finish(&mut self, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        let mut events = self.flush(stats)?;
        if self.unfinished {
            let before: BTreeMap<u64, u64> = self.run.nodes.clone();
            self.run.checkpoint_extra = self.checkpoint_extra();
            self.note_others();
            let out = self
                .run
                .finish_objects(&self.cfg, i64::from(self.next_index));
            self.seen_seq = self.store.commit_seq();
            self.run.checkpoint_extra.clear();
            let post = out?;
            self.report.commits += 1;
            stats.commits += 1;
            let removed: Vec<u64> = post
                .dropped
                .iter()
                .chain(post.merged.iter().map(|m| &m.1))
                .filter_map(|i| before.get(i).copied())
                .collect();
            let grown: Vec<u64> = post
                .merged
                .iter()
                .filter_map(|m| self.run.nodes.get(&m.0).copied())
                .collect();
            if !removed.is_empty() {
                events.push(self.event(MapEventKind::InstanceRemoved, removed));
            }
            if !grown.is_empty() {
                let mut g = grown;
                g.dedup();
                events.push(self.event(MapEventKind::InstanceUpdated, g));
            }
            self.report.post = post;
            self.unfinished = false;
            self.hierarchy_stale = true;
        }
        if self.hierarchy_stale {
            events.extend(self.refresh_hierarchy(stats)?);
        }
        Ok(events)
    }

    /// What the clock asks for, `idle_secs` after the last frame: the map finished once the
    /// stream has been idle for `[live] idle_finish_secs`, otherwise the hierarchy refreshed
    /// when it is stale and `[live] hierarchy_period_secs` (or ten times the last refresh's
    /// duration, when longer) have passed since the last one.
    ///
    /// # Errors
    /// As [`LiveBuild::push`].
    pub fn tick(&mut self, idle_secs: f64, stats: &mut LiveStats) -> Result<Vec<MapEvent>> {
        if idle_secs >= self.live.idle_finish_secs
            && (self.unfinished || self.window.iter().any(|b| !b.mapped))
        {
            return self.finish(stats);
        }
        let period = self
            .live
            .hierarchy_period_secs
            .max(10.0 * self.last_hierarchy_secs);
        let due = self
            .last_hierarchy
            .is_none_or(|t| t.elapsed().as_secs_f64() >= period);
        if self.hierarchy_stale && due && self.report.commits > 0 {
            return self.refresh_hierarchy(stats);
        }
        Ok(Vec::new())
    }

    /// When the frames committed since the last call arrived (the input's clock).
    pub fn take_committed(&mut self) -> Vec<f64> {
        std::mem::take(&mut self.committed_arrivals)
    }

    /// What this run did, in the batch build's terms.
    pub fn report(&self) -> &BuildReport {
        &self.report
    }
}

/// Runs live ingest into `store` until `stop` is set: opens the live build (continuing the
/// one a previous server left), hands the input side to `ready` (the transport feeds it),
/// then maps frames as they come, calling `emit` with each change. On `stop` everything
/// received is mapped, committed and finished.
///
/// # Errors
/// What [`LiveBuild::open`] refuses. Failures while running (a store write refused, an
/// embedder error) are logged and counted in the input's `last_error`; the loop goes on.
#[allow(clippy::too_many_arguments)]
pub fn run_live(
    store: &Store,
    cfg: &BuildConfig,
    live: &LiveConfig,
    embedder: &mut dyn Embedder,
    merger: &mut dyn CaptionMerger,
    ready: &mut dyn FnMut(std::sync::Arc<crate::sources::live::LiveInput>),
    emit: &mut dyn FnMut(MapEvent),
    stop: &std::sync::atomic::AtomicBool,
) -> Result<BuildReport> {
    use std::sync::atomic::Ordering;
    let mut build = LiveBuild::open(store, cfg, live, embedder, merger)?;
    let input = std::sync::Arc::new(crate::sources::live::LiveInput::new(
        live,
        build.mapped_through_ns(),
    )?);
    ready(input.clone());
    let mut stats = LiveStats::default();
    let mut last_frame = Instant::now();
    let fail = |e: Error| {
        tracing::error!(target: "opengraph::live", "live mapping: {e}");
    };
    loop {
        let stopping = stop.load(Ordering::Relaxed);
        input.tick();
        for (stamp, p) in input.take_poses() {
            build.add_pose(stamp, &p);
        }
        if stopping {
            while let Some(f) = input.queue().pop(std::time::Duration::ZERO) {
                match build.push(f, &mut stats) {
                    Ok(ev) => ev.into_iter().for_each(&mut *emit),
                    Err(e) => fail(e),
                }
            }
            match build.finish(&mut stats) {
                Ok(ev) => ev.into_iter().for_each(&mut *emit),
                Err(e) => fail(e),
            }
            input.record_committed(&build.take_committed());
            input.record_mapping(&stats);
            break;
        }
        if let Some(f) = input.queue().pop(std::time::Duration::from_millis(50)) {
            last_frame = Instant::now();
            match build.push(f, &mut stats) {
                Ok(ev) => ev.into_iter().for_each(&mut *emit),
                Err(e) => fail(e),
            }
        }
        match build.tick(last_frame.elapsed().as_secs_f64(), &mut stats) {
            Ok(ev) => ev.into_iter().for_each(&mut *emit),
            Err(e) => fail(e),
        }
        input.record_committed(&build.take_committed());
        input.record_mapping(&stats);
    }
    Ok(build.report().clone())
}
