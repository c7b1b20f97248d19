//! The robustness benchmark (issue "Similarity users can trust on real data"): how well each
//! similarity classifies the synthetic deformations when they are perturbed as real data is
//! (random rigid placement, vertex noise, amplitude spread, time warps, and all combined), judged
//! against baselines computed in the same run on the same data.
//!
//! For every scenario the data set is [`perturbed_benchmark`]; every method gives a distance
//! matrix; each matrix is scored by leave-one-out 1-NN accuracy, kernel k-means and k-medoids
//! accuracy after Hungarian matching, eq. 15 sensitivity / specificity and the adjusted Rand
//! index of the k-medoids clustering. The clusterings follow the stable protocol
//! ([`qcshape::cluster::stable`]): the best objective over restarts grown until the seeds `seed`
//! and `seed + 1` keep the same partition (or a cap), the restarts used reported per row. One
//! run can cover several mesh resolutions (icosphere levels): the same scenarios, methods and
//! seeds at each level, one column group per level in the tables.

use std::fmt::Write as _;
use std::time::Instant;

use rayon::prelude::*;
use thiserror::Error;

use qcshape::align::{align_deformation, Alignment};
use qcshape::cluster::{stable_kernel_kmeans, stable_kmedoids, ClusterError, Clustering, StableOptions};
use qcshape::dataset::Deformation;
use qcshape::eval::{
    adjusted_rand_index, encode_labels, loo_nearest_neighbour_accuracy, matched_confusion, one_vs_rest,
    EvalError,
};
use qcshape::mesh::geometry::{edge_lengths, sub};
use qcshape::similarity::{
    similarity_matrix, DistanceMatrix, MatrixError, PipelineError, PipelineOptions, Run,
};
use qcshape::synth::{
    perturbed_benchmark, DeformationKind, InitialShape, Perturbation, SynthError, VertexNoise,
};

/// A named perturbation of the benchmark.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Scenario {
    /// Short name (`clean`, `rigid`, `noise-var-1`, ...).
    pub name: String,
    /// What is done to every deformation.
    pub perturbation: Perturbation,
}

impl Scenario {
    /// The default scenarios: each perturbation alone (rigid placement up to 35 degrees; noise
    /// at the paper's Table 3 variances 1 %, 5 % and 20 % of `lbar^2` and at 1 % and 2 % of the
    /// bounding-box diagonal; amplitude spread +-50 %; time warps of strength 1) and all combined
    /// (rigid, 2 % noise, +-50 %, time warps), plus the clean set (amplitude jitter 10 %).
    pub fn defaults() -> Vec<Scenario> {
        let base = Perturbation::default();
        let with = |name: &str, p: Perturbation| Scenario {
            name: name.to_string(),
            perturbation: p,
        };
        let noise = |v| Perturbation { noise: v, ..base };
        vec![
            with("clean", base),
            with(
                "rigid",
                Perturbation {
                    max_rotation_deg: 35.0,
                    ..base
                },
            ),
            with("noise-var-1", noise(VertexNoise::Variance(1.0))),
            with("noise-var-5", noise(VertexNoise::Variance(5.0))),
            with("noise-var-20", noise(VertexNoise::Variance(20.0))),
            with("noise-diag-1", noise(VertexNoise::Diagonal(0.01))),
            with("noise-diag-2", noise(VertexNoise::Diagonal(0.02))),
            with(
                "amplitude",
                Perturbation {
                    amplitude_spread: 0.5,
                    ..base
                },
            ),
            with(
                "time-warp",
                Perturbation {
                    time_warp: 1.0,
                    ..base
                },
            ),
            with("combined", Self::combined(VertexNoise::Diagonal(0.02))),
        ]
    }

    /// Every perturbation of the combined scenario (rigid placement up to 35 degrees, amplitude
    /// spread +-50 %, time warps of strength 1) with this vertex noise.
    fn combined(noise: VertexNoise) -> Perturbation {
        Perturbation {
            max_rotation_deg: 35.0,
            noise,
            amplitude_spread: 0.5,
            time_warp: 1.0,
        }
    }

