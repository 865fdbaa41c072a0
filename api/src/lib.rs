#![doc = include_str!("../README.md")]

pub mod http;
pub mod mcp;

// the service layer, under the names the adapters and the CLI use
pub use opengraph_service::{
    ask, commit_cache, demo, find, info, plan, query_cache, service, tools, update, view,
};
