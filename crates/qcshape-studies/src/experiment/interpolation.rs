//! Interpolation accuracy (paper section 3.1, Fig. 4): how well each metric's temporal
//! interpolation recovers a known pose.
//!
//! - Synthetic ([`InterpolationExperiment::run_synthetic`]): for every deformation with an odd
//!   number `P >= 3` of poses, the middle pose `P_{(P-1)/2}` is interpolated from the first and
//!   the last pose along each metric's discrete geodesic ([`Interpolator`]) and compared with the
//!   true middle pose, vertex by vertex.
//! - Real ([`InterpolationExperiment::run_leave_one_out`]): every chosen interior frame `k` of a
//!   sequence is interpolated from frames `k - 1` and `k + 1` and compared with frame `k`.
//!
//! **Error measure.** The error of a vertex is the Euclidean distance between its predicted and
//! true positions divided by the mean edge length of the true pose, so it is dimensionless (1
//! = one average edge) and comparable across shapes and resolutions; the case's error is the
//! mean over vertices. Leave-one-out reports it in input units (millimetres for the biv-me
//! data) as well. The baseline [`BASELINE`] (`"linear"`) predicts the average of the two known
//! poses. Per deformation type (the label; the name if unlabelled) and method the report gives
//! the mean and the sample standard deviation (`n - 1`; 0 for one case) of the case errors.
//!
//! All shapes of one run are scaled by one common factor while solving (docs/method.md
//! "Metrics"): 1 / the mean edge length of the first pose of the first deformation used.

mod report;

pub use super::ExperimentError;
use super::ExperimentInput;
pub use report::Comparison;

use std::sync::Arc;

use rayon::prelude::*;

use qcshape::dataset::Deformation;
use qcshape::geodesic::{
    normalization_factor, GeodesicOptions, InterpolationError, InterpolationOptions, Interpolator,
    Normalization,
};
use qcshape::mesh::{geometry, Topology};
use qcshape::metric::{Metric, MetricKind, MetricSpec};
use qcshape::multires::DEFAULT_RATIO;

/// Name of the baseline method: the average of the two known poses (linear interpolation).
pub const BASELINE: &str = "linear";

/// The experiment's settings.
#[derive(Debug, Clone)]
pub struct InterpolationExperiment {
    /// The metrics compared. Default: quasi-conformal, conformal, isometric, L2, each with
    /// [`MetricSpec::new`]'s defaults.
    pub metrics: Vec<MetricSpec>,
    /// Poses inserted between the two known poses; must be odd, the middle one is compared.
    /// Default 1 (the middle pose only).
    pub insert: usize,
    /// Spatial resolution levels of the interpolation (1 = no multiresolution). Default 1.
    pub levels: usize,
    /// Solver options (`steps` is set by the insertion schedule).
    pub geodesic: GeodesicOptions,
    /// Name of the synthetic deformation whose predicted middle poses are kept as error maps
    /// (Fig. 4a-b). Default `None`: the first deformation labelled `bend`, else the first used.
    pub showcase: Option<String>,
}

/// The metrics of Fig. 4, in its order (the default of [`InterpolationExperiment::metrics`] and
/// of `qcshape experiment interpolation --metrics`): a selection of the registry
/// ([`qcshape::metric::METRICS`]), the rigid metric left out as in the paper.
pub const FIG4_METRICS: [MetricKind; 4] = [
    MetricKind::QuasiConformal,
    MetricKind::Conformal,
    MetricKind::Isometric,
    MetricKind::L2,
];

impl Default for InterpolationExperiment {
    fn default() -> Self {
        InterpolationExperiment {
            metrics: FIG4_METRICS.into_iter().map(MetricSpec::new).collect(),
            insert: 1,
            levels: 1,
            geodesic: GeodesicOptions::default(),
            showcase: None,
        }
    }
}

