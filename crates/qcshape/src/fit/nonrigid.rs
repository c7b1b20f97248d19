//! The non-rigid fit: the template's vertices `x` (#V x 3) pulled onto the target under a
//! deformation prior measured against the aligned template `p` (the rest shape).
//!
//! # Energy
//!
//! With `N(i)` the neighbours of vertex `i` and `A_i` a linear map (3 x 3) per vertex,
//!
//! `E(x) = alpha sum_i sum_{j in N(i)} |x_i - x_j - A_i (p_i - p_j)|^2`  (prior)
//! `     + sum_i c_i |x_i - y_i|^2`                 (point-to-surface: `y_i` the closest target point)
//! `     + sum_k w_k |sum_m b_km x_{f_k m} - s_k|^2` (surface-to-point: target sample `s_k`
//!                                                   pulls its closest template point, face `f_k`,
//!                                                   barycentric `b_k`)
//! `     + mu sum_i |x_i - a_i|^2`                  (a tiny anchor at the current positions,
//!                                                   `mu = 1e-6`, so the system is always definite)
//!
//! minimized by alternation (the local-global scheme of Sorkine and Alexa 2007): closest points
//! and robust weights, then the maps `A_i` from the current fit ([`local`]), then `x` by one
//! sparse linear solve (the same #V x #V matrix for the three coordinates; its symbolic Cholesky
//! factorization is made once per topology in `Solver::new`).
//!
//! # The priors
//!
//! The maps decide what the prior charges ([`super::Prior`], [`local`]):
//! - `smooth` (the default): affine maps near each fan's best similarity that vary smoothly
//!   over the surface. A smooth deformation of the whole shape (stretch, shear, taper, bend)
//!   is nearly free, local strain is charged; the fit then places vertices along the surface
//!   the way a smooth motion would, where the data (which only pin the normal position) leave
//!   it free.
//! - `arap`: rotations (as-rigid-as-possible, uniform edge weights): every edge strain is
//!   charged, the discrete analogue of the library's isometric metric. A smooth stretch costs
//!   as much as a local one, so the fit slides along the surface to spread it.
//! - `asap`: rotations times the fan's best uniform scale in `[0.5, 2]`.
//!
//! Uniform weights (not cotangent) stay positive on any triangulation; per-vertex maps make
//! the prior invariant to large bends and twists, which a linear (Laplacian) prior is not.
//!
//! # Robust weights
//!
//! A point-to-surface pair counts (`c_i = 1`) unless its distance exceeds
//! `max(3 median, outlier_distance lbar)`, or the closest point lies on a boundary edge of the
//! target (the template part beyond a partial target), or the normals differ by more than
//! `normal_angle` (surfaces only; the target's global orientation is detected, so inward
//! triangulations fit too). Surface-to-point pairs use the same rules on the template's side;
//! their weights sum to `surface_to_point * #V`.
//!
//! # Annealing
//!
//! `alpha` falls geometrically from `stiffness_start` to `stiffness_end` over `stages` stages
//! (Amberg et al. 2007): stiff stages find the gross shape, soft ones the detail. A stage ends
//! after `iterations` solves or when no vertex moves more than `1e-3 lbar`.

use std::collections::HashSet;
use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use rayon::prelude::*;

use super::closest::SurfaceIndex;
use super::error::FitError;
use super::local::{self, Mat3};
use super::options::FitOptions;
use super::rigid::stride;
use super::target::Prepared;
use crate::mesh::geometry::{
    add, dot, face_normals, largest_move, mean_edge_length, scale, sub, vertex_normals,
};
use crate::mesh::Topology;

/// Weight of the anchor term (relative to a data weight of 1).
const ANCHOR: f64 = 1e-6;

/// A template vertex overlaps the target when its correspondence is accepted and lies within
/// this many outlier distances (`outlier_distance lbar`); fewer than a tenth of the vertices
/// overlapping at the first iteration is [`FitError::NoOverlap`].
pub const OVERLAP: f64 = 5.0;

/// A stage ends when no vertex moved more than this many mean edge lengths.
const CONVERGED: f64 = 1e-3;

/// The fit's linear system structure (upper triangle of the #V x #V vertex-adjacency
/// pattern) with its symbolic Cholesky factorization (AMD), and the template's boundary edges.
pub(crate) struct Solver {
    topo: Arc<Topology>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
    boundary: HashSet<(u32, u32)>,
}

