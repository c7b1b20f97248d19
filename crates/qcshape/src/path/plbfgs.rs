//! L-BFGS preconditioned by the path's Kronecker structure (the default solver).
//!
//! Near a path with similar metric matrices at every pose, the Gauss-Newton matrix of the path
//! energy (eq. 12) in the pose unknowns is close to `4 (T_c (x) A)`: `T_c` the weighted
//! second difference along the path (`N - 1` x `N - 1`, diagonal `c_{j-1} + c_j`, off-diagonal
//! `-c_j`, with `c_s` the trace of segment `s`'s metric matrix relative to the mean: the metric
//! may grow or shrink along the path) and `A = J_X^T J_X`, the metric's quadratic form averaged
//! over the segments (3 #V x 3 #V, sparse with the mesh's vertex pattern).
//! Its inverse `T^{-1} (x) A^{-1}` costs one sparse Cholesky of size 3 #V, built with a symbolic
//! factorization made once per topology, and `N - 1` triangular solve pairs per application.
//! The model is refitted at the current path every [`GeodesicOptions::preconditioner_refresh`]
//! iterations. L-BFGS with this initial inverse Hessian learns the rest (the pose-to-pose variation of
//! the metric and the large-residual curvature terms that Gauss-Newton leaves out). Auxiliary
//! unknowns (rigid motions) are eliminated: they are set to their optimum at every evaluation,
//! and by the envelope theorem the pose part of the gradient is then the exact gradient.

// Index loops mirror the formulas (vertex, coordinate, residual indices) in these kernels.
#![allow(clippy::needless_range_loop)]

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, SymbolicCholesky, SymmetricOrdering};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use super::energy::{Ends, PathEnergy};
use super::pairs::VertexPairs;
use super::{GeodesicError, GeodesicOptions, SolveOutput, StopReason};
use crate::metric::At;

/// Structure of the spatial matrix `A` (upper triangle of 3 x 3 vertex blocks on the metric's
/// vertex-pair set), with its symbolic factorization. Built once per (topology, metric).
pub(crate) struct SpatialLayout {
    nv: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// For value `k` of the CSC: (slot in the vertex-pair set, 3 x 3 component).
    src: Vec<(usize, usize)>,
    diag_idx: Vec<usize>,
    /// Vertex pairs sharing a residual, and per-residual pair slots.
    pairs: VertexPairs,
    symbolic: SymbolicCholesky<usize>,
}

