//! The settings of a similarity run, declared once: every metric, solver and pipeline setting a
//! user can give, with its command-line flag (`--KEY`), its Python keyword, its help text, the
//! kind and range of its value and its default. Nothing else declares them:
//!
//! - the command line's flags take their help, default, value parser and choices from here
//!   (`crates/qcshape-cli/src/args.rs`, through the named constants such as [`LAMBDA`]);
//! - Python reads its keywords from [`SETTINGS`] ([`by_python`], an exhaustive `match` on
//!   [`Id`]), and its text signatures, the `.pyi` stub's option lists and docs/defaults.md's
//!   table are rendered from it ([`python_signature`], [`pyi_lines`], [`markdown_table`]) by
//!   `cargo run -p qcshape-cli --example gen-settings`;
//! - the validation errors ([`crate::limits::LimitError`]) name a setting by its key.
//!
//! `crates/qcshape-cli/tests/settings.rs` (`each_setting_is_declared_once`) fails if a second
//! declaration appears or a generated text differs. The values are held by [`MetricSpec`],
//! [`GeodesicOptions`] and [`PipelineOptions`], which validate them
//! ([`PipelineOptions::validate`]); the defaults are those structs' defaults.

use std::sync::OnceLock;

use crate::align::Alignment;
use crate::geodesic::{Gauge, GeodesicOptions, Solver};
use crate::limits::{
    MAX_INSERT, MAX_LAMBDA, MAX_LEVELS, MAX_SMOOTH_LENGTH, MAX_STEPS, MAX_SWEEPS, MAX_TOLERANCE,
};
use crate::metric::{ConformalForm, L2Areas, MetricKind, MetricScale, MetricSpec, QcScaling, QcWeights};
use crate::similarity::{Approx, PipelineOptions, Smoothing};
use crate::transport::Transport;

/// Which options struct a setting belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    /// The metric ([`MetricSpec`]): every command that measures a length takes these.
    Metric,
    /// The geodesic solver ([`GeodesicOptions`]): every command that solves a geodesic.
    Solver,
    /// The rest of the pipeline of eq. 13 ([`PipelineOptions`]): every command that computes
    /// a similarity matrix from a data set.
    Pipeline,
}

impl Group {
    /// `"metric"`, `"solver"` or `"pipeline"`.
    pub fn label(self) -> &'static str {
        match self {
            Group::Metric => "metric",
            Group::Solver => "solver",
            Group::Pipeline => "pipeline",
        }
    }
}

/// Which setting: front ends `match` on it exhaustively, so a new setting cannot be forgotten.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Id {
    /// `--metric`.
    Metric,
    /// `--form`.
    Form,
    /// `--weights`.
    Weights,
    /// `--lambda`.
    Lambda,
    /// `--scale`.
    Scale,
    /// `--stretch`.
    Stretch,
    /// `--bending`.
    Bending,
    /// `--qc-weights`.
    QcWeights,
    /// `--qc-floor`.
    QcFloor,
    /// `--qc-smooth`.
    QcSmooth,
    /// `--l2-areas`.
    L2Areas,
    /// `--steps`.
    Steps,
    /// `--solver`.
    Solver,
    /// `--gauge`.
    Gauge,
    /// `--tolerance`.
    Tolerance,
    /// `--energy-tolerance`.
    EnergyTolerance,
    /// `--length-tolerance`.
    LengthTolerance,
    /// `--insert`.
    Insert,
    /// `--levels`.
    Levels,
    /// `--transport`.
    Transport,
    /// `--align`.
    Align,
    /// `--smooth`.
    Smooth,
    /// `--smooth-length`.
    SmoothLength,
    /// `--base`.
    Base,
    /// `--approx`.
    Approx,
}

