//! Tests of the geodesic solver ([`super::GeodesicSolver`], [`super::geodesic`]).

use super::*;
use crate::metric::{Isometric, Regularized, L2};
use crate::synth::icosphere;

fn bent(s: &Shape) -> Shape {
    let pos = s
        .positions
        .iter()
        .map(|p| [p[0] + 0.3 * p[2] * p[2], p[1] * (1.0 + 0.3 * p[0]), 1.4 * p[2]])
        .collect();
    Shape::new(s.topology.clone(), pos).unwrap()
}

#[test]
fn straight_lengths_of_one_segment_and_of_n_segments_agree_with_the_definition() {
    let a = icosphere(2);
    let b = bent(&a);
    let qc = crate::metric::MetricSpec::previous(crate::metric::MetricKind::QuasiConformal)
        .build(&crate::metric::Calibration::RAW);
    let iso = Regularized::new(Box::new(Isometric), 0.5);
    let metrics: [&dyn Metric; 3] = [qc.as_ref(), &iso, &crate::metric::FrozenL2];
    for m in metrics {
        let solver = |steps| {
            let options = GeodesicOptions {
                steps,
                ..GeodesicOptions::default()
            };
            GeodesicSolver::new(m, a.topology.clone(), options).unwrap()
        };
        // One segment (the copy-free branch) against the definition through the residuals.
        let one = solver(1).straight_length(&a.positions, &b.positions).unwrap();
        let frozen = m.frozen_weights(&a.topology, &a.positions, &b.positions);
        let pat = m.pattern(&a.topology);
        let g: f64 = [At::Start, At::End]
            .map(|at| {
                let seg = Segment {
                    a: &a.positions,
                    b: &b.positions,
                    at,
                    aux: &[],
                    frozen: frozen.as_deref(),
                };
                crate::metric::squared_norm_from_residuals(m, &a.topology, pat.as_ref(), &seg)
            })
            .iter()
            .sum();
        let want = (g / 2.0).sqrt();
        assert!(
            want > 0.0 && (one - want).abs() <= 1e-12 * want,
            "{}: {one} vs {want}",
            m.name()
        );
        // Four segments (through the path): an upper bound of the geodesic, and for the
        // frozen L2 metric (flat) the straight line is the geodesic, whatever N.
        let four = solver(4);
        let len4 = four.straight_length(&a.positions, &b.positions).unwrap();
        let geo = four.solve(&a.positions, &b.positions).unwrap().length;
        assert!(
            geo <= len4 * (1.0 + 1e-9),
            "{}: geodesic {geo} > straight {len4}",
            m.name()
        );
        if m.name() == "l2(frozen)" {
            assert!((len4 - one).abs() <= 1e-12 * one, "flat: {len4} vs {one}");
        }
    }
}

#[test]
fn gradient_of_path_energy_matches_finite_differences() {
    let a = icosphere(1);
    let b = bent(&a);
    let m = Regularized::new(Box::new(Isometric), 0.5);
    let pe = PathEnergy::new(&m, a.topology.clone(), 3);
    let frozen = m.frozen_weights(&a.topology, &a.positions, &b.positions);
    let ends = Ends {
        start: a.positions.clone(),
        end: b.positions.clone(),
        frozen,
    };
    let mut x = pe.linear_start(&ends);
    for (i, v) in x.iter_mut().enumerate() {
        *v += 0.01 * ((i * 7919 % 13) as f64 - 6.0);
    }
    let mut g = vec![0.0; x.len()];
    pe.energy_gradient(&x, &ends, &mut g);
    let h = 1e-6;
    for i in (0..x.len()).step_by(37) {
        let mut xp = x.clone();
        xp[i] += h;
        let mut xm = x.clone();
        xm[i] -= h;
        let fd = (pe.energy(&xp, &ends) - pe.energy(&xm, &ends)) / (2.0 * h);
        assert!(
            (fd - g[i]).abs() <= 1e-6 * (1.0 + g[i].abs()),
            "{i}: {fd} vs {}",
            g[i]
        );
    }
}

/// The default solver reports its own last evaluation (no second pass): energy, initial
/// energy and segment lengths agree with evaluating the returned path afresh.
#[test]
fn reported_energy_and_lengths_match_a_fresh_evaluation() {
    let a = icosphere(1);
    let b = bent(&a);
    let m = Regularized::new(Box::new(Isometric), 0.1);
    let solver = GeodesicSolver::new(&m, a.topology.clone(), GeodesicOptions::default()).unwrap();
    let g = solver.solve(&a.positions, &b.positions).unwrap();
    assert!(g.iterations > 0);
    let ends = solver.ends(&a.positions, &b.positions).unwrap();
    let pe = solver.path_energy();
    let x = pe.pack(&g.poses[1..g.poses.len() - 1], &ends);
    let mut grad = vec![0.0; pe.n_vars()];
    let e = pe.energy_gradient(&x, &ends, &mut grad);
    assert!((g.energy - e).abs() <= 1e-12 * e, "{} vs {e}", g.energy);
    let e0 = pe.energy(&pe.linear_start(&ends), &ends);
    assert!((g.initial_energy - e0).abs() <= 1e-12 * e0);
    // The reported norm is the gauge's (the rigid gauge, the default): the gradient projected
    // onto the subspace the solver minimizes on.
    super::gauge::RigidGauge::new(&ends, pe.steps()).project(&mut grad);
    let gn = grad.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(
        (g.gradient_norm - gn).abs() <= 1e-9 * (1.0 + gn),
        "{} vs {gn}",
        g.gradient_norm
    );
    for (l, (g0, g1)) in g.segment_lengths.iter().zip(pe.segment_norms(&x, &ends)) {
        let want = ((g0 + g1) / 2.0).sqrt();
        assert!((l - want).abs() <= 1e-12 * want, "{l} vs {want}");
    }
}

