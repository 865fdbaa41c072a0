//! Expression evaluation and the function library.

use std::collections::BTreeMap;

use super::ast::{BinOp, Expr, MapProjItem, Quant};
use super::exec::{Ctx, Row};
use super::value::{Val, compare, equals, order};
use super::{QueryError, R};
use crate::Direction;

pub(crate) fn type_err(msg: impl Into<String>) -> QueryError {
    QueryError::new(super::ErrorKind::Type, "InvalidArgumentType", msg, None)
}

pub(crate) fn arg_err(code: &'static str, msg: impl Into<String>) -> QueryError {
    QueryError::new(super::ErrorKind::Argument, code, msg, None)
}

/// A rounding mode of `round(value, precision, mode)` (Neo4j's, after Java's
/// `java.math.RoundingMode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RoundMode {
    /// Away from zero when anything is dropped.
    Up,
    /// Towards zero.
    Down,
    /// Towards positive infinity.
    Ceiling,
    /// Towards negative infinity.
    Floor,
    /// To the nearest, a half away from zero (the default).
    HalfUp,
    /// To the nearest, a half towards zero.
    HalfDown,
    /// To the nearest, a half to the even neighbour.
    HalfEven,
}

impl RoundMode {
    fn parse(m: &str) -> Option<Self> {
        Some(match m.to_ascii_uppercase().as_str() {
            "UP" => Self::Up,
            "DOWN" => Self::Down,
            "CEILING" => Self::Ceiling,
            "FLOOR" => Self::Floor,
            "HALF_UP" => Self::HalfUp,
            "HALF_DOWN" => Self::HalfDown,
            "HALF_EVEN" => Self::HalfEven,
            _ => return None,
        })
    }
}

/// `x` rounded to `precision` decimal places (negative: to tens, hundreds, ...), on the
/// decimal the float prints as, as Neo4j does (`BigDecimal.valueOf(x).setScale(precision,
/// mode)`): `round(2.675, 2)` is 2.68, though the float nearest 2.675 lies below it. NaN and
/// infinities are returned as they are.
pub(crate) fn round_decimal(x: f64, precision: i64, mode: RoundMode) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    // the shortest decimal that reads back as x: digits d0.d1d2... times 10^exp
    let sci = format!("{:e}", x.abs());
    let Some((mantissa, exp)) = sci.split_once('e') else {
        return x;
    };
    let Ok(exp) = exp.parse::<i64>() else {
        return x;
    };
    let digits: Vec<u8> = mantissa
        .bytes()
        .filter(u8::is_ascii_digit)
        .map(|b| b - b'0')
        .collect();
    // how many leading digits have a place of 10^-precision or more
    let keep = i128::from(exp) + i128::from(precision) + 1;
    if keep >= digits.len() as i128 {
        return x;
    }
    let negative = x < 0.0;
    let (kept, dropped): (&[u8], Vec<u8>) = if keep <= 0 {
        // every digit lies below the place kept; a half needs the first to be that place's
        let zeros = usize::try_from(-keep).unwrap_or(usize::MAX).min(400);
        let mut d = vec![0u8; zeros];
        d.extend_from_slice(&digits);
        (&[], d)
    } else {
        let k = usize::try_from(keep).unwrap_or(digits.len());
        (&digits[..k], digits[k..].to_vec())
    };
    let nonzero = dropped.iter().any(|d| *d != 0);
    let first = dropped.first().copied().unwrap_or(0);
    let rest_nonzero = dropped.iter().skip(1).any(|d| *d != 0);
    let last_odd = kept.last().is_some_and(|d| d % 2 == 1);
    let up = match mode {
        RoundMode::Up => nonzero,
        RoundMode::Down => false,
        RoundMode::Ceiling => nonzero && !negative,
        RoundMode::Floor => nonzero && negative,
        RoundMode::HalfUp => first >= 5,
        RoundMode::HalfDown => first > 5 || (first == 5 && rest_nonzero),
        RoundMode::HalfEven => first > 5 || (first == 5 && (rest_nonzero || last_odd)),
    };
    let mut int: Vec<u8> = kept.to_vec();
    if up {
        let mut i = int.len();
        loop {
            if i == 0 {
                int.insert(0, 1);
                break;
            }
            i -= 1;
            if int[i] == 9 {
                int[i] = 0;
            } else {
                int[i] += 1;
                break;
            }
        }
    }
    if int.iter().all(|d| *d == 0) {
        return 0.0;
    }
    let text: String = int.iter().map(|d| char::from(b'0' + d)).collect();
    format!("{}{text}e{}", if negative { "-" } else { "" }, -precision)
        .parse::<f64>()
        .unwrap_or(x)
}

/// Formats a float as Cypher (Java) prints it: `1.0`, `0.5`, `1.0E10`.
pub(crate) fn fmt_float(f: f64) -> String {
    if f.is_nan() {
        return "NaN".into();
    }
    if f.is_infinite() {
        return if f > 0.0 {
            "Infinity".into()
        } else {
            "-Infinity".into()
        };
    }
    let a = f.abs();
    if a != 0.0 && !(1e-3..1e7).contains(&a) {
        let s = format!("{f:e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = if m.contains('.') {
            m.to_string()
        } else {
            format!("{m}.0")
        };
        return format!("{m}E{e}");
    }
    let s = format!("{f}");
    if s.contains('.') { s } else { format!("{s}.0") }
}

pub(crate) fn to_bool(v: &Val, what: &str) -> R<Option<bool>> {
    match v {
        Val::Null => Ok(None),
        Val::Bool(b) => Ok(Some(*b)),
        other => Err(type_err(format!(
            "{what} expects a boolean, got {}",
            other.type_name()
        ))),
    }
}

pub(crate) fn int_overflow() -> QueryError {
    arg_err("NumberOutOfRange", "integer overflow")
}

/// Bytes of one runtime value's own slot (a list of `n` values holds `n` of these).
pub(crate) const VAL_BYTES: u64 = std::mem::size_of::<Val>() as u64;

/// About the bytes `a + b` builds: the joined string, or the joined list's slots.
fn concat_bytes(a: &Val, b: &Val) -> u64 {
    let own = |v: &Val| match v {
        Val::Str(s) => s.len() as u64,
        Val::List(l) => l.len() as u64 * VAL_BYTES,
        _ => VAL_BYTES,
    };
    match (a, b) {
        (Val::Str(_) | Val::List(_), _) | (_, Val::Str(_) | Val::List(_)) => own(a) + own(b),
        _ => 0,
    }
}

