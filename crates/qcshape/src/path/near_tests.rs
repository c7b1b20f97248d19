//! Geodesics started from a nearby geodesic ([`GeodesicSolver::solve_near`]), tests only.

use super::{GeodesicError, GeodesicOptions, GeodesicSolver, SolveContext};
use crate::metric::{MetricKind, MetricSpec};
use crate::synth::icosphere;

/// A bend of the unit sphere's vertices that grows with `s`.
fn bent(pos: &[[f64; 3]], s: f64) -> Vec<[f64; 3]> {
    pos.iter()
        .map(|v| {
            [
                v[0] * (1.0 + s * v[2]),
                v[1] + s * v[0] * v[0],
                v[2] * (1.0 + 0.5 * s),
            ]
        })
        .collect()
}

/// A sequence of pose pairs like those of two deformations: started from the previous pair's
/// geodesic, every solve reaches the fresh solve's length to solver tolerance, in fewer
/// iterations over the sequence; a geodesic started from itself stops at once; and a start path
/// of the wrong shape is an error, not a panic.
#[test]
fn started_from_the_previous_geodesic_the_lengths_agree_in_fewer_iterations() {
    let a = icosphere(2);
    for kind in [
        MetricKind::Conformal,
        MetricKind::QuasiConformal,
        MetricKind::Isometric,
    ] {
        let metric = MetricSpec::new(kind).build();
        let solver =
            GeodesicSolver::new(metric.as_ref(), a.topology.clone(), GeodesicOptions::default()).unwrap();
        let ends: Vec<_> = (1..=6)
            .map(|k| {
                let t = 0.08 * k as f64;
                (bent(&a.positions, t), bent(&a.positions, 1.6 * t))
            })
            .collect();
        let (mut cold, mut warm) = (SolveContext::default(), SolveContext::default());
        let (mut cold_iterations, mut warm_iterations) = (0, 0);
        let mut previous = None;
        for (x, y) in &ends {
            let c = solver.solve_in(&mut cold, x, y).unwrap();
            let w = solver.solve_near(&mut warm, x, y, previous.as_ref()).unwrap();
            assert!(c.converged && w.converged, "{kind:?}: {:?} {:?}", c.stop, w.stop);
            let rel = (c.length - w.length).abs() / c.length;
            assert!(rel < 1e-7, "{kind:?}: {} vs {} ({rel:e})", c.length, w.length);
            cold_iterations += c.iterations;
            warm_iterations += w.iterations;
            previous = Some(w);
        }
        assert!(
            warm_iterations < cold_iterations,
            "{kind:?}: {warm_iterations} iterations started near, {cold_iterations} from straight lines"
        );
        // A converged geodesic as its own start: already stationary.
        let g = previous.unwrap();
        let (x, y) = ends.last().unwrap();
        let again = solver
            .solve_near(&mut SolveContext::default(), x, y, Some(&g))
            .unwrap();
        assert!(again.iterations <= 2, "{kind:?}: {} iterations", again.iterations);
        assert!((again.length - g.length).abs() <= 1e-9 * g.length);
        // A start with the wrong number of poses.
        let mut short = g.clone();
        short.poses.pop();
        let err = solver
            .solve_near(&mut SolveContext::default(), x, y, Some(&short))
            .unwrap_err();
        assert!(matches!(err, GeodesicError::Option(_)), "{err}");
    }
}
