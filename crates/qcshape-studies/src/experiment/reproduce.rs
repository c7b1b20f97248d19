//! The reproduction of the paper's synthetic experiments (section 3): the 48 synthetic
//! deformations classified with every metric (Table 1, Table 2, Fig. 6), the interpolation
//! and transfer experiments (Fig. 4, Fig. 5), the noise resistance of the classification
//! (Table 3), and the report that puts every table beside the paper's numbers.
//!
//! A caller (the `qcshape reproduce` command) runs the steps in order, reporting progress
//! between them: [`Reproduction::benchmark`], [`Reproduction::run_metric`] per metric (and
//! [`MetricRun::write`]), [`Reproduction::fig4`] and [`Reproduction::fig5`], and
//! [`Reproduction::noise_tau`] per noise level and kind; then [`ReproduceReport::new`]
//! assembles the report and [`ReproduceReport::to_markdown`] writes `report.md`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::classification::{classify_set, score, ClassificationError, Classified, Scores};
use super::interpolation::{InterpolationExperiment, FIG4_METRICS};
use super::provenance::Provenance;
use super::transfer::TransferExperiment;
use crate::plot::PlotError;
use qcshape::align::Alignment;
use qcshape::cluster::IntrinsicOptions;
use qcshape::dataset::Deformation;
use qcshape::defaults;
use qcshape::embed::{smacof, MdsError, MdsOptions};
use qcshape::eval::{tau, EvalError};
use qcshape::geodesic::GeodesicOptions;
use qcshape::io::{write_atomically, IoError};
use qcshape::metric::{MetricKind, MetricScale, MetricSpec};
use qcshape::similarity::{MatrixFileError, PipelineOptions, ShareSummary, Smoothing, Stage};
use qcshape::synth::{genus0_benchmark, NoiseKind, SynthError, SynthOptions};
use qcshape::transport::Transport;

use super::noise::noisy_set;

/// Number of classes of the synthetic benchmark (its eight deformation kinds).
pub const CLASSES: usize = 8;