/// Solves through one [`SolveContext`] (one preconditioner fit for several geodesics)
/// reach the same distances as fresh solves to solver tolerance, and repeat bit for bit.
#[test]
fn shared_preconditioner_gives_the_same_distances() {
    let a = icosphere(2);
    let m = Regularized::new(Box::new(Isometric), 0.1);
    let solver = GeodesicSolver::new(&m, a.topology.clone(), GeodesicOptions::default()).unwrap();
    // A sequence of growing deformations of one shape, like the poses of a pair.
    let ends: Vec<(crate::similarity::Pose, crate::similarity::Pose)> = (1..=5)
        .map(|k| {
            let t = 0.1 * k as f64;
            let p = |s: f64| -> Vec<[f64; 3]> {
                a.positions
                    .iter()
                    .map(|v| {
                        [
                            v[0] * (1.0 + s * v[2]),
                            v[1] + s * v[0] * v[0],
                            v[2] * (1.0 + 0.5 * s),
                        ]
                    })
                    .collect()
            };
            (p(t), p(1.5 * t))
        })
        .collect();
    let shared = |()| {
        let mut ctx = SolveContext::default();
        ends.iter()
            .map(|(x, y)| solver.solve_in(&mut ctx, x, y).unwrap())
            .collect::<Vec<_>>()
    };
    let (first, again) = (shared(()), shared(()));
    let mut ctx = SolveContext::default();
    for (x, y) in &ends {
        solver.solve_in(&mut ctx, x, y).unwrap();
    }
    assert!((1..ends.len()).contains(&ctx.fits()), "{} fits", ctx.fits());
    for ((s, r), (x, y)) in first.iter().zip(&again).zip(&ends) {
        assert_eq!(s.length.to_bits(), r.length.to_bits());
        assert!(s.converged, "{:?}", s.stop);
        let fresh = solver.solve(x, y).unwrap();
        let rel = (s.length - fresh.length).abs() / fresh.length;
        assert!(rel < 1e-6, "{} vs {} ({rel:e})", s.length, fresh.length);
    }
}

/// The default Kronecker model and the pose-wise one precondition the same iteration: both
/// reach the same minimum.
#[test]
fn the_solvers_models_agree_on_small_problems() {
    let a = icosphere(1);
    let b = bent(&a);
    for m in [&L2 as &dyn Metric, &Regularized::new(Box::new(Isometric), 0.1)] {
        let o = |solver| GeodesicOptions {
            steps: 4,
            solver,
            gradient_tolerance: 1e-9,
            ..Default::default()
        };
        let kr = geodesic(
            m,
            &a,
            &b,
            &o(Solver::Preconditioned),
            Normalization::MeanEdgeOfFirst,
        )
        .unwrap();
        let pw = geodesic(
            m,
            &a,
            &b,
            &o(Solver::PoseKronecker),
            Normalization::MeanEdgeOfFirst,
        )
        .unwrap();
        assert!(kr.converged, "{:?}", kr.stop);
        assert!(kr.energy <= kr.initial_energy);
        let rel = (kr.energy - pw.energy).abs() / kr.energy;
        assert!(
            rel < 1e-6,
            "{}: {} vs {} ({:?}, {} its)",
            m.name(),
            kr.energy,
            pw.energy,
            pw.stop,
            pw.iterations
        );
        assert_eq!(kr.poses[0], a.positions);
        assert_eq!(kr.poses[4], b.positions);
    }
}

