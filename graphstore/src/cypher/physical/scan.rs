//! Where a pattern's first node comes from: a node bound earlier, a property index (equality
//! or range), every node of a label, or every node.

use super::super::R;
use super::super::eval::type_err;
use super::super::value::Val;
use super::expr::CExpr;
use super::node_check::NodeCheck;
use super::{Exec, Flow, Next, Operator, Slots};
use crate::{Value, ValueBound};

/// The candidates of a scan.
#[derive(Debug)]
pub(crate) enum ScanSource {
    /// The node in the check's slot, bound earlier (`name` for errors).
    Argument { name: String },
    /// Every node of a label (`None`: a label the store never saw).
    Label { id: Option<u32>, name: String },
    /// Every node.
    All,
    /// `label.key = value` through the property index.
    IndexEq {
        label: String,
        key: String,
        value: CExpr,
        shown: String,
    },
    /// `label.key` in a range through the property index.
    IndexRange {
        label: String,
        key: String,
        lower: Option<(CExpr, bool)>,
        upper: Option<(CExpr, bool)>,
        shown: String,
    },
}

/// Binds each candidate that passes its node's checks and hands the row on.
#[derive(Debug)]
pub(crate) struct NodeScan {
    pub source: ScanSource,
    pub check: NodeCheck,
    /// The variable's name and labels, for EXPLAIN.
    pub var: String,
    pub labels: Vec<String>,
}

fn bound_of(ex: &Exec<'_>, b: &Option<(CExpr, bool)>, row: &Slots) -> R<Option<ValueBound>> {
    Ok(match b {
        None => Some(ValueBound::Unbounded),
        Some((e, incl)) => {
            let v = match e.eval(ex, row, &[])?.to_value() {
                Some(Value::Int(i)) => Value::Int(i),
                Some(Value::Float(f)) if f.is_finite() => Value::Float(f),
                Some(Value::String(s)) => Value::String(s),
                _ => return Ok(None),
            };
            Some(if *incl {
                ValueBound::Inclusive(v)
            } else {
                ValueBound::Exclusive(v)
            })
        }
    })
}

impl NodeScan {
    fn each(&self, ex: &Exec<'_>, ids: &[u64], row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        for &id in ids {
            ex.host.tick()?;
            if self.check.check(ex, id, row)? && next(row)? == Flow::Stop {
                return Ok(Flow::Stop);
            }
        }
        Ok(Flow::Go)
    }
}

impl Operator for NodeScan {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        true
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        match &self.source {
            ScanSource::Argument { name } => match row[self.check.slot] {
                Val::Node(id) => self.each(ex, &[id], row, next),
                Val::Null => Ok(Flow::Go),
                ref other => Err(type_err(format!(
                    "`{name}` is a {}, not a node",
                    other.type_name()
                ))),
            },
            ScanSource::Label { id: None, .. } => Ok(Flow::Go),
            ScanSource::Label { id: Some(l), .. } => {
                let members = ex.src.label_nodes(*l)?;
                self.each(ex, &members.ids, row, next)
            }
            ScanSource::All => {
                let ids = ex.src.all_nodes()?;
                self.each(ex, &ids, row, next)
            }
            ScanSource::IndexEq {
                label, key, value, ..
            } => {
                let ids = match value.eval(ex, row, &[])?.to_value() {
                    Some(Value::Null) | None => Vec::new(),
                    Some(v) => ex.src.index_eq(label, key, &v)?,
                };
                self.each(ex, &ids, row, next)
            }
            ScanSource::IndexRange {
                label,
                key,
                lower,
                upper,
                ..
            } => {
                let ids = match (bound_of(ex, lower, row)?, bound_of(ex, upper, row)?) {
                    (Some(lo), Some(hi)) => ex.src.index_range(label, key, lo, hi)?,
                    _ => Vec::new(),
                };
                self.each(ex, &ids, row, next)
            }
        }
    }

    fn describe(&self) -> String {
        let v = &self.var;
        let labels = self.check.describe(&self.labels);
        match &self.source {
            ScanSource::Argument { .. } => format!("Argument {v}{labels} (bound earlier)"),
            ScanSource::Label { name, .. } => format!("NodeByLabelScan {v}:{name}{labels}"),
            ScanSource::All => format!("AllNodesScan {v}{labels}"),
            ScanSource::IndexEq {
                label, key, shown, ..
            } => format!("NodeIndexSeek {v}:{label}({key} = {shown}){labels}"),
            ScanSource::IndexRange {
                label, key, shown, ..
            } => format!("NodeIndexRangeScan {v}:{label}({key}{shown}){labels}"),
        }
    }
}
