//! The fused segment kernel of the quadratic conformal form (eq. 7 with
//! [`super::ConformalForm::Quadratic`]), shared by the conformal and the quasi-conformal metric
//! (eq. 10, frozen curvature-change weights): both terms of a path segment (eq. 12: the
//! geometry of its start and of its end) in one pass, written on the mesh's undirected edges.
//!
//! Corner `k` of a face (neighbours `k+1`, `k+2`) is `T_k = P_ka L_kb - P_kb L_ka` with the
//! squared edge lengths `L_ij = |g_i - g_j|^2` and the products `P_ij = <g_i - g_j, X_i - X_j>`
//! of the geometry `g` and the displacement `X`. Every quantity a face needs is a scalar of one
//! of its edges, and both are unchanged when an edge is traversed the other way, so the
//! kernel computes them once per edge (each interior edge serves two faces), the faces turn
//! them into per-edge derivatives, and each edge writes its gradient on its two vertices.

use super::gradient::SegmentSink;
use crate::mesh::geometry::{dot, sub};
use crate::mesh::Topology;

/// The weights of a face's corners (all 1 without weights).
#[inline(always)]
pub(crate) fn face_weights(weights: Option<&[f64]>, v: &[usize; 3]) -> [f64; 3] {
    match weights {
        Some(w) => [w[v[0]], w[v[1]], w[v[2]]],
        None => [1.0; 3],
    }
}

/// The edge vectors `(e^a, e^b) = (a_i - a_j, b_i - b_j)` of every edge `(i, j)` of
/// [`Topology::edges`] on the segment `a -> b`.
fn edge_vectors<'a>(
    topo: &'a Topology,
    a: &'a [[f64; 3]],
    b: &'a [[f64; 3]],
) -> impl Iterator<Item = ([f64; 3], [f64; 3])> + 'a {
    topo.edges().iter().map(move |&[i, j]| {
        let (i, j) = (i as usize, j as usize);
        (sub(a[i], a[j]), sub(b[i], b[j]))
    })
}

/// The scalars of one edge `i -> j` (`(min, max)` of [`Topology::edges`]) on a segment
/// `a -> b`: with `e^a = a_i - a_j`, `e^b = b_i - b_j` and the displacement edge
/// `d = e^b - e^a`, `[L^a, L^b, P^a, P^b] = [|e^a|^2, |e^b|^2, <e^a, d>, <e^b, d>]`
/// (length^2 each).
#[inline(always)]
fn edge_scalars(ea: [f64; 3], eb: [f64; 3]) -> [f64; 4] {
    let d = sub(eb, ea);
    [dot(ea, ea), dot(eb, eb), dot(ea, d), dot(eb, d)]
}

/// The squared lengths `l` and products `p` of a face's edges (edge `k` joins corners `k` and
/// `k+1`) from the per-edge scalars, for the start term (`t = 0`: `L^a`, `P^a`) or the end
/// term (`t = 1`: `L^b`, `P^b`).
#[inline(always)]
fn face_scalars(s: &[[f64; 4]], fe: &[u32; 3], t: usize) -> ([f64; 3], [f64; 3]) {
    let e = [fe[0] as usize, fe[1] as usize, fe[2] as usize];
    (
        [s[e[0]][t], s[e[1]][t], s[e[2]][t]],
        [s[e[0]][2 + t], s[e[1]][2 + t], s[e[2]][2 + t]],
    )
}

/// One face term of the quadratic form on its edges: adds `sum_k (w_k T_k)^2` to `value` and
/// returns `dphi/dL`, `dphi/dP` per edge for `phi = sum_k c_k T_k`, `c_k = two_w w_k^2 T_k`
/// (`two_w = 2 weight`), i.e. the derivatives of `weight sum_k (w_k T_k)^2`.
#[inline(always)]
fn edge_derivatives(
    l: &[f64; 3],
    p: &[f64; 3],
    w: &[f64; 3],
    two_w: f64,
    value: &mut f64,
) -> ([f64; 3], [f64; 3]) {
    let mut dl = [0.0; 3];
    let mut dp = [0.0; 3];
    for (k, &wk) in w.iter().enumerate() {
        // Edge to corner k+1 is edge k, edge to k+2 is edge k+2 (P, L symmetric in i, j).
        let (ea, eb) = (k, (k + 2) % 3);
        let wt = wk * (p[ea] * l[eb] - p[eb] * l[ea]);
        *value += wt * wt;
        let c = two_w * wk * wt;
        dp[ea] += c * l[eb];
        dl[eb] += c * p[ea];
        dp[eb] -= c * l[ea];
        dl[ea] -= c * p[eb];
    }
    (dl, dp)
}

/// `sum_k (w_k T_k)^2` of one face from its edge quantities (the value part of
/// [`edge_derivatives`]).
#[inline(always)]
fn edge_value(l: &[f64; 3], p: &[f64; 3], w: &[f64; 3]) -> f64 {
    let mut value = 0.0;
    for (k, &wk) in w.iter().enumerate() {
        let (ea, eb) = (k, (k + 2) % 3);
        let wt = wk * (p[ea] * l[eb] - p[eb] * l[ea]);
        value += wt * wt;
    }
    value
}

