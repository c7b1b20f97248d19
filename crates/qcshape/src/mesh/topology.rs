use std::collections::HashMap;
use std::sync::Arc;

use super::MeshError;

/// Sentinel for "no face" in [`Topology::edge_faces`].
pub const NO_FACE: u32 = u32::MAX;

/// Immutable triangle connectivity shared by every shape compared together.
///
/// Built once by [`Topology::new`], which validates the face list, and then shared through an
/// `Arc`. Holds the faces (#F x 3, consistently oriented), the unique undirected edges (#E x 2,
/// each stored as `(min, max)`), the faces beside each edge, vertex one-rings and boundary loops.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    n_vertices: usize,
    faces: Vec<[u32; 3]>,
    edges: Vec<[u32; 2]>,
    edge_faces: Vec<[u32; 2]>,
    /// `face_edges[f][k]` is the edge between corners `k` and `k+1 (mod 3)` of face `f`.
    face_edges: Vec<[u32; 3]>,
    vf_offsets: Vec<u32>,
    vf: Vec<(u32, u8)>,
    vv_offsets: Vec<u32>,
    vv: Vec<u32>,
    boundary_vertex: Vec<bool>,
    boundary_loops: Vec<Vec<u32>>,
}

impl Topology {
    /// Builds and validates a topology from `n_vertices` and a face list (#F x 3).
    ///
    /// Errors, in this order: no faces, an index out of range, a repeated index in a face, a
    /// duplicated face, an edge shared by more than two faces (with the count), two faces
    /// inconsistently oriented across an edge, a non-manifold ("bowtie") vertex. Isolated
    /// vertices (in no face) are allowed; [`Topology::isolated_vertices`] lists them.
    pub fn new(n_vertices: usize, faces: Vec<[u32; 3]>) -> Result<Arc<Self>, MeshError> {
        let t = Self::allowing_nonmanifold_vertices(n_vertices, faces)?;
        if let Some((vertex, faces, fans)) = t.nonmanifold_vertices().first().copied() {
            return Err(MeshError::NonManifoldVertex { vertex, faces, fans });
        }
        Ok(t)
    }

