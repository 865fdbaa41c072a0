//! Typed property values.

use std::collections::BTreeMap;

/// A property value. Maps nested inside values are keyed by plain strings; top-level
/// node and relationship properties are keyed by interned [`crate::PropKey`]s.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Value {
    /// Cypher's null. Setting a property to null removes it.
    #[default]
    Null,
    /// A boolean.
    Bool(bool),
    /// A signed 64-bit integer.
    Int(i64),
    /// A 64-bit float.
    Float(f64),
    /// A UTF-8 string.
    String(String),
    /// A heterogeneous list.
    List(Vec<Value>),
    /// A string-keyed map (sorted, so output is deterministic).
    Map(BTreeMap<String, Value>),
    /// A 2D point in metres.
    Point2D([f64; 2]),
    /// A 3D point in metres.
    Point3D([f64; 3]),
    /// A dense f32 vector (embeddings).
    Vector(Vec<f32>),
    /// Opaque bytes.
    Bytes(Vec<u8>),
}

impl Value {
    /// The value in the store's own binary encoding: exact for every value (NaN, -0.0,
    /// integers beyond 2^53, vectors, bytes), unlike JSON.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        crate::codec::encode_value(&mut out, self);
        out
    }

    /// Decodes [`Value::to_bytes`].
    ///
    /// # Errors
    /// [`crate::Error::Corrupt`] for bytes that are not one whole encoded value.
    pub fn from_bytes(bytes: &[u8]) -> crate::Result<Value> {
        let mut r = crate::codec::Reader::new(bytes, "value");
        let v = r.value()?;
        if !r.is_empty() {
            return Err(crate::error::corrupt(
                "value",
                format!("extra bytes after the value ({} in all)", bytes.len()),
            ));
        }
        Ok(v)
    }
}

/// The type of a [`Value`], used by schema rules.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum ValueType {
    /// [`Value::Null`]
    Null,
    /// [`Value::Bool`]
    Bool,
    /// [`Value::Int`]
    Int,
    /// [`Value::Float`]
    Float,
    /// [`Value::String`]
    String,
    /// [`Value::List`]
    List,
    /// [`Value::Map`]
    Map,
    /// [`Value::Point2D`]
    #[serde(rename = "point2d")]
    Point2D,
    /// [`Value::Point3D`]
    #[serde(rename = "point3d")]
    Point3D,
    /// [`Value::Vector`]
    Vector,
    /// [`Value::Bytes`]
    Bytes,
    /// An axis-aligned box: a list of exactly two 3D points, `[min, max]`.
    #[serde(rename = "box3d")]
    Box3D,
    /// Int or Float.
    Number,
    /// Anything.
    Any,
}

impl ValueType {
    /// Whether `v` conforms to this type.
    pub fn accepts(self, v: &Value) -> bool {
        match self {
            ValueType::Any => true,
            ValueType::Number => matches!(v, Value::Int(_) | Value::Float(_)),
            ValueType::Box3D => v.as_box3d().is_some(),
            t => v.value_type() == t,
        }
    }
}

impl std::fmt::Display for ValueType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = serde_json::to_value(self).ok();
        let name = s.as_ref().and_then(|v| v.as_str()).unwrap_or("?");
        f.write_str(name)
    }
}

impl Value {
    /// The value's type.
    pub fn value_type(&self) -> ValueType {
        match self {
            Value::Null => ValueType::Null,
            Value::Bool(_) => ValueType::Bool,
            Value::Int(_) => ValueType::Int,
            Value::Float(_) => ValueType::Float,
            Value::String(_) => ValueType::String,
            Value::List(_) => ValueType::List,
            Value::Map(_) => ValueType::Map,
            Value::Point2D(_) => ValueType::Point2D,
            Value::Point3D(_) => ValueType::Point3D,
            Value::Vector(_) => ValueType::Vector,
            Value::Bytes(_) => ValueType::Bytes,
        }
    }

