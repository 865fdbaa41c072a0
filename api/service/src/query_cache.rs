//! Answers of read-only Cypher statements, shared by a server's workers and kept until the
//! next commit: an analyst's dashboard asks the same few questions again and again, and a
//! statement that scans every relationship (22,418 `RELATED` on the small city) costs tens of
//! milliseconds each time. Keyed by the statement's text and parameters; valid only at the
//! [`graphstore::Store::commit_seq`] it was computed at, so any write, through any worker or
//! tool, retires every entry. Statements that call `rand()`, `EXPLAIN`/`PROFILE` plans and
//! answers of more than [`MAX_CACHED_ROWS`] rows are never kept. Least recently used out
//! ([`lru`]).
//!
//! Misses fly once: while one worker computes a statement at a commit, another worker that
//! asks the same statement at the same commit waits for that answer instead of computing it
//! again ([`QueryCache::get_or_compute`]). Right after a write every dashboard asks at once;
//! without this, a 30 ms scan ran once per waiting request and held every worker.

use std::collections::HashMap;
use std::num::NonZeroUsize;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::Duration;

use serde_json::Value as Json;

/// Answers with more rows are not kept (they are rare and large).
pub const MAX_CACHED_ROWS: usize = 1000;

/// (statement text, parameters as JSON text).
pub type Key = (String, String);

/// A computation under way: `None` until it ends, then the answer when it may be shared.
#[derive(Debug, Default)]
struct Flight {
    done: Mutex<Option<Option<Arc<Json>>>>,
    ended: Condvar,
}

#[derive(Debug)]
struct Entries {
    /// key → (commit sequence, answer)
    ready: lru::LruCache<Key, (u64, Arc<Json>)>,
    /// key → (commit sequence, its computation)
    flying: HashMap<Key, (u64, Arc<Flight>)>,
}

/// The shared cache.
#[derive(Debug)]
pub struct QueryCache {
    entries: Mutex<Entries>,
    hits: AtomicU64,
    misses: AtomicU64,
    waits: AtomicU64,
}

/// Ends a flight however its computation ends (an error or a panic shares nothing, and the
/// waiters compute for themselves).
struct Landing<'a> {
    cache: &'a QueryCache,
    key: Option<Key>,
    flight: Arc<Flight>,
    answer: Option<Arc<Json>>,
}

impl Drop for Landing<'_> {
    fn drop(&mut self) {
        if let Some(key) = self.key.take() {
            let mut e = self.cache.lock();
            if e.flying
                .get(&key)
                .is_some_and(|(_, f)| Arc::ptr_eq(f, &self.flight))
            {
                e.flying.remove(&key);
            }
        }
        *self
            .flight
            .done
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = Some(self.answer.take());
        self.flight.ended.notify_all();
    }
}

