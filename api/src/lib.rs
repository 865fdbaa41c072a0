#![doc = include_str!("../README.md")]

pub mod http;
pub mod mcp;
pub mod zenoh_front;

// the service layer, under the names the adapters and the CLI use
pub use opengraph_service::{
    area, ask, builder, commit_cache, demo, error, events, find, info, live, ops, plan,
    query_cache, service, tasks, tools, update, view,
};
