#![doc = include_str!("../README.md")]

mod ground;
mod obb;
pub mod pose;

pub use ground::GroundFrame;
pub use obb::{OBB_VALUES, OrientedBox};
