//! Import of the CSV files of Neo4j's bulk importer (`neo4j-admin database import full`), in
//! its documented header format
//! (<https://neo4j.com/docs/operations-manual/current/tools/neo4j-admin/neo4j-admin-import/>),
//! as [`crate::export::neo4j_csv`] writes them.
//!
//! - Node files: `:ID` (or `name:ID`, which also stores the id as property `name`; an id space
//!   as `:ID(Space)`), `:LABEL` (`;`-separated) and `key:type` columns. Labels can also be
//!   given per file (`Label1:Label2=nodes.csv`, as on neo4j-admin's command line).
//! - Relationship files: `:START_ID`, `:END_ID` (with the id space of their nodes), `:TYPE`
//!   (or the type given per file, `TYPE=rels.csv`) and `key:type` columns.
//! - Types: `int`, `long`, `short`, `byte` (integers); `float`, `double`; `boolean`; `string`,
//!   `char`; `point` (`{x: .., y: ..[, z: ..]}`); `date`, `time`, `datetime`, `localtime`,
//!   `localdatetime`, `duration` are kept as their text; each with `[]` for an array of items
//!   separated by `;`. `float[]` becomes a dense vector (embeddings), as the export writes
//!   them. A column without a type is `string`; `:IGNORE` columns are skipped. An empty field
//!   is an absent property.
//!
//! When every `:ID` is a non-negative integer and the store is empty, nodes keep their ids (so
//! a map exported and imported answers with the same node ids); otherwise they get new ids and
//! the relationship files are resolved through the file ids.
//!
//! The import reads each node file twice: first the ids only (checking they are unique and
//! counting them), then everything, committing a transaction every `batch_rows` rows. A bad
//! field fails with the file, the line and the column; the batches committed before stay,
//! so callers that must leave nothing behind import into a new store (as `opengraph import`
//! does: into a temporary file, renamed at the end).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::adjacency::AdjRow;
use crate::error::{Error, Result};
use crate::export::neo4j_csv::ARRAY_DELIMITER;
use crate::store::Store;
use crate::tokens::{LabelId, PropKey, RelType};
use crate::txn::WriteTxn;
use crate::value::{Value, ValueType};

/// One file to import, with the labels (node files) or the type (relationship files) given
/// for all of its rows, besides those of its `:LABEL` or `:TYPE` column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CsvFile {
    /// The CSV file.
    pub path: PathBuf,
    /// Labels of every row (node files) or the type of every row (relationship files: at
    /// most one).
    pub given: Vec<String>,
}

impl CsvFile {
    /// Parses neo4j-admin's file argument: `path`, or `Label1:Label2=path` / `TYPE=path`.
    pub fn parse(arg: &str) -> CsvFile {
        match arg.split_once('=') {
            Some((given, path)) if !given.is_empty() && !given.contains(['/', '\\']) => CsvFile {
                path: PathBuf::from(path),
                given: given
                    .split(':')
                    .filter(|s| !s.is_empty())
                    .map(str::to_string)
                    .collect(),
            },
            _ => CsvFile {
                path: PathBuf::from(arg),
                given: Vec::new(),
            },
        }
    }
}

/// The files of one import.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CsvFiles {
    /// Node files, imported in this order.
    pub nodes: Vec<CsvFile>,
    /// Relationship files, imported after every node file.
    pub relationships: Vec<CsvFile>,
}

impl CsvFiles {
    /// The files of a folder as the export writes it: `nodes*.csv` and
    /// `relationships*.csv`, each sorted by name.
    ///
    /// # Errors
    /// [`Error::Io`] when the folder cannot be read; [`Error::Import`] when it holds no node
    /// file.
    pub fn from_folder(dir: &Path) -> Result<CsvFiles> {
        let rd = std::fs::read_dir(dir).map_err(|error| Error::Io {
            path: dir.to_path_buf(),
            error,
        })?;
        let mut names: Vec<String> = rd
            .filter_map(|e| e.ok())
            .filter_map(|e| e.file_name().to_str().map(str::to_string))
            .filter(|n| n.ends_with(".csv"))
            .collect();
        names.sort();
        let pick = |prefix: &str| -> Vec<CsvFile> {
            names
                .iter()
                .filter(|n| n.starts_with(prefix))
                .map(|n| CsvFile {
                    path: dir.join(n),
                    given: Vec::new(),
                })
                .collect()
        };
        let files = CsvFiles {
            nodes: pick("nodes"),
            relationships: pick("relationships"),
        };
        if files.nodes.is_empty() {
            return Err(Error::Import {
                path: dir.to_path_buf(),
                line: 0,
                detail: "no nodes*.csv file in this folder (name the files with --nodes and \
                         --relationships)"
                    .into(),
            });
        }
        Ok(files)
    }

    /// The files' total size in bytes (what the import's progress counts up to).
    pub fn total_bytes(&self) -> u64 {
        self.nodes
            .iter()
            .chain(&self.relationships)
            .filter_map(|f| std::fs::metadata(&f.path).ok())
            .map(|m| m.len())
            .sum()
    }
}