    /// Scenarios a run can name besides [`Scenario::defaults`]: `combined-noiseless`, the
    /// combined scenario without its vertex noise, which splits a method's loss on the combined
    /// scenario into what the noise costs and what the other perturbations cost.
    pub fn extras() -> Vec<Scenario> {
        vec![Scenario {
            name: "combined-noiseless".to_string(),
            perturbation: Self::combined(VertexNoise::None),
        }]
    }

    /// The scenario called `name`, among [`Scenario::defaults`] and [`Scenario::extras`].
    pub fn named(name: &str) -> Result<Scenario, UnknownScenario> {
        let all: Vec<Scenario> = Self::defaults().into_iter().chain(Self::extras()).collect();
        all.iter()
            .find(|s| s.name == name)
            .cloned()
            .ok_or_else(|| UnknownScenario {
                name: name.to_string(),
                expected: all.into_iter().map(|s| s.name).collect(),
            })
    }
}

/// A scenario name that is none of [`Scenario::defaults`] and [`Scenario::extras`].
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("unknown scenario '{name}' (expected {})", .expected.join(", "))]
pub struct UnknownScenario {
    /// The name asked for.
    pub name: String,
    /// The names there are.
    pub expected: Vec<String>,
}

/// A similarity that needs no shape space: what the metrics are judged against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Baseline {
    /// Euclidean distance between the concatenated displacement fields `M_k - M_0`
    /// (k = 1..K, K #V x 3 values per deformation; input units).
    Displacement,
    /// The same after the rigid alignment of each deformation to the base
    /// ([`qcshape::align`]).
    AlignedDisplacement,
    /// Euclidean distance between the concatenated relative edge-length changes
    /// `|e_k| / |e_0| - 1` (k = 1..K, per edge; rigid-invariant).
    EdgeStrain,
}

impl Baseline {
    /// Every baseline.
    pub fn all() -> [Baseline; 3] {
        [
            Baseline::Displacement,
            Baseline::AlignedDisplacement,
            Baseline::EdgeStrain,
        ]
    }

    /// `"displacement"`, `"aligned-displacement"` or `"edge-strain"`.
    pub fn label(self) -> &'static str {
        match self {
            Baseline::Displacement => "displacement",
            Baseline::AlignedDisplacement => "aligned-displacement",
            Baseline::EdgeStrain => "edge-strain",
        }
    }

    /// The feature vector of a deformation (see the variants); `base` is the common base pose.
    fn features(self, d: &Deformation, base: &[[f64; 3]]) -> Vec<f64> {
        let poses = match self {
            Baseline::AlignedDisplacement => {
                align_deformation(&d.topology, &d.poses, base, Alignment::Rigid).0
            }
            _ => d.poses.clone(),
        };
        match self {
            Baseline::Displacement | Baseline::AlignedDisplacement => poses[1..]
                .iter()
                .flat_map(|p| p.iter().zip(&poses[0]).flat_map(|(a, b)| sub(*a, *b)))
                .collect(),
            Baseline::EdgeStrain => {
                let l0 = edge_lengths(&d.topology, &poses[0]);
                poses[1..]
                    .iter()
                    .flat_map(|p| {
                        edge_lengths(&d.topology, p)
                            .into_iter()
                            .zip(&l0)
                            .map(|(l, l0)| l / l0 - 1.0)
                            .collect::<Vec<_>>()
                    })
                    .collect()
            }
        }
    }

    /// The distance matrix of the baseline on a data set (deformation 0's first pose is the
    /// base of [`Baseline::AlignedDisplacement`]).
    pub fn matrix(self, defs: &[Deformation]) -> Result<DistanceMatrix, MatrixError> {
        let base = &defs[0].poses[0];
        let f: Vec<Vec<f64>> = defs.par_iter().map(|d| self.features(d, base)).collect();
        let n = defs.len();
        let mut v = vec![0.0; n * n];
        for i in 0..n {
            for j in i + 1..n {
                let d = f[i]
                    .iter()
                    .zip(&f[j])
                    .map(|(a, b)| (a - b).powi(2))
                    .sum::<f64>()
                    .sqrt();
                v[i * n + j] = d;
                v[j * n + i] = d;
            }
        }
        DistanceMatrix::new(defs.iter().map(|d| d.name.clone()).collect(), v)
    }
}