impl Solver {
    /// The structure and symbolic factorization for `topo`.
    pub fn new(topo: &Arc<Topology>) -> Result<Solver, FitError> {
        let nv = topo.n_vertices();
        let mut col_ptr = vec![0usize];
        let mut row_idx = Vec::new();
        for v in 0..nv {
            let mut rows: Vec<usize> = topo
                .neighbors(v)
                .iter()
                .map(|&u| u as usize)
                .filter(|&u| u < v)
                .collect();
            rows.push(v);
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend(rows);
            col_ptr.push(row_idx.len());
        }
        let sym = SymbolicSparseColMatRef::new_checked(nv, nv, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(FitError::Symbolic)?;
        let mut boundary = HashSet::new();
        for lp in topo.boundary_loops() {
            for k in 0..lp.len() {
                let (a, b) = (lp[k], lp[(k + 1) % lp.len()]);
                boundary.insert((a.min(b), a.max(b)));
            }
        }
        Ok(Solver {
            topo: topo.clone(),
            col_ptr,
            row_idx,
            symbolic,
            boundary,
        })
    }

    /// The template's topology.
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topo
    }

    /// Index of entry `(u, v)` (either order) in the upper CSC values.
    fn slot(&self, u: usize, v: usize) -> usize {
        let (r, c) = (u.min(v), u.max(v));
        let rows = &self.row_idx[self.col_ptr[c]..self.col_ptr[c + 1]];
        self.col_ptr[c] + rows.binary_search(&r).expect("entry in the adjacency pattern")
    }

    /// Solves `A X = B` in place (`rhs` column-major #V x 3), `A` given by its upper CSC values.
    fn solve(&self, vals: &[f64], rhs: &mut [f64]) -> Result<(), FitError> {
        let nv = self.topo.n_vertices();
        let sym = SymbolicSparseColMatRef::new_checked(nv, nv, &self.col_ptr, None, &self.row_idx);
        let mut l = vec![0.0; self.symbolic.len_val()];
        let par = Par::Seq;
        let mut mem = MemBuffer::new(
            self.symbolic
                .factorize_numeric_llt_scratch::<f64>(par, Default::default())
                .or(self.symbolic.solve_in_place_scratch::<f64>(3, par)),
        );
        self.symbolic
            .factorize_numeric_llt(
                &mut l,
                SparseColMatRef::new(sym, vals),
                Side::Upper,
                LltRegularization::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(FitError::Factorization)?;
        LltRef::new(&self.symbolic, &l).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, nv, 3),
            par,
            MemStack::new(&mut mem),
        );
        if rhs.iter().any(|v| !v.is_finite()) {
            return Err(FitError::NotFinite);
        }
        Ok(())
    }

    fn on_boundary(&self, f: [u32; 3], bary: [f64; 3]) -> bool {
        (0..3).any(|k| {
            bary[k] <= 1e-9 && {
                let (a, b) = (f[(k + 1) % 3], f[(k + 2) % 3]);
                self.boundary.contains(&(a.min(b), a.max(b)))
            }
        })
    }
}

/// A surface-to-point pull: target point `s` on the template point `sum bary_m x_{face_m}`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sample {
    /// The template face holding the pulled point.
    pub face: [u32; 3],
    /// Its barycentric coordinates on `face`.
    pub bary: [f64; 3],
    /// The pull's weight.
    pub weight: f64,
    /// The target point.
    pub s: [f64; 3],
    /// The target's unit normal at the target point (zero for a point cloud).
    pub n: [f64; 3],
}

/// The correspondences of one iteration at the current fit `x` (#V x 3).
pub(crate) struct Matches {
    /// Point-to-surface weight per template vertex (0 = rejected, else 1) (#V).
    pub c: Vec<f64>,
    /// The closest target point per template vertex (`x_i` itself when rejected) (#V x 3).
    pub y: Vec<[f64; 3]>,
    /// The target's unit normal at each closest point (zero when rejected or for a point
    /// cloud) (#V x 3).
    pub n: Vec<[f64; 3]>,
    /// The accepted surface-to-point pulls, weights summing to `surface_to_point * #V`.
    pub samples: Vec<Sample>,
    /// Template vertices with an accepted match within [`OVERLAP`] outlier distances.
    pub matched: usize,
}

