//! Prolongation from a coarse level to the next finer one (paper section 2.2.1, docs/method.md
//! "Temporal interpolation").
//!
//! Every fine vertex either is kept in the coarse level (it takes the coarse value directly) or
//! was projected onto the coarse mesh at the rest pose (closest point over all coarse
//! triangles, found with a uniform grid) and takes the barycentric combination of the coarse
//! values at that triangle's corners.

use crate::mesh::{geometry, Topology};

/// Where a fine vertex takes its value from in the coarse level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// The vertex is coarse vertex `id` itself.
    Kept(u32),
    /// The vertex projects onto coarse face `face` with corners `corners` (coarse vertex ids)
    /// and barycentric coordinates `bary` (non-negative, summing to 1).
    Face {
        /// Coarse face index.
        face: u32,
        /// The face's coarse vertex ids.
        corners: [u32; 3],
        /// Barycentric coordinates of the projection.
        bary: [f64; 3],
    },
}

/// Linear map from coarse vertex values (#Vc x 3) to fine vertex values (#Vf x 3).
#[derive(Debug, Clone)]
pub struct Prolongation {
    sources: Vec<Source>,
    n_coarse: usize,
    max_distance: f64,
}

impl Prolongation {
    /// Builds the map for a coarse level whose vertex `i` is fine vertex `kept[i]`.
    ///
    /// `coarse` is the coarse topology (on `kept.len()` vertices) and `fine_rest` the fine rest
    /// pose (#Vf x 3): the coarse rest pose is `fine_rest[kept[i]]`. Every fine vertex not in
    /// `kept` is projected onto the closest coarse triangle. `kept` must hold distinct ids below
    /// `fine_rest.len()` (the hierarchy guarantees it).
    pub fn new(coarse: &Topology, kept: &[u32], fine_rest: &[[f64; 3]]) -> Self {
        let coarse_rest: Vec<[f64; 3]> = kept.iter().map(|&i| fine_rest[i as usize]).collect();
        let mut coarse_of = vec![u32::MAX; fine_rest.len()];
        for (c, &f) in kept.iter().enumerate() {
            coarse_of[f as usize] = c as u32;
        }
        let grid = TriangleGrid::new(coarse.faces(), &coarse_rest, fine_rest);
        let mut stamp = vec![0u32; coarse.n_faces()];
        let mut max_distance: f64 = 0.0;
        let sources = fine_rest
            .iter()
            .enumerate()
            .map(|(v, &p)| {
                if coarse_of[v] != u32::MAX {
                    return Source::Kept(coarse_of[v]);
                }
                let (face, bary, d2) =
                    grid.closest(p, coarse.faces(), &coarse_rest, &mut stamp, v as u32 + 1);
                max_distance = max_distance.max(d2.sqrt());
                Source::Face {
                    face,
                    corners: coarse.faces()[face as usize],
                    bary,
                }
            })
            .collect();
        Prolongation {
            sources,
            n_coarse: kept.len(),
            max_distance,
        }
    }

    /// Per fine vertex, where its value comes from.
    pub fn sources(&self) -> &[Source] {
        &self.sources
    }
    /// Number of fine vertices #Vf.
    pub fn n_fine(&self) -> usize {
        self.sources.len()
    }
    /// Number of coarse vertices #Vc.
    pub fn n_coarse(&self) -> usize {
        self.n_coarse
    }
    /// Largest distance (rest-pose units) from a projected fine vertex to its coarse triangle.
    pub fn max_distance(&self) -> f64 {
        self.max_distance
    }

