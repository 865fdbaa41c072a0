//! `UNWIND list AS x`: one row per element (none for null; a non-list is one element).

use super::super::R;
use super::super::value::Val;
use super::expr::CExpr;
use super::{Exec, Flow, Next, Operator, Slots};

/// One row per element of `expr`, the element in `slot`.
#[derive(Debug)]
pub(crate) struct Unwind {
    pub expr: CExpr,
    pub slot: usize,
    pub text: String,
}

impl Operator for Unwind {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        true
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        match self.expr.eval(ex, row, &[])? {
            Val::Null => Ok(Flow::Go),
            Val::List(items) => {
                for it in items {
                    ex.host.tick()?;
                    row[self.slot] = it;
                    if next(row)? == Flow::Stop {
                        return Ok(Flow::Stop);
                    }
                }
                Ok(Flow::Go)
            }
            other => {
                row[self.slot] = other;
                next(row)
            }
        }
    }

    fn describe(&self) -> String {
        format!("Unwind {}", self.text)
    }
}
