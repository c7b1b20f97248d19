//! Options shared by every command that measures lengths: the metric with its variants, the
//! geodesic solver, and the whole pipeline of a similarity run ([`PipelineArgs`]). Each flag's
//! help, default, range and choices come from its declaration in [`qcshape::settings`] (`S::X`
//! below); the values are validated by the library, once.

use anyhow::{bail, Context, Result};
use clap::builder::{PossibleValue, StringValueParser, TypedValueParser};
use qcshape::align::Alignment;
use qcshape::dataset::Dataset;
use qcshape::geodesic::{Gauge, GeodesicOptions, Solver};
use qcshape::metric::{
    ConformalForm, L2Areas, MetricKind, MetricScale, MetricSpec, QcNormalize, QcScaling, QcWeights,
};
use qcshape::settings::{self as S, Named, Setting, Value};
use qcshape::similarity::{Approx, PipelineOptions, Smoothing};
use qcshape::transport::Transport;

/// The value parser of the real setting `s` (its range from the declaration).
pub(crate) fn real(s: &Setting) -> crate::bounds::Real {
    match s.value {
        Value::Real { max } => crate::bounds::real(max),
        _ => panic!("--{} is not a real setting", s.key),
    }
}

/// The value parser of the whole-number setting `s` (its range from the declaration).
pub(crate) fn count(s: &Setting) -> crate::bounds::Count<usize> {
    match s.value {
        Value::Count { min, max } => crate::bounds::count::<usize>(min as u64, max as u64),
        _ => panic!("--{} is not a count setting", s.key),
    }
}

/// The value parser of a choice setting: the library's `FromStr` (aliases included), its
/// names ([`Named`]) as the possible values.
#[derive(Clone)]
pub(crate) struct Choice<T>(std::marker::PhantomData<T>);

/// [`Choice`] for `T`.
pub(crate) fn choice<T>() -> Choice<T> {
    Choice(std::marker::PhantomData)
}

impl<T> TypedValueParser for Choice<T>
where
    T: Named + std::str::FromStr + Clone + Send + Sync,
    T::Err: Into<Box<dyn std::error::Error + Send + Sync + 'static>>,
{
    type Value = T;
    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<T, clap::Error> {
        StringValueParser::new()
            .try_map(|v| v.parse::<T>())
            .parse_ref(cmd, arg, value)
    }
    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(T::ALL.iter().map(|v| PossibleValue::new(v.name()))))
    }
}

/// The names of `kinds`, comma-separated, as the default value of a list of metrics
/// (`--metrics`): clap takes a `&'static str`, so the text is kept for the program's life (one
/// per list, built once with the command line).
pub(crate) fn metric_list(kinds: &[MetricKind]) -> &'static str {
    Box::leak(MetricKind::list(kinds).into_boxed_str())
}

/// The metric (docs/method.md "Metrics") and its variants.
#[derive(Debug, Clone, clap::Args)]
pub struct MetricArgs {
    #[arg(long, help = S::METRIC.help(), default_value = S::METRIC.default_text(), value_parser = choice::<MetricKind>())]
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
    #[arg(long, help = S::FORM.help(), default_value = S::FORM.default_text(), value_parser = choice::<ConformalForm>())]
    pub form: ConformalForm,
    #[arg(long, help = S::WEIGHTS.help(), default_value = S::WEIGHTS.default_text(), value_parser = choice::<QcWeights>())]
    pub weights: QcWeights,
    #[arg(long, help = S::LAMBDA.help(), default_value = S::LAMBDA.default_text(), value_parser = real(&S::LAMBDA), allow_negative_numbers = true)]
    pub lambda: f64,
    #[arg(long, help = S::SCALE.help(), default_value = S::SCALE.default_text(), value_parser = choice::<MetricScale>())]
    pub scale: MetricScale,
    #[arg(long, help = S::STRETCH.help(), default_value = S::STRETCH.default_text(), value_parser = real(&S::STRETCH), allow_negative_numbers = true)]
    pub stretch: f64,
    #[arg(long, help = S::BENDING.help(), default_value = S::BENDING.default_text(), value_parser = real(&S::BENDING), allow_negative_numbers = true)]
    pub bending: f64,
    #[arg(long, help = S::QC_WEIGHTS.help(), default_value = S::QC_WEIGHTS.default_text(), value_parser = choice::<QcScaling>())]
    pub qc_weights: QcScaling,
    #[arg(long, help = S::QC_FLOOR.help(), default_value = S::QC_FLOOR.default_text(), value_parser = real(&S::QC_FLOOR), allow_negative_numbers = true)]
    pub qc_floor: f64,
    #[arg(long, help = S::QC_SMOOTH.help(), default_value = S::QC_SMOOTH.default_text(), value_parser = count(&S::QC_SMOOTH), allow_negative_numbers = true)]
    pub qc_smooth: usize,
    #[arg(long, help = S::L2_AREAS.help(), default_value = S::L2_AREAS.default_text(), value_parser = choice::<L2Areas>())]
    pub l2_areas: L2Areas,
}

