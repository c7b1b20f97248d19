//! From a frame-0 volume to a clean closed surface: threshold, iso-surface, largest
//! component, Taubin smoothing, decimation (meshoptimizer), validation.

use std::sync::Arc;

use super::surface::{compact, isosurface, otsu_thresholds, SurfaceError, TriMesh};
use qcshape::io::nifti::Volume;
use qcshape::io::DEGENERATE_REL_TOL;
use qcshape::mesh::{Shape, Topology};

/// Choices for [`extract_surface`].
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceOptions {
    /// Intensity threshold of the cavity; `None` calibrates it as the upper two-level Otsu
    /// threshold of the histogram ([`otsu_thresholds`]).
    pub threshold: Option<f64>,
    /// Taubin smoothing iterations (each a `lambda = 0.5` shrink and `mu = -0.53` inflate
    /// step with uniform Laplacian weights); 0 disables smoothing.
    pub smoothing_iterations: usize,
    /// Target vertex count after decimation; `None` keeps every vertex.
    pub target_vertices: Option<usize>,
    /// Tangential relaxation sweeps after decimation ([`tangential_relax`]).
    pub relax_iterations: usize,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            threshold: None,
            smoothing_iterations: 10,
            target_vertices: Some(1000),
            relax_iterations: 5,
        }
    }
}

/// A closed surface with its validated topology.
#[derive(Debug, Clone)]
pub struct Surface {
    /// Positions (#V x 3, world mm) on the shared topology (closed, outward normals).
    pub shape: Shape,
    /// The threshold used.
    pub threshold: f64,
    /// Vertex count of the largest component before decimation.
    pub raw_vertices: usize,
}

/// Taubin smoothing (lambda | mu) with uniform weights over the one-ring, `iterations` times, in
/// place ([`qcshape::mesh::smooth::taubin`]).
pub fn taubin_smooth(topo: &Topology, positions: &mut [[f64; 3]], iterations: usize) {
    let smoothed = qcshape::mesh::smooth::taubin(topo, positions, iterations);
    positions.copy_from_slice(&smoothed);
}

/// Tangential relaxation: each vertex moves half-way towards the centroid of its one-ring,
/// with the normal component of the move removed (area-weighted vertex normals), so the
/// triangles become more regular while the surface stays in place. `iterations` sweeps.
pub fn tangential_relax(topo: &Topology, positions: &mut [[f64; 3]], iterations: usize) {
    for _ in 0..iterations {
        let normals = qcshape::mesh::geometry::vertex_normals(topo, positions);
        let next: Vec<[f64; 3]> = (0..positions.len())
            .map(|v| {
                let nb = topo.neighbors(v);
                if nb.is_empty() {
                    return positions[v];
                }
                let mut d = [0.0; 3];
                for &u in nb {
                    for c in 0..3 {
                        d[c] += (positions[u as usize][c] - positions[v][c]) / nb.len() as f64;
                    }
                }
                let n = normals[v];
                let dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                std::array::from_fn(|c| positions[v][c] + 0.5 * (d[c] - dn * n[c]))
            })
            .collect();
        positions.copy_from_slice(&next);
    }
}

/// Checks that a mesh is one closed surface (of Euler characteristic `chi` when given; 2 is
/// a sphere) without isolated vertices or zero-area faces, and returns its topology.
pub fn check_closed(mesh: &TriMesh, chi: Option<i64>) -> Result<Arc<Topology>, SurfaceError> {
    let topo = mesh.topology()?;
    let (loops, comps) = (topo.boundary_loops().len(), topo.n_components());
    let chi_ok = chi.is_none_or(|c| c == topo.euler_characteristic());
    if loops != 0 || comps != 1 || !chi_ok || !topo.isolated_vertices().is_empty() {
        return Err(SurfaceError::Topology {
            components: comps,
            loops,
            euler: topo.euler_characteristic(),
        });
    }
    Shape::new_checked(topo.clone(), mesh.positions.clone(), DEGENERATE_REL_TOL)?;
    Ok(topo)
}

/// Decimates a closed mesh to about `target` vertices with meshoptimizer's edge-collapse
/// simplifier (vertices keep their positions, so they stay on the iso-surface). A result that
/// is not a closed surface of the input's Euler characteristic is retried with 30% more vertices (up to 6 times); below
/// that the undecimated mesh is returned.
pub fn decimate(mesh: &TriMesh, target: usize) -> TriMesh {
    if target >= mesh.positions.len() {
        return mesh.clone();
    }
    let verts: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.map(|c| c as f32)).collect();
    let indices: Vec<u32> = mesh.faces.iter().flatten().copied().collect();
    let chi = mesh.positions.len() as i64 - mesh.faces.len() as i64 / 2;
    let mut want = target.max(8);
    for _ in 0..6 {
        // A closed surface with V vertices and Euler characteristic chi has 2 (V - chi) faces.
        let target_indices = 3 * 2 * (want as i64 - chi).max(4) as usize;
        let out = meshopt::simplify_decoder(
            &indices,
            &verts,
            target_indices,
            1.0,
            meshopt::SimplifyOptions::Regularize,
            None,
        );
        let faces: Vec<[u32; 3]> = out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        if !faces.is_empty() {
            let m = compact(&mesh.positions, &faces);
            if check_closed(&m, Some(chi)).is_ok() {
                return m;
            }
        }
        want = want * 13 / 10;
        if want >= mesh.positions.len() {
            break;
        }
    }
    mesh.clone()
}

/// The cavity surface of a volume: threshold (given or Otsu), iso-surface, largest
/// component, Taubin smoothing, decimation, tangential relaxation, validation (closed, one component, outward
/// normals, no zero-area face; decimation keeps the genus). Positions in world mm.
pub fn extract_surface(vol: &Volume, opts: &SurfaceOptions) -> Result<Surface, SurfaceError> {
    let threshold = match opts.threshold {
        Some(t) => t,
        None => otsu_thresholds(vol)?.1,
    };
    let mut mesh = isosurface(vol, threshold)?.largest_component();
    if mesh.signed_volume() < 0.0 {
        mesh.flip();
    }
    let topo = check_closed(&mesh, None)?;
    let chi = topo.euler_characteristic();
    let raw_vertices = mesh.positions.len();
    taubin_smooth(&topo, &mut mesh.positions, opts.smoothing_iterations);
    if let Some(target) = opts.target_vertices {
        mesh = decimate(&mesh, target);
    }
    let topo = check_closed(&mesh, Some(chi))?;
    tangential_relax(&topo, &mut mesh.positions, opts.relax_iterations);
    let topo = check_closed(&mesh, Some(chi))?;
    if mesh.signed_volume() <= 0.0 {
        return Err(SurfaceError::NoVolume);
    }
    Ok(Surface {
        shape: Shape::new(topo, mesh.positions)?,
        threshold,
        raw_vertices,
    })
}
