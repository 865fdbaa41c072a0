//! What the mapping benches share: the real KITTI sequence-00 key frames with SemanticKITTI
//! labels (frames 0-2), run through the label oracle, each detection's caption embedded by
//! the hash embedder.

use std::path::PathBuf;
use std::time::Instant;

use ingest::build::Sequence;
use ingest::mapping::MappingConfig;
use ingest::mapping::project::Camera;
use ingest::sources::detections::DetectionFrame;
use ingest::sources::kitti::{read_labels, read_scan};
use ingest::sources::oracle::{OracleConfig, OracleTruth, oracle_detections};
use llm_tools::{Embedder, HashEmbedder};
use scene::pose::Rigid3;

/// One labelled key frame after the oracle.
pub struct OracleFrame {
    pub index: u32,
    pub world_from_velo: Rigid3,
    /// The scan, velodyne frame (x, y, z, intensity).
    pub points: Vec<[f32; 4]>,
    pub detections: DetectionFrame,
    /// The oracle's truth per detection (its class).
    pub truth: Vec<OracleTruth>,
    /// The hash embedder's 384-d feature of each detection's caption.
    pub features: Vec<Vec<f32>>,
    /// Time the oracle took on this frame.
    pub oracle_ms: f64,
}

/// Sequence 00's labelled frames through the oracle, with the camera of `cfg`'s image size;
/// None (after saying so) when ../shared/data is absent.
pub fn seq00_oracle_frames(
    cfg: &MappingConfig,
) -> anyhow::Result<Option<(Camera, Vec<OracleFrame>)>> {
    let dir =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/kitti/sequences/00");
    if !dir.join("labels").is_dir() {
        println!("skipping: {} is absent", dir.display());
        return Ok(None);
    }
    let seq = Sequence::open(&dir, None)?;
    let camera = Camera::kitti_p2(&seq.calib, cfg.image_size[0], cfg.image_size[1]);
    let mut hash = HashEmbedder::new(384);
    let mut frames = Vec::new();
    for index in 0..3u32 {
        let scan = read_scan(&seq.scan_path(index))?;
        let labels = read_labels(&seq.label_path(index), scan.points.len())?;
        let world_from_velo = seq.world_from_velo(index);
        let t = Instant::now();
        let (detections, truth) = oracle_detections(
            index,
            &scan.points,
            &labels,
            &camera,
            Some(&world_from_velo),
            &OracleConfig::default(),
        )?;
        let oracle_ms = t.elapsed().as_secs_f64() * 1e3;
        let caps: Vec<&str> = detections
            .detections
            .iter()
            .map(|d| d.caption.as_str())
            .collect();
        let features = hash.embed(&caps)?;
        frames.push(OracleFrame {
            index,
            world_from_velo,
            points: scan.points,
            detections,
            truth,
            features,
            oracle_ms,
        });
    }
    Ok(Some((camera, frames)))
}