/// The kind and range of a setting's value.
#[derive(Debug, Clone, Copy)]
pub enum Value {
    /// One of named choices (an enum with [`Named`]; the names in `--help` order).
    Choice(fn() -> Vec<&'static str>),
    /// A real number in `[0, max]`.
    Real {
        /// The largest value accepted.
        max: f64,
    },
    /// A whole number in `[min, max]`.
    Count {
        /// The smallest value accepted.
        min: usize,
        /// The largest value accepted.
        max: usize,
    },
    /// A deformation's name (Python: also its index).
    Name,
}

/// One setting.
#[derive(Debug, Clone, Copy)]
pub struct Setting {
    /// Which setting.
    pub id: Id,
    /// The key: the command-line flag without its dashes (`lambda` for `--lambda`), the name
    /// validation errors use.
    pub key: &'static str,
    /// The Python keyword (`lam` for `--lambda`).
    pub python: &'static str,
    /// Another Python keyword accepted for it (`lambda_`).
    pub python_alias: Option<&'static str>,
    /// The options struct that holds it.
    pub group: Group,
    /// Its help text (`--help`, the `.pyi`, docs/defaults.md), without the range, which
    /// [`Setting::help`] appends (and, for `--metric`, without the metrics' names, which it
    /// appends from [`crate::metric::METRICS`]).
    pub about: &'static str,
    /// The kind and range of its value.
    pub value: Value,
    /// Its default, as the command line's `--help` shows it (`None`: no default value, e.g.
    /// the base is the first deformation).
    pub default: fn() -> Option<String>,
}

pub use crate::named::{parse_named, Named};

fn names<T: Named>() -> Vec<&'static str> {
    T::ALL.iter().map(|v| v.name()).collect()
}

macro_rules! named {
    ($t:ty: $($v:expr),+) => {
        impl Named for $t {
            const ALL: &'static [Self] = &[$($v),+];
            fn name(self) -> &'static str {
                self.label()
            }
        }
    };
}
named!(ConformalForm: ConformalForm::Quadratic, ConformalForm::Paper);
named!(QcWeights: QcWeights::Endpoints, QcWeights::Segment);
named!(MetricScale: MetricScale::Invariant, MetricScale::Calibrated, MetricScale::Raw);
named!(Gauge: Gauge::Linear, Gauge::Free);
named!(Solver: Solver::Preconditioned, Solver::HessianKronecker, Solver::PoseKronecker);
named!(Transport: Transport::Translate, Transport::Parallel, Transport::Schild);
named!(Alignment: Alignment::Rigid, Alignment::Similarity, Alignment::None);

impl QcScaling {
    /// `"rms"` or `"raw"`.
    pub fn label(self) -> &'static str {
        match self {
            QcScaling::Rms => "rms",
            QcScaling::Raw => "raw",
        }
    }
}
named!(QcScaling: QcScaling::Rms, QcScaling::Raw);

impl L2Areas {
    /// `"frozen"` or `"pose"`.
    pub fn label(self) -> &'static str {
        match self {
            L2Areas::Frozen => "frozen",
            L2Areas::Pose => "pose",
        }
    }
}
named!(L2Areas: L2Areas::Frozen, L2Areas::Pose);

impl Named for Approx {
    const ALL: &'static [Self] = &[Approx::Exact, Approx::Straight, Approx::Tangent];
    fn name(self) -> &'static str {
        match self {
            Approx::Exact => "exact",
            Approx::Straight => "straight",
            Approx::Tangent => "tangent",
        }
    }
}

fn metric() -> MetricSpec {
    PipelineOptions::default().metric
}

fn solver() -> GeodesicOptions {
    GeodesicOptions::default()
}

fn pipeline() -> PipelineOptions {
    PipelineOptions::default()
}

const fn real(max: f64) -> Value {
    Value::Real { max }
}

const fn count(min: usize, max: usize) -> Value {
    Value::Count { min, max }
}

