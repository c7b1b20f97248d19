//! L-BFGS preconditioned by the path's Kronecker structure (the default solver).
//!
//! The initial inverse Hessian is `gamma (2 T_c (x) A)^{-1}`, the Kronecker model of the
//! energy's Gauss-Newton Hessian `2 J^T J` ([`super::kronecker`]: one sparse Cholesky of size
//! 3 #V, `N - 1` triangular solve pairs per application), refitted at the current path every
//! [`GeodesicOptions::preconditioner_refresh`] iterations, and scaled by
//! `gamma = s.y / y.H0 y` of the newest correction pair (the model's scale can be off by a
//! large factor where second-order terms dominate). L-BFGS with this initial inverse Hessian
//! learns the rest (the pose-to-pose variation of
//! the metric and the large-residual curvature terms that Gauss-Newton leaves out). Auxiliary
//! unknowns (rigid motions) are eliminated: they are set to their optimum at every evaluation,
//! and by the envelope theorem the pose part of the gradient is then the exact gradient.

use std::collections::VecDeque;

use super::energy::{Ends, PathEnergy};
use super::kronecker::{KroneckerModel, SpatialLayout};
use super::{dot, norm, GeodesicError, GeodesicOptions, SolveOutput, StopReason};

/// The factorized preconditioner `(2 T_c (x) A)^{-1}` (the energy's Gauss-Newton Hessian is
/// `2 J^T J ~ 2 T_c (x) A`), fitted at one path.
struct Preconditioner<'l> {
    layout: &'l SpatialLayout,
    model: KroneckerModel,
}

impl<'l> Preconditioner<'l> {
    /// Fits the model to the blocks of `J^T J` at `x` ([`KroneckerModel::fit`]).
    fn new(
        layout: &'l SpatialLayout,
        pe: &PathEnergy,
        x: &[f64],
        ends: &Ends,
    ) -> Result<Self, GeodesicError> {
        let (blocks, _, _) = layout.structure().assemble(pe, x, ends);
        let model = KroneckerModel::fit(layout, &blocks)?;
        Ok(Preconditioner { layout, model })
    }

    /// `q <- (2 T_c (x) A)^{-1} q` on the pose part (length 3 #V (N - 1)).
    fn apply(&self, q: &mut [f64]) {
        self.model.apply(self.layout, q, 0.5);
    }
}

/// Energy and pose gradient (into `out`) with the auxiliary unknowns at their optimum
/// (variable projection).
fn eval(
    pe: &PathEnergy,
    ends: &Ends,
    xp: &[f64],
    full: &mut [f64],
    grad: &mut [f64],
    out: &mut [f64],
) -> f64 {
    let np = pe.n_pose_vars();
    full[..np].copy_from_slice(xp);
    pe.reset_aux(full, ends);
    let e = pe.energy_gradient(full, ends, grad);
    out.copy_from_slice(&grad[..np]);
    e
}

