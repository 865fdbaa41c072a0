//! openCypher TCK runner: executes the Gherkin scenarios in `../shared/tck/features` against a
//! fresh store each and prints pass/fail/skip per feature directory.
//!
//! The pass count must not drop below `tests/tck-baseline.txt`. Set `TCK_FILTER=substring` to
//! run only matching scenarios and `TCK_VERBOSE=1` to print every failure.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use graphstore::cypher::{QueryError, QueryOptions, QueryResult, Val};
use graphstore::{GraphRead, Store};

fn tck_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/tck")
}

// ------------------------------------------------------------------ Gherkin

#[derive(Debug, Clone)]
struct Step {
    text: String,
    doc: Option<String>,
    table: Vec<Vec<String>>,
}

#[derive(Debug, Clone)]
struct Scenario {
    name: String,
    steps: Vec<Step>,
    ignored: bool,
}

fn split_row(line: &str) -> Vec<String> {
    // split on | outside of single-quoted strings
    let inner = line.trim().trim_start_matches('|');
    let inner = inner.strip_suffix('|').unwrap_or(inner);
    // Gherkin table cells escape `\|`, `\\` and `\n`
    let mut cells = Vec::new();
    let mut cur = String::new();
    let mut chars = inner.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' => match chars.next() {
                Some('|') => cur.push('|'),
                Some('\\') => cur.push('\\'),
                Some('n') => cur.push('\n'),
                Some(o) => {
                    cur.push('\\');
                    cur.push(o);
                }
                None => cur.push('\\'),
            },
            '|' => {
                cells.push(cur.trim().to_string());
                cur.clear();
            }
            _ => cur.push(c),
        }
    }
    cells.push(cur.trim().to_string());
    cells
}

/// Reads a `"""` doc string starting at line `i` (left on the closing line), dropping the
/// opening quotes' indentation.
fn doc_string(lines: &[&str], i: &mut usize) -> String {
    let indent = lines[*i].find('"').unwrap_or(0);
    let mut doc = Vec::new();
    *i += 1;
    while *i < lines.len() && !lines[*i].trim().starts_with("\"\"\"") {
        let raw = lines[*i];
        let cut = raw
            .char_indices()
            .nth(indent)
            .map(|(b, _)| b)
            .unwrap_or(raw.len());
        let cut = if raw[..cut].trim().is_empty() { cut } else { 0 };
        doc.push(&raw[cut..]);
        *i += 1;
    }
    doc.join("\n")
}

