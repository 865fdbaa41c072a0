//! Chat language models behind one narrow trait, [`ChatModel`], with three backends:
//! - [`local::LocalGguf`]: llama.cpp on a GGUF file (the embedded default), with JSON-schema
//!   constrained sampling so every structured answer parses;
//! - [`openai::OpenAiChat`]: any OpenAI-compatible HTTP server (llama.cpp server, vLLM,
//!   Ollama, hosted APIs), with `response_format` JSON schemas and tool calls;
//! - [`scripted::Scripted`]: deterministic replies for tests, chosen explicitly, never a silent
//!   stand-in for a real model.
//!
//! Every backend answers the same [`ChatRequest`] with a [`ChatResponse`]; a structured answer
//! (`schema` set) is validated against its JSON Schema here, whatever the backend, so callers
//! never see an answer of the wrong shape. One conformance suite (`tests/chat_conformance.rs`)
//! runs against every backend.

pub mod local;
pub mod openai;
pub mod scripted;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Who said a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Instructions.
    System,
    /// The person or program asking.
    User,
    /// The model.
    Assistant,
    /// A tool's result, answering a [`ToolCall`].
    Tool,
}

/// One chat message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Message {
    /// Its author.
    pub role: Role,
    /// Its text (a tool result is JSON text).
    pub content: String,
    /// For an assistant message: the tools it called.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tool_calls: Vec<ToolCall>,
    /// For a tool message: the call it answers.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_call_id: Option<String>,
}

impl Message {
    /// A message without tool calls.
    pub fn new(role: Role, content: impl Into<String>) -> Message {
        Message {
            role,
            content: content.into(),
            tool_calls: Vec::new(),
            tool_call_id: None,
        }
    }
    /// A system message.
    pub fn system(content: impl Into<String>) -> Message {
        Message::new(Role::System, content)
    }
    /// A user message.
    pub fn user(content: impl Into<String>) -> Message {
        Message::new(Role::User, content)
    }
}

/// A tool the model may call: a name, what it does, and a JSON Schema of its arguments.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ToolSpec {
    /// Name (`[a-z_]+`).
    pub name: String,
    /// What it does, for the model.
    pub description: String,
    /// JSON Schema of the arguments object.
    pub parameters: serde_json::Value,
}

/// A call of a tool by the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ToolCall {
    /// Call id (backend-made; `call_N` for local models).
    pub id: String,
    /// The tool's name.
    pub name: String,
    /// Arguments, an object valid against the tool's schema.
    pub arguments: serde_json::Value,
}

/// What to ask.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct ChatRequest {
    /// The conversation so far.
    pub messages: Vec<Message>,
    /// When set, the answer must be one JSON value valid against this JSON Schema; local
    /// models are constrained to it while sampling, remote ones get it as `response_format`.
    pub schema: Option<serde_json::Value>,
    /// Tools the model may call instead of answering.
    pub tools: Vec<ToolSpec>,
    /// The model must call one of the tools rather than answer (OpenAI `tool_choice:
    /// "required"`; local models get a grammar without the answer option).
    pub require_tool: bool,
    /// Most tokens to generate.
    pub max_tokens: u32,
}

impl ChatRequest {
    /// A request with `messages`, no schema, no tools and 256 tokens at most.
    pub fn new(messages: Vec<Message>) -> ChatRequest {
        ChatRequest {
            messages,
            schema: None,
            tools: Vec::new(),
            require_tool: false,
            max_tokens: 256,
        }
    }
    /// Requires a tool call (see [`ChatRequest::require_tool`]).
    pub fn with_required_tool(mut self) -> ChatRequest {
        self.require_tool = true;
        self
    }
    /// Requires the answer to follow `schema`.
    pub fn with_schema(mut self, schema: serde_json::Value) -> ChatRequest {
        self.schema = Some(schema);
        self
    }
    /// Offers `tools`.
    pub fn with_tools(mut self, tools: Vec<ToolSpec>) -> ChatRequest {
        self.tools = tools;
        self
    }
    /// Sets the token limit.
    pub fn with_max_tokens(mut self, n: u32) -> ChatRequest {
        self.max_tokens = n;
        self
    }
}

/// Token counts and times of one answer.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Usage {
    /// Tokens in the prompt.
    pub prompt_tokens: u32,
    /// Tokens generated.
    pub completion_tokens: u32,
    /// Time to read the prompt, milliseconds (0 when the backend does not say).
    pub prompt_ms: f64,
    /// Time to generate, milliseconds (for remote backends: the whole request).
    pub completion_ms: f64,
}

/// The model's answer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChatResponse {
    /// The answer's text (empty when the model only called tools).
    pub text: String,
    /// The answer parsed as JSON when the request had a schema (already validated).
    pub json: Option<serde_json::Value>,
    /// Tools the model called.
    pub tool_calls: Vec<ToolCall>,
    /// Which model answered ([`ChatModel::model_id`]).
    pub model: String,
    /// Counts and times.
    pub usage: Usage,
}

