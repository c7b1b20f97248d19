//! The geodesic solvers' options ([`GeodesicOptions`], [`Solver`]) and why a solve stopped
//! ([`StopReason`]).

#[cfg(doc)]
use super::GeodesicSolver;
#[cfg(doc)]
use crate::metric::Metric;

/// Which optimizer minimizes the path energy: the preconditioned L-BFGS iteration with one of
/// three models of the Hessian. The research solvers (truncated Gauss-Newton and Newton,
/// Levenberg-Marquardt, argmin's L-BFGS, L-BFGS without preconditioner) were retired on
/// 2026-12-07: slower than the default in every measured case (docs/log/solvers.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Solver {
    /// L-BFGS preconditioned by the Kronecker model `2 T_c (x) A` of the Gauss-Newton Hessian
    /// (one sparse Cholesky of size 3 #V per refit, every
    /// [`GeodesicOptions::preconditioner_refresh`] iterations) plus a vertex-block term
    /// ([`GeodesicOptions::vertex_block_weight`]), scaled by the newest curvature pair. The
    /// default: the fastest in the benchmark (docs/log/solvers.md).
    #[default]
    Preconditioned,
    /// [`Solver::Preconditioned`] with the pose-wise Kronecker model: each interior pose keeps
    /// its own spatial block of `J^T J` (one sparse Cholesky of size 3 #V per pose and refit)
    /// and the poses are coupled by the normalized second difference. Fewer iterations where
    /// the metric's cheap directions change along the path: on eq. 7's calibrated scale at
    /// lambda 1e-5 it converges where the default stops without progress (quasi-conformal,
    /// 162 vertices: 170 iterations to an energy 15 % below the default's stop), and without
    /// the rigid gauge on noisy poses (642 vertices: 0.44-0.82x the default's instructions;
    /// docs/log/solvers.md). Otherwise slower (1.03-1.5x the default's instructions on the
    /// twisted sphere with the gauge). Command-line value `pose-kronecker`.
    PoseKronecker,
    /// [`Solver::Preconditioned`] with the Kronecker model fitted to the exact Hessian (`J^T J`
    /// plus the metric's second-order part, where the model is positive definite; `J^T J`
    /// elsewhere and for metrics without second derivatives) and refitted every 15 iterations.
    /// The Gauss-Newton matrix leaves out a stress-like part of the Hessian that grows with the
    /// resolution, so without the bending term (`bending = 0`) the default's iterations grow
    /// with every subdivision of the mesh and this model's less (isometric, 2,562 vertices: 384
    /// against 578; 10,242: 1,340 against 3,772; docs/log/solvers.md,
    /// docs/log/scale-invariant.md). The bending term has no second-order part, so with it (the
    /// default metric) this is the default's model refitted more often (4-10 % more
    /// instructions). Command-line value `hessian-kronecker`.
    HessianKronecker,
}

/// Every solver's command-line name, in the order of the `--solver` help.
const SOLVER_NAMES: &str = "preconditioned, hessian-kronecker or pose-kronecker";

impl std::str::FromStr for Solver {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "preconditioned" | "plbfgs" => Ok(Solver::Preconditioned),
            "pose-kronecker" => Ok(Solver::PoseKronecker),
            "hessian-kronecker" => Ok(Solver::HessianKronecker),
            "gauss-newton"
            | "gn"
            | "newton"
            | "gauss-newton-direct"
            | "gn-direct"
            | "lm"
            | "levenberg-marquardt"
            | "lbfgs"
            | "l-bfgs"
            | "plain-lbfgs" => Err(format!(
                "solver '{s}' was retired (slower than the default in every measured case, \
                 docs/log/solvers.md); expected {SOLVER_NAMES}"
            )),
            _ => Err(format!("unknown solver '{s}' (expected {SOLVER_NAMES})")),
        }
    }
}

