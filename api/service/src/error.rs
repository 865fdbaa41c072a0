//! The service's one error kind and the one place it is mapped to the CLI's exit code, the HTTP
//! status and the MCP error; every adapter calls these and has no classifier of its own.

/// Why a call failed. This is the service's one error kind: [`ToolError::exit_code`],
/// [`ToolError::http_status`] and [`ToolError::mcp_error_code`] below are the only place it
/// is mapped to the CLI, HTTP and MCP.
///
/// | kind | exit | HTTP | MCP |
/// |---|---|---|---|
/// | `Unknown` | 2 | 404 | JSON-RPC error -32602 (invalid params: the MCP specification's code for an unknown tool) |
/// | `BadArguments` | 2 | 400 | tool result with `isError` |
/// | `NotFound` | 2 | 404 | tool result with `isError` |
/// | `Forbidden` | 2 | 401 | tool result with `isError` |
/// | `Busy` | 1 | 503 | tool result with `isError` |
/// | `TimedOut` | 1 | 504 | tool result with `isError` |
/// | `Failed` | 1 | 500 | tool result with `isError` |
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum ToolError {
    /// No tool of that name (or a write tool while writes are off).
    #[error("no tool named {name:?}{hint}", name = .0, hint = write_hint(.0))]
    Unknown(String),
    /// The arguments do not match the tool's schema, or name nothing.
    #[error("bad arguments: {0}")]
    BadArguments(String),
    /// A write the map's schema or constraints refuse (a unique property taken, a required
    /// one missing, a node deleted with relationships left); nothing was changed.
    #[error("{0}")]
    Constraint(String),
    /// What the caller named is unusable: a missing or malformed file, a bad config, a model
    /// that cannot be opened (the message names the file, line or field).
    #[error("{0}")]
    Input(String),
    /// The arguments name a node that does not exist.
    #[error("{0}")]
    NotFound(String),
    /// A write without the write token.
    #[error("{0}")]
    Forbidden(String),
    /// Every worker stayed busy for the whole request timeout.
    #[error("{0}")]
    Busy(String),
    /// The operation took longer than the request timeout.
    #[error("{0}")]
    TimedOut(String),
    /// The operation failed on the map.
    #[error("{0}")]
    Failed(String),
}

impl ToolError {
    /// A short machine-readable code (`bad_request`, `not_found`, ...), the `code` of HTTP
    /// error bodies.
    pub fn code(&self) -> &'static str {
        match self {
            ToolError::Unknown(_) => "unknown_tool",
            ToolError::BadArguments(_) | ToolError::Input(_) => "bad_request",
            ToolError::NotFound(_) => "not_found",
            ToolError::Constraint(_) => "constraint",
            ToolError::Forbidden(_) => "unauthorized",
            ToolError::Busy(_) => "busy",
            ToolError::TimedOut(_) => "timeout",
            ToolError::Failed(_) => "internal",
        }
    }

    /// The error an error body (`{"error": {"code", "message"}}`, [`ToolError::code`]) stands
    /// for, as another server sent it (a region shard over zenoh); a body of another shape
    /// is a failure named by its text.
    pub fn from_body(body: &serde_json::Value) -> ToolError {
        let e = &body["error"];
        let (Some(code), Some(m)) = (e["code"].as_str(), e["message"].as_str()) else {
            return ToolError::Failed(format!("an error reply of no known shape: {body}"));
        };
        let m = m.to_string();
        match code {
            // its text already says "no tool named …"
            "unknown_tool" => ToolError::BadArguments(m),
            "bad_request" => {
                ToolError::BadArguments(m.trim_start_matches("bad arguments: ").into())
            }
            "not_found" => ToolError::NotFound(m),
            "constraint" => ToolError::Constraint(m),
            "unauthorized" => ToolError::Forbidden(m),
            "busy" => ToolError::Busy(m),
            "timeout" => ToolError::TimedOut(m),
            _ => ToolError::Failed(m),
        }
    }

    /// The CLI's exit code: 2 for the caller's input, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            ToolError::Unknown(_)
            | ToolError::BadArguments(_)
            | ToolError::Input(_)
            | ToolError::Constraint(_)
            | ToolError::NotFound(_)
            | ToolError::Forbidden(_) => 2,
            _ => 1,
        }
    }

    /// The HTTP status.
    pub fn http_status(&self) -> u16 {
        match self {
            ToolError::Unknown(_) | ToolError::NotFound(_) => 404,
            ToolError::BadArguments(_) | ToolError::Input(_) => 400,
            ToolError::Constraint(_) => 409,
            ToolError::Forbidden(_) => 401,
            ToolError::Busy(_) => 503,
            ToolError::TimedOut(_) => 504,
            ToolError::Failed(_) => 500,
        }
    }

    /// The MCP JSON-RPC error code, or `None` where the error is a tool result with
    /// `isError` (which the model sees and can act on).
    pub fn mcp_error_code(&self) -> Option<i32> {
        match self {
            ToolError::Unknown(_) => Some(-32602),
            _ => None,
        }
    }
}

/// The hint for a write tool asked for while writes are off.
fn write_hint(name: &str) -> &'static str {
    if matches!(name, "write_cypher" | "update_map" | "undo_map_edit") {
        " (write tools are offered only when writes are enabled: --writes, mcp --allow-writes, or serve with a --token-file or $OPENGRAPH_TOKEN)"
    } else {
        ""
    }
}

