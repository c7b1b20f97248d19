//! The metric's inner product `<<U, V>>_S` at a pose `S` (docs/method.md
//! "Deformation transfer").
//!
//! Every metric of the library is a sum of squared residuals `G_S(X) = |r(S, X)|^2`. For all
//! forms used by the transport the residuals are linear in the tangent vector `X` at fixed
//! geometry `S` (and fixed frozen weights), `r = J X`, so `G_S(X) = X^T J^T J X` and the inner
//! product is the polarization `<<U, V>>_S = U^T J^T J V`. `J = dr/dX` is read from the metric's
//! own Jacobian on the segment `a = S, b = S + X` measured at [`At::Start`]: with the geometry
//! taken from `a`, the `b`-block of the Jacobian is exactly `dr/dX` (and it does not depend on
//! `X`). The operator `G_S v = J^T (J v)` is applied from the sparsity pattern, one pass over the
//! Jacobian entries per product.
//!
//! Which form (docs/method.md "Deformation transfer"):
//! - the conformal / quasi-conformal `paper` form `(|T_p| + |T_q| + |T_r|)^2` is not a quadratic
//!   form; its `quadratic` companion `T_p^2 + T_q^2 + T_r^2` is used ([`quadratic_companion`]);
//! - the quasi-conformal `segment` reading has weights `K(b) - K(a)` that depend on `X` itself
//!   (the form is quartic); the transport uses the `endpoints` weights instead, i.e. the
//!   curvature change between the ends of the transport curve, like the `endpoints` metric;
//! - frozen weights (quasi-conformal `endpoints` weights, frozen L2 areas of the regularizer or of
//!   the L2 metric) are taken from the transport curve `gamma` from `S_0` to `S_J`:
//!   [`TransportMetric::frozen_weights`]`(S_0, S_J)`, and are the same at every sample of the curve;
//! - the rigid metric has auxiliary unknowns (the fitted rigid motion `a`):
//!   `G(X) = min_a |J_x X + J_a a|^2`, still a quadratic form in `X`. It is applied exactly as
//!   `G = J_x^T (I - P_a) J_x`, with `P_a = J_a (J_a^T J_a)^+ J_a^T` the orthogonal projection onto
//!   the span of the motion's columns (a 6 x 6 pseudo-inverse by a symmetric eigensolver).
//!   [`crate::metric::Rigid::best_aux`] adds a relative ridge of 1e-14 to its 3 x 3 solve, so
//!   the two agree to about that precision.

use std::sync::Arc;

use super::{dot, TransportError};
use crate::mesh::Topology;
use crate::metric::{
    At, Calibration, ConformalForm, Jacobian, Metric, MetricSpec, Pattern, QcWeights, Segment,
};

/// The metric whose polarization is the transport's inner product: `spec` with the conformal
/// triangle term set to [`ConformalForm::Quadratic`] and the quasi-conformal weights set to
/// [`QcWeights::Endpoints`] (docs/method.md "Deformation transfer": the `paper` form is replaced
/// by its `quadratic` companion; the `segment` reading by the endpoint weights of the transport
/// curve). `lambda` and the L2 area choice are kept.
pub fn quadratic_companion(spec: &MetricSpec) -> MetricSpec {
    MetricSpec {
        form: ConformalForm::Quadratic,
        weights: QcWeights::Endpoints,
        ..*spec
    }
}

/// The transport's metric on one topology: the [`quadratic_companion`] of a [`MetricSpec`], its
/// Jacobian pattern (built once) and the topology. Cheap to share across threads (`Sync`).
#[derive(Debug)]
pub struct TransportMetric {
    spec: MetricSpec,
    metric: Box<dyn Metric>,
    topo: Arc<Topology>,
    pattern: Pattern,
}

impl TransportMetric {
    /// Builds the quadratic companion of `spec` on `topo`, with the factors `calibration` of
    /// the analysis ([`MetricSpec::calibrate`]).
    pub fn new(spec: &MetricSpec, calibration: &Calibration, topo: Arc<Topology>) -> Self {
        let spec = quadratic_companion(spec);
        let metric = spec.build(calibration);
        let pattern = metric.pattern(&topo);
        TransportMetric {
            spec,
            metric,
            topo,
            pattern,
        }
    }

    /// The companion spec actually used.
    pub fn spec(&self) -> &MetricSpec {
        &self.spec
    }

    /// The companion metric (a quadratic form in `X`).
    pub fn metric(&self) -> &dyn Metric {
        self.metric.as_ref()
    }

    /// Its Jacobian pattern on the topology.
    pub fn pattern(&self) -> &Pattern {
        &self.pattern
    }