impl Solver {
    /// The command-line name (`preconditioned`, `hessian-kronecker`, `pose-kronecker`);
    /// [`str::parse`] reads it back.
    pub fn label(self) -> &'static str {
        match self {
            Solver::Preconditioned => "preconditioned",
            Solver::PoseKronecker => "pose-kronecker",
            Solver::HessianKronecker => "hessian-kronecker",
        }
    }

    /// What to try when a solve stopped at its iteration limit, for a metric with the bending
    /// term (`bending`) or without. Without it the iterations grow with the resolution
    /// (twisted sphere, invariant scale, quasi-conformal: 271, 690 and 1,516 iterations at 642,
    /// 2,562 and 10,242 vertices; conformal 4,058 at 10,242; docs/log/scale-invariant.md), so a
    /// higher limit or a coarser mesh helps, and for the isometric metric the hessian-kronecker
    /// solver. With it the slowest measured solves are captured meshes whose thin faces fold
    /// between the ends (horse gallop: more than 5,510 iterations with every solver, 904 with
    /// `bending = 0`; docs/log/bending.md "Folding faces on captured meshes"), and the
    /// hessian-kronecker solver is the default's model refitted more often: it does not help.
    pub fn stall_hint(self, bending: bool) -> &'static str {
        if bending {
            "the path was still moving; a higher limit or a coarser mesh lets it converge, unless \
             thin faces fold between the ends, as in captured meshes, where leaving the bending \
             term out does"
        } else {
            "the path was still moving; the default limit, 60 sqrt(#V), covers the slowest \
             measured (conformal, 10,242 vertices: 4,058 iterations), so a higher limit or a \
             coarser mesh lets it converge; for the isometric metric on fine meshes the \
             hessian-kronecker solver needs fewer (1,340 against 3,772 at 10,242 vertices)"
        }
    }

    /// The iteration limit when [`GeodesicOptions::max_iterations`] is `None`, on the coarsest
    /// meshes: 1,000. The limit grows with the mesh: [`Solver::iteration_limit_for`].
    pub fn default_max_iterations(self) -> usize {
        1000
    }

    /// The default iteration limit on a mesh of `n_vertices` (#V): the larger of
    /// [`Solver::default_max_iterations`] and `ITERATIONS_PER_SQRT_VERTEX` (60) `x sqrt(#V)`
    /// (6,073 at 10,242 vertices), since the iterations grow about like `sqrt(#V)` (the twisted
    /// sphere's conformal geodesic without the bending term: 4,058 iterations at 10,242
    /// vertices, about twice per subdivision; docs/log/scale-invariant.md).
    pub fn iteration_limit_for(self, n_vertices: usize) -> usize {
        let grown = (ITERATIONS_PER_SQRT_VERTEX * (n_vertices as f64).sqrt()).ceil() as usize;
        self.default_max_iterations().max(grown)
    }
}

/// Where the interior poses' rigid placement comes from (docs/method.md "Rigid gauge").
///
/// The path energy charges a rigid motion of an interior pose only through the L2 regularizer
/// and second-order parts of the membrane terms (the bending term not at all), so it barely
/// decides how the middle poses are placed: on the paper's Fig. 4 deformations (162 vertices)
/// the solver left them turned by 3-16 degrees against the truth, and on the real left
/// ventricle by 1.3 degrees, enough to double the interpolation error (docs/log/bending.md
/// "Rigid gauge").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Gauge {
    /// Every interior pose `P_i` keeps the rigid placement of the linear interpolation
    /// `L_i = (1 - i/N) P_0 + (i/N) P_N` to first order: the translation and infinitesimal
    /// rotation that best map `P_i - L_i` to zero vanish (`sum_v (P_i - L_i)_v = 0`,
    /// `sum_v (L_i - c_i) x (P_i - L_i)_v = 0`). Linear constraints fixed by the ends: every
    /// start path ends at the same geodesic. Every solver applies it. The default.
    #[default]
    Linear,
    /// No constraint: the interior poses' rigid placement is whatever the solver reaches (the
    /// releases before 2026-12-07).
    Free,
}

