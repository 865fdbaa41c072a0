//! Fuzz target `tool_args` (`og-fuzz`; `OG_FUZZ_SECS=600 cargo test -p opengraph-service --test
//! fuzz -- --nocapture` for ten minutes): what an HTTP body, an MCP call or `opengraph tool`
//! hands the service, a tool name and its JSON arguments, mutated as bytes. Every tool, the
//! write tools included (on a scratch copy of the demo map), must answer a value or a
//! `ToolError`, never panic, and the store stays consistent.

use std::path::Path;

use opengraph_service::find::Finder;
use opengraph_service::tools::{Toolbox, tools};

#[test]
fn fuzz_tool_arguments() {
    let dir = tempfile::tempdir().unwrap();
    let store = graphstore::Store::create(dir.path().join("d.og")).unwrap();
    opengraph_service::demo::build(&store).unwrap();
    let finder = Finder::new(
        Box::new(llm_tools::HashEmbedder::new(scene::FEATURE_DIM)),
        None,
    );
    let mut tb = Toolbox::new(store.clone(), finder, true);
    let examples = [
        ("get_schema", "{}"),
        (
            "read_cypher",
            r#"{"query": "MATCH (n) RETURN n LIMIT 3", "params": {"x": 1}}"#,
        ),
        ("write_cypher", r#"{"query": "CREATE (:Fuzz {v: 1})"}"#),
        (
            "find_objects",
            r#"{"text": "the bench near the bus stop", "k": 5, "class": "car"}"#,
        ),
        (
            "locate",
            r#"{"text": "I'm at a T-junction, there's a bus stop on my left", "k": 3}"#,
        ),
        (
            "plan_route",
            r#"{"from": "0,0", "to": "lane:1", "poses": false}"#,
        ),
        ("describe_area", r#"{"segment": 3}"#),
        ("get_instance", r#"{"id": 2}"#),
        (
            "update_map",
            r#"{"text": "the bench is gone", "apply": false}"#,
        ),
        ("undo_map_edit", r#"{"edit_id": 99}"#),
        (
            "nearest_objects",
            r#"{"kind": "benches", "near": "lane:1", "k": 3, "measure": "box_gap"}"#,
        ),
        (
            "count_objects",
            r#"{"kind": "cars", "near": "0,0", "radius_m": 20.0, "list": 5}"#,
        ),
        (
            "measure_distance",
            r#"{"from": "instance:2", "to": "the start of the drive"}"#,
        ),
        ("neighbours", r#"{"id": 2, "radius_m": 5.0, "k": 3}"#),
    ];
    // every tool has an example
    for t in tools(true) {
        assert!(
            examples.iter().any(|(n, _)| *n == t.name),
            "tool {} has no fuzz seed",
            t.name
        );
    }
    // the first byte picks the tool, the rest is its arguments
    let seeds: Vec<Vec<u8>> = examples
        .iter()
        .enumerate()
        .map(|(i, (_, a))| {
            let mut b = vec![i as u8];
            b.extend_from_slice(a.as_bytes());
            b
        })
        .collect();
    let (mut calls, mut answered) = (0u64, 0u64);
    let regressions = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fuzz-regressions"
    ));
    og_fuzz::fuzz("tool_args", &seeds, regressions, |bytes| {
        let Some((&pick, args)) = bytes.split_first() else {
            return;
        };
        let name = examples[usize::from(pick) % examples.len()].0;
        // bad JSON is the adapters' to refuse; what parses goes to the tool as it is
        if let Ok(args) = serde_json::from_slice::<serde_json::Value>(args) {
            calls += 1;
            if tb.call(name, &args).is_ok() {
                answered += 1;
            }
        }
    });
    eprintln!("fuzz tool_args: {calls} calls with JSON arguments, {answered} answered");
    assert!(calls > 0);
    assert!(store.check_consistency().unwrap().is_empty());
}
