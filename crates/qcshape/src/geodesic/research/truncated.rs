//! Truncated (inexact) Gauss-Newton: the Gauss-Newton step of the path energy solved by
//! preconditioned conjugate gradients instead of a factorization of the full system.
//!
//! Every outer iteration assembles the 3 x 3 vertex blocks of `J^T J` (block-tridiagonal in the
//! poses, [`Structure::assemble`]) and solves `J^T J p = -J^T r` approximately by conjugate
//! gradients, with products taken directly on the blocks. The preconditioner is the Kronecker
//! model of the same matrix refitted at every outer iteration: `T_c (x) A`, where `A` is the
//! mean of the diagonal pose blocks (one sparse Cholesky of size 3 #V, symbolic factorization
//! made once per topology) and `T_c = tridiag(-c_{j}, c_{j-1} + c_j, -c_j)` carries one weight
//! per segment (the trace of its blocks relative to `A`'s), so that a metric that grows or
//! shrinks along the path is still modelled. Applying it costs `N - 1` triangular solve pairs.
//! The inner solve stops at a relative residual `eta_k = min(0.1, sqrt(|g_k| / |g_0|))`
//! (Eisenstat-Walker), and a backtracking line search on the true energy globalizes the step.
//! Auxiliary unknowns (rigid motions) are eliminated: they are reset to their optimum after
//! every step, and the conjugate gradients run on the Schur complement of their blocks.
//!
//! Newton's method ([`crate::geodesic::Solver::Newton`]) runs the same iteration on the exact Hessian:
//! the metric's second-order part `sum r_i d2 r_i` is added to the blocks (the geodesic is a
//! large-residual problem, on which the Gauss-Newton model converges only linearly). Far from
//! the geodesic that Hessian is indefinite: conjugate gradients stop at the first direction of
//! negative curvature (the step so far, or the preconditioned gradient at the first one), and
//! the preconditioner is fitted to the Gauss-Newton part whenever the fit to the full Hessian
//! is not positive definite.
//!
//! Compared with the direct factorization of the full block-tridiagonal system, whose fill
//! grows with the path length times the spatial factor, memory and time per iteration stay
//! linear in `N` times one spatial factorization.

// Index loops mirror the formulas (pose, vertex, coordinate indices) in these kernels.
#![allow(clippy::needless_range_loop)]

use rayon::prelude::*;

use crate::geodesic::energy::{Ends, PathEnergy};
use crate::geodesic::hessian::{SegmentBlocks, Structure};
use crate::geodesic::kronecker::{KroneckerModel, SpatialLayout};
use crate::geodesic::{dot, norm, GeodesicError, GeodesicOptions, SolveOutput, StopReason};

/// Conjugate-gradient iterations allowed per Gauss-Newton step.
const MAX_CG: usize = 250;

/// The Gauss-Newton matrix at one iterate, reduced to the pose unknowns, and its preconditioner.
struct Model<'a> {
    spatial: &'a SpatialLayout,
    /// The blocks, with each interior pose's diagonal block summed into the `aa` of the
    /// segment it starts (`bb` emptied).
    blocks: Vec<SegmentBlocks>,
    /// Per term `t = 2 s + e`: the inverse of its aux-aux block (n_aux x n_aux).
    aux_inv: Vec<Vec<f64>>,
    /// The preconditioner.
    kron: KroneckerModel,
}

fn add_mul(y: &mut [f64], b: &[f64; 9], x: &[f64]) {
    for r in 0..3 {
        y[r] += b[3 * r] * x[0] + b[3 * r + 1] * x[1] + b[3 * r + 2] * x[2];
    }
}

fn add_mul_t(y: &mut [f64], b: &[f64; 9], x: &[f64]) {
    for c in 0..3 {
        y[c] += b[c] * x[0] + b[3 + c] * x[1] + b[6 + c] * x[2];
    }
}