/// What one import wrote.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct CsvImport {
    /// Nodes created.
    pub nodes: u64,
    /// Relationships created.
    pub relationships: u64,
    /// True when the nodes kept the integer ids of their files.
    pub ids_kept: bool,
    /// Transactions committed.
    pub batches: u64,
}

/// A column's type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    Int,
    /// `float`: a number; as an array (`float[]`), a dense f32 vector.
    Float32,
    /// `double`: a number; as an array, a list of floats.
    Float,
    Bool,
    Str,
    Point,
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum Col {
    /// `:ID`, storing the id as property `Some(name)` too.
    Id(Option<String>, String),
    Label,
    StartId(String),
    EndId(String),
    Type,
    Ignore,
    /// A property: name, item type, array.
    Prop(String, Scalar, bool),
}

fn parse_header(path: &Path, fields: &csv::StringRecord) -> Result<Vec<Col>> {
    let bad = |detail: String| Error::Import {
        path: path.to_path_buf(),
        line: 1,
        detail,
    };
    let mut cols = Vec::with_capacity(fields.len());
    for (i, h) in fields.iter().enumerate() {
        let h = h.trim();
        // `point{crs:WGS-84}`: options in braces are accepted and ignored
        let core = h.split('{').next().unwrap_or(h);
        let (name, ty) = match core.rfind(':') {
            Some(p) => (&core[..p], core[p + 1..].trim()),
            None => (core, "string"),
        };
        let (base, group) = match ty.split_once('(') {
            Some((b, rest)) => (b, rest.trim_end_matches(')').to_string()),
            None => (ty, String::new()),
        };
        let col = match base.to_ascii_uppercase().as_str() {
            "ID" => Col::Id((!name.is_empty()).then(|| name.to_string()), group),
            "LABEL" => Col::Label,
            "START_ID" => Col::StartId(group),
            "END_ID" => Col::EndId(group),
            "TYPE" => Col::Type,
            "IGNORE" => Col::Ignore,
            _ => {
                if name.is_empty() {
                    return Err(bad(format!(
                        "column {} ({h:?}) has no property name",
                        i + 1
                    )));
                }
                let lower = base.to_ascii_lowercase();
                let (item, array) = match lower.strip_suffix("[]") {
                    Some(t) => (t.to_string(), true),
                    None => (lower, false),
                };
                let scalar = match item.as_str() {
                    "int" | "long" | "short" | "byte" => Scalar::Int,
                    "float" => Scalar::Float32,
                    "double" => Scalar::Float,
                    "boolean" => Scalar::Bool,
                    "string" | "char" | "date" | "time" | "datetime" | "localtime"
                    | "localdatetime" | "duration" => Scalar::Str,
                    "point" => Scalar::Point,
                    other => {
                        return Err(bad(format!(
                            "column {} ({h:?}): unknown type {other:?} (int, long, float, \
                             double, boolean, string, point, date/time types, each with [] \
                             for arrays)",
                            i + 1
                        )));
                    }
                };
                Col::Prop(name.to_string(), scalar, array)
            }
        };
        cols.push(col);
    }
    Ok(cols)
}

fn parse_f64(s: &str) -> Option<f64> {
    match s.trim() {
        "NaN" => Some(f64::NAN),
        "Infinity" | "+Infinity" => Some(f64::INFINITY),
        "-Infinity" => Some(f64::NEG_INFINITY),
        t => t.parse().ok(),
    }
}

/// `{x: 1.0, y: 2.0[, z: 3.0][, crs: ..]}`, keys in any order.
fn parse_point(s: &str) -> Option<Value> {
    let inner = s.trim().strip_prefix('{')?.strip_suffix('}')?;
    let (mut x, mut y, mut z) = (None, None, None);
    for part in inner.split(',') {
        let (k, v) = part.split_once(':')?;
        let k = k.trim().trim_matches(['"', '\'']).to_ascii_lowercase();
        match k.as_str() {
            "x" | "longitude" => x = Some(parse_f64(v)?),
            "y" | "latitude" => y = Some(parse_f64(v)?),
            "z" | "height" => z = Some(parse_f64(v)?),
            _ => {}
        }
    }
    match (x, y, z) {
        (Some(x), Some(y), Some(z)) => Some(Value::Point3D([x, y, z])),
        (Some(x), Some(y), None) => Some(Value::Point2D([x, y])),
        _ => None,
    }
}

fn parse_scalar(s: &str, t: Scalar) -> std::result::Result<Value, String> {
    let fail = |what: &str| format!("{s:?} is not {what}");
    Ok(match t {
        Scalar::Int => Value::Int(s.trim().parse().map_err(|_| fail("an integer"))?),
        Scalar::Float | Scalar::Float32 => {
            Value::Float(parse_f64(s).ok_or_else(|| fail("a number"))?)
        }
        Scalar::Bool => match s.trim().to_ascii_lowercase().as_str() {
            "true" => Value::Bool(true),
            "false" => Value::Bool(false),
            _ => return Err(fail("true or false")),
        },
        Scalar::Str => Value::String(s.to_string()),
        Scalar::Point => parse_point(s).ok_or_else(|| fail("a point {x: .., y: ..[, z: ..]}"))?,
    })
}

