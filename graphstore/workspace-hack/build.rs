//! A build script is what makes cargo resolve this crate's build-dependencies (hakari's
//! unified features for build scripts and proc macros).
fn main() {}