/// A chat language model.
pub trait ChatModel: Send {
    /// A stable id of the model, recorded with every fact it makes (for a GGUF: the file name
    /// and the first 12 hex digits of its sha256; for HTTP: `openai:<model>@<host>`).
    fn model_id(&self) -> String;
    /// Answers one request. A request with a schema yields a [`ChatResponse::json`] valid
    /// against it or an error; never an answer of another shape.
    fn chat(&mut self, req: &ChatRequest) -> Result<ChatResponse>;
}

impl std::fmt::Debug for dyn ChatModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ChatModel({})", self.model_id())
    }
}

/// Parses `text` as one JSON value and validates it against `schema`.
///
/// Errors: [`Error::LlmAnswer`] naming the byte offset of a parse error or the first schema
/// violation (with its JSON pointer).
pub fn parse_structured(text: &str, schema: &serde_json::Value) -> Result<serde_json::Value> {
    let v: serde_json::Value = serde_json::from_str(text.trim()).map_err(|e| {
        Error::LlmAnswer(format!(
            "the answer is not JSON (line {}, column {}: {e}): {}",
            e.line(),
            e.column(),
            clip(text, 200)
        ))
    })?;
    validate(&v, schema)?;
    Ok(v)
}

/// Validates a value against a JSON Schema (draft 2020-12 unless the schema says otherwise).
pub fn validate(v: &serde_json::Value, schema: &serde_json::Value) -> Result<()> {
    let validator = jsonschema::validator_for(schema)
        .map_err(|e| Error::Invalid(format!("invalid JSON Schema: {e}")))?;
    if let Some(e) = validator.iter_errors(v).next() {
        return Err(Error::LlmAnswer(format!(
            "the answer does not follow the schema at {:?}: {e}",
            e.instance_path().to_string()
        )));
    }
    Ok(())
}

/// The first `n` characters of `s`, with an ellipsis when cut.
pub(crate) fn clip(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(n).collect::<String>())
    }
}

/// Which backend to use, as the CLI and the build's `[llm]` TOML section name it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LlmConfig {
    /// `local`, `openai` or `none`.
    #[serde(default = "default_backend")]
    pub backend: String,
    /// For `local`: the GGUF file (default: the default model in the models folder).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_path: Option<std::path::PathBuf>,
    /// For `openai`: the base URL (else `OPENAI_BASE_URL`), e.g. `http://127.0.0.1:8080/v1`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub url: Option<String>,
    /// For `openai`: the model name (else `OPENAI_MODEL`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// For `openai`: the environment variable holding the API key (default `OPENAI_API_KEY`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub api_key_env: Option<String>,
    /// For `openai`: seconds per request before it times out (default 60).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timeout_secs: Option<f64>,
    /// For `local`: threads (default: the machine's cores).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threads: Option<u32>,
}

fn default_backend() -> String {
    "none".into()
}

impl Default for LlmConfig {
    /// No language model (`backend = "none"`).
    fn default() -> LlmConfig {
        LlmConfig {
            backend: default_backend(),
            model_path: None,
            url: None,
            model: None,
            api_key_env: None,
            timeout_secs: None,
            threads: None,
        }
    }
}

/// The default local model's file name in the models folder (see `scripts/setup.sh`).
pub const DEFAULT_LOCAL_MODEL: &str = "qwen2.5-coder-0.5b-instruct-q4_k_m.gguf";
/// The smallest local model (fast, weak answers; serves tests that only need the right shape).
pub const SMALLEST_LOCAL_MODEL: &str = "SmolLM2-135M-Instruct.Q4_1.gguf";

/// Opens the backend `cfg` names; `Ok(None)` for `none`.
///
/// Errors: [`Error::Invalid`] for an unknown backend or a bad value; the backend's own errors
/// (missing model file, missing URL).
pub fn open(cfg: &LlmConfig) -> Result<Option<Box<dyn ChatModel>>> {
    match cfg.backend.as_str() {
        "none" => Ok(None),
        "local" => {
            let path = cfg
                .model_path
                .clone()
                .unwrap_or_else(|| crate::embed::default_models_dir().join(DEFAULT_LOCAL_MODEL));
            let threads = match cfg.threads {
                Some(0) => return Err(Error::Invalid("[llm] threads must be at least 1".into())),
                Some(t) => t,
                None => std::thread::available_parallelism()
                    .map(|n| n.get() as u32)
                    .unwrap_or(2),
            };
            Ok(Some(Box::new(local::LocalGguf::open(&path, threads)?)))
        }
        "openai" => Ok(Some(Box::new(openai::OpenAiChat::from_config(cfg)?))),
        other => Err(Error::Invalid(format!(
            "unknown LLM backend {other:?}: use local, openai or none"
        ))),
    }
}
