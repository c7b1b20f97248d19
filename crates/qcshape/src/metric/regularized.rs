use super::gradient::{GradientSink, PoseShare, Scratch, SegmentSink};
use super::l2::{FrozenL2, L2};
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::relative::RelativeL2;
use super::second_order::SecondOrderSink;
use super::segment::Segment;
use super::sum::{join_frozen, split_pattern, SplitPattern};
use super::traits::Metric;
use crate::mesh::Topology;

/// `G + lambda * L2` (eq. 11): the inner metric's residuals followed by `sqrt(lambda)` times
/// the L2 residuals. Makes conformal-type metrics positive definite (docs/method.md "Metrics").
///
/// The L2 part is [`FrozenL2`] (area weights frozen at the path's ends) by default, the
/// literal [`L2`] (weights of the pose itself) with [`Regularized::with_pose_areas`], or the
/// scale-invariant [`RelativeL2`] with [`Regularized::relative`]. Frozen weights are passed as
/// one array: the inner metric's, then the regularizer's (#V, or 2 #F for [`RelativeL2`]).
#[derive(Debug)]
pub struct Regularized {
    /// The metric being regularized.
    pub inner: Box<dyn Metric>,
    /// Weight `lambda >= 0` of the L2 term.
    pub lambda: f64,
    /// Which L2 term regularizes.
    pub l2: RegularizerL2,
}

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

impl Regularized {
    /// `inner + lambda * L2` with frozen area weights ([`FrozenL2`]).
    pub fn new(inner: Box<dyn Metric>, lambda: f64) -> Self {
        Regularized {
            inner,
            lambda,
            l2: RegularizerL2::Frozen,
        }
    }

    /// `inner + lambda * L2` with the literal per-pose area weights of eq. 11 ([`L2`]).
    pub fn with_pose_areas(inner: Box<dyn Metric>, lambda: f64) -> Self {
        Regularized {
            inner,
            lambda,
            l2: RegularizerL2::PoseAreas,
        }
    }

    /// `inner + lambda * L2` with the scale-invariant [`RelativeL2`] (docs/method.md
    /// "Scale-invariant forms").
    pub fn relative(inner: Box<dyn Metric>, lambda: f64) -> Self {
        Regularized {
            inner,
            lambda,
            l2: RegularizerL2::Relative,
        }
    }

    fn l2(&self) -> &dyn Metric {
        match self.l2 {
            RegularizerL2::Frozen => &FrozenL2,
            RegularizerL2::PoseAreas => &L2,
            RegularizerL2::Relative => &RelativeL2,
        }
    }

    /// Number of the L2 part's frozen values.
    fn l2_frozen_len(&self, topo: &Topology) -> usize {
        match self.l2 {
            RegularizerL2::Frozen => topo.n_vertices(),
            RegularizerL2::PoseAreas => 0,
            RegularizerL2::Relative => super::relative::PER_FACE * topo.n_faces(),
        }
    }
}

impl Metric for Regularized {
    fn name(&self) -> String {
        format!("{}+{}*{}", self.inner.name(), self.lambda, self.l2().name())
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        let mut p = self.inner.pattern(topo);
        p.append(&self.l2().pattern(topo));
        p
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        self.inner.n_residuals(topo) + self.l2().n_residuals(topo)
    }

    fn support(&self, topo: &Topology) -> Pattern {
        let mut p = self.inner.support(topo);
        p.append(&self.l2().support(topo));
        p
    }

    fn n_aux(&self) -> usize {
        self.inner.n_aux()
    }