fn parse_field(s: &str, t: Scalar, array: bool) -> std::result::Result<Value, String> {
    if !array {
        return parse_scalar(s, t);
    }
    let items = s.split(ARRAY_DELIMITER);
    if t == Scalar::Float32 {
        // float[]: a dense vector, as the export writes embeddings
        let mut v = Vec::new();
        for it in items {
            let f = parse_f64(it).ok_or_else(|| format!("array item {it:?} is not a number"))?;
            v.push(f as f32);
        }
        return Ok(Value::Vector(v));
    }
    items
        .map(|it| parse_scalar(it, t))
        .collect::<std::result::Result<Vec<_>, _>>()
        .map(Value::List)
}

/// Node ids of the import: the files' own integers, or new ids by (id space, file id).
enum Ids {
    Kept,
    Mapped(HashMap<(String, String), u64>),
}

/// Records read ahead per block by [`Reader`]'s thread.
const READ_AHEAD: usize = 4096;

/// A property field parsed by [`Reader`]'s thread: `None` for an empty field or a column
/// that is not a property.
type Parsed = Option<std::result::Result<Value, String>>;

/// A block of records read ahead: the buffer, each record's parsed property fields (when the
/// reader parses), how many of it were read, and whether the file ends after them (with the
/// error that ended it, if one did).
struct Block {
    recs: Vec<csv::StringRecord>,
    vals: Vec<Vec<Parsed>>,
    len: usize,
    end: bool,
    err: Option<csv::Error>,
}

/// One CSV file's rows. The file is split into records, and with `parse` their property
/// fields parsed, on a thread of its own, a block of [`READ_AHEAD`] ahead of the caller, so
/// that work overlaps with the writes; buffers go back to that thread for reuse.
struct Reader {
    path: PathBuf,
    cols: Vec<Col>,
    rec: csv::StringRecord,
    /// The current record's parsed property fields, by column (empty without `parse`).
    vals: Vec<Parsed>,
    block: Block,
    at: usize,
    full: std::sync::mpsc::Receiver<Block>,
    spare: std::sync::mpsc::SyncSender<(Vec<csv::StringRecord>, Vec<Vec<Parsed>>)>,
}

impl Reader {
    fn open(path: &Path, parse: bool) -> Result<Reader> {
        let file = std::fs::File::open(path).map_err(|error| Error::Io {
            path: path.to_path_buf(),
            error,
        })?;
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .flexible(false)
            .from_reader(file);
        let header = rdr.headers().map_err(|e| csv_err(path, &e))?.clone();
        let cols = parse_header(path, &header)?;
        let (full_tx, full) = std::sync::mpsc::sync_channel::<Block>(2);
        let (spare, spare_rx) = std::sync::mpsc::sync_channel(4);
        let types: Vec<Option<(Scalar, bool)>> = cols
            .iter()
            .map(|c| match c {
                Col::Prop(_, t, array) => Some((*t, *array)),
                _ => None,
            })
            .collect();
        std::thread::Builder::new()
            .name("csv-read".into())
            .spawn(move || {
                loop {
                    let (mut recs, mut vals): (Vec<csv::StringRecord>, Vec<Vec<Parsed>>) =
                        spare_rx.try_recv().unwrap_or_default();
                    recs.resize_with(READ_AHEAD, csv::StringRecord::new);
                    if parse {
                        vals.resize_with(READ_AHEAD, Vec::new);
                    }
                    let (mut len, mut end, mut err) = (0, false, None);
                    while len < READ_AHEAD {
                        match rdr.read_record(&mut recs[len]) {
                            Ok(true) => {
                                if parse {
                                    let row = &mut vals[len];
                                    row.clear();
                                    row.extend(types.iter().zip(recs[len].iter()).map(
                                        |(t, field)| match t {
                                            Some((t, array)) if !field.is_empty() => {
                                                Some(parse_field(field, *t, *array))
                                            }
                                            _ => None,
                                        },
                                    ));
                                }
                                len += 1;
                            }
                            Ok(false) => {
                                end = true;
                                break;
                            }
                            Err(e) => {
                                (end, err) = (true, Some(e));
                                break;
                            }
                        }
                    }
                    // a closed channel: the caller stopped reading
                    let block = Block {
                        recs,
                        vals,
                        len,
                        end,
                        err,
                    };
                    if full_tx.send(block).is_err() || end {
                        return;
                    }
                }
            })
            .map_err(|error| Error::Io {
                path: path.to_path_buf(),
                error,
            })?;
        Ok(Reader {
            path: path.to_path_buf(),
            cols,
            rec: csv::StringRecord::new(),
            vals: Vec::new(),
            block: Block {
                recs: Vec::new(),
                vals: Vec::new(),
                len: 0,
                end: false,
                err: None,
            },
            at: 0,
            full,
            spare,
        })
    }

