//! `qcshape run`: the whole analysis of a data set in one command.

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::dataset::Dataset;
use qcshape::embed::{smacof, MdsOptions};
use qcshape::transport::{Alignment, Transport};

use crate::args::{in_pool, MetricArgs, SolverArgs};
use crate::classify::{score, write_assignments, write_confusion};
use crate::reproduce::cluster_intrinsic;
use crate::similarity::{journaled_matrix, pipeline_options, prepare_with_progress};

/// Run the whole analysis of a data set: interpolation, transfer, similarity, classification,
/// projection and a report.
///
/// Writes to DIR: similarity.csv (eq. 13), assignments.csv (k-means with intrinsic means, eq. 14,
/// started from the best of --restarts seeded kernel k-means runs), confusion.csv and the
/// scores of eq. 15 when the data set has labels, coordinates.csv and map.svg/png (SMACOF MDS,
/// eq. 16), heatmap.svg, and report.md with the tables, the exact command line and the version.
/// The similarity step is resumable: re-run with --resume after an interruption.
#[derive(Debug, clap::Args)]
#[command(
    about = "Interpolation, transfer, similarity, classification, projection and a report",
    long_about
)]
pub struct Args {
    /// The data set: a manifest CSV (`deformation,label,pose,path`) or a folder of deformation folders.
    input: PathBuf,
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    metric: MetricArgs,
    #[command(flatten)]
    solver: SolverArgs,
    /// Poses inserted between consecutive key poses (section 2.2.1).
    #[arg(long, default_value_t = 3)]
    insert: usize,
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
    /// Name of the reference deformation whose first pose is the common base (default: the first).
    #[arg(long)]
    base: Option<String>,
    /// Number of classes (default: the number of distinct labels).
    #[arg(long)]
    k: Option<usize>,
    /// Kernel k-means restarts (the start of the intrinsic k-means).
    #[arg(long, default_value_t = 20)]
    restarts: usize,
    /// Seed of the clustering.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Reuse the finished pairs of an interrupted run.
    #[arg(long)]
    resume: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let t0 = Instant::now();
    let data = Dataset::load(&args.input)?;
    let n = data.deformations.len();
    if n < 2 {
        bail!(
            "{}: the analysis needs at least two deformations",
            args.input.display()
        );
    }
    let labels: Option<Vec<String>> = data
        .deformations
        .iter()
        .map(|d| d.label.clone().filter(|l| !l.is_empty()))
        .collect();
    let n_classes = labels
        .as_ref()
        .map(|l| l.iter().collect::<HashSet<_>>().len())
        .unwrap_or(0);
    let k = match (args.k, n_classes) {
        (Some(k), _) => k,
        (None, c) if c >= 2 => c,
        _ => bail!("the data set has no labels (or one class): give the number of classes with --k"),
    };
    if k == 0 || k > n {
        bail!("--k must be between 1 and the number of deformations ({n})");
    }
    let opts = pipeline_options(
        &data,
        &args.metric,
        &args.solver,
        args.insert,
        1,
        args.transport,
        args.base.as_deref(),
    )?;
    let opts = qcshape::similarity::PipelineOptions {
        align: args.align,
        smoothing: args.smooth,
        ..opts
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;

    let tp = Instant::now();
    let prepared = prepare_with_progress(&data, &opts)?;
    let t_prepare = tp.elapsed().as_secs_f64();

    let ts = Instant::now();
    let matrix_path = args.out.join("similarity.csv");
    let (matrix, _, journal) = journaled_matrix(&prepared, &opts, &matrix_path, args.resume)?;
    matrix.write_csv(&matrix_path)?;
    journal.remove()?;
    let t_sim = ts.elapsed().as_secs_f64();

    let tk = Instant::now();
    let (_, clustering) = cluster_intrinsic(&matrix, &prepared, &opts, k, args.restarts, args.seed)?;
    let metric = opts.metric.build();
    let t_cluster = tk.elapsed().as_secs_f64();
    let scores = labels
        .as_deref()
        .filter(|_| n_classes >= 2)
        .map(|l| score(&matrix, &clustering, l))
        .transpose()?;
    write_assignments(
        &args.out.join("assignments.csv"),
        &matrix,
        &clustering,
        scores.as_ref(),
    )?;
    if let Some(s) = &scores {
        write_confusion(&args.out.join("confusion.csv"), s)?;
    }

    let e = smacof(&matrix, &MdsOptions::default())?;
    let mut coords = String::from("name,x,y\n");
    for (name, c) in matrix.names().iter().zip(&e.coords) {
        writeln!(coords, "{name},{:?},{:?}", c[0], c[1])?;
    }
    qcshape::io::write_atomically(&args.out.join("coordinates.csv"), |w| {
        w.write_all(coords.as_bytes())
    })?;
    let plot_labels: Vec<String> = match &labels {
        Some(l) => l.clone(),
        None => clustering
            .assignments
            .iter()
            .map(|c| format!("cluster {c}"))
            .collect(),
    };
    for ext in ["svg", "png"] {
        qcshape::plot::scatter_map(
            &args.out.join(format!("map.{ext}")),
            &e.coords,
            matrix.names(),
            Some(&plot_labels),
            &format!("MDS of {n} deformations ({})", metric.name()),
            Some(e.normalized_stress),
        )?;
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| plot_labels[a].cmp(&plot_labels[b]).then(a.cmp(&b)));
    qcshape::plot::heatmap(&args.out.join("heatmap.svg"), &matrix, &order, Some(&plot_labels))?;

    // report.md
    let mut md = String::new();
    let cmd: Vec<String> = std::env::args().collect();
    writeln!(md, "# qcshape analysis of `{}`\n", args.input.display())?;
    writeln!(md, "Command: `{}`  ", cmd.join(" "))?;
    writeln!(
        md,
        "qcshape {} ({} {}), {} worker threads, total {:.1} s.\n",
        env!("CARGO_PKG_VERSION"),
        std::env::consts::OS,
        std::env::consts::ARCH,
        rayon::current_num_threads(),
        t0.elapsed().as_secs_f64()
    )?;
    writeln!(
        md,
        "{n} deformations, {} key poses each, {} vertices; metric `{}`; {} poses inserted between key \
         poses; {} transport to the first pose of `{}`; geodesics with N = {}. Distances are in units of \
         the base pose's mean edge length.\n",
        data.deformations[0].poses.len(),
        prepared.topology.n_vertices(),
        metric.name(),
        args.insert,
        args.transport.label(),
        prepared.names[opts.base],
        opts.geodesic.steps
    )?;
    writeln!(md, "## Time\n\n| step | seconds |\n|---|---|")?;
    writeln!(md, "| interpolation + transfer | {t_prepare:.2} |")?;
    writeln!(md, "| similarity ({} pairs) | {t_sim:.2} |", n * (n - 1) / 2)?;
    writeln!(
        md,
        "| clustering ({} intrinsic rounds) | {t_cluster:.2} |",
        clustering.iterations
    )?;
    writeln!(md, "\n## Classification (k = {k})\n")?;
    match &scores {
        Some(s) => {
            writeln!(md, "| measure | value |\n|---|---|")?;
            writeln!(
                md,
                "| sensitivity (eq. 15) | {:.1} % |",
                100.0 * s.eq15.sensitivity
            )?;
            writeln!(
                md,
                "| specificity (eq. 15) | {:.1} % |",
                100.0 * s.eq15.specificity
            )?;
            writeln!(
                md,
                "| mean per-class sensitivity | {:.1} % |",
                100.0 * s.eq15.macro_sensitivity
            )?;
            writeln!(
                md,
                "| mean per-class specificity | {:.1} % |",
                100.0 * s.eq15.macro_specificity
            )?;
            writeln!(
                md,
                "| leave-one-out 1-NN accuracy | {:.1} % |",
                100.0 * s.nn_accuracy
            )?;
            writeln!(md, "| adjusted Rand index | {:.3} |", s.ari)?;
            writeln!(
                md,
                "\nConfusion matrix (rows: class; columns: class matched to the cluster): `confusion.csv`."
            )?;
        }
        None => writeln!(md, "No labels: clusters only (`assignments.csv`).")?,
    }
    writeln!(
        md,
        "\n## Map\n\n![MDS map](map.svg)\n\nSMACOF stress-1 {:.4} ({} iterations); similarity heat map: `heatmap.svg`.",
        e.normalized_stress,
        e.iterations
    )?;
    qcshape::io::write_atomically(&args.out.join("report.md"), |w| w.write_all(md.as_bytes()))?;
    eprintln!(
        "wrote {} in {:.1} s",
        args.out.join("report.md").display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
