//! Compile-time checks: variable scope, kinds, functions, aggregation and clause order.

use std::collections::BTreeMap;

use super::ast::*;
use super::eval::FUNCTIONS;
use super::{ErrorKind, Pos, QueryError, R};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Node,
    Rel,
    Path,
    /// A value that is certainly not a graph element (a literal, list or map).
    Value,
    Any,
}

type Scope = BTreeMap<String, Kind>;

fn syn(code: &'static str, msg: impl Into<String>, pos: Option<Pos>) -> QueryError {
    QueryError::new(ErrorKind::Syntax, code, msg, pos)
}

/// Checks a parsed statement before it runs.
pub(crate) fn check(stmt: &Statement) -> R<()> {
    if stmt.union_all.iter().any(|a| *a) && stmt.union_all.iter().any(|a| !*a) {
        return Err(syn(
            "InvalidClauseComposition",
            "UNION and UNION ALL cannot be mixed",
            None,
        ));
    }
    let mut first: Option<Vec<String>> = None;
    for part in &stmt.parts {
        let cols = check_single(part, stmt.parts.len() > 1)?;
        match &first {
            None => first = Some(cols),
            Some(c) if *c != cols => {
                return Err(syn(
                    "DifferentColumnsInUnion",
                    format!(
                        "all parts of a UNION must return the same columns ({} vs {})",
                        c.join(", "),
                        cols.join(", ")
                    ),
                    part.positions.first().copied(),
                ));
            }
            _ => {}
        }
    }
    Ok(())
}

