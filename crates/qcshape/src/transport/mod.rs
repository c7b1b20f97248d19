//! Discrete parallel transport and deformation transfer (paper section 2.2.2, docs/method.md
//! "Deformation transfer").
//!
//! - [`inner`]: the metric's inner product `<<U, V>>_S` (the polarization of its quadratic form at
//!   a pose `S`, #V x 3 tangent vectors) as a sparse operator `G_S = J^T J`;
//! - [`parallel`]: the paper's discrete parallel transport along the samples of a curve (each
//!   step the closest vector that keeps the inner product with the tangent and the norm), and
//!   the trivial Euclidean transport;
//! - [`schild`]: Schild's ladder, built from geodesic midpoints only;
//! - [`mod@transfer`]: the transfer of a deformation `M_0 .. M_K` to a new base `N_0`.
//!
//! All computations run in the normalized coordinates of the geodesic solver (one common
//! factor, see [`crate::geodesic::Normalization`]): the forms mix different powers of length (for
//! example `G + lambda L2`), so the transport depends on the scale.

pub mod defaults;
pub mod inner;
pub mod parallel;
pub mod schild;
pub mod transfer;

pub use inner::{quadratic_companion, InnerProduct, TransportMetric};
pub use parallel::{euclidean_transport, parallel_transport, ParallelOptions, StepDiagnostics, Transported};
pub use schild::{schild_ladder, RungDiagnostics, SchildOptions, SchildTransported};
pub use transfer::{
    transfer, SegmentReport, Transfer, TransferOptions, TransferSetup, Transferred, Transport,
};

use thiserror::Error;

use crate::geodesic::GeodesicError;
use crate::mesh::MeshError;

/// Errors of the transport and transfer computations.
#[derive(Debug, Error)]
pub enum TransportError {
    /// Shapes, curve samples or vectors that do not share one topology / vertex count.
    #[error("shapes do not share a topology: {0}")]
    Mesh(#[from] MeshError),
    /// A shape of the transfer does not have the connectivity of the others.
    #[error("{what} does not have the topology of the others: {error}")]
    Mismatch {
        /// Which shape (e.g. "pose 3 of the deformation", "the base").
        what: String,
        /// What differs.
        error: MeshError,
    },
    /// A geodesic (of the transfer or of a Schild rung) failed.
    #[error("geodesic failed: {0}")]
    Geodesic(#[from] GeodesicError),
    /// A metric or geodesic setting out of its range (`lambda`, steps, tolerances).
    #[error(transparent)]
    Setting(Box<crate::limits::LimitError>),
    /// A transport option that must be positive is not (`tolerance`, `cg-tolerance`,
    /// `epsilon`).
    #[error("invalid input: {name} must be positive, got {value}")]
    NotPositive {
        /// The option.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// Schild's ladder was given a geodesic solver with `steps` segments instead of 2.
    #[error("invalid input: Schild's ladder needs a geodesic solver with N = 2 segments, got {steps}")]
    SchildSteps {
        /// The solver's segment count.
        steps: usize,
    },
    /// An empty input: `what` has no `items`.
    #[error("invalid input: the {what} has no {items}")]
    Empty {
        /// The argument: "curve" or "deformation".
        what: &'static str,
        /// What it lacks: "samples" or "poses".
        items: &'static str,
    },
    /// A pose (or curve sample) without the topology's vertex count.
    #[error("invalid input: {what} has {got} vertices, the topology {expected}")]
    VertexCount {
        /// Which pose: "pose 3", "the base", "curve sample 2".
        what: String,
        /// Its vertex count.
        got: usize,
        /// The topology's.
        expected: usize,
    },
    /// The vector to transport does not have one entry per vertex.
    #[error("invalid input: the vector has {got} entries, expected {expected} (#V x 3)")]
    VectorLength {
        /// Its length.
        got: usize,
        /// The topology's vertex count.
        expected: usize,
    },
    /// The transport metric does not vanish at `X = 0`, so it is not a quadratic form.
    #[error("invalid input: {metric} does not vanish at X = 0: not a quadratic form")]
    NotQuadratic {
        /// The metric's name.
        metric: String,
    },
    /// The normalization factor of the base is zero, negative or not finite (a degenerate
    /// base: zero edge lengths or area).
    #[error("invalid input: normalization factor {factor} is not positive")]
    Normalization {
        /// The factor.
        factor: f64,
    },
    /// The metric's Jacobian, a pose or a transported vector is not finite (degenerate poses).
    #[error("non-finite values: {what}")]
    NonFinite {
        /// What is not finite, e.g. "the vector to transport", "Schild rung 3's vector".
        what: String,
    },
}

/// Flat copy (3 #V) of a #V x 3 array.
pub(crate) fn flat(v: &[[f64; 3]]) -> Vec<f64> {
    v.as_flattened().to_vec()
}

/// #V x 3 copy of a flat array (length 3 #V).
pub(crate) fn unflat(v: &[f64]) -> Vec<[f64; 3]> {
    v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Euclidean dot product of two flat vectors (the geodesic solvers' vectorized one).
pub(crate) use crate::geodesic::dot;

/// `b - a` (#V x 3).
pub(crate) fn difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> Vec<[f64; 3]> {
    a.iter()
        .zip(b)
        .map(|(p, q)| [q[0] - p[0], q[1] - p[1], q[2] - p[2]])
        .collect()
}

/// A setting's limit error (boxed: it holds the setting's names, and this error travels in
/// larger ones).
impl From<crate::limits::LimitError> for TransportError {
    fn from(e: crate::limits::LimitError) -> Self {
        TransportError::Setting(Box::new(e))
    }
}