/// `--metric`.
pub const METRIC: Setting = Setting {
    id: Id::Metric,
    key: "metric",
    python: "metric",
    python_alias: None,
    group: Group::Metric,
    // `Setting::help` appends the names, from the registry (`crate::metric::METRICS`).
    about: "Metric",
    value: Value::Choice(names::<MetricKind>),
    default: || Some(metric().kind.label().to_string()),
};

/// `--form`.
pub const FORM: Setting = Setting {
    id: Id::Form,
    key: "form",
    python: "form",
    python_alias: None,
    group: Group::Metric,
    about: "Conformal triangle term: quadratic (T_p^2 + T_q^2 + T_r^2) or paper ((|T_p|+|T_q|+|T_r|)^2)",
    value: Value::Choice(names::<ConformalForm>),
    default: || Some(metric().form.label().to_string()),
};

/// `--weights`.
pub const WEIGHTS: Setting = Setting {
    id: Id::Weights,
    key: "weights",
    python: "weights",
    python_alias: None,
    group: Group::Metric,
    about: "Quasi-conformal curvature-change weights: endpoints (frozen K(B) - K(A)) or segment",
    value: Value::Choice(names::<QcWeights>),
    default: || Some(metric().weights.label().to_string()),
};

/// `--lambda` (Python `lam`).
pub const LAMBDA: Setting = Setting {
    id: Id::Lambda,
    key: "lambda",
    python: "lam",
    python_alias: Some("lambda_"),
    group: Group::Metric,
    about: "Weight of the L2 regularizer (eq. 11); 0 disables it. On the invariant scale (the default) \
            and the calibrated scale a ratio of two dimensionless terms; on the raw scale the previous \
            releases' weight (their default was 0.1)",
    value: real(MAX_LAMBDA),
    default: || Some(metric().lambda.to_string()),
};

/// `--scale` (Python `metric_scale`).
pub const SCALE: Setting = Setting {
    id: Id::Scale,
    key: "scale",
    python: "metric_scale",
    python_alias: None,
    group: Group::Metric,
    about: "How the metric's terms are scaled: invariant (every term a relative rate weighted by its \
            face's area share: scaling a pose and its motion together changes nothing, so geodesics do \
            not shrink the shape; the conformal terms as eq. 6), calibrated (eq. 3's and eq. 7's sums \
            divided by their scale at the reference pose: the 2026-12-04 releases') or raw (the paper's \
            sums in mean-edge units, the releases before)",
    value: Value::Choice(names::<MetricScale>),
    default: || Some(metric().scale.label().to_string()),
};

/// `--stretch`.
pub const STRETCH: Setting = Setting {
    id: Id::Stretch,
    key: "stretch",
    python: "stretch",
    python_alias: None,
    group: Group::Metric,
    about: "Weight of the stretch term of the conformal and quasi-conformal metrics on the invariant \
            scale: the relative rate of change of each face's area, which the conformal terms leave free \
            (uniform scaling); 0 disables it",
    value: real(MAX_LAMBDA),
    default: || Some(metric().stretch.to_string()),
};

/// `--bending`.
pub const BENDING: Setting = Setting {
    id: Id::Bending,
    key: "bending",
    python: "bending",
    python_alias: None,
    group: Group::Metric,
    about: "Weight of the bending term of the isometric, conformal and quasi-conformal metrics on the \
            invariant scale: the change of the dihedral angles along the path (the discrete shells' bending \
            energy), which charges the vertex-scale normal wrinkles that the membrane terms leave almost free; 0 disables it",
    value: real(MAX_LAMBDA),
    default: || Some(metric().bending.to_string()),
};

/// `--qc-weights`.
pub const QC_WEIGHTS: Setting = Setting {
    id: Id::QcWeights,
    key: "qc-weights",
    python: "qc_weights",
    python_alias: None,
    group: Group::Metric,
    about: "Quasi-conformal endpoint weights: rms (the curvature-change density over its RMS, with \
            --qc-floor) or raw (the paper's angle-defect change in radians)",
    value: Value::Choice(names::<QcScaling>),
    default: || {
        let q = if metric().qc_normalize.is_some() {
            QcScaling::Rms
        } else {
            QcScaling::Raw
        };
        Some(q.label().to_string())
    },
};