impl SpatialLayout {
    pub fn new(pe: &PathEnergy) -> Result<Self, faer::sparse::FaerError> {
        let nv = pe.n_vertices();
        let pairs = VertexPairs::new(nv, &pe.pattern);
        let (s_off, s_rows) = (&pairs.off, &pairs.rows);
        let n = 3 * nv;
        let mut col_ptr = vec![0usize];
        let mut row_idx = Vec::new();
        let mut src = Vec::new();
        let mut diag_idx = Vec::with_capacity(n);
        for v in 0..nv {
            for c in 0..3 {
                for idx in s_off[v]..s_off[v + 1] {
                    let u = s_rows[idx];
                    if u > v {
                        break;
                    }
                    let last = if u == v { c } else { 2 };
                    for cr in 0..=last {
                        if u == v && cr == c {
                            diag_idx.push(row_idx.len());
                        }
                        row_idx.push(3 * u + cr);
                        src.push((idx, cr * 3 + c));
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic =
            factorize_symbolic_cholesky(sym, Side::Upper, SymmetricOrdering::Amd, Default::default())?;
        Ok(SpatialLayout {
            nv,
            col_ptr,
            row_idx,
            src,
            diag_idx,
            pairs,
            symbolic,
        })
    }

    /// Cholesky factor values of the 3 #V x 3 #V matrix whose 3 x 3 block at vertex pair slot
    /// `k` (row `u`, column `v`, row-major; slots of [`VertexPairs::new`] on the metric's
    /// pattern) is `blocks[k]`; the diagonal is floored at `1e-8`
    /// times its largest entry (the matrix is only semi-definite for metrics with null spaces
    /// and `lambda = 0`).
    pub fn factorize(&self, blocks: &[[f64; 9]]) -> Result<Vec<f64>, GeodesicError> {
        let mut vals: Vec<f64> = self.src.iter().map(|&(slot, k)| blocks[slot][k]).collect();
        let dmax = self.diag_idx.iter().map(|&i| vals[i]).fold(0.0f64, f64::max);
        let ridge = 1e-8 * dmax.max(f64::MIN_POSITIVE);
        for &i in &self.diag_idx {
            vals[i] += ridge;
        }
        let n = 3 * self.nv;
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let mut l_values = vec![0.0; self.symbolic.len_val()];
        let par = Par::Seq;
        let mut mem = MemBuffer::new(
            self.symbolic
                .factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        );
        self.symbolic
            .factorize_numeric_llt(
                &mut l_values,
                SparseColMatRef::new(sym, &vals),
                Side::Upper,
                LltRegularization::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| GeodesicError::LinearAlgebra(format!("spatial preconditioner: {e:?}")))?;
        Ok(l_values)
    }

    /// `q <- A^{-1} q` for every column of `q` (column-major, 3 #V rows), `A` factorized by
    /// [`Self::factorize`] into `l_values`.
    pub fn solve(&self, l_values: &[f64], q: &mut [f64]) {
        let n = 3 * self.nv;
        let m = q.len() / n;
        let par = Par::Seq;
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(m, par));
        let llt = faer::sparse::linalg::cholesky::LltRef::new(&self.symbolic, l_values);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(q, n, m),
            par,
            MemStack::new(&mut mem),
        );
    }
}

/// The factorized preconditioner `(4 T_c (x) A)^{-1}`.
struct Preconditioner<'l> {
    layout: &'l SpatialLayout,
    l_values: Vec<f64>,
    tinv: Vec<f64>,
    m: usize,
}

impl<'l> Preconditioner<'l> {
    /// `A` from the `At::Start` term of segment `s` (its `d r / d b` is `d r / d X` at the
    /// geometry of `P_s`), averaged over all segments.
    fn new(
        layout: &'l SpatialLayout,
        pe: &PathEnergy,
        x: &[f64],
        ends: &Ends,
    ) -> Result<Self, GeodesicError> {
        let mut blocks = vec![[0.0f64; 9]; layout.pairs.n_slots()];
        let mut te = pe.new_term_eval();
        let pat = &pe.pattern;
        // Per-segment trace of the blocks: the weights c_s of T_c.
        let mut c = vec![0.0f64; pe.steps];
        for s in 0..pe.steps {
            pe.eval_term(x, ends, s, At::Start, &mut te, true);
            for i in 0..pat.n_residuals() {
                let range = pat.row(i);
                let l = range.len();
                let ps = layout.pairs.slots(i);
                for k in 0..l {
                    let dk = te.jac.db[range.start + k];
                    c[s] += dk[0] * dk[0] + dk[1] * dk[1] + dk[2] * dk[2];
                    for ll in 0..l {
                        let dl = te.jac.db[range.start + ll];
                        let b = &mut blocks[ps[k * l + ll] as usize];
                        for r in 0..3 {
                            for cc in 0..3 {
                                b[r * 3 + cc] += dk[r] * dl[cc];
                            }
                        }
                    }
                }
            }
        }
        let scale = 1.0 / pe.steps as f64;
        blocks.iter_mut().flatten().for_each(|v| *v *= scale);
        let l_values = layout.factorize(&blocks)?;
        let mean = c.iter().sum::<f64>() * scale;
        let c: Vec<f64> = c
            .iter()
            .map(|v| (v / mean.max(f64::MIN_POSITIVE)).max(1e-6))
            .collect();
        let m = pe.steps - 1;
        let d: Vec<f64> = (0..m).map(|i| c[i] + c[i + 1]).collect();
        let e: Vec<f64> = (0..m.saturating_sub(1)).map(|i| -c[i + 1]).collect();
        let tinv = tridiagonal_inverse(&d, &e);
        Ok(Preconditioner {
            layout,
            l_values,
            tinv,
            m,
        })
    }