    /// The string, if this is a string.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::String(s) => Some(s),
            _ => None,
        }
    }

    /// The integer, if this is an integer.
    pub fn as_int(&self) -> Option<i64> {
        match self {
            Value::Int(i) => Some(*i),
            _ => None,
        }
    }

    /// The number as f64, if this is an integer or a float.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Int(i) => Some(*i as f64),
            Value::Float(f) => Some(*f),
            _ => None,
        }
    }

    /// The vector, if this is a vector.
    pub fn as_vector(&self) -> Option<&[f32]> {
        match self {
            Value::Vector(v) => Some(v),
            _ => None,
        }
    }

    /// A point as 3D (2D points get z = 0).
    pub fn as_point3(&self) -> Option<[f64; 3]> {
        match self {
            Value::Point2D([x, y]) => Some([*x, *y, 0.0]),
            Value::Point3D(p) => Some(*p),
            _ => None,
        }
    }

    /// A box `[min, max]`: a list of exactly two points with min <= max on every axis.
    pub fn as_box3d(&self) -> Option<([f64; 3], [f64; 3])> {
        match self {
            Value::List(items) if items.len() == 2 => {
                let lo = items[0].as_point3()?;
                let hi = items[1].as_point3()?;
                let ordered = (0..3).all(|i| lo[i] <= hi[i]);
                ordered.then_some((lo, hi))
            }
            _ => None,
        }
    }

    /// Builds a box value from its corners.
    pub fn box3d(min: [f64; 3], max: [f64; 3]) -> Value {
        Value::List(vec![Value::Point3D(min), Value::Point3D(max)])
    }

    /// True for [`Value::Null`].
    pub fn is_null(&self) -> bool {
        matches!(self, Value::Null)
    }

    /// Whether every float inside is finite (NaN and inf are refused by the store).
    pub fn is_finite(&self) -> bool {
        match self {
            Value::Float(f) => f.is_finite(),
            Value::Point2D(p) => p.iter().all(|c| c.is_finite()),
            Value::Point3D(p) => p.iter().all(|c| c.is_finite()),
            Value::Vector(v) => v.iter().all(|c| c.is_finite()),
            Value::List(l) => l.iter().all(Value::is_finite),
            Value::Map(m) => m.values().all(Value::is_finite),
            _ => true,
        }
    }

    /// The value as JSON. Points become `{"x","y"[,"z"]}`, bytes become a list of numbers.
    /// A float that JSON has no number for is `{"$float": "NaN"}`, `{"$float": "Infinity"}`
    /// or `{"$float": "-Infinity"}` ([`float_json`]), never `null`, which is Cypher's null.
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        match self {
            Value::Null => serde_json::Value::Null,
            Value::Bool(b) => json!(b),
            Value::Int(i) => json!(i),
            Value::Float(f) => float_json(*f),
            Value::String(s) => json!(s),
            Value::List(l) => serde_json::Value::Array(l.iter().map(Value::to_json).collect()),
            Value::Map(m) => {
                serde_json::Value::Object(m.iter().map(|(k, v)| (k.clone(), v.to_json())).collect())
            }
            Value::Point2D([x, y]) => json!({"x": float_json(*x), "y": float_json(*y)}),
            Value::Point3D([x, y, z]) => {
                json!({"x": float_json(*x), "y": float_json(*y), "z": float_json(*z)})
            }
            Value::Vector(v) => {
                // finite f32 as f32 (shortest form: 0.1, not 0.10000000149011612)
                serde_json::Value::Array(
                    v.iter()
                        .map(|c| {
                            if c.is_finite() {
                                json!(c)
                            } else {
                                float_json(f64::from(*c))
                            }
                        })
                        .collect(),
                )
            }
            Value::Bytes(b) => json!(b),
        }
    }

    /// The value of JSON that [`Value::to_json`] wrote: `{x, y[, z]}` objects of numbers are
    /// points, `{"$float": "NaN"}` and the like are floats, integers stay integers. Vectors and
    /// bytes come back as lists (JSON does not tell them apart).
    pub fn from_json(j: &serde_json::Value) -> Value {
        use serde_json::Value as J;
        match j {
            J::Null => Value::Null,
            J::Bool(b) => Value::Bool(*b),
            J::Number(n) => n
                .as_i64()
                .map(Value::Int)
                .unwrap_or_else(|| Value::Float(n.as_f64().unwrap_or(f64::NAN))),
            J::String(t) => Value::String(t.clone()),
            J::Array(a) => Value::List(a.iter().map(Value::from_json).collect()),
            J::Object(o) => {
                let num = |k: &str| match o.get(k).map(Value::from_json) {
                    Some(Value::Int(i)) => Some(i as f64),
                    Some(Value::Float(f)) => Some(f),
                    _ => None,
                };
                if let (1, Some(J::String(t))) = (o.len(), o.get("$float"))
                    && let Ok(f) = t.parse::<f64>()
                {
                    return Value::Float(f);
                }
                match (o.len(), num("x"), num("y"), num("z")) {
                    (2, Some(x), Some(y), None) => Value::Point2D([x, y]),
                    (3, Some(x), Some(y), Some(z)) => Value::Point3D([x, y, z]),
                    _ => Value::Map(
                        o.iter()
                            .map(|(k, v)| (k.clone(), Value::from_json(v)))
                            .collect(),
                    ),
                }
            }
        }
    }
}