/// `--qc-floor`.
pub const QC_FLOOR: Setting = Setting {
    id: Id::QcFloor,
    key: "qc-floor",
    python: "qc_floor",
    python_alias: None,
    group: Group::Metric,
    about: "Floor of the rms quasi-conformal weights, sqrt(floor^2 + w^2): no vertex moves for free",
    value: real(MAX_LAMBDA),
    default: || Some(metric().qc_normalize.map_or(0.0, |q| q.floor).to_string()),
};

/// `--qc-smooth`.
pub const QC_SMOOTH: Setting = Setting {
    id: Id::QcSmooth,
    key: "qc-smooth",
    python: "qc_smooth",
    python_alias: None,
    group: Group::Metric,
    about: "One-ring smoothing passes of the curvature-change density before the rms weights",
    value: count(0, MAX_SWEEPS),
    default: || Some(metric().qc_normalize.map_or(0, |q| q.smooth).to_string()),
};

/// `--l2-areas`.
pub const L2_AREAS: Setting = Setting {
    id: Id::L2Areas,
    key: "l2-areas",
    python: "l2_areas",
    python_alias: None,
    group: Group::Metric,
    about: "L2 area weights: frozen at the path's ends, or taken from each pose (degenerates, see docs)",
    value: Value::Choice(names::<L2Areas>),
    default: || {
        let a = if metric().frozen_areas {
            L2Areas::Frozen
        } else {
            L2Areas::Pose
        };
        Some(a.label().to_string())
    },
};

/// `--steps`.
pub const STEPS: Setting = Setting {
    id: Id::Steps,
    key: "steps",
    python: "steps",
    python_alias: None,
    group: Group::Solver,
    about: "Number of path segments N of each geodesic",
    value: count(1, MAX_STEPS),
    default: || Some(solver().steps.to_string()),
};

/// `--solver`.
pub const SOLVER: Setting = Setting {
    id: Id::Solver,
    key: "solver",
    python: "solver",
    python_alias: None,
    group: Group::Solver,
    about: "Optimizer, L-BFGS preconditioned by a model of the Hessian: preconditioned (the \
            path's Kronecker and vertex-block model of J^T J), hessian-kronecker (the same model \
            fitted to the exact Hessian: fewer iterations without the bending term on fine \
            meshes), pose-kronecker (each pose's own spatial block: converges where the default \
            stalls on the calibrated scale at small --lambda, each iteration about twice as \
            costly)",
    value: Value::Choice(names::<Solver>),
    default: || Some(solver().solver.label().to_string()),
};

/// `--gauge`.
pub const GAUGE: Setting = Setting {
    id: Id::Gauge,
    key: "gauge",
    python: "gauge",
    python_alias: None,
    group: Group::Solver,
    about: "Rigid placement of the geodesic's interior poses, which the path energy barely charges: \
            linear (each keeps the rigid placement of the linear interpolation of the ends, to first \
            order: no solver-dependent turn of the middle poses; applied by every solver) or free (wherever the solver stops, the releases before 2026-12-07)",
    value: Value::Choice(names::<Gauge>),
    default: || Some(solver().gauge.label().to_string()),
};

/// `--tolerance`.
pub const TOLERANCE: Setting = Setting {
    id: Id::Tolerance,
    key: "tolerance",
    python: "tolerance",
    python_alias: None,
    group: Group::Solver,
    about: "Relative gradient tolerance: converged when the gradient norm falls below this fraction of \
            its value at the start",
    value: real(MAX_TOLERANCE),
    default: || Some(solver().gradient_tolerance.to_string()),
};

