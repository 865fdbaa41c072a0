//! The typed operations: one request type per operation, each deriving serde and a JSON
//! Schema (schemars, draft 2020-12). The tool registry's argument schemas, the OpenAPI
//! document's request bodies and the MCP tool list are generated from these types, and a call
//! is validated against the schema (`jsonschema`, for messages that name the place) and then
//! deserialised into its type (strictly: `5.5` or `1e308` is not an integer), so every
//! adapter refuses the same inputs with the same message.
//!
//! The answer types the service assembles itself are here too ([`SchemaAnswer`],
//! [`CypherAnswer`], [`AreaAnswer`], [`InstanceAnswer`], [`FindObjectsAnswer`]); the answers
//! of `locate`, `navigate`, `update` and `undo` keep their types beside their operations
//! (`find.rs`, `plan.rs`, `update.rs`, and `ingest::map_edit`). Every answer type derives its
//! JSON Schema ([`answer_schema_of`]); none is written by hand.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value as Json;

use crate::error::{ToolError, ToolResult};

/// The longest Cypher statement a tool takes, in characters (the body limit bounds it too).
pub const MAX_CYPHER_CHARS: u64 = 100_000;

/// The longest free text an operation takes (a request, a description, a change), characters.
pub const MAX_TEXT_CHARS: u64 = 2000;

fn five() -> u64 {
    5
}
fn three() -> u64 {
    3
}
fn four() -> u64 {
    4
}

/// `get_schema`: no arguments.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SchemaRequest {}

/// `read_cypher` and `write_cypher`: a Cypher statement and its parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CypherRequest {
    /// The Cypher statement.
    #[schemars(description = "the Cypher statement", length(min = 1, max = MAX_CYPHER_CHARS))]
    pub query: String,
    /// Values for $name parameters.
    #[schemars(description = "values for $name parameters")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub params: Option<serde_json::Map<String, Json>>,
    /// Whole nodes and relationships with every property: their vectors (feature) and long
    /// coordinate lists (polygons, polylines) too. Without it those are summarised as a short
    /// string; a property returned on its own (`RETURN n.feature`) is always whole.
    #[schemars(
        description = "true: whole nodes keep their vectors and long coordinate lists; default false summarises them (RETURN n.feature gives one in full)"
    )]
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub full_properties: bool,
}

/// `find_objects`: graph-aware retrieval from words.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FindObjectsRequest {
    /// The request.
    #[schemars(description = "the request", length(min = 1, max = MAX_TEXT_CHARS))]
    pub text: String,
    // how many objects to return (no description: the tool surface the models were tried on)
    #[serde(default = "five")]
    #[schemars(range(min = 1, max = 50))]
    pub k: u64,
    /// Only objects of this SemanticKITTI class (`Instance.semantic_class`; `class` is
    /// read too, as earlier versions named it).
    #[schemars(description = "only objects of this SemanticKITTI class (semantic_class)")]
    #[serde(default, alias = "class", skip_serializing_if = "Option::is_none")]
    pub semantic_class: Option<String>,
}

/// `locate`: road segments for a description of the surroundings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LocateToolRequest {
    /// The description.
    #[schemars(description = "the description", length(min = 1, max = MAX_TEXT_CHARS))]
    pub text: String,
    // how many segments to return
    #[serde(default = "three")]
    #[schemars(range(min = 1, max = 20))]
    pub k: u64,
}

/// `plan_route`: a route between two ends, in words or as specs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlanRouteRequest {
    /// Where to start.
    #[schemars(description = "where to start", length(min = 1, max = MAX_TEXT_CHARS))]
    pub from: String,
    /// Where to go.
    #[schemars(description = "where to go", length(min = 1, max = MAX_TEXT_CHARS))]
    pub to: String,
    /// Include the planned path's poses [x, z, heading] (for a robot; long).
    #[schemars(
        description = "include the planned path's poses [x, z, heading] (for a robot; long)"
    )]
    #[serde(default)]
    pub poses: bool,
}

/// `describe_area`: the environment's segments, or one segment's objects.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DescribeAreaRequest {
    /// A Segment node id.
    #[schemars(description = "a Segment node id")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segment_id: Option<u64>,
}

