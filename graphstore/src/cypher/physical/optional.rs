//! `OPTIONAL MATCH`: the matches of the inner operators, or the row with the clause's new
//! variables null when there are none.

use super::super::R;
use super::super::value::Val;
use super::{Exec, Flow, Next, Operator, Slots, push_into};

/// Runs `inner` (streaming operators only) on each row.
#[derive(Debug)]
pub(crate) struct Optional {
    pub inner: Vec<Box<dyn Operator>>,
    /// Slots the inner operators bind.
    pub new_slots: Vec<usize>,
}

impl Operator for Optional {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        self.inner.iter_mut().all(|op| op.reset())
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        let mut matched = false;
        let mut stop = false;
        let flow = push_into(&mut self.inner, ex, row, &mut |r: &mut Slots| {
            matched = true;
            let f = next(r)?;
            stop |= f == Flow::Stop;
            Ok(f)
        })?;
        if stop || flow == Flow::Stop {
            return Ok(Flow::Stop);
        }
        if matched {
            return Ok(Flow::Go);
        }
        for s in &self.new_slots {
            row[*s] = Val::Null;
        }
        next(row)
    }

    fn describe(&self) -> String {
        "Optional".to_string()
    }

    fn inner(&self) -> &[Box<dyn Operator>] {
        &self.inner
    }

    fn profile_inner(&mut self) {
        self.inner = super::profile_ops(std::mem::take(&mut self.inner));
    }
}
