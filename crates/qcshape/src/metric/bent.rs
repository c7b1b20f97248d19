//! A membrane metric plus the bending term ([`Bent`]).

use super::gradient::{GradientSink, PoseShare, Scratch, SegmentSink};
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::relative::{RelativeBending, PER_FACE};
use super::second_order::SecondOrderSink;
use super::segment::Segment;
use super::sum::{join_frozen, split_pattern, SplitPattern};
use super::traits::Metric;
use crate::mesh::Topology;

/// `G + beta * B`: a membrane metric `G` (the invariant isometric, conformal or quasi-conformal
/// form) followed by `sqrt(beta)` times the residuals of the bending term `B`
/// ([`RelativeBending`], docs/method.md "Bending term"), which charges the change of
/// the dihedral angles that the membrane terms see only through the curvature. Dimensionless
/// and scale-invariant like its parts. Frozen values: the inner metric's, then the bending
/// term's face values (2 #F). [`Metric::segment_energy_parts`] counts the bending term as
/// geometric; [`Bent::bending_energy`] gives its part alone.
#[derive(Debug)]
pub struct Bent {
    /// The membrane metric.
    pub inner: Box<dyn Metric>,
    /// Weight `beta > 0` of the bending term.
    pub beta: f64,
}

impl Bent {
    /// `inner + beta * B`.
    pub fn new(inner: Box<dyn Metric>, beta: f64) -> Self {
        Bent { inner, beta }
    }

    fn sb(&self) -> f64 {
        self.beta.max(0.0).sqrt()
    }

    /// The inner rows of `pattern` and the bending rows ([`split_pattern`]).
    fn parts<'p>(&self, topo: &Topology, pattern: PatternRef<'p>) -> SplitPattern<'p> {
        split_pattern(pattern, self.inner.n_residuals(topo))
    }

    /// The segment as seen by the inner metric and by the bending term.
    fn segments<'a>(&self, topo: &Topology, seg: &Segment<'a>) -> (Segment<'a>, Segment<'a>) {
        let nb = PER_FACE * topo.n_faces();
        let (fi, fb) = match seg.frozen {
            Some(f) if f.len() >= nb => {
                let (a, b) = f.split_at(f.len() - nb);
                ((!a.is_empty()).then_some(a), Some(b))
            }
            other => (other, None),
        };
        (
            Segment { frozen: fi, ..*seg },
            Segment {
                frozen: fb,
                aux: &[],
                ..*seg
            },
        )
    }

    /// `beta B` of both terms of a segment (eq. 12's two terms summed): the bending term's part
    /// of [`Metric::segment_squared_norms`]. `pattern` is this metric's.
    pub fn bending_energy(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> f64 {
        let parts = self.parts(topo, pattern);
        let bp = parts.second();
        let (b0, b1) = (self.segments(topo, segs[0]).1, self.segments(topo, segs[1]).1);
        let [v0, v1] = RelativeBending.segment_squared_norms(topo, bp, [&b0, &b1]);
        self.beta * (v0 + v1)
    }
}

impl Metric for Bent {
    fn name(&self) -> String {
        format!("{}+{}*{}", self.inner.name(), self.beta, RelativeBending.name())
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        let mut p = self.inner.pattern(topo);
        p.append(&RelativeBending.pattern(topo));
        p
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        self.inner.n_residuals(topo) + RelativeBending.n_residuals(topo)
    }

    fn support(&self, topo: &Topology) -> Pattern {
        let mut p = self.inner.support(topo);
        p.append(&RelativeBending.support(topo));
        p
    }

    fn n_aux(&self) -> usize {
        self.inner.n_aux()
    }

