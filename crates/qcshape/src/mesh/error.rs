use thiserror::Error;

/// Problems found while building or checking a mesh. Indices are 0-based.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MeshError {
    /// The mesh has no faces.
    #[error("mesh has no faces")]
    NoFaces,
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but there are only {n_vertices} vertices")]
    IndexOutOfRange {
        /// Face index.
        face: usize,
        /// Offending vertex index.
        index: usize,
        /// Number of vertices.
        n_vertices: usize,
    },
    /// A face uses the same vertex twice.
    #[error("face {face} repeats a vertex: {indices:?}")]
    RepeatedIndex {
        /// Face index.
        face: usize,
        /// The face's vertex indices.
        indices: [u32; 3],
    },
    /// More than two faces share an edge.
    #[error("edge ({a}, {b}) is non-manifold: it is shared by {count} faces")]
    NonManifoldEdge {
        /// First vertex.
        a: u32,
        /// Second vertex.
        b: u32,
        /// Number of faces on the edge.
        count: usize,
    },
    /// Two faces traverse a shared edge in the same direction (inconsistent orientation).
    #[error("faces {f0} and {f1} are inconsistently oriented across edge ({a}, {b})")]
    InconsistentOrientation {
        /// First face.
        f0: usize,
        /// Second face.
        f1: usize,
        /// First vertex of the edge.
        a: u32,
        /// Second vertex of the edge.
        b: u32,
    },
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate {value:?}")]
    NonFinite {
        /// Vertex index.
        vertex: usize,
        /// Its position.
        value: [f64; 3],
    },
    /// The position array does not have the topology's vertex count.
    #[error("expected {expected} vertices, got {got}")]
    VertexCountMismatch {
        /// Vertices in the topology.
        expected: usize,
        /// Vertices given.
        got: usize,
    },
    /// A triangle has (numerically) zero area.
    #[error("face {face} {indices:?} is degenerate (area {area:e})")]
    DegenerateFace {
        /// Face index.
        face: usize,
        /// Its vertex indices.
        indices: [u32; 3],
        /// Its area.
        area: f64,
    },
    /// Two shapes that must share a topology do not.
    #[error("shapes do not share one connectivity: {0}")]
    TopologyMismatch(String),
}
