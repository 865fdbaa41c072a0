//! ROS 2 messages as they cross rmw_zenoh: the structs of the five message types live ingest
//! reads (`sensor_msgs/PointCloud2`, `nav_msgs/Odometry`, `geometry_msgs/PoseStamped`,
//! `sensor_msgs/CameraInfo`, `std_msgs/String`), their CDR encoding (little- or big-endian
//! plain CDR after the 4-byte encapsulation header, by [`cdr_encoding`]), and the checked
//! conversions into what mapping uses: points, poses, a camera, detections.
//!
//! Every decoder takes untrusted bytes: lengths are checked against the payload before
//! anything is allocated (a declared 4 GiB `data` is refused, not allocated), every number
//! that reaches the map is checked finite, and each error says which message and, for CDR,
//! the byte offset where decoding stopped. No ROS installation is needed; the type hashes
//! (`RIHS01_…`) are the ones ROS 2 Jazzy computes (cross-checked with PyPI `rosbags`).

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::sources::detections::DetectionFrame;
use scene::pose::{Projection, Rigid3};

/// The encapsulation header of little-endian plain CDR (`CDR_LE`).
pub const CDR_LE: [u8; 4] = [0, 1, 0, 0];
/// The encapsulation header of big-endian plain CDR (`CDR_BE`).
pub const CDR_BE: [u8; 4] = [0, 0, 0, 0];

/// Most points one cloud may declare (`width × height`): 16 M, about 30 Velodyne HDL-64
/// sweeps at once. A larger declaration is refused before anything is allocated.
pub const MAX_CLOUD_POINTS: u64 = 1 << 24;

/// A ROS 2 message type as rmw_zenoh names it in key expressions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RosType {
    /// `package/msg/Name`, e.g. `sensor_msgs/msg/PointCloud2`.
    pub name: &'static str,
    /// The DDS type name in the key: `sensor_msgs::msg::dds_::PointCloud2_`.
    pub dds: &'static str,
    /// The type hash in the key: `RIHS01_` and 64 hex digits (REP 2011, ROS 2 Jazzy).
    pub hash: &'static str,
}

/// `sensor_msgs/msg/PointCloud2`.
pub const POINT_CLOUD2: RosType = RosType {
    name: "sensor_msgs/msg/PointCloud2",
    dds: "sensor_msgs::msg::dds_::PointCloud2_",
    hash: "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5",
};
/// `nav_msgs/msg/Odometry`.
pub const ODOMETRY: RosType = RosType {
    name: "nav_msgs/msg/Odometry",
    dds: "nav_msgs::msg::dds_::Odometry_",
    hash: "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
};
/// `geometry_msgs/msg/PoseStamped`.
pub const POSE_STAMPED: RosType = RosType {
    name: "geometry_msgs/msg/PoseStamped",
    dds: "geometry_msgs::msg::dds_::PoseStamped_",
    hash: "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
};
/// `sensor_msgs/msg/CameraInfo`.
pub const CAMERA_INFO: RosType = RosType {
    name: "sensor_msgs/msg/CameraInfo",
    dds: "sensor_msgs::msg::dds_::CameraInfo_",
    hash: "RIHS01_b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275",
};
/// `std_msgs/msg/String`.
pub const STRING: RosType = RosType {
    name: "std_msgs/msg/String",
    dds: "std_msgs::msg::dds_::String_",
    hash: "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
};

/// `builtin_interfaces/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds since the epoch.
    pub sec: i32,
    /// Nanoseconds, `0..1e9`.
    pub nanosec: u32,
}

impl Time {
    /// Nanoseconds since the epoch.
    pub fn as_nanos(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }

    /// The time of `nanos` nanoseconds since the epoch (clamped to `i32` seconds).
    pub fn from_nanos(nanos: i64) -> Time {
        let sec = nanos.div_euclid(1_000_000_000);
        Time {
            sec: sec.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32,
            nanosec: nanos.rem_euclid(1_000_000_000) as u32,
        }
    }
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The coordinate frame of the data.
    pub frame_id: String,
}

/// `sensor_msgs/PointField`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PointField {
    /// `x`, `y`, `z`, `intensity`, …
    pub name: String,
    /// Byte offset inside a point.
    pub offset: u32,
    /// `INT8 = 1` … `FLOAT64 = 8`.
    pub datatype: u8,
    /// Elements in the field.
    pub count: u32,
}

