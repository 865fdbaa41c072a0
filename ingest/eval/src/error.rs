//! The crate's one error type.

use std::path::PathBuf;

/// What can go wrong while evaluating a map.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A truth, label or query file is missing something it must have.
    #[error("{}: {detail}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// Invalid arguments (an empty frame range, a map without what the evaluation needs).
    #[error("invalid input: {0}")]
    Invalid(String),
    /// Reading a source or the map's layers failed.
    #[error(transparent)]
    Ingest(#[from] ingest::Error),
    /// The store failed.
    #[error(transparent)]
    Store(#[from] graphstore::Error),
    /// The map model cannot be read.
    #[error(transparent)]
    Scene(#[from] scene::Error),
    /// Retrieval or localisation failed.
    #[error(transparent)]
    Llm(#[from] llm_tools::Error),
}

/// Result alias for the evaluations.
pub type Result<T, E = Error> = std::result::Result<T, E>;