/// The error of one predicted pose by one method.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseError {
    /// The deformation (sequence) name.
    pub deformation: String,
    /// Its type: the label, else the name.
    pub group: String,
    /// The method: a metric column name ([`InterpolationReport::methods`]) or [`BASELINE`].
    pub method: String,
    /// Index of the predicted pose in the deformation.
    pub pose: usize,
    /// Mean over vertices of the error relative to the true pose's mean edge length.
    pub mean: f64,
    /// Root mean square of the relative errors.
    pub rms: f64,
    /// Largest relative error.
    pub max: f64,
    /// Mean over vertices of the error in input units.
    pub mean_abs: f64,
    /// Mean edge length of the true pose (input units).
    pub mean_edge: f64,
    /// Whether the geodesic solve converged (always true for the baseline).
    pub converged: bool,
    /// Solver iterations (0 for the baseline).
    pub iterations: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Mean and sample SD of the case errors of one (type, method).
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The deformation type (or the sequence name for leave-one-out).
    pub group: String,
    /// The method.
    pub method: String,
    /// Number of cases.
    pub n: usize,
    /// Mean of the cases' relative mean errors (dimensionless).
    pub mean: f64,
    /// Sample SD of the cases' relative mean errors.
    pub sd: f64,
    /// Mean of the cases' mean errors in input units.
    pub mean_abs: f64,
    /// Sample SD of the cases' mean errors in input units.
    pub sd_abs: f64,
    /// Cases whose solve did not converge.
    pub unconverged: usize,
}

/// A predicted pose with its per-vertex error (Fig. 4a-b).
#[derive(Debug, Clone)]
pub struct ErrorMap {
    /// The deformation.
    pub deformation: String,
    /// The method.
    pub method: String,
    /// Connectivity.
    pub topology: Arc<Topology>,
    /// The predicted pose (#V x 3, input units).
    pub predicted: Vec<[f64; 3]>,
    /// The true pose (#V x 3, input units).
    pub truth: Vec<[f64; 3]>,
    /// Per-vertex error relative to the true pose's mean edge length (#V).
    pub errors: Vec<f64>,
}

/// The synthetic experiment's result (Fig. 4).
#[derive(Debug, Clone)]
pub struct InterpolationReport {
    /// Method columns in order: one per metric (its kind's name, e.g. `quasi-conformal`; the
    /// full metric name if two metrics share a kind), then [`BASELINE`].
    pub methods: Vec<String>,
    /// Deformation types in order of first appearance.
    pub groups: Vec<String>,
    /// Every case, deformation-major.
    pub cases: Vec<CaseError>,
    /// One row per (type, method), types in [`InterpolationReport::groups`] order.
    pub summary: Vec<Summary>,
    /// The showcase deformation's predictions, one per method.
    pub maps: Vec<ErrorMap>,
    /// Deformations left out (fewer than 3 or an even number of poses), with the reason.
    pub skipped: Vec<String>,
    /// The common factor coordinates were multiplied by while solving.
    pub scale: f64,
    /// Poses inserted per interpolation.
    pub insert: usize,
    /// Spatial levels.
    pub levels: usize,
}

/// The leave-one-frame-out result on one real sequence.
#[derive(Debug, Clone)]
pub struct LeaveOneOutReport {
    /// The sequence name.
    pub sequence: String,
    /// Vertices per pose.
    pub vertices: usize,
    /// Poses in the sequence.
    pub poses: usize,
    /// The interior frames predicted.
    pub frames: Vec<usize>,
    /// Method columns, as in [`InterpolationReport::methods`].
    pub methods: Vec<String>,
    /// Every (frame, method), frame-major.
    pub cases: Vec<CaseError>,
    /// One row per method (group = the sequence name).
    pub summary: Vec<Summary>,
    /// The common factor coordinates were multiplied by while solving.
    pub scale: f64,
}

/// One prediction task: predict `pose` of deformation `def` from poses `from` and `to`.
struct Task<'a> {
    def: &'a Deformation,
    pose: usize,
    from: usize,
    to: usize,
}

/// A finished metric case with its prediction.
struct Outcome {
    case: CaseError,
    predicted: Vec<[f64; 3]>,
    errors: Vec<f64>,
}

impl InterpolationExperiment {
    /// The method column names: one per metric, then [`BASELINE`].
    pub fn methods(&self) -> Vec<String> {
        let mut out: Vec<String> = self
            .metrics
            .iter()
            .map(|m| {
                let dup = self.metrics.iter().filter(|o| o.kind == m.kind).count() > 1;
                if dup {
                    m.label()
                } else {
                    m.kind.label().to_string()
                }
            })
            .collect();
        out.push(BASELINE.to_string());
        out
    }

