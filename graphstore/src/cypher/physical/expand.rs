//! One relationship of a pattern: from a bound node, every relationship of the allowed types
//! and direction to a node that passes the far end's checks.

use super::super::R;
use super::super::source::{Types, Way};
use super::super::value::Val;
use super::node_check::{NodeCheck, PropsCheck, props_hold};
use super::{Exec, Flow, Next, Operator, Slots};

/// Expands from the node in `from` along one relationship pattern.
#[derive(Debug)]
pub(crate) struct Expand {
    pub from: usize,
    pub rel: usize,
    /// The relationship's variable was bound before: only that relationship is taken.
    pub rel_bound: bool,
    pub way: Way,
    pub types: Types,
    pub rel_props: Option<PropsCheck>,
    /// Relationship slots bound earlier in the same MATCH: a relationship is used once.
    pub unique: Vec<usize>,
    pub to: NodeCheck,
    /// EXPLAIN's text: `Expand (a:A)-[:T]->(b)`.
    pub text: String,
    pub buf: Vec<(u64, u64)>,
}

impl Expand {
    /// Whether relationship `rid` may stand here in `row` (its uniqueness, properties and
    /// variable); on success its slot holds it.
    #[inline]
    fn rel_fits(&self, ex: &Exec<'_>, rid: u64, row: &mut Slots) -> R<bool> {
        if self
            .unique
            .iter()
            .any(|s| matches!(row[*s], Val::Rel(r) if r == rid))
        {
            return Ok(false);
        }
        if let Some(p) = &self.rel_props
            && !props_hold(ex, p, row, |ex, key, h| {
                let h = match h {
                    Some(h) => h,
                    None => ex.src.rel_prop_handle(ex.src.key_id(key)),
                };
                ex.src.rel_prop(rid, h)
            })?
        {
            return Ok(false);
        }
        if self.rel_bound {
            return Ok(matches!(row[self.rel], Val::Rel(b) if b == rid));
        }
        row[self.rel] = Val::Rel(rid);
        Ok(true)
    }
}

impl Operator for Expand {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reset(&mut self) -> bool {
        // a hub's expansion is not held on to between runs
        if self.buf.capacity() > 256 {
            self.buf = Vec::new();
        }
        true
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        let Val::Node(from) = row[self.from] else {
            return Ok(Flow::Go);
        };
        let mut buf = std::mem::take(&mut self.buf);
        buf.clear();
        ex.src.expand(from, self.way, &self.types, &mut buf)?;
        let mut flow = Flow::Go;
        for &(rid, other) in &buf {
            ex.host.tick()?;
            if !self.rel_fits(ex, rid, row)? || !self.to.check(ex, other, row)? {
                continue;
            }
            if next(row)? == Flow::Stop {
                flow = Flow::Stop;
                break;
            }
        }
        self.buf = buf;
        Ok(flow)
    }

    fn describe(&self) -> String {
        self.text.clone()
    }
}
