//! Index commands, outside the query grammar as in Neo4j (they are schema commands, not
//! clauses): `CREATE INDEX [name] [IF NOT EXISTS] FOR (n:Label) ON (n.key)`, the older
//! `CREATE INDEX ON :Label(key)`, `DROP INDEX name [IF EXISTS]`, `DROP INDEX ON :Label(key)`
//! and `SHOW INDEXES`. A property index serves equality and range lookups of `Label.key`
//! (inline `{key: value}` and `WHERE n.key = / < / > ...`); the planner picks it (EXPLAIN
//! shows `NodeIndexSeek`). An index's name is the one given, else `label_key` in lower case.
//!
//! `CREATE VECTOR INDEX [name] [IF NOT EXISTS] FOR (n:Label) ON [(]n.key[)] OPTIONS
//! {indexConfig: {`vector.dimensions`: 384, `vector.similarity_function`: 'cosine',
//! `vector.quantization.enabled`: true}}` declares an exact cosine vector index in Neo4j 5's
//! syntax (for `db.index.vector.queryNodes`); dimensions are required, cosine is the only
//! similarity, and quantization (an int8 pre-scan that keeps results exact) is on by default.
//! `DROP INDEX name` drops either kind.

use super::value::Val;
use super::{ErrorKind, QueryError};
use crate::schema::PropertyIndexSpec;

/// A parsed index command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum IndexCmd {
    /// Create a property index.
    Create {
        name: Option<String>,
        label: String,
        key: String,
        if_not_exists: bool,
    },
    /// Drop by name, or by label and key.
    Drop {
        name: Option<String>,
        on: Option<(String, String)>,
        if_exists: bool,
    },
    /// Create an exact cosine vector index.
    CreateVector {
        name: Option<String>,
        label: String,
        key: String,
        dim: usize,
        int8: bool,
        if_not_exists: bool,
    },
    /// List every index.
    Show,
}

/// A value in an index command's OPTIONS map.
#[derive(Debug, Clone, PartialEq)]
enum Opt {
    Map(Vec<(String, Opt)>),
    Str(String),
    Int(i64),
    Bool(bool),
}

impl std::fmt::Display for Opt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Opt::Map(m) => {
                write!(f, "{{")?;
                for (i, (k, v)) in m.iter().enumerate() {
                    write!(f, "{}{k}: {v}", if i > 0 { ", " } else { "" })?;
                }
                write!(f, "}}")
            }
            Opt::Str(s) => write!(f, "'{s}'"),
            Opt::Int(n) => write!(f, "{n}"),
            Opt::Bool(b) => write!(f, "{b}"),
        }
    }
}

/// Largest vector dimension an index takes (Neo4j's limit).
const MAX_DIMENSIONS: i64 = 4096;

/// Reads `{key: value, ...}` starting at token `*i` (values: maps, strings, integers, booleans).
fn options_map(t: &[String], i: &mut usize) -> Result<Opt, QueryError> {
    let at = |i: usize| t.get(i).map(String::as_str);
    if at(*i) != Some("{") {
        return Err(syntax("expected { after OPTIONS"));
    }
    *i += 1;
    let mut out = Vec::new();
    if at(*i) == Some("}") {
        *i += 1;
        return Ok(Opt::Map(out));
    }
    loop {
        let key = match at(*i) {
            Some(k) if !"{}:,'".contains(k) && !k.starts_with('\'') => name(k),
            _ => return Err(syntax("expected an option name in OPTIONS")),
        };
        if at(*i + 1) != Some(":") {
            return Err(syntax(format!("expected : after option {key}")));
        }
        *i += 2;
        let value = match at(*i) {
            Some("{") => options_map(t, i)?,
            Some(v) if v.starts_with('\'') => {
                *i += 1;
                Opt::Str(v[1..].to_string())
            }
            Some(v) if v.eq_ignore_ascii_case("true") => {
                *i += 1;
                Opt::Bool(true)
            }
            Some(v) if v.eq_ignore_ascii_case("false") => {
                *i += 1;
                Opt::Bool(false)
            }
            Some(v) => match v.parse::<i64>() {
                Ok(n) => {
                    *i += 1;
                    Opt::Int(n)
                }
                Err(_) => {
                    return Err(syntax(format!(
                        "option {key}: expected a map, a quoted string, an integer or a boolean, got {v:?}"
                    )));
                }
            },
            None => return Err(syntax(format!("option {key} has no value"))),
        };
        out.push((key, value));
        match at(*i) {
            Some(",") => *i += 1,
            Some("}") => {
                *i += 1;
                return Ok(Opt::Map(out));
            }
            _ => return Err(syntax("expected , or } in OPTIONS")),
        }
    }
}

