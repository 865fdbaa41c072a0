//! Export to the CSV files of Neo4j's bulk importer (`neo4j-admin database import full`),
//! in its documented header format
//! (<https://neo4j.com/docs/operations-manual/current/tools/neo4j-admin/neo4j-admin-import/>).
//!
//! - One node file per set of labels, `nodes_<Label>[_<Label>].csv`, with the header
//!   `:ID,<key>:<type>,...,:LABEL`. `:ID` is the store's node id (one global id space), so the
//!   ids `find`, `query` and `plan` print stay valid; `:LABEL` lists the labels, `;`-separated.
//! - One relationship file per type and pair of node files,
//!   `relationships_<TYPE>_<start file>_<end file>.csv`, with `:START_ID,:END_ID,:TYPE,...`.
//! - Column types: `boolean`, `long`, `double`, `string`, `point` (`{x: .., y: ..[, z: ..]}`,
//!   Cartesian, metres), and arrays with `;` between items: `float[]` (embeddings), `long[]`,
//!   `double[]`, `string[]`. A column whose values differ in type, and maps, lists of points or
//!   mixed lists, are `string` holding the value's JSON. An absent property is an empty field.
//! - `neo4j-admin.txt` holds the import command for exactly these files.
//!
//! Files are written in the store's order, sorted by name, so two exports of one store are
//! byte-identical.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::read::GraphRead;
use crate::value::Value;

/// The separator between array items (`--array-delimiter` of the import command).
pub const ARRAY_DELIMITER: char = ';';

/// What one export wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CsvExport {
    /// Nodes written.
    pub nodes: u64,
    /// Relationships written.
    pub relationships: u64,
    /// The files written, sorted (the node and relationship files, then `neo4j-admin.txt`).
    pub files: Vec<PathBuf>,
}

/// A column's type in the header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ColType {
    Boolean,
    Long,
    Double,
    Str,
    Point,
    FloatArray,
    LongArray,
    DoubleArray,
    StringArray,
}

impl ColType {
    fn header(self) -> &'static str {
        match self {
            ColType::Boolean => "boolean",
            ColType::Long => "long",
            ColType::Double => "double",
            ColType::Str => "string",
            ColType::Point => "point",
            ColType::FloatArray => "float[]",
            ColType::LongArray => "long[]",
            ColType::DoubleArray => "double[]",
            ColType::StringArray => "string[]",
        }
    }

    /// The type a value would have on its own; `None` for null.
    fn of(v: &Value) -> Option<ColType> {
        Some(match v {
            Value::Null => return None,
            Value::Bool(_) => ColType::Boolean,
            Value::Int(_) => ColType::Long,
            Value::Float(_) => ColType::Double,
            Value::String(_) => ColType::Str,
            Value::Point2D(_) | Value::Point3D(_) => ColType::Point,
            Value::Vector(_) => ColType::FloatArray,
            Value::List(items) if items.is_empty() => ColType::StringArray,
            Value::List(items) => if items.iter().all(|i| matches!(i, Value::Int(_))) {
                ColType::LongArray
            } else if items
                .iter()
                .all(|i| matches!(i, Value::Int(_) | Value::Float(_)))
            {
                ColType::DoubleArray
            } else if items.iter().all(
                |i| matches!(i, Value::String(s) if !s.contains(ARRAY_DELIMITER) && !s.is_empty()),
            ) {
                ColType::StringArray
            } else {
                ColType::Str
            },
            Value::Map(_) | Value::Bytes(_) => ColType::Str,
        })
    }

    /// The one type two values of a column can share.
    fn unify(a: ColType, b: ColType) -> ColType {
        use ColType::*;
        match (a, b) {
            (x, y) if x == y => x,
            (Long, Double) | (Double, Long) => Double,
            (LongArray, DoubleArray) | (DoubleArray, LongArray) => DoubleArray,
            // an empty list reads as any array type
            (StringArray, t @ (LongArray | DoubleArray | FloatArray))
            | (t @ (LongArray | DoubleArray | FloatArray), StringArray) => t,
            _ => Str,
        }
    }
}

/// A float as the importer reads it (Java's `Double.parseDouble`: `NaN`, `Infinity`).
fn float_text(f: f64) -> String {
    if f.is_nan() {
        "NaN".into()
    } else if f.is_infinite() {
        if f > 0.0 { "Infinity" } else { "-Infinity" }.into()
    } else {
        format!("{f:?}")
    }
}