/// One similarity of the comparison.
#[derive(Debug, Clone)]
pub enum Method {
    /// A baseline.
    Baseline(Baseline),
    /// The qcshape pipeline (interpolation, alignment, transfer, eq. 13) with these options.
    Pipeline {
        /// Name in the tables (e.g. `quasi-conformal`, `qc, no alignment`).
        name: String,
        /// The pipeline's options.
        options: Box<PipelineOptions>,
    },
}

impl Method {
    /// The name in the tables.
    pub fn name(&self) -> String {
        match self {
            Method::Baseline(b) => b.label().to_string(),
            Method::Pipeline { name, .. } => name.clone(),
        }
    }

    /// The distance matrix of this method on `defs` and whether every geodesic converged.
    pub fn matrix(&self, defs: &[Deformation]) -> Result<(DistanceMatrix, bool), RobustnessError> {
        match self {
            Method::Baseline(b) => Ok((b.matrix(defs)?, true)),
            Method::Pipeline { options, .. } => {
                let (prepared, outcome) = similarity_matrix(defs, options, &Run::default())?;
                let ok = prepared.converged && outcome.pairs.iter().all(|p| p.converged);
                Ok((outcome.matrix.expect("all pairs"), ok))
            }
        }
    }
}

/// Options of [`run`].
#[derive(Debug, Clone)]
pub struct RobustnessOptions {
    /// Icosphere levels of the shapes, one resolution each (2 = 162 vertices, 3 = 642,
    /// 4 = 2,562); at least one, no repeats, each at most [`qcshape::limits::MAX_ICOSPHERE_LEVEL`].
    pub levels: Vec<u32>,
    /// The initial shapes.
    pub shapes: Vec<InitialShape>,
    /// The deformation kinds (the classes).
    pub kinds: Vec<DeformationKind>,
    /// Poses per deformation.
    pub poses: usize,
    /// The scenarios.
    pub scenarios: Vec<Scenario>,
    /// The methods compared (baselines included).
    pub methods: Vec<Method>,
    /// Seed of the data and of the clusterings (the stable protocol's seeds are `seed` and
    /// `seed + 1`).
    pub seed: u64,
    /// Restarts per seed of the stable protocol's first round.
    pub restarts: usize,
    /// Most restarts per seed of the stable protocol.
    pub max_restarts: usize,
}

impl Default for RobustnessOptions {
    /// 6 shapes x 10 kinds (the paper's eight and two with curved trajectories), 4 poses, at
    /// level 3 (642 vertices), every default scenario, the three baselines and the five
    /// metrics with the pipeline's defaults, the stable protocol from 20 restarts up to 1,280,
    /// seed 0.
    fn default() -> Self {
        let mut methods: Vec<Method> = Baseline::all().into_iter().map(Method::Baseline).collect();
        for kind in qcshape::metric::MetricKind::all() {
            let options = PipelineOptions {
                metric: qcshape::metric::MetricSpec::new(kind),
                ..Default::default()
            };
            methods.push(Method::Pipeline {
                name: kind.label().to_string(),
                options: Box::new(options),
            });
        }
        RobustnessOptions {
            levels: vec![3],
            shapes: InitialShape::all().to_vec(),
            kinds: DeformationKind::extended().to_vec(),
            poses: 4,
            scenarios: Scenario::defaults(),
            methods,
            seed: 0,
            restarts: qcshape::defaults::RESTARTS,
            max_restarts: qcshape::cluster::stable::MAX_STABLE_RESTARTS,
        }
    }
}

