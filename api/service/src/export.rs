//! The `export` operation: the whole map in a format another tool reads, stating its frame
//! and units. `opengraph export`, `GET /api/export/{format}` and Python's `Map.export` call it.
//!
//! | format | what | written by |
//! |---|---|---|
//! | `node-link` | networkx `node_link_data` JSON, every node and relationship with its properties | `graphstore::export` |
//! | `graphml` | GraphML 1.0, the same | `graphstore::export` |
//! | `neo4j-csv` | a folder of CSV files for `neo4j-admin database import full` | `graphstore::export::neo4j_csv` |
//! | `geojson` | lanes, lane nodes, segment areas, drivable areas, instance footprints on the ground plane | `scene::export::geojson` |
//! | `spark-dsg` | Hydra's Spark-DSG scene-graph JSON (objects, lane places, segments, environment) | `scene::export::spark_dsg` |
//! | `ply` | every instance's points, coloured by class or instance | `scene::export::ply` |

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use graphstore::GraphRead;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{ToolError, ToolResult};

/// An export format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum ExportFormat {
    /// networkx node-link JSON.
    NodeLink,
    /// GraphML 1.0.
    Graphml,
    /// Neo4j bulk-import CSV files (a folder).
    Neo4jCsv,
    /// GeoJSON of the ground plane.
    Geojson,
    /// Spark-DSG (Hydra) scene-graph JSON.
    SparkDsg,
    /// PLY of the point-cloud layer.
    Ply,
}

impl ExportFormat {
    /// Every format's name, as the CLI and the HTTP route take it.
    pub const NAMES: [&'static str; 6] = [
        "node-link",
        "graphml",
        "neo4j-csv",
        "geojson",
        "spark-dsg",
        "ply",
    ];

    /// The format's name.
    pub fn name(self) -> &'static str {
        match self {
            ExportFormat::NodeLink => "node-link",
            ExportFormat::Graphml => "graphml",
            ExportFormat::Neo4jCsv => "neo4j-csv",
            ExportFormat::Geojson => "geojson",
            ExportFormat::SparkDsg => "spark-dsg",
            ExportFormat::Ply => "ply",
        }
    }

    /// The HTTP content type of a one-file format.
    pub fn content_type(self) -> &'static str {
        match self {
            ExportFormat::NodeLink | ExportFormat::SparkDsg => "application/json",
            ExportFormat::Graphml => "application/graphml+xml",
            ExportFormat::Geojson => "application/geo+json",
            ExportFormat::Ply | ExportFormat::Neo4jCsv => "application/octet-stream",
        }
    }

    /// Whether it writes a folder of files rather than one file.
    pub fn is_folder(self) -> bool {
        self == ExportFormat::Neo4jCsv
    }
}

impl std::str::FromStr for ExportFormat {
    type Err = ToolError;
    fn from_str(s: &str) -> ToolResult<ExportFormat> {
        match s {
            "node-link" | "nodelink" | "json" => Ok(ExportFormat::NodeLink),
            "graphml" => Ok(ExportFormat::Graphml),
            "neo4j-csv" | "neo4j" => Ok(ExportFormat::Neo4jCsv),
            "geojson" => Ok(ExportFormat::Geojson),
            "spark-dsg" | "dsg" => Ok(ExportFormat::SparkDsg),
            "ply" => Ok(ExportFormat::Ply),
            other => Err(ToolError::BadArguments(format!(
                "no export format {other:?}; the formats are {}",
                ExportFormat::NAMES.join(", ")
            ))),
        }
    }
}

/// The key of node-link's edge list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum EdgesKey {
    /// `edges`, networkx 3.6 and later.
    #[default]
    Edges,
    /// `links`, older networkx.
    Links,
}

/// How the PLY's points are coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PlyColouring {
    /// By SemanticKITTI class.
    #[default]
    Class,
    /// One colour per instance.
    Instance,
}

/// An export request.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExportRequest {
    /// The format.
    pub format: ExportFormat,
    /// node-link only: the key of the edge list.
    #[serde(default)]
    pub edges_key: EdgesKey,
    /// ply only: how points are coloured.
    #[serde(default)]
    pub colour: PlyColouring,
}

