//! `qcshape reproduce`: the paper's synthetic experiments (section 3) from one command.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::cluster::{kernel_kmeans, ClusterOptions, Clustering};
use qcshape::dataset::{Dataset, Deformation};
use qcshape::embed::{smacof, MdsOptions};
use qcshape::experiment::interpolation::InterpolationExperiment;
use qcshape::experiment::transfer::TransferExperiment;
use qcshape::metric::{MetricKind, MetricSpec};
use qcshape::path::GeodesicOptions;
use qcshape::path::GeodesicSolver;
use qcshape::similarity::{
    assemble, intrinsic_kmeans, similarities, DistanceMatrix, IntrinsicOptions, PipelineOptions, Prepared,
};
use qcshape::synth::{add_noise, genus0_benchmark, write_benchmark, NoiseKind, SynthOptions};
use qcshape::transport::{Alignment, Transport};

use crate::args::in_pool;
use crate::classify::{score, Scores};
use crate::similarity::{bar, prepare_with_progress};

/// Reproduce the paper's synthetic experiments and write a report beside the paper's figures.
///
/// Generates the 48 synthetic deformations (6 shapes x 8 deformations x 3 poses, `qcshape
/// synth`), then for each metric: interpolation (--insert poses between key poses), transfer to
/// the first pose of the first deformation (--transport), the similarity matrix (eq. 13),
/// k-means into 8 classes (Table 1: eq. 15 sensitivity and specificity, plus leave-one-out 1-NN
/// accuracy and the adjusted Rand index), the MDS map (Fig. 6) and a heat map; the time of each
/// step (Table 2); and the noise resistance of the quasi-conformal classification (Table 3,
/// eq. 17). Writes DIR/report.md with every table beside the paper's numbers, the figures
/// (SVG and PNG) and the CSVs.
///
/// --quick uses coarse meshes (42 vertices), one inserted pose, 2-segment geodesics, fewer
/// restarts and one noise level: it finishes in well under a minute on 2 cores.
#[derive(Debug, clap::Args)]
#[command(about = "Reproduce the paper's synthetic tables and figures", long_about)]
pub struct Args {
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
    /// Small and fast: icosphere level 1, --insert 1, --steps 2, 5 restarts, noise level 1 %.
    #[arg(long)]
    quick: bool,
    /// Icosphere level of the synthetic meshes (default 2 = 162 vertices; 1 with --quick).
    #[arg(long)]
    level: Option<u32>,
    /// Poses inserted between consecutive key poses (default 3 as in section 3.3; 1 with --quick).
    #[arg(long)]
    insert: Option<usize>,
    /// Segments N of every geodesic (default 4; 2 with --quick).
    #[arg(long)]
    steps: Option<usize>,
    /// k-means restarts (default 20; 5 with --quick).
    #[arg(long)]
    restarts: Option<usize>,
    /// Noise variances in percent for Table 3 (default 1,2.5,5,10,20; 1 with --quick).
    #[arg(long, value_delimiter = ',')]
    noise_levels: Option<Vec<f64>>,
    /// Skip Table 3.
    #[arg(long)]
    skip_noise: bool,
    /// Metrics of Table 1 (l2, a baseline the paper does not report, last).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "rigid,isometric,conformal,quasi-conformal,l2"
    )]
    metrics: Vec<MetricKind>,
    /// Weight of the L2 regularizer of every metric (eq. 11).
    #[arg(long, default_value_t = 0.1)]
    lambda: f64,
    /// Transport to the common base: euclidean (the default: it gave the lower transfer error and the
    /// better classification in the measurements, README), parallel (the paper's) or schild.
    #[arg(long, default_value = "euclidean")]
    transport: Transport,
    /// Placement of each deformation on the base before transfer: rigid (the default: area-weighted
    /// Procrustes of its first pose onto the base, the same motion for all its poses), similarity (also
    /// a uniform scale) or none (the paper's pipeline).
    #[arg(long, default_value = "rigid")]
    align: Alignment,
    /// Taubin smoothing iterations applied to every pose before comparing (a low-pass filter that
    /// takes vertex noise out of real data; 0 = none).
    #[arg(long, default_value_t = qcshape::similarity::PipelineOptions::default().smoothing)]
    smooth: usize,
    /// Seed of the synthetic amplitudes, k-means and noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// The settings after applying --quick and the explicit options.