/// Why a step of the reproduction failed.
#[derive(Debug, Error)]
pub enum ReproduceError {
    /// `metrics` is empty.
    #[error("invalid reproduction: --metrics is empty")]
    NoMetrics,
    /// `lambda` is negative or NaN.
    #[error("invalid reproduction: --lambda must be non-negative, got {0}")]
    Lambda(f64),
    /// `steps` or `restarts` is 0.
    #[error("invalid reproduction: --steps and --restarts must be at least 1, got {steps} and {restarts}")]
    Count {
        /// The segments of every geodesic.
        steps: usize,
        /// The k-means restarts.
        restarts: usize,
    },
    /// A metric of Table 3 is not among the metrics of Table 1.
    #[error(
        "invalid reproduction: --noise-metrics {} is not among --metrics: Table 3 needs that metric's \
         Table 1 run as its noise-free reference",
        .0.label()
    )]
    NoiseMetric(MetricKind),
    /// A report was asked for without a metric run or a deformation.
    #[error("a reproduction report needs at least one metric run and one deformation")]
    EmptyReport,
    /// The synthetic benchmark cannot be made.
    #[error(transparent)]
    Synth(#[from] SynthError),
    /// A classification failed.
    #[error(transparent)]
    Classification(#[from] ClassificationError),
    /// `tau` cannot be computed.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// The MDS map cannot be computed.
    #[error(transparent)]
    Mds(#[from] MdsError),
    /// A figure cannot be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A similarity matrix cannot be written.
    #[error(transparent)]
    Matrix(#[from] MatrixFileError),
    /// A file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
}

/// The settings of the reproduction.
#[derive(Debug, Clone, PartialEq)]
pub struct Reproduction {
    /// Icosphere level of the synthetic meshes (`10 * 4^level + 2` vertices).
    pub level: u32,
    /// Poses inserted between consecutive key poses (section 3.3).
    pub insert: usize,
    /// Segments N of every geodesic.
    pub steps: usize,
    /// Seeded kernel k-means runs (the best starts the intrinsic k-means).
    pub restarts: usize,
    /// Noise variances of Table 3, in percent of `lbar^2`.
    pub noise_levels: Vec<f64>,
    /// The metrics of Table 1, in order.
    pub metrics: Vec<MetricKind>,
    /// The metrics of Table 3, each classified again under every noise level and kind; each
    /// one's Table 1 run is its noise-free reference, so each must be one of
    /// [`Reproduction::metrics`] ([`Reproduction::validate`]). Empty: every metric of
    /// [`Reproduction::metrics`] ([`Reproduction::noise_kinds`]).
    pub noise_metrics: Vec<MetricKind>,
    /// Weight `lambda` of the L2 regularizer of every metric (eq. 11).
    pub lambda: f64,
    /// How every metric's terms are scaled ([`MetricScale`]; default invariant).
    pub scale: MetricScale,
    /// Weight of the conformal metrics' stretch term on the invariant scale.
    pub stretch: f64,
    /// Transport to the common base.
    pub transport: Transport,
    /// Placement of each deformation on the base before transfer.
    pub align: Alignment,
    /// The smoothing of every pose before comparing ([`Smoothing`]; `Iterations(0)` = none).
    pub smoothing: Smoothing,
    /// Seed of the synthetic amplitudes, k-means and noise.
    pub seed: u64,
    /// Also run Table 1 with the previous configuration ([`MetricSpec::calibrated`]: eq. 3's
    /// and eq. 7's terms on the calibrated scale, no stretch term, the default of the releases
    /// of 2026-12-04 to 2026-12-06), beside the default.
    pub previous: bool,
}

impl Reproduction {
    /// The full settings: level 2 (162 vertices), [`defaults::PAPER_INSERT`] (3) inserted
    /// poses, N = [`crate::study_defaults::PAPER_STEPS`] (4), [`defaults::RESTARTS`] (20) restarts, noise
    /// levels 1, 2.5, 5, 10, 20 %, every metric ([`table1_metrics`]: the paper's rows, then
    /// l2), and the common defaults for the rest: [`defaults::LAMBDA`], [`defaults::TRANSPORT`]
    /// (Euclidean), [`defaults::ALIGN`] (rigid), the length filter of [`defaults::SMOOTH_LENGTH`],
    /// [`defaults::SEED`].
    pub fn full() -> Reproduction {
        Reproduction {
            level: 2,
            insert: defaults::PAPER_INSERT,
            steps: crate::study_defaults::PAPER_STEPS,
            restarts: defaults::RESTARTS,
            noise_levels: vec![1.0, 2.5, 5.0, 10.0, 20.0],
            metrics: table1_metrics(),
            noise_metrics: Vec::new(),
            lambda: defaults::LAMBDA,
            scale: defaults::SCALE,
            stretch: defaults::STRETCH,
            transport: defaults::TRANSPORT,
            align: defaults::ALIGN,
            smoothing: Smoothing::Length(defaults::SMOOTH_LENGTH),
            seed: defaults::SEED,
            previous: true,
        }
    }

    /// Small and fast: as [`Reproduction::full`] with level 1 (42 vertices), one inserted pose,
    /// N = 2, 5 restarts and one noise level (1 %).
    pub fn quick() -> Reproduction {
        Reproduction {
            level: 1,
            insert: 1,
            steps: 2,
            restarts: 5,
            noise_levels: vec![1.0],
            ..Reproduction::full()
        }
    }

    /// The 48 synthetic deformations (6 shapes x 8 deformations x 3 poses) at
    /// [`Reproduction::level`] and [`Reproduction::seed`].
    pub fn benchmark(&self) -> Result<Vec<Deformation>, ReproduceError> {
        Ok(genus0_benchmark(&SynthOptions {
            level: self.level,
            seed: self.seed,
            ..Default::default()
        })?)
    }

    /// The metric `kind` at this run's `lambda`, scale and stretch weight.
    pub fn metric(&self, kind: MetricKind) -> MetricSpec {
        MetricSpec {
            lambda: self.lambda,
            scale: self.scale,
            stretch: self.stretch,
            ..MetricSpec::new(kind)
        }
    }

    /// The pipeline options for one metric.
    pub fn pipeline(&self, kind: MetricKind) -> PipelineOptions {
        PipelineOptions {
            metric: self.metric(kind),
            geodesic: GeodesicOptions {
                steps: self.steps,
                ..Default::default()
            },
            insert: self.insert,
            levels: 1,
            transport: self.transport,
            align: self.align,
            smoothing: self.smoothing,
            base: 0,
            approx: Default::default(),
        }
    }

    /// Interpolation, transfer, similarity and k-means of `defs` into [`CLASSES`] classes for
    /// one metric, scored against `labels` (n). `progress` as in [`classify_set`].
    pub fn run_metric(
        &self,
        defs: &[Deformation],
        labels: &[String],
        kind: MetricKind,
        progress: &(dyn Fn(Stage) + Sync),
    ) -> Result<MetricRun, ReproduceError> {
        self.run_options(defs, labels, kind, self.pipeline(kind), progress)
    }

    /// [`Reproduction::run_metric`] with the previous configuration of the metric
    /// ([`MetricSpec::calibrated`]: the calibrated scale, eq. 7's conformal terms, no stretch
    /// term), everything else as in [`Reproduction::pipeline`].
    pub fn run_previous(
        &self,
        defs: &[Deformation],
        labels: &[String],
        kind: MetricKind,
        progress: &(dyn Fn(Stage) + Sync),
    ) -> Result<MetricRun, ReproduceError> {
        let opts = PipelineOptions {
            metric: MetricSpec {
                lambda: self.lambda,
                ..MetricSpec::calibrated(kind)
            },
            ..self.pipeline(kind)
        };
        self.run_options(defs, labels, kind, opts, progress)
    }

    fn run_options(
        &self,
        defs: &[Deformation],
        labels: &[String],
        kind: MetricKind,
        opts: PipelineOptions,
        progress: &(dyn Fn(Stage) + Sync),
    ) -> Result<MetricRun, ReproduceError> {
        let c = classify_set(defs, &opts, CLASSES, self.restarts, self.seed, progress)?;
        Ok(MetricRun {
            kind,
            metric: opts.metric.label(),
            kernel_scores: score(&c.matrix, &c.kernel, labels)?,
            scores: score(&c.matrix, &c.clustering, labels)?,
            classified: c,
        })
    }

    /// The Fig. 4 experiment: interpolation of the middle pose from the first and the last,
    /// with the quasi-conformal, conformal, isometric and L2 metrics at [`Reproduction::lambda`].
    pub fn fig4(&self) -> InterpolationExperiment {
        InterpolationExperiment {
            metrics: FIG4_METRICS.into_iter().map(|k| self.metric(k)).collect(),
            ..Default::default()
        }
    }

    /// The Fig. 5 experiment: transfer of analytic deformations from a sphere to other bases,
    /// at [`Reproduction::level`] and [`Reproduction::lambda`].
    pub fn fig5(&self) -> TransferExperiment {
        let mut exp = TransferExperiment {
            level: self.level,
            ..Default::default()
        };
        for m in &mut exp.metrics {
            m.lambda = self.lambda;
            m.scale = self.scale;
            m.stretch = self.stretch;
        }
        exp
    }

    /// The metrics of Table 3, in the order of [`Reproduction::metrics`]:
    /// [`Reproduction::noise_metrics`], or every metric when that is empty.
    pub fn noise_kinds(&self) -> Vec<MetricKind> {
        self.metrics
            .iter()
            .copied()
            .filter(|m| self.noise_metrics.is_empty() || self.noise_metrics.contains(m))
            .collect()
    }

    /// One Table 3 cell: `defs` with noise of `kind` at `level` % classified with the metric of
    /// `reference`; `tau` (eq. 17) against `reference`'s clusters, and the noisy partition's
    /// matched accuracy against `labels`.
    pub fn noise_tau(
        &self,
        defs: &[Deformation],
        labels: &[String],
        reference: &MetricRun,
        kind: NoiseKind,
        level: f64,
        progress: &(dyn Fn(Stage) + Sync),
    ) -> Result<NoiseCell, ReproduceError> {
        let noisy = noisy_set(defs, kind, level, self.seed);
        let r = self.run_metric(&noisy, labels, reference.kind, progress)?;
        Ok(NoiseCell {
            tau: tau(
                &reference.classified.clustering.assignments,
                &r.classified.clustering.assignments,
            )?,
            accuracy: r.scores.eq15.sensitivity,
        })
    }

    /// One Table 3 row of `reference`'s metric at `level` % ([`Self::noise_tau`] for
    /// [`NoiseKind::Uniform`], then [`NoiseKind::Gaussian`]), beside the paper's numbers;
    /// `done` is called after each cell with its kind and result (or `None` when it fails).
    pub fn noise_row(
        &self,
        defs: &[Deformation],
        labels: &[String],
        reference: &MetricRun,
        level: f64,
        progress: &(dyn Fn(Stage) + Sync),
        done: &dyn Fn(NoiseKind, Option<NoiseCell>),
    ) -> Result<Table3Row, ReproduceError> {
        let mut row = Table3Row {
            metric: reference.kind.label().to_string(),
            level,
            uniform: 0.0,
            gaussian: 0.0,
            paper: paper_table3(level),
            accuracy: (0.0, 0.0),
            reference_accuracy: reference.scores.eq15.sensitivity,
        };
        for kind in [NoiseKind::Uniform, NoiseKind::Gaussian] {
            let t = self.noise_tau(defs, labels, reference, kind, level, progress);
            done(kind, t.as_ref().ok().copied());
            let t = t?;
            if kind == NoiseKind::Uniform {
                (row.uniform, row.accuracy.0) = (t.tau, t.accuracy);
            } else {
                (row.gaussian, row.accuracy.1) = (t.tau, t.accuracy);
            }
        }
        Ok(row)
    }

    /// Checks the settings: at least one metric, a non-negative `lambda`, at least one step
    /// and one restart, every Table 3 metric among the metrics.
    pub fn validate(&self) -> Result<(), ReproduceError> {
        if self.metrics.is_empty() {
            return Err(ReproduceError::NoMetrics);
        }
        if self.lambda.is_nan() || self.lambda < 0.0 {
            return Err(ReproduceError::Lambda(self.lambda));
        }
        if self.steps == 0 || self.restarts == 0 {
            return Err(ReproduceError::Count {
                steps: self.steps,
                restarts: self.restarts,
            });
        }
        if let Some(&m) = self.noise_metrics.iter().find(|m| !self.metrics.contains(m)) {
            return Err(ReproduceError::NoiseMetric(m));
        }
        Ok(())
    }
}

/// One metric's classification of the benchmark, scored.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MetricRun {
    /// The metric.
    #[serde(serialize_with = "serialize_kind")]
    pub kind: MetricKind,
    /// The metric's name as built (with its variants and regularization).
    pub metric: String,
    /// The classification.
    pub classified: Classified,
    /// Scores of the intrinsic k-means partition.
    pub scores: Scores,
    /// Scores of the kernel k-means partition (its start).
    pub kernel_scores: Scores,
}

fn serialize_kind<S: serde::Serializer>(kind: &MetricKind, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(kind.label())
}

impl MetricRun {
    /// The file names this run writes with [`MetricRun::write`]: the similarity matrix
    /// `similarity_NAME.csv`, the Fig. 6 MDS map `fig6_mds_NAME.svg` / `.png` and the heat map
    /// of the matrix `similarity_NAME.svg` / `.png` (ordered by class; `NAME` the metric's
    /// label).
    pub fn file_names(&self) -> [String; 5] {
        let name = self.kind.label();
        [
            format!("similarity_{name}.csv"),
            format!("fig6_mds_{name}.svg"),
            format!("fig6_mds_{name}.png"),
            format!("similarity_{name}.svg"),
            format!("similarity_{name}.png"),
        ]
    }

    /// Writes the similarity matrix, the Fig. 6 MDS map and the heat map to `dir`; `labels`
    /// (n) colour the map and order the heat map. Returns the paths.
    pub fn write(&self, dir: &Path, labels: &[String]) -> Result<Vec<PathBuf>, ReproduceError> {
        let name = self.kind.label();
        let [csv, mds_svg, mds_png, heat_svg, heat_png] = self.file_names().map(|f| dir.join(f));
        let matrix = &self.classified.matrix;
        matrix.write_csv(&csv)?;
        let e = smacof(matrix, &MdsOptions::default())?;
        let title = format!("MDS of the {} deformations, {name} metric", matrix.len());
        for path in [&mds_svg, &mds_png] {
            crate::plot::scatter_map(
                path,
                &e.coords,
                matrix.names(),
                Some(labels),
                &title,
                Some(e.normalized_stress),
            )?;
        }
        let mut order: Vec<usize> = (0..labels.len()).collect();
        order.sort_by(|&a, &b| labels[a].cmp(&labels[b]).then(a.cmp(&b)));
        let title = format!(
            "{name} distances, {} synthetic deformations (by class)",
            matrix.len()
        );
        for path in [&heat_svg, &heat_png] {
            crate::plot::heatmap(
                path,
                matrix,
                &order,
                Some(labels),
                &title,
                "distance (mean-edge units)",
            )?;
        }
        Ok(vec![csv, mds_svg, mds_png, heat_svg, heat_png])
    }
}

/// Every metric of the registry ([`qcshape::metric::METRICS`]) in the order of Table 1: the
/// paper's rows ([`paper_table1`]) first, then the metrics it does not report (L2), each group
/// in the registry's order. The default of [`Reproduction::metrics`] and of `qcshape reproduce
/// --metrics`.
pub fn table1_metrics() -> Vec<MetricKind> {
    let (paper, ours): (Vec<MetricKind>, Vec<MetricKind>) = MetricKind::ALL
        .into_iter()
        .partition(|k| paper_table1(*k).is_some());
    paper.into_iter().chain(ours).collect()
}

/// The paper's Table 1 (specificity, sensitivity in %).
pub fn paper_table1(kind: MetricKind) -> Option<(f64, f64)> {
    match kind {
        MetricKind::Rigid => Some((63.4, 55.2)),
        MetricKind::Isometric => Some((71.3, 69.2)),
        MetricKind::Conformal => Some((80.7, 84.2)),
        MetricKind::QuasiConformal => Some((97.9, 99.7)),
        MetricKind::L2 => None,
    }
}

/// The paper's Table 3 (uniform, Gaussian tau in %) by noise variance in percent.
pub fn paper_table3(level: f64) -> Option<(f64, f64)> {
    [
        (1.0, 97.9, 97.9),
        (2.5, 93.7, 93.7),
        (5.0, 91.6, 89.5),
        (10.0, 85.4, 83.3),
        (20.0, 75.0, 70.8),
    ]
    .iter()
    .find(|(l, _, _)| (l - level).abs() < 1e-9)
    .map(|&(_, u, g)| (u, g))
}

/// Mean and sample standard deviation (divisor `max(n - 1, 1)`; (0, 0) for no values).
fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, v.sqrt())
}

