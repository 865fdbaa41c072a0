//! `opengraph query`.

use super::args::*;
use super::common::*;

/// `opengraph query`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Query {
        db,
        params,
        json,
        read_only,
        timeout_secs,
        max_rows,
        repeat,
        cypher,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Query here")
    };
    if !(timeout_secs.is_finite() && timeout_secs > 0.0) {
        return Err(UsageError(format!(
            "--timeout-secs must be positive, got {timeout_secs}"
        ))
        .into());
    }
    // a statement that does not write (the parser decides) opens the map read-only: opening
    // a redb file for writing rewrites its header and allocator state even when nothing
    // changes; a statement that does not parse is refused by the query below as before
    let writes = !read_only && graphstore::cypher::is_write(&cypher).unwrap_or(true);
    if writes && repeat > 0 {
        return Err(UsageError("--repeat runs read-only statements only".into()).into());
    }
    let t_open = std::time::Instant::now();
    let store = open_store(&db, writes)?;
    let open_ms = t_open.elapsed().as_secs_f64() * 1e3;
    let opts = graphstore::cypher::QueryOptions {
        params: params.into_iter().collect(),
        timeout: Some(std::time::Duration::from_secs_f64(timeout_secs)),
        row_limit: Some(usize::try_from(max_rows).unwrap_or(usize::MAX)),
        read_only,
        ground_axes: scene::records::ground_axes(&store),
        ..graphstore::cypher::QueryOptions::default()
    };
    let t0 = std::time::Instant::now();
    let r = store.query(&cypher, &opts)?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    if repeat > 0 {
        let mut times = Vec::with_capacity(repeat as usize);
        for _ in 0..repeat {
            let t = std::time::Instant::now();
            let again = store.query(&cypher, &opts)?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(again);
        }
        times.sort_by(f64::total_cmp);
        let at = |q: f64| times[((times.len() - 1) as f64 * q).round() as usize];
        errln!(
            "timing: open_ms={open_ms:.3} first_ms={ms:.3} runs={repeat} p50_ms={:.3} p99_ms={:.3}",
            at(0.5),
            at(0.99)
        );
    }
    // PROFILE: the rows as usual, the plan with rows and times per clause on stderr
    if let Some(plan) = r.plan.as_ref().filter(|_| !r.columns.is_empty()) {
        if json {
            let v = serde_json::json!({"plan": r.plan_json()});
            errln!("{}", serde_json::to_string(&v)?);
        } else {
            errln!("{}", plan.trim_end());
        }
    } else if let Some(plan) = &r.plan {
        if json {
            let v = serde_json::json!({"plan": r.plan_json()});
            outln!("{}", serde_json::to_string_pretty(&v)?);
        } else {
            out!("{plan}");
        }
        return Ok(());
    }
    if json {
        outln!("{}", serde_json::to_string_pretty(&r.rows_json())?);
    } else {
        let cells: Vec<Vec<String>> = r
            .rows
            .iter()
            .map(|row| row.iter().map(|v| cell(r.render(v))).collect())
            .collect();
        let mut width: Vec<usize> = r.columns.iter().map(|c| c.chars().count()).collect();
        for row in &cells {
            for (w, c) in width.iter_mut().zip(row) {
                *w = (*w).max(c.chars().count());
            }
        }
        let line = |vals: &[String]| {
            let parts: Vec<String> = vals
                .iter()
                .zip(&width)
                .map(|(v, w)| format!("{v}{}", " ".repeat(w - v.chars().count())))
                .collect();
            format!("| {} |", parts.join(" | "))
        };
        if !r.columns.is_empty() {
            outln!("{}", line(&r.columns));
            let rule: Vec<String> = width.iter().map(|w| "-".repeat(*w)).collect();
            outln!("{}", line(&rule));
            for row in &cells {
                outln!("{}", line(row));
            }
        }
    }
    let st = r.stats;
    let mut wrote = Vec::new();
    for (n, what) in [
        (st.nodes_created, "nodes created"),
        (st.nodes_deleted, "nodes deleted"),
        (st.relationships_created, "relationships created"),
        (st.relationships_deleted, "relationships deleted"),
        (st.properties_set, "properties set"),
        (st.properties_removed, "properties removed"),
        (st.labels_added, "labels added"),
        (st.labels_removed, "labels removed"),
    ] {
        if n > 0 {
            wrote.push(format!("{n} {what}"));
        }
    }
    errln!(
        "{} row(s) in {ms:.1} ms{}",
        r.rows.len(),
        if wrote.is_empty() {
            String::new()
        } else {
            format!("; {}", wrote.join(", "))
        }
    );
    Ok(())
}