impl QueryCache {
    /// A cache of at most `capacity` answers (at least 1).
    pub fn new(capacity: usize) -> Arc<QueryCache> {
        Arc::new(QueryCache {
            entries: Mutex::new(Entries {
                ready: lru::LruCache::new(
                    NonZeroUsize::new(capacity.max(1)).unwrap_or(NonZeroUsize::MIN),
                ),
                flying: HashMap::new(),
            }),
            hits: 0.into(),
            misses: 0.into(),
            waits: 0.into(),
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Entries> {
        // a panic while holding the lock leaves only a cache behind: keep using it
        self.entries.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Keeps `answer`, computed on a snapshot at commit `seq` or later (a later one is never
    /// served: the commit sequence has moved on by then).
    fn put(&self, key: Key, seq: u64, answer: Arc<Json>) {
        self.lock().ready.put(key, (seq, answer));
    }

    /// The answer for `key` at commit `seq`: the kept one; else the one another caller is
    /// computing at the same commit, waited for up to `wait` (then, or when that computation
    /// fails or is not kept, computed here after all); else `compute`'s, kept when it says so
    /// (`(answer, keep)`). Never holds the cache's lock while computing or waiting.
    ///
    /// # Errors
    /// `compute`'s error.
    pub fn get_or_compute<E>(
        &self,
        key: Key,
        seq: u64,
        wait: Duration,
        compute: impl FnOnce() -> Result<(Json, bool), E>,
    ) -> Result<Arc<Json>, E> {
        let joined = {
            let mut e = self.lock();
            if let Some((s, a)) = e.ready.get(&key)
                && *s == seq
            {
                let a = a.clone();
                drop(e);
                self.hits.fetch_add(1, Ordering::Relaxed);
                return Ok(a);
            }
            match e.flying.get(&key) {
                Some((s, f)) if *s == seq => Ok(f.clone()),
                _ => {
                    let f = Arc::new(Flight::default());
                    e.flying.insert(key.clone(), (seq, f.clone()));
                    Err(f)
                }
            }
        };
        let flight = match joined {
            Ok(flight) => flight,
            Err(own) => return self.lead(key, seq, own, compute),
        };
        self.waits.fetch_add(1, Ordering::Relaxed);
        let done = flight.done.lock().unwrap_or_else(PoisonError::into_inner);
        let (done, _) = flight
            .ended
            .wait_timeout_while(done, wait, |d| d.is_none())
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(Some(answer)) = done.as_ref() {
            self.hits.fetch_add(1, Ordering::Relaxed);
            return Ok(answer.clone());
        }
        drop(done);
        self.misses.fetch_add(1, Ordering::Relaxed);
        compute().map(|(a, _)| Arc::new(a))
    }

    /// Computes an answer others may be waiting for on `flight`.
    fn lead<E>(
        &self,
        key: Key,
        seq: u64,
        flight: Arc<Flight>,
        compute: impl FnOnce() -> Result<(Json, bool), E>,
    ) -> Result<Arc<Json>, E> {
        self.misses.fetch_add(1, Ordering::Relaxed);
        let mut landing = Landing {
            cache: self,
            key: Some(key.clone()),
            flight,
            answer: None,
        };
        let (answer, keep) = compute()?;
        let answer = Arc::new(answer);
        if keep {
            self.put(key, seq, answer.clone());
            landing.answer = Some(answer.clone());
        }
        drop(landing);
        Ok(answer)
    }

    /// (hits, misses) so far; an answer waited for counts as a hit.
    pub fn stats(&self) -> (u64, u64) {
        (
            self.hits.load(Ordering::Relaxed),
            self.misses.load(Ordering::Relaxed),
        )
    }

    /// How many callers waited for another's computation so far.
    pub fn waits(&self) -> u64 {
        self.waits.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    fn key(q: &str) -> Key {
        (q.to_string(), String::new())
    }

    /// Waits (at most 10 s) until `n` callers wait on another's computation.
    fn until_waiting(c: &QueryCache, n: u64) {
        let t = Instant::now();
        while c.waits() < n {
            assert!(t.elapsed() < Duration::from_secs(10), "nobody joined");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn a_statement_at_one_commit_is_computed_once_for_concurrent_callers() {
        let c = QueryCache::new(8);
        let computed = AtomicU64::new(0);
        std::thread::scope(|s| {
            let leader = s.spawn(|| {
                c.get_or_compute(key("q"), 7, Duration::from_secs(10), || {
                    computed.fetch_add(1, Ordering::SeqCst);
                    // hold the flight until the others have joined it
                    until_waiting(&c, 3);
                    Ok::<_, ()>((Json::from(42), true))
                })
            });
            until_waiting_for_flight(&c);
            let joiners: Vec<_> = (0..3)
                .map(|_| {
                    s.spawn(|| {
                        c.get_or_compute(key("q"), 7, Duration::from_secs(10), || {
                            computed.fetch_add(1, Ordering::SeqCst);
                            Ok::<_, ()>((Json::from(-1), true))
                        })
                    })
                })
                .collect();
            assert_eq!(*leader.join().unwrap().unwrap(), Json::from(42));
            for j in joiners {
                assert_eq!(*j.join().unwrap().unwrap(), Json::from(42));
            }
        });
        assert_eq!(computed.load(Ordering::SeqCst), 1);
        assert_eq!(c.stats(), (3, 1));
        // kept: a later caller at the same commit computes nothing; at the next it does
        let again = c.get_or_compute(key("q"), 7, Duration::from_secs(1), || {
            Err::<(Json, bool), _>("computed again")
        });
        assert_eq!(*again.unwrap(), Json::from(42));
        let next = c.get_or_compute(key("q"), 8, Duration::from_secs(1), || {
            Ok::<_, ()>((Json::from(43), true))
        });
        assert_eq!(*next.unwrap(), Json::from(43));
    }

    /// Waits until some computation is under way.
    fn until_waiting_for_flight(c: &QueryCache) {
        let t = Instant::now();
        while c.lock().flying.is_empty() {
            assert!(t.elapsed() < Duration::from_secs(10), "no flight began");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn a_failed_or_panicked_computation_releases_its_waiters_who_compute_for_themselves() {
        for panics in [false, true] {
            let c = QueryCache::new(8);
            std::thread::scope(|s| {
                let leader = s.spawn(|| {
                    c.get_or_compute(key("q"), 1, Duration::from_secs(10), || {
                        until_waiting(&c, 1);
                        if panics {
                            panic!("the statement's evaluation panicked");
                        }
                        Err::<(Json, bool), _>("timed out")
                    })
                });
                until_waiting_for_flight(&c);
                let joiner = s.spawn(|| {
                    c.get_or_compute(key("q"), 1, Duration::from_secs(10), || {
                        Ok::<_, &str>((Json::from(5), true))
                    })
                });
                let led = leader.join();
                if panics {
                    assert!(led.is_err());
                } else {
                    assert_eq!(led.unwrap().unwrap_err(), "timed out");
                }
                assert_eq!(*joiner.join().unwrap().unwrap(), Json::from(5));
            });
            // nothing is left flying, and a waiter's own answer is not kept
            assert!(c.lock().flying.is_empty());
            assert!(c.lock().ready.is_empty());
        }
    }

    #[test]
    fn an_answer_not_to_be_kept_is_not_served_to_later_callers() {
        let c = QueryCache::new(8);
        for n in 0..2 {
            let a = c.get_or_compute(key("EXPLAIN q"), 1, Duration::from_secs(1), || {
                Ok::<_, ()>((Json::from(n), false))
            });
            assert_eq!(*a.unwrap(), Json::from(n));
        }
        assert_eq!(c.stats(), (0, 2));
    }
}
