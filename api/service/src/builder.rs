//! The one way a service is assembled (`serve`, `mcp`, tests): reader workers, the writer's
//! own toolbox, the caches the workers share, and the language model for `ask`.

use std::sync::Arc;
use std::time::Duration;

use graphstore::Store;

use crate::error::{ToolError, ToolResult};
use crate::find::{Finder, SharedScene};
use crate::service::Service;
use crate::toolbox::Toolbox;

/// Settings of a service, with [`ServiceBuilder::build`] to assemble it.
///
/// Defaults: one reader worker, no writer, a 30 s request timeout, no caches, no model.
pub struct ServiceBuilder {
    workers: usize,
    writer: bool,
    timeout: Duration,
    embedding_cache: usize,
    query_cache: usize,
    llm: Option<Box<dyn llm_tools::ChatModel>>,
}

impl std::fmt::Debug for ServiceBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServiceBuilder")
            .field("workers", &self.workers)
            .field("writer", &self.writer)
            .field("timeout", &self.timeout)
            .field("embedding_cache", &self.embedding_cache)
            .field("query_cache", &self.query_cache)
            .field("llm", &self.llm.is_some())
            .finish()
    }
}

impl Default for ServiceBuilder {
    fn default() -> ServiceBuilder {
        ServiceBuilder {
            workers: 1,
            writer: false,
            timeout: Duration::from_secs(30),
            embedding_cache: 0,
            query_cache: 0,
            llm: None,
        }
    }
}

impl ServiceBuilder {
    /// The defaults.
    pub fn new() -> ServiceBuilder {
        ServiceBuilder::default()
    }

    /// Reader workers (at least 1).
    pub fn workers(mut self, n: usize) -> ServiceBuilder {
        self.workers = n.max(1);
        self
    }

    /// Gives the write tools a toolbox of their own (needs a first toolbox with writes on).
    pub fn writer(mut self, on: bool) -> ServiceBuilder {
        self.writer = on;
        self
    }

    /// How long one call may take: the wait for a worker and the work.
    pub fn timeout(mut self, t: Duration) -> ServiceBuilder {
        self.timeout = t;
        self
    }

    /// Query embeddings every worker shares, least recently used out (0: none).
    pub fn embedding_cache(mut self, entries: usize) -> ServiceBuilder {
        self.embedding_cache = entries;
        self
    }

    /// Read-only Cypher answers every worker shares until the next commit (0: none).
    pub fn query_cache(mut self, entries: usize) -> ServiceBuilder {
        self.query_cache = entries;
        self
    }

    /// The language model `ask` runs on.
    pub fn llm(mut self, model: Option<Box<dyn llm_tools::ChatModel>>) -> ServiceBuilder {
        self.llm = model;
        self
    }

    /// The service over `first`'s store: `first` and forks of it with finders from
    /// `finder`, one per further worker and for the writer, all sharing one map view per
    /// commit and the caches asked for.
    ///
    /// # Errors
    /// What `finder` returns; [`ToolError::Failed`] when a writer is asked for over a
    /// toolbox without writes.
    pub fn build(
        self,
        first: Toolbox,
        mut finder: impl FnMut(&Store) -> ToolResult<Finder>,
    ) -> ToolResult<Arc<Service>> {
        if self.writer && !first.writes() {
            return Err(ToolError::Failed(
                "a writer needs a toolbox with writes on".into(),
            ));
        }
        let n = self.workers + usize::from(self.writer);
        let mut boxes = Vec::with_capacity(n);
        for _ in 1..n {
            let f = finder(first.store())?;
            boxes.push(first.fork(f));
        }
        boxes.push(first);
        if self.embedding_cache > 0 {
            let cache = llm_tools::EmbeddingCache::new(self.embedding_cache);
            for b in &mut boxes {
                b.share_embedding_cache(cache.clone());
            }
        }
        let scene = SharedScene::new(1);
        for b in &mut boxes {
            b.share_scene(scene.clone());
        }
        if self.query_cache > 0 {
            let cache = crate::query_cache::QueryCache::new(self.query_cache);
            for b in &mut boxes {
                b.share_query_cache(cache.clone());
            }
        }
        let writer = if self.writer { boxes.pop() } else { None };
        let shared = || ToolError::Failed("the service is shared".into());
        let service = match self.llm {
            Some(m) => Service::with_llm(boxes, self.timeout, m),
            None => Service::new(boxes, self.timeout),
        }
        .ok_or_else(shared)?;
        match writer {
            Some(w) => service.with_writer(w).ok_or_else(shared),
            None => Ok(service),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{demo_store, hash_finder};

    #[test]
    fn a_service_with_workers_and_a_writer_answers_and_writes() {
        let (_dir, store) = demo_store();
        let first = Toolbox::new(store, hash_finder(), true);
        let svc = ServiceBuilder::new()
            .workers(2)
            .writer(true)
            .query_cache(8)
            .build(first, |_| Ok(hash_finder()))
            .unwrap();
        assert!(format!("{svc:?}").contains("workers: 2"), "{svc:?}");
        assert!(format!("{svc:?}").contains("writer: true"), "{svc:?}");
        let (_dir, store) = demo_store();
        let reader = Toolbox::new(store, hash_finder(), false);
        assert!(
            ServiceBuilder::new()
                .writer(true)
                .build(reader, |_| Ok(hash_finder()))
                .is_err()
        );
    }
}
