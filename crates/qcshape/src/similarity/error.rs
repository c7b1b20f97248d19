//! The errors of the similarity path ([`SimilarityError`], and [`JournalProblem`], why a
//! journal or a shard file is refused): shared by the compute kernel, the journal, the shard
//! merge and the runner, so none of them imports another for its error type.

use std::path::PathBuf;

use crate::geodesic::GeodesicError;

use super::shard::Shard;

/// The first line of a journal of this version (3).
pub(crate) const HEADER: &str = "# qcshape similarity journal v3";

/// The header of version 2 (pair lines without the energy split), still read.
pub(crate) const HEADER_V2: &str = "# qcshape similarity journal v2";

/// Why a similarity computation failed.
#[derive(Debug, thiserror::Error)]
pub enum SimilarityError {
    /// A pair to compute is not `(i, j)` with `i < j < n`.
    #[error("pair ({i}, {j}) is not a pair i < j of the {n} deformations")]
    NotAPair {
        /// First index.
        i: usize,
        /// Second index.
        j: usize,
        /// Number of deformations.
        n: usize,
    },
    /// The names and the deformations differ in number.
    #[error("{names} names for {deformations} deformations")]
    NameCount {
        /// Number of names.
        names: usize,
        /// Number of deformations.
        deformations: usize,
    },
    /// Two deformations have different pose counts, so they cannot be compared pose by pose.
    #[error("deformation '{name}' has {poses} poses, '{first}' has {first_poses}: interpolate them to one count first")]
    PoseCount {
        /// The deformation.
        name: String,
        /// Its pose count.
        poses: usize,
        /// The first deformation.
        first: String,
        /// Its pose count.
        first_poses: usize,
    },
    /// A listed selection of pairs was asked to write a journal (only shards are journaled).
    #[error("a listed selection of pairs is not journaled (use a shard)")]
    ListedNotJournaled,
    /// No shard file to merge.
    #[error("no shard files given")]
    NoShards,
    /// Shards of the run are missing from the merge.
    #[error("shard(s) {} of the run of {} missing", shard_list(.missing, *.count), .run.display())]
    MissingShards {
        /// The missing shards' numbers (1-based).
        missing: Vec<usize>,
        /// The run's shard count.
        count: usize,
        /// The first shard file given.
        run: std::path::PathBuf,
    },
    /// The tangent approximation was asked of a metric whose squared norm at the base is not a
    /// quadratic form with fixed weights.
    #[error(
        "the tangent approximation needs a metric whose squared norm at the base is a quadratic form of \
         the displacement with fixed weights (l2, rigid, isometric, conformal, or quasi-conformal with \
         the quadratic form and endpoint weights); {metric} is not (use --approx straight)"
    )]
    NotTangent {
        /// The metric's name.
        metric: String,
    },
    /// The metric's auxiliary Jacobian has a length that is not a multiple of its auxiliary
    /// unknowns.
    #[error("the auxiliary Jacobian has {values} values, not a multiple of {n_aux}")]
    AuxJacobian {
        /// Its length.
        values: usize,
        /// The number of auxiliary unknowns.
        n_aux: usize,
    },
    /// The auxiliary Jacobian is not finite at the base (a degenerate base pose).
    #[error(
        "the metric's Jacobian with respect to its auxiliary unknowns (the rigid motion) is not \
         finite at the base: the base pose is degenerate"
    )]
    AuxNotFinite,
    /// The eigen-decomposition of the auxiliary unknowns' normal matrix did not converge.
    #[error("the eigen-decomposition of the auxiliary unknowns' normal matrix failed (NoConvergence)")]
    AuxEigen,
    /// A geodesic between two corresponding poses failed.
    #[error("deformations '{a}' and '{b}', pose {pose}: {error}")]
    Geodesic {
        /// First deformation.
        a: String,
        /// Second deformation.
        b: String,
        /// The pose index.
        pose: usize,
        /// The solver's error (boxed: a geodesic error holds a setting's names).
        error: Box<GeodesicError>,
    },
    /// The journal of a resumable run cannot be read or written.
    #[error("{}: {problem}", path.display())]
    Journal {
        /// The journal file.
        path: std::path::PathBuf,
        /// What went wrong.
        problem: JournalProblem,
    },
    /// The run was cancelled (finished pairs are in the journal).
    #[error("cancelled")]
    Cancelled,
}

/// `k/count` for each missing shard `k`, comma-separated.
fn shard_list(missing: &[usize], count: usize) -> String {
    let list: Vec<String> = missing.iter().map(|k| format!("{k}/{count}")).collect();
    list.join(", ")
}

