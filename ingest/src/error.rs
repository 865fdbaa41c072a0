//! The crate's single error type.

use std::path::PathBuf;

/// Everything that can go wrong while reading sources or building the map.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A text file has a bad line.
    #[error("{}:{line}: {detail}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        detail: String,
    },
    /// A file is missing something it must have.
    #[error("{}: {detail}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// An OS error on a file.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// Input that cannot be processed (too short, non-finite, inconsistent).
    #[error("invalid input: {0}")]
    Invalid(String),
    /// A message from a live source (a ROS 2 message, a detections string) is malformed.
    #[error("{what}: {detail}")]
    Message {
        /// The message type or topic.
        what: String,
        /// What is wrong, with the byte offset where there is one.
        detail: String,
    },
    /// The store refused a write or a read failed.
    #[error(transparent)]
    Store(#[from] graphstore::Error),
    /// The map model cannot be read (no ground frame, a malformed record).
    #[error(transparent)]
    Scene(#[from] scene::Error),
    /// A language model or embedder failed.
    #[error(transparent)]
    Llm(#[from] llm_tools::Error),
    /// Drawing or encoding an image failed.
    #[error("rendering failed: {0}")]
    Render(String),
}

/// Result alias for ingest.
pub type Result<T, E = Error> = std::result::Result<T, E>;

pub fn read_text(path: &std::path::Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// Reads and parses a JSON file; a parse error names the file.
pub fn read_json(path: &std::path::Path) -> Result<serde_json::Value> {
    serde_json::from_str(&read_text(path)?).map_err(|e| Error::File {
        path: path.to_path_buf(),
        detail: format!("invalid JSON: {e}"),
    })
}

/// A ground point written as a JSON pair `[x, z]`.
pub fn json_xy(p: &serde_json::Value) -> Option<[f64; 2]> {
    Some([p.get(0)?.as_f64()?, p.get(1)?.as_f64()?])
}
