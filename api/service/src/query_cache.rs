//! Answers of read-only Cypher statements, shared by a server's workers and kept until the
//! next commit: an analyst's dashboard asks the same few questions again and again, and a
//! statement that scans every relationship (22,418 `RELATED` on the small city) costs tens of
//! milliseconds each time. Keyed by the statement's text and parameters; valid only at the
//! [`graphstore::Store::commit_seq`] it was computed at, so any write, through any worker or
//! tool, retires every entry. Statements that call `rand()`, `EXPLAIN`/`PROFILE` plans and
//! answers of more than [`MAX_CACHED_ROWS`] rows are never kept. Least recently used out
//! ([`lru`]).

use std::num::NonZeroUsize;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use serde_json::Value as Json;

/// Answers with more rows are not kept (they are rare and large).
pub const MAX_CACHED_ROWS: usize = 1000;

/// (statement text, parameters as JSON text) → (commit sequence, answer).
type Entries = lru::LruCache<(String, String), (u64, Arc<Json>)>;

/// The shared cache.
#[derive(Debug)]
pub struct QueryCache {
    entries: Mutex<Entries>,
    hits: AtomicU64,
    misses: AtomicU64,
}

impl QueryCache {
    /// A cache of at most `capacity` answers (at least 1).
    pub fn new(capacity: usize) -> Arc<QueryCache> {
        Arc::new(QueryCache {
            entries: Mutex::new(lru::LruCache::new(
                NonZeroUsize::new(capacity.max(1)).unwrap_or(NonZeroUsize::MIN),
            )),
            hits: 0.into(),
            misses: 0.into(),
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Entries> {
        // a panic while holding the lock leaves only a cache behind: keep using it
        self.entries
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The answer kept for `key` when it was computed at commit `seq`.
    pub fn get(&self, key: &(String, String), seq: u64) -> Option<Arc<Json>> {
        let hit = match self.lock().get(key) {
            Some((s, a)) if *s == seq => Some(a.clone()),
            _ => None,
        };
        let counter = if hit.is_some() {
            &self.hits
        } else {
            &self.misses
        };
        counter.fetch_add(1, Ordering::Relaxed);
        hit
    }

    /// Keeps `answer`, computed on a snapshot at commit `seq` or later (a later one is never
    /// served: the commit sequence has moved on by then).
    pub fn put(&self, key: (String, String), seq: u64, answer: Arc<Json>) {
        self.lock().put(key, (seq, answer));
    }

    /// (hits, misses) so far.
    pub fn stats(&self) -> (u64, u64) {
        (
            self.hits.load(Ordering::Relaxed),
            self.misses.load(Ordering::Relaxed),
        )
    }
}
