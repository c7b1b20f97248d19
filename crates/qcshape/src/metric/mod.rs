//! Shape-space metrics (paper section 2.1, docs/method.md "Metrics").
//!
//! Every metric is a squared norm `G_M(X) = <<X, X>>_M = |r|^2` written as a sum of squared
//! residuals `r`, where `M` is the pose that supplies the geometry and `X` a tangent vector
//! (#V x 3). The path energy (eq. 12) evaluates each metric on a path segment `X = b - a` with
//! the geometry of either end, so the [`Metric`] trait works on segments: it returns the
//! residuals and their exact Jacobian blocks with respect to both ends (`a` and `b`), computed
//! from the same intermediates. The sparsity [`Pattern`] (which vertices each residual depends
//! on) is built once per topology and reused for every evaluation.
//!
//! Metrics: [`L2`] (eq. 11), [`Isometric`] (eq. 3), [`Rigid`] (eq. 1), [`Conformal`] (eqs. 7-9),
//! [`QuasiConformal`] (eq. 10), and the sums of a metric and a weighted term ([`TermSum`]):
//! [`Regularized`] (`G + lambda * L2`, eq. 11) and [`Bent`] (`G + beta * B`, the bending term).
//!
//! The modules stand on floors (`crates/qcshape/floors.txt`): at the bottom the segment
//! ([`At`], [`Segment`]), the sparsity ([`Pattern`], [`Jacobian`]) and the names a setting
//! chooses a metric by ([`MetricKind`]); above them the gradient and Hessian accumulators, then
//! the [`Metric`] trait, then the metrics, then [`MetricSpec`], which builds them. This file
//! only declares the modules and re-exports their public items.

mod bent;
mod conformal;
mod curvature;
pub mod defaults;
mod fused;
mod gradient;
mod isometric;
mod kind;
mod l2;
mod pattern;
mod quasi_conformal;
mod regularized;
mod relative;
mod rigid;
mod rigid_frozen;
mod second_order;
mod segment;
mod spec;
mod sum;
mod traits;
mod weighted;

#[cfg(test)]
pub(crate) mod fdcheck;

pub use bent::Bent;
pub use conformal::{Conformal, ConformalForm};
pub use gradient::{GradientSink, PoseShare, Scratch, SegmentSink};
pub use isometric::Isometric;
pub use kind::{
    EnergyPart, L2Areas, MetricInfo, MetricKind, MetricScale, MetricTerm, QcScaling, TermInfo, TermKind,
    UnknownName, Weight, METRICS, TERMS,
};
pub use l2::{FrozenL2, L2};
pub use pattern::{Jacobian, JacobianMut, Pattern, PatternRef};
pub use quasi_conformal::{QcNormalize, QcWeights, QuasiConformal};
pub use regularized::{Regularized, RegularizerL2};
pub use relative::{
    dihedral_angles, Folds, RelativeBending, RelativeConformal, RelativeIsometric, RelativeL2,
    BENDING_SHARE_WARNING, FOLD_TURN_DEGREES,
};
pub use rigid::{fit_motion_weighted, Rigid};
pub use rigid_frozen::FrozenRigid;
pub use second_order::SecondOrderSink;
pub use segment::{At, Segment};
pub use spec::{Calibration, CalibrationError, MetricSpec};
pub use sum::{Term, TermSum};
pub use traits::{
    gradient_from_jacobian, residuals_at_best_aux, segment_gradient_per_term, squared_norm_from_residuals,
    Metric,
};
pub use weighted::Weighted;
