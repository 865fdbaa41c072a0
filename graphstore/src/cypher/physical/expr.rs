//! Expressions compiled against a plan's slots.
//!
//! Variables become slot reads, property keys, labels and relationship types become ids
//! resolved once, and property reads go through the [`Source`]'s handles (a column lookup once
//! the commit has the column). The operators and functions are the interpreter's own
//! (`eval::apply_op`, `eval::cmp_op`, the function library through [`Host::call`]), so a
//! compiled expression means exactly what the interpreter's does. What needs the
//! interpreter's scoping (comprehensions, pattern predicates, subqueries, map projections,
//! indexing) is handed to it whole ([`CExpr::Fallback`]) with the visible variables by name.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::rc::Rc;

use super::super::ast::{BinOp, Expr};
use super::super::eval::{and3, apply_op, cmp_op, int_overflow, to_bool, type_err};
use super::super::logical::Scope;
use super::super::source::Source;
use super::super::value::{Val, equals};
use super::super::{ErrorKind, Pos, QueryError, R};
use super::{Exec, Slots};

/// A compiled expression.
#[derive(Debug, Clone)]
pub(crate) enum CExpr {
    Lit(Val),
    Param(String, Pos),
    Slot(usize),
    /// An aggregate's result, in an aggregation's outputs.
    Agg(usize),
    /// `base.key`: node and relationship reads through handles, maps and points directly.
    Prop {
        base: Box<CExpr>,
        key: String,
        node: usize,
        rel: usize,
    },
    Bin(BinOp, Box<CExpr>, Box<CExpr>),
    Chain(Vec<CExpr>, Vec<BinOp>),
    Not(Box<CExpr>),
    Neg(Box<CExpr>),
    IsNull(Box<CExpr>, bool),
    /// `x:A:B`; `None`: a label the store has never seen (no node has it).
    HasLabels(Box<CExpr>, Vec<Option<u32>>),
    List(Vec<CExpr>),
    Map(Vec<(String, CExpr)>),
    Case {
        subject: Option<Box<CExpr>>,
        whens: Vec<(CExpr, CExpr)>,
        else_: Option<Box<CExpr>>,
    },
    Coalesce(Vec<CExpr>),
    Func {
        lower: String,
        name: String,
        args: Vec<CExpr>,
        pos: Pos,
    },
    /// Evaluated by the interpreter over the visible variables.
    Fallback {
        expr: Box<Expr>,
        vars: Rc<[(Rc<str>, usize)]>,
    },
}

/// Compiles expressions seeing `scope`.
pub(crate) struct Compiler<'c> {
    pub src: &'c dyn Source,
    pub scope: &'c Scope,
    /// Whether `AggRef`s may appear (an aggregation's outputs).
    pub aggs: bool,
}

fn needs_aggs(e: &Expr) -> bool {
    let mut found = false;
    e.walk(&mut |x| found |= matches!(x, Expr::AggRef(_)));
    found
}

