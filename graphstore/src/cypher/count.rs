//! Counts answered from the store's counts instead of a scan: `MATCH (n:Label) RETURN
//! count(*)`, `MATCH (n) RETURN count(n)`, `MATCH ()-[r:TYPE]->() RETURN count(r)` and the
//! like. The store keeps nodes per label, relationships per type and both totals in step with
//! every commit (`og_counts`), so these take one small table read, not one record per node.

use super::ast::*;
use super::value::Val;
use crate::GraphRead;

/// What a count query counts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum StoreCount {
    /// Nodes with this label, or all nodes.
    Nodes(Option<String>),
    /// Relationships of this type, or all relationships.
    Rels(Option<String>),
}

/// The count a query asks for, when the store's counts answer it exactly: one MATCH (not
/// optional, no WHERE) of one pattern — a node with at most one label and no properties, or
/// one directed single-hop relationship with at most one type between two distinct, bare
/// nodes — then `RETURN count(*)` or `count(v)` of a pattern variable, alone, without
/// DISTINCT, ORDER BY, SKIP or LIMIT.
pub(crate) fn store_count(q: &SingleQuery) -> Option<(StoreCount, String)> {
    let [
        Clause::Match {
            optional: false,
            patterns,
            where_: None,
        },
        Clause::Return(ret),
    ] = q.clauses.as_slice()
    else {
        return None;
    };
    let [p] = patterns.as_slice() else {
        return None;
    };
    if p.var.is_some()
        || ret.distinct
        || ret.star
        || !ret.order.is_empty()
        || ret.skip.is_some()
        || ret.limit.is_some()
        || ret.where_.is_some()
    {
        return None;
    }
    let [item] = ret.items.as_slice() else {
        return None;
    };
    let bare = |n: &NodePat| n.props.is_none() && n.labels.is_empty();
    let (what, vars): (StoreCount, Vec<&Option<String>>) = match p.steps.as_slice() {
        [] if p.start.props.is_none() && p.start.labels.len() <= 1 => (
            StoreCount::Nodes(p.start.labels.first().cloned()),
            vec![&p.start.var],
        ),
        [(r, end)]
            if bare(&p.start)
                && bare(end)
                && r.props.is_none()
                && r.range.is_none()
                && r.types.len() <= 1
                && r.dir != Dir::Both
                // (a)-[r]->(a) counts self-loops only
                && (p.start.var.is_none() || p.start.var != end.var) =>
        {
            (
                StoreCount::Rels(r.types.first().cloned()),
                vec![&p.start.var, &r.var, &end.var],
            )
        }
        _ => return None,
    };
    match &item.expr {
        Expr::CountStar => {}
        Expr::Func {
            name,
            distinct: false,
            args,
            ..
        } if name.eq_ignore_ascii_case("count") => {
            let [Expr::Var(v, _)] = args.as_slice() else {
                return None;
            };
            // a node of a relationship pattern is counted once per relationship only with
            // count(*); count(n) of an end counts the same, but keep to the plain cases
            let counted = match &what {
                StoreCount::Nodes(_) => vars[0],
                StoreCount::Rels(_) => vars[1],
            };
            if counted.as_deref() != Some(v.as_str()) {
                return None;
            }
        }
        _ => return None,
    }
    Some((what, item.name.clone()))
}

/// The count from the store's counts.
pub(crate) fn read_count(g: &dyn GraphRead, what: &StoreCount) -> crate::Result<Val> {
    let c = g.counts()?;
    let n = match what {
        StoreCount::Nodes(None) => c.total_nodes,
        StoreCount::Nodes(Some(l)) => c.nodes.get(l).copied().unwrap_or(0),
        StoreCount::Rels(None) => c.total_relationships,
        StoreCount::Rels(Some(t)) => c.relationships.get(t).copied().unwrap_or(0),
    };
    Ok(Val::Int(i64::try_from(n).unwrap_or(i64::MAX)))
}
