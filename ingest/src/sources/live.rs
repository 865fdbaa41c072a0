//! Frames from live sensor messages: the `[live]` configuration (topics, domain, frames and
//! calibration, timing), the assembler that pairs each cloud with its pose, camera and
//! detections by timestamp, and the bounded queue between the transport and the mapping.
//!
//! The assembler is transport-free and driven by an explicit clock, so it is tested without
//! a network. A cloud waits at most `max_wait_secs` for its parts, then it is dropped and
//! counted; frames leave in stamp order; a cloud whose stamp is not after the last one taken
//! is refused and counted. The queue holds at most `queue_frames` frames: when mapping falls
//! behind, the oldest is dropped and counted, so memory stays bounded.

use std::collections::{BTreeMap, VecDeque};
use std::sync::{Condvar, Mutex, PoisonError};
use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::mapping::project::Camera;
use crate::sources::detections::DetectionFrame;
use scene::pose::{Projection, Rigid3};

/// `[live]`: what `opengraph serve --zenoh` subscribes to and how it turns messages into
/// frames. Frames: clouds are in the LiDAR frame; the odometry gives the pose of its child
/// frame in `odom` (ROS: x forward, y left, z up); the map's world is KITTI's camera-style
/// frame (y down), reached by `world_from_odom`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LiveConfig {
    /// The ROS 2 domain id: the first chunk of every rmw_zenoh key.
    pub domain_id: u32,
    /// `sensor_msgs/PointCloud2` topic (LiDAR scans).
    pub cloud_topic: String,
    /// `nav_msgs/Odometry` topic; empty to use `pose_topic` instead.
    pub odometry_topic: String,
    /// `geometry_msgs/PoseStamped` topic; empty for none.
    pub pose_topic: String,
    /// `sensor_msgs/CameraInfo` topic (the rectified camera's `P` and image size).
    pub camera_info_topic: String,
    /// `std_msgs/String` topic carrying the detections JSON with a `stamp` member.
    pub detections_topic: String,
    /// Row-major `[R | t]` (12 numbers): the camera's frame from the LiDAR's (KITTI's `Tr`).
    /// Projection is `P · cam_from_velo`. Required: there is no default calibration.
    pub cam_from_velo: Vec<f64>,
    /// Row-major `[R | t]`: the pose's child frame from the LiDAR frame (identity when the
    /// odometry is the LiDAR's own).
    pub child_from_velo: Vec<f64>,
    /// Row-major `[R | t]`: the map's world frame from the odometry frame. The default turns
    /// ROS's z-up `odom` into KITTI's camera-style world (x right, y down, z forward).
    pub world_from_odom: Vec<f64>,
    /// Parts of one frame match when their stamps differ by at most this much.
    pub stamp_tolerance_secs: f64,
    /// A cloud waits this long for its pose, camera and detections, then is dropped.
    pub max_wait_secs: f64,
    /// Frames waiting for the mapping at most; beyond it the oldest is dropped.
    pub queue_frames: usize,
    /// The hierarchy (lanes, segments, relations) is refreshed from the poses so far at most
    /// this often (and at most every ten times the last refresh's duration), while frames
    /// arrive.
    pub hierarchy_period_secs: f64,
    /// With no frame for this long, post-processing and the hierarchy run over the whole map
    /// (as at the end of a batch build).
    pub idle_finish_secs: f64,
    /// The environment node's name.
    pub environment: String,
}

/// ROS's `odom` (x forward, y left, z up) to KITTI's camera-style world (x right, y down,
/// z forward).
pub const WORLD_FROM_ROS: [f64; 12] = [
    0.0, -1.0, 0.0, 0.0, //
    0.0, 0.0, -1.0, 0.0, //
    1.0, 0.0, 0.0, 0.0,
];

const IDENTITY: [f64; 12] = [
    1.0, 0.0, 0.0, 0.0, //
    0.0, 1.0, 0.0, 0.0, //
    0.0, 0.0, 1.0, 0.0,
];

impl Default for LiveConfig {
    fn default() -> Self {
        LiveConfig {
            domain_id: 0,
            cloud_topic: "velodyne_points".into(),
            odometry_topic: "odom".into(),
            pose_topic: String::new(),
            camera_info_topic: "camera/camera_info".into(),
            detections_topic: "detections".into(),
            cam_from_velo: Vec::new(),
            child_from_velo: IDENTITY.to_vec(),
            world_from_odom: WORLD_FROM_ROS.to_vec(),
            stamp_tolerance_secs: 0.02,
            max_wait_secs: 2.0,
            queue_frames: 32,
            hierarchy_period_secs: 10.0,
            idle_finish_secs: 3.0,
            environment: "live".into(),
        }
    }
}

fn rigid(name: &str, v: &[f64]) -> Result<Rigid3> {
    if v.len() != 12 || !v.iter().all(|x| x.is_finite()) {
        return Err(Error::Invalid(format!(
            "[live] {name} must be 12 finite numbers (row-major [R | t]), got {}",
            v.len()
        )));
    }
    let t = scene::pose::rigid_from_row_major(v).expect("12 numbers");
    let r = t.rotation.matrix();
    if (r * r.transpose() - nalgebra::Matrix3::identity())
        .abs()
        .max()
        > 1e-3
    {
        return Err(Error::Invalid(format!(
            "[live] {name}: the rotation block is not orthonormal"
        )));
    }
    Ok(t)
}

