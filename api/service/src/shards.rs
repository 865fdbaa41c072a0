//! A map spread over several servers, each holding one region (a region shard), and
//! questions fanned out over them. Transport-free: the zenoh front end carries the passes
//! ([`ShardTransport`]); this module says what is asked and how the answers are merged.
//!
//! - [`split`] cuts a map into regions ([`scene::regions`]), one store per region, node ids
//!   kept, so a result names the same node as in the whole map.
//! - [`fan_out`] asks every region and merges:
//!   - `find_objects` in two passes: each region's candidate cosines
//!     ([`ShardPass::FindCuts`]), then every region ranks under the whole map's best and
//!     candidate cut ([`ShardPass::Find`]); the global top k is the best k of the union, with
//!     the scores one map holding every region gives, except that an anchor or a segment in
//!     another region is not seen.
//!   - `locate` in three passes (best cosines, segments with a good match, the ranking;
//!     [`llm_tools::locate::LocateNorms`]); landmarks in another region are not seen.
//!   - `read_cypher`: the union of the rows, each with its `region` (no joins across
//!     regions; ORDER BY, LIMIT and aggregates hold within each region only).
//!   - any other read-only tool: each region's answer under `by_region`.
//! - A region that does not answer a pass within the deadline, or answers with an error, is
//!   reported in `missing` with the reason; its results are not in the answer.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};

use crate::error::{ToolError, ToolResult};
use llm_tools::graph_find::{FindCuts, FindNorms};
use llm_tools::locate::{LocateNorms, LocateStats};

/// One pass of a fanned-out tool (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "pass", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShardPass {
    /// `find_objects`, first pass: the region's [`FindCuts`].
    FindCuts,
    /// `find_objects`, second pass: the answer under the whole map's norms.
    Find {
        /// [`FindCuts::merge`] of every region's cuts.
        norms: FindNorms,
    },
    /// `locate`, first pass: the region's [`LocateStats`] (its best cosines).
    LocateBests,
    /// `locate`, second pass: the region's [`LocateStats`] (its hits) under the whole map's
    /// best cosines.
    LocateHits {
        /// Per landmark, the best cosine over every region.
        bests: Vec<Option<f64>>,
    },
    /// `locate`, third pass: the answer under the whole map's norms.
    Locate {
        /// The best cosines, hits and segments over every region.
        norms: LocateNorms,
    },
}

impl ShardPass {
    /// Its name (the `pass` tag).
    pub fn name(&self) -> &'static str {
        match self {
            ShardPass::FindCuts => "find_cuts",
            ShardPass::Find { .. } => "find",
            ShardPass::LocateBests => "locate_bests",
            ShardPass::LocateHits { .. } => "locate_hits",
            ShardPass::Locate { .. } => "locate",
        }
    }
}

/// What a region is asked: a read-only tool with its arguments, and for a fanned-out
/// `find_objects` or `locate`, the pass. As JSON it is the zenoh query's payload:
/// `{"tool": NAME, "args": {...}, "shard": {"pass": ...}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ShardQuery {
    /// The tool's name.
    pub tool: String,
    /// Its arguments (as `POST /api/tools/NAME` takes them).
    #[serde(default)]
    pub args: Json,
    /// The pass, for a fanned-out `find_objects` or `locate`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<ShardPass>,
}

/// How a fanned-out question reaches the regions (zenoh: a query on
/// `opengraph/<map>/*/query`).
pub trait ShardTransport {
    /// Sends `query` to every region; returns the replies that came within `deadline`, by
    /// region (an error reply as its error).
    fn ask(&self, query: &ShardQuery, deadline: Duration) -> Vec<(String, ToolResult<Json>)>;
    /// The regions that say they are there.
    fn regions(&self, deadline: Duration) -> Vec<String>;
}

/// A question for every region.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FanOutRequest {
    /// A read-only tool's name.
    pub tool: String,
    /// Its arguments.
    #[serde(default)]
    pub args: Json,
    /// The regions expected; a listed region that does not answer is reported missing.
    /// Default: the regions that say they are there when asked.
    #[serde(default)]
    pub regions: Option<Vec<String>>,
    /// Seconds each pass waits for the regions' replies.
    #[serde(default = "default_deadline")]
    pub deadline_secs: f64,
}

