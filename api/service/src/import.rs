//! The import operation: a new store from the CSV files of Neo4j's bulk importer (the format
//! `export --format neo4j-csv` writes, and that other graph databases and pandas can write),
//! or from networkx's node-link JSON (what `export --format node-link` and
//! `networkx.node_link_data` write).
//! The store is written into `<db>.importing` and renamed to `<db>` at the end, so a failed
//! import leaves nothing behind (and an existing map is never touched).

use std::path::PathBuf;
use std::time::Instant;

use graphstore::import::{CsvFile, CsvFiles};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{ToolError, ToolResult, classify};

/// The schema the new store carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ImportSchema {
    /// Schema-free: any labels, types and properties.
    #[default]
    None,
    /// The OpenGraph map schema (labels, constraints, spatial, vector and text indexes): for
    /// a map exported by OpenGraph; rows that break it fail the import.
    Opengraph,
}

fn default_type() -> String {
    "RELATED_TO".into()
}

fn batch_default() -> u32 {
    100_000
}

/// An import request.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImportRequest {
    /// The store file to create (must not exist).
    pub db: PathBuf,
    /// A folder of `nodes*.csv` and `relationships*.csv` files (as the export writes them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub folder: Option<PathBuf>,
    /// Node files, after the folder's: `file.csv` or `Label1:Label2=file.csv`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nodes: Vec<String>,
    /// Relationship files, after the folder's: `file.csv` or `TYPE=file.csv`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub relationships: Vec<String>,
    /// A node-link JSON file instead of CSV files (the edge list under `edges` or `links`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node_link: Option<PathBuf>,
    /// For node-link edges without a `type`: the relationship type they get.
    #[serde(default = "default_type")]
    pub default_type: String,
    /// The new store's schema.
    #[serde(default)]
    pub schema: ImportSchema,
    /// Rows per committed transaction.
    #[serde(default = "batch_default")]
    #[schemars(range(min = 1))]
    pub batch_rows: u32,
}

/// What an import did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ImportAnswer {
    /// The store written.
    pub db: PathBuf,
    /// Nodes imported.
    pub nodes: u64,
    /// Relationships imported.
    pub relationships: u64,
    /// True when every node kept the integer `:ID` of its file as its node id.
    pub ids_kept: bool,
    /// Transactions committed.
    pub batches: u64,
    /// Bytes of the input files (CSV or node-link JSON).
    pub input_bytes: u64,
    /// The store file's size.
    pub store_bytes: u64,
    /// Wall time of the import.
    pub duration_secs: f64,
}

/// Imports the request's files into a new store.
///
/// # Errors
/// [`ToolError::Input`] when `db` exists or its folder does not, when no node file is given,
/// for unreadable files and for a bad header or field (the message names the file and line);
/// [`ToolError::Failed`] for storage failures. Nothing is left at `db` on failure.
pub fn import(req: &ImportRequest, progress: &mut dyn FnMut(u64, u64)) -> ToolResult<ImportAnswer> {
    let t = Instant::now();
    if req.db.exists() {
        return Err(ToolError::Input(format!(
            "{} already exists; import makes a new store (give a new path)",
            req.db.display()
        )));
    }
    if let Some(parent) = req.db.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.is_dir()
    {
        return Err(ToolError::Input(format!(
            "cannot create {}: the folder {} does not exist",
            req.db.display(),
            parent.display()
        )));
    }
    let mut files = match &req.folder {
        Some(dir) => CsvFiles::from_folder(dir).map_err(|e| classify(&e))?,
        None => CsvFiles::default(),
    };
    files
        .nodes
        .extend(req.nodes.iter().map(|a| CsvFile::parse(a)));
    files
        .relationships
        .extend(req.relationships.iter().map(|a| CsvFile::parse(a)));
    if let Some(nl) = &req.node_link {
        if !files.nodes.is_empty() || !files.relationships.is_empty() {
            return Err(ToolError::Input(
                "give either a node-link file or CSV files, not both".into(),
            ));
        }
        if !nl.is_file() {
            return Err(ToolError::Input(format!("{}: no such file", nl.display())));
        }
        if req.default_type.trim().is_empty() {
            return Err(ToolError::Input(
                "the default relationship type is empty".into(),
            ));
        }
    } else if files.nodes.is_empty() {
        return Err(ToolError::Input(
            "no node files: give a folder, node files or a node-link file".into(),
        ));
    }
    for f in files.nodes.iter().chain(&files.relationships) {
        if !f.path.is_file() {
            return Err(ToolError::Input(format!(
                "{}: no such file",
                f.path.display()
            )));
        }
    }
    let mut tmp = req.db.clone().into_os_string();
    tmp.push(".importing");
    let tmp = PathBuf::from(tmp);
    // a leftover of an import that was killed
    let _ = std::fs::remove_file(&tmp);
    let result = (|| {
        let store = graphstore::Store::create(&tmp).map_err(|e| classify(&e))?;
        if req.schema == ImportSchema::Opengraph {
            store
                .set_schema(scene::opengraph_schema())
                .map_err(|e| classify(&e))?;
        }
        let got = match &req.node_link {
            Some(nl) => {
                let g = graphstore::import::import_node_link(
                    &store,
                    nl,
                    &req.default_type,
                    req.batch_rows as usize,
                    progress,
                )
                .map_err(|e| classify(&e))?;
                (g.nodes, g.relationships, g.ids_kept, g.batches)
            }
            None => {
                let g = graphstore::import::import_neo4j_csv(
                    &store,
                    &files,
                    req.batch_rows as usize,
                    progress,
                )
                .map_err(|e| classify(&e))?;
                (g.nodes, g.relationships, g.ids_kept, g.batches)
            }
        };
        // batches leave B-tree pages half full: compacting halves the file (285 -> 140 MB for
        // 200k nodes and 1M relationships) for about a tenth of the import's time
        let mut store = store;
        store.compact().map_err(|e| classify(&e))?;
        drop(store);
        Ok::<_, ToolError>(got)
    })();
    let got = match result {
        Ok(g) => g,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
    };
    std::fs::rename(&tmp, &req.db).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        ToolError::Failed(format!(
            "renaming {} to {}: {e}",
            tmp.display(),
            req.db.display()
        ))
    })?;
    let input_bytes = match &req.node_link {
        Some(nl) => std::fs::metadata(nl).map_or(0, |m| m.len()),
        None => files.total_bytes(),
    };
    let (nodes, relationships, ids_kept, batches) = got;
    Ok(ImportAnswer {
        db: req.db.clone(),
        nodes,
        relationships,
        ids_kept,
        batches,
        input_bytes,
        store_bytes: std::fs::metadata(&req.db).map_or(0, |m| m.len()),
        duration_secs: t.elapsed().as_secs_f64(),
    })
}
