//! Cypher through the tools: `read_cypher` (read-only by the parser, answers shared until the
//! next commit) and `write_cypher`, with the time, row, memory and answer-size limits of one
//! statement.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use graphstore::cypher::JsonForm;
use serde_json::Value as Json;

use crate::error::{ToolError, ToolResult, failed};
use crate::ops::{CypherAnswer, CypherStats, PlanStep};
use crate::toolbox::Toolbox;

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

/// Time a Cypher call may take.
pub const CYPHER_TIMEOUT: Duration = Duration::from_secs(10);

impl Toolbox {
    pub(crate) fn cypher(
        &self,
        query: &str,
        params: Option<&serde_json::Map<String, Json>>,
        read_only: bool,
        form: JsonForm,
    ) -> ToolResult<Json> {
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
                    format!(
                        "{}{}",
                        if form == JsonForm::Full { "full " } else { "" },
                        params
                            .map(|m| serde_json::to_string(m).unwrap_or_default())
                            .unwrap_or_default()
                    ),
                );
                let seq = self.store.commit_seq();
                // an error (a timeout too) is shared with those who waited for it, not kept
                // the leader's statement ends by its own time limit, a little past it; a waiter
                // that gave up just before would run the whole statement again
                let wait = CYPHER_TIMEOUT + Duration::from_secs(5);
                let answer = c.get_or_compute(key, seq, wait, || {
                    let out = self.cypher_uncached(query, params, read_only, form);
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
            _ => self.cypher_uncached(query, params, read_only, form),
        }
    }

    fn cypher_uncached(
        &self,
        query: &str,
        params: Option<&serde_json::Map<String, Json>>,
        read_only: bool,
        form: JsonForm,
    ) -> ToolResult<Json> {
        let mut p = BTreeMap::new();
        if let Some(m) = params {
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
            ground_axes: scene::records::ground_axes(&self.store),
            ..graphstore::cypher::QueryOptions::default()
        };
        let r = self.store.query(query, &opts).map_err(|e| match e {
            graphstore::Error::Query(ref q)
                if q.kind == graphstore::cypher::ErrorKind::Timeout =>
            {
                ToolError::TimedOut(format!(
                    "the Cypher statement ran past its {} s limit{}; narrow the pattern or add LIMIT",
                    CYPHER_TIMEOUT.as_secs(),
                    q.pos
                        .map(|p| format!(" (at line {}, column {})", p.line, p.col))
                        .unwrap_or_default()
                ))
            }
            graphstore::Error::Query(ref q)
                if q.kind == graphstore::cypher::ErrorKind::Constraint =>
            {
                ToolError::Constraint(e.to_string())
            }
            graphstore::Error::Query(_) | graphstore::Error::InvalidValue(_) => {
                ToolError::BadArguments(e.to_string())
            }
            graphstore::Error::Constraint { .. }
            | graphstore::Error::Schema(_)
            | graphstore::Error::NodeHasRelationships { .. } => ToolError::Constraint(e.to_string()),
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
        let rows = match r.rows_json_as(form) {
            Json::Array(rows) => rows
                .into_iter()
                .map(|row| match row {
                    Json::Object(m) => m,
                    _ => serde_json::Map::new(),
                })
                .collect(),
            _ => Vec::new(),
        };
        let plan = r
            .plan_json()
            .map(serde_json::from_value::<Vec<PlanStep>>)
            .transpose()
            .map_err(failed)?;
        let answer = CypherAnswer {
            columns: r.columns.clone(),
            rows,
            row_count: r.rows.len() as u64,
            stats: CypherStats {
                nodes_created: r.stats.nodes_created,
                nodes_deleted: r.stats.nodes_deleted,
                relationships_created: r.stats.relationships_created,
                relationships_deleted: r.stats.relationships_deleted,
                properties_set: r.stats.properties_set,
            },
            plan,
        };
        serde_json::to_value(answer).map_err(failed)
    }
}