/// The scores of one method in one scenario (accuracies in [0, 1]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Row {
    /// Icosphere level.
    pub level: u32,
    /// Vertices per mesh at this level.
    pub vertices: usize,
    /// Scenario name.
    pub scenario: String,
    /// Method name.
    pub method: String,
    /// Whether the method is a baseline.
    pub baseline: bool,
    /// Leave-one-out 1-NN accuracy.
    pub nn: f64,
    /// Kernel k-means accuracy after Hungarian matching.
    pub kmeans: f64,
    /// k-medoids (PAM) accuracy after Hungarian matching.
    pub kmedoids: f64,
    /// Eq. 15 sensitivity of the k-medoids clustering.
    pub sensitivity: f64,
    /// Eq. 15 specificity of the k-medoids clustering.
    pub specificity: f64,
    /// Adjusted Rand index of the k-medoids clustering.
    pub ari: f64,
    /// Restarts per seed the kernel k-means protocol used.
    pub kmeans_restarts: usize,
    /// Whether its two seeds agreed (false: stopped at the cap).
    pub kmeans_agreed: bool,
    /// Restarts per seed the k-medoids protocol used.
    pub kmedoids_restarts: usize,
    /// Whether its two seeds agreed (false: stopped at the cap).
    pub kmedoids_agreed: bool,
    /// Seconds to compute the matrix.
    pub seconds: f64,
    /// Whether every geodesic converged.
    pub converged: bool,
}

/// The result of [`run`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct RobustnessReport {
    /// The levels, in order, with their vertices per mesh.
    pub levels: Vec<(u32, usize)>,
    /// Deformations per scenario.
    pub deformations: usize,
    /// Classes.
    pub classes: usize,
    /// Seed (of the data; the clusterings' seeds are it and the next).
    pub seed: u64,
    /// The stable protocol's first-round restarts per seed and its cap.
    pub restarts: (usize, usize),
    /// The scenarios, in order.
    pub scenarios: Vec<Scenario>,
    /// One row per level, scenario and method.
    pub rows: Vec<Row>,
}

/// Why the benchmark failed.
#[derive(Debug, Error)]
pub enum RobustnessError {
    /// The data set could not be generated.
    #[error(transparent)]
    Synth(#[from] SynthError),
    /// A pipeline failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// A matrix is not a distance matrix.
    #[error(transparent)]
    Matrix(#[from] MatrixError),
    /// A clustering failed.
    #[error(transparent)]
    Cluster(#[from] ClusterError),
    /// A score could not be computed.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// Nothing to compare: no method, scenario or shape, or fewer than two deformation kinds.
    #[error(
        "the robustness benchmark needs at least one method, one scenario, two kinds and one shape \
         (got {methods}, {scenarios}, {kinds} and {shapes})"
    )]
    Empty {
        /// Methods given.
        methods: usize,
        /// Scenarios given.
        scenarios: usize,
        /// Deformation kinds given.
        kinds: usize,
        /// Initial shapes given.
        shapes: usize,
    },
    /// No icosphere level, or one above [`qcshape::limits::MAX_ICOSPHERE_LEVEL`].
    #[error(
        "the robustness benchmark needs one or more icosphere levels, each at most {max} (got {levels:?})"
    )]
    Levels {
        /// The levels given.
        levels: Vec<u32>,
        /// The largest level allowed.
        max: u32,
    },
    /// A level is given twice.
    #[error("a level is given twice: {0}")]
    LevelTwice(u32),
}

/// Accuracy of a clustering against the classes after Hungarian matching, and the clustering's
/// eq. 15 scores and ARI.
fn clustering_scores(c: &Clustering, classes: &[usize], k: usize) -> Result<(f64, f64, f64, f64), EvalError> {
    let (_, cm) = matched_confusion(&c.assignments, c.k, classes, k)?;
    let ovr = one_vs_rest(&cm)?;
    let ari = adjusted_rand_index(&c.assignments, classes)?;
    Ok((cm.accuracy(), ovr.sensitivity, ovr.specificity, ari))
}

