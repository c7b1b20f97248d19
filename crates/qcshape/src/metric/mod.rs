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
//! [`QuasiConformal`] (eq. 10), and [`Regularized`] (`G + lambda * L2`, eq. 11).

mod bent;
mod conformal;
mod curvature;
pub mod defaults;
mod fused;
mod gradient;
mod isometric;
mod l2;
mod quasi_conformal;
mod regularized;
mod relative;
mod rigid;
mod rigid_frozen;
mod second_order;
mod spec;
mod weighted;

#[cfg(test)]
pub(crate) mod fdcheck;

pub use bent::Bent;
pub use conformal::{Conformal, ConformalForm};
pub(crate) use gradient::same_frozen;
pub use gradient::{
    gradient_from_jacobian, segment_gradient_per_term, GradientSink, PoseShare, Scratch, SegmentSink,
};
pub use isometric::Isometric;
pub use l2::{FrozenL2, L2};
pub use quasi_conformal::{QcNormalize, QcWeights, QuasiConformal};
pub use regularized::{Regularized, RegularizerL2};
pub use relative::{dihedral_angles, RelativeBending, RelativeConformal, RelativeIsometric, RelativeL2};
pub use rigid::{fit_motion_weighted, Rigid};
pub use rigid_frozen::FrozenRigid;
pub use second_order::SecondOrderSink;
pub use spec::{Calibration, CalibrationError, L2Areas, MetricKind, MetricScale, MetricSpec, QcScaling};
pub use weighted::Weighted;

use std::fmt::Debug;

use crate::mesh::Topology;

/// Which end of a path segment supplies the metric's geometry: `G_{P_i}(X_i)` is
/// [`At::Start`], `G_{P_{i+1}}(X_i)` is [`At::End`] (eq. 12).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum At {
    /// Geometry of the segment's first pose `a = P_i`.
    Start,
    /// Geometry of the segment's second pose `b = P_{i+1}`.
    End,
}

/// One evaluation of a metric on a path segment: `X = b - a` measured at `a` or `b`.
#[derive(Debug, Clone, Copy)]
pub struct Segment<'a> {
    /// First pose `P_i` (#V x 3).
    pub a: &'a [[f64; 3]],
    /// Second pose `P_{i+1}` (#V x 3).
    pub b: &'a [[f64; 3]],
    /// Which pose supplies the geometry.
    pub at: At,
    /// Auxiliary unknowns of this term ([`Metric::n_aux`] values; the rigid motion for
    /// [`Rigid`]); empty for the other metrics.
    pub aux: &'a [f64],
    /// Per-vertex weights frozen for a whole path ([`Metric::frozen_weights`]), if any.
    pub frozen: Option<&'a [f64]>,
}

/// Jacobian sparsity of a metric's residuals: residual `i` depends on the vertices
/// `vertices[offsets[i]..offsets[i+1]]` (unique within a residual). Built once per topology.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Pattern {
    /// Row offsets (#residuals + 1).
    pub offsets: Vec<u32>,
    /// Vertex indices of each residual's entries.
    pub vertices: Vec<u32>,
}

impl Pattern {
    /// Number of residuals.
    pub fn n_residuals(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
    /// Number of (residual, vertex) entries.
    pub fn n_entries(&self) -> usize {
        self.vertices.len()
    }
    /// Entry range of residual `i`.
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }
    /// Borrowed view of the pattern.
    pub fn as_ref(&self) -> PatternRef<'_> {
        PatternRef {
            offsets: &self.offsets,
            vertices: &self.vertices,
        }
    }
    /// Builds a pattern from rows of vertex lists.
    pub fn from_rows<I: IntoIterator<Item = R>, R: AsRef<[u32]>>(rows: I) -> Self {
        let mut p = Pattern {
            offsets: vec![0],
            vertices: Vec::new(),
        };
        for r in rows {
            p.vertices.extend_from_slice(r.as_ref());
            p.offsets.push(p.vertices.len() as u32);
        }
        p
    }
    /// Concatenates `other` after `self` (residuals of `other` follow).
    pub fn append(&mut self, other: &Pattern) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&other.vertices);
        self.offsets.extend(other.offsets[1..].iter().map(|o| o + base));
    }
}

/// Borrowed view of a [`Pattern`] (or of a prefix of one: the first residuals).
#[derive(Debug, Clone, Copy)]
pub struct PatternRef<'a> {
    /// Row offsets (#residuals + 1).
    pub offsets: &'a [u32],
    /// Vertex indices of the entries.
    pub vertices: &'a [u32],
}

impl PatternRef<'_> {
    /// Number of residuals.
    pub fn n_residuals(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
    /// Entry range of residual `i`.
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }
}

/// Mutable view of Jacobian values (see [`Jacobian`]).
#[derive(Debug)]
pub struct JacobianMut<'a> {
    /// `dr/da_v` per entry.
    pub da: &'a mut [[f64; 3]],
    /// `dr/db_v` per entry.
    pub db: &'a mut [[f64; 3]],
    /// `dr/daux`, #residuals x n_aux, row-major.
    pub daux: &'a mut [f64],
}

