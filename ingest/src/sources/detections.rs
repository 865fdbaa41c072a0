//! The per-frame detections format (version 1): how perception from any front end (RAM,
//! Grounding-DINO, TAP, a VLM, the label oracle, the simulator) enters OpenGraph.
//! `docs/detections.md` documents it with a JSON Schema.

use std::path::Path;

use serde_json::{Value as Json, json};

use super::rle::Rle;
use crate::error::{Error, Result};

/// The `format` field.
pub const FORMAT: &str = "opengraph-detections";
/// The version this build reads and writes.
pub const VERSION: u64 = 1;

/// Who produced the detections.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Producer {
    /// A perception front end run elsewhere.
    Detector,
    /// The SemanticKITTI label oracle (ground truth projected into the camera).
    Oracle,
    /// The synthetic city simulator.
    Simulator,
}

impl Producer {
    /// The name in the file.
    pub fn as_str(self) -> &'static str {
        match self {
            Producer::Detector => "detector",
            Producer::Oracle => "oracle",
            Producer::Simulator => "simulator",
        }
    }

    fn parse(s: &str) -> Option<Producer> {
        match s {
            "detector" => Some(Producer::Detector),
            "oracle" => Some(Producer::Oracle),
            "simulator" => Some(Producer::Simulator),
            _ => None,
        }
    }
}

/// One detection.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// Instance mask in the image.
    pub mask: Rle,
    /// Box `[x, y, w, h]` in pixels (COCO convention).
    pub bbox: [f64; 4],
    /// Confidence in [0, 1].
    pub score: f64,
    /// Open-vocabulary tags.
    pub tags: Vec<String>,
    /// A caption of the object.
    pub caption: String,
    /// Optional feature vector (e.g. a CLIP image embedding).
    pub feature: Option<Vec<f32>>,
}

/// The detections of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectionFrame {
    /// Frame index (matches the scan and pose numbering).
    pub frame: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Who produced them.
    pub producer: Producer,
    /// The detections.
    pub detections: Vec<Detection>,
}

fn bad(path: &Path, detail: String) -> Error {
    Error::File {
        path: path.to_path_buf(),
        detail,
    }
}

impl DetectionFrame {
    /// The JSON form (masks as compressed RLE strings).
    pub fn to_json(&self) -> Json {
        json!({
            "format": FORMAT,
            "version": VERSION,
            "frame": self.frame,
            "image": {"width": self.width, "height": self.height},
            "producer": self.producer.as_str(),
            "detections": self.detections.iter().map(|d| {
                let mut o = json!({
                    "mask": {"size": [d.mask.height, d.mask.width], "counts": d.mask.to_coco_string()},
                    "bbox": d.bbox,
                    "score": d.score,
                    "tags": d.tags,
                    "caption": d.caption,
                });
                if let Some(f) = &d.feature {
                    o["feature"] = json!(f);
                }
                o
            }).collect::<Vec<_>>(),
        })
    }