fn parse_feature(path: &Path) -> Vec<Scenario> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    let mut pending_tags: Vec<String> = Vec::new();
    let mut background: Vec<Step> = Vec::new();
    while i < lines.len() {
        let l = lines[i].trim();
        if l.starts_with("Background:") {
            i += 1;
            while i < lines.len()
                && !lines[i].trim().starts_with("Scenario")
                && !lines[i].trim().starts_with('@')
            {
                let l = lines[i].trim();
                if l.starts_with("\"\"\"") {
                    let doc = doc_string(&lines, &mut i);
                    if let Some(s) = background.last_mut() {
                        s.doc = Some(doc);
                    }
                } else {
                    for kw in ["Given ", "And "] {
                        if let Some(rest) = l.strip_prefix(kw) {
                            background.push(Step {
                                text: rest.trim().to_string(),
                                doc: None,
                                table: Vec::new(),
                            });
                        }
                    }
                }
                i += 1;
            }
            continue;
        }
        if l.starts_with('@') {
            pending_tags.extend(l.split_whitespace().map(String::from));
            i += 1;
            continue;
        }
        let outline = l.starts_with("Scenario Outline:");
        if !(l.starts_with("Scenario:") || outline) {
            i += 1;
            continue;
        }
        let name = l
            .split_once(':')
            .map(|x| x.1.trim().to_string())
            .unwrap_or_default();
        let ignored = pending_tags.iter().any(|t| t == "@ignore");
        pending_tags.clear();
        i += 1;
        let mut steps: Vec<Step> = background.clone();
        let mut examples: Vec<Vec<String>> = Vec::new();
        let mut in_examples = false;
        while i < lines.len() {
            let l = lines[i].trim();
            if l.starts_with("Scenario") || l.starts_with('@') {
                break;
            }
            if l.starts_with("Examples:") {
                in_examples = true;
                i += 1;
                continue;
            }
            if l.starts_with("\"\"\"") {
                let doc = doc_string(&lines, &mut i);
                if let Some(s) = steps.last_mut() {
                    s.doc = Some(doc);
                }
                i += 1;
                continue;
            }
            if l.starts_with('|') {
                let row = split_row(l);
                if in_examples {
                    examples.push(row);
                } else if let Some(s) = steps.last_mut() {
                    s.table.push(row);
                }
                i += 1;
                continue;
            }
            for kw in ["Given ", "And ", "When ", "Then ", "But "] {
                if let Some(rest) = l.strip_prefix(kw) {
                    steps.push(Step {
                        text: rest.trim().to_string(),
                        doc: None,
                        table: Vec::new(),
                    });
                }
            }
            i += 1;
        }
        if outline {
            if examples.len() < 2 {
                continue;
            }
            let header = examples[0].clone();
            for (k, row) in examples[1..].iter().enumerate() {
                let subst = |s: &str| {
                    let mut s = s.to_string();
                    for (h, v) in header.iter().zip(row) {
                        s = s.replace(&format!("<{h}>"), v);
                    }
                    s
                };
                let steps = steps
                    .iter()
                    .map(|st| Step {
                        text: subst(&st.text),
                        doc: st.doc.as_deref().map(subst),
                        table: st
                            .table
                            .iter()
                            .map(|r| r.iter().map(|c| subst(c)).collect())
                            .collect(),
                    })
                    .collect();
                out.push(Scenario {
                    name: format!("{name} #{}", k + 1),
                    steps,
                    ignored,
                });
            }
        } else {
            out.push(Scenario {
                name,
                steps,
                ignored,
            });
        }
    }
    out
}

// ------------------------------------------------------------ TCK values

#[derive(Debug, Clone)]
enum T {
    Null,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    List(Vec<T>),
    Map(BTreeMap<String, T>),
    Node(BTreeSet<String>, BTreeMap<String, T>),
    Rel(String, BTreeMap<String, T>),
    /// start node, then (relationship, forward, node)
    Path(Box<T>, Vec<(T, bool, T)>),
}

fn t_eq(a: &T, b: &T, unordered_lists: bool) -> bool {
    match (a, b) {
        (T::Null, T::Null) => true,
        (T::Bool(x), T::Bool(y)) => x == y,
        (T::Int(x), T::Int(y)) => x == y,
        (T::Float(x), T::Float(y)) => {
            (x.is_nan() && y.is_nan())
                || x == y
                || (x - y).abs() <= 1e-12 * x.abs().max(y.abs()).max(1e-300) * 1e3
        }
        (T::Str(x), T::Str(y)) => x == y,
        (T::List(x), T::List(y)) => {
            if x.len() != y.len() {
                return false;
            }
            if unordered_lists {
                let mut used = vec![false; y.len()];
                x.iter().all(|p| {
                    if let Some(j) = (0..y.len()).find(|j| !used[*j] && t_eq(p, &y[*j], true)) {
                        used[j] = true;
                        true
                    } else {
                        false
                    }
                })
            } else {
                x.iter().zip(y).all(|(p, q)| t_eq(p, q, false))
            }
        }
        (T::Map(x), T::Map(y)) => maps_eq(x, y, unordered_lists),
        (T::Node(l1, p1), T::Node(l2, p2)) => l1 == l2 && maps_eq(p1, p2, unordered_lists),
        (T::Rel(t1, p1), T::Rel(t2, p2)) => t1 == t2 && maps_eq(p1, p2, unordered_lists),
        (T::Path(s1, e1), T::Path(s2, e2)) => {
            t_eq(s1, s2, false)
                && e1.len() == e2.len()
                && e1.iter().zip(e2).all(|((r1, f1, n1), (r2, f2, n2))| {
                    f1 == f2 && t_eq(r1, r2, false) && t_eq(n1, n2, false)
                })
        }
        _ => false,
    }
}

