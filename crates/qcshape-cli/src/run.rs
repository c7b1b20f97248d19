//! `qcshape run`: the whole analysis of a data set in one command.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::similarity::{journal_path, Selection, Sink};
use qcshape_studies::experiment::analysis::{analyse, class_count, dataset_labels, AnalysisReport};
use qcshape_studies::experiment::provenance::Provenance;

use crate::args::{in_pool, PipelineArgs};
use crate::pipeline::{matrix_with_progress, prepare_with_progress, report_shares};

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
    pipeline: PipelineArgs,
    #[command(flatten)]
    template: crate::template::TemplateArgs,
    /// Number of classes (default: the number of distinct labels).
    /// At most 10,000.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_CLUSTERS as u64), allow_negative_numbers = true)]
    k: Option<usize>,
    /// Kernel k-means restarts (the start of the intrinsic k-means).
    /// At most 10,000.
    #[arg(long, default_value_t = qcshape::defaults::RESTARTS, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_RESTARTS as u64), allow_negative_numbers = true)]
    restarts: usize,
    /// Seed of the clustering.
    #[arg(long, default_value_t = qcshape::defaults::SEED)]
    seed: u64,
    /// Reuse the finished pairs of an interrupted run.
    #[arg(long)]
    resume: bool,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let t0 = Instant::now();
    let source = crate::template::Source::Dataset(&args.input);
    let quality = args.out.join("quality.csv");
    let (data, _) = args.template.load(source, &[], &quality, Some(&args.out), &[])?;
    crate::input::refuse_out_folder(&data.input_paths(&args.input), &args.out, "--out")?;
    let n = data.deformations.len();
    if n < 2 {
        bail!(
            "{}: the analysis needs at least two deformations",
            args.input.display()
        );
    }
    // The report's scores need a label on every deformation once any has one.
    data.refuse_partial_labels(&args.input, "run")?;
    let labels = dataset_labels(&data.deformations);
    let k = match (args.k, class_count(labels.as_deref())) {
        (Some(k), _) => k,
        (None, c) if c >= 2 => c,
        _ => bail!("the data set has no labels (or one class): give the number of classes with --k"),
    };
    if k == 0 || k > n {
        bail!("--k must be between 1 and the number of deformations ({n})");
    }
    let opts = args.pipeline.options(&data)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    // One run at a time on OUT's journal (taken before anything is computed; released on exit).
    let matrix_path = args.out.join("similarity.csv");
    let _lock = qcshape::outputs::RunLock::acquire(&journal_path(&matrix_path))?;

    let tp = Instant::now();
    let prepared = prepare_with_progress(&data, &opts)?;
    let prepare_seconds = tp.elapsed().as_secs_f64();

    let ts = Instant::now();
    let sink = Sink::Journal {
        path: journal_path(&matrix_path),
        resume: args.resume,
    };
    let mut outcome = matrix_with_progress(&prepared, &opts, Selection::All, sink)?;
    let matrix = outcome.matrix.take().context("the run computed every pair")?;
    matrix.write_csv(&matrix_path)?;
    outcome.finish()?;
    let pairs = outcome.pairs;
    let similarity_seconds = ts.elapsed().as_secs_f64();
    let shares = report_shares(&pairs, opts.metric.kind.label());

    let analysis = analyse(
        &matrix,
        &prepared,
        &opts,
        k,
        args.restarts,
        args.seed,
        labels.as_deref(),
    )?;
    let metric = opts.metric.label();
    analysis.write(&args.out, &matrix, &metric)?;
    let cmd: Vec<String> = std::env::args().collect();
    let report = AnalysisReport {
        provenance: Provenance::current(cmd.join(" "), t0.elapsed().as_secs_f64()),
        input: args.input.display().to_string(),
        deformations: n,
        key_poses: data.deformations[0].poses.len(),
        vertices: prepared.topology.n_vertices(),
        metric,
        insert: opts.insert,
        transport: opts.transport.label().to_string(),
        base: prepared.names[opts.base].clone(),
        steps: opts.geodesic.steps,
        prepare_seconds,
        similarity_seconds,
        shares,
        k,
        analysis,
    };
    let path = args.out.join("report.md");
    let md = report.to_markdown();
    qcshape::io::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
    eprintln!("wrote {} in {:.1} s", path.display(), t0.elapsed().as_secs_f64());
    Ok(())
}
