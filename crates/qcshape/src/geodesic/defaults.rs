//! The default settings of the geodesic solver and the temporal interpolation, defined here and re-exported with
//! every other default by [`crate::defaults`] (the index the command line's `--help` and the
//! docs take them from).

use super::Solver;

/// Segments N of every geodesic (transfer, similarity, interpolation steps).
pub const STEPS: usize = 8;

/// The geodesic optimizer: the preconditioned L-BFGS, the fastest in the benchmark
/// (`docs/log/benchmarks.md`).
pub const SOLVER: Solver = Solver::Preconditioned;

/// Relative gradient tolerance of the geodesic solvers (converged when the gradient norm falls
/// below this fraction of its start value).
pub const TOLERANCE: f64 = 1e-6;

/// Relative energy tolerance of the geodesic solvers (also converged when an accepted step
/// lowers the energy by less than this fraction; 0 disables the test).
pub const ENERGY_TOLERANCE: f64 = 1e-12;

/// Relative length tolerance of distance solves (similarity matrices, the intrinsic k-means
/// assignment): also converged when two consecutive steps each change the path's length by
/// less than this fraction (0 disables the test; path solves never use it).
pub const LENGTH_TOLERANCE: f64 = 1e-8;

/// Spatial levels of the temporal interpolation: 1 (no multiresolution). The multiresolution
/// solve was not faster to the solver's tolerance in the benchmark (README).
pub const LEVELS: usize = 1;

/// Poses inserted between key poses in the paper's experiments (section 3.3: 3 key poses + 3
/// inserted between each pair; section 4: 8 frames + 24 inserted poses per cycle). Used by
/// `reproduce`, `lv run`, `lv cycle` and [`crate::geodesic::InterpolationOptions`]'s default (an
/// interpolator that inserts nothing does nothing).
pub const PAPER_INSERT: usize = 3;
