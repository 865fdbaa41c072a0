//! Exit codes over every command: an error caused by the user's input or files exits 2 with a
//! message on stderr, never 1 (internal) or 101 (a panic). One bad-input case per command and
//! subcommand, on the hand-made demo map (hash embedder) so that no model is needed; the
//! commands that use a language model point at an OpenAI-compatible server that is not
//! there, and must fail on the input before they need it.

mod common;
use common::{og, ok, s};

#[test]
fn user_errors_exit_2_on_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("demo.og");
    ok(&og(&["demo", "--db", s(&db)]));
    let db = s(&db).to_string();
    let nowhere = dir.path().join("missing");
    let nowhere = s(&nowhere).to_string();
    let missing_db = format!("{nowhere}/x.og");
    let bad_json = dir.path().join("bad.json");
    std::fs::write(&bad_json, "{not json").unwrap();
    let bad_json = s(&bad_json).to_string();
    let bad_csv = dir.path().join("nodes.csv");
    std::fs::write(&bad_csv, ":ID,n:int\n1,2\n2,two\n").unwrap();
    let bad_csv = s(&bad_csv).to_string();
    let new_db = dir.path().join("new.og");
    let new_db = s(&new_db).to_string();
    let llm = [
        "--llm",
        "openai",
        "--llm-url",
        "http://127.0.0.1:9/v1",
        "--llm-model",
        "x",
    ];
    let with_llm = |mut v: Vec<&'static str>| {
        v.extend(llm);
        v
    };
    // (command, arguments): each must exit 2
    let cases: Vec<(&str, Vec<String>)> = vec![
        (
            "info",
            vec!["info".into(), "--db".into(), missing_db.clone()],
        ),
        (
            "export",
            vec![
                "export".into(),
                "--db".into(),
                db.clone(),
                "--format".into(),
                "graphml".into(),
                "--out".into(),
                format!("{nowhere}/x.graphml"),
            ],
        ),
        (
            "import",
            vec![
                "import".into(),
                "--db".into(),
                db.clone(),
                "--nodes".into(),
                bad_csv.clone(),
            ],
        ),
        (
            "import bad field",
            vec![
                "import".into(),
                "--db".into(),
                new_db.clone(),
                "--nodes".into(),
                bad_csv.clone(),
            ],
        ),
        (
            "lanes",
            vec![
                "lanes".into(),
                "--poses".into(),
                nowhere.clone(),
                "--out".into(),
                "x.geojson".into(),
            ],
        ),
        (
            "hierarchy",
            vec![
                "hierarchy".into(),
                "--db".into(),
                db.clone(),
                "--poses".into(),
                nowhere.clone(),
            ],
        ),
        (
            "plan",
            vec![
                "plan".into(),
                "--db".into(),
                db.clone(),
                "--from".into(),
                "instance:999999".into(),
                "--to".into(),
                "0,0".into(),
            ],
        ),
        (
            "plan --av2-map",
            vec![
                "plan".into(),
                "--av2-map".into(),
                bad_json.clone(),
                "--from".into(),
                "0,0".into(),
                "--to".into(),
                "1,1".into(),
            ],
        ),
        (
            "build",
            vec![
                "build".into(),
                "--kitti".into(),
                nowhere.clone(),
                "--oracle-labels".into(),
                "--db".into(),
                format!("{}/new.og", s(dir.path())),
            ],
        ),
        (
            "sim",
            vec!["sim".into(), "--out".into(), "/dev/null/x".into()],
        ),
        (
            "find",
            vec!["find".into(), "--db".into(), db.clone(), "".into()],
        ),
        (
            "locate",
            vec!["locate".into(), "--db".into(), db.clone(), "  ".into()],
        ),
        (
            "navigate",
            vec!["navigate".into(), "--db".into(), db.clone(), "".into()],
        ),
        (
            "serve",
            vec!["serve".into(), "--db".into(), missing_db.clone()],
        ),
        ("mcp", vec!["mcp".into(), "--db".into(), missing_db.clone()]),
        (
            "update",
            vec!["update".into(), "--db".into(), db.clone(), "".into()],
        ),
        (
            "init",
            vec!["init".into(), "--db".into(), missing_db.clone()],
        ),
        (
            "ask",
            with_llm(vec!["ask", "--db"])
                .into_iter()
                .map(String::from)
                .chain([db.clone(), "".into()])
                .collect(),
        ),
        ("tools", vec!["tools".into(), "--bogus".into()]),
        (
            "tool",
            vec![
                "tool".into(),
                "--db".into(),
                db.clone(),
                "find_objects".into(),
                "{bad".into(),
            ],
        ),
        (
            "query",
            vec![
                "query".into(),
                "--db".into(),
                db.clone(),
                "MATCH (n RETURN n".into(),
            ],
        ),
        (
            "oracle",
            vec![
                "oracle".into(),
                "--kitti".into(),
                nowhere.clone(),
                "--out".into(),
                format!("{}/orc", s(dir.path())),
            ],
        ),
        (
            "eval semseg",
            vec![
                "eval".into(),
                "semseg".into(),
                "--db".into(),
                db.clone(),
                "--kitti".into(),
                nowhere.clone(),
            ],
        ),
        (
            "captions",
            with_llm(vec!["captions"])
                .into_iter()
                .map(String::from)
                .chain(["--db".into(), missing_db.clone()])
                .collect(),
        ),
        (
            "relations",
            with_llm(vec!["relations", "--experimental"])
                .into_iter()
                .map(String::from)
                .chain(["--db".into(), missing_db.clone()])
                .collect(),
        ),
        (
            "eval captions",
            vec![
                "eval".into(),
                "captions".into(),
                "--db".into(),
                db.clone(),
                "--sim".into(),
                nowhere.clone(),
            ],
        ),
        (
            "eval relations",
            vec![
                "eval".into(),
                "relations".into(),
                "--db".into(),
                db.clone(),
                "--sim".into(),
                nowhere.clone(),
            ],
        ),
        (
            "eval instances",
            vec![
                "eval".into(),
                "instances".into(),
                "--db".into(),
                db.clone(),
                "--sim".into(),
                nowhere.clone(),
            ],
        ),
        (
            "eval retrieval",
            vec![
                "eval".into(),
                "retrieval".into(),
                "--db".into(),
                db.clone(),
                "--sim".into(),
                nowhere.clone(),
                "--queries".into(),
                bad_json.clone(),
            ],
        ),
        (
            "eval locate",
            vec![
                "eval".into(),
                "locate".into(),
                "--db".into(),
                db.clone(),
                "--sim".into(),
                nowhere.clone(),
            ],
        ),
        ("demo", vec!["demo".into(), "--db".into(), db.clone()]),
        (
            "replay",
            vec!["replay".into(), "--kitti".into(), nowhere.clone()],
        ),
        (
            "shard",
            vec![
                "shard".into(),
                "--db".into(),
                missing_db.clone(),
                "--out".into(),
                format!("{nowhere}/shards"),
            ],
        ),
        (
            "zenoh-query",
            vec![
                "zenoh-query".into(),
                "--map".into(),
                "city".into(),
                "read_cypher".into(),
                "{not json".into(),
            ],
        ),
    ];
    // every command of the binary is in the table
    let help = String::from_utf8_lossy(&og(&["--help"]).stdout).to_string();
    let listed: Vec<String> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect();
    assert!(listed.len() > 20, "{help}");
    for c in &listed {
        assert!(
            cases
                .iter()
                .any(|(name, _)| name.split(' ').next() == Some(c.as_str())),
            "command {c} has no case in the table"
        );
    }
    let mut wrong = Vec::new();
    for (name, args) in &cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = og(&args);
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        if out.status.code() != Some(2) || !err.contains("error") {
            wrong.push(format!(
                "{name}: exit {:?}: {}",
                out.status.code(),
                err.trim()
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
