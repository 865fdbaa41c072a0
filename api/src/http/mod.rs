//! The HTTP adapter (`opengraph serve`): axum routes over the [`Service`], the OpenAPI 3.1
//! document at `/openapi.json` (built with utoipa from the same route table the router is
//! built from), and MCP over streamable HTTP at `/mcp`.
//!
//! Every answer is JSON; an error is `{"error": {"code", "message"}}` with the status of
//! [`ToolError::http_status`]. Instance points are binary: `application/octet-stream`,
//! little-endian float32 `x y z` per point (12 bytes, world frame, metres), the count in the
//! `X-Point-Count` header.
//!
//! Security: binds loopback unless told otherwise, and a non-loopback bind needs a token
//! ([`check_bind`]); writes need `Authorization: Bearer <token>`; read routes run read-only
//! Cypher (decided by the parser); request bodies are capped, requests are bounded in time
//! and in number; CORS is off unless origins are configured.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{DefaultBodyLimit, Path, State};
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{MethodFilter, on};
use axum::{Json, Router};
use serde_json::{Value as JsonValue, json};
use tokio::sync::Semaphore;
use utoipa::openapi::path::{
    HttpMethod, OperationBuilder, ParameterBuilder, ParameterIn, PathItem, PathsBuilder,
};
use utoipa::openapi::request_body::RequestBodyBuilder;
use utoipa::openapi::response::ResponseBuilder;
use utoipa::openapi::{
    ContentBuilder, InfoBuilder, ObjectBuilder, OpenApiBuilder, Ref, Required, Type,
};

use crate::mcp::McpServer;
use crate::service::{Service, WriteGate, error_body};
use crate::tools::ToolError;

mod accept;
mod guard;
mod openapi;
pub use accept::*;
use guard::*;
pub use openapi::*;

/// The viewer page (HTML, no external resources).
pub const PAGE_HTML: &str = include_str!("../../web/index.html");
/// The viewer's script.
pub const VIEWER_JS: &str = include_str!("../../web/viewer.js");

/// Server settings; [`ServeOptions::default`] is what `opengraph serve` uses without flags.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// Where to listen (default 127.0.0.1:7878).
    pub bind: SocketAddr,
    /// The write token; `None` means the server is read-only.
    pub token: Option<String>,
    /// The largest request body in bytes (default 1 MiB).
    pub body_limit_bytes: usize,
    /// Requests in progress at once; more are answered 503 at once (default 64).
    pub max_concurrent: usize,
    /// Origins allowed to call the API from a browser (CORS); empty: CORS off.
    pub cors_origins: Vec<String>,
    /// `Host` names (without port) a request may carry besides the loopback names
    /// (`localhost`, `127.0.0.1`, `[::1]`) and the bind address; any other `Host` is refused
    /// with 403 on every route, so a DNS-rebinding page cannot read the map.
    pub allowed_hosts: Vec<String>,
    /// Time a client has to send a request's headers, and to start the next request on a
    /// kept-alive connection; the connection is closed after it (default 10 s).
    pub header_timeout: Duration,
    /// Time a client has to send a whole request body (default 10 s); past it: 408 and the
    /// connection is closed. A request holds no request slot while its body arrives.
    pub body_timeout: Duration,
    /// Open connections at most; more are answered 503 and closed at once (default 1024).
    pub max_connections: usize,
    /// Open connections from one client address at most (default 256).
    pub max_connections_per_client: usize,
}

impl Default for ServeOptions {
    fn default() -> ServeOptions {
        ServeOptions {
            bind: SocketAddr::from(([127, 0, 0, 1], 7878)),
            token: None,
            body_limit_bytes: 1 << 20,
            max_concurrent: 64,
            cors_origins: Vec::new(),
            allowed_hosts: Vec::new(),
            header_timeout: Duration::from_secs(10),
            body_timeout: Duration::from_secs(10),
            max_connections: 1024,
            max_connections_per_client: 256,
        }
    }
}

/// Refuses a bind that would expose writes or the map without a token: any non-loopback
/// address needs one.
///
/// # Errors
/// A message for the user (exit 2).
pub fn check_bind(bind: &SocketAddr, token: Option<&str>) -> Result<(), String> {
    if !bind.ip().is_loopback() && token.is_none() {
        return Err(format!(
            "refusing to serve on {bind} without a token: other machines could reach the map. \
             Pass --token-file FILE (and send Authorization: Bearer <token> for writes), or bind 127.0.0.1"
        ));
    }
    Ok(())
}