/// `--energy-tolerance`.
pub const ENERGY_TOLERANCE: Setting = Setting {
    id: Id::EnergyTolerance,
    key: "energy-tolerance",
    python: "energy_tolerance",
    python_alias: None,
    group: Group::Solver,
    about: "Relative energy tolerance: also converged when an accepted step lowers the path energy by \
            less than this fraction. On flat energies (conformal, isometric on fine meshes) this test \
            stops first, with the energy converged but the gradient above --tolerance; 0 disables it, so \
            that the gradient test decides (more iterations)",
    value: real(MAX_TOLERANCE),
    default: || Some(solver().energy_tolerance.to_string()),
};

/// `--length-tolerance`.
pub const LENGTH_TOLERANCE: Setting = Setting {
    id: Id::LengthTolerance,
    key: "length-tolerance",
    python: "length_tolerance",
    python_alias: None,
    group: Group::Solver,
    about: "Relative length tolerance of the distances (similarity matrices, the intrinsic k-means \
            assignment): also converged when two consecutive steps each change a geodesic's length by \
            less than this fraction. The length settles long before the path; 0 disables the test \
            (every distance solved to --tolerance / --energy-tolerance, slower). Paths (interpolation, \
            transfer, means) never use it",
    value: real(MAX_TOLERANCE),
    default: || Some(solver().length_tolerance.to_string()),
};

/// `--insert`.
pub const INSERT: Setting = Setting {
    id: Id::Insert,
    key: "insert",
    python: "insert",
    python_alias: None,
    group: Group::Pipeline,
    about: "Poses inserted between consecutive key poses before comparing (section 2.2.1)",
    value: count(0, MAX_INSERT),
    default: || Some(pipeline().insert.to_string()),
};

/// `--levels`.
pub const LEVELS: Setting = Setting {
    id: Id::Levels,
    key: "levels",
    python: "levels",
    python_alias: None,
    group: Group::Pipeline,
    about: "Spatial levels of the interpolation (1 = single level, the measured fastest)",
    value: count(1, MAX_LEVELS),
    default: || Some(pipeline().levels.to_string()),
};

/// `--transport`.
pub const TRANSPORT: Setting = Setting {
    id: Id::Transport,
    key: "transport",
    python: "transport",
    python_alias: None,
    group: Group::Pipeline,
    about: "Transport to the common base: euclidean (the default: it gave the lower transfer error and \
            the better classification in the measurements, docs/log/results.md), parallel (the paper's) \
            or schild",
    value: Value::Choice(names::<Transport>),
    default: || Some(pipeline().transport.label().to_string()),
};

/// `--align`.
pub const ALIGN: Setting = Setting {
    id: Id::Align,
    key: "align",
    python: "align",
    python_alias: None,
    group: Group::Pipeline,
    about: "Placement of each deformation on the base before transfer: rigid (the default: \
            area-weighted Procrustes of its first pose onto the base, the same motion for all its \
            poses), similarity (also a uniform scale) or none (the paper's pipeline)",
    value: Value::Choice(names::<Alignment>),
    default: || Some(pipeline().align.label().to_string()),
};

/// `--smooth`: Taubin iterations, an override of the length filter, so no default of its own.
pub const SMOOTH: Setting = Setting {
    id: Id::Smooth,
    key: "smooth",
    python: "smooth",
    python_alias: None,
    group: Group::Pipeline,
    about: "Taubin smoothing iterations of every pose before comparing, instead of the length filter \
            (a filter in mesh units: it smooths a quarter as much of the surface per subdivision; the \
            default before --smooth-length was 10; 0 = no smoothing, the paper's pipeline)",
    value: count(0, MAX_SWEEPS),
    default: || match pipeline().smoothing {
        Smoothing::Iterations(n) => Some(n.to_string()),
        Smoothing::Length(_) => None,
    },
};