/// Dimensions and quantization from a vector index's OPTIONS.
fn vector_options(opts: Option<Opt>) -> Result<(usize, bool), QueryError> {
    let need =
        "a vector index needs OPTIONS {indexConfig: {`vector.dimensions`: N}} (N from 1 to 4096)";
    let Some(Opt::Map(top)) = opts else {
        return Err(syntax(need));
    };
    let mut config = None;
    for (k, v) in top {
        match (k.as_str(), v) {
            ("indexConfig", Opt::Map(m)) => config = Some(m),
            ("indexProvider", Opt::Str(_)) => {}
            (k, _) => {
                return Err(syntax(format!(
                    "unsupported vector index option {k} (indexConfig is read; indexProvider is ignored)"
                )));
            }
        }
    }
    let (mut dim, mut int8) = (None, true);
    for (k, v) in config.ok_or_else(|| syntax(need))? {
        match (k.as_str(), v) {
            ("vector.dimensions", Opt::Int(n)) if (1..=MAX_DIMENSIONS).contains(&n) => {
                dim = Some(n as usize);
            }
            ("vector.similarity_function", Opt::Str(f)) if f.eq_ignore_ascii_case("cosine") => {}
            ("vector.similarity_function", other) => {
                return Err(syntax(format!(
                    "vector.similarity_function: only 'cosine' is supported, got {other}"
                )));
            }
            ("vector.quantization.enabled", Opt::Bool(b)) => int8 = b,
            (k, v) => {
                return Err(syntax(format!(
                    "unsupported or invalid vector index setting {k}: {v} (vector.dimensions: \
                     1..4096, vector.similarity_function: 'cosine', \
                     vector.quantization.enabled: true/false)"
                )));
            }
        }
    }
    Ok((dim.ok_or_else(|| syntax(need))?, int8))
}

fn syntax(msg: impl Into<String>) -> QueryError {
    QueryError::new(ErrorKind::Syntax, "InvalidIndexCommand", msg, None)
}

/// Words and punctuation of a command: identifiers (backquotes allowed), and `( ) : . ,`.
fn tokens(text: &str) -> Result<Vec<String>, QueryError> {
    let mut out = Vec::new();
    let mut it = text.trim().trim_end_matches(';').chars().peekable();
    while let Some(&c) = it.peek() {
        if c.is_whitespace() {
            it.next();
        } else if "():.,{}".contains(c) {
            out.push(c.to_string());
            it.next();
        } else if c == '`' {
            it.next();
            let mut s = String::new();
            loop {
                match it.next() {
                    Some('`') => break,
                    Some(ch) => s.push(ch),
                    None => return Err(syntax("a backquoted name is not closed")),
                }
            }
            out.push(format!("`{s}"));
        } else if c == '\'' || c == '"' {
            it.next();
            let mut s = String::from("'");
            loop {
                match it.next() {
                    Some(ch) if ch == c => break,
                    Some(ch) => s.push(ch),
                    None => return Err(syntax("a quoted string is not closed")),
                }
            }
            out.push(s);
        } else if c.is_alphanumeric() || c == '_' || c == '-' {
            let mut s = String::new();
            while let Some(&ch) = it.peek() {
                if ch.is_alphanumeric() || ch == '_' || ch == '-' {
                    s.push(ch);
                    it.next();
                } else {
                    break;
                }
            }
            out.push(s);
        } else {
            return Err(syntax(format!("unexpected {c:?} in an index command")));
        }
    }
    Ok(out)
}

