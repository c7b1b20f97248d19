//! Path energy (eq. 12) and discrete geodesics (METHOD.md "Path energy, geodesics, distance").
//!
//! A discrete geodesic from `A` to `B` minimizes the path energy over the interior poses of a
//! path with `N` segments, started from the linear interpolation. Six solvers, the default
//! first:
//! - [`Solver::Preconditioned`] (default, `plbfgs.rs`): L-BFGS whose initial inverse Hessian is
//!   a Kronecker model `T_c (x) A` of the Gauss-Newton Hessian (`kronecker.rs`; one sparse
//!   Cholesky of size 3 #V whose symbolic factorization is built once per (topology, metric)
//!   and reused for every refit and every pair solved by one [`GeodesicSolver`]) plus the
//!   block-Jacobi inverse of its 3 x 3 vertex blocks per pose (`vertex_blocks.rs`), refitted
//!   periodically;
//! - [`Solver::LevenbergMarquardt`] (`levenberg_marquardt.rs`): Levenberg-Marquardt with a
//!   sparse Cholesky factorization of the full block-tridiagonal normal equations
//!   `J^T J + mu D` (exact steps; the factor grows with `N` times the spatial fill, practical
//!   up to a few hundred vertices);
//! - [`Solver::PlainLbfgs`]: the default solver without its preconditioner.
//!
//! Kept for the benchmark and the `--solver` choices (module `research`):
//! - [`Solver::GaussNewton`]: truncated Gauss-Newton on the stacked residuals; the normal
//!   equations `J^T J p = -J^T r` (block-tridiagonal in the poses) are solved by conjugate
//!   gradients on the assembled 3 x 3 vertex blocks, preconditioned by the Kronecker model
//!   refitted at every iteration;
//! - [`Solver::Newton`]: the truncated iteration on the exact Hessian (the metrics'
//!   second-order parts added to `J^T J`);
//! - [`Solver::Lbfgs`]: the paper's quasi-Newton method (argmin's L-BFGS with a More-Thuente
//!   line search) on the exact gradient.
//!
//! The length of a path is `L = sum_i sqrt((G_{P_i}(X_i) + G_{P_{i+1}}(X_i)) / 2)`, and the
//! distance `dis(A, B)` is the length of the discrete geodesic.
//!
//! Temporal interpolation between key poses (section 2.2.1) with spatial multiresolution is in
//! [`Interpolator`] and [`interpolate_sequence`].

mod compact;
mod energy;
mod hessian;
mod interpolate;
mod kronecker;
mod levenberg_marquardt;
#[cfg(test)]
mod near_tests;
mod pairs;
mod plbfgs;
mod research;
#[cfg(test)]
mod second_order_tests;
mod vertex_blocks;

use std::sync::Arc;
use std::time::Instant;

use thiserror::Error;

pub use energy::{Ends, PathEnergy};
pub use interpolate::{
    insertion_schedule, interpolate_deformation, interpolate_middle, interpolate_sequence, Interpolated,
    InterpolationError, InterpolationOptions, Interpolator, LevelStats, MiddleError, PairInterpolation,
    PairStats,
};

use crate::mesh::{geometry, MeshError, Shape, Topology};
use crate::metric::{At, Metric, Segment};

/// Which optimizer minimizes the path energy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Solver {
    /// L-BFGS preconditioned by the Kronecker model `2 T_c (x) A` of the Gauss-Newton Hessian
    /// (one sparse Cholesky of size 3 #V per refit, every
    /// [`GeodesicOptions::preconditioner_refresh`] iterations) plus a vertex-block term
    /// ([`GeodesicOptions::vertex_block_weight`]), scaled by the newest curvature pair. The
    /// default: the fastest in the benchmark.
    #[default]
    Preconditioned,
    /// Truncated Gauss-Newton: the Gauss-Newton step by preconditioned conjugate gradients
    /// (Kronecker preconditioner `T_c (x) A`, one sparse Cholesky of size 3 #V per
    /// iteration), line search on the energy.
    GaussNewton,
    /// Truncated Newton: [`Solver::GaussNewton`] with the metric's second-order part
    /// `sum r_i d2 r_i` added to `J^T J` (the exact Hessian, [`Metric::add_second_order`]);
    /// conjugate gradients stop at negative curvature. Converges superlinearly near the
    /// geodesic, where Gauss-Newton converges linearly (a geodesic is a large-residual
    /// problem). Metrics without second derivatives (rigid, paper forms, segment weights,
    /// per-pose L2) run as Gauss-Newton.
    Newton,
    /// Levenberg-Marquardt: damped Gauss-Newton steps from a sparse Cholesky factorization of
    /// the full block-tridiagonal normal equations `J^T J + mu D` at every iteration (small
    /// meshes). Command-line values `gauss-newton-direct`, `gn-direct`, `lm` or
    /// `levenberg-marquardt`. Formerly `Solver::GaussNewtonDirect`.
    LevenbergMarquardt,
    /// L-BFGS (the paper's quasi-Newton method) through argmin (More-Thuente line search).
    Lbfgs,
    /// [`Solver::Preconditioned`] without its preconditioner (`H0 = gamma I`, same compact
    /// L-BFGS and backtracking line search): the reference for what the Kronecker model buys,
    /// and a lean L-BFGS (one energy-and-gradient evaluation per accepted step, where argmin's
    /// [`Solver::Lbfgs`] evaluates the gradient about twice per iteration).
    PlainLbfgs,
}

