//! A deterministic chat model for tests: it answers from a script, in order, or from a
//! function of the request. It is only ever chosen explicitly (`Scripted::new`), never as a
//! stand-in for a real model, and its id says what it is.

use std::collections::VecDeque;

use super::{ChatModel, ChatRequest, ChatResponse, ToolCall, Usage, parse_structured};
use crate::error::{Error, Result};

/// One scripted answer.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// Answer with this text (parsed and validated when the request has a schema).
    Text(String),
    /// Call these tools: (name, arguments).
    Tools(Vec<(String, serde_json::Value)>),
}

type Responder = Box<dyn FnMut(&ChatRequest) -> Reply + Send>;

/// A scripted chat model.
pub struct Scripted {
    name: String,
    queue: VecDeque<Reply>,
    responder: Option<Responder>,
    calls: u32,
}

impl std::fmt::Debug for Scripted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scripted")
            .field("name", &self.name)
            .field("queued", &self.queue.len())
            .finish()
    }
}

impl Scripted {
    /// Answers with `replies` in order; errors once they run out.
    pub fn new(name: &str, replies: Vec<Reply>) -> Scripted {
        Scripted {
            name: name.to_string(),
            queue: replies.into(),
            responder: None,
            calls: 0,
        }
    }

    /// Answers every request with `f(request)`.
    pub fn from_fn(name: &str, f: impl FnMut(&ChatRequest) -> Reply + Send + 'static) -> Scripted {
        Scripted {
            name: name.to_string(),
            queue: VecDeque::new(),
            responder: Some(Box::new(f)),
            calls: 0,
        }
    }

    /// Requests answered so far.
    pub fn calls(&self) -> u32 {
        self.calls
    }
}

impl ChatModel for Scripted {
    fn model_id(&self) -> String {
        format!("scripted:{}", self.name)
    }

    fn chat(&mut self, req: &ChatRequest) -> Result<ChatResponse> {
        let reply = match (&mut self.responder, self.queue.pop_front()) {
            (_, Some(r)) => r,
            (Some(f), None) => f(req),
            (None, None) => {
                return Err(Error::Llm(format!(
                    "the scripted model {:?} has no reply left for request {}",
                    self.name,
                    self.calls + 1
                )));
            }
        };
        self.calls += 1;
        let prompt_tokens = req
            .messages
            .iter()
            .map(|m| m.content.split_whitespace().count() as u32)
            .sum();
        let (text, tool_calls) = match reply {
            Reply::Text(t) => (t, Vec::new()),
            Reply::Tools(calls) => {
                let mut out = Vec::new();
                for (i, (name, arguments)) in calls.into_iter().enumerate() {
                    let Some(spec) = req.tools.iter().find(|t| t.name == name) else {
                        return Err(Error::LlmAnswer(format!(
                            "the scripted model called {name:?}, which the request does not offer"
                        )));
                    };
                    super::validate(&arguments, &spec.parameters)?;
                    out.push(ToolCall {
                        id: format!("call_{}_{i}", self.calls),
                        name,
                        arguments,
                    });
                }
                (String::new(), out)
            }
        };
        let json = match (&req.schema, tool_calls.is_empty()) {
            (Some(s), true) => Some(parse_structured(&text, s)?),
            _ => None,
        };
        Ok(ChatResponse {
            usage: Usage {
                prompt_tokens,
                completion_tokens: text.split_whitespace().count() as u32,
                ..Usage::default()
            },
            text,
            json,
            tool_calls,
            model: self.model_id(),
        })
    }
}