fn maps_eq(x: &BTreeMap<String, T>, y: &BTreeMap<String, T>, unordered_lists: bool) -> bool {
    x.len() == y.len()
        && x.iter()
            .zip(y)
            .all(|((k1, v1), (k2, v2))| k1 == k2 && t_eq(v1, v2, unordered_lists))
}

struct VP<'a> {
    s: &'a [u8],
    i: usize,
}

impl VP<'_> {
    fn ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }
    fn peek(&mut self) -> Option<u8> {
        self.ws();
        self.s.get(self.i).copied()
    }
    fn eat(&mut self, c: u8) -> bool {
        if self.peek() == Some(c) {
            self.i += 1;
            true
        } else {
            false
        }
    }
    fn expect(&mut self, c: u8) -> Result<(), String> {
        if self.eat(c) {
            Ok(())
        } else {
            Err(format!("expected '{}' at {}", c as char, self.i))
        }
    }
    fn name(&mut self) -> Result<String, String> {
        self.ws();
        if self.eat(b'`') {
            let st = self.i;
            while self.i < self.s.len() && self.s[self.i] != b'`' {
                self.i += 1;
            }
            let n = String::from_utf8_lossy(&self.s[st..self.i]).to_string();
            self.i += 1;
            return Ok(n);
        }
        let st = self.i;
        while self.i < self.s.len()
            && (self.s[self.i].is_ascii_alphanumeric()
                || self.s[self.i] == b'_'
                || self.s[self.i] >= 0x80)
        {
            self.i += 1;
        }
        if st == self.i {
            return Err(format!("expected a name at {}", self.i));
        }
        Ok(String::from_utf8_lossy(&self.s[st..self.i]).to_string())
    }
    fn props(&mut self) -> Result<BTreeMap<String, T>, String> {
        let mut m = BTreeMap::new();
        self.expect(b'{')?;
        if self.eat(b'}') {
            return Ok(m);
        }
        loop {
            let k = self.name()?;
            self.expect(b':')?;
            let v = self.value()?;
            m.insert(k, v);
            if self.eat(b'}') {
                return Ok(m);
            }
            self.expect(b',')?;
        }
    }
    fn node(&mut self) -> Result<T, String> {
        self.expect(b'(')?;
        let mut labels = BTreeSet::new();
        while self.eat(b':') {
            labels.insert(self.name()?);
        }
        let props = if self.peek() == Some(b'{') {
            self.props()?
        } else {
            BTreeMap::new()
        };
        self.expect(b')')?;
        Ok(T::Node(labels, props))
    }
    fn rel(&mut self) -> Result<T, String> {
        self.expect(b'[')?;
        self.expect(b':')?;
        let ty = self.name()?;
        let props = if self.peek() == Some(b'{') {
            self.props()?
        } else {
            BTreeMap::new()
        };
        self.expect(b']')?;
        Ok(T::Rel(ty, props))
    }
    fn value(&mut self) -> Result<T, String> {
        match self.peek() {
            None => Err("unexpected end".into()),
            Some(b'(') => self.node(),
            Some(b'<') => {
                self.i += 1;
                let start = self.node()?;
                let mut steps = Vec::new();
                while self.peek() != Some(b'>') {
                    if self.eat(b'<') {
                        self.expect(b'-')?;
                        let r = self.rel()?;
                        self.expect(b'-')?;
                        let n = self.node()?;
                        steps.push((r, false, n));
                    } else {
                        self.expect(b'-')?;
                        let r = self.rel()?;
                        self.expect(b'-')?;
                        self.expect(b'>')?;
                        let n = self.node()?;
                        steps.push((r, true, n));
                    }
                }
                self.i += 1;
                Ok(T::Path(Box::new(start), steps))
            }
            Some(b'[') => {
                let save = self.i;
                self.i += 1;
                if self.peek() == Some(b':') {
                    self.i = save;
                    return self.rel();
                }
                let mut l = Vec::new();
                if self.eat(b']') {
                    return Ok(T::List(l));
                }
                loop {
                    l.push(self.value()?);
                    if self.eat(b']') {
                        return Ok(T::List(l));
                    }
                    self.expect(b',')?;
                }
            }
            Some(b'{') => Ok(T::Map(self.props()?)),
            Some(b'\'') => {
                self.i += 1;
                let mut out = Vec::new();
                while self.i < self.s.len() && self.s[self.i] != b'\'' {
                    if self.s[self.i] == b'\\' && self.i + 1 < self.s.len() {
                        self.i += 1;
                        out.push(match self.s[self.i] {
                            b'n' => b'\n',
                            b't' => b'\t',
                            c => c,
                        });
                    } else {
                        out.push(self.s[self.i]);
                    }
                    self.i += 1;
                }
                self.i += 1;
                Ok(T::Str(String::from_utf8_lossy(&out).to_string()))
            }
            Some(_) => {
                let st = self.i;
                while self.i < self.s.len()
                    && !matches!(self.s[self.i], b',' | b']' | b'}' | b')')
                    && !self.s[self.i].is_ascii_whitespace()
                {
                    self.i += 1;
                }
                let w = String::from_utf8_lossy(&self.s[st..self.i]).to_string();
                match w.as_str() {
                    "null" => Ok(T::Null),
                    "true" => Ok(T::Bool(true)),
                    "false" => Ok(T::Bool(false)),
                    "NaN" => Ok(T::Float(f64::NAN)),
                    "Inf" | "Infinity" => Ok(T::Float(f64::INFINITY)),
                    "-Inf" | "-Infinity" => Ok(T::Float(f64::NEG_INFINITY)),
                    _ => {
                        if let Ok(i) = w.parse::<i64>() {
                            Ok(T::Int(i))
                        } else if let Ok(f) = w.parse::<f64>() {
                            Ok(T::Float(f))
                        } else {
                            Err(format!("cannot read value {w:?}"))
                        }
                    }
                }
            }
        }
    }
}

