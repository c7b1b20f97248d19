//! Schild's ladder: parallel transport built from geodesics only (docs/method.md
//! "Deformation transfer", optional method).
//!
//! Along samples `S_0 .. S_J` (each #V x 3) with a vector `V_j` at `S_j`, one rung:
//! 1. the tip `X_j = S_j + eps V_j`;
//! 2. the geodesic midpoint `M_j` of `X_j` and `S_{j+1}` (a discrete geodesic with N = 2 segments;
//!    its middle pose);
//! 3. the geodesic from `S_j` through `M_j` extended to twice its length, `P_j` ("doubling"):
//!    first `P_j = 2 M_j - S_j`, then `doubling_iterations` fixed-point corrections
//!    `P_j <- P_j + 2 (M_j - mid(S_j, P_j))` that make `M_j` the geodesic midpoint of `S_j` and
//!    `P_j` (each one more N = 2 geodesic);
//! 4. `V_{j+1} = (P_j - S_{j+1}) / eps`.
//!
//! Every geodesic is computed by the caller's [`GeodesicSolver`] (built with N = 2 for the
//! metric itself, not its quadratic companion; each rung geodesic takes its frozen weights from
//! its own ends). A flat metric (constant quadratic form, e.g. L2 with frozen areas) has
//! straight geodesics, and the ladder then returns `V_0` unchanged.

use crate::geodesic::{GeodesicSolver, SolveContext};

use super::parallel::check_curve;
use super::TransportError;

/// Options of [`schild_ladder`].
#[derive(Debug, Clone)]
pub struct SchildOptions {
    /// Fixed-point corrections of each rung's doubling (0: the linear doubling `2 M - S_j`).
    /// Default 2.
    pub doubling_iterations: usize,
    /// The ladder carries `eps V` and divides by `eps` at the end (smaller rungs, closer to the
    /// infinitesimal construction). Default 1.
    pub epsilon: f64,
}

impl Default for SchildOptions {
    fn default() -> Self {
        SchildOptions {
            doubling_iterations: 2,
            epsilon: 1.0,
        }
    }
}

/// Diagnostics of one rung.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RungDiagnostics {
    /// Geodesic solves of the rung (1 midpoint + the doubling corrections).
    pub geodesics: usize,
    /// Whether every geodesic solve of the rung converged.
    pub converged: bool,
    /// `|mid(S_j, P_j) - M_j| / |eps V_j|` after the last correction (NaN-free; 0 when no
    /// correction was made or `V_j = 0`): how far the doubling is from a geodesic extension.
    pub doubling_mismatch: f64,
}

/// A vector transported by Schild's ladder.
#[derive(Debug, Clone)]
pub struct SchildTransported {
    /// The vector at the last sample (#V x 3).
    pub vector: Vec<[f64; 3]>,
    /// The vector at every sample `S_0 .. S_J`.
    pub along: Vec<Vec<[f64; 3]>>,
    /// One entry per rung (J entries).
    pub rungs: Vec<RungDiagnostics>,
}

fn norm(v: &[[f64; 3]]) -> f64 {
    v.iter().flatten().map(|c| c * c).sum::<f64>().sqrt()
}

/// Schild's ladder transport of `v0` (#V x 3) along `curve = S_0 .. S_J` (each #V x 3), with
/// the geodesic midpoints of `midpoints` (a solver built with `steps = 2`; coordinates as that
/// solver expects them, i.e. already normalized). See the [module docs](self).
pub fn schild_ladder(
    midpoints: &GeodesicSolver,
    curve: &[Vec<[f64; 3]>],
    v0: &[[f64; 3]],
    options: &SchildOptions,
) -> Result<SchildTransported, TransportError> {
    if midpoints.options().steps != 2 {
        return Err(TransportError::SchildSteps {
            steps: midpoints.options().steps,
        });
    }
    if !(options.epsilon.is_finite() && options.epsilon > 0.0) {
        return Err(TransportError::NotPositive {
            name: "epsilon",
            value: options.epsilon,
        });
    }
    let nv = midpoints.path_energy().n_vertices();
    check_curve(curve, v0, nv)?;
    let eps = options.epsilon;
    let mut out = SchildTransported {
        vector: v0.to_vec(),
        along: vec![v0.to_vec()],
        rungs: Vec::with_capacity(curve.len().saturating_sub(1)),
    };
    if v0.iter().flatten().all(|c| *c == 0.0) {
        out.along = vec![v0.to_vec(); curve.len()];
        out.rungs = vec![
            RungDiagnostics {
                converged: true,
                ..Default::default()
            };
            curve.len() - 1
        ];
        return Ok(out);
    }
    // The midpoint geodesics of a ladder are short and close to each other: they share a
    // preconditioner fit ([`SolveContext`]).
    let mut ctx = SolveContext::default();
    let mut mid = |a: &[[f64; 3]], b: &[[f64; 3]]| -> Result<(Vec<[f64; 3]>, bool), TransportError> {
        let g = midpoints.solve_in(&mut ctx, a, b)?;
        Ok((g.poses[1].clone(), g.converged))
    };
    let mut v: Vec<[f64; 3]> = v0.iter().map(|p| p.map(|c| c * eps)).collect();
    for w in curve.windows(2) {
        let (s, s1) = (&w[0], &w[1]);
        let tip: Vec<[f64; 3]> = s.iter().zip(&v).map(|(p, x)| add3(*p, *x)).collect();
        let (m, mut converged) = mid(&tip, s1)?;
        let mut p: Vec<[f64; 3]> = m
            .iter()
            .zip(s.iter())
            .map(|(a, b)| [2.0 * a[0] - b[0], 2.0 * a[1] - b[1], 2.0 * a[2] - b[2]])
            .collect();
        let mut diag = RungDiagnostics {
            geodesics: 1,
            ..Default::default()
        };
        let vn = norm(&v);
        for _ in 0..options.doubling_iterations {
            let (mp, c) = mid(s, &p)?;
            converged &= c;
            diag.geodesics += 1;
            let mut mis = 0.0;
            for ((pi, a), b) in p.iter_mut().zip(&m).zip(&mp) {
                for k in 0..3 {
                    let d = a[k] - b[k];
                    mis += d * d;
                    pi[k] += 2.0 * d;
                }
            }
            diag.doubling_mismatch = if vn > 0.0 { mis.sqrt() / vn } else { 0.0 };
        }
        diag.converged = converged;
        v = p
            .iter()
            .zip(s1.iter())
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
            .collect();
        if v.iter().flatten().any(|c| !c.is_finite()) {
            return Err(TransportError::NonFinite {
                what: format!("Schild rung {}'s vector", out.rungs.len()),
            });
        }
        out.along.push(v.iter().map(|p| p.map(|c| c / eps)).collect());
        out.rungs.push(diag);
    }
    out.vector = v.iter().map(|p| p.map(|c| c / eps)).collect();
    Ok(out)
}

#[inline]
fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
