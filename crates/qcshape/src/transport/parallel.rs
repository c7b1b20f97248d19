//! Discrete parallel transport along the samples of a curve (paper section 2.2.2, docs/method.md
//! "Deformation transfer").
//!
//! Along samples `S_0 .. S_J` (each #V x 3) of a curve, a tangent vector `V_0` (#V x 3) is
//! carried step by step: `V_{j+1}` is the vector closest (Euclidean) to `V_j` such that
//! `<<V, T_{j+1}>>_{S_{j+1}} = a_0` with `T_{j+1} = S_{j+1} - S_j`, and
//! `<<V, V>>_{S_{j+1}} = n_0`, where `a_0 = <<V_0, S_1 - S_0>>_{S_0}` and
//! `n_0 = <<V_0, V_0>>_{S_0}` (the paper's "angle" with the tangent and the norm stay constant).
//!
//! # How one step is solved (exactly, up to a stated tolerance)
//! Write `G = G_{S_{j+1}}` (positive semi-definite), `c = G T` and `P = V_j`. The linear
//! constraint is `c . V = a_0`. Let `V* = P + ((a_0 - c . P) / |c|^2) c` be the Euclidean projection
//! of `P` onto that hyperplane and `Pi` the projection onto `c`'s orthogonal complement. Every
//! feasible `V` is `V* + Z` with `Pi Z = Z`, and `|V - P|^2 = |V* - P|^2 + |Z|^2`, so the step is
//! `min |Z|^2` subject to `h(Z) = (V* + Z)^T G (V* + Z) - n_0 = 0`: the closest point of a
//! quadric. Its stationarity conditions give `Z(mu) = -mu (I + mu Q)^{-1} b` with `Q = Pi G Pi`,
//! `b = Pi G V*`; the global minimizer is the root `mu` with `I + mu Q` positive definite (the
//! S-lemma for one quadratic constraint). In `Q`'s eigenbasis
//! `h(mu) = h_inf + sum_i (b_i^2 / q_i) / (1 + mu q_i)^2`: convex and strictly decreasing on
//! `(-1 / q_max, inf)`, so the root is unique. It is found by Newton's method on `mu`
//! (`h'(mu) = -2 y^T (I + mu Q)^{-1} y`, `y = (I + mu Q)^{-1} b`), safeguarded by a bracket
//! (bisection when a step leaves it, and when conjugate gradients meet a non-positive curvature,
//! which means `mu` lies below `-1 / q_max`). The linear systems are solved by conjugate gradients
//! with the operator of [`InnerProduct`]. This is the KKT system
//! `V = (I + beta G)^{-1} (V_prev - alpha G T)` of the brief with `alpha` eliminated in closed
//! form (the linear constraint holds by construction) and `beta = mu` found from a monotone
//! scalar equation.
//!
//! Degenerate cases: `V_0 = 0` gives zeros; a zero tangent (or one in `G`'s null space, `c = 0`)
//! drops the linear constraint (its residual is reported); if `V_j` already satisfies both
//! constraints (for example all samples equal: the identity) the step returns it unchanged;
//! with a metric that has a null space and `V_0` in it (`n_0 = 0` to rounding, e.g. a rotation for
//! the unregularized isometric metric), each step takes the limit `mu -> inf` exactly,
//! `Z = -Q^+ b` (conjugate gradients on the consistent singular system `Q Z = -b`): the closest
//! null vector of `G_{S_{j+1}}`; any other target norm below the smallest reachable one stops
//! Newton at `|mu| tr(G) = 1e14` or the iteration limit, and the residual is reported.

use super::inner::{InnerProduct, TransportMetric};
use super::{difference, dot, flat, unflat, TransportError};

/// Options of [`parallel_transport`].
#[derive(Debug, Clone)]
pub struct ParallelOptions {
    /// Relative tolerance on the norm constraint, `|<<V,V>> - n_0| <= tolerance * n_0`.
    /// Default 1e-11 (the inner-product constraint holds to rounding by construction).
    pub tolerance: f64,
    /// Newton iterations per step. Default 60.
    pub max_newton: usize,
    /// Relative residual of the conjugate-gradient solves. Default 1e-13.
    pub cg_tolerance: f64,
    /// Iteration limit of one conjugate-gradient solve (0: 3 #V + 100). Default 0.
    pub max_cg: usize,
}

