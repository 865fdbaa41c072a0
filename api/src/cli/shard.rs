//! `opengraph shard` and `opengraph zenoh-query`: a map cut into regions, and questions
//! fanned out over them ([`opengraph_service::shards`]).

use super::args::*;
use super::common::*;
use opengraph_service::shards::{FanOutRequest, SplitRequest};

/// `opengraph shard`.
pub(crate) fn split(cmd: Command) -> anyhow::Result<()> {
    let Command::Shard {
        db,
        parts,
        out,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Shard here")
    };
    let a = opengraph_service::shards::split(&SplitRequest { db, parts, out })?;
    if json {
        outln!("{}", serde_json::to_string(&a)?);
        return Ok(());
    }
    let cuts: Vec<String> = a.cuts_m.iter().map(|c| format!("{c:.1}")).collect();
    if cuts.is_empty() {
        outln!("1 region (no cut)");
    } else {
        outln!(
            "{} regions across {} (cuts at {} m)",
            a.regions.len(),
            a.axis,
            cuts.join(", ")
        );
    }
    for r in &a.regions {
        outln!(
            "  {}: {} ({} own nodes; {} of the others' removed)",
            r.region,
            r.db.display(),
            r.owned_nodes,
            r.removed_nodes
        );
    }
    Ok(())
}

/// `opengraph zenoh-query`.
pub(crate) fn zenoh_query(cmd: Command) -> anyhow::Result<()> {
    let Command::ZenohQuery {
        map,
        tool,
        args,
        regions,
        deadline_secs,
        session,
    } = cmd
    else {
        unreachable!("run dispatches only Command::ZenohQuery here")
    };
    let args: serde_json::Value = serde_json::from_str(&args)
        .map_err(|e| UsageError(format!("the arguments are not JSON: {e}")))?;
    if let Some(bad) = regions.iter().find(|r| !og_zenoh::keys::is_chunk(r)) {
        return Err(UsageError(format!(
            "the region name {bad:?} cannot be part of a zenoh key: use letters, digits, _, - and ."
        ))
        .into());
    }
    let z = session.open_client()?;
    let shards = api::zenoh_front::ZenohShards::new(z.clone(), &map)?;
    let a = opengraph_service::shards::fan_out(
        &shards,
        &FanOutRequest {
            tool,
            args,
            regions: (!regions.is_empty()).then_some(regions),
            deadline_secs,
        },
    )?;
    use zenoh::Wait;
    let _ = z.close().wait();
    for m in &a.missing {
        eprintln!("region {} is missing: {}", m.region, m.reason);
    }
    outln!("{}", serde_json::to_string_pretty(&a)?);
    Ok(())
}
