//! The tool registry: the map's operations as typed tools with JSON Schemas, for LLM agents.
//! One registry feeds every agent front end (the MCP server, `opengraph tool`, OpenAI-style
//! function calling in `opengraph ask`); each call is validated against its schema
//! (`jsonschema`) and runs the same service operations as the CLI.
//!
//! | tool | what |
//! |---|---|
//! | `get_schema` | labels, relationship types, counts, indexes, and what the layers mean |
//! | `read_cypher` | a Cypher read, read-only by the parser, 10 s and 1000 rows at most |
//! | `write_cypher` | a Cypher write (only when writes are enabled) |
//! | `find_objects` | graph-aware retrieval (`find`) with evidence |
//! | `locate` | road segments for a description of the surroundings |
//! | `plan_route` | a route between two ends given in words or as specs (`navigate`) |
//! | `describe_area` | top-down: the environment's segments, or one segment's objects |
//! | `get_instance` | one instance: caption, class, box, segment, relations |

use std::collections::BTreeMap;
use std::time::Duration;

use graphstore::{Direction, GraphRead, Store, Value};
use serde_json::{Value as Json, json};

use crate::find::{FindRequest, Finder, LocateRequest, ParserKind, Ranking};
use crate::plan::{NavigateAnswer, PlanOptions};

/// One tool: name, description, JSON Schema of its arguments, and whether it writes.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Tool {
    /// The tool's name.
    pub name: &'static str,
    /// What it does, for the model.
    pub description: &'static str,
    /// JSON Schema (draft 2020-12) of its arguments.
    pub input_schema: Json,
    /// Whether it changes the map.
    pub writes: bool,
}

/// Why a tool call failed; each maps to one MCP error and one exit code.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ToolError {
    /// No tool of that name (or a write tool while writes are off).
    #[error("no tool named {name:?}{hint}", name = .0, hint = write_hint(.0))]
    Unknown(String),
    /// The arguments do not match the tool's schema, or name nothing.
    #[error("bad arguments: {0}")]
    BadArguments(String),
    /// The operation failed on the map.
    #[error("{0}")]
    Failed(String),
}

/// The hint for a write tool asked for while writes are off.
fn write_hint(name: &str) -> &'static str {
    if name == "write_cypher" {
        " (write tools are offered only when writes are enabled: --writes, or mcp --allow-writes)"
    } else {
        ""
    }
}

/// Result alias for tool calls.
pub type ToolResult<T> = std::result::Result<T, ToolError>;

/// Rows a `read_cypher` call may return.
pub const MAX_ROWS: usize = 1000;

/// Time a Cypher call may take.
pub const CYPHER_TIMEOUT: Duration = Duration::from_secs(10);

/// What the layers of an OpenGraph map mean (returned by `get_schema`).
const LAYERS: &str = "An OpenGraph map is a hierarchy: one Environment node CONTAINS Segment nodes \
(kind: intersection = crossroads, t_intersection, l_intersection = bend, straight_roadway), which \
CONNECTS to each other; LaneNode nodes (the lane graph along the driven path) are linked by LANE \
relationships (length_m); Instance nodes are mapped objects (caption, class, centroid point3d, bbox, \
feature vector) with IN_SEGMENT to their segment and RELATED to nearby instances (relation, \
distance_m). Node ids (id(n)) are the ids every tool takes and returns.";

