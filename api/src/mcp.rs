//! The MCP server (`opengraph mcp` over stdio, and `/mcp` inside `opengraph serve` over
//! streamable HTTP): the tool registry ([`crate::tools`]) served with `rmcp` over the one
//! [`Service`]. It holds no logic: `tools/list` lists the registry, `tools/call` calls it and
//! answers the tool's JSON as structured content (and as text). Arguments that break a tool's
//! schema and failed operations come back as tool errors the client shows (`isError`); an
//! unknown tool is a JSON-RPC error (method not found); the mapping is
//! [`ToolError::mcp_error_code`]. Over HTTP the write tools are listed only when the server
//! has a token, and a call runs only with `Authorization: Bearer <token>`.

use std::sync::Arc;

use rmcp::model::{
    CallToolRequestParams, CallToolResponse, CallToolResult, ContentBlock, Implementation,
    ListToolsResult, PaginatedRequestParams, ServerCapabilities, ServerConfig, Tool,
};
use rmcp::service::RequestContext;
use rmcp::{ErrorData, RoleServer, ServerHandler, ServiceExt};

use crate::service::{Service, WriteGate};
use crate::tools::Toolbox;

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
                Tool::new(t.name, t.description, object(t.input_schema))
                    .with_raw_output_schema(Arc::new(object(t.output_schema)))
            })
            .collect()
    }
}

impl ServerHandler for McpServer {
    fn get_info(&self) -> ServerConfig {
        ServerConfig::new(ServerCapabilities::builder().enable_tools().build())
            .with_server_info(Implementation::new("opengraph", env!("CARGO_PKG_VERSION")))
            .with_instructions(
                "OpenGraph: a 3D scene graph of a street map (road segments, lane graph, objects). \
                 Call get_schema first; find_objects and locate answer requests in words; \
                 read_cypher runs read-only Cypher.",
            )
    }

    async fn list_tools(
        &self,
        _request: Option<PaginatedRequestParams>,
        _context: RequestContext<RoleServer>,
    ) -> Result<ListToolsResult, ErrorData> {
        Ok(ListToolsResult::with_all_items(self.mcp_tools()))
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
    let service = Service::new(vec![toolbox], std::time::Duration::from_secs(3600))
        .ok_or_else(|| std::io::Error::other("no toolbox"))?;
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
