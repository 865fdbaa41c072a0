//! An OpenAI-compatible chat backend over HTTP (`POST {base}/chat/completions`): llama.cpp's
//! server, vLLM, Ollama and hosted APIs speak it. Structured answers go as
//! `response_format: {type: "json_schema", ...}`, tools as `tools: [{type: "function", ...}]`.
//! Each request has a timeout; timeouts, connection failures, 429 and 5xx are retried a
//! bounded number of times with exponential backoff (honouring `Retry-After` up to 30 s);
//! other 4xx answers and unparseable replies fail at once with the server's message.

use std::time::{Duration, Instant};

use serde_json::{Value, json};

use super::{
    ChatModel, ChatRequest, ChatResponse, LlmConfig, Message, Role, ToolCall, Usage, clip,
};
use crate::error::{Error, Result};

/// An HTTP answer: status, body, and the `Retry-After` seconds if given.
type Reply = (u16, String, Option<u64>);

/// Largest reply body read, bytes.
const MAX_REPLY_BYTES: u64 = 16 << 20;

/// How a structured answer's schema is asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SchemaForm {
    /// OpenAI's `{"type": "json_schema", "json_schema": {"name", "schema", "strict"}}`.
    JsonSchema,
    /// `{"type": "json_object", "schema": ...}`: llama-cpp-python's server (and Anyscale's),
    /// which refuses the OpenAI form; taken after the server refuses it once.
    JsonObject,
}

/// The OpenAI-compatible backend.
#[derive(Debug, Clone)]
pub struct OpenAiChat {
    schema_form: SchemaForm,
    base_url: String,
    model: String,
    api_key: Option<String>,
    timeout: Duration,
    max_retries: u32,
    backoff: Duration,
    agent: ureq::Agent,
}

impl OpenAiChat {
    /// A client for `base_url` (e.g. `http://127.0.0.1:8080/v1`) and `model`, with an optional
    /// API key, a per-request `timeout`, and `max_retries` retries after the first try.
    ///
    /// Errors: [`Error::Invalid`] for a URL that is not `http://` or `https://`, an empty model
    /// name, or a zero or non-finite timeout.
    pub fn new(
        base_url: &str,
        model: &str,
        api_key: Option<String>,
        timeout: Duration,
        max_retries: u32,
    ) -> Result<OpenAiChat> {
        let base_url = base_url.trim().trim_end_matches('/').to_string();
        if !(base_url.starts_with("http://") || base_url.starts_with("https://")) {
            return Err(Error::Invalid(format!(
                "LLM URL {base_url:?} must start with http:// or https://"
            )));
        }
        if model.trim().is_empty() {
            return Err(Error::Invalid(
                "the OpenAI-compatible backend needs a model name ([llm] model or OPENAI_MODEL)"
                    .into(),
            ));
        }
        if timeout.is_zero() {
            return Err(Error::Invalid("LLM timeout must be positive".into()));
        }
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .timeout_global(Some(timeout))
            .http_status_as_error(false)
            .build()
            .into();
        Ok(OpenAiChat {
            schema_form: SchemaForm::JsonSchema,
            base_url,
            model: model.trim().to_string(),
            api_key: api_key.filter(|k| !k.is_empty()),
            timeout,
            max_retries,
            backoff: Duration::from_millis(500),
            agent,
        })
    }

    /// From `[llm]` settings, falling back to `OPENAI_BASE_URL`, `OPENAI_MODEL` and the key in
    /// `api_key_env` (default `OPENAI_API_KEY`).
    pub fn from_config(cfg: &LlmConfig) -> Result<OpenAiChat> {
        let url = cfg
            .url
            .clone()
            .or_else(|| std::env::var("OPENAI_BASE_URL").ok())
            .ok_or_else(|| {
                Error::Invalid(
                    "the openai backend needs a URL: --llm-url, [llm] url or OPENAI_BASE_URL"
                        .into(),
                )
            })?;
        let model = cfg
            .model
            .clone()
            .or_else(|| std::env::var("OPENAI_MODEL").ok())
            .unwrap_or_default();
        let key_env = cfg.api_key_env.as_deref().unwrap_or("OPENAI_API_KEY");
        let timeout_secs = cfg.timeout_secs.unwrap_or(60.0);
        if !(timeout_secs.is_finite() && timeout_secs > 0.0 && timeout_secs <= 3600.0) {
            return Err(Error::Invalid(format!(
                "[llm] timeout_secs must be in (0, 3600], got {timeout_secs}"
            )));
        }
        OpenAiChat::new(
            &url,
            &model,
            std::env::var(key_env).ok(),
            Duration::from_secs_f64(timeout_secs),
            3,
        )
    }

    /// Sets the first backoff delay (doubled on each retry); tests make it short.
    pub fn with_backoff(mut self, d: Duration) -> OpenAiChat {
        self.backoff = d;
        self
    }