/// What a route does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    /// Liveness (outside the request gate).
    Health,
    /// Readiness (outside the request gate).
    Ready,
    /// The map's summary.
    Info,
    /// The tool list.
    Tools,
    /// Any tool by name (`/api/tools/{name}`), the body its arguments.
    CallTool,
    /// One tool, the JSON body its arguments.
    Tool(&'static str),
    /// One tool without a body; `{id}` in the path becomes this argument.
    ToolGet(&'static str, Option<&'static str>),
    /// An instance's points, binary.
    Points,
    /// This document.
    OpenApi,
    /// The web viewer's page.
    Page,
    /// The web viewer's script.
    Script,
    /// What the viewer draws.
    View,
    /// The whole map exported (`{format}`: node-link, graphml, geojson, spark-dsg or ply).
    Export,
    /// A question answered by the server's language model calling the tools.
    Ask,
}

/// One route: method, path, operation, summary.
struct Route {
    method: HttpMethod,
    path: &'static str,
    op: Op,
    summary: &'static str,
}

/// Every route; the router and the OpenAPI document are both built from this table.
fn routes() -> Vec<Route> {
    use HttpMethod::{Get, Post};
    let r = |method, path, op, summary| Route {
        method,
        path,
        op,
        summary,
    };
    vec![
        r(
            Get,
            "/healthz",
            Op::Health,
            "Liveness: {\"status\": \"ok\"}.",
        ),
        r(
            Get,
            "/readyz",
            Op::Ready,
            "Readiness: 200 {\"status\": \"ready\"} while a request slot is free, else 503.",
        ),
        r(
            Get,
            "/openapi.json",
            Op::OpenApi,
            "This OpenAPI 3.1 document.",
        ),
        r(
            Get,
            "/",
            Op::Page,
            "The web viewer: a bird's-eye view of the map with find, locate and route.",
        ),
        r(Get, "/viewer.js", Op::Script, "The web viewer's script."),
        r(
            Get,
            "/api/view",
            Op::View,
            "What the viewer draws: instance points on the ground plane (subsampled), lane polylines, segment outlines, class colours.",
        ),
        r(
            Get,
            "/api/info",
            Op::Info,
            "The map's summary: node and relationship counts, environment, build metadata.",
        ),
        r(
            Get,
            "/api/schema",
            Op::ToolGet("get_schema", None),
            "Labels, relationship types, counts, indexes, and what each layer means.",
        ),
        r(
            Get,
            "/api/tools",
            Op::Tools,
            "The agent tools with their JSON Schemas (the write tools only when the server has a token).",
        ),
        r(
            Post,
            "/api/tools/{name}",
            Op::CallTool,
            "Call any agent tool by name; the body is its arguments.",
        ),
        r(
            Post,
            "/api/cypher",
            Op::Tool("read_cypher"),
            "Run a Cypher read (read-only by the parser; 10 s, 1000 rows).",
        ),
        r(
            Post,
            "/api/cypher/write",
            Op::Tool("write_cypher"),
            "Run a Cypher write as one transaction (needs the token).",
        ),
        r(
            Post,
            "/api/find",
            Op::Tool("find_objects"),
            "Find objects from a request in words, with evidence.",
        ),
        r(
            Post,
            "/api/locate",
            Op::Tool("locate"),
            "Road segments for a description of the surroundings.",
        ),
        r(
            Post,
            "/api/route",
            Op::Tool("plan_route"),
            "A route between two ends given in words or as specs.",
        ),
        r(
            Post,
            "/api/update",
            Op::Tool("update_map"),
            "Propose (and with apply, commit) a map edit from a described change (applying needs the token).",
        ),
        r(
            Post,
            "/api/update/undo",
            Op::Tool("undo_map_edit"),
            "Undo an applied map edit exactly (needs the token).",
        ),
        r(
            Get,
            "/api/segments",
            Op::ToolGet("describe_area", None),
            "The environment and every road segment with counts.",
        ),
        r(
            Get,
            "/api/segments/{id}",
            Op::ToolGet("describe_area", Some("segment_id")),
            "One segment's objects by class and its notable objects.",
        ),
        r(
            Get,
            "/api/instances/{id}",
            Op::ToolGet("get_instance", Some("id")),
            "One instance: caption, class, box, segment, relations.",
        ),
        r(
            Post,
            "/api/ask",
            Op::Ask,
            "Ask in words: the server's language model answers by calling the tools (needs serve --llm); the write tools only with the token.",
        ),
        r(
            Get,
            "/api/export/{format}",
            Op::Export,
            "The whole map in one file: node-link (networkx JSON), graphml, geojson (ground-plane metres), spark-dsg (Hydra's scene-graph JSON, z-up metres) or ply (the points, world frame); neo4j-csv writes a folder and is for the CLI.",
        ),
        r(
            Get,
            "/api/instances/{id}/points",
            Op::Points,
            "One instance's points: little-endian float32 x y z per point (world frame, metres).",
        ),
    ]
}