/// The scores of one matrix (see [`Row`] for the fields).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scores {
    /// Leave-one-out 1-NN accuracy.
    pub nn: f64,
    /// Kernel k-means accuracy (stable protocol).
    pub kmeans: f64,
    /// k-medoids accuracy (stable protocol).
    pub kmedoids: f64,
    /// Eq. 15 sensitivity of the k-medoids clustering.
    pub sensitivity: f64,
    /// Eq. 15 specificity of the k-medoids clustering.
    pub specificity: f64,
    /// Adjusted Rand index of the k-medoids clustering.
    pub ari: f64,
    /// Restarts per seed and agreement of the kernel k-means protocol.
    pub kmeans_protocol: (usize, bool),
    /// Restarts per seed and agreement of the k-medoids protocol.
    pub kmedoids_protocol: (usize, bool),
}

/// Scores a distance matrix against class indices (`k` classes); the clusterings follow the
/// stable protocol from `restarts` up to `max_restarts` restarts per seed, seeds `seed` and
/// `seed + 1`.
pub fn score(
    d: &DistanceMatrix,
    classes: &[usize],
    k: usize,
    (restarts, max_restarts): (usize, usize),
    seed: u64,
) -> Result<Scores, RobustnessError> {
    let opts = StableOptions {
        initial_restarts: restarts,
        max_restarts,
        ..StableOptions::from_seed(k, seed)
    };
    let nn = loo_nearest_neighbour_accuracy(d, classes)?;
    let km = stable_kernel_kmeans(d, &opts)?;
    let kmed = stable_kmedoids(d, &opts)?;
    let (kmeans, ..) = clustering_scores(&km.clustering, classes, k)?;
    let (kmedoids, sensitivity, specificity, ari) = clustering_scores(&kmed.clustering, classes, k)?;
    Ok(Scores {
        nn,
        kmeans,
        kmedoids,
        sensitivity,
        specificity,
        ari,
        kmeans_protocol: (km.restarts, km.agreed),
        kmedoids_protocol: (kmed.restarts, kmed.agreed),
    })
}

/// Runs every method on every scenario at every level. `progress(level, scenario, method)` is
/// called as each matrix is scored.
pub fn run(
    opts: &RobustnessOptions,
    progress: &(dyn Fn(u32, &str, &str) + Sync),
) -> Result<RobustnessReport, RobustnessError> {
    if opts.methods.is_empty() || opts.scenarios.is_empty() || opts.kinds.len() < 2 || opts.shapes.is_empty()
    {
        return Err(RobustnessError::Empty {
            methods: opts.methods.len(),
            scenarios: opts.scenarios.len(),
            kinds: opts.kinds.len(),
            shapes: opts.shapes.len(),
        });
    }
    let max = qcshape::limits::MAX_ICOSPHERE_LEVEL;
    if opts.levels.is_empty() || opts.levels.iter().any(|&l| l > max) {
        return Err(RobustnessError::Levels {
            levels: opts.levels.clone(),
            max,
        });
    }
    if let Some(i) = (1..opts.levels.len()).find(|&i| opts.levels[..i].contains(&opts.levels[i])) {
        return Err(RobustnessError::LevelTwice(opts.levels[i]));
    }
    let mut rows = Vec::new();
    let mut levels = Vec::new();
    let mut deformations = 0;
    for &level in &opts.levels {
        let mut vertices = 0;
        for sc in &opts.scenarios {
            (vertices, deformations) = run_scenario(opts, level, sc, &mut rows, progress)?;
        }
        levels.push((level, vertices));
    }
    Ok(RobustnessReport {
        levels,
        deformations,
        classes: opts.kinds.len(),
        seed: opts.seed,
        restarts: (opts.restarts, opts.max_restarts),
        scenarios: opts.scenarios.clone(),
        rows,
    })
}

