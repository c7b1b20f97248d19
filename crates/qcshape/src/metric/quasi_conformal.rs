//! The quasi-conformal metric (eq. 10): the conformal corner terms weighted by the change of
//! angle-defect curvature, in the two readings of docs/method.md "Metrics" (`segment` and `endpoints`).

use super::conformal::ConformalForm;
use super::conformal::{
    eval_constant_weights, face_gradients, face_kernel, face_pattern, face_second_order, face_values, sign0,
    FaceOut,
};
use super::curvature::{angle_defect_with_gradient, closed_ring, ring_offsets};
use super::fused::{quadratic_segment_gradient, quadratic_segment_values};
use super::gradient::{GradientSink, Scratch, SegmentSink};
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::second_order::SecondOrderSink;
use super::segment::{geometry_and_displacement, split_segment, Segment};
use super::traits::{gradient_from_jacobian, segment_gradient_per_term, squared_norm_from_residuals, Metric};
use crate::mesh::geometry::{add, angle_defect, scale, vertex_areas};
use crate::mesh::Topology;

/// Which "change of curvature during deformation" weights the quasi-conformal terms
/// (docs/method.md "Metrics"). `K_v` is the angle defect of
/// [`crate::mesh::geometry::angle_defect`] (radians).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum QcWeights {
    /// Literal reading: on the path segment `a -> b`, `w_v = K_v(b) - K_v(a)`. The weights
    /// depend on the unknowns and their derivatives are part of the Jacobian (`K_v` depends on
    /// `v` and its one-ring, so a residual's row holds the one-rings of its corners).
    ///
    /// With this reading `w = O(|X|)`, so the squared norm is quartic in the velocity: a
    /// segment of a path refined into `N` samples has `G = O(N^-4)` and the polyline length
    /// `sum_i sqrt(G_i)` shrinks like `1/N` as the path is refined (docs/method.md "Metrics").
    Segment,
    /// Frozen reading: for a path from `A` to `B`, `w_v = K_v(B) - K_v(A)` is fixed for the
    /// whole path ([`Metric::frozen_weights`], passed back as [`Segment::frozen`]); the metric
    /// is then a weighted quadratic form in `X`.
    Endpoints,
}

impl QcWeights {
    /// `"segment"` or `"endpoints"` (used in metric names).
    pub fn label(self) -> &'static str {
        match self {
            QcWeights::Segment => "segment",
            QcWeights::Endpoints => "endpoints",
        }
    }
}

/// The quasi-conformal metric (eq. 10): the conformal terms of [`super::Conformal`] (eq. 7) with
/// each corner term `T_v` multiplied by a curvature-change weight `w_v` (`v` the corner vertex
/// of `T_v`, weights from [`QcWeights`]). Per triangle `(p, q, r)` of `M`: residuals
/// `w_p T_p, w_q T_q, w_r T_r` ([`ConformalForm::Quadratic`]) or the single residual
/// `|w_p T_p| + |w_q T_q| + |w_r T_r|` ([`ConformalForm::Paper`], eqs. 8-9).
///
/// Vanishes on infinitesimal similarities, on conformal fields and wherever `w = 0`;
/// regularize with [`super::Regularized`] for a unique geodesic. Units: `w` is in radians, so
/// a residual is length^4 x radians and `G` length^8 (as [`super::Conformal`]); with
/// [`QcWeights::Segment`] `G` is quartic in the velocity (see there).
///
/// Sparsity: with [`QcWeights::Endpoints`] every residual depends on its face's 3 vertices;
/// with [`QcWeights::Segment`] a residual's row is the sorted union of the closed one-rings of
/// the corners it involves (one corner for the quadratic form, three for the paper form).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuasiConformal {
    /// Which triangle term (paper or quadratic).
    pub form: ConformalForm,
    /// Which curvature-change weights.
    pub weights: QcWeights,
    /// How the `endpoints` weights are scaled: `None` is the paper's raw angle-defect change
    /// (radians); [`QcNormalize`] turns it into a dimensionless, resolution- and
    /// amplitude-independent weight with an optional floor. Ignored by [`QcWeights::Segment`].
    pub normalize: Option<QcNormalize>,
}

