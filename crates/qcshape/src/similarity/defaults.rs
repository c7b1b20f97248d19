//! The default settings of the similarity pipeline, defined here and re-exported with
//! every other default by [`crate::defaults`] (the index the command line's `--help` and the
//! docs take them from).

/// Poses inserted between consecutive key poses before comparing (section 2.2.1): none. The
/// similarity pipeline compares the key poses as given; the paper's setting is
/// [`crate::defaults::PAPER_INSERT`].
pub const INSERT: usize = 0;

/// Taubin smoothing iterations that were the default before [`SMOOTH_LENGTH`] (`--smooth 10`,
/// chosen on the robustness benchmark, `docs/robustness.md`); [`SMOOTH_LENGTH`] was calibrated
/// to match them at 162 vertices. `--smooth N` (N iterations, 0 = none, the paper's pipeline)
/// has no default any more: without it the length filter smooths.
pub const SMOOTH: usize = 10;

/// The smoothing length of every pose before comparing, relative to the pose's area radius
/// `sqrt(A / 4 pi)` ([`crate::mesh::smooth::smooth_to_length`]; 0 = none): the length filter
/// whose transfer function is closest to [`SMOOTH`] Taubin iterations on the icosphere of 162
/// vertices (least squares over the Laplacian's spectrum: 0.186; half-power point: 0.184), so
/// it filters as the previous default did there, and the same share of the surface at every
/// resolution (the Taubin iterations smooth a quarter of it per subdivision).
pub const SMOOTH_LENGTH: f64 = 0.18;
