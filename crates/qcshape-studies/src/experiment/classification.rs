//! Classification of deformations (paper section 3.3, Table 1; the step Table 3 repeats on
//! noisy data): the similarity matrix (eq. 13) of a data set, kernel k-means on it, k-means with
//! intrinsic means (eq. 14) started from that partition, and the scores of a partition against
//! known classes (eq. 15 sensitivity and specificity, leave-one-out 1-NN accuracy, adjusted Rand
//! index), with the CSV writers of the assignments and the matched confusion matrix.
//!
//! [`classify_set`] is the whole chain for one data set; [`cluster_intrinsic`] is its last step
//! on a matrix computed elsewhere (e.g. a resumable journaled run); [`score`] scores any
//! partition.

use std::path::Path;
use std::time::Instant;

use thiserror::Error;

use qcshape::cluster::{intrinsic_kmeans, IntrinsicError, IntrinsicOptions};
use qcshape::cluster::{kernel_kmeans, ClusterError, ClusterOptions, Clustering};
use qcshape::dataset::Deformation;
use qcshape::eval::{
    adjusted_rand_index, encode_labels, loo_nearest_neighbour_accuracy, matched_confusion, one_vs_rest,
    ConfusionMatrix, EvalError, Matching, OneVsRest,
};
use qcshape::geodesic::{GeodesicError, GeodesicSolver};
use qcshape::io::{write_atomically, IoError};
use qcshape::similarity::{
    compute, prepare, DistanceMatrix, Event, MatrixError, PipelineError, PipelineOptions, Prepared, Run,
    ShareSummary, Stage,
};

