//! Data sources.

pub mod detections;
pub mod kitti;
pub mod oracle;
pub mod rle;
pub mod sim;
