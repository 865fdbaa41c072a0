//! Data sources.

pub mod kitti;
