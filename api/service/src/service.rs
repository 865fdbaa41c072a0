//! The service every network front end calls: a pool of [`Toolbox`]es over one store, so
//! that requests run side by side (each on its own read snapshot), bounded in number and in
//! time. The HTTP server (`api::http`) and the MCP server (`api::mcp`) are adapters over
//! it; neither holds logic of its own.
//!
//! Writes: the store has one writer at a time (redb); write tools run only for callers that
//! presented the write token (`may_write`), and every worker loads the new scene after a
//! write (scenes are kept by the store's commit sequence; see [`Toolbox::fork`]). A service
//! given a writer ([`Service::with_writer`]) runs the write tools on it alone, so a commit
//! waiting on the disk never holds a reader's worker: many readers and one writer.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use graphstore::{GraphRead, Store};
use serde_json::{Value as Json, json};
use tokio::sync::Semaphore;

use crate::tools::{Tool, ToolError, ToolResult, Toolbox};

/// A language model shared by the requests that need one (`ask`), one at a time.
type SharedModel = Arc<Mutex<Box<dyn llm_tools::ChatModel>>>;

/// How long one `ask` may take: a local model needs seconds per step.
pub const ASK_TIMEOUT: Duration = Duration::from_secs(300);

/// Toolboxes that take turns: a permit for each.
struct WorkerPool {
    idle: Arc<Mutex<Vec<Toolbox>>>,
    permits: Arc<Semaphore>,
    size: usize,
}

impl WorkerPool {
    fn new(toolboxes: Vec<Toolbox>) -> WorkerPool {
        WorkerPool {
            size: toolboxes.len(),
            permits: Arc::new(Semaphore::new(toolboxes.len())),
            idle: Arc::new(Mutex::new(toolboxes)),
        }
    }
}

/// A pool of toolboxes over one store.
pub struct Service {
    llm: Option<SharedModel>,
    store: Store,
    readers: WorkerPool,
    /// The write tools' own toolbox, when the service has one.
    writer: Option<WorkerPool>,
    writes: bool,
    timeout: Duration,
    events: crate::events::EventBus,
    /// The counts of live ingest into this service's store, while one runs.
    live: std::sync::Mutex<Option<crate::live::LiveWatch>>,
}

impl std::fmt::Debug for Service {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Service")
            .field("llm", &self.llm.is_some())
            .field("store", &self.store.path())
            .field("workers", &self.readers.size)
            .field("writer", &self.writer.is_some())
            .field("writes", &self.writes)
            .field("timeout", &self.timeout)
            .finish()
    }
}

impl Service {
    /// A service over these toolboxes (one per worker, made with [`Toolbox::fork`] so that
    /// they share one store). `timeout` bounds each call: the wait for a free worker and the
    /// work itself.
    ///
    /// # Panics
    /// Never; an empty list is refused by returning `None`.
    pub fn new(toolboxes: Vec<Toolbox>, timeout: Duration) -> Option<Arc<Service>> {
        let first = toolboxes.first()?;
        let store = first.store().clone();
        let writes = first.writes();
        Some(Arc::new(Service {
            llm: None,
            store,
            readers: WorkerPool::new(toolboxes),
            writer: None,
            writes,
            timeout,
            events: crate::events::EventBus::default(),
            live: std::sync::Mutex::new(None),
        }))
    }

    /// [`Service::new`] with a language model for `ask`.
    pub fn with_llm(
        toolboxes: Vec<Toolbox>,
        timeout: Duration,
        llm: Box<dyn llm_tools::ChatModel>,
    ) -> Option<Arc<Service>> {
        let s = Service::new(toolboxes, timeout)?;
        let mut s = Arc::into_inner(s)?;
        s.llm = Some(Arc::new(Mutex::new(llm)));
        Some(Arc::new(s))
    }

    /// The service with `writer` (a [`Toolbox::fork`] of the others) for the write tools alone,
    /// so that a write, which waits for the disk at its commit, never holds a reader's worker.
    /// `None` when the service is already shared.
    pub fn with_writer(self: Arc<Self>, writer: Toolbox) -> Option<Arc<Service>> {
        let mut s = Arc::into_inner(self)?;
        s.writer = Some(WorkerPool::new(vec![writer]));
        Some(Arc::new(s))
    }