fn default_deadline() -> f64 {
    5.0
}

/// A region that is not in the answer, and why.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct MissingRegion {
    /// The region.
    pub region: String,
    /// "no reply within the deadline", or its error.
    pub reason: String,
}

/// The merged answer of a fanned-out question.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct FanOutAnswer {
    /// The tool's answer over the regions that answered (see the module docs); each result
    /// and row carries its `region`.
    pub answer: Json,
    /// The regions in it, sorted.
    pub regions: Vec<String>,
    /// The regions expected or heard from that are not in it.
    pub missing: Vec<MissingRegion>,
    /// Round trips made.
    pub passes: u32,
    /// Milliseconds taken.
    pub time_ms: f64,
}

struct Round<'a> {
    transport: &'a dyn ShardTransport,
    deadline: Duration,
    /// regions still in the answer
    live: BTreeSet<String>,
    missing: BTreeMap<String, String>,
    /// the caller named the regions: no other region's reply counts
    named: bool,
    /// regions that answered "not found" (their error bodies)
    not_found: BTreeMap<String, Json>,
    passes: u32,
}

impl Round<'_> {
    /// One pass: the replies of the regions still in, parsed; the rest become missing.
    fn pass<T: serde::de::DeserializeOwned>(
        &mut self,
        query: &ShardQuery,
    ) -> ToolResult<BTreeMap<String, T>> {
        self.passes += 1;
        let mut got: BTreeMap<String, ToolResult<Json>> = BTreeMap::new();
        for (region, answer) in self.transport.ask(query, self.deadline) {
            // a region heard from for the first time joins when nothing was listed
            let wanted = !self.named || self.live.contains(&region);
            if wanted && !self.missing.contains_key(&region) {
                got.insert(region, answer);
            }
        }
        // the caller's mistake is every region's: say it once
        let all_refused = !got.is_empty()
            && got.values().all(|a| {
                matches!(
                    a,
                    Err(ToolError::BadArguments(_) | ToolError::Input(_) | ToolError::Unknown(_))
                )
            });
        if all_refused && let Some((_, Err(e))) = got.pop_first() {
            return Err(e);
        }
        let mut out = BTreeMap::new();
        let expected: Vec<String> = self.live.iter().cloned().collect();
        for region in expected {
            if !got.contains_key(&region) {
                self.live.remove(&region);
                self.missing.insert(
                    region,
                    format!(
                        "no reply to pass {} (it waited at most {:.1} s; a stopped region's is missing at once)",
                        query.shard.as_ref().map_or("call", ShardPass::name),
                        self.deadline.as_secs_f64(),
                    ),
                );
            }
        }
        for (region, answer) in got {
            if self.passes > 1 && !self.live.contains(&region) {
                // it missed an earlier pass: its answer would not be under the same norms
                continue;
            }
            let parsed = answer.and_then(|v| {
                serde_json::from_value::<T>(v).map_err(|e| {
                    ToolError::Failed(format!("region {region} answered in another shape: {e}"))
                })
            });
            match parsed {
                Ok(v) => {
                    self.live.insert(region.clone());
                    out.insert(region, v);
                }
                Err(e) => {
                    self.live.remove(&region);
                    if matches!(e, ToolError::NotFound(_)) {
                        self.not_found
                            .insert(region.clone(), crate::service::error_body(&e));
                    }
                    self.missing.insert(region, e.to_string());
                }
            }
        }
        Ok(out)
    }
}

