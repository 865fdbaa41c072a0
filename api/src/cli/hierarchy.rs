//! `opengraph hierarchy`.

use anyhow::Context;

use super::args::*;

/// `opengraph hierarchy`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Hierarchy {
        db,
        poses,
        calib,
        name,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Hierarchy here")
    };
    let traj = ingest::sources::kitti::load_trajectory(&poses, calib.as_deref())?;
    let store =
        graphstore::Store::create(&db).with_context(|| format!("opening {}", db.display()))?;
    if store.schema() == graphstore::Schema::default() {
        store.set_schema(scene::opengraph_schema())?;
    }
    let (_, _, report) = ingest::hierarchy::build_hierarchy(
        &store,
        &traj,
        scene::GroundFrame::KittiCam,
        &name,
        &ingest::hierarchy::HierarchyConfig::default(),
    )?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        outln!("{report:?}");
    }
    Ok(())
}
