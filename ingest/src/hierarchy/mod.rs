//! The paper's third module: lane graph, segments, environment and instance relations.

pub mod lanes;
pub mod render;
pub mod segments;