/// `PointField.datatype` values.
pub mod datatype {
    /// int8
    pub const INT8: u8 = 1;
    /// uint8
    pub const UINT8: u8 = 2;
    /// int16
    pub const INT16: u8 = 3;
    /// uint16
    pub const UINT16: u8 = 4;
    /// int32
    pub const INT32: u8 = 5;
    /// uint32
    pub const UINT32: u8 = 6;
    /// float32
    pub const FLOAT32: u8 = 7;
    /// float64
    pub const FLOAT64: u8 = 8;
}

/// `sensor_msgs/PointCloud2`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Stamp and frame.
    pub header: Header,
    /// Rows (1 for an unordered cloud).
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// The layout of one point.
    pub fields: Vec<PointField>,
    /// Byte order of `data`.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// The points.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    /// No invalid points.
    pub is_dense: bool,
}

/// `geometry_msgs/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x
    pub x: f64,
    /// y
    pub y: f64,
    /// z
    pub z: f64,
}

/// `geometry_msgs/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x
    pub x: f64,
    /// y
    pub y: f64,
    /// z
    pub z: f64,
    /// w
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseWithCovariance` (covariance row-major 6 × 6).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Row-major 6 × 6 covariance (x, y, z, rotation about x, y, z).
    pub covariance: [[f64; 6]; 6],
}

/// `geometry_msgs/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x
    pub x: f64,
    /// y
    pub y: f64,
    /// z
    pub z: f64,
}

/// `geometry_msgs/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// m/s
    pub linear: Vector3,
    /// rad/s
    pub angular: Vector3,
}

/// `geometry_msgs/TwistWithCovariance`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Row-major 6 × 6 covariance.
    pub covariance: [[f64; 6]; 6],
}

/// `nav_msgs/Odometry`: the pose of `child_frame_id` in `header.frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the parent frame (`odom`).
    pub header: Header,
    /// The moving frame.
    pub child_frame_id: String,
    /// Its pose.
    pub pose: PoseWithCovariance,
    /// Its velocity.
    pub twist: TwistWithCovariance,
}

/// `geometry_msgs/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and the parent frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// `sensor_msgs/RegionOfInterest`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Left edge.
    pub x_offset: u32,
    /// Top edge.
    pub y_offset: u32,
    /// Height.
    pub height: u32,
    /// Width.
    pub width: u32,
    /// Whether to rectify.
    pub do_rectify: bool,
}

/// `sensor_msgs/CameraInfo`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Stamp and the camera's optical frame.
    pub header: Header,
    /// Image height in pixels.
    pub height: u32,
    /// Image width in pixels.
    pub width: u32,
    /// `plumb_bob`, …
    pub distortion_model: String,
    /// Distortion coefficients.
    pub d: Vec<f64>,
    /// Intrinsics, row-major 3 × 3.
    pub k: [f64; 9],
    /// Rectification, row-major 3 × 3.
    pub r: [f64; 9],
    /// Projection of the rectified camera, row-major 3 × 4.
    pub p: [f64; 12],
    /// Binning.
    pub binning_x: u32,
    /// Binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}

/// `std_msgs/String`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RosString {
    /// The text.
    pub data: String,
}

fn bad(what: &str, detail: impl Into<String>) -> Error {
    Error::Message {
        what: what.to_string(),
        detail: detail.into(),
    }
}

/// Decodes a CDR payload (encapsulation header included) into `T`; `what` names the
/// message in errors.
///
/// # Errors
/// [`Error::Message`] for a payload shorter than its header, an encapsulation other than
/// plain CDR, and any decoding failure, with the byte offset (from the start of the payload)
/// where decoding stopped.
pub fn decode<T: DeserializeOwned>(what: &str, payload: &[u8]) -> Result<T> {
    use cdr_encoding::CdrDeserializer;
    if payload.len() < 4 {
        return Err(bad(
            what,
            format!(
                "{} bytes: shorter than the 4-byte CDR encapsulation header",
                payload.len()
            ),
        ));
    }
    let (head, body) = payload.split_at(4);
    let at = |consumed: usize, e: cdr_encoding::Error| {
        bad(
            what,
            format!(
                "CDR decoding stopped at byte {} of {}: {e}",
                consumed + 4,
                payload.len()
            ),
        )
    };
    match [head[0], head[1]] {
        [0, 1] => {
            let mut de = CdrDeserializer::<byteorder::LittleEndian>::new(body);
            T::deserialize(&mut de).map_err(|e| at(de.bytes_consumed(), e))
        }
        [0, 0] => {
            let mut de = CdrDeserializer::<byteorder::BigEndian>::new(body);
            T::deserialize(&mut de).map_err(|e| at(de.bytes_consumed(), e))
        }
        other => Err(bad(
            what,
            format!(
                "encapsulation {:02x} {:02x} is not plain CDR (00 01 little-endian, 00 00 big-endian)",
                other[0], other[1]
            ),
        )),
    }
}

