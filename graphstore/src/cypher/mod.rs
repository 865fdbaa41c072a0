//! An openCypher engine over the store.
//!
//! [`Store::query`] parses a statement, checks it, and runs it in one transaction: a read
//! transaction when it only reads, one write transaction when it writes (all or nothing).
//!
//! ```
//! use graphstore::{Store, cypher::{QueryOptions, Val}};
//! let dir = tempfile::tempdir().unwrap();
//! let store = Store::create(dir.path().join("g.og")).unwrap();
//! store.query("CREATE (:Lane {id: 1})-[:NEXT]->(:Lane {id: 2})", &QueryOptions::default()).unwrap();
//! let r = store
//!     .query("MATCH (a:Lane)-[:NEXT]->(b) RETURN a.id AS from, b.id AS to", &QueryOptions::default())
//!     .unwrap();
//! assert_eq!(r.columns, ["from", "to"]);
//! assert_eq!(r.rows, vec![vec![Val::Int(1), Val::Int(2)]]);
//! ```

mod ast;
mod check;
mod count;
mod eval;
mod exec;
mod index_cmd;
mod label_set;
mod lexer;
mod logical;
mod parser;
mod physical;
mod pipeline;
mod plan;
mod source;
mod value;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

pub use value::Val;

use crate::{GraphRead, Store};

/// A place in the query text (1-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pos {
    /// Line, from 1.
    pub line: u32,
    /// Column in characters, from 1.
    pub col: u32,
}

/// The class of a query error, following the openCypher TCK's error types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The text is not valid Cypher, or is invalid before running (unknown function, ...).
    Syntax,
    /// A semantic error found while checking or running (undefined variable, ...).
    Semantic,
    /// A value of the wrong type.
    Type,
    /// A value out of range.
    Argument,
    /// A deleted node or relationship was used.
    EntityNotFound,
    /// A constraint would be violated (deleting a connected node, a schema rule).
    Constraint,
    /// A parameter was not given.
    Parameter,
    /// An unknown procedure or a failing procedure call.
    Procedure,
    /// The query ran past its time limit.
    Timeout,
    /// The result has more rows than allowed.
    RowLimit,
    /// A write in read-only mode.
    ReadOnly,
    /// The statement would hold more memory than its budget
    /// ([`QueryOptions::max_memory_bytes`]).
    MemoryLimit,
}

impl ErrorKind {
    /// The TCK's name for this class (`SyntaxError`, `TypeError`, ...).
    pub fn name(self) -> &'static str {
        match self {
            ErrorKind::Syntax => "SyntaxError",
            ErrorKind::Semantic => "SemanticError",
            ErrorKind::Type => "TypeError",
            ErrorKind::Argument => "ArgumentError",
            ErrorKind::EntityNotFound => "EntityNotFound",
            ErrorKind::Constraint => "ConstraintVerificationFailed",
            ErrorKind::Parameter => "ParameterMissing",
            ErrorKind::Procedure => "ProcedureError",
            ErrorKind::Timeout => "Timeout",
            ErrorKind::RowLimit => "RowLimit",
            ErrorKind::ReadOnly => "ReadOnly",
            ErrorKind::MemoryLimit => "MemoryLimit",
        }
    }
}

/// A query that could not be parsed, checked or run.
#[derive(Debug, Clone, PartialEq)]
pub struct QueryError {
    /// Its class.
    pub kind: ErrorKind,
    /// A short code (`UnexpectedSyntax`, `UndefinedVariable`, `InvalidArgumentType`, ...).
    pub code: &'static str,
    /// What went wrong.
    pub message: String,
    /// Where in the query, when known.
    pub pos: Option<Pos>,
}

impl QueryError {
    pub(crate) fn new(
        kind: ErrorKind,
        code: &'static str,
        message: impl Into<String>,
        pos: Option<Pos>,
    ) -> Self {
        QueryError {
            kind,
            code,
            message: message.into(),
            pos,
        }
    }
    pub(crate) fn syntax(code: &'static str, message: impl Into<String>, pos: Option<Pos>) -> Self {
        Self::new(ErrorKind::Syntax, code, message, pos)
    }
    /// Fills in the position if it is not known yet.
    pub(crate) fn at(mut self, pos: Pos) -> Self {
        if self.pos.is_none() {
            self.pos = Some(pos);
        }
        self
    }
}