/// One L-BFGS correction pair with its preconditioned `y`.
struct Pair {
    s: Vec<f64>,
    y: Vec<f64>,
    /// `1 / s.y`.
    rho: f64,
    /// `M^{-1} y` for the current preconditioner `M`.
    my: Vec<f64>,
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
    let mut g = vec![0.0; np];
    let mut e = eval(pe, ends, &x, &mut full, &mut gfull, &mut g);
    let g0 = norm(&g);
    let mut pre = Preconditioner::new(layout, pe, &full, ends)?;
    let refresh = opts.preconditioner_refresh;
    let mut gamma = 1.0f64;
    let mem = opts.lbfgs_memory.max(1);
    // M^{-1} g for the current gradient, and the history (s, y, 1 / s.y, M^{-1} y): by
    // linearity the two-loop recursion's `H0 q` is `gamma (M^{-1} g - sum_i alpha_i M^{-1} y_i)`,
    // so one preconditioner application per iteration suffices (`M^{-1} y` is the difference
    // of two consecutive `M^{-1} g`).
    let precondition = |pre: &Preconditioner, v: &[f64], z: &mut Vec<f64>| {
        z.clear();
        z.extend_from_slice(v);
        pre.apply(z);
    };
    let mut mg = Vec::with_capacity(np);
    precondition(&pre, &g, &mut mg);
    // Work vectors reused across iterations (no allocation in the loop but for new pairs).
    let (mut q, mut r, mut d) = (vec![0.0; np], vec![0.0; np], vec![0.0; np]);
    let (mut xn, mut gn, mut mg_new) = (vec![0.0; np], vec![0.0; np], Vec::with_capacity(np));
    let (mut ws, mut wy, mut wmy) = (vec![0.0; np], vec![0.0; np], vec![0.0; np]);
    let mut hist: VecDeque<Pair> = VecDeque::new();
    let mut iterations = 0;
    let max_iterations = opts.max_iterations * 10;
    let mut stop = StopReason::MaxIterations;
    if np == 0 || super::at_roundoff(g0, e) {
        return Ok(SolveOutput {
            x: full,
            iterations,
            stop: StopReason::GradientTolerance,
        });
    }
    while iterations < max_iterations {
        if let Some(reason) = opts.stop_before_iteration(e, norm(&g), g0) {
            stop = reason;
            break;
        }
        iterations += 1;
        // Refit `T_c (x) A` at the current path (the history stays: its pairs are still
        // valid secant information; their `M^{-1} y` are recomputed).
        if refresh > 0 && iterations % refresh == 0 {
            full[..np].copy_from_slice(&x);
            pe.reset_aux(&mut full, ends);
            pre = Preconditioner::new(layout, pe, &full, ends)?;
            precondition(&pre, &g, &mut mg);
            for pair in hist.iter_mut() {
                precondition(&pre, &pair.y, &mut pair.my);
            }
        }
        // Two-loop recursion with H0 = gamma M^{-1}.
        q.copy_from_slice(&g);
        let mut alphas = Vec::with_capacity(hist.len());
        for pair in hist.iter().rev() {
            let a = pair.rho * dot(&pair.s, &q);
            for (qi, yi) in q.iter_mut().zip(&pair.y) {
                *qi -= a * yi;
            }
            alphas.push(a);
        }
        r.copy_from_slice(&mg);
        for (pair, a) in hist.iter().rev().zip(&alphas) {
            for (ri, mi) in r.iter_mut().zip(&pair.my) {
                *ri -= a * mi;
            }
        }
        r.iter_mut().for_each(|v| *v *= gamma);
        for (pair, a) in hist.iter().zip(alphas.iter().rev()) {
            let b = pair.rho * dot(&pair.y, &r);
            for (ri, si) in r.iter_mut().zip(&pair.s) {
                *ri += (a - b) * si;
            }
        }
        for (di, ri) in d.iter_mut().zip(&r) {
            *di = -ri;
        }
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Not a descent direction (can happen with a stale history): restart.
            hist.clear();
            for (di, mi) in d.iter_mut().zip(&mg) {
                *di = -gamma * mi;
            }
            slope = dot(&g, &d);
        }
        // Backtracking line search (Armijo), full step first.
        let mut t = 1.0;
        let accepted = loop {
            for ((xi, a), b) in xn.iter_mut().zip(&x).zip(&d) {
                *xi = a + t * b;
            }
            let en = eval(pe, ends, &xn, &mut full, &mut gfull, &mut gn);
            if en.is_finite() && en <= e + 1e-4 * t * slope {
                break Some(en);
            }
            t *= 0.5;
            if t < 1e-12 {
                break None;
            }
        };
        let Some(en) = accepted else {
            stop = StopReason::NoProgress;
            break;
        };
        precondition(&pre, &gn, &mut mg_new);
        for k in 0..np {
            ws[k] = xn[k] - x[k];
            wy[k] = gn[k] - g[k];
            wmy[k] = mg_new[k] - mg[k];
        }
        let sy = dot(&ws, &wy);
        if sy > 1e-12 * norm(&wy) * norm(&ws) {
            // Scale H0 to the newest pair's curvature along y: gamma = s.y / y.M^{-1} y (the
            // preconditioned form of Nocedal & Wright's eq. 7.20).
            let ymy = dot(&wy, &wmy);
            if ymy > 0.0 {
                gamma = sy / ymy;
            }
            // The oldest pair's storage becomes the next work vectors when the history is full.
            let (ns, ny, nmy) = if hist.len() == mem {
                let old = hist.pop_front().expect("full history");
                (old.s, old.y, old.my)
            } else {
                (vec![0.0; np], vec![0.0; np], vec![0.0; np])
            };
            hist.push_back(Pair {
                s: std::mem::replace(&mut ws, ns),
                y: std::mem::replace(&mut wy, ny),
                rho: 1.0 / sy,
                my: std::mem::replace(&mut wmy, nmy),
            });
        }
        let decrease = e - en;
        std::mem::swap(&mut x, &mut xn);
        std::mem::swap(&mut g, &mut gn);
        std::mem::swap(&mut mg, &mut mg_new);
        e = en;
        if decrease <= opts.energy_tolerance * e.abs() {
            stop = StopReason::EnergyTolerance;
            break;
        }
    }
    let stop = opts.final_stop(stop, norm(&g), g0);
    full[..np].copy_from_slice(&x);
    pe.reset_aux(&mut full, ends);
    Ok(SolveOutput {
        x: full,
        iterations,
        stop,
    })
}