impl Default for ParallelOptions {
    fn default() -> Self {
        ParallelOptions {
            tolerance: 1e-11,
            max_newton: 60,
            cg_tolerance: 1e-13,
            max_cg: 0,
        }
    }
}

/// Diagnostics of one transport step `S_j -> S_{j+1}`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct StepDiagnostics {
    /// `|<<V, T_{j+1}>>_{S_{j+1}} - a_0|`, relative to `sqrt(n_0 <<T_{j+1}, T_{j+1}>>_{S_{j+1}})`
    /// (the Cauchy-Schwarz bound; absolute if that is 0), evaluated afresh after the step.
    pub inner_residual: f64,
    /// `|<<V, V>>_{S_{j+1}} - n_0| / n_0`, evaluated afresh; when `V_0` is a null vector
    /// (`n_0 = 0` to rounding), `<<V, V>> / (tr(G) |V|^2)` instead.
    pub norm_residual: f64,
    /// Whether the inner-product constraint was active (false: zero tangent or tangent in the
    /// metric's null space).
    pub tangent_constraint: bool,
    /// Newton iterations on the multiplier.
    pub newton_iterations: usize,
    /// Conjugate-gradient iterations in all.
    pub cg_iterations: usize,
    /// The multiplier `mu` of the norm constraint (infinite when `V_0` lies in the metric's null
    /// space: the step is then the limit `mu -> inf`, the closest null vector).
    pub multiplier: f64,
    /// Euclidean change `|V_{j+1} - V_j|` (normalized units).
    pub change: f64,
}

/// A transported vector and its diagnostics.
#[derive(Debug, Clone)]
pub struct Transported {
    /// The vector at the last sample `S_J` (#V x 3), in the units of the samples.
    pub vector: Vec<[f64; 3]>,
    /// The vector at every sample `S_0 .. S_J` (J + 1 entries; the first is `V_0`).
    pub along: Vec<Vec<[f64; 3]>>,
    /// `a_0 = <<V_0, S_1 - S_0>>_{S_0}` (0 for a single sample).
    pub initial_inner: f64,
    /// `n_0 = <<V_0, V_0>>_{S_0}`.
    pub initial_norm: f64,
    /// One entry per step (J entries).
    pub steps: Vec<StepDiagnostics>,
}

impl Transported {
    /// The largest relative inner-product residual over the steps (0 without steps).
    pub fn max_inner_residual(&self) -> f64 {
        self.steps.iter().map(|s| s.inner_residual).fold(0.0, f64::max)
    }
    /// The largest relative norm residual over the steps (0 without steps).
    pub fn max_norm_residual(&self) -> f64 {
        self.steps.iter().map(|s| s.norm_residual).fold(0.0, f64::max)
    }
}

/// Euclidean transport (the baseline): the vector is unchanged along any curve.
pub fn euclidean_transport(curve: &[Vec<[f64; 3]>], v0: &[[f64; 3]]) -> Transported {
    Transported {
        vector: v0.to_vec(),
        along: vec![v0.to_vec(); curve.len().max(1)],
        initial_inner: 0.0,
        initial_norm: 0.0,
        steps: Vec::new(),
    }
}

/// Checks a curve of samples (each #V x 3, at least one) and a vector (#V x 3).
pub(crate) fn check_curve(curve: &[Vec<[f64; 3]>], v0: &[[f64; 3]], nv: usize) -> Result<(), TransportError> {
    if curve.is_empty() {
        return Err(TransportError::Empty {
            what: "curve",
            items: "samples",
        });
    }
    if let Some(j) = curve.iter().position(|s| s.len() != nv) {
        return Err(TransportError::VertexCount {
            what: format!("curve sample {j}"),
            got: curve[j].len(),
            expected: nv,
        });
    }
    if v0.len() != nv {
        return Err(TransportError::VectorLength {
            got: v0.len(),
            expected: nv,
        });
    }
    if v0.iter().flatten().any(|c| !c.is_finite()) {
        return Err(TransportError::NonFinite {
            what: "the vector to transport".into(),
        });
    }
    Ok(())
}