    /// `q <- (4 T_c (x) A)^{-1} q` on the pose part (length 3 #V (N - 1)).
    fn apply(&self, q: &mut [f64]) {
        let n = 3 * self.layout.nv;
        let m = self.m;
        self.layout.solve(&self.l_values, q);
        let y = q.to_vec();
        for i in 0..m {
            let out = &mut q[i * n..(i + 1) * n];
            out.fill(0.0);
            for j in 0..m {
                let t = 0.25 * self.tinv[i * m + j];
                for (o, v) in out.iter_mut().zip(&y[j * n..(j + 1) * n]) {
                    *o += t * v;
                }
            }
        }
    }
}

/// Inverse of the symmetric tridiagonal `T` with diagonal `d` and off-diagonal `e` (m x m,
/// row-major), column by column (Thomas algorithm).
pub(crate) fn tridiagonal_inverse(d: &[f64], e: &[f64]) -> Vec<f64> {
    let m = d.len();
    let mut inv = vec![0.0; m * m];
    for c in 0..m {
        let mut cp = vec![0.0; m];
        let mut rhs: Vec<f64> = (0..m).map(|i| if i == c { 1.0 } else { 0.0 }).collect();
        let mut piv = d[0];
        for i in 0..m {
            if i > 0 {
                piv = d[i] - e[i - 1] * cp[i - 1];
                rhs[i] -= e[i - 1] * rhs[i - 1];
            }
            if i + 1 < m {
                cp[i] = e[i] / piv;
            }
            rhs[i] /= piv;
        }
        for i in (0..m.saturating_sub(1)).rev() {
            rhs[i] -= cp[i] * rhs[i + 1];
        }
        for i in 0..m {
            inv[i * m + c] = rhs[i];
        }
    }
    inv
}

/// Energy and pose gradient with the auxiliary unknowns at their optimum (variable projection).
fn eval(pe: &PathEnergy, ends: &Ends, xp: &[f64], full: &mut [f64], grad: &mut [f64]) -> (f64, Vec<f64>) {
    let np = pe.n_pose_vars();
    full[..np].copy_from_slice(xp);
    pe.reset_aux(full, ends);
    let e = pe.energy_gradient(full, ends, grad);
    (e, grad[..np].to_vec())
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Minimizes the path energy from `x0` (see the module docs).
pub(crate) fn minimize(
    pe: &PathEnergy,
    layout: &SpatialLayout,
    ends: &Ends,
    x0: Vec<f64>,
    opts: &GeodesicOptions,
) -> Result<SolveOutput, GeodesicError> {
    let np = pe.n_pose_vars();
    let mut full = x0.clone();
    let mut gfull = vec![0.0; pe.n_vars()];
    let mut x = x0[..np].to_vec();
    let (mut e, mut g) = eval(pe, ends, &x, &mut full, &mut gfull);
    let g0 = dot(&g, &g).sqrt();
    let mut pre = Preconditioner::new(layout, pe, &full, ends)?;
    let refresh = opts.preconditioner_refresh;
    let mem = opts.lbfgs_memory.max(1);
    let mut hist: std::collections::VecDeque<(Vec<f64>, Vec<f64>, f64)> = std::collections::VecDeque::new();
    let mut iterations = 0;
    let max_iterations = opts.max_iterations * 10;
    let mut stop = StopReason::MaxIterations;
    if g0 == 0.0 || np == 0 || super::at_roundoff(g0, e) {
        return Ok(SolveOutput {
            x: full,
            iterations,
            stop: StopReason::GradientTolerance,
        });
    }
    while iterations < max_iterations {
        if let Some(t) = opts.target_energy {
            if e <= t {
                stop = StopReason::TargetEnergy;
                break;
            }
        }
        if dot(&g, &g).sqrt() <= opts.gradient_tolerance * g0 {
            stop = StopReason::GradientTolerance;
            break;
        }
        iterations += 1;
        // Refit `T_c (x) A` at the current path (the history stays: its pairs are still
        // valid secant information).
        if refresh > 0 && iterations % refresh == 0 {
            full[..np].copy_from_slice(&x);
            pe.reset_aux(&mut full, ends);
            pre = Preconditioner::new(layout, pe, &full, ends)?;
        }
        // Two-loop recursion with H0 = preconditioner.
        let mut q = g.clone();
        let mut alphas = Vec::with_capacity(hist.len());
        for (s, y, rho) in hist.iter().rev() {
            let a = rho * dot(s, &q);
            for (qi, yi) in q.iter_mut().zip(y) {
                *qi -= a * yi;
            }
            alphas.push(a);
        }
        pre.apply(&mut q);
        for ((s, y, rho), a) in hist.iter().zip(alphas.iter().rev()) {
            let b = rho * dot(y, &q);
            for (qi, si) in q.iter_mut().zip(s) {
                *qi += (a - b) * si;
            }
        }
        let mut d: Vec<f64> = q.iter().map(|v| -v).collect();
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Not a descent direction (can happen with a stale history): restart.
            hist.clear();
            d = g.clone();
            pre.apply(&mut d);
            d.iter_mut().for_each(|v| *v = -*v);
            slope = dot(&g, &d);
        }
        // Backtracking line search (Armijo), full step first.
        let mut t = 1.0;
        let accepted = loop {
            let xn: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + t * b).collect();
            let (en, gn) = eval(pe, ends, &xn, &mut full, &mut gfull);
            if en.is_finite() && en <= e + 1e-4 * t * slope {
                break Some((xn, en, gn));
            }
            t *= 0.5;
            if t < 1e-12 {
                break None;
            }
        };
        let Some((xn, en, gn)) = accepted else {
            stop = StopReason::NoProgress;
            break;
        };
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 1e-12 * dot(&y, &y).sqrt() * dot(&s, &s).sqrt() {
            if hist.len() == mem {
                hist.pop_front();
            }
            hist.push_back((s, y, 1.0 / sy));
        }
        let decrease = e - en;
        x = xn;
        e = en;
        g = gn;
        if decrease <= opts.energy_tolerance * e.abs() {
            stop = StopReason::EnergyTolerance;
            break;
        }
    }
    if stop == StopReason::MaxIterations && dot(&g, &g).sqrt() <= opts.gradient_tolerance * g0 {
        stop = StopReason::GradientTolerance;
    }
    full[..np].copy_from_slice(&x);
    pe.reset_aux(&mut full, ends);
    Ok(SolveOutput {
        x: full,
        iterations,
        stop,
    })
}
