//! The tool registry: the map's operations as typed tools with JSON Schemas, for LLM agents.
//! One registry feeds every agent front end (the MCP server, `opengraph tool`, OpenAI-style
//! function calling in `opengraph ask`, the HTTP API); each tool's argument schema is generated
//! from its request type in [`crate::ops`], each call is validated against it (`jsonschema`)
//! and deserialised into that type, and runs the same service operations as the CLI.
//!
//! | tool | request | what |
//! |---|---|---|
//! | `get_schema` | [`SchemaRequest`] | labels, relationship types, counts, indexes, and what the layers mean |
//! | `read_cypher` | [`CypherRequest`] | a Cypher read, read-only by the parser, 10 s and 1000 rows at most |
//! | `write_cypher` | [`CypherRequest`] | a Cypher write (only when writes are enabled) |
//! | `find_objects` | [`FindObjectsRequest`] | graph-aware retrieval (`find`) with evidence |
//! | `locate` | [`LocateToolRequest`] | road segments for a description of the surroundings |
//! | `plan_route` | [`PlanRouteRequest`] | a route between two ends given in words or as specs (`navigate`) |
//! | `describe_area` | [`DescribeAreaRequest`] | top-down: the environment's segments, or one segment's objects |
//! | `get_instance` | [`GetInstanceRequest`] | one instance: label, caption, semantic class, box, segment (and how far outside it), relations |
//! | `nearest_objects` | [`NearestObjectsRequest`] | the objects of a kind nearest a place, with distances |
//! | `count_objects` | [`CountObjectsRequest`] | the objects of a kind in a segment, a circle or the map |
//! | `measure_distance` | [`DistanceRequest`] | the ground-plane distance between two places |
//! | `neighbours` | [`NeighboursRequest`] | what stands around an object, with gaps and relations |
//! | `update_map` | [`UpdateMapRequest`] | propose (and with `apply`, commit) an edit from a described change |
//! | `undo_map_edit` | [`UndoMapEditRequest`] | revert an applied edit exactly |

use schemars::JsonSchema;
use serde_json::{Value as Json, json};

pub use crate::cypher::{
    CYPHER_TIMEOUT, MAX_ANSWER_BYTES, MAX_INTERMEDIATE_ROWS, MAX_ROWS, MAX_STATEMENT_BYTES,
};
use crate::error::failed;
pub use crate::error::{ToolError, ToolResult};
use crate::find::{FindRequest, LocateAnswer, LocateRequest, ParserKind, Ranking};
pub use crate::ops::MAX_CYPHER_CHARS;
use crate::ops::{
    AreaAnswer, CountObjectsRequest, CypherAnswer, CypherRequest, DescribeAreaRequest,
    DistanceRequest, FindObjectsAnswer, FindObjectsRequest, GetInstanceRequest, InstanceAnswer,
    LocateToolRequest, NearestObjectsRequest, NeighboursRequest, PlanRouteRequest, SchemaAnswer,
    SchemaRequest, UndoMapEditRequest, UpdateMapRequest, answer_schema_of, check_args, non_blank,
    parse, request_schema_of,
};
use crate::plan::NavigateAnswer;
use crate::tasks::{CountAnswer, DistanceAnswer, NearestAnswer, NeighboursAnswer};
pub use crate::toolbox::Toolbox;
use crate::update::UpdateAnswer;
use ingest::map_edit::EditInfo;

/// How an agent should use the map's tools: served as the MCP prompt `use_the_map` and the
/// resource `opengraph://guide`, and summarised in the MCP server's instructions.
pub const AGENT_GUIDE: &str = "\
You are answering questions about an OpenGraph map: a 3D scene graph of streets built from LiDAR and \
camera data. It has road segments (kind: intersection = crossroads, t_intersection, l_intersection = \
bend, straight_roadway), a lane graph along the driven path, and mapped objects (Instance nodes).

1. Call get_schema once: every label's properties with types, units and frames, which axis is up \
(frame) and which ids the tools take (ids).
2. Prefer the task tools to Cypher; each answer says how it measured:
   - nearest_objects: the objects of a kind nearest a place, with distances;
   - count_objects: how many objects of a kind on the map, in a segment, or within a radius of a place;
   - measure_distance: the ground-plane distance between two places;
   - plan_route: a route between two places; route_length_m is the route's length;
   - neighbours: what stands around an object;
   - find_objects: objects from a request in words ('somewhere I can post a letter');
   - locate: where someone is from what they see ('a T-junction with a bus stop on my left');
   - describe_area and get_instance: the map top-down, one segment, one object.
