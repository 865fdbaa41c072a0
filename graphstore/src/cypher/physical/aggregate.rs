//! Grouping and aggregation: one output row per distinct combination of the grouping keys,
//! with running accumulators (`count`, `sum`, `avg`, `min`, `max`, `collect` hold a number or
//! a running value, not every input), in the order the groups were first seen.
//!
//! The results are the interpreter's: the same null, DISTINCT and type rules, sums added in
//! input order, `stdev` and the percentiles computed by the interpreter's own `aggregate`
//! from the values kept.

use std::collections::HashSet;

use hashbrown::{DefaultHashBuilder, HashTable};

use super::super::R;
use super::super::eval::{arg_err, type_err};
use super::super::exec::aggregate;
use super::super::value::{Val, order};
use super::distinct::{GroupKey, hash_vals, same_vals};
use super::expr::CExpr;
use super::{Exec, Flow, Next, Operator, Slots};

/// Which aggregate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum AggKind {
    CountStar,
    Count,
    Sum,
    Avg,
    Min,
    Max,
    Collect,
    /// stdev, stdevp, percentileDisc, percentileCont: values kept, computed at the end.
    Kept,
}

impl AggKind {
    pub(crate) fn of(name: &str) -> AggKind {
        match name {
            "count*" => AggKind::CountStar,
            "count" => AggKind::Count,
            "sum" => AggKind::Sum,
            "avg" => AggKind::Avg,
            "min" => AggKind::Min,
            "max" => AggKind::Max,
            "collect" => AggKind::Collect,
            _ => AggKind::Kept,
        }
    }
}

/// One aggregate call.
#[derive(Debug, Clone)]
pub(crate) struct AggSpec {
    pub kind: AggKind,
    /// Lower-case name.
    pub name: String,
    pub distinct: bool,
    pub args: Vec<CExpr>,
}

/// A running aggregate.
#[derive(Debug, Clone)]
enum Acc {
    Count(i64),
    Sum {
        int: Option<i64>,
        all_int: bool,
        float: f64,
        bad: Option<&'static str>,
    },
    Avg {
        sum: f64,
        n: u64,
        bad: Option<&'static str>,
    },
    Best(Option<Val>),
    Vals(Vec<Val>),
}

impl Acc {
    fn new(kind: AggKind) -> Acc {
        match kind {
            AggKind::CountStar | AggKind::Count => Acc::Count(0),
            // a float sum starts from -0.0, as Rust's `Sum` of floats does
            AggKind::Sum => Acc::Sum {
                int: Some(0),
                all_int: true,
                float: -0.0,
                bad: None,
            },
            AggKind::Avg => Acc::Avg {
                sum: -0.0,
                n: 0,
                bad: None,
            },
            AggKind::Min | AggKind::Max => Acc::Best(None),
            AggKind::Collect | AggKind::Kept => Acc::Vals(Vec::new()),
        }
    }

    /// Adds one (non-null, already DISTINCT-filtered) input.
    fn add(&mut self, kind: AggKind, v: Val) {
        match self {
            Acc::Count(n) => *n += 1,
            Acc::Sum {
                int,
                all_int,
                float,
                bad,
            } => {
                if let Val::Int(i) = v {
                    *int = int.and_then(|s| s.checked_add(i));
                } else {
                    *all_int = false;
                }
                match v.as_f64() {
                    Some(f) => *float += f,
                    None => {
                        if bad.is_none() {
                            *bad = Some(v.type_name());
                        }
                    }
                }
            }
            Acc::Avg { sum, n, bad } => {
                *n += 1;
                match v.as_f64() {
                    Some(f) => *sum += f,
                    None => {
                        if bad.is_none() {
                            *bad = Some(v.type_name());
                        }
                    }
                }
            }
            Acc::Best(best) => {
                let better = match best {
                    None => true,
                    Some(b) => {
                        let o = order(&v, b);
                        if kind == AggKind::Min {
                            o.is_lt()
                        } else {
                            o.is_gt()
                        }
                    }
                };
                if better {
                    *best = Some(v);
                }
            }
            Acc::Vals(vals) => vals.push(v),
        }
    }

    fn finish(self, spec: &AggSpec) -> R<Val> {
        let name = &spec.name;
        Ok(match self {
            Acc::Count(n) => Val::Int(n),
            Acc::Sum {
                int,
                all_int,
                float,
                bad,
            } => {
                if all_int {
                    Val::Int(int.ok_or_else(|| arg_err("NumberOutOfRange", "sum() overflowed"))?)
                } else if let Some(t) = bad {
                    return Err(type_err(format!("{name}() needs numbers, got {t}")));
                } else {
                    Val::Float(float)
                }
            }
            Acc::Avg { sum, n, bad } => {
                if n == 0 {
                    Val::Null
                } else if let Some(t) = bad {
                    return Err(type_err(format!("{name}() needs numbers, got {t}")));
                } else {
                    Val::Float(sum / n as f64)
                }
            }
            Acc::Best(b) => b.unwrap_or(Val::Null),
            Acc::Vals(vals) => match spec.kind {
                AggKind::Collect => Val::List(vals),
                _ => aggregate(name, spec.distinct, vals)?,
            },
        })
    }
}

