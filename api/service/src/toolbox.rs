//! The map and what calls share: the store, the finder, whether writes are on, the caches.
//! The tool registry ([`crate::tools`]), Cypher ([`crate::cypher`]) and the top-down reads
//! ([`crate::area`]) are operations on it.

use std::sync::Arc;

use graphstore::Store;

use crate::find::Finder;

/// The map and what calls share: the store, the finder, whether writes are on. Toolboxes
/// made with [`Toolbox::fork`] share one store; each finder keeps its scene by the store's
/// commit sequence, so after a write through any of them each loads the new scene on its
/// next call.
pub struct Toolbox {
    pub(crate) store: Store,
    pub(crate) finder: Finder,
    pub(crate) writes: bool,
    /// Answers of read-only Cypher statements, shared with the forks given it.
    pub(crate) query_cache: Option<Arc<crate::query_cache::QueryCache>>,
}

impl std::fmt::Debug for Toolbox {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Toolbox")
            .field("store", &self.store.path())
            .field("writes", &self.writes)
            .finish()
    }
}

impl Toolbox {
    /// A toolbox over an open store. `writes` enables `write_cypher` (the store must then be
    /// open for writing).
    pub fn new(store: Store, finder: Finder, writes: bool) -> Toolbox {
        Toolbox {
            store,
            finder,
            writes,
            query_cache: None,
        }
    }

    /// Another toolbox over the same store with its own finder (for a pool of workers).
    pub fn fork(&self, finder: Finder) -> Toolbox {
        Toolbox {
            store: self.store.clone(),
            finder,
            writes: self.writes,
            query_cache: self.query_cache.clone(),
        }
    }

    /// Shares loaded scenes with every other toolbox given `shared` (a server's workers):
    /// after a write one worker loads the map's scene and the others take it.
    pub fn share_scene(&mut self, shared: Arc<crate::find::SharedScene>) {
        self.finder.share_scene(shared);
    }

    /// Keeps answers of read-only Cypher statements in `cache`, shared with every other
    /// toolbox given it (a server's workers), until the next commit
    /// ([`crate::query_cache`]).
    pub fn share_query_cache(&mut self, cache: Arc<crate::query_cache::QueryCache>) {
        self.query_cache = Some(cache);
    }

    /// Shares `cache` for query embeddings with every other toolbox given it (a server's
    /// workers): a request text is embedded once, then read back.
    pub fn share_embedding_cache(&mut self, cache: std::sync::Arc<llm_tools::EmbeddingCache>) {
        self.finder.share_embedding_cache(cache);
    }

    /// The store.
    pub fn store(&self) -> &Store {
        &self.store
    }

    /// The finder and the store, for operations outside the registry.
    pub fn parts(&mut self) -> (&mut Finder, &Store) {
        (&mut self.finder, &self.store)
    }

    /// Whether the write tools are offered.
    pub fn writes(&self) -> bool {
        self.writes
    }

    /// Offers or withholds the write tools (withholding is always safe; offering them needs a
    /// store open for writing).
    pub fn set_writes(&mut self, writes: bool) {
        self.writes = writes && !self.store.is_read_only();
    }
}
