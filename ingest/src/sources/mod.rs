//! Data sources.

pub mod detections;
pub mod kitti;
pub mod rle;