impl std::fmt::Display for QueryError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.kind.name())?;
        if self.code != self.kind.name() {
            write!(f, " ({})", self.code)?;
        }
        if let Some(p) = self.pos {
            write!(f, " at line {}, column {}", p.line, p.col)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for QueryError {}

impl From<crate::Error> for QueryError {
    fn from(e: crate::Error) -> Self {
        match e {
            crate::Error::Query(q) => q,
            crate::Error::Constraint { .. } => QueryError::new(
                ErrorKind::Constraint,
                "ConstraintViolation",
                e.to_string(),
                None,
            ),
            crate::Error::InvalidValue(_) => QueryError::new(
                ErrorKind::Argument,
                "InvalidArgumentValue",
                e.to_string(),
                None,
            ),
            crate::Error::NoSuchIndex { .. } => {
                QueryError::new(ErrorKind::Procedure, "NoSuchIndex", e.to_string(), None)
            }
            other => QueryError::new(ErrorKind::Semantic, "StoreError", other.to_string(), None),
        }
    }
}

pub(crate) type R<T> = Result<T, QueryError>;

/// How to run a query.
#[derive(Debug, Clone)]
pub struct QueryOptions {
    /// Values for `$name` parameters.
    pub params: BTreeMap<String, Val>,
    /// Stop with [`ErrorKind::Timeout`] after this long (the transaction is rolled back).
    pub timeout: Option<Duration>,
    /// Fail with [`ErrorKind::RowLimit`] when the result would have more rows.
    pub row_limit: Option<usize>,
    /// Refuse statements that write.
    pub read_only: bool,
    /// Fail with [`ErrorKind::RowLimit`] when an operator holds more rows than this at once (a
    /// memory guard for runaway patterns; default 10 million). The interpreter holds every
    /// clause's rows; the pipeline streams, so only what sorts, groups, deduplicates or is
    /// returned counts there.
    pub max_intermediate_rows: usize,
    /// Fail with [`ErrorKind::MemoryLimit`] when the statement would hold more bytes than
    /// this at once: rows, paths, lists, strings, maps, aggregation state (measured with
    /// [`crate::mem::CountingAlloc`] where the binary installs it; default 1 GiB). Sizes that
    /// could never be allocated (a `range` of 10^15 elements, `k` of a vector search) are
    /// refused before allocating whether or not allocations are counted.
    pub max_memory_bytes: u64,
    /// Seed of `rand()`.
    pub seed: u64,
    /// The two world axes that span the ground plane (0 = x, 1 = y, 2 = z), in the order
    /// of ground coordinates: what `db.index.spatial.withinGroundDistance` and
    /// `db.index.spatial.nearestOnGround` measure on, and what makes `withinDistance` and
    /// `nearest` refuse a 2-D point (it has no height). None: the ground procedures fail.
    /// OpenGraph sets it from the map's `Environment.ground_frame` (`[0, 2]` for KITTI).
    pub ground_axes: Option<[usize; 2]>,
    /// Which engine runs read-only single queries (see [`Engine`]).
    pub engine: Engine,
}

/// Which engine runs a read-only single query.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Engine {
    /// The pipeline of physical operators where its logical plan covers the query (MATCH
    /// of fixed-length patterns, OPTIONAL MATCH, WHERE, UNWIND, WITH, RETURN, aggregation,
    /// DISTINCT, ORDER BY, SKIP, LIMIT), else the clause interpreter. Writes, procedures,
    /// variable-length and shortest paths run on the interpreter.
    #[default]
    Auto,
    /// The clause interpreter for everything (for differential tests and comparisons).
    Interpreter,
}

impl Default for QueryOptions {
    fn default() -> Self {
        QueryOptions {
            params: BTreeMap::new(),
            timeout: Some(Duration::from_secs(60)),
            row_limit: None,
            read_only: false,
            max_intermediate_rows: 10_000_000,
            max_memory_bytes: 1 << 30,
            seed: 0,
            ground_axes: None,
            engine: Engine::Auto,
        }
    }
}

/// What a write did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Nodes created.
    pub nodes_created: u64,
    /// Nodes deleted.
    pub nodes_deleted: u64,
    /// Relationships created.
    pub relationships_created: u64,
    /// Relationships deleted (DETACH DELETE included).
    pub relationships_deleted: u64,
    /// Properties set to a non-null value.
    pub properties_set: u64,
    /// Properties removed with REMOVE.
    pub properties_removed: u64,
    /// Labels added.
    pub labels_added: u64,
    /// Labels removed.
    pub labels_removed: u64,
}

/// A node referenced by a result, read in the query's transaction.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeData {
    /// Label names, sorted.
    pub labels: Vec<String>,
    /// Properties by name.
    pub props: BTreeMap<String, Val>,
}

/// A relationship referenced by a result.
#[derive(Debug, Clone, PartialEq)]
pub struct RelData {
    /// Its type.
    pub ty: String,
    /// Start node id.
    pub start: u64,
    /// End node id.
    pub end: u64,
    /// Properties by name.
    pub props: BTreeMap<String, Val>,
}

