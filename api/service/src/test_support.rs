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

/// The demo map with each instance's caption feature (hash embedder), as a build writes
/// them, so that the map's view ([`scene::view::MapView`]) holds its instances.
pub(crate) fn demo_store_with_features() -> (tempfile::TempDir, Store) {
    use graphstore::{GraphRead, Value};
    use llm_tools::Embedder;
    let (dir, store) = demo_store();
    let r = store.read().unwrap();
    let ids = r.nodes_with_label(scene::label::INSTANCE).unwrap();
    let mut hash = llm_tools::HashEmbedder::new(scene::FEATURE_DIM);
    let mut features = Vec::new();
    for &id in &ids {
        let c = r.node_prop(id, scene::key::CAPTION).unwrap().unwrap();
        let c = c.as_str().unwrap().to_string();
        features.push((id, hash.embed(&[c.as_str()]).unwrap().remove(0)));
    }
    drop(r);
    store
        .write(|tx| {
            let k = tx.prop_key_id(scene::key::FEATURE)?;
            for (id, f) in &features {
                tx.set_node_prop(*id, k, Value::Vector(f.clone()))?;
            }
            Ok(())
        })
        .unwrap();
    (dir, store)
}