fn check_single(q: &SingleQuery, in_union: bool) -> R<Vec<String>> {
    let mut scope: Scope = BTreeMap::new();
    let n = q.clauses.len();
    let mut columns = Vec::new();
    for (i, c) in q.clauses.iter().enumerate() {
        let pos = q.positions.get(i).copied();
        let last = i + 1 == n;
        match c {
            Clause::Match {
                patterns, where_, ..
            } => {
                for p in patterns {
                    declare_pattern(p, &mut scope, false)?;
                }
                for p in patterns {
                    pattern_exprs(p, &scope)?;
                }
                if let Some(w) = where_ {
                    predicate(w, &scope)?;
                }
            }
            Clause::Unwind { expr: e, var } => {
                expr(e, &scope, false)?;
                bind_new(&mut scope, var, pos)?;
            }
            Clause::With(p) | Clause::Return(p) => {
                let is_return = matches!(c, Clause::Return(_));
                if is_return && !last {
                    return Err(syn(
                        "InvalidClauseComposition",
                        "RETURN must be the last clause",
                        pos,
                    ));
                }
                if is_return && p.star && scope.is_empty() {
                    return Err(syn(
                        "NoVariablesInScope",
                        "RETURN * / WITH * with no variables in scope",
                        pos,
                    ));
                }
                let mut next: Scope = if p.star {
                    scope.clone()
                } else {
                    BTreeMap::new()
                };
                let mut names: Vec<&str> = Vec::new();
                let agg = p.items.iter().any(|it| it.expr.has_aggregate());
                for it in &p.items {
                    expr(&it.expr, &scope, true)?;
                    if !is_return && !it.aliased && !matches!(it.expr, Expr::Var(..)) {
                        return Err(syn(
                            "NoExpressionAlias",
                            format!("expression `{}` in WITH needs an alias (AS name)", it.text),
                            Some(it.pos),
                        ));
                    }
                    if names.contains(&it.name.as_str()) {
                        return Err(syn(
                            "ColumnNameConflict",
                            format!("column `{}` appears twice", it.name),
                            Some(it.pos),
                        ));
                    }
                    names.push(&it.name);
                    let kind = match &it.expr {
                        Expr::Var(v, _) => scope.get(v).copied().unwrap_or(Kind::Any),
                        Expr::Lit(super::value::Val::Null) => Kind::Any,
                        Expr::Lit(_) | Expr::Map(_) => Kind::Value,
                        _ => Kind::Any,
                    };
                    next.insert(it.name.clone(), kind);
                }
                let mut order_scope = next.clone();
                if !p.distinct && !agg {
                    for (k, v) in &scope {
                        order_scope.entry(k.clone()).or_insert(*v);
                    }
                }
                for (e, _, text) in &p.order {
                    if p.items.iter().any(|i| &i.text == text) {
                        continue;
                    }
                    let e = if agg {
                        subst_keys(e, &p.items)
                    } else {
                        e.clone()
                    };
                    check_expr(
                        &e,
                        &order_scope,
                        Cx {
                            agg_ok: agg,
                            agg_scope: Some(&scope),
                            ..Cx::plain()
                        },
                    )?;
                }
                if agg {
                    let keys: Vec<String> = p
                        .items
                        .iter()
                        .filter(|i| !i.expr.has_aggregate())
                        .map(|i| super::plan::show(&i.expr))
                        .collect();
                    for it in p.items.iter().filter(|i| i.expr.has_aggregate()) {
                        if ambiguous(&it.expr, &keys) {
                            return Err(syn(
                                "AmbiguousAggregationExpression",
                                format!(
                                    "`{}` mixes an aggregate with variables that are not grouping keys",
                                    it.text
                                ),
                                Some(it.pos),
                            ));
                        }
                    }
                }
                for (what, e) in [("SKIP", &p.skip), ("LIMIT", &p.limit)] {
                    if let Some(e) = e {
                        count_literal(what, e)?;
                    }
                }
                if let Some(w) = &p.where_ {
                    let mut both = next.clone();
                    if !agg {
                        for (k, v) in &scope {
                            both.entry(k.clone()).or_insert(*v);
                        }
                    }
                    predicate(w, &both)?;
                }
                if is_return {
                    columns = p.items.iter().map(|i| i.name.clone()).collect();
                    if p.star {
                        let mut vars: Vec<String> = scope.keys().cloned().collect();
                        vars.extend(columns);
                        columns = vars;
                    }
                }
                scope = next;
            }
            Clause::Create(patterns) => {
                for p in patterns {
                    no_shortest(p, "CREATE")?;
                    declare_pattern(p, &mut scope, true)?;
                    pattern_exprs(p, &scope)?;
                }
            }
            Clause::Merge {
                pattern,
                on_create,
                on_match,
            } => {
                no_shortest(pattern, "MERGE")?;
                declare_pattern_in(pattern, &mut scope, true, true)?;
                pattern_exprs(pattern, &scope)?;
                for it in on_create.iter().chain(on_match) {
                    set_item(it, &scope)?;
                }
            }
            Clause::Set(items) => {
                for it in items {
                    set_item(it, &scope)?;
                }
            }
            Clause::Remove(items) => {
                for it in items {
                    match it {
                        RemoveItem::Prop { target, .. } => expr(target, &scope, false)?,
                        RemoveItem::Labels { var, pos, .. } => need(var, &scope, *pos)?,
                    }
                }
            }
            Clause::Delete { exprs, .. } => {
                for e in exprs {
                    expr(e, &scope, false)?;
                    if matches!(
                        e,
                        Expr::Lit(_) | Expr::Bin(..) | Expr::Map(_) | Expr::HasLabels(..)
                    ) {
                        return Err(syn(
                            "InvalidArgumentType",
                            "DELETE takes nodes, relationships or paths",
                            pos,
                        ));
                    }
                }
            }
            Clause::Call {
                args,
                yields,
                where_,
                ..
            } => {
                for a in args {
                    expr(a, &scope, false)?;
                }
                if let Some(ys) = yields {
                    for (_, alias) in ys {
                        if alias == "*" {
                            continue;
                        }
                        bind_new(&mut scope, alias, pos)?;
                    }
                }
                if let Some(w) = where_ {
                    predicate(w, &scope)?;
                }
            }
        }
        if last {
            let ok = matches!(c, Clause::Return(_) | Clause::Call { .. }) || c.is_write();
            if !ok {
                let name = match c {
                    Clause::Match { optional: true, .. } => "OPTIONAL MATCH",
                    Clause::Match { .. } => "MATCH",
                    Clause::With(_) => "WITH",
                    _ => "UNWIND",
                };
                return Err(syn(
                    "InvalidClauseComposition",
                    format!("a query cannot end with {name}; add RETURN"),
                    pos,
                ));
            }
            if in_union && !matches!(c, Clause::Return(_)) {
                return Err(syn(
                    "InvalidClauseComposition",
                    "every part of a UNION must end with RETURN",
                    pos,
                ));
            }
        }
    }
    Ok(columns)
}

