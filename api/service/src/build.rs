//! The `build` operation: a map from a KITTI-layout sequence (scans, poses, calibration) and
//! its perception input (a detections folder, or the SemanticKITTI label oracle), with the
//! optional LLM caption merge after it. `opengraph build` and Python's `opengraph.build` call
//! it; both show its progress events their own way.

use std::path::PathBuf;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{ToolError, ToolResult, classify};

/// The store's page cache during a build. The build writes in batches and reads little back,
/// so redb's default (1 GiB) only held written pages: on the city (`sim --size city`) the
/// peak RSS fell from 1,017 MiB to 937 MiB with 128 MiB and 871 MiB with 64 MiB; the steps
/// after the frames, which read the map back, took about 3 s longer (42 s against 39 s).
const BUILD_STORE_CACHE_BYTES: usize = 64 << 20;

pub use ingest::build::Progress;

fn one() -> u32 {
    1
}
fn environment() -> String {
    "environment".into()
}

pub use crate::find::EmbedderChoice;

/// A language model chosen for an operation, laid over a config's `[llm]` table.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LlmChoice {
    /// `local` (llama.cpp on a GGUF file), `openai` (an OpenAI-compatible server) or `none`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backend: Option<String>,
    /// For local: the GGUF file; for openai: the model name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// For openai: the server's base URL.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub url: Option<String>,
}

impl LlmChoice {
    /// This choice laid over `base`; `default_backend` when neither names one.
    pub fn over(
        &self,
        mut base: llm_tools::LlmConfig,
        default_backend: &str,
    ) -> llm_tools::LlmConfig {
        if let Some(b) = &self.backend {
            base.backend = b.clone();
        } else if base.backend == "none" {
            base.backend = default_backend.to_string();
        }
        if let Some(m) = &self.model {
            if base.backend == "local" {
                base.model_path = Some(PathBuf::from(m));
            } else {
                base.model = Some(m.clone());
            }
        }
        if let Some(u) = &self.url {
            base.url = Some(u.clone());
        }
        base
    }
}

/// A build request.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BuildRequest {
    /// The sequence folder (velodyne/, calib.txt, poses.txt; labels/ for the oracle).
    pub kitti: PathBuf,
    /// A folder of detections files NNNNNN.json (docs/detections.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detections: Option<PathBuf>,
    /// Use the SemanticKITTI label oracle instead of detections.
    #[serde(default)]
    pub oracle_labels: bool,
    /// Key frames [A, B) (half-open); every frame with input when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frames: Option<[u32; 2]>,
    /// Use every N-th frame.
    #[serde(default = "one")]
    #[schemars(range(min = 1))]
    pub stride: u32,
    /// Scans accumulated into each key frame (overrides the config's `mapping.accumulate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 1))]
    pub accumulate: Option<u32>,
    /// poses.txt from another path.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poses: Option<PathBuf>,
    /// A TOML file with `[mapping]`, `[oracle]`, `[hierarchy]` and `[llm]` tables
    /// (docs/config.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<PathBuf>,
    /// The store file.
    pub db: PathBuf,
    /// Continue an interrupted build (same arguments).
    #[serde(default)]
    pub resume: bool,
    /// The environment node's name.
    #[serde(default = "environment")]
    pub name: String,
    /// The sentence embedder.
    #[serde(default)]
    pub embedder: EmbedderChoice,
    /// The language model that merges each object's captions after mapping (default: the
    /// config's `[llm]`, else none: the medoid caption).
    #[serde(default)]
    pub llm: LlmChoice,
}

impl BuildRequest {
    /// A request with the defaults: `kitti` mapped with `detections` into `db`.
    pub fn new(kitti: PathBuf, detections: Option<PathBuf>, db: PathBuf) -> BuildRequest {
        BuildRequest {
            oracle_labels: detections.is_none(),
            kitti,
            detections,
            frames: None,
            stride: 1,
            accumulate: None,
            poses: None,
            config: None,
            db,
            resume: false,
            name: environment(),
            embedder: EmbedderChoice::default(),
            llm: LlmChoice::default(),
        }
    }
}

/// The caption merge after mapping.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum CaptionMerge {
    /// A language model merged the captions.
    Llm(ingest::llm::PassReport),
    /// No model: each object's caption is the medoid of its latest captions.
    Medoid {
        /// `none`.
        model: String,
        /// `medoid`.
        method: String,
    },
}

/// What a build did.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct BuildAnswer {
    /// The mapping and hierarchy report.
    #[serde(flatten)]
    pub report: ingest::build::BuildReport,
    /// The caption merge.
    pub caption_merge: CaptionMerge,
}

/// Builds the map `req` asks for, calling `progress` as key frames are integrated and
/// committed.
///
/// # Errors
/// [`ToolError::Input`] for what the request names (missing or malformed files, a bad
/// config, an unknown model) and [`ToolError::Failed`] for the rest; a failed build leaves
/// the store at its last commit, from which `resume` goes on.
pub fn build(req: &BuildRequest, progress: &mut dyn FnMut(Progress)) -> ToolResult<BuildAnswer> {
    use ingest::build::{BuildArgs, BuildConfig, Source};
    let mut cfg = match &req.config {
        Some(p) => BuildConfig::from_toml_file(p).map_err(|e| classify(&e))?,
        None => BuildConfig::default(),
    };
    // the language model is opened before any mapping, so a bad [llm] fails at once instead
    // of after the whole build
    let llm_cfg = req.llm.over(cfg.llm.clone(), "none");
    let mut chat = llm_tools::chat::open(&llm_cfg).map_err(|e| classify(&e))?;
    if let Some(a) = req.accumulate {
        cfg.mapping.accumulate = a as usize;
    }
    let source = match (&req.detections, req.oracle_labels) {
        (Some(d), false) => Source::Detections(d.clone()),
        (None, true) => Source::Oracle,
        _ => {
            return Err(ToolError::Input(
                "give either detections (a folder) or oracle_labels".into(),
            ));
        }
    };
    if req.stride == 0 {
        return Err(ToolError::Input("stride must be at least 1".into()));
    }
    let frames = req.frames.map(|[a, b]| a..b);
    let mut emb = req.embedder.open()?;
    let store = graphstore::Store::create_with(
        &req.db,
        &graphstore::StoreOptions::default().with_cache_bytes(BUILD_STORE_CACHE_BYTES),
    )
    .map_err(|e| ToolError::Input(format!("opening {}: {e}", req.db.display())))?;
    let args = BuildArgs {
        sequence: req.kitti.clone(),
        poses: req.poses.clone(),
        source,
        frames,
        stride: req.stride,
        config: cfg,
        environment: req.name.clone(),
    };
    let mut merger = ingest::mapping::MedoidMerger;
    let report = ingest::build::build(
        &store,
        &args,
        emb.as_mut(),
        &mut merger,
        req.resume,
        progress,
    )
    .map_err(|e| classify(&e))?;
    let caption_merge = match chat.as_mut() {
        Some(m) => CaptionMerge::Llm(
            ingest::llm::merge_captions(
                &store,
                m.as_mut(),
                emb.as_mut(),
                args.config.mapping.merge_captions.max(2),
                &ingest::llm::PassOptions::default(),
            )
            .map_err(|e| classify(&e))?,
        ),
        None => CaptionMerge::Medoid {
            model: "none".into(),
            method: "medoid".into(),
        },
    };
    Ok(BuildAnswer {
        report,
        caption_merge,
    })
}
