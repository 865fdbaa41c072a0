//! Runs one parsed command.

use super::args::*;
use super::{
    ask, build, captions, demo, eval, export, find, hierarchy, import, info, init, lanes, locate,
    mcp, navigate, oracle, plan, query, relations, replay, serve, shard, sim, tool, tools, update,
};

pub(crate) fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        cmd @ Command::Info { .. } => info::run(cmd)?,
        cmd @ Command::Export { .. } => export::run(cmd)?,
        cmd @ Command::Import { .. } => import::run(cmd)?,
        cmd @ Command::Lanes { .. } => lanes::run(cmd)?,
        cmd @ Command::Hierarchy { .. } => hierarchy::run(cmd)?,
        cmd @ Command::Plan { .. } => plan::run(cmd)?,
        cmd @ Command::Navigate { .. } => navigate::run(cmd)?,
        cmd @ Command::Build { .. } => build::run(cmd)?,
        cmd @ Command::Relations { .. } => relations::run(cmd)?,
        cmd @ Command::Captions { .. } => captions::run(cmd)?,
        cmd @ Command::Sim { .. } => sim::run(cmd)?,
        cmd @ Command::Find { .. } => find::run(cmd)?,
        cmd @ Command::Update { .. } => update::run(cmd)?,
        cmd @ Command::Serve { .. } => serve::run(cmd)?,
        cmd @ Command::Replay { .. } => replay::run(cmd)?,
        cmd @ Command::Shard { .. } => shard::split(cmd)?,
        cmd @ Command::ZenohQuery { .. } => shard::zenoh_query(cmd)?,
        cmd @ Command::Mcp { .. } => mcp::run(cmd)?,
        cmd @ Command::Ask { .. } => ask::run(cmd)?,
        cmd @ Command::Tools { .. } => tools::run(cmd)?,
        cmd @ Command::Tool { .. } => tool::run(cmd)?,
        cmd @ Command::Locate { .. } => locate::run(cmd)?,
        cmd @ Command::Query { .. } => query::run(cmd)?,
        cmd @ Command::Oracle { .. } => oracle::run(cmd)?,
        cmd @ Command::Eval {
            what: EvalCommand::Semseg { .. },
        } => eval::semseg(cmd)?,
        cmd @ Command::Eval {
            what: EvalCommand::Relations { .. },
        } => eval::relations(cmd)?,
        cmd @ Command::Eval {
            what: EvalCommand::Retrieval { .. },
        } => eval::retrieval(cmd)?,
        cmd @ Command::Eval {
            what: EvalCommand::Locate { .. },
        } => eval::locate(cmd)?,
        cmd @ Command::Eval {
            what: EvalCommand::Instances { .. },
        } => eval::instances(cmd)?,
        cmd @ Command::Eval {
            what: EvalCommand::Captions { .. },
        } => eval::captions(cmd)?,
        cmd @ Command::Eval {
            what: EvalCommand::Roads { .. },
        } => eval::roads(cmd)?,
        cmd @ Command::Init { .. } => init::run(cmd)?,
        cmd @ Command::Demo { .. } => demo::run(cmd)?,
    }
    Ok(())
}