/// Declares a variable that must not exist yet (UNWIND ... AS x, YIELD x).
fn bind_new(scope: &mut Scope, var: &str, pos: Option<Pos>) -> R<()> {
    if scope.contains_key(var) {
        return Err(syn(
            "VariableAlreadyBound",
            format!("variable `{var}` is already defined"),
            pos,
        ));
    }
    scope.insert(var.to_string(), Kind::Any);
    Ok(())
}

fn count_literal(what: &str, e: &Expr) -> R<()> {
    let mut has_var = false;
    e.walk(&mut |x| {
        if matches!(
            x,
            Expr::Var(..) | Expr::Pattern(_) | Expr::PatternComp { .. } | Expr::Subquery { .. }
        ) {
            has_var = true;
        }
    });
    if has_var {
        return Err(syn(
            "NonConstantExpression",
            format!("{what} must be a constant expression"),
            None,
        ));
    }
    match e {
        Expr::Lit(super::value::Val::Int(i)) if *i < 0 => Err(syn(
            "NegativeIntegerArgument",
            format!("{what} must not be negative"),
            None,
        )),
        Expr::Lit(super::value::Val::Float(_)) => Err(syn(
            "InvalidArgumentType",
            format!("{what} takes an integer"),
            None,
        )),
        _ => Ok(()),
    }
}

/// A literal operand of a boolean operator that cannot be a boolean is a compile-time error.
fn not_boolean(e: &Expr) -> R<()> {
    let bad = match e {
        Expr::Lit(super::value::Val::Bool(_) | super::value::Val::Null) => false,
        Expr::Lit(_) | Expr::List(_) | Expr::Map(_) => true,
        _ => false,
    };
    if bad {
        return Err(syn(
            "InvalidArgumentType",
            "a boolean operator needs boolean operands",
            None,
        ));
    }
    Ok(())
}

fn need(var: &str, scope: &Scope, pos: Pos) -> R<()> {
    if scope.contains_key(var) {
        Ok(())
    } else {
        Err(QueryError::new(
            ErrorKind::Syntax,
            "UndefinedVariable",
            format!("variable `{var}` is not defined"),
            Some(pos),
        ))
    }
}

fn set_item(it: &SetItem, scope: &Scope) -> R<()> {
    match it {
        SetItem::Prop { target, value, .. } => {
            expr(target, scope, false)?;
            expr(value, scope, false)
        }
        SetItem::Replace { var, value, pos } | SetItem::Merge { var, value, pos } => {
            need(var, scope, *pos)?;
            expr(value, scope, false)
        }
        SetItem::Labels { var, pos, .. } => need(var, scope, *pos),
    }
}

fn declare(scope: &mut Scope, var: &str, kind: Kind, pos: Pos) -> R<()> {
    match scope.get(var) {
        Some(k) if *k != kind && *k != Kind::Any => Err(syn(
            "VariableTypeConflict",
            format!("`{var}` is a {k:?} and cannot be used as a {kind:?}"),
            Some(pos),
        )),
        _ => {
            scope.entry(var.to_string()).or_insert(kind);
            Ok(())
        }
    }
}

fn declare_pattern(p: &PathPattern, scope: &mut Scope, creating: bool) -> R<()> {
    declare_pattern_in(p, scope, creating, false)
}

