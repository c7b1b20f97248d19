//! Keyword options -> library option structs. A keyword left out (None) keeps the library's
//! default ([`MetricSpec::new`], [`GeodesicOptions::default`], [`PipelineOptions::default`]),
//! so the Python results equal the CLI's.

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use qcshape::geodesic::{Gauge, GeodesicOptions, Solver};
use qcshape::metric::{L2Areas, MetricKind, MetricScale, MetricSpec, QcNormalize, QcScaling};
use qcshape::settings::{Id, Setting, Value};
use qcshape::similarity::{PipelineOptions, Smoothing};
use qcshape::transport::Transport;

/// The metric keywords (the CLI's `--metric --form --weights --lambda --l2-areas --scale
/// --stretch --qc-weights --qc-floor --qc-smooth`; `--scale` is `metric_scale`).
#[derive(Debug, Clone, Default)]
pub struct MetricKw {
    pub metric: Option<String>,
    pub form: Option<String>,
    pub weights: Option<String>,
    pub lam: Option<f64>,
    pub l2_areas: Option<String>,
    pub metric_scale: Option<String>,
    pub stretch: Option<f64>,
    pub bending: Option<f64>,
    pub qc_weights: Option<String>,
    pub qc_floor: Option<f64>,
    pub qc_smooth: Option<usize>,
}

impl MetricKw {
    /// The metric specification (default metric: the pipeline's, isometric).
    pub fn spec(&self) -> PyResult<MetricSpec> {
        let kind = match &self.metric {
            None => PipelineOptions::default().metric.kind,
            Some(m) => m
                .parse::<MetricKind>()
                .map_err(|e| PyValueError::new_err(format!("metric: {e}")))?,
        };
        let mut spec = MetricSpec::new(kind);
        if let Some(f) = &self.form {
            spec.form = f
                .parse()
                .map_err(|e| PyValueError::new_err(format!("form: {e}")))?;
        }
        if let Some(w) = &self.weights {
            spec.weights = w
                .parse()
                .map_err(|e| PyValueError::new_err(format!("weights: {e}")))?;
        }
        if let Some(l) = self.lam {
            spec.lambda = l;
        }
        if let Some(a) = &self.l2_areas {
            let a: L2Areas = a
                .parse()
                .map_err(|e| PyValueError::new_err(format!("l2_areas: {e}")))?;
            spec.frozen_areas = a == L2Areas::Frozen;
        }
        if let Some(s) = &self.metric_scale {
            spec.scale = s
                .parse::<MetricScale>()
                .map_err(|e| PyValueError::new_err(format!("metric_scale: {e}")))?;
        }
        if let Some(s) = self.stretch {
            spec.stretch = s;
        }
        if let Some(b) = self.bending {
            spec.bending = b;
        }
        let mut qc = spec.qc_normalize.unwrap_or(QcNormalize {
            floor: 0.0,
            smooth: 0,
        });
        if let Some(f) = self.qc_floor {
            qc.floor = f;
        }
        if let Some(n) = self.qc_smooth {
            qc.smooth = n;
        }
        let scaling = match self.qc_weights.as_deref() {
            None => None,
            Some(w) => Some(
                w.parse::<QcScaling>()
                    .map_err(|e| PyValueError::new_err(format!("qc_weights: {e}")))?,
            ),
        };
        spec.qc_normalize = match scaling {
            None if spec.qc_normalize.is_none() => None,
            None | Some(QcScaling::Rms) => Some(qc),
            Some(QcScaling::Raw) => None,
        };
        spec.validate().map_err(keyword_error)?;
        // The metric's own warning, once and in Python's words (`lam`, `stretch=`).
        Python::attach(|py| crate::warn::spec(py, &spec))?;
        Ok(spec)
    }
}

/// A library validation error ([`qcshape::limits::LimitError`], naming a setting by its key) as
/// a `ValueError` naming the Python keyword: `lam must be >= 0 ...`.
pub fn keyword_error(e: qcshape::limits::LimitError) -> PyErr {
    PyValueError::new_err(
        e.renamed(|k| qcshape::settings::python_name(k).to_string())
            .to_string(),
    )
}

/// The solver keywords (the CLI's `--steps --solver --gauge --tolerance --energy-tolerance
/// --length-tolerance`).
#[derive(Debug, Clone, Default)]
pub struct SolverKw {
    pub steps: Option<usize>,
    pub solver: Option<String>,
    pub gauge: Option<String>,
    pub tolerance: Option<f64>,
    pub energy_tolerance: Option<f64>,
    pub length_tolerance: Option<f64>,
}