impl LiveConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the key: an empty `cloud_topic` or `camera_info_topic`,
    /// neither pose topic, a topic that is not a ROS name, a transform that is not 12 finite
    /// numbers with an orthonormal rotation, a time that is not finite and positive (or
    /// above a day), or a queue of 0 or more than 1024 frames.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Invalid(format!("[live] {m}")));
        for (k, t) in [
            ("cloud_topic", &self.cloud_topic),
            ("camera_info_topic", &self.camera_info_topic),
            ("detections_topic", &self.detections_topic),
            ("odometry_topic", &self.odometry_topic),
            ("pose_topic", &self.pose_topic),
        ] {
            let optional = matches!(k, "odometry_topic" | "pose_topic");
            if t.is_empty() && !optional {
                return bad(format!("{k} is empty"));
            }
            let name = t.trim_start_matches('/');
            if !t.is_empty()
                && (name.is_empty()
                    || !name.split('/').all(|c| {
                        !c.is_empty() && c.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
                    }))
            {
                return bad(format!(
                    "{k} = {t:?} is not a ROS topic name (letters, digits, _ and /)"
                ));
            }
        }
        if self.odometry_topic.is_empty() && self.pose_topic.is_empty() {
            return bad("one of odometry_topic and pose_topic must be set".into());
        }
        if !self.cam_from_velo.is_empty() {
            rigid("cam_from_velo", &self.cam_from_velo)?;
        }
        rigid("child_from_velo", &self.child_from_velo)?;
        rigid("world_from_odom", &self.world_from_odom)?;
        for (k, v) in [
            ("stamp_tolerance_secs", self.stamp_tolerance_secs),
            ("max_wait_secs", self.max_wait_secs),
            ("hierarchy_period_secs", self.hierarchy_period_secs),
            ("idle_finish_secs", self.idle_finish_secs),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 86_400.0) {
                return bad(format!("{k} = {v} must be above 0 and at most 86400"));
            }
        }
        if self.queue_frames == 0 || self.queue_frames > 1024 {
            return bad(format!(
                "queue_frames = {} must be 1 to 1024",
                self.queue_frames
            ));
        }
        Ok(())
    }

    /// The LiDAR-to-camera calibration.
    ///
    /// # Errors
    /// [`Error::Invalid`] when `cam_from_velo` is not set (or not a rigid transform).
    pub fn cam_from_velo(&self) -> Result<Rigid3> {
        if self.cam_from_velo.is_empty() {
            return Err(Error::Invalid(
                "[live] cam_from_velo is not set: give the LiDAR-to-camera calibration (12 numbers, KITTI's Tr), or --calib calib.txt".into(),
            ));
        }
        rigid("cam_from_velo", &self.cam_from_velo)
    }

    /// `world_from_odom` and `child_from_velo` as transforms.
    ///
    /// # Errors
    /// As [`LiveConfig::validate`].
    pub fn frames(&self) -> Result<(Rigid3, Rigid3)> {
        Ok((
            rigid("world_from_odom", &self.world_from_odom)?,
            rigid("child_from_velo", &self.child_from_velo)?,
        ))
    }
}

/// One decoded message, as the assembler takes it. Stamps are nanoseconds.
#[derive(Debug, Clone)]
pub enum Part {
    /// A LiDAR scan (velodyne frame, finite points only).
    Cloud {
        /// Its stamp.
        stamp_ns: i64,
        /// Its points.
        points: Vec<[f32; 4]>,
    },
    /// A pose of the LiDAR in the map's world frame.
    Pose {
        /// Its stamp.
        stamp_ns: i64,
        /// `world_from_velo`.
        world_from_velo: Rigid3,
    },
    /// The camera (latched: the latest is used for every later cloud).
    Camera {
        /// `P` of the rectified camera.
        projection: Projection,
        /// Image width in pixels.
        width: u32,
        /// Image height in pixels.
        height: u32,
    },
    /// Detections for the cloud with this stamp.
    Detections {
        /// Its stamp.
        stamp_ns: i64,
        /// The detections.
        frame: DetectionFrame,
    },
}

/// A complete frame for the mapping.
#[derive(Debug, Clone)]
pub struct LiveFrame {
    /// The cloud's stamp (nanoseconds).
    pub stamp_ns: i64,
    /// The frame number: the detections' `frame`.
    pub index: u32,
    /// The scan (velodyne frame).
    pub points: Vec<[f32; 4]>,
    /// The LiDAR's pose.
    pub world_from_velo: Rigid3,
    /// The camera.
    pub camera: Camera,
    /// The detections.
    pub detections: DetectionFrame,
    /// When its cloud arrived, in seconds on the input's clock ([`LiveInput::clock_secs`]).
    pub arrived_secs: f64,
}

