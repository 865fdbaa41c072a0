//! Answers of read-only Cypher statements, shared by a server's workers and kept until the
//! next commit: an analyst's dashboard asks the same few questions again and again, and a
//! statement that scans every relationship (22,418 `RELATED` on the small city) costs tens of
//! milliseconds each time. Keyed by the statement's text and parameters; valid only at the
//! [`graphstore::Store::commit_seq`] it was computed at, so any write, through any worker or
//! tool, retires every entry. Statements that call `rand()`, `EXPLAIN`/`PROFILE` plans and
//! answers of more than [`MAX_CACHED_ROWS`] rows are never kept. Least recently used out
//! ([`lru`]).
//!
//! A miss is computed once for every worker that asks it at the same commit
//! ([`crate::commit_cache`]).

use serde_json::Value as Json;

use crate::error::ToolResult;

/// Answers with more rows are not kept (they are rare and large).
pub const MAX_CACHED_ROWS: usize = 1000;

/// (statement text, parameters as JSON text).
pub type Key = (String, String);

/// The shared cache of read-only answers. An error is an answer too: shared with the callers
/// that waited for the same statement at the same commit, never kept.
pub type QueryCache = crate::commit_cache::CommitCache<Key, ToolResult<Json>>;
