//! Options shared by every command that measures lengths: the metric with its variants and the
//! geodesic solver.

use anyhow::{bail, Context, Result};
use qcshape::defaults;
use qcshape::geodesic::{GeodesicOptions, Solver};
use qcshape::metric::{ConformalForm, MetricKind, MetricScale, MetricSpec, QcNormalize, QcWeights};

/// The metric (METHOD.md) and its variants.
#[derive(Debug, Clone, clap::Args)]
pub struct MetricArgs {
    /// Metric: l2, rigid, isometric, conformal, quasi-conformal.
    #[arg(long, default_value = defaults::METRIC.label())]
    pub metric: MetricKind,
    #[command(flatten)]
    pub variants: VariantArgs,
}

impl MetricArgs {
    /// The metric specification, after checking the values.
    pub fn spec(&self) -> Result<MetricSpec> {
        self.variants.spec(self.metric)
    }
}

/// A metric's variants and regularization (shared by every metric a command compares).
#[derive(Debug, Clone, clap::Args)]
pub struct VariantArgs {
    /// Conformal triangle term: quadratic (T_p^2 + T_q^2 + T_r^2) or paper ((|T_p|+|T_q|+|T_r|)^2).
    #[arg(long, default_value = "quadratic", value_parser = ["quadratic", "paper"])]
    pub form: String,
    /// Quasi-conformal curvature-change weights: endpoints (frozen K(B) - K(A)) or segment.
    #[arg(long, default_value = "endpoints", value_parser = ["endpoints", "segment"])]
    pub weights: String,
    /// Weight of the L2 regularizer (eq. 11); 0 disables it. On the calibrated scale a ratio of
    /// two dimensionless terms; on the raw scale the previous releases' weight (their default
    /// was 0.1).
    /// At most 1e6.
    #[arg(long, default_value_t = defaults::LAMBDA, value_parser = crate::bounds::real(qcshape::limits::MAX_LAMBDA), allow_negative_numbers = true)]
    pub lambda: f64,
    /// How the metric's terms are scaled: calibrated (each term divided by its own
    /// resolution-consistent scale at the reference pose, so distances and lambda do not depend
    /// on the mesh resolution or size) or raw (the paper's sums in mean-edge units, the
    /// previous releases').
    #[arg(long, default_value = defaults::SCALE.label())]
    pub scale: MetricScale,
    /// Quasi-conformal endpoint weights: rms (the curvature-change density over its RMS, with
    /// --qc-floor) or raw (the paper's angle-defect change in radians).
    #[arg(long, default_value = if defaults::QC_NORMALIZE.is_some() { "rms" } else { "raw" }, value_parser = ["rms", "raw"])]
    pub qc_weights: String,
    /// Floor of the rms quasi-conformal weights, sqrt(floor^2 + w^2): no vertex moves for free.
    /// At most 1e6.
    #[arg(long, default_value_t = defaults::QC_NORMALIZE.map_or(0.0, |n| n.floor), value_parser = crate::bounds::real(qcshape::limits::MAX_LAMBDA), allow_negative_numbers = true)]
    pub qc_floor: f64,
    /// One-ring smoothing passes of the curvature-change density before the rms weights.
    /// At most 1,000.
    #[arg(long, default_value_t = defaults::QC_NORMALIZE.map_or(0, |n| n.smooth), value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_SWEEPS as u64), allow_negative_numbers = true)]
    pub qc_smooth: usize,
    /// L2 area weights: frozen at the path's ends, or taken from each pose (degenerates, see docs).
    #[arg(long, default_value = "frozen", value_parser = ["frozen", "pose"])]
    pub l2_areas: String,
}

