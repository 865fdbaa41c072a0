//! `opengraph update`.

use super::args::*;
use super::common::*;

/// `opengraph update`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Update {
        db,
        text,
        apply,
        undo,
        list,
        parser,
        llm,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Update here")
    };
    if list {
        let store = open_read(&db)?;
        let edits = ingest::map_edit::list(&store.read()?)?;
        if json {
            outln!("{}", serde_json::to_string_pretty(&edits)?);
        } else if edits.is_empty() {
            outln!("no map edits");
        } else {
            for e in &edits {
                outln!(
                    "edit {:>6}  {:<6}  {}{}",
                    e.edit_id,
                    e.kind,
                    e.text,
                    if e.undone { "  (undone)" } else { "" }
                );
            }
        }
        return Ok(());
    }
    let writes = apply || undo.is_some();
    let parser = parser_of(&parser);
    let with_llm = (parser == api::find::ParserKind::Llm).then_some(&llm);
    let mut tb = open_toolbox_with(&db, writes, with_llm)?;
    let user = |e: api::tools::ToolError| -> anyhow::Error {
        if e.exit_code() == 2 {
            UsageError(e.to_string()).into()
        } else {
            e.into()
        }
    };
    if let Some(id) = undo {
        let info = tb
            .call("undo_map_edit", &serde_json::json!({"edit_id": id}))
            .map_err(user)?;
        if json {
            outln!("{}", serde_json::to_string_pretty(&info)?);
        } else {
            outln!(
                "undone: edit {id} ({})",
                info["text"].as_str().unwrap_or_default()
            );
        }
        return Ok(());
    }
    let text = text.unwrap_or_default();
    // a proposal needs no write access: the store is read-only then
    let (finder, store) = tb.parts();
    let a = serde_json::to_value(
        api::update::update(
            finder,
            store,
            &api::update::UpdateRequest {
                text,
                apply,
                parser,
            },
        )
        .map_err(user)?,
    )?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&a)?);
    } else {
        outln!("{}", a["proposal"].as_str().unwrap_or_default());
        for key in ["target", "anchor"] {
            if let Some(cands) = a[key]["candidates"].as_array() {
                outln!("{key} {:?}:", a[key]["phrase"].as_str().unwrap_or_default());
                for c in cands {
                    outln!(
                        "  {:>6}  {:.2}  {:<14} {}",
                        c["id"],
                        c["score"].as_f64().unwrap_or_default(),
                        c["label"]
                            .as_str()
                            .filter(|l| !l.is_empty())
                            .or(c["semantic_class"].as_str())
                            .unwrap_or_default(),
                        c["caption"].as_str().unwrap_or_default()
                    );
                }
            }
        }
        match a["applied"]["edit_id"].as_u64() {
            Some(id) => outln!(
                "applied as edit {id} (undo: opengraph update --db {} --undo {id})",
                db.display()
            ),
            None if apply => {}
            None => outln!("not applied (add --apply to commit it)"),
        }
    }
    if apply && a["no_match"] == true {
        return Err(UsageError(
            "nothing in the map matches the description well; nothing was changed".into(),
        )
        .into());
    }
    if apply && a["ambiguous"] == true {
        return Err(
            UsageError("the description fits several objects; nothing was changed".into()).into(),
        );
    }
    Ok(())
}
