//! Export to networkx's node-link JSON and to GraphML, streamed to a writer, and to the CSV
//! files of Neo4j's bulk importer ([`neo4j_csv`]).
//!
//! Node attributes: `labels` (list in node-link; `:A:B` in GraphML, as Neo4j writes it) and
//! every property. Relationship attributes: `type`, `key` (the relationship id) and every
//! property. A property whose name collides with one of these gets a leading underscore.
//! Points become `{x, y[, z]}` maps (JSON strings in GraphML), vectors and lists JSON arrays.
//! Payloads (point clouds) are not exported. In GraphML, carriage returns, tabs and line feeds
//! are character references; other control characters, which XML 1.0 cannot carry, become
//! their Unicode control pictures, with a warning (see `xml_escape`).

use std::collections::BTreeMap;
use std::io::Write;

pub mod neo4j_csv;
pub use neo4j_csv::{CsvExport, export_neo4j_csv};

use crate::error::{Error, Result};
use crate::read::GraphRead;
use crate::tokens::PropKey;
use crate::value::Value;

/// Supported formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// networkx `node_link_data` JSON (directed multigraph). Edges go under `edges`, the
    /// default of networkx >= 3.6; older networkx reads them with `node_link_graph(d,
    /// link="edges")`, or export with [`export_node_link`] and `"links"`.
    NodeLink,
    /// GraphML 1.0.
    GraphMl,
}

impl std::str::FromStr for ExportFormat {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "node-link" | "nodelink" | "json" => Ok(ExportFormat::NodeLink),
            "graphml" => Ok(ExportFormat::GraphMl),
            other => Err(Error::InvalidValue(format!(
                "unknown export format {other:?} (node-link or graphml)"
            ))),
        }
    }
}

const NODE_RESERVED: &[&str] = &["id", "labels"];
const EDGE_RESERVED: &[&str] = &["source", "target", "key", "type"];

/// The attribute a property is written as: a name that is reserved once its leading
/// underscores are dropped (`id`, `_id`, `__id`, ...) gets one more underscore, so every
/// property keeps a distinct attribute and the import ([`crate::import::node_link`]) can
/// take exactly one off again.
pub(crate) fn attr_name(name: String, reserved: &[&str]) -> String {
    if reserved.contains(&name.trim_start_matches('_')) {
        format!("_{name}")
    } else {
        name
    }
}

fn io(e: std::io::Error) -> Error {
    Error::Io {
        path: "<export>".into(),
        error: e,
    }
}

/// Writes the whole graph in `format` to `out`. Returns (nodes, relationships) written.
pub fn export<R: GraphRead + ?Sized>(
    r: &R,
    format: ExportFormat,
    out: &mut dyn Write,
) -> Result<(u64, u64)> {
    match format {
        ExportFormat::NodeLink => node_link(r, "edges", out),
        ExportFormat::GraphMl => graphml(r, out),
    }
}

fn props_json<R: GraphRead + ?Sized>(
    r: &R,
    props: &[(PropKey, Value)],
    reserved: &[&str],
    obj: &mut serde_json::Map<String, serde_json::Value>,
) {
    for (k, v) in props {
        let name = r.name_of(k.0).unwrap_or_else(|| format!("#{}", k.0));
        obj.insert(attr_name(name, reserved), v.to_json());
    }
}

/// Node-link JSON with a chosen key for the edge list (`"edges"` or `"links"`).
pub fn export_node_link<R: GraphRead + ?Sized>(
    r: &R,
    edges_key: &str,
    out: &mut dyn Write,
) -> Result<(u64, u64)> {
    if edges_key != "edges" && edges_key != "links" {
        return Err(Error::InvalidValue(format!(
            "edge list key must be edges or links, not {edges_key:?}"
        )));
    }
    node_link(r, edges_key, out)
}