fn declare_pattern_in(p: &PathPattern, scope: &mut Scope, creating: bool, merging: bool) -> R<()> {
    let before = scope.clone();
    if creating
        && p.steps.is_empty()
        && let Some(v) = &p.start.var
        && before.contains_key(v)
    {
        return Err(syn(
            "VariableAlreadyBound",
            format!("`{v}` is already bound; there is nothing to create"),
            Some(p.start.pos),
        ));
    }
    if !creating || merging {
        let params = std::iter::once(&p.start.props)
            .chain(p.steps.iter().flat_map(|(r, n)| [&r.props, &n.props]))
            .any(|x| matches!(x, Some(Expr::Param(..))));
        if params {
            return Err(syn(
                "InvalidParameterUse",
                "a parameter cannot stand for a property map in MATCH or MERGE; write {key: $value}",
                Some(p.pos),
            ));
        }
    }
    if let Some(pv) = &p.var
        && p.vars().iter().skip(1).any(|(v, _, _)| v == pv)
    {
        return Err(syn(
            "VariableAlreadyBound",
            format!("`{pv}` names both the path and an element of it"),
            Some(p.pos),
        ));
    }
    if let Some(v) = &p.var
        && scope.contains_key(v)
    {
        return Err(syn(
            "VariableAlreadyBound",
            format!("path variable `{v}` is already defined"),
            Some(p.pos),
        ));
    }
    let mut seen_rels: Vec<&str> = Vec::new();
    let node = |np: &NodePat, scope: &mut Scope| -> R<()> {
        if let Some(v) = &np.var {
            if creating && before.contains_key(v) && (!np.labels.is_empty() || np.props.is_some()) {
                return Err(syn(
                    "VariableAlreadyBound",
                    format!(
                        "`{v}` is already bound; it cannot be re-created with labels or properties"
                    ),
                    Some(np.pos),
                ));
            }
            declare(scope, v, Kind::Node, np.pos)?;
        }
        Ok(())
    };
    node(&p.start, scope)?;
    for (rp, np) in &p.steps {
        if creating {
            if rp.types.len() != 1 {
                return Err(syn(
                    "NoSingleRelationshipType",
                    "a created relationship needs exactly one type",
                    Some(rp.pos),
                ));
            }
            if rp.dir == Dir::Both && !merging {
                return Err(syn(
                    "RequiresDirectedRelationship",
                    "a created relationship needs a direction",
                    Some(rp.pos),
                ));
            }
            if rp.range.is_some() {
                return Err(syn(
                    "CreatingVarLength",
                    "variable-length relationships cannot be created",
                    Some(rp.pos),
                ));
            }
        }
        if let Some(v) = &rp.var {
            if creating && before.contains_key(v) {
                return Err(syn(
                    "VariableAlreadyBound",
                    format!("relationship `{v}` is already bound"),
                    Some(rp.pos),
                ));
            }
            if seen_rels.contains(&v.as_str()) {
                return Err(syn(
                    "RelationshipUniquenessViolation",
                    format!("relationship `{v}` appears twice in one pattern"),
                    Some(rp.pos),
                ));
            }
            seen_rels.push(v);
            let kind = if rp.range.is_some() {
                Kind::Any
            } else {
                Kind::Rel
            };
            if rp.range.is_some() {
                if let Some(k) = scope.get(v.as_str())
                    && *k != Kind::Any
                {
                    return Err(syn(
                        "VariableTypeConflict",
                        format!("`{v}` is a {k:?}, not a list of relationships"),
                        Some(rp.pos),
                    ));
                }
                scope.entry(v.clone()).or_insert(kind);
            } else {
                match scope.get(v.as_str()) {
                    Some(Kind::Rel) | None => {
                        scope.insert(v.clone(), Kind::Rel);
                    }
                    Some(Kind::Any) => {}
                    Some(k) => {
                        return Err(syn(
                            "VariableTypeConflict",
                            format!("`{v}` is a {k:?}, not a relationship"),
                            Some(rp.pos),
                        ));
                    }
                }
            }
        }
        node(np, scope)?;
    }
    if let Some(v) = &p.var {
        scope.insert(v.clone(), Kind::Path);
    }
    Ok(())
}

fn pattern_exprs(p: &PathPattern, scope: &Scope) -> R<()> {
    let mut res = Ok(());
    p.walk_exprs(&mut |e| {
        if res.is_ok() {
            res = check_expr(e, scope, Cx::plain());
        }
    });
    res
}

/// What an expression may contain where it is checked.
#[derive(Clone, Copy)]
struct Cx<'a> {
    /// Aggregates allowed (WITH / RETURN items and ORDER BY of an aggregating projection).
    agg_ok: bool,
    /// Inside an aggregate's arguments.
    in_agg: bool,
    /// Pattern predicates allowed (WHERE).
    pattern_ok: bool,
    /// Scope for variables inside aggregate arguments, when wider than `scope`.
    agg_scope: Option<&'a Scope>,
}