3. What an object is: its label ('post box', 'fire hydrant', 'bus stop shelter'), not its semantic_class (the \
SemanticKITTI class used for segmentation; street furniture is often other-object).
4. Places are words ('the start of the drive', 'the T-junction with two bus shelters', 'the post box \
by the crossroads') or specs with node ids: instance:ID, segment:ID, lane:ID, node:ID, or 'x,z' \
ground coordinates.
5. Distances are in metres on the ground plane, between centroids unless measure=box_gap (between \
footprints).
6. In Cypher (read_cypher): a node's id is id(n); LANE relationships are stored one way and travelled \
both ways, so match them undirected, -[:LANE]-; shortestPath((a)-[:LANE*]-(b)) gives the fewest hops; \
ground-plane searches are db.index.spatial.withinGroundDistance and db.index.spatial.nearestOnGround; \
whole nodes come with their 384-number feature summarised.
7. Answer from the tools' results: say the number, the object's label and id, or the distance with its \
unit, and how it was measured.";

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

/// One tool's registry entry: its name, description, request and answer types, and whether
/// it writes; both schemas are generated from the types.
fn tool<Req: JsonSchema, Ans: JsonSchema>(
    name: &'static str,
    description: &'static str,
    writes: bool,
) -> Tool {
    Tool {
        name,
        description,
        input_schema: request_schema_of::<Req>(),
        output_schema: answer_schema_of::<Ans>(),
        writes,
    }
}

