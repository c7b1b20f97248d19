//! `qcshape similarity`: the similarity matrix of a data set of deformations (eq. 13).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::similarity::{
    journal_path, merge_shards, PipelineOptions, Prepared, Selection, Shard, Sink, Unconverged,
};

use crate::args::{in_pool, PipelineArgs};
use crate::matrix_out::{matrix_files, write_details, write_matrix};
use crate::pipeline::{matrix_with_progress, prepare_with_progress, report_shares};

/// Compute the similarity matrix of the deformations of a data set.
///
/// Every deformation is interpolated (--insert poses between consecutive key poses), carried
/// to one common base (the first pose of --base, default the first deformation) by --transport,
/// and `similarity(M, N) = sum_i dis(M_i, N_i)` over corresponding poses (eq. 13) is computed for
/// every pair, pairs in parallel. Units: dimensionless with the default --scale invariant (the
/// same at any size and resolution); mean-edge units with --scale calibrated or raw.
///
/// The L2 regularizer's share of each pair's path energy is summarized on stderr (min, median,
/// max, pairs above 50 %), with a warning when it is above one half for more than half of the
/// pairs: the distances then measure L2 displacement more than the metric's geometry.
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
    pipeline: PipelineArgs,
    #[command(flatten)]
    template: crate::template::TemplateArgs,
    /// Worker threads (default: all cores). The results are bit-identical for any count, so a run
    /// can be resumed with another one.
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
    /// Reuse the pairs recorded in OUTPUT.journal by an interrupted run with the same inputs and settings.
    #[arg(long)]
    resume: bool,
    /// Output CSV: header `name,<name_1>,...,<name_n>`, one row per deformation; a name ending
    /// in .npy writes a NumPy float64 (n, n) array instead, with the names in NAME.names.txt.
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// Also write the per-pose distances dis(M_i, N_i) of every pair to this CSV, with the
    /// energy split of each pose's path (geometric_energy, regularizer_energy) and the pair's
    /// regularizer_share (empty with --approx tangent).
    #[arg(long)]
    details: Option<PathBuf>,
    /// Compute only shard K of S of the pairs (a deterministic round-robin split) into
    /// OUTPUT.shard-K-of-S, for batch systems (one array task per shard); then
    /// `qcshape similarity-merge OUTPUT.shard-*-of-S -o OUTPUT` writes the matrix, byte-identical
    /// to a single run. A killed shard continues with --resume.
    #[arg(long, value_name = "K/S")]
    shard: Option<Shard>,
    /// With --details: split the similarity of the pair NAME_A,NAME_B per pose and vertex and
    /// write DETAILS_STEM.explain_A_vs_B.csv (vertex,total,pose_000,...), .vtk and .ply on the
    /// base mesh (those fields as point data) and .png (the total, six views). Normalized
    /// length units; `total` sums to the pair's similarity.
    #[arg(long, value_name = "NAME_A,NAME_B", requires = "details")]
    explain: Option<String>,
}

/// Merge the shards of a sharded similarity run into the matrix.
///
/// Checks that the files are the shards of one run (same data fingerprint, settings and shard
/// count), that every shard is there once and complete, and writes the matrix: the same bytes as
/// a single `qcshape similarity` run with the same inputs and settings.
#[derive(Debug, clap::Args)]
#[command(
    about = "Merge the shards of `similarity --shard K/S` into the matrix",
    long_about
)]
pub struct MergeArgs {
    /// The shard files, OUTPUT.shard-K-of-S for K = 1..S (any order).
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Output matrix: CSV, or .npy (names in NAME.names.txt), as for `qcshape similarity`.
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// Also write the per-pose distances of every pair to this CSV (with the energy split, as
    /// `similarity --details`; empty for shards written before it was recorded).
    #[arg(long)]
    details: Option<PathBuf>,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let t0 = Instant::now();
    // Every output is checked, and the journal (or shard file) claimed, before the data set is
    // read or fitted (--template): one run at a time on it, released on exit.
    let outputs = output_files(args)?;
    let claimed = match args.shard {
        Some(shard) => shard.file_for(&args.output),
        None => journal_path(&args.output),
    };
    let _lock = qcshape::outputs::RunLock::acquire(&claimed)?;
    let source = crate::template::Source::Dataset(&args.input);
    let quality = crate::template::quality_beside(&args.output);
    let (data, _) = args.template.load(source, &[], &quality, None, &outputs)?;
    for (file, what) in &outputs {
        data.refuse_overwrite(&args.input, file, what)?;
    }
    let n = data.deformations.len();
    if n < 2 {
        bail!(
            "{}: a similarity matrix needs at least two deformations",
            args.input.display()
        );
    }
    if let Some(pair) = &args.explain {
        // Checked before the matrix is computed.
        let names: Vec<&str> = pair.split(',').map(str::trim).collect();
        for name in &names {
            if !data.deformations.iter().any(|d| d.name == *name) {
                bail!(
                    "--explain: no deformation named {name:?} in {}",
                    args.input.display()
                );
            }
        }
        if names.len() != 2 || names[0] == names[1] {
            bail!("--explain {pair:?}: give two different deformation names separated by a comma");
        }
    }
    let opts = args.pipeline.options(&data)?;
    // Different pose counts are refused by the pipeline; refused here, before the summary line
    // claims one count for all.
    let base = &data.deformations[opts.base];
    if let Some(d) = data
        .deformations
        .iter()
        .find(|d| d.poses.len() != base.poses.len())
    {
        bail!(
            "{}: deformation {:?} has {} poses but {:?} has {}: all deformations need the same \
             number of key poses",
            args.input.display(),
            d.name,
            d.poses.len(),
            base.name,
            base.poses.len()
        );
    }
    eprintln!(
        "{n} deformations, {} poses each, {} vertices; {}",
        base.poses.len(),
        data.deformations[0].topology.n_vertices(),
        opts.metric.label()
    );
    let prepared = prepare_with_progress(&data, &opts)?;
    if let Some(shard) = args.shard {
        let file = shard.file_for(&args.output);
        let sink = Sink::Journal {
            path: file.clone(),
            resume: args.resume,
        };
        let outcome = matrix_with_progress(&prepared, &opts, Selection::Shard(shard), sink)?;
        let pairs = outcome.pairs;
        eprintln!(
            "wrote shard {shard} ({} of {} pairs) to {} in {:.1} s; when all {} shards are done: qcshape similarity-merge {}.shard-*-of-{} -o {}",
            pairs.len(),
            n * (n - 1) / 2,
            file.display(),
            t0.elapsed().as_secs_f64(),
            shard.count,
            args.output.display(),
            shard.count,
            args.output.display()
        );
        return Ok(());
    }
    let sink = Sink::Journal {
        path: journal_path(&args.output),
        resume: args.resume,
    };
    let mut outcome = matrix_with_progress(&prepared, &opts, Selection::All, sink)?;
    let pairs = &outcome.pairs;
    report_shares(pairs, opts.metric.kind.label());
    let matrix = outcome.matrix.as_ref().context("the run computed every pair")?;
    write_matrix(&args.output, matrix)?;
    if let Some(path) = &args.details {
        write_details(path, &prepared.names, pairs)?;
        if let Some(pair) = &args.explain {
            explain_pair(path, pair, &prepared, &opts)?;
        }
    }
    let unconverged = Unconverged::of(&prepared.names, pairs);
    outcome.finish()?;
    eprintln!(
        "wrote {} ({n} x {n}) in {:.1} s",
        args.output.display(),
        t0.elapsed().as_secs_f64(),
    );
    let hint = format!(" ({})", opts.geodesic.solver.stall_hint(opts.metric.bends()));
    if let Some(u) = unconverged {
        eprintln!("warning: {u}{hint}");
    }
    if !prepared.converged {
        eprintln!("warning: a geodesic of the interpolation or the transfer did not converge{hint}");
    }
    Ok(())
}