#[derive(Debug, Clone)]
struct Settings {
    level: u32,
    insert: usize,
    steps: usize,
    restarts: usize,
    noise_levels: Vec<f64>,
}

impl Settings {
    fn of(args: &Args) -> Settings {
        let q = args.quick;
        Settings {
            level: args.level.unwrap_or(if q { 1 } else { 2 }),
            insert: args.insert.unwrap_or(if q { 1 } else { 3 }),
            steps: args.steps.unwrap_or(if q { 2 } else { 4 }),
            restarts: args.restarts.unwrap_or(if q { 5 } else { 20 }),
            noise_levels: args.noise_levels.clone().unwrap_or(if q {
                vec![1.0]
            } else {
                vec![1.0, 2.5, 5.0, 10.0, 20.0]
            }),
        }
    }
}

/// The paper's Table 1 (specificity, sensitivity in %).
fn paper_table1(kind: MetricKind) -> Option<(f64, f64)> {
    match kind {
        MetricKind::Rigid => Some((63.4, 55.2)),
        MetricKind::Isometric => Some((71.3, 69.2)),
        MetricKind::Conformal => Some((80.7, 84.2)),
        MetricKind::QuasiConformal => Some((97.9, 99.7)),
        MetricKind::L2 => None,
    }
}

/// The paper's Table 3 (uniform, Gaussian tau in %) by noise variance in percent.
fn paper_table3(level: f64) -> Option<(f64, f64)> {
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

fn metric_name(kind: MetricKind) -> &'static str {
    match kind {
        MetricKind::L2 => "l2",
        MetricKind::Rigid => "rigid",
        MetricKind::Isometric => "isometric",
        MetricKind::Conformal => "conformal",
        MetricKind::QuasiConformal => "quasi-conformal",
    }
}

/// One metric's run of the pipeline.
struct MetricRun {
    kind: MetricKind,
    metric: String,
    matrix: DistanceMatrix,
    clustering: Clustering,
    scores: Scores,
    prepared: Prepared,
    pair_seconds: Vec<f64>,
    /// Elapsed seconds: interpolation, transfer, similarity, intrinsic k-means.
    wall: [f64; 4],
    /// Scores of the kernel k-means partition (the start of the intrinsic k-means).
    kernel_scores: Scores,
    intrinsic_iterations: usize,
    unconverged: usize,
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, v.sqrt())
}

/// A data set classified by the pipeline: similarity matrix, kernel k-means and the intrinsic
/// k-means started from it.
pub(crate) struct Classified {
    pub(crate) prepared: Prepared,
    pub(crate) matrix: DistanceMatrix,
    /// The best kernel k-means partition (the start of the intrinsic k-means).
    pub(crate) kernel: Clustering,
    /// k-means with intrinsic means (eq. 14).
    pub(crate) clustering: Clustering,
    pub(crate) pair_seconds: Vec<f64>,
    /// Elapsed seconds: interpolation, transfer, similarity, intrinsic k-means.
    pub(crate) wall: [f64; 4],
    pub(crate) unconverged: usize,
}

/// Interpolation, transfer, similarity, kernel k-means (`restarts` seeded runs) and k-means with
/// intrinsic means of `defs` into `k` classes.
pub(crate) fn classify_set(
    defs: &[Deformation],
    opts: &PipelineOptions,
    k: usize,
    restarts: usize,
    seed: u64,
    what: &str,
) -> Result<Classified> {
    let data = Dataset {
        deformations: defs.to_vec(),
    };
    let t0 = Instant::now();
    let prepared = prepare_with_progress(&data, opts)?;
    let t_prepare = t0.elapsed().as_secs_f64();
    let n = defs.len();
    let pb = bar(n * (n - 1) / 2, what);
    let t1 = Instant::now();
    let pairs = similarities(&prepared, opts, &Default::default(), None, |_| {
        pb.inc(1);
        Ok(())
    })?;
    pb.finish_and_clear();
    let t_sim = t1.elapsed().as_secs_f64();
    let matrix = DistanceMatrix::new(prepared.names.clone(), assemble(n, &pairs))?;
    let t2 = Instant::now();
    let (kernel, clustering) = cluster_intrinsic(&matrix, &prepared, opts, k, restarts, seed)?;
    let t_kmeans = t2.elapsed().as_secs_f64();
    // Interpolation and transfer share one parallel pass each; split the measured wall time of
    // `prepare` in proportion to their summed per-deformation times.
    let (ti, tt): (f64, f64) = (
        prepared.interpolation_seconds.iter().sum(),
        prepared.transfer_seconds.iter().sum(),
    );
    let share = if ti + tt > 0.0 { ti / (ti + tt) } else { 0.5 };
    Ok(Classified {
        unconverged: pairs.iter().filter(|p| !p.converged).count(),
        pair_seconds: pairs.iter().map(|p| p.seconds).collect(),
        wall: [t_prepare * share, t_prepare * (1.0 - share), t_sim, t_kmeans],
        prepared,
        matrix,
        kernel,
        clustering,
    })
}

