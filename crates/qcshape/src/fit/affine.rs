//! The affine-field prior ([`super::Prior::Affine`]): one affine map per template vertex, with
//! the stiffness of Amberg, Romdhani and Vetter's optimal-step non-rigid ICP (CVPR 2007), the
//! method of trimesh's `nricp_amberg`.
//!
//! # Energy
//!
//! Each template vertex `i` carries an affine map `X_i` (4 x 3: `x_i = X_i^T [p_i; 1]`, `p` the
//! rest shape). With `E` the template's edges,
//!
//! `E(X) = alpha sum_{(i,j) in E} |G (X_i - X_j)|_F^2`   (stiffness; `G = diag(1, 1, 1, gamma)`)
//! `     + sum_i c_i |X_i^T d_i - y_i|^2`               (point-to-surface, `d_i = [p_i; 1]`)
//! `     + sum_k w_k |sum_m b_km X_{f_km}^T d_{f_km} - s_k|^2` (surface-to-point samples)
//! `     + beta sum_l |X_l^T d_l - q_l|^2`               (landmarks: vertex `l` onto point `q_l`)
//! `     + mu sum_i |X_i - X_i^0|_F^2`                  (a tiny anchor, `mu = 1e-8`)
//!
//! in coordinates where the rest shape has its centroid at 0 and rms radius 1 (so the fit does
//! not depend on the unit or the size). The minimizer over `X` is one sparse solve of a
//! 4#V x 4#V system (three right-hand sides); its symbolic Cholesky factorization is made once
//! per topology (`AffineSolver::new`).
//!
//! # Schedule
//!
//! Unlike the edge-vector priors, the stiffness here is a diffusion length: at `alpha` the maps
//! vary over about `sqrt(alpha)` edges. `alpha` falls geometrically from `stiffness_start *
//! #V` (the whole template moves as nearly one affine map: the gross shape, a bend, a taper
//! are found first, without local sliding) to `stiffness_end` (detail at the scale of an edge)
//! over `stages` stages, each ending when no vertex moved more than `1e-3` mean edge lengths
//! or after `iterations` solves. Correspondences are refreshed at every iteration (closest
//! points both ways, normal and distance tests: `nonrigid::matches`).

// Index loops over the 4 x 3 maps and 4 x 4 blocks read as the formulas.
#![allow(clippy::needless_range_loop)]

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use super::error::FitError;
use super::nonrigid::{matches, Sample, Solver};
use super::options::FitOptions;
use super::rigid::stride;
use super::target::Prepared;
use crate::align::{horn_rotation, Motion};
use crate::mesh::geometry::{centroid_and_rms_radius, dot, largest_move, mean_edge_length, sub};
use crate::mesh::Topology;

/// Weight of the translation column against the linear part in the stiffness (`gamma`).
pub const GAMMA: f64 = 1.0;

/// Anchor weight `mu` (keeps the system definite where no data reach).
const ANCHOR: f64 = 1e-8;

/// A stage ends when no vertex moved more than this many mean edge lengths.
const CONVERGED: f64 = 1e-3;

/// A landmark: template vertex `vertex` should land on `point` (target units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark {
    /// The template vertex.
    pub vertex: usize,
    /// Its position on the target (target units).
    pub point: [f64; 3],
}

/// The 4#V x 4#V system's pattern (upper triangle, CSC, 4 x 4 blocks on the template's vertex
/// adjacency) and its symbolic Cholesky factorization (AMD).
pub(crate) struct AffineSolver {
    nv: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
}

type Block = [[f64; 4]; 4];

impl AffineSolver {
    /// The pattern and symbolic factorization for `topo`.
    pub fn new(topo: &Topology) -> Result<AffineSolver, FitError> {
        let nv = topo.n_vertices();
        let mut col_ptr = vec![0usize];
        let mut row_idx = Vec::new();
        for v in 0..nv {
            let mut lower: Vec<usize> = topo
                .neighbors(v)
                .iter()
                .map(|&u| u as usize)
                .filter(|&u| u < v)
                .collect();
            lower.sort_unstable();
            lower.dedup();
            for a in 0..4 {
                for &u in &lower {
                    row_idx.extend(4 * u..4 * u + 4);
                }
                row_idx.extend(4 * v..=4 * v + a);
                col_ptr.push(row_idx.len());
            }
        }
        let n = 4 * nv;
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(FitError::Symbolic)?;
        Ok(AffineSolver {
            nv,
            col_ptr,
            row_idx,
            symbolic,
        })
    }