/// The result of a query.
#[derive(Debug, Clone, Default)]
pub struct QueryResult {
    /// Column names, in order.
    pub columns: Vec<String>,
    /// Rows of values, one per column.
    pub rows: Vec<Vec<Val>>,
    /// The nodes the rows mention (deleted ones are absent).
    pub nodes: BTreeMap<u64, NodeData>,
    /// The relationships the rows mention.
    pub rels: BTreeMap<u64, RelData>,
    /// What the statement wrote.
    pub stats: Stats,
    /// For `EXPLAIN`: the plan; no rows are produced. For `PROFILE`: the plan, then per clause
    /// the rows it handed on and its time, beside the rows.
    pub plan: Option<String>,
}

impl QueryResult {
    /// For `EXPLAIN`: the plan as JSON, one `{"operator", "depth"}` per line of the text plan,
    /// outermost first (depth 0 is a clause, deeper lines the operators under it); None when
    /// the statement was not an `EXPLAIN`.
    pub fn plan_json(&self) -> Option<serde_json::Value> {
        let plan = self.plan.as_ref()?;
        Some(serde_json::Value::Array(
            plan.lines()
                .filter(|l| !l.trim().is_empty())
                .map(|l| {
                    let indent = l.len() - l.trim_start().len();
                    serde_json::json!({"operator": l.trim(), "depth": indent / 2})
                })
                .collect(),
        ))
    }

