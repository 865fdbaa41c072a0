#![doc = include_str!("../README.md")]

pub mod embed;
mod error;
pub mod hash_embed;
pub mod retrieve;
pub mod wordpiece;

pub use embed::{Embedder, MiniLm};
pub use error::{Error, Result};
pub use hash_embed::HashEmbedder;