    fn body(&self, req: &ChatRequest) -> Value {
        let messages: Vec<Value> = req.messages.iter().map(message_json).collect();
        let mut body = json!({
            "model": self.model,
            "messages": messages,
            "temperature": 0,
            "max_tokens": req.max_tokens,
        });
        if let Some(s) = &req.schema {
            body["response_format"] = match self.schema_form {
                SchemaForm::JsonSchema => json!({
                    "type": "json_schema",
                    "json_schema": {"name": "answer", "schema": s, "strict": true},
                }),
                SchemaForm::JsonObject => json!({"type": "json_object", "schema": s}),
            };
        }
        if !req.tools.is_empty() {
            body["tools"] = req
                .tools
                .iter()
                .map(|t| {
                    json!({"type": "function", "function": {
                        "name": t.name, "description": t.description, "parameters": t.parameters}})
                })
                .collect();
            if req.require_tool {
                body["tool_choice"] = json!("required");
            }
        }
        body
    }

    /// One POST; `Ok(Err(..))` is a failure worth retrying.
    fn post(&self, body: &str) -> Result<std::result::Result<Reply, String>> {
        let url = format!("{}/chat/completions", self.base_url);
        let mut rb = self
            .agent
            .post(&url)
            .header("Content-Type", "application/json");
        if let Some(k) = &self.api_key {
            rb = rb.header("Authorization", &format!("Bearer {k}"));
        }
        match rb.send(body) {
            Ok(mut resp) => {
                let status = resp.status().as_u16();
                let retry_after = resp
                    .headers()
                    .get("retry-after")
                    .and_then(|v| v.to_str().ok())
                    .and_then(|v| v.trim().parse::<u64>().ok());
                let text = resp
                    .body_mut()
                    .with_config()
                    .limit(MAX_REPLY_BYTES)
                    .read_to_string();
                match text {
                    Ok(t) => Ok(Ok((status, t, retry_after))),
                    Err(ureq::Error::Timeout(_)) => Ok(Err(format!(
                        "timed out after {:.1} s reading the reply",
                        self.timeout.as_secs_f64()
                    ))),
                    Err(e) => Err(Error::Llm(format!("{url}: reading the reply failed: {e}"))),
                }
            }
            Err(ureq::Error::Timeout(_)) => Ok(Err(format!(
                "timed out after {:.1} s",
                self.timeout.as_secs_f64()
            ))),
            Err(
                e
                @ (ureq::Error::Io(_) | ureq::Error::ConnectionFailed | ureq::Error::HostNotFound),
            ) => Ok(Err(format!("cannot reach {url}: {e}"))),
            Err(e) => Err(Error::Llm(format!("{url}: {e}"))),
        }
    }
}

fn message_json(m: &Message) -> Value {
    let role = match m.role {
        Role::System => "system",
        Role::User => "user",
        Role::Assistant => "assistant",
        Role::Tool => "tool",
    };
    let mut v = json!({"role": role, "content": m.content});
    if !m.tool_calls.is_empty() {
        v["tool_calls"] = m
            .tool_calls
            .iter()
            .map(|c| {
                json!({"id": c.id, "type": "function", "function": {
                    "name": c.name, "arguments": c.arguments.to_string()}})
            })
            .collect();
    }
    if let Some(id) = &m.tool_call_id {
        v["tool_call_id"] = json!(id);
    }
    v
}

/// Whether an error body says the server does not take `response_format.type: json_schema`.
fn refuses_json_schema(body: &str) -> bool {
    let m = server_message(body);
    m.contains("response_format") && (m.contains("json_schema") || m.contains("json_object"))
}

/// Tool calls a chat template wrote into the text instead of `tool_calls`: Qwen2.5's
/// `<tool_call>{"name": ..., "arguments": {...}}</tool_call>` (llama-cpp-python's server
/// with the model's own template leaves them there). Each as `(name, arguments)`.
fn tool_calls_in_text(content: &str) -> Vec<(String, Value)> {
    let mut out = Vec::new();
    let mut rest = content;
    while let Some(i) = rest.find("<tool_call>") {
        let after = &rest[i + "<tool_call>".len()..];
        let end = after.find("</tool_call>").unwrap_or(after.len());
        if let Ok(v) = serde_json::from_str::<Value>(after[..end].trim())
            && let Some(name) = v.get("name").and_then(Value::as_str)
        {
            let args = match v.get("arguments") {
                Some(Value::String(s)) => serde_json::from_str(s).unwrap_or(Value::Null),
                Some(a) => a.clone(),
                None => Value::Object(Default::default()),
            };
            out.push((name.to_string(), args));
        }
        rest = &after[end.min(after.len())..];
    }
    out
}

/// The server's own error message from an error body, if it has one.
fn server_message(body: &str) -> String {
    serde_json::from_str::<Value>(body)
        .ok()
        .and_then(|v| {
            v.pointer("/error/message")
                .or_else(|| v.get("error"))
                .or_else(|| v.get("message"))
                .map(|m| {
                    m.as_str()
                        .map(str::to_string)
                        .unwrap_or_else(|| m.to_string())
                })
        })
        .unwrap_or_else(|| clip(body.trim(), 300))
}

