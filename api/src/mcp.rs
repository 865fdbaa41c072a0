//! The MCP server over stdio (`opengraph mcp`): the tool registry ([`crate::tools`]) served
//! with `rmcp`. It holds no logic: `tools/list` lists the registry, `tools/call` calls it and
//! answers the tool's JSON as structured content (and as text). Arguments that break a tool's
//! schema and failed operations come back as tool errors the client shows (`isError`); an
//! unknown tool is a JSON-RPC error (method not found).

use std::sync::{Arc, Mutex};

use rmcp::model::{
    CallToolRequestParams, CallToolResponse, CallToolResult, ContentBlock, Implementation,
    ListToolsResult, PaginatedRequestParams, ServerCapabilities, ServerConfig, Tool,
};
use rmcp::service::RequestContext;
use rmcp::{ErrorData, RoleServer, ServerHandler, ServiceExt};

use crate::tools::{ToolError, Toolbox};

/// The MCP server: the toolbox behind a lock (one call at a time).
#[derive(Clone)]
pub struct McpServer {
    toolbox: Arc<Mutex<Toolbox>>,
}

impl std::fmt::Debug for McpServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McpServer").finish_non_exhaustive()
    }
}

impl McpServer {
    /// A server over this toolbox.
    pub fn new(toolbox: Toolbox) -> McpServer {
        McpServer {
            toolbox: Arc::new(Mutex::new(toolbox)),
        }
    }

    fn mcp_tools(&self) -> Vec<Tool> {
        let tb = self.toolbox.lock().unwrap_or_else(|e| e.into_inner());
        tb.tools()
            .into_iter()
            .map(|t| {
                let schema = match t.input_schema {
                    serde_json::Value::Object(m) => m,
                    _ => serde_json::Map::new(),
                };
                Tool::new(t.name, t.description, schema)
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
        _context: RequestContext<RoleServer>,
    ) -> Result<CallToolResponse, ErrorData> {
        let args = request
            .arguments
            .map(serde_json::Value::Object)
            .unwrap_or(serde_json::Value::Null);
        let name = request.name.to_string();
        let toolbox = self.toolbox.clone();
        // the operations block (store reads, embedding, planning): off the async workers
        let answer = tokio::task::spawn_blocking(move || {
            let mut tb = toolbox.lock().unwrap_or_else(|e| e.into_inner());
            tb.call(&name, &args)
        })
        .await
        .map_err(|e| ErrorData::internal_error(e.to_string(), None))?;
        match answer {
            Ok(v) => {
                let text = serde_json::to_string(&v).unwrap_or_default();
                let mut r = CallToolResult::structured(v);
                r.content = vec![ContentBlock::text(text)];
                Ok(r.into())
            }
            Err(ToolError::Unknown(n)) => Err(ErrorData::new(
                rmcp::model::ErrorCode::METHOD_NOT_FOUND,
                format!("no tool named {n:?}"),
                None,
            )),
            Err(e) => Ok(CallToolResult::error(vec![ContentBlock::text(e.to_string())]).into()),
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
    rt.block_on(async move {
        let running = McpServer::new(toolbox)
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
