//! `--llm openai` against an OpenAI-compatible server no one here wrote: llama-cpp-python's
//! `python -m llama_cpp.server` (PyPI `llama-cpp-python`, built from source by
//! `scripts/setup_llama_server.sh`) running the default local model, Qwen2.5-Coder 0.5B.
//! `ask` reads a question as a task through the server (a structured answer; llama-cpp-python
//! takes the `json_object` form, which the backend falls back to), and answers what our own
//! Cypher counts; `find --parser llm` parses through it; a server killed in the middle of an
//! answer is a clear error naming it, within the timeout.
//!
//! Opt-in, as it costs a source build of llama.cpp: runs only with `OPENGRAPH_LLAMA_SERVER=1`
//! and when the project's Python imports `llama_cpp`; otherwise it says why and passes.

mod common;
use common::{free_port, json, og, output_within, python_importing, read_query, s, sim_map};

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A llama_cpp.server child on a free loopback port, killed when dropped.
struct LlamaServer {
    child: Child,
    url: String,
}

impl Drop for LlamaServer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start_server(py: &Path, model: &Path, log: &Path) -> LlamaServer {
    let port = free_port();
    let child = Command::new(py)
        .args(["-m", "llama_cpp.server", "--model"])
        .arg(model)
        .args(["--host", "127.0.0.1", "--port", &port.to_string()])
        .args(["--n_ctx", "4096", "--n_threads", "2"])
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap();
    let url = format!("http://127.0.0.1:{port}/v1");
    let mut server = LlamaServer { child, url };
    // ready when GET /v1/models answers; 120 s at most
    let t0 = Instant::now();
    loop {
        if let Some(status) = server.child.try_wait().unwrap() {
            panic!(
                "llama_cpp.server exited ({status}) before it was ready: {}",
                std::fs::read_to_string(log).unwrap_or_default()
            );
        }
        let ok = std::net::TcpStream::connect(("127.0.0.1", port)).is_ok()
            && Command::new("curl")
                .args(["-sf", "-m", "5", &format!("{}/models", server.url)])
                .stdout(Stdio::null())
                .status()
                .is_ok_and(|s| s.success());
        if ok {
            return server;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "llama_cpp.server not ready in 120 s"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
}

#[test]
fn ask_and_find_through_a_llama_cpp_python_server() {
    if std::env::var("OPENGRAPH_LLAMA_SERVER").as_deref() != Ok("1") {
        eprintln!(
            "skipping: opt-in (OPENGRAPH_LLAMA_SERVER=1, after scripts/setup_llama_server.sh)"
        );
        return;
    }
    let Some(py) = python_importing("llama_cpp.server") else {
        eprintln!(
            "skipping: the project's Python has no llama_cpp (run scripts/setup_llama_server.sh)"
        );
        return;
    };
    let model =
        llm_tools::embed::default_models_dir().join("qwen2.5-coder-0.5b-instruct-q4_k_m.gguf");
    if !model.exists() {
        eprintln!(
            "skipping: {} is not there (run scripts/setup.sh)",
            model.display()
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (_sim, db) = sim_map(dir.path(), &["--size", "small", "--seed", "0"], &[]);
    let log = dir.path().join("llama_server.log");
    let server = start_server(&py, &model, &log);
    let url = server.url.clone();
    let openai = |args: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = args.iter().map(|a| a.to_string()).collect();
        v.extend(
            [
                "--llm",
                "openai",
                "--llm-url",
                &url,
                "--llm-model",
                "qwen2.5-coder-0.5b",
            ]
            .map(str::to_string),
        );
        v
    };
    let run = |args: Vec<String>| {
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        og(&refs)
    };

    // ask: the question read as a task by the model behind the server, answered by the tools
    let truth = read_query(
        &db,
        "MATCH (i:Instance) WHERE i.label = 'bench' RETURN count(i) AS n",
    )[0]["n"]
        .as_u64()
        .unwrap();
    let t0 = Instant::now();
    let out = run(openai(&[
        "ask",
        "--db",
        s(&db),
        "--json",
        "How many benches are there?",
    ]));
    let secs = t0.elapsed().as_secs_f64();
    let a = json(&out);
    let model_id = a["model"].as_str().unwrap();
    assert!(
        model_id.contains("openai:qwen2.5-coder-0.5b@127.0.0.1"),
        "{a}"
    );
    assert_eq!(a["task"]["task"], "count", "{a}");
    assert_eq!(a["value"].as_u64(), Some(truth), "{a}");
    eprintln!("ask through llama_cpp.server: {secs:.1} s, model {model_id}");

    // find with the request parsed by the model behind the server
    let find_by_llm = || {
        run(openai(&[
            "find",
            "--db",
            s(&db),
            "--parser",
            "llm",
            "--json",
            "the bench near the bus stop",
        ]))
    };
    let out = find_by_llm();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("parsed by openai:qwen2.5-coder-0.5b"), "{err}");
    let results = json(&out);
    assert!(!results.as_array().unwrap().is_empty());

    // the server dies in the middle of an answer: ask says so in its transcript and answers
    // with the rule parser's reading instead, without hanging
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_opengraph"));
    cmd.args(openai(&[
        "ask",
        "--db",
        s(&db),
        "--json",
        "What is the nearest bench to the start of the drive?",
    ]));
    let mut server = server;
    let killer = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(300));
        let _ = server.child.kill();
        let _ = server.child.wait();
    });
    let t0 = Instant::now();
    let out = output_within(cmd, 300);
    killer.join().unwrap();
    let took = t0.elapsed();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let a: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        a["model"]
            .as_str()
            .unwrap()
            .starts_with("rules, after openai:"),
        "{a}"
    );
    let transcript = a["transcript"].to_string();
    assert!(
        transcript.contains("127.0.0.1"),
        "the failure names the server: {transcript}"
    );
    assert!(a["answer"].is_string(), "{a}");
    assert!(took < Duration::from_secs(240), "{took:?}");
    eprintln!(
        "server killed mid-answer: rules answered after {:.1} s",
        took.as_secs_f64()
    );

    // with the server gone, a find parsed by it fails at once, naming the server (exit 1: not
    // the user's input)
    let out = find_by_llm();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains(&url), "{err}");
}
