//! Import into a store: the CSV files of Neo4j's bulk importer ([`neo4j_csv`]), which
//! [`crate::export::neo4j_csv`] writes, and networkx's node-link JSON ([`node_link`]), which
//! [`crate::export::export_node_link`] writes.

pub mod neo4j_csv;
pub mod node_link;
pub use neo4j_csv::{CsvFile, CsvFiles, CsvImport, import_neo4j_csv};
pub use node_link::{NodeLinkImport, import_node_link};
