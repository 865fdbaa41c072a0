//! The zenoh front end of `opengraph serve --zenoh`: a thin adapter over the service.
//!
//! Under `opengraph/<map>` (or `opengraph/<map>/<region>` for one region of a sharded map):
//! - `…/events`: every change of the map as a JSON [`opengraph_service::events::MapEvent`]
//!   (`seq` consecutive, `commit` the store's commit sequence);
//! - `…/query` (queryable): `{"tool": NAME, "args": {...}}` with a read-only tool's name and
//!   the same arguments as `POST /api/tools/NAME`; the reply is the same answer, or
//!   `{"error": {"code", "message"}}` as an error reply;
//! - `…/graph` (queryable): the whole map as node-link JSON, for a late joiner;
//! - `…/status` (queryable): the live ingest counts and the map's summary.
//!
//! With live ingest on, the sensor topics are subscribed with rmw_zenoh key expressions
//! ([`og_zenoh::subscribe`]) and fed to [`opengraph_service::live`].

use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use opengraph_service::error::ToolError;
use opengraph_service::export::{ExportFormat, ExportRequest};
use opengraph_service::live::{LiveHandle, LiveRequest};
use opengraph_service::service::{Service, error_body};
use opengraph_service::shards::{ShardQuery, ShardTransport};
use serde_json::{Value as Json, json};
use zenoh::Wait;

/// What `serve --zenoh` runs.
#[derive(Debug, Clone)]
pub struct ZenohServe {
    /// How to open the session.
    pub session: og_zenoh::SessionOptions,
    /// The map's name in keys.
    pub map: String,
    /// The region this server holds, for a sharded map.
    pub region: Option<String>,
    /// Live ingest, when on.
    pub live: Option<LiveRequest>,
}

/// The running front end; [`ZenohFront::stop`] ends it.
pub struct ZenohFront {
    session: zenoh::Session,
    queryables: Vec<zenoh::query::Queryable<()>>,
    subscriptions: Arc<Mutex<Option<og_zenoh::subscribe::Subscriptions>>>,
    live: Option<LiveHandle>,
    events: tokio::task::JoinHandle<()>,
    _token: zenoh::liveliness::LivelinessToken,
    /// The key prefix served.
    pub prefix: String,
}

impl std::fmt::Debug for ZenohFront {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohFront")
            .field("prefix", &self.prefix)
            .field("queryables", &self.queryables.len())
            .field("live", &self.live.is_some())
            .finish_non_exhaustive()
    }
}

/// The read-only tools a zenoh query may call.
fn readable(tool: &str) -> bool {
    opengraph_service::tools::tools(false)
        .iter()
        .any(|t| t.name == tool)
        && !matches!(tool, "ask")
}

/// Replies `answer`; an error as its body with the server's `region`, if it has one (an
/// error reply names no key, so a fanned-out question could not tell whose it is).
fn reply_json(
    query: &zenoh::query::Query,
    key: &str,
    answer: Result<Json, ToolError>,
    region: Option<&str>,
) {
    let r = match answer {
        // the queryable's own key, not the query's (which may hold a wildcard over regions)
        Ok(v) => query.reply(key, v.to_string()).wait(),
        Err(e) => {
            let mut body = error_body(&e);
            if let Some(r) = region {
                body["region"] = Json::String(r.to_string());
            }
            query.reply_err(body.to_string()).wait()
        }
    };
    if let Err(e) = r {
        tracing::warn!(target: "opengraph::zenoh", "reply to {} failed: {e}", query.key_expr());
    }
}