/// A value's field under a column of type `t`.
fn field(v: &Value, t: ColType) -> String {
    let d = ARRAY_DELIMITER.to_string();
    match (t, v) {
        (_, Value::Null) => String::new(),
        (ColType::Boolean, Value::Bool(b)) => b.to_string(),
        (ColType::Long, Value::Int(i)) => i.to_string(),
        (ColType::Double, Value::Int(i)) => float_text(*i as f64),
        (ColType::Double, Value::Float(f)) => float_text(*f),
        (ColType::Str, Value::String(s)) => s.clone(),
        (ColType::Point, Value::Point2D([x, y])) => {
            format!("{{x: {}, y: {}}}", float_text(*x), float_text(*y))
        }
        (ColType::Point, Value::Point3D([x, y, z])) => format!(
            "{{x: {}, y: {}, z: {}}}",
            float_text(*x),
            float_text(*y),
            float_text(*z)
        ),
        (ColType::FloatArray, Value::Vector(xs)) => xs
            .iter()
            .map(|x| float_text(f64::from(*x)))
            .collect::<Vec<_>>()
            .join(&d),
        (ColType::LongArray | ColType::DoubleArray | ColType::StringArray, Value::List(items))
        | (ColType::FloatArray, Value::List(items)) => items
            .iter()
            .map(|i| match i {
                Value::Int(n) if t == ColType::LongArray => n.to_string(),
                Value::Int(n) => float_text(*n as f64),
                Value::Float(f) => float_text(*f),
                Value::String(s) => s.clone(),
                other => other.to_json().to_string(),
            })
            .collect::<Vec<_>>()
            .join(&d),
        // a column of mixed types: the value's JSON
        (_, other) => other.to_json().to_string(),
    }
}

/// A file-name part from a name: letters, digits and `_`, everything else `_`.
fn file_part(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

fn io(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        error: std::io::Error::other(e.to_string()),
    }
}

/// One row's fields under `cols`: each column's value, or empty where the row lacks it.
fn fields(props: &[(String, Value)], cols: &BTreeMap<String, ColType>) -> Vec<String> {
    let by_key: BTreeMap<&str, &Value> = props.iter().map(|(k, v)| (k.as_str(), v)).collect();
    cols.iter()
        .map(|(k, t)| {
            by_key
                .get(k.as_str())
                .map_or(String::new(), |v| field(v, *t))
        })
        .collect()
}

/// Columns of a file: property name → type, in name order.
fn columns<'a>(rows: impl Iterator<Item = &'a [(String, Value)]>) -> BTreeMap<String, ColType> {
    let mut cols: BTreeMap<String, ColType> = BTreeMap::new();
    for row in rows {
        for (k, v) in row {
            if let Some(t) = ColType::of(v) {
                cols.entry(k.clone())
                    .and_modify(|c| *c = ColType::unify(*c, t))
                    .or_insert(t);
            }
        }
    }
    cols
}

