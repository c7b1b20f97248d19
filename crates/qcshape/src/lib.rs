//! # qcshape
//!
//! Deformation similarity in quasi-conformal shape space (Kilian-style shape spaces with the
//! rigid, isometric, conformal, L2 and quasi-conformal metrics of Taimouri and Hua,
//! Graphical Models 2014 (cited in the README), with its open choices fixed in docs/method.md).
//!
//! Conventions used throughout:
//! - a [`mesh::Topology`] is an immutable, shared (`Arc`) triangle list `F` (#F x 3);
//! - a shape (pose) is a position array `V` (#V x 3, `[[f64; 3]]`) on one topology;
//! - a tangent vector (deformation field) `X` is a #V x 3 array of displacements;
//! - a path `P_0 .. P_N` has fixed ends; its segments are `X_i = P_{i+1} - P_i`.
//!
//! Lengths are in the units of the input coordinates unless a function says it normalizes.
#![warn(missing_docs)]

pub mod align;
pub mod cluster;
pub mod dataset;
pub mod defaults;
pub mod embed;
pub mod eval;
pub mod fit;
pub mod geodesic;
pub mod io;
pub mod limits;
pub mod mesh;
pub mod metric;
pub mod multires;
pub mod named;
pub mod numfmt;
pub mod outputs;
pub mod settings;
pub mod similarity;
pub mod space;
pub mod synth;
pub mod transport;
