//! The [`Metric`] trait: a shape-space metric as a sum of squared residuals on a path segment,
//! with exact sparse Jacobians, and the generic forms its default methods go through.

use std::fmt::Debug;

use super::gradient::{GradientSink, PoseShare, Scratch, SegmentSink};
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::second_order::SecondOrderSink;
use super::segment::Segment;
use crate::mesh::Topology;

/// A shape-space metric as a sum of squared residuals with exact sparse Jacobians.
///
/// Implementations compute residuals and derivatives from the same intermediates, and each has
/// a finite-difference test beside it.
pub trait Metric: Send + Sync + Debug {
    /// Short name with variant, e.g. `"quasi-conformal(quadratic,endpoints)"`.
    fn name(&self) -> String;

    /// Jacobian sparsity on `topo` (build once per topology and reuse).
    fn pattern(&self, topo: &Topology) -> Pattern;

    /// Number of residuals on `topo` (cheap; equals `pattern(topo).n_residuals()`).
    fn n_residuals(&self, topo: &Topology) -> usize;

    /// The residual rows whose values and derivatives are the same in both terms of a segment
    /// (eq. 12's `G_{P_i}(X_i)` at `At::Start` and `G_{P_{i+1}}(X_i)` at `At::End`) when both
    /// carry the same frozen values, as the path energy's do: the bending term's, a change of
    /// the angles from `a` to `b` whichever pose measures it. The Gauss-Newton assembly
    /// counts these rows' `J^T J` once, doubled, instead of once per term. Empty (the default)
    /// where the terms differ.
    fn rows_shared_by_both_terms(&self, _topo: &Topology) -> std::ops::Range<usize> {
        0..0
    }

    /// The mesh element each residual belongs to, as a pattern with one row per residual: the
    /// vertices of its face (triangle terms), edge (edge terms) or vertex (per-vertex terms).
    /// `qcshape_studies::contribution` splits each squared residual equally among its row's vertices.
    /// The default is [`Metric::pattern`], which is that element for every metric whose
    /// residuals depend only on their own element; metrics whose Jacobian reaches further
    /// (curvature weights of the quasi-conformal `segment` reading depend on one-rings)
    /// override it with the element itself.
    fn support(&self, topo: &Topology) -> Pattern {
        self.pattern(topo)
    }

    /// Number of auxiliary unknowns per segment term (6 for [`Rigid`](super::Rigid), else 0). They are
    /// optimized together with the path, `G(X) = min_aux |r(X, aux)|^2`.
    fn n_aux(&self) -> usize {
        0
    }

    /// Optimal auxiliary unknowns for a segment with the others fixed (the start value for the
    /// solvers and the value used when measuring lengths). Empty when [`Metric::n_aux`] is 0.
    fn best_aux(&self, _topo: &Topology, _seg: &Segment) -> Vec<f64> {
        Vec::new()
    }

    /// Per-vertex weights that stay fixed along a path from `start` to `end` (the
    /// quasi-conformal `endpoints` reading: `K(end) - K(start)`); `None` otherwise.
    fn frozen_weights(&self, _topo: &Topology, _start: &[[f64; 3]], _end: &[[f64; 3]]) -> Option<Vec<f64>> {
        None
    }

    /// What [`Metric::frozen_weights`] computes from one end pose alone (#V x 3 -> #V values:
    /// the quasi-conformal angle defects), so that a caller comparing many pairs of the same
    /// poses computes it once per pose; `None` (the default) when there is nothing worth
    /// keeping.
    fn pose_summary(&self, _topo: &Topology, _pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        None
    }

    /// The factor each residual (pattern order) takes from the frozen weights `frozen` (as
    /// [`Metric::frozen_weights`] returns them), for metrics whose residuals are such a factor
    /// times a term that does not depend on the weights: the quasi-conformal `endpoints`
    /// weights of the quadratic form (the residual of the corner at `v` is `w_v T_v`, eq. 10).
    /// With [`Metric::unit_frozen`] it lets the tangent approximation linearize the unweighted
    /// terms once at the base and weigh them per pair. `None` (the default): the residuals
    /// carry no such factors (or the weights do not enter as factors, as in the paper form).
    fn residual_factors(&self, _topo: &Topology, _frozen: &[f64]) -> Option<Vec<f64>> {
        None
    }

    /// `frozen` with the weights that [`Metric::residual_factors`] reads set to one (every
    /// factor 1) and every other frozen value (the L2 regularizer's areas) unchanged; the
    /// default returns `frozen` as it is.
    fn unit_frozen(&self, _topo: &Topology, frozen: Vec<f64>) -> Vec<f64> {
        frozen
    }