fn is_kw(t: Option<&String>, kw: &str) -> bool {
    t.is_some_and(|t| !t.starts_with('`') && t.eq_ignore_ascii_case(kw))
}

fn name(t: &str) -> String {
    t.strip_prefix('`').unwrap_or(t).to_string()
}

/// The command `text` is, or None when it is not an index command (then it is a query).
pub(crate) fn parse(text: &str) -> Result<Option<IndexCmd>, QueryError> {
    let head: Vec<String> = text
        .split_whitespace()
        .take(2)
        .map(|w| w.to_ascii_uppercase())
        .collect();
    let kind = match (
        head.first().map(String::as_str),
        head.get(1).map(String::as_str),
    ) {
        (Some("CREATE"), Some("INDEX")) => 0,
        (Some("CREATE"), Some("VECTOR")) => 3,
        (Some("DROP"), Some("INDEX")) => 1,
        (Some("SHOW"), Some(w)) if w.starts_with("INDEX") => 2,
        _ => return Ok(None),
    };
    let t = tokens(text)?;
    let vector = kind == 3;
    if vector && !is_kw(t.get(2), "INDEX") {
        return Err(syntax("expected CREATE VECTOR INDEX"));
    }
    let kind = if vector { 0 } else { kind };
    let mut i = if vector { 3 } else { 2 };
    let at = |i: usize| t.get(i);
    // `ON :Label(key)`, after CREATE INDEX or DROP INDEX
    let on_label_key = |i: &mut usize| -> Result<(String, String), QueryError> {
        let bad = || syntax("expected ON :Label(key)");
        if !is_kw(at(*i), "ON") || at(*i + 1).map(String::as_str) != Some(":") {
            return Err(bad());
        }
        let label = at(*i + 2).ok_or_else(bad)?;
        if at(*i + 3).map(String::as_str) != Some("(")
            || at(*i + 5).map(String::as_str) != Some(")")
        {
            return Err(bad());
        }
        let key = at(*i + 4).ok_or_else(bad)?;
        *i += 6;
        Ok((name(label), name(key)))
    };
    let cmd = match kind {
        0 => {
            let mut nm = None;
            if !is_kw(at(i), "FOR") && !is_kw(at(i), "ON") && !is_kw(at(i), "IF") {
                nm = at(i).map(|s| name(s));
                i += 1;
            }
            let mut if_not_exists = false;
            if is_kw(at(i), "IF") {
                if !(is_kw(at(i + 1), "NOT") && is_kw(at(i + 2), "EXISTS")) {
                    return Err(syntax("expected IF NOT EXISTS"));
                }
                if_not_exists = true;
                i += 3;
            }
            let (label, key) = if is_kw(at(i), "ON") {
                on_label_key(&mut i)?
            } else {
                // FOR (n:Label) ON (n.key)
                let bad = || syntax("expected FOR (n:Label) ON (n.key)");
                let want = |i: usize, s: &str| at(i).map(String::as_str) == Some(s);
                if !(is_kw(at(i), "FOR")
                    && want(i + 1, "(")
                    && want(i + 3, ":")
                    && want(i + 5, ")"))
                {
                    return Err(bad());
                }
                let var = at(i + 2).ok_or_else(bad)?.clone();
                let label = name(at(i + 4).ok_or_else(bad)?);
                i += 6;
                // a vector index may name its property without parentheses: ON n.key
                if vector && is_kw(at(i), "ON") && !want(i + 1, "(") && want(i + 2, ".") {
                    i -= 1;
                    if at(i + 2) != Some(&var) {
                        return Err(bad());
                    }
                    let key = name(at(i + 4).ok_or_else(bad)?);
                    i += 5;
                    (label, key)
                } else {
                    if !(is_kw(at(i), "ON")
                        && want(i + 1, "(")
                        && want(i + 3, ".")
                        && want(i + 5, ")"))
                    {
                        return Err(bad());
                    }
                    if at(i + 2) != Some(&var) {
                        return Err(syntax(format!(
                            "ON ({}.key) must use the variable of FOR ({var}:{label})",
                            at(i + 2).map(|s| name(s)).unwrap_or_default()
                        )));
                    }
                    let key = name(at(i + 4).ok_or_else(bad)?);
                    i += 6;
                    (label, key)
                }
            };
            if vector {
                let opts = if is_kw(at(i), "OPTIONS") {
                    i += 1;
                    Some(options_map(&t, &mut i)?)
                } else {
                    None
                };
                let (dim, int8) = vector_options(opts)?;
                IndexCmd::CreateVector {
                    name: nm,
                    label,
                    key,
                    dim,
                    int8,
                    if_not_exists,
                }
            } else {
                IndexCmd::Create {
                    name: nm,
                    label,
                    key,
                    if_not_exists,
                }
            }
        }
        1 => {
            if is_kw(at(i), "ON") {
                let on = on_label_key(&mut i)?;
                IndexCmd::Drop {
                    name: None,
                    on: Some(on),
                    if_exists: false,
                }
            } else {
                let nm = at(i)
                    .map(|s| name(s))
                    .ok_or_else(|| syntax("expected DROP INDEX name"))?;
                i += 1;
                let mut if_exists = false;
                if is_kw(at(i), "IF") {
                    if !is_kw(at(i + 1), "EXISTS") {
                        return Err(syntax("expected IF EXISTS"));
                    }
                    if_exists = true;
                    i += 2;
                }
                IndexCmd::Drop {
                    name: Some(nm),
                    on: None,
                    if_exists,
                }
            }
        }
        _ => {
            // SHOW INDEX / SHOW INDEXES
            IndexCmd::Show
        }
    };
    if let Some(extra) = at(i) {
        return Err(syntax(format!(
            "unexpected {:?} after the index command",
            name(extra)
        )));
    }
    Ok(Some(cmd))
}