/// `get_instance`: one instance by node id.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GetInstanceRequest {
    /// An Instance node id.
    #[schemars(description = "an Instance node id")]
    pub id: u64,
}

/// `update_map`: a described change, proposed or applied.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct UpdateMapRequest {
    /// The described change.
    #[schemars(description = "the described change", length(min = 1, max = MAX_TEXT_CHARS))]
    pub text: String,
    /// Commit the edit.
    #[schemars(description = "commit the edit")]
    #[serde(default)]
    pub apply: bool,
}

/// `undo_map_edit`: revert an applied edit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct UndoMapEditRequest {
    /// A MapEdit node id.
    #[schemars(description = "a MapEdit node id")]
    pub edit_id: u64,
}

/// The longest kind of object a task tool takes ("post box"), characters.
pub const MAX_KIND_CHARS: u64 = 200;

fn ten() -> u64 {
    10
}
fn twenty() -> u64 {
    20
}
fn yes() -> bool {
    true
}
fn ten_m() -> f64 {
    10.0
}

/// How a task tool measures distances on the ground plane.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Measure {
    /// Between centroids (height ignored).
    #[default]
    Centroid,
    /// Between footprints (0 when they overlap); to a segment's area for a segment.
    BoxGap,
}

/// `nearest_objects`: the objects of a kind nearest a place.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NearestObjectsRequest {
    /// The kind of object, in words or as a label.
    #[schemars(
        description = "the kind of object, in words or as a label: 'post box', 'trees', 'a bench'",
        length(min = 1, max = MAX_KIND_CHARS)
    )]
    pub kind: String,
    /// The place, in words or as a spec.
    #[schemars(
        description = "the place: words ('the start of the drive', 'the T-junction', 'the bus shelter by the crossroads') or a spec (instance:ID, segment:ID, lane:ID, node:ID with node ids, or 'x,z' ground coordinates)",
        length(min = 1, max = MAX_TEXT_CHARS)
    )]
    pub near: String,
    /// How many objects.
    #[schemars(description = "how many objects", range(min = 1, max = 50))]
    #[serde(default = "five")]
    pub k: u64,
    /// How distances are measured.
    #[schemars(
        description = "centroid (default): ground-plane distance between centroids; box_gap: between footprints"
    )]
    #[serde(default)]
    pub measure: Measure,
    /// Count parts of the kind (a tree's trunk and crown are mapped as objects of their own).
    #[schemars(
        description = "include objects that are parts of the kind (a tree's trunk or crown), default true"
    )]
    #[serde(default = "yes")]
    pub parts: bool,
}

/// `count_objects`: the objects of a kind in an area.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CountObjectsRequest {
    /// The kind of object, in words or as a label.
    #[schemars(
        description = "the kind of object, in words or as a label: 'post box', 'trees', 'a bench'",
        length(min = 1, max = MAX_KIND_CHARS)
    )]
    pub kind: String,
    /// A road segment, in words or as segment:ID.
    #[schemars(
        description = "only in this road segment: words ('the T-junction', 'the crossroads with two bus shelters') or segment:ID (node id)",
        length(min = 1, max = MAX_TEXT_CHARS)
    )]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within: Option<String>,
    /// The centre of a circle, in words or as a spec.
    #[schemars(
        description = "only within radius_m of this place (words or a spec as for nearest_objects)",
        length(min = 1, max = MAX_TEXT_CHARS)
    )]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub near: Option<String>,
    /// The circle's radius, metres.
    #[schemars(
        description = "the circle's radius around near, metres (default 20)",
        range(min = 0.0, max = 100000.0)
    )]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_m: Option<f64>,
    /// How many of the objects to list.
    #[schemars(
        description = "how many of the objects to list (the count is of all)",
        range(min = 0, max = 500)
    )]
    #[serde(default = "twenty")]
    pub list: u64,
    /// Count parts of the kind.
    #[schemars(
        description = "include objects that are parts of the kind (a tree's trunk or crown), default true"
    )]
    #[serde(default = "yes")]
    pub parts: bool,
}

