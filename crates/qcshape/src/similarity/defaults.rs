//! The default settings of the similarity pipeline, defined here and re-exported with
//! every other default by [`crate::defaults`] (the index the command line's `--help` and the
//! docs take them from).

/// Poses inserted between consecutive key poses before comparing (section 2.2.1): none. The
/// similarity pipeline compares the key poses as given; the paper's setting is
/// [`crate::defaults::PAPER_INSERT`].
pub const INSERT: usize = 0;

/// Taubin smoothing iterations of every pose before comparing (0 = none, the paper's
/// pipeline). 10 was chosen on the robustness benchmark (`docs/robustness.md`).
pub const SMOOTH: usize = 10;
