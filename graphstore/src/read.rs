//! The read API shared by read and write transactions.

use std::ops::Bound;
use std::sync::Arc;

use crate::codec::{K_BOOL, K_NUMBER, K_STRING, int_exact_in_f64, sort_key};
use crate::error::{Error, Result};
use crate::index::{spatial, text, vector};
use crate::layout::{Committed, GraphCounts, NodeRec, PendingMem};
use crate::model::{Adjacent, Direction, Node, Relationship, typed_props};
use crate::payload::PointCloud;
use crate::tokens::{LabelId, PropKey, RelType, TokenKind};
use crate::value::Value;

/// An adjacency row: `(node, direction, type, rel)` and the node at the other end.
pub(crate) use crate::adjacency::AdjRow;

/// Low-level access implemented by both transaction kinds.
pub(crate) trait Raw {
    fn base(&self) -> &Arc<Committed>;
    fn pending_mem(&self) -> Option<&PendingMem>;
    /// The base commit's in-memory indexes (built on first use by a reader; a writer's base
    /// has them built before it starts).
    fn mem(&self) -> Result<&crate::layout::Mem>;
    fn token(&self, kind: TokenKind, name: &str) -> Option<u32>;
    fn token_name(&self, id: u32) -> Option<String>;
    fn load_rec(&self, id: u64) -> Result<Option<NodeRec>>;
    /// [`Raw::load_rec`] with only the properties whose key is in `keep` (sorted).
    fn load_rec_keys(&self, id: u64, keep: &[u32]) -> Result<Option<NodeRec>>;
    fn load_rel(&self, id: u64) -> Result<Option<Relationship>>;
    /// One property of a relationship (None when it or the property is missing).
    fn load_rel_prop(&self, id: u64, key: u32) -> Result<Option<Value>>;
    /// (rel, type, other) for one direction (0 out, 1 in), optionally one type.
    fn adj(&self, node: u64, dir: u8, ty: Option<u32>) -> Result<Vec<(u64, u32, u64)>>;
    fn label_nodes(&self, label: u32) -> Result<Vec<u64>>;
    fn propidx(&self, lo: Bound<&[u8]>, hi: Bound<&[u8]>) -> Result<Vec<u64>>;
    /// The nodes of property index `index` whose value has sort key `sort_key`, ascending
    /// (a reader of a committed snapshot answers from its in-memory copy once it has one).
    fn propidx_eq(&self, index: u32, sort_key: &[u8]) -> Result<Vec<u64>> {
        propidx_eq_scan(self, index, sort_key)
    }
    fn count_rows(&self) -> Result<Vec<((u8, u32), u64)>>;
    fn payload(&self, node: u64, key: &str) -> Result<Option<Vec<u8>>>;
    fn payload_keys(&self, node: u64) -> Result<Vec<String>>;
    fn all_nodes(&self) -> Result<Vec<u64>>;
    fn all_rels(&self) -> Result<Vec<u64>>;
    fn raw_adjacency_rows(&self) -> Result<Vec<AdjRow>>;
    fn raw_label_rows(&self) -> Result<Vec<(u32, u64)>>;
    fn raw_propidx_rows(&self) -> Result<Vec<Vec<u8>>>;
    fn next_ids(&self) -> Result<(u64, u64)>;
}

/// Opaque handle used by [`GraphRead`]'s provided methods.
#[derive(Clone, Copy)]
pub struct View<'a> {
    pub(crate) raw: &'a dyn Raw,
}

impl std::fmt::Debug for View<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("View")
    }
}

/// A range bound on an indexed property value.
#[derive(Debug, Clone, PartialEq)]
pub enum ValueBound {
    /// No bound on this side (the range stays within the other bound's type).
    Unbounded,
    /// >= (lower) or <= (upper).
    Inclusive(Value),
    /// > (lower) or < (upper).
    Exclusive(Value),
}

/// A hit from a scored index query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// The node.
    pub node: u64,
    /// Cosine similarity (vector), BM25 score (text) or distance in metres (spatial).
    pub score: f64,
}

/// Top-k vector search. The exact flat index ([`FlatVectorIndex`]) implements it; an
/// approximate index (HNSW, IVF) would implement it too and report `is_exact() == false`.
pub trait VectorSearch {
    /// Dimension of the vectors.
    fn dim(&self) -> usize;
    /// Whether results are guaranteed to be the true top-k.
    fn is_exact(&self) -> bool;
    /// The `k` most cosine-similar nodes, best first (ties by id).
    fn top_k(&self, query: &[f32], k: usize) -> Result<Vec<Hit>>;
}

