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
use super::{dot, GeodesicError, GeodesicOptions, SolveOutput, StopReason};

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

/// Energy and pose gradient with the auxiliary unknowns at their optimum (variable projection).
fn eval(pe: &PathEnergy, ends: &Ends, xp: &[f64], full: &mut [f64], grad: &mut [f64]) -> (f64, Vec<f64>) {
    let np = pe.n_pose_vars();
    full[..np].copy_from_slice(xp);
    pe.reset_aux(full, ends);
    let e = pe.energy_gradient(full, ends, grad);
    (e, grad[..np].to_vec())
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
    let (mut e, mut g) = eval(pe, ends, &x, &mut full, &mut gfull);
    let g0 = dot(&g, &g).sqrt();
    let mut pre = Preconditioner::new(layout, pe, &full, ends)?;
    let refresh = opts.preconditioner_refresh;
    let mut gamma = 1.0f64;
    let mem = opts.lbfgs_memory.max(1);
    // M^{-1} g for the current gradient, and the history (s, y, 1 / s.y, M^{-1} y): by
    // linearity the two-loop recursion's `H0 q` is `gamma (M^{-1} g - sum_i alpha_i M^{-1} y_i)`,
    // so one preconditioner application per iteration suffices (`M^{-1} y` is the difference
    // of two consecutive `M^{-1} g`).
    let precondition = |pre: &Preconditioner, v: &[f64]| {
        let mut z = v.to_vec();
        pre.apply(&mut z);
        z
    };
    let mut mg = precondition(&pre, &g);
    let mut hist: VecDeque<Pair> = VecDeque::new();
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
        // valid secant information; their `M^{-1} y` are recomputed).
        if refresh > 0 && iterations % refresh == 0 {
            full[..np].copy_from_slice(&x);
            pe.reset_aux(&mut full, ends);
            pre = Preconditioner::new(layout, pe, &full, ends)?;
            mg = precondition(&pre, &g);
            for pair in hist.iter_mut() {
                pair.my = precondition(&pre, &pair.y);
            }
        }
        // Two-loop recursion with H0 = gamma M^{-1}.
        let mut q = g.clone();
        let mut alphas = Vec::with_capacity(hist.len());
        for pair in hist.iter().rev() {
            let a = pair.rho * dot(&pair.s, &q);
            for (qi, yi) in q.iter_mut().zip(&pair.y) {
                *qi -= a * yi;
            }
            alphas.push(a);
        }
        let mut r = mg.clone();
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
        let mut d: Vec<f64> = r.iter().map(|v| -v).collect();
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Not a descent direction (can happen with a stale history): restart.
            hist.clear();
            d = mg.iter().map(|v| -gamma * v).collect();
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
        let mg_new = precondition(&pre, &gn);
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 1e-12 * dot(&y, &y).sqrt() * dot(&s, &s).sqrt() {
            if hist.len() == mem {
                hist.pop_front();
            }
            let my: Vec<f64> = mg_new.iter().zip(&mg).map(|(a, b)| a - b).collect();
            // Scale H0 to the newest pair's curvature along y: gamma = s.y / y.M^{-1} y (the
            // preconditioned form of Nocedal & Wright's eq. 7.20).
            let ymy = dot(&y, &my);
            if ymy > 0.0 {
                gamma = sy / ymy;
            }
            hist.push_back(Pair {
                s,
                y,
                rho: 1.0 / sy,
                my,
            });
        }
        let decrease = e - en;
        x = xn;
        e = en;
        g = gn;
        mg = mg_new;
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