/// Writes the whole graph as Neo4j bulk-import CSV files into `dir` (made if missing; files
/// of the same names are replaced).
///
/// # Errors
/// [`Error::Io`] naming the file that could not be written; the store fails.
pub fn export_neo4j_csv<R: GraphRead + ?Sized>(r: &R, dir: &Path) -> Result<CsvExport> {
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    // nodes grouped by label set, each with its named properties
    type Row = (u64, Vec<(String, Value)>);
    let mut groups: BTreeMap<Vec<String>, Vec<Row>> = BTreeMap::new();
    let mut file_of: BTreeMap<u64, String> = BTreeMap::new();
    for id in r.all_node_ids()? {
        let Some(node) = r.node(id)? else { continue };
        let mut labels: Vec<String> = node.labels.iter().filter_map(|l| r.name_of(l.0)).collect();
        labels.sort();
        let props = node
            .props
            .iter()
            .map(|(k, v)| {
                (
                    r.name_of(k.0).unwrap_or_else(|| format!("#{}", k.0)),
                    v.clone(),
                )
            })
            .collect();
        groups.entry(labels).or_default().push((id, props));
    }
    let mut files = Vec::new();
    let mut nodes = 0u64;
    for (labels, rows) in &groups {
        let stem = if labels.is_empty() {
            "nodes".to_string()
        } else {
            format!(
                "nodes_{}",
                labels
                    .iter()
                    .map(|l| file_part(l))
                    .collect::<Vec<_>>()
                    .join("_")
            )
        };
        let cols = columns(rows.iter().map(|(_, p)| p.as_slice()));
        let path = dir.join(format!("{stem}.csv"));
        let mut w = csv::Writer::from_path(&path).map_err(|e| io(&path, e))?;
        let mut header = vec![":ID".to_string()];
        header.extend(cols.iter().map(|(k, t)| format!("{k}:{}", t.header())));
        header.push(":LABEL".into());
        w.write_record(&header).map_err(|e| io(&path, e))?;
        let label_field = labels.join(&ARRAY_DELIMITER.to_string());
        for (id, props) in rows {
            let mut rec = vec![id.to_string()];
            rec.extend(fields(props, &cols));
            rec.push(label_field.clone());
            w.write_record(&rec).map_err(|e| io(&path, e))?;
            file_of.insert(*id, stem.trim_start_matches("nodes_").to_string());
            nodes += 1;
        }
        w.flush().map_err(|e| io(&path, e))?;
        files.push(path);
    }
    // relationships grouped by type and the files of their ends
    type RelRow = (u64, u64, Vec<(String, Value)>);
    let mut rels: BTreeMap<(String, String, String), Vec<RelRow>> = BTreeMap::new();
    for id in r.all_rel_ids()? {
        let Some(rel) = r.rel(id)? else { continue };
        let ty = r.name_of(rel.ty.0).unwrap_or_default();
        let end_file = |n: u64| file_of.get(&n).cloned().unwrap_or_default();
        let props = rel
            .props
            .iter()
            .map(|(k, v)| {
                (
                    r.name_of(k.0).unwrap_or_else(|| format!("#{}", k.0)),
                    v.clone(),
                )
            })
            .collect();
        rels.entry((ty, end_file(rel.start), end_file(rel.end)))
            .or_default()
            .push((rel.start, rel.end, props));
    }
    let mut relationships = 0u64;
    for ((ty, a, b), rows) in &rels {
        let path = dir.join(format!("relationships_{}_{}_{}.csv", file_part(ty), a, b));
        let cols = columns(rows.iter().map(|(_, _, p)| p.as_slice()));
        let mut w = csv::Writer::from_path(&path).map_err(|e| io(&path, e))?;
        let mut header = vec![":START_ID".to_string(), ":END_ID".into(), ":TYPE".into()];
        header.extend(cols.iter().map(|(k, t)| format!("{k}:{}", t.header())));
        w.write_record(&header).map_err(|e| io(&path, e))?;
        for (s, e, props) in rows {
            let mut rec = vec![s.to_string(), e.to_string(), ty.clone()];
            rec.extend(fields(props, &cols));
            w.write_record(&rec).map_err(|e| io(&path, e))?;
            relationships += 1;
        }
        w.flush().map_err(|e| io(&path, e))?;
        files.push(path);
    }
    files.sort();
    let mut cmd = String::from(
        "# Load these files into an empty Neo4j database (run in this folder):\n\
         neo4j-admin database import full --array-delimiter=';' --multiline-fields=true",
    );
    for f in &files {
        let name = f.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        let flag = if name.starts_with("nodes") {
            "--nodes"
        } else {
            "--relationships"
        };
        cmd.push_str(&format!(" \\\n  {flag}={name}"));
    }
    cmd.push_str(" \\\n  neo4j\n");
    let readme = dir.join("neo4j-admin.txt");
    std::fs::File::create(&readme)
        .and_then(|mut f| f.write_all(cmd.as_bytes()))
        .map_err(|e| io(&readme, e))?;
    files.push(readme);
    Ok(CsvExport {
        nodes,
        relationships,
        files,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_take_one_type_each() {
        let rows = [
            vec![
                ("a".to_string(), Value::Int(1)),
                ("p".into(), Value::Point3D([1.0, 2.0, 3.0])),
            ],
            vec![
                ("a".to_string(), Value::Float(0.5)),
                ("b".into(), Value::Bool(true)),
            ],
            vec![("b".to_string(), Value::String("x".into()))],
        ];
        let cols = columns(rows.iter().map(|r| r.as_slice()));
        assert_eq!(cols["a"], ColType::Double);
        assert_eq!(cols["b"], ColType::Str);
        assert_eq!(cols["p"], ColType::Point);
        assert_eq!(field(&Value::Bool(true), ColType::Str), "true");
        assert_eq!(
            field(&Value::Point3D([1.0, -2.5, 3.0]), ColType::Point),
            "{x: 1.0, y: -2.5, z: 3.0}"
        );
        assert_eq!(
            field(&Value::Vector(vec![0.5, 1.0]), ColType::FloatArray),
            "0.5;1.0"
        );
        assert_eq!(field(&Value::Float(f64::NAN), ColType::Double), "NaN");
        // a string holding the delimiter cannot be an array item: the list is JSON
        let l = Value::List(vec![Value::String("a;b".into())]);
        assert_eq!(ColType::of(&l), Some(ColType::Str));
        assert_eq!(field(&l, ColType::Str), r#"["a;b"]"#);
    }
}
