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
//! | `update_map` | propose (and with `apply`, commit) an edit from a described change |
//! | `undo_map_edit` | revert an applied edit exactly |

use std::collections::BTreeMap;
use std::sync::Arc;
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
    /// JSON Schema (draft 2020-12) of its answer.
    pub output_schema: Json,
    /// Whether it changes the map.
    pub writes: bool,
}

/// Why a call failed. This is the service's one error kind: [`ToolError::exit_code`],
/// [`ToolError::http_status`] and [`ToolError::mcp_error_code`] below are the only place it
/// is mapped to the CLI, HTTP and MCP.
///
/// | kind | exit | HTTP | MCP |
/// |---|---|---|---|
/// | `Unknown` | 2 | 404 | JSON-RPC error -32602 (invalid params: the MCP specification's code for an unknown tool) |
/// | `BadArguments` | 2 | 400 | tool result with `isError` |
/// | `NotFound` | 2 | 404 | tool result with `isError` |
/// | `Forbidden` | 2 | 401 | tool result with `isError` |
/// | `Busy` | 1 | 503 | tool result with `isError` |
/// | `TimedOut` | 1 | 504 | tool result with `isError` |
/// | `Failed` | 1 | 500 | tool result with `isError` |
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum ToolError {
    /// No tool of that name (or a write tool while writes are off).
    #[error("no tool named {name:?}{hint}", name = .0, hint = write_hint(.0))]
    Unknown(String),
    /// The arguments do not match the tool's schema, or name nothing.
    #[error("bad arguments: {0}")]
    BadArguments(String),
    /// The arguments name a node that does not exist.
    #[error("{0}")]
    NotFound(String),
    /// A write without the write token.
    #[error("{0}")]
    Forbidden(String),
    /// Every worker stayed busy for the whole request timeout.
    #[error("{0}")]
    Busy(String),
    /// The operation took longer than the request timeout.
    #[error("{0}")]
    TimedOut(String),
    /// The operation failed on the map.
    #[error("{0}")]
    Failed(String),
}

impl ToolError {
    /// A short machine-readable code (`bad_request`, `not_found`, ...), the `code` of HTTP
    /// error bodies.
    pub fn code(&self) -> &'static str {
        match self {
            ToolError::Unknown(_) => "unknown_tool",
            ToolError::BadArguments(_) => "bad_request",
            ToolError::NotFound(_) => "not_found",
            ToolError::Forbidden(_) => "unauthorized",
            ToolError::Busy(_) => "busy",
            ToolError::TimedOut(_) => "timeout",
            ToolError::Failed(_) => "internal",
        }
    }

    /// The CLI's exit code: 2 for the caller's input, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            ToolError::Unknown(_)
            | ToolError::BadArguments(_)
            | ToolError::NotFound(_)
            | ToolError::Forbidden(_) => 2,
            _ => 1,
        }
    }

    /// The HTTP status.
    pub fn http_status(&self) -> u16 {
        match self {
            ToolError::Unknown(_) | ToolError::NotFound(_) => 404,
            ToolError::BadArguments(_) => 400,
            ToolError::Forbidden(_) => 401,
            ToolError::Busy(_) => 503,
            ToolError::TimedOut(_) => 504,
            ToolError::Failed(_) => 500,
        }
    }

    /// The MCP JSON-RPC error code, or `None` where the error is a tool result with
    /// `isError` (which the model sees and can act on).
    pub fn mcp_error_code(&self) -> Option<i32> {
        match self {
            ToolError::Unknown(_) => Some(-32602),
            _ => None,
        }
    }
}

/// The hint for a write tool asked for while writes are off.
fn write_hint(name: &str) -> &'static str {
    if matches!(name, "write_cypher" | "update_map" | "undo_map_edit") {
        " (write tools are offered only when writes are enabled: --writes, mcp --allow-writes, or serve with a --token-file)"
    } else {
        ""
    }
}

/// Result alias for tool calls.
pub type ToolResult<T> = std::result::Result<T, ToolError>;

/// Rows a `read_cypher` call may return.
pub const MAX_ROWS: usize = 1000;