/// `--smooth-length`.
pub const SMOOTH_LENGTH: Setting = Setting {
    id: Id::SmoothLength,
    key: "smooth-length",
    python: "smooth_length",
    python_alias: None,
    group: Group::Pipeline,
    about: "Smoothing length L of every pose before comparing, relative to the area radius R = \
            sqrt(area / 4 pi) of the base's first pose: a low-pass filter that takes vertex noise out of \
            real data, the same at every mesh resolution (a wave of wavenumber w keeps exp(-(w L R)^4) \
            of its amplitude; 0 = none; docs/robustness.md)",
    value: real(MAX_SMOOTH_LENGTH),
    default: || match pipeline().smoothing {
        Smoothing::Length(l) => Some(l.to_string()),
        Smoothing::Iterations(_) => None,
    },
};

/// `--base`.
pub const BASE: Setting = Setting {
    id: Id::Base,
    key: "base",
    python: "base",
    python_alias: None,
    group: Group::Pipeline,
    about: "Name of the reference deformation whose first pose is the common base (default: the first)",
    value: Value::Name,
    default: || None,
};

/// `--approx`.
pub const APPROX: Setting = Setting {
    id: Id::Approx,
    key: "approx",
    python: "approx",
    python_alias: None,
    group: Group::Pipeline,
    about: "Pose distances: exact (geodesic lengths, the paper's), straight (the straight-path length \
            with the same steps, no optimization: an upper bound, about 20-100x cheaper) or tangent (the \
            metric linearized at the common base: one feature vector per pose, then Euclidean distances; \
            quasi-conformal weighs each pair by its curvature-change weights). Errors against exact: \
            docs/scale.md. Interpolation and transfer stay exact",
    value: Value::Choice(names::<Approx>),
    default: || Some(Named::name(pipeline().approx).to_string()),
};

/// Every setting, in the order of the command line's `--help`.
pub const SETTINGS: &[Setting] = &[
    METRIC,
    FORM,
    WEIGHTS,
    LAMBDA,
    SCALE,
    STRETCH,
    BENDING,
    QC_WEIGHTS,
    QC_FLOOR,
    QC_SMOOTH,
    L2_AREAS,
    STEPS,
    SOLVER,
    GAUGE,
    TOLERANCE,
    ENERGY_TOLERANCE,
    LENGTH_TOLERANCE,
    INSERT,
    LEVELS,
    TRANSPORT,
    ALIGN,
    SMOOTH,
    SMOOTH_LENGTH,
    BASE,
    APPROX,
];

/// Texts computed once per setting and kept for the program's life (clap takes `&'static str`).
struct Texts {
    default: Option<&'static str>,
    help: &'static str,
}

fn texts(id: Id) -> &'static Texts {
    static TEXTS: OnceLock<Vec<Texts>> = OnceLock::new();
    let all = TEXTS.get_or_init(|| {
        SETTINGS
            .iter()
            .map(|s| Texts {
                default: (s.default)().map(|d| &*Box::leak(d.into_boxed_str())),
                help: Box::leak(s.help_text().into_boxed_str()),
            })
            .collect()
    });
    let i = SETTINGS
        .iter()
        .position(|s| s.id == id)
        .expect("every Id is in SETTINGS");
    &all[i]
}