/// A vector index as seen by one transaction.
#[derive(Debug, Clone, Copy)]
pub struct FlatVectorIndex<'a> {
    view: View<'a>,
    slot: usize,
    name: &'a str,
}

impl VectorSearch for FlatVectorIndex<'_> {
    fn dim(&self) -> usize {
        self.view.raw.base().schema.vector[self.slot].params.dim
    }

    fn is_exact(&self) -> bool {
        true
    }

    fn top_k(&self, query: &[f32], k: usize) -> Result<Vec<Hit>> {
        let raw = self.view.raw;
        let dim = self.dim();
        if query.len() != dim {
            return Err(Error::InvalidValue(format!(
                "query has {} dimensions, index {:?} has {dim}",
                query.len(),
                self.name
            )));
        }
        if query.iter().any(|x| !x.is_finite()) {
            return Err(Error::InvalidValue("query vector has NaN or inf".into()));
        }
        let i = self.slot;
        Ok(vector::top_k(
            &raw.mem()?.vector[i],
            raw.pending_mem().map(|p| &p.vector[i]),
            query,
            k,
        )
        .into_iter()
        .map(|(node, s)| Hit {
            node,
            score: f64::from(s),
        })
        .collect())
    }
}

pub(crate) fn index_prefix(index: u32) -> Vec<u8> {
    index.to_be_bytes().to_vec()
}

/// [`Raw::propidx_eq`] by a range scan of the index table: the entries `index`, `sort_key`,
/// any node id.
pub(crate) fn propidx_eq_scan<R: Raw + ?Sized>(
    raw: &R,
    index: u32,
    sort_key: &[u8],
) -> Result<Vec<u64>> {
    let mut lo = index_prefix(index);
    lo.extend_from_slice(sort_key);
    let mut hi = lo.clone();
    hi.extend_from_slice(&[0xff; 8]);
    raw.propidx(Bound::Included(&lo), Bound::Included(&hi))
}

/// Reads over a consistent view of the graph. Implemented by [`crate::ReadTxn`] and
/// [`crate::WriteTxn`] (which also sees its own uncommitted writes).
pub trait GraphRead {
    #[doc(hidden)]
    fn view(&self) -> View<'_>;

    /// The [`crate::Store::commit_seq`] a committed snapshot sees; None inside a write
    /// transaction (its state is not a commit yet).
    fn commit_seq(&self) -> Option<u64> {
        None
    }

    /// The nodes that the commits after `seq`, up to the one this snapshot sees, changed:
    /// created, deleted, written (labels, properties, payloads), or an end of a relationship
    /// that was created, deleted or given new properties. Ascending, each once; empty when
    /// `seq` is this snapshot's own commit. `None` when it is not known: the store remembers
    /// the last 64 commits of this handle, a commit that changed more than 4,096 nodes (a bulk
    /// load) or the schema is not listed, and a write transaction has no commit yet. For
    /// bringing something derived from commit `seq` up to date instead of deriving it again.
    fn nodes_changed_since(&self, seq: u64) -> Option<Vec<u64>> {
        let _ = seq;
        None
    }

    /// The id of a label, if the store has seen it.
    fn label(&self, name: &str) -> Option<LabelId> {
        self.view().raw.token(TokenKind::Label, name).map(LabelId)
    }

    /// The id of a relationship type, if the store has seen it.
    fn rel_type(&self, name: &str) -> Option<RelType> {
        self.view().raw.token(TokenKind::RelType, name).map(RelType)
    }

    /// The id of a property key, if the store has seen it.
    fn prop_key(&self, name: &str) -> Option<PropKey> {
        self.view().raw.token(TokenKind::PropKey, name).map(PropKey)
    }

    /// The name behind any token id.
    fn name_of(&self, id: u32) -> Option<String> {
        self.view().raw.token_name(id)
    }

    /// A node by id.
    fn node(&self, id: u64) -> Result<Option<Node>> {
        Ok(self.view().raw.load_rec(id)?.map(|r| Node {
            id,
            labels: r.labels.into_iter().map(LabelId).collect(),
            props: typed_props(r.props),
        }))
    }