fn parse_t(s: &str) -> Result<T, String> {
    let mut p = VP {
        s: s.as_bytes(),
        i: 0,
    };
    let v = p.value()?;
    if p.peek().is_some() {
        return Err(format!("trailing text in {s:?}"));
    }
    Ok(v)
}

fn t_to_val(t: &T) -> Val {
    match t {
        T::Null => Val::Null,
        T::Bool(b) => Val::Bool(*b),
        T::Int(i) => Val::Int(*i),
        T::Float(f) => Val::Float(*f),
        T::Str(s) => Val::Str(s.clone()),
        T::List(l) => Val::List(l.iter().map(t_to_val).collect()),
        T::Map(m) => Val::Map(m.iter().map(|(k, v)| (k.clone(), t_to_val(v))).collect()),
        _ => Val::Null,
    }
}

fn val_to_t(v: &Val, r: &QueryResult) -> T {
    let props = |m: &BTreeMap<String, Val>| {
        m.iter()
            .map(|(k, v)| (k.clone(), val_to_t(v, r)))
            .collect::<BTreeMap<_, _>>()
    };
    let node = |id: &u64| match r.nodes.get(id) {
        Some(n) => T::Node(n.labels.iter().cloned().collect(), props(&n.props)),
        None => T::Str(format!("<deleted node {id}>")),
    };
    let rel = |id: &u64| match r.rels.get(id) {
        Some(d) => T::Rel(d.ty.clone(), props(&d.props)),
        None => T::Str(format!("<deleted rel {id}>")),
    };
    match v {
        Val::Null => T::Null,
        Val::Bool(b) => T::Bool(*b),
        Val::Int(i) => T::Int(*i),
        Val::Float(f) => T::Float(*f),
        Val::Str(s) => T::Str(s.clone()),
        Val::List(l) => T::List(l.iter().map(|x| val_to_t(x, r)).collect()),
        Val::Map(m) => T::Map(props(m)),
        Val::Node(id) => node(id),
        Val::Rel(id) => rel(id),
        Val::Path { nodes, rels } => T::Path(
            Box::new(node(&nodes[0])),
            rels.iter()
                .enumerate()
                .map(|(i, id)| {
                    let fwd = r.rels.get(id).is_none_or(|d| d.start == nodes[i]);
                    (rel(id), fwd, node(&nodes[i + 1]))
                })
                .collect(),
        ),
        other => T::Str(format!("{other:?}")),
    }
}