fn node_link<R: GraphRead + ?Sized>(
    r: &R,
    edges_key: &str,
    out: &mut dyn Write,
) -> Result<(u64, u64)> {
    out.write_all(br#"{"directed": true, "multigraph": true, "graph": {}, "nodes": ["#)
        .map_err(io)?;
    let mut n_nodes = 0;
    for (i, id) in r.all_node_ids()?.into_iter().enumerate() {
        let Some(node) = r.node(id)? else { continue };
        let mut obj = serde_json::Map::new();
        obj.insert("id".into(), id.into());
        let mut labels: Vec<String> = node.labels.iter().filter_map(|l| r.name_of(l.0)).collect();
        labels.sort();
        obj.insert("labels".into(), labels.into());
        props_json(r, &node.props, NODE_RESERVED, &mut obj);
        if i > 0 {
            out.write_all(b",").map_err(io)?;
        }
        out.write_all(b"\n").map_err(io)?;
        serde_json::to_writer(&mut *out, &obj).map_err(|e| Error::Storage(e.to_string()))?;
        n_nodes += 1;
    }
    out.write_all(format!("\n], \"{edges_key}\": [").as_bytes())
        .map_err(io)?;
    let mut n_rels = 0;
    for (i, id) in r.all_rel_ids()?.into_iter().enumerate() {
        let Some(rel) = r.rel(id)? else { continue };
        let mut obj = serde_json::Map::new();
        obj.insert("source".into(), rel.start.into());
        obj.insert("target".into(), rel.end.into());
        obj.insert("key".into(), id.into());
        obj.insert(
            "type".into(),
            r.name_of(rel.ty.0).unwrap_or_default().into(),
        );
        props_json(r, &rel.props, EDGE_RESERVED, &mut obj);
        if i > 0 {
            out.write_all(b",").map_err(io)?;
        }
        out.write_all(b"\n").map_err(io)?;
        serde_json::to_writer(&mut *out, &obj).map_err(|e| Error::Storage(e.to_string()))?;
        n_rels += 1;
    }
    out.write_all(b"\n]}\n").map_err(io)?;
    Ok((n_nodes, n_rels))
}

/// GraphML attribute type of a value.
fn graphml_type(v: &Value) -> &'static str {
    match v {
        Value::Bool(_) => "boolean",
        Value::Int(_) => "long",
        Value::Float(_) => "double",
        _ => "string",
    }
}

fn unify(a: &'static str, b: &'static str) -> &'static str {
    match (a, b) {
        (x, y) if x == y => x,
        ("long", "double") | ("double", "long") => "double",
        _ => "string",
    }
}

fn graphml_text(v: &Value) -> String {
    match v {
        Value::Bool(b) => b.to_string(),
        Value::Int(i) => i.to_string(),
        Value::Float(f) => format!("{f:?}"),
        Value::String(s) => s.clone(),
        other => other.to_json().to_string(),
    }
}

/// Escapes text for XML 1.0. A carriage return becomes `&#13;` (a parser would turn a raw one
/// into a line feed), tabs and line feeds `&#9;` and `&#10;` (kept in attributes too). The
/// other C0 control characters, which XML 1.0 cannot carry at all, become their Unicode
/// control pictures (U+0001 → U+2401 "␁"), and U+FFFE / U+FFFF become U+FFFD; such
/// substitutions are counted in `replaced`, and the export warns once with the total.
pub(crate) fn xml_escape(s: &str, replaced: &std::cell::Cell<usize>) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            '\t' => o.push_str("&#9;"),
            '\n' => o.push_str("&#10;"),
            '\r' => o.push_str("&#13;"),
            c if (c as u32) < 0x20 => {
                replaced.set(replaced.get() + 1);
                o.push(char::from_u32(0x2400 + c as u32).unwrap_or('\u{FFFD}'));
            }
            '\u{FFFE}' | '\u{FFFF}' => {
                replaced.set(replaced.get() + 1);
                o.push('\u{FFFD}');
            }
            c => o.push(c),
        }
    }
    o
}

