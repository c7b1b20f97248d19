//! The default settings, defined once: the library's option structs
//! ([`crate::geodesic::GeodesicOptions`], [`crate::geodesic::InterpolationOptions`],
//! [`crate::metric::MetricSpec::new`], [`crate::similarity::PipelineOptions`], the experiments)
//! and every `qcshape` command's `--help` take their defaults from here, so that the same
//! option means the same method in every command.
//!
//! The values are the ones the README's "How the defaults were chosen" section measured; a
//! command that keeps a different value does so through one of the named exceptions at the end
//! of this module, each with the reason, and says so in its `--help`.

use crate::geodesic::Solver;
use crate::metric::{MetricKind, MetricScale, QcNormalize};
use crate::transport::{Alignment, Transport};

/// The metric: isometric. On the calibrated scale it is the metric whose geometry carries its
/// distances (the L2 regularizer's share of the energy is under 1 % on the synthetic and
/// left-ventricle data), whose geodesics keep lengths (the bent tube's centre line at 9.70 of
/// 10, against 6.37 for L2 and 3.5-5 for the conformal metrics) and whose 1-NN accuracy matches
/// the displacement baseline on the robustness benchmark's combined scenario (0.95). The
/// paper's quasi-conformal metric, with its geometry switched on, classifies worse (0.67 on
/// the combined scenario) because its conformal null space leaves the regularizer to carry
/// most of the energy (docs/geometry.md).
pub const METRIC: MetricKind = MetricKind::Isometric;

/// Weight `lambda` of the L2 regularizer of every metric (eq. 11), on the
/// [`MetricScale::Calibrated`] scale (a ratio of two dimensionless terms; docs/geometry.md).
pub const LAMBDA: f64 = 0.01;

/// How the metric's terms are scaled: calibrated (dimensionless, resolution-consistent terms;
/// docs/geometry.md).
pub const SCALE: MetricScale = MetricScale::Calibrated;

/// Normalization of the quasi-conformal `endpoints` weights: the curvature-change density over
/// its RMS, floored (docs/geometry.md).
pub const QC_NORMALIZE: Option<QcNormalize> = Some(QcNormalize {
    floor: 0.5,
    smooth: 0,
});

/// `lambda` of the previous releases' [`MetricScale::Raw`] scale (coordinates in mean-edge
/// units): 0.1. With it the regularizer carried almost all of the energy (docs/geometry.md);
/// kept so that [`crate::metric::MetricSpec::previous`] reproduces the previous tables.
pub const RAW_LAMBDA: f64 = 0.1;

/// Segments N of every geodesic (transfer, similarity, interpolation steps).
pub const STEPS: usize = 8;

/// The geodesic optimizer: the preconditioned L-BFGS, the fastest in the benchmark
/// (`docs/benchmarks.md`).
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

/// Poses inserted between consecutive key poses before comparing (section 2.2.1): none. The
/// similarity pipeline compares the key poses as given; the paper's setting is
/// [`PAPER_INSERT`].
pub const INSERT: usize = 0;

/// Spatial levels of the temporal interpolation: 1 (no multiresolution). The multiresolution
/// solve was not faster to the solver's tolerance in the benchmark (README).
pub const LEVELS: usize = 1;

/// Transport of every deformation to the common base: Euclidean (`N_k = N_0 + M_k - M_0`,
/// command-line value `euclidean`). It gave the lower transfer error and the better
/// classification in the measurements (README); `parallel` is the paper's.
pub const TRANSPORT: Transport = Transport::Translate;

/// Placement of each deformation on the base before transfer: rigid (area-weighted Procrustes
/// of its first pose onto the base, the same motion for all its poses).
pub const ALIGN: Alignment = Alignment::Rigid;

/// Taubin smoothing iterations of every pose before comparing (0 = none, the paper's
/// pipeline). 10 was chosen on the robustness benchmark (`docs/robustness.md`).
pub const SMOOTH: usize = 10;

/// Seeded clustering runs (kernel k-means restarts; the best starts the intrinsic k-means).
pub const RESTARTS: usize = 20;

/// Seed of every random choice (data, clustering, noise, MDS jitter).
pub const SEED: u64 = 0;

// ---------------------------------------------------------------------------------------------
// Named exceptions: settings of the paper's experiments, kept so that the tables the README
// reports are reproduced by the command as documented.
// ---------------------------------------------------------------------------------------------

