//! The default settings of the metric, defined here and re-exported with
//! every other default by [`crate::defaults`] (the index the command line's `--help` and the
//! docs take them from).

use super::{MetricKind, MetricScale, QcNormalize};

/// The metric: isometric. Chosen on the calibrated scale (2026-12-04): the metric whose
/// geometry carried its distances (the L2 regularizer's share of the energy under 1 % on the
/// synthetic and left-ventricle data), whose geodesics kept lengths (the bent tube's centre line
/// at 9.70 of 10, against 6.37 for L2 and 3.5-5 for the conformal metrics) and whose 1-NN
/// accuracy matched the displacement baseline on the robustness benchmark's combined scenario
/// (0.95); the paper's quasi-conformal metric classified worse (0.67) because its conformal
/// terms left the regularizer to carry most of the energy (docs/log/geometry.md). It stayed
/// the default on the invariant scale (100 / 100 % in Table 1; README, "What the measurements
/// say").
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