/// `measure_distance`: the distance between two places.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DistanceRequest {
    /// One place.
    #[schemars(
        description = "one place: words or a spec (instance:ID, segment:ID, lane:ID, node:ID, 'x,z')",
        length(min = 1, max = MAX_TEXT_CHARS)
    )]
    pub from: String,
    /// The other place.
    #[schemars(description = "the other place", length(min = 1, max = MAX_TEXT_CHARS))]
    pub to: String,
    /// How the distance is measured.
    #[schemars(
        description = "centroid (default): ground-plane distance between centroids; box_gap: between footprints"
    )]
    #[serde(default)]
    pub measure: Measure,
}

/// `neighbours`: what stands around an object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NeighboursRequest {
    /// An Instance node id.
    #[schemars(description = "an Instance node id")]
    pub id: u64,
    /// How far to look, metres (footprint gap).
    #[schemars(
        description = "how far to look: the gap between footprints, metres (default 10)",
        range(min = 0.0, max = 1000.0)
    )]
    #[serde(default = "ten_m")]
    pub radius_m: f64,
    /// How many neighbours.
    #[schemars(
        description = "how many neighbours, nearest first",
        range(min = 1, max = 100)
    )]
    #[serde(default = "ten")]
    pub k: u64,
}

/// `ask`: a question for the agent loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AskRequest {
    // the question
    #[schemars(length(min = 1, max = MAX_TEXT_CHARS))]
    pub question: String,
    // rounds of tool calls at most
    #[serde(default = "four")]
    #[schemars(range(min = 1, max = 20))]
    pub max_steps: u64,
}

/// The answer of `get_schema`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SchemaAnswer {
    /// What the layers of an OpenGraph map mean.
    pub layers: String,
    /// Which axis is up, what ground coordinates are, and the units of positions.
    pub frame: String,
    /// Which id each tool takes and returns.
    pub ids: String,
    /// Every declared node label: its properties with types, units and frames.
    pub labels: BTreeMap<String, LabelSchema>,
    /// Every declared relationship type: its ends and properties.
    pub relationship_types: BTreeMap<String, RelationshipTypeSchema>,
    /// Nodes per label.
    pub nodes: BTreeMap<String, u64>,
    /// Relationships per type.
    pub relationships: BTreeMap<String, u64>,
    /// The indexes, one line each (`property Instance.semantic_class`, `spatial instance_space (...)`).
    pub indexes: Vec<String>,
}

/// One declared property.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PropertySchema {
    /// The property key.
    pub key: String,
    /// Its value type (`int`, `float`, `string`, `point3d`, `box3d`, `vector`, `list`, ...).
    #[serde(rename = "type")]
    pub value_type: String,
    /// Whether every node (or relationship) has it.
    pub required: bool,
    /// What it means, with its unit and frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub meaning: Option<String>,
}

/// One declared node label.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct LabelSchema {
    /// What its nodes are.
    pub description: String,
    /// Its properties.
    pub properties: Vec<PropertySchema>,
    /// Properties unique among its nodes.
    pub unique: Vec<String>,
}

/// One declared relationship type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RelationshipTypeSchema {
    /// What it means.
    pub description: String,
    /// Labels it may start from (empty: any).
    pub from: Vec<String>,
    /// Labels it may end at (empty: any).
    pub to: Vec<String>,
    /// Its properties.
    pub properties: Vec<PropertySchema>,
}

/// What a Cypher statement changed.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CypherStats {
    /// Nodes created.
    pub nodes_created: u64,
    /// Nodes deleted.
    pub nodes_deleted: u64,
    /// Relationships created.
    pub relationships_created: u64,
    /// Relationships deleted.
    pub relationships_deleted: u64,
    /// Properties set.
    pub properties_set: u64,
}

/// One operator of an `EXPLAIN` or `PROFILE` plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PlanStep {
    /// The operator, as the plan prints it.
    pub operator: String,
    /// Its depth in the plan tree.
    pub depth: u64,
}

/// The answer of `read_cypher` and `write_cypher`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CypherAnswer {
    /// The columns, in order.
    pub columns: Vec<String>,
    /// The rows, each an object by column.
    pub rows: Vec<serde_json::Map<String, Json>>,
    /// How many rows.
    pub row_count: u64,
    /// What the statement changed.
    pub stats: CypherStats,
    /// The plan, for `EXPLAIN` and `PROFILE`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plan: Option<Vec<PlanStep>>,
}