/// The Table 1 rows of `runs`, one per metric.
fn table1_rows(runs: &[MetricRun]) -> Vec<Table1Row> {
    runs.iter()
        .map(|r| Table1Row {
            metric: r.kind.label().to_string(),
            specificity: r.scores.eq15.specificity,
            sensitivity: r.scores.eq15.sensitivity,
            paper: paper_table1(r.kind),
            kernel_specificity: r.kernel_scores.eq15.specificity,
            kernel_sensitivity: r.kernel_scores.eq15.sensitivity,
            nn_accuracy: r.scores.nn_accuracy,
            ari: r.scores.ari,
            shares: r.classified.shares,
        })
        .collect()
}

/// A row of Table 1 (shares in [0, 1]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Table1Row {
    /// The metric's label.
    pub metric: String,
    /// Eq. 15 specificity of the intrinsic k-means partition.
    pub specificity: f64,
    /// Eq. 15 sensitivity of the intrinsic k-means partition.
    pub sensitivity: f64,
    /// The paper's (specificity, sensitivity) in %, if it reports the metric.
    pub paper: Option<(f64, f64)>,
    /// Eq. 15 specificity of the kernel k-means partition.
    pub kernel_specificity: f64,
    /// Eq. 15 sensitivity of the kernel k-means partition.
    pub kernel_sensitivity: f64,
    /// Leave-one-out 1-NN accuracy on the similarity matrix.
    pub nn_accuracy: f64,
    /// Adjusted Rand index of the intrinsic k-means partition.
    pub ari: f64,
    /// The L2 regularizer's share of the energy over the similarity matrix's pairs.
    pub shares: ShareSummary,
}

