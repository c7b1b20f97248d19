//! Spatial multiresolution for temporal interpolation (paper section 2.2.1, docs/method.md
//! "Temporal interpolation").
//!
//! A [`Hierarchy`] holds coarser versions of one mesh (three levels by default), each keeping
//! a subset of the finer level's vertices. Every fine vertex missing from a coarse level is
//! located by projecting it onto the coarse mesh at the rest pose; its barycentric coordinates
//! ([`Prolongation`]) carry a coarse solution up as the next level's starting point.

mod hierarchy;
mod prolong;

pub use hierarchy::{Hierarchy, HierarchyError, Level, DEFAULT_RATIO, MIN_VERTICES};
pub use prolong::{Prolongation, Source};