/// Parallel transport of `v0` (#V x 3) along the samples `curve = S_0 .. S_J` (each #V x 3) for
/// the inner product of `metric` (see the [module docs](self) for the method). Frozen weights
/// come from the curve's ends, `metric.frozen_weights(S_0, S_J)`. Units: those of the samples
/// (use the normalized coordinates of the geodesic solver).
pub fn parallel_transport(
    metric: &TransportMetric,
    curve: &[Vec<[f64; 3]>],
    v0: &[[f64; 3]],
    options: &ParallelOptions,
) -> Result<Transported, TransportError> {
    let nv = metric.topology().n_vertices();
    check_curve(curve, v0, nv)?;
    for (name, value) in [
        ("tolerance", options.tolerance),
        ("cg-tolerance", options.cg_tolerance),
    ] {
        if value.is_nan() || value <= 0.0 {
            return Err(TransportError::NotPositive { name, value });
        }
    }
    let frozen = metric.frozen_weights(&curve[0], &curve[curve.len() - 1]);
    let g0 = metric.at(&curve[0], frozen.as_deref())?;
    let v = flat(v0);
    let n0 = g0.inner_flat(&v, &v);
    let a0 = if curve.len() > 1 {
        g0.inner_flat(&v, &flat(&difference(&curve[0], &curve[1])))
    } else {
        0.0
    };
    let mut out = Transported {
        vector: v0.to_vec(),
        along: vec![v0.to_vec()],
        initial_inner: a0,
        initial_norm: n0,
        steps: Vec::with_capacity(curve.len().saturating_sub(1)),
    };
    // A curve whose length is at the rounding level of its samples (e.g. the geodesic between
    // two poses that agree to the last bits) has no resolvable tangent: the tangent constraint
    // would compare directions of rounding noise, so transport along it is the identity.
    let length: f64 = curve
        .windows(2)
        .map(|w| dot(&flat(&difference(&w[0], &w[1])), &flat(&difference(&w[0], &w[1]))).sqrt())
        .sum();
    let size = dot(&flat(&curve[0]), &flat(&curve[0])).sqrt();
    let zero = v.iter().all(|c| *c == 0.0) || length <= CONSTANT_CURVE_RELATIVE * size;
    // V_0 in the metric's null space (to rounding): the target is the null space at each sample.
    let null_target = n0 <= NULL_RELATIVE * g0.trace_bound() * dot(&v, &v);
    let targets = Targets { a0, n0, null_target };
    let mut cur = v;
    for w in curve.windows(2) {
        let (next, diag) = if zero {
            (cur.clone(), StepDiagnostics::default())
        } else {
            let g = metric.at(&w[1], frozen.as_deref())?;
            let t = flat(&difference(&w[0], &w[1]));
            step(&g, &t, &cur, targets, options)
        };
        if next.iter().any(|c| !c.is_finite()) {
            return Err(TransportError::NonFinite {
                what: format!("transport step {}'s vector", out.steps.len()),
            });
        }
        cur = next;
        out.along.push(unflat(&cur));
        out.steps.push(diag);
    }
    out.vector = unflat(&cur);
    Ok(out)
}