    /// Carries a coarse field (#Vc x 3) to the fine vertices (#Vf x 3).
    pub fn apply(&self, coarse: &[[f64; 3]]) -> Vec<[f64; 3]> {
        assert_eq!(
            coarse.len(),
            self.n_coarse,
            "coarse field has the wrong vertex count"
        );
        self.sources
            .iter()
            .map(|s| match *s {
                Source::Kept(c) => coarse[c as usize],
                Source::Face { corners, bary, .. } => {
                    let [a, b, c] = corners.map(|i| coarse[i as usize]);
                    [0, 1, 2].map(|k| bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k])
                }
            })
            .collect()
    }

    /// Starting interior poses at the fine level from a coarse path (docs/method.md "Temporal
    /// interpolation"): pose `i` of a path with `N = coarse_interior.len() + 1` segments is
    /// `fine_linear(t) + apply(coarse_i - coarse_linear(t))` with `t = i / N`, where the linear
    /// paths run from `a` to `b` at each level. Kept vertices thus take the coarse pose exactly,
    /// and a coarse path that is exactly linear gives the fine linear path.
    ///
    /// `fine_a`, `fine_b`: #Vf x 3; `coarse_a`, `coarse_b` and each coarse interior pose: #Vc x 3.
    pub fn prolong_path(
        &self,
        fine_a: &[[f64; 3]],
        fine_b: &[[f64; 3]],
        coarse_a: &[[f64; 3]],
        coarse_b: &[[f64; 3]],
        coarse_interior: &[Vec<[f64; 3]>],
    ) -> Vec<Vec<[f64; 3]>> {
        let n = coarse_interior.len() + 1;
        coarse_interior
            .iter()
            .enumerate()
            .map(|(k, pose)| {
                let t = (k + 1) as f64 / n as f64;
                let lin = |p: [f64; 3], q: [f64; 3]| [0, 1, 2].map(|c| (1.0 - t) * p[c] + t * q[c]);
                let correction: Vec<[f64; 3]> = pose
                    .iter()
                    .zip(coarse_a.iter().zip(coarse_b))
                    .map(|(x, (&p, &q))| geometry::sub(*x, lin(p, q)))
                    .collect();
                self.apply(&correction)
                    .into_iter()
                    .zip(fine_a.iter().zip(fine_b))
                    .map(|(d, (&p, &q))| geometry::add(lin(p, q), d))
                    .collect()
            })
            .collect()
    }
}

/// Uniform grid of triangles (by bounding box) for closest-triangle queries.
struct TriangleGrid {
    origin: [f64; 3],
    h: f64,
    dims: [usize; 3],
    offsets: Vec<u32>,
    tris: Vec<u32>,
}