    /// Parses and validates the JSON form; `path` names the source in errors.
    pub fn from_json(path: &Path, v: &Json) -> Result<DetectionFrame> {
        let b = |d: String| bad(path, d);
        if v.get("format").and_then(Json::as_str) != Some(FORMAT) {
            return Err(b(format!(
                "not an OpenGraph detections file (\"format\" must be {FORMAT:?})"
            )));
        }
        match v.get("version").and_then(whole) {
            Some(VERSION) => {}
            Some(other) => {
                return Err(b(format!(
                    "detections format version {other}; this build reads version {VERSION}"
                )));
            }
            None if v.get("version").is_some() => {
                return Err(b(format!(
                    "\"version\" must be the integer {VERSION}, got {}",
                    v["version"]
                )));
            }
            None => return Err(b("missing \"version\"".into())),
        }
        let u32_of = |x: Option<&Json>, what: &str| -> Result<u32> {
            x.and_then(whole)
                .and_then(|n| u32::try_from(n).ok())
                .ok_or_else(|| {
                    b(format!(
                        "{what} must be a whole number from 0 to {}",
                        u32::MAX
                    ))
                })
        };
        let frame = u32_of(v.get("frame"), "\"frame\"")?;
        let image = v
            .get("image")
            .ok_or_else(|| b("missing \"image\"".into()))?;
        let width = u32_of(image.get("width"), "image.width")?;
        let height = u32_of(image.get("height"), "image.height")?;
        if width == 0 || height == 0 {
            return Err(b("image width and height must be positive".into()));
        }
        let producer = v
            .get("producer")
            .and_then(Json::as_str)
            .and_then(Producer::parse)
            .ok_or_else(|| {
                b("\"producer\" must be \"detector\", \"oracle\" or \"simulator\"".into())
            })?;
        let list = v
            .get("detections")
            .and_then(Json::as_array)
            .ok_or_else(|| b("\"detections\" must be a list".into()))?;
        let mut detections = Vec::with_capacity(list.len());
        for (i, d) in list.iter().enumerate() {
            let e = |m: String| b(format!("detection {i}: {m}"));
            let mask = d.get("mask").ok_or_else(|| e("missing mask".into()))?;
            let size = mask
                .get("size")
                .and_then(Json::as_array)
                .filter(|s| s.len() == 2)
                .ok_or_else(|| e("mask.size must be [height, width]".into()))?;
            let (mh, mw) = (
                u32_of(size.first(), "mask height").map_err(|_| e("bad mask height".into()))?,
                u32_of(size.get(1), "mask width").map_err(|_| e("bad mask width".into()))?,
            );
            if (mh, mw) != (height, width) {
                return Err(e(format!(
                    "mask is {mh}x{mw} but the image is {height}x{width}"
                )));
            }
            let rle = match mask.get("counts") {
                Some(Json::String(s)) => Rle::from_coco_string(mh, mw, s),
                Some(Json::Array(a)) => a
                    .iter()
                    .map(|c| {
                        whole(c).and_then(|c| u32::try_from(c).ok()).ok_or_else(|| {
                            Error::Invalid("counts must be non-negative integers".into())
                        })
                    })
                    .collect::<Result<Vec<u32>>>()
                    .and_then(|counts| {
                        let r = Rle {
                            height: mh,
                            width: mw,
                            counts,
                        };
                        r.validate().map(|_| r)
                    }),
                _ => Err(Error::Invalid(
                    "mask.counts must be a string or a list".into(),
                )),
            }
            .map_err(|err| match err {
                Error::Invalid(m) => e(format!("invalid RLE: {m}")),
                other => e(format!("invalid RLE: {other}")),
            })?;
            let bbox: Vec<f64> = d
                .get("bbox")
                .and_then(Json::as_array)
                .map(|a| a.iter().filter_map(Json::as_f64).collect())
                .unwrap_or_default();
            if bbox.len() != 4
                || bbox.iter().any(|x| !x.is_finite())
                || bbox[2] < 0.0
                || bbox[3] < 0.0
            {
                return Err(e(
                    "bbox must be four finite numbers [x, y, w, h] with w, h >= 0".into(),
                ));
            }
            let score = d
                .get("score")
                .and_then(Json::as_f64)
                .filter(|s| (0.0..=1.0).contains(s))
                .ok_or_else(|| e("score must be a number in [0, 1]".into()))?;
            let tags = match d.get("tags") {
                None => Vec::new(),
                Some(Json::Array(a)) => a
                    .iter()
                    .map(|t| t.as_str().map(str::to_string))
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| e("tags must be strings".into()))?,
                Some(_) => return Err(e("tags must be a list of strings".into())),
            };
            let caption = d
                .get("caption")
                .and_then(Json::as_str)
                .ok_or_else(|| e("caption must be a string".into()))?
                .to_string();
            let feature = match d.get("feature") {
                None | Some(Json::Null) => None,
                Some(Json::Array(a)) => {
                    let f: Option<Vec<f32>> =
                        a.iter().map(|x| x.as_f64().map(|x| x as f32)).collect();
                    let f = f
                        .filter(|f| f.iter().all(|x| x.is_finite()))
                        .ok_or_else(|| e("feature must be finite numbers".into()))?;
                    Some(f)
                }
                Some(_) => return Err(e("feature must be a list of numbers".into())),
            };
            if let (Some(f), Some(first)) = (
                &feature,
                detections
                    .iter()
                    .find_map(|d: &Detection| d.feature.as_ref()),
            ) && f.len() != first.len()
            {
                return Err(e(format!(
                    "feature has {} numbers but an earlier detection's has {}: one length per file",
                    f.len(),
                    first.len()
                )));
            }
            detections.push(Detection {
                mask: rle,
                bbox: [bbox[0], bbox[1], bbox[2], bbox[3]],
                score,
                tags,
                caption,
                feature,
            });
        }
        Ok(DetectionFrame {
            frame,
            width,
            height,
            producer,
            detections,
        })
    }
}

/// A JSON number that is a whole non-negative value: `123` or `123.0` (JSON Schema's
/// "integer", which the documented schema uses, admits both).
fn whole(v: &Json) -> Option<u64> {
    v.as_u64().or_else(|| {
        v.as_f64()
            .filter(|f| f.fract() == 0.0 && *f >= 0.0 && *f <= u64::MAX as f64)
            .map(|f| f as u64)
    })
}

