//! Finds operator sequences the columnar kernel ([`super::columnar`]) can run and puts one
//! [`Columnar`] in their place, with the sequence kept inside it as its fallback.
//!
//! A sequence qualifies when it is a scan of one label with no other checks, then
//! expansions over exactly one relationship type to nodes of at most one label (no property
//! maps, no variables bound before), and filters that compare one property of a node or
//! relationship of the chain with a constant (a literal or a parameter) or test it for null;
//! and it ends in an aggregation whose keys and arguments are such properties (`count(*)`,
//! `count`, `sum`, `avg`, `min`, `max`, not DISTINCT, outputs that read only the aggregates),
//! or in a projection of plain reads and a sort on one such property with a LIMIT after it.

use super::super::Pos;
use super::super::ast::BinOp;
use super::super::source::Types;
use super::Operator;
use super::aggregate::{AggKind, Aggregate};
use super::columnar::{ChainSpec, ColRef, Columnar, Elem, Hop, Pred, PredOp, Sink};
use super::expand::Expand;
use super::expr::CExpr;
use super::filter::Filter;
use super::project::Project;
use super::scan::{NodeScan, ScanSource};
use super::sort::Sort;

/// The chain read so far: slots of its nodes and relationships.
struct Chain {
    label: u32,
    var: String,
    node_slots: Vec<usize>,
    rel_slots: Vec<usize>,
    hops: Vec<Hop>,
    preds: Vec<Pred>,
    text: Vec<String>,
}

impl Chain {
    fn elem(&self, slot: usize) -> Option<Elem> {
        if let Some(p) = self.node_slots.iter().position(|s| *s == slot) {
            return Some(Elem::Node(p));
        }
        self.rel_slots
            .iter()
            .position(|s| *s == slot)
            .map(Elem::Rel)
    }

    /// `slot.key` of a chain element as a column reference.
    fn col(&self, e: &CExpr) -> Option<ColRef> {
        let CExpr::Prop {
            base, node, rel, ..
        } = e
        else {
            return None;
        };
        let CExpr::Slot(s) = **base else { return None };
        let elem = self.elem(s)?;
        Some(ColRef {
            elem,
            handle: match elem {
                Elem::Node(_) => *node,
                Elem::Rel(_) => *rel,
            },
        })
    }

    /// A filter the kernel checks on a column.
    fn pred(&self, f: &Filter) -> Option<Pred> {
        let constant = |e: &CExpr| matches!(e, CExpr::Lit(_) | CExpr::Param(..));
        match &f.pred {
            CExpr::Bin(op, a, b)
                if matches!(
                    op,
                    BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge
                ) =>
            {
                if let (Some(c), true) = (self.col(a), constant(b)) {
                    return Some(Pred {
                        col: c,
                        op: PredOp::Cmp {
                            op: *op,
                            value: (**b).clone(),
                            flipped: false,
                        },
                    });
                }
                if let (Some(c), true) = (self.col(b), constant(a)) {
                    return Some(Pred {
                        col: c,
                        op: PredOp::Cmp {
                            op: *op,
                            value: (**a).clone(),
                            flipped: true,
                        },
                    });
                }
                None
            }
            CExpr::IsNull(x, neg) => Some(Pred {
                col: self.col(x)?,
                op: PredOp::IsNull(!*neg),
            }),
            _ => None,
        }
    }

    /// An expansion the kernel walks.
    fn hop(&self, e: &Expand) -> Option<Hop> {
        let from = self.node_slots.iter().position(|s| *s == e.from)?;
        let Types::Only(ts) = &e.types else {
            return None;
        };
        let [ty] = ts.as_slice() else { return None };
        if e.rel_bound || e.rel_props.is_some() || e.to.props.is_some() || e.to.bound {
            return None;
        }
        let to_label = match e.to.labels.as_slice() {
            [] => None,
            [Some(l)] => Some(*l),
            _ => return None,
        };
        let unique = e
            .unique
            .iter()
            .map(|s| self.rel_slots.iter().position(|r| r == s))
            .collect::<Option<Vec<_>>>()?;
        Some(Hop {
            from,
            way: e.way,
            ty: *ty,
            to_label,
            unique,
        })
    }
}

fn down<T: 'static>(op: &dyn Operator) -> Option<&T> {
    op.as_any().downcast_ref::<T>()
}