/// A row of Table 2 (seconds).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Table2Row {
    /// The metric's label.
    pub metric: String,
    /// Interpolation per deformation: (mean, SD).
    pub interpolation: (f64, f64),
    /// Transfer per deformation: (mean, SD).
    pub transfer: (f64, f64),
    /// Similarity per pair: (mean, SD).
    pub pair: (f64, f64),
    /// Elapsed seconds: interpolation, transfer, similarity, intrinsic k-means.
    pub wall: [f64; 4],
    /// Rounds of the intrinsic k-means.
    pub rounds: usize,
}

/// A row of Table 3 (`tau` in [0, 1]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Table3Row {
    /// The metric's label.
    pub metric: String,
    /// Noise variance in percent.
    pub level: f64,
    /// `tau` with uniform noise.
    pub uniform: f64,
    /// `tau` with Gaussian noise.
    pub gaussian: f64,
    /// The paper's (uniform, Gaussian) in %, if it reports the level.
    pub paper: Option<(f64, f64)>,
    /// Matched accuracy (eq. 15 sensitivity) of the noisy partitions against the true classes:
    /// (uniform, Gaussian).
    pub accuracy: (f64, f64),
    /// Matched accuracy of the noise-free partition `tau` compares with.
    pub reference_accuracy: f64,
}

/// One Table 3 cell ([`Reproduction::noise_tau`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseCell {
    /// `tau` (eq. 17, in [0, 1]): the share of deformations whose cluster is unchanged against
    /// the noise-free partition.
    pub tau: f64,
    /// Matched accuracy (eq. 15 sensitivity, in [0, 1]) of the noisy partition.
    pub accuracy: f64,
}

