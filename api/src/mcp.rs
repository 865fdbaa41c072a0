//! The MCP server (`opengraph mcp` over stdio, and `/mcp` inside `opengraph serve` over
//! streamable HTTP): the tool registry ([`crate::tools`]) served with `rmcp` over the one
//! [`Service`]. It holds no logic: `tools/list` lists the registry, `tools/call` calls it and
//! answers the tool's JSON as structured content (and as text). Arguments that break a tool's
//! schema and failed operations come back as tool errors the client shows (`isError`); an
//! unknown tool is a JSON-RPC error (invalid params, as the MCP specification has it); the mapping is
//! [`ToolError::mcp_error_code`]. Over HTTP the write tools are listed only when the server
//! has a token, and a call runs only with `Authorization: Bearer <token>`.

use std::sync::Arc;

use rmcp::model::{
    CallToolRequestParams, CallToolResponse, CallToolResult, ContentBlock, GetPromptRequestParams,
    GetPromptResponse, GetPromptResult, Implementation, ListPromptsResult, ListResourcesResult,
    ListToolsResult, PaginatedRequestParams, Prompt, PromptArgument, PromptMessage,
    ReadResourceRequestParams, ReadResourceResponse, ReadResourceResult, Resource,
    ResourceContents, Role, ServerCapabilities, ServerConfig, Tool, ToolAnnotations,
};
use rmcp::service::RequestContext;
use rmcp::{ErrorData, RoleServer, ServerHandler, ServiceExt};

use crate::service::{Service, WriteGate};
use crate::tools::{AGENT_GUIDE, Toolbox};

/// The MCP server over the service.
#[derive(Clone)]
pub struct McpServer {
    service: Arc<Service>,
    gate: WriteGate,
}

impl std::fmt::Debug for McpServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McpServer").finish_non_exhaustive()
    }
}

impl McpServer {
    /// A server over the service; `gate` decides who may call the write tools.
    pub fn new(service: Arc<Service>, gate: WriteGate) -> McpServer {
        McpServer { service, gate }
    }

    fn mcp_tools(&self) -> Vec<Tool> {
        let object = |v: serde_json::Value| match v {
            serde_json::Value::Object(m) => m,
            _ => serde_json::Map::new(),
        };
        self.service
            .tools()
            .into_iter()
            .map(|t| {
                // the MCP hints follow from the registry: a tool that writes may delete (a
                // Cypher DELETE, an object removed from the map) and is not idempotent; the
                // map is a closed world
                let annotations = ToolAnnotations::with_title(title(t.name))
                    .read_only(!t.writes)
                    .destructive(t.writes)
                    .idempotent(!t.writes)
                    .open_world(false);
                Tool::new(t.name, t.description, object(t.input_schema))
                    .with_raw_output_schema(Arc::new(object(t.output_schema)))
                    .with_annotations(annotations)
            })
            .collect()
    }
}