// ----------------------------------------------------------------- graph diff

#[derive(Default)]
struct Snapshot {
    nodes: BTreeSet<u64>,
    rels: BTreeSet<u64>,
    labels: BTreeSet<String>,
    props: BTreeSet<(String, String, String)>,
}

fn snapshot(store: &Store) -> Snapshot {
    let mut s = Snapshot::default();
    let Ok(txn) = store.read() else { return s };
    for id in txn.all_node_ids().unwrap_or_default() {
        s.nodes.insert(id);
        if let Ok(Some(n)) = txn.node(id) {
            for l in &n.labels {
                s.labels.insert(txn.name_of(l.0).unwrap_or_default());
            }
            for (k, v) in &n.props {
                s.props.insert((
                    format!("n{id}"),
                    txn.name_of(k.0).unwrap_or_default(),
                    format!("{v:?}"),
                ));
            }
        }
    }
    for id in txn.all_rel_ids().unwrap_or_default() {
        s.rels.insert(id);
        if let Ok(Some(r)) = txn.rel(id) {
            for (k, v) in &r.props {
                s.props.insert((
                    format!("r{id}"),
                    txn.name_of(k.0).unwrap_or_default(),
                    format!("{v:?}"),
                ));
            }
        }
    }
    s
}

fn side_effects(before: &Snapshot, after: &Snapshot) -> BTreeMap<&'static str, usize> {
    let mut m = BTreeMap::new();
    m.insert("+nodes", after.nodes.difference(&before.nodes).count());
    m.insert("-nodes", before.nodes.difference(&after.nodes).count());
    m.insert(
        "+relationships",
        after.rels.difference(&before.rels).count(),
    );
    m.insert(
        "-relationships",
        before.rels.difference(&after.rels).count(),
    );
    m.insert("+labels", after.labels.difference(&before.labels).count());
    m.insert("-labels", before.labels.difference(&after.labels).count());
    m.insert("+properties", after.props.difference(&before.props).count());
    m.insert("-properties", before.props.difference(&after.props).count());
    m
}

// ------------------------------------------------------------------- running

enum Outcome {
    Pass,
    Fail(String),
    Skip(String),
}

const TEMPORAL: &[&str] = &[
    "date(",
    "time(",
    "datetime(",
    "localtime(",
    "localdatetime(",
    "duration(",
];

