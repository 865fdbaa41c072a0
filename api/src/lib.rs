#![doc = include_str!("../README.md")]

pub mod http;
pub mod mcp;

// the service layer, under the names the adapters and the CLI use
pub use opengraph_service::{
    area, ask, builder, commit_cache, demo, error, find, info, ops, plan, query_cache, service,
    tools, update, view,
};