/// The energy's terms at fixed rotations, correspondences and weights (see the module docs).
pub(crate) struct Terms {
    alpha: f64,
    /// The prior's per-vertex linear maps `A_i` ([`local::maps`]).
    maps: Vec<Mat3>,
    c: Vec<f64>,
    y: Vec<[f64; 3]>,
    samples: Vec<Sample>,
    anchor: Vec<[f64; 3]>,
}

fn rotate(r: &Mat3, v: [f64; 3]) -> [f64; 3] {
    r.map(|row| dot(row, v))
}

impl Terms {
    /// `E(x)` (rest shape `p`, #V x 3 each).
    #[cfg_attr(not(test), allow(dead_code))]
    fn energy(&self, topo: &Topology, p: &[[f64; 3]], x: &[[f64; 3]]) -> f64 {
        let mut e = 0.0;
        for i in 0..x.len() {
            for &j in topo.neighbors(i) {
                let j = j as usize;
                let d = sub(sub(x[i], x[j]), rotate(&self.maps[i], sub(p[i], p[j])));
                e += self.alpha * dot(d, d);
            }
            let d = sub(x[i], self.y[i]);
            e += self.c[i] * dot(d, d);
            let d = sub(x[i], self.anchor[i]);
            e += ANCHOR * dot(d, d);
        }
        for s in &self.samples {
            let mut q = [0.0; 3];
            for m in 0..3 {
                q = add(q, scale(x[s.face[m] as usize], s.bary[m]));
            }
            let d = sub(q, s.s);
            e += s.weight * dot(d, d);
        }
        e
    }

    /// `dE/dx` (#V x 3).
    #[cfg_attr(not(test), allow(dead_code))]
    fn gradient(&self, topo: &Topology, p: &[[f64; 3]], x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut g = vec![[0.0; 3]; x.len()];
        for i in 0..x.len() {
            for &j in topo.neighbors(i) {
                let j = j as usize;
                let d = sub(sub(x[i], x[j]), rotate(&self.maps[i], sub(p[i], p[j])));
                g[i] = add(g[i], scale(d, 2.0 * self.alpha));
                g[j] = sub(g[j], scale(d, 2.0 * self.alpha));
            }
            g[i] = add(g[i], scale(sub(x[i], self.y[i]), 2.0 * self.c[i]));
            g[i] = add(g[i], scale(sub(x[i], self.anchor[i]), 2.0 * ANCHOR));
        }
        for s in &self.samples {
            let mut q = [0.0; 3];
            for m in 0..3 {
                q = add(q, scale(x[s.face[m] as usize], s.bary[m]));
            }
            let d = sub(q, s.s);
            for m in 0..3 {
                let v = s.face[m] as usize;
                g[v] = add(g[v], scale(d, 2.0 * s.weight * s.bary[m]));
            }
        }
        g
    }