impl std::str::FromStr for Solver {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "gauss-newton" | "gn" => Ok(Solver::GaussNewton),
            "newton" => Ok(Solver::Newton),
            "gauss-newton-direct" | "gn-direct" | "lm" | "levenberg-marquardt" => Ok(Solver::LevenbergMarquardt),
            "lbfgs" | "l-bfgs" => Ok(Solver::Lbfgs),
            "preconditioned" | "plbfgs" => Ok(Solver::Preconditioned),
            "plain-lbfgs" => Ok(Solver::PlainLbfgs),
            _ => Err(format!(
                "unknown solver '{s}' (expected preconditioned, newton, gauss-newton, gauss-newton-direct, lbfgs or plain-lbfgs)"
            )),
        }
    }
}

impl Solver {
    /// The command-line name (`preconditioned`, `gauss-newton`, `newton`,
    /// `gauss-newton-direct`, `lbfgs`, `plain-lbfgs`); [`str::parse`] reads it back.
    pub fn label(self) -> &'static str {
        match self {
            Solver::Preconditioned => "preconditioned",
            Solver::GaussNewton => "gauss-newton",
            Solver::Newton => "newton",
            Solver::LevenbergMarquardt => "gauss-newton-direct",
            Solver::Lbfgs => "lbfgs",
            Solver::PlainLbfgs => "plain-lbfgs",
        }
    }

    /// The iteration limit when [`GeodesicOptions::max_iterations`] is `None`: 100 outer
    /// steps for Gauss-Newton, Newton and Levenberg-Marquardt (each solves a linear system),
    /// 1,000 for the preconditioned L-BFGS, 5,000 for the unpreconditioned L-BFGS solvers
    /// (`plain-lbfgs`, `lbfgs`), whose steps are cheaper and more numerous.
    pub fn default_max_iterations(self) -> usize {
        match self {
            Solver::GaussNewton | Solver::Newton | Solver::LevenbergMarquardt => 100,
            Solver::Preconditioned => 1000,
            Solver::PlainLbfgs | Solver::Lbfgs => 5000,
        }
    }
}

/// Options of the geodesic solvers.
#[derive(Debug, Clone)]
pub struct GeodesicOptions {
    /// Number of path segments `N` (N - 1 free interior poses). Default 8.
    pub steps: usize,
    /// The optimizer. Default [`Solver::Preconditioned`].
    pub solver: Solver,
    /// Iteration limit of the solver; `None` (the default): the solver's own limit,
    /// [`Solver::default_max_iterations`] (100 outer steps for the Gauss-Newton family, 1,000
    /// for the preconditioned L-BFGS, 5,000 for the unpreconditioned L-BFGS solvers). A `Some`
    /// value is the limit itself, for every solver.
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
    /// most 5e-8 relative; at 2,562 by up to 3e-7 (docs/speed.md, round 4). Only the default
    /// solver ([`Solver::Preconditioned`]) applies it; 0 disables it. Default
    /// [`crate::defaults::LENGTH_TOLERANCE`].
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
    /// / 0.86 s, conformal 1.90 / 1.56 / 1.43 / 1.49 s; README "Benchmark").
    pub preconditioner_refresh: usize,
    /// Weight `omega` of the vertex-block term of the preconditioned solver:
    /// `M^{-1} = (2 T_c (x) A)^{-1} + omega (2 D)^{-1}`, `D` the 3 x 3 diagonal blocks of
    /// `J^T J` per interior pose and vertex (0: the Kronecker model alone). Default 0.3
    /// (2,562-vertex benchmark, one core, iterations to E* (1 + 1e-6) for omega = 0 / 0.2 /
    /// 0.3 / 0.4 / 0.5: conformal 155 / 96 / 70 / 66 / 61, isometric 148 / 155 / 148 / 164 /
    /// 179; at 162 and 642 vertices within +-2 iterations of omega = 0; on the real left
    /// ventricle neutral; isometric runs to convergence can take up to 25 % longer, ending in
    /// other minima 1e-5 apart; README "Benchmark" and "How the defaults were chosen").
    pub vertex_block_weight: f64,
    /// How long [`GeodesicSolver::solve_in`] keeps one preconditioner fit for the next
    /// geodesics: refit once the solves after the fitting one have together taken more than
    /// this many iterations beyond the fitting solve's count (0: refit as soon as a solve
    /// with the fit needs more iterations than the one that fitted it). Default 10 (162-vertex benchmark,
    /// 48 deformations x 9 poses, iterations per geodesic fresh / 0 / 4 / 10 / never refit:
    /// quasi-conformal 4.7 / 5.0 / 5.3 / 5.4 / 6.5, conformal 13.0 / 13.2 / 13.8 / 14.3 / 18.6;
    /// CPU time of the matrix lowest for 4-10; docs/speed.md).
    pub preconditioner_reuse: usize,
}