impl Compiler<'_> {
    /// The compiled form, or None when the expression names a variable the scope lacks (the
    /// interpreter then reports it) or needs what the compiled form cannot give it.
    pub(crate) fn compile(&self, e: &Expr) -> Option<CExpr> {
        let b = |x: &Expr| self.compile(x).map(Box::new);
        Some(match e {
            Expr::Lit(v) => CExpr::Lit(v.clone()),
            Expr::Param(p, pos) => CExpr::Param(p.clone(), *pos),
            Expr::Var(v, _) => CExpr::Slot(self.scope.get(v)?.0),
            Expr::AggRef(i) if self.aggs => CExpr::Agg(*i),
            Expr::AggRef(_) | Expr::CountStar => return None,
            Expr::Prop(base, key) => {
                let k = self.src.key_id(key);
                CExpr::Prop {
                    base: b(base)?,
                    key: key.clone(),
                    node: self.src.node_prop_handle(k),
                    rel: self.src.rel_prop_handle(k),
                }
            }
            Expr::Bin(op, x, y) => CExpr::Bin(*op, b(x)?, b(y)?),
            Expr::Chain(xs, ops) => CExpr::Chain(
                xs.iter().map(|x| self.compile(x)).collect::<Option<_>>()?,
                ops.clone(),
            ),
            Expr::Not(x) => CExpr::Not(b(x)?),
            Expr::Neg(x) => CExpr::Neg(b(x)?),
            Expr::IsNull(x, neg) => CExpr::IsNull(b(x)?, *neg),
            Expr::HasLabels(x, labels) => {
                CExpr::HasLabels(b(x)?, labels.iter().map(|l| self.src.label_id(l)).collect())
            }
            Expr::List(xs) => {
                CExpr::List(xs.iter().map(|x| self.compile(x)).collect::<Option<_>>()?)
            }
            Expr::Map(kv) => CExpr::Map(
                kv.iter()
                    .map(|(k, x)| Some((k.clone(), self.compile(x)?)))
                    .collect::<Option<_>>()?,
            ),
            Expr::Case {
                subject,
                whens,
                else_,
            } => CExpr::Case {
                subject: match subject {
                    Some(s) => Some(b(s)?),
                    None => None,
                },
                whens: whens
                    .iter()
                    .map(|(w, t)| Some((self.compile(w)?, self.compile(t)?)))
                    .collect::<Option<_>>()?,
                else_: match else_ {
                    Some(x) => Some(b(x)?),
                    None => None,
                },
            },
            Expr::Func {
                name, args, pos, ..
            } => {
                let lower = name.to_ascii_lowercase();
                if super::super::ast::AGGREGATES.contains(&lower.as_str()) {
                    return None;
                }
                match lower.as_str() {
                    "exists" => return self.fallback(e),
                    "coalesce" => CExpr::Coalesce(
                        args.iter()
                            .map(|x| self.compile(x))
                            .collect::<Option<_>>()?,
                    ),
                    _ => CExpr::Func {
                        lower,
                        name: name.clone(),
                        args: args
                            .iter()
                            .map(|x| self.compile(x))
                            .collect::<Option<_>>()?,
                        pos: *pos,
                    },
                }
            }
            Expr::Index(..)
            | Expr::Slice(..)
            | Expr::ListComp { .. }
            | Expr::Quantified { .. }
            | Expr::Reduce { .. }
            | Expr::Pattern(_)
            | Expr::PatternComp { .. }
            | Expr::Subquery { .. }
            | Expr::MapProj(..) => return self.fallback(e),
        })
    }

    fn fallback(&self, e: &Expr) -> Option<CExpr> {
        // the interpreter does not see aggregate results
        if needs_aggs(e) {
            return None;
        }
        let vars: Vec<(Rc<str>, usize)> = self
            .scope
            .sorted()
            .into_iter()
            .map(|(n, s)| (Rc::from(n.as_str()), s))
            .collect();
        Some(CExpr::Fallback {
            expr: Box::new(e.clone()),
            vars: vars.into(),
        })
    }
}

/// `v.key` on an evaluated value.
pub(crate) fn property(ex: &Exec<'_>, v: &Val, key: &str, node: usize, rel: usize) -> R<Val> {
    Ok(match v {
        Val::Null => Val::Null,
        Val::Node(id) => ex.src.node_prop(*id, node)?,
        Val::Rel(id) => ex.src.rel_prop(*id, rel)?,
        Val::Map(m) => m.get(key).cloned().unwrap_or(Val::Null),
        Val::Point2D([x, y]) => match key {
            "x" => Val::Float(*x),
            "y" => Val::Float(*y),
            _ => Val::Null,
        },
        Val::Point3D([x, y, z]) => match key {
            "x" => Val::Float(*x),
            "y" => Val::Float(*y),
            "z" => Val::Float(*z),
            _ => Val::Null,
        },
        o => {
            return Err(type_err(format!(
                "cannot read property `{key}` of {}",
                o.type_name()
            )));
        }
    })
}

