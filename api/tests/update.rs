//! `opengraph update` on a simulated city: a described change is resolved to the right
//! instance and shown first (nothing changes), `--apply` commits it and records a `MapEdit`,
//! `--undo` restores the map exactly, and an ambiguous description changes nothing.

mod common;
use common::{json, og, read_query, s, sim_map};

use std::path::Path;

/// Every node but the edit records, with labels and properties, and every relationship.
fn snapshot(db: &Path) -> serde_json::Value {
    let nodes = read_query(
        db,
        "MATCH (n) WHERE NOT n:MapEdit RETURN id(n) AS id, labels(n) AS l, properties(n) AS p ORDER BY id",
    );
    let rels = read_query(
        db,
        "MATCH (a)-[r]->(b) RETURN id(r) AS id, type(r) AS t, id(a) AS a, id(b) AS b, properties(r) AS p ORDER BY id",
    );
    serde_json::json!([nodes, rels])
}

fn map() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let (_, db) = sim_map(
        dir.path(),
        &["--seed", "3", "--frames", "24"],
        &["--embedder", "hash"],
    );
    (dir, db)
}

/// An instance whose caption no other instance has, and that caption.
fn unique_instance(db: &Path) -> (u64, String) {
    let v = read_query(
        db,
        "MATCH (i:Instance) WHERE NOT i.semantic_class IN ['road', 'sidewalk', 'parking', 'terrain', 'other-ground'] \
         WITH i.caption AS c, collect(id(i)) AS ids WHERE size(ids) = 1 \
         RETURN ids[0] AS id, c ORDER BY id LIMIT 1",
    );
    (
        v[0]["id"].as_u64().unwrap(),
        v[0]["c"].as_str().unwrap().to_string(),
    )
}

