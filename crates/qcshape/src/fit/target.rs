//! A target surface ([`Target`]), checked and with its search structure, normals and boundary
//! ([`Prepared`]), and the checks of a template.

use std::collections::HashMap;

use super::closest::SurfaceIndex;
use super::error::{FitError, TemplateProblem};
use crate::limits::MAX_VERTICES;
use crate::mesh::geometry::{add, cross, mean_edge_length, norm, scale, sub};
use crate::mesh::{Shape, MAX_COORDINATE};

/// A target surface: positions (#P x 3, any length unit) and triangles (#T x 3 indices into
/// them), any triangulation (not necessarily manifold or closed); no faces = a point cloud.
#[derive(Debug, Clone, Copy)]
pub struct Target<'a> {
    /// Points (#P x 3).
    pub positions: &'a [[f64; 3]],
    /// Triangles (#T x 3), possibly empty.
    pub faces: &'a [[u32; 3]],
}

/// A checked target with its search structure, face normals and boundary edges.
pub(crate) struct Prepared<'a> {
    pub positions: &'a [[f64; 3]],
    pub faces: &'a [[u32; 3]],
    pub index: SurfaceIndex,
    /// Unit face normals (#T x 3; zero for degenerate faces); empty for a point cloud.
    pub face_normals: Vec<[f64; 3]>,
    /// Area-weighted unit vertex normals (#P x 3); empty for a point cloud.
    pub vertex_normals: Vec<[f64; 3]>,
    /// Edges (sorted pairs) used by exactly one face.
    pub boundary: HashMap<(u32, u32), ()>,
    /// Per-point weights for moments (a third of the adjacent faces' areas; 1 for a cloud).
    pub weights: Vec<f64>,
}

impl Prepared<'_> {
    /// Whether the target has faces.
    pub fn is_surface(&self) -> bool {
        !self.faces.is_empty()
    }

    /// Whether the point with barycentric coordinates `bary` on face `f` lies on a boundary
    /// edge of the target.
    pub fn on_boundary(&self, f: usize, bary: [f64; 3]) -> bool {
        let face = self.faces[f];
        (0..3).any(|k| {
            bary[k] <= 1e-9 && {
                let (a, b) = (face[(k + 1) % 3], face[(k + 2) % 3]);
                self.boundary.contains_key(&(a.min(b), a.max(b)))
            }
        })
    }
}

fn check_points(what: &'static str, p: &[[f64; 3]]) -> Result<(), FitError> {
    if p.len() > MAX_VERTICES {
        return Err(FitError::TooLarge {
            what,
            count: p.len(),
            limit: MAX_VERTICES,
        });
    }
    match p
        .iter()
        .position(|x| x.iter().any(|c| !c.is_finite() || c.abs() > MAX_COORDINATE))
    {
        Some(vertex) => Err(FitError::NonFinite { what, vertex }),
        None => Ok(()),
    }
}

/// Checks a target and builds its search structure.
pub(crate) fn prepare<'a>(target: &Target<'a>) -> Result<Prepared<'a>, FitError> {
    let (pos, faces) = (target.positions, target.faces);
    if pos.is_empty() {
        return Err(FitError::EmptyTarget);
    }
    check_points("target", pos)?;
    if faces.len() > MAX_VERTICES {
        return Err(FitError::TooLarge {
            what: "target",
            count: faces.len(),
            limit: MAX_VERTICES,
        });
    }
    for (face, f) in faces.iter().enumerate() {
        if let Some(&index) = f.iter().find(|&&i| i as usize >= pos.len()) {
            return Err(FitError::FaceIndex {
                face,
                index,
                n_vertices: pos.len(),
            });
        }
    }
    let mut face_normals = Vec::with_capacity(faces.len());
    let mut vertex_normals = vec![[0.0; 3]; if faces.is_empty() { 0 } else { pos.len() }];
    let mut weights = vec![if faces.is_empty() { 1.0 } else { 0.0 }; pos.len()];
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for f in faces {
        let [a, b, c] = f.map(|i| pos[i as usize]);
        let n2 = cross(sub(b, a), sub(c, a));
        let l = norm(n2);
        face_normals.push(if l > 0.0 { scale(n2, 1.0 / l) } else { [0.0; 3] });
        for &i in f {
            vertex_normals[i as usize] = add(vertex_normals[i as usize], n2);
            weights[i as usize] += l / 6.0;
        }
        for k in 0..3 {
            let (u, v) = (f[k], f[(k + 1) % 3]);
            *edges.entry((u.min(v), u.max(v))).or_insert(0) += 1;
        }
    }
    for n in &mut vertex_normals {
        let l = norm(*n);
        if l > 0.0 {
            *n = scale(*n, 1.0 / l);
        }
    }
    let boundary = edges
        .into_iter()
        .filter(|e| e.1 == 1)
        .map(|e| (e.0, ()))
        .collect();
    let index = if faces.is_empty() {
        SurfaceIndex::points(pos)
    } else {
        SurfaceIndex::triangles(pos, faces)
    };
    Ok(Prepared {
        positions: pos,
        faces,
        index,
        face_normals,
        vertex_normals,
        boundary,
        weights,
    })
}

pub(crate) fn check_template(template: &Shape) -> Result<f64, FitError> {
    check_points("template", &template.positions)?;
    let topo = &template.topology;
    if topo.n_faces() == 0 {
        return Err(FitError::Template(TemplateProblem::NoFaces));
    }
    if let Some((v, _, fans)) = topo.nonmanifold_vertices().first() {
        return Err(FitError::Template(TemplateProblem::NotManifold {
            vertex: *v,
            fans: *fans,
        }));
    }
    let lbar = mean_edge_length(topo, &template.positions);
    if !(lbar.is_finite() && lbar > 0.0) {
        return Err(FitError::Template(TemplateProblem::ZeroEdgeLength));
    }
    Ok(lbar)
}
