//! Runtime values of the Cypher engine: store values plus nodes, relationships and paths.

use std::cmp::Ordering;
use std::collections::BTreeMap;

use crate::Value;

/// A value produced by a query.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Val {
    /// null
    #[default]
    Null,
    /// A boolean.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A float.
    Float(f64),
    /// A string.
    Str(String),
    /// A list.
    List(Vec<Val>),
    /// A map.
    Map(BTreeMap<String, Val>),
    /// A node, by id.
    Node(u64),
    /// A relationship, by id.
    Rel(u64),
    /// A path: `nodes.len() == rels.len() + 1`.
    Path {
        /// The nodes in order.
        nodes: Vec<u64>,
        /// The relationships in order.
        rels: Vec<u64>,
    },
    /// A 2D point.
    Point2D([f64; 2]),
    /// A 3D point.
    Point3D([f64; 3]),
    /// A dense vector.
    Vector(Vec<f32>),
    /// Bytes.
    Bytes(Vec<u8>),
}

impl Val {
    /// About the bytes this value holds, its own slot included (for size limits on answers).
    pub fn approx_bytes(&self) -> u64 {
        let slot = std::mem::size_of::<Val>() as u64;
        slot + match self {
            Val::Str(s) => s.len() as u64,
            Val::List(l) => l.iter().map(Val::approx_bytes).sum(),
            Val::Map(m) => m
                .iter()
                .map(|(k, v)| k.len() as u64 + 48 + v.approx_bytes())
                .sum(),
            Val::Path { nodes, rels } => 8 * (nodes.len() + rels.len()) as u64,
            Val::Vector(v) => 4 * v.len() as u64,
            Val::Bytes(b) => b.len() as u64,
            _ => 0,
        }
    }
}

impl From<Value> for Val {
    fn from(v: Value) -> Val {
        match v {
            Value::Null => Val::Null,
            Value::Bool(b) => Val::Bool(b),
            Value::Int(i) => Val::Int(i),
            Value::Float(f) => Val::Float(f),
            Value::String(s) => Val::Str(s),
            Value::List(l) => Val::List(l.into_iter().map(Val::from).collect()),
            Value::Map(m) => Val::Map(m.into_iter().map(|(k, v)| (k, Val::from(v))).collect()),
            Value::Point2D(p) => Val::Point2D(p),
            Value::Point3D(p) => Val::Point3D(p),
            Value::Vector(v) => Val::Vector(v),
            Value::Bytes(b) => Val::Bytes(b),
        }
    }
}

impl Val {
    /// The type name used in error messages.
    pub fn type_name(&self) -> &'static str {
        match self {
            Val::Null => "Null",
            Val::Bool(_) => "Boolean",
            Val::Int(_) => "Integer",
            Val::Float(_) => "Float",
            Val::Str(_) => "String",
            Val::List(_) => "List",
            Val::Map(_) => "Map",
            Val::Node(_) => "Node",
            Val::Rel(_) => "Relationship",
            Val::Path { .. } => "Path",
            Val::Point2D(_) | Val::Point3D(_) => "Point",
            Val::Vector(_) => "Vector",
            Val::Bytes(_) => "Bytes",
        }
    }

    /// Converts to a storable value; None for graph elements (which cannot be stored).
    pub fn to_value(&self) -> Option<Value> {
        Some(match self {
            Val::Null => Value::Null,
            Val::Bool(b) => Value::Bool(*b),
            Val::Int(i) => Value::Int(*i),
            Val::Float(f) => Value::Float(*f),
            Val::Str(s) => Value::String(s.clone()),
            Val::List(l) => Value::List(l.iter().map(Val::to_value).collect::<Option<_>>()?),
            Val::Map(m) => Value::Map(
                m.iter()
                    .map(|(k, v)| Some((k.clone(), v.to_value()?)))
                    .collect::<Option<_>>()?,
            ),
            Val::Point2D(p) => Value::Point2D(*p),
            Val::Point3D(p) => Value::Point3D(*p),
            Val::Vector(v) => Value::Vector(v.clone()),
            Val::Bytes(b) => Value::Bytes(b.clone()),
            Val::Node(_) | Val::Rel(_) | Val::Path { .. } => return None,
        })
    }

    pub(crate) fn as_f64(&self) -> Option<f64> {
        match self {
            Val::Int(i) => Some(*i as f64),
            Val::Float(f) => Some(*f),
            _ => None,
        }
    }

    pub(crate) fn is_null(&self) -> bool {
        matches!(self, Val::Null)
    }

    /// A vector view of a list of numbers or a vector.
    pub(crate) fn as_f32s(&self) -> Option<Vec<f32>> {
        match self {
            Val::Vector(v) => Some(v.clone()),
            Val::List(l) => l.iter().map(|x| x.as_f64().map(|f| f as f32)).collect(),
            _ => None,
        }
    }
}