/// What the live path has seen, in counts. Every message either becomes part of a frame or
/// is counted here under the reason it was not.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct LiveStats {
    /// Messages received, by kind (`cloud`, `odometry`, `pose`, `camera_info`,
    /// `detections`).
    pub received: BTreeMap<String, u64>,
    /// Messages refused as malformed (bad CDR, sizes, NaNs, layouts, JSON), by kind.
    pub malformed: BTreeMap<String, u64>,
    /// Non-finite points dropped from clouds.
    pub nonfinite_points: u64,
    /// Messages on a configured topic of another ROS type than the topic takes (not
    /// decoded), by kind.
    #[serde(default)]
    pub wrong_type: BTreeMap<String, u64>,
    /// Clouds dropped because a part did not come within `max_wait_secs`, by the part.
    pub incomplete: BTreeMap<String, u64>,
    /// Clouds refused because their stamp was not after the last cloud taken.
    pub stamp_backwards: u64,
    /// Clouds already in the map (a resumed stream), skipped.
    pub already_mapped: u64,
    /// Frames dropped (oldest first) because the mapping fell behind.
    pub dropped_behind: u64,
    /// Frames assembled.
    pub frames_assembled: u64,
    /// Frames mapped.
    pub frames_mapped: u64,
    /// Commits of mapped frames.
    pub commits: u64,
    /// Hierarchy refreshes.
    pub hierarchy_refreshes: u64,
    /// The last malformed message: its key and what was wrong.
    pub last_error: Option<String>,
    /// Milliseconds from a cloud's arrival to the commit that makes its frame queryable,
    /// median over the last 10,000 frames.
    pub latency_ms_p50: Option<f64>,
    /// The same, 99th percentile.
    pub latency_ms_p99: Option<f64>,
}

impl LiveStats {
    /// Counts a malformed message of `kind` from `key`, and logs it.
    pub fn malformed(&mut self, kind: &str, key: &str, error: &str) {
        *self.malformed.entry(kind.to_string()).or_default() += 1;
        tracing::warn!(target: "opengraph::live", "malformed {kind} on {key}: {error}");
        self.last_error = Some(format!("{key}: {error}"));
    }

    /// Counts and logs a message of another type (DDS type name `got`) on `kind`'s topic.
    pub fn wrong_type(&mut self, kind: MessageKind, key: &str, got: &str) {
        *self.wrong_type.entry(kind.name().to_string()).or_default() += 1;
        let want = kind.ros_type();
        tracing::warn!(
            target: "opengraph::live",
            "{got} on {key}: the {} topic takes {}; not read",
            kind.name(),
            want.name
        );
        self.last_error = Some(format!(
            "{key}: a {got} message, but the {} topic takes {}",
            kind.name(),
            want.name
        ));
    }

    /// Counts a received message of `kind`.
    pub fn received(&mut self, kind: &str) {
        *self.received.entry(kind.to_string()).or_default() += 1;
    }
}

struct Waiting {
    arrived_secs: f64,
    points: Vec<[f32; 4]>,
}

/// Pairs clouds with poses, the camera and detections by stamp; see the module docs.
#[derive(Debug)]
pub struct Assembler {
    tolerance_ns: i64,
    max_wait_secs: f64,
    cam_from_velo: Rigid3,
    clouds: BTreeMap<i64, Waiting>,
    poses: BTreeMap<i64, Rigid3>,
    camera: Option<(Projection, u32, u32)>,
    detections: BTreeMap<i64, DetectionFrame>,
    /// The stamp of the last cloud taken (or skipped as already mapped).
    last_ns: Option<i64>,
    /// Clouds at or before this stamp are in the map already.
    mapped_through_ns: Option<i64>,
}

impl std::fmt::Debug for Waiting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Waiting")
            .field("arrived_secs", &self.arrived_secs)
            .field("points", &self.points.len())
            .finish()
    }
}

/// Older parts than this behind the newest cloud are forgotten.
const KEEP_PARTS_NS: i64 = 60_000_000_000;

impl Assembler {
    /// An assembler with `cfg`'s timing and calibration; clouds stamped at or before
    /// `mapped_through_ns` are skipped as already mapped.
    ///
    /// # Errors
    /// [`Error::Invalid`] for a bad configuration or no calibration.
    pub fn new(cfg: &LiveConfig, mapped_through_ns: Option<i64>) -> Result<Assembler> {
        cfg.validate()?;
        Ok(Assembler {
            tolerance_ns: (cfg.stamp_tolerance_secs * 1e9) as i64,
            max_wait_secs: cfg.max_wait_secs,
            cam_from_velo: cfg.cam_from_velo()?,
            clouds: BTreeMap::new(),
            poses: BTreeMap::new(),
            camera: None,
            detections: BTreeMap::new(),
            last_ns: mapped_through_ns,
            mapped_through_ns,
        })
    }