    /// The topology.
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topo
    }

    /// Frozen weights for a transport curve from `start` to `end` (each #V x 3): the metric's
    /// [`Metric::frozen_weights`] (curvature change `K(end) - K(start)` for quasi-conformal, mean
    /// vertex areas of the ends for the frozen L2 parts), or `None`.
    pub fn frozen_weights(&self, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        self.metric.frozen_weights(&self.topo, start, end)
    }

    /// The inner product at `pose` (#V x 3) with the given frozen weights (from
    /// [`TransportMetric::frozen_weights`] of the curve). Errors if `pose` does not have #V
    /// vertices, if the Jacobian is not finite (degenerate pose), or if the metric's residuals
    /// do not vanish at `X = 0` (not a quadratic form).
    pub fn at(&self, pose: &[[f64; 3]], frozen: Option<&[f64]>) -> Result<InnerProduct<'_>, TransportError> {
        let nv = self.topo.n_vertices();
        if pose.len() != nv {
            return Err(TransportError::VertexCount {
                what: "pose".into(),
                got: pose.len(),
                expected: nv,
            });
        }
        let n_aux = self.metric.n_aux();
        let aux = vec![0.0; n_aux];
        let seg = Segment {
            a: pose,
            b: pose,
            at: At::Start,
            aux: &aux,
            frozen,
        };
        let m = self.pattern.n_residuals();
        let mut r = vec![0.0; m];
        let mut jac = Jacobian::zeros(&self.pattern, n_aux);
        self.metric.residuals(
            &self.topo,
            self.pattern.as_ref(),
            &seg,
            &mut r,
            Some(jac.as_mut()),
        );
        if jac.db.iter().flatten().chain(&jac.daux).any(|v| !v.is_finite()) {
            return Err(TransportError::NonFinite {
                what: format!(
                    "the Jacobian of {} is not finite at this pose (degenerate triangles?)",
                    self.metric.name()
                ),
            });
        }
        if r.iter().any(|v| *v != 0.0) {
            return Err(TransportError::NotQuadratic {
                metric: self.metric.name().to_string(),
            });
        }
        let trace = jac.db.iter().flatten().map(|v| v * v).sum();
        let aux = (n_aux > 0).then(|| AuxProjection::new(jac.daux, n_aux));
        Ok(InnerProduct {
            pattern: &self.pattern,
            n: 3 * nv,
            jx: jac.db,
            aux,
            trace,
        })
    }
}

/// The exact projection `I - J_a (J_a^T J_a)^+ J_a^T` removing the auxiliary unknowns.
#[derive(Debug, Clone)]
struct AuxProjection {
    /// Number of auxiliary unknowns `k`.
    k: usize,
    /// `J_a`, #residuals x k, row-major.
    ja: Vec<f64>,
    /// `(J_a^T J_a)^+`, k x k.
    pinv: Vec<f64>,
}

impl AuxProjection {
    fn new(ja: Vec<f64>, k: usize) -> Self {
        let mut m = vec![0.0; k * k];
        for row in ja.chunks_exact(k) {
            for i in 0..k {
                for j in 0..k {
                    m[i * k + j] += row[i] * row[j];
                }
            }
        }
        let pinv = symmetric_pinv(&m, k);
        AuxProjection { k, ja, pinv }
    }

    /// `r <- r - J_a (J_a^T J_a)^+ J_a^T r`.
    fn project(&self, r: &mut [f64]) {
        let k = self.k;
        let mut t = vec![0.0; k];
        for (row, ri) in self.ja.chunks_exact(k).zip(r.iter()) {
            for (tj, a) in t.iter_mut().zip(row) {
                *tj += a * ri;
            }
        }
        let s: Vec<f64> = (0..k)
            .map(|i| (0..k).map(|j| self.pinv[i * k + j] * t[j]).sum())
            .collect();
        for (row, ri) in self.ja.chunks_exact(k).zip(r.iter_mut()) {
            *ri -= dot(row, &s);
        }
    }
}

/// Moore-Penrose pseudo-inverse of a small symmetric positive semi-definite matrix (k x k,
/// row-major) by cyclic Jacobi rotations; eigenvalues below `1e-12` times the largest count as
/// zero.
fn symmetric_pinv(m: &[f64], k: usize) -> Vec<f64> {
    let mut a = m.to_vec();
    let mut v = vec![0.0; k * k];
    for i in 0..k {
        v[i * k + i] = 1.0;
    }
    for _sweep in 0..100 {
        let off: f64 = (0..k)
            .flat_map(|i| (0..k).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * k + j] * a[i * k + j])
            .sum();
        let diag: f64 = (0..k).map(|i| a[i * k + i] * a[i * k + i]).sum();
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for p in 0..k {
            for q in p + 1..k {
                let apq = a[p * k + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * k + q] - a[p * k + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                // A <- R^T A R with the rotation in the (p, q) plane.
                for i in 0..k {
                    let (aip, aiq) = (a[i * k + p], a[i * k + q]);
                    a[i * k + p] = c * aip - s * aiq;
                    a[i * k + q] = s * aip + c * aiq;
                }
                for j in 0..k {
                    let (apj, aqj) = (a[p * k + j], a[q * k + j]);
                    a[p * k + j] = c * apj - s * aqj;
                    a[q * k + j] = s * apj + c * aqj;
                }
                for i in 0..k {
                    let (vip, viq) = (v[i * k + p], v[i * k + q]);
                    v[i * k + p] = c * vip - s * viq;
                    v[i * k + q] = s * vip + c * viq;
                }
            }
        }
    }
    let lmax = (0..k).map(|i| a[i * k + i].abs()).fold(0.0, f64::max);
    let mut out = vec![0.0; k * k];
    for e in 0..k {
        let l = a[e * k + e];
        if l <= 1e-12 * lmax || l <= 0.0 {
            continue;
        }
        for i in 0..k {
            for j in 0..k {
                out[i * k + j] += v[i * k + e] * v[j * k + e] / l;
            }
        }
    }
    out
}

