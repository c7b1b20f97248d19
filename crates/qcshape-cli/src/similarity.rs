//! `qcshape similarity`: the similarity matrix of a data set of deformations (eq. 13).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::dataset::Dataset;
use qcshape::similarity::{PipelineOptions, Prepared};
use qcshape::transport::{Alignment, Transport};

use crate::args::{in_pool, MetricArgs, SolverArgs};
use crate::pipeline::{journal_path, journaled_matrix, pipeline_options, prepare_with_progress};

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
    /// Worker threads (default: all cores). The results are bit-identical for any count, so a run
    /// can be resumed with another one.
    #[arg(long)]
    threads: Option<usize>,
    /// Reuse the pairs recorded in OUTPUT.journal by an interrupted run with the same inputs and settings.
    #[arg(long)]
    resume: bool,
    /// Output CSV: header `name,<name_1>,...,<name_n>`, one row per deformation; a name ending
    /// in .npy writes a NumPy float64 (n, n) array instead, with the names in NAME.names.txt.
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// Also write the per-pose distances dis(M_i, N_i) of every pair to this CSV.
    #[arg(long)]
    details: Option<PathBuf>,
    /// With --details: split the similarity of the pair NAME_A,NAME_B per pose and vertex and
    /// write DETAILS_STEM.explain_A_vs_B.csv (vertex,total,pose_000,...), .vtk and .ply on the
    /// base mesh (those fields as point data) and .png (the total, six views). Normalized
    /// length units; `total` sums to the pair's similarity.
    #[arg(long, value_name = "NAME_A,NAME_B", requires = "details")]
    explain: Option<String>,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let t0 = Instant::now();
    let data = Dataset::load(&args.input)?;
    data.refuse_overwrite(&args.input, &args.output, "-o")?;
    data.refuse_overwrite(&args.input, &journal_path(&args.output), "the journal of -o")?;
    if let Some(details) = &args.details {
        data.refuse_overwrite(&args.input, details, "--details")?;
        if details == &args.output {
            bail!("--details {} is the same file as -o", details.display());
        }
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
    if args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"))
    {
        // A NumPy array (n, n) float64; the names, which .npy cannot hold, go to NAME.names.txt.
        let n = matrix.len();
        qcshape::io::npy::write_matrix(&args.output, matrix.values(), n, n)?;
        let names = args.output.with_extension("names.txt");
        let text: String = matrix.names().iter().map(|s| format!("{s}\n")).collect();
        qcshape::io::write_atomically(&names, |w: &mut dyn std::io::Write| w.write_all(text.as_bytes()))?;
    } else {
        matrix.write_csv(&args.output)?;
    }
    if let Some(path) = &args.details {
        write_details(path, &prepared, &pairs)?;
        if let Some(pair) = &args.explain {
            explain_pair(path, pair, &prepared, &opts)?;
        }
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

/// `--explain NAME_A,NAME_B`: the pair's per-pose, per-vertex split beside the details file.
fn explain_pair(details: &Path, pair: &str, prepared: &Prepared, opts: &PipelineOptions) -> Result<()> {
    let Some((a, b)) = pair.split_once(',') else {
        bail!("--explain {pair:?}: give two deformation names separated by a comma");
    };
    let e = qcshape::explain::explain(prepared, opts, a.trim(), b.trim())?;
    let stem = qcshape::explain::stem_beside(details, &e.a, &e.b);
    let base = &prepared.transferred[0][0];
    let files = e.write(
        &stem,
        base,
        prepared.topology.faces(),
        &opts.metric.build().name(),
    )?;
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

fn write_details(
    path: &Path,
    prepared: &Prepared,
    pairs: &[qcshape::similarity::PairDistance],
) -> Result<()> {
    let text = qcshape::similarity::details_csv(&prepared.names, pairs);
    qcshape::io::write_atomically(path, |w| w.write_all(text.as_bytes()))
        .with_context(|| format!("cannot write {}", path.display()))
}