    fn slot(&self, r: usize, c: usize) -> usize {
        let (r, c) = (r.min(c), r.max(c));
        let rows = &self.row_idx[self.col_ptr[c]..self.col_ptr[c + 1]];
        // Every (r, c) asked for lies in the pattern by construction.
        self.col_ptr[c] + rows.binary_search(&r).unwrap_or(0)
    }

    /// Adds block `m` at block position (i, j) of the symmetric matrix (and, implicitly, its
    /// transpose at (j, i)); the diagonal block's upper triangle only.
    fn add(&self, vals: &mut [f64], i: usize, j: usize, m: &Block) {
        if i == j {
            for a in 0..4 {
                for b in a..4 {
                    vals[self.slot(4 * i + a, 4 * i + b)] += m[a][b];
                }
            }
        } else if i < j {
            for a in 0..4 {
                for b in 0..4 {
                    vals[self.slot(4 * i + a, 4 * j + b)] += m[a][b];
                }
            }
        } else {
            for a in 0..4 {
                for b in 0..4 {
                    vals[self.slot(4 * j + b, 4 * i + a)] += m[a][b];
                }
            }
        }
    }

    /// Solves in place (`rhs` column-major 4#V x 3).
    fn solve(&self, vals: &[f64], rhs: &mut [f64]) -> Result<(), FitError> {
        let n = 4 * self.nv;
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
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
            MatMut::from_column_major_slice_mut(rhs, n, 3),
            par,
            MemStack::new(&mut mem),
        );
        if rhs.iter().any(|v| !v.is_finite()) {
            return Err(FitError::NotFinite);
        }
        Ok(())
    }
}

fn outer(a: [f64; 4], b: [f64; 4], w: f64) -> Block {
    let mut m = [[0.0; 4]; 4];
    for r in 0..4 {
        for c in 0..4 {
            m[r][c] = w * a[r] * b[c];
        }
    }
    m
}

/// The fixed terms of one solve, in normalized coordinates.
struct System<'a> {
    topo: &'a Topology,
    /// `d_i = [p_i; 1]` (#V).
    d: Vec<[f64; 4]>,
    alpha: f64,
    c: &'a [f64],
    y: &'a [[f64; 3]],
    samples: &'a [Sample],
    landmarks: &'a [(usize, [f64; 3])],
    beta: f64,
    /// Current maps (#V of 4 x 3, row-major).
    x0: &'a [[[f64; 3]; 4]],
    /// Isometric weight and the nearest rotation of each current linear part (#V).
    iso: f64,
    rotations: &'a [[[f64; 3]; 3]],
}