/// A tool's name as a title: `find_objects` is "Find objects".
fn title(name: &str) -> String {
    let words = name.replace('_', " ");
    let mut c = words.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

/// The resource with the map's schema (the `get_schema` tool's answer).
const SCHEMA_URI: &str = "opengraph://schema";
/// The resource with [`AGENT_GUIDE`].
const GUIDE_URI: &str = "opengraph://guide";
/// The prompt that gives an agent [`AGENT_GUIDE`], with a question when there is one.
const GUIDE_PROMPT: &str = "use_the_map";

impl ServerHandler for McpServer {
    fn get_info(&self) -> ServerConfig {
        let capabilities = ServerCapabilities::builder()
            .enable_tools()
            .enable_resources()
            .enable_prompts()
            .build();
        ServerConfig::new(capabilities)
            .with_server_info(Implementation::new("opengraph", env!("CARGO_PKG_VERSION")))
            .with_instructions(
                "OpenGraph: a 3D scene graph of a street map (road segments, lane graph, objects). \
                 Call get_schema first; prefer the task tools (nearest_objects, count_objects, \
                 measure_distance, plan_route, neighbours, find_objects, locate) to read_cypher. \
                 The prompt use_the_map and the resource opengraph://guide say how to use them; \
                 opengraph://schema is the schema.",
            )
    }

    async fn list_resources(
        &self,
        _request: Option<PaginatedRequestParams>,
        _context: RequestContext<RoleServer>,
    ) -> Result<ListResourcesResult, ErrorData> {
        Ok(ListResourcesResult::with_all_items(vec![
            Resource::new(SCHEMA_URI, "schema")
                .with_title("The map's schema")
                .with_description(
                    "Labels and relationship types with their properties (types, units, frames), \
                     counts, indexes, which axis is up and which ids the tools take: get_schema's answer.",
                )
                .with_mime_type("application/json"),
            Resource::new(GUIDE_URI, "guide")
                .with_title("How to use the map")
                .with_description("Which tool answers which question, places, ids and units.")
                .with_mime_type("text/markdown"),
        ]))
    }

    async fn read_resource(
        &self,
        request: ReadResourceRequestParams,
        _context: RequestContext<RoleServer>,
    ) -> Result<ReadResourceResponse, ErrorData> {
        let contents = match request.uri.as_str() {
            SCHEMA_URI => {
                let schema = self
                    .service
                    .call("get_schema", serde_json::json!({}), false)
                    .await
                    .map_err(|e| ErrorData::internal_error(e.to_string(), None))?;
                let text = serde_json::to_string_pretty(&schema).unwrap_or_default();
                ResourceContents::text(text, SCHEMA_URI).with_mime_type("application/json")
            }
            GUIDE_URI => {
                ResourceContents::text(AGENT_GUIDE, GUIDE_URI).with_mime_type("text/markdown")
            }
            other => {
                return Err(ErrorData::resource_not_found(
                    format!("no resource {other:?}; there are {SCHEMA_URI} and {GUIDE_URI}"),
                    None,
                ));
            }
        };
        Ok(ReadResourceResult::new(vec![contents]).into())
    }

    async fn list_prompts(
        &self,
        _request: Option<PaginatedRequestParams>,
        _context: RequestContext<RoleServer>,
    ) -> Result<ListPromptsResult, ErrorData> {
        let question = PromptArgument::new("question")
            .with_description("a question about the map to answer with the tools (optional)")
            .with_required(false);
        Ok(ListPromptsResult::with_all_items(vec![Prompt::new(
            GUIDE_PROMPT,
            Some(
                "How to answer questions about this map with its tools (ids, places, units), with a question when given.",
            ),
            Some(vec![question]),
        )]))
    }

    async fn get_prompt(
        &self,
        request: GetPromptRequestParams,
        _context: RequestContext<RoleServer>,
    ) -> Result<GetPromptResponse, ErrorData> {
        if request.name != GUIDE_PROMPT {
            return Err(ErrorData::invalid_params(
                format!("no prompt {:?}; there is {GUIDE_PROMPT}", request.name),
                None,
            ));
        }
        let question = request
            .arguments
            .as_ref()
            .and_then(|a| a.get("question"))
            .and_then(|q| q.as_str())
            .map(str::trim)
            .filter(|q| !q.is_empty());
        let text = match question {
            Some(q) => format!("{AGENT_GUIDE}\n\nThe question: {q}"),
            None => AGENT_GUIDE.to_string(),
        };
        let message = PromptMessage::new(Role::User, ContentBlock::text(text));
        Ok(GetPromptResult::new(vec![message])
            .with_description("How to use the OpenGraph map's tools")
            .into())
    }

    async fn list_tools(
        &self,
        _request: Option<PaginatedRequestParams>,
        _context: RequestContext<RoleServer>,
    ) -> Result<ListToolsResult, ErrorData> {
        Ok(ListToolsResult::with_all_items(self.mcp_tools()))
    }

    /// A request rmcp could not read as one of the methods it knows lands here: a method we
    /// serve (`tools/call` with `arguments` that are not an object, a `name` that is not a
    /// string, ...) is -32602 (invalid params) with what is wrong; any other method -32601.
    async fn on_custom_request(
        &self,
        request: rmcp::model::CustomRequest,
        _context: RequestContext<RoleServer>,
    ) -> Result<rmcp::model::CustomResult, ErrorData> {
        Err(custom_request_error(
            &request.method,
            request.params.as_ref(),
        ))
    }

    async fn call_tool(
        &self,
        request: CallToolRequestParams,
        context: RequestContext<RoleServer>,
    ) -> Result<CallToolResponse, ErrorData> {
        let args = request
            .arguments
            .map(serde_json::Value::Object)
            .unwrap_or(serde_json::Value::Null);
        // over HTTP the request's headers come with the context
        let authorization = context
            .extensions
            .get::<axum::http::request::Parts>()
            .and_then(|p| p.headers.get(axum::http::header::AUTHORIZATION))
            .and_then(|v| v.to_str().ok());
        let may_write = self.gate.allows(authorization);
        let answer = self.service.call(&request.name, args, may_write).await;
        match answer {
            Ok(v) => {
                let text = serde_json::to_string(&v).unwrap_or_default();
                let mut r = CallToolResult::structured(v);
                r.content = vec![ContentBlock::text(text)];
                Ok(r.into())
            }
            Err(e) => match e.mcp_error_code() {
                Some(code) => Err(ErrorData::new(
                    rmcp::model::ErrorCode(code),
                    e.to_string(),
                    None,
                )),
                None => Ok(CallToolResult::error(vec![ContentBlock::text(e.to_string())]).into()),
            },
        }
    }
}

/// The methods this server answers; a request for one of them that rmcp could not read
/// has invalid params.
const SERVED_METHODS: [&str; 8] = [
    "initialize",
    "ping",
    "tools/list",
    "tools/call",
    "resources/list",
    "resources/read",
    "prompts/list",
    "prompts/get",
];

/// The JSON-RPC error for a request rmcp read as a custom one (see `on_custom_request`).
fn custom_request_error(method: &str, params: Option<&serde_json::Value>) -> ErrorData {
    if !SERVED_METHODS.contains(&method) {
        return ErrorData::new(
            rmcp::model::ErrorCode::METHOD_NOT_FOUND,
            format!("method not found: {method:.100}; this server answers {SERVED_METHODS:?}"),
            None,
        );
    }
    let why = match method {
        "tools/call" => match params {
            None => "params are required: {\"name\": tool name, \"arguments\": {...}}".to_string(),
            Some(p) => match serde_json::from_value::<CallToolRequestParams>(p.clone()) {
                Err(e) => format!("{e}"),
                Ok(_) => "params are not a tools/call request".into(),
            },
        },
        _ => "params do not match the method".into(),
    };
    ErrorData::new(
        rmcp::model::ErrorCode::INVALID_PARAMS,
        format!("invalid params for {method}: {why:.300}"),
        None,
    )
}

/// A JSON-RPC error response as HTTP: status, `{"jsonrpc": "2.0", "id", "error"}`.
fn jsonrpc_error(
    status: axum::http::StatusCode,
    id: serde_json::Value,
    code: i32,
    message: String,
) -> axum::response::Response {
    use axum::response::IntoResponse;
    (
        status,
        axum::Json(serde_json::json!({
            "jsonrpc": "2.0",
            "id": id,
            "error": {"code": code, "message": message},
        })),
    )
        .into_response()
}

/// In front of `/mcp` (over HTTP): a POST body that is not JSON is JSON-RPC -32700 (parse
/// error) and one that is JSON but no JSON-RPC message (an array, no `jsonrpc: "2.0"`, no
/// method or result) -32600 (invalid request), both with status 400 (rmcp answers them 415);
/// ending a session (DELETE) answers 204 where rmcp answers 202, which clients take for a
/// failed termination. Everything else goes to rmcp unchanged. The body was already read
/// within the server's limits by the HTTP guard.
pub async fn protocol_errors(
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> axum::response::Response {
    use axum::http::{Method, StatusCode};
    let is_json = req
        .headers()
        .get(axum::http::header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| {
            v.split(';')
                .next()
                .is_some_and(|e| e.trim().eq_ignore_ascii_case("application/json"))
        });
    if req.method() == Method::POST && is_json {
        let (parts, body) = req.into_parts();
        let Ok(bytes) = axum::body::to_bytes(body, usize::MAX).await else {
            return jsonrpc_error(
                StatusCode::BAD_REQUEST,
                serde_json::Value::Null,
                -32700,
                "Parse error: the body broke off".into(),
            );
        };
        let value: serde_json::Value = match serde_json::from_slice(&bytes) {
            Ok(v) => v,
            Err(e) => {
                return jsonrpc_error(
                    StatusCode::BAD_REQUEST,
                    serde_json::Value::Null,
                    -32700,
                    format!("Parse error: the body is not JSON: {e}"),
                );
            }
        };
        let id = value
            .get("id")
            .filter(|i| i.is_string() || i.is_number())
            .cloned()
            .unwrap_or(serde_json::Value::Null);
        let shaped = value.get("jsonrpc").and_then(|v| v.as_str()) == Some("2.0")
            && (value.get("method").is_some_and(|m| m.is_string())
                || value.get("result").is_some()
                || value.get("error").is_some());
        if !value.is_object() || !shaped {
            return jsonrpc_error(
                StatusCode::BAD_REQUEST,
                id,
                -32600,
                "Invalid Request: the body must be one JSON-RPC 2.0 message (an object with \"jsonrpc\": \"2.0\" and a \"method\"); batches are not supported".into(),
            );
        }
        // from the bytes, as rmcp reads them (a duplicate key passes as a Value, not here)
        if serde_json::from_slice::<rmcp::model::ClientJsonRpcMessage>(&bytes).is_err() {
            return jsonrpc_error(
                StatusCode::BAD_REQUEST,
                id,
                -32600,
                "Invalid Request: not a JSON-RPC request, notification or response this server reads (check id, method and params)".into(),
            );
        }
        let req = axum::extract::Request::from_parts(parts, axum::body::Body::from(bytes));
        return next.run(req).await;
    }
    let deleting = req.method() == Method::DELETE;
    let mut res = next.run(req).await;
    if deleting && res.status() == StatusCode::ACCEPTED {
        *res.status_mut() = StatusCode::NO_CONTENT;
    }
    res
}

/// Serves the toolbox over stdin/stdout until the client closes the stream.
///
/// # Errors
/// The runtime cannot start or the transport fails.
pub fn serve_stdio(toolbox: Toolbox) -> std::io::Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    // one client: one worker, no timeout beyond the tools' own (a Cypher call stops at 10 s)
    let service = crate::builder::ServiceBuilder::new()
        .timeout(std::time::Duration::from_secs(3600))
        .build(toolbox, |_| {
            Err(crate::error::ToolError::Failed(
                "one worker has no second finder".into(),
            ))
        })
        .map_err(|e| std::io::Error::other(e.to_string()))?;
    rt.block_on(async move {
        let running = McpServer::new(service, WriteGate::Open)
            .serve(rmcp::transport::stdio())
            .await
            .map_err(|e| std::io::Error::other(e.to_string()))?;
        running
            .waiting()
            .await
            .map_err(|e| std::io::Error::other(e.to_string()))?;
        Ok(())
    })
}