/// Result alias for tool calls.
pub type ToolResult<T> = std::result::Result<T, ToolError>;

/// A failure of ours, with its message.
pub(crate) fn failed(e: impl std::fmt::Display) -> ToolError {
    ToolError::Failed(e.to_string())
}

/// An error of the language layer: the caller's input (empty text, an unknown class, a map
/// built with another embedder) or a failure of ours (a model, the store).
impl From<llm_tools::Error> for ToolError {
    fn from(e: llm_tools::Error) -> ToolError {
        match e {
            llm_tools::Error::Invalid(m) => ToolError::BadArguments(m),
            // a map without its hierarchy yet (a live server before its first frames)
            llm_tools::Error::Scene(s @ scene::Error::NoGroundFrame(_)) => {
                ToolError::Input(s.to_string())
            }
            other => ToolError::Failed(other.to_string()),
        }
    }
}

/// An error of a map edit: the caller's input (not an instance, an edit already undone or
/// depended on) or a failure of ours.
impl From<ingest::Error> for ToolError {
    fn from(e: ingest::Error) -> ToolError {
        match e {
            ingest::Error::Invalid(m) => ToolError::BadArguments(m),
            other => ToolError::Failed(other.to_string()),
        }
    }
}

/// An error of the crates below as the service's one kind: [`ToolError::Input`] when it is
/// the caller's ([`is_caller_error`]), [`ToolError::Failed`] otherwise; the message is the
/// error's own, causes included.
pub fn classify(e: &(dyn std::error::Error + 'static)) -> ToolError {
    let mut msg = e.to_string();
    let mut src = e.source();
    let mut caller = is_caller_error(e) == Some(true);
    while let Some(s) = src {
        let m = s.to_string();
        if !msg.contains(&m) {
            msg.push_str(": ");
            msg.push_str(&m);
        }
        caller |= is_caller_error(s) == Some(true);
        src = s.source();
    }
    if caller {
        ToolError::Input(msg)
    } else {
        ToolError::Failed(msg)
    }
}

/// Whether an error of any of OpenGraph's crates (or the OS) is the caller's to fix: `Some(true)`
/// for bad input (a path that is missing or not allowed, a bad file, a bad argument, a missing
/// or bad model file: the CLI exits 2 for these, as for [`ToolError::BadArguments`]),
/// `Some(false)` for a failure of ours (storage, rendering, a model failing on good input: exit
/// 1), `None` for an error of another kind. The CLI asks this of each error in a chain; it is
/// the one place the crates' errors are classified.
pub fn is_caller_error(e: &(dyn std::error::Error + 'static)) -> Option<bool> {
    if let Some(t) = e.downcast_ref::<ToolError>() {
        return Some(t.exit_code() == 2);
    }
    // the user's paths: missing, not allowed, already there, a folder for a file
    if let Some(io) = e.downcast_ref::<std::io::Error>() {
        use std::io::ErrorKind as K;
        return Some(matches!(
            io.kind(),
            K::NotFound
                | K::PermissionDenied
                | K::AlreadyExists
                | K::IsADirectory
                | K::NotADirectory
                | K::ReadOnlyFilesystem
        ));
    }
    let store_input = |g: &graphstore::Error| {
        !matches!(
            g,
            graphstore::Error::Storage(_) | graphstore::Error::Io { .. }
        )
    };
    if let Some(g) = e.downcast_ref::<graphstore::Error>() {
        return Some(store_input(g));
    }
    if let Some(s) = e.downcast_ref::<scene::Error>() {
        return Some(match s {
            scene::Error::Store(g) => store_input(g),
            _ => true,
        });
    }
    if let Some(p) = e.downcast_ref::<planner::Error>() {
        return Some(!matches!(
            p,
            planner::Error::Render(_) | planner::Error::Store(graphstore::Error::Storage(_))
        ));
    }
    if let Some(l) = e.downcast_ref::<llm_tools::Error>() {
        return Some(llm_input_error(l));
    }
    let ingest_input = |i: &ingest::Error| match i {
        ingest::Error::Llm(l) => llm_input_error(l),
        _ => !matches!(
            i,
            ingest::Error::Render(_) | ingest::Error::Store(graphstore::Error::Storage(_))
        ),
    };
    if let Some(i) = e.downcast_ref::<ingest::Error>() {
        return Some(ingest_input(i));
    }
    if let Some(v) = e.downcast_ref::<og_eval::Error>() {
        return Some(match v {
            og_eval::Error::Llm(l) => llm_input_error(l),
            og_eval::Error::Ingest(i) => ingest_input(i),
            og_eval::Error::Store(g) => store_input(g),
            _ => true,
        });
    }
    None
}

/// Missing or bad model files, bad settings and requests a server refuses are the caller's to
/// fix; a model or server failing on a good request is not.
pub fn llm_input_error(e: &llm_tools::Error) -> bool {
    matches!(
        e,
        llm_tools::Error::ModelMissing { .. }
            | llm_tools::Error::BadModel { .. }
            | llm_tools::Error::Invalid(_)
            | llm_tools::Error::LlmHttp { .. }
    )
}