    /// A node by id with only the properties `keys` decoded (the record's other values are
    /// skipped, not decoded: a reader of a few small properties of nodes that also hold large
    /// lists pays for what it reads). Labels are all given. None if the node is missing.
    ///
    /// # Errors
    /// The store fails or the record is corrupt.
    fn node_keys(&self, id: u64, keys: &[PropKey]) -> Result<Option<Node>> {
        let mut keep: Vec<u32> = keys.iter().map(|k| k.0).collect();
        keep.sort_unstable();
        keep.dedup();
        Ok(self.view().raw.load_rec_keys(id, &keep)?.map(|r| Node {
            id,
            labels: r.labels.into_iter().map(LabelId).collect(),
            props: typed_props(r.props),
        }))
    }

    /// A relationship by id.
    fn rel(&self, id: u64) -> Result<Option<Relationship>> {
        self.view().raw.load_rel(id)
    }

    /// One property of a relationship, decoding only that value (None if the relationship or
    /// the property is missing).
    fn rel_prop(&self, id: u64, key: PropKey) -> Result<Option<Value>> {
        self.view().raw.load_rel_prop(id, key.0)
    }

    /// One property of a node, by name (None if the node or property is missing).
    fn node_prop(&self, id: u64, key: &str) -> Result<Option<Value>> {
        let Some(k) = self.prop_key(key) else {
            return Ok(None);
        };
        Ok(self
            .view()
            .raw
            .load_rec(id)?
            .and_then(|r| r.get(k.0).cloned()))
    }

    /// The relationships at `node`, optionally of one type, sorted by (direction, type, rel).
    fn neighbours(&self, node: u64, dir: Direction, ty: Option<RelType>) -> Result<Vec<Adjacent>> {
        let raw = self.view().raw;
        let t = ty.map(|t| t.0);
        let mut out = Vec::new();
        if matches!(dir, Direction::Outgoing | Direction::Both) {
            out.extend(
                raw.adj(node, 0, t)?
                    .into_iter()
                    .map(|(rel, ty, other)| Adjacent {
                        rel,
                        ty: RelType(ty),
                        other,
                        outgoing: true,
                    }),
            );
        }
        if matches!(dir, Direction::Incoming | Direction::Both) {
            out.extend(
                raw.adj(node, 1, t)?
                    .into_iter()
                    .filter(|(_, _, other)| dir != Direction::Both || *other != node)
                    .map(|(rel, ty, other)| Adjacent {
                        rel,
                        ty: RelType(ty),
                        other,
                        outgoing: false,
                    }),
            );
        }
        Ok(out)
    }

    /// Ids of all nodes with a label, ascending.
    fn label_scan(&self, label: LabelId) -> Result<Vec<u64>> {
        self.view().raw.label_nodes(label.0)
    }

    /// Ids of all nodes with the named label (empty for an unknown label).
    fn nodes_with_label(&self, label: &str) -> Result<Vec<u64>> {
        match self.label(label) {
            Some(l) => self.label_scan(l),
            None => Ok(Vec::new()),
        }
    }

    /// Ids of all nodes, ascending.
    fn all_node_ids(&self) -> Result<Vec<u64>> {
        self.view().raw.all_nodes()
    }

    /// Ids of all relationships, ascending.
    fn all_rel_ids(&self) -> Result<Vec<u64>> {
        self.view().raw.all_rels()
    }

    /// Whether `label.key` has a property index.
    fn has_property_index(&self, label: &str, key: &str) -> bool {
        let (Some(l), Some(k)) = (self.label(label), self.prop_key(key)) else {
            return false;
        };
        self.view()
            .raw
            .base()
            .schema
            .prop_index_of
            .contains_key(&(l.0, k.0))
    }

    /// Nodes with `label` whose `key` equals `value`, through the property index.
    /// Numbers compare by value (2 = 2.0), as in Cypher.
    fn find_nodes(&self, label: &str, key: &str, value: &Value) -> Result<Vec<u64>> {
        let idx = property_index(self.view(), label, key)?;
        let Some(idx) = idx else {
            return Ok(Vec::new());
        };
        let Some(sk) = sort_key(value) else {
            return Ok(Vec::new());
        };
        let ids = self.view().raw.propidx_eq(idx, &sk)?;
        verify_exact(
            self.view(),
            key,
            ids,
            &ValueBound::Inclusive(value.clone()),
            &ValueBound::Inclusive(value.clone()),
        )
    }