impl VariantArgs {
    /// The specification of the metric `kind` with these variants, after checking the values.
    pub fn spec(&self, kind: MetricKind) -> Result<MetricSpec> {
        if !self.lambda.is_finite() || self.lambda < 0.0 {
            bail!(
                "--lambda must be a finite non-negative number (got {})",
                self.lambda
            );
        }
        if !self.qc_floor.is_finite() || self.qc_floor < 0.0 {
            bail!("--qc-floor must be a finite number >= 0 (got {})", self.qc_floor);
        }
        if self.qc_smooth > 1000 {
            bail!("--qc-smooth must be at most 1000 (got {})", self.qc_smooth);
        }
        if self.lambda == 0.0 && matches!(kind, MetricKind::Conformal | MetricKind::QuasiConformal) {
            eprintln!(
                "warning: --lambda 0 leaves the {} metric's null space free (rigid motions, scalings, \
                 conformal fields; every normal motion of a sphere): geodesics are not unique and \
                 distances collapse towards 0 (docs/geometry.md)",
                kind.label()
            );
        }
        Ok(MetricSpec {
            kind,
            scale: self.scale,
            qc_normalize: (self.qc_weights == "rms").then_some(QcNormalize {
                floor: self.qc_floor,
                smooth: self.qc_smooth,
            }),
            form: if self.form == "paper" {
                ConformalForm::Paper
            } else {
                ConformalForm::Quadratic
            },
            weights: if self.weights == "segment" {
                QcWeights::Segment
            } else {
                QcWeights::Endpoints
            },
            lambda: self.lambda,
            frozen_areas: self.l2_areas == "frozen",
        })
    }
}

/// The discrete geodesic solver.
#[derive(Debug, Clone, clap::Args)]
pub struct SolverArgs {
    /// Number of path segments N of each geodesic.
    /// At most 10,000.
    #[arg(long, default_value_t = defaults::STEPS, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_STEPS as u64), allow_negative_numbers = true)]
    pub steps: usize,
    /// Optimizer: preconditioned (L-BFGS with the path's Kronecker and vertex-block
    /// preconditioner), newton
    /// (truncated: conjugate gradients on the exact Hessian), gauss-newton (truncated, on the
    /// Gauss-Newton system), gauss-newton-direct (full sparse Cholesky, small meshes only), lbfgs
    /// (the paper's, through argmin), plain-lbfgs (the preconditioned solver without its
    /// preconditioner).
    #[arg(long, default_value = defaults::SOLVER.label())]
    pub solver: Solver,
    /// Relative gradient tolerance: converged when the gradient norm falls below this fraction
    /// of its value at the start.
    /// At most 1.
    #[arg(long, default_value_t = defaults::TOLERANCE, value_parser = crate::bounds::real(qcshape::limits::MAX_TOLERANCE), allow_negative_numbers = true)]
    pub tolerance: f64,
    /// Relative energy tolerance: also converged when an accepted step lowers the path energy by
    /// less than this fraction. On flat energies (conformal, isometric on fine meshes) this test
    /// stops first, with the energy converged but the gradient above --tolerance; 0 disables it,
    /// so that the gradient test decides (more iterations).
    /// At most 1.
    #[arg(long, default_value_t = defaults::ENERGY_TOLERANCE, value_parser = crate::bounds::real(qcshape::limits::MAX_TOLERANCE), allow_negative_numbers = true)]
    pub energy_tolerance: f64,
    /// Relative length tolerance of the distances (similarity matrices, the intrinsic k-means
    /// assignment): also converged when two consecutive steps each change a geodesic's length
    /// by less than this fraction. The length settles long before the path; 0 disables the
    /// test (every distance solved to --tolerance / --energy-tolerance, slower). Paths
    /// (interpolation, transfer, means) never use it.
    /// At most 1.
    #[arg(long, default_value_t = defaults::LENGTH_TOLERANCE, value_parser = crate::bounds::real(qcshape::limits::MAX_TOLERANCE), allow_negative_numbers = true)]
    pub length_tolerance: f64,
}

impl SolverArgs {
    /// The geodesic options, after checking the values.
    pub fn options(&self) -> Result<GeodesicOptions> {
        if self.steps == 0 {
            bail!("--steps must be at least 1");
        }
        Ok(GeodesicOptions {
            steps: self.steps,
            solver: self.solver,
            gradient_tolerance: non_negative("--tolerance", self.tolerance)?,
            energy_tolerance: non_negative("--energy-tolerance", self.energy_tolerance)?,
            length_tolerance: non_negative("--length-tolerance", self.length_tolerance)?,
            ..Default::default()
        })
    }
}

/// `value` if it is a finite non-negative number, else an error naming the option.
pub(crate) fn non_negative(option: &str, value: f64) -> Result<f64> {
    if !value.is_finite() || value < 0.0 {
        bail!("{option} must be a finite non-negative number (got {value})");
    }
    Ok(value)
}

/// Runs `f` in a worker pool of `threads` threads (default: all cores).
pub(crate) fn in_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        if t == 0 {
            bail!("--threads must be at least 1");
        }
        b = b.num_threads(t);
    }
    b.build().context("cannot start the worker threads")?.install(f)
}
