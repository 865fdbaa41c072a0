//! The result: each row's output slots, in order.

use std::cell::RefCell;
use std::rc::Rc;

use super::super::R;
use super::super::value::Val;
use super::{Exec, Flow, Next, Operator, Slots};

/// Keeps each row's `slots` as a result row.
#[derive(Debug)]
pub(crate) struct Produce {
    pub slots: Vec<usize>,
    pub rows: Rc<RefCell<Vec<Vec<Val>>>>,
    pub columns: Vec<String>,
}

impl Operator for Produce {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        true
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        let n = {
            let mut rows = self.rows.borrow_mut();
            rows.push(self.slots.iter().map(|s| row[*s].clone()).collect());
            rows.len()
        };
        ex.host.room(n)?;
        // nothing follows; PROFILE counts the rows produced here
        next(row)
    }

    fn describe(&self) -> String {
        format!("ProduceResults {}", self.columns.join(", "))
    }
}