    /// [`Metric::frozen_weights`] of `start`, `end` given their [`Metric::pose_summary`]
    /// values (bit for bit the same weights). The default ignores the summaries.
    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        _summaries: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        self.frozen_weights(topo, start, end)
    }

    /// Evaluates the residuals `r` (length `pattern.n_residuals()`) of `G_M(b - a)` with `M` the
    /// end chosen by `seg.at`, and, if `jac` is given, their Jacobian in pattern order. Every
    /// Jacobian value of the metric's entries is written (the caller need not zero them).
    fn residuals(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        jac: Option<JacobianMut>,
    );

    /// `weight |r|^2` of the segment term, adding its gradient `weight * 2 J^T r` (with
    /// respect to `a`, `b` and the auxiliary unknowns) into `sink` (eq. 12's gradient, one
    /// term). The default goes through [`Metric::residuals`] and the stored Jacobian
    /// ([`gradient_from_jacobian`]); metrics override it with a fused kernel that never stores
    /// the Jacobian. `scratch` is grown as needed ([`Scratch::reserve`]).
    fn gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        scratch: &mut Scratch,
        sink: &mut GradientSink,
    ) -> f64 {
        gradient_from_jacobian(self, topo, pattern, seg, scratch, sink)
    }

    /// [`Metric::gradient`] of both terms of a segment (eq. 12 sums `G_{P_k}` and
    /// `G_{P_{k+1}}` of the same displacement): `segs[0]` at `At::Start`, `segs[1]` at
    /// `At::End`, on the same poses. The default makes one call per term
    /// ([`segment_gradient_per_term`]); metrics whose two terms share per-element work
    /// (edges, displacements) override it with one fused pass.
    fn segment_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        segment_gradient_per_term(self, topo, pattern, segs, scratch, sink)
    }

    /// Values of one pose that the terms of both segments at that pose share (the bending
    /// term's dihedral angles and sliver factors, [`RelativeBending`](super::RelativeBending)), written to `out`: the
    /// path energy computes them once per pose and evaluation and passes them to
    /// [`Metric::segment_gradient_with`]. Left empty (the default) by metrics without any.
    /// `pattern` is this metric's, `pose` #V x 3.
    fn pose_values(&self, _topo: &Topology, _pattern: PatternRef, _pose: &[[f64; 3]], out: &mut Vec<f64>) {
        out.clear();
    }

    /// [`Metric::segment_gradient`] in the path energy's three passes. With the
    /// [`Metric::pose_values`] of the segment's poses `a` and `b` in `share` (non-empty), it
    /// returns the same value, adds to `sink` the gradient of every part that has no pose
    /// values, and writes to `share`'s coefficients those from which [`Metric::pose_gradient`]
    /// gives the rest at each pose, once the coefficients of the pose's two segments are
    /// summed. With empty values it is [`Metric::segment_gradient`] (the default, whatever
    /// `share`).
    fn segment_gradient_with(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        _share: PoseShare,
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        self.segment_gradient(topo, pattern, segs, scratch, sink)
    }

    /// Adds to `g` (#V x 3) the gradient at `pose` of the parts with pose values, from the
    /// pose's own [`Metric::pose_values`] `values` and the summed coefficients `coeffs` of
    /// [`Metric::segment_gradient_with`]. Nothing (the default) for metrics without pose values.
    fn pose_gradient(
        &self,
        _topo: &Topology,
        _pattern: PatternRef,
        _pose: &[[f64; 3]],
        _values: &[f64],
        _coeffs: &[f64],
        _g: &mut [[f64; 3]],
    ) {
    }

    /// Second-order part of the Hessian of `|r|^2 / 2`: adds `sum_i r_i d2 r_i` (second
    /// derivatives of the residuals with respect to `a` and `b`, weighted by the residuals `r`
    /// of the same segment from [`Metric::residuals`]) into `sink`. Together with `J^T J` this
    /// is the exact Hessian used by Newton's method (eq. 12's energy is a sum of such terms).
    /// Returns `false`, adding nothing, for metrics that do not provide it (non-smooth forms,
    /// auxiliary unknowns, weights depending on the unknowns): the solver then keeps the
    /// Gauss-Newton model `J^T J`.
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

    /// The squared norm `G_M(X) = |r|^2` of the segment (with the optimal auxiliary unknowns).
    fn squared_norm(&self, topo: &Topology, pattern: &Pattern, seg: &Segment) -> f64 {
        squared_norm_from_residuals(self, topo, pattern.as_ref(), seg)
    }

    /// Both terms of a segment's squared norm, `[G_a(b - a), G_b(b - a)]` (eq. 12's two terms
    /// of one segment; `segs[0]` at `At::Start`, `segs[1]` at `At::End`, on the same poses,
    /// each with its frozen weights), with the optimal auxiliary unknowns: the straight-path
    /// length (eq. 13 on the linear path) needs nothing else. The default evaluates the
    /// residuals of each term; metrics override it with one value-only pass that stores
    /// neither residuals nor Jacobian (same values to rounding: checked by every metric's
    /// finite-difference test, `fdcheck::check_values`).
    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        segs.map(|seg| squared_norm_from_residuals(self, topo, pattern, seg))
    }

    /// [`Metric::segment_squared_norms`] split into the geometric term and the L2 regularizer of
    /// eq. 11 ([`Regularized`](super::Regularized)): `[geometric, regularizer]`, each the sum of
    /// the segment's two terms, adding up to theirs (to rounding). The default: everything is
    /// geometric.
    fn segment_energy_parts(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        let [g0, g1] = self.segment_squared_norms(topo, pattern, segs);
        [g0 + g1, 0.0]
    }

    /// The bending term's part of [`Metric::segment_squared_norms`] (both terms of the segment
    /// summed; [`Bent::bending_energy`](super::Bent::bending_energy)): 0 for metrics without one.
    /// Counted as geometric by [`Metric::segment_energy_parts`].
    fn segment_bending_energy(&self, _topo: &Topology, _pattern: PatternRef, _segs: [&Segment; 2]) -> f64 {
        0.0
    }

    /// [`Metric::segment_squared_norms`] and [`Metric::segment_energy_parts`] of one segment
    /// in one pass, bit for bit the values of the two calls (the straight-path length and its
    /// energy split, `similarity --approx straight`, without evaluating the metric twice). The
    /// default is right for metrics that keep the default [`Metric::segment_energy_parts`]
    /// (everything geometric); a metric that overrides that one overrides this one too.
    fn segment_norms_and_parts(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
    ) -> ([f64; 2], [f64; 2]) {
        let [g0, g1] = self.segment_squared_norms(topo, pattern, segs);
        ([g0, g1], [g0 + g1, 0.0])
    }
}

