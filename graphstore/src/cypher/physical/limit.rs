//! `SKIP n` and `LIMIT n` (counts checked as the interpreter checks them: constant, not
//! negative, integers).

use super::super::R;
use super::super::ast::Expr;
use super::{Exec, Flow, Next, Operator, Slots};

/// Drops the first `n` rows.
#[derive(Debug)]
pub(crate) struct Skip {
    pub count: Expr,
    pub text: String,
    /// Rows still to drop, once the count is known.
    pub left: Option<usize>,
}

impl Operator for Skip {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        self.left = None;
        true
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        let left = match self.left {
            Some(l) => l,
            None => ex.host.count_arg(&self.count, "SKIP")?.unwrap_or(0),
        };
        if left > 0 {
            self.left = Some(left - 1);
            return Ok(Flow::Go);
        }
        self.left = Some(0);
        next(row)
    }

    fn finish(&mut self, ex: &Exec<'_>, _next: &mut Next<'_>) -> R<Flow> {
        // an empty input still checks its count
        if self.left.is_none() {
            ex.host.count_arg(&self.count, "SKIP")?;
        }
        Ok(Flow::Go)
    }

    fn describe(&self) -> String {
        format!("Skip {}", self.text)
    }
}

/// Hands on at most `n` rows, then stops what feeds it.
#[derive(Debug)]
pub(crate) struct Limit {
    pub count: Expr,
    pub text: String,
    /// Rows still to hand on, once the count is known.
    pub left: Option<usize>,
}

impl Operator for Limit {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        self.left = None;
        true
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        let left = match self.left {
            Some(l) => l,
            None => ex
                .host
                .count_arg(&self.count, "LIMIT")?
                .unwrap_or(usize::MAX),
        };
        if left == 0 {
            self.left = Some(0);
            return Ok(Flow::Stop);
        }
        self.left = Some(left - 1);
        let f = next(row)?;
        Ok(if left == 1 { Flow::Stop } else { f })
    }

    fn finish(&mut self, ex: &Exec<'_>, _next: &mut Next<'_>) -> R<Flow> {
        if self.left.is_none() {
            ex.host.count_arg(&self.count, "LIMIT")?;
        }
        Ok(Flow::Go)
    }

    fn describe(&self) -> String {
        format!("Limit {}", self.text)
    }
}
