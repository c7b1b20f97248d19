//! The classification study of section 4.3 (Tables 4 and 5) on deformations of one
//! connectivity: closed cycles, interpolation, parallel transport to the first subject's
//! frame 0, similarity (eq. 13), a 2-cluster split, sensitivity and specificity beside the two
//! radial baselines of [`super::analysis`]. Results are plain [`Serialize`] structs; the
//! Markdown and CSV writers are in [`super::study_report`].

use std::path::PathBuf;
use std::time::Instant;

use serde::Serialize;
use thiserror::Error;

use super::analysis::{close_cycle, drop_closing_pose, radial_features, Axis, LvAnalysisError};
use super::cohort::LvError;
use crate::plot::PlotError;
use qcshape::cluster::{intrinsic_kmeans, IntrinsicError, IntrinsicOptions};
use qcshape::cluster::{kernel_kmeans, ClusterError, ClusterMethod, ClusterOptions, Clustering};
use qcshape::dataset::{DatasetError, Deformation};
use qcshape::embed::MdsError;
use qcshape::eval::{
    adjusted_rand_index, encode_labels, loo_nearest_neighbour_accuracy, matched_confusion, one_vs_rest,
    EvalError,
};
use qcshape::geodesic::{GeodesicError, GeodesicSolver, InterpolationError};
use qcshape::io::IoError;
use qcshape::multires::{Hierarchy, HierarchyError};
use qcshape::similarity::{
    compute, prepare, DistanceMatrix, Event, MatrixError, MatrixFileError, PipelineError, PipelineOptions,
    Prepared, Run, ShareSummary, Stage,
};