/// Rows any clause of a tool's Cypher statement may produce (intermediate rows take about
/// 600 bytes each, so about 600 MB at most per statement, against 6 GB at graphstore's own
/// default of 10 million).
pub const MAX_INTERMEDIATE_ROWS: usize = 1_000_000;

/// Bytes one tool's Cypher statement may hold at once (rows, paths, lists, strings, maps;
/// counted by the binary's allocator, see `graphstore::mem`): a statement past it is refused
/// with 400 `MemoryLimit`, and two readers and the writer together stay under 1.5 GiB.
pub const MAX_STATEMENT_BYTES: u64 = 512 << 20;

/// The largest Cypher answer a tool returns, estimated before it is turned into JSON.
pub const MAX_ANSWER_BYTES: u64 = 32 << 20;

/// The longest Cypher statement a tool takes, in characters (the body limit bounds it too).
pub const MAX_CYPHER_CHARS: u64 = 100_000;

/// Time a Cypher call may take.
pub const CYPHER_TIMEOUT: Duration = Duration::from_secs(10);

/// What the layers of an OpenGraph map mean (returned by `get_schema`).
const LAYERS: &str = "An OpenGraph map is a hierarchy: one Environment node CONTAINS Segment nodes \
(kind: intersection = crossroads, t_intersection, l_intersection = bend, straight_roadway), which \
CONNECTS to each other; LaneNode nodes (the lane graph along the driven path) are linked by LANE \
relationships (length_m); Instance nodes are mapped objects (caption, class, centroid point3d, bbox, \
feature vector) with IN_SEGMENT to their segment and RELATED to nearby instances (relation, \
distance_m). MapEdit nodes record applied map edits (text, kind, undone). Node ids (id(n)) are \
the ids every tool takes and returns.";