impl SolverKw {
    /// The geodesic options.
    pub fn options(&self) -> PyResult<GeodesicOptions> {
        let mut g = GeodesicOptions::default();
        if let Some(s) = self.steps {
            g.steps = s;
        }
        if let Some(s) = &self.solver {
            g.solver = s
                .parse::<Solver>()
                .map_err(|e| PyValueError::new_err(format!("solver: {e}")))?;
        }
        if let Some(s) = &self.gauge {
            g.gauge = s
                .parse::<Gauge>()
                .map_err(|e| PyValueError::new_err(format!("gauge: {e}")))?;
        }
        if let Some(t) = self.tolerance {
            g.gradient_tolerance = t;
        }
        if let Some(t) = self.energy_tolerance {
            g.energy_tolerance = t;
        }
        if let Some(t) = self.length_tolerance {
            g.length_tolerance = t;
        }
        g.validate().map_err(keyword_error)?;
        Ok(g)
    }
}

/// A transport method by name (`parallel`, `schild`, `euclidean`); None: `default`.
pub fn transport(name: Option<&str>, default: Transport) -> PyResult<Transport> {
    match name {
        None => Ok(default),
        Some(n) => n
            .parse::<Transport>()
            .map_err(|e| PyValueError::new_err(format!("transport: {e}"))),
    }
}

/// Base deformation: by name or index.
#[derive(Debug, Clone)]
pub enum BaseKw {
    Index(usize),
    Name(String),
}

/// Everything `similarity_matrix` (and `KMeans.fit` on a data set) accepts.
#[derive(Debug, Clone, Default)]
pub struct PipelineKw {
    pub metric: MetricKw,
    pub solver: SolverKw,
    pub insert: Option<usize>,
    pub levels: Option<usize>,
    pub transport: Option<String>,
    pub align: Option<String>,
    pub smooth: Option<usize>,
    pub smooth_length: Option<f64>,
    pub base: Option<BaseKw>,
    pub threads: Option<usize>,
    /// `progress=`: None (auto), True, False or a callable (see `qcshape._progress`).
    pub progress: Option<std::sync::Arc<Py<PyAny>>>,
    pub approx: Option<String>,
}

/// The keywords of the pipeline (the library's settings table, then `threads` and
/// `progress`), for the error on an unknown one.
pub fn pipeline_keys() -> String {
    let mut keys: Vec<&str> = qcshape::settings::SETTINGS.iter().map(|s| s.python).collect();
    keys.extend(["threads", "progress"]);
    keys.join(", ")
}

impl PipelineKw {
    /// Reads the keywords of a `**kwargs` dict; an unknown keyword is a `TypeError`.
    pub fn from_kwargs(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut k = PipelineKw::default();
        let Some(d) = kwargs else {
            return Ok(k);
        };
        for (key, value) in d.iter() {
            let key: String = key.extract()?;
            if value.is_none() {
                continue;
            }
            if let Some(s) = qcshape::settings::by_python(&key) {
                k.set(s, &key, &value)?;
                continue;
            }
            let bad = |e: PyErr| PyValueError::new_err(format!("{key}: {e}"));
            match key.as_str() {
                "threads" => {
                    k.threads = Some(crate::convert::count(
                        "threads",
                        value.extract().map_err(bad)?,
                        1,
                        qcshape::limits::MAX_THREADS,
                    )?)
                }
                "progress" => {
                    if !(value.is_instance_of::<pyo3::types::PyBool>() || value.is_callable()) {
                        return Err(PyValueError::new_err(format!(
                            "progress: expected None (auto), True, False or a callable \
                             (stage, done, total), got {}",
                            value.repr()?
                        )));
                    }
                    k.progress = Some(std::sync::Arc::new(value.clone().unbind()))
                }
                _ => {
                    return Err(PyTypeError::new_err(format!(
                        "unexpected keyword argument '{key}' (accepted: {})",
                        pipeline_keys()
                    )))
                }
            }
        }
        Ok(k)
    }