    /// The language model's id, when the service has one.
    pub fn llm_id(&self) -> Option<String> {
        self.llm
            .as_ref()
            .map(|m| m.lock().unwrap_or_else(|e| e.into_inner()).model_id())
    }

    /// `ask` ([`crate::ask::ask`]): the question read as one task by the service's model, or
    /// by the rule parser when it has none, and answered from a worker's tools (the agent
    /// loop, with at most `max_steps` tool calls, only for a question no task fits). The
    /// write tools are offered to the model only when the caller may write.
    ///
    /// # Errors
    /// [`ToolError::BadArguments`] for an empty question; the model's failures;
    /// [`ToolError::TimedOut`] past [`ASK_TIMEOUT`].
    pub async fn ask(self: &Arc<Self>, args: &Json, may_write: bool) -> ToolResult<Json> {
        let req = crate::ops::check_ask(args)?;
        let (question, max_steps) = (req.question, req.max_steps as usize);
        let llm = self.llm.clone();
        self.run_for(ASK_TIMEOUT.max(self.timeout), move |tb| {
            let mut guard = llm
                .as_ref()
                .map(|l| l.lock().unwrap_or_else(|e| e.into_inner()));
            let model = guard
                .as_mut()
                .map(|m| m.as_mut() as &mut dyn llm_tools::ChatModel);
            let writes = tb.writes();
            tb.set_writes(writes && may_write);
            let out = crate::ask::ask(model, tb, &question, max_steps);
            tb.set_writes(writes);
            let a = out?;
            serde_json::to_value(a).map_err(|e| ToolError::Failed(e.to_string()))
        })
        .await
    }

    /// The store (for operations that need no toolbox, like reading points).
    pub fn store(&self) -> &Store {
        &self.store
    }

    /// Whether the write tools exist on this service (a token is configured and the store is
    /// open for writing).
    pub fn writes(&self) -> bool {
        self.writes
    }

    /// The request timeout.
    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    /// The tools a caller sees: the write tools only where the service has them.
    pub fn tools(&self) -> Vec<Tool> {
        crate::tools::tools(self.writes)
    }

    /// Calls a tool on a free worker (a write tool on the writer, where the service has one).
    ///
    /// # Errors
    /// [`ToolError::Forbidden`] for a call that changes the map without `may_write` (an
    /// `update_map` proposal, without `apply`, needs none); [`ToolError::Busy`] when
    /// no worker is free within the timeout; [`ToolError::TimedOut`] when the call runs past
    /// it (the worker finishes in the background and rejoins the pool); otherwise the tool's
    /// own error.
    pub async fn call(
        self: &Arc<Self>,
        name: &str,
        args: Json,
        may_write: bool,
    ) -> ToolResult<Json> {
        // a write tool exists only where the service has writes (elsewhere: an unknown tool);
        // there it runs on the writer, and needs the token unless it only proposes
        let writes = self.writes && crate::tools::is_write_tool(name);
        if writes && !may_write && crate::tools::call_writes(name, &args) {
            return Err(ToolError::Forbidden(format!(
                "{name} changes the map: send the write token (Authorization: Bearer <token>)"
            )));
        }
        let name = name.to_string();
        let pool = match &self.writer {
            Some(w) if writes => w,
            _ => &self.readers,
        };
        let tool = name.clone();
        let answer = self
            .run_on(pool, self.timeout, move |tb| tb.call(&name, &args))
            .await?;
        if writes
            && let Some(e) =
                crate::events::EventBus::of_tool(&tool, &answer, self.store.commit_seq())
        {
            self.events.emit(e);
        }
        Ok(answer)
    }

    /// One pass of a `find_objects` or `locate` fanned out over region shards
    /// ([`crate::shards`]), on a reader.
    ///
    /// # Errors
    /// As [`crate::toolbox::Toolbox::call_shard`]; busy or timed out as [`Service::call`].
    pub async fn call_shard(
        self: &Arc<Self>,
        name: &str,
        args: Json,
        pass: crate::shards::ShardPass,
    ) -> ToolResult<Json> {
        let name = name.to_string();
        self.run_on(&self.readers, self.timeout, move |tb| {
            tb.call_shard(&name, &args, &pass)
        })
        .await
    }