pub(crate) fn arith(op: BinOp, a: &Val, b: &Val) -> R<Val> {
    use Val::*;
    if a.is_null() || b.is_null() {
        return Ok(Null);
    }
    if op == BinOp::Add {
        match (a, b) {
            (Str(x), Str(y)) => return Ok(Str(format!("{x}{y}"))),
            (Str(x), Int(_) | Float(_) | Bool(_)) => {
                return Ok(Str(format!("{x}{}", to_string(b).unwrap_or_default())));
            }
            (Int(_) | Float(_) | Bool(_), Str(y)) => {
                return Ok(Str(format!("{}{y}", to_string(a).unwrap_or_default())));
            }
            (List(x), List(y)) => return Ok(List(x.iter().chain(y).cloned().collect())),
            (List(x), y) => {
                let mut l = x.clone();
                l.push(y.clone());
                return Ok(List(l));
            }
            (x, List(y)) => {
                let mut l = vec![x.clone()];
                l.extend(y.iter().cloned());
                return Ok(List(l));
            }
            _ => {}
        }
    }
    match (a, b) {
        (Int(x), Int(y)) => {
            let (x, y) = (*x, *y);
            let r = match op {
                BinOp::Add => x.checked_add(y),
                BinOp::Sub => x.checked_sub(y),
                BinOp::Mul => x.checked_mul(y),
                BinOp::Div => {
                    if y == 0 {
                        return Err(arg_err("DivisionByZero", "/ by zero"));
                    }
                    x.checked_div(y)
                }
                BinOp::Mod => {
                    if y == 0 {
                        return Err(arg_err("DivisionByZero", "% by zero"));
                    }
                    x.checked_rem(y)
                }
                BinOp::Pow => return Ok(Float((x as f64).powf(y as f64))),
                _ => None,
            };
            r.map(Int).ok_or_else(int_overflow)
        }
        (Int(_) | Float(_), Int(_) | Float(_)) => {
            let (x, y) = (a.as_f64().unwrap_or(0.0), b.as_f64().unwrap_or(0.0));
            Ok(Float(match op {
                BinOp::Add => x + y,
                BinOp::Sub => x - y,
                BinOp::Mul => x * y,
                BinOp::Div => x / y,
                BinOp::Mod => x % y,
                _ => x.powf(y),
            }))
        }
        _ => Err(type_err(format!(
            "cannot apply {} to {} and {}",
            op_name(op),
            a.type_name(),
            b.type_name()
        ))),
    }
}

fn op_name(op: BinOp) -> &'static str {
    match op {
        BinOp::Add => "+",
        BinOp::Sub => "-",
        BinOp::Mul => "*",
        BinOp::Div => "/",
        BinOp::Mod => "%",
        BinOp::Pow => "^",
        _ => "an operator",
    }
}

pub(crate) fn to_string(v: &Val) -> Option<String> {
    match v {
        Val::Str(s) => Some(s.clone()),
        Val::Int(i) => Some(i.to_string()),
        Val::Float(f) => Some(fmt_float(*f)),
        Val::Bool(b) => Some(b.to_string()),
        Val::Point2D([x, y]) => Some(format!(
            "point({{x: {}, y: {}}})",
            fmt_float(*x),
            fmt_float(*y)
        )),
        Val::Point3D([x, y, z]) => Some(format!(
            "point({{x: {}, y: {}, z: {}}})",
            fmt_float(*x),
            fmt_float(*y),
            fmt_float(*z)
        )),
        _ => None,
    }
}

pub(crate) fn cmp_op(op: BinOp, a: &Val, b: &Val) -> Val {
    match op {
        BinOp::Eq => equals(a, b).map_or(Val::Null, Val::Bool),
        BinOp::Ne => equals(a, b).map_or(Val::Null, |x| Val::Bool(!x)),
        _ => {
            if a.is_null() || b.is_null() {
                return Val::Null;
            }
            // NaN compares false against numbers, not null
            if let (Some(x), Some(y)) = (a.as_f64(), b.as_f64())
                && (x.is_nan() || y.is_nan())
            {
                return Val::Bool(false);
            }
            match compare(a, b) {
                None => Val::Null,
                Some(o) => Val::Bool(match op {
                    BinOp::Lt => o.is_lt(),
                    BinOp::Le => o.is_le(),
                    BinOp::Gt => o.is_gt(),
                    _ => o.is_ge(),
                }),
            }
        }
    }
}

fn list_index(len: usize, i: i64) -> Option<usize> {
    let len = len as i64;
    let j = if i < 0 { len + i } else { i };
    (0..len).contains(&j).then_some(j as usize)
}

fn slice_bounds(len: usize, lo: Option<i64>, hi: Option<i64>) -> (usize, usize) {
    let len_i = len as i64;
    let norm = |x: i64| {
        if x < 0 {
            (len_i + x).max(0)
        } else {
            x.min(len_i)
        }
    };
    let a = lo.map_or(0, norm);
    let b = hi.map_or(len_i, norm);
    if a >= b {
        (0, 0)
    } else {
        (a as usize, b as usize)
    }
}

impl Ctx<'_, '_> {
    pub(crate) fn eval(&self, e: &Expr, row: &Row) -> R<Val> {
        self.eval_in(e, row, &[])
    }