/// `defs` with noise of `kind` and variance `level` % (METHOD.md) added to every pose; each
/// deformation gets its own seed derived from `seed`, its index, the level and the kind.
pub(crate) fn noisy_set(defs: &[Deformation], kind: NoiseKind, level: f64, seed: u64) -> Vec<Deformation> {
    defs.iter()
        .enumerate()
        .map(|(i, d)| {
            let seed = seed ^ ((i as u64) << 16) ^ ((level * 1000.0) as u64) ^ (kind as u64 * 0x9e37);
            Deformation {
                poses: add_noise(&d.topology, &d.poses, kind, level, seed),
                ..d.clone()
            }
        })
        .collect()
}

/// Kernel k-means of `matrix` (the best of `restarts` seeded runs), then k-means with intrinsic
/// means (eq. 14) of the prepared deformations started from it. Returns both partitions.
pub(crate) fn cluster_intrinsic(
    matrix: &DistanceMatrix,
    prepared: &Prepared,
    opts: &PipelineOptions,
    k: usize,
    restarts: usize,
    seed: u64,
) -> Result<(Clustering, Clustering)> {
    let kernel = kernel_kmeans(
        matrix,
        &ClusterOptions {
            k,
            restarts,
            seed,
            max_iterations: 100,
        },
    )?;
    let metric = opts.metric.build();
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

/// The pipeline options of the reproduction for one metric.
fn options_for(kind: MetricKind, s: &Settings, args: &Args) -> PipelineOptions {
    let mut spec = MetricSpec::new(kind);
    spec.lambda = args.lambda;
    PipelineOptions {
        metric: spec,
        geodesic: GeodesicOptions {
            steps: s.steps,
            ..Default::default()
        },
        insert: s.insert,
        levels: 1,
        transport: args.transport,
        align: args.align,
        smoothing: args.smooth,
        base: 0,
    }
}

/// Interpolation, transfer, similarity and k-means of `defs` for one metric, scored.
fn run_metric(
    defs: &[Deformation],
    labels: &[String],
    kind: MetricKind,
    s: &Settings,
    args: &Args,
) -> Result<MetricRun> {
    let opts = options_for(kind, s, args);
    let c = classify_set(defs, &opts, 8, s.restarts, args.seed, metric_name(kind))?;
    Ok(MetricRun {
        kind,
        metric: opts.metric.build().name(),
        kernel_scores: score(&c.matrix, &c.kernel, labels)?,
        scores: score(&c.matrix, &c.clustering, labels)?,
        intrinsic_iterations: c.clustering.iterations,
        unconverged: c.unconverged,
        pair_seconds: c.pair_seconds,
        wall: c.wall,
        matrix: c.matrix,
        clustering: c.clustering,
        prepared: c.prepared,
    })
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let t_all = Instant::now();
    let s = Settings::of(args);
    if args.metrics.is_empty() {
        bail!("--metrics is empty");
    }
    if args.lambda.is_nan() || args.lambda < 0.0 {
        bail!("--lambda must be non-negative");
    }
    if s.steps == 0 || s.restarts == 0 {
        bail!("--steps and --restarts must be at least 1");
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let defs = genus0_benchmark(&SynthOptions {
        level: s.level,
        seed: args.seed,
        ..Default::default()
    })?;
    let manifest = write_benchmark(&args.out.join("data"), &defs, qcshape::io::Format::Ply)?;
    let labels: Vec<String> = defs.iter().map(|d| d.label.clone().unwrap_or_default()).collect();
    eprintln!(
        "{} synthetic deformations, {} vertices, {} key poses; data in {}",
        defs.len(),
        defs[0].topology.n_vertices(),
        defs[0].poses.len(),
        manifest.display()
    );

    let mut runs = Vec::new();
    for &kind in &args.metrics {
        let r = run_metric(&defs, &labels, kind, &s, args)?;
        let name = metric_name(kind);
        r.matrix
            .write_csv(&args.out.join(format!("similarity_{name}.csv")))?;
        figures(&args.out, name, &r, &labels)?;
        eprintln!(
            "{name:>16}: sensitivity {:.1} %, specificity {:.1} %, 1-NN {:.1} %, {:.1} s",
            100.0 * r.scores.eq15.sensitivity,
            100.0 * r.scores.eq15.specificity,
            100.0 * r.scores.nn_accuracy,
            r.wall.iter().sum::<f64>()
        );
        runs.push(r);
    }

    // Fig. 4: interpolation of the middle pose from the first and the last.
    let fig4 = {
        let exp = InterpolationExperiment {
            metrics: [
                MetricKind::QuasiConformal,
                MetricKind::Conformal,
                MetricKind::Isometric,
                MetricKind::L2,
            ]
            .into_iter()
            .map(|k| {
                let mut spec = MetricSpec::new(k);
                spec.lambda = args.lambda;
                spec
            })
            .collect(),
            ..Default::default()
        };
        let pb = bar(defs.len(), "interp. error");
        let r = exp.run_synthetic(&defs, &|| pb.inc(1))?;
        pb.finish_and_clear();
        r.write(&args.out.join("fig4"))?;
        eprintln!("{:>16}: {}", "Fig. 4", r.claim());
        r.to_markdown()
    };

    // Fig. 5: transfer of analytic deformations from a sphere to other bases.
    let fig5 = {
        let mut exp = TransferExperiment {
            level: s.level,
            ..Default::default()
        };
        for m in &mut exp.metrics {
            m.lambda = args.lambda;
        }
        let pb = bar(exp.n_transfers(), "transfer error");
        let r = exp.run(&|| pb.inc(1))?;
        pb.finish_and_clear();
        r.write(&args.out.join("fig5"))?;
        r.to_markdown()
    };

    // Table 3 with the quasi-conformal metric (or the last metric run).
    let noise_kind = runs
        .iter()
        .position(|r| r.kind == MetricKind::QuasiConformal)
        .unwrap_or(runs.len() - 1);
    let mut noise_rows = Vec::new();
    if !args.skip_noise {
        let reference = &runs[noise_kind];
        for &level in &s.noise_levels {
            let mut row = (level, 0.0, 0.0);
            for kind in [NoiseKind::Uniform, NoiseKind::Gaussian] {
                let noisy = noisy_set(&defs, kind, level, args.seed);
                let r = run_metric(&noisy, &labels, reference.kind, &s, args)?;
                let t = qcshape::eval::tau(&reference.clustering.assignments, &r.clustering.assignments)?;
                eprintln!(
                    "{:>16}: {level} % {} noise, tau {:.1} %",
                    "noise",
                    kind.name(),
                    100.0 * t
                );
                if kind == NoiseKind::Uniform {
                    row.1 = t;
                } else {
                    row.2 = t;
                }
            }
            noise_rows.push(row);
        }
    }

    let report = report(
        args,
        &s,
        &defs,
        &runs,
        (noise_kind, &noise_rows),
        [&fig4, &fig5],
        t_all.elapsed().as_secs_f64(),
    )?;
    let path = args.out.join("report.md");
    qcshape::io::write_atomically(&path, |w| w.write_all(report.as_bytes()))
        .with_context(|| format!("cannot write {}", path.display()))?;
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        t_all.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Fig. 6 (MDS map) and the similarity heat map of one metric.
fn figures(out: &Path, name: &str, r: &MetricRun, labels: &[String]) -> Result<()> {
    let e = smacof(&r.matrix, &MdsOptions::default())?;
    let title = format!("MDS of the 48 deformations, {name} metric");
    for ext in ["svg", "png"] {
        qcshape::plot::scatter_map(
            &out.join(format!("fig6_mds_{name}.{ext}")),
            &e.coords,
            r.matrix.names(),
            Some(labels),
            &title,
            Some(e.normalized_stress),
        )?;
    }
    let mut order: Vec<usize> = (0..labels.len()).collect();
    order.sort_by(|&a, &b| labels[a].cmp(&labels[b]).then(a.cmp(&b)));
    qcshape::plot::heatmap(
        &out.join(format!("similarity_{name}.svg")),
        &r.matrix,
        &order,
        Some(labels),
    )?;
    Ok(())
}

fn report(
    args: &Args,
    s: &Settings,
    defs: &[Deformation],
    runs: &[MetricRun],
    (noise_kind, noise): (usize, &[(f64, f64, f64)]),
    [fig4, fig5]: [&str; 2],
    seconds: f64,
) -> Result<String> {
    let mut md = String::new();
    let cmd: Vec<String> = std::env::args().collect();
    writeln!(
        md,
        "# qcshape reproduction of the paper's synthetic experiments\n"
    )?;
    writeln!(md, "Command: `{}`  ", cmd.join(" "))?;
    writeln!(
        md,
        "qcshape {} ({} {}), {} worker threads, total {:.1} s.\n",
        env!("CARGO_PKG_VERSION"),
        std::env::consts::OS,
        std::env::consts::ARCH,
        rayon::current_num_threads(),
        seconds
    )?;
    writeln!(
        md,
        "Data: {} deformations (6 initial shapes x 8 deformations, `qcshape synth --level {} --seed {}`), \
         {} vertices, {} key poses, {} poses inserted between key poses ({} poses per deformation), \
         geodesics with N = {} segments, metrics regularized with lambda = {} (eq. 11), \
         transfer by {} transport to the first pose of `{}`, k-means with intrinsic means \
         started from the best of {} seeded kernel k-means runs (k = 8). Data set: `data/manifest.csv`.\n",
        defs.len(),
        s.level,
        args.seed,
        defs[0].topology.n_vertices(),
        defs[0].poses.len(),
        s.insert,
        runs[0].prepared.transferred[0].len(),
        s.steps,
        args.lambda,
        args.transport.label(),
        defs[0].name,
        s.restarts
    )?;

    writeln!(
        md,
        "## Table 1: classification of the 48 deformations into 8 classes\n"
    )?;
    writeln!(
        md,
        "| metric | specificity (%) | sensitivity (%) | paper specificity | paper sensitivity | kernel k-means spec. / sens. (%) | 1-NN (%) | ARI |"
    )?;
    writeln!(md, "|---|---|---|---|---|---|---|---|")?;
    for r in runs {
        let p = paper_table1(r.kind);
        writeln!(
            md,
            "| {} | {:.1} | {:.1} | {} | {} | {:.1} / {:.1} | {:.1} | {:.3} |",
            metric_name(r.kind),
            100.0 * r.scores.eq15.specificity,
            100.0 * r.scores.eq15.sensitivity,
            p.map_or("-".into(), |p| format!("{:.1}", p.0)),
            p.map_or("-".into(), |p| format!("{:.1}", p.1)),
            100.0 * r.kernel_scores.eq15.specificity,
            100.0 * r.kernel_scores.eq15.sensitivity,
            100.0 * r.scores.nn_accuracy,
            r.scores.ari
        )?;
    }
    writeln!(
        md,
        "\nClasses come from k-means with intrinsic means (eq. 14: class means are deformations whose \
         poses are Karcher means, METHOD.md), started from the best of the seeded kernel k-means \
         runs on the squared similarities (whose own scores are in the sixth column); {} rounds \
         at most. Sensitivity and specificity follow eq. 15 on the average of the per-class one-vs-rest \
         confusion matrices after Hungarian matching of clusters to classes; with this reading the \
         sensitivity equals the matched accuracy and the specificity is never below it (the paper's \
         quasi-conformal row, 97.9 / 99.7, has specificity below sensitivity, so it cannot come from \
         this reading). 1-NN: leave-one-out nearest-neighbour accuracy on the similarity matrix \
         (no clustering). Metric names as computed: {}.",
        IntrinsicOptions::default().max_iterations,
        runs.iter()
            .map(|r| format!("`{}`", r.metric))
            .collect::<Vec<_>>()
            .join(", ")
    )?;
    let unconverged: usize = runs.iter().map(|r| r.unconverged).sum();
    if unconverged > 0 || runs.iter().any(|r| !r.prepared.converged) {
        writeln!(
            md,
            "\nWarning: {unconverged} pair(s) had a similarity geodesic that stopped at the iteration limit."
        )?;
    }

    writeln!(
        md,
        "\n## Table 2: time of each pipeline step for all {} deformations\n",
        defs.len()
    )?;
    writeln!(
        md,
        "| metric | interpolation, per deformation (s) | transfer, per deformation (s) | similarity, per pair (s) | wall clock: interpolation / transfer / similarity / intrinsic k-means (s) |"
    )?;
    writeln!(md, "|---|---|---|---|---|")?;
    for r in runs {
        let (im, is) = mean_sd(&r.prepared.interpolation_seconds);
        let (tm, ts) = mean_sd(&r.prepared.transfer_seconds);
        let (pm, ps) = mean_sd(&r.pair_seconds);
        writeln!(
            md,
            "| {} | {im:.4} ± {is:.4} | {tm:.4} ± {ts:.4} | {pm:.4} ± {ps:.4} | {:.2} / {:.2} / {:.2} / {:.2} ({} rounds) |",
            metric_name(r.kind),
            r.wall[0],
            r.wall[1],
            r.wall[2],
            r.wall[3],
            r.intrinsic_iterations
        )?;
    }
    writeln!(
        md,
        "\nThe paper reports 40 ± 0.47, 102 ± 0.11 and 15 ± 0.28 *minutes* for the three steps on a \
         3 GHz Pentium. Per-item times are measured inside parallel loops (each item's own wall \
         time); the last column is the elapsed time of each step."
    )?;

    if !noise.is_empty() {
        writeln!(
            md,
            "\n## Table 3: noise resistance ({} metric)\n",
            metric_name(runs[noise_kind].kind)
        )?;
        writeln!(
            md,
            "| noise variance (%) | uniform tau (%) | Gaussian tau (%) | paper uniform | paper Gaussian |"
        )?;
        writeln!(md, "|---|---|---|---|---|")?;
        for &(level, u, g) in noise {
            let p = paper_table3(level);
            writeln!(
                md,
                "| {level} | {:.1} | {:.1} | {} | {} |",
                100.0 * u,
                100.0 * g,
                p.map_or("-".into(), |p| format!("{:.1}", p.0)),
                p.map_or("-".into(), |p| format!("{:.1}", p.1))
            )?;
        }
        writeln!(
            md,
            "\nNoise is added to every key pose with per-coordinate variance `level/100 * lbar^2` \
             (lbar: the pose's mean edge length; METHOD.md); tau (eq. 17) is the share of \
             deformations whose cluster is unchanged against the noise-free run, after Hungarian \
             matching of the clusters."
        )?;
    }

    writeln!(
        md,
        "\n## Fig. 4: interpolation of the middle pose (files in `fig4/`)\n"
    )?;
    writeln!(
        md,
        "The middle pose of every deformation is interpolated from its first and last poses \
         (one inserted pose) and compared per vertex with the true middle pose. Error bars: \
         `fig4/interpolation.svg`; error maps of one case per metric: `fig4/*.ply`.\n"
    )?;
    writeln!(md, "{}", fig4.trim_end())?;

    writeln!(md, "\n## Fig. 5: deformation transfer (files in `fig5/`)\n")?;
    writeln!(
        md,
        "Analytic deformations of a sphere are transferred to other initial shapes and compared per \
         vertex with the same analytic deformation applied to each shape directly.\n"
    )?;
    writeln!(md, "{}", fig5.trim_end())?;

    writeln!(md, "\n## Fig. 6: MDS maps\n")?;
    for r in runs {
        let name = metric_name(r.kind);
        writeln!(md, "![{name}](fig6_mds_{name}.svg)")?;
    }
    writeln!(
        md,
        "\nSimilarity matrices: {} (CSV, and heat maps ordered by class: {}).",
        runs.iter()
            .map(|r| format!("`similarity_{}.csv`", metric_name(r.kind)))
            .collect::<Vec<_>>()
            .join(", "),
        runs.iter()
            .map(|r| format!("`similarity_{}.svg`", metric_name(r.kind)))
            .collect::<Vec<_>>()
            .join(", ")
    )?;
    Ok(md)
}
