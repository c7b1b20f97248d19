//! Fitting one template mesh to surfaces of any triangulation (issue 49): the template's
//! connectivity at positions that lie on each target, so that data from segmentations, scanners
//! and other tools (every pose with its own triangulation) can be compared by the rest of the
//! library, which needs one connectivity per deformation.
//!
//! A fit has three steps:
//! 1. a similarity (or rigid) initial alignment of the template onto the target ([`rigid`]):
//!    area-weighted centroids, scale by the ratio of rms radii, principal axes with their sign
//!    ambiguities tried (and the input orientation), each refined by ICP with scale;
//! 2. a non-rigid fit ([`nonrigid`]): the template's vertices pulled onto the target surface
//!    (point-to-surface) and target samples pulling their nearest template point
//!    (surface-to-point), with robust weights, under a deformation prior ([`Prior`]: smooth
//!    local affine maps by default) whose stiffness is annealed from stiff to soft;
//! 3. the fit's quality ([`quality`]): symmetric surface distance in template edge lengths,
//!    triangle quality, flips and edge strain, with a `poor` flag.
//!
//! Targets without faces are point clouds: only the terms that need no target faces are used
//! (no normal test, no boundary test). Sequences are tracked ([`fit_sequence`]): the first
//! frame is fitted from the template, each next frame from the previous fit, always under the
//! prior of the (aligned) template. A cohort is one template fitted to each subject's first
//! frame, then tracked through the subject's frames.
//!
//! Units: positions are in the target's length unit; the fit's thresholds are in units of the
//! aligned template's mean edge length `lbar`, so the result does not depend on the scale of
//! the data.
//!
//! This file declares the modules and re-exports their public items; the errors, the options and
//! the checked target sit below the steps, and the steps below [`fit`] and [`fit_sequence`]
//! (`crates/qcshape/floors.txt`).

pub mod affine;
pub mod closest;
pub mod data;
mod error;
pub mod local;
pub mod nonrigid;
mod options;
pub mod polynomial;
pub mod quality;
pub mod rigid;
mod run;
pub mod shell;
mod target;

pub use error::{FitError, TemplateProblem};
pub use options::{FitOptions, Prior, AFFINE_STIFFNESS, MAX_GLOBAL_DEGREE};
pub use quality::FitQuality;
pub use run::{fit, fit_sequence, fit_with_landmarks, initial_alignment, Fitted};
pub use target::Target;

#[cfg(test)]
mod tests;