/// Normalization of the quasi-conformal `endpoints` weights (docs/method.md
/// "Scale-invariant forms"). The paper's weight `w_v = K_v(B) - K_v(A)` is an angle-defect
/// change, an *integrated* curvature: it shrinks like the vertex area (`h^2`) as the mesh is
/// refined and grows with the size of the motion, so the quasi-conformal term's weight against
/// any other term depends on both.
/// Normalized, the weight is the change of the Gaussian curvature density
/// `d_v = w_v / Abar_v` (`Abar_v` the mean vertex area of the two ends, one-third rule),
/// optionally smoothed over one-rings (`smooth` passes of the area-weighted average of the
/// closed one-ring), divided by its area-weighted RMS over the surface, then floored:
/// `w_v = sqrt(floor^2 + (d_v / rms(d))^2)`. The weights are dimensionless with RMS about 1
/// (exactly 1 without floor), so the metric is a curvature-weighted conformal metric whose
/// scale is that of [`super::Conformal`]; a floor > 0 leaves no vertex free (the metric's null
/// space is then the conformal metric's). A motion that changes no curvature (rms 0) gets the
/// weight `floor` everywhere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QcNormalize {
    /// The weight floor (>= 0, dimensionless, relative to the RMS weight 1).
    pub floor: f64,
    /// One-ring smoothing passes of the curvature-change density before the RMS.
    pub smooth: usize,
}

impl QuasiConformal {
    /// The quasi-conformal metric with the given triangle form and weights (raw, the paper's).
    pub fn new(form: ConformalForm, weights: QcWeights) -> Self {
        QuasiConformal {
            form,
            weights,
            normalize: None,
        }
    }

    /// The same metric with normalized `endpoints` weights ([`QcNormalize`]).
    pub fn normalized(mut self, normalize: QcNormalize) -> Self {
        self.normalize = Some(normalize);
        self
    }

    /// Whether each residual is a frozen weight times a term that does not depend on it
    /// (`endpoints` weights with the quadratic form: [`Metric::residual_factors`]).
    fn weights_are_factors(&self) -> bool {
        self.weights == QcWeights::Endpoints && self.form == ConformalForm::Quadratic
    }

    /// The two terms' frozen weights (#V each) when the fused segment kernels of the
    /// quadratic form apply (endpoint weights present on both terms); `None` otherwise.
    fn fused_weights<'a>(&self, topo: &Topology, segs: [&Segment<'a>; 2]) -> Option<[Option<&'a [f64]>; 2]> {
        let nv = topo.n_vertices();
        match (segs[0].frozen, segs[1].frozen) {
            (Some(w0), Some(w1)) if self.weights_are_factors() && w0.len() == nv && w1.len() == nv => {
                Some([Some(w0), Some(w1)])
            }
            _ => None,
        }
    }
}

impl Metric for QuasiConformal {
    fn name(&self) -> String {
        match (self.weights, self.normalize) {
            (QcWeights::Endpoints, Some(n)) => format!(
                "quasi-conformal({},{},rms,floor={},smooth={})",
                self.form.label(),
                self.weights.label(),
                n.floor,
                n.smooth
            ),
            _ => format!("quasi-conformal({},{})", self.form.label(), self.weights.label()),
        }
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        match self.weights {
            QcWeights::Endpoints => face_pattern(topo, self.form.residuals_per_face()),
            QcWeights::Segment => segment_pattern(topo, self.form),
        }
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        self.form.residuals_per_face() * topo.n_faces()
    }

    /// The face of each residual (also for [`QcWeights::Segment`], whose Jacobian rows reach
    /// the faces' one-rings through the curvature weights).
    fn support(&self, topo: &Topology) -> Pattern {
        face_pattern(topo, self.form.residuals_per_face())
    }