impl GeodesicOptions {
    /// The iteration limit in force: `max_iterations`, or the solver's default.
    pub fn iteration_limit(&self) -> usize {
        self.max_iterations
            .unwrap_or_else(|| self.solver.default_max_iterations())
    }
}

impl Default for GeodesicOptions {
    fn default() -> Self {
        GeodesicOptions {
            steps: crate::defaults::STEPS,
            solver: crate::defaults::SOLVER,
            max_iterations: None,
            gradient_tolerance: crate::defaults::TOLERANCE,
            energy_tolerance: crate::defaults::ENERGY_TOLERANCE,
            length_tolerance: crate::defaults::LENGTH_TOLERANCE,
            target_energy: None,
            lbfgs_memory: 10,
            preconditioner_refresh: 45,
            vertex_block_weight: 0.3,
            preconditioner_reuse: 10,
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
    /// No step could lower the energy further (the damping grew without bound).
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

/// A discrete geodesic (or, if not converged, the best path found).
#[derive(Debug, Clone)]
pub struct Geodesic {
    /// The poses `P_0 .. P_N` (each #V x 3), ends included, in the input's units.
    pub poses: Vec<Vec<[f64; 3]>>,
    /// Path energy (eq. 12) at the solution, in the solver's (normalized) units.
    pub energy: f64,
    /// Path energy of the linear interpolation (the start).
    pub initial_energy: f64,
    /// Length `L` of the path = `dis(A, B)` (normalized units).
    pub length: f64,
    /// Length of each segment, `sqrt((G_{P_i}(X_i) + G_{P_{i+1}}(X_i)) / 2)`.
    pub segment_lengths: Vec<f64>,
    /// Iterations taken.
    pub iterations: usize,
    /// Whether the solver converged.
    pub converged: bool,
    /// Why it stopped.
    pub stop: StopReason,
    /// Norm of the energy gradient at the solution.
    pub gradient_norm: f64,
    /// The factor all coordinates were multiplied by before solving (1 if not normalized).
    pub scale: f64,
    /// Wall-clock seconds spent in the solver.
    pub seconds: f64,
}

/// Errors of the geodesic computation.
#[derive(Debug, Error)]
pub enum GeodesicError {
    /// The two shapes do not share a connectivity (or vertex count).
    #[error("shapes cannot be joined by a path: {0}")]
    Mesh(#[from] MeshError),
    /// A bad option value.
    #[error("invalid option: {0}")]
    Option(String),
    /// The linear algebra of the solver's set-up or preconditioner failed (`what`: which
    /// part; the source error is kept).
    #[error("linear algebra failure in {what}: {source}")]
    LinearAlgebra {
        /// The part that failed (a structure or a factorization).
        what: &'static str,
        /// The failure.
        source: LinearAlgebraError,
    },
    /// The optimizer failed.
    #[error("optimizer failure: {0}")]
    Optimizer(String),
    /// The energy became NaN or infinite (degenerate poses along the path).
    #[error("the path energy is not finite ({0}); the poses may be degenerate")]
    NonFinite(String),
}

/// The failure behind [`GeodesicError::LinearAlgebra`].
#[derive(Debug, Error)]
pub enum LinearAlgebraError {
    /// A sparse structure or its symbolic factorization could not be built (faer's
    /// allocation or index errors).
    #[error("{0}")]
    Structure(#[from] faer::sparse::FaerError),
    /// A Cholesky factorization met a non-positive pivot, even after the diagonal ridges
    /// were tried.
    #[error("Cholesky factorization: {0}")]
    Cholesky(#[from] faer::linalg::cholesky::llt::factor::LltError),
    /// The matrix to factorize has non-finite entries.
    #[error("the Gauss-Newton blocks are not finite")]
    NonFinite,
}

/// A reusable geodesic solver for one (metric, topology, N): the metric's Jacobian pattern and
/// the Gauss-Newton structure with its symbolic Cholesky factorization are built once and used
/// for every pair.
pub struct GeodesicSolver<'m> {
    energy: PathEnergy<'m>,
    options: GeodesicOptions,
    layout: Option<hessian::HessianLayout>,
    /// The spatial structure of the Kronecker model (preconditioned and truncated solvers).
    spatial: Option<kronecker::SpatialLayout>,
}

impl<'m> GeodesicSolver<'m> {
    /// Prepares a solver. Builds the Gauss-Newton structure now if that solver is chosen.
    pub fn new(
        metric: &'m dyn Metric,
        topo: Arc<Topology>,
        options: GeodesicOptions,
    ) -> Result<Self, GeodesicError> {
        if options.steps == 0 {
            return Err(GeodesicError::Option("steps must be at least 1".into()));
        }
        if !(options.gradient_tolerance >= 0.0
            && options.energy_tolerance >= 0.0
            && options.length_tolerance >= 0.0)
        {
            return Err(GeodesicError::Option("tolerances must be non-negative".into()));
        }
        if !(options.vertex_block_weight >= 0.0 && options.vertex_block_weight.is_finite()) {
            return Err(GeodesicError::Option(format!(
                "the vertex-block weight must be a non-negative number (got {})",
                options.vertex_block_weight
            )));
        }
        let energy = PathEnergy::new(metric, topo, options.steps);
        let layout = if options.solver == Solver::LevenbergMarquardt && energy.n_vars() > 0 {
            Some(
                hessian::HessianLayout::new(&energy).map_err(|e| GeodesicError::LinearAlgebra {
                    what: "the Gauss-Newton structure",
                    source: e.into(),
                })?,
            )
        } else {
            None
        };
        let spatial = if matches!(
            options.solver,
            Solver::Preconditioned | Solver::GaussNewton | Solver::Newton
        ) && energy.n_vars() > 0
        {
            Some(
                kronecker::SpatialLayout::new(&energy).map_err(|e| GeodesicError::LinearAlgebra {
                    what: "the spatial preconditioner's structure",
                    source: e.into(),
                })?,
            )
        } else {
            None
        };
        Ok(GeodesicSolver {
            energy,
            options,
            layout,
            spatial,
        })
    }

    /// The path energy being minimized.
    pub fn path_energy(&self) -> &PathEnergy<'m> {
        &self.energy
    }

    /// Sizes of the Gauss-Newton system: (unknowns, stored entries of the upper triangle of
    /// `J^T J`, stored values of its Cholesky factor); `None` for L-BFGS.
    pub fn system_size(&self) -> Option<(usize, usize, usize)> {
        self.layout
            .as_ref()
            .map(|l| (self.energy.n_vars(), l.nnz(), l.factor_len()))
    }

    /// The options.
    pub fn options(&self) -> &GeodesicOptions {
        &self.options
    }

    /// Geodesic from `a` to `b` (each #V x 3, already scaled), started from the linear path.
    pub fn solve(&self, a: &[[f64; 3]], b: &[[f64; 3]]) -> Result<Geodesic, GeodesicError> {
        self.solve_in(&mut SolveContext::default(), a, b)
    }

    /// [`Self::solve`] with the set-up of the previous solves through `ctx` (a preconditioner
    /// fitted once for a sequence of related geodesics, such as the poses of one pair of
    /// deformations, instead of once per geodesic; [`SolveContext`]).
    pub fn solve_in<'s>(
        &'s self,
        ctx: &mut SolveContext<'s>,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
    ) -> Result<Geodesic, GeodesicError> {
        self.solve_near(ctx, a, b, None)
    }

    /// [`Self::solve_in`] started from `near` when given: a geodesic of this solver (N + 1
    /// poses of #V x 3, `scale` 1) between other ends close to `a` and `b`, such as the
    /// previous pose pair of two deformations or the previous iteration of a Karcher mean. The
    /// start keeps `near`'s bend and moves its straight line onto `a`, `b`
    /// ([`PathEnergy::shifted_start`]); without `near`, the linear path. A start changes the
    /// iterates, not the minimum: lengths agree with [`Self::solve`] to solver tolerance
    /// (measured on the 48-deformation benchmark: at most 1.5e-9 relative, conformal), in
    /// fewer iterations when the ends move little (docs/speed.md).
    pub fn solve_near<'s>(
        &'s self,
        ctx: &mut SolveContext<'s>,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        near: Option<&Geodesic>,
    ) -> Result<Geodesic, GeodesicError> {
        self.solve_near_with(ctx, a, b, near, None)
    }

    /// [`Self::solve_near`] with the metric's [`Metric::pose_summary`] of `a` and `b` computed
    /// beforehand (once per pose for a whole similarity matrix instead of once per geodesic):
    /// the same geodesic, bit for bit.
    pub fn solve_near_with<'s>(
        &'s self,
        ctx: &mut SolveContext<'s>,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        near: Option<&Geodesic>,
        summaries: Option<[&[f64]; 2]>,
    ) -> Result<Geodesic, GeodesicError> {
        self.near(ctx, a, b, near, summaries, Goal::Path)
    }

    /// The distance `dis(a, b)` (each #V x 3, already scaled): [`Self::solve_near_with`] that
    /// also stops once the length has settled ([`GeodesicOptions::length_tolerance`]), for
    /// callers that use only [`Geodesic::length`] (similarity matrices, the intrinsic k-means
    /// assignment). The returned path is a less converged geodesic than `solve_near_with`'s
    /// (its speed may still be uneven) and its length agrees with it to about the tolerance
    /// (48-deformation benchmark: docs/speed.md); it is still a good start for the next
    /// distance (`near`).
    pub fn distance_near_with<'s>(
        &'s self,
        ctx: &mut SolveContext<'s>,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        near: Option<&Geodesic>,
        summaries: Option<[&[f64]; 2]>,
    ) -> Result<Geodesic, GeodesicError> {
        self.near(ctx, a, b, near, summaries, Goal::Length)
    }