    /// Number of geodesic interpolations [`InterpolationExperiment::run_synthetic`] performs
    /// on `defs` (the number of `progress` calls).
    pub fn synthetic_cases(&self, defs: &[Deformation]) -> usize {
        defs.iter().filter(|d| usable(d).is_ok()).count() * self.metrics.len()
    }

    fn validate(&self) -> Result<(), ExperimentError> {
        if self.metrics.is_empty() {
            return Err(ExperimentError::Input(ExperimentInput::Empty("metrics")));
        }
        if self.insert.is_multiple_of(2) {
            return Err(ExperimentError::Input(ExperimentInput::EvenInsert(self.insert)));
        }
        if self.levels == 0 {
            return Err(ExperimentError::Input(ExperimentInput::ZeroLevels));
        }
        let methods = self.methods();
        if methods[..methods.len() - 1].iter().any(|m| m == BASELINE) {
            return Err(ExperimentError::Input(ExperimentInput::BaselineName(BASELINE)));
        }
        Ok(())
    }

    /// The synthetic experiment (section 3.1, Fig. 4c): for each deformation of `defs` with an
    /// odd number `P >= 3` of poses (others are listed in [`InterpolationReport::skipped`]),
    /// and each metric, the middle pose is interpolated from the first and last and compared
    /// with the true one; plus the linear baseline. All shapes share one scale factor (1 /
    /// mean edge length of the first used deformation's first pose). Cases run in parallel;
    /// `progress` is called once per finished geodesic interpolation.
    pub fn run_synthetic(
        &self,
        defs: &[Deformation],
        progress: &(dyn Fn() + Sync),
    ) -> Result<InterpolationReport, ExperimentError> {
        self.validate()?;
        let mut skipped = Vec::new();
        let mut used = Vec::new();
        for d in defs {
            match usable(d) {
                Ok(()) => used.push(d),
                Err(why) => skipped.push(format!("{}: {why}", d.name)),
            }
        }
        let Some(first) = used.first() else {
            return Err(ExperimentError::Input(ExperimentInput::NoOddDeformation));
        };
        let showcase = match &self.showcase {
            Some(name) => used
                .iter()
                .find(|d| &d.name == name)
                .map(|d| d.name.clone())
                .ok_or_else(|| ExperimentError::Input(ExperimentInput::UnknownShowcase(name.clone())))?,
            None => used
                .iter()
                .find(|d| d.label.as_deref() == Some("bend"))
                .unwrap_or(first)
                .name
                .clone(),
        };
        let scale = normalization_factor(Normalization::MeanEdgeOfFirst, &first.topology, &first.poses[0]);
        let tasks: Vec<Task> = used
            .iter()
            .map(|d| Task {
                def: d,
                pose: (d.n_poses() - 1) / 2,
                from: 0,
                to: d.n_poses() - 1,
            })
            .collect();
        let (cases, outcomes) = self.run_tasks(&tasks, scale, progress)?;
        let methods = self.methods();
        let mut maps = Vec::new();
        for (t, per_method) in tasks.iter().zip(outcomes) {
            if t.def.name != showcase {
                continue;
            }
            for (m, o) in methods.iter().zip(per_method) {
                maps.push(ErrorMap {
                    deformation: t.def.name.clone(),
                    method: m.clone(),
                    topology: t.def.topology.clone(),
                    predicted: o.predicted,
                    truth: t.def.poses[t.pose].clone(),
                    errors: o.errors,
                });
            }
        }
        let mut groups: Vec<String> = Vec::new();
        for c in &cases {
            if !groups.contains(&c.group) {
                groups.push(c.group.clone());
            }
        }
        let summary = summarize(&groups, &methods, &cases);
        Ok(InterpolationReport {
            methods,
            groups,
            cases,
            summary,
            maps,
            skipped,
            scale,
            insert: self.insert,
            levels: self.levels,
        })
    }