/// The inner product `<<U, V>>_S = U^T G_S V` of a metric at one pose `S` (built by
/// [`TransportMetric::at`]). Vectors are #V x 3 arrays or flat arrays of length 3 #V
/// (`x0, y0, z0, x1, ...`), in the (normalized) units of the pose; the value is in the metric's
/// units (length^4 for L2, see each metric).
#[derive(Debug, Clone)]
pub struct InnerProduct<'t> {
    pattern: &'t Pattern,
    n: usize,
    jx: Vec<[f64; 3]>,
    aux: Option<AuxProjection>,
    trace: f64,
}

impl InnerProduct<'_> {
    /// Length 3 #V of the flat vectors.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// `sum |dr/dX|^2` over the Jacobian entries: `trace(J^T J)`, an upper bound of the largest
    /// eigenvalue of `G_S` (used as the operator's scale).
    pub fn trace_bound(&self) -> f64 {
        self.trace
    }

    /// The residual image `(I - P_a) J x` (flat `x`, length 3 #V).
    fn image(&self, x: &[f64]) -> Vec<f64> {
        let m = self.pattern.n_residuals();
        let mut r = vec![0.0; m];
        for (i, ri) in r.iter_mut().enumerate() {
            let mut s = 0.0;
            for k in self.pattern.row(i) {
                let v = self.pattern.vertices[k] as usize;
                let j = self.jx[k];
                s += j[0] * x[3 * v] + j[1] * x[3 * v + 1] + j[2] * x[3 * v + 2];
            }
            *ri = s;
        }
        if let Some(p) = &self.aux {
            p.project(&mut r);
        }
        r
    }

    /// `out = G_S x` for flat `x` and `out` (length 3 #V): one pass `J x`, the projection for
    /// auxiliary unknowns, one pass `J^T`.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        let r = self.image(x);
        out.fill(0.0);
        for (i, ri) in r.iter().enumerate() {
            for k in self.pattern.row(i) {
                let v = self.pattern.vertices[k] as usize;
                let j = self.jx[k];
                out[3 * v] += j[0] * ri;
                out[3 * v + 1] += j[1] * ri;
                out[3 * v + 2] += j[2] * ri;
            }
        }
    }

    /// `<<u, v>>_S` for flat vectors (length 3 #V).
    pub fn inner_flat(&self, u: &[f64], v: &[f64]) -> f64 {
        let ru = self.image(u);
        if std::ptr::eq(u, v) {
            return dot(&ru, &ru);
        }
        dot(&ru, &self.image(v))
    }

    /// `<<u, v>>_S` (each #V x 3).
    pub fn inner(&self, u: &[[f64; 3]], v: &[[f64; 3]]) -> f64 {
        self.inner_flat(u.as_flattened(), v.as_flattened())
    }

    /// `<<v, v>>_S = G_S(v)` (#V x 3).
    pub fn squared_norm(&self, v: &[[f64; 3]]) -> f64 {
        let r = self.image(v.as_flattened());
        dot(&r, &r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pseudo_inverse_of_a_rank_deficient_matrix() {
        // M = u u^T + 2 w w^T with orthonormal u, w in R^3: pinv = u u^T + w w^T / 2.
        let s = 1.0 / 2f64.sqrt();
        let (u, w) = ([s, s, 0.0], [0.0, 0.0, 1.0]);
        let mut m = vec![0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                m[i * 3 + j] = u[i] * u[j] + 2.0 * w[i] * w[j];
            }
        }
        let p = symmetric_pinv(&m, 3);
        for i in 0..3 {
            for j in 0..3 {
                let want = u[i] * u[j] + 0.5 * w[i] * w[j];
                assert!(
                    (p[i * 3 + j] - want).abs() < 1e-12,
                    "{i}{j}: {} vs {want}",
                    p[i * 3 + j]
                );
            }
        }
    }

    #[test]
    fn companion_replaces_paper_form_and_segment_weights() {
        use crate::metric::MetricKind;
        let mut s = MetricSpec::new(MetricKind::QuasiConformal);
        s.form = ConformalForm::Paper;
        s.weights = QcWeights::Segment;
        s.lambda = 0.3;
        let c = quadratic_companion(&s);
        assert_eq!(c.form, ConformalForm::Quadratic);
        assert_eq!(c.weights, QcWeights::Endpoints);
        assert_eq!(c.lambda, 0.3);
        assert_eq!(c.kind, MetricKind::QuasiConformal);
    }
}
