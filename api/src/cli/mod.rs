//! The `opengraph` command line: argument definitions (`args`), what the commands share
//! (`common`), the dispatch of one command (`run`) and the server command (`serve`). Every
//! command calls the service operations of the `api` library; none holds logic of its own
//! beyond parsing and printing.

pub(crate) mod args;
pub(crate) mod ask;
pub(crate) mod build;
pub(crate) mod captions;
pub(crate) mod common;
pub(crate) mod demo;
pub(crate) mod eval;
pub(crate) mod export;
pub(crate) mod find;
pub(crate) mod hierarchy;
pub(crate) mod import;
pub(crate) mod info;
pub(crate) mod init;
pub(crate) mod lanes;
pub(crate) mod locate;
pub(crate) mod mcp;
pub(crate) mod navigate;
pub(crate) mod oracle;
pub(crate) mod plan;
pub(crate) mod query;
pub(crate) mod relations;
pub(crate) mod replay;
pub(crate) mod run;
pub(crate) mod serve;
pub(crate) mod shard;
pub(crate) mod sim;
pub(crate) mod tool;
pub(crate) mod tools;
pub(crate) mod update;
pub(crate) mod values;