fn run_scenario(sc: &Scenario, dir: &Path) -> Outcome {
    if sc.ignored {
        return Outcome::Skip("tagged @ignore".into());
    }
    for st in &sc.steps {
        if st.text.starts_with("there exists a procedure") {
            return Outcome::Skip("TCK-specific procedure".into());
        }
        if let Some(d) = &st.doc {
            let low = d.to_ascii_lowercase();
            if TEMPORAL.iter().any(|t| low.contains(t)) {
                return Outcome::Skip("temporal types".into());
            }
        }
    }
    let _ = std::fs::remove_file(dir.join("g.og"));
    let store = match Store::create(dir.join("g.og")) {
        Ok(s) => s,
        Err(e) => return Outcome::Fail(format!("cannot create store: {e}")),
    };
    let mut opts = QueryOptions {
        timeout: Some(std::time::Duration::from_secs(20)),
        ..QueryOptions::default()
    };
    let mut result: Option<Result<QueryResult, QueryError>> = None;
    let mut before = Snapshot::default();
    for st in &sc.steps {
        let t = st.text.as_str();
        if t == "an empty graph" || t == "any graph" {
            continue;
        }
        if let Some(rest) = t
            .strip_prefix("the ")
            .and_then(|r| r.strip_suffix(" graph"))
        {
            let path = tck_root()
                .join("graphs")
                .join(rest)
                .join(format!("{rest}.cypher"));
            let Ok(q) = std::fs::read_to_string(&path) else {
                return Outcome::Skip(format!("named graph {rest} not found"));
            };
            if let Err(e) = store.query(&q, &opts) {
                return Outcome::Fail(format!("building graph {rest}: {e}"));
            }
            continue;
        }
        if t.starts_with("having executed") {
            if let Err(e) = store.query(st.doc.as_deref().unwrap_or(""), &opts) {
                return Outcome::Fail(format!("setup query failed: {e}"));
            }
            continue;
        }
        if t.starts_with("parameters are") {
            for row in &st.table {
                if row.len() == 2 {
                    match parse_t(&row[1]) {
                        Ok(v) => {
                            opts.params.insert(row[0].clone(), t_to_val(&v));
                        }
                        Err(e) => return Outcome::Skip(format!("parameter value: {e}")),
                    }
                }
            }
            continue;
        }
        if t.starts_with("executing query") || t.starts_with("executing control query") {
            let control = t.contains("control");
            if !control {
                before = snapshot(&store);
            }
            let q = st.doc.as_deref().unwrap_or("");
            result = Some(store.query(q, &opts).map_err(|e| match e {
                graphstore::Error::Query(q) => q,
                other => QueryError::from(other),
            }));
            continue;
        }
        let Some(res) = &result else {
            return Outcome::Skip(format!("unsupported step before a query: {t}"));
        };
        if t.starts_with("the result should be") {
            let r = match res {
                Ok(r) => r,
                Err(e) => return Outcome::Fail(format!("query failed: {e}")),
            };
            if t == "the result should be empty" {
                if r.rows.is_empty() {
                    continue;
                }
                return Outcome::Fail(format!("expected no rows, got {}", r.rows.len()));
            }
            let ordered = t.contains("in order");
            let unordered_lists = t.contains("ignoring element order for lists");
            let Some(header) = st.table.first() else {
                return Outcome::Fail("no table".into());
            };
            let mut idx = Vec::new();
            for h in header {
                match r.columns.iter().position(|c| c == h) {
                    Some(i) => idx.push(i),
                    None => {
                        return Outcome::Fail(format!("column {h:?} missing; got {:?}", r.columns));
                    }
                }
            }
            if r.columns.len() != header.len() {
                return Outcome::Fail(format!("columns {:?}, expected {header:?}", r.columns));
            }
            let mut expected = Vec::new();
            for row in &st.table[1..] {
                let mut vals = Vec::new();
                for c in row {
                    match parse_t(c) {
                        Ok(v) => vals.push(v),
                        Err(e) => return Outcome::Skip(format!("expected value: {e}")),
                    }
                }
                expected.push(vals);
            }
            let actual: Vec<Vec<T>> = r
                .rows
                .iter()
                .map(|row| idx.iter().map(|i| val_to_t(&row[*i], r)).collect())
                .collect();
            if actual.len() != expected.len() {
                return Outcome::Fail(format!(
                    "{} rows, expected {}: got {:?}",
                    actual.len(),
                    expected.len(),
                    actual.iter().take(5).collect::<Vec<_>>()
                ));
            }
            let row_eq =
                |a: &Vec<T>, b: &Vec<T>| a.iter().zip(b).all(|(x, y)| t_eq(x, y, unordered_lists));
            if ordered {
                for (k, (a, e)) in actual.iter().zip(&expected).enumerate() {
                    if !row_eq(a, e) {
                        return Outcome::Fail(format!("row {k}: got {a:?}, expected {e:?}"));
                    }
                }
            } else {
                let mut used = vec![false; actual.len()];
                for e in &expected {
                    match (0..actual.len()).find(|j| !used[*j] && row_eq(&actual[*j], e)) {
                        Some(j) => used[j] = true,
                        None => {
                            return Outcome::Fail(format!(
                                "expected row {e:?} not found in {:?}",
                                actual.iter().take(6).collect::<Vec<_>>()
                            ));
                        }
                    }
                }
            }
            continue;
        }
        if t == "no side effects" || t.starts_with("the side effects should be") {
            if res.is_err() {
                return Outcome::Fail("query failed".into());
            }
            let got = side_effects(&before, &snapshot(&store));
            let mut want: BTreeMap<&str, usize> = got.keys().map(|k| (*k, 0)).collect();
            for row in &st.table {
                if row.len() == 2
                    && let Some(slot) = want.iter_mut().find(|(k, _)| **k == row[0]).map(|(_, v)| v)
                {
                    *slot = row[1].parse().unwrap_or(usize::MAX);
                }
            }
            if got != want {
                let diff: Vec<String> = got
                    .iter()
                    .filter(|(k, v)| want.get(*k) != Some(v))
                    .map(|(k, v)| {
                        format!("{k} {v} (expected {})", want.get(k).copied().unwrap_or(0))
                    })
                    .collect();
                return Outcome::Fail(format!("side effects: {}", diff.join(", ")));
            }
            continue;
        }
        if t.contains("should be raised") {
            let class = t
                .trim_start_matches("a ")
                .trim_start_matches("an ")
                .split_whitespace()
                .next()
                .unwrap_or("");
            match res {
                Ok(_) => {
                    return Outcome::Fail(format!("expected {class}, but the query succeeded"));
                }
                Err(e) if e.kind.name() == class => continue,
                Err(e) => return Outcome::Fail(format!("expected {class}, got {e}")),
            }
        }
        return Outcome::Skip(format!("unsupported step: {t}"));
    }
    Outcome::Pass
}