/// Inverse of a small symmetric positive semi-definite matrix (n x n, row-major) by Cholesky,
/// with a ridge of `1e-12` times its largest diagonal entry.
fn spd_inverse(a: &[f64], n: usize) -> Vec<f64> {
    let dmax = (0..n).map(|i| a[i * n + i]).fold(0.0f64, f64::max);
    let ridge = 1e-12 * dmax.max(f64::MIN_POSITIVE);
    let mut l = vec![0.0; n * n];
    for j in 0..n {
        let mut d = a[j * n + j] + ridge - (0..j).map(|k| l[j * n + k] * l[j * n + k]).sum::<f64>();
        if d <= ridge {
            d = ridge;
        }
        let d = d.sqrt();
        l[j * n + j] = d;
        for i in j + 1..n {
            let s = a[i * n + j] - (0..j).map(|k| l[i * n + k] * l[j * n + k]).sum::<f64>();
            l[i * n + j] = s / d;
        }
    }
    // Columns of the inverse: solve L L^T x = e_c.
    let mut inv = vec![0.0; n * n];
    for c in 0..n {
        let mut y = vec![0.0; n];
        for i in 0..n {
            let s = if i == c { 1.0 } else { 0.0 } - (0..i).map(|k| l[i * n + k] * y[k]).sum::<f64>();
            y[i] = s / l[i * n + i];
        }
        for i in (0..n).rev() {
            let s = y[i] - (i + 1..n).map(|k| l[k * n + i] * y[k]).sum::<f64>();
            y[i] = s / l[i * n + i];
        }
        for i in 0..n {
            inv[i * n + c] = y[i];
        }
    }
    inv
}

impl<'a> Model<'a> {
    /// The model of `blocks`. With second-order parts (Newton) the operator is the exact
    /// Hessian, and the preconditioner is fitted to it; where the fitted spatial matrix is not
    /// positive definite (far from the geodesic the Hessian is indefinite), to the
    /// Gauss-Newton part instead.
    fn new(layout: &'a SpatialLayout, mut blocks: Vec<SegmentBlocks>) -> Result<Self, GeodesicError> {
        let st = layout.structure();
        let (steps, n_aux) = (st.steps, st.n_aux);
        let (kron, _, _) = KroneckerModel::fit_merging_second(layout, &mut blocks)?;
        let aux_inv = if n_aux == 0 {
            Vec::new()
        } else {
            (0..2 * steps)
                .map(|t| spd_inverse(&blocks[t / 2].aux_aux[t % 2], n_aux))
                .collect()
        };
        // Interior pose j's diagonal block is bb of segment j - 1 plus aa of segment j: summed
        // once into aa (the products then read one block per slot instead of two).
        for j in 1..steps {
            let (left, right) = blocks.split_at_mut(j);
            let bb = std::mem::take(&mut left[j - 1].bb);
            for (a, b) in right[0].aa.iter_mut().zip(&bb) {
                for k in 0..9 {
                    a[k] += b[k];
                }
            }
        }
        Ok(Model {
            spatial: layout,
            blocks,
            aux_inv,
            kron,
        })
    }

