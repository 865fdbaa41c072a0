//! `opengraph replay`: publishes a KITTI-layout sequence as ROS 2 messages on rmw_zenoh keys,
//! at a chosen rate, so the live path can be driven by any recorded or simulated sequence
//! (and ROS 2 nodes on rmw_zenoh can receive it too).
//!
//! Per pose of `poses.txt`: a `nav_msgs/Odometry` (the LiDAR's pose in `odom`, ROS axes,
//! through `[live] world_from_odom` and `child_from_velo`). Per scan that has a detections
//! file: a `sensor_msgs/CameraInfo` (P2 and the image size), the `sensor_msgs/PointCloud2`
//! (float32 x, y, z, intensity) and the detections JSON with its `stamp` in a
//! `std_msgs/String`. Stamps are `times.txt` (or 0.1 s a pose) after a fixed epoch, so a
//! replay run again gives the same stamps and a restarted server skips what it has mapped.

use std::ops::Range;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use ingest::build::Sequence;
use ingest::sources::detections::read_detections;
use ingest::sources::live::{LiveConfig, MessageKind};
use ingest::sources::ros::{
    self, CameraInfo, Header, Odometry, PointCloud2, Pose, PoseWithCovariance, RosString, Time,
};
use zenoh::Wait;

use crate::{Error, Result, keys, zerr};

/// The stamp of a sequence's time 0: 2023-11-14 22:13:20 UTC.
pub const EPOCH_NS: i64 = 1_700_000_000_000_000_000;

/// What to replay.
#[derive(Debug, Clone)]
pub struct ReplayArgs {
    /// The sequence directory (`velodyne/`, `poses.txt`, `calib.txt`, optional `times.txt`,
    /// `image_2/`).
    pub sequence: PathBuf,
    /// The detections directory (default: `<sequence>/detections`).
    pub detections: Option<PathBuf>,
    /// Poses to replay (half-open frame numbers); all when `None`.
    pub frames: Option<Range<u32>>,
    /// Speed: 1.0 is real time, 2.0 twice as fast; 0 publishes as fast as possible.
    pub rate: f64,
    /// Topics, domain and frames.
    pub live: LiveConfig,
    /// The image size when the sequence has no `image_2/` (`[width, height]`).
    pub image_size: [u32; 2],
    /// How long to wait for a subscriber to the clouds before publishing.
    pub wait_secs: f64,
}

/// What a replay published.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ReplayReport {
    /// Odometry messages.
    pub poses: u64,
    /// Clouds (each with its camera info and detections).
    pub clouds: u64,
    /// Payload bytes.
    pub bytes: u64,
    /// Wall-clock seconds.
    pub secs: f64,
    /// The stamps of the first and last cloud (nanoseconds).
    pub stamps_ns: Option<(i64, i64)>,
}

fn stamp_of(seq: &Sequence, i: u32) -> i64 {
    let secs = seq
        .times
        .as_ref()
        .and_then(|t| t.get(i as usize).copied())
        .unwrap_or(f64::from(i) * 0.1);
    EPOCH_NS + (secs * 1e9).round() as i64
}