/// The reproduction's report (`report.md`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ReproduceReport {
    /// Command line, version, machine, total time.
    pub provenance: Provenance,
    /// Number of deformations.
    pub deformations: usize,
    /// Icosphere level of the meshes.
    pub level: u32,
    /// Seed of the data, k-means and noise.
    pub seed: u64,
    /// Vertices per mesh.
    pub vertices: usize,
    /// Key poses per deformation.
    pub key_poses: usize,
    /// Poses inserted between key poses.
    pub insert: usize,
    /// Poses per deformation after interpolation.
    pub poses: usize,
    /// Segments N of every geodesic.
    pub steps: usize,
    /// Weight of the L2 regularizer.
    pub lambda: f64,
    /// The transport's label.
    pub transport: String,
    /// The name of the deformation whose first pose is the base.
    pub base: String,
    /// Kernel k-means restarts.
    pub restarts: usize,
    /// Table 1, one row per metric.
    pub table1: Vec<Table1Row>,
    /// Table 1 with the previous configuration ([`Reproduction::previous`]; empty when not
    /// run), and the metric names as built.
    pub previous: Vec<Table1Row>,
    /// The metric names of [`ReproduceReport::previous`] as built.
    pub previous_names: Vec<String>,
    /// The metric names as built, one per metric.
    pub metric_names: Vec<String>,
    /// Rounds of the intrinsic k-means at most.
    pub max_rounds: usize,
    /// Similarity pairs whose geodesic stopped at the iteration limit, over all metrics.
    pub unconverged: usize,
    /// Whether every interpolation and transfer geodesic converged.
    pub prepared_converged: bool,
    /// Table 2, one row per metric.
    pub table2: Vec<Table2Row>,
    /// The metric labels of Table 3, in order.
    pub noise_metrics: Vec<String>,
    /// Table 3, one row per metric and noise level done (empty when skipped).
    pub table3: Vec<Table3Row>,
    /// The Fig. 4 experiment's Markdown.
    pub fig4: String,
    /// The Fig. 5 experiment's Markdown.
    pub fig5: String,
    /// The metric labels with a Fig. 6 map and a similarity matrix.
    pub figures: Vec<String>,
    /// `Some(step)` for a report written while the reproduction still runs (after `step`);
    /// `None` for the final one. See [`ReproduceReport::partial`].
    pub partial: Option<String>,
}

impl ReproduceReport {
    /// Assembles the report of `runs` (one per metric, non-empty) on the benchmark `defs`, with
    /// the Table 3 rows done so far (`noise`, [`Reproduction::noise_row`]) and the Markdown of
    /// Fig. 4 and Fig. 5.
    pub fn new(
        settings: &Reproduction,
        defs: &[Deformation],
        runs: &[MetricRun],
        noise: &[Table3Row],
        [fig4, fig5]: [&str; 2],
        provenance: Provenance,
    ) -> Result<ReproduceReport, ReproduceError> {
        if runs.is_empty() || defs.is_empty() {
            return Err(ReproduceError::EmptyReport);
        }
        let table1 = table1_rows(runs);
        let table2 = runs
            .iter()
            .map(|r| {
                let c = &r.classified;
                Table2Row {
                    metric: r.kind.label().to_string(),
                    interpolation: mean_sd(&c.prepared.interpolation_seconds),
                    transfer: mean_sd(&c.prepared.transfer_seconds),
                    pair: mean_sd(&c.pair_seconds),
                    wall: c.wall,
                    rounds: c.clustering.iterations,
                }
            })
            .collect();
        let table3 = noise.to_vec();
        Ok(ReproduceReport {
            provenance,
            deformations: defs.len(),
            level: settings.level,
            seed: settings.seed,
            vertices: defs[0].topology.n_vertices(),
            key_poses: defs[0].poses.len(),
            insert: settings.insert,
            poses: runs[0].classified.prepared.transferred[0].len(),
            steps: settings.steps,
            lambda: settings.lambda,
            transport: settings.transport.label().to_string(),
            base: defs[0].name.clone(),
            restarts: settings.restarts,
            table1,
            previous: Vec::new(),
            previous_names: Vec::new(),
            metric_names: runs.iter().map(|r| r.metric.clone()).collect(),
            max_rounds: IntrinsicOptions::default().max_iterations,
            unconverged: runs.iter().map(|r| r.classified.unconverged).sum(),
            prepared_converged: runs.iter().all(|r| r.classified.prepared.converged),
            table2,
            noise_metrics: settings
                .noise_kinds()
                .iter()
                .map(|k| k.label().to_string())
                .collect(),
            table3,
            fig4: fig4.to_string(),
            fig5: fig5.to_string(),
            figures: runs.iter().map(|r| r.kind.label().to_string()).collect(),
            partial: None,
        })
    }

    /// The report with the Table 1 rows of the previous configuration
    /// ([`Reproduction::run_previous`], one run per metric).
    pub fn with_previous(mut self, runs: &[MetricRun]) -> ReproduceReport {
        self.previous = table1_rows(runs);
        self.previous_names = runs.iter().map(|r| r.metric.clone()).collect();
        self
    }

    /// The report marked as partial: its first lines say "Partial report: still running
    /// (written after `after`)". The command writes one after each step (each metric of Table
    /// 1, Fig. 4, Fig. 5, each level of Table 3), so an interrupted run leaves the tables done
    /// so far; Fig. 4 and Fig. 5 sections are left out while their Markdown is empty.
    pub fn partial(mut self, after: impl Into<String>) -> ReproduceReport {
        self.partial = Some(after.into());
        self
    }

    /// `report.md`: every table beside the paper's numbers, the figures and the files.
    pub fn to_markdown(&self) -> String {
        let mut md = String::new();
        // Writing to a String cannot fail.
        let _ = self.write_markdown(&mut md);
        md
    }

    /// Writes [`ReproduceReport::to_markdown`] to `path` (atomically).
    pub fn write(&self, path: &Path) -> Result<(), ReproduceError> {
        let md = self.to_markdown();
        write_atomically(path, |w| w.write_all(md.as_bytes()))?;
        Ok(())
    }

