//! One similarity run (eq. 13): the one place a similarity matrix is computed and assembled.
//!
//! Every caller (the `similarity`, `run`, `classify` and `reproduce` commands, the experiments,
//! the LV study, [`crate::space::ShapeSpace`], Python and Dask) describes a run the same way:
//! the deformations to compare ([`Comparison`], e.g. [`Prepared::comparison`]), the pipeline
//! options, which pairs ([`Selection`]: all, one shard, a list), where finished pairs are
//! recorded ([`Sink`]: memory, or a journal file a later run resumes from), a cancel flag and one
//! event callback ([`Event`]). [`compute`] builds the geodesic solver once with the metric the
//! caller built once ([`Comparison::metric`]) and
//! returns an [`Outcome`]; [`similarity_matrix`] is [`prepare`] followed by [`compute`].

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use crate::dataset::Deformation;
use crate::geodesic::GeodesicSolver;
use crate::mesh::Topology;
use crate::metric::Metric;

use super::engine::compute_listed_pairs;
use super::error::SimilarityError;
use super::journal::{fingerprint, Journal};
use super::matrix::{matrix_of, DistanceMatrix};
use super::pipeline::{prepare, settings_key, PipelineError, PipelineOptions, Prepared};
use super::shard::Shard;
use super::types::{all_pairs, Event, PairDistance, Pose};

/// Which pairs `(i, j)`, `i < j`, of the n deformations a run computes.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Selection {
    /// Every pair: the run returns the n x n matrix.
    #[default]
    All,
    /// The pairs of one shard of a sharded run (`qcshape similarity --shard K/S`), merged later
    /// by [`super::merge_shards`].
    Shard(Shard),
    /// The listed pairs, in the order given (the batches of a distributed run, `qcshape.dask`).
    Listed(Vec<(usize, usize)>),
}

/// Where a run records its pairs as they finish.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Sink {
    /// Nowhere but the returned [`Outcome`].
    #[default]
    Memory,
    /// Appended to a journal file (for [`Selection::Shard`], the shard file that
    /// `similarity-merge` reads). With `resume`, the pairs of an earlier run with the same inputs
    /// and settings are read back from it instead of computed; without, an earlier journal is
    /// started over. [`Outcome::finish`] removes a matrix journal once the outputs are written;
    /// a shard file is the output and stays.
    Journal {
        /// The journal file (`OUTPUT.journal` for the CLI, [`journal_path`]).
        path: PathBuf,
        /// Keep the pairs an earlier run recorded there.
        resume: bool,
    },
}

/// How to run: which pairs, where they go, cancellation and progress.
pub struct Run<'a> {
    /// The pairs to compute.
    pub selection: Selection,
    /// Where finished pairs are recorded.
    pub sink: Sink,
    /// When set, stops the run between poses with [`SimilarityError::Cancelled`] (recorded
    /// pairs stay in the journal).
    pub cancel: Option<&'a AtomicBool>,
    /// Sees every [`Event`].
    pub events: &'a (dyn Fn(Event<'_>) + Sync),
}

fn no_events(_: Event<'_>) {}

impl Default for Run<'_> {
    /// All pairs, in memory, no cancel flag, no events.
    fn default() -> Self {
        Run {
            selection: Selection::All,
            sink: Sink::Memory,
            cancel: None,
            events: &no_events,
        }
    }
}

/// Deformations ready for comparison: one pose count, every deformation starting at one
/// common base, on one connectivity.
#[derive(Debug, Clone)]
pub struct Comparison<'a> {
    /// Names (n), in order.
    pub names: &'a [String],
    /// The shared connectivity.
    pub topology: Arc<Topology>,
    /// The run's metric, built once by the caller from the options' metric and its factors
    /// calibrated at the base in the solver's coordinates
    /// ([`crate::metric::MetricSpec::calibrate`]); [`compute`] uses it as given.
    pub metric: &'a dyn Metric,
    /// The factor every coordinate is multiplied by before solving (1 / mean edge of the base;
    /// 1 for poses already in the solver's coordinates).
    pub factor: f64,
    /// The deformations: n x #poses x #V x 3 positions, in input units.
    pub poses: &'a [Vec<Pose>],
}

impl Prepared {
    /// The transferred deformations as a [`Comparison`] for [`compute`].
    pub fn comparison(&self) -> Comparison<'_> {
        Comparison {
            names: &self.names,
            topology: self.topology.clone(),
            metric: self.run_metric.as_ref(),
            factor: self.factor,
            poses: &self.transferred,
        }
    }
}

/// What a run computed.
#[derive(Debug)]
pub struct Outcome {
    /// Every pair of the selection (those read back from a journal included), in row order
    /// (for [`Selection::Listed`], in the order listed).
    pub pairs: Vec<PairDistance>,
    /// The n x n matrix (eq. 13; zero diagonal, symmetric) when every pair was selected.
    pub matrix: Option<DistanceMatrix>,
    /// Pairs read back from an earlier run's journal instead of computed.
    pub recorded: usize,
    journal: Option<Journal>,
    keep_journal: bool,
}

