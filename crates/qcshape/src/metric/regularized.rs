//! A metric plus the L2 regularizer of eq. 11 ([`Regularized`]).

use super::kind::EnergyPart;
use super::l2::{FrozenL2, L2};
use super::relative::{RelativeL2, PER_FACE};
use super::segment::Segment;
use super::sum::{Term, TermSum};
use super::traits::Metric;
use crate::mesh::Topology;

/// `G + lambda * L2` (eq. 11): the inner metric's residuals followed by `sqrt(lambda)` times
/// the L2 residuals. Makes conformal-type metrics positive definite (docs/method.md "Metrics").
///
/// The L2 part is [`FrozenL2`] (area weights frozen at the path's ends) by default, the
/// literal [`L2`] (weights of the pose itself) with [`Regularized::with_pose_areas`], or the
/// scale-invariant [`RelativeL2`] with [`Regularized::relative`]. Frozen weights are passed as
/// one array: the inner metric's, then the regularizer's (#V, or 2 #F for [`RelativeL2`]).
/// The sum is a [`TermSum`]: `inner` is the metric being regularized, `weight` is `lambda`,
/// `term` says which L2 term regularizes.
pub type Regularized = TermSum<RegularizerL2>;

/// The L2 term of a [`Regularized`] metric (eq. 11).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegularizerL2 {
    /// [`FrozenL2`]: area weights frozen at the path's ends (#V frozen values).
    Frozen,
    /// [`L2`]: the area weights of the pose itself (no frozen values).
    PoseAreas,
    /// [`RelativeL2`]: the scale-invariant form (2 #F frozen values).
    Relative,
}

/// The L2 term as the added term of [`Regularized`]: reported as the regularizer. With frozen
/// areas its residuals are linear (no second-order part of its own), so the sum forwards the
/// inner metric's second-order part; with per-pose areas or the relative form it provides
/// none.
impl Term for RegularizerL2 {
    fn metric(&self) -> &dyn Metric {
        match self {
            RegularizerL2::Frozen => &FrozenL2,
            RegularizerL2::PoseAreas => &L2,
            RegularizerL2::Relative => &RelativeL2,
        }
    }

    /// #V for frozen areas, 2 #F for the relative form, none with per-pose areas.
    fn frozen_len(&self, topo: &Topology) -> usize {
        match self {
            RegularizerL2::Frozen => topo.n_vertices(),
            RegularizerL2::PoseAreas => 0,
            RegularizerL2::Relative => PER_FACE * topo.n_faces(),
        }
    }

    fn part(&self) -> EnergyPart {
        EnergyPart::Regularizer
    }

    fn has_second_order(&self) -> bool {
        *self == RegularizerL2::Frozen
    }

    /// The frozen L2 part needs no pattern (its values are a sum over the vertices).
    fn norms_without_pattern(&self, topo: &Topology, segs: [&Segment; 2]) -> Option<[f64; 2]> {
        (*self == RegularizerL2::Frozen).then(|| FrozenL2::values(topo, segs))
    }
}

impl Regularized {
    /// `inner + lambda * L2` with frozen area weights ([`FrozenL2`]).
    pub fn new(inner: Box<dyn Metric>, lambda: f64) -> Self {
        TermSum::of(inner, lambda, RegularizerL2::Frozen)
    }

    /// `inner + lambda * L2` with the literal per-pose area weights of eq. 11 ([`L2`]).
    pub fn with_pose_areas(inner: Box<dyn Metric>, lambda: f64) -> Self {
        TermSum::of(inner, lambda, RegularizerL2::PoseAreas)
    }

    /// `inner + lambda * L2` with the scale-invariant [`RelativeL2`] (docs/method.md
    /// "Scale-invariant forms").
    pub fn relative(inner: Box<dyn Metric>, lambda: f64) -> Self {
        TermSum::of(inner, lambda, RegularizerL2::Relative)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{fdcheck, ConformalForm, Isometric, QcWeights, QuasiConformal, Rigid};

    #[test]
    fn regularized_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&Regularized::new(Box::new(Isometric), 0.3), 5);
        fdcheck::check_metric(&Regularized::with_pose_areas(Box::new(Isometric), 0.3), 6);
        fdcheck::check_metric(&Regularized::new(Box::new(Rigid), 0.2), 7);
        let qc = QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Endpoints);
        fdcheck::check_metric(&Regularized::new(Box::new(qc), 0.2), 8);
    }

    #[test]
    fn frozen_weights_are_split_between_inner_and_l2() {
        let s = crate::synth::icosphere(1);
        let b: Vec<[f64; 3]> = s.positions.iter().map(|p| [p[0] * 1.2, p[1], p[2]]).collect();
        let qc = QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Endpoints);
        let m = Regularized::new(Box::new(qc), 0.5);
        let f = m.frozen_weights(&s.topology, &s.positions, &b).unwrap();
        assert_eq!(f.len(), 2 * s.n_vertices());
        let (i, l) = m.split_frozen(&s.topology, Some(&f));
        assert_eq!(i.unwrap().len(), s.n_vertices());
        assert_eq!(
            l.unwrap(),
            FrozenL2::weights(&s.topology, &s.positions, &b).as_slice()
        );
    }
}