/// The fused gradient of the quadratic form `weight sum_k (w_k T_k)^2` over all faces, for
/// both terms of a segment `a -> b` (each #V x 3) in one pass (`weights[t]`, #V, those of term
/// `t`: `At::Start` with the geometry of `a`, then `At::End` with that of `b`; `None`: all 1),
/// added to `sink.ga` and `sink.gb` (#V x 3). Returns `weight |r|^2` of both terms (units:
/// length^8 times the weights squared).
///
/// With the derivatives `dl_S, dp_S` (start term) and `dl_E, dp_E` (end term) of an edge,
/// summed over its faces, the chain rule through `L^a = |e^a|^2`, `P^a = <e^a, e^b - e^a>`,
/// `L^b = |e^b|^2` and `P^b = <e^b, e^b - e^a>` gives the edge's gradients
/// `G^a = (2 dl_S - 2 dp_S) e^a + (dp_S - dp_E) e^b` and
/// `G^b = (dp_S - dp_E) e^a + (2 dl_E + 2 dp_E) e^b`, added to the edge's first vertex and
/// subtracted from its second. The same result as two calls of the general per-face kernel
/// (test `segment_gradients_match_the_per_term_jacobian_form`), up to rounding.
pub(crate) fn quadratic_segment_gradient(
    topo: &Topology,
    a: &[[f64; 3]],
    b: &[[f64; 3]],
    weights: [Option<&[f64]>; 2],
    sink: &mut SegmentSink,
) -> f64 {
    let two_w = 2.0 * sink.weight;
    let edges = topo.edges();
    // Pass 1, per edge: the edge vectors of both poses and their scalars.
    let vectors: Vec<([f64; 3], [f64; 3])> = edge_vectors(topo, a, b).collect();
    let scalars: Vec<[f64; 4]> = vectors.iter().map(|&(ea, eb)| edge_scalars(ea, eb)).collect();
    // Pass 2, per face: the derivatives, summed per edge as the three coefficients of
    // `G^a = ca e^a + cm e^b`, `G^b = cm e^a + cb e^b`.
    let mut coef = vec![[0.0f64; 3]; edges.len()];
    let mut value = 0.0;
    for (f, fe) in topo.faces().iter().zip(topo.face_edges()) {
        let v = [f[0] as usize, f[1] as usize, f[2] as usize];
        let (la, pa) = face_scalars(&scalars, fe, 0);
        let (lb, pb) = face_scalars(&scalars, fe, 1);
        let (dls, dps) = edge_derivatives(&la, &pa, &face_weights(weights[0], &v), two_w, &mut value);
        let (dle, dpe) = edge_derivatives(&lb, &pb, &face_weights(weights[1], &v), two_w, &mut value);
        for k in 0..3 {
            let c = &mut coef[fe[k] as usize];
            c[0] += 2.0 * (dls[k] - dps[k]);
            c[1] += dps[k] - dpe[k];
            c[2] += 2.0 * (dle[k] + dpe[k]);
        }
    }
    // Pass 3, per edge: the gradients on its two vertices.
    for ((&[i, j], (ea, eb)), c) in edges.iter().zip(&vectors).zip(&coef) {
        let (i, j) = (i as usize, j as usize);
        for k in 0..3 {
            let ga = c[0] * ea[k] + c[1] * eb[k];
            let gb = c[1] * ea[k] + c[2] * eb[k];
            sink.ga[i][k] += ga;
            sink.ga[j][k] -= ga;
            sink.gb[i][k] += gb;
            sink.gb[j][k] -= gb;
        }
    }
    sink.weight * value
}

/// The value-only sibling of [`quadratic_segment_gradient`]: `[sum_k (w_k T_k)^2]` of the start
/// term (geometry `a`, weights `weights[0]`) and of the end term (geometry `b`, `weights[1]`)
/// for the displacement `b - a` (each #V x 3), with the same per-edge quantities (the
/// straight-path lengths of the cohort mode). Units: length^8.
pub(crate) fn quadratic_segment_values(
    topo: &Topology,
    a: &[[f64; 3]],
    b: &[[f64; 3]],
    weights: [Option<&[f64]>; 2],
) -> [f64; 2] {
    let scalars: Vec<[f64; 4]> = edge_vectors(topo, a, b)
        .map(|(ea, eb)| edge_scalars(ea, eb))
        .collect();
    let mut value = [0.0; 2];
    for (f, fe) in topo.faces().iter().zip(topo.face_edges()) {
        let v = [f[0] as usize, f[1] as usize, f[2] as usize];
        for (t, out) in value.iter_mut().enumerate() {
            let (l, p) = face_scalars(&scalars, fe, t);
            *out += edge_value(&l, &p, &face_weights(weights[t], &v));
        }
    }
    value
}