/// `n` with thousands separators (`10,000`).
fn grouped(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

impl Setting {
    /// The default as text (`None`: no default), kept for the program's life.
    pub fn default_text(&self) -> Option<&'static str> {
        texts(self.id).default
    }

    /// The help text: [`Setting::about`] and the range (`At most 1e6`).
    pub fn help(&self) -> &'static str {
        texts(self.id).help
    }

    fn help_text(&self) -> String {
        match self.value {
            Value::Real { max } if max >= 1e4 => format!("{}. At most {max:e}", self.about),
            Value::Real { max } => format!("{}. At most {max}", self.about),
            Value::Count { max, .. } => format!("{}. At most {}", self.about, grouped(max)),
            // The metrics' names come from their registry, not from a list in the text.
            Value::Choice(_) if self.id == Id::Metric => {
                format!("{}: {}", self.about, self.choices().join(", "))
            }
            Value::Choice(_) | Value::Name => self.about.to_string(),
        }
    }

    /// The names of a choice setting's values (empty for the others).
    pub fn choices(&self) -> Vec<&'static str> {
        match self.value {
            Value::Choice(f) => f(),
            _ => Vec::new(),
        }
    }

    /// The default as a Python literal (`'isometric'`, `0.01`, `8`, `None`).
    pub fn python_default(&self) -> String {
        match ((self.default)(), self.value) {
            (None, _) => "None".to_string(),
            (Some(d), Value::Choice(_) | Value::Name) => format!("'{d}'"),
            (Some(d), Value::Real { .. }) => {
                let x: f64 = d.parse().expect("a real default");
                format!("{x:?}")
            }
            (Some(d), Value::Count { .. }) => d,
        }
    }

    /// The `.pyi` type of the keyword.
    pub fn python_type(&self) -> &'static str {
        match self.value {
            Value::Choice(_) => "Optional[str]",
            Value::Real { .. } => "Optional[float]",
            Value::Count { .. } => "Optional[int]",
            Value::Name => "Optional[Union[int, str]]",
        }
    }
}

/// The setting with command-line key `key`.
pub fn by_key(key: &str) -> Option<&'static Setting> {
    SETTINGS.iter().find(|s| s.key == key)
}

/// The setting with Python keyword `keyword` (or its alias).
pub fn by_python(keyword: &str) -> Option<&'static Setting> {
    SETTINGS
        .iter()
        .find(|s| s.python == keyword || s.python_alias == Some(keyword))
}

/// The Python keyword of the setting with key `key` (`key` itself for a name outside the
/// table).
pub fn python_name(key: &str) -> &str {
    by_key(key).map_or(key, |s| s.python)
}

/// The settings of the groups `groups`, in table order.
pub fn of_groups(groups: &[Group]) -> impl Iterator<Item = &'static Setting> + '_ {
    SETTINGS.iter().filter(move |s| groups.contains(&s.group))
}