#[derive(Clone)]
struct AppState {
    service: Arc<Service>,
    gate: WriteGate,
    openapi: Arc<JsonValue>,
    inflight: Arc<Semaphore>,
    body_limit_bytes: usize,
    body_timeout: Duration,
    hosts: Arc<Vec<String>>,
}

/// A JSON error response.
fn error_response(e: &ToolError) -> Response {
    let status = StatusCode::from_u16(e.http_status()).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
    (status, Json(error_body(e))).into_response()
}

/// An error response with a status of its own (framework-level: size, method, route).
fn plain_error(status: StatusCode, code: &str, message: String) -> Response {
    (
        status,
        Json(json!({"error": {"code": code, "message": message}})),
    )
        .into_response()
}

/// A request refused before it reaches the service (body, path): status, code, message.
struct HttpError(StatusCode, &'static str, String);

impl IntoResponse for HttpError {
    fn into_response(self) -> Response {
        plain_error(self.0, self.1, self.2)
    }
}

/// The JSON object in a request body; an empty body is `{}`.
fn parse_args(
    body: Result<Bytes, BytesRejection>,
    limit_bytes: usize,
) -> Result<JsonValue, HttpError> {
    let bytes = body.map_err(|rej| {
        let status = rej.status();
        if status == StatusCode::PAYLOAD_TOO_LARGE {
            HttpError(
                status,
                "payload_too_large",
                format!("the body is over this server's limit of {limit_bytes} bytes (--body-limit-bytes)"),
            )
        } else {
            HttpError(status, "bad_request", rej.body_text())
        }
    })?;
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Ok(json!({}));
    }
    let v: JsonValue = serde_json::from_slice(&bytes).map_err(|e| {
        HttpError(
            StatusCode::BAD_REQUEST,
            "bad_json",
            format!("the body is not valid JSON: {e}"),
        )
    })?;
    if !v.is_object() {
        return Err(HttpError(
            StatusCode::BAD_REQUEST,
            "bad_request",
            "the body must be a JSON object of arguments".into(),
        ));
    }
    Ok(v)
}

/// A node id from the path.
fn path_id(params: &BTreeMap<String, String>) -> Result<u64, HttpError> {
    let raw = params.get("id").map(String::as_str).unwrap_or_default();
    raw.parse::<u64>().map_err(|_| {
        HttpError(
            StatusCode::BAD_REQUEST,
            "bad_request",
            format!("{raw:?} is not a node id (a non-negative integer)"),
        )
    })
}