/// Every tool, sorted by name; the write tools only when `writes` is true.
pub fn tools(writes: bool) -> Vec<Tool> {
    let mut v = vec![
        tool::<DescribeAreaRequest, AreaAnswer>(
            "describe_area",
            "Describe the map top-down. Without segment_id: the environment and every road segment (id, kind, how many objects, the most common labels). With segment_id: that segment's objects by label and its notable objects with their labels and captions.",
            false,
        ),
        tool::<FindObjectsRequest, FindObjectsAnswer>(
            "find_objects",
            "Find objects in the map from a request in words, e.g. 'the bench near the bus stop', 'somewhere I can post a letter', 'a red car at the T-junction'. Returns instances (node id, label, caption, semantic_class, centroid, segment) best first, each with its evidence (anchors found near it).",
            false,
        ),
        tool::<GetInstanceRequest, InstanceAnswer>(
            "get_instance",
            "One instance by node id: label, caption, semantic_class, centroid, box, its segment (the nearest; segment_distance_m says how far outside its area the object lies, 0 inside), and its RELATED neighbours.",
            false,
        ),
        tool::<SchemaRequest, SchemaAnswer>(
            "get_schema",
            "The map's schema: every node label and relationship type with its properties (type, unit, frame), counts, indexes, what each layer means, which axis is up (frame) and which id each tool takes (ids). Call this before writing Cypher.",
            false,
        ),
        tool::<LocateToolRequest, LocateAnswer>(
            "locate",
            "Where is someone who describes their surroundings, e.g. 'I'm at a T-junction, there's a bus stop on my left'? Returns road segments best first with a position estimate and the landmarks that support each.",
            false,
        ),
        tool::<PlanRouteRequest, NavigateAnswer>(
            "plan_route",
            "Plan a route between two ends, each in words ('the bus stop by the crossroads', 'the T-junction') or as a spec (lane:ID, segment:ID, instance:ID, node:ID, or 'x,z' ground coordinates). Ends may also be 'the start of the drive' or 'the end of the drive'. Returns both ends with how they were resolved, route_length_m (the route's length along the lane graph, metres) and the plan (the route's nodes and polyline; path is the smoothed path a robot would drive).",
            false,
        ),
        tool::<NearestObjectsRequest, NearestAnswer>(
            "nearest_objects",
            "The objects of a kind nearest a place, nearest first, with distances in metres. kind: words or a label ('post box', 'trees', 'a bench'; synonyms, kinds and parts count: a hatchback is a car, a tree trunk part of a tree). near: words ('the start of the drive', 'the T-junction', 'the bus shelter by the crossroads') or a spec (instance:ID, segment:ID, lane:ID, node:ID with node ids, or 'x,z' ground coordinates). Distances are on the ground plane between centroids, or between footprints with measure=box_gap. The answer lists the labels the kind took and how the place was resolved.",
            false,
        ),
        tool::<CountObjectsRequest, CountAnswer>(
            "count_objects",
            "Count (and list) the objects of a kind: on the whole map, in one road segment (within: words such as 'the T-junction' or segment:ID; an object belongs to its nearest segment), or within radius_m of a place (near). Answers how many, how each label matched the kind (parts such as tree trunks are counted unless parts=false), and the first objects with distances.",
            false,
        ),
        tool::<DistanceRequest, DistanceAnswer>(
            "measure_distance",
            "The ground-plane distance in metres between two places, each in words or as a spec (instance:ID, segment:ID, lane:ID, node:ID, 'x,z', 'the start of the drive'): between centroids by default, between footprints with measure=box_gap. For the length of a drive between them use plan_route.",
            false,
        ),
        tool::<NeighboursRequest, NeighboursAnswer>(
            "neighbours",
            "What stands around an object (Instance node id): the objects whose footprints are within radius_m (default 10) of its footprint, nearest first, with the gap, the centroid distance and the map's geometric relation (next_to, on, ...) where it stores one.",
            false,
        ),
        tool::<CypherRequest, CypherAnswer>(
            "read_cypher",
            "Run a read-only Cypher query (openCypher; writes are refused by the parser) with a 10 s time limit and at most 1000 rows. Whole nodes come with their vectors and long coordinate lists summarised (full_properties=true keeps them). Spatial procedures on the ground plane: db.index.spatial.withinGroundDistance('instance_space', [x, z], metres) and db.index.spatial.nearestOnGround('instance_space', [x, z], k) (ground coordinates; see get_schema's frame); db.index.vector.queryNodes for vectors.",
            false,
        ),
    ];
    if writes {
        v.push(tool::<UpdateMapRequest, UpdateAnswer>(
            "update_map",
            "Update the map from a described change: 'the bush under the street sign at the crossing is gone', 'the bench by the bus stop was moved next to the post box', 'the bench by the bus stop is now red', 'there is a new bin next to the post box'. Without apply it only proposes the edit (the object it found, with candidates); with apply=true it commits it and returns the edit id. An ambiguous description lists the candidates and changes nothing.",
            true,
        ));
        v.push(tool::<UndoMapEditRequest, EditInfo>(
            "undo_map_edit",
            "Undo an applied map edit exactly (its id is update_map's applied.edit_id; edits are listed by MATCH (e:MapEdit) RETURN id(e), e.text, e.undone). A later edit touching the same objects must be undone first.",
            true,
        ));
        v.push(tool::<CypherRequest, CypherAnswer>(
            "write_cypher",
            "Run a Cypher statement that may write (CREATE, SET, DELETE, MERGE), as one transaction: a failure changes nothing. 10 s time limit.",
            true,
        ));
    }
    v.sort_by_key(|t| t.name);
    v
}

/// Whether `name` is a tool that changes the map (looked up in the registry, built once).
pub fn is_write_tool(name: &str) -> bool {
    registry().iter().any(|(t, _)| t.name == name && t.writes)
}