    /// Evaluates with the aggregate results `aggs` available to [`Expr::AggRef`].
    pub(crate) fn eval_in(&self, e: &Expr, row: &Row, aggs: &[Val]) -> R<Val> {
        self.tick()?;
        Ok(match e {
            Expr::Lit(v) => v.clone(),
            Expr::AggRef(i) => aggs.get(*i).cloned().unwrap_or(Val::Null),
            Expr::Param(p, pos) => match self.params.get(p) {
                Some(v) => v.clone(),
                None => {
                    return Err(QueryError::new(
                        super::ErrorKind::Parameter,
                        "ParameterMissing",
                        format!("parameter ${p} was not given"),
                        Some(*pos),
                    ));
                }
            },
            Expr::Var(v, pos) => match row.get(v) {
                Some(x) => {
                    // a large list or string is copied here: check the copy fits first
                    let copy = match x {
                        Val::List(l) if l.len() > 4096 => l.len() as u64 * VAL_BYTES,
                        Val::Str(t) if t.len() > 1 << 16 => t.len() as u64,
                        _ => 0,
                    };
                    if copy > 0 {
                        self.reserve(copy, "a copy of a variable")?;
                    }
                    x.clone()
                }
                None => {
                    return Err(QueryError::new(
                        super::ErrorKind::Semantic,
                        "UndefinedVariable",
                        format!("variable `{v}` is not defined"),
                        Some(*pos),
                    ));
                }
            },
            Expr::Prop(base, key) => {
                let b = self.eval_in(base, row, aggs)?;
                self.property(&b, key)?
            }
            Expr::Index(base, idx) => {
                let b = self.eval_in(base, row, aggs)?;
                let i = self.eval_in(idx, row, aggs)?;
                match (&b, &i) {
                    (Val::Null, _) | (_, Val::Null) => Val::Null,
                    (Val::List(l), Val::Int(i)) => {
                        list_index(l.len(), *i).map_or(Val::Null, |j| l[j].clone())
                    }
                    (Val::Vector(l), Val::Int(i)) => {
                        list_index(l.len(), *i).map_or(Val::Null, |j| Val::Float(f64::from(l[j])))
                    }
                    (Val::List(_) | Val::Vector(_), other) => {
                        return Err(type_err(format!(
                            "list index must be an integer, got {}",
                            other.type_name()
                        )));
                    }
                    (Val::Map(_) | Val::Node(_) | Val::Rel(_), Val::Str(k)) => {
                        self.property(&b, k)?
                    }
                    (Val::Map(_) | Val::Node(_) | Val::Rel(_), other) => {
                        return Err(type_err(format!(
                            "map key must be a string, got {}",
                            other.type_name()
                        )));
                    }
                    (other, _) => {
                        return Err(type_err(format!("cannot index into {}", other.type_name())));
                    }
                }
            }
            Expr::Slice(base, lo, hi) => {
                let b = self.eval_in(base, row, aggs)?;
                let bound = |x: &Option<Box<Expr>>| -> R<Option<Option<i64>>> {
                    match x {
                        None => Ok(Some(None)),
                        Some(e) => match self.eval_in(e, row, aggs)? {
                            Val::Null => Ok(None),
                            Val::Int(i) => Ok(Some(Some(i))),
                            o => Err(type_err(format!(
                                "slice bound must be an integer, got {}",
                                o.type_name()
                            ))),
                        },
                    }
                };
                let (Some(l), Some(h)) = (bound(lo)?, bound(hi)?) else {
                    return Ok(Val::Null);
                };
                match b {
                    Val::Null => Val::Null,
                    Val::List(v) => {
                        let (a, z) = slice_bounds(v.len(), l, h);
                        Val::List(v[a..z].to_vec())
                    }
                    o => return Err(type_err(format!("cannot slice {}", o.type_name()))),
                }
            }
            Expr::List(items) => Val::List(
                items
                    .iter()
                    .map(|x| self.eval_in(x, row, aggs))
                    .collect::<R<_>>()?,
            ),
            Expr::Map(entries) => {
                let mut m = BTreeMap::new();
                for (k, x) in entries {
                    m.insert(k.clone(), self.eval_in(x, row, aggs)?);
                }
                Val::Map(m)
            }
            Expr::Bin(op, a, b) => self.binary(*op, a, b, row, aggs)?,
            Expr::Chain(operands, ops) => {
                let vals = operands
                    .iter()
                    .map(|x| self.eval_in(x, row, aggs))
                    .collect::<R<Vec<_>>>()?;
                let mut acc = Val::Bool(true);
                for (i, op) in ops.iter().enumerate() {
                    let c = cmp_op(*op, &vals[i], &vals[i + 1]);
                    acc = and3(&acc, &c)?;
                }
                acc
            }
            Expr::Not(x) => match to_bool(&self.eval_in(x, row, aggs)?, "NOT")? {
                None => Val::Null,
                Some(b) => Val::Bool(!b),
            },
            Expr::Neg(x) => match self.eval_in(x, row, aggs)? {
                Val::Null => Val::Null,
                Val::Int(i) => Val::Int(i.checked_neg().ok_or_else(int_overflow)?),
                Val::Float(f) => Val::Float(-f),
                o => return Err(type_err(format!("cannot negate {}", o.type_name()))),
            },
            Expr::IsNull(x, neg) => {
                let n = self.eval_in(x, row, aggs)?.is_null();
                Val::Bool(n != *neg)
            }
            Expr::HasLabels(x, labels) => match self.eval_in(x, row, aggs)? {
                Val::Null => Val::Null,
                Val::Node(id) => {
                    let have = self.labels_of(id)?;
                    Val::Bool(labels.iter().all(|l| have.contains(l)))
                }
                o => return Err(type_err(format!("label check on {}", o.type_name()))),
            },
            Expr::CountStar => {
                return Err(QueryError::new(
                    super::ErrorKind::Syntax,
                    "InvalidAggregation",
                    "count(*) is only allowed in WITH and RETURN",
                    None,
                ));
            }
            Expr::Func {
                name, args, pos, ..
            } => {
                let lower = name.to_ascii_lowercase();
                if super::ast::AGGREGATES.contains(&lower.as_str()) {
                    return Err(QueryError::new(
                        super::ErrorKind::Syntax,
                        "InvalidAggregation",
                        format!("aggregate {name}() is only allowed in WITH and RETURN"),
                        Some(*pos),
                    ));
                }
                if lower == "exists" {
                    return self.exists(args, row, aggs);
                }
                if lower == "coalesce" {
                    for a in args {
                        let v = self.eval_in(a, row, aggs)?;
                        if !v.is_null() {
                            return Ok(v);
                        }
                    }
                    return Ok(Val::Null);
                }
                let vals = args
                    .iter()
                    .map(|x| self.eval_in(x, row, aggs))
                    .collect::<R<Vec<_>>>()?;
                self.call_function(&lower, name, vals)
                    .map_err(|e| e.at(*pos))?
            }
            Expr::Case {
                subject,
                whens,
                else_,
            } => {
                let subj = subject
                    .as_ref()
                    .map(|s| self.eval_in(s, row, aggs))
                    .transpose()?;
                for (w, t) in whens {
                    let wv = self.eval_in(w, row, aggs)?;
                    let hit = match &subj {
                        Some(s) => equals(s, &wv) == Some(true),
                        None => matches!(wv, Val::Bool(true)),
                    };
                    if hit {
                        return self.eval_in(t, row, aggs);
                    }
                }
                match else_ {
                    Some(x) => self.eval_in(x, row, aggs)?,
                    None => Val::Null,
                }
            }
            Expr::ListComp {
                var,
                list,
                filter,
                map,
            } => {
                let l = self.eval_in(list, row, aggs)?;
                let items = match l {
                    Val::Null => return Ok(Val::Null),
                    Val::List(v) => v,
                    o => {
                        return Err(type_err(format!(
                            "list comprehension over {}",
                            o.type_name()
                        )));
                    }
                };
                let mut out = Vec::new();
                let mut r = row.clone();
                for it in items {
                    r.set(var, it.clone());
                    if let Some(f) = filter
                        && !matches!(self.eval_in(f, &r, aggs)?, Val::Bool(true))
                    {
                        continue;
                    }
                    out.push(match map {
                        Some(m) => self.eval_in(m, &r, aggs)?,
                        None => it,
                    });
                }
                Val::List(out)
            }
            Expr::Quantified { q, var, list, pred } => {
                let l = self.eval_in(list, row, aggs)?;
                let items = match l {
                    Val::Null => return Ok(Val::Null),
                    Val::List(v) => v,
                    o => return Err(type_err(format!("quantifier over {}", o.type_name()))),
                };
                let (mut t, mut nulls) = (0usize, 0usize);
                let mut r = row.clone();
                let n = items.len();
                for it in items {
                    r.set(var, it);
                    match to_bool(&self.eval_in(pred, &r, aggs)?, "a quantifier predicate")? {
                        Some(true) => t += 1,
                        None => nulls += 1,
                        Some(false) => {}
                    }
                }
                let f = n - t - nulls;
                match q {
                    Quant::All => {
                        if f > 0 {
                            Val::Bool(false)
                        } else if nulls > 0 {
                            Val::Null
                        } else {
                            Val::Bool(true)
                        }
                    }
                    Quant::Any => {
                        if t > 0 {
                            Val::Bool(true)
                        } else if nulls > 0 {
                            Val::Null
                        } else {
                            Val::Bool(false)
                        }
                    }
                    Quant::None => {
                        if t > 0 {
                            Val::Bool(false)
                        } else if nulls > 0 {
                            Val::Null
                        } else {
                            Val::Bool(true)
                        }
                    }
                    Quant::Single => {
                        if t > 1 {
                            Val::Bool(false)
                        } else if nulls > 0 {
                            Val::Null
                        } else {
                            Val::Bool(t == 1)
                        }
                    }
                }
            }
            Expr::Reduce {
                acc,
                init,
                var,
                list,
                expr,
            } => {
                let mut a = self.eval_in(init, row, aggs)?;
                let items = match self.eval_in(list, row, aggs)? {
                    Val::Null => return Ok(Val::Null),
                    Val::List(v) => v,
                    o => return Err(type_err(format!("reduce over {}", o.type_name()))),
                };
                let mut r = row.clone();
                for it in items {
                    r.set(acc, a);
                    r.set(var, it);
                    a = self.eval_in(expr, &r, aggs)?;
                }
                a
            }
            Expr::Pattern(p) => Val::Bool(
                !self
                    .match_paths(row, std::slice::from_ref(p.as_ref()), None, Some(1))?
                    .is_empty(),
            ),
            Expr::PatternComp {
                pattern,
                filter,
                map,
            } => {
                let rows =
                    self.match_paths(row, std::slice::from_ref(pattern.as_ref()), None, None)?;
                let mut out = Vec::new();
                for r in rows {
                    if let Some(f) = filter
                        && !matches!(self.eval_in(f, &r, aggs)?, Val::Bool(true))
                    {
                        continue;
                    }
                    out.push(self.eval_in(map, &r, aggs)?);
                }
                Val::List(out)
            }
            Expr::Subquery {
                count,
                patterns,
                where_,
                ..
            } => {
                if *count {
                    Val::Int(self.count_matches(row, patterns, where_.as_deref())? as i64)
                } else {
                    Val::Bool(
                        !self
                            .match_paths(row, patterns, where_.as_deref(), Some(1))?
                            .is_empty(),
                    )
                }
            }
            Expr::MapProj(base, items) => {
                let b = self.eval_in(base, row, aggs)?;
                if b.is_null() {
                    return Ok(Val::Null);
                }
                let mut m = BTreeMap::new();
                for it in items {
                    match it {
                        MapProjItem::Prop(k) => {
                            m.insert(k.clone(), self.property(&b, k)?);
                        }
                        MapProjItem::AllProps => {
                            if let Val::Map(all) = self.properties(&b)? {
                                m.extend(all);
                            }
                        }
                        MapProjItem::Var(v) => {
                            let x = row.get(v).cloned().ok_or_else(|| {
                                QueryError::new(
                                    super::ErrorKind::Semantic,
                                    "UndefinedVariable",
                                    format!("variable `{v}` is not defined"),
                                    None,
                                )
                            })?;
                            m.insert(v.clone(), x);
                        }
                        MapProjItem::Lit(k, x) => {
                            m.insert(k.clone(), self.eval_in(x, row, aggs)?);
                        }
                    }
                }
                Val::Map(m)
            }
        })
    }