    /// Takes one part that arrived at `now_secs` (any monotonic clock).
    pub fn push(&mut self, part: Part, now_secs: f64, stats: &mut LiveStats) {
        match part {
            Part::Cloud { stamp_ns, points } => {
                if self.mapped_through_ns.is_some_and(|m| stamp_ns <= m) {
                    stats.already_mapped += 1;
                    return;
                }
                if self.last_ns.is_some_and(|l| stamp_ns <= l)
                    || self.clouds.contains_key(&stamp_ns)
                {
                    stats.stamp_backwards += 1;
                    tracing::warn!(target: "opengraph::live", "cloud stamped {stamp_ns} ns is not after the last cloud; dropped");
                    return;
                }
                self.clouds.insert(
                    stamp_ns,
                    Waiting {
                        arrived_secs: now_secs,
                        points,
                    },
                );
            }
            Part::Pose {
                stamp_ns,
                world_from_velo,
            } => {
                self.poses.insert(stamp_ns, world_from_velo);
            }
            Part::Camera {
                projection,
                width,
                height,
            } => self.camera = Some((projection, width, height)),
            Part::Detections { stamp_ns, frame } => {
                self.detections.insert(stamp_ns, frame);
            }
        }
    }

    fn nearest<T>(map: &BTreeMap<i64, T>, stamp: i64, tol: i64) -> Option<i64> {
        let before = map.range(..=stamp).next_back().map(|(k, _)| *k);
        let after = map.range(stamp..).next().map(|(k, _)| *k);
        [before, after]
            .into_iter()
            .flatten()
            .filter(|k| (k - stamp).abs() <= tol)
            .min_by_key(|k| (k - stamp).abs())
    }

    /// The frames complete at `now_secs`, oldest first. A cloud older than a complete one
    /// is waited for until its time is up (then dropped and counted), so frames leave in
    /// stamp order.
    pub fn poll(&mut self, now_secs: f64, stats: &mut LiveStats) -> Vec<LiveFrame> {
        let mut out = Vec::new();
        while let Some((&stamp, waiting)) = self.clouds.iter().next() {
            let tol = self.tolerance_ns;
            let pose = Self::nearest(&self.poses, stamp, tol);
            let dets = Self::nearest(&self.detections, stamp, tol);
            match (pose, dets, self.camera) {
                (Some(p), Some(d), Some((projection, width, height))) => {
                    let world_from_velo = self.poses[&p];
                    let detections = self.detections.remove(&d).expect("found");
                    let cloud = self.clouds.remove(&stamp).expect("found");
                    let camera = Camera {
                        image_from_velo: projection * self.cam_from_velo.to_homogeneous(),
                        width,
                        height,
                    };
                    self.last_ns = Some(stamp);
                    stats.frames_assembled += 1;
                    out.push(LiveFrame {
                        stamp_ns: stamp,
                        index: detections.frame,
                        points: cloud.points,
                        world_from_velo,
                        camera,
                        detections,
                        arrived_secs: cloud.arrived_secs,
                    });
                }
                (pose, _, camera) => {
                    if now_secs - waiting.arrived_secs < self.max_wait_secs {
                        break;
                    }
                    let missing = if pose.is_none() {
                        "pose"
                    } else if camera.is_none() {
                        "camera_info"
                    } else {
                        "detections"
                    };
                    *stats.incomplete.entry(missing.into()).or_default() += 1;
                    tracing::warn!(target: "opengraph::live", "cloud stamped {stamp} ns dropped: no {missing} within {} s", self.max_wait_secs);
                    // not taken: a later cloud stamped before it is still welcome (a cloud
                    // stamped far ahead must not shut out the stream behind it)
                    self.clouds.remove(&stamp);
                }
            }
        }
        // parts far behind the last cloud taken, the oldest one waiting and the newest pose
        // can no longer match anything (a cloud stamped far ahead, even the first one, must not
        // make the stream's own parts look old)
        let oldest_waiting = self.clouds.keys().next().copied();
        let newest_pose = self.poses.keys().next_back().copied();
        if let Some(anchor) = [self.last_ns, oldest_waiting].into_iter().flatten().min() {
            let cut = newest_pose.map_or(anchor, |p| anchor.min(p)) - KEEP_PARTS_NS;
            self.poses = self.poses.split_off(&cut);
            self.detections = self.detections.split_off(&cut);
        }
        out
    }

    /// Clouds waiting for a part.
    pub fn waiting(&self) -> usize {
        self.clouds.len()
    }
}

/// The bounded queue between the transport and the mapping: at most `capacity` frames;
/// pushing onto a full queue drops the oldest frame and counts it.
#[derive(Debug)]
pub struct FrameQueue {
    inner: Mutex<(VecDeque<LiveFrame>, bool)>,
    ready: Condvar,
    capacity: usize,
}

impl FrameQueue {
    /// An empty queue of `capacity` frames (at least 1).
    pub fn new(capacity: usize) -> FrameQueue {
        FrameQueue {
            inner: Mutex::new((VecDeque::new(), false)),
            ready: Condvar::new(),
            capacity: capacity.max(1),
        }
    }

