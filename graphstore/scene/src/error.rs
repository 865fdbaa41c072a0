//! The crate's one error type.

/// What can go wrong reading or writing the map model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The store does not say which world axes are the ground plane; none is guessed.
    #[error(
        "{0}: the ground frame is unknown, so positions cannot be placed on the ground plane. A live server (`serve --zenoh`) writes it with its first mapped frames; for a store built without the hierarchy, run `opengraph hierarchy` (it writes the Environment with its ground_frame) or set Environment.ground_frame to \"kitti_cam\" or \"enu\""
    )]
    NoGroundFrame(String),
    /// A record whose properties do not have the layer's shape.
    #[error("{0}")]
    Invalid(String),
    /// The store failed.
    #[error(transparent)]
    Store(#[from] graphstore::Error),
}

/// Result alias for the map model.
pub type Result<T, E = Error> = std::result::Result<T, E>;
