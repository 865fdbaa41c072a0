//! The language-model commands from the command line: clear errors before any work (no model,
//! a missing model file, an openai backend without a URL), and, with the smallest real model
//! (SmolLM2-135M, when `scripts/setup.sh` fetched it), a caption merge and relation labels on a
//! small simulated map that record their model and prompt and resume without asking again.

mod common;
use common::{json, og, read_query, s, sim_map};

fn expect_usage_error(args: &[&str], needles: &[&str]) {
    let out = og(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {n:?} not in {err}");
    }
}

#[test]
fn llm_commands_fail_clearly_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("d.og");
    assert!(og(&["demo", "--db", s(&db)]).status.success());
    // the LLM relation labels are an experiment, run only when asked for
    expect_usage_error(
        &["relations", "--db", s(&db)],
        &["not a feature", "--experimental"],
    );
    expect_usage_error(
        &[
            "relations",
            "--db",
            s(&db),
            "--experimental",
            "--llm",
            "none",
        ],
        &["relations needs a language model"],
    );
    let missing = dir.path().join("no-such-model.gguf");
    expect_usage_error(
        &[
            "captions",
            "--db",
            s(&db),
            "--llm",
            "local",
            "--llm-model",
            s(&missing),
        ],
        &["no-such-model.gguf", "scripts/setup.sh"],
    );
    let notgguf = dir.path().join("x.gguf");
    std::fs::write(&notgguf, "hello").unwrap();
    expect_usage_error(
        &[
            "relations",
            "--db",
            s(&db),
            "--experimental",
            "--llm-model",
            s(&notgguf),
        ],
        &["x.gguf", "not a GGUF file"],
    );
    for b in ["nan", "-1", "0", "inf", "1e12", "soon"] {
        expect_usage_error(
            &[
                "relations",
                "--db",
                s(&db),
                "--experimental",
                "--budget-secs",
                b,
            ],
            &["budget"],
        );
    }
    // build: an openai backend without a URL fails before any mapping (no store is made)
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args([
            "build",
            "--kitti",
            s(dir.path()),
            "--oracle-labels",
            "--db",
            s(&dir.path().join("b.og")),
            "--llm",
            "openai",
        ])
        .env_remove("OPENAI_BASE_URL")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("needs a URL"));
    assert!(!dir.path().join("b.og").exists());
}

