//! `opengraph tool`.

use super::args::*;
use super::common::*;

/// `opengraph tool`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Tool {
        db,
        name,
        args,
        writes,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Tool here")
    };
    let args: serde_json::Value = serde_json::from_str(&args)
        .map_err(|e| UsageError(format!("the arguments are not JSON: {e}")))?;
    let mut tb = open_toolbox(&db, writes)?;
    match tb.call(&name, &args) {
        Ok(v) => outln!("{}", serde_json::to_string_pretty(&v)?),
        Err(e) if e.exit_code() == 2 => return Err(UsageError(e.to_string()).into()),
        Err(e) => return Err(e.into()),
    }
    Ok(())
}
