#![doc = include_str!("../README.md")]

pub mod captions;
mod error;
pub mod instance_points;
pub mod instances;
mod labelled;
pub mod locate;
pub mod relations;
pub mod retrieval;
pub mod roads;
pub mod semseg;

pub use error::{Error, Result};
