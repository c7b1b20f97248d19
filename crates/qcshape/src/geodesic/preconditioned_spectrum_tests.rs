//! The spectrum of the preconditioned path Hessian `M^{-1} H` at 642, 2,562 and 10,242 vertices
//! (a study, run on demand: `cargo test --release -p qcshape --lib preconditioned_spectrum --
//! --ignored --nocapture`; docs/log/bending.md "Why the iterations grow with the mesh").
//!
//! `H` is the exact Hessian of the path energy (central differences of the exact gradient along
//! each direction), `M^{-1}` a preconditioner (the default solver's Kronecker model, the
//! pose-wise model of `--solver pose-kronecker` or the Hessian-fitted model of `--solver
//! hessian-kronecker`, each plus the vertex-block term), both restricted to the rigid gauge's
//! subspace. Conjugate gradients on
//! `H x = b` preconditioned by `M^{-1}` build the Lanczos tridiagonal matrix of `M^{-1} H`; its
//! eigenvalues (Ritz values) estimate the extreme eigenvalues of `M^{-1} H`, which bound how fast
//! a preconditioned solver converges.

use super::energy::Ends;
use super::gauge::RigidGauge;
use super::plbfgs::{Model, Preconditioner};
use super::*;
use crate::metric::{MetricKind, MetricSpec};

/// Eigenvalues (ascending) of the symmetric tridiagonal matrix with diagonal `d` and
/// off-diagonal `e`.
fn tridiagonal_eigenvalues(d: &[f64], e: &[f64]) -> Vec<f64> {
    let n = d.len();
    let m = faer::Mat::<f64>::from_fn(n, n, |i, j| {
        if i == j {
            d[i]
        } else if i + 1 == j {
            e[i]
        } else if j + 1 == i {
            e[j]
        } else {
            0.0
        }
    });
    m.self_adjoint_eigenvalues(faer::Side::Lower)
        .expect("eigenvalues")
}

/// `H v` by central differences of the exact gradient at `x` (pose part only; the metric
/// has no auxiliary unknowns here), projected onto the gauge.
fn hessian_vector(pe: &PathEnergy, ends: &Ends, x: &[f64], v: &[f64], gauge: &RigidGauge) -> Vec<f64> {
    let n = x.len();
    let vn = norm(v);
    let h = 1e-6 / vn.max(1e-300);
    let xp: Vec<f64> = x.iter().zip(v).map(|(a, b)| a + h * b).collect();
    let xm: Vec<f64> = x.iter().zip(v).map(|(a, b)| a - h * b).collect();
    let (mut gp, mut gm) = (vec![0.0; n], vec![0.0; n]);
    pe.energy_gradient(&xp, ends, &mut gp);
    pe.energy_gradient(&xm, ends, &mut gm);
    let mut out: Vec<f64> = gp.iter().zip(&gm).map(|(p, m)| (p - m) / (2.0 * h)).collect();
    gauge.project(&mut out);
    out
}

/// Ritz values of `M^{-1} H` from `k` steps of preconditioned conjugate gradients on `H x = b`,
/// and the number of steps that reduced the preconditioned residual norm by 1e-6.
fn pcg_ritz(
    pe: &PathEnergy,
    ends: &Ends,
    x: &[f64],
    pre: &mut dyn FnMut(&mut [f64]),
    gauge: &RigidGauge,
    k: usize,
) -> (Vec<f64>, Option<usize>) {
    let n = x.len();
    // A fixed, smooth-and-rough right-hand side (no random generator needed).
    let mut r: Vec<f64> = (0..n)
        .map(|i| ((i as f64) * 0.618_033_988_7).fract() - 0.5)
        .collect();
    gauge.project(&mut r);
    let precondition = |pre: &mut dyn FnMut(&mut [f64]), v: &[f64]| -> Vec<f64> {
        let mut z = v.to_vec();
        pre(&mut z);
        gauge.project(&mut z);
        z
    };
    let mut z = precondition(&mut *pre, &r);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let rz0 = rz;
    let (mut alphas, mut betas) = (Vec::new(), Vec::new());
    let mut reached = None;
    for it in 0..k {
        let hp = hessian_vector(pe, ends, x, &p, gauge);
        let php = dot(&p, &hp);
        if php.is_nan() || php <= 0.0 {
            break;
        }
        let alpha = rz / php;
        for i in 0..n {
            r[i] -= alpha * hp[i];
        }
        z = precondition(&mut *pre, &r);
        let rz_new = dot(&r, &z);
        let beta = rz_new / rz;
        alphas.push(alpha);
        betas.push(beta);
        if reached.is_none() && rz_new.sqrt() <= 1e-6 * rz0.sqrt() {
            reached = Some(it + 1);
        }
        if !(beta.is_finite() && alpha.is_finite()) || rz_new.sqrt() <= 1e-10 * rz0.sqrt() {
            break;
        }
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
        rz = rz_new;
    }
    if alphas.len() > betas.len() || betas.last().is_some_and(|b| !b.is_finite()) {
        alphas.truncate(betas.len().saturating_sub(1));
    }
    let m = alphas.len();
    let mut d = vec![0.0; m];
    let mut e = vec![0.0; m.saturating_sub(1)];
    for j in 0..m {
        d[j] = 1.0 / alphas[j] + if j > 0 { betas[j - 1] / alphas[j - 1] } else { 0.0 };
        if j + 1 < m {
            e[j] = betas[j].sqrt() / alphas[j];
        }
    }
    (tridiagonal_eigenvalues(&d, &e), reached)
}

