#![doc = include_str!("../README.md")]

mod error;
mod ffi;
pub mod graph;
pub mod motion;
pub mod render;
pub mod route;

pub use error::{Error, Result};
pub use graph::{RoadEdge, RoadGraph, RoadNode};
pub use motion::{MotionConfig, MotionPath, Obstacle, Refinement, Validity, plan_path};
pub use route::{Anchor, Route, Spec, Target, astar, resolve, snap, target, unit_cost_route};
pub use scene::GroundFrame;