    /// The next row, into `rec`; false at the end.
    fn next(&mut self) -> Result<bool> {
        loop {
            if self.at < self.block.len {
                std::mem::swap(&mut self.rec, &mut self.block.recs[self.at]);
                if let Some(v) = self.block.vals.get_mut(self.at) {
                    std::mem::swap(&mut self.vals, v);
                }
                self.at += 1;
                return Ok(true);
            }
            if let Some(e) = self.block.err.take() {
                return Err(csv_err(&self.path, &e));
            }
            if self.block.end {
                return Ok(false);
            }
            let Ok(block) = self.full.recv() else {
                return Err(Error::Import {
                    path: self.path.clone(),
                    line: self.line(),
                    detail: "the thread reading the file stopped".into(),
                });
            };
            let used = std::mem::replace(&mut self.block, block);
            // a full return channel: the reading thread allocates afresh instead
            let _ = self.spare.try_send((used.recs, used.vals));
            self.at = 0;
        }
    }

    fn line(&self) -> u64 {
        self.rec.position().map_or(0, |p| p.line())
    }

    /// Where the current row starts in the file, in bytes.
    fn bytes(&self) -> u64 {
        self.rec.position().map_or(0, csv::Position::byte)
    }

    fn err(&self, detail: impl Into<String>) -> Error {
        Error::Import {
            path: self.path.clone(),
            line: self.line(),
            detail: detail.into(),
        }
    }
}

fn csv_err(path: &Path, e: &csv::Error) -> Error {
    let line = e.position().map_or(0, |p| p.line());
    Error::Import {
        path: path.to_path_buf(),
        line,
        detail: match e.kind() {
            csv::ErrorKind::UnequalLengths {
                expected_len, len, ..
            } => format!("{len} fields where the header has {expected_len}"),
            csv::ErrorKind::Utf8 { .. } => "not valid UTF-8".into(),
            csv::ErrorKind::Io(io) => io.to_string(),
            _ => e.to_string(),
        },
    }
}

/// Interned property keys of one file's columns.
fn prop_keys(tx: &mut WriteTxn<'_>, cols: &[Col]) -> Result<Vec<Option<PropKey>>> {
    cols.iter()
        .map(|c| match c {
            Col::Prop(n, ..) | Col::Id(Some(n), _) => tx.prop_key_id(n).map(Some),
            _ => Ok(None),
        })
        .collect()
}

/// The property values of the reader's current row.
/// A `string` field holding the JSON of a value the schema types otherwise (a box, a map, a
/// list of points: the export writes those as JSON text) becomes that value again.
fn coerce(v: Value, want: Option<ValueType>) -> Value {
    match (&v, want) {
        (Value::String(t), Some(ty))
            if !matches!(ty, ValueType::String | ValueType::Any) && !ty.accepts(&v) =>
        {
            serde_json::from_str::<serde_json::Value>(t)
                .ok()
                .map(|j| Value::from_json(&j))
                .filter(|j| ty.accepts(j))
                .unwrap_or(v)
        }
        _ => v,
    }
}

/// The declared property types of the store's schema, by label or type, then key.
type Typed = HashMap<String, HashMap<String, ValueType>>;

fn typed(store: &Store) -> (Typed, Typed) {
    let schema = store.schema();
    let node = schema
        .labels
        .iter()
        .map(|(l, r)| {
            let m = r.properties.iter().map(|p| (p.key.clone(), p.ty)).collect();
            (l.clone(), m)
        })
        .collect();
    let rel = schema
        .relationships
        .iter()
        .map(|(t, r)| {
            let m = r.properties.iter().map(|p| (p.key.clone(), p.ty)).collect();
            (t.clone(), m)
        })
        .collect();
    (node, rel)
}

/// The schema's type for each of a file's columns, for rows of one label set or type
/// (`want(property name)`); `None` where the schema declares none.
fn column_types(cols: &[Col], want: impl Fn(&str) -> Option<ValueType>) -> Vec<Option<ValueType>> {
    cols.iter()
        .map(|c| match c {
            Col::Prop(name, ..) => want(name),
            _ => None,
        })
        .collect()
}

/// The row's properties: each column's field as the reader parsed it (a reader opened with
/// `parse`), coerced to `want[column]`.
fn row_props(
    r: &mut Reader,
    keys: &[Option<PropKey>],
    want: &[Option<ValueType>],
) -> Result<Vec<(PropKey, Value)>> {
    let mut props = Vec::new();
    for (i, c) in r.cols.iter().enumerate() {
        let (Col::Prop(name, ..), Some(k)) = (c, keys[i]) else {
            if let (Col::Id(Some(_), _), Some(k)) = (c, keys[i]) {
                let id = r.rec.get(i).unwrap_or_default();
                props.push((k, Value::String(id.to_string())));
            }
            continue;
        };
        match r.vals.get_mut(i).and_then(Option::take) {
            None => {}
            Some(Ok(v)) => props.push((k, coerce(v, want[i]))),
            Some(Err(e)) => return Err(r.err(format!("column {} ({name}): {e}", i + 1))),
        }
    }
    Ok(props)
}

