//! One conformance suite for every `ChatModel` backend: plain answers, JSON-schema answers,
//! tool calls and tool results, token limits and model ids. It runs against the scripted
//! backend, the OpenAI-compatible backend (against a recorded-reply server on 127.0.0.1, port
//! 0) and the local llama.cpp backend on the smallest real model (SmolLM2-135M) and, when its
//! file is there, the default model (Qwen2.5-Coder-0.5B), which must also answer correctly.
//! Local runs skip with a message when `scripts/setup.sh` has not fetched the models.

mod common;

use common::RecordedServer;
use llm_tools::chat::local::LocalGguf;
use llm_tools::chat::openai::OpenAiChat;
use llm_tools::chat::scripted::{Reply, Scripted};
use llm_tools::chat::{DEFAULT_LOCAL_MODEL, SMALLEST_LOCAL_MODEL};
use llm_tools::{ChatModel, ChatRequest, Message, Role, ToolCall, ToolSpec};
use serde_json::{Value, json};

fn colour_schema() -> Value {
    json!({"type": "object",
           "properties": {"colour": {"type": "string", "enum": ["red", "green", "blue"]},
                          "count": {"type": "integer", "minimum": 0, "maximum": 10}},
           "required": ["colour", "count"], "additionalProperties": false})
}

fn weather_tool() -> ToolSpec {
    ToolSpec {
        name: "get_weather".into(),
        description: "The current weather in a city.".into(),
        parameters: json!({"type": "object", "properties": {"city": {"type": "string"}},
                           "required": ["city"], "additionalProperties": false}),
    }
}

fn structured_request() -> ChatRequest {
    ChatRequest::new(vec![
        Message::system("You extract facts from the user's text."),
        Message::user(
            "Three red cars are parked outside. Give their colour and how many there are.",
        ),
    ])
    .with_schema(colour_schema())
    .with_max_tokens(48)
}

fn tool_request() -> ChatRequest {
    ChatRequest::new(vec![
        Message::system("You are a helpful assistant. Use a tool when it helps."),
        Message::user("What is the weather in Paris right now?"),
    ])
    .with_tools(vec![weather_tool()])
    .with_max_tokens(64)
}

/// The suite. `capable`: the model must also get the structured answer right, not only its
/// shape; `uses_tools`: it must also call the offered tool and answer from its result.
fn conformance(m: &mut dyn ChatModel, capable: bool, uses_tools: bool) {
    let id = m.model_id();
    assert!(!id.is_empty());
    // 1. a plain answer within the token limit
    let r = m
        .chat(
            &ChatRequest::new(vec![Message::user("Say hello in one short sentence.")])
                .with_max_tokens(24),
        )
        .unwrap();
    assert_eq!(r.model, id);
    assert!(!r.text.trim().is_empty(), "{r:?}");
    assert!(r.json.is_none() && r.tool_calls.is_empty());
    assert!(r.usage.completion_tokens <= 24, "{:?}", r.usage);
    // 2. a structured answer is valid JSON of the schema (validated by the trait's contract)
    let r = m.chat(&structured_request()).unwrap();
    let v = r.json.clone().expect("a structured answer");
    llm_tools::chat::validate(&v, &colour_schema()).unwrap();
    if capable {
        assert_eq!(v["colour"], "red", "{v}");
        assert_eq!(v["count"], 3, "{v}");
    }
    // 3. tools: a call with arguments valid against the tool's schema, or an answer
    let r = m.chat(&tool_request()).unwrap();
    for c in &r.tool_calls {
        assert_eq!(c.name, "get_weather");
        llm_tools::chat::validate(&c.arguments, &weather_tool().parameters).unwrap();
    }
    if uses_tools {
        assert_eq!(r.tool_calls.len(), 1, "{r:?}");
        assert!(
            r.tool_calls[0].arguments["city"]
                .as_str()
                .is_some_and(|c| c.contains("Paris")),
            "{r:?}"
        );
    } else {
        assert!(!r.tool_calls.is_empty() || !r.text.is_empty(), "{r:?}");
    }
    // 4. a tool result goes back and the model answers from it
    let call = ToolCall {
        id: "call_1".into(),
        name: "get_weather".into(),
        arguments: json!({"city": "Paris"}),
    };
    let mut msgs = tool_request().messages;
    msgs.push(Message {
        role: Role::Assistant,
        content: String::new(),
        tool_calls: vec![call],
        tool_call_id: None,
    });
    msgs.push(Message {
        role: Role::Tool,
        content: json!({"city": "Paris", "weather": "light rain", "temperature_c": 11}).to_string(),
        tool_calls: Vec::new(),
        tool_call_id: Some("call_1".into()),
    });
    let r = m
        .chat(
            &ChatRequest::new(msgs)
                .with_tools(vec![weather_tool()])
                .with_max_tokens(48),
        )
        .unwrap();
    assert!(
        !r.text.trim().is_empty() || !r.tool_calls.is_empty(),
        "{r:?}"
    );
    if uses_tools {
        let t = r.text.to_lowercase();
        assert!(t.contains("rain") || t.contains("11"), "{}", r.text);
    }
}