/// Why a classification or its scoring failed.
#[derive(Debug, Error)]
pub enum ClassificationError {
    /// The labels name fewer than two classes: there is nothing to score.
    #[error("the labels name only one class ({0:?}): nothing to score")]
    OneClass(String),
    /// Interpolation, transfer or similarity failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The pairwise distances do not make a distance matrix.
    #[error(transparent)]
    Matrix(#[from] MatrixError),
    /// Kernel k-means failed (bad `k`, too few items).
    #[error(transparent)]
    Cluster(#[from] ClusterError),
    /// The geodesic solver of the intrinsic means cannot be set up.
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// k-means with intrinsic means failed.
    #[error(transparent)]
    Intrinsic(#[from] IntrinsicError),
    /// A score cannot be computed.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// A CSV record cannot be encoded (the csv crate's error, kept).
    #[error("cannot encode CSV: {error}")]
    Csv {
        /// The csv crate's error.
        error: csv::Error,
    },
    /// An output file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
}

/// Scores of a partition against known classes.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Scores {
    /// The class names (c), in order of first appearance in the labels.
    pub classes: Vec<String>,
    /// The class index of each item (n, `< c`).
    pub class_of: Vec<usize>,
    /// The Hungarian matching of clusters to classes.
    pub matching: Matching,
    /// The matched confusion matrix (rows: actual class; columns: class matched to the cluster,
    /// and one last column for items in unmatched clusters).
    pub confusion: ConfusionMatrix,
    /// Eq. 15 on the mean of the per-class one-vs-rest matrices.
    pub eq15: OneVsRest,
    /// Leave-one-out 1-nearest-neighbour accuracy on the distance matrix, in [0, 1] (no
    /// clustering).
    pub nn_accuracy: f64,
    /// Adjusted Rand index of the partition against the classes.
    pub ari: f64,
}

/// Scores the partition `c` of the items of `d` against their class `labels` (n, matrix order).
/// Needs at least two classes.
pub fn score(d: &DistanceMatrix, c: &Clustering, labels: &[String]) -> Result<Scores, ClassificationError> {
    let (class_of, classes) = encode_labels(labels);
    if classes.len() < 2 {
        return Err(ClassificationError::OneClass(
            classes.first().cloned().unwrap_or_default(),
        ));
    }
    let (matching, confusion) = matched_confusion(&c.assignments, c.k, &class_of, classes.len())?;
    Ok(Scores {
        eq15: one_vs_rest(&confusion)?,
        nn_accuracy: loo_nearest_neighbour_accuracy(d, &class_of)?,
        ari: adjusted_rand_index(&c.assignments, &class_of)?,
        classes,
        class_of,
        matching,
        confusion,
    })
}

fn csv_bytes(
    fill: impl FnOnce(&mut csv::Writer<Vec<u8>>) -> Result<(), csv::Error>,
) -> Result<Vec<u8>, ClassificationError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    fill(&mut w).map_err(|error| ClassificationError::Csv { error })?;
    w.into_inner().map_err(|e| ClassificationError::Csv {
        error: csv::Error::from(e.into_error()),
    })
}

/// The assignments as CSV: `name,cluster` per item of `d`, with `label,matched_label` (the
/// item's class and the class matched to its cluster, empty if none) when `scores` are given.
pub fn assignments_csv(
    d: &DistanceMatrix,
    c: &Clustering,
    scores: Option<&Scores>,
) -> Result<Vec<u8>, ClassificationError> {
    csv_bytes(|w| {
        match scores {
            Some(_) => w.write_record(["name", "cluster", "label", "matched_label"])?,
            None => w.write_record(["name", "cluster"])?,
        }
        for (i, name) in d.names().iter().enumerate() {
            let cluster = c.assignments[i].to_string();
            match scores {
                Some(s) => {
                    let matched =
                        s.matching.cluster_class[c.assignments[i]].map_or("", |k| s.classes[k].as_str());
                    w.write_record([name.as_str(), &cluster, &s.classes[s.class_of[i]], matched])?;
                }
                None => w.write_record([name.as_str(), &cluster])?,
            }
        }
        Ok(())
    })
}

/// The matched confusion matrix as CSV: header `actual,<class_1>,...,<class_c>,unmatched`, one
/// row of counts per actual class.
pub fn confusion_csv(s: &Scores) -> Result<Vec<u8>, ClassificationError> {
    csv_bytes(|w| {
        let mut header = vec!["actual".to_string()];
        header.extend(s.classes.iter().cloned());
        header.push("unmatched".into());
        w.write_record(&header)?;
        for (k, row) in s.confusion.counts.iter().enumerate() {
            let mut rec = vec![s.classes[k].clone()];
            rec.extend(row.iter().map(usize::to_string));
            w.write_record(&rec)?;
        }
        Ok(())
    })
}

/// Writes [`assignments_csv`] to `path` (atomically).
pub fn write_assignments(
    path: &Path,
    d: &DistanceMatrix,
    c: &Clustering,
    scores: Option<&Scores>,
) -> Result<(), ClassificationError> {
    let bytes = assignments_csv(d, c, scores)?;
    write_atomically(path, |o| o.write_all(&bytes))?;
    Ok(())
}

/// Writes [`confusion_csv`] to `path` (atomically).
pub fn write_confusion(path: &Path, s: &Scores) -> Result<(), ClassificationError> {
    let bytes = confusion_csv(s)?;
    write_atomically(path, |o| o.write_all(&bytes))?;
    Ok(())
}

/// A data set classified by [`classify_set`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct Classified {
    /// The deformations interpolated and transferred to the common base.
    #[serde(skip)]
    pub prepared: Prepared,
    /// The similarity matrix (eq. 13; n x n, in units of the base pose's mean edge length).
    pub matrix: DistanceMatrix,
    /// The best kernel k-means partition (the start of the intrinsic k-means).
    pub kernel: Clustering,
    /// k-means with intrinsic means (eq. 14).
    pub clustering: Clustering,
    /// Seconds of each pair's similarity (n (n - 1) / 2, row order), measured inside the
    /// parallel loop.
    pub pair_seconds: Vec<f64>,
    /// Elapsed seconds of the steps: interpolation, transfer, similarity, intrinsic k-means.
    /// Interpolation and transfer run in one pass; its time is split in proportion to their
    /// summed per-deformation times.
    pub wall: [f64; 4],
    /// Pairs whose similarity geodesic stopped at the iteration limit.
    pub unconverged: usize,
    /// The L2 regularizer's share of the pairs' energy, over the pairs of the matrix.
    pub shares: ShareSummary,
}

