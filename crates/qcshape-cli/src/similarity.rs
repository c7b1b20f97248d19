//! `qcshape similarity`: the similarity matrix of a data set of deformations (eq. 13).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use qcshape::dataset::Dataset;
use qcshape::similarity::{
    assemble, fingerprint, prepare, settings_key, similarities, DistanceMatrix, Journal, PairDistance,
    PipelineOptions, Prepared, Stage,
};
use qcshape::transport::{Alignment, Transport};

use crate::args::{in_pool, MetricArgs, SolverArgs};

/// Compute the similarity matrix of the deformations of a data set.
///
/// Every deformation is interpolated (--insert poses between consecutive key poses), carried
/// to one common base (the first pose of --base, default the first deformation) by --transport,
/// and `similarity(M, N) = sum_i dis(M_i, N_i)` over corresponding poses (eq. 13) is computed for
/// every pair, pairs in parallel. Distances are in normalized units (coordinates divided by the
/// mean edge length of the base pose).
///
/// Finished pairs are appended to OUTPUT.journal as they complete; after an interruption, run
/// the same command with --resume to compute only the missing pairs. OUTPUT appears only when
/// the matrix is complete (the journal is then removed).
#[derive(Debug, clap::Args)]
#[command(
    about = "Similarity matrix of a data set of deformations (eq. 13)",
    long_about
)]
pub struct Args {
    /// The data set: a manifest CSV (`deformation,label,pose,path`) or a folder of deformation folders.
    input: PathBuf,
    #[command(flatten)]
    metric: MetricArgs,
    #[command(flatten)]
    solver: SolverArgs,
    /// Poses inserted between consecutive key poses before comparing (section 2.2.1).
    #[arg(long, default_value_t = 0)]
    insert: usize,
    /// Spatial levels of the interpolation (1 = single level, the measured fastest).
    #[arg(long, default_value_t = 1)]
    levels: usize,
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
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Reuse the pairs recorded in OUTPUT.journal by an interrupted run with the same inputs and settings.
    #[arg(long)]
    resume: bool,
    /// Output CSV: header `name,<name_1>,...,<name_n>`, one row per deformation.
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// Also write the per-pose distances dis(M_i, N_i) of every pair to this CSV.
    #[arg(long)]
    details: Option<PathBuf>,
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
pub(crate) fn bar(len: usize, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{msg:>14} {bar:40} {pos}/{len} [{elapsed_precise}, ETA {eta}]")
    {
        pb.set_style(style);
    }
    pb.set_message(what.to_string());
    pb
}

/// The pipeline options of the command line.
pub(crate) fn pipeline_options(
    data: &Dataset,
    metric: &MetricArgs,
    solver: &SolverArgs,
    insert: usize,
    levels: usize,
    transport: Transport,
    base: Option<&str>,
) -> Result<PipelineOptions> {
    if levels == 0 {
        bail!("--levels must be at least 1");
    }
    let base = match base {
        None => 0,
        Some(name) => data
            .deformations
            .iter()
            .position(|d| d.name == name)
            .with_context(|| format!("--base {name:?} is not a deformation of the data set"))?,
    };
    Ok(PipelineOptions {
        metric: metric.spec()?,
        geodesic: solver.options()?,
        insert,
        levels,
        transport,
        base,
        align: Alignment::default(),
        smoothing: 0,
    })
}

/// Interpolation and transfer with progress bars.
pub(crate) fn prepare_with_progress(data: &Dataset, opts: &PipelineOptions) -> Result<Prepared> {
    let n = data.deformations.len();
    let interp = bar(n, "interpolating");
    let transfer = bar(n, "transferring");
    let prepared = prepare(&data.deformations, opts, &|stage, _| match stage {
        Stage::Interpolation => interp.inc(1),
        Stage::Transfer => transfer.inc(1),
        Stage::Similarity => {}
    })?;
    interp.finish_and_clear();
    transfer.finish_and_clear();
    Ok(prepared)
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
            "{}: a similarity matrix needs at least two deformations",
            args.input.display()
        );
    }
    let opts = pipeline_options(
        &data,
        &args.metric,
        &args.solver,
        args.insert,
        args.levels,
        args.transport,
        args.base.as_deref(),
    )?;
    let opts = PipelineOptions {
        align: args.align,
        smoothing: args.smooth,
        ..opts
    };
    eprintln!(
        "{n} deformations, {} poses each, {} vertices; {}",
        data.deformations[0].poses.len(),
        data.deformations[0].topology.n_vertices(),
        opts.metric.build().name()
    );
    let prepared = prepare_with_progress(&data, &opts)?;
    let (matrix, pairs, journal) = journaled_matrix(&prepared, &opts, &args.output, args.resume)?;
    matrix.write_csv(&args.output)?;
    if let Some(path) = &args.details {
        write_details(path, &prepared, &pairs)?;
    }
    journal.remove()?;
    let unconverged = pairs.iter().filter(|p| !p.converged).count();
    eprintln!(
        "wrote {} ({n} x {n}) in {:.1} s{}",
        args.output.display(),
        t0.elapsed().as_secs_f64(),
        if unconverged > 0 || !prepared.converged {
            format!("; warning: {unconverged} pair(s) with a geodesic that did not converge")
        } else {
            String::new()
        }
    );
    Ok(())
}

