//! How much accuracy a cheaper similarity costs (`qcshape experiment approx`): the exact
//! similarity matrix (eq. 13, geodesic lengths) and approximate ones computed in the same run on
//! the same prepared (interpolated, aligned, transferred) data, with the speed-up of each and
//! its agreement with the exact matrix: Spearman correlation of the pair distances, their
//! largest and median relative error, agreement of the leave-one-out 1-NN labels, and the
//! adjusted Rand index between kernel k-means clusterings of the two matrices (same seed).

use std::time::Instant;

use thiserror::Error;

use qcshape::cluster::{kernel_kmeans, ClusterError, ClusterOptions};
use qcshape::dataset::Deformation;
use qcshape::eval::{adjusted_rand_index, nearest_neighbour, EvalError};
use qcshape::similarity::{
    compute, prepare, Approx, DistanceMatrix, MatrixError, PipelineError, PipelineOptions, Prepared, Run,
};

/// Why the experiment failed.
#[derive(Debug, Error)]
pub enum ApproxError {
    /// The pipeline (interpolation, transfer, geodesics) failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// A matrix could not be formed.
    #[error(transparent)]
    Matrix(#[from] MatrixError),
    /// Clustering failed.
    #[error(transparent)]
    Cluster(#[from] ClusterError),
    /// Scoring failed.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// The two matrices differ in size, or hold fewer than two deformations.
    #[error("matrices of {exact} and {approx} deformations (need the same size, at least 2)")]
    MatrixSizes {
        /// Deformations in the exact matrix.
        exact: usize,
        /// Deformations in the approximate one.
        approx: usize,
    },
    /// Fewer than two modes (a reference and one to compare).
    #[error("give a reference mode and at least one more")]
    TooFewModes,
    /// A mode with zero path segments.
    #[error("mode {}: steps must be at least 1", .0.name())]
    ZeroSteps(Mode),
}

/// One way of computing the pose distances.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mode {
    /// Geodesic or straight-path lengths.
    pub approx: Approx,
    /// Path segments N (the geodesic's, or the straight path's).
    pub steps: usize,
}

impl Mode {
    /// `exact-N` (geodesics with N segments), `straight-N` or `tangent-N` (N unused).
    pub fn name(&self) -> String {
        format!("{}-{}", self.approx, self.steps)
    }
}

impl std::str::FromStr for Mode {
    type Err = String;

