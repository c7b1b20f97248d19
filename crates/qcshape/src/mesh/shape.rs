use std::sync::Arc;

use super::{geometry, FaceDifference, MeshError, Topology};

/// The largest coordinate magnitude a shape may have: products of four coordinates (squared
/// areas, the metrics' energies before normalization) must stay finite in `f64` (1e308).
pub const MAX_COORDINATE: f64 = 1e75;

/// A pose: vertex positions (#V x 3, in the input's length unit) on a shared [`Topology`].
///
/// A shape is just positions; areas, angles and curvature come from [`geometry`] functions.
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    /// The shared connectivity.
    pub topology: Arc<Topology>,
    /// Vertex positions (#V x 3).
    pub positions: Vec<[f64; 3]>,
}

impl Shape {
    /// Makes a shape, checking the vertex count and that every coordinate is finite and at most
    /// [`MAX_COORDINATE`] in magnitude.
    pub fn new(topology: Arc<Topology>, positions: Vec<[f64; 3]>) -> Result<Self, MeshError> {
        if positions.len() != topology.n_vertices() {
            return Err(MeshError::VertexCountMismatch {
                expected: topology.n_vertices(),
                got: positions.len(),
            });
        }
        if let Some((vertex, p)) = positions
            .iter()
            .enumerate()
            .find(|(_, p)| p.iter().any(|c| !c.is_finite()))
        {
            return Err(MeshError::NonFinite { vertex, value: *p });
        }
        if let Some((vertex, value)) = positions
            .iter()
            .enumerate()
            .flat_map(|(v, p)| p.iter().map(move |&c| (v, c)))
            .find(|(_, c)| c.abs() > MAX_COORDINATE)
        {
            return Err(MeshError::TooLarge {
                vertex,
                value,
                limit: MAX_COORDINATE,
            });
        }
        Ok(Shape { topology, positions })
    }

    /// Like [`Shape::new`], and also rejects faces whose area is below `rel_tol` times the
    /// squared mean edge length (zero-area triangles make angles and curvature undefined).
    pub fn new_checked(
        topology: Arc<Topology>,
        positions: Vec<[f64; 3]>,
        rel_tol: f64,
    ) -> Result<Self, MeshError> {
        let s = Self::new(topology, positions)?;
        s.check_degenerate(rel_tol)?;
        Ok(s)
    }

    /// Errors on the first face whose area is below `rel_tol * lbar^2` (`lbar` the mean edge length).
    pub fn check_degenerate(&self, rel_tol: f64) -> Result<(), MeshError> {
        let lbar = geometry::mean_edge_length(&self.topology, &self.positions);
        let areas = geometry::face_areas(&self.topology, &self.positions);
        for (face, &area) in areas.iter().enumerate() {
            if area.is_nan() || area <= rel_tol * lbar * lbar {
                return Err(MeshError::DegenerateFace {
                    face,
                    indices: self.topology.faces()[face],
                    area,
                });
            }
        }
        Ok(())
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Positions as a flat slice of length 3 #V (x0, y0, z0, x1, ...).
    pub fn flat(&self) -> &[f64] {
        self.positions.as_flattened()
    }

    /// Errors unless `other` has the same connectivity (same `Arc` or equal face lists).
    pub fn check_same_topology(&self, other: &Shape) -> Result<(), MeshError> {
        if Arc::ptr_eq(&self.topology, &other.topology) || self.topology.faces() == other.topology.faces() {
            if self.n_vertices() == other.n_vertices() {
                return Ok(());
            }
            return Err(MeshError::VertexCountMismatch {
                expected: self.n_vertices(),
                got: other.n_vertices(),
            });
        }
        if self.n_vertices() != other.n_vertices() {
            return Err(MeshError::VertexCountMismatch {
                expected: self.n_vertices(),
                got: other.n_vertices(),
            });
        }
        let (a, b) = (self.topology.faces(), other.topology.faces());
        if a.len() != b.len() {
            return Err(MeshError::TopologyMismatch(FaceDifference::Count {
                expected: a.len(),
                got: b.len(),
            }));
        }
        let f = a.iter().zip(b).position(|(x, y)| x != y).unwrap_or(0);
        Err(MeshError::TopologyMismatch(FaceDifference::Face {
            face: f,
            expected: a[f],
            got: b[f],
        }))
    }
}
