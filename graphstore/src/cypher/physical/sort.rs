//! `ORDER BY`: a stable sort of the rows by their keys, or with a `LIMIT` after it only the
//! best `SKIP + LIMIT` rows kept while they come (a top-k).

use super::super::R;
use super::super::ast::Expr;
use super::super::eval::sort_key_cmp;
use super::super::value::Val;
use super::expr::CExpr;
use super::{Exec, Flow, Next, Operator, Slots};

/// Holds every row with its sort keys; hands them on sorted when the input ends.
#[derive(Debug)]
pub(crate) struct Sort {
    pub keys: Vec<CExpr>,
    pub asc: Vec<bool>,
    pub text: String,
    /// With a LIMIT after it: the counts (SKIP, LIMIT) that bound the rows kept.
    pub top: Option<(Option<Expr>, Expr)>,
    /// Rows kept at most, once the counts are known.
    pub keep: Option<usize>,
    pub rows: Vec<(Vec<Val>, Slots)>,
}

impl Sort {
    fn cut(&mut self, keep: usize) {
        let asc = &self.asc;
        // stable: ties keep their arrival order, as the full sort would
        self.rows.sort_by(|a, b| sort_key_cmp(&a.0, &b.0, asc));
        self.rows.truncate(keep);
    }
}

impl Operator for Sort {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, _next: &mut Next<'_>) -> R<Flow> {
        ex.host.tick()?;
        if self.keep.is_none()
            && let Some((skip, limit)) = &self.top
        {
            let s = match skip {
                Some(s) => ex.host.count_arg(s, "SKIP")?.unwrap_or(0),
                None => 0,
            };
            let l = ex.host.count_arg(limit, "LIMIT")?.unwrap_or(usize::MAX);
            self.keep = Some(s.saturating_add(l));
        }
        if self.keep == Some(0) {
            return Ok(Flow::Go);
        }
        let keys = self
            .keys
            .iter()
            .map(|k| k.eval(ex, row, &[]))
            .collect::<R<Vec<_>>>()?;
        self.rows.push((keys, row.clone()));
        ex.host.room(self.rows.len())?;
        if let Some(k) = self.keep
            && self.rows.len() >= k.saturating_mul(2).max(64)
        {
            self.cut(k);
        }
        Ok(Flow::Go)
    }

    fn finish(&mut self, _ex: &Exec<'_>, next: &mut Next<'_>) -> R<Flow> {
        self.cut(self.keep.unwrap_or(usize::MAX));
        for (_, mut row) in std::mem::take(&mut self.rows) {
            if next(&mut row)? == Flow::Stop {
                return Ok(Flow::Stop);
            }
        }
        Ok(Flow::Go)
    }

    fn describe(&self) -> String {
        match &self.top {
            Some(_) => format!("Top {}", self.text),
            None => format!("Sort {}", self.text),
        }
    }
}
