//! The JSON Schema in `docs/detections.md` and the reader agree: on the documented example
//! and on edge cases, a real JSON Schema validator (`jsonschema`) and
//! `DetectionFrame::from_json` give the same verdict, except for the checks the document
//! lists as beyond a schema (mask size against the image, runs covering the mask, an RLE
//! string that decodes), where the schema accepts and the reader refuses.

use std::path::Path;

use ingest::sources::detections::DetectionFrame;
use serde_json::{Value, json};

/// The first ```json block after `## heading` in docs/detections.md.
fn block_after(doc: &str, heading: &str) -> Value {
    let start = doc.find(heading).map_or(0, |i| i + heading.len());
    let rest = &doc[start..];
    let a = rest.find("```json").unwrap() + "```json".len();
    let b = a + rest[a..].find("```").unwrap();
    serde_json::from_str(&rest[a..b]).unwrap()
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Verdict {
    /// Both accept.
    Valid,
    /// Both refuse.
    Invalid,
    /// The schema accepts; the reader refuses (a check no schema can make).
    ReaderOnly,
}

#[test]
fn documented_schema_and_reader_agree() {
    let doc = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/detections.md"),
    )
    .unwrap();
    let example = block_after(&doc, "# The detections format");
    let schema = block_after(&doc, "## JSON Schema");
    let validator = jsonschema::validator_for(&schema).unwrap();
    use Verdict::*;
    // (what, JSON pointer, new value or None to remove it, verdict)
    let cases: Vec<(&str, &str, Option<Value>, Verdict)> = vec![
        ("the example", "", None, Valid),
        (
            "whole numbers as floats",
            "/detections/0/mask/counts",
            Some(json!([120075.0, 40.0, 335, 40, 345260])),
            Valid,
        ),
        ("frame as a float", "/frame", Some(json!(12.0)), Valid),
        ("version 1.0", "/version", Some(json!(1.0)), Valid),
        ("no tags", "/detections/0/tags", None, Valid),
        ("no feature", "/detections/0/feature", None, Valid),
        (
            "a null feature",
            "/detections/0/feature",
            Some(Value::Null),
            Valid,
        ),
        ("an extra field", "/extra", Some(json!("x")), Valid),
        ("no detections", "/detections", Some(json!([])), Valid),
        (
            "a fractional run",
            "/detections/0/mask/counts",
            Some(json!([120075.5, 40, 335, 40, 345259.5])),
            Invalid,
        ),
        (
            "a negative run",
            "/detections/0/mask/counts",
            Some(json!([-1, 465751])),
            Invalid,
        ),
        (
            "a run beyond u32",
            "/detections/0/mask/counts",
            Some(json!([4294967296u64])),
            Invalid,
        ),
        (
            "counts not a list or string",
            "/detections/0/mask/counts",
            Some(json!({"a": 1})),
            Invalid,
        ),
        (
            "an RLE string with a bad character",
            "/detections/0/mask/counts",
            Some(json!("hn]3~")),
            Invalid,
        ),
        ("a negative frame", "/frame", Some(json!(-1)), Invalid),
        ("a fractional frame", "/frame", Some(json!(1.5)), Invalid),
        ("version 2", "/version", Some(json!(2)), Invalid),
        ("another format", "/format", Some(json!("coco")), Invalid),
        (
            "an unknown producer",
            "/producer",
            Some(json!("camera")),
            Invalid,
        ),
        ("a zero width", "/image/width", Some(json!(0)), Invalid),
        ("no image", "/image", None, Invalid),
        (
            "a score above 1",
            "/detections/0/score",
            Some(json!(1.5)),
            Invalid,
        ),
        (
            "a score as text",
            "/detections/0/score",
            Some(json!("0.5")),
            Invalid,
        ),
        ("no caption", "/detections/0/caption", None, Invalid),
        (
            "a caption that is a number",
            "/detections/0/caption",
            Some(json!(3)),
            Invalid,
        ),
        (
            "null tags",
            "/detections/0/tags",
            Some(Value::Null),
            Invalid,
        ),
        (
            "a tag that is a number",
            "/detections/0/tags",
            Some(json!(["car", 1])),
            Invalid,
        ),
        (
            "a three-number bbox",
            "/detections/0/bbox",
            Some(json!([1, 2, 3])),
            Invalid,
        ),
        (
            "a negative bbox width",
            "/detections/0/bbox",
            Some(json!([1, 2, -3, 4])),
            Invalid,
        ),
        (
            "a text in the feature",
            "/detections/0/feature",
            Some(json!([0.1, "x"])),
            Invalid,
        ),
        ("no mask", "/detections/0/mask", None, Invalid),
        (
            "a mask size of three",
            "/detections/0/mask/size",
            Some(json!([375, 1242, 1])),
            Invalid,
        ),
        (
            "a mask of another size",
            "/detections/0/mask/size",
            Some(json!([376, 1242])),
            ReaderOnly,
        ),
        (
            "runs that do not cover the mask",
            "/detections/0/mask/counts",
            Some(json!([10, 20])),
            ReaderOnly,
        ),
        (
            "an RLE string that does not decode",
            "/detections/0/mask/counts",
            Some(json!("hn]3")),
            ReaderOnly,
        ),
    ];
    let mut wrong = Vec::new();
    for (what, pointer, value, want) in &cases {
        let mut v = example.clone();
        if !pointer.is_empty() {
            let (parent, key) = pointer.rsplit_once('/').unwrap();
            let target = if parent.is_empty() {
                &mut v
            } else {
                v.pointer_mut(parent).unwrap()
            };
            let obj = target.as_object_mut().unwrap();
            match value {
                Some(x) => {
                    obj.insert(key.to_string(), x.clone());
                }
                None => {
                    obj.remove(key);
                }
            }
        }
        let schema_ok = validator.is_valid(&v);
        let reader = DetectionFrame::from_json(Path::new("case.json"), &v);
        let got = match (schema_ok, &reader) {
            (true, Ok(_)) => Valid,
            (false, Err(_)) => Invalid,
            (true, Err(_)) => ReaderOnly,
            (false, Ok(_)) => {
                wrong.push(format!(
                    "{what}: the schema refuses what the reader accepts"
                ));
                continue;
            }
        };
        if got != *want {
            wrong.push(format!("{what}: {got:?}, expected {want:?} ({reader:?})"));
        }
        // a refusal names the file
        if let Err(e) = &reader {
            assert!(e.to_string().contains("case.json"), "{what}: {e}");
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
