//! A membrane metric plus the bending term ([`Bent`]).

use super::kind::EnergyPart;
use super::pattern::PatternRef;
use super::relative::{RelativeBending, PER_FACE};
use super::segment::Segment;
use super::sum::{Term, TermSum};
use super::traits::Metric;
use crate::mesh::Topology;

/// `G + beta * B`: a membrane metric `G` (the invariant isometric, conformal or quasi-conformal
/// form) followed by `sqrt(beta)` times the residuals of the bending term `B`
/// ([`RelativeBending`], docs/method.md "Bending term"), which charges the change of
/// the dihedral angles that the membrane terms see only through the curvature. Dimensionless
/// and scale-invariant like its parts. Frozen values: the inner metric's, then the bending
/// term's face values (2 #F). [`Metric::segment_energy_parts`] counts the bending term as
/// geometric; [`Bent::bending_energy`] gives its part alone. The sum is a [`TermSum`]: `inner`
/// is the membrane metric, `weight` is `beta`.
pub type Bent = TermSum<RelativeBending>;

/// The bending term as the added term of [`Bent`]: its frozen values are the 2 #F face shares,
/// it is geometric, and the sum's pose values are its own (the dihedral angles); it has no
/// second-order part (third derivatives of the dihedral angles), so neither has the sum.
impl Term for RelativeBending {
    fn metric(&self) -> &dyn Metric {
        self
    }

    fn frozen_len(&self, topo: &Topology) -> usize {
        PER_FACE * topo.n_faces()
    }

    fn part(&self) -> EnergyPart {
        EnergyPart::Bending
    }

    fn has_pose_values(&self) -> bool {
        true
    }
}

impl Bent {
    /// `inner + beta * B`.
    pub fn new(inner: Box<dyn Metric>, beta: f64) -> Self {
        TermSum::of(inner, beta, RelativeBending)
    }

    /// `beta B` of both terms of a segment (eq. 12's two terms summed): the bending term's part
    /// of [`Metric::segment_squared_norms`] ([`TermSum::term_energy`]). `pattern` is this
    /// metric's.
    pub fn bending_energy(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> f64 {
        self.term_energy(topo, pattern, segs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{fdcheck, RelativeConformal, RelativeIsometric};

    #[test]
    fn bent_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&Bent::new(Box::new(RelativeIsometric), 0.3), 81);
        let conformal = RelativeConformal {
            qc: None,
            stretch: 0.1,
        };
        fdcheck::check_metric(&Bent::new(Box::new(conformal), 0.05), 82);
    }
}
