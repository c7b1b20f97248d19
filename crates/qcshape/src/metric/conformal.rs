//! The conformal metric (eqs. 7-9) and the per-triangle kernel `T_p, T_q, T_r` it shares with
//! the quasi-conformal metric (eq. 10).

use super::fused::face_weights;
use super::gradient::{GradientSink, Scratch, SegmentSink};
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::second_order::SecondOrderSink;
use super::segment::{geometry_and_displacement, split_segment, Segment};
use super::traits::{segment_gradient_per_term, squared_norm_from_residuals, Metric};
use crate::mesh::geometry::{add, dot, scale, sub};
use crate::mesh::Topology;

/// How the three corner terms `T_p, T_q, T_r` of a triangle enter the squared norm
/// (docs/method.md "Metrics").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ConformalForm {
    /// The paper's eqs. 8-9 with `X = Y`: one residual per face, `|T_p| + |T_q| + |T_r|`, so
    /// the triangle contributes `(|T_p| + |T_q| + |T_r|)^2`. Not smooth where a `T_v` vanishes
    /// (the derivative of `|T|` is taken as `sign(T) dT`, with `sign(0) = 0`).
    Paper,
    /// Three residuals per face, `T_p, T_q, T_r`: the triangle contributes
    /// `T_p^2 + T_q^2 + T_r^2`, a true quadratic form (smooth for Gauss-Newton).
    Quadratic,
}

impl ConformalForm {
    /// Residuals per face: 1 for [`ConformalForm::Paper`], 3 for [`ConformalForm::Quadratic`].
    pub fn residuals_per_face(self) -> usize {
        match self {
            ConformalForm::Paper => 1,
            ConformalForm::Quadratic => 3,
        }
    }

    /// `"paper"` or `"quadratic"` (used in metric names).
    pub fn label(self) -> &'static str {
        match self {
            ConformalForm::Paper => "paper",
            ConformalForm::Quadratic => "quadratic",
        }
    }
}

