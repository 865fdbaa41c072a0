//! Data sources.

pub mod detections;
pub mod kitti;
pub mod live;
pub mod oracle;
pub mod rle;
pub mod ros;
pub mod sim;