/// Poses inserted between key poses in the paper's experiments (section 3.3: 3 key poses + 3
/// inserted between each pair; section 4: 8 frames + 24 inserted poses per cycle). Used by
/// `reproduce`, `lv run`, `lv cycle` and [`crate::geodesic::InterpolationOptions`]'s default (an
/// interpolator that inserts nothing does nothing).
pub const PAPER_INSERT: usize = 3;

/// Segments N of the paper-reproduction geodesics (`reproduce`, `lv run`, `lv cycle`): 4. The
/// README's Table 1 and the LV tables were measured with it; [`STEPS`] = 8 would double their
/// run time for distances that differ in the third digit.
pub const PAPER_STEPS: usize = 4;

/// Segments N of the noise experiment's geodesics (`experiment noise`): 4. The README's Table 3
/// (tau at 1 % to 20 % noise, 162 vertices, 8.6 min) was measured with it; the experiment
/// classifies the 48 deformations 2 x (levels + 1) times, so [`STEPS`] = 8 doubles a run
/// that already takes minutes.
pub const NOISE_STEPS: usize = 4;

/// Kernel k-means restarts of the noise experiment (`experiment noise`): 10, the setting the
/// README's Table 3 was measured with (every classification of every level uses it).
pub const NOISE_RESTARTS: usize = 10;

/// Fourier harmonics of the cycle kept in every landmark trajectory before the registration of
/// `lv run` ([`crate::lv::landmarks::Landmarks::low_pass`]): 2. On five harder phantom cohorts
/// (`lv phantom --overlap --seed 1..5`, 1 mm landmark noise per frame, 8 frames) it raised the
/// mean ARI of the 2-cluster split from 0.00 to 0.24 and leave-one-out 1-NN from 66 to 73 %,
/// and left the default cohort at 100 / 100 (README, "Left ventricle"; docs/lv-clustering.md).
/// `None` is the paper's registration of the raw landmarks.
pub const LANDMARK_HARMONICS: Option<usize> = Some(2);
/// Image refinement of `lv run` and `lv mesh` ([`crate::lv::refine::refine_to_image`]): every
/// carried frame's vertices move along their normals to the cavity wall of that frame's image,
/// searched within 4 mm (about four times the landmark noise of the harder phantom). On
/// phantom cohorts with 1 mm landmark noise it brings the meshes from 1.5 to 0.65 mm RMS off
/// the true wall (test `image_refinement_brings_carried_meshes_onto_the_true_cavity_wall`);
/// the 2-means splits: README, "Left ventricle", and docs/lv-clustering.md section 5. `None`
/// is the paper's registration (landmark splines alone).
pub const LV_REFINE_MM: Option<f64> = Some(4.0);
/// Transport of `lv run`: parallel, the paper's section 4 pipeline, with which
/// the README's LV tables were measured (euclidean gave the same splits on the five harder
/// phantom cohorts).
pub const LV_TRANSPORT: Transport = Transport::Parallel;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::{GeodesicOptions, InterpolationOptions};
    use crate::similarity::PipelineOptions;

    #[test]
    fn the_library_defaults_are_these_constants() {
        let g = GeodesicOptions::default();
        assert_eq!(g.steps, STEPS);
        assert_eq!(g.solver, SOLVER);
        assert_eq!(g.gradient_tolerance, TOLERANCE);
        assert_eq!(g.energy_tolerance, ENERGY_TOLERANCE);
        assert_eq!(g.length_tolerance, LENGTH_TOLERANCE);
        let i = InterpolationOptions::default();
        assert_eq!((i.insert, i.levels), (PAPER_INSERT, LEVELS));
        // PipelineOptions is defined in the similarity module; its Default must agree.
        let p = PipelineOptions::default();
        assert_eq!(p.metric.kind, METRIC);
        assert_eq!(p.metric.lambda, LAMBDA);
        assert_eq!(p.geodesic.steps, STEPS);
        assert_eq!(p.insert, INSERT);
        assert_eq!(p.levels, LEVELS);
        assert_eq!(p.transport, TRANSPORT);
        assert_eq!(p.align, ALIGN);
        assert_eq!(p.smoothing, SMOOTH);
        assert_eq!(crate::metric::MetricSpec::new(METRIC).lambda, LAMBDA);
    }
}