/// Every tool, sorted by name; `write_cypher` only when `writes` is true.
pub fn tools(writes: bool) -> Vec<Tool> {
    let text =
        |d: &str| json!({"type": "string", "minLength": 1, "maxLength": 2000, "description": d});
    let mut v = vec![
        Tool {
            name: "describe_area",
            description: "Describe the map top-down. Without segment_id: the environment and every road segment (id, kind, how many objects, the most common classes). With segment_id: that segment's objects by class and its notable objects with their captions.",
            input_schema: json!({"type": "object", "properties": {
                "segment_id": {"type": "integer", "minimum": 0, "description": "a Segment node id"}},
                "additionalProperties": false}),
            writes: false,
        },
        Tool {
            name: "find_objects",
            description: "Find objects in the map from a request in words, e.g. 'the bench near the bus stop', 'somewhere I can post a letter', 'a red car at the T-junction'. Returns instances (node id, caption, class, centroid, segment) best first, each with its evidence (anchors found near it).",
            input_schema: json!({"type": "object", "properties": {
                "text": text("the request"),
                "k": {"type": "integer", "minimum": 1, "maximum": 50, "default": 5},
                "class": {"type": "string", "description": "only this SemanticKITTI class"}},
                "required": ["text"], "additionalProperties": false}),
            writes: false,
        },
        Tool {
            name: "get_instance",
            description: "One instance by node id: caption, class, centroid, box, segment, and its RELATED neighbours.",
            input_schema: json!({"type": "object", "properties": {
                "id": {"type": "integer", "minimum": 0, "description": "an Instance node id"}},
                "required": ["id"], "additionalProperties": false}),
            writes: false,
        },
        Tool {
            name: "get_schema",
            description: "The map's schema: node labels and relationship types with counts, indexes, and what each layer means. Call this before writing Cypher.",
            input_schema: json!({"type": "object", "properties": {}, "additionalProperties": false}),
            writes: false,
        },
        Tool {
            name: "locate",
            description: "Where is someone who describes their surroundings, e.g. 'I'm at a T-junction, there's a bus stop on my left'? Returns road segments best first with a position estimate and the landmarks that support each.",
            input_schema: json!({"type": "object", "properties": {
                "text": text("the description"),
                "k": {"type": "integer", "minimum": 1, "maximum": 20, "default": 3}},
                "required": ["text"], "additionalProperties": false}),
            writes: false,
        },
        Tool {
            name: "plan_route",
            description: "Plan a route between two ends, each in words ('the bus stop by the crossroads', 'the T-junction') or as a spec (lane:ID, segment:ID, instance:ID, node:ID, or 'x,z' ground coordinates). Returns both ends with how they were resolved, the lane-graph route and its length.",
            input_schema: json!({"type": "object", "properties": {
                "from": text("where to start"),
                "to": text("where to go")},
                "required": ["from", "to"], "additionalProperties": false}),
            writes: false,
        },
        Tool {
            name: "read_cypher",
            description: "Run a read-only Cypher query (openCypher; writes are refused by the parser) with a 10 s time limit and at most 1000 rows. Spatial and vector procedures: db.index.spatial.withinDistance('instance_space', point, metres), db.index.vector.queryNodes.",
            input_schema: json!({"type": "object", "properties": {
                "query": text("the Cypher statement"),
                "params": {"type": "object", "description": "values for $name parameters"}},
                "required": ["query"], "additionalProperties": false}),
            writes: false,
        },
    ];
    if writes {
        v.push(Tool {
            name: "write_cypher",
            description: "Run a Cypher statement that may write (CREATE, SET, DELETE, MERGE), as one transaction: a failure changes nothing. 10 s time limit.",
            input_schema: json!({"type": "object", "properties": {
                "query": text("the Cypher statement"),
                "params": {"type": "object", "description": "values for $name parameters"}},
                "required": ["query"], "additionalProperties": false}),
            writes: true,
        });
    }
    v.sort_by_key(|t| t.name);
    v
}

/// The map and what calls share: the store, the finder, whether writes are on.
pub struct Toolbox {
    store: Store,
    finder: Finder,
    writes: bool,
}

impl std::fmt::Debug for Toolbox {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Toolbox")
            .field("store", &self.store.path())
            .field("writes", &self.writes)
            .finish()
    }
}

fn failed(e: impl std::fmt::Display) -> ToolError {
    ToolError::Failed(e.to_string())
}

/// Validates tool arguments against a schema with `jsonschema`; the message names each
/// offending place (`/k: 0 is less than the minimum of 1`).
fn check_args(args: &Json, schema: &Json) -> ToolResult<()> {
    let v = jsonschema::validator_for(schema)
        .map_err(|e| ToolError::Failed(format!("the tool's schema is invalid: {e}")))?;
    let errors: Vec<String> = v
        .iter_errors(args)
        .map(|e| {
            let at = e.instance_path().to_string();
            format!("{}: {e}", if at.is_empty() { "arguments" } else { &at })
        })
        .collect();
    if errors.is_empty() {
        Ok(())
    } else {
        Err(ToolError::BadArguments(errors.join("; ")))
    }
}

