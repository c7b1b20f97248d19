//! The shared types of the similarity path, at the bottom of `similarity/`: what a pair's
//! distance is ([`PairDistance`]), how pose distances are measured ([`Approx`]), which pairs
//! there are ([`all_pairs`]) and what a run reports while it works ([`Event`], [`Stage`]).
//! Every other file of the folder builds on these; this one imports none of them.

use std::path::Path;

pub use crate::mesh::Pose;

/// The distance between two deformations and how it was obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct PairDistance {
    /// Index of the first deformation (`i < j`).
    pub i: usize,
    /// Index of the second deformation.
    pub j: usize,
    /// `sum_k dis(M_k, N_k)` (eq. 13), in the solver's normalized length units.
    pub distance: f64,
    /// `dis(M_k, N_k)` for every pose `k`.
    pub per_pose: Vec<f64>,
    /// For every pose `k`, the energy (eq. 12) of the path whose length is `dis(M_k, N_k)`
    /// split as `[geometric, regularizer]` (the geometric term `c_G G` and the L2 regularizer
    /// `lambda c_L L2` of eq. 11, in the metric's units; [`crate::geodesic::Geodesic`]): the
    /// geodesic's for [`Approx::Exact`], the straight path's for [`Approx::Straight`], `[0, 0]`
    /// for identical poses. `None` when unknown: [`Approx::Tangent`] measures no path, and
    /// pairs read from journals or shard files written before the parts were recorded have
    /// none.
    pub per_pose_energy: Option<Vec<[f64; 2]>>,
    /// Whether every geodesic converged.
    pub converged: bool,
    /// Solver iterations, summed over the poses.
    pub iterations: usize,
    /// Wall-clock seconds for this pair.
    pub seconds: f64,
}

impl PairDistance {
    /// The pair's energy split `[geometric, regularizer]`, each summed over the poses (in the
    /// metric's units); `None` when the parts are unknown ([`PairDistance::per_pose_energy`]).
    pub fn energy_parts(&self) -> Option<[f64; 2]> {
        self.per_pose_energy
            .as_ref()
            .map(|e| e.iter().fold([0.0, 0.0], |acc, p| [acc[0] + p[0], acc[1] + p[1]]))
    }

    /// The L2 regularizer's share of the pair's energy, `sum_k regularizer_k / sum_k
    /// (geometric_k + regularizer_k)` in [0, 1] (0 for a pair of zero energy,
    /// [`crate::geodesic::share`]); above 0.5 the pair's distance measures L2 displacement more
    /// than the metric's geometry. `None` when the parts are unknown.
    pub fn regularizer_share(&self) -> Option<f64> {
        self.energy_parts().map(|[g, r]| crate::geodesic::share(g, r))
    }
}

/// How the pose distances `dis(M_k, N_k)` of a similarity matrix are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Approx {
    /// The length of the discrete geodesic (eq. 12 minimized): the paper's distance.
    #[default]
    Exact,
    /// The length of the straight path with the same N segments, no optimization
    /// ([`crate::geodesic::GeodesicSolver::straight_length`]): an upper bound of the geodesic length, 2N metric
    /// evaluations per pose instead of a solve (the energy split is the straight path's). Its
    /// error against the exact matrix is measured by `qcshape experiment approx`
    /// (docs/scale.md).
    Straight,
    /// The metric linearized at the common base: `|y(M_k) - y(N_k)|` with `y(P) = J_B (P - B)`,
    /// `J_B` the residual Jacobian at the base `B` (`super::tangent`; for the rigid metric
    /// minus its projection onto the rigid motions, the optimal motion in closed form), so that
    /// `|y(P) - y(Q)|^2 = G_B(P - Q)`: one sparse product per pose, then one Euclidean distance
    /// per pair and pose. For every metric; the quasi-conformal metric (quadratic form,
    /// endpoint weights) weighs each pair's feature difference by that pair's curvature-change
    /// weights, and its paper form and segment weights are refused. No path is measured, so the energy split
    /// of [`PairDistance::per_pose_energy`] is unknown (`None`).
    Tangent,
}

impl std::fmt::Display for Approx {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Approx::Exact => "exact",
            Approx::Straight => "straight",
            Approx::Tangent => "tangent",
        })
    }
}

impl std::str::FromStr for Approx {
    type Err = String;