/// Interpolation, transfer, similarity (eq. 13), kernel k-means (the best of `restarts` seeded
/// runs) and k-means with intrinsic means (eq. 14) of `defs` into `k` classes.
/// `progress(stage)` is called as each deformation finishes interpolation and transfer, and as
/// each pair finishes.
pub fn classify_set(
    defs: &[Deformation],
    opts: &PipelineOptions,
    k: usize,
    restarts: usize,
    seed: u64,
    progress: &(dyn Fn(Stage) + Sync),
) -> Result<Classified, ClassificationError> {
    let t0 = Instant::now();
    let prepared = prepare(defs, opts, &|e| {
        if let Event::Prepared { stage, .. } = e {
            progress(stage)
        }
    })?;
    let t_prepare = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let run = Run {
        events: &|e| {
            if let Event::Pair(_) = e {
                progress(Stage::Similarity);
            }
        },
        ..Default::default()
    };
    let outcome = compute(&prepared.comparison(), opts, &run)?;
    let t_sim = t1.elapsed().as_secs_f64();
    let (pairs, matrix) = (outcome.pairs, outcome.matrix.expect("all pairs"));
    let t2 = Instant::now();
    let (kernel, clustering) = cluster_intrinsic(&matrix, &prepared, opts, k, restarts, seed)?;
    let t_kmeans = t2.elapsed().as_secs_f64();
    let (ti, tt): (f64, f64) = (
        prepared.interpolation_seconds.iter().sum(),
        prepared.transfer_seconds.iter().sum(),
    );
    let share = if ti + tt > 0.0 { ti / (ti + tt) } else { 0.5 };
    Ok(Classified {
        unconverged: pairs.iter().filter(|p| !p.converged).count(),
        shares: ShareSummary::of(&pairs),
        pair_seconds: pairs.iter().map(|p| p.seconds).collect(),
        wall: [t_prepare * share, t_prepare * (1.0 - share), t_sim, t_kmeans],
        prepared,
        matrix,
        kernel,
        clustering,
    })
}