    fn near<'s>(
        &'s self,
        ctx: &mut SolveContext<'s>,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        near: Option<&Geodesic>,
        summaries: Option<[&[f64]; 2]>,
        goal: Goal,
    ) -> Result<Geodesic, GeodesicError> {
        let ends = self.ends_with(a, b, summaries)?;
        let x0 = match near {
            None => self.energy.linear_start(&ends),
            Some(g) => {
                let nv = self.energy.n_vertices();
                if g.scale != 1.0
                    || g.poses.len() != self.energy.steps() + 1
                    || g.poses.iter().any(|p| p.len() != nv)
                {
                    return Err(GeodesicError::Option(format!(
                        "a start path needs {} unscaled poses of {nv} vertices",
                        self.energy.steps() + 1
                    )));
                }
                self.energy.shifted_start(&g.poses, &ends)
            }
        };
        self.solve_from(&ends, x0, Some(ctx), goal)
    }

    /// The length of the straight (linear) path from `a` to `b` with the solver's N segments,
    /// `L = sum_i sqrt((G_{P_i}(X) + G_{P_{i+1}}(X)) / 2)` with `X = (b - a) / N` (eq. 12's
    /// discretization, no optimization): an upper bound of the geodesic distance `dis(a, b)` (each
    /// #V x 3, already scaled; normalized length units), at the cost of 2N metric evaluations
    /// instead of a solve. Used by the `straight` approximation of similarity matrices.
    pub fn straight_length(&self, a: &[[f64; 3]], b: &[[f64; 3]]) -> Result<f64, GeodesicError> {
        self.straight_length_with(a, b, None)
    }

    /// [`Self::straight_length`] with the metric's [`Metric::pose_summary`] of `a` and `b`
    /// computed beforehand (once per pose for a whole matrix): the same length, bit for bit.
    pub fn straight_length_with(
        &self,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        summaries: Option<[&[f64]; 2]>,
    ) -> Result<f64, GeodesicError> {
        let length: f64 = if self.energy.steps() == 1 {
            // One segment from `a` to `b`: no path to build, no copy of the poses (a cohort
            // matrix measures millions of such pairs).
            self.check_ends(a, b)?;
            let frozen = self.frozen_weights(a, b, summaries);
            let seg = |at| Segment {
                a,
                b,
                at,
                aux: &[],
                frozen: frozen.as_deref(),
            };
            let (s0, s1) = (seg(At::Start), seg(At::End));
            let pe = &self.energy;
            let [g0, g1] = pe
                .metric
                .segment_squared_norms(&pe.topo, pe.pattern.as_ref(), [&s0, &s1]);
            segment_length(g0 + g1)
        } else {
            let ends = self.ends_with(a, b, summaries)?;
            let x0 = self.energy.linear_start(&ends);
            self.energy
                .segment_norms(&x0, &ends)
                .iter()
                .map(|&(g0, g1)| segment_length(g0 + g1))
                .sum()
        };
        if !length.is_finite() {
            return Err(GeodesicError::NonFinite(format!("straight-path length {length}")));
        }
        Ok(length)
    }

    /// Geodesic from `a` to `b` started from the given interior poses `P_1 .. P_{N-1}`.
    pub fn solve_with_start(
        &self,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        interior: &[Vec<[f64; 3]>],
    ) -> Result<Geodesic, GeodesicError> {
        let ends = self.ends(a, b)?;
        if interior.len() + 1 != self.energy.steps() || interior.iter().any(|p| p.len() != a.len()) {
            return Err(GeodesicError::Option(format!(
                "expected {} interior poses of {} vertices",
                self.energy.steps() - 1,
                a.len()
            )));
        }
        let x0 = self.energy.pack(interior, &ends);
        self.solve_from(&ends, x0, None, Goal::Path)
    }

    fn ends(&self, a: &[[f64; 3]], b: &[[f64; 3]]) -> Result<Ends, GeodesicError> {
        self.ends_with(a, b, None)
    }

    fn ends_with(
        &self,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        summaries: Option<[&[f64]; 2]>,
    ) -> Result<Ends, GeodesicError> {
        self.check_ends(a, b)?;
        Ok(Ends {
            start: a.to_vec(),
            end: b.to_vec(),
            frozen: self.frozen_weights(a, b, summaries),
        })
    }

    /// The metric's frozen weights of a path from `a` to `b` (from the pose summaries when
    /// given).
    fn frozen_weights(
        &self,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        summaries: Option<[&[f64]; 2]>,
    ) -> Option<Vec<f64>> {
        let (metric, topo) = (self.energy.metric, &self.energy.topo);
        match summaries {
            Some(s) => metric.frozen_weights_from(topo, a, b, s),
            None => metric.frozen_weights(topo, a, b),
        }
    }

    /// Both end poses have #V finite vertices.
    fn check_ends(&self, a: &[[f64; 3]], b: &[[f64; 3]]) -> Result<(), GeodesicError> {
        let nv = self.energy.n_vertices();
        for p in [a, b] {
            if p.len() != nv {
                return Err(MeshError::VertexCountMismatch {
                    expected: nv,
                    got: p.len(),
                }
                .into());
            }
            if let Some((vertex, v)) = p
                .iter()
                .enumerate()
                .find(|(_, v)| v.iter().any(|c| !c.is_finite()))
            {
                return Err(MeshError::NonFinite { vertex, value: *v }.into());
            }
        }
        Ok(())
    }

    fn solve_from<'s>(
        &'s self,
        ends: &Ends,
        x0: Vec<f64>,
        mut ctx: Option<&mut SolveContext<'s>>,
        goal: Goal,
    ) -> Result<Geodesic, GeodesicError> {
        let t0 = Instant::now();
        let pe = &self.energy;
        // The default solver evaluates the start itself (its first energy and gradient);
        // the others, and a path without unknowns, are evaluated here.
        let own_start = pe.n_vars() > 0 && self.options.solver == Solver::Preconditioned;
        let checked_start = if own_start {
            None
        } else {
            let e0 = pe.energy(&x0, ends);
            if !e0.is_finite() {
                return Err(GeodesicError::NonFinite(format!("initial energy {e0}")));
            }
            Some(e0)
        };
        let out = if pe.n_vars() == 0 {
            SolveOutput {
                x: x0,
                iterations: 0,
                stop: StopReason::NothingToOptimize,
                last: None,
            }
        } else {
            match self.options.solver {
                Solver::GaussNewton | Solver::Newton => {
                    let layout = self.spatial.as_ref().expect("layout is built for Gauss-Newton");
                    let newton = self.options.solver == Solver::Newton;
                    research::truncated::minimize(pe, layout, ends, x0, &self.options, newton)?
                }
                Solver::LevenbergMarquardt => {
                    let layout = self
                        .layout
                        .as_ref()
                        .expect("layout is built for Levenberg-Marquardt");
                    levenberg_marquardt::minimize(pe, layout, ends, x0, &self.options)?
                }
                Solver::Lbfgs => research::lbfgs::minimize(pe, ends, x0, &self.options)?,
                Solver::Preconditioned => {
                    let layout = self
                        .spatial
                        .as_ref()
                        .expect("layout is built for the preconditioned solver");
                    let fitted = ctx.as_ref().is_some_and(|c| c.pre.is_none());
                    let shared = ctx.as_mut().map(|c| &mut c.pre);
                    let length_tolerance = match goal {
                        Goal::Path => 0.0,
                        Goal::Length => self.options.length_tolerance,
                    };
                    let out = plbfgs::minimize(
                        pe,
                        Some(layout),
                        ends,
                        x0,
                        &self.options,
                        length_tolerance,
                        shared,
                    )?;
                    if let Some(c) = ctx {
                        c.record(fitted, out.iterations, self.options.preconditioner_reuse);
                    }
                    out
                }
                Solver::PlainLbfgs => plbfgs::minimize(pe, None, ends, x0, &self.options, 0.0, None)?,
            }
        };
        let (energy, initial_energy, gradient_norm, segment_energies) = match out.last {
            Some(last) => (
                last.energy,
                last.initial_energy,
                last.gradient_norm,
                last.segments,
            ),
            None => {
                let mut grad = vec![0.0; pe.n_vars()];
                let energy = pe.energy_gradient(&out.x, ends, &mut grad);
                let segments = pe
                    .segment_norms(&out.x, ends)
                    .iter()
                    .map(|(g0, g1)| g0 + g1)
                    .collect();
                let gnorm = grad.iter().map(|g| g * g).sum::<f64>().sqrt();
                (energy, checked_start.unwrap_or(energy), gnorm, segments)
            }
        };
        // (The initial energy was checked finite where it was evaluated.)
        if !energy.is_finite() {
            return Err(GeodesicError::NonFinite(format!("final energy {energy}")));
        }
        let segment_lengths: Vec<f64> = segment_energies.iter().map(|&e| segment_length(e)).collect();
        let poses = (0..=pe.steps())
            .map(|i| pe.pose(&out.x, ends, i).to_vec())
            .collect();
        Ok(Geodesic {
            poses,
            energy,
            initial_energy,
            length: segment_lengths.iter().sum(),
            segment_lengths,
            iterations: out.iterations,
            converged: out.stop.is_converged(),
            stop: out.stop,
            gradient_norm,
            scale: 1.0,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}

/// What a solve is for: the converged path, or only its length (a looser stop,
/// [`GeodesicOptions::length_tolerance`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Goal {
    Path,
    Length,
}

/// Dot product of two equally long vectors, summed in 8 interleaved lanes (vectorizes; the
/// order is fixed, so results are deterministic).
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    (acc[0] + acc[4]) + (acc[1] + acc[5]) + (acc[2] + acc[6]) + (acc[3] + acc[7]) + tail
}

