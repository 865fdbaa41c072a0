//! The build's checkpoint in the store (`Build` node) and what a resumed build reloads: the
//! objects mapped so far and the configuration it must match.

use super::*;

pub(super) const BUILD_ID: i64 = 0;
pub(super) const PAYLOAD_KEY: &str = scene::payload::POINTS;

pub(super) struct Checkpoint {
    pub(super) node: u64,
    pub(super) args: String,
    pub(super) next_frame: i64,
    pub(super) next_instance_id: u64,
    pub(super) finished: bool,
    pub(super) hierarchy_done: bool,
}

/// Writes a new build's checkpoint (`Build` node): its arguments, the first frame to map,
/// unfinished, and what it maps from (`source`); returns the node.
pub(super) fn create_checkpoint(
    store: &Store,
    args_json: &str,
    next_frame: i64,
    source: &str,
) -> Result<u64> {
    Ok(store.write(|tx| {
        tx.create_node_named(
            &[scene::label::BUILD],
            &[
                (key::BUILD_ID, Value::Int(BUILD_ID)),
                (key::ARGS, Value::String(args_json.to_string())),
                (key::NEXT_FRAME, Value::Int(next_frame)),
                (key::NEXT_INSTANCE_ID, Value::Int(0)),
                (key::FINISHED, Value::Bool(false)),
                (key::SOURCE, Value::String(source.to_string())),
            ],
        )
    })?)
}

pub(super) fn load_checkpoint(r: &impl GraphRead) -> Result<Option<Checkpoint>> {
    let Some(&node) = r
        .find_nodes(scene::label::BUILD, key::BUILD_ID, &Value::Int(BUILD_ID))?
        .first()
    else {
        return Ok(None);
    };
    let get = |k: &str| r.node_prop(node, k);
    Ok(Some(Checkpoint {
        node,
        args: get(key::ARGS)?
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default(),
        next_frame: get(key::NEXT_FRAME)?.and_then(|v| v.as_int()).unwrap_or(0),
        next_instance_id: get(key::NEXT_INSTANCE_ID)?
            .and_then(|v| v.as_int())
            .unwrap_or(0)
            .max(0) as u64,
        finished: matches!(get(key::FINISHED)?, Some(Value::Bool(true))),
        hierarchy_done: matches!(get(key::HIERARCHY_DONE)?, Some(Value::Bool(true))),
    }))
}

/// Instance node ids by instance id, and the objects, from a store.
pub(super) fn load_objects(
    r: &impl GraphRead,
    voxel_m: f32,
) -> Result<(Vec<MapObject>, BTreeMap<u64, u64>)> {
    let mut objects = Vec::new();
    let mut nodes = BTreeMap::new();
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let p = |k: &str| r.node_prop(id, k);
        let int = |v: Option<Value>| v.and_then(|v| v.as_int()).unwrap_or(0);
        let instance_id = int(p(key::INSTANCE_ID)?).max(0) as u64;
        let tile = match p(key::TILE)? {
            Some(Value::List(v)) if v.len() == 3 => {
                let i = |k: usize| v[k].as_int().unwrap_or(0);
                Some((i(0) as u8, [i(1), i(2)]))
            }
            _ => None,
        };
        let feature = match p(key::DETECTION_FEATURE)? {
            Some(Value::Vector(v)) => v,
            _ => Vec::new(),
        };
        let captions = match p(key::CAPTIONS)? {
            Some(Value::List(v)) => v
                .iter()
                .filter_map(|c| c.as_str().map(str::to_string))
                .collect(),
            _ => Vec::new(),
        };
        let points = r
            .point_cloud(id, PAYLOAD_KEY)?
            .map(|c| c.xyz)
            .unwrap_or_default();
        objects.push(MapObject::restore(
            instance_id,
            tile,
            points,
            feature,
            captions,
            int(p(key::DETECTION_COUNT)?) as u32,
            int(p(key::FIRST_FRAME)?) as u32,
            int(p(key::LAST_FRAME)?) as u32,
            voxel_m,
        ));
        nodes.insert(instance_id, id);
    }
    Ok((objects, nodes))
}

/// The configuration as a resumed build must match it: everything but `[llm]`, whose caption
/// merge is a pass of its own, and `[live]` (topics and timing, not the map).
pub(super) fn resume_config(cfg: &BuildConfig) -> Result<serde_json::Value> {
    let mut v = serde_json::to_value(cfg).map_err(|e| Error::Invalid(e.to_string()))?;
    if let Some(o) = v.as_object_mut() {
        o.remove("llm");
        o.remove("live");
    }
    Ok(v)
}

/// How a map names an input path: relative to `base` when it lies inside it, else by its
/// last component alone (a map never holds the build machine's absolute paths).
pub(super) fn display_name(path: &Path, base: Option<&Path>) -> String {
    if let Some(rel) = base.and_then(|b| path.strip_prefix(b).ok())
        && !rel.as_os_str().is_empty()
    {
        return rel.display().to_string();
    }
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}
