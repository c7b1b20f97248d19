//! Path energy (eq. 12) and discrete geodesics (docs/method.md
//! "Path energy, geodesics, distance").
//!
//! A discrete geodesic from `A` to `B` minimizes the path energy over the interior poses of a
//! path with `N` segments, started from the linear interpolation. Three solvers, one iteration
//! (`plbfgs.rs`: L-BFGS whose initial inverse Hessian is a model of the Hessian), the default
//! first:
//! - [`Solver::Preconditioned`] (default): the model is a Kronecker product `T_c (x) A` of the
//!   Gauss-Newton Hessian (`kronecker.rs`; one sparse Cholesky of size 3 #V whose symbolic
//!   factorization is built once per (topology, metric) and reused for every refit and every
//!   pair solved by one [`GeodesicSolver`]) plus the block-Jacobi inverse of its 3 x 3 vertex
//!   blocks per pose (`vertex_blocks.rs`), refitted periodically;
//! - [`Solver::PoseKronecker`] (with `pose_kronecker.rs`): each interior pose's own spatial
//!   block in the model (the calibrated scale at small lambda, noisy poses without the gauge);
//! - [`Solver::HessianKronecker`]: the Kronecker model fitted to the exact Hessian (where
//!   positive definite) and refitted more often: fewer iterations on fine meshes without the
//!   bending term.
//!
//! The research solvers (truncated Gauss-Newton and Newton, Levenberg-Marquardt, argmin's
//! L-BFGS, L-BFGS without preconditioner) were retired on 2026-12-07 (docs/log/solvers.md).
//!
//! The length of a path is `L = sum_i sqrt((G_{P_i}(X_i) + G_{P_{i+1}}(X_i)) / 2)`, and the
//! distance `dis(A, B)` is the length of the discrete geodesic.
//!
//! Temporal interpolation between key poses (section 2.2.1) with spatial multiresolution is in
//! [`Interpolator`] and [`interpolate_sequence`].

mod compact;
pub mod defaults;
mod energy;
mod escape;
mod gauge;
mod hessian;
mod interpolate;
mod kronecker;
#[cfg(test)]
mod multires_start_tests;
#[cfg(test)]
mod near_tests;
mod options;
mod pairs;
mod plbfgs;
mod pose_kronecker;
#[cfg(test)]
mod preconditioned_spectrum_tests;
#[cfg(test)]
mod second_order_tests;
#[cfg(test)]
mod spectrum_tests;
mod vertex_blocks;

use std::sync::Arc;
use std::time::Instant;

use thiserror::Error;

pub use energy::{Ends, PathEnergy};
pub use escape::{OffPath, OFF_PATH_EDGES, OFF_PATH_FACTOR};
pub use interpolate::{
    insertion_schedule, interpolate_middle, interpolate_sequence, Interpolated, InterpolationError,
    InterpolationOptions, Interpolator, LevelStats, MiddleError, PairInterpolation, PairStats,
};
pub use options::{Gauge, GeodesicOptions, Monitor, MonitorFn, Solver, StopReason};

use crate::mesh::{geometry, MeshError, Shape, Topology};
use crate::metric::{At, CalibrationError, Metric, MetricSpec, Segment};

/// A discrete geodesic (or, if not converged, the best path found).
#[derive(Debug, Clone)]
pub struct Geodesic {
    /// The poses `P_0 .. P_N` (each #V x 3), ends included, in the input's units.
    pub poses: Vec<Vec<[f64; 3]>>,
    /// Path energy (eq. 12) at the solution, in the solver's (normalized) units.
    pub energy: f64,
    /// Path energy of the linear interpolation (the start).
    pub initial_energy: f64,
    /// The part of [`Geodesic::energy`] carried by the geometric term (the metric without its
    /// L2 regularizer, eq. 12 with `G` alone); with [`Geodesic::regularizer_energy`] it sums
    /// to the energy (to rounding).
    pub geometric_energy: f64,
    /// The part of [`Geodesic::energy`] carried by the L2 regularizer `lambda * L2` of eq. 11
    /// (0 without regularizer).
    pub regularizer_energy: f64,
    /// The part of [`Geodesic::geometric_energy`] carried by the bending term (`beta B`,
    /// docs/method.md "Bending term"; 0 without one).
    pub bending_energy: f64,
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
    /// Norm of the energy gradient at the solution; with the rigid gauge
    /// ([`Gauge::Linear`], the default) the gradient projected onto the
    /// gauge's subspace (the constraints' own force, the rigid part, left out).
    pub gradient_norm: f64,
    /// The factor all coordinates were multiplied by before solving (1 if not normalized).
    pub scale: f64,
    /// Wall-clock seconds spent in the solver.
    pub seconds: f64,
}