fn features(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "feature") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The directories the issue sets the 70% goal on.
const GOAL_DIRS: &[&str] = &[
    "clauses/match",
    "clauses/match-where",
    "clauses/return",
    "clauses/return-orderby",
    "clauses/return-skip-limit",
    "clauses/with",
    "clauses/with-where",
    "clauses/with-orderBy",
    "clauses/with-skip-limit",
    "clauses/unwind",
    "clauses/create",
    "clauses/delete",
    "clauses/set",
    "clauses/remove",
    "clauses/merge",
    "clauses/union",
    "expressions/aggregation",
    "expressions/boolean",
    "expressions/comparison",
    "expressions/conditional",
    "expressions/list",
    "expressions/literals",
    "expressions/map",
    "expressions/mathematical",
    "expressions/null",
    "expressions/precedence",
    "expressions/string",
];

#[test]
fn opencypher_tck() {
    let root = tck_root().join("features");
    if !root.is_dir() {
        eprintln!("skipping the TCK: {} is absent", root.display());
        return;
    }
    let filter = std::env::var("TCK_FILTER").ok();
    let verbose = std::env::var("TCK_VERBOSE").is_ok();
    let tmp = tempfile::tempdir().expect("tempdir");
    // per directory: (pass, fail, skip)
    let mut per_dir: BTreeMap<String, (usize, usize, usize)> = BTreeMap::new();
    let mut skip_reasons: BTreeMap<String, usize> = BTreeMap::new();
    let mut failures = Vec::new();
    for f in features(&root) {
        let dir = f
            .parent()
            .and_then(|p| p.strip_prefix(&root).ok())
            .map(|p| p.display().to_string())
            .unwrap_or_default();
        for sc in parse_feature(&f) {
            let label = format!(
                "{} / {}",
                f.file_name()
                    .map(|n| n.to_string_lossy().to_string())
                    .unwrap_or_default(),
                sc.name
            );
            if filter
                .as_ref()
                .is_some_and(|flt| !label.contains(flt.as_str()) && !dir.contains(flt.as_str()))
            {
                continue;
            }
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                run_scenario(&sc, tmp.path())
            }))
            .unwrap_or_else(|_| Outcome::Fail("PANIC".into()));
            let e = per_dir.entry(dir.clone()).or_default();
            match outcome {
                Outcome::Pass => e.0 += 1,
                Outcome::Fail(why) => {
                    e.1 += 1;
                    failures.push(format!("{dir}/{label}: {why}"));
                }
                Outcome::Skip(why) => {
                    e.2 += 1;
                    *skip_reasons.entry(why).or_default() += 1;
                }
            }
        }
    }
    let (mut p, mut fl, mut s) = (0, 0, 0);
    let (mut gp, mut gt) = (0, 0);
    println!(
        "{:<36} {:>6} {:>6} {:>6}",
        "directory", "pass", "fail", "skip"
    );
    for (d, (a, b, c)) in &per_dir {
        println!("{d:<36} {a:>6} {b:>6} {c:>6}");
        p += a;
        fl += b;
        s += c;
        if GOAL_DIRS.contains(&d.as_str()) {
            gp += a;
            gt += a + b + c;
        }
    }
    println!("skipped because:");
    for (why, n) in &skip_reasons {
        println!("  {n:>5}  {why}");
    }
    if verbose {
        for f in &failures {
            println!("FAIL {f}");
        }
    }
    let report = Path::new(env!("CARGO_TARGET_TMPDIR")).join("tck-failures.txt");
    let _ = std::fs::write(&report, failures.join("\n"));
    println!("failures listed in {}", report.display());
    if gt > 0 {
        println!(
            "goal directories: {gp} of {gt} passed ({:.1}%)",
            100.0 * gp as f64 / gt as f64
        );
    }
    println!(
        "tck: {p} passed, {fl} failed, {s} skipped of {}",
        p + fl + s
    );
    if filter.is_none() {
        let baseline: usize = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/tck-baseline.txt"),
        )
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| !l.starts_with('#'))
                .and_then(|l| l.trim().parse().ok())
        })
        .unwrap_or(0);
        assert!(
            p >= baseline,
            "TCK pass count {p} fell below the committed baseline {baseline}"
        );
    }
}

