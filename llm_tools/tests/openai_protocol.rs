//! Protocol edge cases of the OpenAI-compatible backend against a recorded-reply server on
//! 127.0.0.1: retries on 5xx and 429 (with Retry-After), no retry on other 4xx, timeouts,
//! unparseable replies, answers that break the schema, unknown tools, bad settings.

mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use common::{Answer, RecordedServer};
use llm_tools::chat::openai::OpenAiChat;
use llm_tools::{ChatModel, ChatRequest, LlmConfig, Message};
use serde_json::{Value, json};

fn ok_body(content: &str) -> String {
    json!({"choices": [{"index": 0, "message": {"role": "assistant", "content": content}}],
           "usage": {"prompt_tokens": 5, "completion_tokens": 2}})
    .to_string()
}

fn client(server: &RecordedServer, timeout_ms: u64, retries: u32) -> OpenAiChat {
    OpenAiChat::new(
        &server.url(),
        "m",
        None,
        Duration::from_millis(timeout_ms),
        retries,
    )
    .unwrap()
    .with_backoff(Duration::from_millis(10))
}

fn hello() -> ChatRequest {
    ChatRequest::new(vec![Message::user("hi")])
}

#[test]
fn server_errors_and_rate_limits_are_retried_then_succeed() {
    let n = Arc::new(AtomicU32::new(0));
    let c = n.clone();
    let server = RecordedServer::start(move |_: &Value| -> Answer {
        match c.fetch_add(1, Ordering::SeqCst) {
            0 => (
                503,
                r#"{"error": {"message": "loading model"}}"#.to_string(),
            )
                .into(),
            1 => Answer {
                status: 429,
                body: r#"{"error": {"message": "slow down"}}"#.into(),
                delay: Duration::ZERO,
                headers: vec![("Retry-After".into(), "0".into())],
            },
            _ => (200, ok_body("hello")).into(),
        }
    });
    let r = client(&server, 2000, 3).chat(&hello()).unwrap();
    assert_eq!(r.text, "hello");
    assert_eq!(r.usage.prompt_tokens, 5);
    assert_eq!(n.load(Ordering::SeqCst), 3);
}

#[test]
fn retries_are_bounded_and_the_last_error_is_given() {
    let server =
        RecordedServer::start(|_: &Value| (500, r#"{"error": {"message": "boom"}}"#.to_string()));
    let e = client(&server, 2000, 2)
        .chat(&hello())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("gave up after 3 tries") && e.contains("HTTP 500: boom"),
        "{e}"
    );
    assert_eq!(server.requests().len(), 3);
}

#[test]
fn client_errors_fail_at_once_with_the_servers_message() {
    let server = RecordedServer::start(|_: &Value| {
        (
            401,
            r#"{"error": {"message": "Incorrect API key provided"}}"#.to_string(),
        )
    });
    let e = client(&server, 2000, 3)
        .chat(&hello())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("HTTP 401") && e.contains("Incorrect API key"),
        "{e}"
    );
    assert_eq!(server.requests().len(), 1, "a 4xx is not retried");
}

#[test]
fn a_slow_server_times_out() {
    let server = RecordedServer::start(|_: &Value| Answer {
        status: 200,
        body: ok_body("late"),
        delay: Duration::from_millis(800),
        headers: Vec::new(),
    });
    let t = Instant::now();
    let e = client(&server, 200, 1)
        .chat(&hello())
        .unwrap_err()
        .to_string();
    assert!(e.contains("timed out"), "{e}");
    assert!(t.elapsed() < Duration::from_secs(5));
}

