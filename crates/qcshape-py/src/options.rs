//! Keyword options -> library option structs. A keyword left out (None) keeps the library's
//! default ([`MetricSpec::new`], [`GeodesicOptions::default`], [`PipelineOptions::default`]),
//! so the Python results equal the CLI's.

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use qcshape::geodesic::{GeodesicOptions, Solver};
use qcshape::metric::{ConformalForm, MetricKind, MetricScale, MetricSpec, QcNormalize, QcWeights};
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
            spec.form = match f.as_str() {
                "quadratic" => ConformalForm::Quadratic,
                "paper" => ConformalForm::Paper,
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "form: expected 'quadratic' or 'paper', got {f:?}"
                    )))
                }
            };
        }
        if let Some(w) = &self.weights {
            spec.weights = match w.as_str() {
                "endpoints" => QcWeights::Endpoints,
                "segment" => QcWeights::Segment,
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "weights: expected 'endpoints' or 'segment', got {w:?}"
                    )))
                }
            };
        }
        if let Some(l) = self.lam {
            spec.lambda = l;
        }
        if let Some(a) = &self.l2_areas {
            spec.frozen_areas = match a.as_str() {
                "frozen" => true,
                "pose" => false,
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "l2_areas: expected 'frozen' or 'pose', got {a:?}"
                    )))
                }
            };
        }
        if let Some(s) = &self.metric_scale {
            spec.scale = s
                .parse::<MetricScale>()
                .map_err(|e| PyValueError::new_err(format!("metric_scale: {e}")))?;
        }
        if let Some(s) = self.stretch {
            spec.stretch = s;
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
        spec.qc_normalize = match self.qc_weights.as_deref() {
            None if spec.qc_normalize.is_none() => None,
            None | Some("rms") => Some(qc),
            Some("raw") => None,
            Some(w) => {
                return Err(PyValueError::new_err(format!(
                    "qc_weights: expected 'rms' or 'raw', got {w:?}"
                )))
            }
        };
        spec.validate().map_err(keyword_error)?;
        if let Some(w) = spec.warning() {
            Python::attach(|py| {
                PyErr::warn(
                    py,
                    &py.get_type::<pyo3::exceptions::PyUserWarning>(),
                    &std::ffi::CString::new(w).unwrap_or_default(),
                    2,
                )
            })?;
        }
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

/// The solver keywords (the CLI's `--steps --solver --tolerance --energy-tolerance
/// --length-tolerance`).
#[derive(Debug, Clone, Default)]
pub struct SolverKw {
    pub steps: Option<usize>,
    pub solver: Option<String>,
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
    pub progress: Option<bool>,
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
            let bad = |e: PyErr| PyValueError::new_err(format!("{key}: {e}"));
            match key.as_str() {
                "metric" => k.metric.metric = Some(value.extract().map_err(bad)?),
                "form" => k.metric.form = Some(value.extract().map_err(bad)?),
                "weights" => k.metric.weights = Some(value.extract().map_err(bad)?),
                "lam" | "lambda_" => k.metric.lam = Some(value.extract().map_err(bad)?),
                "l2_areas" => k.metric.l2_areas = Some(value.extract().map_err(bad)?),
                "metric_scale" => k.metric.metric_scale = Some(value.extract().map_err(bad)?),
                "stretch" => k.metric.stretch = Some(value.extract().map_err(bad)?),
                "qc_weights" => k.metric.qc_weights = Some(value.extract().map_err(bad)?),
                "qc_floor" => k.metric.qc_floor = Some(value.extract().map_err(bad)?),
                "qc_smooth" => {
                    k.metric.qc_smooth = Some(crate::convert::count(
                        "qc_smooth",
                        value.extract().map_err(bad)?,
                        0,
                        qcshape::limits::MAX_SWEEPS,
                    )?)
                }
                "steps" => {
                    k.solver.steps = Some(crate::convert::count(
                        "steps",
                        value.extract().map_err(bad)?,
                        1,
                        qcshape::limits::MAX_STEPS,
                    )?)
                }
                "solver" => k.solver.solver = Some(value.extract().map_err(bad)?),
                "tolerance" => k.solver.tolerance = Some(value.extract().map_err(bad)?),
                "energy_tolerance" => k.solver.energy_tolerance = Some(value.extract().map_err(bad)?),
                "length_tolerance" => k.solver.length_tolerance = Some(value.extract().map_err(bad)?),
                "insert" => {
                    k.insert = Some(crate::convert::count(
                        "insert",
                        value.extract().map_err(bad)?,
                        0,
                        qcshape::limits::MAX_INSERT,
                    )?)
                }
                "levels" => {
                    k.levels = Some(crate::convert::count(
                        "levels",
                        value.extract().map_err(bad)?,
                        1,
                        qcshape::limits::MAX_LEVELS,
                    )?)
                }
                "transport" => k.transport = Some(value.extract().map_err(bad)?),
                "align" => k.align = Some(value.extract().map_err(bad)?),
                "smooth" => {
                    k.smooth = Some(crate::convert::count(
                        "smooth",
                        value.extract().map_err(bad)?,
                        0,
                        qcshape::limits::MAX_SWEEPS,
                    )?)
                }
                "smooth_length" => k.smooth_length = Some(value.extract().map_err(bad)?),
                "base" => {
                    k.base = Some(if let Ok(i) = value.extract::<usize>() {
                        BaseKw::Index(i)
                    } else {
                        BaseKw::Name(value.extract().map_err(bad)?)
                    })
                }
                "threads" => {
                    k.threads = Some(crate::convert::count(
                        "threads",
                        value.extract().map_err(bad)?,
                        1,
                        qcshape::limits::MAX_THREADS,
                    )?)
                }
                "progress" => k.progress = value.extract().map_err(bad)?,
                "approx" => k.approx = Some(value.extract().map_err(bad)?),
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
    use qcshape::settings::{Group, SETTINGS};
    let out = PyDict::new(py);
    for s in SETTINGS {
        let d = PyDict::new(py);
        d.set_item("flag", format!("--{}", s.key))?;
        d.set_item(
            "group",
            match s.group {
                Group::Metric => "metric",
                Group::Solver => "solver",
                Group::Pipeline => "pipeline",
            },
        )?;
        d.set_item("default", (s.default)())?;
        out.set_item(s.python, d)?;
    }
    Ok(out)
}