    fn best_aux(&self, topo: &Topology, seg: &Segment) -> Vec<f64> {
        let (inner, _) = self.split_frozen(topo, seg.frozen);
        self.inner.best_aux(
            topo,
            &Segment {
                frozen: inner,
                ..*seg
            },
        )
    }

    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        join_frozen(
            self.inner.frozen_weights(topo, start, end),
            self.l2().frozen_weights(topo, start, end),
        )
    }

    /// The inner metric's summary followed by the L2 part's (the vertex areas, #V, when the
    /// areas are frozen), split again by [`Metric::frozen_weights_from`].
    fn pose_summary(&self, topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        join_frozen(
            self.inner.pose_summary(topo, pose),
            self.l2().pose_summary(topo, pose),
        )
    }

    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        [sa, sb]: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        // The same split as the frozen weights: the L2 part is the last values.
        let ((ia, la), (ib, lb)) = (
            self.split_frozen(topo, Some(sa)),
            self.split_frozen(topo, Some(sb)),
        );
        let inner = match (ia, ib) {
            (Some(a), Some(b)) => self.inner.frozen_weights_from(topo, start, end, [a, b]),
            _ => self.inner.frozen_weights(topo, start, end),
        };
        let l2 = match (la, lb) {
            (Some(a), Some(b)) => self.l2().frozen_weights_from(topo, start, end, [a, b]),
            _ => self.l2().frozen_weights(topo, start, end),
        };
        join_frozen(inner, l2)
    }

    /// The inner metric's factors, then 1 for every L2 residual (the regularizer's frozen
    /// areas are not factors of a pair-dependent weight).
    fn residual_factors(&self, topo: &Topology, frozen: &[f64]) -> Option<Vec<f64>> {
        let (inner, _) = self.split_frozen(topo, Some(frozen));
        let mut f = self.inner.residual_factors(topo, inner?)?;
        f.resize(f.len() + self.l2().n_residuals(topo), 1.0);
        Some(f)
    }

    /// The inner metric's part set to one ([`Metric::unit_frozen`]), the L2 areas unchanged.
    fn unit_frozen(&self, topo: &Topology, frozen: Vec<f64>) -> Vec<f64> {
        match self.split_frozen(topo, Some(&frozen)) {
            (Some(inner), l2) => join_frozen(
                Some(self.inner.unit_frozen(topo, inner.to_vec())),
                l2.map(<[f64]>::to_vec),
            )
            .unwrap_or_default(),
            (None, _) => frozen,
        }
    }

    fn residuals(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        jac: Option<JacobianMut>,
    ) {
        // The inner pattern is a prefix of the combined one (rows and entries).
        let parts = self.patterns(topo, pattern);
        let (inner_pat, l2_pat) = (parts.first, parts.second());
        let (seg_in, seg_l2) = self.segments(topo, seg);
        let (n_in, e_in) = (inner_pat.n_residuals(), inner_pat.vertices.len());
        let (r_in, r_l2) = r.split_at_mut(n_in);
        let sl = self.lambda.max(0.0).sqrt();
        match jac {
            None => {
                self.inner.residuals(topo, inner_pat, &seg_in, r_in, None);
                self.l2().residuals(topo, l2_pat, &seg_l2, r_l2, None);
            }
            Some(j) => {
                let (da_in, da_l2) = j.da.split_at_mut(e_in);
                let (db_in, db_l2) = j.db.split_at_mut(e_in);
                let n_aux = self.inner.n_aux();
                let (daux_in, daux_l2) = j.daux.split_at_mut(n_in * n_aux);
                let ji = JacobianMut {
                    da: da_in,
                    db: db_in,
                    daux: daux_in,
                };
                self.inner.residuals(topo, inner_pat, &seg_in, r_in, Some(ji));
                let jl = JacobianMut {
                    da: da_l2,
                    db: db_l2,
                    daux: &mut [],
                };
                self.l2().residuals(topo, l2_pat, &seg_l2, r_l2, Some(jl));
                for d in da_l2.iter_mut().chain(db_l2.iter_mut()) {
                    *d = d.map(|v| v * sl);
                }
                // The L2 part does not depend on the auxiliary unknowns.
                daux_l2.fill(0.0);
            }
        }
        for v in r_l2.iter_mut() {
            *v *= sl;
        }
    }

    /// The inner metric's gradient plus `lambda` times the L2 part's (residuals scaled by
    /// `sqrt(lambda)`), each by its own (fused where available) kernel.
    fn gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        scratch: &mut Scratch,
        sink: &mut GradientSink,
    ) -> f64 {
        let parts = self.patterns(topo, pattern);
        let (seg_in, seg_l2) = self.segments(topo, seg);
        let v_in = self.inner.gradient(topo, parts.first, &seg_in, scratch, sink);
        let weight = sink.weight;
        sink.weight = weight * self.lambda.max(0.0);
        // The L2 part does not depend on the auxiliary unknowns: no aux gradient.
        let mut no_aux = GradientSink {
            ga: &mut *sink.ga,
            gb: &mut *sink.gb,
            gaux: &mut [],
            weight: sink.weight,
        };
        let v_l2 = self
            .l2()
            .gradient(topo, parts.second(), &seg_l2, scratch, &mut no_aux);
        sink.weight = weight;
        v_in + v_l2
    }

    fn segment_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        self.segment_gradient_with(topo, pattern, segs, PoseShare::none(), scratch, sink)
    }

    /// The inner metric's (the L2 part has none).
    fn pose_values(&self, topo: &Topology, pattern: PatternRef, pose: &[[f64; 3]], out: &mut Vec<f64>) {
        let parts = self.patterns(topo, pattern);
        self.inner.pose_values(topo, parts.first, pose, out);
    }

    /// The inner metric's.
    fn pose_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        pose: &[[f64; 3]],
        coeffs: &[f64],
        g: &mut [[f64; 3]],
    ) {
        let parts = self.patterns(topo, pattern);
        self.inner.pose_gradient(topo, parts.first, pose, coeffs, g);
    }

    fn segment_gradient_with(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        share: PoseShare,
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        let parts = self.patterns(topo, pattern);
        let ((s0_in, s0_l2), (s1_in, s1_l2)) = (self.segments(topo, segs[0]), self.segments(topo, segs[1]));
        let v_in =
            self.inner
                .segment_gradient_with(topo, parts.first, [&s0_in, &s1_in], share, scratch, sink);
        // The L2 part does not depend on the auxiliary unknowns: no aux gradient.
        let mut no_aux = SegmentSink {
            ga: &mut *sink.ga,
            gb: &mut *sink.gb,
            gaux: &mut [],
            weight: sink.weight * self.lambda.max(0.0),
        };
        let v_l2 = self
            .l2()
            .segment_gradient(topo, parts.second(), [&s0_l2, &s1_l2], scratch, &mut no_aux);
        v_in + v_l2
    }

    /// The inner metric's values plus `lambda` times the L2 part's, each by its own
    /// (value-only where available) pass.
    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        let (v_in, v_l2) = self.parts_values(topo, pattern, segs);
        [v_in[0] + v_l2[0], v_in[1] + v_l2[1]]
    }

    /// `[inner, lambda * L2]`, each summed over the segment's two terms.
    fn segment_energy_parts(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        let (v_in, v_l2) = self.parts_values(topo, pattern, segs);
        [v_in[0] + v_in[1], v_l2[0] + v_l2[1]]
    }

    /// The inner metric's bending part (the L2 term bends nothing).
    fn segment_bending_energy(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> f64 {
        let inner = self.inner_pattern(topo, pattern);
        let ((s0, _), (s1, _)) = (self.segments(topo, segs[0]), self.segments(topo, segs[1]));
        self.inner.segment_bending_energy(topo, inner, [&s0, &s1])
    }

    /// Both of the above from one pass over the two parts.
    fn segment_norms_and_parts(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
    ) -> ([f64; 2], [f64; 2]) {
        let (v_in, v_l2) = self.parts_values(topo, pattern, segs);
        (
            [v_in[0] + v_l2[0], v_in[1] + v_l2[1]],
            [v_in[0] + v_in[1], v_l2[0] + v_l2[1]],
        )
    }

    /// The inner metric's part (its residuals are the first rows); the frozen L2 part adds
    /// nothing (linear residuals). Not provided with per-pose areas.
    fn add_second_order(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &[f64],
        sink: &mut SecondOrderSink,
    ) -> bool {
        if self.l2 != RegularizerL2::Frozen {
            return false;
        }
        let parts = self.patterns(topo, pattern);
        let (seg_in, seg_l2) = self.segments(topo, seg);
        let n_in = parts.first.n_residuals();
        self.inner
            .add_second_order(topo, parts.first, &seg_in, &r[..n_in], sink)
            && self
                .l2()
                .add_second_order(topo, parts.second(), &seg_l2, &r[n_in..], sink)
    }
}

