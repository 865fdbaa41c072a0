#![doc = include_str!("../README.md")]

pub mod embed;
mod error;
pub mod wordpiece;

pub use embed::{Embedder, MiniLm};
pub use error::{Error, Result};
