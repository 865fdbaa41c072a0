//! The syntax tree of a Cypher statement.

use super::Pos;
use super::value::Val;

/// A whole statement: one or more single queries joined by UNION.
#[derive(Debug, Clone)]
pub(crate) struct Statement {
    pub explain: bool,
    /// `PROFILE`: run, and report rows and time per clause.
    pub profile: bool,
    pub parts: Vec<SingleQuery>,
    /// For each join between parts: true for `UNION ALL`.
    pub union_all: Vec<bool>,
}

#[derive(Debug, Clone)]
pub(crate) struct SingleQuery {
    pub clauses: Vec<Clause>,
    /// Where each clause starts.
    pub positions: Vec<Pos>,
}

#[derive(Debug, Clone)]
pub(crate) enum Clause {
    Match {
        optional: bool,
        patterns: Vec<PathPattern>,
        where_: Option<Expr>,
    },
    Unwind {
        expr: Expr,
        var: String,
    },
    With(Projection),
    Return(Projection),
    Create(Vec<PathPattern>),
    Merge {
        pattern: PathPattern,
        on_create: Vec<SetItem>,
        on_match: Vec<SetItem>,
    },
    Set(Vec<SetItem>),
    Remove(Vec<RemoveItem>),
    Delete {
        detach: bool,
        exprs: Vec<Expr>,
    },
    Call {
        name: String,
        args: Vec<Expr>,
        /// `(name, alias)`; None when there is no YIELD.
        yields: Option<Vec<(String, String)>>,
        where_: Option<Expr>,
        pos: Pos,
    },
}

impl Clause {
    /// The clause's name as a profile prints it.
    pub fn name(&self) -> &'static str {
        match self {
            Clause::Match { optional: true, .. } => "OptionalMatch",
            Clause::Match { .. } => "Match",
            Clause::Unwind { .. } => "Unwind",
            Clause::With(_) => "With",
            Clause::Return(_) => "Return",
            Clause::Create(_) => "Create",
            Clause::Merge { .. } => "Merge",
            Clause::Set(_) => "Set",
            Clause::Remove(_) => "Remove",
            Clause::Delete { .. } => "Delete",
            Clause::Call { .. } => "ProcedureCall",
        }
    }

    pub fn is_write(&self) -> bool {
        matches!(
            self,
            Clause::Create(_)
                | Clause::Merge { .. }
                | Clause::Set(_)
                | Clause::Remove(_)
                | Clause::Delete { .. }
        )
    }
}

#[derive(Debug, Clone)]
pub(crate) struct Projection {
    pub distinct: bool,
    pub star: bool,
    pub items: Vec<Item>,
    /// `(expression, ascending, source text)`
    pub order: Vec<(Expr, bool, String)>,
    pub skip: Option<Expr>,
    pub limit: Option<Expr>,
    pub where_: Option<Expr>,
    pub pos: Pos,
}

#[derive(Debug, Clone)]
pub(crate) struct Item {
    pub expr: Expr,
    /// The expression's source text.
    pub text: String,
    /// The column name: the alias, or the source text.
    pub name: String,
    pub aliased: bool,
    pub pos: Pos,
}

#[derive(Debug, Clone)]
pub(crate) enum SetItem {
    Prop {
        target: Expr,
        key: String,
        value: Expr,
    },
    Replace {
        var: String,
        value: Expr,
        pos: Pos,
    },
    Merge {
        var: String,
        value: Expr,
        pos: Pos,
    },
    Labels {
        var: String,
        labels: Vec<String>,
        pos: Pos,
    },
}

