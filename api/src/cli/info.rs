//! `opengraph info`.

use api::info;

use super::args::*;
use super::common::*;

/// `opengraph info`: counts and indexes; with `--check`, the store's consistency too
/// (exit 1 when a problem is found: the file is damaged, not the command misused).
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Info { db, json, check } = cmd else {
        unreachable!("run dispatches only Command::Info here")
    };
    let store = open_read(&db)?;
    let problems = if check {
        Some(store.check_consistency()?)
    } else {
        None
    };
    let text = if json {
        let mut v = info::value(&store)?;
        if let Some(p) = &problems {
            v["consistency"] = serde_json::json!({"consistent": p.is_empty(), "problems": p});
        }
        format!("{}\n", serde_json::to_string_pretty(&v)?)
    } else {
        let mut t = info::table(&store)?;
        if let Some(p) = &problems {
            if p.is_empty() {
                t.push_str("consistency: every index and count agrees with the data\n");
            } else {
                t.push_str(&format!("consistency: {} problem(s)\n", p.len()));
                for line in p {
                    t.push_str(&format!("  {line}\n"));
                }
            }
        }
        t
    };
    out!("{text}");
    if let Some(p) = problems
        && !p.is_empty()
    {
        anyhow::bail!(
            "{}: {} consistency problem(s), listed above",
            db.display(),
            p.len()
        );
    }
    Ok(())
}