/// Encodes `msg` as little-endian plain CDR with its encapsulation header, as rmw_zenoh
/// publishes it.
///
/// # Errors
/// Only if serde refuses the value (it does not for the message types here).
pub fn encode<T: Serialize>(msg: &T) -> Result<Vec<u8>> {
    let mut out = CDR_LE.to_vec();
    out.extend(
        cdr_encoding::to_vec::<T, byteorder::LittleEndian>(msg)
            .map_err(|e| bad("CDR encoding", e.to_string()))?,
    );
    Ok(out)
}

/// A cloud's points in its sensor frame, as mapping takes them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CloudPoints {
    /// x, y, z (metres) and intensity (0 when the cloud has none).
    pub points: Vec<[f32; 4]>,
    /// Points dropped because a coordinate was NaN or infinite.
    pub nonfinite: u64,
}

fn field_size(datatype: u8) -> Option<usize> {
    use datatype::*;
    Some(match datatype {
        INT8 | UINT8 => 1,
        INT16 | UINT16 => 2,
        INT32 | UINT32 | FLOAT32 => 4,
        FLOAT64 => 8,
        _ => return None,
    })
}

fn read_field(bytes: &[u8], datatype: u8, big: bool) -> f64 {
    macro_rules! num {
        ($t:ty, $n:expr) => {{
            let a: [u8; $n] = bytes[..$n].try_into().expect("length checked");
            f64::from(if big {
                <$t>::from_be_bytes(a)
            } else {
                <$t>::from_le_bytes(a)
            })
        }};
    }
    use datatype::*;
    match datatype {
        INT8 => f64::from(bytes[0] as i8),
        UINT8 => f64::from(bytes[0]),
        INT16 => num!(i16, 2),
        UINT16 => num!(u16, 2),
        INT32 => num!(i32, 4),
        UINT32 => num!(u32, 4),
        FLOAT32 => num!(f32, 4),
        _ => num!(f64, 8),
    }
}