/// The runner's own pieces: values are read as the TCK writes them and compared strictly.
#[test]
fn tck_values_parse_and_compare_strictly() {
    let node = parse_t("(:A:B {name: 'x', n: [1, 2.5, null]})").expect("node");
    let same = parse_t("(:B:A {n: [1, 2.5, null], name: 'x'})").expect("node");
    assert!(t_eq(&node, &same, false));
    assert!(!t_eq(
        &node,
        &parse_t("(:A {name: 'x', n: [1, 2.5, null]})").expect("node"),
        false
    ));
    // 1 and 1.0 are different values in a TCK table
    assert!(!t_eq(
        &parse_t("1").expect("int"),
        &parse_t("1.0").expect("float"),
        false
    ));
    assert!(t_eq(
        &parse_t("NaN").expect("nan"),
        &T::Float(f64::NAN),
        false
    ));
    let path = parse_t("<(:A)-[:T {k: 1}]->(:B)<-[:U]-()>").expect("path");
    assert!(matches!(&path, T::Path(_, steps) if steps.len() == 2 && steps[0].1 && !steps[1].1));
    // list order matters unless the step says otherwise
    let (a, b) = (
        parse_t("[1, 2]").expect("list"),
        parse_t("[2, 1]").expect("list"),
    );
    assert!(!t_eq(&a, &b, false) && t_eq(&a, &b, true));
    assert_eq!(
        split_row(r"| 'a\|b' | x |"),
        vec!["'a|b'".to_string(), "x".to_string()]
    );
    assert!(parse_t("(:A").is_err() && parse_t("[1, 2").is_err() && parse_t("1 2").is_err());
}
