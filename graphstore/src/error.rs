//! The crate's single error type.

use std::path::PathBuf;

/// Everything that can go wrong in graphstore.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be opened or created as a redb database.
    #[error("cannot open store {path}: {reason}")]
    Open {
        /// The file.
        path: PathBuf,
        /// What redb or the OS said.
        reason: String,
    },
    /// Another process holds the store for writing (a build, a pass, a server).
    #[error(
        "{path} is open for writing by another process (a build, an LLM pass or a server); wait for it to finish, or read a copy of the file"
    )]
    InUse {
        /// The file.
        path: PathBuf,
    },
    /// A write on a store opened read-only.
    #[error("{path} was opened read-only; this needs a store opened for writing")]
    ReadOnlyStore {
        /// The file.
        path: PathBuf,
    },
    /// The file is a redb database but not an OpenGraph store.
    #[error("{path} is not an OpenGraph store (no graphstore header table)")]
    NotAStore {
        /// The file.
        path: PathBuf,
    },
    /// The store was written by another on-disk format version.
    #[error(
        "{path} has store format version {found}, this build reads version {expected}; {}",
        if found < expected {
            "opening it for writing converts it in place"
        } else {
            "export it with the matching opengraph version and re-import"
        }
    )]
    FormatVersion {
        /// The file.
        path: PathBuf,
        /// Version found in the file.
        found: u32,
        /// Version this build understands.
        expected: u32,
    },
    /// Stored bytes could not be decoded.
    #[error("corrupt store data in {what}: {detail}")]
    Corrupt {
        /// Which record or table.
        what: String,
        /// What was wrong.
        detail: String,
    },
    /// An error reported by the storage engine.
    #[error("storage engine error: {0}")]
    Storage(String),
    /// A node id that does not exist.
    #[error("node {0} does not exist")]
    NodeNotFound(u64),
    /// A relationship id that does not exist.
    #[error("relationship {0} does not exist")]
    RelNotFound(u64),
    /// Deleting a node that still has relationships without detaching.
    #[error("node {node} still has {count} relationship(s); detach-delete it or delete them first")]
    NodeHasRelationships {
        /// The node.
        node: u64,
        /// How many relationships it still has.
        count: usize,
    },
    /// A schema constraint would be violated; the write was not applied.
    #[error("constraint violation on {target}: {detail}")]
    Constraint {
        /// The label or relationship type whose rule failed.
        target: String,
        /// What failed.
        detail: String,
    },
    /// A schema declaration is invalid or conflicts with existing data.
    #[error("schema error: {0}")]
    Schema(String),
    /// A value is not acceptable where it was given.
    #[error("invalid value: {0}")]
    InvalidValue(String),
    /// An index that is not declared.
    #[error("no {kind} index named {name:?}")]
    NoSuchIndex {
        /// spatial, vector, text or property.
        kind: &'static str,
        /// The name asked for.
        name: String,
    },
    /// A name (label, type, property key) that the store has never seen.
    #[error("unknown {kind} {name:?}")]
    UnknownToken {
        /// label, relationship type or property key.
        kind: &'static str,
        /// The name.
        name: String,
    },
    /// A transaction was rolled back on request.
    #[error("transaction rolled back")]
    RolledBack,
    /// A Cypher query failed to parse, check or run.
    #[error(transparent)]
    Query(#[from] crate::cypher::QueryError),
    /// A bad line in a file being imported.
    #[error("{path}:{line}: {detail}")]
    Import {
        /// The file.
        path: PathBuf,
        /// The 1-based line (the header is line 1; 0 when no line applies).
        line: u64,
        /// What was wrong.
        detail: String,
    },
    /// An I/O error outside redb (export files and the like).
    #[error("i/o error on {path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        error: std::io::Error,
    },
}

/// Result alias used throughout graphstore.
pub type Result<T, E = Error> = std::result::Result<T, E>;

pub(crate) fn storage<E: std::fmt::Display>(e: E) -> Error {
    Error::Storage(e.to_string())
}

pub(crate) fn corrupt(what: impl Into<String>, detail: impl Into<String>) -> Error {
    Error::Corrupt {
        what: what.into(),
        detail: detail.into(),
    }
}