/// Jacobian values in [`Pattern`] order: entry `k` (vertex `pattern.vertices[k]` of its
/// residual) holds `dr/da_v` and `dr/db_v` (3 each); `daux` holds `dr/daux` row-major
/// (#residuals x [`Metric::n_aux`]).
#[derive(Debug, Clone, Default)]
pub struct Jacobian {
    /// Derivatives with respect to the first pose's vertex, per entry.
    pub da: Vec<[f64; 3]>,
    /// Derivatives with respect to the second pose's vertex, per entry.
    pub db: Vec<[f64; 3]>,
    /// Derivatives with respect to the auxiliary unknowns.
    pub daux: Vec<f64>,
}

impl Jacobian {
    /// Zeroed storage for `pattern` with `n_aux` auxiliary unknowns.
    pub fn zeros(pattern: &Pattern, n_aux: usize) -> Self {
        Jacobian {
            da: vec![[0.0; 3]; pattern.n_entries()],
            db: vec![[0.0; 3]; pattern.n_entries()],
            daux: vec![0.0; pattern.n_residuals() * n_aux],
        }
    }
    /// Mutable view.
    pub fn as_mut(&mut self) -> JacobianMut<'_> {
        JacobianMut {
            da: &mut self.da,
            db: &mut self.db,
            daux: &mut self.daux,
        }
    }
    /// Sets every value to zero (keeps the storage).
    pub fn clear(&mut self) {
        self.da.fill([0.0; 3]);
        self.db.fill([0.0; 3]);
        self.daux.fill(0.0);
    }
}

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

    /// Number of auxiliary unknowns per segment term (6 for [`Rigid`], else 0). They are
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
    /// term's dihedral angles and sliver factors, [`RelativeBending`]), written to `out`: the
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
    /// summed coefficients `coeffs` of [`Metric::segment_gradient_with`]. Nothing (the default)
    /// for metrics without pose values.
    fn pose_gradient(
        &self,
        _topo: &Topology,
        _pattern: PatternRef,
        _pose: &[[f64; 3]],
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

    /// [`Metric::segment_squared_norms`] split into the geometric term and the L2
    /// regularizer of eq. 11 ([`Regularized`]): `[geometric, regularizer]`, each the sum of
    /// the segment's two terms, adding up to theirs (to rounding). The default: everything is
    /// geometric.
    fn segment_energy_parts(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        let [g0, g1] = self.segment_squared_norms(topo, pattern, segs);
        [g0 + g1, 0.0]
    }

    /// The bending term's part of [`Metric::segment_squared_norms`] (both terms of the segment
    /// summed; [`Bent::bending_energy`]): 0 for metrics without one. Counted as geometric by
    /// [`Metric::segment_energy_parts`].
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

/// A pattern made of two metrics' patterns one after the other ([`Regularized`], [`Bent`]):
/// the first metric's rows (a prefix, rows and entries) and the second's with their offsets
/// rebased to their first entry.
pub(crate) struct SplitPattern<'p> {
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
pub(crate) fn split_pattern(pattern: PatternRef<'_>, n_first: usize) -> SplitPattern<'_> {
    let e_first = pattern.offsets[n_first] as usize;
    SplitPattern {
        first: PatternRef {
            offsets: &pattern.offsets[..=n_first],
            vertices: &pattern.vertices[..e_first],
        },
        second_offsets: pattern.offsets[n_first..]
            .iter()
            .map(|o| o - e_first as u32)
            .collect(),
        second_vertices: &pattern.vertices[e_first..],
    }
}

/// Two metrics' frozen values (or pose summaries) one after the other, as a sum of two metrics
/// stores them; `None` when neither has any.
pub(crate) fn join_frozen(first: Option<Vec<f64>>, second: Option<Vec<f64>>) -> Option<Vec<f64>> {
    match (first, second) {
        (Some(mut a), Some(b)) => {
            a.extend_from_slice(&b);
            Some(a)
        }
        (a, b) => a.or(b),
    }
}

/// Chain rule from `(geometry g, displacement X)` derivatives to `(a, b)` derivatives for a
/// segment with `X = b - a` and `g = a` or `g = b`: `dr/da = -dr/dX + [g = a] dr/dg`,
/// `dr/db = dr/dX + [g = b] dr/dg`.
#[inline]
pub(crate) fn split_segment(at: At, dg: [f64; 3], dx: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    match at {
        At::Start => ([dg[0] - dx[0], dg[1] - dx[1], dg[2] - dx[2]], dx),
        At::End => (
            [-dx[0], -dx[1], -dx[2]],
            [dg[0] + dx[0], dg[1] + dx[1], dg[2] + dx[2]],
        ),
    }
}

/// The pose that supplies a segment term's geometry (#V x 3): `a` for `At::Start`, `b` for
/// `At::End`.
pub(crate) fn geometry<'a>(seg: &Segment<'a>) -> &'a [[f64; 3]] {
    match seg.at {
        At::Start => seg.a,
        At::End => seg.b,
    }
}

/// The geometry pose and the displacement `X = b - a` (#V x 3) of a segment.
pub(crate) fn geometry_and_displacement<'a>(seg: &Segment<'a>) -> (&'a [[f64; 3]], Vec<[f64; 3]>) {
    let g = geometry(seg);
    let x = seg
        .a
        .iter()
        .zip(seg.b)
        .map(|(p, q)| [q[0] - p[0], q[1] - p[1], q[2] - p[2]])
        .collect();
    (g, x)
}
