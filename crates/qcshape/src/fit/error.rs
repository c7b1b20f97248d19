//! What can go wrong in a fit ([`FitError`]), and why a template cannot carry one
//! ([`TemplateProblem`]).

use thiserror::Error;

/// Why a template cannot carry a fit ([`FitError::Template`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TemplateProblem {
    /// The template has vertices but no triangles.
    #[error("it has no faces")]
    NoFaces,
    /// Several separate fans of faces meet at one vertex.
    #[error("it is not manifold: vertex {vertex} joins {fans} separate fans of faces")]
    NotManifold {
        /// The vertex.
        vertex: usize,
        /// Fans of faces meeting there.
        fans: usize,
    },
    /// All edges have length zero (or the mean is not finite).
    #[error("its mean edge length is zero")]
    ZeroEdgeLength,
}

/// Why a fit cannot be made. Each message is one line naming what is wrong.
#[derive(Debug, Error, Clone)]
pub enum FitError {
    /// The target has no points.
    #[error("the target is empty: it has no vertices")]
    EmptyTarget,
    /// A coordinate is NaN, infinite or beyond [`MAX_COORDINATE`](crate::mesh::MAX_COORDINATE).
    #[error("the {what} has a non-finite or too large coordinate at vertex {vertex}")]
    NonFinite {
        /// `"template"` or `"target"`.
        what: &'static str,
        /// The vertex.
        vertex: usize,
    },
    /// A target face refers to a vertex that does not exist.
    #[error("target face {face} refers to vertex {index}, but the target has {n_vertices} vertices")]
    FaceIndex {
        /// The face.
        face: usize,
        /// The index.
        index: u32,
        /// Target vertex count.
        n_vertices: usize,
    },
    /// More points than [`MAX_VERTICES`](crate::limits::MAX_VERTICES).
    #[error("the {what} has {count} vertices or faces, more than the limit {limit}")]
    TooLarge {
        /// `"template"` or `"target"`.
        what: &'static str,
        /// Its count.
        count: usize,
        /// The limit.
        limit: usize,
    },
    /// The template cannot carry a fit (no faces, zero edge length, non-manifold vertices).
    #[error("the template cannot be fitted: {0}")]
    Template(TemplateProblem),
    /// An option is out of range.
    #[error("fit option {name} = {value} is out of range ({expected})")]
    Option {
        /// The option.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The accepted range.
        expected: &'static str,
    },
    /// After the initial alignment too few template vertices have a plausible match on the
    /// target.
    #[error("no overlap after alignment: only {matched} of {total} template vertices found a target point within the outlier distance")]
    NoOverlap {
        /// Vertices with a correspondence.
        matched: usize,
        /// Template vertices.
        total: usize,
    },
    /// The symbolic analysis of the fit's sparse system failed (out of memory, index overflow).
    #[error("the fit's linear system could not be analysed: {0}")]
    Symbolic(faer::sparse::FaerError),
    /// The numeric Cholesky factorization of the fit's system failed (a non-positive pivot).
    #[error("the fit's linear system could not be factorized: {0}")]
    Factorization(faer::linalg::solvers::LltError),
    /// A solve of the fit's system gave non-finite positions.
    #[error("the fit's linear system gave a non-finite solution")]
    NotFinite,
    /// A landmark names a template vertex that does not exist or a non-finite point.
    #[error("landmark {landmark}: vertex {vertex} is out of range (the template has {n_vertices} vertices) or its point is not finite")]
    Landmark {
        /// The landmark's index.
        landmark: usize,
        /// Its template vertex.
        vertex: usize,
        /// Template vertex count.
        n_vertices: usize,
    },
    /// No candidate of the initial alignment has a finite score or scale.
    #[error("the initial alignment did not converge (no candidate with a finite score and scale)")]
    Alignment,
}
