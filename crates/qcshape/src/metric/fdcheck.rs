//! Finite-difference check of a metric's Jacobian (tests only): random meshes (closed and open)
//! and perturbations, central differences, relative and absolute tolerance.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{At, Jacobian, Metric, Segment};
use crate::mesh::Shape;

fn jitter(rng: &mut ChaCha8Rng, pos: &[[f64; 3]], amp: f64) -> Vec<[f64; 3]> {
    pos.iter()
        .map(|p| p.map(|c| c + amp * (rng.random::<f64>() - 0.5)))
        .collect()
}

/// Directional derivative check on an icosphere and an open curved grid, both ends `At`.
pub(crate) fn check_metric(metric: &dyn Metric, seed: u64) {
    let sphere = crate::synth::icosphere(1);
    let mut grid = crate::synth::grid(5);
    for p in &mut grid.positions {
        p[2] = 0.3 * (p[0] - 0.5) * (p[1] + 0.2);
    }
    for (mi, base) in [sphere, grid].iter().enumerate() {
        for at in [At::Start, At::End] {
            check_on(metric, base, at, seed.wrapping_mul(31).wrapping_add(mi as u64));
        }
        check_values(metric, base, seed.wrapping_mul(37).wrapping_add(mi as u64));
    }
}

/// The value-only paths against the residuals: [`Metric::segment_squared_norms`] equals
/// `|r|^2` of each term (to rounding: the fused passes sum in another order), and the frozen
/// weights from [`Metric::pose_summary`] values are bit for bit [`Metric::frozen_weights`].
fn check_values(metric: &dyn Metric, base: &Shape, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let topo = &base.topology;
    let a = jitter(&mut rng, &base.positions, 0.1);
    let b: Vec<[f64; 3]> = jitter(&mut rng, &a, 0.3);
    let pat = metric.pattern(topo);
    let frozen = metric.frozen_weights(topo, &a, &b);
    if let (Some(sa), Some(sb)) = (metric.pose_summary(topo, &a), metric.pose_summary(topo, &b)) {
        assert_eq!(
            metric.frozen_weights_from(topo, &a, &b, [&sa, &sb]),
            frozen,
            "{}: frozen weights from the pose summaries",
            metric.name()
        );
    }
    let aux = vec![0.0; metric.n_aux()];
    let seg = |at| Segment {
        a: &a,
        b: &b,
        at,
        aux: &aux,
        frozen: frozen.as_deref(),
    };
    let (s0, s1) = (seg(At::Start), seg(At::End));
    let fused = metric.segment_squared_norms(topo, pat.as_ref(), [&s0, &s1]);
    for (g, s) in fused.into_iter().zip([&s0, &s1]) {
        let slow = super::squared_norm_from_residuals(metric, topo, pat.as_ref(), s);
        assert!(slow > 0.0, "{}: a zero norm checks nothing", metric.name());
        assert!(
            (g - slow).abs() <= 1e-12 * slow,
            "{} ({:?}): segment_squared_norms {g:e} vs residuals {slow:e}",
            metric.name(),
            s.at
        );
    }
}

fn check_on(metric: &dyn Metric, base: &Shape, at: At, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let topo = &base.topology;
    let a = jitter(&mut rng, &base.positions, 0.1);
    let b: Vec<[f64; 3]> = jitter(&mut rng, &a, 0.3);
    let pat = metric.pattern(topo);
    assert_eq!(
        pat.n_residuals(),
        metric.n_residuals(topo),
        "{}: n_residuals",
        metric.name()
    );
    let n_aux = metric.n_aux();
    let aux: Vec<f64> = (0..n_aux).map(|_| rng.random::<f64>() - 0.5).collect();
    let frozen = metric.frozen_weights(topo, &a, &b);
    let eval = |a: &[[f64; 3]], b: &[[f64; 3]], aux: &[f64]| {
        let seg = Segment {
            a,
            b,
            at,
            aux,
            frozen: frozen.as_deref(),
        };
        let mut r = vec![0.0; pat.n_residuals()];
        metric.residuals(topo, pat.as_ref(), &seg, &mut r, None);
        r
    };
    let seg = Segment {
        a: &a,
        b: &b,
        at,
        aux: &aux,
        frozen: frozen.as_deref(),
    };
    let mut r0 = vec![0.0; pat.n_residuals()];
    let mut jac = Jacobian::zeros(&pat, n_aux);
    // Poison the storage: implementations must write every value.
    jac.da.fill([f64::NAN; 3]);
    jac.db.fill([f64::NAN; 3]);
    jac.daux.fill(f64::NAN);
    metric.residuals(topo, pat.as_ref(), &seg, &mut r0, Some(jac.as_mut()));
    assert_eq!(
        r0,
        eval(&a, &b, &aux),
        "{}: residuals differ with and without Jacobian",
        metric.name()
    );
    let scale = r0.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    for trial in 0..3 {
        let da: Vec<[f64; 3]> = jitter(&mut rng, &vec![[0.0; 3]; a.len()], 2.0);
        let db: Vec<[f64; 3]> = jitter(&mut rng, &vec![[0.0; 3]; a.len()], 2.0);
        let dx: Vec<f64> = (0..n_aux).map(|_| rng.random::<f64>() - 0.5).collect();
        let h = 1e-6;
        let shift = |s: f64| {
            let a2: Vec<[f64; 3]> = a
                .iter()
                .zip(&da)
                .map(|(p, d)| [0, 1, 2].map(|c| p[c] + s * d[c]))
                .collect();
            let b2: Vec<[f64; 3]> = b
                .iter()
                .zip(&db)
                .map(|(p, d)| [0, 1, 2].map(|c| p[c] + s * d[c]))
                .collect();
            let x2: Vec<f64> = aux.iter().zip(&dx).map(|(p, d)| p + s * d).collect();
            eval(&a2, &b2, &x2)
        };
        let (rp, rm) = (shift(h), shift(-h));
        for i in 0..pat.n_residuals() {
            let mut an = 0.0;
            for k in pat.row(i) {
                let v = pat.vertices[k] as usize;
                for c in 0..3 {
                    an += jac.da[k][c] * da[v][c] + jac.db[k][c] * db[v][c];
                }
            }
            for (m, d) in dx.iter().enumerate() {
                an += jac.daux[i * n_aux + m] * d;
            }
            let fd = (rp[i] - rm[i]) / (2.0 * h);
            let tol = 1e-6 * scale + 1e-5 * fd.abs().max(an.abs());
            assert!(
                (fd - an).abs() <= tol,
                "{} ({:?}, trial {trial}): residual {i}: analytic {an:e} vs central difference {fd:e}",
                metric.name(),
                at
            );
        }
    }
}