    /// `K(end) - K(start)` (#V, radians) for [`QcWeights::Endpoints`], normalized by
    /// [`QcNormalize`] when set (`None` if a pose does not have #V vertices); `None` for
    /// [`QcWeights::Segment`].
    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        let nv = topo.n_vertices();
        if self.weights != QcWeights::Endpoints || start.len() != nv || end.len() != nv {
            return None;
        }
        let w = curvature_change(topo, start, end);
        Some(match self.normalize {
            None => w,
            Some(n) => normalized_weights(topo, &w, &vertex_areas(topo, start), &vertex_areas(topo, end), n),
        })
    }

    /// With [`QcWeights::Endpoints`]: the angle defects `K(pose)` (#V), followed by the vertex
    /// areas (#V) when the weights are normalized.
    fn pose_summary(&self, topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        if self.weights != QcWeights::Endpoints || pose.len() != topo.n_vertices() {
            return None;
        }
        let mut s = angle_defect(topo, pose);
        if self.normalize.is_some() {
            s.extend(vertex_areas(topo, pose));
        }
        Some(s)
    }

    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        [ss, se]: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        let nv = topo.n_vertices();
        let want = if self.normalize.is_some() { 2 * nv } else { nv };
        if self.weights != QcWeights::Endpoints || ss.len() != want || se.len() != want {
            return self.frozen_weights(topo, start, end);
        }
        let w = curvature_difference(&ss[..nv], se[..nv].to_vec());
        Some(match self.normalize {
            None => w,
            Some(n) => normalized_weights(topo, &w, &ss[nv..], &se[nv..], n),
        })
    }

    /// With [`QcWeights::Endpoints`] and the quadratic form: `w_v` for the residual of each
    /// face's corner at `v` (3 per face, in face order); `None` for the paper form (whose one
    /// residual per face is a sum of absolute values, not a factor times a term) and for
    /// [`QcWeights::Segment`] (no frozen weights), or when `frozen` is not #V values.
    fn residual_factors(&self, topo: &Topology, frozen: &[f64]) -> Option<Vec<f64>> {
        if !self.weights_are_factors() || frozen.len() != topo.n_vertices() {
            return None;
        }
        Some(
            topo.faces()
                .iter()
                .flat_map(|f| f.map(|v| frozen[v as usize]))
                .collect(),
        )
    }

    /// All ones (#V) where [`Metric::residual_factors`] applies, else `frozen` unchanged.
    fn unit_frozen(&self, topo: &Topology, frozen: Vec<f64>) -> Vec<f64> {
        if self.weights_are_factors() {
            vec![1.0; topo.n_vertices()]
        } else {
            frozen
        }
    }

    /// With [`QcWeights::Endpoints`] the weights are `seg.frozen`; if it is absent (or not of
    /// length #V) the weights fall back to `K(b) - K(a)` of this segment, held constant (their
    /// derivatives are not in the Jacobian, which then is that of the frozen-weight form).
    fn residuals(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        jac: Option<JacobianMut>,
    ) {
        match self.weights {
            QcWeights::Endpoints => match seg.frozen {
                Some(w) if w.len() == topo.n_vertices() => {
                    eval_constant_weights(topo, self.form, seg, Some(w), r, jac)
                }
                _ => {
                    let w = self
                        .frozen_weights(topo, seg.a, seg.b)
                        .unwrap_or_else(|| curvature_change(topo, seg.a, seg.b));
                    eval_constant_weights(topo, self.form, seg, Some(&w), r, jac)
                }
            },
            QcWeights::Segment => eval_segment(topo, self.form, pattern, seg, r, jac),
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
        match (self.weights, seg.frozen) {
            (QcWeights::Endpoints, Some(w)) if w.len() == topo.n_vertices() => {
                face_kernel(topo, self.form, seg, Some(w), FaceOut::Gradient(sink))
            }
            // The fallback weights and the segment weights: through the Jacobian.
            _ => gradient_from_jacobian(self, topo, pattern, seg, scratch, sink),
        }
    }

    fn segment_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        match self.fused_weights(topo, segs) {
            Some(w) => quadratic_segment_gradient(topo, segs[0].a, segs[0].b, w, sink),
            None => segment_gradient_per_term(self, topo, pattern, segs, scratch, sink),
        }
    }

    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        match self.fused_weights(topo, segs) {
            Some(w) => quadratic_segment_values(topo, segs[0].a, segs[0].b, w),
            None => segs.map(|seg| squared_norm_from_residuals(self, topo, pattern, seg)),
        }
    }

    /// Frozen (`endpoints`) weights with the quadratic form only: the segment weights depend
    /// on the unknowns, and the fallback weights' derivatives are not in the Jacobian.
    fn add_second_order(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        r: &[f64],
        sink: &mut SecondOrderSink,
    ) -> bool {
        match (self.weights, seg.frozen) {
            (QcWeights::Endpoints, Some(w)) if w.len() == topo.n_vertices() => {
                face_second_order(topo, self.form, seg, Some(w), r, sink)
            }
            _ => false,
        }
    }
}