    /// Adds a frame; returns how many were dropped to make room (0 or 1).
    pub fn push(&self, frame: LiveFrame) -> u64 {
        let mut g = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        let mut dropped = 0;
        while g.0.len() >= self.capacity {
            g.0.pop_front();
            dropped += 1;
        }
        g.0.push_back(frame);
        self.ready.notify_one();
        dropped
    }

    /// The oldest frame, waiting at most `timeout`; `None` on timeout or once closed and
    /// empty.
    pub fn pop(&self, timeout: Duration) -> Option<LiveFrame> {
        let g = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        let (mut g, _) = self
            .ready
            .wait_timeout_while(g, timeout, |q| q.0.is_empty() && !q.1)
            .unwrap_or_else(PoisonError::into_inner);
        g.0.pop_front()
    }

    /// No more frames will come; waiters wake.
    pub fn close(&self) {
        self.inner.lock().unwrap_or_else(PoisonError::into_inner).1 = true;
        self.ready.notify_all();
    }

    /// Whether [`FrameQueue::close`] was called.
    pub fn is_closed(&self) -> bool {
        self.inner.lock().unwrap_or_else(PoisonError::into_inner).1
    }

    /// Frames waiting.
    pub fn len(&self) -> usize {
        self.inner
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .0
            .len()
    }

    /// Whether no frame waits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The kinds of message live ingest subscribes to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MessageKind {
    /// `sensor_msgs/PointCloud2`.
    Cloud,
    /// `nav_msgs/Odometry`.
    Odometry,
    /// `geometry_msgs/PoseStamped`.
    Pose,
    /// `sensor_msgs/CameraInfo`.
    CameraInfo,
    /// Detections JSON in a `std_msgs/String`.
    Detections,
}

impl MessageKind {
    /// Every kind.
    pub const ALL: [MessageKind; 5] = [
        MessageKind::Cloud,
        MessageKind::Odometry,
        MessageKind::Pose,
        MessageKind::CameraInfo,
        MessageKind::Detections,
    ];

    /// The name counts use: `cloud`, `odometry`, `pose`, `camera_info`, `detections`.
    pub fn name(self) -> &'static str {
        match self {
            MessageKind::Cloud => "cloud",
            MessageKind::Odometry => "odometry",
            MessageKind::Pose => "pose",
            MessageKind::CameraInfo => "camera_info",
            MessageKind::Detections => "detections",
        }
    }

    /// The ROS 2 type.
    pub fn ros_type(self) -> crate::sources::ros::RosType {
        use crate::sources::ros::*;
        match self {
            MessageKind::Cloud => POINT_CLOUD2,
            MessageKind::Odometry => ODOMETRY,
            MessageKind::Pose => POSE_STAMPED,
            MessageKind::CameraInfo => CAMERA_INFO,
            MessageKind::Detections => STRING,
        }
    }

    /// Its topic in `cfg` (`None` when not subscribed).
    pub fn topic(self, cfg: &LiveConfig) -> Option<&str> {
        let t = match self {
            MessageKind::Cloud => &cfg.cloud_topic,
            MessageKind::Odometry => &cfg.odometry_topic,
            MessageKind::Pose => &cfg.pose_topic,
            MessageKind::CameraInfo => &cfg.camera_info_topic,
            MessageKind::Detections => &cfg.detections_topic,
        };
        (!t.is_empty()).then(|| t.trim_start_matches('/'))
    }
}

/// Counts the mapping side keeps (frames mapped, commits, hierarchy refreshes).
#[derive(Debug, Default)]
struct MappingCounts {
    frames_mapped: std::sync::atomic::AtomicU64,
    commits: std::sync::atomic::AtomicU64,
    hierarchy_refreshes: std::sync::atomic::AtomicU64,
    /// Arrival-to-commit latencies (ms), the last [`LATENCY_WINDOW`].
    latencies_ms: Mutex<VecDeque<f64>>,
}

/// Latencies kept for the percentiles.
const LATENCY_WINDOW: usize = 10_000;

/// The input side of live ingest, shared by the transport's callbacks and the mapping
/// thread: messages in ([`LiveInput::accept`]), assembled frames out through the bounded
/// [`FrameQueue`], poses out for the trajectory, and the counts.
#[derive(Debug)]
pub struct LiveInput {
    assembler: Mutex<Assembler>,
    queue: FrameQueue,
    stats: Mutex<LiveStats>,
    poses: Mutex<Vec<(i64, Rigid3)>>,
    world_from_odom: Rigid3,
    child_from_velo: Rigid3,
    clock: std::time::Instant,
    mapping: MappingCounts,
}

/// Most poses waiting for the mapping thread; older ones are dropped (the trajectory then
/// has a gap, which the lane graph bridges).
const MAX_WAITING_POSES: usize = 100_000;

impl LiveInput {
    /// The input for `cfg`; clouds stamped at or before `mapped_through_ns` are skipped.
    ///
    /// # Errors
    /// [`Error::Invalid`] for a bad configuration or a missing calibration.
    pub fn new(cfg: &LiveConfig, mapped_through_ns: Option<i64>) -> Result<LiveInput> {
        let (world_from_odom, child_from_velo) = cfg.frames()?;
        Ok(LiveInput {
            assembler: Mutex::new(Assembler::new(cfg, mapped_through_ns)?),
            queue: FrameQueue::new(cfg.queue_frames),
            stats: Mutex::new(LiveStats::default()),
            poses: Mutex::new(Vec::new()),
            world_from_odom,
            child_from_velo,
            clock: std::time::Instant::now(),
            mapping: MappingCounts::default(),
        })
    }