/// Asks every region `req.tool` and merges the answers (see the module docs).
///
/// # Errors
/// [`ToolError::BadArguments`] for a tool that writes or is unknown, or arguments every
/// region refuses; a deadline that is not a positive number of seconds.
pub fn fan_out(transport: &dyn ShardTransport, req: &FanOutRequest) -> ToolResult<FanOutAnswer> {
    let t0 = Instant::now();
    if !(req.deadline_secs.is_finite() && req.deadline_secs > 0.0 && req.deadline_secs <= 3600.0) {
        return Err(ToolError::BadArguments(format!(
            "deadline_secs is {}: give a number of seconds in (0, 3600]",
            req.deadline_secs
        )));
    }
    if crate::tools::is_write_tool(&req.tool) || req.tool == "ask" {
        return Err(ToolError::BadArguments(format!(
            "{} is not a read-only tool; a fanned-out question takes read-only tools",
            req.tool
        )));
    }
    let deadline = Duration::from_secs_f64(req.deadline_secs);
    let expected = match &req.regions {
        Some(r) => r.clone(),
        None => transport.regions(deadline),
    };
    let mut round = Round {
        transport,
        deadline,
        live: expected.into_iter().collect(),
        missing: BTreeMap::new(),
        named: req.regions.is_some(),
        not_found: BTreeMap::new(),
        passes: 0,
    };
    let args = if req.args.is_null() {
        json!({})
    } else {
        req.args.clone()
    };
    let query = |shard: Option<ShardPass>| ShardQuery {
        tool: req.tool.clone(),
        args: args.clone(),
        shard,
    };
    let answer = match req.tool.as_str() {
        "find_objects" => {
            let cuts: BTreeMap<String, FindCuts> = round.pass(&query(Some(ShardPass::FindCuts)))?;
            let norms = FindCuts::merge(&cuts.into_values().collect::<Vec<_>>());
            let answers: BTreeMap<String, Json> =
                round.pass(&query(Some(ShardPass::Find { norms })))?;
            let k = args["k"].as_u64().unwrap_or(5) as usize;
            merge_ranked(answers, "results", "score", "id", k)
        }
        "locate" => {
            let firsts: BTreeMap<String, LocateStats> =
                round.pass(&query(Some(ShardPass::LocateBests)))?;
            let bests = max_bests(firsts.values());
            let seconds: BTreeMap<String, LocateStats> =
                round.pass(&query(Some(ShardPass::LocateHits {
                    bests: bests.clone(),
                })))?;
            let mut hits = vec![0usize; bests.len()];
            for s in seconds.values() {
                for (h, x) in hits.iter_mut().zip(&s.hits) {
                    *h += x;
                }
            }
            let norms = LocateNorms {
                bests,
                hits: Some(hits),
                segments: Some(seconds.values().map(|s| s.segments).sum()),
            };
            let answers: BTreeMap<String, Json> =
                round.pass(&query(Some(ShardPass::Locate { norms })))?;
            let k = args["k"].as_u64().unwrap_or(3) as usize;
            merge_ranked(answers, "results", "score", "segment", k)
        }
        "read_cypher" => {
            let answers: BTreeMap<String, Json> = round.pass(&query(None))?;
            merge_rows(answers)
        }
        _ => {
            let mut answers: BTreeMap<String, Json> = round.pass(&query(None))?;
            if answers.is_empty()
                && let Some(body) = round.not_found.values().next()
            {
                // nowhere: the caller named something the map does not hold
                return Err(ToolError::from_body(body));
            }
            // "not found" in one region is that region's answer, not its absence
            for (region, body) in std::mem::take(&mut round.not_found) {
                round.missing.remove(&region);
                round.live.insert(region.clone());
                answers.insert(region, body);
            }
            json!({ "by_region": answers })
        }
    };
    if round.live.is_empty() && round.missing.is_empty() {
        return Err(ToolError::NotFound(
            "no region answered and none was named: is the map's name right, and are its servers reachable? (give --regions to have the silent ones named)".into(),
        ));
    }
    Ok(FanOutAnswer {
        answer,
        regions: round.live.into_iter().collect(),
        missing: round
            .missing
            .into_iter()
            .map(|(region, reason)| MissingRegion { region, reason })
            .collect(),
        passes: round.passes,
        time_ms: t0.elapsed().as_secs_f64() * 1e3,
    })
}

/// The best of every region's best cosine per landmark.
fn max_bests<'a>(stats: impl Iterator<Item = &'a LocateStats>) -> Vec<Option<f64>> {
    let mut out: Vec<Option<f64>> = Vec::new();
    for s in stats {
        if out.len() < s.bests.len() {
            out.resize(s.bests.len(), None);
        }
        for (o, b) in out.iter_mut().zip(&s.bests) {
            *o = match (*o, *b) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            };
        }
    }
    out
}