    /// Nodes with `label` whose `key` lies in the range, ascending by value then id. Only
    /// values of the bounds' type family (numbers, strings or booleans) match.
    fn find_range(
        &self,
        label: &str,
        key: &str,
        lower: ValueBound,
        upper: ValueBound,
    ) -> Result<Vec<u64>> {
        let Some(idx) = property_index(self.view(), label, key)? else {
            return Ok(Vec::new());
        };
        let class_of = |b: &ValueBound| match b {
            ValueBound::Unbounded => Ok(None),
            ValueBound::Inclusive(v) | ValueBound::Exclusive(v) => {
                sort_key(v).map(|k| Some(k[0])).ok_or_else(|| {
                    Error::InvalidValue(format!(
                        "range bound {v:?} is not a number, string or boolean"
                    ))
                })
            }
        };
        let class = match (class_of(&lower)?, class_of(&upper)?) {
            (Some(a), Some(b)) if a != b => return Ok(Vec::new()),
            (Some(a), _) | (None, Some(a)) => a,
            (None, None) => {
                return Err(Error::InvalidValue(
                    "a range needs at least one bound".into(),
                ));
            }
        };
        debug_assert!([K_BOOL, K_NUMBER, K_STRING].contains(&class));
        let p = index_prefix(idx);
        let key_of = |v: &Value, tail: &[u8]| {
            let mut k = p.clone();
            k.extend_from_slice(&sort_key(v).unwrap_or_default());
            k.extend_from_slice(tail);
            k
        };
        let lo_key;
        let lo = match &lower {
            ValueBound::Unbounded => {
                lo_key = [p.as_slice(), &[class]].concat();
                Bound::Included(lo_key.as_slice())
            }
            ValueBound::Inclusive(v) => {
                lo_key = key_of(v, &[]);
                Bound::Included(lo_key.as_slice())
            }
            ValueBound::Exclusive(v) if shares_key(&lower) => {
                lo_key = key_of(v, &[]);
                Bound::Included(lo_key.as_slice())
            }
            ValueBound::Exclusive(v) => {
                lo_key = key_of(v, &[0xff; 8]);
                Bound::Excluded(lo_key.as_slice())
            }
        };
        let hi_key;
        let hi = match &upper {
            ValueBound::Unbounded => {
                hi_key = [p.as_slice(), &[class + 1]].concat();
                Bound::Excluded(hi_key.as_slice())
            }
            ValueBound::Inclusive(v) => {
                hi_key = key_of(v, &[0xff; 8]);
                Bound::Included(hi_key.as_slice())
            }
            ValueBound::Exclusive(v) if shares_key(&upper) => {
                hi_key = key_of(v, &[0xff; 8]);
                Bound::Included(hi_key.as_slice())
            }
            ValueBound::Exclusive(v) => {
                hi_key = key_of(v, &[]);
                Bound::Excluded(hi_key.as_slice())
            }
        };
        let ids = self.view().raw.propidx(lo, hi)?;
        verify_exact(self.view(), key, ids, &lower, &upper)
    }

    /// Nodes of a spatial index whose box intersects `[min, max]`, ascending by id.
    fn spatial_in_box(&self, index: &str, min: [f64; 3], max: [f64; 3]) -> Result<Vec<u64>> {
        let raw = self.view().raw;
        let i = raw.base().schema.spatial_by_name(index)?;
        Ok(spatial::in_box(
            &raw.mem()?.spatial[i],
            raw.pending_mem().map(|p| &p.spatial[i]),
            (min, max),
        ))
    }

    /// Nodes of a spatial index within `radius_m` of `center` (distance to the box), nearest
    /// first.
    fn spatial_within(&self, index: &str, center: [f64; 3], radius_m: f64) -> Result<Vec<Hit>> {
        if !(radius_m >= 0.0 && radius_m.is_finite()) || center.iter().any(|c| !c.is_finite()) {
            return Err(Error::InvalidValue(format!(
                "radius {radius_m} m or centre {center:?} is not finite and non-negative"
            )));
        }
        spatial_hits(self.view(), index, |stack, pending| {
            spatial::within(stack, pending, center, radius_m)
        })
    }

    /// Nodes of a spatial index whose footprint lies within `radius_m` of the ground point
    /// `ground` on the plane spanned by world axes `axes` (0 = x, 1 = y, 2 = z; `ground[i]`
    /// is along `axes[i]`), height ignored; distances on that plane, nearest first.
    ///
    /// # Errors
    /// An unknown index, a radius or point that is not finite, or axes that are not two
    /// different axes of 0..3 ([`Error::InvalidValue`]).
    fn spatial_within_ground(
        &self,
        index: &str,
        ground: [f64; 2],
        axes: [usize; 2],
        radius_m: f64,
    ) -> Result<Vec<Hit>> {
        check_ground(ground, axes)?;
        if !(radius_m >= 0.0 && radius_m.is_finite()) {
            return Err(Error::InvalidValue(format!(
                "radius {radius_m} m is not finite and non-negative"
            )));
        }
        spatial_hits(self.view(), index, |stack, pending| {
            spatial::within_ground(stack, pending, ground, axes, radius_m)
        })
    }