/// Every tool, sorted by name; `write_cypher` only when `writes` is true.
pub fn tools(writes: bool) -> Vec<Tool> {
    let text =
        |d: &str| json!({"type": "string", "minLength": 1, "maxLength": 2000, "description": d});
    // a Cypher statement may carry a literal vector (384 numbers take about 3 KB)
    let cypher_text = |d: &str| json!({"type": "string", "minLength": 1, "maxLength": MAX_CYPHER_CHARS, "description": d});
    let mut v = vec![
        Tool {
            name: "describe_area",
            description: "Describe the map top-down. Without segment_id: the environment and every road segment (id, kind, how many objects, the most common classes). With segment_id: that segment's objects by class and its notable objects with their captions.",
            input_schema: json!({"type": "object", "properties": {
                "segment_id": {"type": "integer", "minimum": 0, "description": "a Segment node id"}},
                "additionalProperties": false}),
            writes: false,
            output_schema: Json::Null,
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
            output_schema: Json::Null,
        },
        Tool {
            name: "get_instance",
            description: "One instance by node id: caption, class, centroid, box, segment, and its RELATED neighbours.",
            input_schema: json!({"type": "object", "properties": {
                "id": {"type": "integer", "minimum": 0, "description": "an Instance node id"}},
                "required": ["id"], "additionalProperties": false}),
            writes: false,
            output_schema: Json::Null,
        },
        Tool {
            name: "get_schema",
            description: "The map's schema: node labels and relationship types with counts, indexes, and what each layer means. Call this before writing Cypher.",
            input_schema: json!({"type": "object", "properties": {}, "additionalProperties": false}),
            writes: false,
            output_schema: Json::Null,
        },
        Tool {
            name: "locate",
            description: "Where is someone who describes their surroundings, e.g. 'I'm at a T-junction, there's a bus stop on my left'? Returns road segments best first with a position estimate and the landmarks that support each.",
            input_schema: json!({"type": "object", "properties": {
                "text": text("the description"),
                "k": {"type": "integer", "minimum": 1, "maximum": 20, "default": 3}},
                "required": ["text"], "additionalProperties": false}),
            writes: false,
            output_schema: Json::Null,
        },
        Tool {
            name: "plan_route",
            description: "Plan a route between two ends, each in words ('the bus stop by the crossroads', 'the T-junction') or as a spec (lane:ID, segment:ID, instance:ID, node:ID, or 'x,z' ground coordinates). Returns both ends with how they were resolved, the lane-graph route and its length.",
            input_schema: json!({"type": "object", "properties": {
                "from": text("where to start"),
                "to": text("where to go"),
                "poses": {"type": "boolean", "default": false, "description": "include the planned path's poses [x, z, heading] (for a robot; long)"}},
                "required": ["from", "to"], "additionalProperties": false}),
            writes: false,
            output_schema: Json::Null,
        },
        Tool {
            name: "read_cypher",
            description: "Run a read-only Cypher query (openCypher; writes are refused by the parser) with a 10 s time limit and at most 1000 rows. Spatial and vector procedures: db.index.spatial.withinDistance('instance_space', point, metres), db.index.vector.queryNodes.",
            input_schema: json!({"type": "object", "properties": {
                "query": cypher_text("the Cypher statement"),
                "params": {"type": "object", "description": "values for $name parameters"}},
                "required": ["query"], "additionalProperties": false}),
            writes: false,
            output_schema: Json::Null,
        },
    ];
    if writes {
        v.push(Tool {
            name: "update_map",
            description: "Update the map from a described change: 'the bush under the street sign at the crossing is gone', 'the bench by the bus stop was moved next to the post box', 'the bench by the bus stop is now red', 'there is a new bin next to the post box'. Without apply it only proposes the edit (the object it found, with candidates); with apply=true it commits it and returns the edit id. An ambiguous description lists the candidates and changes nothing.",
            input_schema: json!({"type": "object", "properties": {
                "text": text("the described change"),
                "apply": {"type": "boolean", "default": false, "description": "commit the edit"}},
                "required": ["text"], "additionalProperties": false}),
            writes: true,
            output_schema: Json::Null,
        });
        v.push(Tool {
            name: "undo_map_edit",
            description: "Undo an applied map edit exactly (its id is update_map's applied.edit_id; edits are listed by MATCH (e:MapEdit) RETURN id(e), e.text, e.undone). A later edit touching the same objects must be undone first.",
            input_schema: json!({"type": "object", "properties": {
                "edit_id": {"type": "integer", "minimum": 0, "description": "a MapEdit node id"}},
                "required": ["edit_id"], "additionalProperties": false}),
            writes: true,
            output_schema: Json::Null,
        });
        v.push(Tool {
            name: "write_cypher",
            description: "Run a Cypher statement that may write (CREATE, SET, DELETE, MERGE), as one transaction: a failure changes nothing. 10 s time limit.",
            input_schema: json!({"type": "object", "properties": {
                "query": cypher_text("the Cypher statement"),
                "params": {"type": "object", "description": "values for $name parameters"}},
                "required": ["query"], "additionalProperties": false}),
            writes: true,
            output_schema: Json::Null,
        });
    }
    for t in &mut v {
        t.output_schema = output_schema(t.name);
    }
    v.sort_by_key(|t| t.name);
    v
}

