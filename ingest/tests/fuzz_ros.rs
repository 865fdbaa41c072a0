//! A time-boxed fuzz target (`og-fuzz`; `OG_FUZZ_SECS=600 cargo test -p ingest --test
//! fuzz_ros -- --nocapture` runs it for ten minutes) over what live ingest reads from the
//! network: the CDR decoders of the five ROS 2 message types and their conversions (cloud
//! points, poses, the camera, detections JSON), and the live input that takes any bytes on
//! any topic. Any outcome but a panic is fine; a panicking input is saved under
//! `tests/fuzz-regressions/ros_messages/` and replayed on every run once committed.

use std::path::Path;

use ingest::sources::live::{LiveConfig, LiveInput, MessageKind};
use ingest::sources::ros::*;

fn regressions() -> &'static Path {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fuzz-regressions"
    ))
}

fn seeds() -> Vec<Vec<u8>> {
    let header = Header {
        stamp: Time { sec: 7, nanosec: 9 },
        frame_id: "velodyne".into(),
    };
    let cloud = PointCloud2::from_xyzi(header.clone(), &[[1.0, 2.0, 3.0, 0.5], [f32::NAN; 4]]);
    let odom = Odometry {
        header: header.clone(),
        child_frame_id: "base".into(),
        ..Odometry::default()
    };
    let pose = PoseStamped {
        header: header.clone(),
        pose: Pose::default(),
    };
    let mut p = [0.0; 12];
    p[0] = 100.0;
    p[5] = 100.0;
    p[10] = 1.0;
    let cam = CameraInfo {
        header,
        height: 10,
        width: 20,
        p,
        ..CameraInfo::default()
    };
    let dets = RosString {
        data: r#"{"format": "opengraph-detections", "version": 1, "frame": 0, "stamp": {"sec": 7, "nanosec": 9}, "image": {"width": 20, "height": 10}, "producer": "detector", "detections": [{"mask": {"size": [10, 20], "counts": [5, 10, 185]}, "bbox": [0, 5, 1, 10], "score": 0.9, "tags": [], "caption": "a bench"}]}"#.into(),
    };
    vec![
        encode(&cloud).unwrap(),
        encode(&odom).unwrap(),
        encode(&pose).unwrap(),
        encode(&cam).unwrap(),
        encode(&dets).unwrap(),
    ]
}

#[test]
fn ros_messages() {
    let cfg = LiveConfig {
        cam_from_velo: vec![1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        ..LiveConfig::default()
    };
    let input = LiveInput::new(&cfg, None).unwrap();
    og_fuzz::fuzz("ros_messages", &seeds(), regressions(), |bytes| {
        if let Ok(c) = decode::<PointCloud2>("cloud", bytes) {
            let _ = c.points();
        }
        if let Ok(o) = decode::<Odometry>("odom", bytes) {
            let _ = o.pose.pose.to_rigid("odom");
        }
        if let Ok(c) = decode::<CameraInfo>("camera", bytes) {
            let _ = c.projection();
        }
        if let Ok(s) = decode::<RosString>("string", bytes) {
            let _ = detections_of_string(&s.data);
        }
        // the whole input path, on every topic: counted, never a panic
        for kind in MessageKind::ALL {
            input.accept(kind, "fuzz", bytes);
        }
    });
    let st = input.stats();
    let got: u64 = st.received.values().sum();
    let bad: u64 = st.malformed.values().sum();
    assert!(got > 0 && bad > 0 && bad <= got, "{st:?}");
}