    fn now(&self) -> f64 {
        self.clock.elapsed().as_secs_f64()
    }

    /// Seconds on the input's clock (what [`LiveFrame::arrived_secs`] is measured on).
    pub fn clock_secs(&self) -> f64 {
        self.now()
    }

    /// Records that frames which arrived at `arrivals` (clock seconds) are now committed.
    pub fn record_committed(&self, arrivals: &[f64]) {
        let now = self.now();
        let mut l = self
            .mapping
            .latencies_ms
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        for a in arrivals {
            if l.len() >= LATENCY_WINDOW {
                l.pop_front();
            }
            l.push_back((now - a) * 1e3);
        }
    }

    fn decode(&self, kind: MessageKind, payload: &[u8], stats: &mut LiveStats) -> Result<Part> {
        use crate::sources::ros::*;
        let what = kind.ros_type().name;
        Ok(match kind {
            MessageKind::Cloud => {
                let c: PointCloud2 = decode(what, payload)?;
                let p = c.points()?;
                stats.nonfinite_points += p.nonfinite;
                Part::Cloud {
                    stamp_ns: c.header.stamp.as_nanos(),
                    points: p.points,
                }
            }
            MessageKind::Odometry | MessageKind::Pose => {
                let (stamp, pose) = if kind == MessageKind::Odometry {
                    let o: Odometry = decode(what, payload)?;
                    (o.header.stamp, o.pose.pose)
                } else {
                    let o: PoseStamped = decode(what, payload)?;
                    (o.header.stamp, o.pose)
                };
                let odom_from_child = pose.to_rigid(what)?;
                Part::Pose {
                    stamp_ns: stamp.as_nanos(),
                    world_from_velo: self.world_from_odom * odom_from_child * self.child_from_velo,
                }
            }
            MessageKind::CameraInfo => {
                let c: CameraInfo = decode(what, payload)?;
                let (projection, width, height) = c.projection()?;
                Part::Camera {
                    projection,
                    width,
                    height,
                }
            }
            MessageKind::Detections => {
                let s: RosString = decode(what, payload)?;
                let (stamp_ns, frame) = detections_of_string(&s.data)?;
                Part::Detections { stamp_ns, frame }
            }
        })
    }

    /// Takes one message of `kind` that arrived on `key`. A malformed one is counted and
    /// logged with its key; nothing else happens to it. Complete frames go to the queue.
    pub fn accept(&self, kind: MessageKind, key: &str, payload: &[u8]) {
        let now = self.now();
        let mut stats = LiveStats::default();
        stats.received(kind.name());
        let part = self.decode(kind, payload, &mut stats);
        let frames = {
            let mut a = self
                .assembler
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            match part {
                Ok(part) => {
                    if let Part::Pose {
                        world_from_velo,
                        stamp_ns,
                    } = &part
                    {
                        let mut p = self.poses.lock().unwrap_or_else(PoisonError::into_inner);
                        if p.len() >= MAX_WAITING_POSES {
                            p.remove(0);
                        }
                        p.push((*stamp_ns, *world_from_velo));
                    }
                    a.push(part, now, &mut stats);
                }
                Err(e) => stats.malformed(kind.name(), key, &e.to_string()),
            }
            a.poll(now, &mut stats)
        };
        self.enqueue(frames, stats);
    }

    /// Counts a message of another ROS type (DDS type name `got`) that came on `kind`'s
    /// topic at `key`; it is not decoded.
    pub fn refuse_type(&self, kind: MessageKind, key: &str, got: &str) {
        let mut stats = LiveStats::default();
        stats.wrong_type(kind, key, got);
        self.enqueue(Vec::new(), stats);
    }

    /// Drops the clouds whose parts are overdue (call it now and then when no message comes).
    pub fn tick(&self) {
        let mut stats = LiveStats::default();
        let frames = self
            .assembler
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .poll(self.now(), &mut stats);
        self.enqueue(frames, stats);
    }

    fn enqueue(&self, frames: Vec<LiveFrame>, mut stats: LiveStats) {
        for f in frames {
            stats.dropped_behind += self.queue.push(f);
        }
        let mut s = self.stats.lock().unwrap_or_else(PoisonError::into_inner);
        merge(&mut s, stats);
    }

    /// The queue of assembled frames.
    pub fn queue(&self) -> &FrameQueue {
        &self.queue
    }

    /// The poses received since the last call (stamp in nanoseconds, `world_from_velo`),
    /// in arrival order.
    pub fn take_poses(&self) -> Vec<(i64, Rigid3)> {
        std::mem::take(&mut *self.poses.lock().unwrap_or_else(PoisonError::into_inner))
    }