impl Toolbox {
    /// A toolbox over an open store. `writes` enables `write_cypher` (the store must then be
    /// open for writing).
    pub fn new(store: Store, finder: Finder, writes: bool) -> Toolbox {
        Toolbox {
            store,
            finder,
            writes,
        }
    }

    /// The tools this toolbox offers.
    pub fn tools(&self) -> Vec<Tool> {
        tools(self.writes)
    }

    /// Calls a tool with JSON arguments (validated against its schema); the answer is JSON.
    ///
    /// # Errors
    /// [`ToolError::Unknown`] for a name not offered, [`ToolError::BadArguments`] for
    /// arguments that break the schema, [`ToolError::Failed`] when the operation fails.
    pub fn call(&mut self, name: &str, args: &Json) -> ToolResult<Json> {
        let tool = self
            .tools()
            .into_iter()
            .find(|t| t.name == name)
            .ok_or_else(|| ToolError::Unknown(name.to_string()))?;
        let args = if args.is_null() {
            json!({})
        } else {
            args.clone()
        };
        check_args(&args, &tool.input_schema)?;
        let s = |k: &str| args[k].as_str().unwrap_or_default().to_string();
        let n = |k: &str, d: u64| args[k].as_u64().unwrap_or(d) as usize;
        match name {
            "get_schema" => self.get_schema(),
            "read_cypher" | "write_cypher" => {
                self.cypher(&s("query"), args.get("params"), name == "read_cypher")
            }
            "find_objects" => {
                let r = self.store.read().map_err(failed)?;
                let a = self
                    .finder
                    .find(
                        &r,
                        &FindRequest {
                            text: s("text"),
                            k: n("k", 5),
                            class: args["class"].as_str().map(str::to_string),
                            near: None,
                            ranking: Ranking::Graph {
                                parser: ParserKind::Rules,
                                rerank: false,
                            },
                            rerank_n: 10,
                        },
                    )
                    .map_err(failed)?;
                Ok(json!({"request": a.request, "results": a.results}))
            }
            "locate" => {
                let r = self.store.read().map_err(failed)?;
                let a = self
                    .finder
                    .locate(
                        &r,
                        &LocateRequest {
                            text: s("text"),
                            k: n("k", 3),
                            parser: ParserKind::Rules,
                        },
                    )
                    .map_err(failed)?;
                serde_json::to_value(a).map_err(failed)
            }
            "plan_route" => {
                let r = self.store.read().map_err(failed)?;
                // what cannot be resolved or routed comes from the arguments
                let bad = |e: &dyn std::fmt::Display| ToolError::BadArguments(e.to_string());
                let (a, start) =
                    crate::plan::resolve_end(&mut self.finder, &r, &s("from"), ParserKind::Rules)
                        .map_err(|e| bad(&e))?;
                let (b, goal) =
                    crate::plan::resolve_end(&mut self.finder, &r, &s("to"), ParserKind::Rules)
                        .map_err(|e| bad(&e))?;
                let opts = PlanOptions {
                    turning_radius_m: 5.0,
                    budget_ms: 200.0,
                    corridor_m: 6.0,
                    snap_m: 15.0,
                    png: None,
                };
                let mut plan = crate::plan::plan(&r, &a, &b, &opts).map_err(|e| bad(&e))?;
                // the poses are for a robot; an agent needs the route
                plan.path.poses.clear();
                serde_json::to_value(NavigateAnswer { start, goal, plan }).map_err(failed)
            }
            "describe_area" => self.describe_area(args["segment_id"].as_u64()),
            "get_instance" => self.get_instance(args["id"].as_u64().unwrap_or_default()),
            other => Err(ToolError::Unknown(other.to_string())),
        }
    }

    fn get_schema(&self) -> ToolResult<Json> {
        let c = self.store.counts().map_err(failed)?;
        let s = self.store.schema();
        let mut indexes: Vec<String> = s
            .effective_property_indexes()
            .iter()
            .map(|p| format!("property {}.{}", p.label, p.key))
            .collect();
        indexes.extend(
            s.spatial_indexes
                .iter()
                .map(|x| format!("spatial {} ({}.{})", x.name, x.label, x.position_key)),
        );
        indexes.extend(
            s.vector_indexes
                .iter()
                .map(|x| format!("vector {} ({}.{})", x.name, x.label, x.key)),
        );
        indexes.extend(
            s.text_indexes
                .iter()
                .map(|x| format!("text {} ({}.{})", x.name, x.label, x.key)),
        );
        Ok(json!({
            "layers": LAYERS,
            "nodes": c.nodes,
            "relationships": c.relationships,
            "indexes": indexes,
        }))
    }