    fn exists(&self, args: &[Expr], row: &Row, aggs: &[Val]) -> R<Val> {
        match args {
            [Expr::Pattern(p)] => Ok(Val::Bool(
                !self
                    .match_paths(row, std::slice::from_ref(p.as_ref()), None, Some(1))?
                    .is_empty(),
            )),
            [e @ Expr::Prop(..)] => Ok(Val::Bool(!self.eval_in(e, row, aggs)?.is_null())),
            [e] => Ok(Val::Bool(!self.eval_in(e, row, aggs)?.is_null())),
            _ => Err(QueryError::new(
                super::ErrorKind::Syntax,
                "InvalidNumberOfArguments",
                "exists() takes one argument",
                None,
            )),
        }
    }

    fn binary(&self, op: BinOp, a: &Expr, b: &Expr, row: &Row, aggs: &[Val]) -> R<Val> {
        // a left-deep chain of one family (`a OR b OR c`, `a + b - c`) is folded left to right
        // in a loop, so long chains do not deepen the recursion
        if let Expr::Bin(inner, _, _) = a
            && super::ast::same_family(*inner, op)
        {
            let mut rhs: Vec<(BinOp, &Expr)> = vec![(op, b)];
            let mut cur = a;
            while let Expr::Bin(o, l, r) = cur {
                if !super::ast::same_family(*o, op) {
                    break;
                }
                rhs.push((*o, r));
                cur = l;
            }
            let mut acc = self.eval_in(cur, row, aggs)?;
            for (o, r) in rhs.into_iter().rev() {
                let y = self.eval_in(r, row, aggs)?;
                acc = self.apply(o, &acc, &y)?;
            }
            return Ok(acc);
        }
        let x = self.eval_in(a, row, aggs)?;
        let y = self.eval_in(b, row, aggs)?;
        self.apply(op, &x, &y)
    }

    /// Applies a binary operator to two evaluated operands.
    fn apply(&self, op: BinOp, x: &Val, y: &Val) -> R<Val> {
        apply_op(op, x, y, &|bytes, what| self.reserve(bytes, what))
    }