#[test]
fn smallest_model_merges_captions_and_labels_relations() {
    let smol = llm_tools::embed::default_models_dir().join(llm_tools::chat::SMALLEST_LOCAL_MODEL);
    if !smol.exists() {
        eprintln!(
            "skipping: {} not found (run scripts/setup.sh)",
            smol.display()
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (sim, db) = sim_map(
        dir.path(),
        &["--seed", "5", "--frames", "12"],
        &["--embedder", "hash"],
    );
    let r = json(&og(&[
        "captions",
        "--db",
        s(&db),
        "--llm",
        "local",
        "--llm-model",
        s(&smol),
        "--max-items",
        "3",
        "--json",
    ]));
    assert_eq!(r["done"], 3, "{r}");
    assert!(r["left"].as_u64().unwrap() > 0, "{r}");
    assert!(
        r["model"]
            .as_str()
            .unwrap()
            .starts_with("SmolLM2-135M-Instruct.Q4_1.gguf:")
    );
    let q = read_query(
        &db,
        "MATCH (i:Instance) WHERE i.caption_model IS NOT NULL RETURN count(*) AS n, collect(DISTINCT i.caption_prompt) AS p",
    );
    assert_eq!(q[0]["n"], 3);
    assert_eq!(q[0]["p"][0], llm_tools::prompts::MERGE_CAPTIONS.id());
    let e = json(&og(&[
        "eval",
        "captions",
        "--db",
        s(&db),
        "--sim",
        s(&sim),
        "--json",
    ]));
    assert!(
        e["merged"]["llm"]["instances"].as_u64().unwrap() <= 3,
        "{e}"
    );
    let r = json(&og(&[
        "relations",
        "--db",
        s(&db),
        "--experimental",
        "--llm-model",
        s(&smol),
        "--max-pairs",
        "2",
        "--json",
    ]));
    assert_eq!(r["done"], 2, "{r}");
    let q = read_query(
        &db,
        "MATCH ()-[r:RELATED {source: 'llm'}]->() RETURN count(*) AS n, collect(DISTINCT r.prompt) AS p",
    );
    assert_eq!(q[0]["n"], 2);
    assert_eq!(q[0]["p"][0], llm_tools::prompts::RELATION.id());
    // the same two pairs are not asked again
    let r = json(&og(&[
        "relations",
        "--db",
        s(&db),
        "--experimental",
        "--llm-model",
        s(&smol),
        "--max-pairs",
        "1",
        "--json",
    ]));
    assert_eq!(r["already_done"], 2, "{r}");
    // find with the model as parser and as re-ranker: both record model and prompt, and the
    // answers are instances of the map
    for (flag, prompt) in [
        ("--parser", llm_tools::prompts::PARSE_REQUEST.id()),
        ("--rerank", llm_tools::prompts::RERANK.id()),
    ] {
        let out = og(&[
            "find",
            "--db",
            s(&db),
            "a bench near the bus stop",
            flag,
            "llm",
            "--llm-model",
            s(&smol),
            "-k",
            "3",
            "--json",
        ]);
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "{flag}: {err}");
        assert!(
            err.contains("SmolLM2-135M-Instruct.Q4_1.gguf:") && err.contains(&prompt),
            "{flag}: {err}"
        );
        let hits: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let hits = hits.as_array().unwrap();
        assert!(!hits.is_empty() && hits.len() <= 3, "{hits:?}");
        for h in hits {
            assert!(
                h["id"].as_u64().is_some() && h["evidence"].is_array(),
                "{h}"
            );
        }
    }
    // without a model, the LLM parser is a usage error
    expect_usage_error(
        &[
            "find",
            "--db",
            s(&db),
            "a bench",
            "--parser",
            "llm",
            "--llm",
            "none",
        ],
        &["needs a language model"],
    );
    expect_usage_error(
        &[
            "ask",
            "--db",
            s(&db),
            "How many?",
            "--llm",
            "none",
            "--blind",
        ],
        &["--blind needs a language model"],
    );
    // ask: the model fills the task form (grammar-constrained), every call is one of the
    // registry's tools, and the transcript records the model and prompt
    let a = json(&og(&[
        "ask",
        "--db",
        s(&db),
        "How many post boxes are there?",
        "--llm-model",
        s(&smol),
        "--max-steps",
        "2",
        "--json",
    ]));
    // the model's id (after "rules, after" when the rules read what its form could not)
    assert!(
        a["model"]
            .as_str()
            .unwrap()
            .contains("SmolLM2-135M-Instruct.Q4_1.gguf:")
            && a["model"]
                .as_str()
                .unwrap()
                .contains(&format!("({})", llm_tools::prompts::ASK_TASK.id())),
        "{a}"
    );
    let steps = a["steps"].as_array().unwrap();
    assert!(!steps.is_empty(), "{a}");
    let names: Vec<String> = json(&og(&["tools"]))
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["name"].as_str().unwrap().to_string())
        .collect();
    for st in steps {
        assert!(
            names.contains(&st["tool"].as_str().unwrap().to_string()),
            "{st}"
        );
    }
    assert!(a["answer"].is_string() || a["stopped"].is_string(), "{a}");
    // the blind baseline: the same model without tools, a value and no steps
    let b = json(&og(&[
        "ask",
        "--db",
        s(&db),
        "How many post boxes are there?",
        "--llm-model",
        s(&smol),
        "--blind",
        "--json",
    ]));
    assert!(
        b["model"].as_str().unwrap().contains("ask_blind@v1")
            && b["steps"] == serde_json::json!([]),
        "{b}"
    );
    assert!(b["value"].is_number() || b["value"].is_string(), "{b}");
}
