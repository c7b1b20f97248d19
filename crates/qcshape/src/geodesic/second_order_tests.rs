//! Finite-difference check of the exact Hessian (Gauss-Newton blocks plus the metrics'
//! second-order parts) against the assembled gradient, on random paths (tests only).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::energy::{Ends, PathEnergy};
use super::hessian::HessianLayout;
use crate::mesh::Shape;
use crate::metric::{
    Conformal, ConformalForm, FrozenL2, Isometric, Metric, QcWeights, QuasiConformal, Regularized, Rigid,
};

fn jitter(rng: &mut ChaCha8Rng, pos: &[[f64; 3]], amp: f64) -> Vec<[f64; 3]> {
    pos.iter()
        .map(|p| p.map(|c| c + amp * (rng.random::<f64>() - 0.5)))
        .collect()
}

/// A closed and an open base mesh.
fn bases() -> Vec<Shape> {
    let sphere = crate::synth::icosphere(0);
    let mut grid = crate::synth::grid(3);
    for p in &mut grid.positions {
        p[2] = 0.3 * (p[0] - 0.5) * (p[1] + 0.2);
    }
    vec![sphere, grid]
}

fn problem<'m>(m: &'m dyn Metric, base: &Shape, rng: &mut ChaCha8Rng) -> (PathEnergy<'m>, Ends, Vec<f64>) {
    random_path(m, base, 3, rng)
}

/// A random path problem on `base` with `steps` segments: jittered ends `a`, `b` (amplitudes
/// 0.1 and 0.6) and a perturbed linear path (shared with the Kronecker tests).
pub(super) fn random_path<'m>(
    m: &'m dyn Metric,
    base: &Shape,
    steps: usize,
    rng: &mut ChaCha8Rng,
) -> (PathEnergy<'m>, Ends, Vec<f64>) {
    let a = jitter(rng, &base.positions, 0.1);
    let b = jitter(rng, &a, 0.6);
    let pe = PathEnergy::new(m, base.topology.clone(), steps);
    let frozen = m.frozen_weights(&base.topology, &a, &b);
    let ends = Ends {
        start: a,
        end: b,
        frozen,
    };
    let mut x = pe.linear_start(&ends);
    for v in x.iter_mut() {
        *v += 0.1 * (rng.random::<f64>() - 0.5);
    }
    (pe, ends, x)
}

/// Upper triangle of half the Hessian (`J^T J + sum r d2 r`) in the layout's order, or `None`
/// when the metric has no second-order part.
fn exact_half_hessian(layout: &HessianLayout, pe: &PathEnergy, ends: &Ends, x: &[f64]) -> Option<Vec<f64>> {
    let (mut blocks, _, _) = layout.structure().assemble_with(pe, x, ends, true);
    let mut all = true;
    for b in &mut blocks {
        all &= b.merge_second();
    }
    all.then(|| layout.values(&blocks))
}

#[test]
fn exact_hessian_matches_finite_differences_of_the_gradient() {
    let lam = 0.3;
    let reg = |m: Box<dyn Metric>| -> Box<dyn Metric> { Box::new(Regularized::new(m, lam)) };
    let metrics: Vec<Box<dyn Metric>> = vec![
        reg(Box::new(Isometric)),
        Box::new(Isometric),
        Box::new(crate::metric::RelativeIsometric),
        reg(Box::new(crate::metric::RelativeIsometric)),
        reg(Box::new(Conformal::new(ConformalForm::Quadratic))),
        reg(Box::new(QuasiConformal::new(
            ConformalForm::Quadratic,
            QcWeights::Endpoints,
        ))),
        Box::new(FrozenL2),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    for m in &metrics {
        for base in bases() {
            let (pe, ends, x) = problem(m.as_ref(), &base, &mut rng);
            let layout = HessianLayout::new(&pe);
            let vals = exact_half_hessian(&layout, &pe, &ends, &x)
                .unwrap_or_else(|| panic!("{}: second-order part missing", m.name()));
            let n = pe.n_vars();
            let (col_ptr, row_idx) = layout.pattern();
            let grad = |x: &[f64]| layout.structure().assemble(&pe, x, &ends).2;
            let mut dense = vec![vec![0.0; n]; n];
            let scale = vals.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            for j in 0..n {
                let h = 1e-5 * (1.0 + x[j].abs());
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[j] += h;
                xm[j] -= h;
                let (gp, gm) = (grad(&xp), grad(&xm));
                for i in 0..n {
                    dense[i][j] = (gp[i] - gm[i]) / (2.0 * h);
                }
            }
            let mut seen = vec![vec![false; n]; n];
            for col in 0..n {
                for k in col_ptr[col]..col_ptr[col + 1] {
                    let row = row_idx[k];
                    seen[row][col] = true;
                    let want = 0.5 * (dense[row][col] + dense[col][row]);
                    assert!(
                        (vals[k] - want).abs() <= 1e-6 * scale + 1e-6 * want.abs(),
                        "{}: H[{row},{col}] {} vs finite differences {want} (scale {scale})",
                        m.name(),
                        vals[k]
                    );
                }
            }
            for r in 0..n {
                for c in r..n {
                    assert!(
                        seen[r][c] || dense[r][c].abs() <= 1e-6 * scale,
                        "{}: H[{r},{c}] = {} outside the structure",
                        m.name(),
                        dense[r][c]
                    );
                }
            }
        }
    }
}

#[test]
fn metrics_without_second_derivatives_keep_the_gauss_newton_model() {
    let metrics: Vec<Box<dyn Metric>> = vec![
        Box::new(Regularized::new(Box::new(Rigid), 0.3)),
        Box::new(Regularized::new(
            Box::new(Conformal::new(ConformalForm::Paper)),
            0.3,
        )),
        Box::new(Regularized::with_pose_areas(Box::new(Isometric), 0.3)),
        Box::new(Regularized::new(
            Box::new(QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Segment)),
            0.3,
        )),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(43);
    let base = crate::synth::icosphere(0);
    for m in &metrics {
        let (pe, ends, x) = problem(m.as_ref(), &base, &mut rng);
        let layout = HessianLayout::new(&pe);
        assert!(
            exact_half_hessian(&layout, &pe, &ends, &x).is_none(),
            "{}: unexpected second-order part",
            m.name()
        );
    }
}
