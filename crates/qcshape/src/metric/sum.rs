//! A metric plus a weighted term, `G + w T` ([`TermSum`]; [`Regularized`](super::Regularized)
//! adds the L2 term of eq. 11, [`Bent`](super::Bent) the bending term): the split of the sum's
//! pattern, frozen values and segments between its two parts, and its [`Metric`] plumbing,
//! written once. A new term implements [`Term`] and names its sum with a type alias.

use std::fmt::Debug;

use super::gradient::{GradientSink, PoseShare, Scratch, SegmentSink};
use super::kind::EnergyPart;
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::second_order::SecondOrderSink;
use super::segment::Segment;
use super::traits::Metric;
use crate::mesh::Topology;

/// A pattern made of two metrics' patterns one after the other ([`TermSum`]): the first
/// metric's rows (a prefix, rows and entries) and the second's with their offsets rebased to
/// their first entry.
struct SplitPattern<'p> {
    /// The first metric's rows.
    pub first: PatternRef<'p>,
    second_offsets: Vec<u32>,
    second_vertices: &'p [u32],
}

impl SplitPattern<'_> {
    /// The second metric's rows, rebased.
    pub fn second(&self) -> PatternRef<'_> {
        PatternRef {
            offsets: &self.second_offsets,
            vertices: self.second_vertices,
        }
    }
}