impl CExpr {
    /// The value, borrowed where it is a literal or a slot.
    pub(crate) fn eval_cow<'r>(
        &'r self,
        ex: &Exec<'_>,
        row: &'r Slots,
        aggs: &'r [Val],
    ) -> R<Cow<'r, Val>> {
        Ok(match self {
            CExpr::Lit(v) => Cow::Borrowed(v),
            CExpr::Slot(s) => Cow::Borrowed(&row[*s]),
            CExpr::Agg(i) => Cow::Borrowed(aggs.get(*i).unwrap_or(&Val::Null)),
            other => Cow::Owned(other.eval(ex, row, aggs)?),
        })
    }

    /// The value of the expression on `row` (`aggs`: an aggregation's results).
    pub(crate) fn eval(&self, ex: &Exec<'_>, row: &Slots, aggs: &[Val]) -> R<Val> {
        Ok(match self {
            CExpr::Lit(v) => v.clone(),
            CExpr::Slot(s) => row[*s].clone(),
            CExpr::Agg(i) => aggs.get(*i).cloned().unwrap_or(Val::Null),
            CExpr::Param(p, pos) => match ex.host.param(p) {
                Some(v) => v.clone(),
                None => {
                    return Err(QueryError::new(
                        ErrorKind::Parameter,
                        "ParameterMissing",
                        format!("parameter ${p} was not given"),
                        Some(*pos),
                    ));
                }
            },
            CExpr::Prop {
                base,
                key,
                node,
                rel,
            } => {
                let b = base.eval_cow(ex, row, aggs)?;
                property(ex, &b, key, *node, *rel)?
            }
            CExpr::Bin(op, x, y) => {
                let a = x.eval_cow(ex, row, aggs)?;
                let b = y.eval_cow(ex, row, aggs)?;
                apply_op(*op, &a, &b, &|bytes, what| ex.host.reserve(bytes, what))?
            }
            CExpr::Chain(xs, ops) => {
                let vals = xs
                    .iter()
                    .map(|x| x.eval_cow(ex, row, aggs))
                    .collect::<R<Vec<_>>>()?;
                let mut acc = Val::Bool(true);
                for (i, op) in ops.iter().enumerate() {
                    let c = cmp_op(*op, &vals[i], &vals[i + 1]);
                    acc = and3(&acc, &c)?;
                }
                acc
            }
            CExpr::Not(x) => match to_bool(&*x.eval_cow(ex, row, aggs)?, "NOT")? {
                None => Val::Null,
                Some(b) => Val::Bool(!b),
            },
            CExpr::Neg(x) => match &*x.eval_cow(ex, row, aggs)? {
                Val::Null => Val::Null,
                Val::Int(i) => Val::Int(i.checked_neg().ok_or_else(int_overflow)?),
                Val::Float(f) => Val::Float(-f),
                o => return Err(type_err(format!("cannot negate {}", o.type_name()))),
            },
            CExpr::IsNull(x, neg) => Val::Bool(x.eval_cow(ex, row, aggs)?.is_null() != *neg),
            CExpr::HasLabels(x, labels) => match &*x.eval_cow(ex, row, aggs)? {
                Val::Null => Val::Null,
                Val::Node(id) => {
                    let mut all = true;
                    for l in labels {
                        match l {
                            Some(l) if ex.src.has_label(*id, *l)? => {}
                            _ => {
                                all = false;
                                break;
                            }
                        }
                    }
                    Val::Bool(all)
                }
                o => return Err(type_err(format!("label check on {}", o.type_name()))),
            },
            CExpr::List(xs) => {
                Val::List(xs.iter().map(|x| x.eval(ex, row, aggs)).collect::<R<_>>()?)
            }
            CExpr::Map(kv) => {
                let mut m = BTreeMap::new();
                for (k, x) in kv {
                    m.insert(k.clone(), x.eval(ex, row, aggs)?);
                }
                Val::Map(m)
            }
            CExpr::Case {
                subject,
                whens,
                else_,
            } => {
                let subj = match subject {
                    Some(s) => Some(s.eval(ex, row, aggs)?),
                    None => None,
                };
                for (w, t) in whens {
                    let wv = w.eval_cow(ex, row, aggs)?;
                    let hit = match &subj {
                        Some(s) => equals(s, &wv) == Some(true),
                        None => matches!(*wv, Val::Bool(true)),
                    };
                    if hit {
                        return t.eval(ex, row, aggs);
                    }
                }
                match else_ {
                    Some(x) => x.eval(ex, row, aggs)?,
                    None => Val::Null,
                }
            }
            CExpr::Coalesce(xs) => {
                for x in xs {
                    let v = x.eval(ex, row, aggs)?;
                    if !v.is_null() {
                        return Ok(v);
                    }
                }
                Val::Null
            }
            CExpr::Func {
                lower,
                name,
                args,
                pos,
            } => {
                let vals = args
                    .iter()
                    .map(|x| x.eval(ex, row, aggs))
                    .collect::<R<Vec<_>>>()?;
                ex.host.call(lower, name, vals).map_err(|e| e.at(*pos))?
            }
            CExpr::Fallback { expr, vars } => {
                let named: Vec<(Rc<str>, Val)> = vars
                    .iter()
                    .map(|(n, s)| (n.clone(), row[*s].clone()))
                    .collect();
                ex.host.eval_fallback(expr, &named)?
            }
        })
    }

    /// Whether a predicate holds (true, not false or null).
    pub(crate) fn holds(&self, ex: &Exec<'_>, row: &Slots) -> R<bool> {
        Ok(matches!(*self.eval_cow(ex, row, &[])?, Val::Bool(true)))
    }
}
