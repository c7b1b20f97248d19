//! The scale-invariant ("relative") forms of the metrics (docs/method.md "Scale-invariant
//! forms"): every term is a rate of *relative* change, so that scaling a pose and its
//! displacement together by `s` leaves the metric unchanged, `G_{sM}(sX) = G_M(X)`.
//!
//! - [`RelativeL2`] (eq. 11): displacement over the local size of the pose;
//! - [`RelativeIsometric`] (eq. 3): edge strain rate `<X_p - X_q, p - q> / |p - q|^2`;
//! - [`RelativeConformal`] (eq. 6, and eq. 10 with curvature-change weights): the difference of
//!   the two edge strain rates at each corner, plus an optional stretch term on the relative
//!   rate of change of each face's area.
//!
//! Every term is weighted by its face's share of the surface area, frozen along a path (the
//! mean of the two ends' shares, [`Metric::frozen_weights`]); so each metric is an
//! area-weighted mean of squared dimensionless rates: it does not depend on the coordinates'
//! units, converges as the mesh is refined and needs no calibration against a reference pose.
//! With eq. 7's form (the rates multiplied by squared edge lengths) a shape's conformal cost
//! falls like the sixth power of its size, and geodesics shrink the shape on the way (the
//! reason for these forms).

mod bending;
mod conformal;
mod faces;
mod folds;
mod isometric;
mod l2;

pub use bending::{dihedral_angles, RelativeBending};
pub use conformal::RelativeConformal;
pub use folds::{Folds, BENDING_SHARE_WARNING, FOLD_TURN_DEGREES};
pub use isometric::RelativeIsometric;
pub use l2::RelativeL2;

/// For `bent.rs` and `regularized.rs` (the frozen lengths of their terms).
pub(crate) use faces::PER_FACE;

#[cfg(test)]
mod tests;