/// A node by id with its name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct EnvironmentRef {
    /// The Environment node id.
    pub id: u64,
    /// Its name.
    pub name: String,
}

/// How many objects of one kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct LabelCount {
    /// The kind: the objects' label (`Instance.label`; their SemanticKITTI class on maps
    /// built without labels).
    pub label: String,
    /// How many.
    pub count: u64,
}

/// One segment in the environment's overview.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(transform = require_all)]
pub struct SegmentSummary {
    /// The Segment node id.
    pub id: u64,
    /// Its kind (intersection, t_intersection, l_intersection, straight_roadway).
    pub kind: Option<String>,
    /// Instances in it.
    pub objects: u64,
    /// The four most common kinds of object, by label (ground surfaces left out).
    pub common_labels: Vec<LabelCount>,
}

/// A notable object of a segment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Notable {
    /// The Instance node id.
    pub id: u64,
    /// What it is: its label (`Instance.label`).
    pub label: String,
    /// Its SemanticKITTI class (`Instance.semantic_class`).
    pub semantic_class: String,
    /// Its caption.
    pub caption: String,
}

/// `describe_area` without `segment_id`: the environment and its segments.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(transform = require_all)]
pub struct EnvironmentOverview {
    /// The Environment node.
    pub environment: Option<EnvironmentRef>,
    /// Every segment.
    pub segments: Vec<SegmentSummary>,
}

/// `describe_area` with `segment_id`: one segment's objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SegmentDetail {
    /// The Segment node id.
    pub id: u64,
    /// Its kind.
    pub kind: String,
    /// Its instances per label (ground surfaces by their SemanticKITTI class).
    pub objects_by_label: BTreeMap<String, u64>,
    /// Up to 25 objects that are not ground surfaces, with captions.
    pub notable: Vec<Notable>,
}

/// The answer of `describe_area`: the environment's overview, or one segment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum AreaAnswer {
    /// Without `segment_id`.
    Environment(EnvironmentOverview),
    /// With `segment_id`.
    Segment(SegmentDetail),
}

/// The segment an instance is in.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(transform = require_all)]
pub struct SegmentRef {
    /// The Segment node id.
    pub id: u64,
    /// Its kind.
    pub kind: Option<String>,
}

/// A `RELATED` neighbour of an instance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(transform = require_all)]
pub struct RelatedRef {
    /// The other Instance node id.
    pub id: u64,
    /// Whether the relationship starts at the asked instance.
    pub outgoing: bool,
    /// The relation (`next_to`, `on`, ...).
    pub relation: Json,
    /// The distance between the boxes, metres.
    pub distance_m: Json,
    /// Where the relation comes from (`geometric`, or `llm` for an LLM pass).
    pub source: Json,
    /// The other instance's caption.
    pub caption: Option<String>,
}

/// The answer of `get_instance`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(transform = require_all)]
pub struct InstanceAnswer {
    /// The Instance node id.
    pub id: u64,
    /// Its properties (the feature vectors and the caption list left out).
    pub properties: serde_json::Map<String, Json>,
    /// Its segment: the nearest one (`IN_SEGMENT`).
    pub segment: Option<SegmentRef>,
    /// How far outside that segment's area it lies, metres on the ground plane (0: inside;
    /// more: it lies in no segment, and this one is the nearest); `IN_SEGMENT.distance_m`.
    pub segment_distance_m: Option<f64>,
    /// Its `RELATED` neighbours.
    pub related: Vec<RelatedRef>,
}

/// The answer of `find_objects`: the structured request and the results, best first.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct FindObjectsAnswer {
    /// The request as the rule parser understood it.
    pub request: Option<llm_tools::request::Request>,
    /// The instances found, best first, each with its evidence.
    pub results: Vec<llm_tools::graph_find::GraphFound>,
    /// For a request for the nearest to a place ("the fire hydrant nearest the start of the
    /// drive"): the place and how it was resolved; the results are then nearest first, each
    /// with `place_distance_m`.
    pub nearest_to: Option<crate::plan::Resolved>,
}