/// Sign with `sign(0) = 0` (the derivative convention for `|T|`).
#[inline]
pub(crate) fn sign0(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Value of `T` (eq. 7) at corner `0` of the triangle `(g0, g1, g2)` with displacements
/// `(x0, x1, x2)`: `<g0-g1, x0-x1> |g0-g2|^2 - <g0-g2, x0-x2> |g0-g1|^2`.
#[inline]
fn corner_value(g: [[f64; 3]; 3], x: [[f64; 3]; 3]) -> f64 {
    let (e1, e2) = (sub(g[0], g[1]), sub(g[0], g[2]));
    let (d1, d2) = (sub(x[0], x[1]), sub(x[0], x[2]));
    dot(e1, d1) * dot(e2, e2) - dot(e2, d2) * dot(e1, e1)
}

/// Gradient of [`corner_value`] with respect to `(g0, g1, g2)` and `(x0, x1, x2)`.
#[inline]
fn corner_gradient(g: [[f64; 3]; 3], x: [[f64; 3]; 3]) -> ([[f64; 3]; 3], [[f64; 3]; 3]) {
    let (e1, e2) = (sub(g[0], g[1]), sub(g[0], g[2]));
    let (d1, d2) = (sub(x[0], x[1]), sub(x[0], x[2]));
    let (l1, l2) = (dot(e1, e1), dot(e2, e2));
    let (p1, p2) = (dot(e1, d1), dot(e2, d2));
    // dT/de1 = d1 |e2|^2 - 2 (e2.d2) e1, dT/de2 = 2 (e1.d1) e2 - d2 |e1|^2.
    let de1 = sub(scale(d1, l2), scale(e1, 2.0 * p2));
    let de2 = sub(scale(e2, 2.0 * p1), scale(d2, l1));
    // dT/dd1 = e1 |e2|^2, dT/dd2 = -e2 |e1|^2.
    let dd1 = scale(e1, l2);
    let dd2 = scale(e2, -l1);
    (
        [add(de1, de2), scale(de1, -1.0), scale(de2, -1.0)],
        [add(dd1, dd2), scale(dd1, -1.0), scale(dd2, -1.0)],
    )
}

/// 3 x 3 blocks per local vertex pair `(j, l)` of a triangle.
type PairBlocks = [[[f64; 9]; 3]; 3];

#[inline]
fn outer9(u: [f64; 3], v: [f64; 3], s: f64) -> [f64; 9] {
    [
        s * u[0] * v[0],
        s * u[0] * v[1],
        s * u[0] * v[2],
        s * u[1] * v[0],
        s * u[1] * v[1],
        s * u[1] * v[2],
        s * u[2] * v[0],
        s * u[2] * v[1],
        s * u[2] * v[2],
    ]
}

/// `out += s_m m + s_n n^T + diag I` (3 x 3, row-major; `n^T` the transpose of `n`).
#[inline]
fn add_block(out: &mut [f64; 9], m: &[f64; 9], s_m: f64, n: &[f64; 9], s_n: f64, diag: f64) {
    for r in 0..3 {
        for c in 0..3 {
            out[3 * r + c] += s_m * m[3 * r + c] + s_n * n[3 * c + r];
        }
        out[4 * r] += diag;
    }
}

/// Maps blocks in the edge variables `e1 = v0 - v1`, `e2 = v0 - v2` to vertex pairs,
/// `H[j][l] = sum E_aj E_bl H_ab` with `E_1 = (1, -1, 0)`, `E_2 = (1, 0, -1)`, for
/// `H = [[alpha I, B], [C, delta I]]` given by `B` and the transpose `c_t = C^T` (what
/// [`add_block`] takes); accumulated into `out[map[j]][map[l]]`.
#[inline]
fn add_edge_blocks(
    out: &mut PairBlocks,
    map: [usize; 3],
    alpha: f64,
    b: &[f64; 9],
    c_t: &[f64; 9],
    delta: f64,
) {
    let [m0, m1, m2] = map;
    // [0][0] = A + B + C + D.
    add_block(&mut out[m0][m0], b, 1.0, c_t, 1.0, alpha + delta);
    // [0][1] = -(A + C), [0][2] = -(B + D).
    add_block(&mut out[m0][m1], &ZERO9, 0.0, c_t, -1.0, -alpha);
    add_block(&mut out[m0][m2], b, -1.0, &ZERO9, 0.0, -delta);
    // [1][0] = -(A + B), [1][1] = A, [1][2] = B.
    add_block(&mut out[m1][m0], b, -1.0, &ZERO9, 0.0, -alpha);
    add_block(&mut out[m1][m1], &ZERO9, 0.0, &ZERO9, 0.0, alpha);
    add_block(&mut out[m1][m2], b, 1.0, &ZERO9, 0.0, 0.0);
    // [2][0] = -(C + D), [2][1] = C, [2][2] = D.
    add_block(&mut out[m2][m0], &ZERO9, 0.0, c_t, -1.0, -delta);
    add_block(&mut out[m2][m1], &ZERO9, 0.0, c_t, 1.0, 0.0);
    add_block(&mut out[m2][m2], &ZERO9, 0.0, &ZERO9, 0.0, delta);
}

const ZERO9: [f64; 9] = [0.0; 9];

/// Adds `c` times the second derivatives of [`corner_value`] at corner `k` of a face into the
/// face-slot blocks `hgg[m][n] = d2/dg_m dg_n`, `hgx[m][n] = d2/dg_m dX_n` (`d2/dX dX = 0`).
///
/// With `T = <e1, d1> |e2|^2 - <e2, d2> |e1|^2`: `d2T/de1 de1 = -2 <e2, d2> I`,
/// `d2T/de1 de2 = 2 d1 e2^T - 2 e1 d2^T`, `d2T/de2 de2 = 2 <e1, d1> I`; `d2T/de1 dd1 = |e2|^2 I`,
/// `d2T/de1 dd2 = -2 e1 e2^T`, `d2T/de2 dd1 = 2 e2 e1^T`, `d2T/de2 dd2 = -|e1|^2 I`.
#[inline]
fn add_corner_hessian(
    g: [[f64; 3]; 3],
    x: [[f64; 3]; 3],
    k: usize,
    c: f64,
    hgg: &mut PairBlocks,
    hgx: &mut PairBlocks,
) {
    let (g, x) = (rot(g, k), rot(x, k));
    let (e1, e2) = (sub(g[0], g[1]), sub(g[0], g[2]));
    let (d1, d2) = (sub(x[0], x[1]), sub(x[0], x[2]));
    let (l1, l2) = (dot(e1, e1), dot(e2, e2));
    let (p1, p2) = (dot(e1, d1), dot(e2, d2));
    let b = {
        let (u, v) = (outer9(d1, e2, 2.0 * c), outer9(e1, d2, -2.0 * c));
        std::array::from_fn(|i| u[i] + v[i])
    };
    // The d2/de de block is symmetric: C = B^T, so C^T = B.
    add_edge_blocks(hgg, NEXT[k], -2.0 * c * p2, &b, &b, 2.0 * c * p1);
    // d2/de dd: B = -2c e1 e2^T, C = 2c e2 e1^T, so C^T = 2c e1 e2^T.
    let xb = outer9(e1, e2, -2.0 * c);
    let xc_t = outer9(e1, e2, 2.0 * c);
    add_edge_blocks(hgx, NEXT[k], c * l2, &xb, &xc_t, -c * l1);
}

/// One face's geometry, displacement and weights (all 1 without `weights`), in face order.
/// Always inlined: it runs in the per-face loop of every gradient evaluation.
#[inline(always)]
fn face_data(
    g: &[[f64; 3]],
    x: &[[f64; 3]],
    weights: Option<&[f64]>,
    f: &[u32; 3],
) -> ([[f64; 3]; 3], [[f64; 3]; 3], [f64; 3]) {
    let (i0, i1, i2) = (f[0] as usize, f[1] as usize, f[2] as usize);
    let w = face_weights(weights, &[i0, i1, i2]);
    ([g[i0], g[i1], g[i2]], [x[i0], x[i1], x[i2]], w)
}

/// Second-order part of the (quasi-)conformal quadratic form with constant weights
/// ([`Metric::add_second_order`](super::Metric::add_second_order)): residual `w_k T_k` of every
/// face corner contributes `r_k w_k d2 T_k`. Returns `false` for the paper form (not twice
/// differentiable where a `T_v` changes sign).
pub(crate) fn face_second_order(
    topo: &Topology,
    form: ConformalForm,
    seg: &Segment,
    weights: Option<&[f64]>,
    r: &[f64],
    sink: &mut SecondOrderSink,
) -> bool {
    if form != ConformalForm::Quadratic {
        return false;
    }
    let (g, x) = geometry_and_displacement(seg);
    for (fi, f) in topo.faces().iter().enumerate() {
        let (gf, xf, w) = face_data(g, &x, weights, f);
        let mut hgg = [[[0.0; 9]; 3]; 3];
        let mut hgx = [[[0.0; 9]; 3]; 3];
        for k in 0..3 {
            let c = r[3 * fi + k] * w[k];
            if c != 0.0 {
                add_corner_hessian(gf, xf, k, c, &mut hgg, &mut hgx);
            }
        }
        // The three rows of a face share its vertices (and pair slots).
        for m in 0..3 {
            for n in 0..3 {
                sink.add(3 * fi, m, n, &hgg[m][n], &hgx[m][n]);
            }
        }
    }
    true
}

/// The three corner terms of one face in face order: `t[k]` is `T` at corner `k` (for corner
/// `k` the triangle is read as `(f[k], f[k+1], f[k+2])`, the cyclic permutation of eq. 7).
#[inline]
pub(crate) fn face_values(g: [[f64; 3]; 3], x: [[f64; 3]; 3]) -> [f64; 3] {
    // Written out: `array::map` compiles to a slower loop in this hot path.
    [
        corner_value(g, x),
        corner_value(rot(g, 1), rot(x, 1)),
        corner_value(rot(g, 2), rot(x, 2)),
    ]
}

/// Per corner `k` and face slot `m`, a 3-vector: `[k][m]`.
pub(crate) type FaceGradient = [[[f64; 3]; 3]; 3];

/// Gradients of [`face_values`] in face slots: `dg[k][m] = dT_k/dg_{f[m]}`,
/// `dx[k][m] = dT_k/dX_{f[m]}`.
#[inline]
pub(crate) fn face_gradients(g: [[f64; 3]; 3], x: [[f64; 3]; 3]) -> (FaceGradient, FaceGradient) {
    let mut dg = [[[0.0; 3]; 3]; 3];
    let mut dx = [[[0.0; 3]; 3]; 3];
    for k in 0..3 {
        let (cg, cx) = corner_gradient(rot(g, k), rot(x, k));
        for j in 0..3 {
            dg[k][NEXT[k][j]] = cg[j];
            dx[k][NEXT[k][j]] = cx[j];
        }
    }
    (dg, dx)
}

/// `NEXT[k][j] = (k + j) mod 3` (a table: the hot loops avoid integer division).
const NEXT: [[usize; 3]; 3] = [[0, 1, 2], [1, 2, 0], [2, 0, 1]];

/// `[v[k], v[k+1], v[k+2]]` (indices mod 3), for `k < 3`.
#[inline]
fn rot(v: [[f64; 3]; 3], k: usize) -> [[f64; 3]; 3] {
    match k {
        0 => v,
        1 => [v[1], v[2], v[0]],
        _ => [v[2], v[0], v[1]],
    }
}

/// Pattern with every residual on its face's three vertices (face order), `per_face` rows per
/// face.
pub(crate) fn face_pattern(topo: &Topology, per_face: usize) -> Pattern {
    Pattern::from_rows(
        topo.faces()
            .iter()
            .flat_map(|f| std::iter::repeat_n(*f, per_face)),
    )
}

/// Where [`face_kernel`] puts each face's residuals and derivatives.
pub(crate) enum FaceOut<'r, 'j, 's, 'g> {
    /// Residuals in [`face_pattern`] order, and the Jacobian if given.
    Residuals(&'r mut [f64], Option<JacobianMut<'j>>),
    /// `weight * 2 J^T r` accumulated per vertex (the Jacobian is never stored).
    Gradient(&'s mut GradientSink<'g>),
}

/// Residuals and Jacobian of the (quasi-)conformal metric with weights that do not depend on
/// the segment: `w_v = weights[v]` (all 1 when `None`, the conformal metric). Rows are those of
/// [`face_pattern`] (entry `row * 3 + m` is face slot `m`).
pub(crate) fn eval_constant_weights(
    topo: &Topology,
    form: ConformalForm,
    seg: &Segment,
    weights: Option<&[f64]>,
    r: &mut [f64],
    jac: Option<JacobianMut>,
) {
    face_kernel(topo, form, seg, weights, FaceOut::Residuals(r, jac));
}

/// The per-face kernel of [`eval_constant_weights`], writing residuals (and Jacobian) or
/// accumulating the gradient. Returns `|r|^2` (times the sink's weight for a gradient).
pub(crate) fn face_kernel(
    topo: &Topology,
    form: ConformalForm,
    seg: &Segment,
    weights: Option<&[f64]>,
    mut out: FaceOut,
) -> f64 {
    let (g, x) = geometry_and_displacement(seg);
    let n_rows = form.residuals_per_face();
    let mut value = 0.0;
    for (fi, f) in topo.faces().iter().enumerate() {
        let (gf, xf, w) = face_data(g, &x, weights, f);
        let t = face_values(gf, xf);
        let wt = [w[0] * t[0], w[1] * t[1], w[2] * t[2]];
        // Residuals of this face, and the coefficient of dT_k in each.
        let mut rows = [0.0; 3];
        let mut coef = [[0.0; 3]; 3];
        match form {
            ConformalForm::Quadratic => {
                for k in 0..3 {
                    rows[k] = wt[k];
                    coef[k][k] = w[k];
                }
            }
            ConformalForm::Paper => {
                rows[0] = wt[0].abs() + wt[1].abs() + wt[2].abs();
                for k in 0..3 {
                    coef[0][k] = sign0(wt[k]) * w[k];
                }
            }
        }
        value += rows[..n_rows].iter().map(|v| v * v).sum::<f64>();
        let need_jac = match &mut out {
            FaceOut::Residuals(r, jac) => {
                r[n_rows * fi..n_rows * (fi + 1)].copy_from_slice(&rows[..n_rows]);
                jac.is_some()
            }
            FaceOut::Gradient(_) => true,
        };
        if !need_jac {
            continue;
        }
        let (dg, dx) = face_gradients(gf, xf);
        for (i, c) in coef.iter().enumerate().take(n_rows) {
            let row = n_rows * fi + i;
            for m in 0..3 {
                let mut sg = [0.0; 3];
                let mut sx = [0.0; 3];
                for k in 0..3 {
                    if c[k] != 0.0 {
                        sg = add(sg, scale(dg[k][m], c[k]));
                        sx = add(sx, scale(dx[k][m], c[k]));
                    }
                }
                let (da, db) = split_segment(seg.at, sg, sx);
                match &mut out {
                    FaceOut::Residuals(_, Some(j)) => {
                        j.da[row * 3 + m] = da;
                        j.db[row * 3 + m] = db;
                    }
                    FaceOut::Residuals(_, None) => {}
                    FaceOut::Gradient(sink) => sink.add(f[m] as usize, rows[i], da, db),
                }
            }
        }
    }
    match out {
        FaceOut::Gradient(sink) => sink.weight * value,
        FaceOut::Residuals(..) => value,
    }
}

/// The conformal metric (eqs. 7-9): for every triangle `(p, q, r)` of `M`,
/// `T_p(X) = <p-q, X_p-X_q> |p-r|^2 - <p-r, X_p-X_r> |p-q|^2` (eq. 7) and `T_q`, `T_r` by the
/// cyclic permutation `p -> q -> r -> p`; the triangle contributes
/// `(|T_p| + |T_q| + |T_r|)^2` ([`ConformalForm::Paper`], eqs. 8-9) or
/// `T_p^2 + T_q^2 + T_r^2` ([`ConformalForm::Quadratic`]).
///
/// `T_p` is the (scaled) rate of change of the ratio `|p-q|^2 / |p-r|^2` (eqs. 4-6), so the
/// metric vanishes on infinitesimal similarities (translations, rotations, uniform scaling)
/// and on conformal fields; regularize with [`super::Regularized`] when a unique geodesic is
/// needed. Residuals: 1 (paper) or 3 (quadratic) per face, each on the face's 3 vertices.
/// Units: a residual is length^4 (positions length^3 times displacement), `G` length^8.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Conformal {
    /// Which triangle term (paper or quadratic).
    pub form: ConformalForm,
}