    /// The block structure (that of the spatial layout).
    fn st(&self) -> &'a Structure {
        self.spatial.structure()
    }

    fn nv3(&self) -> usize {
        3 * self.st().nv
    }

    /// `w_t = H_aa,t^{-1} (H_ap,t x + h_t)` for every term (`h`: per-term offsets or zero).
    fn aux_solve(&self, x: &[f64], h: Option<&[f64]>) -> Vec<Vec<f64>> {
        let (steps, n_aux, nv3) = (self.st().steps, self.st().n_aux, self.nv3());
        (0..2 * steps)
            .map(|t| {
                let (s, e) = (t / 2, t % 2);
                let b = &self.blocks[s];
                let mut rhs = match h {
                    Some(h) => h[t * n_aux..(t + 1) * n_aux].to_vec(),
                    None => vec![0.0; n_aux],
                };
                for (pose, coup) in [(s, &b.aux_a[e]), (s + 1, &b.aux_b[e])] {
                    if pose == 0 || pose == steps {
                        continue;
                    }
                    let xp = &x[(pose - 1) * nv3..pose * nv3];
                    for q in 0..nv3 {
                        for k in 0..n_aux {
                            rhs[k] += coup[q * n_aux + k] * xp[q];
                        }
                    }
                }
                let inv = &self.aux_inv[t];
                (0..n_aux)
                    .map(|i| (0..n_aux).map(|k| inv[i * n_aux + k] * rhs[k]).sum())
                    .collect()
            })
            .collect()
    }

    /// `y -= H_pa w` for per-term aux vectors `w`.
    fn aux_back(&self, w: &[Vec<f64>], y: &mut [f64]) {
        let (steps, n_aux, nv3) = (self.st().steps, self.st().n_aux, self.nv3());
        for (t, wt) in w.iter().enumerate() {
            let (s, e) = (t / 2, t % 2);
            let b = &self.blocks[s];
            for (pose, coup) in [(s, &b.aux_a[e]), (s + 1, &b.aux_b[e])] {
                if pose == 0 || pose == steps {
                    continue;
                }
                let yp = &mut y[(pose - 1) * nv3..pose * nv3];
                for q in 0..nv3 {
                    yp[q] -= (0..n_aux).map(|k| coup[q * n_aux + k] * wt[k]).sum::<f64>();
                }
            }
        }
    }

    /// `y = S x`, `S = H_pp - H_pa H_aa^{-1} H_ap` (just `H_pp` without auxiliary unknowns).
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let (steps, nv3) = (self.st().steps, self.nv3());
        let pairs = &self.st().pairs;
        y.par_chunks_mut(nv3).enumerate().for_each(|(i, yj)| {
            let j = i + 1;
            yj.fill(0.0);
            let xj = &x[i * nv3..(i + 1) * nv3];
            // Diagonal pose block (bb of segment j - 1 already added, see `new`).
            let diag = &self.blocks[j].aa;
            let next = (j + 1 < steps).then(|| (&self.blocks[j].ab, &x[(i + 1) * nv3..(i + 2) * nv3]));
            let prev = (j >= 2).then(|| (&self.blocks[j - 1].ab, &x[(i - 1) * nv3..i * nv3]));
            for v in 0..self.st().nv {
                for idx in pairs.off[v]..pairs.off[v + 1] {
                    let u = pairs.rows[idx];
                    let yu = &mut yj[3 * u..3 * u + 3];
                    add_mul(yu, &diag[idx], &xj[3 * v..3 * v + 3]);
                    if let Some((ab, xn)) = next {
                        add_mul(yu, &ab[idx], &xn[3 * v..3 * v + 3]);
                    }
                }
                if let Some((ab, xp)) = prev {
                    let yv = &mut yj[3 * v..3 * v + 3];
                    for idx in pairs.off[v]..pairs.off[v + 1] {
                        let u = pairs.rows[idx];
                        add_mul_t(yv, &ab[idx], &xp[3 * u..3 * u + 3]);
                    }
                }
            }
        });
        if self.st().n_aux > 0 {
            let w = self.aux_solve(x, None);
            self.aux_back(&w, y);
        }
    }

    /// Reduced half gradient `g_p - H_pa H_aa^{-1} g_a` from the full `J^T r`.
    fn reduced_gradient(&self, g: &[f64]) -> Vec<f64> {
        let np = self.nv3() * (self.st().steps - 1);
        let mut gp = g[..np].to_vec();
        if self.st().n_aux > 0 {
            // H_aa^{-1} (H_ap 0 + g_a).
            let zero = vec![0.0; np];
            let w = self.aux_solve(&zero, Some(&g[np..]));
            self.aux_back(&w, &mut gp);
        }
        gp
    }

    /// `q <- (T_c (x) A)^{-1} q`.
    fn precondition(&self, q: &mut [f64]) {
        self.kron.apply(self.spatial, q, 1.0);
    }

    /// Preconditioned conjugate gradients on `S p = -g` to relative residual `eta` (at most
    /// [`MAX_CG`] iterations). Returns the step.
    fn step(&self, g: &[f64], eta: f64) -> Vec<f64> {
        let n = g.len();
        let mut p = vec![0.0; n];
        let mut res: Vec<f64> = g.iter().map(|v| -v).collect();
        let mut z = res.clone();
        self.precondition(&mut z);
        let mut d = z.clone();
        let mut rz = dot(&res, &z);
        let mut hd = vec![0.0; n];
        let target = eta * norm(g);
        let mut it = 0;
        while it < MAX_CG {
            it += 1;
            self.apply(&d, &mut hd);
            let dhd = dot(&d, &hd);
            if dhd.is_nan() || dhd <= 0.0 || !rz.is_finite() {
                if it == 1 {
                    // No curvature information: the preconditioned gradient direction.
                    p.copy_from_slice(&d);
                }
                break;
            }
            let alpha = rz / dhd;
            for k in 0..n {
                p[k] += alpha * d[k];
                res[k] -= alpha * hd[k];
            }
            if norm(&res) <= target {
                break;
            }
            z.copy_from_slice(&res);
            self.precondition(&mut z);
            let rz_new = dot(&res, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            for k in 0..n {
                d[k] = z[k] + beta * d[k];
            }
        }
        p
    }
}

