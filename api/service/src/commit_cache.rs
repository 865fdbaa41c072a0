//! Values computed from one commit of the store and shared by a server's workers until the
//! next: a read-only Cypher answer ([`crate::query_cache`]), a finder's scene
//! ([`crate::find::SharedScene`]). Each is kept with the [`graphstore::Store::commit_seq`] it
//! was computed at and served only at that commit, so any write, through any worker or tool,
//! retires it; a newer commit's value is never replaced by an older one's. Least recently
//! used out ([`lru`]).
//!
//! Misses fly once: while one worker computes a key at a commit, another worker that asks
//! the same key at the same commit waits for that value instead of computing it again
//! ([`CommitCache::get_or_compute`]). Right after a write every dashboard asks at once;
//! without this, a 30 ms scan ran once per waiting request and held every worker. What a
//! computation gives is shared with the callers that waited for it even when it is not kept
//! for later ones (a Cypher error, a timeout included, is an answer at that commit too: two
//! identical statements that time out take 10 s, not 10 s and then 10 s more).

use std::collections::HashMap;
use std::hash::Hash;
use std::num::NonZeroUsize;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::Duration;

/// A computation under way: `None` until it ends, then the value when it may be shared.
struct Flight<V> {
    done: Mutex<Option<Option<Arc<V>>>>,
    ended: Condvar,
}

struct Entries<K, V> {
    /// key → (commit sequence, value)
    ready: lru::LruCache<K, (u64, Arc<V>)>,
    /// key → (commit sequence, its computation)
    flying: HashMap<K, (u64, Arc<Flight<V>>)>,
}

/// Values by key, each valid at the commit it was computed at; see the module docs.
pub struct CommitCache<K, V> {
    entries: Mutex<Entries<K, V>>,
    hits: AtomicU64,
    misses: AtomicU64,
    waits: AtomicU64,
}

impl<K, V> std::fmt::Debug for CommitCache<K, V> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CommitCache")
            .field("stats", &self.stats())
            .field("waits", &self.waits())
            .finish_non_exhaustive()
    }
}

/// Ends a flight however its computation ends (an error or a panic shares nothing, and the
/// waiters compute for themselves).
struct Landing<'a, K: Hash + Eq, V> {
    cache: &'a CommitCache<K, V>,
    key: K,
    flight: Arc<Flight<V>>,
    value: Option<Arc<V>>,
}

impl<K: Hash + Eq, V> Drop for Landing<'_, K, V> {
    fn drop(&mut self) {
        let mut e = self.cache.lock();
        if e.flying
            .get(&self.key)
            .is_some_and(|(_, f)| Arc::ptr_eq(f, &self.flight))
        {
            e.flying.remove(&self.key);
        }
        drop(e);
        *self
            .flight
            .done
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = Some(self.value.take());
        self.flight.ended.notify_all();
    }
}

impl<K, V> CommitCache<K, V> {
    fn lock(&self) -> std::sync::MutexGuard<'_, Entries<K, V>> {
        // a panic while holding the lock leaves only a cache behind: keep using it
        self.entries.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// (hits, misses) so far; a value waited for counts as a hit.
    pub fn stats(&self) -> (u64, u64) {
        (
            self.hits.load(Ordering::Relaxed),
            self.misses.load(Ordering::Relaxed),
        )
    }

    /// The newest kept value of `key`, at whatever commit: `(commit sequence, value)` (for
    /// bringing an older value up to date instead of computing it afresh).
    pub fn latest(&self, key: &K) -> Option<(u64, Arc<V>)>
    where
        K: Hash + Eq,
    {
        self.lock().ready.peek(key).map(|(s, v)| (*s, v.clone()))
    }

    /// How many callers waited for another's computation so far.
    pub fn waits(&self) -> u64 {
        self.waits.load(Ordering::Relaxed)
    }
}