impl Cx<'_> {
    fn plain() -> Self {
        Cx {
            agg_ok: false,
            in_agg: false,
            pattern_ok: false,
            agg_scope: None,
        }
    }
}

/// Checks variables, functions and aggregates in an expression.
fn expr(e: &Expr, scope: &Scope, agg_ok: bool) -> R<()> {
    check_expr(
        e,
        scope,
        Cx {
            agg_ok,
            ..Cx::plain()
        },
    )
}

/// A predicate (WHERE): pattern predicates allowed.
fn predicate(e: &Expr, scope: &Scope) -> R<()> {
    check_expr(
        e,
        scope,
        Cx {
            pattern_ok: true,
            ..Cx::plain()
        },
    )
}

/// What is statically known about an expression's value.
fn static_kind(e: &Expr, scope: &Scope) -> Option<Kind> {
    match e {
        Expr::Var(v, _) => scope.get(v).copied(),
        Expr::Lit(super::value::Val::Null) => None,
        Expr::Lit(_) | Expr::Map(_) => Some(Kind::Value),
        _ => None,
    }
}

fn bad_arg(what: &str) -> QueryError {
    syn("InvalidArgumentType", what.to_string(), None)
}

fn check_expr(e: &Expr, scope: &Scope, cx: Cx<'_>) -> R<()> {
    let rec = |x: &Expr| check_expr(x, scope, cx);
    match e {
        Expr::Var(v, pos) => need(v, scope, *pos),
        Expr::CountStar => {
            if !cx.agg_ok {
                return Err(syn(
                    "InvalidAggregation",
                    "count(*) is only allowed in WITH and RETURN",
                    None,
                ));
            }
            Ok(())
        }
        Expr::Func {
            name, args, pos, ..
        } => {
            let lower = name.to_ascii_lowercase();
            let is_agg = AGGREGATES.contains(&lower.as_str());
            if is_agg {
                if !cx.agg_ok {
                    return Err(syn(
                        "InvalidAggregation",
                        format!("aggregate {name}() is only allowed in WITH and RETURN"),
                        Some(*pos),
                    ));
                }
                if cx.in_agg {
                    return Err(syn(
                        "NestedAggregation",
                        format!("aggregate {name}() inside another aggregate"),
                        Some(*pos),
                    ));
                }
                let inner = Cx { in_agg: true, ..cx };
                let sc = cx.agg_scope.unwrap_or(scope);
                for a in args {
                    check_expr(a, sc, inner)?;
                }
                return Ok(());
            }
            if !FUNCTIONS.contains(&lower.as_str()) {
                return Err(syn(
                    "UnknownFunction",
                    format!("unknown function {name}()"),
                    Some(*pos),
                ));
            }
            // arguments whose type is known to be wrong before running
            if let [a] = args.as_slice() {
                let k = static_kind(a, scope);
                let is_pattern = matches!(a, Expr::Pattern(_));
                let wrong = match lower.as_str() {
                    "labels" => matches!(k, Some(Kind::Path | Kind::Rel | Kind::Value)),
                    "type" => matches!(k, Some(Kind::Node | Kind::Path | Kind::Value)),
                    "length" => matches!(k, Some(Kind::Node | Kind::Rel | Kind::Value)),
                    "size" => matches!(k, Some(Kind::Path | Kind::Node | Kind::Rel)) || is_pattern,
                    "properties" => {
                        matches!(k, Some(Kind::Path))
                            || matches!(a, Expr::Lit(v) if !v.is_null())
                            || matches!(a, Expr::List(_))
                    }
                    "nodes" | "relationships" => {
                        matches!(k, Some(Kind::Node | Kind::Rel | Kind::Value))
                    }
                    _ => false,
                };
                if wrong {
                    return Err(bad_arg(&format!("{name}() cannot take this argument")));
                }
            }
            if lower == "exists" {
                let inner = Cx {
                    pattern_ok: true,
                    ..cx
                };
                return args.iter().try_for_each(|a| check_expr(a, scope, inner));
            }
            args.iter().try_for_each(rec)
        }
        Expr::ListComp {
            var,
            list,
            filter,
            map,
        } => {
            rec(list)?;
            let mut inner = scope.clone();
            inner.insert(var.clone(), Kind::Any);
            let cx2 = Cx {
                agg_ok: false,
                ..cx
            };
            if let Some(f) = filter {
                check_expr(
                    f,
                    &inner,
                    Cx {
                        pattern_ok: true,
                        ..cx2
                    },
                )?;
            }
            if let Some(m) = map {
                check_expr(m, &inner, cx2)?;
            }
            Ok(())
        }
        Expr::Quantified {
            var, list, pred, ..
        } => {
            rec(list)?;
            let mut inner = scope.clone();
            inner.insert(var.clone(), Kind::Any);
            check_expr(
                pred,
                &inner,
                Cx {
                    agg_ok: false,
                    pattern_ok: true,
                    ..cx
                },
            )
        }
        Expr::Reduce {
            acc,
            init,
            var,
            list,
            expr: body,
        } => {
            rec(init)?;
            rec(list)?;
            let mut inner = scope.clone();
            inner.insert(acc.clone(), Kind::Any);
            inner.insert(var.clone(), Kind::Any);
            check_expr(
                body,
                &inner,
                Cx {
                    agg_ok: false,
                    ..cx
                },
            )
        }
        Expr::Pattern(p) => {
            if !cx.pattern_ok {
                return Err(syn(
                    "UnexpectedSyntax",
                    "a pattern predicate is only allowed in WHERE or exists()",
                    Some(p.pos),
                ));
            }
            for (v, pos, _) in p.vars() {
                if !scope.contains_key(v) {
                    return Err(syn(
                        "UndefinedVariable",
                        format!(
                            "variable `{v}` is not defined; a pattern predicate cannot introduce variables"
                        ),
                        Some(pos),
                    ));
                }
            }
            pattern_exprs(p, scope)
        }
        Expr::PatternComp {
            pattern,
            filter,
            map,
        } => {
            let mut inner = scope.clone();
            declare_pattern(pattern, &mut inner, false)?;
            pattern_exprs(pattern, &inner)?;
            if let Some(f) = filter {
                check_expr(
                    f,
                    &inner,
                    Cx {
                        agg_ok: false,
                        pattern_ok: true,
                        ..cx
                    },
                )?;
            }
            check_expr(
                map,
                &inner,
                Cx {
                    agg_ok: false,
                    ..cx
                },
            )
        }
        Expr::Subquery {
            patterns, where_, ..
        } => {
            let mut inner = scope.clone();
            for p in patterns {
                declare_pattern(p, &mut inner, false)?;
                pattern_exprs(p, &inner)?;
            }
            match where_ {
                Some(w) => check_expr(
                    w,
                    &inner,
                    Cx {
                        agg_ok: false,
                        pattern_ok: true,
                        ..cx
                    },
                ),
                None => Ok(()),
            }
        }
        Expr::MapProj(base, items) => {
            rec(base)?;
            for it in items {
                match it {
                    MapProjItem::Var(v) if !scope.contains_key(v) => {
                        return Err(syn(
                            "UndefinedVariable",
                            format!("variable `{v}` is not defined"),
                            None,
                        ));
                    }
                    MapProjItem::Lit(_, x) => rec(x)?,
                    _ => {}
                }
            }
            Ok(())
        }
        Expr::Lit(_) | Expr::Param(..) | Expr::AggRef(_) => Ok(()),
        Expr::Not(x) => {
            not_boolean(x)?;
            rec(x)
        }
        Expr::Bin(..) => {
            // walk the left spine in a loop: long chains do not deepen the recursion
            let mut cur = e;
            while let Expr::Bin(op, a, b) = cur {
                match op {
                    BinOp::And | BinOp::Or | BinOp::Xor => {
                        not_boolean(a)?;
                        not_boolean(b)?;
                    }
                    BinOp::In
                        if matches!(b.as_ref(), Expr::Lit(v) if !v.is_null())
                            || matches!(b.as_ref(), Expr::Map(_)) =>
                    {
                        return Err(bad_arg("IN needs a list on its right"));
                    }
                    _ => {}
                }
                rec(b)?;
                cur = a;
            }
            rec(cur)
        }
        Expr::Prop(x, _) => {
            if matches!(static_kind(x, scope), Some(Kind::Path)) {
                return Err(bad_arg("a path has no properties"));
            }
            rec(x)
        }
        Expr::Neg(x) | Expr::IsNull(x, _) | Expr::HasLabels(x, _) => rec(x),
        Expr::Index(a, b) => {
            rec(a)?;
            rec(b)
        }
        Expr::Slice(a, b, c) => {
            rec(a)?;
            if let Some(b) = b {
                rec(b)?;
            }
            if let Some(c) = c {
                rec(c)?;
            }
            Ok(())
        }
        Expr::List(l) | Expr::Chain(l, _) => l.iter().try_for_each(rec),
        Expr::Map(m) => m.iter().try_for_each(|(_, x)| rec(x)),
        Expr::Case {
            subject,
            whens,
            else_,
        } => {
            if let Some(s) = subject {
                rec(s)?;
            }
            for (a, b) in whens {
                rec(a)?;
                rec(b)?;
            }
            if let Some(x) = else_ {
                rec(x)?;
            }
            Ok(())
        }
    }
}