    fn best_aux(&self, topo: &Topology, seg: &Segment) -> Vec<f64> {
        self.inner.best_aux(topo, &self.segments(topo, seg).0)
    }

    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        join_frozen(
            self.inner.frozen_weights(topo, start, end),
            RelativeBending.frozen_weights(topo, start, end),
        )
    }

    fn pose_summary(&self, topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        join_frozen(
            self.inner.pose_summary(topo, pose),
            RelativeBending.pose_summary(topo, pose),
        )
    }

    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        [sa, sb]: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        let nb = PER_FACE * topo.n_faces();
        if sa.len() < nb || sb.len() < nb {
            return self.frozen_weights(topo, start, end);
        }
        let (ia, ba) = sa.split_at(sa.len() - nb);
        let (ib, bb) = sb.split_at(sb.len() - nb);
        let inner = if ia.is_empty() || ib.is_empty() {
            self.inner.frozen_weights(topo, start, end)
        } else {
            self.inner.frozen_weights_from(topo, start, end, [ia, ib])
        };
        join_frozen(
            inner,
            RelativeBending.frozen_weights_from(topo, start, end, [ba, bb]),
        )
    }

    /// The inner metric's factors, then 1 for every bending residual.
    fn residual_factors(&self, topo: &Topology, frozen: &[f64]) -> Option<Vec<f64>> {
        let seg_frozen = self.split(topo, frozen).0?;
        let mut f = self.inner.residual_factors(topo, seg_frozen)?;
        f.resize(f.len() + RelativeBending.n_residuals(topo), 1.0);
        Some(f)
    }

    fn unit_frozen(&self, topo: &Topology, frozen: Vec<f64>) -> Vec<f64> {
        match self.split(topo, &frozen) {
            (Some(inner), Some(bend)) => {
                let mut out = self.inner.unit_frozen(topo, inner.to_vec());
                out.extend_from_slice(bend);
                out
            }
            _ => frozen,
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
        let parts = self.parts(topo, pattern);
        let (ip, bp) = (parts.first, parts.second());
        let (si, sbend) = self.segments(topo, seg);
        let (n_in, e_in) = (ip.n_residuals(), ip.vertices.len());
        let (r_in, r_b) = r.split_at_mut(n_in);
        let sb = self.sb();
        match jac {
            None => {
                self.inner.residuals(topo, ip, &si, r_in, None);
                RelativeBending.residuals(topo, bp, &sbend, r_b, None);
            }
            Some(j) => {
                let (da_in, da_b) = j.da.split_at_mut(e_in);
                let (db_in, db_b) = j.db.split_at_mut(e_in);
                let n_aux = self.inner.n_aux();
                let (daux_in, daux_b) = j.daux.split_at_mut(n_in * n_aux);
                let ji = JacobianMut {
                    da: da_in,
                    db: db_in,
                    daux: daux_in,
                };
                self.inner.residuals(topo, ip, &si, r_in, Some(ji));
                let jb = JacobianMut {
                    da: da_b,
                    db: db_b,
                    daux: &mut [],
                };
                RelativeBending.residuals(topo, bp, &sbend, r_b, Some(jb));
                for d in da_b.iter_mut().chain(db_b.iter_mut()) {
                    *d = d.map(|v| v * sb);
                }
                daux_b.fill(0.0);
            }
        }
        for v in r_b.iter_mut() {
            *v *= sb;
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
        let parts = self.parts(topo, pattern);
        let (ip, bp) = (parts.first, parts.second());
        let (si, sbend) = self.segments(topo, seg);
        let v_in = self.inner.gradient(topo, ip, &si, scratch, sink);
        let mut no_aux = GradientSink {
            ga: &mut *sink.ga,
            gb: &mut *sink.gb,
            gaux: &mut [],
            weight: sink.weight * self.beta.max(0.0),
        };
        v_in + RelativeBending.gradient(topo, bp, &sbend, scratch, &mut no_aux)
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

    /// The bending term's ([`RelativeBending::pose_values`]; the membrane metrics have none).
    fn pose_values(&self, topo: &Topology, pattern: PatternRef, pose: &[[f64; 3]], out: &mut Vec<f64>) {
        RelativeBending.pose_values(topo, self.parts(topo, pattern).second(), pose, out);
    }

    /// The bending term's (the coefficients carry `beta`).
    fn pose_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        pose: &[[f64; 3]],
        coeffs: &[f64],
        g: &mut [[f64; 3]],
    ) {
        RelativeBending.pose_gradient(topo, self.parts(topo, pattern).second(), pose, coeffs, g);
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
        let parts = self.parts(topo, pattern);
        let (ip, bp) = (parts.first, parts.second());
        let ((s0, b0), (s1, b1)) = (self.segments(topo, segs[0]), self.segments(topo, segs[1]));
        let v_in = self.inner.segment_gradient(topo, ip, [&s0, &s1], scratch, sink);
        let mut no_aux = SegmentSink {
            ga: &mut *sink.ga,
            gb: &mut *sink.gb,
            gaux: &mut [],
            weight: sink.weight * self.beta.max(0.0),
        };
        v_in + RelativeBending.segment_gradient_with(topo, bp, [&b0, &b1], share, scratch, &mut no_aux)
    }

    fn segment_bending_energy(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> f64 {
        self.bending_energy(topo, pattern, segs)
    }

    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        let parts = self.parts(topo, pattern);
        let (ip, bp) = (parts.first, parts.second());
        let ((s0, b0), (s1, b1)) = (self.segments(topo, segs[0]), self.segments(topo, segs[1]));
        let v_in = self.inner.segment_squared_norms(topo, ip, [&s0, &s1]);
        let v_b = RelativeBending.segment_squared_norms(topo, bp, [&b0, &b1]);
        [v_in[0] + self.beta * v_b[0], v_in[1] + self.beta * v_b[1]]
    }

    /// The bending term's second-order part (third derivatives of the dihedral angles) is not
    /// provided, so neither is the sum's: the solvers keep the Gauss-Newton model `J^T J`.
    fn add_second_order(
        &self,
        _topo: &Topology,
        _pattern: PatternRef,
        _seg: &Segment,
        _r: &[f64],
        _sink: &mut SecondOrderSink,
    ) -> bool {
        false
    }
}

impl Bent {
    /// Splits a frozen array into the inner metric's values and the bending term's (its last
    /// 2 #F).
    fn split<'a>(&self, topo: &Topology, frozen: &'a [f64]) -> (Option<&'a [f64]>, Option<&'a [f64]>) {
        let nb = PER_FACE * topo.n_faces();
        if frozen.len() < nb {
            return (Some(frozen), None);
        }
        let (a, b) = frozen.split_at(frozen.len() - nb);
        ((!a.is_empty()).then_some(a), Some(b))
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
