//! Levenberg-Marquardt on the stacked residuals of the path energy.

// Index loops mirror the formulas (vertex, coordinate, residual indices) in these kernels.
#![allow(clippy::needless_range_loop)]

use super::energy::{Ends, PathEnergy};
use super::hessian::HessianLayout;
use super::{norm, GeodesicError, GeodesicOptions, SolveOutput, StopReason};

/// Minimizes the path energy from `x` with Levenberg-Marquardt steps
/// `(J^T J + mu D) dx = -J^T r`, `D = diag(J^T J)` floored (Marquardt scaling), `mu` adapted by
/// the ratio of actual to predicted decrease (Nielsen's rule).
pub(crate) fn minimize(
    pe: &PathEnergy,
    layout: &HessianLayout,
    ends: &Ends,
    mut x: Vec<f64>,
    opts: &GeodesicOptions,
) -> Result<SolveOutput, GeodesicError> {
    // Sequential factorization: faer's parallel kernels would share rayon's pool with the pair
    // loop, and their blocking (hence the rounding) would depend on the thread count.
    let par = faer::Par::Seq;
    let (mut blocks, mut energy, mut g) = layout.assemble(pe, &x, ends);
    // The energy gradient is 2 J^T r.
    let g0 = 2.0 * norm(&g);
    let mut mu = 1e-4;
    let mut nu = 2.0;
    let mut iterations = 0;
    let mut stop = StopReason::MaxIterations;
    if super::at_roundoff(g0, energy) {
        return Ok(SolveOutput {
            x,
            iterations,
            stop: StopReason::GradientTolerance,
            last: None,
        });
    }
    let limit = opts
        .max_iterations
        .unwrap_or_else(|| super::Solver::LevenbergMarquardt.default_max_iterations());
    while iterations < limit {
        if let Some(reason) = opts.stop_before_iteration(energy, 2.0 * norm(&g), g0) {
            stop = reason;
            break;
        }
        iterations += 1;
        opts.monitor(iterations, energy)?;
        let jtj = layout.values(&blocks);
        let dmax = layout.diag_idx().iter().map(|&i| jtj[i]).fold(0.0f64, f64::max);
        let floor = 1e-12 * dmax.max(f64::MIN_POSITIVE);
        // Marquardt scaling D = diag(J^T J), floored; independent of mu.
        let dscale: Vec<f64> = layout.diag_idx().iter().map(|&i| jtj[i].max(floor)).collect();
        // Inner loop: raise mu until a step lowers the energy.
        let accepted = loop {
            let mut h = jtj.clone();
            for (&i, d) in layout.diag_idx().iter().zip(&dscale) {
                h[i] += mu * d;
            }
            let mut dx: Vec<f64> = g.iter().map(|v| -v).collect();
            let ok = layout.solve(&h, &mut dx, par);
            if ok.is_err() || dx.iter().any(|v| !v.is_finite()) {
                mu *= nu;
                nu *= 2.0;
                if mu > 1e16 {
                    break None;
                }
                continue;
            }
            // Predicted decrease of |r + J dx|^2: -g.dx + mu dx^T D dx.
            let pred: f64 = -g.iter().zip(&dx).map(|(a, b)| a * b).sum::<f64>()
                + mu * dx.iter().zip(&dscale).map(|(a, d)| a * a * d).sum::<f64>();
            let x_new: Vec<f64> = x.iter().zip(&dx).map(|(a, b)| a + b).collect();
            let e_new = pe.energy(&x_new, ends);
            let rho = if pred > 0.0 { (energy - e_new) / pred } else { -1.0 };
            if e_new.is_finite() && e_new < energy && rho > 1e-4 {
                mu *= (1.0 / 3.0f64).max(1.0 - (2.0 * rho - 1.0).powi(3));
                nu = 2.0;
                break Some((x_new, e_new, norm(&dx)));
            }
            mu *= nu;
            nu *= 2.0;
            if mu > 1e16 {
                break None;
            }
        };
        let Some((mut x_new, e_new, step)) = accepted else {
            stop = StopReason::NoProgress;
            break;
        };
        pe.reset_aux(&mut x_new, ends);
        let decrease = energy - e_new;
        x = x_new;
        let (b, e, gg) = layout.assemble(pe, &x, ends);
        blocks = b;
        energy = e;
        g = gg;
        if decrease <= opts.energy_tolerance * energy.abs() || step <= 1e-15 * (1.0 + norm(&x)) {
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