impl Gauge {
    /// The command-line value.
    pub fn label(self) -> &'static str {
        match self {
            Gauge::Linear => "linear",
            Gauge::Free => "free",
        }
    }
}

impl std::str::FromStr for Gauge {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "linear" => Ok(Gauge::Linear),
            "free" => Ok(Gauge::Free),
            _ => Err(format!("unknown gauge '{s}' (expected linear or free)")),
        }
    }
}

/// Iterations per `sqrt(#V)` of the solvers' default limit
/// ([`Solver::iteration_limit_for`]): 1.5 x the most measured (the conformal geodesic of the
/// twisted sphere at 10,242 vertices: 4,058 iterations, 40 per `sqrt(#V)`).
pub const ITERATIONS_PER_SQRT_VERTEX: f64 = 60.0;

/// Options of the geodesic solvers.
#[derive(Debug, Clone)]
pub struct GeodesicOptions {
    /// Number of path segments `N` (N - 1 free interior poses). Default 8.
    pub steps: usize,
    /// The optimizer. Default [`Solver::Preconditioned`].
    pub solver: Solver,
    /// How the interior poses' rigid placement is fixed. Default [`Gauge::Linear`].
    pub gauge: Gauge,
    /// Iteration limit of the solver; `None` (the default): the limit on the mesh,
    /// [`Solver::iteration_limit_for`] (1,000, or 60 `sqrt(#V)` on meshes above 278 vertices).
    /// A `Some` value is the limit itself.
    pub max_iterations: Option<usize>,
    /// Converged when the gradient norm falls below this fraction of its value at the start.
    /// Default 1e-6.
    pub gradient_tolerance: f64,
    /// Converged when an accepted step lowers the energy by less than this fraction.
    /// Default 1e-12.
    pub energy_tolerance: f64,
    /// Distance solves only ([`GeodesicSolver::distance_near_with`]: similarity matrices, the
    /// intrinsic k-means assignment): also converged when two consecutive accepted steps each
    /// change the path's length `L` (eq. 12) by less than this fraction of it. On coarse
    /// meshes the length settles long before the path (a step that only evens out the speed
    /// along the path lowers the energy but not `L`): at 162 vertices distances move by at
    /// most 5e-8 relative; at 2,562 and 10,242 by up to 3e-7 and 5e-7 (docs/log/speed.md, round
    /// 4). Only the default solver ([`Solver::Preconditioned`]) applies it; 0 disables it.
    /// Default [`super::defaults::LENGTH_TOLERANCE`].
    pub length_tolerance: f64,
    /// Stop as soon as the energy is at or below this value (used to time solvers to a
    /// common energy).
    pub target_energy: Option<f64>,
    /// Number of correction pairs kept by L-BFGS. Default 10.
    pub lbfgs_memory: usize,
    /// The preconditioned solver refits its Kronecker model `T_c (x) A` at the current path
    /// every this many iterations (0: only at the start). Default 45 (2,562-vertex benchmark,
    /// one core, time to the converged energy: without refits isometric 1.38 s and conformal
    /// 3.01 s; refitting every 20 / 30 / 45 / 60 iterations: isometric 0.98 / 0.90 / 0.87
    /// / 0.86 s, conformal 1.90 / 1.56 / 1.43 / 1.49 s; docs/log/benchmarks.md).
    pub preconditioner_refresh: usize,
    /// Weight `omega` of the vertex-block term of the preconditioned solver:
    /// `M^{-1} = (2 T_c (x) A)^{-1} + omega (2 D)^{-1}`, `D` the 3 x 3 diagonal blocks of
    /// `J^T J` per interior pose and vertex (0: the Kronecker model alone). Default 0.3
    /// (2,562-vertex benchmark, one core, iterations to E* (1 + 1e-6) for omega = 0 / 0.2 /
    /// 0.3 / 0.4 / 0.5: conformal 155 / 96 / 70 / 66 / 61, isometric 148 / 155 / 148 / 164 /
    /// 179; at 162 and 642 vertices within +-2 iterations of omega = 0; on the real left
    /// ventricle neutral; isometric runs to convergence can take up to 25 % longer, ending in
    /// other minima 1e-5 apart; docs/log/benchmarks.md and docs/defaults.md).
    pub vertex_block_weight: f64,
    /// How long [`GeodesicSolver::solve_in`] keeps one preconditioner fit for the next
    /// geodesics: refit once the solves after the fitting one have together taken more than
    /// this many iterations beyond the fitting solve's count (0: refit as soon as a solve
    /// with the fit needs more iterations than the one that fitted it). Default 10 (162-vertex benchmark,
    /// 48 deformations x 9 poses, iterations per geodesic fresh / 0 / 4 / 10 / never refit:
    /// quasi-conformal 4.7 / 5.0 / 5.3 / 5.4 / 6.5, conformal 13.0 / 13.2 / 13.8 / 14.3 / 18.6;
    /// CPU time of the matrix lowest for 4-10; docs/log/speed.md).
    pub preconditioner_reuse: usize,
    /// Called by every solver once per iteration ([`Monitor`]): progress reports, and a way
    /// to stop a solve (Ctrl-C) with [`super::GeodesicError::Interrupted`]. Default `None`.
    pub monitor: Option<Monitor>,
}

