#![doc = include_str!("../README.md")]

pub mod cluster;
mod error;
pub mod hierarchy;
pub mod sources;

pub use error::{Error, Result};
