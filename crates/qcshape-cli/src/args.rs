//! Options shared by every command that measures lengths: the metric with its variants, the
//! geodesic solver, and the whole pipeline of a similarity run ([`PipelineArgs`]). The values
//! are validated by the library, once.

use anyhow::{bail, Context, Result};
use qcshape::align::Alignment;
use qcshape::dataset::Dataset;
use qcshape::defaults;
use qcshape::geodesic::{GeodesicOptions, Solver};
use qcshape::metric::{ConformalForm, MetricKind, MetricScale, MetricSpec, QcNormalize, QcWeights};
use qcshape::similarity::{Approx, PipelineOptions, Smoothing};
use qcshape::transport::Transport;

/// The metric (docs/method.md "Metrics") and its variants.
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
    /// How the metric's terms are scaled: invariant (every term a relative rate weighted by its
    /// face's area share: scaling a pose and its motion together changes nothing, so geodesics
    /// do not shrink the shape; the conformal terms as eq. 6), calibrated (eq. 3's and eq. 7's
    /// sums divided by their scale at the reference pose: the 2026-12-04 releases') or raw (the
    /// paper's sums in mean-edge units, the releases before).
    #[arg(long, default_value = defaults::SCALE.label())]
    pub scale: MetricScale,
    /// Weight of the stretch term of the conformal and quasi-conformal metrics on the invariant
    /// scale: the relative rate of change of each face's area, which the conformal terms leave
    /// free (uniform scaling); 0 disables it.
    /// At most 1e6.
    #[arg(long, default_value_t = defaults::STRETCH, value_parser = crate::bounds::real(qcshape::limits::MAX_LAMBDA), allow_negative_numbers = true)]
    pub stretch: f64,
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
        let spec = MetricSpec {
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
            stretch: self.stretch,
        };
        spec.validate().map_err(flag_error)?;
        if let Some(w) = spec.warning() {
            eprintln!("warning: {w}");
        }
        Ok(spec)
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
    /// preconditioner), hessian-kronecker (the same model fitted to the exact Hessian: fewer
    /// iterations for the isometric metric on fine meshes), pose-kronecker (each pose's own spatial block: fewer iterations for the conformal
    /// metrics at small --lambda, each about twice as costly), newton
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
        let g = GeodesicOptions {
            steps: self.steps,
            solver: self.solver,
            gradient_tolerance: self.tolerance,
            energy_tolerance: self.energy_tolerance,
            length_tolerance: self.length_tolerance,
            ..Default::default()
        };
        g.validate().map_err(flag_error)?;
        Ok(g)
    }
}

/// A library validation error ([`qcshape::limits::LimitError`], naming a setting by its key)
/// with the setting spelled as its flag: `--lambda must be >= 0 ...`.
pub(crate) fn flag_error(e: qcshape::limits::LimitError) -> anyhow::Error {
    anyhow::Error::new(e.renamed(|key| format!("--{key}")))
}

/// Every setting of a similarity run, as the library names them
/// ([`qcshape::settings::SETTINGS`]): the metric, the geodesic solver and the rest of the
/// pipeline of eq. 13. Every command that computes a similarity matrix from a data set takes
/// this one group (a test walks their `--help`).
#[derive(Debug, Clone, clap::Args)]
pub struct PipelineArgs {
    #[command(flatten)]
    pub metric: MetricArgs,
    #[command(flatten)]
    pub solver: SolverArgs,
    /// Poses inserted between consecutive key poses before comparing (section 2.2.1).
    /// At most 1,000.
    #[arg(long, default_value_t = defaults::INSERT, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_INSERT as u64), allow_negative_numbers = true)]
    pub insert: usize,
    /// Spatial levels of the interpolation (1 = single level, the measured fastest).
    /// At most 16.
    #[arg(long, default_value_t = defaults::LEVELS, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_LEVELS as u64), allow_negative_numbers = true)]
    pub levels: usize,
    /// Transport to the common base: euclidean (the default: it gave the lower transfer error and the
    /// better classification in the measurements, docs/log/results.md), parallel (the paper's) or schild.
    #[arg(long, default_value = defaults::TRANSPORT.label())]
    pub transport: Transport,
    /// Placement of each deformation on the base before transfer: rigid (the default: area-weighted
    /// Procrustes of its first pose onto the base, the same motion for all its poses), similarity (also
    /// a uniform scale) or none (the paper's pipeline).
    #[arg(long, default_value = defaults::ALIGN.label())]
    pub align: Alignment,
    #[command(flatten)]
    pub smooth: SmoothArgs,
    /// Name of the reference deformation whose first pose is the common base (default: the first).
    #[arg(long)]
    pub base: Option<String>,
    /// Pose distances: exact (geodesic lengths, the paper's), straight (the straight-path length
    /// with the same steps, no optimization: an upper bound, about 20-100x cheaper) or tangent
    /// (the metric linearized at the common base: one feature vector per pose, then Euclidean
    /// distances; quasi-conformal weighs each pair by its curvature-change weights). Errors against exact:
    /// docs/scale.md.
    /// Interpolation and transfer stay exact.
    #[arg(long, default_value = "exact")]
    pub approx: Approx,
}

impl PipelineArgs {
    /// The pipeline options for the data set `data` (the base by name), validated by the
    /// library ([`PipelineOptions::validate`]).
    pub fn options(&self, data: &Dataset) -> Result<PipelineOptions> {
        let base = match self.base.as_deref() {
            None => 0,
            Some(name) => data
                .deformations
                .iter()
                .position(|d| d.name == name)
                .with_context(|| format!("--base {name:?} is not a deformation of the data set"))?,
        };
        let opts = PipelineOptions {
            metric: self.metric.spec()?,
            geodesic: self.solver.options()?,
            insert: self.insert,
            levels: self.levels,
            transport: self.transport,
            base,
            align: self.align,
            smoothing: self.smooth.smoothing(),
            approx: self.approx,
        };
        opts.validate(data.deformations.len()).map_err(flag_error)?;
        Ok(opts)
    }
}

/// The low-pass filter of every pose before comparing ([`Smoothing`]): the length filter, or
/// Taubin iterations when `--smooth N` is given.
#[derive(Debug, Clone, clap::Args)]
pub struct SmoothArgs {
    /// Taubin smoothing iterations of every pose before comparing, instead of the length filter
    /// (a filter in mesh units: it smooths a quarter as much of the surface per subdivision; the
    /// default before --smooth-length was 10; 0 = no smoothing, the paper's pipeline).
    /// At most 1,000.
    #[arg(long, alias = "smoothing", conflicts_with = "smooth_length", value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_SWEEPS as u64), allow_negative_numbers = true)]
    pub smooth: Option<usize>,
    /// Smoothing length L of every pose before comparing, relative to the area radius R =
    /// sqrt(area / 4 pi) of the base's first pose: a low-pass filter that takes vertex noise out
    /// of real data, the same at every mesh resolution (a wave of wavenumber w keeps
    /// exp(-(w L R)^4) of its amplitude; 0 = none; docs/robustness.md).
    /// At most 10.
    #[arg(long, default_value_t = defaults::SMOOTH_LENGTH, value_parser = crate::bounds::real(qcshape::limits::MAX_SMOOTH_LENGTH), allow_negative_numbers = true)]
    pub smooth_length: f64,
}

impl SmoothArgs {
    /// `--smooth N` Taubin iterations if given, else the length filter.
    pub fn smoothing(&self) -> Smoothing {
        self.smooth
            .map_or(Smoothing::Length(self.smooth_length), Smoothing::Iterations)
    }
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
