//! `opengraph init`.

use anyhow::Context;

use super::args::*;
use super::common::*;

/// `opengraph init`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Init { db, schema } = cmd else {
        unreachable!("run dispatches only Command::Init here")
    };
    if db.exists() {
        return Err(UsageError(format!(
            "{} already exists; init makes a new store (query it with opengraph query --db {})",
            db.display(),
            db.display()
        ))
        .into());
    }
    if let Some(parent) = db.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.is_dir()
    {
        return Err(UsageError(format!(
            "cannot create {}: the folder {} does not exist",
            db.display(),
            parent.display()
        ))
        .into());
    }
    let store =
        graphstore::Store::create(&db).with_context(|| format!("creating {}", db.display()))?;
    if schema == "opengraph" {
        store.set_schema(scene::opengraph_schema())?;
    }
    outln!(
        "created {} (schema: {schema}); try: opengraph query --db {} \"CREATE (p:Place {{name: 'home'}}) RETURN p\"",
        db.display(),
        db.display()
    );
    Ok(())
}
