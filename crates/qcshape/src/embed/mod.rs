//! Projection of deformations to 2 or 3 dimensions from their distance matrix (eq. 16).

pub mod mds;

pub use mds::{classical_mds, raw_stress, smacof, smacof_from, Embedding, MdsError, MdsOptions};