    /// Leave-one-frame-out on a real sequence `seq` (at least 3 poses): each frame `k` of
    /// `frames` (interior frames, `1 <= k <= P - 2`; `None` = all of them) is interpolated from
    /// frames `k - 1` and `k + 1` by each metric and by the baseline, and compared with frame
    /// `k`. One scale for the sequence (1 / mean edge length of frame 0). `progress` is called
    /// once per finished geodesic interpolation (`frames x metrics` calls).
    pub fn run_leave_one_out(
        &self,
        seq: &Deformation,
        frames: Option<&[usize]>,
        progress: &(dyn Fn() + Sync),
    ) -> Result<LeaveOneOutReport, ExperimentError> {
        self.validate()?;
        let p = seq.n_poses();
        if p < 3 {
            return Err(ExperimentError::Input(ExperimentInput::ShortSequence {
                name: seq.name.clone(),
                poses: p,
            }));
        }
        let frames: Vec<usize> = match frames {
            None => (1..p - 1).collect(),
            Some(f) => {
                if let Some(bad) = f.iter().find(|&&k| k == 0 || k + 1 >= p) {
                    return Err(ExperimentError::Input(ExperimentInput::NotInterior {
                        frame: *bad,
                        name: seq.name.clone(),
                        last: p - 2,
                    }));
                }
                f.to_vec()
            }
        };
        if frames.is_empty() {
            return Err(ExperimentError::Input(ExperimentInput::NoFrames));
        }
        let scale = normalization_factor(Normalization::MeanEdgeOfFirst, &seq.topology, &seq.poses[0]);
        let tasks: Vec<Task> = frames
            .iter()
            .map(|&k| Task {
                def: seq,
                pose: k,
                from: k - 1,
                to: k + 1,
            })
            .collect();
        let (mut cases, _) = self.run_tasks(&tasks, scale, progress)?;
        for c in &mut cases {
            c.group = seq.name.clone();
        }
        let methods = self.methods();
        let summary = summarize(std::slice::from_ref(&seq.name), &methods, &cases);
        Ok(LeaveOneOutReport {
            sequence: seq.name.clone(),
            vertices: seq.topology.n_vertices(),
            poses: p,
            frames,
            methods,
            cases,
            summary,
            scale,
        })
    }

    /// Runs every (task, metric) in parallel and the baseline of every task; returns the cases
    /// (task-major, methods in [`InterpolationExperiment::methods`] order) and the outcomes per
    /// task (same order).
    fn run_tasks(
        &self,
        tasks: &[Task],
        scale: f64,
        progress: &(dyn Fn() + Sync),
    ) -> Result<(Vec<CaseError>, Vec<Vec<Outcome>>), ExperimentError> {
        let methods = self.methods();
        let nm = self.metrics.len();
        let results: Vec<Outcome> = (0..tasks.len() * nm)
            .into_par_iter()
            .map(|i| {
                let (t, m) = (&tasks[i / nm], i % nm);
                // Each task's metric is calibrated on its first key pose.
                let metric = self.metrics[m]
                    .build_scaled(&t.def.topology, &t.def.poses[t.from], scale)
                    .map_err(|e| ExperimentError::Interpolation {
                        deformation: t.def.name.clone(),
                        pose: t.pose,
                        method: methods[m].clone(),
                        source: InterpolationError::from(qcshape::geodesic::GeodesicError::from(e)),
                    })?;
                let r = self.predict(metric.as_ref(), t, scale, &methods[m]);
                progress();
                r
            })
            .collect::<Result<_, _>>()?;
        let mut results = results.into_iter();
        let mut cases = Vec::with_capacity(tasks.len() * (nm + 1));
        let mut outcomes = Vec::with_capacity(tasks.len());
        for t in tasks {
            let mut per: Vec<Outcome> = results.by_ref().take(nm).collect();
            per.push(baseline(t));
            cases.extend(per.iter().map(|o| o.case.clone()));
            outcomes.push(per);
        }
        Ok((cases, outcomes))
    }

    /// Interpolates `t.pose` with `metric`.
    fn predict(
        &self,
        metric: &dyn Metric,
        t: &Task,
        scale: f64,
        method: &str,
    ) -> Result<Outcome, ExperimentError> {
        let (a, b) = (&t.def.poses[t.from], &t.def.poses[t.to]);
        let wrap = |source| ExperimentError::Interpolation {
            deformation: t.def.name.clone(),
            pose: t.pose,
            method: method.to_string(),
            source,
        };
        let options = InterpolationOptions {
            insert: self.insert,
            levels: self.levels,
            ratio: DEFAULT_RATIO,
            geodesic: self.geodesic.clone(),
            normalization: Normalization::Factor(scale),
        };
        let p = Interpolator::new(metric, &t.def.topology, a, options)
            .and_then(|ip| ip.interpolate(a, b))
            .map_err(wrap)?;
        let predicted = p.poses[self.insert.div_ceil(2)].clone();
        let mut o = measure(t, method, predicted);
        o.case.converged = p.stats.converged;
        o.case.iterations = p.stats.iterations;
        o.case.seconds = p.stats.seconds;
        Ok(o)
    }
}