impl Regularized {
    /// Both terms of a segment for the inner metric and for `lambda * L2`, each by its own
    /// (value-only where available) pass.
    fn parts_values(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
    ) -> ([f64; 2], [f64; 2]) {
        let ((s0_in, s0_l2), (s1_in, s1_l2)) = (self.segments(topo, segs[0]), self.segments(topo, segs[1]));
        let (v_in, v_l2) = if self.l2 == RegularizerL2::Frozen {
            // The frozen L2 part needs no pattern: no rebased copy of its offsets.
            let inner = self.inner_pattern(topo, pattern);
            let v_in = self.inner.segment_squared_norms(topo, inner, [&s0_in, &s1_in]);
            (v_in, FrozenL2::values(topo, [&s0_l2, &s1_l2]))
        } else {
            let parts = self.patterns(topo, pattern);
            let v_in = self
                .inner
                .segment_squared_norms(topo, parts.first, [&s0_in, &s1_in]);
            let v_l2 = self
                .l2()
                .segment_squared_norms(topo, parts.second(), [&s0_l2, &s1_l2]);
            (v_in, v_l2)
        };
        let lambda = self.lambda.max(0.0);
        (v_in, v_l2.map(|v| lambda * v))
    }

    /// The inner metric's rows of `pattern` and the L2 rows ([`split_pattern`]).
    fn patterns<'p>(&self, topo: &Topology, pattern: PatternRef<'p>) -> SplitPattern<'p> {
        split_pattern(pattern, self.inner.n_residuals(topo))
    }

    /// The inner metric's rows of `pattern` (its prefix), without the L2 rows.
    fn inner_pattern<'p>(&self, topo: &Topology, pattern: PatternRef<'p>) -> PatternRef<'p> {
        let n_in = self.inner.n_residuals(topo);
        PatternRef {
            offsets: &pattern.offsets[..=n_in],
            vertices: &pattern.vertices[..pattern.offsets[n_in] as usize],
        }
    }

    /// The segment as seen by the inner metric and by the L2 part (each with its own frozen
    /// weights).
    fn segments<'a>(&self, topo: &Topology, seg: &Segment<'a>) -> (Segment<'a>, Segment<'a>) {
        let (fr_in, fr_l2) = self.split_frozen(topo, seg.frozen);
        let seg_in = Segment {
            frozen: fr_in,
            ..*seg
        };
        let seg_l2 = Segment {
            frozen: fr_l2,
            ..*seg
        };
        (seg_in, seg_l2)
    }

    /// Splits a frozen-weight array into the inner metric's part and the L2 part (its last
    /// values: #V for frozen areas, 2 #F for the relative form).
    fn split_frozen<'a>(
        &self,
        topo: &Topology,
        frozen: Option<&'a [f64]>,
    ) -> (Option<&'a [f64]>, Option<&'a [f64]>) {
        let Some(f) = frozen else { return (None, None) };
        let nl = self.l2_frozen_len(topo);
        if f.len() < nl {
            return (Some(f), None);
        }
        let (a, b) = f.split_at(f.len() - nl);
        (
            if a.is_empty() { None } else { Some(a) },
            if b.is_empty() { None } else { Some(b) },
        )
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