/// Kernel k-means of `matrix` (the best of `restarts` seeded runs, at most 100 Lloyd
/// iterations each), then k-means with intrinsic means (eq. 14) of the prepared deformations
/// started from it. Returns both partitions: (kernel k-means, intrinsic k-means).
pub fn cluster_intrinsic(
    matrix: &DistanceMatrix,
    prepared: &Prepared,
    opts: &PipelineOptions,
    k: usize,
    restarts: usize,
    seed: u64,
) -> Result<(Clustering, Clustering), ClassificationError> {
    let kernel = kernel_kmeans(
        matrix,
        &ClusterOptions {
            k,
            restarts,
            seed,
            max_iterations: 100,
        },
    )?;
    let metric = prepared.metric(&opts.metric);
    let solver = GeodesicSolver::new(metric.as_ref(), prepared.topology.clone(), opts.geodesic.clone())?;
    let intrinsic = intrinsic_kmeans(
        &solver,
        &prepared.scaled(),
        &kernel.assignments,
        k,
        &IntrinsicOptions::default(),
    )?;
    let clustering = Clustering {
        k,
        assignments: intrinsic.assignments,
        medoids: None,
        objective: intrinsic.objective,
        iterations: intrinsic.iterations,
        converged: intrinsic.converged,
        restart: 0,
        restart_objectives: Vec::new(),
    };
    Ok((kernel, clustering))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn matrix() -> DistanceMatrix {
        // Two tight pairs far apart: {a, b} and {c, d}.
        let names = ["a", "b", "c", "d"].map(String::from).to_vec();
        let x: [f64; 4] = [0.0, 0.1, 5.0, 5.1];
        let values = (0..16).map(|k| (x[k / 4] - x[k % 4]).abs()).collect();
        DistanceMatrix::new(names, values).unwrap()
    }

    fn clustering(assignments: Vec<usize>) -> Clustering {
        Clustering {
            k: 2,
            assignments,
            medoids: None,
            objective: 0.0,
            iterations: 1,
            converged: true,
            restart: 0,
            restart_objectives: Vec::new(),
        }
    }

    #[test]
    fn a_perfect_partition_scores_one() {
        let d = matrix();
        let labels = ["x", "x", "y", "y"].map(String::from).to_vec();
        let s = score(&d, &clustering(vec![1, 1, 0, 0]), &labels).unwrap();
        assert_eq!(s.classes, ["x", "y"]);
        assert_eq!(s.eq15.sensitivity, 1.0);
        assert_eq!(s.eq15.specificity, 1.0);
        assert_eq!(s.nn_accuracy, 1.0);
        assert!((s.ari - 1.0).abs() < 1e-12);
        assert_eq!(s.matching.cluster_class, [Some(1), Some(0)]);
        let csv =
            String::from_utf8(assignments_csv(&d, &clustering(vec![1, 1, 0, 0]), Some(&s)).unwrap()).unwrap();
        assert_eq!(
            csv,
            "name,cluster,label,matched_label\na,1,x,x\nb,1,x,x\nc,0,y,y\nd,0,y,y\n"
        );
        let csv = String::from_utf8(confusion_csv(&s).unwrap()).unwrap();
        assert_eq!(csv, "actual,x,y,unmatched\nx,2,0,0\ny,0,2,0\n");
    }

    #[test]
    fn one_class_cannot_be_scored() {
        let labels = ["x"; 4].map(String::from).to_vec();
        let e = score(&matrix(), &clustering(vec![0, 0, 1, 1]), &labels).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the labels name only one class (\"x\"): nothing to score"
        );
    }

    /// Twist and stretch of the sphere and the ellipsoid at level 0 (4 deformations, 2 classes),
    /// and fast isometric pipeline options (N = 2): a data set the pipeline classifies in
    /// well under a second (shared with the noise tests).
    pub(crate) fn two_class_set() -> (Vec<Deformation>, PipelineOptions) {
        use qcshape::synth::{genus0_benchmark, SynthOptions};
        let defs: Vec<Deformation> = genus0_benchmark(&SynthOptions {
            level: 0,
            ..Default::default()
        })
        .unwrap()
        .into_iter()
        .filter(|d| {
            [
                "sphere-twist",
                "ellipsoid-twist",
                "sphere-stretch",
                "ellipsoid-stretch",
            ]
            .contains(&d.name.as_str())
        })
        .collect();
        assert_eq!(defs.len(), 4);
        let opts = PipelineOptions {
            geodesic: qcshape::geodesic::GeodesicOptions {
                steps: 2,
                ..Default::default()
            },
            metric: qcshape::metric::MetricSpec::new(qcshape::metric::MetricKind::Isometric),
            ..Default::default()
        };
        (defs, opts)
    }

    #[test]
    fn a_two_class_set_is_classified() {
        let (defs, opts) = two_class_set();
        let ticks = std::sync::atomic::AtomicUsize::new(0);
        let c = classify_set(&defs, &opts, 2, 2, 0, &|_| {
            ticks.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
        // 4 interpolations, 4 transfers, 6 pairs.
        assert_eq!(ticks.into_inner(), 14);
        assert_eq!(c.matrix.len(), 4);
        assert_eq!(c.pair_seconds.len(), 6);
        assert_eq!(c.clustering.assignments.len(), 4);
        let labels: Vec<String> = defs.iter().map(|d| d.label.clone().unwrap()).collect();
        let s = score(&c.matrix, &c.clustering, &labels).unwrap();
        // Twists and stretches are told apart (measured: every deformation in its class).
        assert_eq!(
            (s.eq15.sensitivity, s.eq15.specificity, s.ari),
            (1.0, 1.0, 1.0),
            "{s:?}"
        );
    }
}