    /// Records the mapping side's counts (cumulative).
    pub fn record_mapping(&self, mapped: &LiveStats) {
        use std::sync::atomic::Ordering::Relaxed;
        self.mapping
            .frames_mapped
            .store(mapped.frames_mapped, Relaxed);
        self.mapping.commits.store(mapped.commits, Relaxed);
        self.mapping
            .hierarchy_refreshes
            .store(mapped.hierarchy_refreshes, Relaxed);
    }

    /// Every count so far.
    pub fn stats(&self) -> LiveStats {
        use std::sync::atomic::Ordering::Relaxed;
        let mut s = self
            .stats
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        s.frames_mapped = self.mapping.frames_mapped.load(Relaxed);
        s.commits = self.mapping.commits.load(Relaxed);
        s.hierarchy_refreshes = self.mapping.hierarchy_refreshes.load(Relaxed);
        let mut l: Vec<f64> = self
            .mapping
            .latencies_ms
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .iter()
            .copied()
            .collect();
        l.sort_by(f64::total_cmp);
        let pct = |q: f64| {
            (!l.is_empty()).then(|| {
                let i = ((l.len() - 1) as f64 * q).round() as usize;
                (l[i] * 10.0).round() / 10.0
            })
        };
        s.latency_ms_p50 = pct(0.5);
        s.latency_ms_p99 = pct(0.99);
        s
    }
}