impl PointCloud2 {
    /// The points (`x`, `y`, `z` as float32 or float64; `intensity` of any numeric type when
    /// present), with non-finite points dropped and counted.
    ///
    /// # Errors
    /// [`Error::Message`] when `x`, `y` or `z` is missing or not a float, a field of unknown
    /// datatype or with `count` other than 1 is one of them, a field lies outside
    /// `point_step`, `row_step` is shorter than a row, `data` is shorter than the declared
    /// points, or more than [`MAX_CLOUD_POINTS`] points are declared.
    pub fn points(&self) -> Result<CloudPoints> {
        const WHAT: &str = "sensor_msgs/PointCloud2";
        let n = u64::from(self.width) * u64::from(self.height);
        if n > MAX_CLOUD_POINTS {
            return Err(bad(
                WHAT,
                format!(
                    "{} × {} points declared; at most {MAX_CLOUD_POINTS} are taken",
                    self.width, self.height
                ),
            ));
        }
        let find = |name: &str, floats_only: bool| -> Result<Option<(usize, u8)>> {
            let Some(f) = self.fields.iter().find(|f| f.name == name) else {
                return Ok(None);
            };
            let size = field_size(f.datatype).ok_or_else(|| {
                bad(
                    WHAT,
                    format!("field {name:?} has unknown datatype {}", f.datatype),
                )
            })?;
            if floats_only && !matches!(f.datatype, datatype::FLOAT32 | datatype::FLOAT64) {
                return Err(bad(
                    WHAT,
                    format!(
                        "field {name:?} has datatype {}; x, y and z must be FLOAT32 (7) or FLOAT64 (8)",
                        f.datatype
                    ),
                ));
            }
            if f.count != 1 {
                return Err(bad(
                    WHAT,
                    format!("field {name:?} has count {}; 1 is expected", f.count),
                ));
            }
            if u64::from(f.offset) + size as u64 > u64::from(self.point_step) {
                return Err(bad(
                    WHAT,
                    format!(
                        "field {name:?} (offset {}, {size} bytes) runs past point_step {}",
                        f.offset, self.point_step
                    ),
                ));
            }
            Ok(Some((f.offset as usize, f.datatype)))
        };
        let mut xyz = [(0, 0); 3];
        for (i, name) in ["x", "y", "z"].into_iter().enumerate() {
            xyz[i] = find(name, true)?.ok_or_else(|| {
                let have: Vec<&str> = self.fields.iter().map(|f| f.name.as_str()).collect();
                bad(
                    WHAT,
                    format!("no {name:?} field (the cloud has {have:?}); x, y and z are required"),
                )
            })?;
        }
        let intensity = find("intensity", false)?;
        let (step, row) = (u64::from(self.point_step), u64::from(self.row_step));
        if self.height > 0 && row < u64::from(self.width) * step {
            return Err(bad(
                WHAT,
                format!(
                    "row_step {row} is shorter than width {} × point_step {step}",
                    self.width
                ),
            ));
        }
        let need = if n == 0 {
            0
        } else {
            (u64::from(self.height) - 1) * row + u64::from(self.width) * step
        };
        if (self.data.len() as u64) < need {
            return Err(bad(
                WHAT,
                format!(
                    "data has {} bytes but {} × {} points of {step} bytes (row_step {row}) need {need}",
                    self.data.len(),
                    self.width,
                    self.height
                ),
            ));
        }
        if n == 0 {
            // no points (a zero width leaves rows that need no bytes)
            return Ok(CloudPoints::default());
        }
        let big = self.is_bigendian;
        let mut out = CloudPoints {
            points: Vec::with_capacity(n as usize),
            nonfinite: 0,
        };
        for r in 0..self.height as usize {
            let row_bytes = &self.data[r * self.row_step as usize..];
            for c in 0..self.width as usize {
                let p = &row_bytes[c * self.point_step as usize..];
                let get = |(o, t): (usize, u8)| read_field(&p[o..], t, big);
                let q = [get(xyz[0]), get(xyz[1]), get(xyz[2])];
                if !q.iter().all(|v| v.is_finite() && v.abs() < 1e6) {
                    out.nonfinite += 1;
                    continue;
                }
                let i = intensity.map_or(0.0, get);
                out.points.push([
                    q[0] as f32,
                    q[1] as f32,
                    q[2] as f32,
                    if i.is_finite() { i as f32 } else { 0.0 },
                ]);
            }
        }
        Ok(out)
    }

    /// An unordered cloud (`height` 1) of float32 `x y z intensity` points, as a Velodyne
    /// driver publishes it.
    pub fn from_xyzi(header: Header, points: &[[f32; 4]]) -> PointCloud2 {
        let mut data = Vec::with_capacity(points.len() * 16);
        for p in points {
            for c in p {
                data.extend_from_slice(&c.to_le_bytes());
            }
        }
        let field = |name: &str, offset| PointField {
            name: name.into(),
            offset,
            datatype: datatype::FLOAT32,
            count: 1,
        };
        PointCloud2 {
            header,
            height: 1,
            width: points.len() as u32,
            fields: vec![
                field("x", 0),
                field("y", 4),
                field("z", 8),
                field("intensity", 12),
            ],
            is_bigendian: false,
            point_step: 16,
            row_step: 16 * points.len() as u32,
            data,
            is_dense: true,
        }
    }
}

impl Pose {
    /// The pose as a rigid transform (`parent_from_child`).
    ///
    /// # Errors
    /// [`Error::Message`] for a non-finite number or a quaternion whose norm is not 1 within
    /// 1e-3 (it is normalised otherwise).
    pub fn to_rigid(&self, what: &str) -> Result<Rigid3> {
        let p = self.position;
        let q = self.orientation;
        if ![p.x, p.y, p.z, q.x, q.y, q.z, q.w]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(bad(what, "the pose has a NaN or infinite number"));
        }
        let quat = nalgebra::Quaternion::new(q.w, q.x, q.y, q.z);
        let norm = quat.norm();
        if (norm - 1.0).abs() > 1e-3 {
            return Err(bad(
                what,
                format!("the orientation quaternion has norm {norm}, not 1"),
            ));
        }
        let r = nalgebra::UnitQuaternion::from_quaternion(quat).to_rotation_matrix();
        Ok(Rigid3::from_parts(
            nalgebra::Translation3::new(p.x, p.y, p.z),
            r,
        ))
    }

    /// The pose of a rigid transform (its rotation as a unit quaternion).
    pub fn from_rigid(t: &Rigid3) -> Pose {
        let q = nalgebra::UnitQuaternion::from_rotation_matrix(&t.rotation);
        Pose {
            position: Point {
                x: t.translation.x,
                y: t.translation.y,
                z: t.translation.z,
            },
            orientation: Quaternion {
                x: q.i,
                y: q.j,
                z: q.k,
                w: q.w,
            },
        }
    }
}