impl Outcome {
    /// The journal file of the run, if it had one.
    pub fn journal_path(&self) -> Option<&Path> {
        self.journal.as_ref().map(Journal::path)
    }

    /// Ends the run once its outputs are written: removes the journal of a matrix run (a
    /// shard file is the run's output and stays). The pairs and the matrix stay in the
    /// outcome.
    pub fn finish(&mut self) -> Result<(), SimilarityError> {
        match self.journal.take() {
            Some(j) if !self.keep_journal => j.remove(),
            _ => Ok(()),
        }
    }
}

/// `OUTPUT.journal`, the journal of a matrix written to `output`.
pub fn journal_path(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".journal");
    PathBuf::from(s)
}

/// The similarity (eq. 13) of the selected pairs of `input`, with the metric of `input` and the
/// solver and approximation of `opts`: the solver's symbolic factorization is built once,
/// pairs run in parallel on the current rayon pool, each is recorded in the sink as it
/// finishes. The distances do not depend on the sink, the selection, the thread count or a
/// resume: the same pair gives the same bits.
pub fn compute(
    input: &Comparison<'_>,
    opts: &PipelineOptions,
    run: &Run<'_>,
) -> Result<Outcome, PipelineError> {
    let n = input.names.len();
    if input.poses.len() != n {
        return Err(SimilarityError::NameCount {
            names: n,
            deformations: input.poses.len(),
        }
        .into());
    }
    let todo: Vec<(usize, usize)> = match &run.selection {
        Selection::All => all_pairs(n),
        Selection::Shard(s) => s.pairs(n),
        Selection::Listed(list) => list.clone(),
    };
    // The journal, and the pairs an earlier run recorded in it.
    let (journal, recorded) = match &run.sink {
        Sink::Memory => (None, Vec::new()),
        Sink::Journal { path, resume } => {
            let settings = settings_key(opts);
            let key = fingerprint(input.names, input.poses, &settings);
            let existed = path.exists();
            // Records of another pose count than this run's are dropped and recomputed.
            let poses = input.poses.first().map(Vec::len);
            let (journal, recorded) = match &run.selection {
                Selection::All => Journal::open(path, key, &settings, n, poses, *resume)?,
                Selection::Shard(s) => {
                    Journal::open_shard(path, key, &settings, input.names, poses, *s, *resume)?
                }
                Selection::Listed(_) => return Err(SimilarityError::ListedNotJournaled.into()),
            };
            (run.events)(Event::Journal {
                path,
                recorded: recorded.len(),
                dropped: journal.dropped_records(),
                total: todo.len(),
                discarded: existed && !*resume,
            });
            (Some(journal), recorded)
        }
    };
    let done: HashSet<(usize, usize)> = recorded.iter().map(|p| (p.i, p.j)).collect();
    let todo: Vec<(usize, usize)> = todo.into_iter().filter(|p| !done.contains(p)).collect();

    let f = input.factor;
    let scaled: Vec<Vec<Pose>> = input
        .poses
        .iter()
        .map(|d| d.iter().map(|p| crate::mesh::geometry::scaled(p, f)).collect())
        .collect();
    let solver = GeodesicSolver::new(input.metric, input.topology.clone(), opts.geodesic.clone())?;
    let fresh = compute_listed_pairs(
        &solver,
        opts.approx,
        input.names,
        &scaled,
        &todo,
        run.cancel,
        |p| {
            if let Some(j) = &journal {
                j.record(p)?;
            }
            (run.events)(Event::Pair(p));
            Ok(())
        },
    )?;

    let n_recorded = recorded.len();
    let mut pairs = recorded;
    pairs.extend(fresh);
    if !matches!(run.selection, Selection::Listed(_)) {
        pairs.sort_by_key(|p| (p.i, p.j));
    }
    let matrix = match run.selection {
        Selection::All => Some(matrix_of(input.names, &pairs)?),
        _ => None,
    };
    Ok(Outcome {
        pairs,
        matrix,
        recorded: n_recorded,
        journal,
        keep_journal: matches!(run.selection, Selection::Shard(_)),
    })
}

