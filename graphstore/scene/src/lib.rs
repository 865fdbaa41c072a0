#![doc = include_str!("../README.md")]

pub mod area;
pub mod classes;
mod error;
pub mod export;
pub mod geom;
mod ground;
pub mod names;
mod obb;
pub mod pose;
pub mod records;
pub mod regions;
mod schema;
pub mod view;

pub use error::{Error, Result};
pub use geom::GroundPoint;
pub use ground::GroundFrame;
pub use names::{index, key, label, payload, rel};
pub use obb::{OBB_VALUES, OrientedBox};
pub use schema::{FEATURE_DIM, opengraph_schema, property_meaning};