#[test]
fn remove_is_shown_applied_and_undone_exactly() {
    let (_dir, db) = map();
    let (id, caption) = unique_instance(&db);
    let text = format!("{caption} is gone");
    let before = snapshot(&db);
    let bytes = std::fs::read(&db).unwrap();
    // shown first: the right object, nothing changed (the file is not even written)
    let p = json(&og(&["update", "--db", s(&db), &text, "--json"]));
    assert_eq!(p["request"]["kind"], "remove");
    assert_eq!(p["target"]["candidates"][0]["id"].as_u64(), Some(id), "{p}");
    assert_eq!(p["ambiguous"], false, "{p}");
    assert!(p["applied"].is_null());
    assert!(
        p["proposal"]
            .as_str()
            .unwrap()
            .contains(&format!("remove instance {id}"))
    );
    assert_eq!(
        std::fs::read(&db).unwrap(),
        bytes,
        "a proposal wrote to the map"
    );
    // applied: the instance, its points and relationships are gone; the edit is recorded
    let a = json(&og(&["update", "--db", s(&db), &text, "--apply", "--json"]));
    let edit = a["applied"]["edit_id"].as_u64().expect("an edit id");
    assert_eq!(a["applied"]["deleted_nodes"], serde_json::json!([id]));
    let gone = read_query(
        &db,
        &format!("MATCH (n) WHERE id(n) = {id} RETURN count(n) AS n"),
    );
    assert_eq!(gone[0]["n"], 0);
    let rec = read_query(
        &db,
        &format!(
            "MATCH (e:MapEdit) WHERE id(e) = {edit} RETURN e.text AS t, e.kind AS k, e.parsed_by AS p"
        ),
    );
    assert_eq!(rec[0]["t"], text.as_str());
    assert_eq!(rec[0]["k"], "remove");
    assert!(rec[0]["p"].as_str().unwrap().contains("edit_rules@v1"));
    assert_ne!(snapshot(&db), before);
    // find no longer answers it
    let f = json(&og(&[
        "find",
        "--db",
        s(&db),
        &caption,
        "-k",
        "3",
        "--json",
    ]));
    assert!(
        f.as_array()
            .unwrap()
            .iter()
            .all(|r| r["id"].as_u64() != Some(id))
    );
    // undone: the same nodes, ids, properties and relationships as before
    let u = json(&og(&[
        "update",
        "--db",
        s(&db),
        "--undo",
        &edit.to_string(),
        "--json",
    ]));
    assert_eq!(u["undone"], true);
    assert_eq!(snapshot(&db), before);
    let f = json(&og(&[
        "find",
        "--db",
        s(&db),
        &caption,
        "-k",
        "1",
        "--json",
    ]));
    assert_eq!(f[0]["id"].as_u64(), Some(id));
    // a second undo, and an id that is no edit, are the user's errors
    for bad in [edit.to_string(), id.to_string()] {
        let out = og(&["update", "--db", s(&db), "--undo", &bad]);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let l = json(&og(&["update", "--db", s(&db), "--list", "--json"]));
    assert_eq!(l.as_array().unwrap().len(), 1);
    assert_eq!(l[0]["undone"], true);
}

#[test]
fn change_add_and_move_then_undo_in_reverse() {
    let (_dir, db) = map();
    let (id, caption) = unique_instance(&db);
    let before = snapshot(&db);
    let c = json(&og(&[
        "update",
        "--db",
        s(&db),
        &format!("{caption} is now purple"),
        "--apply",
        "--json",
    ]));
    assert_eq!(c["target"]["candidates"][0]["id"].as_u64(), Some(id), "{c}");
    let new_caption = c["caption"].as_str().unwrap().to_string();
    assert!(new_caption.contains("purple"), "{new_caption}");
    let now = read_query(
        &db,
        &format!("MATCH (n) WHERE id(n) = {id} RETURN n.caption AS c"),
    );
    assert_eq!(now[0]["c"], new_caption.as_str());
    // a new object beside it, found afterwards, linked to its segment and to it
    let add = json(&og(&[
        "update",
        "--db",
        s(&db),
        &format!("there is a new wooden crate next to {new_caption}"),
        "--apply",
        "--json",
    ]));
    let new = add["applied"]["created_nodes"][0]
        .as_u64()
        .expect("a new node");
    let links = read_query(
        &db,
        &format!("MATCH (n)-[r]-(m) WHERE id(n) = {new} RETURN type(r) AS t, id(m) AS m"),
    );
    assert!(
        links
            .as_array()
            .unwrap()
            .iter()
            .any(|l| l["t"] == "IN_SEGMENT"),
        "{links}"
    );
    assert!(
        links
            .as_array()
            .unwrap()
            .iter()
            .any(|l| l["t"] == "RELATED" && l["m"].as_u64() == Some(id)),
        "{links}"
    );
    // its box overlaps no other object's footprint (ground x, z)
    let boxes = read_query(
        &db,
        "MATCH (i:Instance) WHERE NOT i.semantic_class IN ['road', 'sidewalk', 'parking', 'terrain', 'other-ground'] \
         RETURN id(i) AS id, i.bbox AS b",
    );
    let ground = |b: &serde_json::Value| {
        let (lo, hi) = (&b[0], &b[1]);
        [
            lo["x"].as_f64().unwrap(),
            lo["z"].as_f64().unwrap(),
            hi["x"].as_f64().unwrap(),
            hi["z"].as_f64().unwrap(),
        ]
    };
    let mine = boxes
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["id"].as_u64() == Some(new))
        .map(|r| ground(&r["b"]))
        .unwrap();
    for r in boxes.as_array().unwrap() {
        if r["id"].as_u64() == Some(new) {
            continue;
        }
        let o = ground(&r["b"]);
        let overlap = mine[0] < o[2] && mine[2] > o[0] && mine[1] < o[3] && mine[3] > o[1];
        assert!(
            !overlap,
            "the new box {mine:?} overlaps instance {} {o:?}",
            r["id"]
        );
    }
    let f = json(&og(&[
        "find",
        "--db",
        s(&db),
        "a wooden crate",
        "-k",
        "1",
        "--json",
    ]));
    assert_eq!(f[0]["id"].as_u64(), Some(new));
    // the changed object cannot be undone while the addition that relates to it stands
    let out = og(&[
        "update",
        "--db",
        s(&db),
        "--undo",
        &c["applied"]["edit_id"].to_string(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("first"));
    for e in [&add, &c] {
        json(&og(&[
            "update",
            "--db",
            s(&db),
            "--undo",
            &e["applied"]["edit_id"].to_string(),
            "--json",
        ]));
    }
    assert_eq!(snapshot(&db), before);
}

#[test]
fn an_ambiguous_description_changes_nothing() {
    let (_dir, db) = map();
    // an object whose caption parses without anchors or a segment (nothing but its words
    // tells it apart), and a second object of its class that reads the same
    let all = read_query(
        &db,
        "MATCH (i:Instance) WHERE NOT i.semantic_class IN ['road', 'sidewalk', 'parking', 'terrain', 'other-ground'] \
         RETURN id(i) AS id, i.caption AS c, i.semantic_class AS k ORDER BY id LIMIT 60",
    );
    let (a, caption, class) = all
        .as_array()
        .unwrap()
        .iter()
        .find_map(|r| {
            let c = r["c"].as_str().unwrap();
            let args = serde_json::json!({"text": c, "k": 1}).to_string();
            let f = json(&og(&["tool", "--db", s(&db), "find_objects", &args]));
            let plain = f["request"]["anchors"]
                .as_array()
                .is_some_and(|a| a.is_empty())
                && f["request"]["segment"].is_null();
            plain.then(|| {
                (
                    r["id"].as_u64().unwrap(),
                    c.to_string(),
                    r["k"].as_str().unwrap().to_string(),
                )
            })
        })
        .expect("an object with a plain caption");
    let b = read_query(
        &db,
        &format!("MATCH (i:Instance) WHERE i.semantic_class = '{class}' AND id(i) <> {a} RETURN id(i) AS id ORDER BY id LIMIT 1"),
    )[0]["id"]
        .as_u64()
        .unwrap();
    json(&og(&[
        "query",
        "--db",
        s(&db),
        "--json",
        &format!(
            "MATCH (a), (b) WHERE id(a) = {a} AND id(b) = {b} SET b.caption = a.caption, b.feature = a.feature RETURN 1 AS ok"
        ),
    ]));
    let before = snapshot(&db);
    let out = og(&[
        "update",
        "--db",
        s(&db),
        &format!("{caption} was removed"),
        "--apply",
        "--json",
    ]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let p: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(p["ambiguous"], true);
    assert!(p["applied"].is_null());
    let ids: Vec<u64> = p["target"]["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["id"].as_u64().unwrap())
        .collect();
    assert!(ids.contains(&a) && ids.contains(&b), "{ids:?}");
    assert!(p["proposal"].as_str().unwrap().starts_with("ambiguous"));
    assert_eq!(snapshot(&db), before);
    // what is no change at all is refused with the forms it takes
    let out = og(&["update", "--db", s(&db), "good morning"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("is gone"));
}

/// `--parser llm` with the smallest real model (SmolLM2-135M, fetched by scripts/setup.sh): the
/// answer records the model and the prompt; a reading the report does not support is refused
/// (exit 1, "not a whole change"), never applied; nothing is written without --apply.
#[test]
fn the_llm_parser_records_its_model_and_prompt() {
    let smol = llm_tools::embed::default_models_dir().join(llm_tools::chat::SMALLEST_LOCAL_MODEL);
    if !smol.exists() {
        eprintln!(
            "skipping: {} not found (run scripts/setup.sh)",
            smol.display()
        );
        return;
    }
    let (_dir, db) = map();
    let (id, caption) = unique_instance(&db);
    let bytes = std::fs::read(&db).unwrap();
    let out = og(&[
        "update",
        "--db",
        s(&db),
        &format!("{caption} is gone"),
        "--parser",
        "llm",
        "--llm",
        "local",
        "--llm-model",
        s(&smol),
        "--json",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    match out.status.code() {
        Some(0) => {
            let p: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            let by = p["parsed_by"].as_str().unwrap();
            assert!(
                by.contains("SmolLM2") && by.ends_with("(parse_edit@v1)"),
                "{by}"
            );
            assert_eq!(p["request"]["kind"], "remove", "{p}");
            // what the model named must come from the report
            let target = p["request"]["target"].as_str().unwrap().to_lowercase();
            let said = caption.to_lowercase();
            assert!(
                target
                    .split_whitespace()
                    .map(|w| w.trim_matches(|c: char| !c.is_alphanumeric()))
                    .all(|w| matches!(w, "a" | "an" | "the") || said.contains(w)),
                "{target:?} is not in {said:?}"
            );
            assert!(!target.contains("gone"), "{target}");
            assert!(p["applied"].is_null());
            let _ = id;
        }
        Some(1) => assert!(err.contains("not a whole change"), "{err}"),
        other => panic!("exit {other:?}: {err}"),
    }
    assert_eq!(
        std::fs::read(&db).unwrap(),
        bytes,
        "a proposal wrote to the map"
    );
    // applied, the edit records the model and the prompt that read the report
    let out = og(&[
        "update",
        "--db",
        s(&db),
        &format!("{caption} is gone"),
        "--parser",
        "llm",
        "--llm",
        "local",
        "--llm-model",
        s(&smol),
        "--apply",
        "--json",
    ]);
    if out.status.code() == Some(0) {
        let p: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let edit = p["applied"]["edit_id"].as_u64().expect("an applied edit");
        let rec = read_query(
            &db,
            &format!("MATCH (e:MapEdit) WHERE id(e) = {edit} RETURN e.parsed_by AS p"),
        );
        let by = rec[0]["p"].as_str().unwrap();
        assert!(
            by.contains("SmolLM2") && by.ends_with("(parse_edit@v1)"),
            "{by}"
        );
    }
}

/// With MiniLM (the default embedder; fetched by scripts/setup.sh), words the map holds nothing
/// like are no match: `update` changes nothing and `navigate` refuses to route to them.
#[test]
fn weak_matches_change_nothing() {
    let minilm = llm_tools::embed::default_models_dir().join("all-MiniLM-L6-v2.int8.onnx");
    if !minilm.exists() {
        eprintln!(
            "skipping: {} not found (run scripts/setup.sh)",
            minilm.display()
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (_, db) = sim_map(dir.path(), &["--seed", "3", "--frames", "24"], &[]);
    let before = snapshot(&db);
    // words the map holds nothing like: no match, nothing changed; a route to them is refused
    let out = og(&[
        "update",
        "--db",
        s(&db),
        "the purple elephant is gone",
        "--apply",
        "--json",
    ]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let p: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(p["no_match"], true, "{p}");
    assert!(p["applied"].is_null());
    assert!(
        p["proposal"].as_str().unwrap().starts_with("no good match"),
        "{p}"
    );
    assert_eq!(snapshot(&db), before);
    let out = og(&[
        "navigate",
        "--db",
        s(&db),
        "from the T-junction to the purple elephant",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("well"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// An object named by its exact caption is that object even when another reads almost the
/// same (one word more, the same feature); one named by its id is that instance.
#[test]
fn an_exact_caption_or_an_instance_id_names_the_object() {
    let (_dir, db) = map();
    let (a, caption) = unique_instance(&db);
    let b = read_query(
        &db,
        &format!(
            "MATCH (a), (i:Instance) WHERE id(a) = {a} AND i.semantic_class = a.semantic_class AND id(i) <> {a} \
             RETURN id(i) AS id ORDER BY id LIMIT 1"
        ),
    )[0]["id"]
        .as_u64()
        .unwrap();
    json(&og(&[
        "query",
        "--db",
        s(&db),
        "--json",
        &format!(
            "MATCH (a), (b) WHERE id(a) = {a} AND id(b) = {b} SET b.caption = 'short ' + a.caption, b.feature = a.feature RETURN 1 AS ok"
        ),
    ]));
    let before = snapshot(&db);
    let propose = |text: &str| {
        let out = og(&["update", "--db", s(&db), text, "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
        (out, v)
    };
    let (_, p) = propose(&format!("the {caption} is gone"));
    assert_eq!(p["target"]["candidates"][0]["id"].as_u64(), Some(a), "{p}");
    assert_eq!(p["ambiguous"], false, "{p}");
    let (_, p) = propose(&format!("the short {caption} is gone"));
    assert_eq!(p["target"]["candidates"][0]["id"].as_u64(), Some(b), "{p}");
    assert_eq!(p["ambiguous"], false, "{p}");
    for (text, want) in [
        (format!("instance {b} is gone"), b),
        (format!("instance:{a} was removed"), a),
    ] {
        let (_, p) = propose(&text);
        assert_eq!(
            p["target"]["candidates"][0]["id"].as_u64(),
            Some(want),
            "{text}: {p}"
        );
        assert_eq!(p["ambiguous"], false, "{p}");
    }
    let (out, _) = propose("instance 99999999 is gone");
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("no instance 99999999"));
    assert_eq!(snapshot(&db), before);
}

/// An edit whose object changed afterwards by another write (as the live mapper re-captions
/// what it sees again) is not undone over that change: exit 2, nothing changed; once the
/// object is as the edit left it, the undo goes through.
#[test]
fn undo_refuses_to_overwrite_a_later_change() {
    let (_dir, db) = map();
    let (id, caption) = unique_instance(&db);
    let c = json(&og(&[
        "update",
        "--db",
        s(&db),
        &format!("{caption} is now purple"),
        "--apply",
        "--json",
    ]));
    let edit = c["applied"]["edit_id"].as_u64().expect("applied");
    let left = c["caption"].as_str().unwrap().to_string();
    let set = |caption: &str| {
        json(&og(&[
            "query",
            "--db",
            s(&db),
            "--json",
            "--param",
            &format!("c={}", serde_json::json!(caption)),
            &format!("MATCH (n) WHERE id(n) = {id} SET n.caption = $c RETURN 1 AS ok"),
        ]))
    };
    set("a mapper's newer caption");
    let before = snapshot(&db);
    let out = og(&["update", "--db", s(&db), "--undo", &edit.to_string()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!("node {id} changed after map edit {edit}")),
        "{err}"
    );
    assert_eq!(snapshot(&db), before);
    set(&left);
    let u = json(&og(&[
        "update",
        "--db",
        s(&db),
        "--undo",
        &edit.to_string(),
        "--json",
    ]));
    assert_eq!(u["undone"], true, "{u}");
    let now = read_query(
        &db,
        &format!("MATCH (n) WHERE id(n) = {id} RETURN n.caption AS c"),
    );
    assert_eq!(now[0]["c"], caption.as_str());
}