    /// The map's change events ([`crate::events`]).
    pub fn events(&self) -> &crate::events::EventBus {
        &self.events
    }

    /// The map's summary (`opengraph info --json`): node and relationship counts.
    ///
    /// # Errors
    /// The store fails.
    pub async fn info(self: &Arc<Self>) -> ToolResult<Json> {
        let mut v = self
            .run(|tb| crate::info::value(tb.store()).map_err(|e| ToolError::Failed(e.to_string())))
            .await?;
        if let Some(stats) = self.live_stats() {
            v["live"] = serde_json::to_value(stats).unwrap_or_default();
        }
        Ok(v)
    }

    /// The counts of live ingest into this store ([`crate::live::start`]), while one runs.
    pub fn live_stats(&self) -> Option<ingest::sources::live::LiveStats> {
        self.live
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .as_ref()
            .map(crate::live::LiveWatch::stats)
    }

    /// Live ingest into this store started (`Some`) or stopped (`None`).
    pub(crate) fn set_live(&self, watch: Option<crate::live::LiveWatch>) {
        *self
            .live
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = watch;
    }

    /// The whole map exported in a one-file format ([`crate::export`]), as bytes, with its
    /// content type and what was written.
    ///
    /// # Errors
    /// [`ToolError::BadArguments`] for a format that writes a folder (`neo4j-csv`) or a map
    /// without what the format needs; the store fails.
    pub async fn export(
        self: &Arc<Self>,
        req: crate::export::ExportRequest,
    ) -> ToolResult<(&'static str, Vec<u8>, crate::export::ExportAnswer)> {
        self.run(move |tb| {
            let r = tb
                .store()
                .read()
                .map_err(|e| ToolError::Failed(e.to_string()))?;
            let mut out = Vec::new();
            let a = crate::export::export(&r, &req, crate::export::ExportTarget::Writer(&mut out))?;
            Ok((req.format.content_type(), out, a))
        })
        .await
    }

    /// What the web viewer draws ([`crate::view::view`]).
    ///
    /// # Errors
    /// The store fails or has no ground frame.
    pub async fn view(self: &Arc<Self>) -> ToolResult<Json> {
        self.run(|tb| crate::view::view(tb.store()).map_err(ToolError::Failed))
            .await
    }

    /// One instance's points as little-endian float32 `x y z` triples (12 bytes a point, world
    /// frame, metres), and how many there are.
    ///
    /// # Errors
    /// [`ToolError::NotFound`] when no node has the id, [`ToolError::BadArguments`] when it
    /// is not an Instance.
    pub async fn points(self: &Arc<Self>, id: u64) -> ToolResult<(usize, Vec<u8>)> {
        self.run(move |tb| {
            let failed = |e: graphstore::Error| ToolError::Failed(e.to_string());
            let r = tb.store().read().map_err(failed)?;
            crate::area::instance_node(&r, id)?;
            let pc = r
                .point_cloud(id, scene::payload::POINTS)
                .map_err(failed)?
                .unwrap_or_default();
            let mut bytes = Vec::with_capacity(pc.xyz.len() * 12);
            for p in &pc.xyz {
                for c in p {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
            Ok((pc.xyz.len(), bytes))
        })
        .await
    }

    /// Runs `f` on a free toolbox off the async workers, within the timeout.
    async fn run<T: Send + 'static>(
        self: &Arc<Self>,
        f: impl FnOnce(&mut Toolbox) -> ToolResult<T> + Send + 'static,
    ) -> ToolResult<T> {
        self.run_for(self.timeout, f).await
    }

    /// [`Service::run`] with its own time limit for the work.
    async fn run_for<T: Send + 'static>(
        self: &Arc<Self>,
        limit: Duration,
        f: impl FnOnce(&mut Toolbox) -> ToolResult<T> + Send + 'static,
    ) -> ToolResult<T> {
        self.run_on(&self.readers, limit, f).await
    }