impl Conformal {
    /// The conformal metric with the given triangle form.
    pub fn new(form: ConformalForm) -> Self {
        Conformal { form }
    }
}

impl Metric for Conformal {
    fn name(&self) -> String {
        format!("conformal({})", self.form.label())
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        face_pattern(topo, self.form.residuals_per_face())
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        self.form.residuals_per_face() * topo.n_faces()
    }

    fn residuals(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        jac: Option<JacobianMut>,
    ) {
        eval_constant_weights(topo, self.form, seg, None, r, jac);
    }

    fn gradient(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        _scratch: &mut Scratch,
        sink: &mut GradientSink,
    ) -> f64 {
        face_kernel(topo, self.form, seg, None, FaceOut::Gradient(sink))
    }

    fn segment_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        match self.form {
            ConformalForm::Quadratic => {
                super::fused::quadratic_segment_gradient(topo, segs[0].a, segs[0].b, [None, None], sink)
            }
            ConformalForm::Paper => segment_gradient_per_term(self, topo, pattern, segs, scratch, sink),
        }
    }

    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        match self.form {
            ConformalForm::Quadratic => {
                super::fused::quadratic_segment_values(topo, segs[0].a, segs[0].b, [None, None])
            }
            ConformalForm::Paper => segs.map(|seg| squared_norm_from_residuals(self, topo, pattern, seg)),
        }
    }

    fn add_second_order(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        r: &[f64],
        sink: &mut SecondOrderSink,
    ) -> bool {
        face_second_order(topo, self.form, seg, None, r, sink)
    }
}