/// Why a journal (or a shard journal to merge) cannot be written, read, resumed or merged
/// ([`SimilarityError::Journal`]).
#[derive(Debug, thiserror::Error)]
pub enum JournalProblem {
    /// The settings string holds a line break (it is one line of the header).
    #[error("the settings string has a line break")]
    SettingsLineBreak,
    /// The file exists and is not a journal: it is not replaced.
    #[error("exists and is not a qcshape similarity journal; refusing to replace it (remove it or choose another file)")]
    NotReplaceable,
    /// The deformation names cannot be encoded as JSON.
    #[error("cannot encode the names: {0}")]
    EncodeNames(serde_json::Error),
    /// The temporary file cannot be written.
    #[error("cannot write {}: {error}", tmp.display())]
    WriteTemporary {
        /// The temporary file.
        tmp: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// The temporary file cannot be renamed over the journal.
    #[error("cannot write: {0}")]
    Write(std::io::Error),
    /// A record cannot be appended.
    #[error("cannot append: {0}")]
    Append(std::io::Error),
    /// The journal cannot be removed.
    #[error("cannot remove: {0}")]
    Remove(std::io::Error),
    /// The journal cannot be read.
    #[error("cannot read: {0}")]
    Read(std::io::Error),
    /// The first line is not a journal header of this version.
    #[error("not a qcshape similarity journal of this version (expected the first line {HEADER:?} or {HEADER_V2:?})")]
    NotAJournal,
    /// A header line (2 to 4) that does not hold what it must.
    #[error("line {line}: expected `{expected}`, found {found:?}")]
    HeaderLine {
        /// Line number.
        line: usize,
        /// Its expected form.
        expected: &'static str,
        /// The line.
        found: String,
    },
    /// A `shard,` line whose value is not `K/S`.
    #[error("line {line}: {found:?}: expected K/S, two whole numbers with 1 <= K <= S (e.g. 2/8)")]
    ShardLine {
        /// Line number.
        line: usize,
        /// The value.
        found: String,
    },
    /// A `names,` line that is not a JSON list of strings.
    #[error("line {line}: the names do not parse: {error}")]
    NamesLine {
        /// Line number.
        line: usize,
        /// The JSON error.
        error: serde_json::Error,
    },
    /// A `names,` line with another count than `n`.
    #[error("line {line}: {names} names for n = {n}")]
    NameCount {
        /// Line number.
        line: usize,
        /// Names listed.
        names: usize,
        /// The header's count.
        n: usize,
    },
    /// A journal that cannot be read, found when resuming.
    #[error("{0}; remove it or run without --resume")]
    NotResumable(Box<JournalProblem>),
    /// A journal of a run with another number of deformations.
    #[error("the journal belongs to another run (n = {journal}, this run has {run} deformations); remove it or run without --resume")]
    OtherCount {
        /// The journal's count.
        journal: usize,
        /// This run's.
        run: usize,
    },
    /// A journal of a run with the same settings but other inputs.
    #[error("the journal belongs to another run (the same settings but different inputs (names or coordinates of the transferred deformations)); remove it or run without --resume")]
    OtherInputs,
    /// A journal of a run with other settings: `(name, in the journal, now)`.
    #[error("the journal belongs to another run (different settings: {}); remove it or run without --resume", journal_now(.0))]
    OtherSettings(Vec<(String, String, String)>),
    /// A journal of another shard (or of the whole matrix).
    #[error("the journal is of {}, this run computes {}; remove it or run without --resume", shard_name(.journal), shard_name(.run))]
    OtherShard {
        /// The journal's shard (`None`: the whole matrix).
        journal: Option<Shard>,
        /// This run's.
        run: Option<Shard>,
    },
    /// A journal of a whole run given to merge.
    #[error("a journal of a whole run, not of a shard (--shard K/S)")]
    WholeRun,
    /// A shard journal without the deformation names.
    #[error("the shard journal does not record the deformation names")]
    NoNames,
    /// A shard of a run with other settings than the first file's: `(name, there, here)`.
    #[error("belongs to another run than {}: other settings: {}", first.display(), here_not_there(differing))]
    ShardSettings {
        /// The first file.
        first: PathBuf,
        /// The differing settings.
        differing: Vec<(String, String, String)>,
    },
    /// A shard of a run with other data than the first file's.
    #[error("belongs to another run than {}: other data (names or coordinates of the deformations)", first.display())]
    ShardData {
        /// The first file.
        first: PathBuf,
    },
    /// A shard of a run cut into another number of shards than the first file's.
    #[error("belongs to another run than {}: {count} shards, {} has {first_count}", first.display(), first.display())]
    ShardCount {
        /// The first file.
        first: PathBuf,
        /// This file's shard count.
        count: usize,
        /// The first file's.
        first_count: usize,
    },
    /// A shard with torn or corrupt records.
    #[error("{0} torn or corrupt record(s); rerun this shard with --resume to recompute them")]
    Torn(usize),
    /// A header count too large for a shard.
    #[error("n = {0} deformations is more than a shard can hold")]
    TooLarge(usize),
    /// A shard without all of its pairs.
    #[error("shard {shard} is incomplete: {have} of its {want} pairs (still running or interrupted: rerun it with --resume)")]
    Incomplete {
        /// The shard.
        shard: Shard,
        /// Pairs held.
        have: usize,
        /// Pairs of its share.
        want: usize,
    },
    /// A pair that belongs to another shard.
    #[error("holds pair ({i}, {j}), which is not in shard {shard}")]
    ForeignPair {
        /// First deformation.
        i: usize,
        /// Second deformation.
        j: usize,
        /// The file's shard.
        shard: Shard,
    },
    /// A shard given twice.
    #[error("shard {shard} is also given as {}", other.display())]
    DuplicateShard {
        /// The shard.
        shard: Shard,
        /// The other file.
        other: PathBuf,
    },
}

fn journal_now(differing: &[(String, String, String)]) -> String {
    let named: Vec<String> = differing
        .iter()
        .map(|(name, x, y)| format!("{name}: journal {x}, now {y}"))
        .collect();
    named.join(", ")
}

fn here_not_there(differing: &[(String, String, String)]) -> String {
    let named: Vec<String> = differing
        .iter()
        .map(|(name, x, y)| format!("{name} {y} (not {x})"))
        .collect();
    named.join("; ")
}

fn shard_name(s: &Option<Shard>) -> String {
    s.map_or("the whole matrix".to_string(), |s| format!("shard {s}"))
}