/// Whether calling tool `name` with `args` changes the map: a write tool's call, except an
/// `update_map` without `apply`, which only proposes an edit (and so needs no token).
pub fn call_writes(name: &str, args: &Json) -> bool {
    is_write_tool(name) && !(name == "update_map" && args.get("apply") != Some(&Json::Bool(true)))
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

impl Toolbox {
    /// The tools this toolbox offers.
    pub fn tools(&self) -> Vec<Tool> {
        tools(self.writes)
    }

    /// Calls a tool with JSON arguments (validated against its schema, then deserialised into
    /// its request type); the answer is JSON.
    ///
    /// # Errors
    /// [`ToolError::Unknown`] for a name not offered, [`ToolError::BadArguments`] for
    /// arguments that break the schema, [`ToolError::Failed`] when the operation fails.
    pub fn call(&mut self, name: &str, args: &Json) -> ToolResult<Json> {
        let (tool, validator) = registry()
            .iter()
            .find(|(t, _)| t.name == name && (self.writes || !t.writes))
            .ok_or_else(|| ToolError::Unknown(name.to_string()))?;
        let empty = json!({});
        let args = if args.is_null() { &empty } else { args };
        check_args(args, validator)?;
        match tool.name {
            "get_schema" => {
                parse::<SchemaRequest>(args)?;
                answer(&self.get_schema()?)
            }
            "read_cypher" | "write_cypher" => {
                let req: CypherRequest = parse(args)?;
                let form = if req.full_properties {
                    graphstore::cypher::JsonForm::Full
                } else {
                    graphstore::cypher::JsonForm::Brief
                };
                self.cypher(
                    &req.query,
                    req.params.as_ref(),
                    tool.name == "read_cypher",
                    form,
                )
            }
            "find_objects" => {
                let req = find_request(args)?;
                let r = self.store.read().map_err(failed)?;
                let (a, nearest_to) = crate::tasks::find_near_places(&mut self.finder, &r, &req)?;
                answer(&FindObjectsAnswer {
                    request: a.request,
                    results: a.results,
                    nearest_to,
                })
            }
            "locate" => {
                let req = locate_request(args)?;
                let r = self.store.read().map_err(failed)?;
                answer(&self.finder.locate(&r, &req)?)
            }
            "plan_route" => {
                let req: PlanRouteRequest = parse(args)?;
                let r = self.store.read().map_err(failed)?;
                let mut a = crate::plan::navigate(
                    &mut self.finder,
                    &r,
                    &crate::plan::NavigateRequest {
                        text: None,
                        from: Some(req.from),
                        to: Some(req.to),
                        parser: ParserKind::Rules,
                        options: crate::plan::PlanOptions::default(),
                    },
                )?;
                // the poses are for a robot; an agent needs the route
                if !req.poses {
                    a.plan.path.poses.clear();
                }
                answer(&a)
            }
            "update_map" => {
                let req: UpdateMapRequest = parse(args)?;
                non_blank("text", &req.text)?;
                let a = crate::update::update(
                    &mut self.finder,
                    &self.store,
                    &crate::update::UpdateRequest {
                        text: req.text,
                        apply: req.apply,
                        parser: ParserKind::Rules,
                    },
                )?;
                answer(&a)
            }
            "undo_map_edit" => {
                let req: UndoMapEditRequest = parse(args)?;
                answer(&crate::update::undo(&self.store, req.edit_id)?)
            }
            "describe_area" => {
                let req: DescribeAreaRequest = parse(args)?;
                answer(&self.describe_area(req.segment_id)?)
            }
            "get_instance" => {
                let req: GetInstanceRequest = parse(args)?;
                answer(&self.get_instance(req.id)?)
            }
            "nearest_objects" => {
                let req: NearestObjectsRequest = parse(args)?;
                non_blank("kind", &req.kind)?;
                answer(&self.nearest_objects(&req)?)
            }
            "count_objects" => {
                let req: CountObjectsRequest = parse(args)?;
                non_blank("kind", &req.kind)?;
                answer(&self.count_objects(&req)?)
            }
            "measure_distance" => {
                let req: DistanceRequest = parse(args)?;
                answer(&self.measure_distance(&req)?)
            }
            "neighbours" => {
                let req: NeighboursRequest = parse(args)?;
                answer(&self.neighbours(&req)?)
            }
            other => Err(ToolError::Unknown(other.to_string())),
        }
    }
}

/// `find_objects`' arguments as a find request (graph-aware, rule parser).
fn find_request(args: &Json) -> ToolResult<FindRequest> {
    let req: FindObjectsRequest = parse(args)?;
    non_blank("text", &req.text)?;
    Ok(FindRequest {
        text: req.text,
        k: req.k as usize,
        class: req.semantic_class,
        near: None,
        ranking: Ranking::Graph {
            parser: ParserKind::Rules,
            rerank: false,
        },
        rerank_n: 10,
    })
}

/// `locate`'s arguments as a locate request (rule parser).
fn locate_request(args: &Json) -> ToolResult<LocateRequest> {
    let req: LocateToolRequest = parse(args)?;
    non_blank("text", &req.text)?;
    Ok(LocateRequest {
        text: req.text,
        k: req.k as usize,
        parser: ParserKind::Rules,
    })
}

impl Toolbox {
    /// One pass of `find_objects` or `locate` fanned out over region shards
    /// ([`crate::shards`]): the arguments are the tool's own, checked as [`Toolbox::call`]
    /// checks them; the answer is the pass's ([`crate::shards::ShardPass`]). Any other tool
    /// has no passes: call it plainly.
    ///
    /// # Errors
    /// As [`Toolbox::call`]; [`ToolError::BadArguments`] for a pass that is not the tool's.
    pub fn call_shard(
        &mut self,
        name: &str,
        args: &Json,
        pass: &crate::shards::ShardPass,
    ) -> ToolResult<Json> {
        use crate::shards::ShardPass;
        let (_, validator) = registry()
            .iter()
            .find(|(t, _)| t.name == name && !t.writes)
            .ok_or_else(|| ToolError::Unknown(name.to_string()))?;
        check_args(args, validator)?;
        match (name, pass) {
            ("find_objects", ShardPass::FindCuts | ShardPass::Find { .. }) => {
                let req = find_request(args)?;
                let r = self.store.read().map_err(failed)?;
                let norms = match pass {
                    ShardPass::Find { norms } => Some(norms),
                    _ => None,
                };
                let (a, cuts) = self.finder.find_normed(&r, &req, norms)?;
                match pass {
                    ShardPass::FindCuts => answer(&cuts),
                    // a sharded map answers by relevance only (a place may lie in another
                    // region)
                    _ => answer(&FindObjectsAnswer {
                        request: a.request,
                        results: a.results,
                        nearest_to: None,
                    }),
                }
            }
            (
                "locate",
                ShardPass::LocateBests | ShardPass::LocateHits { .. } | ShardPass::Locate { .. },
            ) => {
                let req = locate_request(args)?;
                let r = self.store.read().map_err(failed)?;
                let norms = match pass {
                    ShardPass::LocateHits { bests } => llm_tools::locate::LocateNorms {
                        bests: bests.clone(),
                        ..Default::default()
                    },
                    ShardPass::Locate { norms } => norms.clone(),
                    _ => llm_tools::locate::LocateNorms::default(),
                };
                let (a, stats) = self.finder.locate_normed(&r, &req, &norms)?;
                match pass {
                    ShardPass::Locate { .. } => answer(&a),
                    _ => answer(&stats),
                }
            }
            _ => Err(ToolError::BadArguments(format!(
                "{name} has no shard pass {:?}: find_objects takes find_cuts and find, locate takes locate_bests, locate_hits and locate",
                pass.name()
            ))),
        }
    }
}

/// An answer as JSON.
fn answer<T: serde::Serialize>(v: &T) -> ToolResult<Json> {
    serde_json::to_value(v).map_err(failed)
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

    /// A tool's statement may not hold more than MAX_INTERMEDIATE_ROWS rows at once (a memory
    /// bound for an unauthenticated caller); just under it runs, and a count that streams over
    /// more rows than that holds none.
    #[test]
    fn a_runaway_statement_stops_at_the_intermediate_row_limit() {
        let (_dir, store) = demo_store();
        let mut tb = Toolbox::new(store, hash_finder(), false);
        let q = |n: usize| json!({"query": format!("UNWIND range(1, {n}) AS a UNWIND range(1, 1000) AS b WITH DISTINCT a, b RETURN count(*) AS n")});
        let e = tb.call("read_cypher", &q(1001)).unwrap_err();
        assert_eq!(e.http_status(), 400);
        assert!(e.to_string().contains("1000000 rows"), "{e}");
        let ok = tb.call("read_cypher", &q(999)).unwrap();
        assert_eq!(ok["rows"][0]["n"], 999_000);
        let streamed = json!({"query": "UNWIND range(1, 1001) AS a UNWIND range(1, 1000) AS b RETURN count(*) AS n"});
        let ok = tb.call("read_cypher", &streamed).unwrap();
        assert_eq!(ok["rows"][0]["n"], 1_001_000);
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

    /// Every tool's answer on a map is valid under the output schema the registry publishes
    /// (the MCP client checks structured content against it), and every published tool is
    /// called here.
    #[test]
    fn every_answer_is_valid_under_its_output_schema() {
        let (_dir, store) = crate::test_support::demo_store_with_features();
        let mut tb = Toolbox::new(store, hash_finder(), true);
        tb.call(
            "write_cypher",
            &json!({"query": "MATCH (e:Environment) SET e.ground_frame = 'enu'"}),
        )
        .unwrap();
        let one = |tb: &mut Toolbox, q: &str| {
            tb.call("read_cypher", &json!({ "query": q })).unwrap()["rows"][0]["id"]
                .as_u64()
                .unwrap()
        };
        let lane = one(
            &mut tb,
            "MATCH (l:LaneNode {lane_id: 0}) RETURN id(l) AS id",
        );
        let seg = one(
            &mut tb,
            "MATCH (s:Segment {segment_id: 2}) RETURN id(s) AS id",
        );
        let bench = one(
            &mut tb,
            "MATCH (n:Instance {instance_id: 1}) RETURN id(n) AS id",
        );
        let mut calls = vec![
            ("get_schema", json!({})),
            (
                "read_cypher",
                json!({"query": "MATCH (n) RETURN labels(n) AS l LIMIT 3"}),
            ),
            (
                "write_cypher",
                json!({"query": "CREATE (:Note {text: 'x'})"}),
            ),
            (
                "find_objects",
                json!({"text": "the bench near the fire hydrant", "k": 3}),
            ),
            (
                "locate",
                json!({"text": "I'm at a T-junction by a stop sign"}),
            ),
            (
                "plan_route",
                json!({"from": format!("lane:{lane}"), "to": format!("segment:{seg}")}),
            ),
            (
                "plan_route",
                json!({"from": "the fire hydrant", "to": "the T-junction"}),
            ),
            ("describe_area", json!({})),
            ("describe_area", json!({ "segment_id": seg })),
            ("get_instance", json!({ "id": bench })),
            (
                "nearest_objects",
                json!({"kind": "benches", "near": format!("lane:{lane}"), "k": 2}),
            ),
            (
                "nearest_objects",
                json!({"kind": "a car", "near": format!("instance:{bench}"), "measure": "box_gap"}),
            ),
            ("count_objects", json!({"kind": "hedges"})),
            (
                "count_objects",
                json!({"kind": "bench", "within": format!("segment:{seg}")}),
            ),
            (
                "count_objects",
                json!({"kind": "car", "near": format!("instance:{bench}"), "radius_m": 50.0}),
            ),
            (
                "measure_distance",
                json!({"from": format!("instance:{bench}"), "to": format!("segment:{seg}"), "measure": "box_gap"}),
            ),
            ("neighbours", json!({ "id": bench, "radius_m": 100.0 })),
            (
                "update_map",
                json!({"text": "the green wooden bench is now red"}),
            ),
            (
                "update_map",
                json!({"text": "the green wooden bench is now red", "apply": true}),
            ),
        ];
        let mut called = std::collections::BTreeSet::new();
        let mut check = |tb: &mut Toolbox, name: &str, args: &Json| -> Json {
            let a = tb
                .call(name, args)
                .unwrap_or_else(|e| panic!("{name} {args}: {e}"));
            let schema = tools(true)
                .into_iter()
                .find(|t| t.name == name)
                .unwrap()
                .output_schema;
            let v = jsonschema::validator_for(&schema).unwrap();
            let errors: Vec<String> = v.iter_errors(&a).map(|e| e.to_string()).collect();
            assert!(errors.is_empty(), "{name}: {errors:?}\n{a}");
            called.insert(name.to_string());
            a
        };
        let mut edit = None;
        for (name, args) in calls.drain(..) {
            let a = check(&mut tb, name, &args);
            if let Some(id) = a["applied"]["edit_id"].as_u64() {
                edit = Some(id);
            }
        }
        let edit = edit.expect("the change was applied");
        check(&mut tb, "undo_map_edit", &json!({ "edit_id": edit }));
        let all: std::collections::BTreeSet<String> =
            tools(true).iter().map(|t| t.name.to_string()).collect();
        assert_eq!(called, all);
    }

    #[test]
    fn the_schema_says_properties_frames_and_ids_and_whole_nodes_come_brief() {
        let (_dir, store) = crate::test_support::demo_store_with_features();
        let mut tb = Toolbox::new(store, hash_finder(), true);
        let s = tb.call("get_schema", &json!({})).unwrap();
        assert!(s["frame"].as_str().unwrap().contains("not known yet"));
        tb.call(
            "write_cypher",
            &json!({"query": "MATCH (e:Environment) SET e.ground_frame = 'kitti_cam'"}),
        )
        .unwrap();
        let s = tb.call("get_schema", &json!({})).unwrap();
        // every property of the map's layers says what it is, with its type
        for owner in [
            "Environment",
            "Segment",
            "LaneNode",
            "Instance",
            "Build",
            "MapEdit",
            "Frame",
        ] {
            let props = s["labels"][owner]["properties"].as_array().unwrap();
            assert!(!props.is_empty(), "{owner}");
            for p in props {
                assert!(
                    p["type"].is_string() && p["meaning"].is_string(),
                    "{owner}: {p}"
                );
            }
        }
        for (ty, rule) in s["relationship_types"].as_object().unwrap() {
            for p in rule["properties"].as_array().unwrap() {
                assert!(p["meaning"].is_string(), "{ty}: {p}");
            }
        }
        let feature = s["labels"]["Instance"]["properties"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["key"] == "feature")
            .unwrap();
        assert_eq!(feature["type"], "vector");
        let frame = s["frame"].as_str().unwrap();
        assert!(frame.contains("up is -y"), "{frame}");
        assert!(s["ids"].as_str().unwrap().contains("instance:ID"));
        // a whole node leaves its vectors out unless asked; the property itself is whole
        let q = |tb: &mut Toolbox, args: Json| tb.call("read_cypher", &args).unwrap();
        let brief = q(
            &mut tb,
            json!({"query": "MATCH (n:Instance) WHERE n.feature IS NOT NULL RETURN n LIMIT 1"}),
        );
        let f = brief["rows"][0]["n"]["feature"].as_str().unwrap();
        assert!(f.starts_with("<vector of 384 floats"), "{f}");
        assert!(brief["rows"][0]["n"]["caption"].is_string());
        let full = q(
            &mut tb,
            json!({"query": "MATCH (n:Instance) WHERE n.feature IS NOT NULL RETURN n LIMIT 1", "full_properties": true}),
        );
        assert_eq!(
            full["rows"][0]["n"]["feature"].as_array().unwrap().len(),
            384
        );
        let own = q(
            &mut tb,
            json!({"query": "MATCH (n:Instance) WHERE n.feature IS NOT NULL RETURN n.feature AS f LIMIT 1"}),
        );
        assert_eq!(own["rows"][0]["f"].as_array().unwrap().len(), 384);
        // get_instance says how far outside its segment an object lies, as IN_SEGMENT stores it
        let rows = q(
            &mut tb,
            json!({"query": "MATCH (n:Instance)-[r:IN_SEGMENT]->(s) RETURN id(n) AS id, r.distance_m AS d, id(s) AS s"}),
        );
        let rows = rows["rows"].as_array().unwrap();
        assert!(!rows.is_empty());
        for row in rows {
            let a = tb.call("get_instance", &json!({"id": row["id"]})).unwrap();
            assert_eq!(a["segment"]["id"], row["s"], "{a}");
            assert_eq!(a["segment_distance_m"], row["d"], "{a}");
        }
    }

    #[test]
    fn a_map_without_its_hierarchy_yet_is_the_callers_error_with_the_way_out() {
        // a live server before its first frames: an empty store with the layer schema
        let dir = tempfile::tempdir().unwrap();
        let store = graphstore::Store::create(dir.path().join("empty.og")).unwrap();
        store.set_schema(scene::opengraph_schema()).unwrap();
        let mut tb = Toolbox::new(store, hash_finder(), false);
        for (tool, args) in [
            ("find_objects", json!({"text": "a bench"})),
            ("locate", json!({"text": "a T-junction next to a bus stop"})),
        ] {
            let e = tb.call(tool, &args).unwrap_err();
            assert!(matches!(e, ToolError::Input(_)), "{tool}: {e:?}");
            assert_eq!(e.http_status(), 400);
            let m = e.to_string();
            assert!(
                m.contains("no Environment node yet") && m.contains("serve --zenoh"),
                "{m}"
            );
        }
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
