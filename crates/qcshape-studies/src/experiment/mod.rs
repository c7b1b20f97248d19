//! The paper's experiments on synthetic and real deformations (section 3), each a library call
//! with a report (CSV, Markdown, figures).
//!
//! - [`classification`]: similarity matrix, kernel k-means, k-means with intrinsic means
//!   (eq. 14) and the scores of eq. 15 (Table 1's classification step);
//! - [`noise`]: noise resistance of the classification (Table 3, eq. 17);
//! - [`interpolation`]: interpolation accuracy (Fig. 4);
//! - [`transfer`]: deformation transfer (Fig. 5);
//! - [`robustness`]: classification under realistic perturbations against baselines;
//! - [`approx`]: the cost and the error of approximate similarity matrices;
//! - [`reproduce`]: all synthetic tables and figures in one report;
//! - [`analysis`]: the whole analysis of one data set (`qcshape run`);
//! - [`provenance`]: the command line, version and machine of a report.

pub mod analysis;
pub mod approx;
pub mod classification;
pub mod geometry;
pub mod interpolation;
pub mod noise;
pub mod provenance;
pub mod reproduce;
pub mod robustness;
pub mod transfer;

use std::path::PathBuf;

use thiserror::Error;

use crate::plot::PlotError;
use qcshape::geodesic::InterpolationError;
use qcshape::io::IoError;
use qcshape::transport::TransportError;

/// Bad settings or input of the interpolation or transfer experiment ([`ExperimentError::Input`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ExperimentInput {
    /// A list of the settings is empty (metrics, transports, deformation kinds, bases).
    #[error("no {0}")]
    Empty(&'static str),
    /// An item is listed twice (a transport, deformation kind or base).
    #[error("a {0} is listed twice")]
    Duplicate(&'static str),
    /// An even number of poses to insert.
    #[error("insert must be odd so that a middle pose exists (got {0})")]
    EvenInsert(usize),
    /// Zero levels.
    #[error("levels must be at least 1")]
    ZeroLevels,
    /// A metric with the baseline's name.
    #[error("a metric is named like the baseline {0:?}")]
    BaselineName(&'static str),
    /// No deformation with an odd number (3 or more) of poses.
    #[error("no deformation has an odd number (3 or more) of poses")]
    NoOddDeformation,
    /// The showcase deformation is not among the usable ones.
    #[error("showcase deformation {0:?} is not among the usable ones")]
    UnknownShowcase(String),
    /// A sequence too short for leave-one-out.
    #[error("sequence {name:?} has {poses} pose(s); leave-one-out needs at least 3")]
    ShortSequence {
        /// The sequence.
        name: String,
        /// Its poses.
        poses: usize,
    },
    /// A frame to predict that is not interior.
    #[error("frame {frame} is not an interior frame of {name:?} (1 to {last})")]
    NotInterior {
        /// The frame.
        frame: usize,
        /// The sequence.
        name: String,
        /// The last interior frame.
        last: usize,
    },
    /// No frames to predict.
    #[error("no frames to predict")]
    NoFrames,
    /// A subdivision level above the largest.
    #[error("level {level} is above the largest, {max}")]
    Level {
        /// The level asked for.
        level: u32,
        /// The largest.
        max: u32,
    },
    /// A base on another topology than the source's.
    #[error("base {name:?} does not have the source's topology: {error}")]
    BaseTopology {
        /// The base.
        name: String,
        /// How it differs.
        error: qcshape::mesh::MeshError,
    },
    /// The source's mean edge length is zero or not finite.
    #[error("the source's mean edge length is {0}")]
    MeanEdge(f64),
    /// A pose count out of range.
    #[error("poses must be between 2 and {max}, got {poses}")]
    Poses {
        /// The count asked for.
        poses: usize,
        /// The largest.
        max: usize,
    },
}

/// Why the interpolation or the transfer experiment cannot run or its report cannot be written
/// (the other experiments have their own errors: [`classification::ClassificationError`],
/// [`noise::NoiseError`], ...).
#[derive(Debug, Error)]
pub enum ExperimentError {
    /// Bad settings or input (empty lists, too few poses, a level out of range, shapes of
    /// different topologies).
    #[error("invalid experiment: {0}")]
    Input(ExperimentInput),
    /// One interpolation failed.
    #[error("deformation {deformation:?}, pose {pose}, metric {method}: {source}")]
    Interpolation {
        /// The deformation.
        deformation: String,
        /// The pose that was being predicted.
        pose: usize,
        /// The metric.
        method: String,
        /// What failed.
        source: InterpolationError,
    },
    /// A transfer failed.
    #[error("{what}: {error}")]
    Transfer {
        /// Which transfer (kind, base, metric, transport).
        what: String,
        /// The error.
        error: TransportError,
    },
    /// The output folder cannot be created.
    #[error("{}: cannot create the folder: {error}", path.display())]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// A file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A figure cannot be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// `md` with every Markdown heading moved `levels` deeper (`# A` -> `### A` for 2), outside
/// fenced code blocks: a sub-report embedded under a heading of the enclosing report.
pub fn demote_headings(md: &str, levels: usize) -> String {
    let extra = "#".repeat(levels);
    let mut fenced = false;
    let mut out = String::with_capacity(md.len() + 16);
    for line in md.split_inclusive('\n') {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if !fenced && line.starts_with('#') {
            out.push_str(&extra);
        }
        out.push_str(line);
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn headings_move_down_outside_code() {
        let md = "# A\ntext # not\n## B\n```\n# code\n```\n";
        assert_eq!(
            super::demote_headings(md, 2),
            "### A\ntext # not\n#### B\n```\n# code\n```\n"
        );
    }
}