    /// The `k` nodes of a spatial index whose footprints are nearest the ground point
    /// `ground` (see [`GraphRead::spatial_within_ground`]), nearest first.
    ///
    /// # Errors
    /// As [`GraphRead::spatial_within_ground`].
    fn spatial_nearest_ground(
        &self,
        index: &str,
        ground: [f64; 2],
        axes: [usize; 2],
        k: usize,
    ) -> Result<Vec<Hit>> {
        check_ground(ground, axes)?;
        spatial_hits(self.view(), index, |stack, pending| {
            spatial::nearest_ground(stack, pending, ground, axes, k)
        })
    }

    /// The `k` nodes of a spatial index nearest to `center`, nearest first.
    fn spatial_nearest(&self, index: &str, center: [f64; 3], k: usize) -> Result<Vec<Hit>> {
        if center.iter().any(|c| !c.is_finite()) {
            return Err(Error::InvalidValue(format!(
                "centre {center:?} is not finite"
            )));
        }
        spatial_hits(self.view(), index, |stack, pending| {
            spatial::nearest(stack, pending, center, k)
        })
    }

    /// A vector index by name, searchable through [`VectorSearch`].
    fn vector_index<'a>(&'a self, name: &'a str) -> Result<FlatVectorIndex<'a>> {
        let view = self.view();
        let slot = view.raw.base().schema.vector_by_name(name)?;
        Ok(FlatVectorIndex { view, slot, name })
    }

    /// Exact top-k by cosine similarity in a vector index, best first (ties by id).
    fn vector_top_k(&self, index: &str, query: &[f32], k: usize) -> Result<Vec<Hit>> {
        self.vector_index(index)?.top_k(query, k)
    }

    /// BM25 search in a text index, best first (ties by id).
    fn text_search(&self, index: &str, query: &str, k: usize) -> Result<Vec<Hit>> {
        let raw = self.view().raw;
        let i = raw.base().schema.text_by_name(index)?;
        Ok(text::search(
            &raw.mem()?.text[i],
            raw.pending_mem().map(|p| &p.text[i]),
            query,
            k,
        )
        .into_iter()
        .map(|(node, score)| Hit { node, score })
        .collect())
    }

    /// A payload stored beside a node.
    fn payload(&self, node: u64, key: &str) -> Result<Option<Vec<u8>>> {
        self.view().raw.payload(node, key)
    }

    /// Keys of the payloads stored beside a node, sorted.
    fn payload_keys(&self, node: u64) -> Result<Vec<String>> {
        self.view().raw.payload_keys(node)
    }

    /// A point cloud stored with [`crate::WriteTxn::put_point_cloud`].
    fn point_cloud(&self, node: u64, key: &str) -> Result<Option<PointCloud>> {
        self.payload(node, key)?
            .map(|b| PointCloud::decode(&b))
            .transpose()
    }

    /// Node and relationship counts by label and type name.
    fn counts(&self) -> Result<GraphCounts> {
        let raw = self.view().raw;
        let mut c = GraphCounts::default();
        for ((kind, tok), n) in raw.count_rows()? {
            let name = || raw.token_name(tok).unwrap_or_else(|| format!("#{tok}"));
            match kind {
                0 if n > 0 => {
                    c.nodes.insert(name(), n);
                }
                1 if n > 0 => {
                    c.relationships.insert(name(), n);
                }
                2 if tok == 0 => c.total_nodes = n,
                2 if tok == 1 => c.total_relationships = n,
                _ => {}
            }
        }
        Ok(c)
    }

    /// Names of all labels the store knows (committed ones), sorted.
    fn label_names(&self) -> Vec<String> {
        self.view()
            .raw
            .base()
            .tokens
            .all(TokenKind::Label)
            .into_iter()
            .map(|(_, n)| n)
            .collect()
    }
}

/// Runs `search` over spatial index `index` (its committed layers and this transaction's
/// pending entries) and gives its (node, distance) results as hits.
fn spatial_hits(
    v: View<'_>,
    index: &str,
    search: impl FnOnce(
        &crate::index::Stack<spatial::SpatialLayer>,
        Option<&crate::index::Pending<spatial::Aabb>>,
    ) -> Vec<(u64, f64)>,
) -> Result<Vec<Hit>> {
    let i = v.raw.base().schema.spatial_by_name(index)?;
    let hits = search(
        &v.raw.mem()?.spatial[i],
        v.raw.pending_mem().map(|p| &p.spatial[i]),
    );
    Ok(hits
        .into_iter()
        .map(|(node, score)| Hit { node, score })
        .collect())
}