    /// `exact-8`, `straight-8`, `straight` (the reference's steps are filled in later: 0).
    fn from_str(s: &str) -> Result<Mode, String> {
        let (a, n) = s.split_once('-').unwrap_or((s, "0"));
        let approx = a.parse()?;
        let steps = n
            .parse()
            .map_err(|_| format!("{s:?}: expected MODE or MODE-STEPS, e.g. straight-8 or exact-2"))?;
        Ok(Mode { approx, steps })
    }
}

/// Median relative error above which [`ApproxReport::markdown`] says that a mode does not
/// approximate the reference's distance values (only, at best, their order).
pub const FAR_MEDIAN_ERROR: f64 = 0.5;

/// How an approximate matrix agrees with the exact one.
#[derive(Debug, Clone, PartialEq)]
pub struct Agreement {
    /// Spearman rank correlation of the n(n-1)/2 pair distances (average ranks for ties).
    pub spearman: f64,
    /// Largest `|approx - exact| / exact` over pairs with a positive exact distance.
    pub max_relative_error: f64,
    /// Median of the same.
    pub median_relative_error: f64,
    /// Share of deformations whose leave-one-out nearest neighbour has the same label under
    /// both matrices (the label of the neighbour, so equidistant neighbours of one class agree;
    /// without labels, the neighbour itself).
    pub nn_agreement: f64,
    /// Adjusted Rand index between the kernel k-means clusterings of the two matrices.
    pub ari: f64,
}

/// The agreement of `approx` with `exact` (both n x n, the same names). `classes` (n) are the
/// labels used for the 1-NN agreement (None: compare the neighbours themselves); `cluster` the
/// kernel k-means options of both clusterings.
pub fn agreement(
    exact: &DistanceMatrix,
    approx: &DistanceMatrix,
    classes: Option<&[usize]>,
    cluster: &ClusterOptions,
) -> Result<Agreement, ApproxError> {
    let n = exact.len();
    if approx.len() != n || n < 2 {
        return Err(ApproxError::MatrixSizes {
            exact: n,
            approx: approx.len(),
        });
    }
    let (mut e, mut a) = (Vec::new(), Vec::new());
    for i in 0..n {
        for j in i + 1..n {
            e.push(exact.get(i, j));
            a.push(approx.get(i, j));
        }
    }
    let mut rel: Vec<f64> = e
        .iter()
        .zip(&a)
        .filter(|(e, _)| **e > 0.0)
        .map(|(e, a)| (a - e).abs() / e)
        .collect();
    rel.sort_by(f64::total_cmp);
    let same = (0..n)
        .filter(|&i| {
            let (p, q) = (nearest_neighbour(exact, i), nearest_neighbour(approx, i));
            match classes {
                Some(c) => c[p] == c[q],
                None => p == q,
            }
        })
        .count();
    let ce = kernel_kmeans(exact, cluster)?;
    let ca = kernel_kmeans(approx, cluster)?;
    Ok(Agreement {
        spearman: spearman(&e, &a),
        max_relative_error: rel.last().copied().unwrap_or(0.0),
        median_relative_error: if rel.is_empty() { 0.0 } else { rel[rel.len() / 2] },
        nn_agreement: same as f64 / n as f64,
        ari: adjusted_rand_index(&ce.assignments, &ca.assignments)?,
    })
}

/// Ranks 1..n with ties given their average rank.
fn ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut k = 0;
    while k < idx.len() {
        let mut m = k;
        while m + 1 < idx.len() && x[idx[m + 1]] == x[idx[k]] {
            m += 1;
        }
        let avg = (k + m) as f64 / 2.0 + 1.0;
        for &i in &idx[k..=m] {
            r[i] = avg;
        }
        k = m + 1;
    }
    r
}

