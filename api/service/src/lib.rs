#![doc = include_str!("../README.md")]

pub mod ask;
pub mod commit_cache;
pub mod demo;
pub mod find;
pub mod info;
pub mod plan;
pub mod query_cache;
pub mod service;
pub mod tools;
pub mod update;
pub mod view;

#[cfg(test)]
mod test_support;