/// Cypher equality: `None` means null (unknown).
pub(crate) fn equals(a: &Val, b: &Val) -> Option<bool> {
    use Val::*;
    match (a, b) {
        (Null, _) | (_, Null) => None,
        (Int(x), Int(y)) => Some(x == y),
        (Int(_) | Float(_), Int(_) | Float(_)) => {
            let (x, y) = (a.as_f64()?, b.as_f64()?);
            if let (Int(i), Float(f)) | (Float(f), Int(i)) = (a, b) {
                // exact comparison of an integer with a float
                return Some(
                    f.is_finite()
                        && f.fract().abs() < f64::MIN_POSITIVE
                        && (*f as i128) == (*i as i128),
                );
            }
            // Cypher's float equality is exact (NaN equals nothing)
            Some(x.partial_cmp(&y) == Some(Ordering::Equal))
        }
        (List(x), List(y)) => {
            if x.len() != y.len() {
                return Some(false);
            }
            let mut unknown = false;
            for (p, q) in x.iter().zip(y) {
                match equals(p, q) {
                    Some(false) => return Some(false),
                    None => unknown = true,
                    Some(true) => {}
                }
            }
            if unknown { None } else { Some(true) }
        }
        (Map(x), Map(y)) => {
            if x.len() != y.len() || x.keys().ne(y.keys()) {
                return Some(false);
            }
            let mut unknown = false;
            for (p, q) in x.values().zip(y.values()) {
                match equals(p, q) {
                    Some(false) => return Some(false),
                    None => unknown = true,
                    Some(true) => {}
                }
            }
            if unknown { None } else { Some(true) }
        }
        (
            Path {
                nodes: n1,
                rels: r1,
            },
            Path {
                nodes: n2,
                rels: r2,
            },
        ) => Some(n1 == n2 && r1 == r2),
        (Vector(x), Vector(y)) => Some(x == y),
        (Vector(_), List(_)) | (List(_), Vector(_)) => {
            Some(a.as_f32s().is_some() && a.as_f32s() == b.as_f32s())
        }
        _ if std::mem::discriminant(a) == std::mem::discriminant(b) => Some(a == b),
        _ => Some(false),
    }
}

/// Cypher comparison for `<`, `<=`, ...: `None` when the values are not comparable.
pub(crate) fn compare(a: &Val, b: &Val) -> Option<Ordering> {
    use Val::*;
    match (a, b) {
        (Int(x), Int(y)) => Some(x.cmp(y)),
        (Int(_) | Float(_), Int(_) | Float(_)) => {
            if let (Int(i), Float(f)) = (a, b) {
                return cmp_int_float(*i, *f);
            }
            if let (Float(f), Int(i)) = (a, b) {
                return cmp_int_float(*i, *f).map(Ordering::reverse);
            }
            a.as_f64()?.partial_cmp(&b.as_f64()?)
        }
        (Str(x), Str(y)) => Some(x.cmp(y)),
        (Bool(x), Bool(y)) => Some(x.cmp(y)),
        (List(x), List(y)) => {
            for (p, q) in x.iter().zip(y) {
                match compare(p, q)? {
                    Ordering::Equal => {}
                    o => return Some(o),
                }
            }
            Some(x.len().cmp(&y.len()))
        }
        _ => None,
    }
}

/// An integer against a float by their exact values (no rounding of the integer through
/// f64, which cannot hold every i64): the float's integer part, exact in i128 for every finite
/// f64 up to 2^127, then its fraction.
fn cmp_int_float(i: i64, f: f64) -> Option<Ordering> {
    if f.is_nan() {
        return None;
    }
    if f.is_infinite() || f.abs() >= 1e38 {
        return Some(if f > 0.0 {
            Ordering::Less
        } else {
            Ordering::Greater
        });
    }
    let fi = f.trunc() as i128;
    match i128::from(i).cmp(&fi) {
        Ordering::Equal => 0.0f64.partial_cmp(&f.fract()),
        o => Some(o),
    }
}

fn rank(v: &Val) -> u8 {
    match v {
        Val::Map(_) => 0,
        Val::Node(_) => 1,
        Val::Rel(_) => 2,
        Val::List(_) | Val::Vector(_) => 3,
        Val::Path { .. } => 4,
        Val::Point2D(_) | Val::Point3D(_) => 5,
        Val::Bytes(_) => 6,
        Val::Str(_) => 7,
        Val::Bool(_) => 8,
        Val::Int(_) | Val::Float(_) => 9,
        Val::Null => 11,
    }
}