/// A float as JSON: a number when finite, else the one tagged form every JSON the project
/// writes uses: `{"$float": "NaN"}`, `{"$float": "Infinity"}` or `{"$float": "-Infinity"}`
/// (JSON has no number for them, and `null` is Cypher's null).
pub fn float_json(f: f64) -> serde_json::Value {
    match serde_json::Number::from_f64(f) {
        Some(n) => serde_json::Value::Number(n),
        None => {
            let name = if f.is_nan() {
                "NaN"
            } else if f > 0.0 {
                "Infinity"
            } else {
                "-Infinity"
            };
            serde_json::json!({ "$float": name })
        }
    }
}

impl From<bool> for Value {
    fn from(v: bool) -> Self {
        Value::Bool(v)
    }
}
impl From<i64> for Value {
    fn from(v: i64) -> Self {
        Value::Int(v)
    }
}
impl From<i32> for Value {
    fn from(v: i32) -> Self {
        Value::Int(v.into())
    }
}
impl From<u32> for Value {
    fn from(v: u32) -> Self {
        Value::Int(v.into())
    }
}
impl From<f64> for Value {
    fn from(v: f64) -> Self {
        Value::Float(v)
    }
}
impl From<&str> for Value {
    fn from(v: &str) -> Self {
        Value::String(v.to_owned())
    }
}
impl From<String> for Value {
    fn from(v: String) -> Self {
        Value::String(v)
    }
}
impl From<Vec<f32>> for Value {
    fn from(v: Vec<f32>) -> Self {
        Value::Vector(v)
    }
}
impl From<Vec<Value>> for Value {
    fn from(v: Vec<Value>) -> Self {
        Value::List(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_requires_ordered_corners() {
        assert!(Value::box3d([0.0; 3], [1.0; 3]).as_box3d().is_some());
        assert!(Value::box3d([1.0; 3], [0.0; 3]).as_box3d().is_none());
        assert!(ValueType::Box3D.accepts(&Value::box3d([0.0; 3], [0.0; 3])));
        assert!(!ValueType::Box3D.accepts(&Value::Int(1)));
    }

    #[test]
    fn number_accepts_int_and_float() {
        assert!(ValueType::Number.accepts(&Value::Int(3)));
        assert!(ValueType::Number.accepts(&Value::Float(3.5)));
        assert!(!ValueType::Number.accepts(&Value::from("3")));
        assert_eq!(ValueType::Point3D.to_string(), "point3d");
        assert_eq!(ValueType::Box3D.to_string(), "box3d");
    }
}