    fn from_str(s: &str) -> Result<Approx, String> {
        match s {
            "exact" => Ok(Approx::Exact),
            "straight" => Ok(Approx::Straight),
            "tangent" => Ok(Approx::Tangent),
            _ => Err(format!("{s:?}: expected exact, straight or tangent")),
        }
    }
}

/// All pairs `(i, j)`, `i < j`, of `n` items, in row order.
pub fn all_pairs(n: usize) -> Vec<(usize, usize)> {
    (0..n).flat_map(|i| (i + 1..n).map(move |j| (i, j))).collect()
}

/// The pipeline stage a progress report is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Temporal interpolation (one report per deformation).
    Interpolation,
    /// Transfer to the base (one report per deformation).
    Transfer,
    /// Pairwise similarity (one report per pair).
    Similarity,
}

/// What a run reports while it works, to one callback (called from worker threads).
#[derive(Debug, Clone, Copy)]
pub enum Event<'a> {
    /// A deformation finished a stage of [`super::prepare`] (interpolation or transfer).
    Prepared {
        /// The stage.
        stage: Stage,
        /// The deformation's name.
        name: &'a str,
    },
    /// The journal is open, before any pair is computed.
    Journal {
        /// The journal file.
        path: &'a Path,
        /// Pairs read back from an earlier run (0 without `resume`).
        recorded: usize,
        /// Records of the earlier run dropped (recomputed): torn, failing their checksum, or
        /// holding values no run writes ([`RecordProblem`]), each named.
        dropped: &'a [DroppedRecord],
        /// Pairs of the selection.
        total: usize,
        /// An earlier journal existed and was started over (no `resume`).
        discarded: bool,
    },
    /// A pair finished (its distances are final and, with a journal sink, recorded).
    Pair(&'a PairDistance),
}

/// A journal record that was dropped on resume, so that its pair is computed again.
#[derive(Debug, Clone, PartialEq)]
pub struct DroppedRecord {
    /// Its line in the journal (1-based).
    pub line: usize,
    /// The pair it names, when its indices could be read.
    pub pair: Option<(usize, usize)>,
    /// Why it was dropped.
    pub problem: RecordProblem,
}

impl std::fmt::Display for DroppedRecord {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the record on line {}", self.line)?;
        if let Some((i, j)) = self.pair {
            write!(f, " (pair {i}, {j})")?;
        }
        write!(f, ": {}", self.problem)
    }
}

/// Why a journal record is not used ([`DroppedRecord`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordProblem {
    /// Torn by a kill or changed on disk: its `,#` check does not match its text.
    #[error("torn or changed (it fails its checksum)")]
    Checksum,
    /// Not `pair,I,J,DISTANCE,CONVERGED,ITERATIONS,SECONDS,PER_POSE[,ENERGY]`.
    #[error("field {field} does not read as {expected}")]
    Malformed {
        /// The field's name.
        field: &'static str,
        /// What it must be.
        expected: &'static str,
    },
    /// Its indices are not a pair `i < j < n`.
    #[error("({i}, {j}) is not a pair i < j of the {n} deformations")]
    NotAPair {
        /// First index.
        i: usize,
        /// Second index.
        j: usize,
        /// The run's deformation count.
        n: usize,
    },
    /// Another pose count than the run's.
    #[error("{found} pose distance(s) where the run has {expected} poses")]
    PoseCount {
        /// Pose distances in the record.
        found: usize,
        /// The run's pose count.
        expected: usize,
    },
    /// An energy split of another length than the pose distances.
    #[error("{found} energy split(s) for {expected} pose distances")]
    EnergyCount {
        /// Splits in the record.
        found: usize,
        /// Pose distances in the record.
        expected: usize,
    },
    /// A value out of its range: a distance, energy or time that is negative or not finite.
    #[error("{field} = {value:?} is out of range (finite and >= 0)")]
    Range {
        /// The field's name.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// A distance that is not the sum of its pose distances (eq. 13).
    #[error("distance {distance:?} is not the sum of its pose distances ({sum:?})")]
    Sum {
        /// The record's distance.
        distance: f64,
        /// The sum of its pose distances.
        sum: f64,
    },
    /// A pair recorded before (the first record of a pair is kept).
    #[error("repeats a pair recorded before")]
    Repeated,
}