/// Why a study step failed. Messages name the subject, file or option.
#[derive(Debug, Error)]
pub enum StudyError {
    /// A cohort folder problem (images, landmarks, layout).
    #[error(transparent)]
    Lv(#[from] LvError),
    /// A meshed data set cannot be read or written.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// An analysis helper failed for one subject.
    #[error("subject '{subject}': {error}")]
    Subject {
        /// The subject.
        subject: String,
        /// Why.
        error: LvAnalysisError,
    },
    /// An analysis helper failed.
    #[error(transparent)]
    Analysis(#[from] LvAnalysisError),
    /// Interpolation, transfer or similarity failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// A geodesic solver cannot be built.
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// A cycle cannot be interpolated.
    #[error(transparent)]
    Interpolation(#[from] InterpolationError),
    /// The coarsening hierarchy cannot be built.
    #[error(transparent)]
    Hierarchy(#[from] HierarchyError),
    /// Clustering failed.
    #[error(transparent)]
    Cluster(#[from] ClusterError),
    /// Intrinsic k-means failed.
    #[error(transparent)]
    Intrinsic(#[from] IntrinsicError),
    /// Scores cannot be computed.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// A distance matrix is invalid.
    #[error(transparent)]
    Matrix(#[from] MatrixError),
    /// A distance matrix file cannot be written.
    #[error(transparent)]
    MatrixFile(#[from] MatrixFileError),
    /// An MDS map cannot be computed.
    #[error(transparent)]
    Mds(#[from] MdsError),
    /// A figure cannot be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// The motion map (localize) failed.
    #[error(transparent)]
    Localize(#[from] crate::localize::LocalizeError),
    /// A map's files could not be written.
    #[error(transparent)]
    MapFile(#[from] crate::localize::MapFileError),
    /// A file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A folder cannot be created.
    #[error("cannot create {}: {source}", path.display())]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A report cannot be formatted.
    #[error(transparent)]
    Fmt(#[from] std::fmt::Error),
    /// A deformation given as input has no long axis (its frame 0 is degenerate).
    #[error("deformation '{name}': {error}")]
    Deformation {
        /// The deformation.
        name: String,
        /// Why.
        error: LvAnalysisError,
    },
    /// A subject's landmarks lack one needed for the long axis in frame 0.
    #[error("{}: landmark {id} is missing in frame 0 (needed for the long axis)", path.display())]
    MissingLandmark {
        /// The landmark file.
        path: PathBuf,
        /// The landmark id.
        id: u32,
    },
    /// Fewer landmarks per frame than asked for.
    #[error("{}: has {found} landmarks per frame, fewer than the {asked} asked for", path.display())]
    TooFewLandmarks {
        /// The landmark file.
        path: PathBuf,
        /// Landmarks per frame.
        found: usize,
        /// Landmarks asked for.
        asked: usize,
    },
    /// A cohort folder with fewer than two subjects.
    #[error("{}: a cohort needs at least two subjects", .0.display())]
    TooFewSubjects(PathBuf),
    /// A subject whose landmark ids differ from the first subject's.
    #[error("{}: landmark ids {ids:?} differ from those of {first} ({first_ids:?}): subjects cannot be matched", path.display())]
    LandmarkIds {
        /// The landmark file.
        path: PathBuf,
        /// Its ids.
        ids: Vec<u32>,
        /// The first subject.
        first: String,
        /// The first subject's ids.
        first_ids: Vec<u32>,
    },
    /// A subject with a different number of image frames than landmark frames.
    #[error("{}: {images} image frames but {landmarks} landmark frames", path.display())]
    FrameCounts {
        /// The subject's folder.
        path: PathBuf,
        /// Image frames.
        images: usize,
        /// Landmark frames.
        landmarks: usize,
    },
    /// A subject with a different number of landmark frames than registration maps.
    #[error("{}: {frames} frames of landmarks but {maps} registration maps", path.display())]
    RegistrationCount {
        /// The landmark file.
        path: PathBuf,
        /// Landmark frames.
        frames: usize,
        /// Registration maps.
        maps: usize,
    },
    /// A cycle of fewer than two frames.
    #[error("a cycle needs at least two frames, got {0}")]
    ShortCycle(usize),
    /// `--tps-lambda` given with meshes as input (it acts on a cohort folder's registration).
    #[error("{}: --tps-lambda acts on the landmark registration of a cohort folder, not on meshes given as input", .0.display())]
    TpsLambdaOnMeshes(PathBuf),
    /// `--mds-subject` names no subject.
    #[error("--mds-subject {0:?} is not a subject")]
    UnknownSubject(String),
    /// Labels naming other than two classes (sensitivity and specificity need two).
    #[error("two classes are needed for sensitivity and specificity, the labels name {}: {classes:?}", classes.len())]
    ClassCount {
        /// The classes the labels name.
        classes: Vec<String>,
    },
    /// A deformation without a class label.
    #[error("deformation '{deformation}' has no class label")]
    NoLabel {
        /// The deformation's name.
        deformation: String,
    },
    /// Deformations on different connectivities (they cannot be compared pose by pose).
    #[error("the deformations do not share one connectivity: they cannot be compared pose by pose")]
    SharedTopology,
}

/// A progress report: one more item of `what` (of `total`) is done. `Tick::DONE` (an empty
/// `what`) says the current stages are over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tick<'a> {
    /// The stage ("interpolating", "pairs", "meshing (n=16)", ...).
    pub what: &'a str,
    /// Items of that stage.
    pub total: usize,
}

impl Tick<'static> {
    /// The end of the current stages.
    pub const DONE: Tick<'static> = Tick { what: "", total: 0 };
}

/// A progress callback (called from worker threads).
pub type Progress<'a> = &'a (dyn Fn(Tick<'_>) + Sync);

/// Sensitivity and specificity of a two-class clustering (Table 4).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BinaryScores {
    /// The positive class (`hcm`, else the second class in order of appearance).
    pub positive: String,
    /// The other class.
    pub negative: String,
    /// TP / (TP + FN) of the positive class after Hungarian matching.
    pub sensitivity: f64,
    /// TN / (TN + FP): negatives predicted negative.
    pub specificity: f64,
    /// Share of items in the cluster matched to their class.
    pub accuracy: f64,
    /// [TP, FN, FP, TN] (items in an unmatched cluster count as misses).
    pub counts: [f64; 4],
    /// Eq. 15 sensitivity and specificity on the averaged one-vs-rest matrices (the
    /// `classify` reading).
    pub eq15: (f64, f64),
    /// Leave-one-out 1-nearest-neighbour accuracy on the distances (no clustering).
    pub nn_accuracy: f64,
    /// Adjusted Rand index of the clusters against the classes.
    pub ari: f64,
}

/// Scores a clustering (`assignments` in `0..k`) of the items of `d` against two classes.
pub fn binary_scores(
    d: &DistanceMatrix,
    assignments: &[usize],
    k: usize,
    labels: &[String],
) -> Result<BinaryScores, StudyError> {
    let (class_of, classes) = encode_labels(labels);
    if classes.len() != 2 {
        return Err(StudyError::ClassCount { classes });
    }
    let (_, confusion) = matched_confusion(assignments, k, &class_of, 2)?;
    let eq15 = one_vs_rest(&confusion)?;
    let pos = classes.iter().position(|c| c == "hcm").unwrap_or(1);
    let b = eq15.per_class[pos];
    Ok(BinaryScores {
        positive: classes[pos].clone(),
        negative: classes[1 - pos].clone(),
        sensitivity: b.sensitivity(),
        specificity: b.specificity(),
        accuracy: confusion.accuracy(),
        counts: [b.tp, b.fn_, b.fp, b.tn],
        eq15: (eq15.sensitivity, eq15.specificity),
        nn_accuracy: loo_nearest_neighbour_accuracy(d, &class_of)?,
        ari: adjusted_rand_index(assignments, &class_of)?,
    })
}

/// How the subjects are split in two.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SplitOptions {
    /// The method.
    pub method: ClusterMethod,
    /// Seeded restarts (>= 1).
    pub restarts: usize,
    /// Seed of every random choice.
    pub seed: u64,
}

impl SplitOptions {
    /// The method in a sentence (`k-means (kernel k-means on squared similarities)` for the
    /// default).
    pub fn sentence(&self) -> String {
        match self.method {
            ClusterMethod::KernelKMeans => "k-means (kernel k-means on squared similarities)".into(),
            m => m.describe(),
        }
    }

    fn cluster_options(&self) -> ClusterOptions {
        ClusterOptions {
            k: 2,
            restarts: self.restarts,
            seed: self.seed,
            max_iterations: 100,
        }
    }
}

/// Splits the items of `d` in two with a matrix method (`Intrinsic` needs [`split_prepared`]).
pub fn split_matrix(d: &DistanceMatrix, s: &SplitOptions) -> Result<Clustering, StudyError> {
    Ok(s.method.on_matrix(d, &s.cluster_options())?)
}

/// Splits prepared deformations in two: a matrix method on `d`, or intrinsic k-means (eq. 14)
/// on the transferred deformations (solver units) from the kernel k-means partition.
pub fn split_prepared(
    prepared: &Prepared,
    opts: &PipelineOptions,
    d: &DistanceMatrix,
    s: &SplitOptions,
) -> Result<Clustering, StudyError> {
    if s.method != ClusterMethod::Intrinsic {
        return split_matrix(d, s);
    }
    let start = kernel_kmeans(d, &s.cluster_options())?;
    let metric = prepared.metric(&opts.metric);
    let solver = GeodesicSolver::new(metric.as_ref(), prepared.topology.clone(), opts.geodesic.clone())?;
    let r = intrinsic_kmeans(
        &solver,
        &prepared.scaled(),
        &start.assignments,
        2,
        &IntrinsicOptions::default(),
    )?;
    Ok(Clustering {
        k: 2,
        medoids: None,
        objective: r.objective,
        iterations: r.iterations,
        converged: r.converged,
        restart: start.restart,
        restart_objectives: vec![r.objective],
        assignments: r.assignments,
    })
}

/// One run of the classification pipeline on deformations of one connectivity.
#[derive(Debug, Clone, Serialize)]
pub struct Analysis {
    /// Interpolated and transferred deformations (not serialized).
    #[serde(skip)]
    pub prepared: Prepared,
    /// The similarity matrix (eq. 13), n x n, in the metric's units (not serialized: written as
    /// `similarity.csv`).
    #[serde(skip)]
    pub matrix: DistanceMatrix,
    /// The 2-cluster split.
    pub clustering: Clustering,
    /// Its scores.
    pub scores: BinaryScores,
    /// Seconds of each similarity pair `(i, j, s)`.
    pub pair_seconds: Vec<(usize, usize, f64)>,
    /// Wall seconds: interpolation + transfer, similarity, clustering.
    pub wall: [f64; 3],
    /// Geodesic solves that stopped at the iteration limit.
    pub unconverged: usize,
    /// The L2 regularizer's share of the energy over the similarity pairs.
    pub shares: ShareSummary,
}

/// The class label of every deformation (an error names the first one without).
pub fn labels_of(defs: &[Deformation]) -> Result<Vec<String>, StudyError> {
    defs.iter()
        .map(|d| {
            d.label.clone().ok_or_else(|| StudyError::NoLabel {
                deformation: d.name.clone(),
            })
        })
        .collect()
}

/// Alignment to the base (`opts.align`), interpolation (closed cycle unless `open`),
/// transfer to the first deformation's frame 0, similarity (eq. 13), the 2-cluster split and
/// its scores.
pub fn analyse(
    defs: &[Deformation],
    opts: &PipelineOptions,
    open: bool,
    split: &SplitOptions,
    progress: Progress<'_>,
) -> Result<Analysis, StudyError> {
    let labels = labels_of(defs)?;
    let data: Vec<Deformation> = defs
        .iter()
        .map(|d| Deformation {
            poses: if open {
                d.poses.clone()
            } else {
                close_cycle(&d.poses)
            },
            ..d.clone()
        })
        .collect();
    let t0 = Instant::now();
    let n = defs.len();
    let mut prepared = prepare(&data, opts, &|e| match e {
        Event::Prepared {
            stage: Stage::Interpolation,
            ..
        } => progress(Tick {
            what: "interpolating",
            total: n,
        }),
        Event::Prepared {
            stage: Stage::Transfer,
            ..
        } => progress(Tick {
            what: "transferring",
            total: n,
        }),
        _ => {}
    })?;
    progress(Tick::DONE);
    if !open {
        prepared.interpolated.iter_mut().for_each(drop_closing_pose);
        prepared.transferred.iter_mut().for_each(drop_closing_pose);
        drop_closing_pose(&mut prepared.is_key);
    }
    let t_prep = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let total = n * (n - 1) / 2;
    let run = Run {
        events: &|e| {
            if let Event::Pair(_) = e {
                progress(Tick { what: "pairs", total });
            }
        },
        ..Default::default()
    };
    let outcome = compute(&prepared.comparison(), opts, &run)?;
    progress(Tick::DONE);
    let t_sim = t1.elapsed().as_secs_f64();
    let (pairs, matrix) = (outcome.pairs, outcome.matrix.expect("all pairs"));
    let t2 = Instant::now();
    let clustering = split_prepared(&prepared, opts, &matrix, split)?;
    let scores = binary_scores(&matrix, &clustering.assignments, 2, &labels)?;
    Ok(Analysis {
        unconverged: pairs.iter().filter(|p| !p.converged).count() + usize::from(!prepared.converged),
        shares: ShareSummary::of(&pairs),
        pair_seconds: pairs.iter().map(|p| (p.i, p.j, p.seconds)).collect(),
        wall: [t_prep, t_sim, t2.elapsed().as_secs_f64()],
        prepared,
        matrix,
        clustering,
        scores,
    })
}

/// A baseline of Table 4: one feature per subject, split in two on it.
#[derive(Debug, Clone, Serialize)]
pub struct Baseline {
    /// Its name ("mean systolic radial displacement", "mean radial velocity").
    pub name: &'static str,
    /// The feature of each subject (mm, mm per frame).
    pub values: Vec<f64>,
    /// The split.
    pub clustering: Clustering,
    /// Its scores.
    pub scores: BinaryScores,
}

impl Baseline {
    /// The distance matrix `|x_i - x_j|` of the feature (n x n, mm or mm per frame).
    pub fn matrix(&self, names: &[String]) -> Result<DistanceMatrix, StudyError> {
        let v = &self.values;
        Ok(DistanceMatrix::from_fn(names.to_vec(), |i, j| {
            (v[i] - v[j]).abs()
        })?)
    }
}

/// The radial baselines and each subject's (ED, ES) frames.
#[derive(Debug, Clone, Serialize)]
pub struct Baselines {
    /// Mean systolic radial displacement, then mean radial velocity.
    pub rows: Vec<Baseline>,
    /// End-diastolic and end-systolic frame of each subject.
    pub ed_es: Vec<(usize, usize)>,
}

/// Radial baselines of the key frames (frame interval 1), each split in two with `split`
/// (`Intrinsic` falls back to kernel k-means: a feature has no deformations).
pub fn baselines(
    defs: &[Deformation],
    axes: &[Axis],
    open: bool,
    split: &SplitOptions,
) -> Result<Baselines, StudyError> {
    let labels = labels_of(defs)?;
    let mut sys = Vec::new();
    let mut vel = Vec::new();
    let mut ed_es = Vec::new();
    for (d, a) in defs.iter().zip(axes) {
        let f = radial_features(&d.poses, a, 1.0, !open).map_err(|error| StudyError::Subject {
            subject: d.name.clone(),
            error,
        })?;
        sys.push(f.systolic_displacement);
        vel.push(f.mean_velocity);
        ed_es.push((f.ed_frame, f.es_frame));
    }
    let names: Vec<String> = defs.iter().map(|d| d.name.clone()).collect();
    let split = SplitOptions {
        method: match split.method {
            ClusterMethod::Intrinsic => ClusterMethod::KernelKMeans,
            m => m,
        },
        ..*split
    };
    let mut rows = Vec::new();
    for (name, values) in [
        ("mean systolic radial displacement", sys),
        ("mean radial velocity", vel),
    ] {
        let d = DistanceMatrix::from_fn(names.clone(), |i, j| (values[i] - values[j]).abs())?;
        let clustering = split_matrix(&d, &split)?;
        let scores = binary_scores(&d, &clustering.assignments, 2, &labels)?;
        rows.push(Baseline {
            name,
            values,
            clustering,
            scores,
        });
    }
    Ok(Baselines { rows, ed_es })
}

/// Coarsens deformations of one connectivity to about `vertices` vertices (a subset of the
/// vertices chosen on the first deformation's frame 0); returns a note, or `None` when
/// nothing was to be done.
pub fn coarsen(defs: &mut [Deformation], vertices: usize) -> Result<Option<String>, StudyError> {
    let Some(first) = defs.first() else {
        return Ok(None);
    };
    let nv = first.topology.n_vertices();
    if vertices == 0 || nv <= vertices {
        return Ok(None);
    }
    if defs.iter().any(|d| d.topology.faces() != first.topology.faces()) {
        return Err(StudyError::SharedTopology);
    }
    let ratio = (vertices as f64 / nv as f64).clamp(0.01, 0.99);
    let h = Hierarchy::new(&first.topology, &first.poses[0], 2, ratio)?;
    if h.n_levels() < 2 {
        return Ok(Some(format!(
            "not coarsened ({})",
            h.stopped().unwrap_or("no coarse level")
        )));
    }
    let level = h.level(1);
    for d in defs.iter_mut() {
        d.poses = d.poses.iter().map(|p| level.restrict(p)).collect();
        d.topology = level.topology.clone();
    }
    Ok(Some(format!(
        "coarsened from {nv} to {} vertices (a vertex subset)",
        level.n_vertices()
    )))
}

/// One row of the clustering comparison: a method on one matrix.
#[derive(Debug, Clone, Serialize)]
pub struct MethodRow {
    /// The matrix: `similarity` or a baseline's name.
    pub data: String,
    /// The method (its command-line name).
    pub method: String,
    /// The 2-cluster split's scores.
    pub scores: BinaryScores,
}

/// Every method of `methods` on the similarity matrix of `main` and on each baseline's
/// feature matrix (`Intrinsic` only on the similarity: a feature has no deformations), with
/// the restarts and seed of `split`.
pub fn compare_methods(
    main: &Analysis,
    opts: &PipelineOptions,
    base: &Baselines,
    labels: &[String],
    methods: &[ClusterMethod],
    split: &SplitOptions,
) -> Result<Vec<MethodRow>, StudyError> {
    let mut rows = Vec::new();
    let names = main.matrix.names().to_vec();
    let mut data: Vec<(String, DistanceMatrix)> = vec![("similarity".into(), main.matrix.clone())];
    for b in &base.rows {
        data.push((b.name.to_string(), b.matrix(&names)?));
    }
    for (k, (name, d)) in data.iter().enumerate() {
        for &method in methods {
            if k > 0 && method == ClusterMethod::Intrinsic {
                continue;
            }
            let s = SplitOptions { method, ..*split };
            let c = split_prepared(&main.prepared, opts, d, &s)?;
            rows.push(MethodRow {
                data: name.clone(),
                method: method.to_string(),
                scores: binary_scores(d, &c.assignments, 2, labels)?,
            });
        }
    }
    Ok(rows)
}