    /// `x.key` on a node, relationship, map or point.
    pub(crate) fn property(&self, b: &Val, key: &str) -> R<Val> {
        Ok(match b {
            Val::Null => Val::Null,
            Val::Node(id) => {
                if self.deleted_node(*id) {
                    return Err(QueryError::new(
                        super::ErrorKind::EntityNotFound,
                        "DeletedEntityAccess",
                        format!("node {id} was deleted"),
                        None,
                    ));
                }
                let g = self.g();
                match (g.prop_key(key), self.node_cached(*id)?) {
                    (Some(k), Some(n)) => n.get(k).cloned().map(Val::from).unwrap_or(Val::Null),
                    _ => Val::Null,
                }
            }
            Val::Rel(id) => {
                if self.deleted_rel(*id) {
                    return Err(QueryError::new(
                        super::ErrorKind::EntityNotFound,
                        "DeletedEntityAccess",
                        format!("relationship {id} was deleted"),
                        None,
                    ));
                }
                let g = self.g();
                match g.prop_key(key) {
                    Some(k) => g.rel_prop(*id, k)?.map(Val::from).unwrap_or(Val::Null),
                    None => Val::Null,
                }
            }
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

    pub(crate) fn properties(&self, b: &Val) -> R<Val> {
        let g = self.g();
        let props = match b {
            Val::Null => return Ok(Val::Null),
            Val::Map(m) => return Ok(Val::Map(m.clone())),
            Val::Node(id) => self
                .node_cached(*id)?
                .map(|n| n.props.clone())
                .unwrap_or_default(),
            Val::Rel(id) => g.rel(*id)?.map(|r| r.props).unwrap_or_default(),
            o => return Err(type_err(format!("properties() of {}", o.type_name()))),
        };
        let mut m = BTreeMap::new();
        for (k, v) in props {
            m.insert(g.name_of(k.0).unwrap_or_default(), Val::from(v));
        }
        Ok(Val::Map(m))
    }

    pub(crate) fn labels_of(&self, id: u64) -> R<Vec<String>> {
        if self.deleted_node(id) {
            return Err(QueryError::new(
                super::ErrorKind::EntityNotFound,
                "DeletedEntityAccess",
                format!("node {id} was deleted"),
                None,
            ));
        }
        let g = self.g();
        let mut out: Vec<String> = self
            .node_cached(id)?
            .map(|n| n.labels.iter().filter_map(|l| g.name_of(l.0)).collect())
            .unwrap_or_default();
        out.sort();
        Ok(out)
    }

    pub(crate) fn call_function(&self, lower: &str, name: &str, a: Vec<Val>) -> R<Val> {
        use Val::*;
        let n = a.len();
        let arity = |lo: usize, hi: usize| -> R<()> {
            if n < lo || n > hi {
                Err(QueryError::new(
                    super::ErrorKind::Syntax,
                    "InvalidNumberOfArguments",
                    format!(
                        "{name}() takes {lo}{} argument(s), got {n}",
                        if hi > lo {
                            format!("..{hi}")
                        } else {
                            String::new()
                        }
                    ),
                    None,
                ))
            } else {
                Ok(())
            }
        };
        let num = |v: &Val| -> R<Option<f64>> {
            match v {
                Null => Ok(None),
                Int(_) | Float(_) => Ok(v.as_f64()),
                o => Err(type_err(format!(
                    "{name}() expects a number, got {}",
                    o.type_name()
                ))),
            }
        };
        macro_rules! math1 {
            ($f:expr) => {{
                arity(1, 1)?;
                return Ok(num(&a[0])?.map_or(Null, |x| Float($f(x))));
            }};
        }
        match lower {
            "id" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Node(i) | Rel(i) => Int(*i as i64),
                    Null => Null,
                    o => return Err(type_err(format!("id() of {}", o.type_name()))),
                })
            }
            "elementid" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Node(i) => Str(format!("n{i}")),
                    Rel(i) => Str(format!("r{i}")),
                    Null => Null,
                    o => return Err(type_err(format!("elementId() of {}", o.type_name()))),
                })
            }
            "labels" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Node(i) => List(self.labels_of(*i)?.into_iter().map(Str).collect()),
                    Null => Null,
                    o => return Err(type_err(format!("labels() of {}", o.type_name()))),
                })
            }
            "type" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Rel(i) => self.rel_type_name(*i)?.map_or(Null, Str),
                    Null => Null,
                    o => return Err(type_err(format!("type() of {}", o.type_name()))),
                })
            }
            "keys" => {
                arity(1, 1)?;
                Ok(match self.properties(&a[0])? {
                    Map(m) => List(
                        m.into_iter()
                            .filter(|(_, v)| !v.is_null() || matches!(a[0], Map(_)))
                            .map(|(k, _)| Str(k))
                            .collect(),
                    ),
                    _ => Null,
                })
            }
            "properties" => {
                arity(1, 1)?;
                self.properties(&a[0])
            }
            "startnode" | "endnode" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Rel(i) => match self.g().rel(*i)? {
                        Some(r) => Node(if lower == "startnode" { r.start } else { r.end }),
                        None => Null,
                    },
                    Null => Null,
                    o => return Err(type_err(format!("{name}() of {}", o.type_name()))),
                })
            }
            "nodes" | "relationships" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Path { nodes, rels } => List(if lower == "nodes" {
                        nodes.iter().map(|i| Node(*i)).collect()
                    } else {
                        rels.iter().map(|i| Rel(*i)).collect()
                    }),
                    Null => Null,
                    o => return Err(type_err(format!("{name}() of {}", o.type_name()))),
                })
            }
            "length" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Path { rels, .. } => Int(rels.len() as i64),
                    Null => Null,
                    o => return Err(type_err(format!("length() of {}", o.type_name()))),
                })
            }
            "size" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    List(l) => Int(l.len() as i64),
                    Str(s) => Int(s.chars().count() as i64),
                    Vector(v) => Int(v.len() as i64),
                    Null => Null,
                    o => return Err(type_err(format!("size() of {}", o.type_name()))),
                })
            }
            "head" | "last" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    List(l) => (if lower == "head" { l.first() } else { l.last() })
                        .cloned()
                        .unwrap_or(Null),
                    Null => Null,
                    o => return Err(type_err(format!("{name}() of {}", o.type_name()))),
                })
            }
            "tail" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    List(l) => List(l.iter().skip(1).cloned().collect()),
                    Null => Null,
                    o => return Err(type_err(format!("tail() of {}", o.type_name()))),
                })
            }
            "reverse" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    List(l) => List(l.iter().rev().cloned().collect()),
                    Str(s) => Str(s.chars().rev().collect()),
                    Null => Null,
                    o => return Err(type_err(format!("reverse() of {}", o.type_name()))),
                })
            }
            "range" => {
                arity(2, 3)?;
                let get = |v: &Val| match v {
                    Int(i) => Ok(*i),
                    o => Err(arg_err(
                        "InvalidArgumentType",
                        format!("range() expects integers, got {}", o.type_name()),
                    )),
                };
                let (s, e) = (get(&a[0])?, get(&a[1])?);
                let step = if n == 3 { get(&a[2])? } else { 1 };
                if step == 0 {
                    return Err(arg_err("NumberOutOfRange", "range() step must not be zero"));
                }
                let count = if (step > 0 && e < s) || (step < 0 && e > s) {
                    0
                } else {
                    ((i128::from(e) - i128::from(s)) / i128::from(step) + 1) as u128
                };
                if count > 10_000_000 {
                    return Err(arg_err(
                        "NumberOutOfRange",
                        format!("range() would make {count} elements (at most 10,000,000)"),
                    ));
                }
                self.reserve(count as u64 * VAL_BYTES, "range()")?;
                Ok(List((0..count as i64).map(|k| Int(s + k * step)).collect()))
            }
            "tostring" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Null => Null,
                    v => match to_string(v) {
                        Some(s) => Str(s),
                        None => return Err(type_err(format!("toString() of {}", v.type_name()))),
                    },
                })
            }
            "tointeger" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Null => Null,
                    Int(i) => Int(*i),
                    Float(f) => float_to_int(*f).map_or(Null, Int),
                    Bool(b) => Int(i64::from(*b)),
                    Str(s) => {
                        let t = s.trim();
                        if let Ok(i) = t.parse::<i64>() {
                            Int(i)
                        } else if let Ok(f) = t.parse::<f64>() {
                            float_to_int(f).map_or(Null, Int)
                        } else {
                            Null
                        }
                    }
                    o => return Err(type_err(format!("toInteger() of {}", o.type_name()))),
                })
            }
            "tofloat" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Null => Null,
                    Int(i) => Float(*i as f64),
                    Float(f) => Float(*f),
                    Str(s) => s.trim().parse::<f64>().map_or(Null, Float),
                    o => return Err(type_err(format!("toFloat() of {}", o.type_name()))),
                })
            }
            "toboolean" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Null => Null,
                    Bool(b) => Bool(*b),
                    Str(s) => match s.trim().to_ascii_lowercase().as_str() {
                        "true" => Bool(true),
                        "false" => Bool(false),
                        _ => Null,
                    },
                    Int(i) => Bool(*i != 0),
                    o => return Err(type_err(format!("toBoolean() of {}", o.type_name()))),
                })
            }
            "toupper" | "tolower" | "trim" | "ltrim" | "rtrim" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Null => Null,
                    Str(s) => Str(match lower {
                        "toupper" => s.to_uppercase(),
                        "tolower" => s.to_lowercase(),
                        "trim" => s.trim().to_string(),
                        "ltrim" => s.trim_start().to_string(),
                        _ => s.trim_end().to_string(),
                    }),
                    o => return Err(type_err(format!("{name}() of {}", o.type_name()))),
                })
            }
            "replace" => {
                arity(3, 3)?;
                Ok(match (&a[0], &a[1], &a[2]) {
                    (Null, _, _) | (_, Null, _) | (_, _, Null) => Null,
                    (Str(s), Str(f), Str(t)) => {
                        let hits = if f.is_empty() {
                            s.chars().count() + 1
                        } else {
                            s.matches(f.as_str()).count()
                        };
                        self.reserve(
                            (s.len() as u64)
                                .saturating_add((hits as u64).saturating_mul(t.len() as u64)),
                            "replace()",
                        )?;
                        Str(s.replace(f.as_str(), t))
                    }
                    _ => return Err(type_err("replace() expects strings")),
                })
            }
            "split" => {
                arity(2, 2)?;
                Ok(match (&a[0], &a[1]) {
                    (Null, _) | (_, Null) => Null,
                    (Str(s), Str(d)) => {
                        let pieces = if d.is_empty() {
                            s.chars().count()
                        } else {
                            s.matches(d.as_str()).count() + 1
                        };
                        self.reserve(
                            (pieces as u64).saturating_mul(VAL_BYTES + 8) + s.len() as u64,
                            "split()",
                        )?;
                        if d.is_empty() {
                            List(s.chars().map(|c| Str(c.to_string())).collect())
                        } else {
                            List(s.split(d.as_str()).map(|p| Str(p.to_string())).collect())
                        }
                    }
                    _ => return Err(type_err("split() expects strings")),
                })
            }
            "substring" => {
                arity(2, 3)?;
                let s = match &a[0] {
                    Null => return Ok(Null),
                    Str(s) => s,
                    o => return Err(type_err(format!("substring() of {}", o.type_name()))),
                };
                let start = match &a[1] {
                    Int(i) if *i >= 0 => *i as usize,
                    Int(_) => {
                        return Err(arg_err(
                            "NegativeIntegerArgument",
                            "substring() start must not be negative",
                        ));
                    }
                    o => {
                        return Err(type_err(format!(
                            "substring() start must be an integer, got {}",
                            o.type_name()
                        )));
                    }
                };
                let len = if n == 3 {
                    match &a[2] {
                        Int(i) if *i >= 0 => Some(*i as usize),
                        Int(_) => {
                            return Err(arg_err(
                                "NegativeIntegerArgument",
                                "substring() length must not be negative",
                            ));
                        }
                        o => {
                            return Err(type_err(format!(
                                "substring() length must be an integer, got {}",
                                o.type_name()
                            )));
                        }
                    }
                } else {
                    None
                };
                let it = s.chars().skip(start);
                Ok(Str(match len {
                    Some(l) => it.take(l).collect(),
                    None => it.collect(),
                }))
            }
            "left" | "right" => {
                arity(2, 2)?;
                let s = match &a[0] {
                    Null => return Ok(Null),
                    Str(s) => s,
                    o => return Err(type_err(format!("{name}() of {}", o.type_name()))),
                };
                let k = match &a[1] {
                    Int(i) if *i >= 0 => *i as usize,
                    Int(_) => {
                        return Err(arg_err(
                            "NegativeIntegerArgument",
                            format!("{name}() length must not be negative"),
                        ));
                    }
                    Null => {
                        return Err(arg_err(
                            "InvalidArgumentValue",
                            format!("{name}() length must not be null"),
                        ));
                    }
                    o => {
                        return Err(type_err(format!(
                            "{name}() length must be an integer, got {}",
                            o.type_name()
                        )));
                    }
                };
                let chars: Vec<char> = s.chars().collect();
                let k = k.min(chars.len());
                Ok(Str(if lower == "left" {
                    chars[..k].iter().collect()
                } else {
                    chars[chars.len() - k..].iter().collect()
                }))
            }
            "abs" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Null => Null,
                    Int(i) => Int(i.checked_abs().ok_or_else(int_overflow)?),
                    Float(f) => Float(f.abs()),
                    o => return Err(type_err(format!("abs() of {}", o.type_name()))),
                })
            }
            "sign" => {
                arity(1, 1)?;
                Ok(match &a[0] {
                    Null => Null,
                    Int(i) => Int(i.signum()),
                    Float(f) => Int(if *f > 0.0 {
                        1
                    } else if *f < 0.0 {
                        -1
                    } else {
                        0
                    }),
                    o => return Err(type_err(format!("sign() of {}", o.type_name()))),
                })
            }
            "ceil" => math1!(f64::ceil),
            "floor" => math1!(f64::floor),
            "round" => {
                arity(1, 3)?;
                let Some(x) = num(&a[0])? else {
                    return Ok(Null);
                };
                if n == 1 {
                    // a half goes up, towards positive infinity (Java's Math.round)
                    // (x - floor(x) is exact)
                    let floor = x.floor();
                    return Ok(Float(if x - floor >= 0.5 { floor + 1.0 } else { floor }));
                }
                let precision = match &a[1] {
                    Null => return Ok(Null),
                    Int(p) => *p,
                    o => {
                        return Err(type_err(format!(
                            "round() precision must be an integer, got {}",
                            o.type_name()
                        )));
                    }
                };
                let mode = match a.get(2) {
                    None => RoundMode::HalfUp,
                    Some(Null) => return Ok(Null),
                    Some(Str(m)) => RoundMode::parse(m).ok_or_else(|| {
                        arg_err(
                            "InvalidArgumentValue",
                            format!(
                                "round() mode must be one of UP, DOWN, CEILING, FLOOR, HALF_UP, \
                                 HALF_DOWN, HALF_EVEN; got {m:?}"
                            ),
                        )
                    })?,
                    Some(o) => {
                        return Err(type_err(format!(
                            "round() mode must be a string, got {}",
                            o.type_name()
                        )));
                    }
                };
                Ok(Float(round_decimal(x, precision, mode)))
            }
            "sqrt" => math1!(f64::sqrt),
            "exp" => math1!(f64::exp),
            "log" => math1!(f64::ln),
            "log10" => math1!(f64::log10),
            "sin" => math1!(f64::sin),
            "cos" => math1!(f64::cos),
            "tan" => math1!(f64::tan),
            "cot" => math1!(|x: f64| 1.0 / x.tan()),
            "asin" => math1!(f64::asin),
            "acos" => math1!(f64::acos),
            "atan" => math1!(f64::atan),
            "degrees" => math1!(f64::to_degrees),
            "radians" => math1!(f64::to_radians),
            "haversin" => math1!(|x: f64| (1.0 - x.cos()) / 2.0),
            "atan2" => {
                arity(2, 2)?;
                Ok(match (num(&a[0])?, num(&a[1])?) {
                    (Some(y), Some(x)) => Float(y.atan2(x)),
                    _ => Null,
                })
            }
            "pi" => {
                arity(0, 0)?;
                Ok(Float(std::f64::consts::PI))
            }
            "e" => {
                arity(0, 0)?;
                Ok(Float(std::f64::consts::E))
            }
            "rand" => {
                arity(0, 0)?;
                Ok(Float(self.rand()))
            }
            "point" => {
                arity(1, 1)?;
                match &a[0] {
                    Null => Ok(Null),
                    Map(m) => {
                        let c = |k: &str| -> R<Option<f64>> {
                            match m.get(k) {
                                None | Some(Null) => Ok(None),
                                Some(v) => v.as_f64().map(Some).ok_or_else(|| {
                                    type_err(format!("point() coordinate {k} must be a number"))
                                }),
                            }
                        };
                        match (c("x")?, c("y")?, c("z")?) {
                            (Some(x), Some(y), Some(z)) => Ok(Point3D([x, y, z])),
                            (Some(x), Some(y), None) => Ok(Point2D([x, y])),
                            _ => Err(arg_err(
                                "InvalidArgumentValue",
                                "point() needs numbers x and y (and optionally z)",
                            )),
                        }
                    }
                    o => Err(type_err(format!(
                        "point() takes a map, got {}",
                        o.type_name()
                    ))),
                }
            }
            "point.distance" | "distance" => {
                arity(2, 2)?;
                let p = |v: &Val| match v {
                    Point2D([x, y]) => Some([*x, *y, 0.0]),
                    Point3D(p) => Some(*p),
                    _ => None,
                };
                match (&a[0], &a[1]) {
                    (Null, _) | (_, Null) => Ok(Null),
                    (x, y) => match (p(x), p(y)) {
                        (Some(u), Some(v)) => Ok(Float(
                            ((u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2) + (u[2] - v[2]).powi(2))
                                .sqrt(),
                        )),
                        _ => Err(type_err("point.distance() takes two points")),
                    },
                }
            }
            "vector.similarity.cosine" | "vector.similarity.euclidean" => {
                arity(2, 2)?;
                if a[0].is_null() || a[1].is_null() {
                    return Ok(Null);
                }
                let (Some(x), Some(y)) = (a[0].as_f32s(), a[1].as_f32s()) else {
                    return Err(type_err(format!(
                        "{name}() takes two vectors or lists of numbers"
                    )));
                };
                if x.len() != y.len() || x.is_empty() {
                    return Err(arg_err(
                        "InvalidArgumentValue",
                        format!(
                            "{name}(): vectors of {} and {} dimensions",
                            x.len(),
                            y.len()
                        ),
                    ));
                }
                if lower.ends_with("cosine") {
                    let dot: f64 = x
                        .iter()
                        .zip(&y)
                        .map(|(p, q)| f64::from(*p) * f64::from(*q))
                        .sum();
                    let nx: f64 = x.iter().map(|p| f64::from(*p).powi(2)).sum::<f64>().sqrt();
                    let ny: f64 = y.iter().map(|p| f64::from(*p).powi(2)).sum::<f64>().sqrt();
                    if nx == 0.0 || ny == 0.0 {
                        return Ok(Null);
                    }
                    Ok(Float((1.0 + dot / (nx * ny)) / 2.0))
                } else {
                    let d2: f64 = x
                        .iter()
                        .zip(&y)
                        .map(|(p, q)| (f64::from(*p) - f64::from(*q)).powi(2))
                        .sum();
                    Ok(Float(1.0 / (1.0 + d2)))
                }
            }
            _ => Err(QueryError::new(
                super::ErrorKind::Syntax,
                "UnknownFunction",
                format!("unknown function {name}()"),
                None,
            )),
        }
    }
}