/// The first region's answer with `list` replaced by the best `k` of every region's, by
/// `score` (then `id`, ascending), each tagged with its region.
fn merge_ranked(
    answers: BTreeMap<String, Json>,
    list: &str,
    score: &str,
    id: &str,
    k: usize,
) -> Json {
    let mut all: Vec<Json> = Vec::new();
    let mut first: Option<Json> = None;
    for (region, mut a) in answers {
        if let Some(items) = a.get_mut(list).and_then(Json::as_array_mut) {
            for mut item in std::mem::take(items) {
                if let Some(o) = item.as_object_mut() {
                    o.insert("region".into(), Json::String(region.clone()));
                }
                all.push(item);
            }
        }
        first.get_or_insert(a);
    }
    all.sort_by(|a, b| {
        let s = |v: &Json| v[score].as_f64().unwrap_or(f64::NEG_INFINITY);
        s(b).total_cmp(&s(a))
            .then(a[id].as_u64().cmp(&b[id].as_u64()))
    });
    all.truncate(k);
    let mut out = first.unwrap_or_else(|| json!({}));
    if let Some(o) = out.as_object_mut() {
        o.insert(list.into(), Json::Array(all));
        // per-region timings say nothing of the whole
        o.remove("timings_ms");
    }
    out
}

/// Every region's rows, each with its `region`; the columns with `region` last.
fn merge_rows(answers: BTreeMap<String, Json>) -> Json {
    let mut columns: Vec<Json> = Vec::new();
    let mut rows: Vec<Json> = Vec::new();
    for (region, a) in answers {
        if columns.is_empty()
            && let Some(c) = a["columns"].as_array()
        {
            columns = c.clone();
        }
        for row in a["rows"].as_array().into_iter().flatten() {
            let mut row = row.clone();
            if let Some(o) = row.as_object_mut() {
                o.insert("region".into(), Json::String(region.clone()));
            }
            rows.push(row);
        }
    }
    columns.push(Json::String("region".into()));
    json!({"columns": columns, "row_count": rows.len(), "rows": rows})
}

/// A map to cut into region shards.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SplitRequest {
    /// The map's store.
    pub db: PathBuf,
    /// How many regions (1..=64).
    pub parts: usize,
    /// The folder for the regions' stores (`r1.og`, `r2.og`, ...), made if missing.
    pub out: PathBuf,
}

/// One region's store.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct RegionStore {
    /// Its name (`r1`, `r2`, ...): the `--region` to serve it under.
    pub region: String,
    /// The store file.
    pub db: PathBuf,
    /// Nodes it holds alone (segments, instances, lane nodes).
    pub owned_nodes: usize,
    /// Nodes left out (the other regions').
    pub removed_nodes: usize,
}

/// What [`split`] made.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct SplitAnswer {
    /// The ground-plane axis the regions are cut across (`x` or `z` for KITTI's camera
    /// frame, `x` or `y` for ENU).
    pub axis: String,
    /// The cuts along it, metres.
    pub cuts_m: Vec<f64>,
    /// The regions, west to east (or along the axis).
    pub regions: Vec<RegionStore>,
}

/// Cuts the map at `req.db` into `req.parts` regions (see [`scene::regions`]): each region's
/// store is a copy of the map without the other regions' segments, instances and lane
/// nodes (and their relationships); node ids are kept.
///
/// # Errors
/// [`ToolError::Input`] for a store that cannot be opened, a region store that already
/// exists (it is not overwritten) or a folder that cannot be made;
/// [`ToolError::BadArguments`] for `parts` outside 1..=64 or a map without a ground frame.
pub fn split(req: &SplitRequest) -> ToolResult<SplitAnswer> {
    if !(1..=64).contains(&req.parts) {
        return Err(ToolError::BadArguments(format!(
            "parts is {}: a map is cut into 1 to 64 regions",
            req.parts
        )));
    }
    let store = graphstore::Store::open_read_only(&req.db)
        .map_err(|e| ToolError::Input(format!("{}: {e}", req.db.display())))?;
    let plan = {
        let r = store.read().map_err(crate::error::failed)?;
        scene::regions::plan_regions(&r, req.parts).map_err(|e| match e {
            scene::Error::NoGroundFrame(_) | scene::Error::Invalid(_) => {
                ToolError::BadArguments(e.to_string())
            }
            other => crate::error::failed(other),
        })?
    };
    drop(store);
    std::fs::create_dir_all(&req.out)
        .map_err(|e| ToolError::Input(format!("{}: {e}", req.out.display())))?;
    let path_of = |i: usize| req.out.join(format!("r{}.og", i + 1));
    for i in 0..req.parts {
        let p = path_of(i);
        if p.exists() {
            return Err(ToolError::Input(format!(
                "{} exists: remove it or give another --out",
                p.display()
            )));
        }
    }
    let mut regions = Vec::with_capacity(req.parts);
    for i in 0..req.parts {
        let p = path_of(i);
        let removed = plan.not_in(i);
        if let Err(e) = write_region(&req.db, &p, &removed) {
            // leave nothing half made
            let _ = std::fs::remove_file(&p);
            return Err(e);
        }
        regions.push(RegionStore {
            region: format!("r{}", i + 1),
            db: p,
            owned_nodes: plan.owned[i].len(),
            removed_nodes: removed.len(),
        });
    }
    let axis = match (plan.ground, plan.axis) {
        (scene::GroundFrame::KittiCam, 0) | (scene::GroundFrame::Enu, 0) => "x",
        (scene::GroundFrame::KittiCam, _) => "z",
        (scene::GroundFrame::Enu, _) => "y",
    };
    Ok(SplitAnswer {
        axis: axis.into(),
        cuts_m: plan.cuts_m.clone(),
        regions,
    })
}

