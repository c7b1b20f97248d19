//! A metric multiplied by a constant: `c G` (the calibrated geometric term of
//! [`super::MetricSpec::build`], docs/method.md "Scale-invariant forms").

use super::gradient::{GradientSink, Scratch, SegmentSink};
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::second_order::SecondOrderSink;
use super::segment::Segment;
use super::traits::Metric;
use crate::mesh::Topology;

/// `weight * G` for an inner metric `G`: residuals `sqrt(weight) r`, so every derivative,
/// value and second-order part is the inner metric's times `weight` (> 0). The calibrated
/// scales of [`super::MetricScale::Calibrated`] use it to turn each metric into a dimensionless,
/// resolution-consistent quantity ([`super::Calibration`]). Units: those of `G` times those of
/// `weight`.
#[derive(Debug)]
pub struct Weighted {
    /// The metric being scaled.
    pub inner: Box<dyn Metric>,
    /// The constant factor (finite, > 0).
    pub weight: f64,
}

impl Weighted {
    /// `weight * inner`.
    pub fn new(inner: Box<dyn Metric>, weight: f64) -> Self {
        Weighted { inner, weight }
    }
}

impl Metric for Weighted {
    fn name(&self) -> String {
        format!("{:.6e}*{}", self.weight, self.inner.name())
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        self.inner.pattern(topo)
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        self.inner.n_residuals(topo)
    }

    fn rows_shared_by_both_terms(&self, topo: &Topology) -> std::ops::Range<usize> {
        self.inner.rows_shared_by_both_terms(topo)
    }

    fn support(&self, topo: &Topology) -> Pattern {
        self.inner.support(topo)
    }

    fn n_aux(&self) -> usize {
        self.inner.n_aux()
    }

    fn best_aux(&self, topo: &Topology, seg: &Segment) -> Vec<f64> {
        self.inner.best_aux(topo, seg)
    }

    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        self.inner.frozen_weights(topo, start, end)
    }

    fn pose_summary(&self, topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        self.inner.pose_summary(topo, pose)
    }

    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        summaries: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        self.inner.frozen_weights_from(topo, start, end, summaries)
    }

    fn residual_factors(&self, topo: &Topology, frozen: &[f64]) -> Option<Vec<f64>> {
        self.inner.residual_factors(topo, frozen)
    }

    fn unit_frozen(&self, topo: &Topology, frozen: Vec<f64>) -> Vec<f64> {
        self.inner.unit_frozen(topo, frozen)
    }

    fn residuals(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        jac: Option<JacobianMut>,
    ) {
        let s = self.weight.sqrt();
        match jac {
            None => self.inner.residuals(topo, pattern, seg, r, None),
            Some(j) => {
                let JacobianMut { da, db, daux } = j;
                self.inner.residuals(
                    topo,
                    pattern,
                    seg,
                    r,
                    Some(JacobianMut {
                        da: &mut *da,
                        db: &mut *db,
                        daux: &mut *daux,
                    }),
                );
                for d in da.iter_mut().chain(db.iter_mut()) {
                    *d = d.map(|v| v * s);
                }
                for d in daux.iter_mut() {
                    *d *= s;
                }
            }
        }
        for v in r.iter_mut() {
            *v *= s;
        }
    }

    fn gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        scratch: &mut Scratch,
        sink: &mut GradientSink,
    ) -> f64 {
        let w = sink.weight;
        sink.weight = w * self.weight;
        let v = self.inner.gradient(topo, pattern, seg, scratch, sink);
        sink.weight = w;
        v
    }

    fn segment_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        let w = sink.weight;
        sink.weight = w * self.weight;
        let v = self.inner.segment_gradient(topo, pattern, segs, scratch, sink);
        sink.weight = w;
        v
    }

    /// `sum_i (s r_i) d2(s r_i) = sum_i (s^2 r_i) d2 r_i` with `s = sqrt(weight)` and `r` this
    /// metric's (scaled) residuals: the inner metric's second-order part with its residuals
    /// replaced by `s r` (= `weight` times the inner residuals).
    fn add_second_order(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &[f64],
        sink: &mut SecondOrderSink,
    ) -> bool {
        let s = self.weight.sqrt();
        let scaled: Vec<f64> = r.iter().map(|v| v * s).collect();
        self.inner.add_second_order(topo, pattern, seg, &scaled, sink)
    }

    fn squared_norm(&self, topo: &Topology, pattern: &Pattern, seg: &Segment) -> f64 {
        self.weight * self.inner.squared_norm(topo, pattern, seg)
    }

    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        self.inner
            .segment_squared_norms(topo, pattern, segs)
            .map(|v| self.weight * v)
    }

    fn segment_bending_energy(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> f64 {
        self.weight * self.inner.segment_bending_energy(topo, pattern, segs)
    }

    fn segment_energy_parts(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        self.inner
            .segment_energy_parts(topo, pattern, segs)
            .map(|v| self.weight * v)
    }

    fn segment_norms_and_parts(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
    ) -> ([f64; 2], [f64; 2]) {
        let (norms, parts) = self.inner.segment_norms_and_parts(topo, pattern, segs);
        (norms.map(|v| self.weight * v), parts.map(|v| self.weight * v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{fdcheck, At, ConformalForm, Isometric, QcWeights, QuasiConformal, Rigid, L2};

    #[test]
    fn weighted_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&Weighted::new(Box::new(Isometric), 3.7), 11);
        fdcheck::check_metric(&Weighted::new(Box::new(Rigid), 0.25), 12);
        let qc = QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Endpoints);
        fdcheck::check_metric(&Weighted::new(Box::new(qc), 5.0), 13);
    }

    #[test]
    fn weighted_values_are_the_inner_values_times_the_weight() {
        let s = crate::synth::icosphere(1);
        let b: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| [p[0] * 1.2, p[1], p[2] + 0.1])
            .collect();
        for inner in [Box::new(L2) as Box<dyn Metric>, Box::new(Isometric)] {
            let raw = inner.segment_squared_norms(
                &s.topology,
                inner.pattern(&s.topology).as_ref(),
                [
                    &Segment {
                        a: &s.positions,
                        b: &b,
                        at: At::Start,
                        aux: &[],
                        frozen: None,
                    },
                    &Segment {
                        a: &s.positions,
                        b: &b,
                        at: At::End,
                        aux: &[],
                        frozen: None,
                    },
                ],
            );
            let w = Weighted::new(inner, 0.3);
            let pat = w.pattern(&s.topology);
            let seg = |at| Segment {
                a: &s.positions,
                b: &b,
                at,
                aux: &[],
                frozen: None,
            };
            let got = w.segment_squared_norms(&s.topology, pat.as_ref(), [&seg(At::Start), &seg(At::End)]);
            for k in 0..2 {
                assert!(
                    (got[k] - 0.3 * raw[k]).abs() <= 1e-14 * raw[k].abs(),
                    "{got:?} vs {raw:?}"
                );
                assert!(raw[k] > 0.0);
            }
        }
    }
}