    /// Runs `f` on a free toolbox of `pool` off the async workers: the wait for it is bounded
    /// by the request timeout, the work by `limit`.
    async fn run_on<T: Send + 'static>(
        &self,
        pool: &WorkerPool,
        limit: Duration,
        f: impl FnOnce(&mut Toolbox) -> ToolResult<T> + Send + 'static,
    ) -> ToolResult<T> {
        let secs = self.timeout.as_secs_f64();
        let permit = tokio::time::timeout(self.timeout, pool.permits.clone().acquire_owned())
            .await
            .map_err(|_| {
                ToolError::Busy(format!(
                    "all {} workers stayed busy for {secs:.0} s; try again later",
                    pool.size
                ))
            })?
            .map_err(|_| ToolError::Failed("the service is shutting down".into()))?;
        let idle = pool.idle.clone();
        let job = tokio::task::spawn_blocking(move || {
            let mut tb = idle
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .pop()
                .expect("a permit guarantees an idle toolbox");
            let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(&mut tb)));
            idle.lock().unwrap_or_else(|e| e.into_inner()).push(tb);
            drop(permit);
            out.unwrap_or_else(|_| Err(ToolError::Failed("the operation panicked".into())))
        });
        match tokio::time::timeout(limit, job).await {
            Ok(Ok(answer)) => answer,
            Ok(Err(e)) => Err(ToolError::Failed(e.to_string())),
            Err(_) => Err(ToolError::TimedOut(format!(
                "the request took longer than {:.0} s",
                limit.as_secs_f64()
            ))),
        }
    }
}

/// The error body every HTTP route answers: `{"error": {"code", "message"}}`.
pub fn error_body(e: &ToolError) -> Json {
    json!({"error": {"code": e.code(), "message": e.to_string()}})
}

/// Who may write: everyone the adapter serves (stdio MCP with `--allow-writes`: the one local
/// client), or only requests that carry the token.
#[derive(Clone)]
pub enum WriteGate {
    /// No write check beyond the service's own `writes`.
    Open,
    /// `Authorization: Bearer <token>` must match.
    Token(Arc<str>),
}

impl std::fmt::Debug for WriteGate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WriteGate::Open => f.write_str("Open"),
            WriteGate::Token(_) => f.write_str("Token(..)"),
        }
    }
}