/// The comma-separated values of the environment variable `name`, or `default`.
pub(super) fn env_list<T: std::str::FromStr>(name: &str, default: Vec<T>) -> Vec<T>
where
    T::Err: std::fmt::Debug,
{
    std::env::var(name)
        .ok()
        .map(|s| s.split(',').map(|v| v.parse().unwrap()).collect())
        .unwrap_or(default)
}

#[test]
#[ignore = "a study (a few minutes in release): prints the preconditioned spectra"]
fn preconditioned_spectrum_of_the_path_hessian() {
    let levels: Vec<u32> = env_list("SPECTRUM_LEVELS", vec![3, 4]);
    let bendings: Vec<f64> = env_list("SPECTRUM_BENDINGS", vec![1e-4, 0.0]);
    let steps_k: usize = std::env::var("SPECTRUM_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(120);
    println!(
        "| vertices | bending | iterations | model, fitted at | Ritz: lowest 4 | highest 2 | \
         kappa | Ritz < 0.1 / < 0.3 | PCG steps to 1e-6 |"
    );
    for level in levels {
        let (a, b) = crate::synth::twisted_sphere(level);
        for &bending in &bendings {
            let spec = MetricSpec {
                bending,
                ..MetricSpec::new(MetricKind::Isometric)
            };
            let (metric, f) = pair_metric(&spec, &a, &b).unwrap();
            let scale = |p: &[[f64; 3]]| -> Vec<[f64; 3]> { p.iter().map(|v| v.map(|c| c * f)).collect() };
            let opts = GeodesicOptions::default();
            let solver = GeodesicSolver::new(metric.as_ref(), a.topology.clone(), opts.clone()).unwrap();
            let (sa, sb) = (scale(&a.positions), scale(&b.positions));
            let g = solver.solve(&sa, &sb).unwrap();
            let pe = PathEnergy::new(metric.as_ref(), a.topology.clone(), opts.steps);
            assert_eq!(
                pe.n_vars(),
                pe.n_pose_vars(),
                "the study assumes no auxiliary unknowns"
            );
            let frozen = metric.frozen_weights(&a.topology, &sa, &sb);
            let ends = Ends {
                start: sa.clone(),
                end: sb.clone(),
                frozen,
            };
            let interior: Vec<Vec<[f64; 3]>> =
                g.poses[1..g.poses.len() - 1].iter().map(|p| scale(p)).collect();
            let x = pe.pack(&interior, &ends);
            let x0 = pe.linear_start(&ends);
            let gauge = RigidGauge::new(&ends, opts.steps);
            let layout = kronecker::SpatialLayout::new(&pe).unwrap();
            let cases = [
                ("Kronecker, linear start", Model::Kronecker, &x0),
                ("Kronecker, geodesic", Model::Kronecker, &x),
                ("pose-wise, linear start", Model::PoseWise, &x0),
                ("pose-wise, geodesic", Model::PoseWise, &x),
                ("Hessian-Kronecker, geodesic", Model::Hessian, &x),
            ];
            for (at, model, xf) in cases {
                let mut pre =
                    Preconditioner::new((&layout, model), &pe, xf, &ends, opts.vertex_block_weight).unwrap();
                let mut apply = |q: &mut [f64]| pre.apply(q);
                let (ritz, reached) = pcg_ritz(&pe, &ends, &x, &mut apply, &gauge, steps_k);
                let m = ritz.len();
                let lo = ritz[..4.min(m)]
                    .iter()
                    .map(|v| format!("{v:.3}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                let hi = format!("{:.3}, {:.3}", ritz[m - 2], ritz[m - 1]);
                let below = |t: f64| ritz.iter().filter(|&&v| v < t).count();
                println!(
                    "| {} | {bending} | {} | {at} | {lo} | {hi} | {:.1} | {} / {} | {} |",
                    a.positions.len(),
                    g.iterations,
                    ritz[m - 1] / ritz[0],
                    below(0.1),
                    below(0.3),
                    reached.map_or(format!("> {steps_k}"), |r| r.to_string())
                );
            }
        }
    }
}