    /// [`Topology::new`] without the non-manifold vertex check (a surface may touch itself at
    /// single vertices; [`Topology::nonmanifold_vertices`] lists them). Every other check
    /// stays: a non-manifold edge or a duplicated face cannot be represented.
    pub fn allowing_nonmanifold_vertices(
        n_vertices: usize,
        faces: Vec<[u32; 3]>,
    ) -> Result<Arc<Self>, MeshError> {
        if faces.is_empty() {
            return Err(MeshError::NoFaces);
        }
        for (f, t) in faces.iter().enumerate() {
            for &i in t {
                if i as usize >= n_vertices {
                    return Err(MeshError::IndexOutOfRange {
                        face: f,
                        index: i as usize,
                        n_vertices,
                    });
                }
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(MeshError::RepeatedIndex { face: f, indices: *t });
            }
        }
        // Duplicated faces, then edges with more than two faces, before the orientation check
        // (which would otherwise report them as inconsistent orientation).
        let mut seen_faces: HashMap<[u32; 3], usize> = HashMap::with_capacity(faces.len());
        let mut edge_count: HashMap<(u32, u32), usize> = HashMap::with_capacity(faces.len() * 2);
        for (f, t) in faces.iter().enumerate() {
            let mut key = *t;
            key.sort_unstable();
            if let Some(&f0) = seen_faces.get(&key) {
                return Err(MeshError::DuplicateFace {
                    f0,
                    f1: f,
                    indices: *t,
                });
            }
            seen_faces.insert(key, f);
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edge_count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        if let Some((&(a, b), &count)) = edge_count.iter().filter(|(_, &c)| c > 2).min_by_key(|(&k, _)| k) {
            return Err(MeshError::NonManifoldEdge { a, b, count });
        }
        // Directed half-edges -> face; undirected edges -> index.
        let mut directed: HashMap<(u32, u32), usize> = HashMap::with_capacity(faces.len() * 3);
        let mut edge_index: HashMap<(u32, u32), u32> = HashMap::with_capacity(faces.len() * 2);
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(faces.len() * 3 / 2 + 8);
        let mut edge_faces: Vec<[u32; 2]> = Vec::with_capacity(edges.capacity());
        let mut face_edges = Vec::with_capacity(faces.len());
        for (f, t) in faces.iter().enumerate() {
            let mut fe = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if let Some(&f0) = directed.get(&(a, b)) {
                    return Err(MeshError::InconsistentOrientation { f0, f1: f, a, b });
                }
                directed.insert((a, b), f);
                let key = (a.min(b), a.max(b));
                let e = *edge_index.entry(key).or_insert_with(|| {
                    edges.push([key.0, key.1]);
                    edge_faces.push([NO_FACE, NO_FACE]);
                    (edges.len() - 1) as u32
                });
                let slot = &mut edge_faces[e as usize];
                if slot[0] == NO_FACE {
                    slot[0] = f as u32;
                } else if slot[1] == NO_FACE {
                    slot[1] = f as u32;
                } else {
                    let count = faces
                        .iter()
                        .filter(|g| {
                            (0..3).any(|j| {
                                let (x, y) = (g[j], g[(j + 1) % 3]);
                                (x.min(y), x.max(y)) == key
                            })
                        })
                        .count();
                    return Err(MeshError::NonManifoldEdge {
                        a: key.0,
                        b: key.1,
                        count,
                    });
                }
                fe[k] = e;
            }
            face_edges.push(fe);
        }
        // Vertex -> (face, corner), CSR.
        let mut vf_offsets = vec![0u32; n_vertices + 1];
        for t in &faces {
            for &v in t {
                vf_offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..n_vertices {
            vf_offsets[i + 1] += vf_offsets[i];
        }
        let mut fill = vf_offsets.clone();
        let mut vf = vec![(0u32, 0u8); faces.len() * 3];
        for (f, t) in faces.iter().enumerate() {
            for (k, &v) in t.iter().enumerate() {
                vf[fill[v as usize] as usize] = (f as u32, k as u8);
                fill[v as usize] += 1;
            }
        }
        // Vertex -> neighbours, CSR, sorted.
        let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); n_vertices];
        for e in &edges {
            nbrs[e[0] as usize].push(e[1]);
            nbrs[e[1] as usize].push(e[0]);
        }
        let mut vv_offsets = Vec::with_capacity(n_vertices + 1);
        let mut vv = Vec::with_capacity(edges.len() * 2);
        vv_offsets.push(0u32);
        for mut n in nbrs {
            n.sort_unstable();
            vv.extend_from_slice(&n);
            vv_offsets.push(vv.len() as u32);
        }
        // Boundary: edges with one face; loops follow the boundary half-edges.
        let mut boundary_vertex = vec![false; n_vertices];
        let mut next: HashMap<u32, u32> = HashMap::new();
        for (e, ef) in edges.iter().zip(&edge_faces) {
            if ef[1] == NO_FACE {
                boundary_vertex[e[0] as usize] = true;
                boundary_vertex[e[1] as usize] = true;
                // The face traverses (a, b); the boundary loop runs (b -> a) so that it keeps
                // the surface on its left when seen from outside.
                let (a, b) = if directed.contains_key(&(e[0], e[1])) {
                    (e[0], e[1])
                } else {
                    (e[1], e[0])
                };
                next.insert(b, a);
            }
        }
        let mut boundary_loops = Vec::new();
        let mut starts: Vec<u32> = next.keys().copied().collect();
        starts.sort_unstable();
        let mut seen = std::collections::HashSet::new();
        for s in starts {
            if seen.contains(&s) {
                continue;
            }
            let mut lp = vec![s];
            seen.insert(s);
            let mut cur = s;
            while let Some(&n) = next.get(&cur) {
                if n == s || !seen.insert(n) {
                    break;
                }
                lp.push(n);
                cur = n;
            }
            boundary_loops.push(lp);
        }
        Ok(Arc::new(Topology {
            n_vertices,
            faces,
            edges,
            edge_faces,
            face_edges,
            vf_offsets,
            vf,
            vv_offsets,
            vv,
            boundary_vertex,
            boundary_loops,
        }))
    }

    /// The non-manifold ("bowtie") vertices: `(vertex, faces at it, fans)` for every vertex
    /// whose faces form more than one edge-connected fan, ascending.
    pub fn nonmanifold_vertices(&self) -> Vec<(usize, usize, usize)> {
        let mut out = Vec::new();
        let mut stack = Vec::new();
        let mut seen: Vec<u32> = Vec::new();
        for v in 0..self.n_vertices {
            let around = self.vertex_faces(v);
            if around.len() < 2 {
                continue;
            }
            seen.clear();
            let mut fans = 0;
            for &(f0, _) in around {
                if seen.contains(&f0) {
                    continue;
                }
                fans += 1;
                seen.push(f0);
                stack.push(f0);
                while let Some(f) = stack.pop() {
                    let t = self.faces[f as usize];
                    for k in 0..3 {
                        // The two edges of f at v.
                        if t[k] as usize != v && t[(k + 1) % 3] as usize != v {
                            continue;
                        }
                        for &g in &self.edge_faces[self.face_edges[f as usize][k] as usize] {
                            if g != NO_FACE && !seen.contains(&g) {
                                seen.push(g);
                                stack.push(g);
                            }
                        }
                    }
                }
            }
            if fans > 1 {
                out.push((v, around.len(), fans));
            }
        }
        out
    }