    fn cypher(&self, query: &str, params: Option<&Json>, read_only: bool) -> ToolResult<Json> {
        let mut p = BTreeMap::new();
        if let Some(Json::Object(m)) = params {
            for (k, v) in m {
                let v = graphstore::cypher::try_from_json(v)
                    .map_err(|e| ToolError::BadArguments(format!("params.{k}: {e}")))?;
                p.insert(k.clone(), v);
            }
        }
        let opts = graphstore::cypher::QueryOptions {
            params: p.into_iter().collect(),
            timeout: Some(CYPHER_TIMEOUT),
            row_limit: Some(MAX_ROWS),
            read_only,
            ..graphstore::cypher::QueryOptions::default()
        };
        let r = self.store.query(query, &opts).map_err(|e| match e {
            graphstore::Error::Query(_) => ToolError::BadArguments(e.to_string()),
            other => failed(other),
        })?;
        Ok(json!({
            "columns": r.columns,
            "rows": r.rows_json(),
            "row_count": r.rows.len(),
            "stats": {
                "nodes_created": r.stats.nodes_created,
                "nodes_deleted": r.stats.nodes_deleted,
                "relationships_created": r.stats.relationships_created,
                "relationships_deleted": r.stats.relationships_deleted,
                "properties_set": r.stats.properties_set,
            },
        }))
    }

    fn describe_area(&self, segment: Option<u64>) -> ToolResult<Json> {
        let r = self.store.read().map_err(failed)?;
        let in_seg = r.rel_type("IN_SEGMENT");
        let kind_of = |id: u64| -> ToolResult<Option<String>> {
            Ok(r.node_prop(id, "kind")
                .map_err(failed)?
                .and_then(|v| v.as_str().map(str::to_string)))
        };
        let str_prop = |id: u64, k: &str| -> ToolResult<String> {
            Ok(r.node_prop(id, k)
                .map_err(failed)?
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default())
        };
        let surfaces = llm_tools::graph_find::SURFACE_CLASSES;
        let members = |seg: u64| -> ToolResult<Vec<u64>> {
            let Some(t) = in_seg else {
                return Ok(Vec::new());
            };
            let mut v: Vec<u64> = r
                .neighbours(seg, Direction::Incoming, Some(t))
                .map_err(failed)?
                .into_iter()
                .map(|a| a.other)
                .collect();
            v.sort_unstable();
            v.retain(|id| {
                r.node(*id)
                    .ok()
                    .flatten()
                    .is_some_and(|n| r.label("Instance").is_some_and(|l| n.labels.contains(&l)))
            });
            Ok(v)
        };
        match segment {
            None => {
                let env = r.nodes_with_label("Environment").map_err(failed)?;
                let mut segs = Vec::new();
                for s in r.nodes_with_label("Segment").map_err(failed)? {
                    let mut by_class: BTreeMap<String, usize> = BTreeMap::new();
                    let ids = members(s)?;
                    for id in &ids {
                        let c = str_prop(*id, "class")?;
                        if !surfaces.contains(&c.as_str()) {
                            *by_class.entry(c).or_insert(0) += 1;
                        }
                    }
                    let mut common: Vec<(String, usize)> = by_class.into_iter().collect();
                    common.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
                    common.truncate(4);
                    segs.push(json!({
                        "id": s,
                        "kind": kind_of(s)?,
                        "objects": ids.len(),
                        "common_classes": common.into_iter().map(|(c, n)| json!({"class": c, "count": n})).collect::<Vec<_>>(),
                    }));
                }
                Ok(json!({
                    "environment": env.first().map(|e| json!({"id": e, "name": str_prop(*e, "name").unwrap_or_default()})),
                    "segments": segs,
                }))
            }
            Some(seg) => {
                let Some(kind) = kind_of(seg)? else {
                    return Err(ToolError::BadArguments(format!(
                        "node {seg} is not a Segment"
                    )));
                };
                let ids = members(seg)?;
                let mut by_class: BTreeMap<String, usize> = BTreeMap::new();
                let mut notable = Vec::new();
                for id in &ids {
                    let c = str_prop(*id, "class")?;
                    *by_class.entry(c.clone()).or_insert(0) += 1;
                    if !surfaces.contains(&c.as_str()) && notable.len() < 25 {
                        notable.push(
                            json!({"id": id, "class": c, "caption": str_prop(*id, "caption")?}),
                        );
                    }
                }
                Ok(
                    json!({"id": seg, "kind": kind, "objects_by_class": by_class, "notable": notable}),
                )
            }
        }
    }

