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

/// The viewer page (HTML, no external resources).
pub const PAGE_HTML: &str = include_str!("../web/index.html");
/// The viewer's script.
pub const VIEWER_JS: &str = include_str!("../web/viewer.js");

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
    /// The whole map exported (`{format}`: node-link or graphml).
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
            "Propose (and with apply, commit) a map edit from a described change (needs the token).",
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
            "The whole map: node-link (networkx JSON) or graphml.",
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
            let question = args["question"].as_str().unwrap_or_default().to_string();
            let steps = args["max_steps"].as_u64().unwrap_or(4);
            if question.trim().is_empty() || question.len() > 2000 || !(1..=20).contains(&steps) {
                return plain_error(
                    StatusCode::BAD_REQUEST,
                    "bad_request",
                    "the body is {\"question\": text (1 to 2000 characters), \"max_steps\": 1 to 20 (default 4)}".into(),
                );
            }
            svc.ask(question, steps as usize, may_write).await
        }
        Op::Export => {
            let format = params.get("format").cloned().unwrap_or_default();
            return match svc.export(&format).await {
                Ok((ct, bytes)) => ([(header::CONTENT_TYPE, ct)], bytes).into_response(),
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

/// Whether a `Host` header value names this server: a loopback name or one of `allowed`,
/// with any port. A request without `Host` (HTTP/1.0) passes: browsers always send one.
fn host_allowed(host: Option<&HeaderValue>, allowed: &[String]) -> bool {
    let Some(host) = host else {
        return true;
    };
    let Ok(host) = host.to_str() else {
        return false;
    };
    let host = host.trim().to_ascii_lowercase();
    // strip the port: `name:port`, `[v6]:port`, `[v6]`
    let name = if let Some(rest) = host.strip_prefix('[') {
        match rest.split_once(']') {
            Some((v6, tail)) if tail.is_empty() || tail.starts_with(':') => format!("[{v6}]"),
            _ => return false,
        }
    } else {
        match host.rsplit_once(':') {
            Some((n, port)) if port.bytes().all(|b| b.is_ascii_digit()) => n.to_string(),
            Some(_) => return false,
            None => host.clone(),
        }
    };
    matches!(name.as_str(), "localhost" | "127.0.0.1" | "[::1]")
        || allowed.iter().any(|a| a.eq_ignore_ascii_case(&name))
}

/// In front of every route, in this order: the `Host` check (403); 413 at once for a declared
/// `Content-Length` over the limit; liveness and readiness answered outside the gate; the
/// whole body read within the body timeout (408, the connection closed) and the limit (413)
/// before a request slot is taken, so a slow sender holds none; then 503 at once when
/// `max_concurrent` requests are already in progress.
async fn guard(
    State(state): State<AppState>,
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    if !host_allowed(req.headers().get(header::HOST), &state.hosts) {
        let host = req
            .headers()
            .get(header::HOST)
            .map(|h| {
                String::from_utf8_lossy(h.as_bytes())
                    .chars()
                    .take(100)
                    .collect::<String>()
            })
            .unwrap_or_default();
        return plain_error(
            StatusCode::FORBIDDEN,
            "forbidden_host",
            format!(
                "Host {host:?} is not this server's name; use 127.0.0.1 or localhost, or start the server with --allowed-host NAME"
            ),
        );
    }
    let declared = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    if let Some(n) = declared
        && n > state.body_limit_bytes as u64
    {
        return plain_error(
            StatusCode::PAYLOAD_TOO_LARGE,
            "payload_too_large",
            format!(
                "the body is {n} bytes; this server takes {} at most (--body-limit-bytes)",
                state.body_limit_bytes
            ),
        );
    }
    let path = req.uri().path();
    if path == "/healthz" || path == "/readyz" {
        return next.run(req).await;
    }
    let (parts, body) = req.into_parts();
    let read = axum::body::to_bytes(body, state.body_limit_bytes);
    let bytes = match tokio::time::timeout(state.body_timeout, read).await {
        Ok(Ok(b)) => b,
        Ok(Err(_)) => {
            return plain_error(
                StatusCode::PAYLOAD_TOO_LARGE,
                "payload_too_large",
                format!(
                    "the body is over this server's limit of {} bytes (--body-limit-bytes), or broke off",
                    state.body_limit_bytes
                ),
            );
        }
        Err(_) => {
            let mut r = plain_error(
                StatusCode::REQUEST_TIMEOUT,
                "request_timeout",
                format!(
                    "the request body did not arrive within {:.0} s",
                    state.body_timeout.as_secs_f64()
                ),
            );
            r.headers_mut()
                .insert(header::CONNECTION, HeaderValue::from_static("close"));
            return r;
        }
    };
    let req = axum::extract::Request::from_parts(parts, axum::body::Body::from(bytes));
    let Ok(_permit) = state.inflight.clone().try_acquire_owned() else {
        return plain_error(
            StatusCode::SERVICE_UNAVAILABLE,
            "busy",
            "too many requests in progress; try again shortly".into(),
        );
    };
    next.run(req).await
}

/// The OpenAPI 3.1 document of [`routes`], with the tools' JSON Schemas as components.
pub fn openapi(service: &Service) -> JsonValue {
    let tools = crate::tools::tools(true);
    let schema_ref = |name: String| Ref::from_schema_name(name);
    let json_content = |name: String| ContentBuilder::new().schema(Some(schema_ref(name))).build();
    let error = ResponseBuilder::new()
        .description("An error: {\"error\": {\"code\", \"message\"}}")
        .content("application/json", json_content("Error".into()))
        .build();
    let mut paths = PathsBuilder::new();
    let mut schemas: BTreeMap<String, JsonValue> = BTreeMap::new();
    for route in routes() {
        let mut op = OperationBuilder::new()
            .summary(Some(route.summary))
            .operation_id(Some(format!(
                "{}{}",
                match route.method {
                    HttpMethod::Post => "post",
                    _ => "get",
                },
                route.path.replace(['/', '{', '}', '.'], "_")
            )));
        if route.path.contains("{id}") {
            op = op.parameter(
                ParameterBuilder::new()
                    .name("id")
                    .parameter_in(ParameterIn::Path)
                    .required(Required::True)
                    .schema(Some(
                        ObjectBuilder::new()
                            .schema_type(Type::Integer)
                            .minimum(Some(0)),
                    )),
            );
        }
        if route.path.contains("{format}") {
            op = op.parameter(
                ParameterBuilder::new()
                    .name("format")
                    .parameter_in(ParameterIn::Path)
                    .required(Required::True)
                    .schema(Some(
                        ObjectBuilder::new()
                            .schema_type(Type::String)
                            .enum_values(Some(["node-link", "graphml"])),
                    )),
            );
        }
        if route.path.contains("{name}") {
            op = op.parameter(
                ParameterBuilder::new()
                    .name("name")
                    .parameter_in(ParameterIn::Path)
                    .required(Required::True)
                    .schema(Some(ObjectBuilder::new().schema_type(Type::String))),
            );
        }
        let tool = match route.op {
            Op::Tool(t) | Op::ToolGet(t, _) => tools.iter().find(|x| x.name == t),
            _ => None,
        };
        let ok = match (route.op, tool) {
            (Op::Page, _) => ResponseBuilder::new()
                .description("The viewer's HTML page.")
                .content("text/html", ContentBuilder::new().build())
                .build(),
            (Op::Script, _) => ResponseBuilder::new()
                .description("The viewer's JavaScript.")
                .content("text/javascript", ContentBuilder::new().build())
                .build(),
            (Op::Export, _) => ResponseBuilder::new()
                .description("The map in the asked format.")
                .content("application/json", ContentBuilder::new().build())
                .content("application/graphml+xml", ContentBuilder::new().build())
                .build(),
            (Op::Points, _) => ResponseBuilder::new()
                .description("Little-endian float32 x y z per point (12 bytes, world frame, metres); X-Point-Count gives the count.")
                .content("application/octet-stream", ContentBuilder::new().build())
                .build(),
            (_, Some(t)) => {
                schemas.insert(format!("{}_output", t.name), t.output_schema.clone());
                ResponseBuilder::new()
                    .description("The tool's answer.")
                    .content("application/json", json_content(format!("{}_output", t.name)))
                    .build()
            }
            (op, None) => {
                let name = match op {
                    Op::Health => "Health",
                    Op::Ready => "Ready",
                    Op::Info => "Info",
                    Op::Tools => "ToolList",
                    Op::OpenApi => "OpenApiDocument",
                    Op::View => "View",
                    Op::Ask => "ask_output",
                    _ => "AnyAnswer",
                };
                ResponseBuilder::new()
                    .description("JSON")
                    .content("application/json", json_content(name.into()))
                    .build()
            }
        };
        if let (Op::Tool(_), Some(t)) = (route.op, tool) {
            schemas.insert(format!("{}_input", t.name), t.input_schema.clone());
            op = op.request_body(Some(
                RequestBodyBuilder::new()
                    .required(Some(Required::True))
                    .content(
                        "application/json",
                        json_content(format!("{}_input", t.name)),
                    )
                    .build(),
            ));
        }
        if route.op == Op::Ask {
            op = op.request_body(Some(
                RequestBodyBuilder::new()
                    .required(Some(Required::True))
                    .content("application/json", json_content("ask_input".into()))
                    .build(),
            ));
        }
        if route.op == Op::CallTool {
            op = op.request_body(Some(
                RequestBodyBuilder::new()
                    .content("application/json", json_content("ToolArguments".into()))
                    .build(),
            ));
        }
        op = op.response("200", ok);
        for status in ["400", "401", "404", "413", "500", "503", "504"] {
            op = op.response(status, error.clone());
        }
        paths = paths.path(route.path, PathItem::new(route.method, op.build()));
    }
    let doc = OpenApiBuilder::new()
        .info(
            InfoBuilder::new()
                .title("OpenGraph")
                .version(env!("CARGO_PKG_VERSION"))
                .description(Some(format!(
                    "A 3D scene graph of a street map as a service. Writes {}. MCP (streamable HTTP) is at /mcp.",
                    if service.writes() {
                        "need Authorization: Bearer <token>"
                    } else {
                        "are off on this server"
                    }
                )))
                .build(),
        )
        .paths(paths.build())
        .build();
    let mut v = serde_json::to_value(&doc).unwrap_or_else(|_| json!({}));
    // the tools' JSON Schemas verbatim (OpenAPI 3.1 schemas are JSON Schema 2020-12)
    schemas.insert(
        "Error".into(),
        json!({"type": "object", "required": ["error"], "properties": {"error": {
            "type": "object", "required": ["code", "message"],
            "properties": {"code": {"type": "string"}, "message": {"type": "string"}}}}}),
    );
    schemas.insert(
        "Health".into(),
        json!({"type": "object", "required": ["status"], "properties": {"status": {"const": "ok"}}}),
    );
    schemas.insert(
        "Ready".into(),
        json!({"type": "object", "required": ["status"], "properties": {"status": {"const": "ready"}}}),
    );
    schemas.insert(
        "Info".into(),
        json!({"type": "object", "required": ["nodes", "relationships"]}),
    );
    schemas.insert(
        "ToolList".into(),
        json!({"type": "array", "items": {"type": "object",
            "required": ["name", "description", "input_schema", "output_schema", "writes"]}}),
    );
    schemas.insert(
        "OpenApiDocument".into(),
        json!({"type": "object", "required": ["openapi", "paths"]}),
    );
    schemas.insert("ToolArguments".into(), json!({"type": "object"}));
    schemas.insert(
        "ask_input".into(),
        json!({"type": "object", "required": ["question"], "additionalProperties": false,
               "properties": {"question": {"type": "string", "minLength": 1, "maxLength": 2000},
                              "max_steps": {"type": "integer", "minimum": 1, "maximum": 20, "default": 4}}}),
    );
    schemas.insert(
        "ask_output".into(),
        json!({"type": "object", "required": ["question", "model", "steps", "answer"],
               "properties": {"model": {"type": "string"}, "steps": {"type": "array"},
                              "answer": {"type": ["string", "null"]}}}),
    );
    schemas.insert(
        "View".into(),
        json!({"type": "object", "required": ["ground", "bounds", "instances", "lanes", "segments", "colours"],
               "properties": {
                   "bounds": {"type": "array", "items": {"type": "number"}, "minItems": 4, "maxItems": 4},
                   "instances": {"type": "array", "items": {"type": "object",
                       "required": ["id", "class", "caption", "surface", "points"],
                       "properties": {"points": {"type": "array", "items": {"type": "number"}}}}},
                   "lanes": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
                   "segments": {"type": "array", "items": {"type": "object", "required": ["id", "kind", "outline"]}},
                   "colours": {"type": "object", "additionalProperties": {"type": "string", "pattern": "^#[0-9a-f]{6}$"}}}}),
    );
    schemas.insert("AnyAnswer".into(), json!({}));
    v["components"] = json!({"schemas": schemas});
    v
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

/// The `Host` names the server answers to besides the loopback names: the bind address
/// when it is not loopback, and `--allowed-host` names.
fn allowed_host_names(opts: &ServeOptions) -> Vec<String> {
    let mut v: Vec<String> = opts
        .allowed_hosts
        .iter()
        .map(|h| h.to_ascii_lowercase())
        .collect();
    if !opts.bind.ip().is_loopback() {
        v.push(match opts.bind.ip() {
            std::net::IpAddr::V6(a) => format!("[{a}]"),
            a => a.to_string(),
        });
    }
    v
}

/// Connections open, in all and per client address.
#[derive(Default)]
struct Connections {
    total: usize,
    per_client: std::collections::HashMap<std::net::IpAddr, usize>,
}

/// One open connection's place in [`Connections`], given back on drop.
struct ConnSlot {
    table: Arc<std::sync::Mutex<Connections>>,
    ip: std::net::IpAddr,
}

impl Drop for ConnSlot {
    fn drop(&mut self) {
        let mut t = self
            .table
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        t.total = t.total.saturating_sub(1);
        if let Some(n) = t.per_client.get_mut(&self.ip) {
            *n -= 1;
            if *n == 0 {
                t.per_client.remove(&self.ip);
            }
        }
    }
}

/// A place for a new connection from `ip`, or why not.
fn take_slot(
    table: &Arc<std::sync::Mutex<Connections>>,
    ip: std::net::IpAddr,
    opts: &ServeOptions,
) -> Result<ConnSlot, &'static str> {
    let mut t = table
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if t.total >= opts.max_connections {
        return Err("too many open connections");
    }
    let mine = t.per_client.get(&ip).copied().unwrap_or(0);
    if mine >= opts.max_connections_per_client {
        return Err("too many open connections from this address");
    }
    t.total += 1;
    *t.per_client.entry(ip).or_insert(0) += 1;
    Ok(ConnSlot {
        table: table.clone(),
        ip,
    })
}

/// Serves until `shutdown` resolves, with the connection limits and the header timeout of
/// `opts` (the body timeout and the request gate are the router's, see [`router`]). A
/// connection over a limit is answered 503 and closed at once. On shutdown, connections
/// finish the request they are serving (10 s at most).
///
/// # Errors
/// The listener fails.
pub async fn serve(
    listener: tokio::net::TcpListener,
    app: Router,
    opts: &ServeOptions,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let table = Arc::new(std::sync::Mutex::new(Connections::default()));
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let mut tasks = tokio::task::JoinSet::new();
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(hyper_util::rt::TokioTimer::new())
        .header_read_timeout(opts.header_timeout)
        // a client that sends its request and closes its sending side still gets the answer
        .half_close(true)
        .keep_alive(true);
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(a) => a,
                // out of file descriptors and the like: wait, do not spin or stop serving
                Err(e) => {
                    tracing::warn!("accept failed: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        // reap finished connection tasks so the set does not grow
        while tasks.try_join_next().is_some() {}
        let slot = match take_slot(&table, peer.ip(), opts) {
            Ok(s) => s,
            Err(why) => {
                tasks.spawn(refuse_connection(stream, why));
                continue;
            }
        };
        let _ = stream.set_nodelay(true);
        let service = hyper_util::service::TowerToHyperService::new(app.clone());
        let conn = http.serve_connection(hyper_util::rt::TokioIo::new(stream), service);
        let mut stop = stop_rx.clone();
        tasks.spawn(async move {
            let _slot = slot;
            let mut conn = std::pin::pin!(conn);
            tokio::select! {
                _ = conn.as_mut() => {}
                _ = stop.changed() => {
                    conn.as_mut().graceful_shutdown();
                    let _ = tokio::time::timeout(Duration::from_secs(10), conn).await;
                }
            }
        });
    }
    let _ = stop_tx.send(true);
    let _ = tokio::time::timeout(Duration::from_secs(11), async {
        while tasks.join_next().await.is_some() {}
    })
    .await;
    Ok(())
}

/// Answers a connection over a limit with 503 and closes it (1 s at most to write).
async fn refuse_connection(mut stream: tokio::net::TcpStream, why: &'static str) {
    use tokio::io::AsyncWriteExt;
    let body = json!({"error": {"code": "busy", "message": format!("{why}; try again shortly")}})
        .to_string();
    let msg = format!(
        "HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/json\r\ncontent-length: {}\r\nconnection: close\r\n\r\n{body}",
        body.len()
    );
    let _ = tokio::time::timeout(Duration::from_secs(1), async {
        let _ = stream.write_all(msg.as_bytes()).await;
        let _ = stream.shutdown().await;
    })
    .await;
}

/// How long a request may take by default.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(30);