/// Every method on one scenario at one level: appends the rows; returns the vertices per mesh
/// and the number of deformations.
fn run_scenario(
    opts: &RobustnessOptions,
    level: u32,
    sc: &Scenario,
    rows: &mut Vec<Row>,
    progress: &(dyn Fn(u32, &str, &str) + Sync),
) -> Result<(usize, usize), RobustnessError> {
    let defs = perturbed_benchmark(
        level,
        &opts.shapes,
        &opts.kinds,
        opts.poses,
        &sc.perturbation,
        opts.seed,
    )?;
    let vertices = defs[0].topology.n_vertices();
    let labels: Vec<String> = defs.iter().map(|d| d.label.clone().unwrap_or_default()).collect();
    let (classes, names) = encode_labels(&labels);
    for m in &opts.methods {
        let t0 = Instant::now();
        let (d, converged) = m.matrix(&defs)?;
        let seconds = t0.elapsed().as_secs_f64();
        let sc_ = score(
            &d,
            &classes,
            names.len(),
            (opts.restarts, opts.max_restarts),
            opts.seed,
        )?;
        rows.push(Row {
            level,
            vertices,
            scenario: sc.name.clone(),
            method: m.name(),
            baseline: matches!(m, Method::Baseline(_)),
            nn: sc_.nn,
            kmeans: sc_.kmeans,
            kmedoids: sc_.kmedoids,
            sensitivity: sc_.sensitivity,
            specificity: sc_.specificity,
            ari: sc_.ari,
            kmeans_restarts: sc_.kmeans_protocol.0,
            kmeans_agreed: sc_.kmeans_protocol.1,
            kmedoids_restarts: sc_.kmedoids_protocol.0,
            kmedoids_agreed: sc_.kmedoids_protocol.1,
            seconds,
            converged,
        });
        progress(level, &sc.name, &m.name());
    }
    Ok((vertices, defs.len()))
}

