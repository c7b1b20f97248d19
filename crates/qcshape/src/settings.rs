//! The settings of a similarity run, named once: every metric, solver and pipeline setting a
//! user can give, with its command-line flag (`--KEY`), its Python keyword and its default as
//! text. The command line's flags, the Python keywords (their list in error messages, the
//! `text_signature` defaults) and the validation errors ([`crate::limits::LimitError`] names a
//! setting by its key) all follow this table, and tests check each front end against it.
//!
//! The values are held by [`MetricSpec`], [`GeodesicOptions`] and [`PipelineOptions`], which
//! validate them ([`PipelineOptions::validate`]); the defaults are those structs' defaults.

use crate::geodesic::GeodesicOptions;
use crate::metric::MetricSpec;
use crate::similarity::{PipelineOptions, Smoothing};

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

/// One setting.
#[derive(Debug, Clone, Copy)]
pub struct Setting {
    /// The key: the command-line flag without its dashes (`lambda` for `--lambda`), the name
    /// validation errors use.
    pub key: &'static str,
    /// The Python keyword (`lam` for `--lambda`).
    pub python: &'static str,
    /// The options struct that holds it.
    pub group: Group,
    /// Its default, as the command line's `--help` shows it (`None`: no default value, e.g.
    /// the base is the first deformation).
    pub default: fn() -> Option<String>,
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

/// Every setting, in the order of the command line's `--help`.
pub const SETTINGS: &[Setting] = &[
    Setting {
        key: "metric",
        python: "metric",
        group: Group::Metric,
        default: || Some(metric().kind.label().to_string()),
    },
    Setting {
        key: "form",
        python: "form",
        group: Group::Metric,
        default: || Some(metric().form.label().to_string()),
    },
    Setting {
        key: "weights",
        python: "weights",
        group: Group::Metric,
        default: || Some(metric().weights.label().to_string()),
    },
    Setting {
        key: "lambda",
        python: "lam",
        group: Group::Metric,
        default: || Some(metric().lambda.to_string()),
    },
    Setting {
        key: "scale",
        python: "metric_scale",
        group: Group::Metric,
        default: || Some(metric().scale.label().to_string()),
    },
    Setting {
        key: "stretch",
        python: "stretch",
        group: Group::Metric,
        default: || Some(metric().stretch.to_string()),
    },
    Setting {
        key: "qc-weights",
        python: "qc_weights",
        group: Group::Metric,
        default: || {
            Some(
                if metric().qc_normalize.is_some() {
                    "rms"
                } else {
                    "raw"
                }
                .to_string(),
            )
        },
    },
    Setting {
        key: "qc-floor",
        python: "qc_floor",
        group: Group::Metric,
        default: || Some(metric().qc_normalize.map_or(0.0, |q| q.floor).to_string()),
    },
    Setting {
        key: "qc-smooth",
        python: "qc_smooth",
        group: Group::Metric,
        default: || Some(metric().qc_normalize.map_or(0, |q| q.smooth).to_string()),
    },
    Setting {
        key: "l2-areas",
        python: "l2_areas",
        group: Group::Metric,
        default: || Some(if metric().frozen_areas { "frozen" } else { "pose" }.to_string()),
    },
    Setting {
        key: "steps",
        python: "steps",
        group: Group::Solver,
        default: || Some(solver().steps.to_string()),
    },
    Setting {
        key: "solver",
        python: "solver",
        group: Group::Solver,
        default: || Some(solver().solver.label().to_string()),
    },
    Setting {
        key: "tolerance",
        python: "tolerance",
        group: Group::Solver,
        default: || Some(solver().gradient_tolerance.to_string()),
    },
    Setting {
        key: "energy-tolerance",
        python: "energy_tolerance",
        group: Group::Solver,
        default: || Some(solver().energy_tolerance.to_string()),
    },
    Setting {
        key: "length-tolerance",
        python: "length_tolerance",
        group: Group::Solver,
        default: || Some(solver().length_tolerance.to_string()),
    },
    Setting {
        key: "insert",
        python: "insert",
        group: Group::Pipeline,
        default: || Some(pipeline().insert.to_string()),
    },
    Setting {
        key: "levels",
        python: "levels",
        group: Group::Pipeline,
        default: || Some(pipeline().levels.to_string()),
    },
    Setting {
        key: "transport",
        python: "transport",
        group: Group::Pipeline,
        default: || Some(pipeline().transport.label().to_string()),
    },
    Setting {
        key: "align",
        python: "align",
        group: Group::Pipeline,
        default: || Some(pipeline().align.label().to_string()),
    },
    // Taubin iterations: an override of the length filter, so no default of its own.
    Setting {
        key: "smooth",
        python: "smooth",
        group: Group::Pipeline,
        default: || match pipeline().smoothing {
            Smoothing::Iterations(n) => Some(n.to_string()),
            Smoothing::Length(_) => None,
        },
    },
    Setting {
        key: "smooth-length",
        python: "smooth_length",
        group: Group::Pipeline,
        default: || match pipeline().smoothing {
            Smoothing::Length(l) => Some(l.to_string()),
            Smoothing::Iterations(_) => None,
        },
    },
    Setting {
        key: "base",
        python: "base",
        group: Group::Pipeline,
        default: || None,
    },
    Setting {
        key: "approx",
        python: "approx",
        group: Group::Pipeline,
        default: || Some(pipeline().approx.to_string()),
    },
];

/// The setting with command-line key `key`.
pub fn by_key(key: &str) -> Option<&'static Setting> {
    SETTINGS.iter().find(|s| s.key == key)
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