/// Marks every property of an answer's object schema as required: serde writes each field,
/// `None` as null, so an `Option` field is always there (schemars would leave it optional).
fn require_all(s: &mut schemars::Schema) {
    let keys: Option<Vec<Json>> = s
        .get("properties")
        .and_then(Json::as_object)
        .map(|p| p.keys().map(|k| Json::String(k.clone())).collect());
    if let Some(keys) = keys {
        s.insert("required".into(), Json::Array(keys));
    }
}

/// The JSON Schema of answer type `T`, as the answer is written: a field serde always writes
/// is required (an `Option` as null), one it may skip is not; every subschema inline, no
/// `$schema`, `title` or top-level `description`. Every adapter's answer to a successful call
/// is valid under it (tested for every tool).
pub fn answer_schema_of<T: JsonSchema>() -> Json {
    inline_schema::<T>(schemars::generate::SchemaSettings::draft2020_12().for_serialize())
}

/// `T`'s root schema under `settings` with every subschema inline, without `$schema`,
/// `title` and top-level `description` (the tool's or route's own description says what it
/// is).
fn inline_schema<T: JsonSchema>(mut settings: schemars::generate::SchemaSettings) -> Json {
    settings.inline_subschemas = true;
    let mut v = settings
        .into_generator()
        .into_root_schema_for::<T>()
        .to_value();
    if let Some(m) = v.as_object_mut() {
        m.remove("$schema");
        m.remove("title");
        m.remove("description");
    }
    v
}

/// The JSON Schema of `T` as a tool or request-body schema: draft 2020-12, every subschema
/// inline (a `$ref` into `$defs` would not resolve once the schema sits inside an OpenAPI
/// document), with no `$schema` `title` and top-level `description` (MCP and OpenAPI documents carry their own).
pub fn schema_of<T: JsonSchema>() -> Json {
    inline_schema::<T>(schemars::generate::SchemaSettings::draft2020_12())
}

/// The JSON Schema of request type `T` ([`schema_of`]) as a tool's argument schema: an
/// optional argument is said by leaving it out, not by null (`["string", "null"]` becomes
/// `"string"`), and integers carry no `format`. A language model writes calls under this
/// schema (grammar-constrained for local models), so it is kept to what the models were tried
/// on.
pub fn request_schema_of<T: JsonSchema>() -> Json {
    let mut v = schema_of::<T>();
    if let Some(o) = v.as_object_mut() {
        o.entry("properties")
            .or_insert_with(|| Json::Object(serde_json::Map::new()));
    }
    if let Some(props) = v.get_mut("properties").and_then(Json::as_object_mut) {
        for p in props.values_mut() {
            let Some(p) = p.as_object_mut() else { continue };
            // annotations a model reads as part of the call's prompt, which say nothing the
            // deserialiser does not enforce (an integer is read as u64; params is any object)
            p.remove("format");
            if p.get("additionalProperties") == Some(&Json::Bool(true)) {
                p.remove("additionalProperties");
            }
            if let Some(Json::Array(ts)) = p.get_mut("type") {
                ts.retain(|x| x != "null");
                if ts.len() == 1 {
                    let t = ts[0].clone();
                    p.insert("type".into(), t);
                }
            }
        }
    }
    v
}

/// Deserialises validated arguments into `T`; a value serde refuses (a float where an integer
/// must be) is [`ToolError::BadArguments`] naming its place.
pub fn parse<T: DeserializeOwned>(args: &Json) -> ToolResult<T> {
    let args = if args.is_null() {
        &Json::Object(serde_json::Map::new())
    } else {
        args
    };
    serde_path_to_error::deserialize(args).map_err(|e| {
        let at = e.path().to_string();
        let mut msg = e.into_inner().to_string();
        if msg.len() > 200 {
            let mut cut = 200;
            while !msg.is_char_boundary(cut) {
                cut -= 1;
            }
            msg.truncate(cut);
            msg.push('…');
        }
        ToolError::BadArguments(format!(
            "{}: {msg}",
            if at == "." { "arguments" } else { &at }
        ))
    })
}