/// Euclidean norm, by [`dot`].
pub(crate) fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
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

/// Whether a gradient norm is zero up to rounding for a path of energy `energy` (normalized
/// units): then the start is already stationary (e.g. a straight path that is a geodesic by
/// symmetry) and no solver can make progress, so it counts as converged (a zero gradient
/// always does).
pub(crate) fn at_roundoff(gradient_norm: f64, energy: f64) -> bool {
    gradient_norm <= 1e-10 * (1.0 + energy.abs())
}

/// What a minimizer returns.
pub(crate) struct SolveOutput {
    pub x: Vec<f64>,
    pub iterations: usize,
    pub stop: StopReason,
    /// The minimizer's evaluations at the start and at `x` (aux unknowns at their optimum),
    /// when it kept them; otherwise [`GeodesicSolver`] evaluates again.
    pub last: Option<LastEvaluation>,
}

/// A minimizer's own evaluations, reused for the reported [`Geodesic`] (no further pass).
pub(crate) struct LastEvaluation {
    /// Path energy at the solution.
    pub energy: f64,
    /// Path energy at the start.
    pub initial_energy: f64,
    /// Norm of the pose gradient at the solution (the auxiliary part vanishes at the optimum).
    pub gradient_norm: f64,
    /// Each segment's energy `G_{P_i}(X_i) + G_{P_{i+1}}(X_i)` at the solution.
    pub segments: Vec<f64>,
}

