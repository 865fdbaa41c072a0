//! Builds the C++ shim over Debian's OMPL 1.5 (libompl-dev). Debian's ompl.pc is broken, so
//! the include directories are given directly.

use std::path::Path;

const OMPL_INCLUDE: &str = "/usr/include/ompl-1.5";
const EIGEN_INCLUDE: &str = "/usr/include/eigen3";

fn main() {
    println!("cargo:rerun-if-changed=shim/ompl_shim.h");
    println!("cargo:rerun-if-changed=shim/ompl_shim.cc");
    println!("cargo:rerun-if-changed=src/ffi.rs");
    for (dir, what) in [(OMPL_INCLUDE, "OMPL"), (EIGEN_INCLUDE, "Eigen")] {
        if !Path::new(dir).is_dir() {
            panic!(
                "\n\nplanner: {what} headers not found at {dir}.\n\
                 Install them with `scripts/setup.sh` (or `apt-get install libompl-dev`).\n\n"
            );
        }
    }
    cxx_build::bridge("src/ffi.rs")
        .file("shim/ompl_shim.cc")
        .include(OMPL_INCLUDE)
        .include(EIGEN_INCLUDE)
        .include(".")
        .std("c++17")
        .flag_if_supported("-Wno-deprecated-copy")
        .flag_if_supported("-Wno-unused-parameter")
        .compile("og_ompl_shim");
    println!("cargo:rustc-link-lib=ompl");
}