impl ChatModel for OpenAiChat {
    fn model_id(&self) -> String {
        let host = self
            .base_url
            .split("://")
            .nth(1)
            .unwrap_or(&self.base_url)
            .split('/')
            .next()
            .unwrap_or("");
        format!("openai:{}@{host}", self.model)
    }

    fn chat(&mut self, req: &ChatRequest) -> Result<ChatResponse> {
        let mut body = self.body(req).to_string();
        let t0 = Instant::now();
        let mut delay = self.backoff;
        let mut last = String::new();
        for attempt in 0..=self.max_retries {
            if attempt > 0 {
                std::thread::sleep(delay);
                delay = delay.saturating_mul(2);
            }
            let mut reply = self.post(&body)?;
            // a server that refuses OpenAI's json_schema form (llama-cpp-python answers 500
            // with a validation error) is asked again at once in the json_object form, and
            // from then on
            if let Ok((status, text, _)) = &reply
                && !(200..=299).contains(status)
                && req.schema.is_some()
                && self.schema_form == SchemaForm::JsonSchema
                && refuses_json_schema(text)
            {
                self.schema_form = SchemaForm::JsonObject;
                body = self.body(req).to_string();
                reply = self.post(&body)?;
            }
            let (status, text, retry_after) = match reply {
                Ok(x) => x,
                Err(e) => {
                    last = e;
                    continue;
                }
            };
            match status {
                200..=299 => {
                    let mut r = parse_reply(&text, req)?;
                    r.model = self.model_id();
                    r.usage.completion_ms = t0.elapsed().as_secs_f64() * 1e3;
                    return Ok(r);
                }
                429 | 500..=599 => {
                    last = format!("HTTP {status}: {}", server_message(&text));
                    if let Some(s) = retry_after {
                        delay = delay.max(Duration::from_secs(s.min(30)));
                    }
                }
                _ => {
                    return Err(Error::LlmHttp {
                        status,
                        message: server_message(&text),
                    });
                }
            }
        }
        Err(Error::Llm(format!(
            "{}: gave up after {} tries: {last}",
            self.model_id(),
            self.max_retries + 1
        )))
    }
}

/// The offered tool a model's call names.
fn offered<'r>(req: &'r ChatRequest, name: &str) -> Result<&'r super::ToolSpec> {
    req.tools.iter().find(|t| t.name == name).ok_or_else(|| {
        Error::LlmAnswer(format!("the model called {name:?}, which was not offered"))
    })
}

/// Reads an OpenAI chat-completion reply: the first choice's content and tool calls.
pub fn parse_reply(text: &str, req: &ChatRequest) -> Result<ChatResponse> {
    let v: Value = serde_json::from_str(text).map_err(|e| {
        Error::LlmAnswer(format!(
            "the server's reply is not JSON (line {}, column {}: {e}): {}",
            e.line(),
            e.column(),
            clip(text, 200)
        ))
    })?;
    let msg = v.pointer("/choices/0/message").ok_or_else(|| {
        Error::LlmAnswer(format!(
            "the server's reply has no choices[0].message: {}",
            clip(text, 200)
        ))
    })?;
    let content = msg
        .get("content")
        .and_then(Value::as_str)
        .unwrap_or("")
        .to_string();
    let mut tool_calls = Vec::new();
    if let Some(calls) = msg.get("tool_calls").and_then(Value::as_array) {
        for (i, c) in calls.iter().enumerate() {
            let name = c
                .pointer("/function/name")
                .and_then(Value::as_str)
                .ok_or_else(|| Error::LlmAnswer(format!("tool call {i} has no function name")))?;
            let spec = offered(req, name)?;
            let args = match c.pointer("/function/arguments") {
                Some(Value::String(s)) => serde_json::from_str(s).map_err(|e| {
                    Error::LlmAnswer(format!("tool call {name:?}: arguments are not JSON: {e}"))
                })?,
                Some(o @ Value::Object(_)) => o.clone(),
                _ => Value::Object(Default::default()),
            };
            super::validate(&args, &spec.parameters)?;
            tool_calls.push(ToolCall {
                id: c
                    .get("id")
                    .and_then(Value::as_str)
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("call_{i}")),
                name: name.to_string(),
                arguments: args,
            });
        }
    }
    if tool_calls.is_empty() && !req.tools.is_empty() {
        for (i, (name, args)) in tool_calls_in_text(&content).into_iter().enumerate() {
            super::validate(&args, &offered(req, &name)?.parameters)?;
            tool_calls.push(ToolCall {
                id: format!("call_{i}"),
                name,
                arguments: args,
            });
        }
    }
    let json = match (&req.schema, tool_calls.is_empty()) {
        (Some(s), true) => Some(super::parse_structured(&content, s)?),
        _ => None,
    };
    let n = |p: &str| v.pointer(p).and_then(Value::as_u64).unwrap_or(0) as u32;
    Ok(ChatResponse {
        text: content,
        json,
        tool_calls,
        model: String::new(),
        usage: Usage {
            prompt_tokens: n("/usage/prompt_tokens"),
            completion_tokens: n("/usage/completion_tokens"),
            prompt_ms: 0.0,
            completion_ms: 0.0,
        },
    })
}