    /// Number of vertices #V (including isolated ones).
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }
    /// Number of faces #F.
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }
    /// Number of undirected edges #E.
    pub fn n_edges(&self) -> usize {
        self.edges.len()
    }
    /// The faces (#F x 3), counter-clockwise as given.
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }
    /// The unique undirected edges (#E x 2), each `(min, max)`.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }
    /// The one or two faces beside each edge (#E x 2; `u32::MAX` marks a boundary side).
    pub fn edge_faces(&self) -> &[[u32; 2]] {
        &self.edge_faces
    }
    /// `face_edges()[f][k]` is the edge joining corners `k` and `(k+1) % 3` of face `f`.
    pub fn face_edges(&self) -> &[[u32; 3]] {
        &self.face_edges
    }
    /// The faces around vertex `v`, each with the corner (0, 1, 2) at which `v` sits.
    pub fn vertex_faces(&self, v: usize) -> &[(u32, u8)] {
        &self.vf[self.vf_offsets[v] as usize..self.vf_offsets[v + 1] as usize]
    }
    /// The vertices joined to `v` by an edge, sorted ascending.
    pub fn neighbors(&self, v: usize) -> &[u32] {
        &self.vv[self.vv_offsets[v] as usize..self.vv_offsets[v + 1] as usize]
    }
    /// Whether vertex `v` lies on a boundary (an edge with a single face).
    pub fn is_boundary_vertex(&self, v: usize) -> bool {
        self.boundary_vertex[v]
    }
    /// Boundary loops, each a cycle of vertex indices (empty for a closed surface).
    pub fn boundary_loops(&self) -> &[Vec<u32>] {
        &self.boundary_loops
    }
    /// Vertices that belong to no face.
    pub fn isolated_vertices(&self) -> Vec<usize> {
        (0..self.n_vertices)
            .filter(|&v| self.vertex_faces(v).is_empty())
            .collect()
    }
    /// Number of connected components of the face graph (isolated vertices not counted).
    pub fn n_components(&self) -> usize {
        let mut parent: Vec<u32> = (0..self.n_vertices as u32).collect();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        for e in &self.edges {
            let (a, b) = (find(&mut parent, e[0]), find(&mut parent, e[1]));
            if a != b {
                parent[a as usize] = b;
            }
        }
        (0..self.n_vertices)
            .filter(|&v| !self.vertex_faces(v).is_empty() && find(&mut parent, v as u32) == v as u32)
            .count()
    }
    /// Euler characteristic `chi = V - E + F`, counting only vertices that belong to a face.
    pub fn euler_characteristic(&self) -> i64 {
        let v = (self.n_vertices - self.isolated_vertices().len()) as i64;
        v - self.edges.len() as i64 + self.faces.len() as i64
    }
    /// Genus of a connected orientable surface, `g = (2 - chi - b) / 2` with `b` boundary
    /// loops; `None` when the mesh has several components.
    pub fn genus(&self) -> Option<i64> {
        if self.n_components() != 1 {
            return None;
        }
        Some((2 - self.euler_characteristic() - self.boundary_loops.len() as i64) / 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed octahedron on vertices `o..o + 6`.
    fn octahedron(o: u32) -> Vec<[u32; 3]> {
        let f = [
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        f.iter().map(|t| t.map(|i| i + o)).collect()
    }

    #[test]
    fn non_manifold_input_is_named_with_indices() {
        assert!(Topology::new(6, octahedron(0)).is_ok());
        // A duplicated face (any corner order).
        let mut f = octahedron(0);
        f.push([2, 4, 0]);
        assert_eq!(
            Topology::new(6, f).unwrap_err(),
            MeshError::DuplicateFace {
                f0: 0,
                f1: 8,
                indices: [2, 4, 0]
            }
        );
        // An edge with three and with four faces.
        let mut f = octahedron(0);
        f.push([0, 2, 6]);
        assert_eq!(
            Topology::new(7, f.clone()).unwrap_err(),
            MeshError::NonManifoldEdge { a: 0, b: 2, count: 3 }
        );
        f.push([2, 0, 7]);
        assert_eq!(
            Topology::new(8, f).unwrap_err(),
            MeshError::NonManifoldEdge { a: 0, b: 2, count: 4 }
        );
        // Two octahedra sharing vertex 0 (vertex 6 of the second is renamed 0).
        let mut f = octahedron(0);
        f.extend(
            octahedron(6)
                .into_iter()
                .map(|t| t.map(|i| if i == 6 { 0 } else { i })),
        );
        let e = Topology::new(12, f.clone()).unwrap_err();
        assert_eq!(
            e,
            MeshError::NonManifoldVertex {
                vertex: 0,
                faces: 8,
                fans: 2
            }
        );
        let t = Topology::allowing_nonmanifold_vertices(12, f).unwrap();
        assert_eq!(t.nonmanifold_vertices(), vec![(0, 8, 2)]);
        // A bowtie of two open triangles.
        let e = Topology::new(5, vec![[0, 1, 2], [0, 3, 4]]).unwrap_err();
        assert!(e.to_string().contains("vertex 0 is non-manifold"), "{e}");
    }
}
