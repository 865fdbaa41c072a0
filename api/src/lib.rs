#![doc = include_str!("../README.md")]

pub mod ask;
pub mod demo;
pub mod find;
pub mod info;
pub mod mcp;
pub mod plan;
pub mod tools;