/// Set-up carried from one solve to the next by [`GeodesicSolver::solve_in`]: the default
/// solver's preconditioner (the Kronecker model and vertex blocks with its Cholesky factor),
/// fitted at the first path solved through the context, refitted within a solve every
/// [`GeodesicOptions::preconditioner_refresh`] iterations, and fitted afresh once the solves
/// after a fit have cost [`GeodesicOptions::preconditioner_reuse`] extra iterations. A
/// preconditioner changes the iterates,
/// not the minimum: results agree with fresh solves to solver tolerance, and depend only on
/// the order of the solves through one context (never on threads). Other solvers ignore it.
#[derive(Default)]
pub struct SolveContext<'s> {
    pre: Option<plbfgs::Preconditioner<'s>>,
    /// Iterations of the solve that fitted `pre`.
    fit_iterations: usize,
    /// Iterations beyond `fit_iterations` spent by later solves with `pre`.
    extra_iterations: usize,
    /// Preconditioner fits made at the start of a solve through this context.
    fits: usize,
}

impl SolveContext<'_> {
    /// How many solves through this context fitted a new preconditioner (the others reused
    /// the previous fit).
    pub fn fits(&self) -> usize {
        self.fits
    }

    /// Books a solve of `iterations` that `fitted` the preconditioner or reused it (ski
    /// rental): the fit is dropped, so the next solve fits afresh, once the reusing solves
    /// have together needed more than `budget` iterations beyond the fitting one's.
    fn record(&mut self, fitted: bool, iterations: usize, budget: usize) {
        if fitted {
            self.fits += 1;
            self.fit_iterations = iterations;
            self.extra_iterations = 0;
        } else {
            self.extra_iterations += iterations.saturating_sub(self.fit_iterations);
            if self.extra_iterations > budget {
                self.pre = None;
            }
        }
    }
}