/// Spearman's rank correlation (Pearson correlation of the ranks); 1 for a single value or
/// constant inputs on both sides, 0 when only one side is constant.
pub fn spearman(x: &[f64], y: &[f64]) -> f64 {
    let (rx, ry) = (ranks(x), ranks(y));
    let n = rx.len() as f64;
    if n < 2.0 {
        return 1.0;
    }
    let (mx, my) = (rx.iter().sum::<f64>() / n, ry.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in rx.iter().zip(&ry) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    match (sxx > 0.0, syy > 0.0) {
        (true, true) => sxy / (sxx * syy).sqrt(),
        (false, false) => 1.0,
        _ => 0.0,
    }
}

/// One mode's matrix and cost.
#[derive(Debug, Clone)]
pub struct ModeResult {
    /// The mode.
    pub mode: Mode,
    /// Its similarity matrix.
    pub matrix: DistanceMatrix,
    /// Wall-clock seconds of the similarity step (the preparation is shared and timed apart).
    pub seconds: f64,
    /// Whether every geodesic converged (always true for straight paths).
    pub converged: bool,
    /// Agreement with the reference (the first mode), `None` for the reference itself.
    pub agreement: Option<Agreement>,
    /// ARI between this matrix's kernel k-means clusters and the classes (`None` without
    /// classes): how well each mode's clusters recover the labels.
    pub class_ari: Option<f64>,
}

/// The whole experiment on one data set.
#[derive(Debug, Clone)]
pub struct ApproxReport {
    /// Deformations, poses per deformation (after interpolation) and vertices.
    pub size: (usize, usize, usize),
    /// Seconds of the shared preparation (interpolation, alignment, transfer).
    pub prepare_seconds: f64,
    /// The reference (first) and the approximate modes, in the order given.
    pub modes: Vec<ModeResult>,
    /// ARI between two kernel k-means runs on the reference matrix itself, with the seed and
    /// the seed + 1: the clustering's own stability, which bounds how well any other matrix's
    /// clusters can agree with the reference's.
    pub reseeded_ari: f64,
}

/// Prepares `defs` once with `opts` and computes the matrix of every mode (the first is the
/// reference, normally `exact-N`), scoring the others against it. `classes` (n) label the
/// deformations for the 1-NN agreement; `cluster` the kernel k-means of the ARI. `progress` is
/// called with the mode's name before each.
pub fn compare_modes(
    defs: &[Deformation],
    opts: &PipelineOptions,
    modes: &[Mode],
    classes: Option<&[usize]>,
    cluster: &ClusterOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<ApproxReport, ApproxError> {
    if modes.len() < 2 {
        return Err(ApproxError::TooFewModes);
    }
    if let Some(m) = modes.iter().find(|m| m.steps == 0) {
        return Err(ApproxError::ZeroSteps(*m));
    }
    let t0 = Instant::now();
    let prepared: Prepared = prepare(defs, opts, &|_| {})?;
    let prepare_seconds = t0.elapsed().as_secs_f64();
    let n = prepared.names.len();
    let mut out: Vec<ModeResult> = Vec::new();
    for &mode in modes {
        progress(&mode.name());
        let mut o = opts.clone();
        o.approx = mode.approx;
        o.geodesic.steps = mode.steps;
        let t = Instant::now();
        let outcome = compute(&prepared.comparison(), &o, &Run::default())?;
        let seconds = t.elapsed().as_secs_f64();
        let matrix = outcome.matrix.expect("all pairs");
        let agreement = match out.first() {
            None => None,
            Some(reference) => Some(agreement(&reference.matrix, &matrix, classes, cluster)?),
        };
        let class_ari = match classes {
            Some(c) => Some(adjusted_rand_index(
                &kernel_kmeans(&matrix, cluster)?.assignments,
                c,
            )?),
            None => None,
        };
        out.push(ModeResult {
            mode,
            matrix,
            seconds,
            converged: outcome.pairs.iter().all(|p| p.converged),
            agreement,
            class_ari,
        });
    }
    let reseeded = ClusterOptions {
        seed: cluster.seed.wrapping_add(1),
        ..*cluster
    };
    let reseeded_ari = adjusted_rand_index(
        &kernel_kmeans(&out[0].matrix, cluster)?.assignments,
        &kernel_kmeans(&out[0].matrix, &reseeded)?.assignments,
    )?;
    let poses = prepared.transferred.first().map_or(0, |d| d.len());
    Ok(ApproxReport {
        size: (n, poses, prepared.topology.n_vertices()),
        prepare_seconds,
        modes: out,
        reseeded_ari,
    })
}

impl ApproxReport {
    /// The table as CSV: `mode,seconds,speedup,converged,spearman,max_relative_error,
    /// median_relative_error,nn_agreement,ari,class_ari` (the reference's agreement columns
    /// empty; `class_ari` empty without classes).
    pub fn csv(&self) -> String {
        let mut s = String::from(
            "mode,seconds,speedup,converged,spearman,max_relative_error,median_relative_error,nn_agreement,ari,class_ari\n",
        );
        let t_ref = self.modes[0].seconds;
        for m in &self.modes {
            let agree = m.agreement.as_ref().map_or(",,,,".to_string(), |a| {
                format!(
                    "{},{},{},{},{}",
                    a.spearman, a.max_relative_error, a.median_relative_error, a.nn_agreement, a.ari
                )
            });
            s.push_str(&format!(
                "{},{},{},{},{agree},{}\n",
                m.mode.name(),
                m.seconds,
                t_ref / m.seconds.max(1e-12),
                m.converged,
                m.class_ari.map_or(String::new(), |a| a.to_string())
            ));
        }
        s
    }

    /// The table as Markdown.
    pub fn markdown(&self) -> String {
        let (n, p, v) = self.size;
        let mut s = format!(
            "{n} deformations x {p} poses, {v} vertices; preparation (interpolation, alignment, transfer; shared) {:.1} s.\n\n\
             | mode | similarity s | speed-up | Spearman | max rel. error | median rel. error | 1-NN agreement | ARI (k-means) vs reference | ARI (k-means) vs classes |\n\
             |---|---|---|---|---|---|---|---|---|\n",
            self.prepare_seconds
        );
        let t_ref = self.modes[0].seconds;
        for m in &self.modes {
            let cells = m
                .agreement
                .as_ref()
                .map_or("reference | | | | |".to_string(), |a| {
                    format!(
                        "{:.4} | {:.2} % | {:.3} % | {:.3} | {:.3} |",
                        a.spearman,
                        100.0 * a.max_relative_error,
                        100.0 * a.median_relative_error,
                        a.nn_agreement,
                        a.ari
                    )
                });
            s.push_str(&format!(
                "| {}{} | {:.2} | {:.1}x | {cells} {} |\n",
                m.mode.name(),
                if m.converged { "" } else { " (not all converged)" },
                m.seconds,
                t_ref / m.seconds.max(1e-12),
                m.class_ari.map_or("-".to_string(), |a| format!("{a:.3}"))
            ));
        }
        s.push_str(&format!(
            "\nKernel k-means of the reference matrix with the seed and the seed + 1 agree to ARI {:.3}: \
             the clustering's own stability, which bounds the ARI of any other matrix against the reference.\n",
            self.reseeded_ari
        ));
        let far: Vec<String> = self
            .modes
            .iter()
            .filter(|m| {
                m.agreement
                    .as_ref()
                    .is_some_and(|a| a.median_relative_error > FAR_MEDIAN_ERROR)
            })
            .map(|m| m.mode.name())
            .collect();
        if !far.is_empty() {
            s.push_str(&format!(
                "\n{} {} off by more than half at the median pair: the reference's geodesics are much \
                 shorter than the straight paths these modes measure (tangent: in the metric linearized at \
                 the base); they bend, with the conformal metrics into directions their terms barely \
                 charge (docs/log/speed.md), so {} only the order of the distances where \
                 the columns above say so, not their values.\n",
                far.join(", "),
                if far.len() == 1 { "is" } else { "are" },
                if far.len() == 1 {
                    "it approximates"
                } else {
                    "they approximate"
                }
            ));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spearman_of_monotone_and_reversed_data_and_ties() {
        let x = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(spearman(&x, &[10.0, 20.0, 30.0, 1000.0]), 1.0);
        assert!((spearman(&x, &[4.0, 3.0, 2.0, 1.0]) + 1.0).abs() < 1e-15);
        assert_eq!(ranks(&[2.0, 1.0, 2.0, 3.0]), vec![2.5, 1.0, 2.5, 4.0]);
        assert_eq!(spearman(&[1.0, 1.0], &[2.0, 2.0]), 1.0);
        assert_eq!(spearman(&[1.0, 1.0], &[1.0, 2.0]), 0.0);
    }

    fn matrix(v: &[f64], n: usize) -> DistanceMatrix {
        let mut d = vec![0.0; n * n];
        let mut k = 0;
        for i in 0..n {
            for j in i + 1..n {
                d[i * n + j] = v[k];
                d[j * n + i] = v[k];
                k += 1;
            }
        }
        DistanceMatrix::new((0..n).map(|i| i.to_string()).collect(), d).unwrap()
    }

    #[test]
    fn agreement_sees_scaling_as_rank_preserving_and_a_swap_as_a_changed_neighbour() {
        // Two tight pairs {0,1}, {2,3} far apart.
        let e = matrix(&[1.0, 10.0, 11.0, 12.0, 13.0, 2.0], 4);
        let opts = ClusterOptions {
            k: 2,
            ..Default::default()
        };
        let scaled = matrix(&[1.2, 12.0, 13.2, 14.4, 15.6, 2.4], 4);
        let a = agreement(&e, &scaled, None, &opts).unwrap();
        assert_eq!(a.spearman, 1.0);
        assert!((a.max_relative_error - 0.2).abs() < 1e-12 && (a.median_relative_error - 0.2).abs() < 1e-12);
        assert_eq!((a.nn_agreement, a.ari), (1.0, 1.0));
        // 0's nearest neighbour becomes 2: the labels (0,0,1,1) disagree for item 0.
        let swapped = matrix(&[5.0, 0.5, 11.0, 12.0, 13.0, 2.0], 4);
        let a = agreement(&e, &swapped, Some(&[0, 0, 1, 1]), &opts).unwrap();
        assert!(a.spearman < 1.0);
        assert!(a.nn_agreement < 1.0, "{a:?}");
        assert!(agreement(&e, &matrix(&[1.0], 2), None, &opts).is_err());
    }

    /// The report says when a mode's median pair is off by more than half (the distances'
    /// values are not approximated), and only then.
    #[test]
    fn the_report_flags_modes_far_from_the_reference_values() {
        let opts = ClusterOptions {
            k: 2,
            ..Default::default()
        };
        let exact = matrix(&[1.0, 2.0, 3.0], 3);
        let report = |scale: f64| {
            let approx = matrix(&[scale, 2.0 * scale, 3.1 * scale], 3);
            let result = |mode: &str, m: &DistanceMatrix, agreement| ModeResult {
                mode: mode.parse().unwrap(),
                matrix: m.clone(),
                seconds: 1.0,
                converged: true,
                agreement,
                class_ari: None,
            };
            let a = agreement(&exact, &approx, None, &opts).unwrap();
            ApproxReport {
                size: (3, 2, 12),
                prepare_seconds: 0.0,
                modes: vec![
                    result("exact-8", &exact, None),
                    result("straight-8", &approx, Some(a)),
                ],
                reseeded_ari: 1.0,
            }
            .markdown()
        };
        let far = report(4.0);
        assert!(far.contains("straight-8 is off by more than half"), "{far}");
        let near = report(1.05);
        assert!(!near.contains("off by more than half"), "{near}");
    }

    #[test]
    fn straight_paths_bound_the_geodesics_and_agree_on_the_benchmark() {
        let defs = qcshape::synth::genus0_benchmark(&qcshape::synth::SynthOptions {
            level: 1,
            ..Default::default()
        })
        .unwrap();
        let defs: Vec<_> = defs.into_iter().step_by(3).collect();
        let labels: Vec<String> = defs.iter().map(|d| d.label.clone().unwrap()).collect();
        let (classes, classnames) = qcshape::eval::encode_labels(&labels);
        let opts = PipelineOptions {
            metric: qcshape::metric::MetricSpec::new(qcshape::metric::MetricKind::Isometric),
            ..Default::default()
        };
        let modes: Vec<Mode> = ["exact-4", "straight-4"]
            .iter()
            .map(|m| m.parse().unwrap())
            .collect();
        let cluster = ClusterOptions {
            k: classnames.len(),
            ..Default::default()
        };
        let r = compare_modes(&defs, &opts, &modes, Some(&classes), &cluster, &|_| {}).unwrap();
        let (exact, straight) = (&r.modes[0].matrix, &r.modes[1].matrix);
        // The straight path is a path: its length is at least the geodesic's (up to the
        // solver's tolerance).
        for i in 0..exact.len() {
            for j in 0..exact.len() {
                assert!(straight.get(i, j) >= exact.get(i, j) * (1.0 - 1e-6), "{i} {j}");
            }
        }
        let a = r.modes[1].agreement.as_ref().unwrap();
        assert!(a.spearman > 0.9, "{a:?}");
        assert!(r.csv().lines().count() == 3 && r.markdown().contains("reference"));
        // Both modes' clusters are scored against the classes; the reference's own reseeded
        // clustering is the stability bound.
        assert!(r
            .modes
            .iter()
            .all(|m| m.class_ari.is_some_and(|x| (-1.0..=1.0).contains(&x))));
        assert!((-1.0..=1.0).contains(&r.reseeded_ari));
        assert!(r.markdown().contains("seed + 1 agree to ARI"));
    }
}