    fn write_markdown(&self, md: &mut String) -> std::fmt::Result {
        writeln!(
            md,
            "# qcshape reproduction of the paper's synthetic experiments\n"
        )?;
        if let Some(after) = &self.partial {
            writeln!(
                md,
                "**Partial report: still running (written after {after}).** The sections below are \
                 the steps done so far; the final report replaces this file.\n"
            )?;
        }
        md.push_str(&self.provenance.to_markdown());
        writeln!(
            md,
            "Data: {} deformations (6 initial shapes x 8 deformations, `qcshape synth --level {} --seed {}`), \
             {} vertices, {} key poses, {} between key poses ({} per deformation), \
             geodesics with N = {} segments, metrics regularized with lambda = {} (eq. 11), \
             transfer by {} transport to the first pose of `{}`, k-means with intrinsic means \
             started from the best of {} seeded kernel k-means runs (k = 8). Data set: `data/manifest.csv`.\n",
            self.deformations,
            self.level,
            self.seed,
            self.vertices,
            self.key_poses,
            qcshape::numfmt::count(self.insert, "pose inserted", "poses inserted"),
            qcshape::numfmt::count(self.poses, "pose", "poses"),
            self.steps,
            self.lambda,
            self.transport,
            self.base,
            self.restarts
        )?;
        self.write_table1(md)?;
        self.write_table2(md)?;
        self.write_table3(md)?;
        self.write_figures(md)
    }

    fn write_table1(&self, md: &mut String) -> std::fmt::Result {
        writeln!(
            md,
            "## Table 1: classification of the 48 deformations into 8 classes\n"
        )?;
        writeln!(
            md,
            "| metric | specificity (%) | sensitivity (%) | paper specificity | paper sensitivity | kernel k-means spec. / sens. (%) | 1-NN (%) | ARI |"
        )?;
        writeln!(md, "|---|---|---|---|---|---|---|---|")?;
        for r in &self.table1 {
            let p = r.paper;
            writeln!(
                md,
                "| {} | {:.1} | {:.1} | {} | {} | {:.1} / {:.1} | {:.1} | {:.3} |",
                r.metric,
                100.0 * r.specificity,
                100.0 * r.sensitivity,
                p.map_or("-".into(), |p| format!("{:.1}", p.0)),
                p.map_or("-".into(), |p| format!("{:.1}", p.1)),
                100.0 * r.kernel_specificity,
                100.0 * r.kernel_sensitivity,
                100.0 * r.nn_accuracy,
                r.ari
            )?;
        }
        writeln!(
            md,
            "\nClasses come from k-means with intrinsic means (eq. 14: class means are deformations whose \
             poses are Karcher means, docs/method.md), started from the best of the seeded kernel k-means \
             runs on the squared similarities (whose own scores are in the sixth column); {} rounds \
             at most. Sensitivity and specificity follow eq. 15 on the average of the per-class one-vs-rest \
             confusion matrices after Hungarian matching of clusters to classes; with this reading the \
             sensitivity equals the matched accuracy and the specificity is never below it (the paper's \
             quasi-conformal row, 97.9 / 99.7, has specificity below sensitivity, so it cannot come from \
             this reading). 1-NN: leave-one-out nearest-neighbour accuracy on the similarity matrix \
             (no clustering). Metric names as computed: {}.",
            self.max_rounds,
            self.metric_names
                .iter()
                .map(|m| format!("`{m}`"))
                .collect::<Vec<_>>()
                .join(", ")
        )?;
        if self.vertices < 162 || self.steps < 4 {
            writeln!(
                md,
                "\nThis run is smaller than the paper's setting ({} vertices, N = {}, {}): it checks \
                 the pipeline end to end, its scores are not the paper's experiment. The full run \
                 (`qcshape reproduce`, 162 vertices, N = 4, 3 inserted poses) is the one the README \
                 compares with the paper.",
                self.vertices,
                self.steps,
                qcshape::numfmt::count(self.insert, "inserted pose", "inserted poses")
            )?;
        }
        if self.unconverged > 0 || !self.prepared_converged {
            writeln!(
                md,
                "\nWarning: {} pair(s) had a similarity geodesic that stopped at the iteration limit.",
                self.unconverged
            )?;
        }
        self.write_shares(md)?;
        self.write_previous(md)
    }