impl CameraInfo {
    /// The rectified camera's projection `P` and the image size `(width, height)`.
    ///
    /// # Errors
    /// [`Error::Message`] for a zero or huge (over 65 536) image size, a non-finite `P`, or a
    /// `P` whose left 3 × 3 block is singular.
    pub fn projection(&self) -> Result<(Projection, u32, u32)> {
        const WHAT: &str = "sensor_msgs/CameraInfo";
        if self.width == 0 || self.height == 0 || self.width > 65_536 || self.height > 65_536 {
            return Err(bad(
                WHAT,
                format!(
                    "image size {} × {} (width × height) must be 1 to 65536 each",
                    self.width, self.height
                ),
            ));
        }
        if !self.p.iter().all(|v| v.is_finite()) {
            return Err(bad(WHAT, "P has a NaN or infinite number"));
        }
        let p = Projection::from_row_slice(&self.p);
        if p.fixed_view::<3, 3>(0, 0).determinant().abs() < 1e-9 {
            return Err(bad(
                WHAT,
                "P is singular (all zeros?): the camera is not calibrated",
            ));
        }
        Ok((p, self.width, self.height))
    }
}

/// Detections as they arrive on a `std_msgs/String` topic: the detections JSON of
/// [`crate::sources::detections`] with one more member, `"stamp": {"sec", "nanosec"}`, the
/// stamp of the cloud they belong to. Returns the stamp (nanoseconds) and the frame.
///
/// # Errors
/// [`Error::Message`] for bad JSON (with line and column), a missing or malformed `stamp`,
/// or a detections frame [`DetectionFrame::from_json`] refuses.
pub fn detections_of_string(text: &str) -> Result<(i64, DetectionFrame)> {
    const WHAT: &str = "detections (std_msgs/String)";
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        bad(
            WHAT,
            format!("bad JSON at line {} column {}: {e}", e.line(), e.column()),
        )
    })?;
    let stamp = v.get("stamp").ok_or_else(|| {
        bad(
            WHAT,
            "no \"stamp\": {\"sec\", \"nanosec\"} (the stamp of the cloud the detections belong to)",
        )
    })?;
    let t: Time = serde_json::from_value(stamp.clone()).map_err(|e| {
        bad(
            WHAT,
            format!("\"stamp\" must be {{\"sec\": int32, \"nanosec\": uint32}}: {e}"),
        )
    })?;
    if t.nanosec >= 1_000_000_000 {
        return Err(bad(WHAT, "stamp.nanosec must be below 1e9"));
    }
    let frame = DetectionFrame::from_json(std::path::Path::new("<std_msgs/String>"), &v)
        .map_err(|e| bad(WHAT, e.to_string()))?;
    Ok((t.as_nanos(), frame))
}