    /// A value as Cypher literal text: `(:Lane {id: 1})`, `[:NEXT]`, `'text'`, `[1, 2]`.
    pub fn render(&self, v: &Val) -> String {
        let map = |m: &BTreeMap<String, Val>| -> String {
            let parts: Vec<String> = m
                .iter()
                .map(|(k, v)| format!("{k}: {}", self.render(v)))
                .collect();
            format!("{{{}}}", parts.join(", "))
        };
        let node = |id: &u64| match self.nodes.get(id) {
            Some(n) => {
                let mut s = String::from("(");
                for l in &n.labels {
                    s.push(':');
                    s.push_str(l);
                }
                if !n.props.is_empty() {
                    if !n.labels.is_empty() {
                        s.push(' ');
                    }
                    s.push_str(&map(&n.props));
                }
                s.push(')');
                s
            }
            None => format!("(deleted node {id})"),
        };
        let rel = |id: &u64| match self.rels.get(id) {
            Some(r) => {
                let mut s = format!("[:{}", r.ty);
                if !r.props.is_empty() {
                    s.push(' ');
                    s.push_str(&map(&r.props));
                }
                s.push(']');
                s
            }
            None => format!("[deleted relationship {id}]"),
        };
        match v {
            Val::Null => "null".into(),
            Val::Str(s) => format!("'{}'", s.replace('\\', "\\\\").replace('\'', "\\'")),
            Val::List(l) => format!(
                "[{}]",
                l.iter()
                    .map(|x| self.render(x))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Val::Vector(l) => format!(
                "[{}]",
                l.iter()
                    .map(|x| eval::fmt_float(f64::from(*x)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Val::Map(m) => map(m),
            Val::Node(id) => node(id),
            Val::Rel(id) => rel(id),
            Val::Path { nodes, rels } => {
                let mut s = String::from("<");
                s.push_str(&node(&nodes[0]));
                for (i, r) in rels.iter().enumerate() {
                    let forward = self.rels.get(r).is_none_or(|d| d.start == nodes[i]);
                    if forward {
                        s.push('-');
                        s.push_str(&rel(r));
                        s.push_str("->");
                    } else {
                        s.push_str("<-");
                        s.push_str(&rel(r));
                        s.push('-');
                    }
                    s.push_str(&node(&nodes[i + 1]));
                }
                s.push('>');
                s
            }
            Val::Bytes(b) => format!("<{} bytes>", b.len()),
            other => eval::to_string(other).unwrap_or_default(),
        }
    }

    /// A value as JSON: nodes become `{"_id", "_labels", ...props}`, relationships
    /// `{"_id", "_type", "_start", "_end", ...props}`, paths `{"nodes": [...], "relationships": [...]}`.
    pub fn to_json(&self, v: &Val) -> serde_json::Value {
        self.to_json_as(v, JsonForm::Full)
    }

    /// A value as JSON in `form`: [`JsonForm::Brief`] summarises the bulky properties of whole
    /// nodes and relationships (see [`JsonForm`]); values returned on their own are whole.
    pub fn to_json_as(&self, v: &Val, form: JsonForm) -> serde_json::Value {
        use serde_json::{Value as J, json};
        let props = |m: &BTreeMap<String, Val>, o: &mut serde_json::Map<String, J>| {
            for (k, v) in m {
                let value = match form.summary(v) {
                    Some(s) => J::String(s),
                    None => self.to_json_as(v, form),
                };
                o.insert(k.clone(), value);
            }
        };
        match v {
            Val::List(l) => J::Array(l.iter().map(|x| self.to_json_as(x, form)).collect()),
            Val::Map(m) => J::Object(
                m.iter()
                    .map(|(k, v)| (k.clone(), self.to_json_as(v, form)))
                    .collect(),
            ),
            Val::Node(id) => {
                let mut o = serde_json::Map::new();
                o.insert("_id".into(), json!(id));
                if let Some(n) = self.nodes.get(id) {
                    o.insert("_labels".into(), json!(n.labels));
                    props(&n.props, &mut o);
                } else {
                    o.insert("_deleted".into(), json!(true));
                }
                J::Object(o)
            }
            Val::Rel(id) => {
                let mut o = serde_json::Map::new();
                o.insert("_id".into(), json!(id));
                if let Some(r) = self.rels.get(id) {
                    o.insert("_type".into(), json!(r.ty));
                    o.insert("_start".into(), json!(r.start));
                    o.insert("_end".into(), json!(r.end));
                    props(&r.props, &mut o);
                } else {
                    o.insert("_deleted".into(), json!(true));
                }
                J::Object(o)
            }
            Val::Path { nodes, rels } => json!({
                "nodes": nodes.iter().map(|n| self.to_json_as(&Val::Node(*n), form)).collect::<Vec<_>>(),
                "relationships": rels.iter().map(|r| self.to_json_as(&Val::Rel(*r), form)).collect::<Vec<_>>(),
            }),
            // everything else is a storable value: the store's JSON form
            other => other.to_value().map_or(J::Null, |x| x.to_json()),
        }
    }

    /// The rows as JSON objects keyed by column.
    pub fn rows_json(&self) -> serde_json::Value {
        self.rows_json_as(JsonForm::Full)
    }

    /// The rows as JSON objects keyed by column, values in `form`.
    pub fn rows_json_as(&self, form: JsonForm) -> serde_json::Value {
        serde_json::Value::Array(
            self.rows
                .iter()
                .map(|r| {
                    serde_json::Value::Object(
                        self.columns
                            .iter()
                            .zip(r)
                            .map(|(c, v)| (c.clone(), self.to_json_as(v, form)))
                            .collect(),
                    )
                })
                .collect(),
        )
    }
}

/// How [`QueryResult::to_json_as`] writes the properties of whole nodes and relationships.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum JsonForm {
    /// Every property whole.
    #[default]
    Full,
    /// A node's or relationship's vectors, byte strings and lists of more than
    /// [`JsonForm::BRIEF_NUMBERS`] numbers (polygons, polylines) become a short string saying
    /// what was left out (`"<vector of 384 floats: return the property itself to see it>"`);
    /// strings, lists of strings and small lists stay whole. For answers read by agents.
    Brief,
}

impl JsonForm {
    /// The most numbers a property may hold and stay whole in [`JsonForm::Brief`].
    pub const BRIEF_NUMBERS: usize = 24;

    /// What a property of a whole node becomes in this form, when it is left out.
    fn summary(self, v: &Val) -> Option<String> {
        if self == JsonForm::Full {
            return None;
        }
        fn numbers(v: &Val) -> usize {
            match v {
                Val::Int(_) | Val::Float(_) => 1,
                Val::Point2D(_) => 2,
                Val::Point3D(_) => 3,
                Val::Vector(x) => x.len(),
                Val::List(l) => l.iter().map(numbers).sum(),
                _ => 0,
            }
        }
        let see = "return the property itself to see it";
        match v {
            Val::Vector(x) => Some(format!("<vector of {} floats: {see}>", x.len())),
            Val::Bytes(b) => Some(format!("<{} bytes: {see}>", b.len())),
            Val::List(l) if numbers(v) > Self::BRIEF_NUMBERS => Some(format!(
                "<list of {} values, {} numbers: {see}>",
                l.len(),
                numbers(v)
            )),
            _ => None,
        }
    }
}

fn collect_elements(v: &Val, nodes: &mut Vec<u64>, rels: &mut Vec<u64>) {
    match v {
        Val::Node(n) => nodes.push(*n),
        Val::Rel(r) => rels.push(*r),
        Val::Path {
            nodes: ns,
            rels: rs,
        } => {
            nodes.extend(ns);
            rels.extend(rs);
        }
        Val::List(l) => l.iter().for_each(|x| collect_elements(x, nodes, rels)),
        Val::Map(m) => m.values().for_each(|x| collect_elements(x, nodes, rels)),
        _ => {}
    }
}

fn resolve(g: &dyn GraphRead, res: &mut QueryResult) -> crate::Result<()> {
    let mut nodes = Vec::new();
    let mut rels = Vec::new();
    for r in &res.rows {
        for v in r {
            collect_elements(v, &mut nodes, &mut rels);
        }
    }
    let named = |props: Vec<(crate::PropKey, crate::Value)>| -> BTreeMap<String, Val> {
        props
            .into_iter()
            .map(|(k, v)| (g.name_of(k.0).unwrap_or_default(), Val::from(v)))
            .collect()
    };
    for r in rels {
        if res.rels.contains_key(&r) {
            continue;
        }
        if let Some(rel) = g.rel(r)? {
            nodes.push(rel.start);
            nodes.push(rel.end);
            res.rels.insert(
                r,
                RelData {
                    ty: g.name_of(rel.ty.0).unwrap_or_default(),
                    start: rel.start,
                    end: rel.end,
                    props: named(rel.props),
                },
            );
        }
    }
    for n in nodes {
        if res.nodes.contains_key(&n) {
            continue;
        }
        if let Some(node) = g.node(n)? {
            let mut labels: Vec<String> =
                node.labels.iter().filter_map(|l| g.name_of(l.0)).collect();
            labels.sort();
            res.nodes.insert(
                n,
                NodeData {
                    labels,
                    props: named(node.props),
                },
            );
        }
    }
    Ok(())
}

fn run_statement(
    ctx: &mut exec::Ctx<'_, '_>,
    stmt: &ast::Statement,
    opts: &QueryOptions,
    plans: Option<&pipeline::PlanCache>,
) -> R<QueryResult> {
    let mut columns = Vec::new();
    let mut rows: Vec<Vec<Val>> = Vec::new();
    if stmt.profile {
        ctx.profile = Some(exec::Profile::default());
    }
    // PROFILE of the parts the pipeline ran: their plans with rows and time per operator
    let mut profiled: Vec<Option<String>> = Vec::new();
    for (i, part) in stmt.parts.iter().enumerate() {
        let piped = match opts.engine {
            Engine::Auto => pipeline::try_run(ctx, part, stmt.profile, plans.map(|p| (p, i))),
            Engine::Interpreter => None,
        };
        let run = match piped {
            Some(r) => r.map(|(cols, rows, text)| {
                profiled.push(text);
                (cols, rows)
            }),
            None => {
                profiled.push(None);
                ctx.run_single(part, i)
            }
        };
        let (cols, mut r) = run.map_err(|e| match ctx.clause_pos {
            Some(p) => e.at(p),
            None => e,
        })?;
        if i == 0 {
            columns = cols;
        }
        rows.append(&mut r);
        if let Some(limit) = opts.row_limit
            && rows.len() > limit
        {
            return Err(QueryError::new(
                ErrorKind::RowLimit,
                "RowLimit",
                format!("the result has more than {limit} rows; add LIMIT or raise the row limit"),
                None,
            ));
        }
    }
    if !stmt.union_all.is_empty() && !stmt.union_all.iter().all(|a| *a) {
        let mut seen = std::collections::BTreeSet::new();
        rows.retain(|r| seen.insert(value::Key(r.clone())));
    }
    let on_pipeline = profiled.iter().all(Option::is_some);
    let plan = ctx.profile.take().map(|p| {
        if on_pipeline {
            return union_text(stmt, profiled.into_iter().flatten().collect());
        }
        let mut text = plan::explain(stmt, ctx.g());
        text.push_str("Profile (rows handed on, time per clause)\n");
        for s in &p.steps {
            let _ = std::fmt::Write::write_fmt(
                &mut text,
                format_args!(
                    "  {}{}: {} rows, {:.3} ms\n",
                    if stmt.parts.len() > 1 {
                        format!("part {} ", s.part + 1)
                    } else {
                        String::new()
                    },
                    s.clause,
                    s.rows,
                    s.ms
                ),
            );
        }
        text
    });
    Ok(QueryResult {
        columns,
        rows,
        stats: ctx.stats,
        plan,
        ..QueryResult::default()
    })
}

/// The texts of a statement's parts, with the UNION between each two.
fn union_text(stmt: &ast::Statement, parts: Vec<String>) -> String {
    let mut text = String::new();
    for (i, t) in parts.into_iter().enumerate() {
        if i > 0 {
            let all = stmt.union_all.get(i - 1).copied().unwrap_or(false);
            text.push_str(if all {
                "UnionAll\n"
            } else {
                "Union (distinct)\n"
            });
        }
        text.push_str(&t);
    }
    text
}

/// EXPLAIN's text: the pipeline's physical and logical plans when it runs every part, else
/// the interpreter's plan.
fn explain_text(stmt: &ast::Statement, txn: &crate::ReadTxn, engine: Engine) -> String {
    if engine == Engine::Auto {
        let parts: Option<Vec<String>> = stmt
            .parts
            .iter()
            .map(|p| pipeline::explain(p, txn))
            .collect();
        if let Some(parts) = parts {
            return union_text(stmt, parts);
        }
    }
    plan::explain(stmt, txn)
}

/// A statement that held more than this at its peak hands freed memory back to the system
/// when it ends, so a server's resident size returns to its baseline.
const TRIM_AFTER_BYTES: u64 = 64 << 20;

/// Releases a large statement's freed memory (its intermediate values are dropped by now).
fn after_statement<T>(res: R<T>, peak: u64) -> R<T> {
    if peak > TRIM_AFTER_BYTES {
        crate::mem::release_free_memory();
    }
    res
}

/// Statements parsed and checked on this thread, most recently used kept: a service asks the
/// same statements over and over, and for an anchored pattern parsing costs as much as
/// running it. Keyed by the statement's text (a pure function of it).
const STATEMENT_CACHE: std::num::NonZeroUsize = std::num::NonZeroUsize::new(128).unwrap();
/// Longer statements are not kept (they are rare, and would hold memory).
const STATEMENT_CACHE_MAX_TEXT: usize = 4096;

thread_local! {
    static STATEMENTS: std::cell::RefCell<lru::LruCache<String, std::rc::Rc<Prepared>>> =
        std::cell::RefCell::new(lru::LruCache::new(STATEMENT_CACHE));
}

/// A statement parsed and checked, and the physical plans of its parts for the last commit
/// they ran on.
#[derive(Debug)]
struct Prepared {
    stmt: ast::Statement,
    plans: pipeline::PlanCache,
}

/// `text` parsed and semantically checked, from this thread's cache when it was seen lately.
fn checked(text: &str) -> Result<std::rc::Rc<Prepared>, QueryError> {
    if let Some(s) = STATEMENTS.with(|c| c.borrow_mut().get(text).cloned()) {
        return Ok(s);
    }
    let stmt = parser::parse(text)?;
    check::check(&stmt)?;
    let stmt = std::rc::Rc::new(Prepared {
        stmt,
        plans: pipeline::PlanCache::default(),
    });
    if text.len() <= STATEMENT_CACHE_MAX_TEXT {
        STATEMENTS.with(|c| c.borrow_mut().put(text.to_string(), stmt.clone()));
    }
    Ok(stmt)
}

impl Store {
    /// Runs `CREATE INDEX`, `DROP INDEX` or `SHOW INDEXES` (see [`index_cmd`]).
    fn index_command(
        &self,
        cmd: index_cmd::IndexCmd,
        opts: &QueryOptions,
    ) -> crate::Result<QueryResult> {
        use index_cmd::IndexCmd;
        let err = |kind, code, msg: String| -> crate::Result<QueryResult> {
            Err(QueryError::new(kind, code, msg, None).into())
        };
        if cmd != IndexCmd::Show && opts.read_only {
            return err(
                ErrorKind::ReadOnly,
                "ReadOnly",
                "this session is read-only; creating or dropping an index writes".into(),
            );
        }
        let mut schema = self.schema();
        match cmd {
            IndexCmd::Show => {
                let (columns, rows) = index_cmd::show(&schema);
                return Ok(QueryResult {
                    columns,
                    rows,
                    ..QueryResult::default()
                });
            }
            IndexCmd::Create {
                name,
                label,
                key,
                if_not_exists,
            } => {
                let spec = crate::schema::PropertyIndexSpec { name, label, key };
                let new_name = index_cmd::index_name(&spec);
                let clash = schema.effective_property_indexes().into_iter().find(|p| {
                    (p.label == spec.label && p.key == spec.key)
                        || index_cmd::index_name(p) == new_name
                });
                if let Some(p) = clash {
                    if if_not_exists {
                        return Ok(QueryResult::default());
                    }
                    return err(
                        ErrorKind::Constraint,
                        "IndexAlreadyExists",
                        format!(
                            "an index {} on :{}({}) already exists",
                            index_cmd::index_name(&p),
                            p.label,
                            p.key
                        ),
                    );
                }
                schema.property_indexes.push(spec);
            }
            IndexCmd::CreateVector {
                name,
                label,
                key,
                dim,
                int8,
                if_not_exists,
            } => {
                let name = name.unwrap_or_else(|| format!("{label}_{key}").to_lowercase());
                let same = |n: &str| n == name;
                let clash = schema
                    .vector_indexes
                    .iter()
                    .any(|v| same(&v.name) || (v.label == label && v.key == key))
                    || schema.spatial_indexes.iter().any(|x| same(&x.name))
                    || schema.text_indexes.iter().any(|x| same(&x.name))
                    || schema
                        .effective_property_indexes()
                        .iter()
                        .any(|p| same(&index_cmd::index_name(p)));
                if clash {
                    if if_not_exists {
                        return Ok(QueryResult::default());
                    }
                    return err(
                        ErrorKind::Constraint,
                        "IndexAlreadyExists",
                        format!(
                            "an index named {name}, or a vector index on :{label}({key}), already exists"
                        ),
                    );
                }
                schema.vector_indexes.push(crate::schema::VectorIndexSpec {
                    name,
                    label,
                    key,
                    dim,
                    int8,
                    method: Default::default(),
                });
            }
            IndexCmd::Drop {
                name: Some(n),
                on: None,
                ..
            } if schema.vector_indexes.iter().any(|v| v.name == n) => {
                schema.vector_indexes.retain(|v| v.name != n);
            }
            IndexCmd::Drop {
                name,
                on,
                if_exists,
            } => {
                let pos = schema
                    .property_indexes
                    .iter()
                    .position(|p| match (&name, &on) {
                        (Some(n), _) => index_cmd::index_name(p) == *n,
                        (None, Some((l, k))) => p.label == *l && p.key == *k,
                        (None, None) => false,
                    });
                match pos {
                    Some(i) => {
                        schema.property_indexes.remove(i);
                    }
                    None if if_exists => return Ok(QueryResult::default()),
                    None => {
                        let what = name.unwrap_or_else(|| {
                            on.map(|(l, k)| format!(":{l}({k})")).unwrap_or_default()
                        });
                        return err(
                            ErrorKind::EntityNotFound,
                            "IndexNotFound",
                            format!(
                                "no index {what} to drop (SHOW INDEXES lists them; the indexes \
                                 behind unique keys go with their constraint)"
                            ),
                        );
                    }
                }
            }
        }
        self.set_schema(schema)?;
        Ok(QueryResult::default())
    }

    /// Runs a Cypher statement. Reads run in a read transaction; a statement that writes runs
    /// in one write transaction and leaves the store unchanged when it fails.
    pub fn query(&self, text: &str, opts: &QueryOptions) -> crate::Result<QueryResult> {
        if let Some(cmd) = index_cmd::parse(text)? {
            return self.index_command(cmd, opts);
        }
        let prepared = checked(text)?;
        let stmt = &prepared.stmt;
        let deadline = opts.timeout.map(|t| Instant::now() + t);
        let writes = stmt
            .parts
            .iter()
            .any(|p| p.clauses.iter().any(ast::Clause::is_write));
        if stmt.explain {
            let txn = self.read()?;
            let plan = explain_text(stmt, &txn, opts.engine);
            return Ok(QueryResult {
                plan: Some(plan),
                ..QueryResult::default()
            });
        }
        if writes {
            if opts.read_only {
                let pos = stmt
                    .parts
                    .iter()
                    .flat_map(|p| p.clauses.iter().zip(&p.positions))
                    .find(|(c, _)| c.is_write())
                    .map(|(_, p)| *p);
                return Err(QueryError::new(
                    ErrorKind::ReadOnly,
                    "ReadOnly",
                    "this session is read-only; the statement writes",
                    pos,
                )
                .into());
            }
            self.write(|tx| {
                let mut ctx =
                    exec::Ctx::new(exec::Tx::Write(&mut *tx), &opts.params, deadline, opts.seed);
                ctx.max_rows = opts.max_intermediate_rows;
                ctx.max_memory = opts.max_memory_bytes;
                ctx.ground_axes = opts.ground_axes;
                let res = run_statement(&mut ctx, stmt, opts, Some(&prepared.plans));
                let peak = ctx.mem_peak();
                drop(ctx);
                let mut res = after_statement(res, peak)?;
                resolve(&*tx, &mut res)?;
                Ok(res)
            })
        } else {
            let txn = self.read()?;
            let mut ctx = exec::Ctx::new(exec::Tx::Read(&txn), &opts.params, deadline, opts.seed);
            ctx.max_rows = opts.max_intermediate_rows;
            ctx.max_memory = opts.max_memory_bytes;
            ctx.ground_axes = opts.ground_axes;
            let res = run_statement(&mut ctx, stmt, opts, Some(&prepared.plans));
            let peak = ctx.mem_peak();
            drop(ctx);
            let mut res = after_statement(res, peak)?;
            resolve(&txn, &mut res)?;
            Ok(res)
        }
    }

    /// The plan of a statement, without running it.
    pub fn explain(&self, text: &str) -> crate::Result<String> {
        let stmt = parser::parse(text)?;
        check::check(&stmt)?;
        let txn = self.read()?;
        Ok(explain_text(&stmt, &txn, Engine::Auto))
    }
}

/// Parses and checks a statement without running it (for tools that validate queries).
pub fn validate(text: &str) -> Result<(), QueryError> {
    let stmt = parser::parse(text)?;
    check::check(&stmt)
}

/// Whether the statement's answer depends only on the graph and its parameters: false when
/// it calls `rand()` (judged from its tokens, so a property named `rand` counts too). A cache
/// of answers must not keep the others.
///
/// # Errors
/// The text does not lex.
pub fn is_deterministic(text: &str) -> Result<bool, QueryError> {
    Ok(!lexer::lex(text)?
        .iter()
        .any(|t| matches!(&t.tok, lexer::Tok::Ident(w) if w.eq_ignore_ascii_case("rand"))))
}

/// Whether the statement writes (CREATE, MERGE, SET, REMOVE, DELETE).
pub fn is_write(text: &str) -> Result<bool, QueryError> {
    if let Some(cmd) = index_cmd::parse(text)? {
        return Ok(cmd != index_cmd::IndexCmd::Show);
    }
    let stmt = parser::parse(text)?;
    Ok(stmt
        .parts
        .iter()
        .any(|p| p.clauses.iter().any(ast::Clause::is_write)))
}

/// Parses a parameter value given on a command line: JSON when it parses as JSON
/// (`3`, `2.5`, `"x"`, `[1,2]`, `{"a":1}`, `true`, `null`), else the plain string.
///
/// # Errors
/// An integer literal outside the 64-bit range (Cypher's INTEGER): it is refused rather than
/// turned into an inexact FLOAT.
pub fn param_from_text(text: &str) -> std::result::Result<Val, String> {
    let t = text.trim();
    let digits = t.strip_prefix('-').unwrap_or(t);
    if !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) && t.parse::<i64>().is_err()
    {
        return Err(format!(
            "{t} is outside the INTEGER range [{}, {}]",
            i64::MIN,
            i64::MAX
        ));
    }
    match serde_json::from_str::<serde_json::Value>(text) {
        Ok(j) => try_from_json(&j),
        Err(_) => Ok(Val::Str(text.to_string())),
    }
}

/// [`from_json`], but a JSON integer outside the 64-bit range is an error instead of a FLOAT.
///
/// # Errors
/// An unsigned integer above `i64::MAX` anywhere in the value.
pub fn try_from_json(j: &serde_json::Value) -> std::result::Result<Val, String> {
    match j {
        serde_json::Value::Number(n) if n.is_u64() && n.as_i64().is_none() => Err(format!(
            "{n} is outside the INTEGER range [{}, {}]",
            i64::MIN,
            i64::MAX
        )),
        serde_json::Value::Array(a) => Ok(Val::List(
            a.iter()
                .map(try_from_json)
                .collect::<std::result::Result<_, _>>()?,
        )),
        serde_json::Value::Object(o) => Ok(Val::Map(
            o.iter()
                .map(|(k, v)| Ok((k.clone(), try_from_json(v)?)))
                .collect::<std::result::Result<_, String>>()?,
        )),
        other => Ok(from_json(other)),
    }
}

/// Converts JSON to a value (integers stay integers).
pub fn from_json(j: &serde_json::Value) -> Val {
    match j {
        serde_json::Value::Null => Val::Null,
        serde_json::Value::Bool(b) => Val::Bool(*b),
        serde_json::Value::Number(n) => n
            .as_i64()
            .map(Val::Int)
            .unwrap_or_else(|| Val::Float(n.as_f64().unwrap_or(f64::NAN))),
        serde_json::Value::String(s) => Val::Str(s.clone()),
        serde_json::Value::Array(a) => Val::List(a.iter().map(from_json).collect()),
        serde_json::Value::Object(o) => {
            Val::Map(o.iter().map(|(k, v)| (k.clone(), from_json(v))).collect())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn store() -> (tempfile::TempDir, Store) {
        let dir = tempfile::tempdir().unwrap();
        let s = Store::create(dir.path().join("m.og")).unwrap();
        (dir, s)
    }

    fn run(s: &Store, q: &str, budget: u64) -> crate::Result<QueryResult> {
        s.query(
            q,
            &QueryOptions {
                max_memory_bytes: budget,
                ..QueryOptions::default()
            },
        )
    }

    fn kind(r: crate::Result<QueryResult>) -> Option<ErrorKind> {
        match r {
            Err(crate::Error::Query(q)) => Some(q.kind),
            _ => None,
        }
    }

    #[test]
    fn a_statement_over_its_memory_budget_is_refused_and_one_under_it_runs() {
        // the lib's tests count allocations (lib.rs), as the binary does
        assert!(crate::mem::counting());
        let (_d, s) = store();
        let q = "RETURN size([x IN range(1, 1000000) | [x, toString(x)]]) AS n";
        assert_eq!(kind(run(&s, q, 16 << 20)), Some(ErrorKind::MemoryLimit));
        let r = run(&s, q, 1 << 30).unwrap();
        assert_eq!(r.rows[0][0], Val::Int(1_000_000));
        // strings and lists that double are stopped before the allocation that breaks it
        for q in [
            "RETURN size(reduce(s = 'x', i IN range(1, 60) | s + s)) AS n",
            "RETURN size(reduce(l = [1], i IN range(1, 60) | l + l)) AS n",
            "WITH reduce(s = 'x', i IN range(1, 16) | s + s) AS s RETURN size(replace(s, 'x', s)) AS n",
        ] {
            assert_eq!(
                kind(run(&s, q, 64 << 20)),
                Some(ErrorKind::MemoryLimit),
                "{q}"
            );
        }
        // a range that could never be allocated is an argument error at once
        let q = "RETURN size(range(0, 9223372036854775807)) AS n";
        assert_eq!(kind(run(&s, q, u64::MAX)), Some(ErrorKind::Argument));
    }
}
