//! Compact binary encoding of values and records, and the order-preserving key encoding
//! used by property indexes. Decoding never panics: malformed bytes give [`Error::Corrupt`].

use std::collections::BTreeMap;

use crate::error::{Error, Result, corrupt};
use crate::value::Value;

const T_NULL: u8 = 0;
const T_FALSE: u8 = 1;
const T_TRUE: u8 = 2;
const T_INT: u8 = 3;
const T_FLOAT: u8 = 4;
const T_STRING: u8 = 5;
const T_LIST: u8 = 6;
const T_MAP: u8 = 7;
const T_POINT2: u8 = 8;
const T_POINT3: u8 = 9;
const T_VECTOR: u8 = 10;
const T_BYTES: u8 = 11;

/// Deepest nesting of lists/maps accepted when decoding (guards the stack).
const MAX_DEPTH: usize = 64;

pub(crate) fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

pub(crate) fn encode_value(out: &mut Vec<u8>, v: &Value) {
    match v {
        Value::Null => out.push(T_NULL),
        Value::Bool(false) => out.push(T_FALSE),
        Value::Bool(true) => out.push(T_TRUE),
        Value::Int(i) => {
            out.push(T_INT);
            // zig-zag so small negative numbers stay small
            put_varint(out, ((i << 1) ^ (i >> 63)) as u64);
        }
        Value::Float(f) => {
            out.push(T_FLOAT);
            out.extend_from_slice(&f.to_le_bytes());
        }
        Value::String(s) => {
            out.push(T_STRING);
            put_varint(out, s.len() as u64);
            out.extend_from_slice(s.as_bytes());
        }
        Value::List(l) => {
            out.push(T_LIST);
            put_varint(out, l.len() as u64);
            for item in l {
                encode_value(out, item);
            }
        }
        Value::Map(m) => {
            out.push(T_MAP);
            put_varint(out, m.len() as u64);
            for (k, item) in m {
                put_varint(out, k.len() as u64);
                out.extend_from_slice(k.as_bytes());
                encode_value(out, item);
            }
        }
        Value::Point2D(p) => {
            out.push(T_POINT2);
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        Value::Point3D(p) => {
            out.push(T_POINT3);
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        Value::Vector(v) => {
            out.push(T_VECTOR);
            put_varint(out, v.len() as u64);
            for c in v {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        Value::Bytes(b) => {
            out.push(T_BYTES);
            put_varint(out, b.len() as u64);
            out.extend_from_slice(b);
        }
    }
}

/// A bounds-checked cursor over stored bytes.
pub(crate) struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    what: &'static str,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(buf: &'a [u8], what: &'static str) -> Self {
        Reader { buf, pos: 0, what }
    }

    fn err(&self, detail: &str) -> Error {
        corrupt(self.what, format!("{detail} at byte {}", self.pos))
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.pos >= self.buf.len()
    }

    pub(crate) fn u8(&mut self) -> Result<u8> {
        let b = *self
            .buf
            .get(self.pos)
            .ok_or_else(|| self.err("unexpected end"))?;
        self.pos += 1;
        Ok(b)
    }

    pub(crate) fn bytes(&mut self, n: usize) -> Result<&'a [u8]> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|e| *e <= self.buf.len())
            .ok_or_else(|| self.err("length runs past the end"))?;
        let s = &self.buf[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    pub(crate) fn array<const N: usize>(&mut self) -> Result<[u8; N]> {
        let s = self.bytes(N)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    pub(crate) fn varint(&mut self) -> Result<u64> {
        let mut v: u64 = 0;
        for shift in (0..64).step_by(7) {
            let b = self.u8()?;
            v |= u64::from(b & 0x7f) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(self.err("varint too long"))
    }

    /// A length prefix, checked against what is left so a corrupt length cannot allocate.
    pub(crate) fn len(&mut self, elem_size: usize) -> Result<usize> {
        let n = self.varint()?;
        let left = (self.buf.len() - self.pos) as u64;
        if n.saturating_mul(elem_size.max(1) as u64) > left {
            return Err(self.err("length exceeds record"));
        }
        Ok(n as usize)
    }

    pub(crate) fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(self.array()?))
    }

    pub(crate) fn string(&mut self) -> Result<String> {
        let n = self.len(1)?;
        let b = self.bytes(n)?;
        String::from_utf8(b.to_vec()).map_err(|_| self.err("invalid utf-8"))
    }

    pub(crate) fn value(&mut self) -> Result<Value> {
        self.value_at(0)
    }

    fn value_at(&mut self, depth: usize) -> Result<Value> {
        if depth > MAX_DEPTH {
            return Err(self.err("nesting too deep"));
        }
        Ok(match self.u8()? {
            T_NULL => Value::Null,
            T_FALSE => Value::Bool(false),
            T_TRUE => Value::Bool(true),
            T_INT => {
                let z = self.varint()?;
                Value::Int(((z >> 1) as i64) ^ -((z & 1) as i64))
            }
            T_FLOAT => Value::Float(self.f64()?),
            T_STRING => Value::String(self.string()?),
            T_LIST => {
                let n = self.len(1)?;
                let mut l = Vec::with_capacity(n);
                for _ in 0..n {
                    l.push(self.value_at(depth + 1)?);
                }
                Value::List(l)
            }
            T_MAP => {
                let n = self.len(2)?;
                let mut m = BTreeMap::new();
                for _ in 0..n {
                    let k = self.string()?;
                    m.insert(k, self.value_at(depth + 1)?);
                }
                Value::Map(m)
            }
            T_POINT2 => Value::Point2D([self.f64()?, self.f64()?]),
            T_POINT3 => Value::Point3D([self.f64()?, self.f64()?, self.f64()?]),
            T_VECTOR => {
                let n = self.len(4)?;
                let raw = self.bytes(n * 4)?;
                Value::Vector(
                    raw.chunks_exact(4)
                        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                )
            }
            T_BYTES => {
                let n = self.len(1)?;
                Value::Bytes(self.bytes(n)?.to_vec())
            }
            t => return Err(self.err(&format!("unknown value tag {t}"))),
        })
    }

    /// Steps over one value without building it.
    fn skip_value_at(&mut self, depth: usize) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(self.err("nesting too deep"));
        }
        match self.u8()? {
            T_NULL | T_FALSE | T_TRUE => {}
            T_INT => {
                self.varint()?;
            }
            T_FLOAT => {
                self.bytes(8)?;
            }
            T_STRING | T_BYTES => {
                let n = self.len(1)?;
                self.bytes(n)?;
            }
            T_LIST => {
                let n = self.len(1)?;
                for _ in 0..n {
                    self.skip_value_at(depth + 1)?;
                }
            }
            T_MAP => {
                let n = self.len(2)?;
                for _ in 0..n {
                    let k = self.len(1)?;
                    self.bytes(k)?;
                    self.skip_value_at(depth + 1)?;
                }
            }
            T_POINT2 => {
                self.bytes(16)?;
            }
            T_POINT3 => {
                self.bytes(24)?;
            }
            T_VECTOR => {
                let n = self.len(4)?;
                self.bytes(n * 4)?;
            }
            t => return Err(self.err(&format!("unknown value tag {t}"))),
        }
        Ok(())
    }

    pub(crate) fn u32_varint(&mut self) -> Result<u32> {
        u32::try_from(self.varint()?).map_err(|_| self.err("token id out of range"))
    }
}

/// Properties as stored: `(key token, value)`, sorted by key.
pub(crate) type RawProps = Vec<(u32, Value)>;

/// Encodes a property list `(key, value)`; keys must be sorted and unique.
pub(crate) fn encode_props(out: &mut Vec<u8>, props: &[(u32, Value)]) {
    put_varint(out, props.len() as u64);
    for (k, v) in props {
        put_varint(out, u64::from(*k));
        encode_value(out, v);
    }
}

pub(crate) fn decode_props(r: &mut Reader<'_>) -> Result<RawProps> {
    let n = r.len(2)?;
    let mut props = Vec::with_capacity(n);
    for _ in 0..n {
        let k = r.u32_varint()?;
        props.push((k, r.value()?));
    }
    Ok(props)
}

/// Node record: labels then properties.
pub(crate) fn encode_node(labels: &[u32], props: &[(u32, Value)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + props.len() * 12);
    put_varint(&mut out, labels.len() as u64);
    for l in labels {
        put_varint(&mut out, u64::from(*l));
    }
    encode_props(&mut out, props);
    out
}

fn read_labels(r: &mut Reader<'_>) -> Result<Vec<u32>> {
    let n = r.len(1)?;
    let mut labels = Vec::with_capacity(n);
    for _ in 0..n {
        labels.push(r.u32_varint()?);
    }
    Ok(labels)
}

/// The labels of a node record, without decoding its properties.
pub(crate) fn node_labels(buf: &[u8]) -> Result<Vec<u32>> {
    read_labels(&mut Reader::new(buf, "node record"))
}

pub(crate) fn decode_node(buf: &[u8]) -> Result<(Vec<u32>, RawProps)> {
    let mut r = Reader::new(buf, "node record");
    let labels = read_labels(&mut r)?;
    let props = decode_props(&mut r)?;
    if !r.is_empty() {
        return Err(r.err("trailing bytes"));
    }
    Ok((labels, props))
}

/// [`decode_node`] keeping only the properties whose key is in `keep` (sorted); the others
/// are stepped over without being decoded.
pub(crate) fn decode_node_keys(buf: &[u8], keep: &[u32]) -> Result<(Vec<u32>, RawProps)> {
    let mut r = Reader::new(buf, "node record");
    let labels = read_labels(&mut r)?;
    let n = r.len(2)?;
    let mut props = Vec::with_capacity(keep.len().min(n));
    for _ in 0..n {
        let k = r.u32_varint()?;
        if keep.binary_search(&k).is_ok() {
            props.push((k, r.value()?));
        } else {
            r.skip_value_at(0)?;
        }
    }
    if !r.is_empty() {
        return Err(r.err("trailing bytes"));
    }
    Ok((labels, props))
}

/// Relationship record: type, start, end, properties.
pub(crate) fn encode_rel(ty: u32, start: u64, end: u64, props: &[(u32, Value)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(24 + props.len() * 12);
    encode_rel_into(&mut out, ty, start, end, props);
    out
}

/// [`encode_rel`] appended to `out`.
pub(crate) fn encode_rel_into(
    out: &mut Vec<u8>,
    ty: u32,
    start: u64,
    end: u64,
    props: &[(u32, Value)],
) {
    put_varint(out, u64::from(ty));
    put_varint(out, start);
    put_varint(out, end);
    encode_props(out, props);
}

pub(crate) fn decode_rel(buf: &[u8]) -> Result<(u32, u64, u64, RawProps)> {
    let mut r = Reader::new(buf, "relationship record");
    let ty = r.u32_varint()?;
    let start = r.varint()?;
    let end = r.varint()?;
    let props = decode_props(&mut r)?;
    if !r.is_empty() {
        return Err(r.err("trailing bytes"));
    }
    Ok((ty, start, end, props))
}

/// One property of a relationship record, building only its value (the others are stepped
/// over; keys are sorted, so the walk stops past `key`). Unlike [`decode_rel`] it does not
/// check the bytes after the property.
pub(crate) fn rel_prop(buf: &[u8], key: u32) -> Result<Option<Value>> {
    let mut r = Reader::new(buf, "relationship record");
    r.u32_varint()?;
    r.varint()?;
    r.varint()?;
    props_value(&mut r, key)
}

/// One property of a node record, building only its value (labels and the other properties
/// are stepped over), as [`rel_prop`] does for relationships.
pub(crate) fn node_prop(buf: &[u8], key: u32) -> Result<Option<Value>> {
    let mut r = Reader::new(buf, "node record");
    let n = r.len(1)?;
    for _ in 0..n {
        r.u32_varint()?;
    }
    props_value(&mut r, key)
}

/// Whether a node record carries label `label` (its labels are sorted; the properties are
/// not read).
pub(crate) fn node_has_label(buf: &[u8], label: u32) -> Result<bool> {
    let mut r = Reader::new(buf, "node record");
    let n = r.len(1)?;
    for _ in 0..n {
        let l = r.u32_varint()?;
        if l >= label {
            return Ok(l == label);
        }
    }
    Ok(false)
}

/// The value of `key` in the property list `r` is at (keys sorted).
fn props_value(r: &mut Reader<'_>, key: u32) -> Result<Option<Value>> {
    let n = r.len(2)?;
    for _ in 0..n {
        let k = r.u32_varint()?;
        if k == key {
            return r.value().map(Some);
        }
        if k > key {
            break;
        }
        r.skip_value_at(0)?;
    }
    Ok(None)
}

// ---- order-preserving keys for property indexes ----

/// Class bytes of indexable values; values of different classes never compare equal.
pub(crate) const K_BOOL: u8 = 0x10;
pub(crate) const K_NUMBER: u8 = 0x20;
pub(crate) const K_STRING: u8 = 0x30;

/// Order-preserving bits of an f64 (total order; -0.0 folded onto 0.0).
pub(crate) fn f64_key(f: f64) -> [u8; 8] {
    let f = if f == 0.0 { 0.0 } else { f };
    let bits = f.to_bits();
    let flipped = if bits >> 63 == 1 {
        !bits
    } else {
        bits | (1 << 63)
    };
    flipped.to_be_bytes()
}

/// The sortable encoding of an indexable value, or None for values that are not
/// indexed (null, lists, maps, points, vectors, bytes, NaN).
pub(crate) fn sort_key(v: &Value) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    match v {
        Value::Bool(b) => {
            out.push(K_BOOL);
            out.push(u8::from(*b));
        }
        Value::Int(i) => {
            out.push(K_NUMBER);
            out.extend_from_slice(&f64_key(*i as f64));
        }
        Value::Float(f) if !f.is_nan() => {
            out.push(K_NUMBER);
            out.extend_from_slice(&f64_key(*f));
        }
        Value::String(s) => {
            out.push(K_STRING);
            for &b in s.as_bytes() {
                out.push(b);
                if b == 0 {
                    out.push(0xff);
                }
            }
            out.extend_from_slice(&[0, 0]);
        }
        _ => return None,
    }
    Some(out)
}

/// Whether an integer survives the trip through f64 exactly (index keys are f64-based).
pub(crate) fn int_exact_in_f64(i: i64) -> bool {
    i.unsigned_abs() <= (1u64 << 53)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn arb_value() -> impl Strategy<Value = Value> {
        let leaf = prop_oneof![
            Just(Value::Null),
            any::<bool>().prop_map(Value::Bool),
            any::<i64>().prop_map(Value::Int),
            any::<f64>()
                .prop_filter("finite", |f| f.is_finite())
                .prop_map(Value::Float),
            ".{0,12}".prop_map(Value::String),
            prop::array::uniform2(-1e6f64..1e6).prop_map(Value::Point2D),
            prop::array::uniform3(-1e6f64..1e6).prop_map(Value::Point3D),
            prop::collection::vec(-1f32..1.0, 0..8).prop_map(Value::Vector),
            prop::collection::vec(any::<u8>(), 0..8).prop_map(Value::Bytes),
        ];
        leaf.prop_recursive(3, 24, 4, |inner| {
            prop_oneof![
                prop::collection::vec(inner.clone(), 0..4).prop_map(Value::List),
                prop::collection::btree_map(".{0,4}", inner, 0..4).prop_map(Value::Map),
            ]
        })
    }

    proptest! {
        #[test]
        fn value_roundtrip(v in arb_value()) {
            let mut buf = Vec::new();
            encode_value(&mut buf, &v);
            let back = Reader::new(&buf, "test").value().unwrap();
            prop_assert_eq!(back, v);
        }

        #[test]
        fn one_rel_prop_is_the_decoded_one(
            props in prop::collection::btree_map(0u32..12, arb_value(), 0..6),
            key in 0u32..14,
        ) {
            let props: Vec<(u32, Value)> = props.into_iter().collect();
            let buf = encode_rel(7, 1, 2, &props);
            let (_, _, _, all) = decode_rel(&buf).unwrap();
            let want = all.iter().find(|(k, _)| *k == key).map(|(_, v)| v.clone());
            prop_assert_eq!(rel_prop(&buf, key).unwrap(), want);
        }

        #[test]
        fn a_node_decoded_for_some_keys_is_the_full_decode_filtered(
            labels in prop::collection::btree_set(0u32..9, 0..4),
            props in prop::collection::btree_map(0u32..12, arb_value(), 0..7),
            keep in prop::collection::btree_set(0u32..14, 0..5),
        ) {
            let labels: Vec<u32> = labels.into_iter().collect();
            let props: Vec<(u32, Value)> = props.into_iter().collect();
            let keep: Vec<u32> = keep.into_iter().collect();
            let buf = encode_node(&labels, &props);
            let (l, all) = decode_node(&buf).unwrap();
            let want: Vec<(u32, Value)> =
                all.into_iter().filter(|(k, _)| keep.contains(k)).collect();
            prop_assert_eq!(decode_node_keys(&buf, &keep).unwrap(), (l, want));
            // a cut record is an error, never a panic
            for cut in [buf.len() / 2, buf.len().saturating_sub(1)] {
                if cut < buf.len() {
                    prop_assert!(decode_node_keys(&buf[..cut], &keep).is_err());
                }
            }
        }

        #[test]
        fn decode_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..64), key in 0u32..4) {
            let _ = decode_node(&bytes);
            let _ = decode_node_keys(&bytes, &[1, 3]);
            let _ = decode_rel(&bytes);
            let _ = rel_prop(&bytes, key);
            let _ = Reader::new(&bytes, "fuzz").value();
        }

        #[test]
        fn number_keys_preserve_order(a in -1e12f64..1e12, b in -1e12f64..1e12) {
            let (ka, kb) = (sort_key(&Value::Float(a)).unwrap(), sort_key(&Value::Float(b)).unwrap());
            prop_assert_eq!(a.partial_cmp(&b).unwrap(), ka.cmp(&kb));
        }

        #[test]
        fn string_keys_preserve_order(a in "[a-c\\x00]{0,6}", b in "[a-c\\x00]{0,6}") {
            let (ka, kb) = (sort_key(&Value::String(a.clone())).unwrap(), sort_key(&Value::String(b.clone())).unwrap());
            prop_assert_eq!(a.as_bytes().cmp(b.as_bytes()), ka.cmp(&kb));
        }
    }

    #[test]
    fn truncated_record_is_corrupt_not_panic() {
        let rec = encode_node(&[1, 2], &[(3, Value::from("hello"))]);
        for cut in 0..rec.len() {
            assert!(
                matches!(decode_node(&rec[..cut]), Err(Error::Corrupt { .. })),
                "cut {cut}"
            );
        }
        assert!(decode_node(&rec).is_ok());
    }

    #[test]
    fn int_and_float_share_number_keys() {
        assert_eq!(sort_key(&Value::Int(2)), sort_key(&Value::Float(2.0)));
        assert_eq!(sort_key(&Value::Float(-0.0)), sort_key(&Value::Float(0.0)));
        assert!(sort_key(&Value::Float(f64::NAN)).is_none());
    }
}