/// The JSON text of `frame` with its `stamp`, for [`detections_of_string`].
pub fn detections_to_string(stamp: Time, frame: &DetectionFrame) -> String {
    let mut v = frame.to_json();
    v["stamp"] = serde_json::json!({"sec": stamp.sec, "nanosec": stamp.nanosec});
    v.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(sec: i32) -> Header {
        Header {
            stamp: Time { sec, nanosec: 5 },
            frame_id: "velodyne".into(),
        }
    }

    #[test]
    fn messages_round_trip_through_cdr() {
        let c = PointCloud2::from_xyzi(header(3), &[[1.0, 2.0, 3.0, 0.5], [4.0, 5.0, 6.0, 0.0]]);
        let bytes = encode(&c).unwrap();
        assert_eq!(&bytes[..4], &CDR_LE);
        let back: PointCloud2 = decode("cloud", &bytes).unwrap();
        assert_eq!(back, c);
        assert_eq!(
            back.points().unwrap().points,
            vec![[1.0, 2.0, 3.0, 0.5], [4.0, 5.0, 6.0, 0.0]]
        );
        let o = Odometry {
            header: header(1),
            child_frame_id: "velodyne".into(),
            ..Odometry::default()
        };
        assert_eq!(decode::<Odometry>("odom", &encode(&o).unwrap()).unwrap(), o);
        let s = RosString { data: "hé".into() };
        // std_msgs/String: length including the NUL, the bytes, the NUL
        let b = encode(&s).unwrap();
        assert_eq!(&b[4..8], &4u32.to_le_bytes());
        assert_eq!(&b[8..], "hé\0".as_bytes());
        assert_eq!(decode::<RosString>("s", &b).unwrap(), s);
    }

    /// Hostile payloads are errors with the offset, never allocations or panics.
    #[test]
    fn hostile_payloads_are_refused() {
        let c = PointCloud2::from_xyzi(header(3), &[[1.0, 2.0, 3.0, 0.5]]);
        let bytes = encode(&c).unwrap();
        for cut in 0..bytes.len() {
            let e = decode::<PointCloud2>("cloud", &bytes[..cut]).unwrap_err();
            assert!(e.to_string().contains("cloud"), "{e}");
        }
        // a 4 GiB data length: the length field sits right before the data
        let mut evil = bytes.clone();
        let data_at = bytes.len() - 1 - 16 - 4 - 3;
        let len_at = (4..bytes.len() - 4)
            .rev()
            .find(|i| bytes[*i..*i + 4] == 16u32.to_le_bytes())
            .unwrap();
        assert!(len_at <= data_at + 3, "{len_at} {data_at}");
        evil[len_at..len_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = decode::<PointCloud2>("cloud", &evil)
            .unwrap_err()
            .to_string();
        assert!(e.contains("byte"), "{e}");
        // declared sizes that do not fit the data
        let mut big = c.clone();
        big.width = u32::MAX;
        big.height = u32::MAX;
        assert!(big.points().unwrap_err().to_string().contains("declared"));
        let mut short = c.clone();
        short.width = 2;
        short.row_step = 32;
        assert!(short.points().unwrap_err().to_string().contains("need"));
        let mut nox = c.clone();
        nox.fields.remove(0);
        assert!(nox.points().unwrap_err().to_string().contains("\"x\""));
        let mut wide = c.clone();
        wide.fields[2].offset = 14;
        assert!(
            wide.points()
                .unwrap_err()
                .to_string()
                .contains("point_step")
        );
        let mut ints = c.clone();
        ints.fields[0].datatype = datatype::INT32;
        assert!(ints.points().unwrap_err().to_string().contains("FLOAT32"));
        // NaN points are dropped and counted
        let nan = PointCloud2::from_xyzi(header(0), &[[f32::NAN, 0.0, 0.0, 0.0], [1.0; 4]]);
        let p = nan.points().unwrap();
        assert_eq!((p.points.len(), p.nonfinite), (1, 1));
        // not CDR at all
        assert!(
            decode::<RosString>("s", b"\x01\x07\0\0abcd")
                .unwrap_err()
                .to_string()
                .contains("encapsulation")
        );
    }

    #[test]
    fn big_endian_clouds_read_the_same() {
        let c = PointCloud2::from_xyzi(header(3), &[[1.5, -2.0, 3.25, 7.0]]);
        let mut be = c.clone();
        be.is_bigendian = true;
        be.data = c
            .data
            .chunks(4)
            .flat_map(|w| [w[3], w[2], w[1], w[0]])
            .collect();
        assert_eq!(be.points().unwrap(), c.points().unwrap());
    }

    #[test]
    fn poses_convert_both_ways_within_1e_12() {
        let t = Rigid3::from_parts(
            nalgebra::Translation3::new(1.0, -2.0, 30.0),
            nalgebra::Rotation3::from_euler_angles(0.1, -0.4, 2.0),
        );
        let back = Pose::from_rigid(&t).to_rigid("pose").unwrap();
        assert!((back.to_matrix() - t.to_matrix()).abs().max() < 1e-12);
        let mut p = Pose::from_rigid(&t);
        p.orientation.w = 5.0;
        assert!(p.to_rigid("pose").unwrap_err().to_string().contains("norm"));
        p.orientation.w = f64::NAN;
        assert!(p.to_rigid("pose").unwrap_err().to_string().contains("NaN"));
    }

    #[test]
    fn detections_need_a_stamp() {
        let e = detections_of_string("{\"format\": 1}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("stamp"), "{e}");
        let e = detections_of_string("{").unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
    }
}
