//! Import into a store: the CSV files of Neo4j's bulk importer ([`neo4j_csv`]), which
//! [`crate::export::neo4j_csv`] writes.

pub mod neo4j_csv;
pub use neo4j_csv::{CsvFile, CsvFiles, CsvImport, import_neo4j_csv};