#[test]
fn unparseable_and_misshapen_replies_are_clear_errors() {
    let server = RecordedServer::start(|b: &Value| {
        let q = b["messages"][0]["content"]
            .as_str()
            .unwrap_or("")
            .to_string();
        let body = match q.as_str() {
            "html" => "<html>502 Bad Gateway</html>".to_string(),
            "nochoices" => r#"{"object": "chat.completion"}"#.to_string(),
            "schema" => ok_body(r#"{"count": "three"}"#),
            "tool" => json!({"choices": [{"message": {"role": "assistant", "content": null,
                "tool_calls": [{"id": "c1", "type": "function",
                                "function": {"name": "rm_rf", "arguments": "{}"}}]}}]})
            .to_string(),
            _ => ok_body("fine"),
        };
        (200, body)
    });
    let mut m = client(&server, 2000, 0);
    let ask = |m: &mut OpenAiChat, q: &str, schema: Option<Value>| {
        let mut r = ChatRequest::new(vec![Message::user(q)]);
        r.schema = schema;
        if q == "tool" {
            r.tools = vec![llm_tools::ToolSpec {
                name: "find".into(),
                description: "find".into(),
                parameters: json!({"type": "object"}),
            }];
        }
        m.chat(&r).unwrap_err().to_string()
    };
    let e = ask(&mut m, "html", None);
    assert!(
        e.contains("not JSON") && e.contains("502 Bad Gateway"),
        "{e}"
    );
    let e = ask(&mut m, "nochoices", None);
    assert!(e.contains("choices[0].message"), "{e}");
    let schema = json!({"type": "object", "properties": {"count": {"type": "integer"}}, "required": ["count"]});
    let e = ask(&mut m, "schema", Some(schema));
    assert!(
        e.contains("does not follow the schema") && e.contains("/count"),
        "{e}"
    );
    let e = ask(&mut m, "tool", None);
    assert!(e.contains("rm_rf") && e.contains("not offered"), "{e}");
}

#[test]
fn an_unreachable_server_is_named() {
    // a port nothing listens on: bind, read the port, close
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let mut m = OpenAiChat::new(
        &format!("http://127.0.0.1:{port}/v1"),
        "m",
        None,
        Duration::from_secs(2),
        1,
    )
    .unwrap()
    .with_backoff(Duration::from_millis(10));
    let e = m.chat(&hello()).unwrap_err().to_string();
    assert!(
        e.contains("gave up after 2 tries") && e.contains(&format!("127.0.0.1:{port}")),
        "{e}"
    );
}

#[test]
fn bad_settings_are_refused_before_any_request() {
    assert!(
        OpenAiChat::new("ftp://x", "m", None, Duration::from_secs(1), 0)
            .unwrap_err()
            .to_string()
            .contains("http://")
    );
    assert!(
        OpenAiChat::new("http://x", " ", None, Duration::from_secs(1), 0)
            .unwrap_err()
            .to_string()
            .contains("model name")
    );
    for t in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e9] {
        let cfg = LlmConfig {
            backend: "openai".into(),
            url: Some("http://127.0.0.1:1/v1".into()),
            model: Some("m".into()),
            timeout_secs: Some(t),
            ..LlmConfig::default()
        };
        let e = OpenAiChat::from_config(&cfg).unwrap_err().to_string();
        assert!(e.contains("timeout_secs"), "{t}: {e}");
    }
    let e = llm_tools::chat::open(&LlmConfig {
        backend: "gpt5".into(),
        ..LlmConfig::default()
    })
    .unwrap_err()
    .to_string();
    assert!(e.contains("unknown LLM backend"), "{e}");
    assert!(
        llm_tools::chat::open(&LlmConfig::default())
            .unwrap()
            .is_none()
    );
}

/// A server that refuses OpenAI's `json_schema` response format (llama-cpp-python answers 500
/// with a validation error) is asked again at once in the `json_object` form, which it takes,
/// and keeps being asked that way; the retry budget is not spent on it.
#[test]
fn a_server_without_json_schema_gets_the_json_object_form() {
    let server = RecordedServer::start(move |body: &Value| -> Answer {
        match body.pointer("/response_format/type").and_then(Value::as_str) {
            Some("json_schema") => (
                500,
                r#"{"error": {"message": "1 validation error: ('body', 'response_format', 'type'): Input should be 'text' or 'json_object'"}}"#
                    .to_string(),
            )
                .into(),
            Some("json_object") => {
                assert!(body.pointer("/response_format/schema/properties").is_some());
                (200, ok_body(r#"{"colour": "blue"}"#)).into()
            }
            _ => (400, r#"{"error": {"message": "no schema"}}"#.to_string()).into(),
        }
    });
    let mut m = client(&server, 2000, 0);
    let schema = json!({"type": "object", "properties": {"colour": {"type": "string"}},
                        "required": ["colour"], "additionalProperties": false});
    let mut req = hello();
    req.schema = Some(schema.clone());
    for _ in 0..2 {
        let r = m.chat(&req).unwrap();
        assert_eq!(r.json, Some(json!({"colour": "blue"})));
    }
    let forms: Vec<String> = server
        .requests()
        .iter()
        .map(|s| {
            s.body["response_format"]["type"]
                .as_str()
                .unwrap_or("")
                .to_string()
        })
        .collect();
    assert_eq!(forms, ["json_schema", "json_object", "json_object"]);
}

/// Tool calls a chat template left in the text (`<tool_call>{...}</tool_call>`, as Qwen2.5's
/// template writes them) are read as tool calls, and checked against the offered tools.
#[test]
fn tool_calls_written_into_the_text_are_read() {
    let server = RecordedServer::start(move |_: &Value| -> Answer {
        (
            200,
            ok_body(
                "<tool_call>\n{\"name\": \"count_objects\", \"arguments\": {\"kind\": \"bench\"}}\n</tool_call>",
            ),
        )
            .into()
    });
    let mut req = hello();
    req.tools = vec![llm_tools::ToolSpec {
        name: "count_objects".into(),
        description: "count".into(),
        parameters: json!({"type": "object", "properties": {"kind": {"type": "string"}},
                           "required": ["kind"]}),
    }];
    let r = client(&server, 2000, 0).chat(&req).unwrap();
    assert_eq!(r.tool_calls.len(), 1);
    assert_eq!(r.tool_calls[0].name, "count_objects");
    assert_eq!(r.tool_calls[0].arguments, json!({"kind": "bench"}));
    // a call to a tool not offered is an error, as in tool_calls
    req.tools[0].name = "other".into();
    assert!(client(&server, 2000, 0).chat(&req).is_err());
}