/// Validates `args` against `T`'s schema (the same messages as the tools give) and
/// deserialises them: the one check of an operation that is not a tool (`ask`), whichever
/// adapter it came through.
///
/// # Errors
/// [`ToolError::BadArguments`] naming each offending place.
pub fn validated<T: JsonSchema + DeserializeOwned>(args: &Json) -> ToolResult<T> {
    let empty = Json::Object(serde_json::Map::new());
    let args = if args.is_null() { &empty } else { args };
    let v = jsonschema::validator_for(&request_schema_of::<T>())
        .map_err(|e| ToolError::Failed(e.to_string()))?;
    check_args(args, &v)?;
    parse(args)
}

/// The `ask` request checked as every adapter checks it: a question of 1 to 2000 characters
/// that is not only white space, 1 to 20 rounds.
///
/// # Errors
/// [`ToolError::BadArguments`] naming what is wrong.
pub fn check_ask(args: &Json) -> ToolResult<AskRequest> {
    let req: AskRequest = validated(args)?;
    non_blank("question", &req.question)?;
    Ok(req)
}

/// Validates tool arguments against a schema with `jsonschema`; the message names each
/// offending place (`/k: 0 is less than the minimum of 1`).
pub(crate) fn check_args(args: &Json, v: &jsonschema::Validator) -> ToolResult<()> {
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

/// Checks what a schema cannot say: text that is only white space.
pub fn non_blank(what: &str, s: &str) -> ToolResult<()> {
    if s.trim().is_empty() {
        Err(ToolError::BadArguments(format!(
            "{what}: the text is empty"
        )))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn request_schemas_say_bounds_defaults_and_no_extra_keys() {
        let s = request_schema_of::<FindObjectsRequest>();
        assert_eq!(s["properties"]["semantic_class"]["type"], "string");
        assert_eq!(s["type"], "object");
        assert_eq!(s["additionalProperties"], false);
        assert_eq!(s["required"], serde_json::json!(["text"]));
        assert_eq!(s["properties"]["k"]["minimum"], 1);
        assert_eq!(s["properties"]["k"]["maximum"], 50);
        assert_eq!(s["properties"]["k"]["default"], 5);
        assert_eq!(s["properties"]["text"]["maxLength"], MAX_TEXT_CHARS);
        assert!(s.get("$schema").is_none());
        let area = answer_schema_of::<AreaAnswer>().to_string();
        assert!(
            !area.contains("$ref") && area.contains("common_labels"),
            "{area}"
        );
    }

    #[test]
    fn integers_are_read_strictly_and_named() {
        let e = parse::<GetInstanceRequest>(&serde_json::json!({"id": 5.5})).unwrap_err();
        assert!(
            e.to_string().contains("id: invalid type: floating point"),
            "{e}"
        );
        let e = parse::<GetInstanceRequest>(&serde_json::json!({"id": 1e308})).unwrap_err();
        assert!(e.to_string().starts_with("bad arguments: id:"), "{e}");
        let e = parse::<GetInstanceRequest>(&serde_json::json!({"id": -1})).unwrap_err();
        assert!(e.to_string().contains("id: invalid value"), "{e}");
        assert_eq!(
            parse::<GetInstanceRequest>(&serde_json::json!({"id": 7})).unwrap(),
            GetInstanceRequest { id: 7 }
        );
        let r: FindObjectsRequest = parse(&serde_json::json!({"text": "a bench"})).unwrap();
        assert_eq!((r.k, r.semantic_class), (5, None));
        let r: FindObjectsRequest =
            parse(&serde_json::json!({"text": "a bench", "class": "car"})).unwrap();
        assert_eq!(r.semantic_class.as_deref(), Some("car"));
        assert!(parse::<AskRequest>(&serde_json::json!({"question": "q", "x": 1})).is_err());
        let e = check_ask(&serde_json::json!({"question": "q", "max_steps": 21})).unwrap_err();
        assert!(e.to_string().contains("/max_steps"), "{e}");
        assert!(check_ask(&serde_json::json!({"question": "  "})).is_err());
        assert_eq!(
            check_ask(&serde_json::json!({"question": "where?"}))
                .unwrap()
                .max_steps,
            4
        );
    }
}
