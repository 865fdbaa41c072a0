//! What a node must be to stand at one place of a pattern: its labels, its property map, and
//! (for a variable bound before) the node bound.

use super::super::R;
use super::super::eval::type_err;
use super::super::value::{Val, equals};
use super::expr::CExpr;
use super::{Exec, Slots};

/// A pattern's property map.
#[derive(Debug, Clone)]
pub(crate) enum PropsCheck {
    /// `{k: expr, ...}`: per key, its read handle and the value it must equal.
    Keys(Vec<(String, usize, CExpr)>),
    /// Any other expression: must give a map (or null, which asks nothing).
    Dynamic(CExpr),
}

/// The checks of one pattern node, applied to a candidate id; binds it into its slot.
#[derive(Debug, Clone)]
pub(crate) struct NodeCheck {
    pub slot: usize,
    /// Labels to check (`None`: a label the store never saw).
    pub labels: Vec<Option<u32>>,
    pub props: Option<PropsCheck>,
    /// The slot was bound before: the candidate must be that node.
    pub bound: bool,
}

impl NodeCheck {
    /// Whether node `id` fits; on success its slot holds it.
    #[inline]
    pub(crate) fn check(&self, ex: &Exec<'_>, id: u64, row: &mut Slots) -> R<bool> {
        if self.bound && !matches!(row[self.slot], Val::Node(b) if b == id) {
            return Ok(false);
        }
        for l in &self.labels {
            match l {
                Some(l) if ex.src.has_label(id, *l)? => {}
                _ => return Ok(false),
            }
        }
        if let Some(p) = &self.props
            && !props_hold(ex, p, row, |ex, key, h| {
                let h = match h {
                    Some(h) => h,
                    None => ex.src.node_prop_handle(ex.src.key_id(key)),
                };
                ex.src.node_prop(id, h)
            })?
        {
            return Ok(false);
        }
        if !self.bound {
            row[self.slot] = Val::Node(id);
        }
        Ok(true)
    }

    /// Its text in plans: ` :A:B {…}`.
    pub(crate) fn describe(&self, names: &[String]) -> String {
        let mut s = String::new();
        for n in names {
            s.push(':');
            s.push_str(n);
        }
        if self.props.is_some() {
            s.push_str(" {…}");
        }
        s
    }
}

/// Whether an element's properties (read through `get`: key, handle when known) match a
/// pattern's property map, as the interpreter's `props_match` decides: every key equal (a
/// null on either side is no match).
pub(crate) fn props_hold(
    ex: &Exec<'_>,
    p: &PropsCheck,
    row: &Slots,
    get: impl Fn(&Exec<'_>, &str, Option<usize>) -> R<Val>,
) -> R<bool> {
    match p {
        PropsCheck::Keys(keys) => {
            // the interpreter evaluates the whole map before comparing
            let mut want = Vec::with_capacity(keys.len());
            for (_, _, e) in keys {
                want.push(e.eval_cow(ex, row, &[])?);
            }
            for ((k, h, _), w) in keys.iter().zip(&want) {
                let have = get(ex, k, Some(*h))?;
                if equals(&have, w) != Some(true) {
                    return Ok(false);
                }
            }
            Ok(true)
        }
        PropsCheck::Dynamic(e) => match e.eval(ex, row, &[])? {
            Val::Null => Ok(true),
            Val::Map(m) => {
                for (k, w) in &m {
                    let have = get(ex, k, None)?;
                    if equals(&have, w) != Some(true) {
                        return Ok(false);
                    }
                }
                Ok(true)
            }
            o => Err(type_err(format!(
                "a pattern's properties must be a map, got {}",
                o.type_name()
            ))),
        },
    }
}