impl TriangleGrid {
    /// Grid over the bounding box of `extent` (which must contain every query point) and the
    /// triangles.
    fn new(faces: &[[u32; 3]], pos: &[[f64; 3]], extent: &[[f64; 3]]) -> Self {
        let (mut lo, mut hi) = geometry::bounding_box(extent);
        let (plo, phi) = geometry::bounding_box(pos);
        for c in 0..3 {
            lo[c] = lo[c].min(plo[c]);
            hi[c] = hi[c].max(phi[c]);
        }
        // Cell size: the mean triangle extent, grown until the grid has at most ~4 cells per
        // triangle.
        let mean_edge = faces
            .iter()
            .map(|f| geometry::norm(geometry::sub(pos[f[0] as usize], pos[f[1] as usize])))
            .sum::<f64>()
            / faces.len().max(1) as f64;
        let size = geometry::sub(hi, lo);
        let diag = geometry::norm(size);
        let mut h = if mean_edge > 0.0 { mean_edge } else { diag.max(1.0) };
        let dims_for = |h: f64| size.map(|s| ((s / h).floor() as usize + 1).max(1));
        let mut dims = dims_for(h);
        while dims.iter().product::<usize>() > 4 * faces.len() + 64 {
            h *= 1.5;
            dims = dims_for(h);
        }
        let cell = |p: [f64; 3]| -> [usize; 3] {
            [0, 1, 2].map(|c| (((p[c] - lo[c]) / h).floor().max(0.0) as usize).min(dims[c] - 1))
        };
        let index = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
        let n_cells = dims.iter().product::<usize>();
        let ranges: Vec<([usize; 3], [usize; 3])> = faces
            .iter()
            .map(|f| {
                let (a, b) = geometry::bounding_box(&f.map(|i| pos[i as usize]));
                (cell(a), cell(b))
            })
            .collect();
        let mut counts = vec![0u32; n_cells + 1];
        let visit = |(a, b): &([usize; 3], [usize; 3]), f: &mut dyn FnMut(usize)| {
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        f(index([x, y, z]));
                    }
                }
            }
        };
        for r in &ranges {
            visit(r, &mut |k| counts[k + 1] += 1);
        }
        for k in 0..n_cells {
            counts[k + 1] += counts[k];
        }
        let mut fill = counts.clone();
        let mut tris = vec![0u32; counts[n_cells] as usize];
        for (t, r) in ranges.iter().enumerate() {
            visit(r, &mut |k| {
                tris[fill[k] as usize] = t as u32;
                fill[k] += 1;
            });
        }
        TriangleGrid {
            origin: lo,
            h,
            dims,
            offsets: counts,
            tris,
        }
    }

    /// Closest triangle to `p`: (face, barycentric coordinates, squared distance). `stamp`
    /// (one slot per face) and a query id unique to this call avoid testing a face twice.
    fn closest(
        &self,
        p: [f64; 3],
        faces: &[[u32; 3]],
        pos: &[[f64; 3]],
        stamp: &mut [u32],
        query: u32,
    ) -> (u32, [f64; 3], f64) {
        let d = self.dims;
        let c: [i64; 3] = [0, 1, 2]
            .map(|k| (((p[k] - self.origin[k]) / self.h).floor().max(0.0) as i64).min(d[k] as i64 - 1));
        let mut best = (0u32, [1.0, 0.0, 0.0], f64::INFINITY);
        let max_r = *d.iter().max().expect("three dimensions") as i64;
        for r in 0..=max_r {
            for z in c[2] - r..=c[2] + r {
                for y in c[1] - r..=c[1] + r {
                    for x in c[0] - r..=c[0] + r {
                        let on_shell =
                            (x - c[0]).abs() == r || (y - c[1]).abs() == r || (z - c[2]).abs() == r;
                        if !on_shell
                            || x < 0
                            || y < 0
                            || z < 0
                            || x >= d[0] as i64
                            || y >= d[1] as i64
                            || z >= d[2] as i64
                        {
                            continue;
                        }
                        let k = ((z as usize * d[1]) + y as usize) * d[0] + x as usize;
                        for &t in &self.tris[self.offsets[k] as usize..self.offsets[k + 1] as usize] {
                            if stamp[t as usize] == query {
                                continue;
                            }
                            stamp[t as usize] = query;
                            let [a, b, cc] = faces[t as usize].map(|i| pos[i as usize]);
                            let (q, bary) = geometry::closest_point_on_triangle(p, a, b, cc);
                            let dq = geometry::sub(p, q);
                            let d2 = geometry::dot(dq, dq);
                            if d2 < best.2 {
                                best = (t, bary, d2);
                            }
                        }
                    }
                }
            }
            // Every cell not yet visited is at least r * h away from p.
            let reach = r as f64 * self.h;
            if best.2.is_finite() && best.2 <= reach * reach {
                break;
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::icosphere;

    #[test]
    fn closest_point_matches_a_dense_search() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.2, 1.0, 0.1]);
        for p in [
            [0.3, 0.3, 0.5],
            [-1.0, -1.0, 0.0],
            [2.0, -0.1, 0.0],
            [0.5, -1.0, 0.3],
            [0.0, 2.0, 0.0],
            [1.0, 1.0, -0.4],
        ] {
            let (q, bary) = geometry::closest_point_on_triangle(p, a, b, c);
            assert!(bary.iter().all(|&x| x >= -1e-12) && (bary.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let rebuilt = [0, 1, 2].map(|k| bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k]);
            assert!(geometry::norm(geometry::sub(rebuilt, q)) < 1e-12);
            let dq = geometry::norm(geometry::sub(p, q));
            let n = 200;
            for i in 0..=n {
                for j in 0..=n - i {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let s = [0, 1, 2].map(|k| (1.0 - u - v) * a[k] + u * b[k] + v * c[k]);
                    assert!(geometry::norm(geometry::sub(p, s)) >= dq - 1e-12);
                }
            }
        }
    }

    #[test]
    fn grid_query_finds_the_brute_force_closest_triangle() {
        // Coarse: icosphere(1) vertices are the first 42 of icosphere(3) (subdivision appends).
        let coarse = icosphere(1);
        let fine = icosphere(3);
        let kept: Vec<u32> = (0..42).collect();
        let pr = Prolongation::new(&coarse.topology, &kept, &fine.positions);
        for (v, s) in pr.sources().iter().enumerate() {
            match *s {
                Source::Kept(c) => assert_eq!(c as usize, v),
                Source::Face { face, bary, .. } => {
                    let p = fine.positions[v];
                    let dist = |f: usize| {
                        let [a, b, c] = coarse.topology.faces()[f].map(|i| coarse.positions[i as usize]);
                        geometry::norm(geometry::sub(
                            p,
                            geometry::closest_point_on_triangle(p, a, b, c).0,
                        ))
                    };
                    let brute = (0..coarse.topology.n_faces())
                        .map(dist)
                        .fold(f64::INFINITY, f64::min);
                    assert!(dist(face as usize) <= brute + 1e-12, "vertex {v}");
                    assert!(bary.iter().all(|&x| x >= -1e-12));
                }
            }
        }
        assert!(pr.max_distance() > 0.0 && pr.max_distance() < 0.2);
    }
}