    /// The minimizer of `E` over `x` (one sparse solve): `(1/2) dE/dx = 0`.
    fn minimize(&self, solver: &Solver, p: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, FitError> {
        let topo = &solver.topo;
        let nv = topo.n_vertices();
        let mut vals = vec![0.0; solver.row_idx.len()];
        let mut rhs = vec![0.0; 3 * nv];
        let add_rhs = |rhs: &mut [f64], v: usize, d: [f64; 3]| {
            for k in 0..3 {
                rhs[k * nv + v] += d[k];
            }
        };
        for i in 0..nv {
            for &j in topo.neighbors(i) {
                let j = j as usize;
                let (sii, sjj, sij) = (solver.slot(i, i), solver.slot(j, j), solver.slot(i, j));
                vals[sii] += self.alpha;
                vals[sjj] += self.alpha;
                vals[sij] -= self.alpha;
                let r = scale(rotate(&self.maps[i], sub(p[i], p[j])), self.alpha);
                add_rhs(&mut rhs, i, r);
                add_rhs(&mut rhs, j, scale(r, -1.0));
            }
            vals[solver.slot(i, i)] += self.c[i] + ANCHOR;
            add_rhs(
                &mut rhs,
                i,
                add(scale(self.y[i], self.c[i]), scale(self.anchor[i], ANCHOR)),
            );
        }
        for s in &self.samples {
            for m in 0..3 {
                let u = s.face[m] as usize;
                add_rhs(&mut rhs, u, scale(s.s, s.weight * s.bary[m]));
                for n in m..3 {
                    let v = s.face[n] as usize;
                    vals[solver.slot(u, v)] += s.weight * s.bary[m] * s.bary[n];
                }
            }
        }
        solver.solve(&vals, &mut rhs)?;
        Ok((0..nv).map(|v| [rhs[v], rhs[nv + v], rhs[2 * nv + v]]).collect())
    }
}

/// The median of finite values (0 if none).
pub(crate) fn median(d: impl Iterator<Item = f64>) -> f64 {
    let mut d: Vec<f64> = d.filter(|x| x.is_finite()).collect();
    if d.is_empty() {
        return 0.0;
    }
    let k = d.len() / 2;
    *d.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The correspondences at `x` (closest points both ways, robust weights; see the module docs),
/// for the surface-to-point `samples` (target vertex indices).
pub(crate) fn matches(
    solver: &Solver,
    x: &[[f64; 3]],
    target: &Prepared,
    samples: &[usize],
    opts: &FitOptions,
    lbar: f64,
) -> Matches {
    let topo = &*solver.topo;
    let nv = x.len();
    let cos_max = opts.normal_angle.to_radians().cos();
    let normals = vertex_normals(topo, x);
    let hits: Vec<_> = x.par_iter().map(|q| target.index.closest(*q)).collect();
    // The target's orientation relative to the template's (+1 or -1), by majority.
    let sigma = if target.is_surface() {
        let s: f64 = hits
            .iter()
            .zip(&normals)
            .filter_map(|(h, n)| h.map(|h| dot(*n, target.face_normals[h.primitive as usize])))
            .sum();
        if s < 0.0 {
            -1.0
        } else {
            1.0
        }
    } else {
        1.0
    };
    let dist = |d2: f64| d2.sqrt();
    let tau =
        (3.0 * median(hits.iter().flatten().map(|h| dist(h.distance_sq)))).max(opts.outlier_distance * lbar);
    let mut c = vec![0.0; nv];
    let mut y = x.to_vec();
    let mut nrm = vec![[0.0; 3]; nv];
    let mut matched = 0;
    for i in 0..nv {
        let Some(h) = hits[i] else { continue };
        if dist(h.distance_sq) > tau {
            continue;
        }
        if target.is_surface() {
            let f = h.primitive as usize;
            if target.on_boundary(f, h.bary) || sigma * dot(normals[i], target.face_normals[f]) < cos_max {
                continue;
            }
        }
        c[i] = 1.0;
        if target.is_surface() {
            nrm[i] = target.face_normals[h.primitive as usize];
        }
        y[i] = if opts.point_to_plane && target.is_surface() {
            // Only the normal part of the pull: the target point moved to the foot of x_i on
            // the target's tangent plane at the closest point, so the data do not drag the
            // vertex along the surface (the prior places it there).
            let n = target.face_normals[h.primitive as usize];
            add(x[i], scale(n, dot(sub(h.point, x[i]), n)))
        } else {
            h.point
        };
        if dist(h.distance_sq) <= OVERLAP * opts.outlier_distance * lbar {
            matched += 1;
        }
    }
    let mut pulls = Vec::new();
    if opts.surface_to_point > 0.0 {
        let faces = topo.faces();
        let tindex = SurfaceIndex::triangles(x, faces);
        let fnormals = face_normals(topo, x);
        let found: Vec<_> = samples
            .par_iter()
            .map(|&k| (k, tindex.closest(target.positions[k])))
            .collect();
        let tau2 = (3.0 * median(found.iter().filter_map(|f| f.1).map(|h| dist(h.distance_sq))))
            .max(opts.outlier_distance * lbar);
        for (k, h) in found {
            let Some(h) = h else { continue };
            let face = faces[h.primitive as usize];
            if dist(h.distance_sq) > tau2 || solver.on_boundary(face, h.bary) {
                continue;
            }
            if target.is_surface()
                && sigma * dot(target.vertex_normals[k], fnormals[h.primitive as usize]) < cos_max
            {
                continue;
            }
            let s = if opts.point_to_plane {
                // The template point moves along the template's normal only.
                let n = fnormals[h.primitive as usize];
                add(h.point, scale(n, dot(sub(target.positions[k], h.point), n)))
            } else {
                target.positions[k]
            };
            pulls.push(Sample {
                face,
                bary: h.bary,
                weight: 1.0,
                s,
                n: if target.is_surface() {
                    target.vertex_normals[k]
                } else {
                    [0.0; 3]
                },
            });
        }
        let w = opts.surface_to_point * nv as f64 / pulls.len().max(1) as f64;
        for s in &mut pulls {
            s.weight = w;
        }
    }
    Matches {
        c,
        y,
        n: nrm,
        samples: pulls,
        matched,
    }
}

#[allow(clippy::too_many_arguments)]
/// Builds the terms at `x` (closest points, robust weights, rotations); also returns how many
/// template vertices found a correspondence within [`OVERLAP`] outlier distances.
fn terms(
    solver: &Solver,
    p: &[[f64; 3]],
    x: &[[f64; 3]],
    target: &Prepared,
    samples: &[usize],
    alpha: f64,
    opts: &FitOptions,
    lbar: f64,
) -> (Terms, usize) {
    let m = matches(solver, x, target, samples, opts, lbar);
    let t = Terms {
        alpha,
        maps: local::maps(&solver.topo, p, x, opts.prior, lbar),
        c: m.c,
        y: m.y,
        samples: m.samples,
        anchor: x.to_vec(),
    };
    (t, m.matched)
}

/// Fits the template from `start` (#V x 3) to `target` under the ARAP prior of the rest shape
/// `p` (#V x 3, the aligned template). Returns the fitted positions and the number of solves.
pub(crate) fn fit(
    solver: &Solver,
    p: &[[f64; 3]],
    start: Vec<[f64; 3]>,
    target: &Prepared,
    opts: &FitOptions,
) -> Result<(Vec<[f64; 3]>, usize), FitError> {
    let topo = &*solver.topo;
    let nv = topo.n_vertices();
    let lbar = mean_edge_length(topo, p);
    let samples: Vec<usize> = stride(target.positions.len(), opts.max_samples.max(2 * nv)).collect();
    let mut x = start;
    let mut solves = 0;
    let (s0, s1) = opts.stiffness();
    for stage in 0..opts.stages {
        let alpha = if opts.stages == 1 {
            s1
        } else {
            let f = stage as f64 / (opts.stages - 1) as f64;
            s0 * (s1 / s0).powf(f)
        };
        for _ in 0..opts.iterations {
            let (t, matched) = terms(solver, p, &x, target, &samples, alpha, opts, lbar);
            if solves == 0 && matched * 10 < nv {
                return Err(FitError::NoOverlap { matched, total: nv });
            }
            let next = t.minimize(solver, p)?;
            let moved = largest_move(&next, &x);
            x = next;
            solves += 1;
            if moved < CONVERGED * lbar {
                break;
            }
        }
    }
    Ok((x, solves))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::target::{prepare, Target};
    use crate::synth::icosphere;

    #[test]
    fn gradient_matches_finite_differences_and_the_solve_is_stationary() {
        let s = icosphere(1);
        let solver = Solver::new(&s.topology).unwrap();
        let p = &s.positions;
        let x: Vec<[f64; 3]> = p
            .iter()
            .map(|q| [1.2 * q[0] + 0.1 * q[2], q[1] + 0.05, 0.8 * q[2]])
            .collect();
        let target: Vec<[f64; 3]> = icosphere(2).positions.iter().map(|q| scale(*q, 1.1)).collect();
        let faces = icosphere(2).topology.faces().to_vec();
        let prepared = prepare(&Target {
            positions: &target,
            faces: &faces,
        })
        .unwrap();
        let opts = FitOptions::default();
        let samples: Vec<usize> = (0..target.len()).collect();
        let (t, matched) = terms(&solver, p, &x, &prepared, &samples, 0.7, &opts, 0.3);
        assert!(matched > 0 && !t.samples.is_empty());
        let g = t.gradient(&s.topology, p, &x);
        let h = 1e-6;
        for v in [0, 5, 17, 41] {
            for k in 0..3 {
                let mut a = x.clone();
                let mut b = x.clone();
                a[v][k] += h;
                b[v][k] -= h;
                let fd = (t.energy(&s.topology, p, &a) - t.energy(&s.topology, p, &b)) / (2.0 * h);
                assert!(
                    (fd - g[v][k]).abs() < 1e-5 * (1.0 + fd.abs()),
                    "{v} {k}: {fd} vs {}",
                    g[v][k]
                );
            }
        }
        let min = t.minimize(&solver, p).unwrap();
        let g = t.gradient(&s.topology, p, &min);
        let gmax = g.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(gmax < 1e-9, "{gmax}");
        assert!(t.energy(&s.topology, p, &min) < t.energy(&s.topology, p, &x));
    }
}