/// Segment `a -> b = a + X` at `at`, for tests.
#[cfg(test)]
pub(crate) fn test_segment<'a>(a: &'a [[f64; 3]], b: &'a [[f64; 3]], at: super::segment::At) -> Segment<'a> {
    Segment {
        a,
        b,
        at,
        aux: &[],
        frozen: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::cross;
    use crate::metric::{fdcheck, At};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const FORMS: [ConformalForm; 2] = [ConformalForm::Paper, ConformalForm::Quadratic];

    #[test]
    fn conformal_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&Conformal::new(ConformalForm::Paper), 13);
        fdcheck::check_metric(&Conformal::new(ConformalForm::Quadratic), 17);
    }

    #[test]
    fn names() {
        assert_eq!(Conformal::new(ConformalForm::Paper).name(), "conformal(paper)");
        assert_eq!(
            Conformal::new(ConformalForm::Quadratic).name(),
            "conformal(quadratic)"
        );
    }

    fn g_of(metric: &dyn Metric, a: &[[f64; 3]], field: impl Fn([f64; 3]) -> [f64; 3], at: At) -> f64 {
        let s = crate::synth::icosphere(2);
        assert_eq!(s.positions.len(), a.len());
        let b: Vec<[f64; 3]> = a.iter().map(|p| add(*p, field(*p))).collect();
        let pat = metric.pattern(&s.topology);
        metric.squared_norm(&s.topology, &pat, &test_segment(a, &b, at))
    }

    #[test]
    fn conformal_vanishes_on_similarities_and_not_on_a_stretch() {
        let s = crate::synth::icosphere(2);
        // A slightly irregular sphere so that nothing vanishes by symmetry.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let a: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| p.map(|c| c + 0.02 * (rng.random::<f64>() - 0.5)))
            .collect();
        let noise: Vec<[f64; 3]> = a
            .iter()
            .map(|_| [0, 1, 2].map(|_| 0.01 * (rng.random::<f64>() - 0.5)))
            .collect();
        let w = [0.3, -0.2, 0.7];
        for form in FORMS {
            let m = Conformal::new(form);
            // Reference: a random field of comparable size (0.01).
            let b: Vec<[f64; 3]> = a.iter().zip(&noise).map(|(p, n)| add(*p, *n)).collect();
            let pat = m.pattern(&s.topology);
            let g_rand = m.squared_norm(&s.topology, &pat, &test_segment(&a, &b, At::Start));
            assert!(g_rand > 0.0);
            for at in [At::Start, At::End] {
                let g_scale = g_of(&m, &a, |p| scale(p, 0.01), at);
                assert!(
                    g_scale < 1e-20 * g_rand,
                    "{form:?} {at:?}: scaling {g_scale} vs {g_rand}"
                );
            }
            let g_rigid = g_of(
                &m,
                &a,
                |p| add(scale(cross(w, p), 0.01), [0.01, -0.02, 0.005]),
                At::Start,
            );
            assert!(g_rigid < 1e-20 * g_rand, "{form:?}: rigid {g_rigid} vs {g_rand}");
            let g_stretch = g_of(&m, &a, |p| [0.01 * p[0], 0.0, 0.0], At::Start);
            assert!(
                g_stretch > 1e-2 * g_rand,
                "{form:?}: stretch {g_stretch} vs {g_rand}"
            );
        }
    }

    #[test]
    fn degenerate_triangles_give_finite_values() {
        let s = crate::synth::icosphere(1);
        let a = vec![[0.0; 3]; s.positions.len()];
        let b = s.positions.clone();
        for form in FORMS {
            let m = Conformal::new(form);
            let pat = m.pattern(&s.topology);
            let mut r = vec![0.0; pat.n_residuals()];
            let mut jac = super::super::Jacobian::zeros(&pat, 0);
            for at in [At::Start, At::End] {
                m.residuals(
                    &s.topology,
                    pat.as_ref(),
                    &test_segment(&a, &b, at),
                    &mut r,
                    Some(jac.as_mut()),
                );
                assert!(r.iter().all(|v| v.is_finite()));
                assert!(jac.da.iter().chain(&jac.db).flatten().all(|v| v.is_finite()));
            }
        }
    }
}
