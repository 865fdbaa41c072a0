//! A recorded-reply OpenAI-compatible server for protocol tests: a thread on 127.0.0.1,
//! port 0, that answers each `POST /v1/chat/completions` with what a function of the request
//! body returns (status and body), and records every request. Socket reads and writes have
//! timeouts, so no test can hang on it.
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpListener;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use llm_tools::{ChatRequest, ChatResponse, Message, Role, ToolCall, ToolSpec};
use serde_json::{Value, json};

/// A request as the server saw it.
#[derive(Debug, Clone)]
pub struct Seen {
    pub path: String,
    pub authorization: Option<String>,
    pub body: Value,
}

/// What the server does with one request: reply (status, body), optionally after a delay,
/// with extra headers.
pub struct Answer {
    pub status: u16,
    pub body: String,
    pub delay: Duration,
    pub headers: Vec<(String, String)>,
}

impl From<(u16, String)> for Answer {
    fn from((status, body): (u16, String)) -> Answer {
        Answer {
            status,
            body,
            delay: Duration::ZERO,
            headers: Vec::new(),
        }
    }
}

pub struct RecordedServer {
    port: u16,
    seen: Arc<Mutex<Vec<Seen>>>,
}

impl RecordedServer {
    pub fn start<A: Into<Answer>>(
        mut f: impl FnMut(&Value) -> A + Send + 'static,
    ) -> RecordedServer {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let seen = Arc::new(Mutex::new(Vec::new()));
        let log = seen.clone();
        std::thread::spawn(move || {
            for stream in listener.incoming() {
                let Ok(mut stream) = stream else { continue };
                stream.set_read_timeout(Some(Duration::from_secs(10))).ok();
                stream.set_write_timeout(Some(Duration::from_secs(10))).ok();
                let mut reader = BufReader::new(stream.try_clone().unwrap());
                let mut line = String::new();
                if reader.read_line(&mut line).is_err() {
                    continue;
                }
                let path = line.split_whitespace().nth(1).unwrap_or("").to_string();
                let (mut len, mut auth) = (0usize, None);
                loop {
                    let mut h = String::new();
                    if reader.read_line(&mut h).is_err() || h.trim().is_empty() {
                        break;
                    }
                    let (k, v) = h.split_once(':').unwrap_or((&h, ""));
                    match k.trim().to_ascii_lowercase().as_str() {
                        "content-length" => len = v.trim().parse().unwrap_or(0),
                        "authorization" => auth = Some(v.trim().to_string()),
                        _ => {}
                    }
                }
                let mut body = vec![0u8; len];
                if reader.read_exact(&mut body).is_err() {
                    continue;
                }
                let body: Value = serde_json::from_slice(&body).unwrap_or(Value::Null);
                let a: Answer = f(&body).into();
                log.lock().unwrap().push(Seen {
                    path,
                    authorization: auth,
                    body,
                });
                std::thread::sleep(a.delay);
                let mut head = format!(
                    "HTTP/1.1 {} X\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n",
                    a.status,
                    a.body.len()
                );
                for (k, v) in &a.headers {
                    head.push_str(&format!("{k}: {v}\r\n"));
                }
                head.push_str("\r\n");
                let _ = stream.write_all(head.as_bytes());
                let _ = stream.write_all(a.body.as_bytes());
            }
        });
        RecordedServer { port, seen }
    }

    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}/v1", self.port)
    }

    pub fn requests(&self) -> Vec<Seen> {
        self.seen.lock().unwrap().clone()
    }
}

/// The chat request an OpenAI request body stands for (so a scripted model can answer it).
pub fn request_from_openai_body(body: &Value) -> ChatRequest {
    let messages = body["messages"]
        .as_array()
        .map(|ms| {
            ms.iter()
                .map(|m| Message {
                    role: serde_json::from_value(m["role"].clone()).unwrap_or(Role::User),
                    content: m["content"].as_str().unwrap_or("").to_string(),
                    tool_calls: m["tool_calls"]
                        .as_array()
                        .map(|cs| {
                            cs.iter()
                                .map(|c| ToolCall {
                                    id: c["id"].as_str().unwrap_or("").into(),
                                    name: c["function"]["name"].as_str().unwrap_or("").into(),
                                    arguments: serde_json::from_str(
                                        c["function"]["arguments"].as_str().unwrap_or("{}"),
                                    )
                                    .unwrap_or(json!({})),
                                })
                                .collect()
                        })
                        .unwrap_or_default(),
                    tool_call_id: m["tool_call_id"].as_str().map(str::to_string),
                })
                .collect()
        })
        .unwrap_or_default();
    ChatRequest {
        messages,
        schema: body.pointer("/response_format/json_schema/schema").cloned(),
        tools: body["tools"]
            .as_array()
            .map(|ts| {
                ts.iter()
                    .map(|t| ToolSpec {
                        name: t["function"]["name"].as_str().unwrap_or("").into(),
                        description: t["function"]["description"].as_str().unwrap_or("").into(),
                        parameters: t["function"]["parameters"].clone(),
                    })
                    .collect()
            })
            .unwrap_or_default(),
        require_tool: body["tool_choice"] == "required",
        max_tokens: body["max_tokens"].as_u64().unwrap_or(256) as u32,
    }
}

/// An OpenAI chat-completion reply body carrying `r`.
pub fn openai_reply(r: &ChatResponse) -> Value {
    let calls: Vec<Value> = r
        .tool_calls
        .iter()
        .map(|c| {
            json!({"id": c.id, "type": "function",
                        "function": {"name": c.name, "arguments": c.arguments.to_string()}})
        })
        .collect();
    let mut msg = json!({"role": "assistant", "content": r.text});
    if !calls.is_empty() {
        msg["tool_calls"] = json!(calls);
        msg["content"] = Value::Null;
    }
    json!({"id": "chatcmpl-1", "object": "chat.completion", "model": "recorded",
           "choices": [{"index": 0, "message": msg,
                        "finish_reason": if calls.is_empty() { "stop" } else { "tool_calls" }}],
           "usage": {"prompt_tokens": r.usage.prompt_tokens, "completion_tokens": r.usage.completion_tokens,
                     "total_tokens": r.usage.prompt_tokens + r.usage.completion_tokens}})
}
