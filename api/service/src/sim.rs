//! The `sim` operation: a synthetic city and a drive through it, written as a KITTI-layout
//! sequence with LiDAR labels, simulator detections and ground truth (the simulator is
//! `ingest::sources::sim`). `opengraph sim` and Python's `opengraph.sim` call it.

use std::path::PathBuf;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{ToolError, ToolResult, classify};

pub use ingest::sources::sim::SimReport;

/// The size of the simulated city.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SimSize {
    /// About 1 km of road.
    #[default]
    Small,
    /// About 5 km.
    Medium,
    /// At least 20 km and 20,000 objects.
    City,
}

fn miss_rate() -> f64 {
    0.05
}
fn false_positives() -> f64 {
    0.2
}
fn paraphrase_rate() -> f64 {
    0.5
}
fn wrong_attribute_rate() -> f64 {
    0.05
}
fn mask_noise_px() -> u32 {
    1
}

/// A simulation request (the CLI's `opengraph sim` flags).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SimRequest {
    /// The output folder (must not already hold a sequence).
    pub out: PathBuf,
    /// The seed: the same seed gives byte-identical output.
    #[serde(default)]
    pub seed: u64,
    /// The city's size.
    #[serde(default)]
    pub size: SimSize,
    /// Sensor frames at 10 Hz (default: 300 small, 600 medium, 1000 city).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 1))]
    pub frames: Option<u32>,
    /// Probability that a visible object is not detected, 0..=1.
    #[serde(default = "miss_rate")]
    #[schemars(range(min = 0.0, max = 1.0))]
    pub miss_rate: f64,
    /// Mean false-positive detections per frame, 0..=50.
    #[serde(default = "false_positives")]
    #[schemars(range(min = 0.0, max = 50.0))]
    pub false_positives: f64,
    /// Probability of a caption phrased differently from the ground truth, 0..=1.
    #[serde(default = "paraphrase_rate")]
    #[schemars(range(min = 0.0, max = 1.0))]
    pub paraphrase_rate: f64,
    /// Probability of a caption with a wrong colour, 0..=1.
    #[serde(default = "wrong_attribute_rate")]
    #[schemars(range(min = 0.0, max = 1.0))]
    pub wrong_attribute_rate: f64,
    /// Masks are eroded or dilated by up to this many pixels.
    #[serde(default = "mask_noise_px")]
    pub mask_noise_px: u32,
    /// No detection noise at all (overrides the five settings above).
    #[serde(default)]
    pub no_noise: bool,
    /// Cars driving to and fro along the roads, 0..=5000.
    #[serde(default)]
    #[schemars(range(max = 5000))]
    pub moving_cars: u32,
    /// People walking along the sidewalks, 0..=5000.
    #[serde(default)]
    #[schemars(range(max = 5000))]
    pub walkers: u32,
    /// Worker threads (the output does not depend on it); default: all cores.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threads: Option<usize>,
}

impl SimRequest {
    /// A request with the defaults, writing to `out`.
    pub fn new(out: PathBuf) -> SimRequest {
        SimRequest {
            out,
            seed: 0,
            size: SimSize::Small,
            frames: None,
            miss_rate: miss_rate(),
            false_positives: false_positives(),
            paraphrase_rate: paraphrase_rate(),
            wrong_attribute_rate: wrong_attribute_rate(),
            mask_noise_px: mask_noise_px(),
            no_noise: false,
            moving_cars: 0,
            walkers: 0,
            threads: None,
        }
    }
}

/// Simulates as `req` asks, calling `progress(done, total)` as sensor frames are written.
///
/// # Errors
/// [`ToolError::Input`] for a setting out of range or an output folder that holds a sequence
/// already or cannot be made; [`ToolError::Failed`] when writing fails.
pub fn sim(req: &SimRequest, progress: &(dyn Fn(usize, usize) + Sync)) -> ToolResult<SimReport> {
    use ingest::sources::sim::{SimConfig, generate, roads, sensors::DetectionNoise};
    let unit = |name: &str, v: f64, hi: f64| {
        if (0.0..=hi).contains(&v) {
            Ok(())
        } else {
            Err(ToolError::Input(format!(
                "{name} must be in 0..={hi}, not {v}"
            )))
        }
    };
    unit("miss_rate", req.miss_rate, 1.0)?;
    unit("false_positives", req.false_positives, 50.0)?;
    unit("paraphrase_rate", req.paraphrase_rate, 1.0)?;
    unit("wrong_attribute_rate", req.wrong_attribute_rate, 1.0)?;
    if req.frames == Some(0) {
        return Err(ToolError::Input("frames must be at least 1".into()));
    }
    if req.moving_cars > 5000 || req.walkers > 5000 {
        return Err(ToolError::Input(
            "moving_cars and walkers must be at most 5000".into(),
        ));
    }
    let mut cfg = SimConfig {
        seed: req.seed,
        size: match req.size {
            SimSize::Small => roads::SimSize::Small,
            SimSize::Medium => roads::SimSize::Medium,
            SimSize::City => roads::SimSize::City,
        },
        frames: req.frames.map(|f| f as usize),
        noise: if req.no_noise {
            DetectionNoise::none()
        } else {
            DetectionNoise {
                miss_rate: req.miss_rate,
                false_positives_per_frame: req.false_positives,
                paraphrase_rate: req.paraphrase_rate,
                wrong_attribute_rate: req.wrong_attribute_rate,
                mask_noise_px: req.mask_noise_px,
            }
        },
        movers: ingest::sources::sim::movers::MoverConfig {
            cars: req.moving_cars as usize,
            walkers: req.walkers as usize,
        },
        ..SimConfig::default()
    };
    if let Some(t) = req.threads {
        cfg.threads = t.max(1);
    }
    std::fs::create_dir_all(&req.out)
        .map_err(|e| ToolError::Input(format!("creating {}: {e}", req.out.display())))?;
    generate(&req.out, &cfg, progress).map_err(|e| classify(&e))
}