/// The length of a segment from its energy `G_{P_i}(X_i) + G_{P_{i+1}}(X_i)` (eq. 12's two
/// terms; normalized length units): `sqrt(energy / 2)`, 0 for a rounding-negative energy.
fn segment_length(energy: f64) -> f64 {
    (energy / 2.0).max(0.0).sqrt()
}

/// How shapes are scaled before solving (METHOD.md: one common factor for all shapes compared).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normalization {
    /// Divide all coordinates by the mean edge length of the first shape (default).
    MeanEdgeOfFirst,
    /// Divide all coordinates by the mean of the two shapes' mean edge lengths,
    /// `(mean_edge(A) + mean_edge(B)) / 2`: symmetric in the two shapes, so that
    /// `dis(A, B) = dis(B, A)` (what [`geodesic`] and `qcshape geodesic` use). With a single
    /// reference pose ([`normalization_factor`]) it is [`Normalization::MeanEdgeOfFirst`].
    MeanEdgeOfBoth,
    /// Multiply all coordinates by this factor.
    Factor(f64),
    /// Use the coordinates as they are.
    None,
}

/// The factor that [`Normalization`] applies for a reference pose.
pub fn normalization_factor(norm: Normalization, topo: &Topology, reference: &[[f64; 3]]) -> f64 {
    match norm {
        Normalization::MeanEdgeOfFirst | Normalization::MeanEdgeOfBoth => {
            1.0 / geometry::mean_edge_length(topo, reference).max(f64::MIN_POSITIVE)
        }
        Normalization::Factor(f) => f,
        Normalization::None => 1.0,
    }
}