impl<K: Hash + Eq + Clone, V> CommitCache<K, V> {
    /// A cache of at most `capacity` values (at least 1).
    pub fn new(capacity: usize) -> Arc<CommitCache<K, V>> {
        Arc::new(CommitCache {
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

    /// The value for `key` at commit `seq`: the kept one; else the one another caller is
    /// computing at the same commit, kept or not, waited for up to `wait` (then, or when that
    /// computation fails or panics, computed here after all); else `compute`'s, kept when it says so
    /// (`(value, keep)`) unless a newer commit's is kept. A caller whose commit is older than
    /// one being computed computes alone. Never holds the cache's lock while computing or
    /// waiting.
    ///
    /// # Errors
    /// `compute`'s error.
    pub fn get_or_compute<E>(
        &self,
        key: K,
        seq: u64,
        wait: Duration,
        compute: impl FnOnce() -> Result<(V, bool), E>,
    ) -> Result<Arc<V>, E> {
        let flight = {
            let mut e = self.lock();
            if let Some((s, v)) = e.ready.get(&key)
                && *s == seq
            {
                let v = v.clone();
                drop(e);
                self.hits.fetch_add(1, Ordering::Relaxed);
                return Ok(v);
            }
            match e.flying.get(&key) {
                Some((s, f)) if *s == seq => Some(f.clone()),
                Some((s, _)) if *s > seq => None,
                _ => {
                    let f = Arc::new(Flight {
                        done: Mutex::new(None),
                        ended: Condvar::new(),
                    });
                    e.flying.insert(key.clone(), (seq, f.clone()));
                    drop(e);
                    return self.lead(key, seq, f, compute);
                }
            }
        };
        if let Some(flight) = flight {
            self.waits.fetch_add(1, Ordering::Relaxed);
            let done = flight.done.lock().unwrap_or_else(PoisonError::into_inner);
            let (done, _) = flight
                .ended
                .wait_timeout_while(done, wait, |d| d.is_none())
                .unwrap_or_else(PoisonError::into_inner);
            if let Some(Some(v)) = done.as_ref() {
                self.hits.fetch_add(1, Ordering::Relaxed);
                return Ok(v.clone());
            }
        }
        self.misses.fetch_add(1, Ordering::Relaxed);
        let (v, keep) = compute()?;
        let v = Arc::new(v);
        if keep {
            self.keep(key, seq, v.clone());
        }
        Ok(v)
    }

    /// Keeps `value`, computed at commit `seq`, unless a newer commit's is kept.
    fn keep(&self, key: K, seq: u64, value: Arc<V>) {
        let mut e = self.lock();
        if e.ready.peek(&key).is_none_or(|(s, _)| *s <= seq) {
            e.ready.put(key, (seq, value));
        }
    }

    /// Computes a value others may be waiting for on `flight`.
    fn lead<E>(
        &self,
        key: K,
        seq: u64,
        flight: Arc<Flight<V>>,
        compute: impl FnOnce() -> Result<(V, bool), E>,
    ) -> Result<Arc<V>, E> {
        self.misses.fetch_add(1, Ordering::Relaxed);
        let mut landing = Landing {
            cache: self,
            key: key.clone(),
            flight,
            value: None,
        };
        let (v, keep) = compute()?;
        let v = Arc::new(v);
        if keep {
            self.keep(key, seq, v.clone());
        }
        landing.value = Some(v.clone());
        drop(landing);
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    type C = CommitCache<&'static str, i64>;

    /// Waits (at most 10 s) until `n` callers wait on another's computation.
    fn until_waiting(c: &C, n: u64) {
        let t = Instant::now();
        while c.waits() < n {
            assert!(t.elapsed() < Duration::from_secs(10), "nobody joined");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn a_statement_at_one_commit_is_computed_once_for_concurrent_callers() {
        let c = C::new(8);
        let computed = AtomicU64::new(0);
        std::thread::scope(|s| {
            let leader = s.spawn(|| {
                c.get_or_compute("q", 7, Duration::from_secs(10), || {
                    computed.fetch_add(1, Ordering::SeqCst);
                    // hold the flight until the others have joined it
                    until_waiting(&c, 3);
                    Ok::<_, ()>((42, true))
                })
            });
            until_waiting_for_flight(&c);
            let joiners: Vec<_> = (0..3)
                .map(|_| {
                    s.spawn(|| {
                        c.get_or_compute("q", 7, Duration::from_secs(10), || {
                            computed.fetch_add(1, Ordering::SeqCst);
                            Ok::<_, ()>((-1, true))
                        })
                    })
                })
                .collect();
            assert_eq!(*leader.join().unwrap().unwrap(), 42);
            for j in joiners {
                assert_eq!(*j.join().unwrap().unwrap(), 42);
            }
        });
        assert_eq!(computed.load(Ordering::SeqCst), 1);
        assert_eq!(c.stats(), (3, 1));
        // kept: a later caller at the same commit computes nothing; at the next it does
        let again = c.get_or_compute("q", 7, Duration::from_secs(1), || {
            Err::<(i64, bool), _>("computed again")
        });
        assert_eq!(*again.unwrap(), 42);
        let next = c.get_or_compute("q", 8, Duration::from_secs(1), || Ok::<_, ()>((43, true)));
        assert_eq!(*next.unwrap(), 43);
    }

    /// Waits until some computation is under way.
    fn until_waiting_for_flight(c: &C) {
        let t = Instant::now();
        while c.lock().flying.is_empty() {
            assert!(t.elapsed() < Duration::from_secs(10), "no flight began");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn a_failed_or_panicked_computation_releases_its_waiters_who_compute_for_themselves() {
        for panics in [false, true] {
            let c = C::new(8);
            std::thread::scope(|s| {
                let leader = s.spawn(|| {
                    c.get_or_compute("q", 1, Duration::from_secs(10), || {
                        until_waiting(&c, 1);
                        if panics {
                            panic!("the statement's evaluation panicked");
                        }
                        Err::<(i64, bool), _>("timed out")
                    })
                });
                until_waiting_for_flight(&c);
                let joiner = s.spawn(|| {
                    c.get_or_compute("q", 1, Duration::from_secs(10), || Ok::<_, &str>((5, true)))
                });
                let led = leader.join();
                if panics {
                    assert!(led.is_err());
                } else {
                    assert_eq!(led.unwrap().unwrap_err(), "timed out");
                }
                assert_eq!(*joiner.join().unwrap().unwrap(), 5);
            });
            // nothing is left flying; the waiter's own value is kept for its commit
            assert!(c.lock().flying.is_empty());
            assert_eq!(
                c.lock().ready.peek(&"q").map(|(s, v)| (*s, **v)),
                Some((1, 5))
            );
        }
    }

    #[test]
    fn an_answer_not_to_be_kept_is_not_served_to_later_callers() {
        let c = C::new(8);
        for n in 0..2 {
            let a = c.get_or_compute("EXPLAIN q", 1, Duration::from_secs(1), || {
                Ok::<_, ()>((n, false))
            });
            assert_eq!(*a.unwrap(), n);
        }
        assert_eq!(c.stats(), (0, 2));
    }

    #[test]
    fn an_older_commit_s_value_never_replaces_a_newer_one() {
        let c = C::new(8);
        let at = |seq: u64, v: i64| {
            *c.get_or_compute("q", seq, Duration::from_secs(1), || Ok::<_, ()>((v, true)))
                .unwrap()
        };
        assert_eq!(at(4, 40), 40);
        // a slow reader still on commit 2 computes its own value and does not keep it
        assert_eq!(at(2, 20), 20);
        assert_eq!(at(4, -1), 40);
        assert_eq!(c.stats(), (1, 2));
        assert!(c.lock().flying.is_empty());
    }

    #[test]
    fn a_value_not_kept_is_still_shared_with_the_callers_that_waited_for_it() {
        let c = C::new(8);
        std::thread::scope(|s| {
            let leader = s.spawn(|| {
                c.get_or_compute("q", 1, Duration::from_secs(10), || {
                    until_waiting(&c, 1);
                    Ok::<_, ()>((7, false))
                })
            });
            until_waiting_for_flight(&c);
            let joiner = s.spawn(|| {
                c.get_or_compute("q", 1, Duration::from_secs(10), || Ok::<_, ()>((-1, false)))
            });
            assert_eq!(*leader.join().unwrap().unwrap(), 7);
            assert_eq!(*joiner.join().unwrap().unwrap(), 7);
        });
        assert_eq!(c.stats(), (1, 1));
        assert!(c.lock().ready.is_empty());
    }
}
