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
    /// Two faces have the same three vertices.
    #[error("faces {f0} and {f1} are the same triangle {indices:?} (duplicated face)")]
    DuplicateFace {
        /// First face.
        f0: usize,
        /// Second face, a copy of the first (any corner order).
        f1: usize,
        /// The second face's vertex indices.
        indices: [u32; 3],
    },
    /// The faces around a vertex form several fans that meet only at the vertex (a "bowtie":
    /// two surfaces touching at one point).
    #[error("vertex {vertex} is non-manifold: its {faces} faces form {fans} separate fans that meet only at this vertex")]
    NonManifoldVertex {
        /// The vertex.
        vertex: usize,
        /// Faces at the vertex.
        faces: usize,
        /// Number of fans (at least 2).
        fans: usize,
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
    /// A coordinate so large that areas (and squared areas) would overflow.
    #[error("vertex {vertex} has the coordinate {value:e}, beyond {limit:e}: areas and energies would overflow; rescale the mesh")]
    TooLarge {
        /// Vertex index.
        vertex: usize,
        /// The coordinate.
        value: f64,
        /// The largest magnitude allowed ([`crate::mesh::MAX_COORDINATE`]).
        limit: f64,
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
    TopologyMismatch(FaceDifference),
}

/// How the faces of two shapes with the same vertex count differ ([`MeshError::TopologyMismatch`]).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum FaceDifference {
    /// Different face counts.
    #[error("{expected} faces against {got}")]
    Count {
        /// Faces of the first shape.
        expected: usize,
        /// Faces of the other.
        got: usize,
    },
    /// The first face (by index) whose corners differ.
    #[error("face {face} is {expected:?} in one and {got:?} in the other")]
    Face {
        /// Face index.
        face: usize,
        /// Its corners in the first shape.
        expected: [u32; 3],
        /// Its corners in the other.
        got: [u32; 3],
    },
}