impl RobustnessReport {
    /// One line per row: `level,vertices,scenario,method,baseline,nn,kmeans,kmedoids,sensitivity,specificity,ari,kmeans_restarts,kmeans_agreed,kmedoids_restarts,kmedoids_agreed,seconds,converged`.
    pub fn to_csv(&self) -> String {
        let mut s = String::from(
            "level,vertices,scenario,method,baseline,nn,kmeans,kmedoids,sensitivity,specificity,ari,\
             kmeans_restarts,kmeans_agreed,kmedoids_restarts,kmedoids_agreed,seconds,converged\n",
        );
        for r in &self.rows {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{:.2},{}",
                r.level,
                r.vertices,
                r.scenario,
                r.method,
                r.baseline,
                r.nn,
                r.kmeans,
                r.kmedoids,
                r.sensitivity,
                r.specificity,
                r.ari,
                r.kmeans_restarts,
                r.kmeans_agreed,
                r.kmedoids_restarts,
                r.kmedoids_agreed,
                r.seconds,
                r.converged
            );
        }
        s
    }

    /// The row of a level, scenario and method.
    pub fn row(&self, level: u32, scenario: &str, method: &str) -> Option<&Row> {
        self.rows
            .iter()
            .find(|r| r.level == level && r.scenario == scenario && r.method == method)
    }

    /// Markdown: one table per score (1-NN, k-means, k-medoids, ARI) with a row per scenario
    /// and, per level, a column group (the best baseline of the row at that level, then a
    /// column per method); a table of the clustering restarts per seed; then the scenarios'
    /// definitions.
    pub fn to_markdown(&self) -> String {
        let sizes: Vec<String> = self
            .levels
            .iter()
            .map(|(l, v)| format!("level {l} ({v} vertices)"))
            .collect();
        let mut s = format!(
            "# Robustness benchmark\n\n{} deformations ({} classes) per scenario at {}, seed {}. \
             Accuracies after Hungarian matching; `best baseline` is the best of the baselines in the same row \
             and level. Clusterings: the best objective over restarts, from {} per seed doubled until the seeds \
             {} and {} keep the same partition in two successive rounds (at most {}).\n",
            self.deformations,
            self.classes,
            sizes.join(", "),
            self.seed,
            self.restarts.0,
            self.seed,
            self.seed.wrapping_add(1),
            self.restarts.1
        );
        let mut methods: Vec<String> = Vec::new();
        for r in &self.rows {
            if !methods.contains(&r.method) {
                methods.push(r.method.clone());
            }
        }
        let multi = self.levels.len() > 1;
        let head = |name: &str, v: usize| {
            if multi {
                format!(" {name} @ {v} v |")
            } else {
                format!(" {name} |")
            }
        };
        let mut header = String::from("| scenario |");
        for &(_, v) in &self.levels {
            header.push_str(&head("best baseline", v));
            for m in &methods {
                header.push_str(&head(m, v));
            }
        }
        let columns = self.levels.len() * (methods.len() + 1);
        let rule = format!("|---|{}\n", "---|".repeat(columns));
        let scores: [(&str, Score); 4] = [
            ("Leave-one-out 1-NN accuracy", |r| r.nn),
            ("Kernel k-means accuracy", |r| r.kmeans),
            ("k-medoids accuracy", |r| r.kmedoids),
            ("Adjusted Rand index (k-medoids)", |r| r.ari),
        ];
        for (title, get) in scores {
            let _ = write!(s, "\n## {title}\n\n{header}\n{rule}");
            for sc in &self.scenarios {
                let _ = write!(s, "| {} |", sc.name);
                for &(level, _) in &self.levels {
                    let best = self
                        .rows
                        .iter()
                        .filter(|r| r.level == level && r.scenario == sc.name && r.baseline)
                        .map(get)
                        .fold(f64::NAN, f64::max);
                    let _ = write!(s, " {} |", fmt(best));
                    for m in &methods {
                        let row = self.row(level, &sc.name, m);
                        let mark = if row.is_some_and(|r| !r.converged) {
                            "*"
                        } else {
                            ""
                        };
                        let _ = write!(s, " {}{mark} |", fmt(row.map(get).unwrap_or(f64::NAN)));
                    }
                }
                s.push('\n');
            }
        }
        s.push_str("\n`*`: some geodesic did not converge.\n");
        let _ =
            write!(
            s,
            "\n## Clustering restarts per seed (kernel k-means / k-medoids)\n\n`!`: the seeds did not agree \
             at the cap; the kept partition is the lower objective of the two.\n\n{}\n{}",
            header.replace("| best baseline", "| -").replace(" best baseline @", " - @"),
            rule
        );
        for sc in &self.scenarios {
            let _ = write!(s, "| {} |", sc.name);
            for &(level, _) in &self.levels {
                s.push_str(" |");
                for m in &methods {
                    let _ = match self.row(level, &sc.name, m) {
                        Some(r) => write!(
                            s,
                            " {}{} / {}{} |",
                            r.kmeans_restarts,
                            if r.kmeans_agreed { "" } else { "!" },
                            r.kmedoids_restarts,
                            if r.kmedoids_agreed { "" } else { "!" }
                        ),
                        None => write!(s, " - |"),
                    };
                }
            }
            s.push('\n');
        }
        s.push_str("\n## Scenarios\n\n| scenario | rotation (deg) | noise | amplitude spread | time warp |\n|---|---|---|---|---|\n");
        for sc in &self.scenarios {
            let p = &sc.perturbation;
            let noise = match p.noise {
                VertexNoise::None => "none".to_string(),
                VertexNoise::Variance(v) => format!("variance {v} % of lbar^2 (Table 3)"),
                VertexNoise::Diagonal(f) => format!("sd {} % of the diagonal", f * 100.0),
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | +-{} % | {} |",
                sc.name,
                p.max_rotation_deg,
                noise,
                p.amplitude_spread * 100.0,
                p.time_warp
            );
        }
        s
    }
}

/// Reads one score of a row.
type Score = fn(&Row) -> f64;