/// The discrete geodesic from shape `a` to shape `b` for `metric`, after scaling both by the
/// common factor of `norm` (lengths and energies are reported in the scaled units; the poses
/// are scaled back to the input's units). Convenience wrapper around [`GeodesicSolver`].
pub fn geodesic(
    metric: &dyn Metric,
    a: &Shape,
    b: &Shape,
    options: &GeodesicOptions,
    norm: Normalization,
) -> Result<Geodesic, GeodesicError> {
    a.check_same_topology(b)?;
    let f = match norm {
        Normalization::MeanEdgeOfBoth => {
            let mean = 0.5
                * (geometry::mean_edge_length(&a.topology, &a.positions)
                    + geometry::mean_edge_length(&b.topology, &b.positions));
            1.0 / mean.max(f64::MIN_POSITIVE)
        }
        _ => normalization_factor(norm, &a.topology, &a.positions),
    };
    if !(f.is_finite() && f > 0.0) {
        return Err(GeodesicError::Option(format!(
            "normalization factor {f} is not positive"
        )));
    }
    let scale = |p: &[[f64; 3]]| -> Vec<[f64; 3]> { p.iter().map(|v| v.map(|c| c * f)).collect() };
    let solver = GeodesicSolver::new(metric, a.topology.clone(), options.clone())?;
    let mut g = solver.solve(&scale(&a.positions), &scale(&b.positions))?;
    for p in &mut g.poses {
        for v in p.iter_mut() {
            *v = v.map(|c| c / f);
        }
    }
    // Keep the ends bit-exact.
    g.poses[0] = a.positions.clone();
    let n = g.poses.len() - 1;
    g.poses[n] = b.positions.clone();
    g.scale = f;
    Ok(g)
}

#[cfg(test)]
mod tests {
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
        let qc = crate::metric::MetricSpec::new(crate::metric::MetricKind::QuasiConformal).build();
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

    #[test]
    fn gauss_newton_and_lbfgs_agree_on_small_problems() {
        let a = icosphere(1);
        let b = bent(&a);
        for m in [&L2 as &dyn Metric, &Regularized::new(Box::new(Isometric), 0.1)] {
            let o = |solver| GeodesicOptions {
                steps: 4,
                solver,
                gradient_tolerance: 1e-9,
                ..Default::default()
            };
            let gn = geodesic(m, &a, &b, &o(Solver::GaussNewton), Normalization::MeanEdgeOfFirst).unwrap();
            let lb = geodesic(m, &a, &b, &o(Solver::Lbfgs), Normalization::MeanEdgeOfFirst).unwrap();
            assert!(gn.converged, "{:?}", gn.stop);
            assert!(gn.energy <= gn.initial_energy);
            let rel = (gn.energy - lb.energy).abs() / gn.energy;
            assert!(
                rel < 1e-6,
                "{}: {} vs {} ({:?}, {} its)",
                m.name(),
                gn.energy,
                lb.energy,
                lb.stop,
                lb.iterations
            );
            assert_eq!(gn.poses[0], a.positions);
            assert_eq!(gn.poses[4], b.positions);
        }
    }
}
