//! Mesh core: the shared immutable [`Topology`], [`Shape`]s as plain positions, and functions
//! that derive geometry (edge lengths, areas, angles, angle-defect curvature, normals).
//!
//! Derived quantities are always computed by functions from positions, never cached, so they
//! cannot go stale.

mod error;
pub mod geometry;

mod shape;
pub mod smooth;
mod topology;

pub use error::{FaceDifference, MeshError};
pub use shape::{Shape, MAX_COORDINATE};
pub use topology::Topology;

/// One pose of a deformation: #V x 3 vertex positions (the connectivity is the deformation's
/// shared [`Topology`]). The one pose type of the library.
pub type Pose = Vec<[f64; 3]>;
