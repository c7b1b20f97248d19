//! L-BFGS (the paper's quasi-Newton method) through argmin, on the exact gradient.

use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{CostFunction, Executor, Gradient, State, TerminationReason, TerminationStatus, KV};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;

use crate::geodesic::energy::{Ends, PathEnergy};
use crate::geodesic::{GeodesicError, GeodesicOptions, SolveOutput, StopReason};

struct Problem<'a, 'm> {
    pe: &'a PathEnergy<'m>,
    ends: &'a Ends,
}

impl CostFunction for Problem<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        Ok(self.pe.energy(x, self.ends))
    }
}

impl Gradient for Problem<'_, '_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, x: &Vec<f64>) -> Result<Vec<f64>, argmin::core::Error> {
        let mut g = vec![0.0; x.len()];
        self.pe.energy_gradient(x, self.ends, &mut g);
        Ok(g)
    }
}

/// [`GeodesicOptions::monitor`] as an argmin observer.
struct Monitored(GeodesicOptions);

impl<I: State<Float = f64>> Observe<I> for Monitored {
    fn observe_iter(&mut self, state: &I, _kv: &KV) -> Result<(), argmin::core::Error> {
        // argmin counts from 0 here; the solvers number iterations from 1.
        Ok(self.0.monitor(state.get_iter() as usize + 1, state.get_cost())?)
    }
}

/// Minimizes the path energy with L-BFGS (`opts.lbfgs_memory` pairs, More-Thuente line
/// search). Converged when the gradient norm is below `gradient_tolerance` times its initial
/// value, or the relative energy change falls below `energy_tolerance`.
pub(crate) fn minimize(
    pe: &PathEnergy,
    ends: &Ends,
    x0: Vec<f64>,
    opts: &GeodesicOptions,
) -> Result<SolveOutput, GeodesicError> {
    let problem = Problem { pe, ends };
    let mut g = vec![0.0; x0.len()];
    let e0 = pe.energy_gradient(&x0, ends, &mut g);
    let g0 = crate::geodesic::norm(&g);
    if crate::geodesic::at_roundoff(g0, e0) {
        return Ok(SolveOutput {
            x: x0,
            iterations: 0,
            stop: StopReason::GradientTolerance,
            last: None,
        });
    }
    let err = |e: argmin::core::Error| GeodesicError::Optimizer { source: e.into() };
    let solver = LBFGS::new(MoreThuenteLineSearch::new(), opts.lbfgs_memory.max(1))
        .with_tolerance_grad(opts.gradient_tolerance * g0)
        .map_err(err)?
        .with_tolerance_cost(opts.energy_tolerance)
        .map_err(err)?;
    let max_iters =
        opts.max_iterations
            .unwrap_or_else(|| crate::geodesic::Solver::Lbfgs.default_max_iterations()) as u64;
    let target = opts.target_energy;
    // The monitor runs after each of argmin's iterations; its stop travels as argmin's error.
    let err = |e: argmin::core::Error| match e.downcast::<GeodesicError>() {
        Ok(stopped) => stopped,
        Err(e) => err(e),
    };
    let monitored = Executor::new(problem, solver);
    let monitored = if opts.monitor.is_some() {
        monitored.add_observer(Monitored(opts.clone()), ObserverMode::Always)
    } else {
        monitored
    };
    let res = monitored
        .configure(|state| {
            let s = state.param(x0).max_iters(max_iters);
            match target {
                Some(t) => s.target_cost(t),
                None => s,
            }
        })
        .run()
        .map_err(err)?;
    let state = res.state();
    let iterations = state.get_iter() as usize;
    let stop = match state.get_termination_status() {
        TerminationStatus::Terminated(TerminationReason::SolverConverged) => {
            let mut g = vec![0.0; pe.n_vars()];
            let x = state.get_best_param().expect("argmin keeps the best parameter");
            pe.energy_gradient(x, ends, &mut g);
            if crate::geodesic::norm(&g) <= opts.gradient_tolerance * g0 {
                StopReason::GradientTolerance
            } else {
                StopReason::EnergyTolerance
            }
        }
        TerminationStatus::Terminated(TerminationReason::TargetCostReached) => StopReason::TargetEnergy,
        TerminationStatus::Terminated(TerminationReason::MaxItersReached) => StopReason::MaxIterations,
        // The line search found no lower energy along the direction (at rounding, or a direction
        // that is not one of descent there): no step could lower the energy.
        TerminationStatus::Terminated(TerminationReason::SolverExit(msg)) if msg.contains("Line search") => {
            StopReason::NoProgress
        }
        other => StopReason::Other(format!("{other:?}")),
    };
    let x = state
        .get_best_param()
        .cloned()
        .ok_or_else(|| GeodesicError::Optimizer {
            source: "argmin returned no parameter".into(),
        })?;
    Ok(SolveOutput {
        x,
        iterations,
        stop,
        last: None,
    })
}