    /// Sets the setting `s` from the keyword `key`'s value (the one place a Python value
    /// becomes a setting: an exhaustive `match` on [`Id`]).
    fn set(&mut self, s: &Setting, key: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let bad = |e: PyErr| PyValueError::new_err(format!("{key}: {e}"));
        let text = || value.extract::<String>().map_err(bad);
        let real = || value.extract::<f64>().map_err(bad);
        let count = || match s.value {
            Value::Count { min, max } => {
                crate::convert::count(s.python, value.extract().map_err(bad)?, min, max)
            }
            _ => unreachable!("--{} is a count", s.key),
        };
        match s.id {
            Id::Metric => self.metric.metric = Some(text()?),
            Id::Form => self.metric.form = Some(text()?),
            Id::Weights => self.metric.weights = Some(text()?),
            Id::Lambda => self.metric.lam = Some(real()?),
            Id::Scale => self.metric.metric_scale = Some(text()?),
            Id::Stretch => self.metric.stretch = Some(real()?),
            Id::Bending => self.metric.bending = Some(real()?),
            Id::QcWeights => self.metric.qc_weights = Some(text()?),
            Id::QcFloor => self.metric.qc_floor = Some(real()?),
            Id::QcSmooth => self.metric.qc_smooth = Some(count()?),
            Id::L2Areas => self.metric.l2_areas = Some(text()?),
            Id::Steps => self.solver.steps = Some(count()?),
            Id::Solver => self.solver.solver = Some(text()?),
            Id::Gauge => self.solver.gauge = Some(text()?),
            Id::Tolerance => self.solver.tolerance = Some(real()?),
            Id::EnergyTolerance => self.solver.energy_tolerance = Some(real()?),
            Id::LengthTolerance => self.solver.length_tolerance = Some(real()?),
            Id::Insert => self.insert = Some(count()?),
            Id::Levels => self.levels = Some(count()?),
            Id::Transport => self.transport = Some(text()?),
            Id::Align => self.align = Some(text()?),
            Id::Smooth => self.smooth = Some(count()?),
            Id::SmoothLength => self.smooth_length = Some(real()?),
            Id::Base => {
                self.base = Some(if let Ok(i) = value.extract::<usize>() {
                    BaseKw::Index(i)
                } else {
                    BaseKw::Name(text()?)
                })
            }
            Id::Approx => self.approx = Some(text()?),
        }
        Ok(())
    }

    /// The pipeline options for deformations named `names` (for a base given by name); every
    /// option without a keyword from [`PipelineOptions::default`].
    pub fn options(&self, names: &[String]) -> PyResult<PipelineOptions> {
        let d = PipelineOptions::default();
        let levels = self.levels.unwrap_or(d.levels);
        let base = match &self.base {
            None => d.base,
            Some(BaseKw::Index(i)) => {
                if *i >= names.len() {
                    return Err(PyValueError::new_err(format!(
                        "base: index {i} is out of range ({} deformations)",
                        names.len()
                    )));
                }
                *i
            }
            Some(BaseKw::Name(n)) => names.iter().position(|x| x == n).ok_or_else(|| {
                PyValueError::new_err(format!("base: {n:?} is not a deformation of the data set"))
            })?,
        };
        // `..d`: options added to the pipeline later (without a keyword here) keep their defaults.
        #[allow(clippy::needless_update)]
        let opts = PipelineOptions {
            metric: self.metric.spec()?,
            geodesic: self.solver.options()?,
            insert: self.insert.unwrap_or(d.insert),
            levels,
            transport: transport(self.transport.as_deref(), d.transport)?,
            align: match self.align.as_deref() {
                None => d.align,
                Some(a) => a
                    .parse::<qcshape::align::Alignment>()
                    .map_err(|e| PyValueError::new_err(format!("align: {e}")))?,
            },
            smoothing: match (self.smooth, self.smooth_length) {
                (Some(_), Some(_)) => {
                    return Err(PyValueError::new_err(
                        "smooth and smooth_length exclude each other: smooth=N is N Taubin iterations instead of the length filter",
                    ))
                }
                (Some(n), None) => Smoothing::Iterations(n),
                (None, Some(l)) => Smoothing::Length(l),
                (None, None) => d.smoothing,
            },
            base,
            approx: match self.approx.as_deref() {
                None => d.approx,
                Some(a) => a
                    .parse::<qcshape::similarity::Approx>()
                    .map_err(|e| PyValueError::new_err(format!("approx: {e}")))?,
            },
            ..d
        };
        opts.validate(names.len()).map_err(keyword_error)?;
        Ok(opts)
    }
}

/// settings() -> dict: every setting of a similarity run, from the library's one table (the
/// CLI's flags follow it too): ``{keyword: {"flag": "--lambda", "group": "metric" | "solver" |
/// "pipeline", "default": "0.01"}}``, the default as text as ``qcshape --help`` shows it (None:
/// no default value, e.g. ``base``, the first deformation). Keywords left out (or None) take
/// these defaults in ``similarity_matrix``, ``ShapeSpace`` and ``KMeans.fit``.
#[pyfunction]
pub fn settings(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    use qcshape::settings::SETTINGS;
    let out = PyDict::new(py);
    for s in SETTINGS {
        let d = PyDict::new(py);
        d.set_item("flag", format!("--{}", s.key))?;
        d.set_item("group", s.group.label())?;
        d.set_item("default", (s.default)())?;
        out.set_item(s.python, d)?;
    }
    Ok(out)
}
