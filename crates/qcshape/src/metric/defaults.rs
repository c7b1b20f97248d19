//! The default settings of the metric, defined here and re-exported with
//! every other default by [`crate::defaults`] (the index the command line's `--help` and the
//! docs take them from).

use super::kind::{MetricKind, MetricScale};
use super::quasi_conformal::QcNormalize;

/// The metric: isometric (edge strain on the invariant scale). Chosen again after the
/// scale-invariant forms (docs/log/scale-invariant.md, 162 vertices): it classifies the clean
/// benchmark at 100 / 100 % (Table 1; quasi-conformal 97.6 / 83.3), its middle poses are closer to
/// the truth than the conformal metrics' (Fig. 4 mean error 0.130 against 0.20), it is as close as
/// the conformal metric on a real LV cycle (leave-one-frame-out 0.33 against 0.34; quasi-conformal
/// 0.71), and it separates the overlap LV phantoms better than L2 (1-NN 87 % against 70 %). Its
/// geodesics keep lengths (the bent tube's centre line at 9.70 of 10, against 6.37 for L2).
pub const METRIC: MetricKind = MetricKind::Isometric;

/// Weight `lambda` of the L2 regularizer of every metric (eq. 11): on the default invariant
/// scale a plain ratio of two dimensionless terms (docs/geometry.md). Chosen on the calibrated
/// scale, where isometric's 1-NN was the same from 0.001 to 1 (docs/log/geometry.md).
pub const LAMBDA: f64 = 0.01;

/// How the metric's terms are scaled: scale-invariant forms (dimensionless,
/// resolution-consistent, and free of the shrinking of eq. 7's conformal terms; docs/method.md
/// "Scale-invariant forms").
pub const SCALE: MetricScale = MetricScale::Invariant;

/// Weight of the stretch term of the conformal and quasi-conformal metrics on the invariant
/// scale (the relative rate of change of each face's area against the corner terms' shear).
pub const STRETCH: f64 = 0.1;

/// Weight `beta` of the bending term of the isometric, conformal and quasi-conformal metrics on
/// the invariant scale (the change of the dihedral angles along the path, docs/method.md "Bending
/// term"). With 1e-4 it carries 4-6 % of the twisted sphere's geodesic energy and the default
/// solver converges in 19 iterations at 642 vertices for every membrane metric, against 138-258
/// without it (docs/log/bending.md).
pub const BENDING: f64 = 1e-4;

/// Normalization of the quasi-conformal `endpoints` weights: the curvature-change density over
/// its RMS, floored (docs/log/geometry.md).
pub const QC_NORMALIZE: Option<QcNormalize> = Some(QcNormalize {
    floor: 0.5,
    smooth: 0,
});

/// `lambda` of the previous releases' [`MetricScale::Raw`] scale (coordinates in mean-edge
/// units): 0.1. With it the regularizer carried almost all of the energy (docs/log/geometry.md);
/// kept so that [`crate::metric::MetricSpec::previous`] reproduces the previous tables.
pub const RAW_LAMBDA: f64 = 0.1;