/// One group: the first row it saw (for outputs that read grouping keys through it), its key
/// values and its accumulators (with, for DISTINCT aggregates, the inputs seen).
#[derive(Debug)]
struct Group {
    first: Option<Slots>,
    keys: Vec<Val>,
    accs: Vec<Acc>,
    seen: Vec<Option<HashSet<GroupKey>>>,
}

/// Groups its input and hands on one row per group when the input ends.
#[derive(Debug)]
pub(crate) struct Aggregate {
    pub keys: Vec<(CExpr, usize)>,
    pub aggs: Vec<AggSpec>,
    /// Items holding aggregates, over [`CExpr::Agg`] and the group's first row.
    pub outputs: Vec<(CExpr, usize)>,
    /// Whether the outputs read the group's first row (not only aggregates).
    pub needs_first: bool,
    pub slots: usize,
    pub text: String,
    /// Group indexes into `list`, by the hash of their keys.
    groups: HashTable<usize>,
    hasher: DefaultHashBuilder,
    list: Vec<Group>,
    /// This row's key values (reused).
    keybuf: Vec<Val>,
}

impl Aggregate {
    pub(crate) fn new(
        keys: Vec<(CExpr, usize)>,
        aggs: Vec<AggSpec>,
        outputs: Vec<(CExpr, usize)>,
        needs_first: bool,
        slots: usize,
        text: String,
    ) -> Aggregate {
        Aggregate {
            keys,
            aggs,
            outputs,
            needs_first,
            slots,
            text,
            groups: HashTable::new(),
            hasher: DefaultHashBuilder::default(),
            list: Vec::new(),
            keybuf: Vec::new(),
        }
    }

    fn fresh(&self, keys: Vec<Val>, first: Option<Slots>) -> Group {
        Group {
            first,
            keys,
            accs: self.aggs.iter().map(|a| Acc::new(a.kind)).collect(),
            seen: self
                .aggs
                .iter()
                .map(|a| {
                    (a.distinct && a.kind != AggKind::Kept && a.kind != AggKind::CountStar)
                        .then(HashSet::new)
                })
                .collect(),
        }
    }
}

impl Operator for Aggregate {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, _next: &mut Next<'_>) -> R<Flow> {
        ex.host.tick()?;
        let mut key = std::mem::take(&mut self.keybuf);
        key.clear();
        for (e, _) in &self.keys {
            key.push(e.eval(ex, row, &[])?);
        }
        let h = hash_vals(&key, &self.hasher);
        let list = &self.list;
        let found = if key.is_empty() && !list.is_empty() {
            // no grouping keys: one group
            Some(&0)
        } else {
            self.groups.find(h, |&g| same_vals(&list[g].keys, &key))
        };
        let gi = match found {
            Some(&gi) => {
                self.keybuf = key;
                gi
            }
            None => {
                let first = self.needs_first.then(|| row.clone());
                let g = self.fresh(key, first);
                self.list.push(g);
                let gi = self.list.len() - 1;
                let (list, hasher) = (&self.list, &self.hasher);
                self.groups
                    .insert_unique(h, gi, |&g| hash_vals(&list[g].keys, hasher));
                ex.host.room(self.list.len())?;
                gi
            }
        };
        let g = &mut self.list[gi];
        for (ai, spec) in self.aggs.iter().enumerate() {
            if spec.kind == AggKind::CountStar {
                if let Acc::Count(n) = &mut g.accs[ai] {
                    *n += 1;
                }
                continue;
            }
            let v = match spec.args.as_slice() {
                [a] => a.eval(ex, row, &[])?,
                args => Val::List(
                    args.iter()
                        .map(|a| a.eval(ex, row, &[]))
                        .collect::<R<Vec<_>>>()?,
                ),
            };
            if spec.kind == AggKind::Kept {
                // the interpreter's aggregate() filters nulls and DISTINCT itself
                g.accs[ai].add(spec.kind, v);
                continue;
            }
            if v.is_null() {
                continue;
            }
            if let Some(seen) = &mut g.seen[ai]
                && !seen.insert(GroupKey(vec![v.clone()]))
            {
                continue;
            }
            g.accs[ai].add(spec.kind, v);
        }
        Ok(Flow::Go)
    }

    fn finish(&mut self, ex: &Exec<'_>, next: &mut Next<'_>) -> R<Flow> {
        if self.list.is_empty() && self.keys.is_empty() {
            let g = self.fresh(Vec::new(), Some(vec![Val::Null; self.slots]));
            self.list.push(g);
        }
        self.groups.clear();
        for g in std::mem::take(&mut self.list) {
            let aggs = g
                .accs
                .into_iter()
                .zip(&self.aggs)
                .map(|(acc, spec)| acc.finish(spec))
                .collect::<R<Vec<_>>>()?;
            let first = g.first.unwrap_or_else(|| vec![Val::Null; self.slots]);
            let mut out = vec![Val::Null; self.slots];
            for (v, (_, s)) in g.keys.into_iter().zip(&self.keys) {
                out[*s] = v;
            }
            for (e, s) in &self.outputs {
                out[*s] = e.eval(ex, &first, &aggs)?;
            }
            if next(&mut out)? == Flow::Stop {
                return Ok(Flow::Stop);
            }
        }
        Ok(Flow::Go)
    }

    fn describe(&self) -> String {
        self.text.clone()
    }
}