impl VariantArgs {
    /// The specification of the metric `kind` with these variants, after checking the values.
    pub fn spec(&self, kind: MetricKind) -> Result<MetricSpec> {
        let spec = MetricSpec {
            kind,
            scale: self.scale,
            qc_normalize: (self.qc_weights == QcScaling::Rms).then_some(QcNormalize {
                floor: self.qc_floor,
                smooth: self.qc_smooth,
            }),
            form: self.form,
            weights: self.weights,
            lambda: self.lambda,
            frozen_areas: self.l2_areas == L2Areas::Frozen,
            stretch: self.stretch,
            bending: self.bending,
        };
        spec.validate().map_err(flag_error)?;
        if let Some(w) = spec.warning() {
            eprintln!("warning: {w}");
        }
        Ok(spec)
    }
}

/// The solver settings of every command that solves geodesics (`--solver`, `--gauge`,
/// `--tolerance`, `--energy-tolerance`): flattened into [`SolverArgs`] and into `interpolate`'s
/// arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct SolveArgs {
    #[arg(long, help = S::SOLVER.help(), default_value = S::SOLVER.default_text(), value_parser = choice::<Solver>())]
    pub solver: Solver,
    #[arg(long, help = S::GAUGE.help(), default_value = S::GAUGE.default_text(), value_parser = choice::<Gauge>())]
    pub gauge: Gauge,
    #[arg(long, help = S::TOLERANCE.help(), default_value = S::TOLERANCE.default_text(), value_parser = real(&S::TOLERANCE), allow_negative_numbers = true)]
    pub tolerance: f64,
    #[arg(long, help = S::ENERGY_TOLERANCE.help(), default_value = S::ENERGY_TOLERANCE.default_text(), value_parser = real(&S::ENERGY_TOLERANCE), allow_negative_numbers = true)]
    pub energy_tolerance: f64,
}

impl SolveArgs {
    /// `base` with these settings, and the progress lines' iteration monitor.
    pub fn apply(&self, base: GeodesicOptions) -> GeodesicOptions {
        GeodesicOptions {
            solver: self.solver,
            gauge: self.gauge,
            gradient_tolerance: self.tolerance,
            energy_tolerance: self.energy_tolerance,
            // Counts solver iterations for the progress lines.
            monitor: Some(crate::progress::monitor()),
            ..base
        }
    }
}

/// The discrete geodesic solver.
#[derive(Debug, Clone, clap::Args)]
pub struct SolverArgs {
    #[arg(long, help = S::STEPS.help(), default_value = S::STEPS.default_text(), value_parser = count(&S::STEPS), allow_negative_numbers = true)]
    pub steps: usize,
    #[command(flatten)]
    pub solve: SolveArgs,
    #[arg(long, help = S::LENGTH_TOLERANCE.help(), default_value = S::LENGTH_TOLERANCE.default_text(), value_parser = real(&S::LENGTH_TOLERANCE), allow_negative_numbers = true)]
    pub length_tolerance: f64,
}

impl SolverArgs {
    /// The geodesic options, after checking the values.
    pub fn options(&self) -> Result<GeodesicOptions> {
        let g = self.solve.apply(GeodesicOptions {
            steps: self.steps,
            length_tolerance: self.length_tolerance,
            ..Default::default()
        });
        g.validate().map_err(flag_error)?;
        Ok(g)
    }
}

/// A library validation error ([`qcshape::limits::LimitError`], naming a setting by its key)
/// with the setting spelled as its flag: `--lambda must be >= 0 ...`.
pub(crate) fn flag_error(e: qcshape::limits::LimitError) -> anyhow::Error {
    anyhow::Error::new(e.renamed(|key| format!("--{key}")))
}

/// Every setting of a similarity run, as the library declares them
/// ([`qcshape::settings::SETTINGS`]): the metric, the geodesic solver and the rest of the
/// pipeline of eq. 13. Every command that computes a similarity matrix from a data set takes
/// this one group (a test walks their `--help`).
#[derive(Debug, Clone, clap::Args)]
pub struct PipelineArgs {
    #[command(flatten)]
    pub metric: MetricArgs,
    #[command(flatten)]
    pub solver: SolverArgs,
    #[arg(long, help = S::INSERT.help(), default_value = S::INSERT.default_text(), value_parser = count(&S::INSERT), allow_negative_numbers = true)]
    pub insert: usize,
    #[arg(long, help = S::LEVELS.help(), default_value = S::LEVELS.default_text(), value_parser = count(&S::LEVELS), allow_negative_numbers = true)]
    pub levels: usize,
    #[arg(long, help = S::TRANSPORT.help(), default_value = S::TRANSPORT.default_text(), value_parser = choice::<Transport>())]
    pub transport: Transport,
    #[arg(long, help = S::ALIGN.help(), default_value = S::ALIGN.default_text(), value_parser = choice::<Alignment>())]
    pub align: Alignment,
    #[command(flatten)]
    pub smooth: SmoothArgs,
    #[arg(long, help = S::BASE.help())]
    pub base: Option<String>,
    #[arg(long, help = S::APPROX.help(), default_value = S::APPROX.default_text(), value_parser = choice::<Approx>())]
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
    #[arg(long, help = S::SMOOTH.help(), alias = "smoothing", conflicts_with = "smooth_length", value_parser = count(&S::SMOOTH), allow_negative_numbers = true)]
    pub smooth: Option<usize>,
    #[arg(long, help = S::SMOOTH_LENGTH.help(), default_value = S::SMOOTH_LENGTH.default_text(), value_parser = real(&S::SMOOTH_LENGTH), allow_negative_numbers = true)]
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