fn write_region(src: &Path, dst: &Path, removed: &[u64]) -> ToolResult<()> {
    std::fs::copy(src, dst).map_err(|e| {
        ToolError::Input(format!(
            "copying {} to {}: {e}",
            src.display(),
            dst.display()
        ))
    })?;
    let store = graphstore::Store::open(dst)
        .map_err(|e| ToolError::Input(format!("{}: {e}", dst.display())))?;
    store
        .write(|tx| {
            for &id in removed {
                tx.detach_delete_node(id)?;
            }
            Ok(())
        })
        .map_err(crate::error::failed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// Regions as plain answers, for the merging rules (the real transport is tested over
    /// zenoh in api/tests/live_zenoh.rs).
    struct Fake {
        answers: BTreeMap<String, Json>,
        asked: Mutex<Vec<ShardQuery>>,
    }

    impl ShardTransport for Fake {
        fn ask(&self, q: &ShardQuery, _: Duration) -> Vec<(String, ToolResult<Json>)> {
            self.asked.lock().unwrap().push(q.clone());
            self.answers
                .iter()
                .map(|(r, a)| {
                    let a = if a.get("error").is_some() {
                        Err(ToolError::from_body(a))
                    } else {
                        Ok(a.clone())
                    };
                    (r.clone(), a)
                })
                .collect()
        }
        fn regions(&self, _: Duration) -> Vec<String> {
            self.answers.keys().cloned().collect()
        }
    }

    #[test]
    fn cypher_rows_are_united_with_their_region_and_a_silent_region_is_missing() {
        let f = Fake {
            answers: BTreeMap::from([
                (
                    "r1".into(),
                    json!({"columns": ["n"], "rows": [{"n": 1}], "row_count": 1}),
                ),
                (
                    "r2".into(),
                    json!({"columns": ["n"], "rows": [{"n": 2}, {"n": 3}], "row_count": 2}),
                ),
            ]),
            asked: Mutex::default(),
        };
        let a = fan_out(
            &f,
            &FanOutRequest {
                tool: "read_cypher".into(),
                args: json!({"query": "RETURN 1 AS n"}),
                regions: Some(vec!["r1".into(), "r2".into(), "r3".into()]),
                deadline_secs: 0.5,
            },
        )
        .unwrap();
        assert_eq!(a.answer["row_count"], 3);
        assert_eq!(a.answer["rows"][2], json!({"n": 3, "region": "r2"}));
        assert_eq!(a.answer["columns"], json!(["n", "region"]));
        assert_eq!(a.regions, vec!["r1", "r2"]);
        assert_eq!(a.missing.len(), 1);
        assert_eq!(a.missing[0].region, "r3");
        assert!(a.missing[0].reason.contains("no reply"), "{:?}", a.missing);
        // only the regions named are asked for
        let a = fan_out(
            &f,
            &FanOutRequest {
                tool: "read_cypher".into(),
                args: json!({"query": "RETURN 1 AS n"}),
                regions: Some(vec!["r2".into()]),
                deadline_secs: 0.5,
            },
        )
        .unwrap();
        assert_eq!(a.regions, vec!["r2"]);
        assert_eq!(a.answer["row_count"], 2);
        assert!(a.missing.is_empty());
    }

    #[test]
    fn an_error_every_region_gives_is_the_callers_and_one_regions_error_makes_it_missing() {
        let bad = json!({"error": {"code": "bad_request", "message": "bad arguments: k: too big"}});
        let f = Fake {
            answers: BTreeMap::from([("r1".into(), bad.clone()), ("r2".into(), bad)]),
            asked: Mutex::default(),
        };
        let req = FanOutRequest {
            tool: "read_cypher".into(),
            args: json!({}),
            regions: None,
            deadline_secs: 1.0,
        };
        let e = fan_out(&f, &req).unwrap_err();
        assert!(
            matches!(e, ToolError::BadArguments(ref m) if m == "k: too big"),
            "{e:?}"
        );
        let f = Fake {
            answers: BTreeMap::from([
                (
                    "r1".into(),
                    json!({"error": {"code": "internal", "message": "disk on fire"}}),
                ),
                (
                    "r2".into(),
                    json!({"columns": [], "rows": [], "row_count": 0}),
                ),
            ]),
            asked: Mutex::default(),
        };
        let a = fan_out(&f, &req).unwrap();
        assert_eq!(a.regions, vec!["r2"]);
        assert_eq!(a.missing[0].reason, "disk on fire");
        let w = FanOutRequest {
            tool: "write_cypher".into(),
            ..req.clone()
        };
        assert!(matches!(fan_out(&f, &w), Err(ToolError::BadArguments(_))));
        let d = FanOutRequest {
            deadline_secs: f64::NAN,
            ..req
        };
        assert!(matches!(fan_out(&f, &d), Err(ToolError::BadArguments(_))));
    }

    #[test]
    fn ranked_lists_merge_by_score_then_id_and_keep_k() {
        let answers = BTreeMap::from([
            (
                "a".to_string(),
                json!({"request": 1, "results": [{"id": 4, "score": 0.9}, {"id": 1, "score": 0.5}], "timings_ms": [1]}),
            ),
            (
                "b".to_string(),
                json!({"request": 1, "results": [{"id": 2, "score": 0.9}, {"id": 3, "score": 0.7}]}),
            ),
        ]);
        let m = merge_ranked(answers, "results", "score", "id", 3);
        let ids: Vec<u64> = m["results"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["id"].as_u64().unwrap())
            .collect();
        assert_eq!(ids, vec![2, 4, 3]);
        assert_eq!(m["results"][0]["region"], "b");
        assert!(m.get("timings_ms").is_none());
        assert_eq!(m["request"], 1);
    }

    #[test]
    fn a_query_reads_back_as_it_was_written_and_unknown_fields_are_refused() {
        let q = ShardQuery {
            tool: "find_objects".into(),
            args: json!({"text": "a bench"}),
            shard: Some(ShardPass::Find {
                norms: FindNorms {
                    target: Some(llm_tools::graph_find::Cut {
                        best: 0.8,
                        last: 0.1,
                    }),
                    anchors: vec![None],
                },
            }),
        };
        let text = serde_json::to_string(&q).unwrap();
        assert_eq!(serde_json::from_str::<ShardQuery>(&text).unwrap(), q);
        let unit: ShardQuery = serde_json::from_value(
            json!({"tool": "locate", "args": {}, "shard": {"pass": "locate_bests"}}),
        )
        .unwrap();
        assert_eq!(unit.shard, Some(ShardPass::LocateBests));
        assert!(
            serde_json::from_value::<ShardQuery>(
                json!({"tool": "locate", "shard": {"pass": "locate_hits", "bests": [], "x": 1}})
            )
            .is_err()
        );
        assert!(serde_json::from_value::<ShardQuery>(json!({"tool": "locate", "y": 2})).is_err());
    }

    #[test]
    fn the_best_cosines_of_the_regions_are_their_maximum() {
        let s = |b: Vec<Option<f64>>| LocateStats {
            bests: b,
            hits: vec![],
            segments: 0,
        };
        let v = [s(vec![Some(0.2), None]), s(vec![Some(0.5), Some(0.1)])];
        assert_eq!(max_bests(v.iter()), vec![Some(0.5), Some(0.1)]);
    }
}
