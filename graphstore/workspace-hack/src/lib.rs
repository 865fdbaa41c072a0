//! Empty on purpose: this crate's dependency list gives every third-party crate the union of
//! the features the workspace asks of it, so that building one crate (`cargo test -p api`,
//! maturin's build of the Python module) reuses what `cargo test --workspace` compiled instead
//! of recompiling zenoh, llama.cpp and the rest with other features. Managed by `cargo hakari`
//! (see README.md).