/// The name of a property index.
pub(crate) fn index_name(spec: &PropertyIndexSpec) -> String {
    spec.name
        .clone()
        .unwrap_or_else(|| format!("{}_{}", spec.label, spec.key).to_lowercase())
}

/// The rows of SHOW INDEXES: name, type, entity, labelsOrTypes, properties, owner.
pub(crate) fn show(schema: &crate::Schema) -> (Vec<String>, Vec<Vec<Val>>) {
    let cols = [
        "name",
        "type",
        "labelsOrTypes",
        "properties",
        "owningConstraint",
    ]
    .map(String::from)
    .to_vec();
    let s = |x: &str| Val::Str(x.into());
    let list = |x: &str| Val::List(vec![s(x)]);
    let mut rows = Vec::new();
    for p in &schema.property_indexes {
        rows.push(vec![
            s(&index_name(p)),
            s("RANGE"),
            list(&p.label),
            list(&p.key),
            Val::Null,
        ]);
    }
    for (label, rule) in &schema.labels {
        for key in &rule.unique {
            rows.push(vec![
                s(&format!("{label}_{key}_unique").to_lowercase()),
                s("RANGE"),
                list(label),
                list(key),
                s("UNIQUE"),
            ]);
        }
    }
    for x in &schema.spatial_indexes {
        rows.push(vec![
            s(&x.name),
            s("POINT"),
            list(&x.label),
            Val::List(
                std::iter::once(&x.position_key)
                    .chain(x.box_key.as_ref())
                    .map(|k| s(k))
                    .collect(),
            ),
            Val::Null,
        ]);
    }
    for x in &schema.vector_indexes {
        rows.push(vec![
            s(&x.name),
            s("VECTOR"),
            list(&x.label),
            list(&x.key),
            Val::Null,
        ]);
    }
    for x in &schema.text_indexes {
        rows.push(vec![
            s(&x.name),
            s("FULLTEXT"),
            list(&x.label),
            list(&x.key),
            Val::Null,
        ]);
    }
    rows.sort_by(|a, b| format!("{:?}", a[0]).cmp(&format!("{:?}", b[0])));
    (cols, rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_index_commands_parse() {
        assert_eq!(
            parse("CREATE INDEX seg_name IF NOT EXISTS FOR (s:Segment) ON (s.name)").unwrap(),
            Some(IndexCmd::Create {
                name: Some("seg_name".into()),
                label: "Segment".into(),
                key: "name".into(),
                if_not_exists: true
            })
        );
        assert_eq!(
            parse("create index on :`My Label`(k);").unwrap(),
            Some(IndexCmd::Create {
                name: None,
                label: "My Label".into(),
                key: "k".into(),
                if_not_exists: false
            })
        );
        assert_eq!(
            parse("DROP INDEX seg_name IF EXISTS").unwrap(),
            Some(IndexCmd::Drop {
                name: Some("seg_name".into()),
                on: None,
                if_exists: true
            })
        );
        assert_eq!(parse("SHOW INDEXES").unwrap(), Some(IndexCmd::Show));
        assert_eq!(parse("MATCH (n) RETURN n").unwrap(), None);
        assert!(parse("CREATE INDEX FOR (s:Segment) ON (t.name)").is_err());
        assert!(parse("CREATE INDEX FOR (s:Segment) ON (s.name) extra").is_err());
    }

    #[test]
    fn the_vector_index_command_parses_in_neo4j_syntax() {
        let want = |name: Option<&str>, dim, int8, if_not_exists| {
            Some(IndexCmd::CreateVector {
                name: name.map(String::from),
                label: "Instance".into(),
                key: "feature".into(),
                dim,
                int8,
                if_not_exists,
            })
        };
        assert_eq!(
            parse(
                "CREATE VECTOR INDEX feat IF NOT EXISTS FOR (n:Instance) ON n.feature OPTIONS \
                 {indexConfig: {`vector.dimensions`: 384, `vector.similarity_function`: 'COSINE'}}"
            )
            .unwrap(),
            want(Some("feat"), 384, true, true)
        );
        assert_eq!(
            parse(
                "create vector index for (n:Instance) on (n.feature) options {indexProvider: \
                 'vector-2.0', indexConfig: {`vector.dimensions`: 8, \
                 `vector.quantization.enabled`: false}};"
            )
            .unwrap(),
            want(None, 8, false, false)
        );
        for (bad, says) in [
            ("CREATE VECTOR INDEX v FOR (n:I) ON n.f", "needs OPTIONS"),
            (
                "CREATE VECTOR INDEX v FOR (n:I) ON n.f OPTIONS {indexConfig: {}}",
                "needs OPTIONS",
            ),
            (
                "CREATE VECTOR INDEX v FOR (n:I) ON n.f OPTIONS {indexConfig: {`vector.dimensions`: 0}}",
                "vector.dimensions",
            ),
            (
                "CREATE VECTOR INDEX v FOR (n:I) ON n.f OPTIONS {indexConfig: {`vector.dimensions`: 3, `vector.similarity_function`: 'euclidean'}}",
                "only 'cosine'",
            ),
            (
                "CREATE VECTOR INDEX v FOR (n:I) ON m.f OPTIONS {}",
                "expected FOR",
            ),
            (
                "CREATE VECTOR INDEX v FOR (n:I) ON n.f OPTIONS {indexConfig: 'x",
                "not closed",
            ),
            ("CREATE VECTOR v", "CREATE VECTOR INDEX"),
            (
                "CREATE VECTOR INDEX v FOR (n:I) ON n.f OPTIONS {a: 1}",
                "unsupported",
            ),
        ] {
            let e = parse(bad).expect_err(bad).to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }
}
