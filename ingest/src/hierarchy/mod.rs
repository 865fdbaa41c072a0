//! The paper's third module: lane graph, segments, environment and instance relations.

pub mod drivable;
pub mod lanes;
pub mod relations;
pub mod render;
pub mod segments;
pub mod write;

pub use write::{HierarchyConfig, HierarchyReport, build_hierarchy};
