//! The MCP server with a real client: the official Python `mcp` package (installed by
//! scripts/setup.sh into $OPENGRAPH_VENV) starts `opengraph mcp` over stdio, lists the tools,
//! calls find / read Cypher / locate, and checks that writes are refused read-only by the
//! parser, that bad arguments are tool errors, and that write_cypher exists only with
//! --allow-writes. Skips with a message when the client is not installed.

mod common;
use common::{json, json_of_run, og, python_with_mcp, read_query, s, sim_map};

fn client(py: &std::path::Path, db: &std::path::Path, extra: &[&str]) -> serde_json::Value {
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/mcp_client.py");
    let mut cmd = std::process::Command::new(py);
    cmd.arg(&script)
        .arg(env!("CARGO_BIN_EXE_opengraph"))
        .arg(db)
        .args(extra);
    // the client's own timeouts bound every call; this bounds the whole run
    json_of_run(cmd, 600)
}

#[test]
fn a_real_mcp_client_lists_and_calls_the_tools() {
    let Some(py) = python_with_mcp() else {
        eprintln!("skipping: no Python with the mcp package (run scripts/setup.sh)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (_, db) = sim_map(
        dir.path(),
        &["--seed", "3", "--frames", "24"],
        &["--embedder", "hash"],
    );
    let r = client(&py, &db, &[]);
    assert_eq!(r["server"], "opengraph");
    let tools: Vec<&str> = r["tools"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    assert_eq!(
        tools,
        [
            "count_objects",
            "describe_area",
            "find_objects",
            "get_instance",
            "get_schema",
            "locate",
            "measure_distance",
            "nearest_objects",
            "neighbours",
            "plan_route",
            "read_cypher"
        ]
    );
    // the schemas the client sees are the registry's
    let registry = json(&og(&["tools"]));
    for t in registry.as_array().unwrap() {
        let name = t["name"].as_str().unwrap();
        assert_eq!(r["schemas"][name], t["input_schema"], "{name}");
    }
    // find: results with evidence, the same as the CLI tool adapter gives
    assert_eq!(r["find"]["is_error"], false, "{}", r["find"]);
    let found = r["find"]["value"]["results"].as_array().unwrap();
    assert!(!found.is_empty() && found.len() <= 3);
    let cli = json(&og(&[
        "tool",
        "--db",
        s(&db),
        "find_objects",
        r#"{"text": "the bench near the bus stop", "k": 3}"#,
    ]));
    assert_eq!(cli, r["find"]["value"], "MCP and CLI answers differ");
    // read Cypher: the count of segments, as the CLI query gives it
    let n = read_query(&db, "MATCH (s:Segment) RETURN count(s) AS n");
    assert_eq!(r["cypher"]["value"]["rows"][0]["n"], n[0]["n"]);
    // a write through the read tool is refused by the parser, and nothing is written
    assert_eq!(r["cypher_write_refused"]["is_error"], true);
    assert!(
        r["cypher_write_refused"]["text"]
            .as_str()
            .unwrap()
            .contains("read-only")
    );
    assert_eq!(r["after_write"]["value"]["rows"][0]["n"], 0);
    // locate answers with segments
    assert_eq!(r["locate"]["is_error"], false, "{}", r["locate"]);
    assert!(
        !r["locate"]["value"]["results"]
            .as_array()
            .unwrap()
            .is_empty()
    );
    // bad arguments: a tool error that names the problem
    assert_eq!(r["bad_args"]["is_error"], true);
    assert!(
        r["bad_args"]["text"].as_str().unwrap().contains("text"),
        "{}",
        r["bad_args"]
    );
    // no write tool without --allow-writes
    assert!(
        r["write"]["protocol_error"]
            .as_str()
            .unwrap()
            .contains("write_cypher")
    );

    // with --allow-writes the write tool exists and writes
    let w = client(&py, &db, &["--allow-writes"]);
    assert!(
        w["tools"]
            .as_array()
            .unwrap()
            .iter()
            .any(|t| t == "write_cypher")
    );
    assert_eq!(w["write"]["is_error"], false, "{}", w["write"]);
    assert_eq!(w["after_write"]["value"]["rows"][0]["n"], 1);

    // annotations: every tool says whether it reads or writes, as the client reads them
    for (name, a) in w["annotations"].as_object().unwrap() {
        let writes = matches!(
            name.as_str(),
            "write_cypher" | "update_map" | "undo_map_edit"
        );
        assert_eq!(a["read_only"], !writes, "{name}: {a}");
        assert_eq!(a["destructive"], writes, "{name}: {a}");
        assert_eq!(a["open_world"], false, "{name}: {a}");
        assert!(a["title"].as_str().is_some_and(|t| !t.is_empty()), "{name}");
    }
    assert_eq!(w["annotations"].as_object().unwrap().len(), 14);
    // resources: the schema (the get_schema tool's answer) and the guide
    assert_eq!(
        r["resources"],
        serde_json::json!(["opengraph://guide", "opengraph://schema"])
    );
    let schema: serde_json::Value =
        serde_json::from_str(r["resource_text"]["opengraph://schema"].as_str().unwrap()).unwrap();
    let tool_schema = json(&og(&["tool", "--db", s(&db), "get_schema"]));
    // (the map has the write client's node now: compare what no write changed)
    for part in ["labels", "relationship_types", "frame", "ids", "indexes"] {
        assert_eq!(schema[part], tool_schema[part], "{part}");
    }
    assert!(
        schema["labels"]["Instance"]["properties"]
            .as_array()
            .unwrap()
            .iter()
            .any(|p| p["key"] == "label" && p["type"] == "string")
    );
    let guide = r["resource_text"]["opengraph://guide"].as_str().unwrap();
    assert!(guide.contains("nearest_objects") && guide.contains("get_schema"));
    assert!(
        r["missing_resource"]
            .as_str()
            .unwrap()
            .contains("opengraph://schema"),
        "{}",
        r["missing_resource"]
    );
    // the prompt: the guide with the question
    assert_eq!(
        r["prompts"],
        serde_json::json!({"use_the_map": ["question"]})
    );
    let prompt = r["prompt_text"]["use_the_map"].as_str().unwrap();
    assert!(prompt.starts_with(guide) && prompt.ends_with("How many benches are there?"));
}