/// Applies a binary operator to two evaluated operands; `reserve` is asked first for the bytes
/// a concatenation will hold.
pub(crate) fn apply_op(
    op: BinOp,
    x: &Val,
    y: &Val,
    reserve: &dyn Fn(u64, &str) -> R<()>,
) -> R<Val> {
    match op {
        BinOp::And | BinOp::Or | BinOp::Xor => match op {
            BinOp::And => and3(x, y),
            BinOp::Or => {
                let (p, q) = (to_bool(x, "OR")?, to_bool(y, "OR")?);
                Ok(match (p, q) {
                    (Some(true), _) | (_, Some(true)) => Val::Bool(true),
                    (Some(false), Some(false)) => Val::Bool(false),
                    _ => Val::Null,
                })
            }
            _ => {
                let (p, q) = (to_bool(x, "XOR")?, to_bool(y, "XOR")?);
                Ok(match (p, q) {
                    (Some(p), Some(q)) => Val::Bool(p != q),
                    _ => Val::Null,
                })
            }
        },
        _ => match op {
            BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => {
                Ok(cmp_op(op, x, y))
            }
            BinOp::In => match y {
                Val::Null => Ok(Val::Null),
                Val::List(l) => {
                    let mut unknown = false;
                    for it in l {
                        match equals(x, it) {
                            Some(true) => return Ok(Val::Bool(true)),
                            None => unknown = true,
                            Some(false) => {}
                        }
                    }
                    Ok(if unknown { Val::Null } else { Val::Bool(false) })
                }
                o => Err(type_err(format!(
                    "IN expects a list, got {}",
                    o.type_name()
                ))),
            },
            BinOp::StartsWith | BinOp::EndsWith | BinOp::Contains => match (x, y) {
                (Val::Str(s), Val::Str(t)) => Ok(Val::Bool(match op {
                    BinOp::StartsWith => s.starts_with(t.as_str()),
                    BinOp::EndsWith => s.ends_with(t.as_str()),
                    _ => s.contains(t.as_str()),
                })),
                _ => Ok(Val::Null),
            },
            BinOp::Regex => match (x, y) {
                (Val::Str(s), Val::Str(p)) => {
                    let re = regex::Regex::new(&format!("^(?:{p})$")).map_err(|e| {
                        arg_err(
                            "InvalidArgumentValue",
                            format!("invalid regular expression: {e}"),
                        )
                    })?;
                    Ok(Val::Bool(re.is_match(s)))
                }
                _ => Ok(Val::Null),
            },
            _ => {
                if op == BinOp::Add {
                    reserve(concat_bytes(x, y), "a concatenation")?;
                }
                arith(op, x, y)
            }
        },
    }
}