impl System<'_> {
    /// `E(X)` (see the module docs).
    #[cfg_attr(not(test), allow(dead_code))]
    fn energy(&self, x: &[[[f64; 3]; 4]]) -> f64 {
        let g = [1.0, 1.0, 1.0, GAMMA * GAMMA];
        let apply = |i: usize| -> [f64; 3] {
            let mut q = [0.0; 3];
            for (a, row) in x[i].iter().enumerate() {
                for k in 0..3 {
                    q[k] += self.d[i][a] * row[k];
                }
            }
            q
        };
        let mut e = 0.0;
        for [i, j] in self.topo.edges() {
            let (i, j) = (*i as usize, *j as usize);
            for a in 0..4 {
                for k in 0..3 {
                    e += self.alpha * g[a] * (x[i][a][k] - x[j][a][k]).powi(2);
                }
            }
        }
        for i in 0..x.len() {
            let r = sub(apply(i), self.y[i]);
            e += self.c[i] * dot(r, r);
            if self.iso > 0.0 {
                for a in 0..3 {
                    for k in 0..3 {
                        e += self.iso * (x[i][a][k] - self.rotations[i][k][a]).powi(2);
                    }
                }
            }
            for a in 0..4 {
                for k in 0..3 {
                    e += ANCHOR * (x[i][a][k] - self.x0[i][a][k]).powi(2);
                }
            }
        }
        for s in self.samples {
            let mut q = [0.0; 3];
            for m in 0..3 {
                let v = apply(s.face[m] as usize);
                for k in 0..3 {
                    q[k] += s.bary[m] * v[k];
                }
            }
            let r = sub(q, s.s);
            e += s.weight * dot(r, r);
        }
        for (l, q) in self.landmarks {
            let r = sub(apply(*l), *q);
            e += self.beta * dot(r, r);
        }
        e
    }

    /// The minimizer of `E` (one sparse solve).
    fn minimize(&self, solver: &AffineSolver) -> Result<Vec<[[f64; 3]; 4]>, FitError> {
        let nv = self.d.len();
        let n = 4 * nv;
        let mut vals = vec![0.0; solver.row_idx.len()];
        let mut rhs = vec![0.0; 3 * n];
        let add_rhs = |rhs: &mut [f64], i: usize, d: [f64; 4], y: [f64; 3], w: f64| {
            for a in 0..4 {
                for k in 0..3 {
                    rhs[k * n + 4 * i + a] += w * d[a] * y[k];
                }
            }
        };
        let mut g = [[0.0; 4]; 4];
        for (a, w) in [1.0, 1.0, 1.0, GAMMA * GAMMA].into_iter().enumerate() {
            g[a][a] = self.alpha * w;
        }
        let neg = g.map(|r| r.map(|v| -v));
        for [i, j] in self.topo.edges() {
            let (i, j) = (*i as usize, *j as usize);
            solver.add(&mut vals, i, i, &g);
            solver.add(&mut vals, j, j, &g);
            solver.add(&mut vals, i, j, &neg);
        }
        let mut anchor = [[0.0; 4]; 4];
        for (a, row) in anchor.iter_mut().enumerate() {
            row[a] = ANCHOR;
        }
        for i in 0..nv {
            let mut m = outer(self.d[i], self.d[i], self.c[i]);
            for a in 0..4 {
                m[a][a] += ANCHOR;
                for k in 0..3 {
                    rhs[k * n + 4 * i + a] += ANCHOR * self.x0[i][a][k];
                }
            }
            if self.iso > 0.0 {
                for a in 0..3 {
                    m[a][a] += self.iso;
                    for k in 0..3 {
                        // Row a of X_i holds column a of A_i: X[a][k] = A[k][a].
                        rhs[k * n + 4 * i + a] += self.iso * self.rotations[i][k][a];
                    }
                }
            }
            solver.add(&mut vals, i, i, &m);
            add_rhs(&mut rhs, i, self.d[i], self.y[i], self.c[i]);
        }
        for s in self.samples {
            for m in 0..3 {
                let u = s.face[m] as usize;
                add_rhs(&mut rhs, u, self.d[u], s.s, s.weight * s.bary[m]);
                for o in m..3 {
                    let v = s.face[o] as usize;
                    let w = s.weight * s.bary[m] * s.bary[o];
                    if u == v {
                        let mut b = outer(self.d[u], self.d[v], w);
                        if m != o {
                            // Both (m, o) and (o, m) land on the diagonal block.
                            b = outer(self.d[u], self.d[v], 2.0 * w);
                        }
                        solver.add(&mut vals, u, u, &b);
                    } else {
                        solver.add(&mut vals, u, v, &outer(self.d[u], self.d[v], w));
                    }
                }
            }
        }
        for (l, q) in self.landmarks {
            solver.add(&mut vals, *l, *l, &outer(self.d[*l], self.d[*l], self.beta));
            add_rhs(&mut rhs, *l, self.d[*l], *q, self.beta);
        }
        solver.solve(&vals, &mut rhs)?;
        Ok((0..nv)
            .map(|i| {
                let mut x = [[0.0; 3]; 4];
                for (a, row) in x.iter_mut().enumerate() {
                    for (k, v) in row.iter_mut().enumerate() {
                        *v = rhs[k * n + 4 * i + a];
                    }
                }
                x
            })
            .collect())
    }
}

