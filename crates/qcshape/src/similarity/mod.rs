//! Similarity of deformations (eq. 13): pairwise distances of deformations transferred to one
//! common base, computed in parallel and resumable through a journal, and the distance matrix
//! they fill.
//!
//! The files are floors, each importing only files of the floors below it (checked by
//! `crates/qcshape/tests/layers.rs`, printed by `scripts/layers`), from the ground up:
//!
//! 1. shared types: [`defaults`], [`types`] (`PairDistance`, `Approx`, `Event`);
//! 2. values: [`shard`] (which pairs a shard computes), [`matrix`] (the distance matrix),
//!    [`shares`], [`details`];
//! 3. errors: [`error`] (`SimilarityError`, `JournalProblem`);
//! 4. the compute kernel: [`tangent`], then [`engine`] (pairs in parallel; no storage, no
//!    orchestration);
//! 5. storage: [`journal`];
//! 6. [`merge`] (shard files into one matrix) and [`pipeline`] (smoothing, alignment,
//!    interpolation, transfer);
//! 7. the runner: [`run`] (one run: the metric and solver built once, the journal, the pairs,
//!    the matrix).

pub mod defaults;
pub mod details;
pub mod engine;
pub mod error;
pub mod journal;
pub mod matrix;
pub mod merge;
pub mod pipeline;
pub mod run;
pub mod shard;
pub mod shares;
pub mod tangent;
pub mod types;

pub use crate::mesh::smooth::Smoothing;
pub use details::{details_csv, Unconverged};
pub use engine::pose_distances;
pub use error::{JournalProblem, SimilarityError};
pub use journal::{fingerprint, Journal, JournalFile};
pub use matrix::*;
pub use merge::{merge as merge_shards, Merged};
pub use pipeline::{prepare, settings_key, PipelineError, PipelineOptions, Prepared};
pub use run::{compute, journal_path, similarity_matrix, Comparison, Outcome, Run, Selection, Sink};
pub use shard::Shard;
pub use shares::ShareSummary;
pub use types::{all_pairs, Approx, DroppedRecord, Event, PairDistance, Pose, RecordProblem, Stage};
