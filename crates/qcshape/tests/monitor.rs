//! The solvers' once-per-iteration hook, `GeodesicOptions::monitor` (issue 60 items 2 and 3):
//! every solver calls it with the iteration number and the energy, and stops with
//! `GeodesicError::Interrupted` when it asks to.

use std::ops::ControlFlow;
use std::sync::{Arc, Mutex};

use qcshape::geodesic::{GeodesicError, GeodesicOptions, GeodesicSolver, Monitor, Solver};
use qcshape::mesh::Shape;
use qcshape::metric::{Isometric, Regularized};
use qcshape::synth::{icosphere, twist_along_z};

const SOLVERS: [Solver; 3] = [
    Solver::Preconditioned,
    Solver::HessianKronecker,
    Solver::PoseKronecker,
];

fn pair() -> (Shape, Shape) {
    let a = icosphere(2);
    let b = Shape::new(a.topology.clone(), twist_along_z(&a.positions, 1.2, 1.3)).unwrap();
    (a, b)
}

#[test]
fn every_solver_calls_the_monitor_each_iteration_and_stops_when_told() {
    let (a, b) = pair();
    let metric = Regularized::new(Box::new(Isometric), 0.1);
    for solver in SOLVERS {
        // Recorded: every call's iteration number and energy.
        let seen = Arc::new(Mutex::new(Vec::new()));
        let log = seen.clone();
        let options = GeodesicOptions {
            steps: 4,
            solver,
            monitor: Some(Monitor::new(move |it, e| {
                log.lock().unwrap().push((it, e));
                ControlFlow::Continue(())
            })),
            ..GeodesicOptions::default()
        };
        let s = GeodesicSolver::new(&metric, a.topology.clone(), options).unwrap();
        let g = s.solve(&a.positions, &b.positions).unwrap();
        let seen = seen.lock().unwrap().clone();
        assert!(g.iterations >= 2, "{solver:?}: {} iterations", g.iterations);
        // One call per iteration, numbered 1, 2, ...
        assert!(
            seen.len() == g.iterations,
            "{solver:?}: {} calls for {} iterations",
            seen.len(),
            g.iterations
        );
        assert!(
            seen.iter().enumerate().all(|(i, (it, _))| *it == i + 1),
            "{solver:?}: {seen:?}"
        );
        assert!(
            seen.iter().all(|(_, e)| e.is_finite() && *e >= 0.0),
            "{solver:?}: {seen:?}"
        );

        // Told to stop at iteration 2: an Interrupted error naming it, no result.
        let options = GeodesicOptions {
            steps: 4,
            solver,
            monitor: Some(Monitor::new(|it, _| {
                if it >= 2 {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            })),
            ..GeodesicOptions::default()
        };
        let s = GeodesicSolver::new(&metric, a.topology.clone(), options).unwrap();
        match s.solve(&a.positions, &b.positions) {
            Err(GeodesicError::Interrupted { iteration }) => assert_eq!(iteration, 2, "{solver:?}"),
            other => panic!(
                "{solver:?}: expected Interrupted, got {:?}",
                other.map(|g| g.iterations)
            ),
        }
    }
}

#[test]
fn a_monitor_that_never_stops_changes_nothing() {
    let (a, b) = pair();
    let metric = Regularized::new(Box::new(Isometric), 0.1);
    let plain = GeodesicSolver::new(&metric, a.topology.clone(), GeodesicOptions::default())
        .unwrap()
        .solve(&a.positions, &b.positions)
        .unwrap();
    let options = GeodesicOptions {
        monitor: Some(Monitor::new(|_, _| ControlFlow::Continue(()))),
        ..GeodesicOptions::default()
    };
    let watched = GeodesicSolver::new(&metric, a.topology.clone(), options)
        .unwrap()
        .solve(&a.positions, &b.positions)
        .unwrap();
    assert_eq!(plain.length.to_bits(), watched.length.to_bits());
    assert_eq!(plain.iterations, watched.iterations);
}