/// Replaces every sequence of `ops` the kernel runs by a [`Columnar`] (`pos` kept in step).
pub(crate) fn fuse(
    ops: Vec<Box<dyn Operator>>,
    pos: Vec<Option<Pos>>,
    slots: usize,
) -> (Vec<Box<dyn Operator>>, Vec<Option<Pos>>) {
    let mut ops: Vec<Option<Box<dyn Operator>>> = ops.into_iter().map(Some).collect();
    let mut out: Vec<Box<dyn Operator>> = Vec::new();
    let mut out_pos = Vec::new();
    let mut i = 0;
    while i < ops.len() {
        if let Some((end, spec, text)) = chain_at(&ops, i, slots) {
            let fallback: Vec<Box<dyn Operator>> =
                ops[i..end].iter_mut().filter_map(Option::take).collect();
            out.push(Box::new(Columnar::new(spec, fallback, text)));
            out_pos.push(pos[i]);
            i = end;
            continue;
        }
        if let Some(op) = ops[i].take() {
            out.push(op);
            out_pos.push(pos[i]);
        }
        i += 1;
    }
    (out, out_pos)
}

/// The chain starting at `ops[i]`, if one does: the end of the operators it replaces, its
/// spec and its text.
fn chain_at(
    ops: &[Option<Box<dyn Operator>>],
    i: usize,
    slots: usize,
) -> Option<(usize, ChainSpec, String)> {
    let op = |j: usize| ops.get(j).and_then(|o| o.as_deref());
    let scan: &NodeScan = down(op(i)?)?;
    let ScanSource::Label {
        id: Some(label),
        name,
    } = &scan.source
    else {
        return None;
    };
    if !scan.check.labels.is_empty() || scan.check.props.is_some() || scan.check.bound {
        return None;
    }
    let mut c = Chain {
        label: *label,
        var: format!("{}:{name}", scan.var),
        node_slots: vec![scan.check.slot],
        rel_slots: Vec::new(),
        hops: Vec::new(),
        preds: Vec::new(),
        text: Vec::new(),
    };
    let mut j = i + 1;
    loop {
        let o = op(j)?;
        if let Some(f) = down::<Filter>(o) {
            c.preds.push(c.pred(f)?);
            c.text.push(f.text.clone());
        } else if let Some(e) = down::<Expand>(o) {
            let h = c.hop(e)?;
            c.hops.push(h);
            c.rel_slots.push(e.rel);
            c.node_slots.push(e.to.slot);
            c.text
                .push(e.text.trim_start_matches("Expand ").to_string());
        } else {
            break;
        }
        j += 1;
    }
    let o = op(j)?;
    let describe = |c: &Chain, sink: &str| {
        format!(
            "ColumnarChain {}{}{} into {sink}",
            c.var,
            if c.text.is_empty() { "" } else { ": " },
            c.text.join(", ")
        )
    };
    if let Some(a) = down::<Aggregate>(o) {
        if a.needs_first {
            return None;
        }
        let keys = a
            .keys
            .iter()
            .map(|(e, s)| Some((c.col(e)?, *s)))
            .collect::<Option<Vec<_>>>()?;
        let aggs = a
            .aggs
            .iter()
            .map(|spec| {
                if spec.distinct {
                    return None;
                }
                match (spec.kind, spec.args.as_slice()) {
                    (AggKind::CountStar, []) => Some((spec.kind, spec.name.clone(), None)),
                    (
                        AggKind::Count | AggKind::Sum | AggKind::Avg | AggKind::Min | AggKind::Max,
                        [x],
                    ) => Some((spec.kind, spec.name.clone(), Some(c.col(x)?))),
                    _ => None,
                }
            })
            .collect::<Option<Vec<_>>>()?;
        let text = describe(&c, &a.text);
        return Some((
            j + 1,
            ChainSpec {
                label: c.label,
                node_slots: c.node_slots,
                rel_slots: c.rel_slots,
                hops: c.hops,
                preds: c.preds,
                sink: Sink::Aggregate {
                    keys,
                    aggs,
                    outputs: a.outputs.clone(),
                },
                slots,
            },
            text,
        ));
    }
    // a projection of plain reads, then a sort with a LIMIT after it
    let (proj, sort_at) = match down::<Project>(o) {
        Some(p) => (Some(p), j + 1),
        None => (None, j),
    };
    if let Some(p) = proj
        && !p
            .items
            .iter()
            .all(|(e, _)| matches!(e, CExpr::Slot(_) | CExpr::Lit(_)) || c.col(e).is_some())
    {
        return None;
    }
    let sort: &Sort = down(op(sort_at)?)?;
    let (skip, limit) = sort.top.clone()?;
    let [key] = sort.keys.as_slice() else {
        return None;
    };
    let key = match key {
        CExpr::Slot(s) => {
            let (e, _) = proj?.items.iter().find(|(_, t)| t == s)?;
            c.col(e)?
        }
        other => c.col(other)?,
    };
    let text = describe(&c, &format!("Top-{} prefilter", sort.text));
    Some((
        j,
        ChainSpec {
            label: c.label,
            node_slots: c.node_slots,
            rel_slots: c.rel_slots,
            hops: c.hops,
            preds: c.preds,
            sink: Sink::Top {
                key,
                asc: sort.asc[0],
                skip,
                limit,
            },
            slots,
        },
        text,
    ))
}
