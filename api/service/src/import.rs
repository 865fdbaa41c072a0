//! The import operation: a new store from the CSV files of Neo4j's bulk importer (the format
//! `export --format neo4j-csv` writes, and that other graph databases and pandas can write).
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
    /// CSV bytes read.
    pub csv_bytes: u64,
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
    if files.nodes.is_empty() {
        return Err(ToolError::Input(
            "no node files: give a folder or node files".into(),
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
        let got =
            graphstore::import::import_neo4j_csv(&store, &files, req.batch_rows as usize, progress)
                .map_err(|e| classify(&e))?;
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
    let csv_bytes = files.total_bytes();
    Ok(ImportAnswer {
        db: req.db.clone(),
        nodes: got.nodes,
        relationships: got.relationships,
        ids_kept: got.ids_kept,
        batches: got.batches,
        csv_bytes,
        store_bytes: std::fs::metadata(&req.db).map_or(0, |m| m.len()),
        duration_secs: t.elapsed().as_secs_f64(),
    })
}
