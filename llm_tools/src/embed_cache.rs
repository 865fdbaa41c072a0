//! A query-embedding cache shared by the workers of a server: the same request text (a
//! find target, an anchor, a landmark) is embedded once and then read back, so a repeated
//! question costs the ranking only. Least-recently-used eviction ([`lru`]).

use std::num::NonZeroUsize;
use std::sync::{Arc, Mutex};

use crate::embed::Embedder;
use crate::error::Result;

/// (model name, text) → its vector.
type Entries = lru::LruCache<(String, String), Arc<[f32]>>;

/// Texts and their vectors, least recently used first out. One cache serves one embedder
/// model: it is keyed by the model's name as well, so two models never share an entry.
#[derive(Debug)]
pub struct EmbeddingCache {
    entries: Mutex<Entries>,
    hits: std::sync::atomic::AtomicU64,
    misses: std::sync::atomic::AtomicU64,
}

impl EmbeddingCache {
    /// A cache of at most `capacity` texts (at least 1). A MiniLM vector is 1.5 KiB, so
    /// 4,096 entries hold about 6 MiB.
    pub fn new(capacity: usize) -> Arc<EmbeddingCache> {
        Arc::new(EmbeddingCache {
            entries: Mutex::new(lru::LruCache::new(
                NonZeroUsize::new(capacity.max(1)).unwrap_or(NonZeroUsize::MIN),
            )),
            hits: 0.into(),
            misses: 0.into(),
        })
    }

    /// (hits, misses) so far, one per text looked up.
    pub fn stats(&self) -> (u64, u64) {
        use std::sync::atomic::Ordering::Relaxed;
        (self.hits.load(Relaxed), self.misses.load(Relaxed))
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Entries> {
        // a panic while holding the lock leaves only a cache behind: keep using it
        self.entries
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// An [`Embedder`] that looks every text up in a shared [`EmbeddingCache`] first and embeds
/// only the missing ones, in one batch, with the embedder it wraps. Its answers are the
/// wrapped embedder's, bit for bit.
pub struct CachedEmbedder {
    inner: Box<dyn Embedder + Send>,
    cache: Arc<EmbeddingCache>,
    name: String,
}

impl std::fmt::Debug for CachedEmbedder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CachedEmbedder")
            .field("inner", &self.name)
            .field("cache", &self.cache.stats())
            .finish()
    }
}

impl CachedEmbedder {
    /// Wraps `inner`, sharing `cache` with every other wrapper given the same one.
    pub fn new(inner: Box<dyn Embedder + Send>, cache: Arc<EmbeddingCache>) -> CachedEmbedder {
        let name = inner.name();
        CachedEmbedder { inner, cache, name }
    }
}

impl Embedder for CachedEmbedder {
    fn dim(&self) -> usize {
        self.inner.dim()
    }

    fn name(&self) -> String {
        self.name.clone()
    }

    fn embed(&mut self, texts: &[&str]) -> Result<Vec<Vec<f32>>> {
        use std::sync::atomic::Ordering::Relaxed;
        let mut out: Vec<Option<Vec<f32>>> = Vec::with_capacity(texts.len());
        let mut missing: Vec<&str> = Vec::new();
        {
            let mut c = self.cache.lock();
            for t in texts {
                let hit = c
                    .get(&(self.name.clone(), (*t).to_string()))
                    .map(|v| v.to_vec());
                if hit.is_none() && !missing.contains(t) {
                    missing.push(t);
                }
                out.push(hit);
            }
        }
        let hits = out.iter().filter(|v| v.is_some()).count();
        self.cache.hits.fetch_add(hits as u64, Relaxed);
        self.cache
            .misses
            .fetch_add((texts.len() - hits) as u64, Relaxed);
        if missing.is_empty() {
            return Ok(out.into_iter().flatten().collect());
        }
        // embedded outside the lock: other workers go on meanwhile
        let fresh = self.inner.embed(&missing)?;
        let mut c = self.cache.lock();
        for (t, v) in missing.iter().zip(&fresh) {
            c.put(
                (self.name.clone(), (*t).to_string()),
                Arc::from(v.as_slice()),
            );
        }
        drop(c);
        Ok(out
            .into_iter()
            .zip(texts)
            .map(|(v, t)| {
                v.unwrap_or_else(|| {
                    let k = missing.iter().position(|m| m == t).unwrap_or(0);
                    fresh[k].clone()
                })
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_embed::HashEmbedder;

    /// Counts the texts it is asked to embed.
    struct Counting(HashEmbedder, Arc<std::sync::atomic::AtomicUsize>);

    impl Embedder for Counting {
        fn dim(&self) -> usize {
            self.0.dim()
        }
        fn name(&self) -> String {
            self.0.name()
        }
        fn embed(&mut self, texts: &[&str]) -> Result<Vec<Vec<f32>>> {
            self.1
                .fetch_add(texts.len(), std::sync::atomic::Ordering::SeqCst);
            self.0.embed(texts)
        }
    }

    #[test]
    fn repeated_texts_are_embedded_once_across_workers_with_the_same_answers() {
        let calls = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let cache = EmbeddingCache::new(2);
        let mut a = CachedEmbedder::new(
            Box::new(Counting(HashEmbedder::new(64), calls.clone())),
            cache.clone(),
        );
        let mut b = CachedEmbedder::new(
            Box::new(Counting(HashEmbedder::new(64), calls.clone())),
            cache.clone(),
        );
        let mut plain = HashEmbedder::new(64);
        let want = plain.embed(&["a red car", "a bench", "a red car"]).unwrap();
        assert_eq!(
            a.embed(&["a red car", "a bench", "a red car"]).unwrap(),
            want
        );
        // a repeat inside one batch is embedded once
        assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), 2);
        // another worker reads them back without embedding
        assert_eq!(
            b.embed(&["a bench", "a red car"]).unwrap(),
            vec![want[1].clone(), want[0].clone()]
        );
        assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), 2);
        assert_eq!(cache.stats(), (2, 3));
        // capacity 2: a third text evicts the least recently used ("a bench" was read before
        // "a red car", so it goes)
        b.embed(&["a tree"]).unwrap();
        b.embed(&["a red car"]).unwrap();
        assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), 3);
        b.embed(&["a bench"]).unwrap();
        assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), 4);
        assert!(b.embed(&[]).unwrap().is_empty());
    }
}