pub(crate) fn property_index(v: View<'_>, label: &str, key: &str) -> Result<Option<u32>> {
    let (Some(l), Some(k)) = (
        v.raw.token(TokenKind::Label, label),
        v.raw.token(TokenKind::PropKey, key),
    ) else {
        // an unknown label or key has no nodes, but an undeclared index is an error
        let declared = v
            .raw
            .base()
            .schema
            .schema
            .effective_property_indexes()
            .iter()
            .any(|s| s.label == label && s.key == key);
        return if declared {
            Ok(None)
        } else {
            Err(Error::NoSuchIndex {
                kind: "property",
                name: format!("{label}.{key}"),
            })
        };
    };
    v.raw
        .base()
        .schema
        .prop_index_of
        .get(&(l, k))
        .copied()
        .map(Some)
        .ok_or_else(|| Error::NoSuchIndex {
            kind: "property",
            name: format!("{label}.{key}"),
        })
}

/// Index keys compare integers as f64; for integers f64 cannot hold exactly, re-check.
/// Whether a bound is an integer whose index key other integers share (keys are f64-based:
/// from 2^53 on, neighbouring integers round to one key), so the index's answer must be
/// checked against the values, and an exclusive bound must not leave out the whole key.
fn shares_key(b: &ValueBound) -> bool {
    matches!(b, ValueBound::Inclusive(Value::Int(i)) | ValueBound::Exclusive(Value::Int(i)) if !int_exact_in_f64(*i) || i.unsigned_abs() == 1 << 53)
}

fn verify_exact(
    v: View<'_>,
    key: &str,
    ids: Vec<u64>,
    lo: &ValueBound,
    hi: &ValueBound,
) -> Result<Vec<u64>> {
    if !shares_key(lo) && !shares_key(hi) {
        return Ok(ids);
    }
    let Some(k) = v.raw.token(TokenKind::PropKey, key) else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for id in ids {
        if let Some(val) = v.raw.load_rec(id)?.and_then(|r| r.get(k).cloned())
            && in_range(&val, lo, hi)
        {
            out.push(id);
        }
    }
    Ok(out)
}

/// Exact comparison of two indexable values of one family.
pub(crate) fn compare(a: &Value, b: &Value) -> Option<std::cmp::Ordering> {
    match (a, b) {
        (Value::Int(x), Value::Int(y)) => Some(x.cmp(y)),
        (Value::Int(x), Value::Float(y)) => (*x as f64).partial_cmp(y),
        (Value::Float(x), Value::Int(y)) => x.partial_cmp(&(*y as f64)),
        (Value::Float(x), Value::Float(y)) => x.partial_cmp(y),
        (Value::String(x), Value::String(y)) => Some(x.as_bytes().cmp(y.as_bytes())),
        (Value::Bool(x), Value::Bool(y)) => Some(x.cmp(y)),
        _ => None,
    }
}

fn in_range(v: &Value, lo: &ValueBound, hi: &ValueBound) -> bool {
    use std::cmp::Ordering::*;
    let lo_ok = match lo {
        ValueBound::Unbounded => true,
        ValueBound::Inclusive(b) => matches!(compare(v, b), Some(Greater | Equal)),
        ValueBound::Exclusive(b) => matches!(compare(v, b), Some(Greater)),
    };
    let hi_ok = match hi {
        ValueBound::Unbounded => true,
        ValueBound::Inclusive(b) => matches!(compare(v, b), Some(Less | Equal)),
        ValueBound::Exclusive(b) => matches!(compare(v, b), Some(Less)),
    };
    lo_ok && hi_ok
}

/// A ground point and the axes of its plane, checked.
fn check_ground(ground: [f64; 2], axes: [usize; 2]) -> Result<()> {
    if ground.iter().any(|c| !c.is_finite()) {
        return Err(Error::InvalidValue(format!(
            "ground point {ground:?} is not finite"
        )));
    }
    if axes[0] > 2 || axes[1] > 2 || axes[0] == axes[1] {
        return Err(Error::InvalidValue(format!(
            "ground axes {axes:?} are not two different axes of 0 (x), 1 (y), 2 (z)"
        )));
    }
    Ok(())
}