#[derive(Debug, Clone)]
pub(crate) enum RemoveItem {
    Prop {
        target: Expr,
        key: String,
    },
    Labels {
        var: String,
        labels: Vec<String>,
        pos: Pos,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PathPattern {
    pub var: Option<String>,
    pub start: NodePat,
    pub steps: Vec<(RelPat, NodePat)>,
    /// `shortestPath(...)` or `allShortestPaths(...)` around the pattern (MATCH only).
    pub shortest: Option<Shortest>,
    pub pos: Pos,
}

/// Which shortest paths a `shortestPath` / `allShortestPaths` pattern matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Shortest {
    /// `shortestPath`: one shortest path per pair of ends.
    One,
    /// `allShortestPaths`: every path of the shortest length.
    All,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NodePat {
    pub var: Option<String>,
    pub labels: Vec<String>,
    pub props: Option<Expr>,
    pub pos: Pos,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Dir {
    Out,
    In,
    Both,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RelPat {
    pub var: Option<String>,
    pub types: Vec<String>,
    pub dir: Dir,
    pub props: Option<Expr>,
    /// `*min..max`; None for a single hop.
    pub range: Option<(Option<u64>, Option<u64>)>,
    pub pos: Pos,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BinOp {
    Or,
    Xor,
    And,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    Pow,
    In,
    StartsWith,
    EndsWith,
    Contains,
    Regex,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Quant {
    All,
    Any,
    None,
    Single,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Expr {
    Lit(Val),
    Param(String, Pos),
    Var(String, Pos),
    Prop(Box<Expr>, String),
    Index(Box<Expr>, Box<Expr>),
    Slice(Box<Expr>, Option<Box<Expr>>, Option<Box<Expr>>),
    List(Vec<Expr>),
    Map(Vec<(String, Expr)>),
    Bin(BinOp, Box<Expr>, Box<Expr>),
    /// `a < b < c`: each adjacent pair compared, all must hold.
    Chain(Vec<Expr>, Vec<BinOp>),
    Not(Box<Expr>),
    Neg(Box<Expr>),
    IsNull(Box<Expr>, bool),
    HasLabels(Box<Expr>, Vec<String>),
    Func {
        name: String,
        distinct: bool,
        args: Vec<Expr>,
        pos: Pos,
    },
    CountStar,
    Case {
        subject: Option<Box<Expr>>,
        whens: Vec<(Expr, Expr)>,
        else_: Option<Box<Expr>>,
    },
    ListComp {
        var: String,
        list: Box<Expr>,
        filter: Option<Box<Expr>>,
        map: Option<Box<Expr>>,
    },
    Quantified {
        q: Quant,
        var: String,
        list: Box<Expr>,
        pred: Box<Expr>,
    },
    Reduce {
        acc: String,
        init: Box<Expr>,
        var: String,
        list: Box<Expr>,
        expr: Box<Expr>,
    },
    /// A pattern used as a predicate (`WHERE (a)-->(b)`), true if it has a match.
    Pattern(Box<PathPattern>),
    /// `[p = (a)-->(b) WHERE pred | expr]`
    PatternComp {
        pattern: Box<PathPattern>,
        filter: Option<Box<Expr>>,
        map: Box<Expr>,
    },
    /// `EXISTS { [MATCH] patterns [WHERE pred] }` (true when there is a match) or
    /// `COUNT { ... }` (how many matches); the patterns may introduce variables of their own.
    Subquery {
        count: bool,
        patterns: Vec<PathPattern>,
        where_: Option<Box<Expr>>,
        pos: Pos,
    },
    /// `n {.a, b: expr, .*}`
    MapProj(Box<Expr>, Vec<MapProjItem>),
    /// An aggregate's result slot, after the projection has been rewritten.
    AggRef(usize),
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum MapProjItem {
    Prop(String),
    AllProps,
    Var(String),
    Lit(String, Expr),
}

pub(crate) const AGGREGATES: &[&str] = &[
    "count",
    "sum",
    "avg",
    "min",
    "max",
    "collect",
    "stdev",
    "stdevp",
    "percentiledisc",
    "percentilecont",
];

impl Expr {
    /// Whether the expression contains an aggregate call (outside nested scopes it cannot see).
    pub fn has_aggregate(&self) -> bool {
        let mut found = false;
        self.walk(&mut |e| {
            if let Expr::Func { name, .. } = e
                && AGGREGATES.contains(&name.to_ascii_lowercase().as_str())
            {
                found = true;
            }
            if matches!(e, Expr::CountStar) {
                found = true;
            }
        });
        found
    }

    /// Calls `f` on this expression and every sub-expression.
    pub fn walk(&self, f: &mut dyn FnMut(&Expr)) {
        f(self);
        for c in self.children() {
            c.walk(f);
        }
    }
}

impl PathPattern {
    pub fn walk_exprs(&self, f: &mut dyn FnMut(&Expr)) {
        if let Some(p) = &self.start.props {
            p.walk(f);
        }
        for (r, n) in &self.steps {
            if let Some(p) = &r.props {
                p.walk(f);
            }
            if let Some(p) = &n.props {
                p.walk(f);
            }
        }
    }

    /// Every variable the pattern names, in order.
    pub fn vars(&self) -> Vec<(&str, Pos, bool)> {
        let mut out = Vec::new();
        if let Some(v) = &self.var {
            out.push((v.as_str(), self.pos, false));
        }
        if let Some(v) = &self.start.var {
            out.push((v.as_str(), self.start.pos, true));
        }
        for (r, n) in &self.steps {
            if let Some(v) = &r.var {
                out.push((v.as_str(), r.pos, false));
            }
            if let Some(v) = &n.var {
                out.push((v.as_str(), n.pos, true));
            }
        }
        out
    }
}

impl Expr {
    /// A copy with every direct child expression replaced by `f(child)`.
    pub fn map_children(&self, f: &mut dyn FnMut(&Expr) -> Expr) -> Expr {
        let b = |e: &Expr, f: &mut dyn FnMut(&Expr) -> Expr| Box::new(f(e));
        match self {
            Expr::Lit(_) | Expr::Param(..) | Expr::Var(..) | Expr::CountStar | Expr::AggRef(_) => {
                self.clone()
            }
            Expr::Pattern(_) | Expr::PatternComp { .. } | Expr::Subquery { .. } => self.clone(),
            Expr::Prop(e, k) => Expr::Prop(b(e, f), k.clone()),
            Expr::Not(e) => Expr::Not(b(e, f)),
            Expr::Neg(e) => Expr::Neg(b(e, f)),
            Expr::IsNull(e, n) => Expr::IsNull(b(e, f), *n),
            Expr::HasLabels(e, l) => Expr::HasLabels(b(e, f), l.clone()),
            Expr::Index(x, y) => Expr::Index(b(x, f), b(y, f)),
            Expr::Bin(op, x, y) => Expr::Bin(*op, b(x, f), b(y, f)),
            Expr::Slice(x, y, z) => Expr::Slice(
                b(x, f),
                y.as_ref().map(|e| b(e, f)),
                z.as_ref().map(|e| b(e, f)),
            ),
            Expr::List(l) => Expr::List(l.iter().map(&mut *f).collect()),
            Expr::Chain(l, ops) => Expr::Chain(l.iter().map(&mut *f).collect(), ops.clone()),
            Expr::Map(m) => Expr::Map(m.iter().map(|(k, e)| (k.clone(), f(e))).collect()),
            Expr::Func {
                name,
                distinct,
                args,
                pos,
            } => Expr::Func {
                name: name.clone(),
                distinct: *distinct,
                args: args.iter().map(&mut *f).collect(),
                pos: *pos,
            },
            Expr::Case {
                subject,
                whens,
                else_,
            } => Expr::Case {
                subject: subject.as_ref().map(|e| b(e, f)),
                whens: whens.iter().map(|(x, y)| (f(x), f(y))).collect(),
                else_: else_.as_ref().map(|e| b(e, f)),
            },
            Expr::ListComp {
                var,
                list,
                filter,
                map,
            } => Expr::ListComp {
                var: var.clone(),
                list: b(list, f),
                filter: filter.as_ref().map(|e| b(e, f)),
                map: map.as_ref().map(|e| b(e, f)),
            },
            Expr::Quantified { q, var, list, pred } => Expr::Quantified {
                q: *q,
                var: var.clone(),
                list: b(list, f),
                pred: b(pred, f),
            },
            Expr::Reduce {
                acc,
                init,
                var,
                list,
                expr,
            } => Expr::Reduce {
                acc: acc.clone(),
                init: b(init, f),
                var: var.clone(),
                list: b(list, f),
                expr: b(expr, f),
            },
            Expr::MapProj(e, items) => Expr::MapProj(
                b(e, f),
                items
                    .iter()
                    .map(|it| match it {
                        MapProjItem::Lit(k, e) => MapProjItem::Lit(k.clone(), f(e)),
                        other => other.clone(),
                    })
                    .collect(),
            ),
        }
    }
}

impl Expr {
    /// The direct sub-expressions (pattern property maps included).
    pub fn children(&self) -> Vec<&Expr> {
        let mut v: Vec<&Expr> = Vec::new();
        match self {
            Expr::Lit(_) | Expr::Param(..) | Expr::Var(..) | Expr::CountStar | Expr::AggRef(_) => {}
            Expr::Prop(e, _)
            | Expr::Not(e)
            | Expr::Neg(e)
            | Expr::IsNull(e, _)
            | Expr::HasLabels(e, _) => v.push(e),
            Expr::Index(a, b) | Expr::Bin(_, a, b) => {
                v.push(a);
                v.push(b);
            }
            Expr::Slice(a, b, c) => {
                v.push(a);
                v.extend(b.as_deref());
                v.extend(c.as_deref());
            }
            Expr::List(l) | Expr::Chain(l, _) => v.extend(l.iter()),
            Expr::Func { args, .. } => v.extend(args.iter()),
            Expr::Map(m) => v.extend(m.iter().map(|(_, e)| e)),
            Expr::Case {
                subject,
                whens,
                else_,
            } => {
                v.extend(subject.as_deref());
                for (a, b) in whens {
                    v.push(a);
                    v.push(b);
                }
                v.extend(else_.as_deref());
            }
            Expr::ListComp {
                list, filter, map, ..
            } => {
                v.push(list);
                v.extend(filter.as_deref());
                v.extend(map.as_deref());
            }
            Expr::Quantified { list, pred, .. } => {
                v.push(list);
                v.push(pred);
            }
            Expr::Reduce {
                init, list, expr, ..
            } => {
                v.push(init);
                v.push(list);
                v.push(expr);
            }
            Expr::Pattern(p) => pattern_children(p, &mut v),
            Expr::PatternComp {
                pattern,
                filter,
                map,
            } => {
                pattern_children(pattern, &mut v);
                v.extend(filter.as_deref());
                v.push(map);
            }
            Expr::Subquery {
                patterns, where_, ..
            } => {
                for p in patterns {
                    pattern_children(p, &mut v);
                }
                v.extend(where_.as_deref());
            }
            Expr::MapProj(e, items) => {
                v.push(e);
                for it in items {
                    if let MapProjItem::Lit(_, e) = it {
                        v.push(e);
                    }
                }
            }
        }
        v
    }

    /// How deep evaluation recurses through the tree, computed without recursion. A chain of
    /// one operator family counts once, as evaluation folds it in a loop.
    pub fn depth(&self) -> usize {
        let mut max = 0;
        let mut stack = vec![(self, 1usize)];
        while let Some((e, d)) = stack.pop() {
            max = max.max(d);
            match e {
                Expr::Bin(op, l, r) => {
                    let flat = matches!(l.as_ref(), Expr::Bin(o, _, _) if same_family(*o, *op));
                    stack.push((l, if flat { d } else { d + 1 }));
                    stack.push((r, d + 1));
                }
                _ => stack.extend(e.children().into_iter().map(|c| (c, d + 1))),
            }
        }
        max
    }
}

fn pattern_children<'a>(p: &'a PathPattern, v: &mut Vec<&'a Expr>) {
    v.extend(p.start.props.as_ref());
    for (r, n) in &p.steps {
        v.extend(r.props.as_ref());
        v.extend(n.props.as_ref());
    }
}

/// Operators evaluated left to right at one precedence level: a chain of them folds in a loop.
pub(crate) fn same_family(a: BinOp, b: BinOp) -> bool {
    use BinOp::*;
    matches!(
        (a, b),
        (Add | Sub, Add | Sub)
            | (Mul | Div | Mod, Mul | Div | Mod)
            | (And, And)
            | (Or, Or)
            | (Xor, Xor)
            | (Pow, Pow)
    )
}
