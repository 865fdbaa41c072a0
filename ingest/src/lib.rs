#![doc = include_str!("../README.md")]

pub mod build;
pub mod cluster;
mod error;
pub mod hierarchy;
pub mod llm;
pub mod map_edit;
pub mod mapping;
pub mod sources;

pub use error::{Error, Result};