impl Geodesic {
    /// The regularizer's share of the energy, `regularizer / (geometric + regularizer)` in
    /// [0, 1] (0 for a path of zero energy). Above 0.5 the L2 regularizer, not the metric's
    /// geometry, decides the path: the metric then measures L2.
    pub fn regularizer_share(&self) -> f64 {
        share(self.geometric_energy, self.regularizer_energy)
    }

    /// The bending term's share of the energy, `bending / energy` in [0, 1] (0 for a path of
    /// zero energy or a metric without bending term).
    pub fn bending_share(&self) -> f64 {
        let total = self.geometric_energy + self.regularizer_energy;
        if total > 0.0 {
            (self.bending_energy / total).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// The straight (linear) path between two poses, measured without optimization
/// ([`GeodesicSolver::straight_path_with`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StraightPath {
    /// Its length (eq. 12's discretization with the solver's N segments), an upper bound of
    /// `dis(a, b)`; in the metric's units.
    pub length: f64,
    /// The geometric term's part of its energy (eq. 12 with `G` alone).
    pub geometric_energy: f64,
    /// The L2 regularizer's part of its energy (0 without regularizer).
    pub regularizer_energy: f64,
}

/// `regularizer / (geometric + regularizer)`, 0 when both are 0 (a path of zero energy).
pub fn share(geometric: f64, regularizer: f64) -> f64 {
    let total = geometric + regularizer;
    if total > 0.0 {
        (regularizer / total).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Errors of the geodesic computation.
#[derive(Debug, Error)]
pub enum GeodesicError {
    /// The two shapes do not share a connectivity (or vertex count).
    #[error("shapes cannot be joined by a path: {0}")]
    Mesh(#[from] MeshError),
    /// A setting out of its range (steps, tolerances, iteration limit), named by its key in
    /// [`crate::settings::SETTINGS`].
    #[error(transparent)]
    Setting(Box<crate::limits::LimitError>),
    /// The solver's internal vertex-block weight is negative or not finite.
    #[error("invalid option: the vertex-block weight must be a non-negative number (got {0})")]
    VertexBlockWeight(f64),
    /// A start path does not fit the solver: `poses` unscaled poses of `vertices` vertices
    /// each were expected.
    #[error("invalid option: a start path needs {poses} unscaled poses of {vertices} vertices")]
    StartPath {
        /// Poses expected.
        poses: usize,
        /// Vertices per pose.
        vertices: usize,
    },
    /// The interior poses given do not fit the solver: `poses` poses of `vertices` vertices.
    #[error("invalid option: expected {poses} interior poses of {vertices} vertices")]
    Interior {
        /// Poses expected.
        poses: usize,
        /// Vertices per pose.
        vertices: usize,
    },
    /// The normalization factor of a pair of shapes is zero, negative or not finite
    /// (degenerate shapes: zero edge lengths or area).
    #[error("invalid option: normalization factor {factor} is not positive")]
    Normalization {
        /// The factor.
        factor: f64,
    },
    /// The linear algebra of the solver's set-up or preconditioner failed (`what`: which
    /// part; the source error is kept).
    #[error("linear algebra failure in {what}: {source}")]
    LinearAlgebra {
        /// The part that failed (a structure or a factorization).
        what: &'static str,
        /// The failure.
        source: LinearAlgebraError,
    },
    /// The metric could not be calibrated on its reference pose(s).
    #[error(transparent)]
    Calibration(#[from] CalibrationError),
    /// The solve was stopped by the options' `monitor` callback ([`GeodesicOptions`]) (e.g. Ctrl-C) before iteration
    /// `iteration`.
    #[error("interrupted at solver iteration {iteration}")]
    Interrupted {
        /// The iteration that was about to run.
        iteration: usize,
    },
    /// The energy became NaN or infinite (degenerate poses along the path).
    #[error("the path energy is not finite ({what} {value}); the poses may be degenerate")]
    NonFinite {
        /// Which quantity: "energy", "initial energy", "final energy", "straight-path length".
        what: &'static str,
        /// Its value.
        value: f64,
    },
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
/// the Kronecker model's spatial structure with its symbolic Cholesky factorization are built
/// once and used for every pair.
pub struct GeodesicSolver<'m> {
    energy: PathEnergy<'m>,
    options: GeodesicOptions,
    /// The spatial structure of the Kronecker model (`None` without unknowns).
    spatial: Option<kronecker::SpatialLayout>,
}

impl<'m> GeodesicSolver<'m> {
    /// Prepares a solver. Builds the Kronecker model's spatial structure now.
    pub fn new(
        metric: &'m dyn Metric,
        topo: Arc<Topology>,
        options: GeodesicOptions,
    ) -> Result<Self, GeodesicError> {
        options.check()?;
        let energy = PathEnergy::new(metric, topo, options.steps);
        let spatial = if energy.n_vars() > 0 {
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
            spatial,
        })
    }

    /// The path energy being minimized.
    pub fn path_energy(&self) -> &PathEnergy<'m> {
        &self.energy
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
    /// fewer iterations when the ends move little (docs/log/speed.md).
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
    /// (48-deformation benchmark: docs/log/speed.md); it is still a good start for the next
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
                    return Err(GeodesicError::StartPath {
                        poses: self.energy.steps() + 1,
                        vertices: nv,
                    });
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
        self.straight_path_with(a, b, summaries).map(|s| s.length)
    }

    /// [`Self::straight_length_with`] with the straight path's energy (eq. 12 on the linear
    /// path) split into the geometric term and the L2 regularizer, from the same metric
    /// evaluations ([`Metric::segment_norms_and_parts`]): the length is the same, bit for bit,
    /// and the parts are those [`PathEnergy::energy_parts`] gives on the linear path.
    pub fn straight_path_with(
        &self,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        summaries: Option<[&[f64]; 2]>,
    ) -> Result<StraightPath, GeodesicError> {
        let (length, [geometric_energy, regularizer_energy]) = if self.energy.steps() == 1 {
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
            let ([g0, g1], parts) =
                pe.metric
                    .segment_norms_and_parts(&pe.topo, pe.pattern.as_ref(), [&s0, &s1]);
            (segment_length(g0 + g1), parts)
        } else {
            let ends = self.ends_with(a, b, summaries)?;
            let x0 = self.energy.linear_start(&ends);
            let (norms, parts) = self.energy.segment_norms_and_energy_parts(&x0, &ends);
            let length: f64 = norms.iter().map(|&(g0, g1)| segment_length(g0 + g1)).sum();
            (length, parts)
        };
        if !length.is_finite() {
            return Err(GeodesicError::NonFinite {
                what: "straight-path length",
                value: length,
            });
        }
        Ok(StraightPath {
            length,
            geometric_energy,
            regularizer_energy,
        })
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
            return Err(GeodesicError::Interior {
                poses: self.energy.steps() - 1,
                vertices: a.len(),
            });
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
        // The solver evaluates the start itself (its first energy and gradient); a path
        // without unknowns is evaluated here.
        let checked_start = if pe.n_vars() > 0 {
            None
        } else {
            let e0 = pe.energy(&x0, ends);
            if !e0.is_finite() {
                return Err(GeodesicError::NonFinite {
                    what: "initial energy",
                    value: e0,
                });
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
            let layout = self
                .spatial
                .as_ref()
                .expect("the spatial layout is built when there are unknowns");
            let fitted = ctx.as_ref().is_some_and(|c| c.pre.is_none());
            let shared = ctx.as_mut().map(|c| &mut c.pre);
            let length_tolerance = match goal {
                Goal::Path => 0.0,
                Goal::Length => self.options.length_tolerance,
            };
            let model = match self.options.solver {
                Solver::Preconditioned => plbfgs::Model::Kronecker,
                Solver::PoseKronecker => plbfgs::Model::PoseWise,
                Solver::HessianKronecker => plbfgs::Model::Hessian,
            };
            let out = plbfgs::minimize(
                pe,
                (layout, model),
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
            return Err(GeodesicError::NonFinite {
                what: "final energy",
                value: energy,
            });
        }
        let segment_lengths: Vec<f64> = segment_energies.iter().map(|&e| segment_length(e)).collect();
        let [geometric_energy, regularizer_energy] = pe.energy_parts(&out.x, ends);
        let bending_energy = pe.bending_energy(&out.x, ends);
        let poses = (0..=pe.steps())
            .map(|i| pe.pose(&out.x, ends, i).to_vec())
            .collect();
        Ok(Geodesic {
            poses,
            energy,
            initial_energy,
            geometric_energy,
            regularizer_energy,
            bending_energy,
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

/// How shapes are scaled before solving (docs/method.md "Metrics": one common factor for all shapes
/// compared).
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
        return Err(GeodesicError::Normalization { factor: f });
    }
    let solver = GeodesicSolver::new(metric, a.topology.clone(), options.clone())?;
    let mut g = solver.solve(
        &geometry::scaled(&a.positions, f),
        &geometry::scaled(&b.positions, f),
    )?;
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

/// The discrete geodesic from shape `a` to shape `b` for the metric `spec`, symmetric in the
/// two shapes: coordinates are multiplied by [`Normalization::MeanEdgeOfBoth`]'s factor and
/// the metric is calibrated on both ends ([`MetricSpec::calibrate`]), so `dis(a, b) =
/// dis(b, a)` (what `qcshape geodesic` and Python's `ShapeSpace.dist` report). Lengths and
/// energies are in the metric's units ([`crate::metric::MetricScale`]); the poses in the
/// input's.
pub fn geodesic_between(
    spec: &MetricSpec,
    a: &Shape,
    b: &Shape,
    options: &GeodesicOptions,
) -> Result<Geodesic, GeodesicError> {
    let (metric, f) = pair_metric(spec, a, b)?;
    geodesic(metric.as_ref(), a, b, options, Normalization::Factor(f))
}

/// The metric `spec` and the coordinate factor of a geodesic between `a` and `b`, symmetric in
/// the two shapes ([`geodesic_between`]): the factor of [`pair_factor`] and the metric
/// calibrated on both scaled ends.
pub fn pair_metric(spec: &MetricSpec, a: &Shape, b: &Shape) -> Result<(Box<dyn Metric>, f64), GeodesicError> {
    a.check_same_topology(b)?;
    let f = pair_factor(&a.positions, &b.positions, &a.topology)?;
    let (sa, sb) = (
        geometry::scaled(&a.positions, f),
        geometry::scaled(&b.positions, f),
    );
    Ok((spec.build_for(&a.topology, &[&sa, &sb])?, f))
}

/// [`Normalization::MeanEdgeOfBoth`]'s factor `2 / (mean_edge(a) + mean_edge(b))`, checked
/// positive and finite.
pub fn pair_factor(a: &[[f64; 3]], b: &[[f64; 3]], topo: &Topology) -> Result<f64, GeodesicError> {
    let mean = 0.5 * (geometry::mean_edge_length(topo, a) + geometry::mean_edge_length(topo, b));
    let f = 1.0 / mean.max(f64::MIN_POSITIVE);
    if !(f.is_finite() && f > 0.0) {
        return Err(GeodesicError::Normalization { factor: f });
    }
    Ok(f)
}

#[cfg(test)]
mod tests;

/// A setting's limit error (boxed: it holds the setting's names, and this error travels in
/// larger ones).
impl From<crate::limits::LimitError> for GeodesicError {
    fn from(e: crate::limits::LimitError) -> Self {
        GeodesicError::Setting(Box::new(e))
    }
}
