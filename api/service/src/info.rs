//! `opengraph info`: counts per label and type, and the declared indexes.

use std::fmt::Write;

use graphstore::Store;

/// `{"nodes": {LABEL: count}, "relationships": {TYPE: count}}`, keys sorted.
pub fn value(store: &Store) -> graphstore::Result<serde_json::Value> {
    let c = store.counts()?;
    Ok(serde_json::json!({"nodes": c.nodes, "relationships": c.relationships}))
}

/// [`value`] as pretty JSON text with a final newline.
pub fn json(store: &Store) -> graphstore::Result<String> {
    Ok(format!(
        "{}\n",
        serde_json::to_string_pretty(&value(store)?).unwrap_or_default()
    ))
}

/// A human-readable summary: counts and declared indexes.
pub fn table(store: &Store) -> graphstore::Result<String> {
    let c = store.counts()?;
    let s = store.schema();
    let mut o = String::new();
    writeln!(
        o,
        "store {} (format v{}{})",
        store.path().display(),
        store.format_version(),
        if store.format_version() < graphstore::FORMAT_VERSION {
            "; an older format, read as it is: a command that writes converts it"
        } else {
            ""
        }
    )
    .map_err(fmt_err)?;
    writeln!(o, "nodes: {}", c.total_nodes).map_err(fmt_err)?;
    for (l, n) in &c.nodes {
        writeln!(o, "  {l:<20} {n:>10}").map_err(fmt_err)?;
    }
    writeln!(o, "relationships: {}", c.total_relationships).map_err(fmt_err)?;
    for (t, n) in &c.relationships {
        writeln!(o, "  {t:<20} {n:>10}").map_err(fmt_err)?;
    }
    let mut idx: Vec<String> = s
        .effective_property_indexes()
        .iter()
        .map(|p| format!("property {}.{}", p.label, p.key))
        .collect();
    idx.extend(s.spatial_indexes.iter().map(|x| {
        format!(
            "spatial {} ({}.{})",
            x.name,
            x.label,
            x.box_key.as_deref().unwrap_or(&x.position_key)
        )
    }));
    idx.extend(s.vector_indexes.iter().map(|x| {
        format!(
            "vector {} ({}.{}, {}-d{})",
            x.name,
            x.label,
            x.key,
            x.dim,
            if x.int8 { ", int8 pre-scan" } else { "" }
        )
    }));
    idx.extend(
        s.text_indexes
            .iter()
            .map(|x| format!("text {} ({}.{})", x.name, x.label, x.key)),
    );
    writeln!(
        o,
        "indexes: {}",
        if idx.is_empty() {
            "none".to_string()
        } else {
            idx.len().to_string()
        }
    )
    .map_err(fmt_err)?;
    for i in idx {
        writeln!(o, "  {i}").map_err(fmt_err)?;
    }
    Ok(o)
}

/// `write!` to a `String` cannot fail; this keeps the signature honest without a panic.
fn fmt_err(e: std::fmt::Error) -> graphstore::Error {
    graphstore::Error::InvalidValue(e.to_string())
}