/// Whether `d` has an odd number of poses, at least 3.
fn usable(d: &Deformation) -> Result<(), String> {
    let p = d.n_poses();
    if p < 3 {
        Err(format!("{p} pose(s), need at least 3"))
    } else if p.is_multiple_of(2) {
        Err(format!("{p} poses: no pose at the middle time"))
    } else {
        Ok(())
    }
}

/// The linear baseline of a task: the average of the two known poses.
fn baseline(t: &Task) -> Outcome {
    let (a, b) = (&t.def.poses[t.from], &t.def.poses[t.to]);
    let predicted = a
        .iter()
        .zip(b)
        .map(|(p, q)| geometry::scale(geometry::add(*p, *q), 0.5))
        .collect();
    let mut o = measure(t, BASELINE, predicted);
    o.case.converged = true;
    o
}

/// Per-vertex errors of `predicted` against the task's true pose.
fn measure(t: &Task, method: &str, predicted: Vec<[f64; 3]>) -> Outcome {
    let truth = &t.def.poses[t.pose];
    let mean_edge = geometry::mean_edge_length(&t.def.topology, truth);
    let abs: Vec<f64> = predicted
        .iter()
        .zip(truth)
        .map(|(x, y)| geometry::norm(geometry::sub(*x, *y)))
        .collect();
    let unit = if mean_edge > 0.0 { mean_edge } else { 1.0 };
    let errors: Vec<f64> = abs.iter().map(|e| e / unit).collect();
    let nv = errors.len().max(1) as f64;
    let case = CaseError {
        deformation: t.def.name.clone(),
        group: t.def.label.clone().unwrap_or_else(|| t.def.name.clone()),
        method: method.to_string(),
        pose: t.pose,
        mean: errors.iter().sum::<f64>() / nv,
        rms: (errors.iter().map(|e| e * e).sum::<f64>() / nv).sqrt(),
        max: errors.iter().copied().fold(0.0, f64::max),
        mean_abs: abs.iter().sum::<f64>() / nv,
        mean_edge,
        converged: false,
        iterations: 0,
        seconds: 0.0,
    };
    Outcome {
        case,
        predicted,
        errors,
    }
}

/// Mean and sample SD (`n - 1`; 0 for `n <= 1`).
fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len();
    if n == 0 {
        return (0.0, 0.0);
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let sd = if n > 1 {
        (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    (mean, sd)
}

/// One [`Summary`] per (group, method) that has cases.
fn summarize(groups: &[String], methods: &[String], cases: &[CaseError]) -> Vec<Summary> {
    let mut out = Vec::new();
    for g in groups {
        for m in methods {
            let sel: Vec<&CaseError> = cases.iter().filter(|c| &c.group == g && &c.method == m).collect();
            if sel.is_empty() {
                continue;
            }
            let (mean, sd) = mean_sd(&sel.iter().map(|c| c.mean).collect::<Vec<_>>());
            let (mean_abs, sd_abs) = mean_sd(&sel.iter().map(|c| c.mean_abs).collect::<Vec<_>>());
            out.push(Summary {
                group: g.clone(),
                method: m.clone(),
                n: sel.len(),
                mean,
                sd,
                mean_abs,
                sd_abs,
                unconverged: sel.iter().filter(|c| !c.converged).count(),
            });
        }
    }
    out
}

/// `count` interior frames (indices `1 .. poses - 2`) of a sequence of `poses` poses, evenly
/// spaced, for leave-one-frame-out (all if `count` is 0 or more than there are).
pub fn pick_frames(poses: usize, count: usize) -> Vec<usize> {
    let interior = poses.saturating_sub(2);
    if count == 0 || count >= interior {
        return (1..=interior).collect();
    }
    if count == 1 {
        return vec![1 + (interior - 1) / 2];
    }
    (0..count)
        .map(|i| 1 + (i * (interior - 1) + (count - 1) / 2) / (count - 1))
        .collect()
}

#[cfg(test)]
mod tests;