/// `K(end) - K(start)` (#V).
fn curvature_change(topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Vec<f64> {
    curvature_difference(&angle_defect(topo, start), angle_defect(topo, end))
}

/// The normalized weights of [`QcNormalize`] (#V) from the angle-defect change `dk` and the
/// two ends' vertex areas (#V each).
pub(crate) fn normalized_weights(
    topo: &Topology,
    dk: &[f64],
    area_start: &[f64],
    area_end: &[f64],
    n: QcNormalize,
) -> Vec<f64> {
    let area: Vec<f64> = area_start
        .iter()
        .zip(area_end)
        .map(|(a, b)| 0.5 * (a + b))
        .collect();
    let mut d: Vec<f64> = dk
        .iter()
        .zip(&area)
        .map(|(k, a)| if *a > 0.0 { k / a } else { 0.0 })
        .collect();
    for _ in 0..n.smooth {
        d = (0..d.len())
            .map(|v| {
                let (mut num, mut den) = (area[v] * d[v], area[v]);
                for &u in topo.neighbors(v) {
                    num += area[u as usize] * d[u as usize];
                    den += area[u as usize];
                }
                if den > 0.0 {
                    num / den
                } else {
                    0.0
                }
            })
            .collect();
    }
    let (num, den) = d
        .iter()
        .zip(&area)
        .fold((0.0, 0.0), |(n, s), (x, a)| (n + a * x * x, s + a));
    let rms = if den > 0.0 { (num / den).sqrt() } else { 0.0 };
    let inv = if rms > 0.0 && rms.is_finite() {
        1.0 / rms
    } else {
        0.0
    };
    d.iter()
        .map(|x| {
            let w = x * inv;
            if n.floor > 0.0 {
                (n.floor * n.floor + w * w).sqrt()
            } else {
                w
            }
        })
        .collect()
}

/// `K(end) - K(start)` from the two poses' angle defects (`ke` is overwritten).
fn curvature_difference(ks: &[f64], mut ke: Vec<f64>) -> Vec<f64> {
    for (x, s) in ke.iter_mut().zip(ks) {
        *x -= s;
    }
    ke
}

/// Rows of the segment reading: per face, for the quadratic form one row per corner (the
/// corner's closed one-ring, sorted), for the paper form one row (the sorted union of the three
/// closed one-rings). The face's own vertices are always included.
fn segment_pattern(topo: &Topology, form: ConformalForm) -> Pattern {
    let mut rows = Pattern {
        offsets: vec![0],
        vertices: Vec::new(),
    };
    let mut buf: Vec<u32> = Vec::with_capacity(32);
    for f in topo.faces() {
        match form {
            ConformalForm::Quadratic => {
                for &v in f {
                    buf.clear();
                    buf.extend(closed_ring(topo, v as usize));
                    buf.sort_unstable();
                    rows.vertices.extend_from_slice(&buf);
                    rows.offsets.push(rows.vertices.len() as u32);
                }
            }
            ConformalForm::Paper => {
                buf.clear();
                for &v in f {
                    buf.extend(closed_ring(topo, v as usize));
                }
                buf.sort_unstable();
                buf.dedup();
                rows.vertices.extend_from_slice(&buf);
                rows.offsets.push(rows.vertices.len() as u32);
            }
        }
    }
    rows
}

/// Adds `(da, db)` to the entry of vertex `u` in the row whose (sorted) vertices are `verts`
/// and whose first entry is `start`. Vertices outside the row are ignored (cannot happen with
/// [`segment_pattern`]).
#[inline]
fn add_entry(j: &mut JacobianMut, verts: &[u32], start: usize, u: u32, da: [f64; 3], db: [f64; 3]) {
    if let Ok(pos) = verts.binary_search(&u) {
        let e = start + pos;
        j.da[e] = add(j.da[e], da);
        j.db[e] = add(j.db[e], db);
    }
}

/// The segment reading: `w_v = K_v(b) - K_v(a)`, with `dw_v/db_u = dK_v(b)/db_u` and
/// `dw_v/da_u = -dK_v(a)/da_u` in the Jacobian. Curvatures and their one-ring gradients are
/// computed once per call for both poses.
fn eval_segment(
    topo: &Topology,
    form: ConformalForm,
    pattern: PatternRef,
    seg: &Segment,
    r: &mut [f64],
    mut jac: Option<JacobianMut>,
) {
    let (g, x) = geometry_and_displacement(seg);
    let off = ring_offsets(topo);
    let want = jac.is_some();
    let (mut ka, mut kb) = (Vec::new(), Vec::new());
    let (mut ga, mut gb) = (Vec::new(), Vec::new());
    angle_defect_with_gradient(topo, seg.a, &off, &mut ka, want.then_some(&mut ga));
    angle_defect_with_gradient(topo, seg.b, &off, &mut kb, want.then_some(&mut gb));
    let n_rows = form.residuals_per_face();
    for (fi, f) in topo.faces().iter().enumerate() {
        let gf = f.map(|i| g[i as usize]);
        let xf = f.map(|i| x[i as usize]);
        let w = f.map(|i| kb[i as usize] - ka[i as usize]);
        let t = face_values(gf, xf);
        let wt = [w[0] * t[0], w[1] * t[1], w[2] * t[2]];
        match form {
            ConformalForm::Quadratic => r[3 * fi..3 * fi + 3].copy_from_slice(&wt),
            ConformalForm::Paper => r[fi] = wt[0].abs() + wt[1].abs() + wt[2].abs(),
        }
        let Some(j) = jac.as_mut() else { continue };
        let (dg, dx) = face_gradients(gf, xf);
        for i in 0..n_rows {
            let range = pattern.row(n_rows * fi + i);
            let verts = &pattern.vertices[range.clone()];
            j.da[range.clone()].fill([0.0; 3]);
            j.db[range.clone()].fill([0.0; 3]);
            // Row i: d(c_T dT_k + c_w dw_k) summed over the corners k it involves.
            let corners = match form {
                ConformalForm::Quadratic => i..i + 1,
                ConformalForm::Paper => 0..3,
            };
            for k in corners {
                let (c_t, c_w) = match form {
                    ConformalForm::Quadratic => (w[k], t[k]),
                    ConformalForm::Paper => {
                        let s = sign0(wt[k]);
                        (s * w[k], s * t[k])
                    }
                };
                if c_t != 0.0 {
                    for m in 0..3 {
                        let (da, db) = split_segment(seg.at, scale(dg[k][m], c_t), scale(dx[k][m], c_t));
                        add_entry(j, verts, range.start, f[m], da, db);
                    }
                }
                if c_w != 0.0 {
                    let v = f[k] as usize;
                    let base = off[v] as usize;
                    for (jj, u) in closed_ring(topo, v).enumerate() {
                        let da = scale(ga[base + jj], -c_w);
                        let db = scale(gb[base + jj], c_w);
                        add_entry(j, verts, range.start, u, da, db);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::conformal::test_segment;
    use crate::metric::{fdcheck, At, Conformal};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const FORMS: [ConformalForm; 2] = [ConformalForm::Paper, ConformalForm::Quadratic];
    const WEIGHTS: [QcWeights; 2] = [QcWeights::Segment, QcWeights::Endpoints];

    #[test]
    fn quasi_conformal_jacobian_matches_finite_differences() {
        for (i, form) in FORMS.into_iter().enumerate() {
            for (j, weights) in WEIGHTS.into_iter().enumerate() {
                fdcheck::check_metric(&QuasiConformal::new(form, weights), 23 + 10 * i as u64 + j as u64);
            }
        }
        // As the prefix of a regularized metric (the pattern handed back is a prefix view).
        let inner = QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Segment);
        fdcheck::check_metric(&crate::metric::Regularized::new(Box::new(inner), 0.2), 41);
    }

    #[test]
    fn names() {
        assert_eq!(
            QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Endpoints).name(),
            "quasi-conformal(quadratic,endpoints)"
        );
        assert_eq!(
            QuasiConformal::new(ConformalForm::Paper, QcWeights::Segment).name(),
            "quasi-conformal(paper,segment)"
        );
    }

    fn bumpy_pair(seed: u64) -> (crate::mesh::Shape, Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let s = crate::synth::icosphere(2);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let a: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| p.map(|c| c + 0.02 * (rng.random::<f64>() - 0.5)))
            .collect();
        let b: Vec<[f64; 3]> = a
            .iter()
            .map(|p| {
                [1.3 * p[0], p[1], p[2] + 0.2 * p[0] * p[1]].map(|c| c + 0.02 * (rng.random::<f64>() - 0.5))
            })
            .collect();
        (s, a, b)
    }

    #[test]
    fn unit_frozen_weights_give_the_conformal_metric() {
        let (s, a, b) = bumpy_pair(1);
        let ones = vec![1.0; a.len()];
        for form in FORMS {
            let qc = QuasiConformal::new(form, QcWeights::Endpoints);
            let c = Conformal::new(form);
            let pat = qc.pattern(&s.topology);
            assert_eq!(pat, c.pattern(&s.topology));
            for at in [At::Start, At::End] {
                let seg = Segment {
                    frozen: Some(&ones),
                    ..test_segment(&a, &b, at)
                };
                let (mut r1, mut r2) = (vec![0.0; pat.n_residuals()], vec![0.0; pat.n_residuals()]);
                qc.residuals(&s.topology, pat.as_ref(), &seg, &mut r1, None);
                c.residuals(&s.topology, pat.as_ref(), &seg, &mut r2, None);
                assert_eq!(r1, r2);
            }
        }
    }

    #[test]
    fn frozen_weights_are_the_curvature_change_and_the_default() {
        let (s, a, b) = bumpy_pair(2);
        let topo = &s.topology;
        assert!(QuasiConformal::new(ConformalForm::Paper, QcWeights::Segment)
            .frozen_weights(topo, &a, &b)
            .is_none());
        for form in FORMS {
            let qc = QuasiConformal::new(form, QcWeights::Endpoints);
            let w = qc.frozen_weights(topo, &a, &b).unwrap_or_default();
            let (ka, kb) = (angle_defect(topo, &a), angle_defect(topo, &b));
            assert_eq!(w.len(), a.len());
            for v in 0..a.len() {
                assert!((w[v] - (kb[v] - ka[v])).abs() < 1e-14);
            }
            // Without frozen weights the segment's own curvature change is used (held constant).
            let pat = qc.pattern(topo);
            let seg_frozen = Segment {
                frozen: Some(&w),
                ..test_segment(&a, &b, At::End)
            };
            let (mut r1, mut r2) = (vec![0.0; pat.n_residuals()], vec![0.0; pat.n_residuals()]);
            qc.residuals(topo, pat.as_ref(), &seg_frozen, &mut r1, None);
            qc.residuals(topo, pat.as_ref(), &test_segment(&a, &b, At::End), &mut r2, None);
            assert_eq!(r1, r2);
        }
    }

    #[test]
    fn segment_reading_is_quartic_and_endpoints_quadratic_in_the_velocity() {
        let (s, a, b) = bumpy_pair(3);
        let topo = &s.topology;
        let field = |t: f64| -> Vec<[f64; 3]> {
            a.iter()
                .zip(&b)
                .map(|(p, q)| [0, 1, 2].map(|c| p[c] + t * (q[c] - p[c])))
                .collect()
        };
        let frozen = curvature_change(topo, &a, &b);
        for form in FORMS {
            let g = |weights: QcWeights, t: f64| {
                let m = QuasiConformal::new(form, weights);
                let pat = m.pattern(topo);
                let bt = field(t);
                let seg = Segment {
                    frozen: Some(&frozen),
                    ..test_segment(&a, &bt, At::Start)
                };
                m.squared_norm(topo, &pat, &seg)
            };
            let h = 1e-3;
            let ratio_seg = g(QcWeights::Segment, 2.0 * h) / g(QcWeights::Segment, h);
            let ratio_end = g(QcWeights::Endpoints, 2.0 * h) / g(QcWeights::Endpoints, h);
            assert!(
                (ratio_seg - 16.0).abs() < 0.2,
                "{form:?}: segment ratio {ratio_seg}"
            );
            assert!(
                (ratio_end - 4.0).abs() < 1e-9,
                "{form:?}: endpoints ratio {ratio_end}"
            );
        }
    }

    #[test]
    fn segment_pattern_rows_are_sorted_unique_and_hold_the_face() {
        let s = crate::synth::grid(4);
        for form in FORMS {
            let pat = QuasiConformal::new(form, QcWeights::Segment).pattern(&s.topology);
            assert_eq!(
                pat.n_residuals(),
                form.residuals_per_face() * s.topology.n_faces()
            );
            for i in 0..pat.n_residuals() {
                let row = &pat.vertices[pat.row(i)];
                assert!(row.windows(2).all(|w| w[0] < w[1]));
                let f = s.topology.faces()[i / form.residuals_per_face()];
                assert!(f.iter().all(|v| row.binary_search(v).is_ok()));
            }
        }
    }
}
