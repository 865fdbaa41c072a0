//! `DISTINCT`: the first row of each combination of values, and the hashed grouping key that
//! aggregation shares.

use std::collections::HashSet;
use std::hash::{Hash, Hasher};

use super::super::R;
use super::super::value::{Val, order};
use super::{Exec, Flow, Next, Operator, Slots};

/// Values compared as grouping and `DISTINCT` compare them ([`order`] equality: 1 and 1.0
/// are one, nulls are one, NaNs are one), with a hash that agrees.
#[derive(Debug, Clone)]
pub(crate) struct GroupKey(pub Vec<Val>);

impl PartialEq for GroupKey {
    fn eq(&self, o: &Self) -> bool {
        self.0.len() == o.0.len()
            && self
                .0
                .iter()
                .zip(&o.0)
                .all(|(a, b)| order(a, b) == std::cmp::Ordering::Equal)
    }
}
impl Eq for GroupKey {}

impl Hash for GroupKey {
    fn hash<H: Hasher>(&self, h: &mut H) {
        for v in &self.0 {
            hash_val(v, h);
        }
    }
}

/// The hash of a row of grouping values, consistent with [`GroupKey`]'s equality.
pub(crate) fn hash_vals(vals: &[Val], b: &impl std::hash::BuildHasher) -> u64 {
    let mut h = b.build_hasher();
    for v in vals {
        hash_val(v, &mut h);
    }
    h.finish()
}

/// Whether two rows of grouping values are one group.
pub(crate) fn same_vals(a: &[Val], b: &[Val]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| order(x, y) == std::cmp::Ordering::Equal)
}

/// A number's hash: an integral float hashes as the integer it equals.
fn hash_num<H: Hasher>(v: &Val, h: &mut H) {
    match v {
        Val::Int(i) => {
            0u8.hash(h);
            i.hash(h);
        }
        Val::Float(f) if f.is_nan() => 1u8.hash(h),
        Val::Float(f) => {
            // -2^63 <= f < 2^63 and integral: the integer it equals
            if f.fract() == 0.0 && *f >= i64::MIN as f64 && *f < -(i64::MIN as f64) {
                0u8.hash(h);
                (*f as i64).hash(h);
            } else {
                2u8.hash(h);
                f.to_bits().hash(h);
            }
        }
        _ => {}
    }
}

/// Hashes a value consistently with [`order`] equality.
pub(crate) fn hash_val<H: Hasher>(v: &Val, h: &mut H) {
    match v {
        Val::Null => 10u8.hash(h),
        Val::Bool(b) => {
            11u8.hash(h);
            b.hash(h);
        }
        Val::Int(_) | Val::Float(_) => {
            12u8.hash(h);
            hash_num(v, h);
        }
        Val::Str(s) => {
            13u8.hash(h);
            s.hash(h);
        }
        Val::List(l) => {
            14u8.hash(h);
            l.len().hash(h);
            for x in l {
                hash_val(x, h);
            }
        }
        Val::Vector(l) => {
            14u8.hash(h);
            l.len().hash(h);
            for x in l {
                hash_val(&Val::Float(f64::from(*x)), h);
            }
        }
        Val::Map(m) => {
            15u8.hash(h);
            m.len().hash(h);
            for (k, x) in m {
                k.hash(h);
                hash_val(x, h);
            }
        }
        Val::Node(i) => {
            16u8.hash(h);
            i.hash(h);
        }
        Val::Rel(i) => {
            17u8.hash(h);
            i.hash(h);
        }
        Val::Path { nodes, rels } => {
            18u8.hash(h);
            nodes.hash(h);
            rels.hash(h);
        }
        Val::Point2D(p) => {
            19u8.hash(h);
            for x in p {
                x.to_bits().hash(h);
            }
        }
        Val::Point3D(p) => {
            20u8.hash(h);
            for x in p {
                x.to_bits().hash(h);
            }
        }
        Val::Bytes(b) => {
            21u8.hash(h);
            b.hash(h);
        }
    }
}

/// Hands on the first row of each distinct combination of `slots`.
#[derive(Debug)]
pub(crate) struct Distinct {
    pub slots: Vec<usize>,
    pub seen: HashSet<GroupKey>,
}

impl Operator for Distinct {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn push(&mut self, ex: &Exec<'_>, row: &mut Slots, next: &mut Next<'_>) -> R<Flow> {
        let key = GroupKey(self.slots.iter().map(|s| row[*s].clone()).collect());
        if !self.seen.insert(key) {
            return Ok(Flow::Go);
        }
        ex.host.room(self.seen.len())?;
        next(row)
    }

    fn describe(&self) -> String {
        "Distinct".to_string()
    }
}
