#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

mod adjacency;
mod codec;
mod columns;
mod compiled;
pub mod cypher;
mod error;
pub mod export;
mod hot;
pub mod import;
mod index;
mod integrity;
mod layout;
pub mod mem;
mod model;
mod payload;
mod read;
mod schema;
mod simd;
mod store;
mod tokens;
mod txn;
mod value;

/// Unit tests count allocations, as the `opengraph` binary does.
#[cfg(test)]
#[global_allocator]
static TEST_ALLOC: mem::CountingAlloc = mem::CountingAlloc;

pub use error::{Error, Result};
pub use index::text::tokenize;
pub use layout::{Committed, FORMAT_VERSION, GraphCounts};
pub use model::{Adjacent, Direction, NewRel, Node, Relationship};
pub use payload::{DEFAULT_RESOLUTION_M, PointCloud};
pub use read::{FlatVectorIndex, GraphRead, Hit, ValueBound, VectorSearch, View};
pub use schema::{
    LabelRule, PropertyIndexSpec, PropertyRule, RelRule, Schema, SpatialIndexSpec, TextIndexSpec,
    VectorIndexSpec, VectorMethod,
};
pub use store::{Store, StoreOptions};
pub use tokens::{LabelId, PropKey, RelType};
pub use txn::{ReadTxn, WriteTxn};
pub use value::{Value, ValueType, float_json};
