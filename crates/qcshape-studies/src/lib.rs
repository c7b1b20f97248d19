//! # qcshape-studies
//!
//! The studies built on the qcshape core (crate `qcshape`): the paper's experiments and its
//! reproduction (`experiment`), the left-ventricle pipeline (`lv`: phantoms, NIfTI meshing, TPS,
//! landmarks), per-vertex maps (`contribution`, `explain`, `localize`), figures (`plot`) and mesh
//! renderings (`render`). They use the core only through its public API; docs/design.md says what
//! lives where.
#![warn(missing_docs)]

pub mod contribution;
pub mod experiment;
pub mod explain;
pub mod localize;
pub mod lv;
pub mod plot;
pub mod render;
pub mod study_defaults;