async fn handle(
    op: Op,
    state: AppState,
    params: BTreeMap<String, String>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Response {
    let svc = &state.service;
    let authorization = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok());
    let may_write = svc.writes() && state.gate.allows(authorization);
    let answer = match op {
        Op::Health => Ok(json!({"status": "ok"})),
        Op::Ready => {
            if state.inflight.available_permits() == 0 {
                return plain_error(
                    StatusCode::SERVICE_UNAVAILABLE,
                    "busy",
                    "every request slot is taken; try again shortly".into(),
                );
            }
            Ok(json!({"status": "ready"}))
        }
        Op::OpenApi => Ok((*state.openapi).clone()),
        Op::Page => {
            return (
                [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
                PAGE_HTML,
            )
                .into_response();
        }
        Op::Script => {
            return (
                [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
                VIEWER_JS,
            )
                .into_response();
        }
        Op::View => svc.view().await,
        Op::Ask => {
            let args = match parse_args(body, state.body_limit_bytes) {
                Ok(a) => a,
                Err(r) => return r.into_response(),
            };
            svc.ask(&args, may_write).await
        }
        Op::Export => {
            let format = params.get("format").cloned().unwrap_or_default();
            let req = match format.parse() {
                Ok(f) => opengraph_service::export::ExportRequest::new(f),
                Err(e) => return error_response(&e),
            };
            return match svc.export(req).await {
                Ok((ct, bytes, _)) => ([(header::CONTENT_TYPE, ct)], bytes).into_response(),
                Err(e) => error_response(&e),
            };
        }
        Op::Info => svc.info().await,
        Op::Tools => {
            serde_json::to_value(svc.tools()).map_err(|e| ToolError::Failed(e.to_string()))
        }
        Op::CallTool => {
            let args = match parse_args(body, state.body_limit_bytes) {
                Ok(a) => a,
                Err(r) => return r.into_response(),
            };
            let name = params.get("name").cloned().unwrap_or_default();
            svc.call(&name, args, may_write).await
        }
        Op::Tool(name) => {
            let args = match parse_args(body, state.body_limit_bytes) {
                Ok(a) => a,
                Err(r) => return r.into_response(),
            };
            svc.call(name, args, may_write).await
        }
        Op::ToolGet(name, arg) => {
            let mut args = json!({});
            if let Some(arg) = arg {
                match path_id(&params) {
                    Ok(id) => args[arg] = json!(id),
                    Err(r) => return r.into_response(),
                }
            }
            svc.call(name, args, may_write).await
        }
        Op::Points => {
            let id = match path_id(&params) {
                Ok(id) => id,
                Err(r) => return r.into_response(),
            };
            return match svc.points(id).await {
                Ok((n, bytes)) => (
                    [
                        (
                            header::CONTENT_TYPE,
                            HeaderValue::from_static("application/octet-stream"),
                        ),
                        (
                            header::HeaderName::from_static("x-point-count"),
                            HeaderValue::from(n),
                        ),
                    ],
                    bytes,
                )
                    .into_response(),
                Err(e) => error_response(&e),
            };
        }
    };
    match answer {
        Ok(v) => Json(v).into_response(),
        Err(e) => error_response(&e),
    }
}

/// The whole application: API routes, `/openapi.json`, `/mcp`, limits.
pub fn router(service: Arc<Service>, opts: &ServeOptions) -> Router {
    let gate = match &opts.token {
        Some(t) => WriteGate::Token(Arc::from(t.as_str())),
        None => WriteGate::Token(Arc::from("")), // nothing matches an empty token
    };
    let hosts = Arc::new(allowed_host_names(opts));
    let state = AppState {
        openapi: Arc::new(openapi(&service)),
        service: service.clone(),
        gate: gate.clone(),
        inflight: Arc::new(Semaphore::new(opts.max_concurrent.max(1))),
        body_limit_bytes: opts.body_limit_bytes,
        body_timeout: opts.body_timeout,
        hosts: hosts.clone(),
    };
    let mut app = Router::new();
    for route in routes() {
        let op = route.op;
        let filter = match route.method {
            HttpMethod::Post => MethodFilter::POST,
            _ => MethodFilter::GET,
        };
        app = app.route(
            route.path,
            on(
                filter,
                move |State(st): State<AppState>,
                      params: Option<Path<BTreeMap<String, String>>>,
                      headers: HeaderMap,
                      body: Result<Bytes, BytesRejection>| async move {
                    let params = params.map(|p| p.0).unwrap_or_default();
                    handle(op, st, params, headers, body).await
                },
            ),
        );
    }
    let mut mcp_config =
        rmcp::transport::streamable_http_server::StreamableHttpServerConfig::default();
    mcp_config.max_request_body_bytes = opts.body_limit_bytes;
    for h in hosts.iter() {
        if !mcp_config.allowed_hosts.contains(h) {
            mcp_config.allowed_hosts.push(h.clone());
        }
    }
    if !opts.bind.ip().is_loopback() {
        // rmcp's own check, as before: the bare address and address:port
        mcp_config.allowed_hosts.push(opts.bind.ip().to_string());
        mcp_config.allowed_hosts.push(opts.bind.to_string());
    }
    let mcp_service = service.clone();
    let mcp = rmcp::transport::streamable_http_server::StreamableHttpService::new(
        move || Ok(McpServer::new(mcp_service.clone(), gate.clone())),
        Arc::new(
            rmcp::transport::streamable_http_server::session::local::LocalSessionManager::default(),
        ),
        mcp_config,
    );
    let mcp_routes = Router::new()
        .route_service("/mcp", mcp)
        .layer(axum::middleware::from_fn(crate::mcp::protocol_errors));
    app = app
        .merge(mcp_routes)
        .fallback(|method: Method, uri: axum::http::Uri| async move {
            plain_error(
                StatusCode::NOT_FOUND,
                "not_found",
                format!(
                    "no route {method} {}; the routes are listed at /openapi.json",
                    uri.path()
                ),
            )
        })
        .method_not_allowed_fallback(|method: Method, uri: axum::http::Uri| async move {
            plain_error(
                StatusCode::METHOD_NOT_ALLOWED,
                "method_not_allowed",
                format!(
                    "{method} is not allowed on {}; see /openapi.json",
                    uri.path()
                ),
            )
        })
        .layer(axum::middleware::from_fn_with_state(state.clone(), guard))
        .layer(DefaultBodyLimit::max(opts.body_limit_bytes));
    if !opts.cors_origins.is_empty() {
        let origins: Vec<HeaderValue> = opts
            .cors_origins
            .iter()
            .filter_map(|o| HeaderValue::from_str(o).ok())
            .collect();
        app = app.layer(
            tower_http::cors::CorsLayer::new()
                .allow_origin(origins)
                .allow_methods([Method::GET, Method::POST])
                .allow_headers([header::CONTENT_TYPE, header::AUTHORIZATION]),
        );
    }
    app.with_state(state)
}

/// How long a request may take by default.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(30);