/// The total order used by ORDER BY, DISTINCT and grouping (null sorts last, NaN just before it).
pub(crate) fn order(a: &Val, b: &Val) -> Ordering {
    use Val::*;
    let nan = |v: &Val| matches!(v, Float(f) if f.is_nan());
    let ra = if nan(a) { 10 } else { rank(a) };
    let rb = if nan(b) { 10 } else { rank(b) };
    if ra != rb {
        return ra.cmp(&rb);
    }
    match (a, b) {
        (Map(x), Map(y)) => {
            for ((k1, v1), (k2, v2)) in x.iter().zip(y) {
                let o = k1.cmp(k2).then_with(|| order(v1, v2));
                if o != Ordering::Equal {
                    return o;
                }
            }
            x.len().cmp(&y.len())
        }
        (Node(x), Node(y)) | (Rel(x), Rel(y)) => x.cmp(y),
        (List(_) | Vector(_), List(_) | Vector(_)) => {
            let x = as_list(a);
            let y = as_list(b);
            for (p, q) in x.iter().zip(&y) {
                let o = order(p, q);
                if o != Ordering::Equal {
                    return o;
                }
            }
            x.len().cmp(&y.len())
        }
        (
            Path {
                nodes: n1,
                rels: r1,
            },
            Path {
                nodes: n2,
                rels: r2,
            },
        ) => n1.cmp(n2).then(r1.cmp(r2)),
        (Point2D(x), Point2D(y)) => x
            .iter()
            .zip(y)
            .map(|(p, q)| p.total_cmp(q))
            .find(|o| o.is_ne())
            .unwrap_or(Ordering::Equal),
        (Point3D(x), Point3D(y)) => x
            .iter()
            .zip(y)
            .map(|(p, q)| p.total_cmp(q))
            .find(|o| o.is_ne())
            .unwrap_or(Ordering::Equal),
        (Point2D(_), Point3D(_)) => Ordering::Less,
        (Point3D(_), Point2D(_)) => Ordering::Greater,
        (Bytes(x), Bytes(y)) => x.cmp(y),
        (Str(x), Str(y)) => x.cmp(y),
        (Bool(x), Bool(y)) => x.cmp(y),
        (Float(x), Float(y)) if x.is_nan() && y.is_nan() => Ordering::Equal,
        (Int(_) | Float(_), Int(_) | Float(_)) => compare(a, b).unwrap_or(Ordering::Equal),
        _ => Ordering::Equal,
    }
}

fn as_list(v: &Val) -> Vec<Val> {
    match v {
        Val::List(l) => l.clone(),
        Val::Vector(v) => v.iter().map(|f| Val::Float(f64::from(*f))).collect(),
        _ => Vec::new(),
    }
}

/// A key that groups by [`order`] equality (so 1 and 1.0 group together, as do nulls).
#[derive(Debug, Clone)]
pub(crate) struct Key(pub Vec<Val>);

impl PartialEq for Key {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Key {
    fn cmp(&self, o: &Self) -> Ordering {
        for (a, b) in self.0.iter().zip(&o.0) {
            let c = order(a, b);
            if c != Ordering::Equal {
                return c;
            }
        }
        self.0.len().cmp(&o.0.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn null_semantics_of_equality() {
        assert_eq!(equals(&Val::Null, &Val::Int(1)), None);
        assert_eq!(equals(&Val::Int(1), &Val::Float(1.0)), Some(true));
        assert_eq!(
            equals(
                &Val::List(vec![Val::Int(1), Val::Null]),
                &Val::List(vec![Val::Int(2), Val::Null])
            ),
            Some(false)
        );
        assert_eq!(
            equals(
                &Val::List(vec![Val::Int(1), Val::Null]),
                &Val::List(vec![Val::Int(1), Val::Null])
            ),
            None
        );
        assert_eq!(equals(&Val::Str("a".into()), &Val::Int(1)), Some(false));
    }

    #[test]
    fn ordering_puts_null_last_and_nan_before_it() {
        let mut v = [
            Val::Null,
            Val::Float(f64::NAN),
            Val::Int(2),
            Val::Str("a".into()),
            Val::Float(1.5),
        ];
        v.sort_by(order);
        assert!(matches!(v[0], Val::Str(_)));
        assert!(matches!(v[1], Val::Float(f) if (f - 1.5).abs() < 1e-12));
        assert!(matches!(v[2], Val::Int(2)));
        assert!(matches!(v[3], Val::Float(f) if f.is_nan()));
        assert!(v[4].is_null());
    }
}