/// Replaces sub-expressions of an ORDER BY key that are grouping keys of an aggregating
/// projection (`me.age` when `me.age AS age` is projected) by the key's column.
pub(crate) fn subst_keys(e: &Expr, items: &[Item]) -> Expr {
    match e {
        Expr::CountStar => e.clone(),
        Expr::Func { name, .. } if AGGREGATES.contains(&name.to_ascii_lowercase().as_str()) => {
            e.clone()
        }
        Expr::Var(..) | Expr::Prop(..) => {
            let shown = super::plan::show(e);
            match items
                .iter()
                .find(|i| !i.expr.has_aggregate() && super::plan::show(&i.expr) == shown)
            {
                Some(i) => Expr::Var(i.name.clone(), Pos { line: 0, col: 0 }),
                None => e.clone(),
            }
        }
        other => other.map_children(&mut |c| subst_keys(c, items)),
    }
}

/// In an aggregating projection, an item mixing an aggregate with other variables may only
/// use those variables through grouping keys.
fn ambiguous(e: &Expr, keys: &[String]) -> bool {
    let with_local = |vars: &[&String]| {
        let mut k = keys.to_vec();
        k.extend(vars.iter().map(|v| v.to_string()));
        k
    };
    match e {
        Expr::ListComp {
            var,
            list,
            filter,
            map,
        } => {
            let k = with_local(&[var]);
            ambiguous(list, keys)
                || filter.as_ref().is_some_and(|f| ambiguous(f, &k))
                || map.as_ref().is_some_and(|m| ambiguous(m, &k))
        }
        Expr::Quantified {
            var, list, pred, ..
        } => ambiguous(list, keys) || ambiguous(pred, &with_local(&[var])),
        Expr::Reduce {
            acc,
            init,
            var,
            list,
            expr,
        } => {
            ambiguous(init, keys)
                || ambiguous(list, keys)
                || ambiguous(expr, &with_local(&[acc, var]))
        }
        Expr::CountStar => false,
        Expr::Func { name, .. } if AGGREGATES.contains(&name.to_ascii_lowercase().as_str()) => {
            false
        }
        Expr::Var(..) | Expr::Prop(..) if keys.contains(&super::plan::show(e)) => false,
        Expr::Var(..) => true,
        other => {
            let mut bad = false;
            other.map_children(&mut |c| {
                bad |= ambiguous(c, keys);
                c.clone()
            });
            bad
        }
    }
}

/// `shortestPath` and `allShortestPaths` find paths; they cannot be created.
fn no_shortest(p: &PathPattern, clause: &str) -> R<()> {
    if p.shortest.is_some() {
        return Err(QueryError::new(
            ErrorKind::Syntax,
            "InvalidShortestPath",
            format!("{clause} cannot take shortestPath or allShortestPaths; use them in MATCH"),
            Some(p.pos),
        ));
    }
    Ok(())
}