/// Minimizes the path energy from `x` (see the module docs): Gauss-Newton, or with `newton`
/// Newton's method on the exact Hessian (Gauss-Newton blocks plus the metric's second-order
/// part where it provides one, [`crate::metric::Metric::add_second_order`]).
pub(crate) fn minimize(
    pe: &PathEnergy,
    layout: &SpatialLayout,
    ends: &Ends,
    mut x: Vec<f64>,
    opts: &GeodesicOptions,
    newton: bool,
) -> Result<SolveOutput, GeodesicError> {
    let np = pe.n_pose_vars();
    pe.reset_aux(&mut x, ends);
    if np == 0 {
        return Ok(SolveOutput {
            x,
            iterations: 0,
            stop: StopReason::GradientTolerance,
            last: None,
        });
    }
    let (blocks, mut energy, g_full) = layout.structure().assemble_with(pe, &x, ends, newton);
    let mut model = Model::new(layout, blocks)?;
    let mut g = model.reduced_gradient(&g_full);
    // The energy gradient is 2 J^T r.
    let g0 = 2.0 * norm(&g);
    let mut iterations = 0;
    let mut stop = StopReason::MaxIterations;
    if crate::geodesic::at_roundoff(g0, energy) {
        return Ok(SolveOutput {
            x,
            iterations,
            stop: StopReason::GradientTolerance,
            last: None,
        });
    }
    let limit = opts.max_iterations.unwrap_or(100);
    while iterations < limit {
        let gn = 2.0 * norm(&g);
        if let Some(reason) = opts.stop_before_iteration(energy, gn, g0) {
            stop = reason;
            break;
        }
        iterations += 1;
        opts.monitor(iterations, energy)?;
        let eta = (gn / g0).sqrt().min(0.1);
        let p = model.step(&g, eta);
        // Backtracking line search on the true energy (Armijo), full step first.
        let slope = 2.0 * dot(&g, &p);
        let mut t = 1.0;
        let accepted = loop {
            if slope.is_nan() || slope >= 0.0 {
                break None;
            }
            let mut xn = x.clone();
            for (a, b) in xn[..np].iter_mut().zip(&p) {
                *a += t * b;
            }
            pe.reset_aux(&mut xn, ends);
            let en = pe.energy(&xn, ends);
            if en.is_finite() && en <= energy + 1e-4 * t * slope {
                break Some((xn, en));
            }
            t *= 0.5;
            if t < 1e-10 {
                break None;
            }
        };
        let Some((xn, en)) = accepted else {
            stop = StopReason::NoProgress;
            break;
        };
        let decrease = energy - en;
        x = xn;
        let (blocks, e, g_full) = layout.structure().assemble_with(pe, &x, ends, newton);
        energy = e;
        model = Model::new(layout, blocks)?;
        g = model.reduced_gradient(&g_full);
        if decrease <= opts.energy_tolerance * energy.abs() {
            stop = StopReason::EnergyTolerance;
            break;
        }
    }
    let stop = opts.final_stop(stop, 2.0 * norm(&g), g0);
    if !energy.is_finite() {
        return Err(GeodesicError::NonFinite {
            what: "energy",
            value: energy,
        });
    }
    Ok(SolveOutput {
        x,
        iterations,
        stop,
        last: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::hessian::tests::{dense, for_each_problem};

    /// Solves the small dense system `a x = b` by Gaussian elimination with partial pivoting.
    fn dense_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
        let n = b.len();
        for k in 0..n {
            let p = (k..n)
                .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
                .unwrap();
            a.swap(k, p);
            b.swap(k, p);
            for i in k + 1..n {
                let f = a[i][k] / a[k][k];
                for j in k..n {
                    a[i][j] -= f * a[k][j];
                }
                b[i] -= f * b[k];
            }
        }
        for k in (0..n).rev() {
            b[k] = (b[k] - (k + 1..n).map(|j| a[k][j] * b[j]).sum::<f64>()) / a[k][k];
        }
        b
    }

    #[test]
    fn block_products_match_the_dense_reduced_system() {
        for_each_problem(4, |m, pe, ends, x| {
            let layout = SpatialLayout::new(pe).unwrap();
            let (blocks, _, g) = layout.structure().assemble(pe, x, ends);
            let model = Model::new(&layout, blocks).unwrap();
            let (h, gd) = dense(pe, x, ends);
            let (n, np) = (pe.n_vars(), pe.n_pose_vars());
            // Dense reduced operator: S v = H_pp v - H_pa H_aa^{-1} H_ap v.
            let v: Vec<f64> = (0..np).map(|i| ((i * 31 % 11) as f64 - 5.0) / 5.0).collect();
            let mut want: Vec<f64> = (0..np).map(|i| (0..np).map(|j| h[i][j] * v[j]).sum()).collect();
            let mut want_g = gd[..np].to_vec();
            if n > np {
                let haa: Vec<Vec<f64>> = (np..n).map(|i| h[i][np..n].to_vec()).collect();
                let hap_v: Vec<f64> = (np..n).map(|i| (0..np).map(|j| h[i][j] * v[j]).sum()).collect();
                let w = dense_solve(haa.clone(), hap_v);
                let wg = dense_solve(haa, gd[np..].to_vec());
                for i in 0..np {
                    want[i] -= (np..n).map(|k| h[i][k] * w[k - np]).sum::<f64>();
                    want_g[i] -= (np..n).map(|k| h[i][k] * wg[k - np]).sum::<f64>();
                }
            }
            let mut got = vec![0.0; np];
            model.apply(&v, &mut got);
            let got_g = model.reduced_gradient(&g);
            let scale = want.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            for i in 0..np {
                assert!(
                    (got[i] - want[i]).abs() < 1e-8 * (1.0 + scale),
                    "{}: (S v)[{i}] {} vs {}",
                    m.name(),
                    got[i],
                    want[i]
                );
                assert!(
                    (got_g[i] - want_g[i]).abs() < 1e-8 * (1.0 + scale),
                    "{}: g[{i}] {} vs {}",
                    m.name(),
                    got_g[i],
                    want_g[i]
                );
            }
            // The preconditioner is symmetric positive definite: v . M^{-1} v > 0 and
            // u . M^{-1} v = v . M^{-1} u (to single precision: the spatial solves run in f32).
            let u: Vec<f64> = (0..np).map(|i| ((i * 17 % 7) as f64 - 3.0) / 3.0).collect();
            let (mut mu, mut mv) = (u.clone(), v.clone());
            model.precondition(&mut mu);
            model.precondition(&mut mv);
            assert!(dot(&v, &mv) > 0.0);
            let (a1, a2) = (dot(&u, &mv), dot(&v, &mu));
            assert!((a1 - a2).abs() < 1e-5 * (a1.abs() + a2.abs()), "{a1} vs {a2}");
        });
    }
}
