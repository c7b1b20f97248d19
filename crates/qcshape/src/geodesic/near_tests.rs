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
        let metric = MetricSpec::previous(kind).build(&crate::metric::Calibration::RAW);
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
        assert!(matches!(err, GeodesicError::StartPath { .. }), "{err}");
    }
}

/// Distance solves ([`GeodesicSolver::distance_near_with`]) stop once the length has settled:
/// on the same sequence of pose pairs their lengths agree with a 10,000x tighter solve to a
/// few times the length tolerance, in fewer iterations than the path solves, and with the
/// length test switched off they are the path solves, bit for bit.
#[test]
fn distance_solves_stop_when_the_length_settles() {
    use super::StopReason;
    let a = icosphere(2);
    for kind in [MetricKind::Conformal, MetricKind::Isometric, MetricKind::Rigid] {
        let metric = MetricSpec::previous(kind).build(&crate::metric::Calibration::RAW);
        let new = |options: GeodesicOptions| {
            GeodesicSolver::new(metric.as_ref(), a.topology.clone(), options).unwrap()
        };
        let solver = new(GeodesicOptions::default());
        let off = new(GeodesicOptions {
            length_tolerance: 0.0,
            ..GeodesicOptions::default()
        });
        let tight = new(GeodesicOptions {
            gradient_tolerance: 1e-10,
            energy_tolerance: 0.0,
            ..GeodesicOptions::default()
        });
        let ends: Vec<_> = (1..=5)
            .map(|k| {
                let t = 0.1 * k as f64;
                (bent(&a.positions, t), bent(&a.positions, 1.7 * t))
            })
            .collect();
        let (mut cp, mut cd, mut co) = (
            SolveContext::default(),
            SolveContext::default(),
            SolveContext::default(),
        );
        let (mut pp, mut pd, mut po) = (None, None, None);
        let (mut path_iterations, mut distance_iterations, mut settled) = (0, 0, 0);
        for (x, y) in &ends {
            let p = solver.solve_near_with(&mut cp, x, y, pp.as_ref(), None).unwrap();
            let d = solver
                .distance_near_with(&mut cd, x, y, pd.as_ref(), None)
                .unwrap();
            let o = off.distance_near_with(&mut co, x, y, po.as_ref(), None).unwrap();
            let t = tight.solve(x, y).unwrap();
            assert!(d.converged, "{kind:?}: {:?}", d.stop);
            assert_eq!(o.length.to_bits(), p.length.to_bits(), "{kind:?}: test off");
            assert_eq!(o.iterations, p.iterations);
            let rel = (d.length - t.length).abs() / t.length;
            assert!(
                rel <= 5.0 * super::defaults::LENGTH_TOLERANCE,
                "{kind:?}: distance {} path {} tight {} ({rel:e})",
                d.length,
                p.length,
                t.length
            );
            path_iterations += p.iterations;
            distance_iterations += d.iterations;
            settled += usize::from(d.stop == StopReason::LengthTolerance);
            pp = Some(p);
            pd = Some(d);
            po = Some(o);
        }
        assert!(settled > 0, "{kind:?}: the length test never stopped a solve");
        assert!(
            distance_iterations < path_iterations,
            "{kind:?}: {distance_iterations} iterations for distances, {path_iterations} for paths"
        );
    }
}