/// One transport step at the new sample: returns the new vector (flat) and its diagnostics.
fn step(
    g: &InnerProduct,
    t: &[f64],
    prev: &[f64],
    targets: Targets,
    options: &ParallelOptions,
) -> (Vec<f64>, StepDiagnostics) {
    let Targets { a0, n0, null_target } = targets;
    let n = g.dim();
    let mut c = vec![0.0; n];
    g.apply(t, &mut c);
    let cc = dot(&c, &c);
    let tnorm = dot(t, t).sqrt();
    let active = cc > 0.0 && cc.sqrt() > 1e-13 * g.trace_bound() * tnorm;
    let proj = |x: &mut [f64]| {
        if active {
            let s = dot(&c, x) / cc;
            for (xi, ci) in x.iter_mut().zip(&c) {
                *xi -= s * ci;
            }
        }
    };
    let mut vstar = prev.to_vec();
    if active {
        let s = (a0 - dot(&c, prev)) / cc;
        for (xi, ci) in vstar.iter_mut().zip(&c) {
            *xi += s * ci;
        }
    }
    // b = Pi G V*, h(0) = V*^T G V* - n0.
    let mut b = vec![0.0; n];
    g.apply(&vstar, &mut b);
    let h0 = dot(&vstar, &b) - n0;
    proj(&mut b);
    let scale = n0.max(f64::MIN_POSITIVE);
    let max_cg = if options.max_cg == 0 {
        n + 100
    } else {
        options.max_cg
    };
    // x -> x + mu Q x, or Q x alone for mu = inf.
    let op = |mu: f64, x: &[f64], out: &mut [f64]| {
        let mut px = x.to_vec();
        proj(&mut px);
        g.apply(&px, out);
        proj(out);
        if mu.is_finite() {
            for (o, xi) in out.iter_mut().zip(x) {
                *o = xi + mu * *o;
            }
        }
    };
    let mut diag = StepDiagnostics {
        tangent_constraint: active,
        ..Default::default()
    };
    if null_target && h0 > options.tolerance * scale {
        // The limit mu -> inf: Z = -Q^+ b (b lies in the range of Q), the closest vector of
        // least norm; conjugate gradients from 0 on the consistent system Q Z = -b give it.
        let neg_b: Vec<f64> = b.iter().map(|v| -v).collect();
        if let Some((mut z, it)) = cg(
            |x, o| op(f64::INFINITY, x, o),
            &neg_b,
            options.cg_tolerance,
            max_cg,
        ) {
            diag.cg_iterations = it;
            diag.multiplier = f64::INFINITY;
            proj(&mut z);
            let cand: Vec<f64> = vstar.iter().zip(&z).map(|(a, b)| a + b).collect();
            return finish(g, t, &c, prev, cand, targets, diag);
        }
    }
    let mut best = vstar.clone();
    let mut best_mu = 0.0;
    let mut h = h0;
    let mut best_h = h0.abs();
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    let mut mu: f64 = 0.0;
    let mut dh = -2.0 * dot(&b, &b);
    // Past |mu| tr(G) = 1e14 the systems are numerically singular (a target norm reachable only
    // in the limit mu -> inf): stop there and report the residual.
    while h.abs() > options.tolerance * scale
        && diag.newton_iterations < options.max_newton
        && mu.abs() * g.trace_bound() < 1e14
    {
        if dh == 0.0 {
            // b = 0: the norm cannot change within the constraint set (h is constant in mu).
            break;
        }
        diag.newton_iterations += 1;
        if h > 0.0 {
            lo = lo.max(mu);
        } else {
            hi = hi.min(mu);
        }
        // Newton step, kept strictly inside the bracket.
        let mut next = if dh < 0.0 { mu - h / dh } else { f64::NAN };
        if !(next > lo && next < hi) {
            next = match (lo.is_finite(), hi.is_finite()) {
                (true, true) => 0.5 * (lo + hi),
                (true, false) => lo + (lo.abs() + 1.0 / g.trace_bound().max(f64::MIN_POSITIVE)),
                (false, true) => hi - (hi.abs() + 1.0 / g.trace_bound().max(f64::MIN_POSITIVE)),
                (false, false) => 0.0,
            };
        }
        mu = next;
        let Some((y, it1)) = cg(|x, o| op(mu, x, o), &b, options.cg_tolerance, max_cg) else {
            // Non-positive curvature: I + mu Q is not positive definite, mu < -1/q_max.
            lo = mu;
            diag.cg_iterations += max_cg.min(n);
            dh = f64::NAN;
            h = f64::INFINITY;
            continue;
        };
        diag.cg_iterations += it1;
        let mut z: Vec<f64> = y.iter().map(|v| -mu * v).collect();
        proj(&mut z);
        let cand: Vec<f64> = vstar.iter().zip(&z).map(|(a, b)| a + b).collect();
        let mut gv = vec![0.0; n];
        g.apply(&cand, &mut gv);
        h = dot(&cand, &gv) - n0;
        // h'(mu) = -2 y^T (I + mu Q)^{-1} y.
        dh = match cg(|x, o| op(mu, x, o), &y, options.cg_tolerance, max_cg) {
            Some((w, it2)) => {
                diag.cg_iterations += it2;
                -2.0 * dot(&y, &w)
            }
            None => f64::NAN,
        };
        if h.abs() <= best_h {
            best_h = h.abs();
            best = cand;
            best_mu = mu;
        }
    }
    diag.multiplier = best_mu;
    finish(g, t, &c, prev, best, targets, diag)
}