fn merge(into: &mut LiveStats, from: LiveStats) {
    let add = |a: &mut BTreeMap<String, u64>, b: BTreeMap<String, u64>| {
        for (k, v) in b {
            *a.entry(k).or_default() += v;
        }
    };
    add(&mut into.received, from.received);
    add(&mut into.malformed, from.malformed);
    add(&mut into.incomplete, from.incomplete);
    add(&mut into.wrong_type, from.wrong_type);
    into.nonfinite_points += from.nonfinite_points;
    into.stamp_backwards += from.stamp_backwards;
    into.already_mapped += from.already_mapped;
    into.dropped_behind += from.dropped_behind;
    into.frames_assembled += from.frames_assembled;
    if from.last_error.is_some() {
        into.last_error = from.last_error;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sources::detections::Producer;

    fn cfg() -> LiveConfig {
        LiveConfig {
            cam_from_velo: IDENTITY.to_vec(),
            ..LiveConfig::default()
        }
    }

    fn dets(frame: u32) -> DetectionFrame {
        DetectionFrame {
            frame,
            width: 10,
            height: 10,
            producer: Producer::Simulator,
            detections: Vec::new(),
        }
    }

    fn camera() -> Part {
        Part::Camera {
            projection: Projection::identity(),
            width: 10,
            height: 10,
        }
    }

    const MS: i64 = 1_000_000;

    #[test]
    fn parts_meet_by_stamp_within_the_tolerance() {
        let mut a = Assembler::new(&cfg(), None).unwrap();
        let mut st = LiveStats::default();
        a.push(camera(), 0.0, &mut st);
        a.push(
            Part::Cloud {
                stamp_ns: 100 * MS,
                points: vec![[1.0; 4]],
            },
            0.0,
            &mut st,
        );
        a.push(
            Part::Pose {
                stamp_ns: 105 * MS,
                world_from_velo: Rigid3::identity(),
            },
            0.0,
            &mut st,
        );
        assert!(a.poll(0.1, &mut st).is_empty(), "no detections yet");
        // detections 30 ms off: outside the 20 ms tolerance
        a.push(
            Part::Detections {
                stamp_ns: 130 * MS,
                frame: dets(9),
            },
            0.1,
            &mut st,
        );
        assert!(a.poll(0.2, &mut st).is_empty());
        a.push(
            Part::Detections {
                stamp_ns: 99 * MS,
                frame: dets(7),
            },
            0.2,
            &mut st,
        );
        let f = a.poll(0.3, &mut st);
        assert_eq!(f.len(), 1);
        assert_eq!((f[0].index, f[0].stamp_ns), (7, 100 * MS));
        assert_eq!(st.frames_assembled, 1);
    }

    #[test]
    fn incomplete_clouds_wait_then_are_dropped_in_order() {
        let mut a = Assembler::new(&cfg(), None).unwrap();
        let mut st = LiveStats::default();
        a.push(camera(), 0.0, &mut st);
        // cloud 1 never gets a pose; cloud 2 is complete but must wait behind it
        a.push(
            Part::Cloud {
                stamp_ns: 100 * MS,
                points: vec![],
            },
            0.0,
            &mut st,
        );
        a.push(
            Part::Detections {
                stamp_ns: 100 * MS,
                frame: dets(1),
            },
            0.0,
            &mut st,
        );
        a.push(
            Part::Cloud {
                stamp_ns: 200 * MS,
                points: vec![],
            },
            0.5,
            &mut st,
        );
        a.push(
            Part::Pose {
                stamp_ns: 200 * MS,
                world_from_velo: Rigid3::identity(),
            },
            0.5,
            &mut st,
        );
        a.push(
            Part::Detections {
                stamp_ns: 200 * MS,
                frame: dets(2),
            },
            0.5,
            &mut st,
        );
        assert!(a.poll(1.0, &mut st).is_empty());
        let f = a.poll(2.1, &mut st);
        assert_eq!(f.iter().map(|f| f.index).collect::<Vec<_>>(), vec![2]);
        assert_eq!(st.incomplete.get("pose"), Some(&1));
        // a late cloud older than the last one is refused
        a.push(
            Part::Cloud {
                stamp_ns: 150 * MS,
                points: vec![],
            },
            3.0,
            &mut st,
        );
        assert_eq!(st.stamp_backwards, 1);
        assert_eq!(a.waiting(), 0);
    }

    #[test]
    fn a_cloud_stamped_far_ahead_does_not_shut_out_the_stream() {
        let mut a = Assembler::new(&cfg(), None).unwrap();
        let mut st = LiveStats::default();
        a.push(camera(), 0.0, &mut st);
        let frame = |a: &mut Assembler, st: &mut LiveStats, k: i64, now: f64| {
            let stamp_ns = k * 100 * MS;
            a.push(
                Part::Cloud {
                    stamp_ns,
                    points: vec![],
                },
                now,
                st,
            );
            a.push(
                Part::Pose {
                    stamp_ns,
                    world_from_velo: Rigid3::identity(),
                },
                now,
                st,
            );
            a.push(
                Part::Detections {
                    stamp_ns,
                    frame: dets(k as u32),
                },
                now,
                st,
            );
        };
        // a cloud a million seconds ahead, with no parts, before anything else; then frame 1's
        // pose, which waits for its cloud across a poll
        a.push(
            Part::Cloud {
                stamp_ns: 1_000_000_000 * MS,
                points: vec![],
            },
            0.0,
            &mut st,
        );
        a.push(
            Part::Pose {
                stamp_ns: 100 * MS,
                world_from_velo: Rigid3::identity(),
            },
            0.0,
            &mut st,
        );
        assert!(a.poll(0.0, &mut st).is_empty());
        a.push(
            Part::Cloud {
                stamp_ns: 100 * MS,
                points: vec![],
            },
            0.0,
            &mut st,
        );
        a.push(
            Part::Detections {
                stamp_ns: 100 * MS,
                frame: dets(1),
            },
            0.0,
            &mut st,
        );
        let mut taken = Vec::new();
        for k in 2..40 {
            let now = k as f64 * 0.1;
            frame(&mut a, &mut st, k, now);
            taken.extend(a.poll(now, &mut st).into_iter().map(|f| f.index));
        }
        assert_eq!(taken, (1..40).collect::<Vec<u32>>());
        assert_eq!(st.incomplete.get("pose"), Some(&1), "{st:?}");
        // after it is dropped, the stream goes on
        frame(&mut a, &mut st, 40, 5.0);
        let f = a.poll(5.0, &mut st);
        assert_eq!(f.iter().map(|f| f.index).collect::<Vec<_>>(), vec![40]);
        assert_eq!(st.stamp_backwards, 0);
        assert_eq!(a.waiting(), 0);
    }

    #[test]
    fn clouds_already_mapped_are_skipped() {
        let mut a = Assembler::new(&cfg(), Some(500 * MS)).unwrap();
        let mut st = LiveStats::default();
        a.push(
            Part::Cloud {
                stamp_ns: 400 * MS,
                points: vec![],
            },
            0.0,
            &mut st,
        );
        a.push(
            Part::Cloud {
                stamp_ns: 500 * MS,
                points: vec![],
            },
            0.0,
            &mut st,
        );
        assert_eq!((st.already_mapped, a.waiting()), (2, 0));
    }

    #[test]
    fn the_queue_drops_the_oldest_when_full() {
        let q = FrameQueue::new(2);
        let frame = |i: u32| LiveFrame {
            stamp_ns: i64::from(i),
            index: i,
            points: Vec::new(),
            world_from_velo: Rigid3::identity(),
            camera: Camera {
                image_from_velo: Projection::identity(),
                width: 1,
                height: 1,
            },
            detections: dets(i),
            arrived_secs: 0.0,
        };
        assert_eq!(q.push(frame(1)) + q.push(frame(2)), 0);
        assert_eq!(q.push(frame(3)), 1);
        assert_eq!(q.pop(Duration::ZERO).map(|f| f.index), Some(2));
        assert_eq!(q.pop(Duration::ZERO).map(|f| f.index), Some(3));
        assert!(q.pop(Duration::from_millis(1)).is_none());
        q.close();
        assert!(q.is_closed() && q.is_empty());
    }

    #[test]
    fn bad_configs_name_the_key() {
        let mut c = cfg();
        c.cloud_topic = "bad topic".into();
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("cloud_topic")
        );
        let mut c = cfg();
        c.cam_from_velo = vec![1.0; 12];
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("orthonormal")
        );
        let mut c = cfg();
        c.max_wait_secs = f64::NAN;
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("max_wait_secs")
        );
        let c = LiveConfig::default();
        assert!(c.cam_from_velo().unwrap_err().to_string().contains("calib"));
        c.validate().unwrap();
    }
}
