//! Similarity of deformations (eq. 13): pairwise distances of deformations transferred to one
//! common base, computed in parallel and resumable through a journal, and the distance matrix
//! they fill.

pub mod defaults;
pub mod engine;
pub mod journal;
pub mod matrix;
pub mod pipeline;
pub mod run;
pub mod shard;
pub mod shares;
pub mod tangent;

pub use crate::mesh::smooth::Smoothing;
pub use engine::{all_pairs, details_csv, pose_distances, Approx, PairDistance, Pose, SimilarityError};
pub use journal::{fingerprint, Journal, JournalFile, JournalProblem};
pub use matrix::*;
pub use pipeline::{prepare, settings_key, PipelineError, PipelineOptions, Prepared, Stage};
pub use run::{compute, journal_path, similarity_matrix, Comparison, Event, Outcome, Run, Selection, Sink};
pub use shard::{merge as merge_shards, Merged, Shard};
pub use shares::ShareSummary;