/// Two decimals, `-` for NaN.
fn fmt(v: f64) -> String {
    if v.is_nan() {
        "-".into()
    } else {
        format!("{v:.2}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use qcshape::geodesic::GeodesicOptions;
    use qcshape::metric::{MetricKind, MetricSpec};

    #[test]
    fn scenarios_are_found_by_name_and_the_noiseless_combined_one_has_no_noise() {
        let combined = Scenario::named("combined").unwrap();
        let noiseless = Scenario::named("combined-noiseless").unwrap();
        assert_eq!(combined.perturbation.noise, VertexNoise::Diagonal(0.02));
        assert_eq!(
            noiseless.perturbation,
            Perturbation {
                noise: VertexNoise::None,
                ..combined.perturbation
            }
        );
        assert!(!Scenario::defaults().contains(&noiseless));
        let e = Scenario::named("combined-nosie").unwrap_err();
        assert!(
            e.to_string().contains("'combined-nosie'") && e.expected.len() == 11,
            "{e}"
        );
    }

    #[test]
    fn baselines_and_a_metric_on_a_small_set() {
        let qc = PipelineOptions {
            metric: MetricSpec::new(MetricKind::Isometric),
            geodesic: GeodesicOptions {
                steps: 2,
                ..Default::default()
            },
            ..Default::default()
        };
        let opts = RobustnessOptions {
            levels: vec![1],
            shapes: InitialShape::all()[..3].to_vec(),
            kinds: vec![
                DeformationKind::Twist,
                DeformationKind::Bulge,
                DeformationKind::Swing,
            ],
            poses: 3,
            scenarios: vec![Scenario::defaults()[0].clone(), Scenario::defaults()[1].clone()],
            methods: vec![
                Method::Baseline(Baseline::Displacement),
                Method::Baseline(Baseline::AlignedDisplacement),
                Method::Baseline(Baseline::EdgeStrain),
                Method::Pipeline {
                    name: "qc".into(),
                    options: Box::new(qc),
                },
            ],
            seed: 1,
            restarts: 5,
            max_restarts: 40,
        };
        let calls = std::sync::Mutex::new(0);
        let r = run(&opts, &|_, _, _| *calls.lock().unwrap() += 1).unwrap();
        assert_eq!(*calls.lock().unwrap(), 8);
        assert_eq!(r.rows.len(), 8);
        assert_eq!(
            (r.deformations, r.classes, r.levels.clone()),
            (9, 3, vec![(1, 42)])
        );
        let get = |sc: &str, m: &str| r.rows.iter().find(|x| x.scenario == sc && x.method == m).unwrap();
        // Clean: every method separates three clearly different motions.
        for m in ["displacement", "aligned-displacement", "edge-strain", "qc"] {
            assert_eq!(get("clean", m).nn, 1.0, "{m}");
        }
        // Rigid placement: the rigid-invariant methods are unchanged.
        for m in ["aligned-displacement", "edge-strain", "qc"] {
            assert_eq!(get("rigid", m).nn, get("clean", m).nn, "{m}");
        }
        let md = r.to_markdown();
        assert!(md.contains("| rigid |") && md.contains("edge-strain"), "{md}");
        assert_eq!(r.to_csv().lines().count(), 9);
    }

    #[test]
    fn edge_strain_ignores_rigid_motion_and_displacement_does_not() {
        let p = Perturbation {
            max_rotation_deg: 35.0,
            ..Default::default()
        };
        let shapes = [InitialShape::Sphere, InitialShape::Pear];
        let kinds = [DeformationKind::Twist, DeformationKind::Taper];
        let clean = perturbed_benchmark(1, &shapes, &kinds, 3, &Perturbation::default(), 2).unwrap();
        let posed = perturbed_benchmark(1, &shapes, &kinds, 3, &p, 2).unwrap();
        let close = |a: &DistanceMatrix, b: &DistanceMatrix| {
            a.values()
                .iter()
                .zip(b.values())
                .all(|(x, y)| (x - y).abs() < 1e-9 * (1.0 + x.abs()))
        };
        let m = |b: Baseline, d: &[Deformation]| b.matrix(d).unwrap();
        assert!(close(
            &m(Baseline::EdgeStrain, &clean),
            &m(Baseline::EdgeStrain, &posed)
        ));
        assert!(!close(
            &m(Baseline::Displacement, &clean),
            &m(Baseline::Displacement, &posed)
        ));
    }
}