/// The whole pipeline of the paper (Fig. 1, eq. 13) on raw deformations: [`prepare`]
/// (smoothing, alignment, interpolation, transfer to the first pose of deformation
/// `opts.base`; [`Event::Prepared`] per deformation and stage) then [`compute`].
pub fn similarity_matrix(
    defs: &[Deformation],
    opts: &PipelineOptions,
    run: &Run<'_>,
) -> Result<(Prepared, Outcome), PipelineError> {
    let prepared = prepare(defs, opts, run.events)?;
    let outcome = compute(&prepared.comparison(), opts, run)?;
    Ok((prepared, outcome))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::icosphere;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Five deformations of an icosphere (three poses each, every one starting at the base).
    fn data() -> (Arc<Topology>, Vec<String>, Vec<Vec<Pose>>) {
        let s = icosphere(1);
        let defs = [0.1, 0.12, 0.4, 0.25, 0.3]
            .iter()
            .enumerate()
            .map(|(d, &amp)| {
                (0..3)
                    .map(|k| {
                        let t = amp * k as f64 / 2.0;
                        s.positions
                            .iter()
                            .map(|p| {
                                [
                                    p[0] * (1.0 + t),
                                    p[1] * (1.0 + 0.1 * t * d as f64),
                                    p[2] * (1.0 - 0.5 * t),
                                ]
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let names = (0..5).map(|i| format!("d{i}")).collect();
        (s.topology.clone(), names, defs)
    }

    fn options() -> PipelineOptions {
        let mut o = PipelineOptions::default();
        o.geodesic.steps = 3;
        o
    }

    fn run_with(sel: Selection, sink: Sink, cancel_after: Option<usize>) -> Result<Outcome, PipelineError> {
        let (topo, names, defs) = data();
        let factor = 1.0 / crate::mesh::geometry::mean_edge_length(&topo, &defs[0][0]);
        let base: Pose = defs[0][0].iter().map(|p| p.map(|c| c * factor)).collect();
        let opts = options();
        let calibration = opts.metric.calibrate(&topo, &[&base]).unwrap();
        let metric = opts.metric.build(&calibration);
        let input = Comparison {
            names: &names,
            topology: topo,
            metric: metric.as_ref(),
            factor,
            poses: &defs,
        };
        let cancel = AtomicBool::new(false);
        let seen = AtomicUsize::new(0);
        let events = |e: Event<'_>| {
            if let Event::Pair(_) = e {
                let k = seen.fetch_add(1, Ordering::SeqCst) + 1;
                if cancel_after.is_some_and(|c| k >= c) {
                    cancel.store(true, Ordering::SeqCst);
                }
            }
        };
        let run = Run {
            selection: sel,
            sink,
            cancel: Some(&cancel),
            events: &events,
        };
        compute(&input, &opts, &run)
    }

    fn bits(pairs: &[PairDistance]) -> Vec<(usize, usize, u64)> {
        pairs.iter().map(|p| (p.i, p.j, p.distance.to_bits())).collect()
    }

    #[test]
    fn sinks_selections_and_resume_give_the_same_bits() {
        let memory = run_with(Selection::All, Sink::Memory, None).unwrap();
        assert_eq!(memory.pairs.len(), 10);
        let m = memory.matrix.as_ref().unwrap();
        assert_eq!(m.len(), 5);
        assert!(m.values().iter().all(|v| v.is_finite()));
        assert!(memory.journal_path().is_none());

        // Journaled, killed (cancelled) after 3 pairs, resumed: the same matrix, bit for bit.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("D.csv.journal");
        let sink = |resume| Sink::Journal {
            path: path.clone(),
            resume,
        };
        let e = run_with(Selection::All, sink(false), Some(3)).unwrap_err();
        assert!(
            matches!(e, PipelineError::Similarity(SimilarityError::Cancelled)),
            "{e}"
        );
        let mut resumed = run_with(Selection::All, sink(true), None).unwrap();
        assert!(resumed.recorded >= 3, "{} pairs read back", resumed.recorded);
        assert_eq!(bits(&resumed.pairs), bits(&memory.pairs));
        assert_eq!(resumed.matrix.as_ref().unwrap().values(), m.values());
        assert_eq!(resumed.journal_path(), Some(path.as_path()));
        resumed.finish().unwrap();
        assert!(!path.exists(), "the journal of a matrix run is removed by finish");

        // Three shards cover the pairs once; their files stay after finish.
        let mut union = Vec::new();
        for k in 1..=3 {
            let shard = Shard::new(k, 3).unwrap();
            let file = shard.file_for(&dir.path().join("D.csv"));
            let mut o = run_with(
                Selection::Shard(shard),
                Sink::Journal {
                    path: file.clone(),
                    resume: false,
                },
                None,
            )
            .unwrap();
            assert!(o.matrix.is_none());
            union.extend(o.pairs.clone());
            o.finish().unwrap();
            assert!(file.exists());
        }
        union.sort_by_key(|p| (p.i, p.j));
        assert_eq!(bits(&union), bits(&memory.pairs));

        // A listed selection keeps its order; it is not journaled.
        let listed = run_with(Selection::Listed(vec![(2, 4), (0, 1)]), Sink::Memory, None).unwrap();
        let ij: Vec<(usize, usize)> = listed.pairs.iter().map(|p| (p.i, p.j)).collect();
        assert_eq!(ij, vec![(2, 4), (0, 1)]);
        assert_eq!(listed.pairs[0].distance.to_bits(), m.get(2, 4).to_bits());
        assert!(run_with(Selection::Listed(vec![(0, 1)]), sink(false), None).is_err());
        assert!(run_with(Selection::Listed(vec![(1, 0)]), Sink::Memory, None).is_err());
    }
}