pub(crate) fn and3(x: &Val, y: &Val) -> R<Val> {
    let (p, q) = (to_bool(x, "AND")?, to_bool(y, "AND")?);
    Ok(match (p, q) {
        (Some(false), _) | (_, Some(false)) => Val::Bool(false),
        (Some(true), Some(true)) => Val::Bool(true),
        _ => Val::Null,
    })
}

/// Names of the scalar functions, for the compile-time check.
pub(crate) const FUNCTIONS: &[&str] = &[
    "id",
    "elementid",
    "labels",
    "type",
    "keys",
    "properties",
    "startnode",
    "endnode",
    "nodes",
    "relationships",
    "length",
    "size",
    "head",
    "last",
    "tail",
    "reverse",
    "range",
    "tostring",
    "tointeger",
    "tofloat",
    "toboolean",
    "toupper",
    "tolower",
    "trim",
    "ltrim",
    "rtrim",
    "replace",
    "split",
    "substring",
    "left",
    "right",
    "abs",
    "sign",
    "ceil",
    "floor",
    "round",
    "sqrt",
    "exp",
    "log",
    "log10",
    "sin",
    "cos",
    "tan",
    "cot",
    "asin",
    "acos",
    "atan",
    "atan2",
    "degrees",
    "radians",
    "haversin",
    "pi",
    "e",
    "rand",
    "point",
    "point.distance",
    "distance",
    "vector.similarity.cosine",
    "vector.similarity.euclidean",
    "exists",
    "coalesce",
];