/// The keywords of the settings of `groups` with their defaults, as a Python text signature
/// lists them: `metric='isometric', form='quadratic', lam=0.01, ...`.
pub fn python_signature(groups: &[Group]) -> String {
    of_groups(groups)
        .map(|s| format!("{}={}", s.python, s.python_default()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The `.pyi` lines of the settings of `groups`, indented by `indent`: `name: type` entries of
/// a `TypedDict` (`as_parameters` false) or `name: type = None,` keyword parameters, each with
/// its choices and default as a comment.
pub fn pyi_lines(groups: &[Group], indent: &str, as_parameters: bool) -> Vec<String> {
    of_groups(groups)
        .map(|s| {
            let mut note = s.choices().join(" | ");
            if let Some(d) = s.default_text() {
                if !note.is_empty() {
                    note.push_str("; ");
                }
                note.push_str(&format!("default {d}"));
            }
            let entry = if as_parameters {
                format!("{indent}{}: {} = None,", s.python, s.python_type())
            } else {
                format!("{indent}{}: {}", s.python, s.python_type())
            };
            if note.is_empty() {
                entry
            } else {
                format!("{entry}  # {note}")
            }
        })
        .collect()
}

/// docs/defaults.md's table of every setting: flag, Python keyword, default and help.
pub fn markdown_table() -> String {
    let mut out = String::from("| Flag | Python | Default | Meaning |\n|---|---|---|---|\n");
    for s in SETTINGS {
        let default = s
            .default_text()
            .map_or("(none)".to_string(), |d| format!("`{d}`"));
        let help = s.help().replace('|', "\\|");
        out.push_str(&format!(
            "| `--{}` | `{}` | {default} | {help} |\n",
            s.key, s.python
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_and_keywords_are_unique_and_defaults_validate() {
        let mut keys: Vec<&str> = SETTINGS.iter().map(|s| s.key).collect();
        let mut py: Vec<&str> = SETTINGS.iter().map(|s| s.python).collect();
        keys.sort_unstable();
        py.sort_unstable();
        keys.dedup();
        py.dedup();
        assert_eq!(keys.len(), SETTINGS.len());
        assert_eq!(py.len(), SETTINGS.len());
        assert_eq!(python_name("lambda"), "lam");
        assert_eq!((by_key("steps").unwrap().default)().as_deref(), Some("8"));
        assert_eq!(
            (by_key("metric").unwrap().default)().as_deref(),
            Some("isometric")
        );
        assert_eq!((by_key("smooth").unwrap().default)(), None);
        assert_eq!(
            (by_key("smooth-length").unwrap().default)().as_deref(),
            Some("0.18")
        );
        PipelineOptions::default().validate(1).unwrap();
    }

    /// The metric registry names settings by their keys: each is a metric setting of the table.
    #[test]
    fn the_metric_registry_names_settings_of_the_table() {
        use crate::metric::{Weight, METRICS};
        for m in METRICS {
            for key in m.settings {
                let s = by_key(key).unwrap_or_else(|| panic!("{}: {key}", m.name));
                assert_eq!(s.group, Group::Metric, "{}: {key}", m.name);
            }
            for t in m.terms {
                if let Weight::Setting(key) = t.weight {
                    assert!(by_key(key).is_some(), "{}: {key}", m.name);
                }
            }
        }
        assert_eq!(METRIC.choices(), MetricKind::ALL.map(|k| k.label()));
    }

    #[test]
    fn every_validation_error_names_a_setting_of_the_table() {
        let mut o = PipelineOptions::default();
        o.metric.lambda = -1.0;
        let e = o.validate(3).unwrap_err();
        assert_eq!(e.what(), "lambda");
        let mut o = PipelineOptions::default();
        o.geodesic.steps = 0;
        assert_eq!(o.validate(3).unwrap_err().what(), "steps");
        o = PipelineOptions::default();
        o.geodesic.length_tolerance = f64::NAN;
        assert_eq!(o.validate(3).unwrap_err().what(), "length-tolerance");
        o = PipelineOptions::default();
        o.levels = 0;
        assert_eq!(o.validate(3).unwrap_err().what(), "levels");
        o = PipelineOptions::default();
        o.base = 3;
        assert!(o.validate(3).unwrap_err().what().starts_with("base"));
        o = PipelineOptions::default();
        o.metric.qc_normalize = Some(crate::metric::QcNormalize {
            floor: -0.5,
            smooth: 0,
        });
        let e = o.validate(3).unwrap_err();
        assert_eq!(e.what(), "qc-floor");
        assert!(by_key(e.what()).is_some());
        let renamed = e.renamed(|k| python_name(k).to_string());
        assert!(
            renamed.to_string().starts_with("qc_floor must be >= 0"),
            "{renamed}"
        );
        for bad in [-0.1, f64::NAN, f64::INFINITY, 11.0] {
            o = PipelineOptions::default();
            o.smoothing = Smoothing::Length(bad);
            let e = o.validate(3).unwrap_err();
            assert_eq!(e.what(), "smooth-length");
            assert_eq!(python_name(e.what()), "smooth_length");
        }
        o = PipelineOptions::default();
        o.smoothing = Smoothing::Iterations(1_001);
        assert_eq!(o.validate(3).unwrap_err().what(), "smooth");
        o = PipelineOptions::default();
        o.metric.stretch = -0.5;
        let e = o.validate(3).unwrap_err();
        assert_eq!(e.what(), "stretch");
        assert_eq!(python_name(e.what()), "stretch");
    }
}