/// Reads a detections file; bad JSON is reported with its line and column.
pub fn read_detections(path: &Path) -> Result<DetectionFrame> {
    let text = crate::error::read_text(path)?;
    let v: Json = serde_json::from_str(&text).map_err(|e| {
        // serde's message ends with its own "at line L column C": say it once
        let msg = e.to_string();
        let msg = msg
            .rfind(" at line ")
            .map_or(msg.as_str(), |i| &msg[..i])
            .to_string();
        Error::Parse {
            path: path.to_path_buf(),
            line: e.line(),
            detail: format!("column {}: {msg}", e.column()),
        }
    })?;
    DetectionFrame::from_json(path, &v)
}

/// Writes a detections file (pretty JSON, masks as compressed RLE).
pub fn write_detections(path: &Path, frame: &DetectionFrame) -> Result<()> {
    let bytes =
        serde_json::to_vec_pretty(&frame.to_json()).map_err(|e| Error::Invalid(e.to_string()))?;
    std::fs::write(path, bytes).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> DetectionFrame {
        let mut m = vec![false; 4 * 6];
        m[6 + 2] = true;
        m[6 + 3] = true;
        m[12 + 2] = true;
        let mask = Rle::from_mask(4, 6, &m).unwrap();
        DetectionFrame {
            frame: 7,
            width: 6,
            height: 4,
            producer: Producer::Oracle,
            detections: vec![Detection {
                bbox: mask.bbox().unwrap(),
                mask,
                score: 1.0,
                tags: vec!["car".into()],
                caption: "a small red car".into(),
                feature: Some(vec![0.5, -0.25]),
            }],
        }
    }

    #[test]
    fn roundtrip_through_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("000007.json");
        write_detections(&p, &frame()).unwrap();
        assert_eq!(read_detections(&p).unwrap(), frame());
        let b = frame().detections[0].bbox;
        assert!(
            b.iter()
                .zip([2.0, 1.0, 2.0, 2.0])
                .all(|(x, y)| (x - y).abs() < 1e-12),
            "{b:?}"
        );
    }

    #[test]
    fn bad_files_give_located_errors() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.json");
        std::fs::write(
            &p,
            "{\n  \"format\": \"opengraph-detections\",\n  \"version\": 1,,\n}",
        )
        .unwrap();
        let e = read_detections(&p).unwrap_err().to_string();
        assert!(e.contains("f.json:3"), "{e}");
        let mut v = frame().to_json();
        v["detections"][0]["mask"]["counts"] = json!("8");
        let e = DetectionFrame::from_json(&p, &v).unwrap_err().to_string();
        assert!(e.contains("detection 0: invalid RLE"), "{e}");
        let mut v = frame().to_json();
        v["detections"][0]["mask"]["size"] = json!([375, 1242]);
        assert!(
            DetectionFrame::from_json(&p, &v)
                .unwrap_err()
                .to_string()
                .contains("mask is 375x1242 but the image is 4x6")
        );
        let mut v = frame().to_json();
        v["version"] = json!(2);
        assert!(
            DetectionFrame::from_json(&p, &v)
                .unwrap_err()
                .to_string()
                .contains("version 2")
        );
        let mut v = frame().to_json();
        v["detections"][0]["score"] = json!(1.5);
        assert!(DetectionFrame::from_json(&p, &v).is_err());
        let mut v = frame().to_json();
        v["detections"][0]["mask"]["counts"] = json!([8, 2, 3, 1, 10]);
        assert_eq!(
            DetectionFrame::from_json(&p, &v).unwrap().detections[0]
                .mask
                .area(),
            3,
            "uncompressed counts are accepted"
        );
    }

    /// What a new user's trial got wrong, each with a message that names the real problem.
    #[test]
    fn messages_name_the_real_problem() {
        let p = Path::new("f.json");
        let msg = |v: &Json| DetectionFrame::from_json(p, v).unwrap_err().to_string();
        let mut v = frame().to_json();
        v["version"] = json!("1");
        assert!(
            msg(&v).contains("\"version\" must be the integer 1, got \"1\""),
            "{}",
            msg(&v)
        );
        let mut v = frame().to_json();
        v["image"]["width"] = json!(4_294_967_296u64);
        assert!(msg(&v).contains("from 0 to 4294967295"), "{}", msg(&v));
        let mut v = frame().to_json();
        v["detections"][0]["mask"]["counts"] = json!([1.5]);
        let m = msg(&v);
        assert!(
            m.contains("invalid RLE: counts") && !m.contains("invalid input"),
            "{m}"
        );
        // features of two lengths in one file
        let mut v = frame().to_json();
        let mut second = v["detections"][0].clone();
        second["feature"] = json!([0.1, 0.2, 0.3]);
        v["detections"].as_array_mut().unwrap().push(second);
        assert!(
            msg(&v).contains("detection 1: feature has 3 numbers but an earlier detection's has 2")
        );
        // a JSON syntax error says its place once
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f.json");
        std::fs::write(&f, "{\"format\": ").unwrap();
        let e = read_detections(&f).unwrap_err().to_string();
        assert_eq!(e.matches("column").count(), 1, "{e}");
    }
}