fn positions(d: &[[f64; 4]], x: &[[[f64; 3]; 4]]) -> Vec<[f64; 3]> {
    d.iter()
        .zip(x)
        .map(|(d, x)| {
            let mut q = [0.0; 3];
            for a in 0..4 {
                for k in 0..3 {
                    q[k] += d[a] * x[a][k];
                }
            }
            q
        })
        .collect()
}

/// Fits the template from `start` (#V x 3, target units) to `target` under the affine-field
/// prior of the rest shape `start` itself (the aligned template, or the previous frame when
/// tracking). `landmarks` pull their vertices with weight `landmark_weight` relative to one
/// vertex's data term. Returns the fitted positions and the number of solves.
pub(crate) fn fit(
    solver: &Solver,
    affine: &AffineSolver,
    start: Vec<[f64; 3]>,
    target: &Prepared,
    opts: &FitOptions,
    landmarks: &[Landmark],
) -> Result<(Vec<[f64; 3]>, usize), FitError> {
    let topo = &**solver.topology();
    let nv = topo.n_vertices();
    let lbar = mean_edge_length(topo, &start);
    // Normalized coordinates: centroid 0, rms radius 1.
    let (center, radius) = centroid_and_rms_radius(&start);
    let to = |p: [f64; 3]| sub(p, center).map(|v| v / radius);
    let from = |p: [f64; 3]| [0, 1, 2].map(|k| center[k] + radius * p[k]);
    let d: Vec<[f64; 4]> = start
        .iter()
        .map(|p| {
            let q = to(*p);
            [q[0], q[1], q[2], 1.0]
        })
        .collect();
    let lm: Vec<(usize, [f64; 3])> = landmarks
        .iter()
        .filter(|l| l.vertex < nv)
        .map(|l| (l.vertex, to(l.point)))
        .collect();
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]];
    let mut maps = vec![identity; nv];
    let samples: Vec<usize> = stride(target.positions.len(), opts.max_samples.max(2 * nv)).collect();
    let (s0, s1) = opts.stiffness();
    let mut x: Vec<[f64; 3]> = start.clone();
    let mut solves = 0;
    for stage in 0..opts.stages {
        let f = if opts.stages == 1 {
            1.0
        } else {
            stage as f64 / (opts.stages - 1) as f64
        };
        let first = s0 * nv as f64;
        let alpha = first * (s1 / first).powf(f);
        for _ in 0..opts.iterations {
            let m = matches(solver, &x, target, &samples, opts, lbar);
            if solves == 0 && m.matched * 10 < nv {
                return Err(FitError::NoOverlap {
                    matched: m.matched,
                    total: nv,
                });
            }
            let y: Vec<[f64; 3]> = m.y.iter().map(|p| to(*p)).collect();
            let pulls: Vec<Sample> = m.samples.iter().map(|s| Sample { s: to(s.s), ..*s }).collect();
            let rotations: Vec<[[f64; 3]; 3]> = if opts.isometric > 0.0 {
                maps.iter().map(nearest_rotation).collect()
            } else {
                Vec::new()
            };
            let system = System {
                iso: opts.isometric,
                rotations: &rotations,
                topo,
                d: d.clone(),
                alpha,
                c: &m.c,
                y: &y,
                samples: &pulls,
                landmarks: &lm,
                beta: opts.landmark_weight * (1.0 - f).max(LANDMARK_FLOOR),
                x0: &maps,
            };
            maps = system.minimize(affine)?;
            let next: Vec<[f64; 3]> = positions(&d, &maps).into_iter().map(from).collect();
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

/// The rotation nearest to the linear part `A` of a map (`A[k][a] = x[a][k]`): the maximizer
/// of `tr(R^T A)` (Horn's method); the identity if `A` is degenerate.
fn nearest_rotation(x: &[[f64; 3]; 4]) -> [[f64; 3]; 3] {
    // Horn's method maximizes tr(R^T C) for C = (its argument)^T; X's first three rows are A^T.
    let at = [x[0], x[1], x[2]];
    horn_rotation(&at).unwrap_or(Motion::IDENTITY.rotation)
}

/// Landmarks keep at least this share of their weight at the last stage (Amberg et al. relax
/// them as the stiffness falls, so that they guide the coarse stages and do not pin a wrong
/// local detail).
pub const LANDMARK_FLOOR: f64 = 0.1;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::icosphere;

    #[test]
    fn the_solve_minimizes_the_energy() {
        let s = icosphere(1);
        let topo = &*s.topology;
        let nv = topo.n_vertices();
        let affine = AffineSolver::new(topo).unwrap();
        let d: Vec<[f64; 4]> = s.positions.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect();
        let c: Vec<f64> = (0..nv).map(|i| if i % 3 == 0 { 0.0 } else { 1.0 }).collect();
        let y: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| {
                [
                    1.3 * p[0] + 0.2 * p[2],
                    p[1] - 0.1,
                    0.7 * p[2] + 0.05 * p[0] * p[0],
                ]
            })
            .collect();
        let samples = vec![
            Sample {
                face: topo.faces()[3],
                bary: [0.2, 0.3, 0.5],
                weight: 2.0,
                s: [0.1, 0.9, 0.2],
                n: [0.0; 3],
            },
            Sample {
                face: topo.faces()[17],
                bary: [0.6, 0.3, 0.1],
                weight: 1.5,
                s: [-0.4, 0.2, 0.8],
                n: [0.0; 3],
            },
        ];
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]];
        let x0 = vec![identity; nv];
        let lm = [(5usize, [0.3, 0.3, 0.3])];
        let sys = System {
            topo,
            d,
            alpha: 0.7,
            c: &c,
            y: &y,
            samples: &samples,
            landmarks: &lm,
            beta: 3.0,
            x0: &x0,
            iso: 0.5,
            rotations: &vec![Motion::IDENTITY.rotation; nv],
        };
        let xm = sys.minimize(&affine).unwrap();
        let e = sys.energy(&xm);
        assert!(e < sys.energy(&x0));
        // Stationary: any small change of any entry raises the energy (to second order).
        let h = 1e-4;
        for i in [0, 5, 17, 41] {
            for a in 0..4 {
                for k in 0..3 {
                    let mut p = xm.clone();
                    let mut q = xm.clone();
                    p[i][a][k] += h;
                    q[i][a][k] -= h;
                    let (ep, eq) = (sys.energy(&p), sys.energy(&q));
                    let slope = (ep - eq) / (2.0 * h);
                    assert!(slope.abs() < 1e-6 * (1.0 + e), "{i} {a} {k}: slope {slope}");
                    assert!(ep >= e - 1e-12 && eq >= e - 1e-12);
                }
            }
        }
    }

    #[test]
    fn a_global_affine_map_costs_no_stiffness() {
        let s = icosphere(2);
        let topo = &*s.topology;
        let nv = topo.n_vertices();
        let affine = AffineSolver::new(topo).unwrap();
        let d: Vec<[f64; 4]> = s.positions.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect();
        let a = |p: [f64; 3]| [1.4 * p[0] + 0.3 * p[1] + 0.2, 0.8 * p[1], 1.1 * p[2] - 0.2 * p[0]];
        let y: Vec<[f64; 3]> = s.positions.iter().map(|p| a(*p)).collect();
        let c = vec![1.0; nv];
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]];
        let x0 = vec![identity; nv];
        let sys = System {
            topo,
            d: d.clone(),
            alpha: 1e4,
            c: &c,
            y: &y,
            samples: &[],
            landmarks: &[],
            beta: 0.0,
            x0: &x0,
            iso: 0.0,
            rotations: &[],
        };
        let xm = sys.minimize(&affine).unwrap();
        let err = positions(&d, &xm)
            .iter()
            .zip(&y)
            .map(|(p, q)| dot(sub(*p, *q), sub(*p, *q)).sqrt())
            .fold(0.0, f64::max);
        assert!(err < 1e-4, "{err}");
    }
}