/// Runs `similarity-merge`.
pub fn run_merge(args: &MergeArgs) -> Result<()> {
    let shards: Vec<&std::path::Path> = args.shards.iter().map(PathBuf::as_path).collect();
    for (file, what) in matrix_files(&args.output) {
        crate::input::refuse_outputs(&shards, &[(Some(&file), what)])?;
    }
    crate::input::refuse_outputs(&shards, &[(args.details.as_deref(), "--details")])?;
    let merged = merge_shards(&args.shards)?;
    let n = merged.names.len();
    let matrix = merged.matrix()?;
    write_matrix(&args.output, &matrix)?;
    if let Some(path) = &args.details {
        write_details(path, &merged.names, &merged.pairs)?;
    }
    // What a merge knows of the metric is the settings string (`MetricSpec { kind: ... }|...`).
    let metric = qcshape::metric::MetricKind::all()
        .into_iter()
        .find(|k| {
            merged
                .settings
                .starts_with(&format!("MetricSpec {{ kind: {k:?},"))
        })
        .map_or("merged matrix's", |k| k.label());
    report_shares(&merged.pairs, metric);
    if let Some(u) = Unconverged::of(&merged.names, &merged.pairs) {
        eprintln!("warning: {u}");
    }
    eprintln!(
        "merged {} shards ({} pairs) into {} ({n} x {n})",
        merged.count,
        merged.pairs.len(),
        args.output.display()
    );
    Ok(())
}

/// `--explain NAME_A,NAME_B`: the pair's per-pose, per-vertex split beside the details file.
fn explain_pair(details: &Path, pair: &str, prepared: &Prepared, opts: &PipelineOptions) -> Result<()> {
    let Some((a, b)) = pair.split_once(',') else {
        bail!("--explain {pair:?}: give two deformation names separated by a comma");
    };
    let e = qcshape_studies::explain::explain(prepared, opts, a.trim(), b.trim())?;
    let stem = qcshape_studies::explain::stem_beside(details, &e.a, &e.b);
    let base = &prepared.transferred[0][0];
    let files = e.write(&stem, base, prepared.topology.faces(), &opts.metric.label())?;
    eprintln!(
        "explained {} vs {} (similarity {:.6}): {}",
        e.a,
        e.b,
        e.contributions.distance,
        files
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}

/// Every file the run may write, with its option's name (the matrix, for `.npy` the names,
/// the journal, the shard file, --details), or an error for a conflicting --details.
fn output_files(args: &Args) -> Result<Vec<(PathBuf, &'static str)>> {
    let mut out = matrix_files(&args.output);
    out.push((journal_path(&args.output), "the journal of -o"));
    if let Some(shard) = args.shard {
        out.push((shard.file_for(&args.output), "the shard file of -o"));
        if args.details.is_some() {
            bail!("--details goes with similarity-merge, not with --shard (a shard holds only some pairs)");
        }
    }
    if let Some(details) = &args.details {
        if details == &args.output {
            bail!("--details {} is the same file as -o", details.display());
        }
        out.push((details.clone(), "--details"));
    }
    Ok(out)
}
