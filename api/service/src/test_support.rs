//! Fixtures for this crate's unit tests.

use graphstore::Store;

use crate::find::Finder;

/// The demo map (`opengraph demo`) in a temporary folder, kept while the folder lives.
pub(crate) fn demo_store() -> (tempfile::TempDir, Store) {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::create(dir.path().join("d.og")).unwrap();
    crate::demo::build(&store).unwrap();
    (dir, store)
}

/// A finder with the deterministic hash embedder and no language model.
pub(crate) fn hash_finder() -> Finder {
    Finder::new(
        Box::new(llm_tools::HashEmbedder::new(scene::FEATURE_DIM)),
        None,
    )
}