/// The similarity matrix (eq. 13) of prepared deformations, with a progress bar. Finished pairs
/// are appended to `OUTPUT.journal` as they complete; with `resume`, the pairs of an earlier
/// run with the same inputs and settings are taken from it. Returns the matrix, all pairs in row
/// order, and the journal, to be removed once the outputs are written.
pub(crate) fn journaled_matrix(
    prepared: &Prepared,
    opts: &PipelineOptions,
    output: &Path,
    resume: bool,
) -> Result<(DistanceMatrix, Vec<PairDistance>, Journal)> {
    let n = prepared.names.len();
    let key = fingerprint(&prepared.names, &prepared.transferred, &settings_key(opts));
    let journal_path = journal_path(output);
    if journal_path.exists() && !resume {
        eprintln!(
            "note: {} exists from an earlier run; starting over (use --resume to keep its pairs)",
            journal_path.display()
        );
    }
    let (journal, done_pairs) = Journal::open(&journal_path, key, n, resume)?;
    if resume {
        eprintln!(
            "resuming: {} of {} pairs already done",
            done_pairs.len(),
            n * (n - 1) / 2
        );
    }
    let done: HashSet<(usize, usize)> = done_pairs.iter().map(|p| (p.i, p.j)).collect();
    let pb = bar(n * (n - 1) / 2, "pairs");
    pb.set_position(done.len() as u64);
    let new_pairs = similarities(prepared, opts, &done, None, |p| {
        journal.record(p)?;
        pb.inc(1);
        Ok(())
    })?;
    pb.finish_and_clear();
    let mut pairs = done_pairs;
    pairs.extend(new_pairs);
    pairs.sort_by_key(|p| (p.i, p.j));
    let matrix = DistanceMatrix::new(prepared.names.clone(), assemble(n, &pairs))?;
    Ok((matrix, pairs, journal))
}

/// `OUTPUT.journal` beside the output.
pub(crate) fn journal_path(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".journal");
    PathBuf::from(s)
}

fn write_details(
    path: &Path,
    prepared: &Prepared,
    pairs: &[qcshape::similarity::PairDistance],
) -> Result<()> {
    let mut text = String::from("a,b,pose,distance,converged\n");
    for p in pairs {
        for (k, d) in p.per_pose.iter().enumerate() {
            text.push_str(&format!(
                "{},{},{k},{d:?},{}\n",
                csv_field(&prepared.names[p.i]),
                csv_field(&prepared.names[p.j]),
                p.converged
            ));
        }
    }
    qcshape::io::write_atomically(path, |w| w.write_all(text.as_bytes()))
        .with_context(|| format!("cannot write {}", path.display()))
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