/// A callback every geodesic solver calls once per outer iteration, before the iteration's
/// work, with the iteration number (1, 2, ...) and the current path energy. Returning
/// [`std::ops::ControlFlow::Break`] stops the solve with [`super::GeodesicError::Interrupted`].
/// It runs on the solver's thread: keep it cheap (an atomic load, a counter).
#[derive(Clone)]
pub struct Monitor(std::sync::Arc<MonitorFn>);

/// The function inside a [`Monitor`]: `(iteration, energy) -> ControlFlow`.
pub type MonitorFn = dyn Fn(usize, f64) -> std::ops::ControlFlow<()> + Send + Sync;

impl Monitor {
    /// A monitor calling `f(iteration, energy)`.
    pub fn new(f: impl Fn(usize, f64) -> std::ops::ControlFlow<()> + Send + Sync + 'static) -> Self {
        Monitor(std::sync::Arc::new(f))
    }
}

impl std::fmt::Debug for Monitor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Monitor")
    }
}

impl GeodesicOptions {
    /// Checks the values a user sets (the one validation of the solver settings): `steps` in
    /// 1..=[`crate::limits::MAX_STEPS`], the tolerances finite, `>= 0` and at most
    /// [`crate::limits::MAX_TOLERANCE`], an iteration limit of at most
    /// [`crate::limits::MAX_ITERATIONS`]. The error names the setting by its key in
    /// [`crate::settings::SETTINGS`].
    pub fn validate(&self) -> Result<(), crate::limits::LimitError> {
        use crate::limits::{count, non_negative, MAX_ITERATIONS, MAX_STEPS, MAX_TOLERANCE};
        count("steps", self.steps, 1, MAX_STEPS)?;
        non_negative("tolerance", self.gradient_tolerance, MAX_TOLERANCE)?;
        non_negative("energy-tolerance", self.energy_tolerance, MAX_TOLERANCE)?;
        non_negative("length-tolerance", self.length_tolerance, MAX_TOLERANCE)?;
        if let Some(m) = self.max_iterations {
            count("max-iterations", m, 0, MAX_ITERATIONS)?;
        }
        Ok(())
    }

