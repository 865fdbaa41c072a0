//! Values computed into slots: a projection's items, and a pattern's path value.

use super::super::R;
use super::super::value::Val;
use super::expr::CExpr;
use super::{Exec, Flow, Next, Operator, Slots};

/// Evaluates each item on the row (all before any is written), then writes it to its slot.
#[derive(Debug)]
pub(crate) struct Project {
    pub items: Vec<(CExpr, usize)>,
    pub text: String,
    pub vals: Vec<Val>,
}

impl Operator for Project {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        self.vals.clear();
        true
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        ex.host.tick()?;
        let mut vals = std::mem::take(&mut self.vals);
        vals.clear();
        for (e, _) in &self.items {
            vals.push(e.eval(ex, row, &[])?);
        }
        for ((_, s), v) in self.items.iter().zip(vals.drain(..)) {
            row[*s] = v;
        }
        self.vals = vals;
        next(row)
    }

    fn describe(&self) -> String {
        format!("Projection {}", self.text)
    }
}

/// Puts a pattern's path (its node and relationship slots, in order) into the path slot.
#[derive(Debug)]
pub(crate) struct SetPath {
    pub slot: usize,
    pub nodes: Vec<usize>,
    pub rels: Vec<usize>,
    pub name: String,
}

impl Operator for SetPath {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        true
    }

    fn push(&mut self, _ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        let id = |v: &Val| match v {
            Val::Node(i) | Val::Rel(i) => *i,
            _ => u64::MAX,
        };
        row[self.slot] = Val::Path {
            nodes: self.nodes.iter().map(|s| id(&row[*s])).collect(),
            rels: self.rels.iter().map(|s| id(&row[*s])).collect(),
        };
        next(row)
    }

    fn describe(&self) -> String {
        format!("ProjectPath {}", self.name)
    }
}