/// The constraint values of a transport: `a_0`, `n_0`, and whether `V_0` is a null vector.
#[derive(Debug, Clone, Copy)]
struct Targets {
    a0: f64,
    n0: f64,
    null_target: bool,
}

/// Length of a curve, relative to the Euclidean norm of its first sample, below which it counts
/// as constant (transport = identity).
const CONSTANT_CURVE_RELATIVE: f64 = 1e-10;

/// Relative size below which `<<V_0, V_0>>` counts as zero: `n_0 <= NULL_RELATIVE tr(G) |V_0|^2`.
const NULL_RELATIVE: f64 = 1e-24;

/// Fills the step's residuals, evaluated afresh on the returned vector `v` (flat).
fn finish(
    g: &InnerProduct,
    t: &[f64],
    c: &[f64],
    prev: &[f64],
    v: Vec<f64>,
    targets: Targets,
    mut diag: StepDiagnostics,
) -> (Vec<f64>, StepDiagnostics) {
    let Targets { a0, n0, null_target } = targets;
    let mut gv = vec![0.0; g.dim()];
    g.apply(&v, &mut gv);
    let nn = dot(&v, &gv);
    diag.norm_residual = if null_target || n0 <= 0.0 {
        // Relative to the largest value the form can take on v.
        nn.abs() / (g.trace_bound() * dot(&v, &v)).max(f64::MIN_POSITIVE)
    } else {
        (nn - n0).abs() / n0
    };
    let tt = dot(t, c);
    let cs = (n0 * tt.max(0.0)).sqrt();
    let inner_err = (dot(&gv, t) - a0).abs();
    diag.inner_residual = if cs > 0.0 { inner_err / cs } else { inner_err };
    diag.change = v
        .iter()
        .zip(prev)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    (v, diag)
}

/// Conjugate gradients for `A x = rhs` with `A` symmetric (applied by `apply(x, out)`), from
/// `x = 0`, until `|r| <= tol |rhs|`. Returns `None` on non-positive curvature `p^T A p <= 0`
/// (`A` not positive definite), else the solution (the last iterate at the iteration limit)
/// and the number of iterations.
fn cg<F: Fn(&[f64], &mut [f64])>(
    apply: F,
    rhs: &[f64],
    tol: f64,
    max_it: usize,
) -> Option<(Vec<f64>, usize)> {
    let n = rhs.len();
    let mut x = vec![0.0; n];
    let mut r = rhs.to_vec();
    let mut p = r.clone();
    let mut ap = vec![0.0; n];
    let mut rr = dot(&r, &r);
    let stop = tol * tol * rr;
    if rr == 0.0 {
        return Some((x, 0));
    }
    for it in 1..=max_it {
        apply(&p, &mut ap);
        let pap = dot(&p, &ap);
        if pap <= 0.0 || !pap.is_finite() {
            return None;
        }
        let alpha = rr / pap;
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
        }
        let rr_new = dot(&r, &r);
        if rr_new <= stop {
            return Some((x, it));
        }
        let beta = rr_new / rr;
        rr = rr_new;
        for i in 0..n {
            p[i] = r[i] + beta * p[i];
        }
    }
    Some((x, max_it))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conjugate_gradients_solve_and_detect_indefiniteness() {
        let a = [[4.0, 1.0], [1.0, 3.0]];
        let mul = |x: &[f64], o: &mut [f64]| {
            o[0] = a[0][0] * x[0] + a[0][1] * x[1];
            o[1] = a[1][0] * x[0] + a[1][1] * x[1];
        };
        let (x, _) = cg(mul, &[1.0, 2.0], 1e-14, 10).unwrap();
        assert!((4.0 * x[0] + x[1] - 1.0).abs() < 1e-12 && (x[0] + 3.0 * x[1] - 2.0).abs() < 1e-12);
        let neg = |x: &[f64], o: &mut [f64]| {
            o[0] = -x[0];
            o[1] = 2.0 * x[1];
        };
        assert!(cg(neg, &[1.0, 0.0], 1e-14, 10).is_none());
    }
}
