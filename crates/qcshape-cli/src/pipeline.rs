//! The similarity pipeline as the commands run it: options from the command line,
//! interpolation and transfer with progress bars, and the resumable (journaled) similarity
//! matrix.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use qcshape::dataset::Dataset;
use qcshape::similarity::{
    assemble, fingerprint, prepare, settings_key, similarities, Approx, DistanceMatrix, Journal,
    PairDistance, PipelineOptions, Prepared, Shard, ShareSummary, Stage,
};
use qcshape::transport::{Alignment, Transport};

use crate::args::{MetricArgs, SolverArgs};
use crate::progress::bar;

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
        smoothing: PipelineOptions::default().smoothing,
        approx: Approx::Exact,
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
    let settings = settings_key(opts);
    let key = fingerprint(&prepared.names, &prepared.transferred, &settings);
    let journal_path = journal_path(output);
    if journal_path.exists() && !resume {
        eprintln!(
            "note: {} exists from an earlier run; starting over (use --resume to keep its pairs)",
            journal_path.display()
        );
    }
    let (journal, done_pairs) = Journal::open(&journal_path, key, &settings, n, resume)?;
    if journal.dropped() > 0 {
        eprintln!(
            "warning: {}: {} torn or corrupt record(s) dropped (failed their checksum); those pairs are recomputed",
            journal_path.display(),
            journal.dropped()
        );
    }
    if resume {
        eprintln!(
            "resuming: {} of {} pairs already done",
            done_pairs.len(),
            n * (n - 1) / 2
        );
    }
    let done: HashSet<(usize, usize)> = done_pairs.iter().map(|p| (p.i, p.j)).collect();
    let pairs = journaled_pairs(prepared, opts, &journal, done_pairs, done, n * (n - 1) / 2)?;
    let matrix = DistanceMatrix::new(prepared.names.clone(), assemble(n, &pairs))?;
    Ok((matrix, pairs, journal))
}

/// The pairs of shard `shard` of the similarity matrix, recorded in the shard journal `file` as
/// they finish (with `resume`, the pairs already in it are kept). Returns the shard's pairs.
pub(crate) fn sharded_pairs(
    prepared: &Prepared,
    opts: &PipelineOptions,
    shard: Shard,
    file: &Path,
    resume: bool,
) -> Result<Vec<PairDistance>> {
    let n = prepared.names.len();
    let settings = settings_key(opts);
    let key = fingerprint(&prepared.names, &prepared.transferred, &settings);
    let (journal, done_pairs) = Journal::open_shard(file, key, &settings, &prepared.names, shard, resume)?;
    let total = shard.pairs(n).len();
    if resume {
        eprintln!(
            "resuming shard {shard}: {} of its {total} pairs already done",
            done_pairs.len()
        );
    }
    let mut skip = shard.others(n);
    skip.extend(done_pairs.iter().map(|p| (p.i, p.j)));
    journaled_pairs(prepared, opts, &journal, done_pairs, skip, total)
}

/// The pairs not in `skip` computed with a progress bar over `total` pairs, each recorded in
/// `journal` as it finishes, joined with the `done` pairs of an earlier run, in row order.
fn journaled_pairs(
    prepared: &Prepared,
    opts: &PipelineOptions,
    journal: &Journal,
    done: Vec<PairDistance>,
    skip: HashSet<(usize, usize)>,
    total: usize,
) -> Result<Vec<PairDistance>> {
    let pb = bar(total, "pairs");
    pb.set_position(done.len() as u64);
    let new_pairs = similarities(prepared, opts, &skip, None, |p| {
        journal.record(p)?;
        pb.inc(1);
        Ok(())
    })?;
    pb.finish_and_clear();
    let mut pairs = done;
    pairs.extend(new_pairs);
    pairs.sort_by_key(|p| (p.i, p.j));
    Ok(pairs)
}

/// The L2 regularizer's share of the energy over `pairs` ([`ShareSummary`]), printed: one
/// stderr line with its distribution and, when the regularizer carries more than half of the
/// energy for more than half of the pairs, a warning naming the metric `metric`.
pub(crate) fn report_shares(pairs: &[PairDistance], metric: &str) -> ShareSummary {
    let s = ShareSummary::of(pairs);
    eprintln!("{}", s.line());
    if let Some(w) = s.warning(metric) {
        eprintln!("warning: {w}");
    }
    s
}

/// `OUTPUT.journal` beside the output.
pub(crate) fn journal_path(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".journal");
    PathBuf::from(s)
}
