//! The spectrum of the path energy's Hessian at a converged geodesic (a study, run on demand:
//! `cargo test --release -p qcshape --lib spectrum -- --ignored --nocapture`): which part of
//! the exact Hessian the Gauss-Newton model `J^T J` misses, for the invariant form with and
//! without the bending term and for the calibrated form (docs/log/bending.md).

use super::energy::Ends;
use super::hessian::HessianLayout;
use super::*;
use crate::metric::{MetricKind, MetricScale, MetricSpec};

/// Eigenvalues (ascending) of the symmetric `n x n` matrix `m` (row-major).
fn eigenvalues(m: &[f64], n: usize) -> Vec<f64> {
    let a = faer::Mat::<f64>::from_fn(n, n, |i, j| 0.5 * (m[i * n + j] + m[j * n + i]));
    a.self_adjoint_eigenvalues(faer::Side::Lower)
        .expect("eigenvalues")
}

/// The exact Hessian of the path energy by central differences of its exact gradient, and
/// the Gauss-Newton Hessian `2 J^T J`, both dense (row-major).
fn hessians(pe: &PathEnergy, ends: &Ends, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = pe.n_vars();
    let mut exact = vec![0.0; n * n];
    let mut gp = vec![0.0; n];
    let mut gm = vec![0.0; n];
    for j in 0..n {
        let h = 1e-6 * (1.0 + x[j].abs());
        let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
        xp[j] += h;
        xm[j] -= h;
        pe.energy_gradient(&xp, ends, &mut gp);
        pe.energy_gradient(&xm, ends, &mut gm);
        for i in 0..n {
            exact[i * n + j] = (gp[i] - gm[i]) / (2.0 * h);
        }
    }
    let layout = HessianLayout::new(pe);
    let (blocks, _, _) = layout.assemble(pe, x, ends);
    let vals = layout.values(&blocks);
    let (col_ptr, row_idx) = layout.pattern();
    let mut gn = vec![0.0; n * n];
    for col in 0..n {
        for k in col_ptr[col]..col_ptr[col + 1] {
            let row = row_idx[k];
            gn[row * n + col] = 2.0 * vals[k];
            gn[col * n + row] = 2.0 * vals[k];
        }
    }
    (exact, gn)
}

#[test]
#[ignore = "a study (about a minute): prints the spectra"]
fn spectrum_of_the_path_hessian() {
    let (a, b) = crate::synth::twisted_sphere(2);
    let cases = [
        (
            "invariant, no bending",
            MetricSpec {
                bending: 0.0,
                ..MetricSpec::new(MetricKind::Isometric)
            },
        ),
        (
            "invariant, bending 1e-4",
            MetricSpec {
                bending: 1e-4,
                ..MetricSpec::new(MetricKind::Isometric)
            },
        ),
        (
            "calibrated",
            MetricSpec {
                scale: MetricScale::Calibrated,
                stretch: 0.0,
                bending: 0.0,
                ..MetricSpec::new(MetricKind::Isometric)
            },
        ),
    ];
    println!(
        "| isometric, 162 vertices, N = 8 | iterations | exact: lowest 5 eigenvalues / largest | negative | \
         below 1e-4 / 1e-3 / 1e-2 of the largest | GN: lowest 5 / largest | ||H - GN|| / ||GN|| |"
    );
    for (name, spec) in cases {
        let (metric, f) = pair_metric(&spec, &a, &b).unwrap();
        let scale = |p: &[[f64; 3]]| -> Vec<[f64; 3]> { p.iter().map(|v| v.map(|c| c * f)).collect() };
        let opts = GeodesicOptions {
            gradient_tolerance: 1e-9,
            energy_tolerance: 0.0,
            max_iterations: Some(20_000),
            ..GeodesicOptions::default()
        };
        let solver = GeodesicSolver::new(metric.as_ref(), a.topology.clone(), opts.clone()).unwrap();
        let (sa, sb) = (scale(&a.positions), scale(&b.positions));
        let g = solver.solve(&sa, &sb).unwrap();
        let pe = PathEnergy::new(metric.as_ref(), a.topology.clone(), opts.steps);
        let frozen = metric.frozen_weights(&a.topology, &sa, &sb);
        let ends = Ends {
            start: sa.clone(),
            end: sb.clone(),
            frozen,
        };
        let interior: Vec<Vec<[f64; 3]>> = g.poses[1..g.poses.len() - 1].iter().map(|p| scale(p)).collect();
        let x = pe.pack(&interior, &ends);
        let n = pe.n_vars();
        let (exact, gn) = hessians(&pe, &ends, &x);
        let diff: f64 = exact
            .iter()
            .zip(&gn)
            .map(|(e, g)| (e - g).powi(2))
            .sum::<f64>()
            .sqrt();
        let gnn: f64 = gn.iter().map(|v| v * v).sum::<f64>().sqrt();
        let (ee, eg) = (eigenvalues(&exact, n), eigenvalues(&gn, n));
        let (me, mg) = (ee[n - 1], eg[n - 1]);
        let fmt = |v: &[f64], m: f64| {
            v[..5]
                .iter()
                .map(|x| format!("{:.1e}", x / m))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let negative = ee.iter().filter(|&&v| v < -1e-9 * me).count();
        let below = |t: f64| ee.iter().filter(|&&v| v < t * me).count();
        println!(
            "| {name} | {} | {} / {me:.2e} | {negative} | {} / {} / {} of {n} | {} / {mg:.2e} | {:.3} |",
            g.iterations,
            fmt(&ee, me),
            below(1e-4),
            below(1e-3),
            below(1e-2),
            fmt(&eg, mg),
            diff / gnn
        );
    }
}
