//! The crate's single error type.

use std::path::PathBuf;

/// Everything that can go wrong while routing or planning.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A start/goal spec that cannot be parsed.
    #[error(
        "bad location {spec:?}: {detail} (use X,Y or lane:ID, segment:ID, instance:ID, node:ID with a node id as `find` and `query` print it)"
    )]
    BadSpec {
        /// What was given.
        spec: String,
        /// What is wrong.
        detail: String,
    },
    /// A node id that does not exist.
    #[error(
        "no node with id {id} (asked for {kind}:{id}; ids are node ids as `find` and `query` print them)"
    )]
    UnknownId {
        /// lane, segment, instance or node.
        kind: &'static str,
        /// The node id.
        id: u64,
    },
    /// A node id whose node is not of the kind asked for.
    #[error("node {id} is a {labels} node, not {wanted} (asked for {kind}:{id})")]
    WrongKind {
        /// lane, segment, instance or node.
        kind: &'static str,
        /// What the kind accepts, in words (`an Instance`).
        wanted: &'static str,
        /// The node id.
        id: u64,
        /// The node's labels, joined with `:`.
        labels: String,
    },
    /// A point too far from every lane.
    #[error(
        "point ({x:.1}, {y:.1}) is {distance_m:.1} m from the nearest lane; the snap limit is {limit_m:.1} m"
    )]
    TooFar {
        /// Ground x.
        x: f64,
        /// Ground y.
        y: f64,
        /// Distance to the nearest lane.
        distance_m: f64,
        /// The limit.
        limit_m: f64,
    },
    /// Start and goal are not connected.
    #[error("no route: the goal is not reachable from the start ({0})")]
    NoRoute(String),
    /// The store has no lane graph.
    #[error(
        "the store has no lane graph (no LaneNode/LANE); run `opengraph hierarchy` or `build` first"
    )]
    NoLaneGraph,
    /// The map model cannot be read (no ground frame, a malformed record).
    #[error(transparent)]
    Scene(#[from] scene::Error),
    /// A map file that cannot be read.
    #[error("{}: {detail}", path.display())]
    Map {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// Invalid parameters.
    #[error("invalid input: {0}")]
    Invalid(String),
    /// A store error.
    #[error(transparent)]
    Store(#[from] graphstore::Error),
    /// Writing an image failed.
    #[error("rendering failed: {0}")]
    Render(String),
}

/// Result alias for the planner.
pub type Result<T, E = Error> = std::result::Result<T, E>;