/// Hands the reader's rows to `row`, `batch_rows` of them per write transaction; after each
/// commit, `committed(rows in it, bytes of the file read so far)`.
fn in_batches(
    store: &Store,
    r: &mut Reader,
    batch_rows: usize,
    row: &mut dyn FnMut(&mut WriteTxn<'_>, &mut Reader) -> Result<()>,
    flush: &mut dyn FnMut(&mut WriteTxn<'_>) -> Result<()>,
    committed: &mut dyn FnMut(u64, u64),
) -> Result<()> {
    let mut more = true;
    while more {
        let n = store.write(|tx| {
            let mut n = 0u64;
            while n < batch_rows as u64 {
                if !r.next()? {
                    more = false;
                    break;
                }
                row(tx, r)?;
                n += 1;
            }
            flush(tx)?;
            Ok(n)
        })?;
        committed(n, r.bytes());
    }
    Ok(())
}

/// Pass 1's fast path: when every node file has an `:ID` column without an id space and
/// every id is a distinct integer, one past the largest (the ids can be kept); otherwise
/// `None`, and [`checked_ids`] reads the ids as text.
fn integer_ids(files: &CsvFiles) -> Result<Option<u64>> {
    let mut seen: hashbrown::HashSet<u64> = hashbrown::HashSet::new();
    for f in &files.nodes {
        let mut r = Reader::open(&f.path, false)?;
        let idx = r.cols.iter().position(|c| matches!(c, Col::Id(..)));
        let Some(idx) = idx.filter(|&i| matches!(&r.cols[i], Col::Id(_, g) if g.is_empty())) else {
            return Ok(None);
        };
        while r.next()? {
            match r.rec.get(idx).unwrap_or_default().parse::<u64>() {
                Ok(n) if seen.insert(n) => {}
                // "7" and "007" are one integer but two ids
                _ => return Ok(None),
            }
        }
    }
    Ok(Some(seen.iter().max().map_or(0, |m| m + 1)))
}

/// Pass 1: checks that the node files' ids, as text within their id space, are not empty and
/// appear once; returns how many there are.
fn checked_ids(files: &CsvFiles) -> Result<usize> {
    let mut seen: hashbrown::HashSet<(String, String)> = hashbrown::HashSet::new();
    for f in &files.nodes {
        let mut r = Reader::open(&f.path, false)?;
        let Some(idx) = r.cols.iter().position(|c| matches!(c, Col::Id(..))) else {
            // no :ID column: rows get new ids and cannot be referred to
            continue;
        };
        let Col::Id(_, group) = r.cols[idx].clone() else {
            unreachable!("position found an Id column")
        };
        while r.next()? {
            let id = r.rec.get(idx).unwrap_or_default();
            if id.is_empty() {
                return Err(r.err(format!("column {}: an empty :ID", idx + 1)));
            }
            if !seen.insert((group.clone(), id.to_string())) {
                return Err(r.err(format!("the :ID {id:?} appears twice")));
            }
        }
    }
    Ok(seen.len())
}

/// Imports `files` into `store`, committing every `batch_rows` rows (at least 1);
/// `progress(bytes_read, bytes_total)` is called after each batch.
///
/// # Errors
/// [`Error::Import`] with the file and line for a bad header or field, a duplicate or
/// unknown id, or a row without a label source or type; [`Error::Io`] for unreadable files;
/// store errors as for the writes. Batches committed before the error stay.
pub fn import_neo4j_csv(
    store: &Store,
    files: &CsvFiles,
    batch_rows: usize,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<CsvImport> {
    let batch_rows = batch_rows.max(1);
    let total = files.total_bytes();
    let (node_types, rel_types) = typed(store);
    // pass 1: the ids, checked unique, and whether they can be kept
    let kept = if store.counts()?.total_nodes == 0 {
        integer_ids(files)?
    } else {
        None
    };
    let ids = match kept {
        Some(_) => Ids::Kept,
        None => Ids::Mapped(HashMap::with_capacity(checked_ids(files)?)),
    };
    let next_after = kept.unwrap_or(0);
    let mut out = CsvImport {
        ids_kept: matches!(ids, Ids::Kept),
        ..CsvImport::default()
    };
    let mut ids = ids;
    let mut done_bytes = 0u64;
    if out.ids_kept {
        store.write(|tx| {
            tx.reserve_node_ids(next_after);
            Ok(())
        })?;
    }
    // pass 2: nodes
    for f in &files.nodes {
        let mut r = Reader::open(&f.path, true)?;
        let id_col = r.cols.iter().position(|c| matches!(c, Col::Id(..)));
        let label_col = r.cols.iter().position(|c| *c == Col::Label);
        let mut keys: Option<Vec<Option<PropKey>>> = None;
        // per `:LABEL` field: the row's labels (the file's given ones first) and the schema's
        // type for each column
        let mut label_sets: hashbrown::HashMap<String, (Vec<LabelId>, Vec<Option<ValueType>>)> =
            hashbrown::HashMap::new();
        // rows keeping their ids, restored together when the batch ends
        // (`WriteTxn::restore_nodes`), with each row's line for errors
        let pending: std::cell::RefCell<(Vec<crate::model::RestoredNode>, Vec<u64>)> =
            Default::default();
        let path = f.path.clone();
        let mut flush = |tx: &mut WriteTxn<'_>| -> Result<()> {
            let (rows, lines) = std::mem::take(&mut *pending.borrow_mut());
            tx.restore_nodes(rows).map_err(|(i, e)| Error::Import {
                path: path.clone(),
                line: lines.get(i).copied().unwrap_or(0),
                detail: e.to_string(),
            })
        };
        let mut row = |tx: &mut WriteTxn<'_>, r: &mut Reader| -> Result<()> {
            let keys = match &keys {
                Some(k) => k,
                None => keys.insert(prop_keys(tx, &r.cols)?),
            };
            let field = label_col.map_or("", |lc| r.rec.get(lc).unwrap_or_default());
            if !label_sets.contains_key(field) {
                let names: Vec<String> = f
                    .given
                    .iter()
                    .map(String::as_str)
                    .chain(field.split(ARRAY_DELIMITER))
                    .map(str::trim)
                    .filter(|s| !s.is_empty())
                    .map(str::to_string)
                    .collect();
                let ids = names
                    .iter()
                    .map(|l| tx.label_id(l))
                    .collect::<Result<Vec<_>>>()?;
                let want = column_types(&r.cols, |k| {
                    names
                        .iter()
                        .find_map(|l| node_types.get(l).and_then(|m| m.get(k)).copied())
                });
                label_sets.insert(field.to_string(), (ids, want));
            }
            let (labels, want) = &label_sets[field];
            let props = row_props(r, keys, want)?;
            let at = |e: Error| r.err(e.to_string());
            match (&mut ids, id_col) {
                (Ids::Kept, Some(ic)) => {
                    let id: u64 =
                        r.rec.get(ic).unwrap_or_default().parse().map_err(|_| {
                            r.err("the :ID changed between the two reads of the file")
                        })?;
                    let mut p = pending.borrow_mut();
                    p.0.push((id, labels.clone(), props));
                    p.1.push(r.line());
                }
                (Ids::Mapped(m), Some(ic)) => {
                    let Col::Id(_, group) = &r.cols[ic] else {
                        unreachable!("id_col points at an Id column")
                    };
                    let id = tx.create_node(labels, props).map_err(at)?;
                    m.insert(
                        (group.clone(), r.rec.get(ic).unwrap_or_default().to_string()),
                        id,
                    );
                }
                (_, None) => {
                    tx.create_node(labels, props).map_err(at)?;
                }
            }
            Ok(())
        };
        in_batches(
            store,
            &mut r,
            batch_rows,
            &mut row,
            &mut flush,
            &mut |rows, bytes| {
                out.nodes += rows;
                out.batches += 1;
                progress(done_bytes + bytes, total);
            },
        )?;
        done_bytes += std::fs::metadata(&f.path).map_or(0, |m| m.len());
    }
    // pass 3: relationships. Into a store without relationships, the adjacency rows wait in
    // memory (up to MAX_DEFERRED_ADJ of them) and go in at the end, sorted: appended to an
    // empty table, its B-tree pages come out full, and the inserts cost a fraction of merging
    // each batch's rows into the table. The batches committed before an error get theirs
    // before the error is returned.
    let mut deferred: Option<Vec<AdjRow>> =
        (store.counts()?.total_relationships == 0).then(Vec::new);
    let result = import_relationships(
        store,
        files,
        batch_rows,
        &ids,
        &rel_types,
        &mut deferred,
        &mut out,
        &mut done_bytes,
        total,
        progress,
    );
    let written = match deferred.as_mut().filter(|r| !r.is_empty()) {
        Some(rows) => store.write(|tx| tx.insert_adjacency(rows)),
        None => Ok(()),
    };
    // the import's own error first; a failed adjacency write after it is the next to report
    result?;
    written?;
    Ok(out)
}

/// Relationship rows held back for one sorted insert at most (32 bytes each).
const MAX_DEFERRED_ADJ: usize = 8 << 20;

/// Pass 3 of [`import_neo4j_csv`]: the relationship files, in batches.
#[allow(clippy::too_many_arguments)]
fn import_relationships(
    store: &Store,
    files: &CsvFiles,
    batch_rows: usize,
    ids: &Ids,
    rel_types: &Typed,
    deferred: &mut Option<Vec<AdjRow>>,
    out: &mut CsvImport,
    done_bytes: &mut u64,
    total: u64,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<()> {
    // the adjacency of the batch being written; moved to `deferred` once it has committed
    let batch_adj: std::cell::RefCell<Vec<AdjRow>> = Default::default();
    // the ends' labels, read once for the whole load
    let end_labels: std::cell::RefCell<crate::txn::EndLabels> = Default::default();
    let defer = deferred.is_some();
    let mut flush_err: Option<Error> = None;
    for f in &files.relationships {
        let mut r = Reader::open(&f.path, true)?;
        let find = |want: fn(&Col) -> bool, what: &str| {
            r.cols.iter().position(want).ok_or_else(|| Error::Import {
                path: f.path.clone(),
                line: 1,
                detail: format!("the header has no {what} column"),
            })
        };
        let sc = find(|c| matches!(c, Col::StartId(_)), ":START_ID")?;
        let ec = find(|c| matches!(c, Col::EndId(_)), ":END_ID")?;
        let tc = r.cols.iter().position(|c| *c == Col::Type);
        let given = f.given.first().map(String::as_str);
        if tc.is_none() && f.given.len() != 1 {
            return Err(Error::Import {
                path: f.path.clone(),
                line: 1,
                detail: "no :TYPE column; give the type with the file (TYPE=file.csv)".into(),
            });
        }
        let (Col::StartId(sg), Col::EndId(eg)) = (r.cols[sc].clone(), r.cols[ec].clone()) else {
            unreachable!("found by kind")
        };
        let mut keys: Option<Vec<Option<PropKey>>> = None;
        // per type name: its id and the schema's type for each column
        let mut types: hashbrown::HashMap<String, (RelType, Vec<Option<ValueType>>)> =
            hashbrown::HashMap::new();
        // a batch's rows, created together when it ends (see `WriteTxn::create_rels`), with
        // each row's line for errors
        let pending: std::cell::RefCell<(Vec<crate::NewRel>, Vec<u64>)> = Default::default();
        let path = f.path.clone();
        let mut flush = |tx: &mut WriteTxn<'_>| -> Result<()> {
            let (rows, lines) = std::mem::take(&mut *pending.borrow_mut());
            let ends: Vec<(u64, u64)> = rows.iter().map(|(s, _, e, _)| (*s, *e)).collect();
            let mut adj = batch_adj.borrow_mut();
            adj.clear();
            let into = defer.then_some(&mut *adj);
            let mut cache = end_labels.borrow_mut();
            tx.create_rels_into(rows, into, &mut cache)
                .map_err(|(i, err)| {
                    let detail = match err {
                        Error::NodeNotFound(id) => format!(
                            "column {}: no node has the :ID \"{id}\"",
                            if ends.get(i).is_some_and(|(s, _)| *s == id) {
                                sc + 1
                            } else {
                                ec + 1
                            }
                        ),
                        other => other.to_string(),
                    };
                    Error::Import {
                        path: path.clone(),
                        line: lines.get(i).copied().unwrap_or(0),
                        detail,
                    }
                })?;
            Ok(())
        };
        let mut row = |tx: &mut WriteTxn<'_>, r: &mut Reader| -> Result<()> {
            let keys = match &keys {
                Some(k) => k,
                None => keys.insert(prop_keys(tx, &r.cols)?),
            };
            // the row's type, else the file's
            let tname = tc
                .and_then(|c| r.rec.get(c))
                .map(str::trim)
                .filter(|t| !t.is_empty())
                .or(given)
                .ok_or_else(|| r.err("an empty :TYPE"))?;
            if !types.contains_key(tname) {
                let id = tx.rel_type_id(tname)?;
                let declared = rel_types.get(tname);
                let want = column_types(&r.cols, |k| declared.and_then(|m| m.get(k)).copied());
                types.insert(tname.to_string(), (id, want));
            }
            let (ty, want) = &types[tname];
            let end_id = |col: usize, group: &str| -> Result<u64> {
                let raw = r.rec.get(col).unwrap_or_default();
                let found = match &ids {
                    Ids::Kept => raw.parse::<u64>().ok(),
                    Ids::Mapped(m) => m.get(&(group.to_string(), raw.to_string())).copied(),
                };
                found.ok_or_else(|| {
                    r.err(format!(
                        "column {}: no node has the :ID {raw:?}{}",
                        col + 1,
                        if group.is_empty() {
                            String::new()
                        } else {
                            format!(" in id space {group}")
                        }
                    ))
                })
            };
            let (s, e) = (end_id(sc, &sg)?, end_id(ec, &eg)?);
            let props = row_props(r, keys, want)?;
            let mut p = pending.borrow_mut();
            p.0.push((s, *ty, e, props));
            p.1.push(r.line());
            Ok(())
        };
        in_batches(
            store,
            &mut r,
            batch_rows,
            &mut row,
            &mut flush,
            &mut |rows, bytes| {
                out.relationships += rows;
                out.batches += 1;
                progress(*done_bytes + bytes, total);
                // a committed batch's adjacency joins the deferred rows (a failed batch's is
                // dropped with it); past the cap they are written in a transaction of their own
                if let Some(d) = deferred.as_mut() {
                    d.append(&mut batch_adj.borrow_mut());
                    if d.len() >= MAX_DEFERRED_ADJ && flush_err.is_none() {
                        match store.write(|tx| tx.insert_adjacency(d)) {
                            Ok(()) => d.clear(),
                            Err(e) => flush_err = Some(e),
                        }
                    }
                }
            },
        )?;
        if let Some(e) = flush_err.take() {
            return Err(e);
        }
        *done_bytes += std::fs::metadata(&f.path).map_or(0, |m| m.len());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_read_every_neo4j_column_kind() {
        let h = csv::StringRecord::from(vec![
            "uid:ID(People)",
            "name",
            "age:int",
            "score:double",
            "tags:string[]",
            "at:point{crs:cartesian}",
            ":LABEL",
            "skip:IGNORE",
        ]);
        let cols = parse_header(Path::new("x.csv"), &h).unwrap();
        assert_eq!(cols[0], Col::Id(Some("uid".into()), "People".into()));
        assert_eq!(cols[1], Col::Prop("name".into(), Scalar::Str, false));
        assert_eq!(cols[2], Col::Prop("age".into(), Scalar::Int, false));
        assert_eq!(cols[3], Col::Prop("score".into(), Scalar::Float, false));
        assert_eq!(cols[4], Col::Prop("tags".into(), Scalar::Str, true));
        assert_eq!(cols[5], Col::Prop("at".into(), Scalar::Point, false));
        assert_eq!(cols[6], Col::Label);
        assert_eq!(cols[7], Col::Ignore);
        let bad = parse_header(
            Path::new("x.csv"),
            &csv::StringRecord::from(vec![":ID", "n:quaternion"]),
        )
        .unwrap_err();
        assert!(bad.to_string().contains("x.csv:1"), "{bad}");
        assert!(bad.to_string().contains("quaternion"), "{bad}");
    }

    #[test]
    fn fields_parse_as_the_export_writes_them() {
        assert_eq!(
            parse_field("{x: 1.5, y: -2.0, z: 3.0}", Scalar::Point, false).unwrap(),
            Value::Point3D([1.5, -2.0, 3.0])
        );
        assert_eq!(
            parse_field("{y: 2, x: 1}", Scalar::Point, false).unwrap(),
            Value::Point2D([1.0, 2.0])
        );
        let Value::Vector(v) = parse_field("0.5;NaN;-Infinity", Scalar::Float32, true).unwrap()
        else {
            panic!("float[] is a vector")
        };
        assert!((v[0] - 0.5).abs() < 1e-9);
        assert!(v[1].is_nan());
        assert!(v[2].is_infinite() && v[2] < 0.0);
        assert_eq!(
            parse_field("0.5;2.0", Scalar::Float, true).unwrap(),
            Value::List(vec![Value::Float(0.5), Value::Float(2.0)])
        );
        assert_eq!(
            parse_field("1;2", Scalar::Int, true).unwrap(),
            Value::List(vec![Value::Int(1), Value::Int(2)])
        );
        assert!(parse_field("12x", Scalar::Int, false).is_err());
        assert!(parse_field("yes", Scalar::Bool, false).is_err());
        assert!(parse_field("{x: 1}", Scalar::Point, false).is_err());
    }

    #[test]
    fn json_text_becomes_the_schema_type() {
        let bx = Value::String(r#"[{"x":0,"y":1.5,"z":2},{"x":1,"y":2,"z":3}]"#.into());
        let got = coerce(bx.clone(), Some(ValueType::Box3D));
        assert!(got.as_box3d().is_some(), "{got:?}");
        // a plain string, or no declared type, stays a string
        assert_eq!(coerce(bx.clone(), Some(ValueType::String)), bx);
        assert_eq!(coerce(bx.clone(), None), bx);
        let m = coerce(
            Value::String(r#"{"a":{"$float":"NaN"},"b":[1,2]}"#.into()),
            Some(ValueType::Map),
        );
        let Value::Map(m) = m else {
            panic!("a map: {m:?}")
        };
        assert!(matches!(m["a"], Value::Float(f) if f.is_nan()));
        assert_eq!(m["b"], Value::List(vec![Value::Int(1), Value::Int(2)]));
        // text that is not that type stays text (and the store's check reports it)
        let bad = Value::String("not json".into());
        assert_eq!(coerce(bad.clone(), Some(ValueType::Map)), bad);
    }

    #[test]
    fn file_arguments_take_neo4j_admin_prefixes() {
        assert_eq!(
            CsvFile::parse("Person:Actor=people.csv"),
            CsvFile {
                path: "people.csv".into(),
                given: vec!["Person".into(), "Actor".into()]
            }
        );
        assert_eq!(CsvFile::parse("a/b=c.csv").given, Vec::<String>::new());
    }
}