/// For every metric (calibrated on the scaled reference, with its default and with a large
/// regularizer): a geodesic's energy split sums to its energy, the straight path's split to
/// the linear path's energy, and the one-pass split of a segment
/// ([`Metric::segment_norms_and_parts`]) is bit for bit the two separate calls.
#[test]
fn energy_parts_sum_to_the_energy_for_every_metric() {
    use crate::metric::{MetricKind, MetricSpec};
    let a = icosphere(2);
    let f = 1.0 / geometry::mean_edge_length(&a.topology, &a.positions);
    let scaled = |p: &[[f64; 3]]| -> Vec<[f64; 3]> { p.iter().map(|v| v.map(|c| c * f)).collect() };
    let (pa, pb) = (scaled(&a.positions), scaled(&bent(&a).positions));
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(f64::MIN_POSITIVE);
    for kind in MetricKind::all() {
        let spec_default_lambda = MetricSpec::new(kind).lambda;
        let mut share_at_default = f64::NAN;
        for (lambda, frozen_areas) in [(None, true), (Some(2.0), true), (Some(0.5), false)] {
            let mut spec = MetricSpec::new(kind);
            if let Some(l) = lambda {
                spec.lambda = l;
            }
            spec.frozen_areas = frozen_areas;
            let cal = spec.calibrate(&a.topology, &[&pa]).unwrap();
            let m = spec.build(&cal);
            let what = format!("{} (lambda {})", spec.label(), spec.lambda);
            let options = GeodesicOptions {
                steps: 3,
                ..Default::default()
            };
            let solver = GeodesicSolver::new(m.as_ref(), a.topology.clone(), options).unwrap();
            let g = solver.solve(&pa, &pb).unwrap();
            let sum = g.geometric_energy + g.regularizer_energy;
            assert!(close(sum, g.energy), "{what}: {sum} vs {}", g.energy);
            assert!(g.geometric_energy > 0.0, "{what}");
            assert_eq!(g.regularizer_energy > 0.0, kind.takes("lambda"), "{what}");
            // The share is the regularizer's part of the energy (README: above one half, the
            // metric measures L2); at the default lambda the metric's own term carries the path
            // (measured: at most 1.1 %, rigid), and a larger lambda raises the share.
            let share = g.regularizer_share();
            assert!(close(share, g.regularizer_energy / g.energy), "{what}: {share}");
            if kind.takes("lambda") {
                match lambda {
                    None => {
                        assert!(share < 0.05, "{what}: {share}");
                        share_at_default = share;
                    }
                    Some(l) if l > spec_default_lambda => {
                        assert!(share > share_at_default, "{what}: {share}")
                    }
                    _ => {}
                }
            }

            // The straight path: its split is the linear path's, and sums to its energy.
            let ends = solver.ends(&pa, &pb).unwrap();
            let pe = solver.path_energy();
            let x0 = pe.linear_start(&ends);
            let line = solver.straight_path_with(&pa, &pb, None).unwrap();
            assert_eq!(
                [line.geometric_energy, line.regularizer_energy],
                pe.energy_parts(&x0, &ends),
                "{what}"
            );
            let e0 = pe.energy(&x0, &ends);
            let sum = line.geometric_energy + line.regularizer_energy;
            assert!(close(sum, e0), "{what}: straight {sum} vs {e0}");
            assert_eq!(
                line.length.to_bits(),
                solver.straight_length(&pa, &pb).unwrap().to_bits()
            );
            let one = GeodesicSolver::new(
                m.as_ref(),
                a.topology.clone(),
                GeodesicOptions {
                    steps: 1,
                    ..Default::default()
                },
            )
            .unwrap()
            .straight_path_with(&pa, &pb, None)
            .unwrap();
            let e1 = one.geometric_energy + one.regularizer_energy;
            assert!(
                close(e1, 2.0 * one.length * one.length),
                "{what}: one segment {e1}"
            );

            // One pass, the same bits as the two calls, on every segment of the linear path.
            for s in 0..pe.steps() {
                let (s0, s1) = (
                    pe.segment(&x0, &ends, s, At::Start),
                    pe.segment(&x0, &ends, s, At::End),
                );
                let p = pe.pattern.as_ref();
                let both = m.segment_norms_and_parts(&a.topology, p, [&s0, &s1]);
                let norms = m.segment_squared_norms(&a.topology, p, [&s0, &s1]);
                let parts = m.segment_energy_parts(&a.topology, p, [&s0, &s1]);
                assert_eq!(both.0.map(f64::to_bits), norms.map(f64::to_bits), "{what}");
                assert_eq!(both.1.map(f64::to_bits), parts.map(f64::to_bits), "{what}");
            }
        }
    }
}

/// Issue 40: a step count or an insertion count above [`crate::limits`] is an option error
/// before anything is allocated (`--insert 18446744073709551615` once wrapped to 1).
#[test]
fn steps_and_insert_above_their_limits_are_option_errors() {
    let a = icosphere(0);
    let spec = crate::metric::MetricSpec::new(crate::metric::MetricKind::L2);
    let m = spec.build(&crate::metric::Calibration::RAW);
    for steps in [crate::limits::MAX_STEPS + 1, usize::MAX] {
        let opts = GeodesicOptions {
            steps,
            ..Default::default()
        };
        let e = GeodesicSolver::new(m.as_ref(), a.topology.clone(), opts)
            .err()
            .unwrap();
        assert!(e.to_string().contains("steps must be at most"), "{e}");
    }
    for insert in [crate::limits::MAX_INSERT + 1, usize::MAX] {
        let opts = InterpolationOptions {
            insert,
            ..Default::default()
        };
        let e = Interpolator::new(m.as_ref(), &a.topology, &a.positions, opts)
            .err()
            .unwrap();
        assert!(e.to_string().contains("insert must be at most"), "{e}");
    }
}
