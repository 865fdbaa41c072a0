//! Rows where a predicate holds (true; false and null drop the row).

use super::super::R;
use super::expr::CExpr;
use super::{Exec, Flow, Next, Operator, Slots};

/// Hands on the rows where `pred` is true.
#[derive(Debug)]
pub(crate) struct Filter {
    pub pred: CExpr,
    pub text: String,
}

impl Operator for Filter {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        true
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        if self.pred.holds(ex, row)? {
            next(row)
        } else {
            Ok(Flow::Go)
        }
    }

    fn describe(&self) -> String {
        format!("Filter {}", self.text)
    }
}