impl WriteGate {
    /// Whether a request with this `Authorization` header value may write. The token is
    /// compared in constant time (`subtle`).
    pub fn allows(&self, authorization: Option<&str>) -> bool {
        match self {
            WriteGate::Open => true,
            WriteGate::Token(token) => {
                let Some(given) = authorization.and_then(|h| h.strip_prefix("Bearer ")) else {
                    return false;
                };
                use subtle::ConstantTimeEq;
                // equal lengths first (the length of a token is not the secret)
                !token.is_empty()
                    && given.len() == token.len()
                    && bool::from(given.as_bytes().ct_eq(token.as_bytes()))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{demo_store, hash_finder};
    use llm_tools::chat::scripted::{Reply, Scripted};
    use serde_json::json;

    /// `ask` offers the write tools to the model only for a caller that may write: for an
    /// unauthenticated caller `write_cypher` is not among the offered tools and nothing is
    /// written; with the token the same call writes.
    #[test]
    fn ask_withholds_the_write_tools_from_callers_without_the_token() {
        let (_dir, store) = demo_store();
        let finder = hash_finder();
        let tb = Toolbox::new(store.clone(), finder, true);
        let script = || {
            Box::new(Scripted::new(
                "script",
                vec![
                    // the task form: nothing a task fits, so the agent loop runs
                    Reply::Text("no task".into()),
                    Reply::Tools(vec![(
                        "write_cypher".into(),
                        serde_json::json!({"query": "CREATE (:Hack)"}),
                    )]),
                    Reply::Text("done".into()),
                ],
            )) as Box<dyn llm_tools::ChatModel>
        };
        let count = |s: &Store| {
            s.query(
                "MATCH (n:Hack) RETURN count(n) AS n",
                &graphstore::cypher::QueryOptions::default(),
            )
            .unwrap()
            .rows_json()[0]["n"]
                .as_u64()
                .unwrap()
        };
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap();
        let svc = Service::with_llm(vec![tb], Duration::from_secs(30), script()).unwrap();
        // the request the model gets does not offer write_cypher (the scripted model checks
        // its calls against the offered tools, as a grammar-constrained local model must)
        let e = rt
            .block_on(svc.ask(
                &serde_json::json!({"question": "make a node", "max_steps": 3}),
                false,
            ))
            .unwrap_err();
        assert!(e.to_string().contains("does not offer"), "{e}");
        assert_eq!(count(&store), 0);
        // the toolbox offers writes again afterwards, to a caller with the token
        drop(svc);
        let finder = hash_finder();
        let tb = Toolbox::new(store.clone(), finder, true);
        let svc = Service::with_llm(vec![tb], Duration::from_secs(30), script()).unwrap();
        let a = rt
            .block_on(svc.ask(
                &serde_json::json!({"question": "make a node", "max_steps": 3}),
                true,
            ))
            .unwrap();
        assert_eq!(a["steps"][0]["is_error"], false, "{a}");
        assert_eq!(count(&store), 1);
        // without a model, the rule parser reads the question; one no task fits is not
        // understood, and says which forms are
        let finder = hash_finder();
        let svc = Service::new(
            vec![Toolbox::new(store, finder, false)],
            Duration::from_secs(5),
        )
        .unwrap();
        let a = rt
            .block_on(svc.ask(
                &serde_json::json!({"question": "hi", "max_steps": 2}),
                false,
            ))
            .unwrap();
        assert_eq!(a["model"], "rules", "{a}");
        assert!(a["answer"].is_null(), "{a}");
        assert!(
            a["stopped"].as_str().unwrap().contains("not understood"),
            "{a}"
        );
    }

    /// With a writer, a write runs while every reader is busy: it does not queue behind them.
    #[test]
    fn writes_run_on_the_writer_while_the_readers_are_busy() {
        let (_dir, store) = demo_store();
        let reader = Toolbox::new(store.clone(), hash_finder(), true);
        let writer = reader.fork(hash_finder());
        let svc = Service::new(vec![reader], Duration::from_secs(60))
            .unwrap()
            .with_writer(writer)
            .unwrap();
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async {
            // the only reader scans for seconds
            let slow = {
                let svc = svc.clone();
                tokio::spawn(async move {
                    let q = json!({"query": "UNWIND range(1, 950) AS a UNWIND range(1, 950) AS b WITH a WHERE a = 0 RETURN count(*) AS n"});
                    svc.call("read_cypher", q, false).await
                })
            };
            let t = std::time::Instant::now();
            while svc.readers.permits.available_permits() > 0 {
                assert!(t.elapsed() < Duration::from_secs(10), "the read never began");
                tokio::time::sleep(Duration::from_millis(1)).await;
            }
            let w = tokio::time::timeout(
                Duration::from_secs(5),
                svc.call(
                    "write_cypher",
                    json!({"query": "CREATE (:Note {text: 'written while reading'})"}),
                    true,
                ),
            )
            .await
            .expect("the write waited for the reader")
            .unwrap();
            assert_eq!(w["stats"]["nodes_created"], 1, "{w}");
            assert!(!slow.is_finished(), "the read ended first: the test proves nothing");
            // a write without the token is refused before any worker is asked
            let e = svc
                .call("write_cypher", json!({"query": "CREATE (:Hack)"}), false)
                .await
                .unwrap_err();
            assert_eq!(e.http_status(), 401);
            let _ = tokio::time::timeout(Duration::from_secs(30), slow).await;
        });
    }

    #[test]
    fn the_token_must_match_exactly() {
        let g = WriteGate::Token(Arc::from("s3cret-token"));
        assert!(g.allows(Some("Bearer s3cret-token")));
        for bad in [
            None,
            Some(""),
            Some("s3cret-token"),
            Some("Bearer s3cret-toke"),
            Some("Bearer s3cret-token "),
            Some("bearer s3cret-token"),
            Some("Bearer S3cret-token"),
        ] {
            assert!(!g.allows(bad), "{bad:?}");
        }
        assert!(WriteGate::Open.allows(None));
    }
}