/// Sorts rows by keys with the ORDER BY total order.
pub(crate) fn sort_key_cmp(a: &[Val], b: &[Val], asc: &[bool]) -> std::cmp::Ordering {
    for ((x, y), up) in a.iter().zip(b).zip(asc) {
        let o = order(x, y);
        let o = if *up { o } else { o.reverse() };
        if o.is_ne() {
            return o;
        }
    }
    std::cmp::Ordering::Equal
}

pub(crate) fn dir_of(d: super::ast::Dir) -> Direction {
    match d {
        super::ast::Dir::Out => Direction::Outgoing,
        super::ast::Dir::In => Direction::Incoming,
        super::ast::Dir::Both => Direction::Both,
    }
}

/// A float's integer part as an INTEGER when it fits exactly: every float in [-2^63, 2^63)
/// truncates to an i64 (-2^63 is i64::MIN); NaN, the infinities and anything beyond are None.
fn float_to_int(f: f64) -> Option<i64> {
    let t = f.trunc();
    (-9_223_372_036_854_775_808.0..9_223_372_036_854_775_808.0)
        .contains(&t)
        .then_some(t as i64)
}

#[cfg(test)]
mod tests {
    use super::{RoundMode, round_decimal};

    #[test]
    fn round_with_precision_rounds_the_printed_decimal() {
        use RoundMode::*;
        let cases: [(f64, i64, RoundMode, f64); 18] = [
            (2.675, 2, HalfUp, 2.68),
            (1.005, 2, HalfUp, 1.01),
            (-2.5, 0, HalfUp, -3.0),
            (2.5, 0, HalfEven, 2.0),
            (3.5, 0, HalfEven, 4.0),
            (1.2345, 3, HalfDown, 1.234),
            (1.23451, 3, HalfDown, 1.235),
            (1234.5, -2, HalfUp, 1200.0),
            (1250.0, -2, HalfUp, 1300.0),
            (0.0004, 2, Up, 0.01),
            (-0.0004, 2, Ceiling, 0.0),
            (-0.0004, 2, Floor, -0.01),
            (9.999, 2, HalfUp, 10.0),
            (5.5, -1, HalfUp, 10.0),
            (4.4, -1, HalfUp, 0.0),
            (123.456, 400, HalfUp, 123.456),
            (-7.25, 1, Down, -7.2),
            (0.049, 1, HalfUp, 0.0),
        ];
        for (x, p, mode, want) in cases {
            let got = round_decimal(x, p, mode);
            assert!(
                (got - want).abs() <= 1e-12 * want.abs().max(1.0),
                "round({x}, {p}, {mode:?}) = {got}, want {want}"
            );
        }
        assert!(round_decimal(f64::NAN, 2, HalfUp).is_nan());
        assert_eq!(
            round_decimal(f64::INFINITY, 2, HalfUp).to_bits(),
            f64::INFINITY.to_bits()
        );
        assert_eq!(
            round_decimal(1e300, 2, HalfUp).to_bits(),
            1e300f64.to_bits()
        );
        assert_eq!(
            round_decimal(123.0, -1000, HalfUp).to_bits(),
            0f64.to_bits()
        );
    }
}
