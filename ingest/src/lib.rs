#![doc = include_str!("../README.md")]

pub mod build;
pub mod classes;
pub mod cluster;
mod error;
pub mod eval;
pub mod eval_instances;
pub mod eval_llm;
pub mod eval_locate;
pub mod eval_retrieval;
pub mod eval_roads;
pub mod hierarchy;
pub mod llm;
pub mod map_edit;
pub mod mapping;
pub mod sources;

pub use error::{Error, Result};