/// A query's request: `{"tool": NAME, "args": {...}}`, with `"shard": {"pass": ...}` for a
/// pass of a fanned-out `find_objects` or `locate` ([`opengraph_service::shards`]).
///
/// # Errors
/// [`ToolError::BadArguments`] for a payload that is not such JSON, or a tool that is not
/// a read-only one.
pub fn parse_query(payload: Option<&[u8]>) -> Result<ShardQuery, ToolError> {
    let bad = |m: String| ToolError::BadArguments(m);
    let bytes = payload.ok_or_else(|| {
        bad("the query has no payload: send {\"tool\": NAME, \"args\": {...}}".into())
    })?;
    let v: Json = serde_json::from_slice(bytes).map_err(|e| {
        bad(format!(
            "the payload is not JSON (line {} column {}): {e}",
            e.line(),
            e.column()
        ))
    })?;
    let tool = v
        .get("tool")
        .and_then(Json::as_str)
        .ok_or_else(|| bad("the payload needs \"tool\": a read-only tool's name".into()))?;
    if !readable(tool) {
        return Err(ToolError::BadArguments(format!(
            "{tool:?} is not a read-only tool; zenoh queries take {}",
            opengraph_service::tools::tools(false)
                .iter()
                .filter(|t| readable(t.name))
                .map(|t| t.name.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let mut q: ShardQuery =
        serde_json::from_value(v).map_err(|e| bad(format!("the payload is not a query: {e}")))?;
    if q.args.is_null() {
        q.args = json!({});
    }
    Ok(q)
}

/// Starts the front end over `service` on `rt`: the session, the queryables, the event
/// publisher and, when asked, live ingest.
///
/// # Errors
/// A bad map or region name, a session zenoh cannot open, a declaration it refuses, or
/// what live ingest refuses (see [`opengraph_service::live::start`]).
pub fn start(
    service: Arc<Service>,
    cfg: ZenohServe,
    rt: tokio::runtime::Handle,
) -> Result<ZenohFront, ToolError> {
    for (what, name) in [("map", Some(&cfg.map)), ("region", cfg.region.as_ref())] {
        if let Some(n) = name
            && !og_zenoh::keys::is_chunk(n)
        {
            return Err(ToolError::Input(format!(
                "the {what} name {n:?} cannot be part of a zenoh key: use letters, digits, _, - and ."
            )));
        }
    }
    let session = cfg.session.open().map_err(|e| match e {
        og_zenoh::Error::Config(m) => ToolError::Input(m),
        other => ToolError::Failed(other.to_string()),
    })?;
    let prefix = og_zenoh::keys::map_prefix(&cfg.map, cfg.region.as_deref());
    let mut queryables = Vec::new();
    let z = |e: zenoh::Error| ToolError::Failed(format!("zenoh: {e}"));
    // read-only tools
    {
        let svc = service.clone();
        let rt = rt.clone();
        let region = cfg.region.clone();
        let key = format!("{prefix}/query");
        queryables.push(
            session
                .declare_queryable(key.clone())
                .callback(move |query: zenoh::query::Query| {
                    let parsed = parse_query(query.payload().map(|p| p.to_bytes()).as_deref());
                    let svc = svc.clone();
                    let region = region.clone();
                    let key = key.clone();
                    rt.spawn(async move {
                        let answer = match parsed {
                            Ok(ShardQuery {
                                tool,
                                args,
                                shard: Some(pass),
                            }) => svc.call_shard(&tool, args, pass).await,
                            Ok(q) => svc.call(&q.tool, q.args, false).await,
                            Err(e) => Err(e),
                        };
                        tokio::task::spawn_blocking(move || {
                            reply_json(&query, &key, answer, region.as_deref())
                        });
                    });
                })
                .wait()
                .map_err(z)?,
        );
    }
    // the whole map
    {
        let svc = service.clone();
        let rt = rt.clone();
        let key = format!("{prefix}/graph");
        queryables.push(
            session
                .declare_queryable(key.clone())
                .callback(move |query: zenoh::query::Query| {
                    let svc = svc.clone();
                    let key = key.clone();
                    rt.spawn(async move {
                        let out = svc
                            .export(ExportRequest::new(ExportFormat::NodeLink))
                            .await;
                        tokio::task::spawn_blocking(move || {
                            let r = match out {
                                Ok((_, bytes, _)) => query.reply(&key, bytes).wait(),
                                Err(e) => query.reply_err(error_body(&e).to_string()).wait(),
                            };
                            if let Err(e) = r {
                                tracing::warn!(target: "opengraph::zenoh", "graph reply failed: {e}");
                            }
                        });
                    });
                })
                .wait()
                .map_err(z)?,
        );
    }
    // live ingest
    let subscriptions: Arc<Mutex<Option<og_zenoh::subscribe::Subscriptions>>> = Arc::default();
    let live = match cfg.live {
        Some(req) => {
            let s = session.clone();
            let slot = subscriptions.clone();
            let live_cfg = req.live.clone();
            Some(opengraph_service::live::start(
                &service,
                req,
                Box::new(move |input| {
                    let subs = og_zenoh::subscribe::subscribe(&s, &live_cfg, input)
                        .map_err(|e| ToolError::Failed(e.to_string()))?;
                    tracing::info!(target: "opengraph::zenoh", "subscribed to {:?}", subs.keys);
                    *slot.lock().unwrap_or_else(PoisonError::into_inner) = Some(subs);
                    Ok(())
                }),
            )?)
        }
        None => None,
    };
    // status: live counts (the service's, see `Service::live_stats`) and the summary
    {
        let svc = service.clone();
        let rt = rt.clone();
        let region = cfg.region.clone();
        let key = format!("{prefix}/status");
        queryables.push(
            session
                .declare_queryable(key.clone())
                .callback(move |query: zenoh::query::Query| {
                    let svc = svc.clone();
                    let live = svc.live_stats();
                    let region = region.clone();
                    let key = key.clone();
                    rt.spawn(async move {
                        let info = svc.info().await;
                        let answer = info.map(|info| json!({"live": live, "info": info}));
                        tokio::task::spawn_blocking(move || {
                            reply_json(&query, &key, answer, region.as_deref())
                        });
                    });
                })
                .wait()
                .map_err(z)?,
        );
    }
    // events
    let events = {
        let mut rx = service.events().subscribe();
        let publisher = session
            .declare_publisher(format!("{prefix}/events"))
            .congestion_control(zenoh::qos::CongestionControl::Block)
            .wait()
            .map_err(z)?;
        rt.spawn(async move {
            loop {
                match rx.recv().await {
                    Ok(e) => {
                        let text = serde_json::to_string(&e).unwrap_or_default();
                        if let Err(err) = publisher.put(text).await {
                            tracing::warn!(target: "opengraph::zenoh", "event not published: {err}");
                        }
                    }
                    // a gap in seq tells subscribers
                    Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => {}
                    Err(tokio::sync::broadcast::error::RecvError::Closed) => break,
                }
            }
        })
    };
    let token = session
        .liveliness()
        .declare_token(format!("{prefix}/alive"))
        .wait()
        .map_err(z)?;
    Ok(ZenohFront {
        session,
        queryables,
        subscriptions,
        live,
        events,
        _token: token,
        prefix,
    })
}

impl ZenohFront {
    /// The live ingest counts, when live ingest is on.
    pub fn live_stats(&self) -> Option<ingest::sources::live::LiveStats> {
        self.live.as_ref().map(LiveHandle::stats)
    }

    /// Stops: the sensor subscribers first, then live ingest (what was received is mapped
    /// and finished), then the queryables and the session.
    ///
    /// # Errors
    /// Live ingest failed, or zenoh cannot close the session.
    pub fn stop(mut self) -> anyhow::Result<Option<ingest::build::BuildReport>> {
        drop(
            self.subscriptions
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .take(),
        );
        let report = self.live.take().map(LiveHandle::stop).transpose()?;
        // let the last events go out
        std::thread::sleep(Duration::from_millis(100));
        self.events.abort();
        self.queryables.clear();
        self.session
            .close()
            .wait()
            .map_err(|e| anyhow::anyhow!("zenoh: {e}"))?;
        Ok(report)
    }
}

/// The regions of a sharded map over zenoh: a fanned-out question is one query on
/// `opengraph/<map>/*/query`, each region's queryable answering; the regions there are
/// the liveliness tokens `opengraph/<map>/*/alive`.
#[derive(Debug)]
pub struct ZenohShards {
    session: zenoh::Session,
    map: String,
}

impl ZenohShards {
    /// Over `session`, for the map named `map`.
    ///
    /// # Errors
    /// [`ToolError::BadArguments`] for a map name that cannot be a key chunk.
    pub fn new(session: zenoh::Session, map: &str) -> Result<ZenohShards, ToolError> {
        if !og_zenoh::keys::is_chunk(map) {
            return Err(ToolError::BadArguments(format!(
                "the map name {map:?} cannot be part of a zenoh key: use letters, digits, _, - and ."
            )));
        }
        Ok(ZenohShards {
            session,
            map: map.to_string(),
        })
    }

    /// The region of a key under `opengraph/<map>/<region>/...`.
    fn region_of(&self, key: &str) -> Option<String> {
        let rest = key.strip_prefix(&format!("opengraph/{}/", self.map))?;
        let (region, _) = rest.split_once('/')?;
        og_zenoh::keys::is_chunk(region).then(|| region.to_string())
    }
}

impl ShardTransport for ZenohShards {
    fn ask(
        &self,
        query: &ShardQuery,
        deadline: Duration,
    ) -> Vec<(String, Result<Json, ToolError>)> {
        let payload = match serde_json::to_vec(query) {
            Ok(p) => p,
            Err(e) => {
                tracing::warn!(target: "opengraph::zenoh", "query not encoded: {e}");
                return Vec::new();
            }
        };
        let replies = match self
            .session
            .get(format!("opengraph/{}/*/query", self.map))
            .payload(payload)
            .consolidation(zenoh::query::ConsolidationMode::None)
            .target(zenoh::query::QueryTarget::All)
            .timeout(deadline)
            .wait()
        {
            Ok(r) => r,
            Err(e) => {
                tracing::warn!(target: "opengraph::zenoh", "query not sent: {e}");
                return Vec::new();
            }
        };
        let mut out = Vec::new();
        while let Ok(reply) = replies.recv() {
            match reply.result() {
                Ok(sample) => {
                    let Some(region) = self.region_of(sample.key_expr().as_str()) else {
                        continue;
                    };
                    let answer = serde_json::from_slice::<Json>(&sample.payload().to_bytes())
                        .map_err(|e| {
                            ToolError::Failed(format!("region {region} sent no JSON: {e}"))
                        });
                    out.push((region, answer));
                }
                Err(err) => {
                    // an error reply names no key: its body says which region when it can
                    let body: Json =
                        serde_json::from_slice(&err.payload().to_bytes()).unwrap_or_default();
                    let region = body["region"].as_str().map(str::to_string);
                    match region {
                        Some(r) => out.push((r, Err(ToolError::from_body(&body)))),
                        None => tracing::warn!(
                            target: "opengraph::zenoh",
                            "an error reply without its region: {body}"
                        ),
                    }
                }
            }
        }
        out
    }

    fn regions(&self, deadline: Duration) -> Vec<String> {
        let mut out = std::collections::BTreeSet::new();
        if let Ok(replies) = self
            .session
            .liveliness()
            .get(format!("opengraph/{}/*/alive", self.map))
            .timeout(deadline)
            .wait()
        {
            while let Ok(reply) = replies.recv() {
                if let Ok(sample) = reply.result()
                    && let Some(r) = self.region_of(sample.key_expr().as_str())
                {
                    out.insert(r);
                }
            }
        }
        out.into_iter().collect()
    }
}