    /// Table 1 with the previous configuration beside the default's, when it was run.
    fn write_previous(&self, md: &mut String) -> std::fmt::Result {
        if self.previous.is_empty() {
            return Ok(());
        }
        writeln!(
            md,
            "\n### Table 1 with the previous configuration\n\nThe same pipeline with every metric on the \
             calibrated scale of the releases of 2026-12-04 to 2026-12-06 (eq. 3's and eq. 7's sums divided \
             by their scale at the base, no stretch term), beside the default (scale-invariant) rows above. \
             With eq. 7's terms the conformal and quasi-conformal geodesics shrink the shape on the way \
             (docs/method.md \"Scale-invariant forms\"). The paper's literal setting, lambda = 0 (section \
             2.1), leaves the conformal metrics' null space free (docs/method.md \"Metrics\").\n"
        )?;
        writeln!(
            md,
            "| metric | default spec. / sens. (%) | previous spec. / sens. (%) | default 1-NN (%) | previous 1-NN (%) | previous: regularizer share, median (%) | paper spec. / sens. |"
        )?;
        writeln!(md, "|---|---|---|---|---|---|---|")?;
        for p in &self.previous {
            let d = self.table1.iter().find(|r| r.metric == p.metric);
            writeln!(
                md,
                "| {} | {} | {:.1} / {:.1} | {} | {:.1} | {} | {} |",
                p.metric,
                d.map_or("-".into(), |d| format!(
                    "{:.1} / {:.1}",
                    100.0 * d.specificity,
                    100.0 * d.sensitivity
                )),
                100.0 * p.specificity,
                100.0 * p.sensitivity,
                d.map_or("-".into(), |d| format!("{:.1}", 100.0 * d.nn_accuracy)),
                100.0 * p.nn_accuracy,
                if p.shares.pairs > 0 {
                    format!("{:.1}", 100.0 * p.shares.median)
                } else {
                    "-".into()
                },
                p.paper.map_or("-".into(), |(s, e)| format!("{s:.1} / {e:.1}")),
            )?;
        }
        writeln!(
            md,
            "\nMetric names as computed: {}.",
            self.previous_names
                .iter()
                .map(|m| format!("`{m}`"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    }

    /// The L2 regularizer's share of the energy of each metric's matrix, and a warning for
    /// each metric whose matrix it dominates.
    fn write_shares(&self, md: &mut String) -> std::fmt::Result {
        writeln!(
            md,
            "\nEnergy share of the L2 regularizer (lambda = {}; its part of each pair's path energy, eq. 11, \
             summed over the poses):\n",
            self.lambda
        )?;
        writeln!(md, "| metric | min / median / max (%) | pairs above 50 % |")?;
        writeln!(md, "|---|---|---|")?;
        for r in &self.table1 {
            let s = &r.shares;
            writeln!(
                md,
                "| {} | {:.1} / {:.1} / {:.1} | {} of {} |",
                r.metric,
                100.0 * s.min,
                100.0 * s.median,
                100.0 * s.max,
                s.above_half,
                s.pairs
            )?;
        }
        for r in &self.table1 {
            if let Some(w) = r.shares.warning(&r.metric) {
                writeln!(md, "\n**Warning:** {w}.")?;
            }
        }
        Ok(())
    }

    fn write_table2(&self, md: &mut String) -> std::fmt::Result {
        writeln!(
            md,
            "\n## Table 2: time of each pipeline step for all {} deformations\n",
            self.deformations
        )?;
        writeln!(
            md,
            "| metric | interpolation, per deformation (s) | transfer, per deformation (s) | similarity, per pair (s) | wall clock: interpolation / transfer / similarity / intrinsic k-means (s) |"
        )?;
        writeln!(md, "|---|---|---|---|---|")?;
        for r in &self.table2 {
            let ((im, is), (tm, ts), (pm, ps)) = (r.interpolation, r.transfer, r.pair);
            writeln!(
                md,
                "| {} | {im:.4} ± {is:.4} | {tm:.4} ± {ts:.4} | {pm:.4} ± {ps:.4} | {:.2} / {:.2} / {:.2} / {:.2} ({}) |",
                r.metric,
                r.wall[0],
                r.wall[1],
                r.wall[2],
                r.wall[3],
                qcshape::numfmt::count(r.rounds, "round", "rounds")
            )?;
        }
        writeln!(
            md,
            "\nThe paper reports 40 ± 0.47, 102 ± 0.11 and 15 ± 0.28 *minutes* for the three steps on a \
             3 GHz Pentium. Per-item times are measured inside parallel loops (each item's own wall \
             time); the last column is the elapsed time of each step."
        )
    }

    /// The noise levels of Table 3's rows, in the order they were run.
    fn table3_levels(&self) -> Vec<f64> {
        let mut levels: Vec<f64> = Vec::new();
        for r in &self.table3 {
            if !levels.contains(&r.level) {
                levels.push(r.level);
            }
        }
        levels
    }

    /// The header of a Table 3 grid: the noise level, a column per metric, then `last`.
    fn write_table3_header(&self, md: &mut String, last: Option<&str>) -> std::fmt::Result {
        write!(md, "| noise variance (%) |")?;
        for m in &self.noise_metrics {
            write!(md, " {m} |")?;
        }
        let n = self.noise_metrics.len() + usize::from(last.is_some());
        match last {
            Some(l) => writeln!(md, " {l} |")?,
            None => writeln!(md)?,
        }
        writeln!(md, "|---|{}", "---|".repeat(n))
    }

    /// A Table 3 grid's rows, one per level: each metric's `cell` (uniform, Gaussian, in
    /// [0, 1]) in %, `-` for a run not done, then the paper's numbers when `paper`.
    fn write_table3_levels(
        &self,
        md: &mut String,
        cell: impl Fn(&Table3Row) -> (f64, f64),
        paper: bool,
    ) -> std::fmt::Result {
        for level in self.table3_levels() {
            write!(md, "| {} |", qcshape::numfmt::plain(level))?;
            for m in &self.noise_metrics {
                match self.table3.iter().find(|r| r.level == level && &r.metric == m) {
                    Some(r) => {
                        let (u, g) = cell(r);
                        write!(md, " {:.1} / {:.1} |", 100.0 * u, 100.0 * g)?
                    }
                    None => write!(md, " - |")?,
                }
            }
            match paper_table3(level).filter(|_| paper) {
                Some((u, g)) => writeln!(md, " {u:.1} / {g:.1} |")?,
                None if paper => writeln!(md, " - |")?,
                None => writeln!(md)?,
            }
        }
        Ok(())
    }

    fn write_table3(&self, md: &mut String) -> std::fmt::Result {
        if self.table3.is_empty() {
            return Ok(());
        }
        writeln!(md, "\n## Table 3: noise resistance, tau (%) uniform / Gaussian\n")?;
        self.write_table3_header(md, Some("paper (quasi-conformal)"))?;
        self.write_table3_levels(md, |r| (r.uniform, r.gaussian), true)?;
        writeln!(
            md,
            "\nMatched accuracy (eq. 15 sensitivity, %) of the same partitions against the true \
             classes, uniform / Gaussian; first row: the noise-free partition tau compares with:\n"
        )?;
        self.write_table3_header(md, None)?;
        write!(md, "| 0 (reference) |")?;
        for m in &self.noise_metrics {
            match self.table3.iter().find(|r| &r.metric == m) {
                Some(r) => write!(md, " {:.1} |", 100.0 * r.reference_accuracy)?,
                None => write!(md, " - |")?,
            }
        }
        writeln!(md)?;
        self.write_table3_levels(md, |r| r.accuracy, false)?;
        writeln!(
            md,
            "\nNoise is added to every key pose with per-coordinate variance `level/100 * lbar^2` \
             (lbar: the pose's mean edge length; docs/method.md); tau (eq. 17) is the share of \
             deformations whose cluster is unchanged against the same metric's noise-free run \
             (Table 1), after Hungarian matching of the clusters, so a noise-free partition that is \
             itself wrong lowers tau even where the noisy one is right: read tau beside the \
             accuracies. Each cell is one seeded run: one deformation moving costs 2.1 points \
             (1/48). The paper reports Table 3 for its quasi-conformal metric only."
        )?;
        let below: Vec<String> = self
            .noise_metrics
            .iter()
            .filter_map(|m| {
                let levels: Vec<String> = self
                    .table3
                    .iter()
                    .filter(|r| &r.metric == m)
                    .filter(|r| {
                        r.paper.is_some_and(|(u, g)| {
                            100.0 * r.uniform < u - 1e-9 || 100.0 * r.gaussian < g - 1e-9
                        })
                    })
                    .map(|r| format!("{} %", qcshape::numfmt::plain(r.level)))
                    .collect();
                (!levels.is_empty()).then(|| format!("{m} at {}", levels.join(", ")))
            })
            .collect();
        if below.is_empty() {
            return writeln!(
                md,
                "\nEvery metric's tau is at least the paper's at every level run."
            );
        }
        writeln!(
            md,
            "\nBelow the paper's tau: {}.{}",
            below.join("; "),
            if self.vertices < 162 {
                format!(
                    " These meshes are coarse ({} vertices). The noise is defined relative to the \
                     mean edge length, so on few, long edges it moves every vertex by a large share \
                     of the deformations themselves, and the short geodesics (N = {}) and few \
                     restarts ({}) of this run add to it; the full run, `qcshape reproduce`, uses \
                     162 vertices (docs/results.md).",
                    self.vertices, self.steps, self.restarts
                )
            } else {
                " docs/results.md measures why for the quasi-conformal metric.".to_string()
            }
        )
    }

    fn write_figures(&self, md: &mut String) -> std::fmt::Result {
        if !self.fig4.trim().is_empty() {
            writeln!(
                md,
                "\n## Fig. 4: interpolation of the middle pose (files in `fig4/`)\n"
            )?;
            writeln!(
                md,
                "The middle pose of every deformation is interpolated from its first and last poses \
                 (one inserted pose) and compared per vertex with the true middle pose. Bar chart: \
                 `fig4/interpolation.png` (and `.svg`); error maps of one case per metric: \
                 `fig4/*.ply`.\n"
            )?;
            writeln!(md, "{}", super::demote_headings(self.fig4.trim_end(), 1))?;
        }
        if !self.fig5.trim().is_empty() {
            writeln!(md, "\n## Fig. 5: deformation transfer (files in `fig5/`)\n")?;
            writeln!(
                md,
                "Analytic deformations of a sphere are transferred to other initial shapes and compared \
                 per vertex with the same analytic deformation applied to each shape directly.\n"
            )?;
            writeln!(md, "{}", super::demote_headings(self.fig5.trim_end(), 2))?;
        }
        writeln!(md, "\n## Fig. 6: MDS maps\n")?;
        writeln!(
            md,
            "Classical-start SMACOF maps of each similarity matrix (eq. 16); colour and marker: the \
             deformation's class (legend); `.svg` beside each PNG.\n"
        )?;
        for name in &self.figures {
            writeln!(md, "![Fig. 6: MDS map, {name} metric](fig6_mds_{name}.png)\n")?;
        }
        writeln!(md, "## Similarity matrices\n")?;
        writeln!(
            md,
            "Heat maps of the matrices, rows and columns ordered by class (white lines between \
             classes); the CSVs are {}.\n",
            self.figures
                .iter()
                .map(|n| format!("`similarity_{n}.csv`"))
                .collect::<Vec<_>>()
                .join(", ")
        )?;
        for name in &self.figures {
            writeln!(md, "![Similarity matrix, {name} metric](similarity_{name}.png)\n")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod validate_tests {
    use super::*;

    #[test]
    fn validate_names_the_bad_setting() {
        let ok = Reproduction {
            metrics: vec![MetricKind::QuasiConformal],
            ..Reproduction::quick()
        };
        assert!(ok.validate().is_ok());
        let msg = |r: Reproduction| r.validate().unwrap_err().to_string();
        assert!(msg(Reproduction {
            metrics: vec![],
            ..ok.clone()
        })
        .contains("--metrics"));
        assert!(msg(Reproduction {
            lambda: -1.0,
            ..ok.clone()
        })
        .contains("--lambda"));
        assert!(msg(Reproduction {
            lambda: f64::NAN,
            ..ok.clone()
        })
        .contains("--lambda"));
        assert!(msg(Reproduction {
            steps: 0,
            ..ok.clone()
        })
        .contains("--steps"));
        let other = Reproduction {
            noise_metrics: vec![MetricKind::QuasiConformal, MetricKind::Isometric],
            ..ok.clone()
        };
        assert!(msg(other).contains("--noise-metrics isometric is not among --metrics"));
        // The default: every metric, the paper's rows first.
        use MetricKind::*;
        assert_eq!(
            table1_metrics(),
            [Rigid, Isometric, Conformal, QuasiConformal, L2]
        );
        // Empty: every metric of Table 1, in its order.
        let all = Reproduction {
            metrics: vec![MetricKind::L2, MetricKind::Isometric],
            ..ok.clone()
        };
        assert_eq!(all.noise_kinds(), [MetricKind::L2, MetricKind::Isometric]);
        let one = Reproduction {
            noise_metrics: vec![MetricKind::Isometric],
            ..all
        };
        assert_eq!(one.noise_kinds(), [MetricKind::Isometric]);
        assert!(msg(Reproduction { restarts: 0, ..ok }).contains("--restarts"));
    }
}
