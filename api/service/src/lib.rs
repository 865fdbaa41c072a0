#![doc = include_str!("../README.md")]

pub mod area;
pub mod ask;
pub mod build;
pub mod builder;
pub mod commit_cache;
mod cypher;
pub mod demo;
pub mod error;
pub mod events;
pub mod export;
pub mod find;
pub mod import;
pub mod info;
pub mod live;
pub mod ops;
pub mod plan;
pub mod query_cache;
pub mod service;
pub mod shards;
pub mod sim;
pub mod tasks;
pub mod toolbox;
pub mod tools;
pub mod update;
pub mod view;

#[cfg(test)]
mod test_support;