/// `pattern` split after its first `n_first` residuals ([`SplitPattern`]).
fn split_pattern(pattern: PatternRef<'_>, n_first: usize) -> SplitPattern<'_> {
    let first = first_rows(pattern, n_first);
    let e_first = first.vertices.len();
    SplitPattern {
        first,
        second_offsets: pattern.offsets[n_first..]
            .iter()
            .map(|o| o - e_first as u32)
            .collect(),
        second_vertices: &pattern.vertices[e_first..],
    }
}

/// The first `n_first` rows of `pattern` (a prefix, rows and entries), without rebasing the
/// rest.
fn first_rows(pattern: PatternRef<'_>, n_first: usize) -> PatternRef<'_> {
    PatternRef {
        offsets: &pattern.offsets[..=n_first],
        vertices: &pattern.vertices[..pattern.offsets[n_first] as usize],
    }
}

/// Two metrics' frozen values (or pose summaries) one after the other, as a sum of two metrics
/// stores them; `None` when neither has any.
fn join_frozen(first: Option<Vec<f64>>, second: Option<Vec<f64>>) -> Option<Vec<f64>> {
    match (first, second) {
        (Some(mut a), Some(b)) => {
            a.extend_from_slice(&b);
            Some(a)
        }
        (a, b) => a.or(b),
    }
}

/// The term a [`TermSum`] adds to its inner metric: a metric without auxiliary unknowns, whose
/// frozen values (and pose summaries) follow the inner metric's, and how the sum reports it.
pub trait Term: Debug + Send + Sync {
    /// The term as a metric.
    fn metric(&self) -> &dyn Metric;

    /// Number of its frozen values on `topo`, the last values of the sum's (and of its pose
    /// summary's, the last values of the sum's [`Metric::pose_summary`]).
    fn frozen_len(&self, topo: &Topology) -> usize;

    /// The energy part it is reported in.
    fn part(&self) -> EnergyPart;

    /// Whether the sum's [`Metric::pose_values`] are the term's (then the inner metric's
    /// segment gradient shares nothing with the poses) rather than the inner metric's (the
    /// default). Only one part's pose values are shared.
    fn has_pose_values(&self) -> bool {
        false
    }

    /// Whether the sum provides its second-order part ([`Metric::add_second_order`]: the inner
    /// metric's and the term's, when both have one); `false` (the default): the sum has none.
    fn has_second_order(&self) -> bool {
        false
    }

    /// Its [`Metric::segment_squared_norms`] when they need no pattern (bit for bit the same
    /// values), which spares the sum the rebased copy of the term's rows; `None` (the default)
    /// otherwise.
    fn norms_without_pattern(&self, _topo: &Topology, _segs: [&Segment; 2]) -> Option<[f64; 2]> {
        None
    }
}

/// `G + weight * T`: the inner metric's residuals followed by `sqrt(weight)` times the term's
/// ([`Term`]). Frozen values (and pose summaries): the inner metric's, then the term's (its
/// last [`Term::frozen_len`] values). The term has no auxiliary unknowns; its energy is reported
/// in its [`Term::part`].
#[derive(Debug)]
pub struct TermSum<T> {
    /// The metric the term is added to.
    pub inner: Box<dyn Metric>,
    /// Weight `>= 0` of the term (a negative weight counts as 0).
    pub weight: f64,
    /// The added term.
    pub term: T,
}

impl<T: Term> TermSum<T> {
    /// `inner + weight * term`.
    pub fn of(inner: Box<dyn Metric>, weight: f64, term: T) -> Self {
        TermSum { inner, weight, term }
    }

    /// `weight T` of both terms of a segment (eq. 12's two terms summed): the term's part of
    /// [`Metric::segment_squared_norms`]. `pattern` is this metric's.
    pub fn term_energy(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> f64 {
        let (t0, t1) = (self.segments(topo, segs[0]).1, self.segments(topo, segs[1]).1);
        let [v0, v1] = self.term_norms(topo, pattern, [&t0, &t1]);
        self.weight() * (v0 + v1)
    }

    /// The weight, negative weights counting as 0.
    fn weight(&self) -> f64 {
        self.weight.max(0.0)
    }

    /// The inner metric's rows of `pattern` and the term's ([`split_pattern`]).
    fn parts<'p>(&self, topo: &Topology, pattern: PatternRef<'p>) -> SplitPattern<'p> {
        split_pattern(pattern, self.inner.n_residuals(topo))
    }

    /// The inner metric's rows of `pattern` (its prefix), without the term's.
    fn inner_rows<'p>(&self, topo: &Topology, pattern: PatternRef<'p>) -> PatternRef<'p> {
        first_rows(pattern, self.inner.n_residuals(topo))
    }

    /// Splits a frozen array into the inner metric's part and the term's (its last
    /// [`Term::frozen_len`] values); all of it is the inner metric's when it is shorter than
    /// that, and an empty part is `None`.
    pub(crate) fn split_frozen<'a>(
        &self,
        topo: &Topology,
        frozen: Option<&'a [f64]>,
    ) -> (Option<&'a [f64]>, Option<&'a [f64]>) {
        let Some(f) = frozen else { return (None, None) };
        let nt = self.term.frozen_len(topo);
        if f.len() < nt {
            return (Some(f), None);
        }
        let (a, b) = f.split_at(f.len() - nt);
        ((!a.is_empty()).then_some(a), (!b.is_empty()).then_some(b))
    }

    /// The segment as seen by the inner metric and by the term (each with its own frozen
    /// values; the term's without auxiliary unknowns).
    fn segments<'a>(&self, topo: &Topology, seg: &Segment<'a>) -> (Segment<'a>, Segment<'a>) {
        let (fi, ft) = self.split_frozen(topo, seg.frozen);
        (
            Segment { frozen: fi, ..*seg },
            Segment {
                frozen: ft,
                aux: &[],
                ..*seg
            },
        )
    }

    /// The term's [`Metric::segment_squared_norms`] (unweighted) of the term's segments `segs`.
    fn term_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        match self.term.norms_without_pattern(topo, segs) {
            Some(v) => v,
            None => {
                let parts = self.parts(topo, pattern);
                self.term
                    .metric()
                    .segment_squared_norms(topo, parts.second(), segs)
            }
        }
    }

    /// Both terms of a segment for the inner metric and for `weight * T`, each by its own
    /// (value-only where available) pass.
    fn parts_values(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
    ) -> ([f64; 2], [f64; 2]) {
        let ((s0, t0), (s1, t1)) = (self.segments(topo, segs[0]), self.segments(topo, segs[1]));
        let v_in = self
            .inner
            .segment_squared_norms(topo, self.inner_rows(topo, pattern), [&s0, &s1]);
        let v_t = self.term_norms(topo, pattern, [&t0, &t1]);
        let w = self.weight();
        (v_in, v_t.map(|v| w * v))
    }
}

impl<T: Term> Metric for TermSum<T> {
    fn name(&self) -> String {
        format!(
            "{}+{}*{}",
            self.inner.name(),
            self.weight,
            self.term.metric().name()
        )
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        let mut p = self.inner.pattern(topo);
        p.append(&self.term.metric().pattern(topo));
        p
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        self.inner.n_residuals(topo) + self.term.metric().n_residuals(topo)
    }

    /// The term's shared rows (after the inner metric's) if it has any, else the inner
    /// metric's.
    fn rows_shared_by_both_terms(&self, topo: &Topology) -> std::ops::Range<usize> {
        let term = self.term.metric().rows_shared_by_both_terms(topo);
        if term.is_empty() {
            return self.inner.rows_shared_by_both_terms(topo);
        }
        let n_in = self.inner.n_residuals(topo);
        n_in + term.start..n_in + term.end
    }