    /// Every check a solver makes on its options: [`Self::validate`] (the user-facing
    /// settings) and the internal vertex-block weight (finite, `>= 0`). The one check of
    /// [`super::GeodesicSolver::new`] and of the shape space's constructors.
    pub fn check(&self) -> Result<(), super::GeodesicError> {
        self.validate()?;
        if !(self.vertex_block_weight >= 0.0 && self.vertex_block_weight.is_finite()) {
            return Err(super::GeodesicError::VertexBlockWeight(self.vertex_block_weight));
        }
        Ok(())
    }

    /// The iteration limit in force on a mesh of `n_vertices` (#V): `max_iterations`, or the
    /// solver's default there ([`Solver::iteration_limit_for`]).
    pub fn iteration_limit(&self, n_vertices: usize) -> usize {
        self.max_iterations
            .unwrap_or_else(|| self.solver.iteration_limit_for(n_vertices))
    }
}

impl Default for GeodesicOptions {
    fn default() -> Self {
        GeodesicOptions {
            steps: super::defaults::STEPS,
            solver: super::defaults::SOLVER,
            gauge: Gauge::Linear,
            max_iterations: None,
            gradient_tolerance: super::defaults::TOLERANCE,
            energy_tolerance: super::defaults::ENERGY_TOLERANCE,
            length_tolerance: super::defaults::LENGTH_TOLERANCE,
            target_energy: None,
            lbfgs_memory: 10,
            preconditioner_refresh: 45,
            vertex_block_weight: 0.3,
            preconditioner_reuse: 10,
            monitor: None,
        }
    }
}

/// Why a solver stopped.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StopReason {
    /// The path has no free unknowns (N = 1 and no auxiliary unknowns).
    NothingToOptimize,
    /// The gradient norm fell below the relative tolerance.
    GradientTolerance,
    /// The energy stopped decreasing (relative decrease below tolerance).
    EnergyTolerance,
    /// The length settled (distance solves: two consecutive relative changes below
    /// [`GeodesicOptions::length_tolerance`]).
    LengthTolerance,
    /// The target energy was reached.
    TargetEnergy,
    /// The iteration limit was reached.
    MaxIterations,
    /// No step could lower the energy further (the line search found no decrease).
    NoProgress,
    /// The solver stopped for another reason (message).
    Other(String),
}

impl StopReason {
    /// Whether the reason counts as converged.
    pub fn is_converged(&self) -> bool {
        matches!(
            self,
            StopReason::NothingToOptimize
                | StopReason::GradientTolerance
                | StopReason::EnergyTolerance
                | StopReason::LengthTolerance
                | StopReason::TargetEnergy
        )
    }
}

impl GeodesicOptions {
    /// The stopping test at the top of a solver iteration: the target energy is reached, or
    /// the gradient norm `gnorm` fell below the relative tolerance of its start value `g0`.
    pub(crate) fn stop_before_iteration(&self, energy: f64, gnorm: f64, g0: f64) -> Option<StopReason> {
        if self.target_energy.is_some_and(|t| energy <= t) {
            Some(StopReason::TargetEnergy)
        } else if gnorm <= self.gradient_tolerance * g0 {
            Some(StopReason::GradientTolerance)
        } else {
            None
        }
    }

    /// The solvers' once-per-iteration call of [`GeodesicOptions::monitor`]:
    /// [`super::GeodesicError::Interrupted`] when it asks to stop.
    pub(crate) fn monitor(&self, iteration: usize, energy: f64) -> Result<(), super::GeodesicError> {
        match &self.monitor {
            Some(m) if (m.0)(iteration, energy).is_break() => {
                Err(super::GeodesicError::Interrupted { iteration })
            }
            _ => Ok(()),
        }
    }

    /// A solver's final stop reason: running out of iterations with the gradient test met
    /// counts as converged.
    pub(crate) fn final_stop(&self, stop: StopReason, gnorm: f64, g0: f64) -> StopReason {
        if stop == StopReason::MaxIterations && gnorm <= self.gradient_tolerance * g0 {
            StopReason::GradientTolerance
        } else {
            stop
        }
    }
}