fn graphml<R: GraphRead + ?Sized>(r: &R, out: &mut dyn Write) -> Result<(u64, u64)> {
    let node_ids = r.all_node_ids()?;
    let rel_ids = r.all_rel_ids()?;
    // pass 1: attribute names and types
    let mut node_keys: BTreeMap<String, &'static str> = BTreeMap::new();
    let mut edge_keys: BTreeMap<String, &'static str> = BTreeMap::new();
    for &id in &node_ids {
        if let Some(n) = r.node(id)? {
            for (k, v) in &n.props {
                let name = attr_name(r.name_of(k.0).unwrap_or_default(), NODE_RESERVED);
                let t = graphml_type(v);
                node_keys
                    .entry(name)
                    .and_modify(|e| *e = unify(e, t))
                    .or_insert(t);
            }
        }
    }
    for &id in &rel_ids {
        if let Some(rel) = r.rel(id)? {
            for (k, v) in &rel.props {
                let name = attr_name(r.name_of(k.0).unwrap_or_default(), EDGE_RESERVED);
                let t = graphml_type(v);
                edge_keys
                    .entry(name)
                    .and_modify(|e| *e = unify(e, t))
                    .or_insert(t);
            }
        }
    }
    let w = |out: &mut dyn Write, s: &str| out.write_all(s.as_bytes()).map_err(io);
    let replaced = std::cell::Cell::new(0usize);
    let xml_escape = |s: &str| xml_escape(s, &replaced);
    w(out, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n")?;
    w(
        out,
        "<graphml xmlns=\"http://graphml.graphdrawing.org/xmlns\">\n",
    )?;
    w(
        out,
        "  <key id=\"labels\" for=\"node\" attr.name=\"labels\" attr.type=\"string\"/>\n",
    )?;
    w(
        out,
        "  <key id=\"type\" for=\"edge\" attr.name=\"type\" attr.type=\"string\"/>\n",
    )?;
    let node_ids_of: BTreeMap<&String, String> = node_keys
        .keys()
        .enumerate()
        .map(|(i, k)| (k, format!("n{i}")))
        .collect();
    let edge_ids_of: BTreeMap<&String, String> = edge_keys
        .keys()
        .enumerate()
        .map(|(i, k)| (k, format!("e{i}")))
        .collect();
    for (k, t) in &node_keys {
        w(
            out,
            &format!(
                "  <key id=\"{}\" for=\"node\" attr.name=\"{}\" attr.type=\"{t}\"/>\n",
                node_ids_of[k],
                xml_escape(k)
            ),
        )?;
    }
    for (k, t) in &edge_keys {
        w(
            out,
            &format!(
                "  <key id=\"{}\" for=\"edge\" attr.name=\"{}\" attr.type=\"{t}\"/>\n",
                edge_ids_of[k],
                xml_escape(k)
            ),
        )?;
    }
    w(out, "  <graph id=\"G\" edgedefault=\"directed\">\n")?;
    let mut n_nodes = 0;
    for &id in &node_ids {
        let Some(n) = r.node(id)? else { continue };
        let mut labels: Vec<String> = n.labels.iter().filter_map(|l| r.name_of(l.0)).collect();
        labels.sort();
        let mut s = format!(
            "    <node id=\"n{id}\"><data key=\"labels\">{}</data>",
            xml_escape(&labels.iter().map(|l| format!(":{l}")).collect::<String>())
        );
        for (k, v) in &n.props {
            let name = attr_name(r.name_of(k.0).unwrap_or_default(), NODE_RESERVED);
            s.push_str(&format!(
                "<data key=\"{}\">{}</data>",
                node_ids_of[&name],
                xml_escape(&graphml_text(v))
            ));
        }
        s.push_str("</node>\n");
        w(out, &s)?;
        n_nodes += 1;
    }
    let mut n_rels = 0;
    for &id in &rel_ids {
        let Some(rel) = r.rel(id)? else { continue };
        let mut s = format!(
            "    <edge id=\"e{id}\" source=\"n{}\" target=\"n{}\"><data key=\"type\">{}</data>",
            rel.start,
            rel.end,
            xml_escape(&r.name_of(rel.ty.0).unwrap_or_default())
        );
        for (k, v) in &rel.props {
            let name = attr_name(r.name_of(k.0).unwrap_or_default(), EDGE_RESERVED);
            s.push_str(&format!(
                "<data key=\"{}\">{}</data>",
                edge_ids_of[&name],
                xml_escape(&graphml_text(v))
            ));
        }
        s.push_str("</edge>\n");
        w(out, &s)?;
        n_rels += 1;
    }
    w(out, "  </graph>\n</graphml>\n")?;
    if replaced.get() > 0 {
        tracing::warn!(
            "GraphML export: {} control character(s) that XML 1.0 cannot carry were written as Unicode control pictures (U+2400-U+241F) or U+FFFD",
            replaced.get()
        );
    }
    Ok((n_nodes, n_rels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup_and_drops_control_chars() {
        let n = std::cell::Cell::new(0);
        assert_eq!(
            xml_escape("a<b & \"c\"\u{1}", &n),
            "a&lt;b &amp; &quot;c&quot;\u{2401}"
        );
        // line ends survive a parser's normalisation
        assert_eq!(xml_escape("a\r\nb\tc", &n), "a&#13;&#10;b&#9;c");
        assert_eq!(xml_escape("\u{FFFF}", &n), "\u{FFFD}");
        assert_eq!(n.get(), 2);
    }

    #[test]
    fn parses_format_names() {
        assert_eq!(
            "node-link".parse::<ExportFormat>().unwrap(),
            ExportFormat::NodeLink
        );
        assert_eq!(
            "graphml".parse::<ExportFormat>().unwrap(),
            ExportFormat::GraphMl
        );
        assert!("csv".parse::<ExportFormat>().is_err());
    }
}