    fn support(&self, topo: &Topology) -> Pattern {
        let mut p = self.inner.support(topo);
        p.append(&self.term.metric().support(topo));
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
            self.term.metric().frozen_weights(topo, start, end),
        )
    }

    /// The inner metric's summary followed by the term's, split again by
    /// [`Metric::frozen_weights_from`].
    fn pose_summary(&self, topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        join_frozen(
            self.inner.pose_summary(topo, pose),
            self.term.metric().pose_summary(topo, pose),
        )
    }

    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        [sa, sb]: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        // The same split as the frozen values: the term's are the last values.
        let ((ia, ta), (ib, tb)) = (
            self.split_frozen(topo, Some(sa)),
            self.split_frozen(topo, Some(sb)),
        );
        let inner = match (ia, ib) {
            (Some(a), Some(b)) => self.inner.frozen_weights_from(topo, start, end, [a, b]),
            _ => self.inner.frozen_weights(topo, start, end),
        };
        let term = self.term.metric();
        let term = match (ta, tb) {
            (Some(a), Some(b)) => term.frozen_weights_from(topo, start, end, [a, b]),
            _ => term.frozen_weights(topo, start, end),
        };
        join_frozen(inner, term)
    }

    /// The inner metric's factors, then 1 for every residual of the term (its frozen values
    /// are not factors of a pair-dependent weight).
    fn residual_factors(&self, topo: &Topology, frozen: &[f64]) -> Option<Vec<f64>> {
        let (inner, _) = self.split_frozen(topo, Some(frozen));
        let mut f = self.inner.residual_factors(topo, inner?)?;
        f.resize(f.len() + self.term.metric().n_residuals(topo), 1.0);
        Some(f)
    }

    /// The inner metric's part set to one ([`Metric::unit_frozen`]), the term's unchanged.
    fn unit_frozen(&self, topo: &Topology, frozen: Vec<f64>) -> Vec<f64> {
        match self.split_frozen(topo, Some(&frozen)) {
            (Some(inner), term) => join_frozen(
                Some(self.inner.unit_frozen(topo, inner.to_vec())),
                term.map(<[f64]>::to_vec),
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
        let parts = self.parts(topo, pattern);
        let (ip, tp) = (parts.first, parts.second());
        let (si, st) = self.segments(topo, seg);
        let (n_in, e_in) = (ip.n_residuals(), ip.vertices.len());
        let (r_in, r_t) = r.split_at_mut(n_in);
        let sw = self.weight().sqrt();
        let term = self.term.metric();
        match jac {
            None => {
                self.inner.residuals(topo, ip, &si, r_in, None);
                term.residuals(topo, tp, &st, r_t, None);
            }
            Some(j) => {
                let (da_in, da_t) = j.da.split_at_mut(e_in);
                let (db_in, db_t) = j.db.split_at_mut(e_in);
                let n_aux = self.inner.n_aux();
                let (daux_in, daux_t) = j.daux.split_at_mut(n_in * n_aux);
                let ji = JacobianMut {
                    da: da_in,
                    db: db_in,
                    daux: daux_in,
                };
                self.inner.residuals(topo, ip, &si, r_in, Some(ji));
                let jt = JacobianMut {
                    da: da_t,
                    db: db_t,
                    daux: &mut [],
                };
                term.residuals(topo, tp, &st, r_t, Some(jt));
                for d in da_t.iter_mut().chain(db_t.iter_mut()) {
                    *d = d.map(|v| v * sw);
                }
                // The term does not depend on the auxiliary unknowns.
                daux_t.fill(0.0);
            }
        }
        for v in r_t.iter_mut() {
            *v *= sw;
        }
    }

    /// The inner metric's gradient plus `weight` times the term's (residuals scaled by
    /// `sqrt(weight)`), each by its own (fused where available) kernel.
    fn gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        scratch: &mut Scratch,
        sink: &mut GradientSink,
    ) -> f64 {
        let parts = self.parts(topo, pattern);
        let (si, st) = self.segments(topo, seg);
        let v_in = self.inner.gradient(topo, parts.first, &si, scratch, sink);
        // The term does not depend on the auxiliary unknowns: no aux gradient.
        let mut no_aux = GradientSink {
            ga: &mut *sink.ga,
            gb: &mut *sink.gb,
            gaux: &mut [],
            weight: sink.weight * self.weight(),
        };
        v_in + self
            .term
            .metric()
            .gradient(topo, parts.second(), &st, scratch, &mut no_aux)
    }

    fn segment_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        let (mut ua, mut ub) = (Vec::new(), Vec::new());
        let share = PoseShare::none([&mut ua, &mut ub]);
        self.segment_gradient_with(topo, pattern, segs, share, scratch, sink)
    }

    /// The term's when it has pose values ([`Term::has_pose_values`]), else the inner
    /// metric's.
    fn pose_values(&self, topo: &Topology, pattern: PatternRef, pose: &[[f64; 3]], out: &mut Vec<f64>) {
        if self.term.has_pose_values() {
            let parts = self.parts(topo, pattern);
            self.term.metric().pose_values(topo, parts.second(), pose, out);
        } else {
            self.inner
                .pose_values(topo, self.inner_rows(topo, pattern), pose, out);
        }
    }

    /// The term's when it has pose values (the coefficients carry the weight), else the inner
    /// metric's.
    fn pose_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        pose: &[[f64; 3]],
        values: &[f64],
        coeffs: &[f64],
        g: &mut [[f64; 3]],
    ) {
        if self.term.has_pose_values() {
            let parts = self.parts(topo, pattern);
            self.term
                .metric()
                .pose_gradient(topo, parts.second(), pose, values, coeffs, g);
        } else {
            self.inner
                .pose_gradient(topo, self.inner_rows(topo, pattern), pose, values, coeffs, g);
        }
    }

    /// The inner metric's segment gradient, then `weight` times the term's; `share` goes to the
    /// part whose pose values the sum's are ([`Metric::pose_values`]).
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
        let ((s0, t0), (s1, t1)) = (self.segments(topo, segs[0]), self.segments(topo, segs[1]));
        let (share_in, share_t) = if self.term.has_pose_values() {
            (None, Some(share))
        } else {
            (Some(share), None)
        };
        let v_in = match share_in {
            Some(share) => {
                self.inner
                    .segment_gradient_with(topo, parts.first, [&s0, &s1], share, scratch, sink)
            }
            None => self
                .inner
                .segment_gradient(topo, parts.first, [&s0, &s1], scratch, sink),
        };
        // The term does not depend on the auxiliary unknowns: no aux gradient.
        let mut no_aux = SegmentSink {
            ga: &mut *sink.ga,
            gb: &mut *sink.gb,
            gaux: &mut [],
            weight: sink.weight * self.weight(),
        };
        let term = self.term.metric();
        let v_t = match share_t {
            Some(share) => {
                term.segment_gradient_with(topo, parts.second(), [&t0, &t1], share, scratch, &mut no_aux)
            }
            None => term.segment_gradient(topo, parts.second(), [&t0, &t1], scratch, &mut no_aux),
        };
        v_in + v_t
    }

    /// The inner metric's values plus `weight` times the term's, each by its own (value-only
    /// where available) pass.
    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        let (v_in, v_t) = self.parts_values(topo, pattern, segs);
        [v_in[0] + v_t[0], v_in[1] + v_t[1]]
    }

    /// A regularizer: `[inner, weight * T]`, each summed over the segment's two terms. A
    /// bending term: everything geometric.
    fn segment_energy_parts(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        self.segment_norms_and_parts(topo, pattern, segs).1
    }

    /// The inner metric's bending part, plus `weight * T` when the term is a bending term
    /// ([`TermSum::term_energy`]).
    fn segment_bending_energy(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> f64 {
        let ((s0, _), (s1, _)) = (self.segments(topo, segs[0]), self.segments(topo, segs[1]));
        let inner = self
            .inner
            .segment_bending_energy(topo, self.inner_rows(topo, pattern), [&s0, &s1]);
        match self.term.part() {
            EnergyPart::Geometric | EnergyPart::Regularizer => inner,
            EnergyPart::Bending => inner + self.term_energy(topo, pattern, segs),
        }
    }

    /// Both of the above from one pass over the two parts.
    fn segment_norms_and_parts(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
    ) -> ([f64; 2], [f64; 2]) {
        let (v_in, v_t) = self.parts_values(topo, pattern, segs);
        let norms = [v_in[0] + v_t[0], v_in[1] + v_t[1]];
        let parts = match self.term.part() {
            EnergyPart::Regularizer => [v_in[0] + v_in[1], v_t[0] + v_t[1]],
            EnergyPart::Geometric | EnergyPart::Bending => [norms[0] + norms[1], 0.0],
        };
        (norms, parts)
    }

    /// The inner metric's part (its residuals are the first rows) and the term's, when the term
    /// provides one ([`Term::has_second_order`]) and the inner metric does; otherwise nothing
    /// (`false`, the solvers keep the Gauss-Newton model `J^T J`).
    fn add_second_order(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &[f64],
        sink: &mut SecondOrderSink,
    ) -> bool {
        if !self.term.has_second_order() {
            return false;
        }
        let parts = self.parts(topo, pattern);
        let (si, st) = self.segments(topo, seg);
        let n_in = parts.first.n_residuals();
        self.inner
            .add_second_order(topo, parts.first, &si, &r[..n_in], sink)
            && self
                .term
                .metric()
                .add_second_order(topo, parts.second(), &st, &r[n_in..], sink)
    }
}