/// The JSON Schema of a tool's answer (what every adapter returns for a successful call).
fn output_schema(name: &str) -> Json {
    let obj = |props: Json, required: &[&str]| json!({"type": "object", "properties": props, "required": required});
    let id = json!({"type": "integer", "minimum": 0});
    let num = json!({"type": "number"});
    let s = json!({"type": "string"});
    let s_or_null = json!({"type": ["string", "null"]});
    let arr = |items: Json| json!({"type": "array", "items": items});
    let xyz = json!({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3});
    let xy = json!({"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2});
    let found = obj(
        json!({"id": id, "caption": s, "class": s, "score": num, "similarity": num, "cosine": num,
               "centroid": xyz, "segment": {"type": ["array", "null"]},
               "evidence": arr(json!({"type": "object"}))}),
        &[
            "id", "caption", "class", "score", "cosine", "centroid", "evidence",
        ],
    );
    let located = obj(
        json!({"segment": id, "kind": s, "score": num, "position": xy,
               "evidence": arr(json!({"type": "object"}))}),
        &["segment", "kind", "score", "position", "evidence"],
    );
    let cypher = obj(
        json!({"columns": arr(s.clone()), "rows": arr(json!({"type": "object"})),
               "row_count": {"type": "integer", "minimum": 0}, "stats": {"type": "object"},
               "plan": arr(obj(json!({"operator": s, "depth": {"type": "integer", "minimum": 0}}),
                               &["operator", "depth"]))}),
        &["columns", "rows", "row_count", "stats"],
    );
    match name {
        "describe_area" => json!({"type": "object", "anyOf": [
            obj(json!({"environment": {"type": ["object", "null"]},
                       "segments": arr(obj(json!({"id": id, "kind": s_or_null, "objects": {"type": "integer"},
                                                  "common_classes": {"type": "array"}}),
                                           &["id", "kind", "objects", "common_classes"]))}),
                &["environment", "segments"]),
            obj(json!({"id": id, "kind": s, "objects_by_class": {"type": "object"},
                       "notable": arr(obj(json!({"id": id, "class": s, "caption": s}), &["id", "class", "caption"]))}),
                &["id", "kind", "objects_by_class", "notable"]),
        ]}),
        "find_objects" => obj(
            json!({"request": {"type": "object"}, "results": arr(found)}),
            &["request", "results"],
        ),
        "get_instance" => obj(
            json!({"id": id, "properties": {"type": "object"},
                   "segment": {"type": ["object", "null"]}, "related": arr(json!({"type": "object"}))}),
            &["id", "properties", "segment", "related"],
        ),
        "get_schema" => obj(
            json!({"layers": s, "nodes": {"type": "object"}, "relationships": {"type": "object"},
                   "indexes": arr(s.clone())}),
            &["layers", "nodes", "relationships", "indexes"],
        ),
        "locate" => obj(
            json!({"description": {"type": "object"}, "parsed_by": s_or_null,
                   "results": arr(located),
                   "unmatched": arr(obj(json!({"landmark": s, "best_cosine": num}), &["landmark", "best_cosine"])),
                   "timings_ms": {"type": "array"}}),
            &["description", "results"],
        ),
        "plan_route" => {
            let end = json!({"type": "object", "required": ["by"]});
            let target = obj(
                json!({"spec": s, "node": {"type": ["integer", "null"]}, "kind": s, "xy": xy}),
                &["spec", "kind", "xy"],
            );
            obj(
                json!({"start": end, "goal": end, "plan": obj(
                    json!({"from": target, "to": target,
                           "route": obj(json!({"nodes": arr(s.clone()), "polyline": arr(xy.clone()), "length_m": num}),
                                        &["nodes", "polyline", "length_m"]),
                           "path": {"type": "object"}}),
                    &["from", "to", "route", "path"])}),
                &["start", "goal", "plan"],
            )
        }
        "update_map" => obj(
            json!({"request": {"type": "object"}, "parsed_by": s, "proposal": s, "ambiguous": {"type": "boolean"}, "no_match": {"type": "boolean"},
                   "target": {"type": ["object", "null"]}, "anchor": {"type": ["object", "null"]},
                   "position": {"type": ["array", "null"]}, "caption": s_or_null,
                   "applied": {"anyOf": [{"type": "null"}, obj(json!({"edit_id": id, "kind": s}), &["edit_id", "kind"])]}}),
            &[
                "request",
                "parsed_by",
                "proposal",
                "ambiguous",
                "no_match",
                "applied",
            ],
        ),
        "undo_map_edit" => obj(
            json!({"edit_id": id, "text": s, "kind": s, "undone": {"const": true}, "summary": {"type": "object"}}),
            &["edit_id", "text", "kind", "undone"],
        ),
        _ => cypher,
    }
}

/// The map and what calls share: the store, the finder, whether writes are on. Toolboxes
/// made with [`Toolbox::fork`] share one store; each finder keeps its scene by the store's
/// commit sequence, so after a write through any of them each loads the new scene on its
/// next call.
pub struct Toolbox {
    store: Store,
    finder: Finder,
    writes: bool,
    /// Answers of read-only Cypher statements, shared with the forks given it.
    query_cache: Option<Arc<crate::query_cache::QueryCache>>,
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

/// The `Instance` node with this node id: [`ToolError::NotFound`] when no node has it,
/// [`ToolError::BadArguments`] when it is another kind of node.
pub(crate) fn instance_node(r: &impl GraphRead, id: u64) -> ToolResult<graphstore::Node> {
    let node = r
        .node(id)
        .map_err(failed)?
        .ok_or_else(|| ToolError::NotFound(format!("no node {id}")))?;
    if !r
        .label("Instance")
        .is_some_and(|l| node.labels.contains(&l))
    {
        return Err(ToolError::BadArguments(format!(
            "node {id} is not an Instance"
        )));
    }
    Ok(node)
}

/// An error of the language layer: the caller's input (empty text, an unknown class, a map
/// built with another embedder) or a failure of ours (a model, the store).
impl From<llm_tools::Error> for ToolError {
    fn from(e: llm_tools::Error) -> ToolError {
        match e {
            llm_tools::Error::Invalid(m) => ToolError::BadArguments(m),
            other => ToolError::Failed(other.to_string()),
        }
    }
}

/// An error of a map edit: the caller's input (not an instance, an edit already undone or
/// depended on) or a failure of ours.
impl From<ingest::Error> for ToolError {
    fn from(e: ingest::Error) -> ToolError {
        match e {
            ingest::Error::Invalid(m) => ToolError::BadArguments(m),
            other => ToolError::Failed(other.to_string()),
        }
    }
}

/// Whether `name` is a tool that changes the map (looked up in the registry, built once).
pub fn is_write_tool(name: &str) -> bool {
    registry().iter().any(|(t, _)| t.name == name && t.writes)
}

/// Every tool (write tools included) with its argument validator, built once per process:
/// a call looks its tool up here instead of rebuilding the schemas and validators.
fn registry() -> &'static [(Tool, jsonschema::Validator)] {
    static REGISTRY: std::sync::OnceLock<Vec<(Tool, jsonschema::Validator)>> =
        std::sync::OnceLock::new();
    REGISTRY.get_or_init(|| {
        tools(true)
            .into_iter()
            .map(|t| {
                let v = jsonschema::validator_for(&t.input_schema)
                    .expect("the registry's schemas are valid (tested)");
                (t, v)
            })
            .collect()
    })
}

/// Validates tool arguments against a schema with `jsonschema`; the message names each
/// offending place (`/k: 0 is less than the minimum of 1`).
/// An integer argument read strictly: absent or null is `None`; anything that is not an
/// integer from 0 to 2^64 - 1 (a float such as `5.5` or `1e308`, a negative or larger number,
/// a string) is [`ToolError::BadArguments`] naming the argument. JSON Schema counts `1e308`
/// and `5.0` as integers, so the schema alone does not keep them out.
pub fn int_arg(args: &Json, key: &str, what: &str) -> ToolResult<Option<u64>> {
    match args.get(key) {
        None | Some(Json::Null) => Ok(None),
        Some(v) => match v.as_u64() {
            Some(n) => Ok(Some(n)),
            None => {
                let mut shown = v.to_string();
                if shown.len() > 40 {
                    shown.truncate(40);
                    shown.push('…');
                }
                Err(ToolError::BadArguments(format!(
                    "{key}: {shown} is not {what} (an integer from 0 to {})",
                    u64::MAX
                )))
            }
        },
    }
}

fn check_args(args: &Json, v: &jsonschema::Validator) -> ToolResult<()> {
    let errors: Vec<String> = v
        .iter_errors(args)
        .map(|e| {
            let at = e.instance_path().to_string();
            // the message quotes the value and then says what is wrong: a huge value must not
            // come back whole, and the reason after it must not be cut off
            let full = e.to_string();
            let msg = if full.len() > 300 {
                let mut head = 100;
                while !full.is_char_boundary(head) {
                    head -= 1;
                }
                let mut tail = full.len() - 150;
                while !full.is_char_boundary(tail) {
                    tail += 1;
                }
                format!("{}…{}", &full[..head], &full[tail..])
            } else {
                full
            };
            format!("{}: {msg}", if at.is_empty() { "arguments" } else { &at })
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
            query_cache: None,
        }
    }

    /// Another toolbox over the same store with its own finder (for a pool of workers).
    pub fn fork(&self, finder: Finder) -> Toolbox {
        Toolbox {
            store: self.store.clone(),
            finder,
            writes: self.writes,
            query_cache: self.query_cache.clone(),
        }
    }

    /// Shares loaded scenes with every other toolbox given `shared` (a server's workers):
    /// after a write one worker loads the map's scene and the others take it.
    pub fn share_scene(&mut self, shared: Arc<crate::find::SharedScene>) {
        self.finder.share_scene(shared);
    }

    /// Keeps answers of read-only Cypher statements in `cache`, shared with every other
    /// toolbox given it (a server's workers), until the next commit
    /// ([`crate::query_cache`]).
    pub fn share_query_cache(&mut self, cache: Arc<crate::query_cache::QueryCache>) {
        self.query_cache = Some(cache);
    }

    /// Shares `cache` for query embeddings with every other toolbox given it (a server's
    /// workers): a request text is embedded once, then read back.
    pub fn share_embedding_cache(&mut self, cache: std::sync::Arc<llm_tools::EmbeddingCache>) {
        self.finder.share_embedding_cache(cache);
    }

    /// The store.
    pub fn store(&self) -> &Store {
        &self.store
    }

    /// The finder and the store, for operations outside the registry.
    pub fn parts(&mut self) -> (&mut Finder, &Store) {
        (&mut self.finder, &self.store)
    }

    /// Whether the write tools are offered.
    pub fn writes(&self) -> bool {
        self.writes
    }

    /// Offers or withholds the write tools (withholding is always safe; offering them needs a
    /// store open for writing).
    pub fn set_writes(&mut self, writes: bool) {
        self.writes = writes && !self.store.is_read_only();
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
        let (tool, validator) = registry()
            .iter()
            .find(|(t, _)| t.name == name && (self.writes || !t.writes))
            .ok_or_else(|| ToolError::Unknown(name.to_string()))?;
        let args = if args.is_null() {
            json!({})
        } else {
            args.clone()
        };
        check_args(&args, validator)?;
        let name = tool.name;
        let s = |k: &str| args[k].as_str().unwrap_or_default().to_string();
        let n = |k: &str, d: u64| -> ToolResult<usize> {
            Ok(int_arg(&args, k, "a count")?.unwrap_or(d) as usize)
        };
        let id = |k: &str| -> ToolResult<u64> {
            int_arg(&args, k, "a node id")?
                .ok_or_else(|| ToolError::BadArguments(format!("{k} is required")))
        };
        match name {
            "get_schema" => self.get_schema(),
            "read_cypher" => self.cypher(&s("query"), args.get("params"), true),
            "write_cypher" => self.cypher(&s("query"), args.get("params"), false),
            "find_objects" => {
                let r = self.store.read().map_err(failed)?;
                let a = self.finder.find(
                    &r,
                    &FindRequest {
                        text: s("text"),
                        k: n("k", 5)?,
                        class: args["class"].as_str().map(str::to_string),
                        near: None,
                        ranking: Ranking::Graph {
                            parser: ParserKind::Rules,
                            rerank: false,
                        },
                        rerank_n: 10,
                    },
                )?;
                Ok(json!({"request": a.request, "results": a.results}))
            }
            "locate" => {
                let r = self.store.read().map_err(failed)?;
                let a = self.finder.locate(
                    &r,
                    &LocateRequest {
                        text: s("text"),
                        k: n("k", 3)?,
                        parser: ParserKind::Rules,
                    },
                )?;
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
                if args["poses"] != json!(true) {
                    plan.path.poses.clear();
                }
                serde_json::to_value(NavigateAnswer { start, goal, plan }).map_err(failed)
            }
            "update_map" => {
                let a = crate::update::update(
                    &mut self.finder,
                    &self.store,
                    &crate::update::UpdateRequest {
                        text: s("text"),
                        apply: args["apply"].as_bool().unwrap_or(false),
                        parser: ParserKind::Rules,
                    },
                )?;
                serde_json::to_value(a).map_err(failed)
            }
            "undo_map_edit" => {
                let a = crate::update::undo(&self.store, id("edit_id")?)?;
                serde_json::to_value(a).map_err(failed)
            }
            "describe_area" => self.describe_area(int_arg(&args, "segment_id", "a node id")?),
            "get_instance" => self.get_instance(id("id")?),
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
        indexes.extend(s.spatial_indexes.iter().map(|x| match &x.box_key {
            Some(b) => format!(
                "spatial {} ({}.{b}, else {})",
                x.name, x.label, x.position_key
            ),
            None => format!("spatial {} ({}.{})", x.name, x.label, x.position_key),
        }));
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
        // a read-only answer kept since the last commit is the answer now; the sequence is
        // read before the statement's snapshot is taken, so nothing newer is ever labelled
        // older, and a statement already being computed at this commit is waited for (see
        // crate::query_cache)
        match &self.query_cache {
            Some(c)
                if read_only && graphstore::cypher::is_deterministic(query).unwrap_or(false) =>
            {
                let key = (
                    query.to_string(),
                    params.map(Json::to_string).unwrap_or_default(),
                );
                let seq = self.store.commit_seq();
                // an error (a timeout too) is shared with those who waited for it, not kept
                // the leader's statement ends by its own time limit, a little past it; a waiter
                // that gave up just before would run the whole statement again
                let wait = CYPHER_TIMEOUT + Duration::from_secs(5);
                let answer = c.get_or_compute(key, seq, wait, || {
                    let out = self.cypher_uncached(query, params, read_only);
                    let keep = out.as_ref().is_ok_and(|out| {
                        out.get("plan").is_none()
                            && out["row_count"]
                                .as_u64()
                                .is_some_and(|n| n as usize <= crate::query_cache::MAX_CACHED_ROWS)
                    });
                    Ok::<_, std::convert::Infallible>((out, keep))
                });
                match answer {
                    Ok(answer) => Arc::unwrap_or_clone(answer),
                    Err(never) => match never {},
                }
            }
            _ => self.cypher_uncached(query, params, read_only),
        }
    }

    fn cypher_uncached(
        &self,
        query: &str,
        params: Option<&Json>,
        read_only: bool,
    ) -> ToolResult<Json> {
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
            max_intermediate_rows: MAX_INTERMEDIATE_ROWS,
            max_memory_bytes: MAX_STATEMENT_BYTES,
            ..graphstore::cypher::QueryOptions::default()
        };
        let r = self.store.query(query, &opts).map_err(|e| match e {
            graphstore::Error::Query(q) if q.kind == graphstore::cypher::ErrorKind::Timeout => {
                ToolError::TimedOut(format!(
                    "the Cypher statement ran past its {} s limit{}; narrow the pattern or add LIMIT",
                    CYPHER_TIMEOUT.as_secs(),
                    q.pos
                        .map(|p| format!(" (at line {}, column {})", p.line, p.col))
                        .unwrap_or_default()
                ))
            }
            graphstore::Error::Query(_) => ToolError::BadArguments(e.to_string()),
            other => failed(other),
        })?;
        let answer_bytes: u64 = r
            .rows
            .iter()
            .flatten()
            .map(graphstore::cypher::Val::approx_bytes)
            .sum::<u64>()
            + 4096 * (r.nodes.len() + r.rels.len()) as u64;
        if answer_bytes > MAX_ANSWER_BYTES {
            return Err(ToolError::BadArguments(format!(
                "the answer would be about {} MiB, over the {} MiB a tool answer may be; return fewer or smaller values (LIMIT, size(), properties instead of whole nodes)",
                answer_bytes >> 20,
                MAX_ANSWER_BYTES >> 20
            )));
        }
        let mut out = json!({
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
        });
        if let Some(plan) = r.plan_json() {
            out["plan"] = plan;
        }
        Ok(out)
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
        let node = instance_node(&r, id)?;
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
    use crate::test_support::{demo_store, hash_finder};

    /// The whole tool surface (names, descriptions, schemas) is pinned by a snapshot: a change
    /// to it is a change to every agent's interface and shows in review. Refresh with
    /// `UPDATE_SNAPSHOTS=1 cargo test -p opengraph-service --lib`.
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
            "the tool surface changed; review it and run UPDATE_SNAPSHOTS=1 cargo test -p opengraph-service --lib"
        );
    }

    /// A tool's statement may not build more than MAX_INTERMEDIATE_ROWS rows in any clause
    /// (a memory bound for an unauthenticated caller); just under it runs.
    #[test]
    fn a_runaway_statement_stops_at_the_intermediate_row_limit() {
        let (_dir, store) = demo_store();
        let mut tb = Toolbox::new(store, hash_finder(), false);
        let q = |n: usize| json!({"query": format!("UNWIND range(1, {n}) AS a UNWIND range(1, 1000) AS b RETURN count(*) AS n")});
        let e = tb.call("read_cypher", &q(1001)).unwrap_err();
        assert_eq!(e.http_status(), 400);
        assert!(e.to_string().contains("1000000 rows"), "{e}");
        let ok = tb.call("read_cypher", &q(999)).unwrap();
        assert_eq!(ok["rows"][0]["n"], 999_000);
    }

    /// Read-only answers come back from the shared cache until a write through any worker;
    /// rand() and plans are never kept; the scene is loaded once per commit for all workers.
    #[test]
    fn read_answers_are_cached_until_a_write() {
        let (_dir, store) = demo_store();
        let mut a = Toolbox::new(store, hash_finder(), true);
        let mut b = a.fork(hash_finder());
        let cache = crate::query_cache::QueryCache::new(16);
        let scene = crate::find::SharedScene::new(1);
        for t in [&mut a, &mut b] {
            t.share_query_cache(cache.clone());
            t.share_scene(scene.clone());
        }
        let count = json!({"query": "MATCH (n:Note) RETURN count(n) AS n"});
        let n0 = a.call("read_cypher", &count).unwrap()["rows"][0]["n"].clone();
        assert_eq!(cache.stats(), (0, 1));
        // the other worker gets the same answer from the cache
        assert_eq!(b.call("read_cypher", &count).unwrap()["rows"][0]["n"], n0);
        assert_eq!(cache.stats(), (1, 1));
        // parameters are part of the key
        let with = json!({"query": "MATCH (n:Note) RETURN count(n) + $k AS n", "params": {"k": 1}});
        a.call("read_cypher", &with).unwrap();
        assert_eq!(cache.stats(), (1, 2));
        // a write through one worker retires the answer for both
        a.call(
            "write_cypher",
            &json!({"query": "CREATE (:Note {text: 'the bench was painted'})"}),
        )
        .unwrap();
        let n1 = b.call("read_cypher", &count).unwrap()["rows"][0]["n"].clone();
        assert_eq!(n1.as_i64().unwrap(), n0.as_i64().unwrap() + 1);
        assert_eq!(cache.stats(), (1, 3));
        // rand() and EXPLAIN are computed every time
        let (h, m) = cache.stats();
        for q in ["RETURN rand() AS r", "EXPLAIN MATCH (n) RETURN n"] {
            a.call("read_cypher", &json!({"query": q})).unwrap();
            a.call("read_cypher", &json!({"query": q})).unwrap();
        }
        let (h2, m2) = cache.stats();
        assert_eq!(h2, h, "nothing came from the cache");
        assert_eq!(
            m2 - m,
            2,
            "EXPLAIN looks up but is never kept; rand() never looks up"
        );
        // both workers' finds see one scene per commit
        a.call(
            "write_cypher",
            &json!({"query": "MATCH (e:Environment) SET e.ground_frame = 'kitti_cam'"}),
        )
        .unwrap();
        let find = json!({"text": "a bench", "k": 3});
        let fa = a.call("find_objects", &find).unwrap();
        let fb = b.call("find_objects", &find).unwrap();
        assert_eq!(fa["results"], fb["results"]);
    }

    #[test]
    fn schemas_are_valid_and_writes_are_gated() {
        for t in tools(true) {
            assert!(
                jsonschema::validator_for(&t.input_schema).is_ok(),
                "{}",
                t.name
            );
            assert_eq!(
                t.writes,
                matches!(t.name, "write_cypher" | "update_map" | "undo_map_edit")
            );
        }
        assert!(tools(false).iter().all(|t| !t.writes));
        let names: Vec<&str> = tools(false).iter().map(|t| t.name).collect();
        let mut sorted = names.clone();
        sorted.sort_unstable();
        assert_eq!(names, sorted);
    }
}
