//! Similarity of deformations (eq. 13): pairwise distances of deformations transferred to one
//! common base, computed in parallel and resumable through a journal.

pub mod engine;
pub mod journal;
pub mod karcher;
pub mod pipeline;

pub use engine::{all_pairs, assemble, compute_pairs, pose_distances, PairDistance, Pose, SimilarityError};
pub use journal::{fingerprint, Journal};
pub use karcher::{karcher_mean, log_map, KarcherMean, KarcherOptions};
pub use pipeline::{prepare, settings_key, similarities, PipelineError, PipelineOptions, Prepared, Stage};