    fn get_instance(&self, id: u64) -> ToolResult<Json> {
        let r = self.store.read().map_err(failed)?;
        let node = r
            .node(id)
            .map_err(failed)?
            .ok_or_else(|| ToolError::BadArguments(format!("no node {id}")))?;
        if !r
            .label("Instance")
            .is_some_and(|l| node.labels.contains(&l))
        {
            return Err(ToolError::BadArguments(format!(
                "node {id} is not an Instance"
            )));
        }
        let mut props = serde_json::Map::new();
        for (k, v) in &node.props {
            let name = r.name_of(k.0).unwrap_or_default();
            if matches!(v, Value::Vector(_)) || name == "captions" {
                continue;
            }
            props.insert(name, v.to_json());
        }
        let mut related = Vec::new();
        let mut segment = Json::Null;
        for adj in r.neighbours(id, Direction::Both, None).map_err(failed)? {
            let ty = r.name_of(adj.ty.0).unwrap_or_default();
            match ty.as_str() {
                "RELATED" => {
                    let rel = r.rel(adj.rel).map_err(failed)?;
                    let get = |k: &str| {
                        rel.as_ref()
                            .and_then(|x| {
                                let key = r.prop_key(k)?;
                                x.props
                                    .iter()
                                    .find(|(n, _)| *n == key)
                                    .map(|(_, v)| v.clone())
                            })
                            .map(|v| v.to_json())
                            .unwrap_or(Json::Null)
                    };
                    related.push(json!({
                        "id": adj.other,
                        "outgoing": adj.outgoing,
                        "relation": get("relation"),
                        "distance_m": get("distance_m"),
                        "source": get("source"),
                        "caption": r.node_prop(adj.other, "caption").map_err(failed)?.and_then(|v| v.as_str().map(str::to_string)),
                    }));
                }
                "IN_SEGMENT" if adj.outgoing => {
                    segment = json!({"id": adj.other, "kind": r.node_prop(adj.other, "kind").map_err(failed)?.and_then(|v| v.as_str().map(str::to_string))});
                }
                _ => {}
            }
        }
        Ok(json!({"id": id, "properties": props, "segment": segment, "related": related}))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The whole tool surface (names, descriptions, schemas) is pinned by a snapshot: a change
    /// to it is a change to every agent's interface and shows in review. Refresh with
    /// `UPDATE_SNAPSHOTS=1 cargo test -p api --lib`.
    #[test]
    fn the_tool_surface_is_pinned() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/snapshots/tools.json");
        let now = serde_json::to_string_pretty(&tools(true)).unwrap() + "\n";
        if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, &now).unwrap();
        }
        let pinned = std::fs::read_to_string(&path).unwrap_or_default();
        assert_eq!(
            pinned, now,
            "the tool surface changed; review it and run UPDATE_SNAPSHOTS=1 cargo test -p api --lib"
        );
    }

    #[test]
    fn schemas_are_valid_and_writes_are_gated() {
        for t in tools(true) {
            assert!(
                jsonschema::validator_for(&t.input_schema).is_ok(),
                "{}",
                t.name
            );
            assert_eq!(t.writes, t.name == "write_cypher");
        }
        assert!(tools(false).iter().all(|t| !t.writes));
        let names: Vec<&str> = tools(false).iter().map(|t| t.name).collect();
        let mut sorted = names.clone();
        sorted.sort_unstable();
        assert_eq!(names, sorted);
    }
}