/// A scripted model that answers the suite's requests in the right shape.
fn scripted() -> Scripted {
    Scripted::from_fn("conformance", |req| {
        if req.schema.is_some() {
            Reply::Text(r#"{"colour": "red", "count": 3}"#.into())
        } else if req.messages.iter().any(|m| m.role == Role::Tool) {
            Reply::Text("It is raining lightly in Paris, 11 °C.".into())
        } else if !req.tools.is_empty() {
            Reply::Tools(vec![("get_weather".into(), json!({"city": "Paris"}))])
        } else {
            Reply::Text("Hello there.".into())
        }
    })
}

#[test]
fn scripted_backend_conforms() {
    conformance(&mut scripted(), true, true);
}

#[test]
fn scripted_backend_refuses_answers_of_the_wrong_shape() {
    let mut m = Scripted::new(
        "bad",
        vec![
            Reply::Text(r#"{"colour": "purple", "count": 3}"#.into()),
            Reply::Text("not json".into()),
            Reply::Tools(vec![("launch_rocket".into(), json!({}))]),
        ],
    );
    let e = m.chat(&structured_request()).unwrap_err().to_string();
    assert!(
        e.contains("does not follow the schema") && e.contains("/colour"),
        "{e}"
    );
    let e = m.chat(&structured_request()).unwrap_err().to_string();
    assert!(e.contains("not JSON") && e.contains("line 1"), "{e}");
    let e = m.chat(&tool_request()).unwrap_err().to_string();
    assert!(e.contains("launch_rocket"), "{e}");
    let e = m.chat(&tool_request()).unwrap_err().to_string();
    assert!(e.contains("no reply left"), "{e}");
}

/// The OpenAI-compatible backend against a server that replays the suite's answers as an
/// OpenAI server sends them.
#[test]
fn openai_backend_conforms() {
    let mut script = scripted();
    let server = RecordedServer::start(move |body: &Value| {
        let req = common::request_from_openai_body(body);
        let reply = match script.chat(&req) {
            Ok(r) => r,
            Err(e) => {
                return (
                    500,
                    json!({"error": {"message": e.to_string()}}).to_string(),
                );
            }
        };
        (200, common::openai_reply(&reply).to_string())
    });
    let mut m = OpenAiChat::new(
        &server.url(),
        "recorded",
        Some("sk-test".into()),
        std::time::Duration::from_secs(5),
        2,
    )
    .unwrap();
    conformance(&mut m, true, true);
    assert!(m.model_id().starts_with("openai:recorded@127.0.0.1:"));
    // what went over the wire: the key, the schema as response_format, the tools
    let seen = server.requests();
    assert!(
        seen.iter()
            .all(|r| r.authorization.as_deref() == Some("Bearer sk-test"))
    );
    assert!(
        seen.iter()
            .any(|r| r.body["response_format"]["json_schema"]["schema"] == colour_schema())
    );
    assert!(
        seen.iter()
            .any(|r| r.body["tools"][0]["function"]["name"] == "get_weather")
    );
    assert!(seen.iter().any(|r| {
        r.body["messages"]
            .as_array()
            .unwrap()
            .iter()
            .any(|m| m["role"] == "tool" && m["tool_call_id"] == "call_1")
    }));
}

fn local(name: &str) -> Option<LocalGguf> {
    let path = llm_tools::embed::default_models_dir().join(name);
    if !path.exists() {
        eprintln!(
            "skipping: {} not found (run scripts/setup.sh)",
            path.display()
        );
        return None;
    }
    Some(LocalGguf::open(&path, 2).unwrap())
}

#[test]
fn local_backend_conforms_on_the_smallest_model() {
    let Some(mut m) = local(SMALLEST_LOCAL_MODEL) else {
        return;
    };
    assert!(m.model_id().starts_with("SmolLM2-135M-Instruct.Q4_1.gguf:"));
    conformance(&mut m, false, false);
}

#[test]
fn local_backend_conforms_and_answers_right_on_the_default_model() {
    let Some(mut m) = local(DEFAULT_LOCAL_MODEL) else {
        return;
    };
    // measured: Qwen2.5-Coder-0.5B answers the weather question itself (an invented forecast)
    // instead of calling get_weather, with and without the <tool_call> form, and after a tool
    // response it answers "{" or calls the tool again; its structured answers are right
    conformance(&mut m, true, false);
}

#[test]
fn local_backend_errors_are_clear() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.gguf");
    let e = LocalGguf::open(&missing, 1).unwrap_err().to_string();
    assert!(
        e.contains("scripts/setup.sh") && e.contains("nope.gguf"),
        "{e}"
    );
    let fake = dir.path().join("fake.gguf");
    std::fs::write(&fake, b"PK\x03\x04 not a model").unwrap();
    let e = LocalGguf::open(&fake, 1).unwrap_err().to_string();
    assert!(
        e.contains("not a GGUF file") && e.contains("fake.gguf"),
        "{e}"
    );
    // a GGUF magic with nothing behind it: llama.cpp refuses it, we do not crash
    let trunc = dir.path().join("trunc.gguf");
    std::fs::write(&trunc, b"GGUF\x03\x00\x00\x00").unwrap();
    let e = LocalGguf::open(&trunc, 1).unwrap_err().to_string();
    assert!(e.contains("trunc.gguf"), "{e}");
}

/// A request whose system prompt is long enough to be kept as a decoded state.
fn long_system_request(question: &str) -> ChatRequest {
    ChatRequest::new(vec![
        Message::system(
            "You extract facts from the user's text. Read the whole text before you answer. \
             A colour is one of red, green or blue; a count is how many things of that colour \
             the text names, from 0 to 10. When the text names no colour, answer the colour \
             it names most often. Never explain; give the JSON object only.",
        ),
        Message::user(question),
    ])
    .with_schema(colour_schema())
    .with_max_tokens(32)
}

#[test]
fn local_backend_reuses_a_system_prompts_state_and_answers_the_same() {
    let Some(mut m) = local(SMALLEST_LOCAL_MODEL) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    m.set_state_dir(Some(dir.path().to_path_buf()));
    let q1 = long_system_request("Three red cars are parked outside.");
    let q2 = long_system_request("Two blue bikes lean on a green fence.");
    let a1 = m.chat(&q1).unwrap();
    let a2 = m.chat(&q2).unwrap();
    let files: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "state"))
        .collect();
    assert_eq!(
        files.len(),
        1,
        "one state file for one system prompt: {files:?}"
    );
    // a fresh process: the state comes from the file; without a state dir it is decoded
    let mut from_file = local(SMALLEST_LOCAL_MODEL).unwrap();
    from_file.set_state_dir(Some(dir.path().to_path_buf()));
    assert_eq!(from_file.chat(&q2).unwrap().text, a2.text);
    let mut fresh = local(SMALLEST_LOCAL_MODEL).unwrap();
    fresh.set_state_dir(None);
    assert_eq!(fresh.chat(&q1).unwrap().text, a1.text);
    assert_eq!(fresh.chat(&q2).unwrap().text, a2.text);
    // a damaged state file (llama.cpp would abort on it) is decoded anew and rewritten,
    // with the same answer
    for damage in [b"not a llama.cpp state file".to_vec(), {
        let b = std::fs::read(&files[0]).unwrap();
        b[..b.len() / 2].to_vec()
    }] {
        std::fs::write(&files[0], damage).unwrap();
        let mut m = local(SMALLEST_LOCAL_MODEL).unwrap();
        m.set_state_dir(Some(dir.path().to_path_buf()));
        assert_eq!(m.chat(&q1).unwrap().text, a1.text);
    }
    let mut again = local(SMALLEST_LOCAL_MODEL).unwrap();
    again.set_state_dir(Some(dir.path().to_path_buf()));
    assert_eq!(again.chat(&q2).unwrap().text, a2.text);
}
