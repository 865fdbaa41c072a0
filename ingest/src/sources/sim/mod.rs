//! The synthetic city (work in progress for issue 6): a procedural road network with every
//! junction type, and a drive over it with KITTI-convention poses. Scene objects, the LiDAR
//! and the camera come next; there is no `opengraph sim` command yet.
//!
//! Known gap: on the drive of `RoadNetwork::exploration_route`, lane extraction agrees with
//! the ground-truth junction kind for 39 of 44 junctions (seeds 0-3, small); it misses some
//! grid corners (L-bends) driven twice in the same direction, and one T-junction.

pub mod roads;