/// Publishes `args.sequence` on `session`; `progress` is called after each cloud with the
/// frame number.
///
/// # Errors
/// The sequence cannot be read, no cloud subscriber appears within `wait_secs`, or zenoh
/// refuses to publish.
pub fn replay(
    session: &zenoh::Session,
    args: &ReplayArgs,
    progress: &mut dyn FnMut(u32),
) -> Result<ReplayReport> {
    if !(args.rate.is_finite() && args.rate >= 0.0) {
        return Err(Error::Config(format!(
            "--rate {} must be 0 (as fast as possible) or positive",
            args.rate
        )));
    }
    args.live.validate()?;
    let seq = Sequence::open(&args.sequence, None)?;
    let det_dir = args
        .detections
        .clone()
        .unwrap_or_else(|| args.sequence.join("detections"));
    if !det_dir.is_dir() {
        return Err(Error::File {
            path: det_dir,
            detail: "no detections directory (give --detections DIR)".into(),
        });
    }
    let (world_from_odom, child_from_velo) = args.live.frames()?;
    let odom_from_world = world_from_odom.inverse();
    let velo_from_child = child_from_velo.inverse();
    let cfg = &args.live;
    let publisher = |kind: MessageKind| -> Result<Option<zenoh::pubsub::Publisher<'static>>> {
        let Some(topic) = kind.topic(cfg) else {
            return Ok(None);
        };
        let key = keys::ros_topic(cfg.domain_id, topic, &kind.ros_type());
        Ok(Some(
            session
                .declare_publisher(key)
                .congestion_control(zenoh::qos::CongestionControl::Block)
                .wait()
                .map_err(zerr)?,
        ))
    };
    let cloud_pub = publisher(MessageKind::Cloud)?.expect("validated");
    let odom_pub = publisher(MessageKind::Odometry)?;
    let pose_pub = if odom_pub.is_none() {
        publisher(MessageKind::Pose)?
    } else {
        None
    };
    let camera_pub = publisher(MessageKind::CameraInfo)?.expect("validated");
    let det_pub = publisher(MessageKind::Detections)?.expect("validated");
    // wait for the server's subscription to arrive
    let waited = Instant::now();
    while !cloud_pub.matching_status().wait().map_err(zerr)?.matching() {
        if waited.elapsed().as_secs_f64() > args.wait_secs {
            return Err(Error::Zenoh(format!(
                "no subscriber to {} after {} s: is a server with --zenoh connected?",
                cloud_pub.key_expr(),
                args.wait_secs
            )));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let last = seq.poses.len() as u32;
    let range = args.frames.clone().unwrap_or(0..last);
    let start = Instant::now();
    let mut rep = ReplayReport::default();
    let first_stamp = stamp_of(&seq, range.start.min(last.saturating_sub(1)));
    let put = |p: &zenoh::pubsub::Publisher<'_>, bytes: Vec<u8>, rep: &mut ReplayReport| {
        rep.bytes += bytes.len() as u64;
        p.put(bytes).wait().map_err(zerr)
    };
    for i in range.start..range.end.min(last) {
        let stamp_ns = stamp_of(&seq, i);
        if args.rate > 0.0 {
            let due = (stamp_ns - first_stamp) as f64 * 1e-9 / args.rate;
            let now = start.elapsed().as_secs_f64();
            if due > now {
                std::thread::sleep(Duration::from_secs_f64(due - now));
            }
        }
        let header = |frame: &str| Header {
            stamp: Time::from_nanos(stamp_ns),
            frame_id: frame.into(),
        };
        let world_from_velo = seq.world_from_velo(i);
        let pose = Pose::from_rigid(&(odom_from_world * world_from_velo * velo_from_child));
        if let Some(p) = &odom_pub {
            let m = Odometry {
                header: header("odom"),
                child_frame_id: "velodyne".into(),
                pose: PoseWithCovariance {
                    pose,
                    ..PoseWithCovariance::default()
                },
                ..Odometry::default()
            };
            put(p, ros::encode(&m)?, &mut rep)?;
            rep.poses += 1;
        } else if let Some(p) = &pose_pub {
            let m = ros::PoseStamped {
                header: header("odom"),
                pose,
            };
            put(p, ros::encode(&m)?, &mut rep)?;
            rep.poses += 1;
        }
        let det_path = det_dir.join(format!("{i:06}.json"));
        if !seq.scan_path(i).exists() || !det_path.exists() {
            continue;
        }
        let camera = seq.camera(i, args.image_size)?;
        let p2 = seq.calib.p[2];
        let mut p = [0.0; 12];
        for (k, v) in p.iter_mut().enumerate() {
            *v = p2[(k / 4, k % 4)];
        }
        let info = CameraInfo {
            header: header("camera"),
            height: camera.height,
            width: camera.width,
            distortion_model: "plumb_bob".into(),
            d: vec![0.0; 5],
            k: [p[0], p[1], p[2], p[4], p[5], p[6], p[8], p[9], p[10]],
            r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            p,
            ..CameraInfo::default()
        };
        put(&camera_pub, ros::encode(&info)?, &mut rep)?;
        let scan = ingest::sources::kitti::read_scan(&seq.scan_path(i))?;
        let cloud = PointCloud2::from_xyzi(header("velodyne"), &scan.points);
        put(&cloud_pub, ros::encode(&cloud)?, &mut rep)?;
        let dets = read_detections(&det_path)?;
        let text = ros::detections_to_string(Time::from_nanos(stamp_ns), &dets);
        put(&det_pub, ros::encode(&RosString { data: text })?, &mut rep)?;
        rep.clouds += 1;
        rep.stamps_ns = Some((rep.stamps_ns.map_or(stamp_ns, |s| s.0), stamp_ns));
        progress(i);
    }
    rep.secs = start.elapsed().as_secs_f64();
    Ok(rep)
}

/// The `[live]` calibration for a sequence: its `Tr` as `cam_from_velo`, the rest of `live`
/// unchanged. A server given the same sequence's `calib.txt` (`--calib`) gets the same.
///
/// # Errors
/// The calibration file cannot be read.
pub fn with_calib(mut live: LiveConfig, calib: &std::path::Path) -> Result<LiveConfig> {
    let c = ingest::sources::kitti::read_calib(calib)?;
    live.cam_from_velo = scene::pose::row_major(&c.cam0_from_velo).to_vec();
    Ok(live)
}