impl ExportRequest {
    /// A request for `format` with the defaults.
    pub fn new(format: ExportFormat) -> ExportRequest {
        ExportRequest {
            format,
            edges_key: EdgesKey::default(),
            colour: PlyColouring::default(),
        }
    }
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct ExportAnswer {
    /// The format.
    pub format: ExportFormat,
    /// Nodes written (features for GeoJSON; instances with points for PLY).
    pub nodes: u64,
    /// Relationships (edges) written; 0 for GeoJSON and PLY.
    pub relationships: u64,
    /// Points written (PLY only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points: Option<u64>,
    /// The files written (a folder format), by name.
    pub files: Vec<String>,
    /// The frame and units of the coordinates.
    pub frame: String,
    /// Milliseconds taken.
    pub time_ms: f64,
}

/// Where an export goes: a writer (one-file formats) or a folder (`neo4j-csv`).
#[allow(missing_debug_implementations)]
pub enum ExportTarget<'a> {
    /// One file's bytes.
    Writer(&'a mut dyn Write),
    /// A folder, made if missing.
    Folder(&'a Path),
}

fn failed(e: impl std::fmt::Display) -> ToolError {
    ToolError::Failed(e.to_string())
}

/// The map-model exports' failures: a map without a ground frame is the caller's to fix.
fn scene_failed(e: scene::Error) -> ToolError {
    match e {
        scene::Error::NoGroundFrame(_) | scene::Error::Invalid(_) => {
            ToolError::BadArguments(e.to_string())
        }
        other => failed(other),
    }
}

const GENERIC_FRAME: &str =
    "every property as stored: points in the map's world frame (Environment.ground_frame), metres";

/// Exports the map read through `r` as `req` asks, to `to`.
///
/// # Errors
/// [`ToolError::BadArguments`] when the target does not suit the format (a folder format to
/// a writer or the other way round) or the map lacks what the format needs (a ground frame);
/// [`ToolError::Failed`] when the store or the output fails.
pub fn export(
    r: &impl GraphRead,
    req: &ExportRequest,
    to: ExportTarget<'_>,
) -> ToolResult<ExportAnswer> {
    let t0 = Instant::now();
    let mut a = ExportAnswer {
        format: req.format,
        nodes: 0,
        relationships: 0,
        points: None,
        files: Vec::new(),
        frame: GENERIC_FRAME.into(),
        time_ms: 0.0,
    };
    match (req.format, to) {
        (ExportFormat::Neo4jCsv, ExportTarget::Folder(dir)) => {
            let e = graphstore::export::export_neo4j_csv(r, dir).map_err(failed)?;
            a.nodes = e.nodes;
            a.relationships = e.relationships;
            a.files = e
                .files
                .iter()
                .filter_map(|f| f.file_name().and_then(|n| n.to_str()).map(str::to_string))
                .collect();
        }
        (ExportFormat::Neo4jCsv, ExportTarget::Writer(_)) => {
            return Err(ToolError::BadArguments(
                "neo4j-csv writes a folder of files: give a folder (opengraph export --out DIR, or Map.export(path) in Python)".into(),
            ));
        }
        (f, ExportTarget::Folder(_)) => {
            return Err(ToolError::BadArguments(format!(
                "{} writes one file, not a folder",
                f.name()
            )));
        }
        (ExportFormat::NodeLink, ExportTarget::Writer(w)) => {
            let key = match req.edges_key {
                EdgesKey::Edges => "edges",
                EdgesKey::Links => "links",
            };
            (a.nodes, a.relationships) =
                graphstore::export::export_node_link(r, key, w).map_err(failed)?;
        }
        (ExportFormat::Graphml, ExportTarget::Writer(w)) => {
            (a.nodes, a.relationships) =
                graphstore::export::export(r, graphstore::export::ExportFormat::GraphMl, w)
                    .map_err(failed)?;
        }
        (ExportFormat::Geojson, ExportTarget::Writer(w)) => {
            let m = scene::export::MapLayers::load(r).map_err(scene_failed)?;
            let fc = scene::export::geojson::feature_collection(&m);
            a.nodes = fc["features"].as_array().map_or(0, |f| f.len() as u64);
            a.frame = fc["opengraph_frame"]
                .as_str()
                .unwrap_or_default()
                .to_string();
            serde_json::to_writer(&mut *w, &fc).map_err(failed)?;
            w.write_all(b"\n").map_err(failed)?;
        }
        (ExportFormat::SparkDsg, ExportTarget::Writer(w)) => {
            let m = scene::export::MapLayers::load(r).map_err(scene_failed)?;
            let g = scene::export::spark_dsg::to_json(&m).map_err(scene_failed)?;
            a.nodes = g["nodes"].as_array().map_or(0, |n| n.len() as u64);
            a.relationships = g["edges"].as_array().map_or(0, |e| e.len() as u64);
            a.frame = g["metadata"]["opengraph"]["frame"]
                .as_str()
                .unwrap_or_default()
                .to_string();
            serde_json::to_writer(&mut *w, &g).map_err(failed)?;
            w.write_all(b"\n").map_err(failed)?;
        }
        (ExportFormat::Ply, ExportTarget::Writer(w)) => {
            let m = scene::export::MapLayers::load(r).map_err(scene_failed)?;
            let colour = match req.colour {
                PlyColouring::Class => scene::export::ply::PlyColour::Class,
                PlyColouring::Instance => scene::export::ply::PlyColour::Instance,
            };
            let e = scene::export::ply::write(r, &m, colour, w).map_err(scene_failed)?;
            a.nodes = e.instances;
            a.points = Some(e.points);
            a.frame = m.frame_words().to_string();
        }
    }
    a.time_ms = t0.elapsed().as_secs_f64() * 1e3;
    Ok(a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::demo_store;

    #[test]
    fn every_format_exports_the_demo_and_names_its_frame() {
        let (dir, store) = demo_store();
        store
            .write(|tx| {
                let k = tx.prop_key_id(scene::key::GROUND_FRAME)?;
                let env = tx.nodes_with_label(scene::label::ENVIRONMENT)?[0];
                tx.set_node_prop(env, k, "enu".into())
            })
            .unwrap();
        let r = store.read().unwrap();
        for name in ExportFormat::NAMES {
            let f: ExportFormat = name.parse().unwrap();
            assert_eq!(f.name(), name);
            let req = ExportRequest::new(f);
            let a = if f.is_folder() {
                let out = dir.path().join("csv");
                let a = export(&r, &req, ExportTarget::Folder(&out)).unwrap();
                assert!(a.files.iter().any(|f| f == "nodes_Instance.csv"), "{a:?}");
                a
            } else {
                let mut buf = Vec::new();
                let a = export(&r, &req, ExportTarget::Writer(&mut buf)).unwrap();
                assert!(!buf.is_empty(), "{name}");
                a
            };
            assert!(a.nodes > 0 || f == ExportFormat::Ply, "{name}: {a:?}");
            assert!(a.frame.contains("metres"), "{name}: {}", a.frame);
        }
        let e = export(
            &r,
            &ExportRequest::new(ExportFormat::Neo4jCsv),
            ExportTarget::Writer(&mut Vec::new()),
        )
        .unwrap_err();
        assert_eq!(e.http_status(), 400);
        assert!("xml".parse::<ExportFormat>().is_err());
    }
}