/// `|r|^2` of one segment term from [`Metric::residuals`] (with the optimal auxiliary
/// unknowns): the default of [`Metric::squared_norm`] and [`Metric::segment_squared_norms`].
pub fn squared_norm_from_residuals<M: Metric + ?Sized>(
    metric: &M,
    topo: &Topology,
    pattern: PatternRef,
    seg: &Segment,
) -> f64 {
    residuals_at_best_aux(metric, topo, pattern, seg)
        .iter()
        .map(|x| x * x)
        .sum()
}

/// The residuals `r` (length `pattern.n_residuals()`) of one segment term with the auxiliary
/// unknowns at [`Metric::best_aux`] (when the metric has any).
pub fn residuals_at_best_aux<M: Metric + ?Sized>(
    metric: &M,
    topo: &Topology,
    pattern: PatternRef,
    seg: &Segment,
) -> Vec<f64> {
    let aux;
    let seg = if metric.n_aux() > 0 {
        aux = metric.best_aux(topo, seg);
        Segment { aux: &aux, ..*seg }
    } else {
        *seg
    };
    let mut r = vec![0.0; pattern.n_residuals()];
    metric.residuals(topo, pattern, &seg, &mut r, None);
    r
}

/// [`Metric::segment_gradient`] as two calls to [`Metric::gradient`], one per term.
pub fn segment_gradient_per_term<M: Metric + ?Sized>(
    metric: &M,
    topo: &Topology,
    pattern: PatternRef,
    segs: [&Segment; 2],
    scratch: &mut Scratch,
    sink: &mut SegmentSink,
) -> f64 {
    let n_aux = metric.n_aux();
    let mut value = 0.0;
    for (k, seg) in segs.into_iter().enumerate() {
        let mut term = GradientSink {
            ga: &mut *sink.ga,
            gb: &mut *sink.gb,
            gaux: &mut sink.gaux[k * n_aux..(k + 1) * n_aux],
            weight: sink.weight,
        };
        value += metric.gradient(topo, pattern, seg, scratch, &mut term);
    }
    value
}

/// [`Metric::gradient`] through the stored Jacobian: residuals and Jacobian into `scratch`
/// (grown to `pattern`'s residuals and entries on first use), then `weight * 2 J^T r` into
/// `sink`. Returns `weight |r|^2`.
pub fn gradient_from_jacobian<M: Metric + ?Sized>(
    metric: &M,
    topo: &Topology,
    pattern: PatternRef,
    seg: &Segment,
    scratch: &mut Scratch,
    sink: &mut GradientSink,
) -> f64 {
    let n_res = pattern.n_residuals();
    let n_ent = pattern.offsets.last().map_or(0, |&o| o as usize);
    let n_aux = metric.n_aux();
    scratch.reserve(n_res, n_ent, n_aux);
    let r = &mut scratch.r[..n_res];
    let jac = JacobianMut {
        da: &mut scratch.jac.da[..n_ent],
        db: &mut scratch.jac.db[..n_ent],
        daux: &mut scratch.jac.daux[..n_res * n_aux],
    };
    metric.residuals(topo, pattern, seg, r, Some(jac));
    let (da, db, daux) = (&scratch.jac.da, &scratch.jac.db, &scratch.jac.daux);
    let mut value = 0.0;
    for (i, (w, &ri)) in pattern.offsets.windows(2).zip(r.iter()).enumerate() {
        value += ri * ri;
        if ri == 0.0 {
            continue;
        }
        let range = w[0] as usize..w[1] as usize;
        for ((&v, a), b) in pattern.vertices[range.clone()]
            .iter()
            .zip(&da[range.clone()])
            .zip(&db[range])
        {
            sink.add(v as usize, ri, *a, *b);
        }
        let s = 2.0 * sink.weight * ri;
        for (g, d) in sink.gaux.iter_mut().zip(&daux[i * n_aux..(i + 1) * n_aux]) {
            *g += s * d;
        }
    }
    sink.weight * value
}
