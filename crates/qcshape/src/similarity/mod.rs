//! Similarity between deformations (eq. 13) and the distance matrix it fills.

pub mod matrix;
pub use matrix::*;
