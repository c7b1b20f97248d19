//! The bending term: the change of the dihedral angles (the discrete shells' bending
//! energy of Grinspun et al. 2003 and Heeren et al. 2012) over each path segment, weighted so
//! that it is scale-invariant and converges as the mesh is refined (docs/method.md "Bending
//! term").

use super::faces::{face_share_frozen_values, segment_faces, PER_FACE};
use crate::mesh::geometry::{add, cross, dot, scale, sub};
use crate::mesh::Topology;
use crate::metric::gradient::{same_frozen, GradientSink, PoseShare, Scratch, SegmentSink};
use crate::metric::pattern::{JacobianMut, Pattern, PatternRef};
use crate::metric::segment::Segment;
use crate::metric::traits::{segment_gradient_per_term, squared_norm_from_residuals, Metric};

/// [`Topology::edge_faces`]' mark of a boundary side.
const NO_FACE: u32 = u32::MAX;

/// The scale-invariant bending term of the discrete shells (Grinspun et al. 2003; Heeren et al.
/// 2012): on a path segment from pose `a` to pose `b`, `sum over interior edges e of
/// w_e (Phi_a Phi_b c_e)^2`, `c_e = 2 sin((theta_e(b) - theta_e(a)) / 2)` the chord of the
/// change of the dihedral angle `theta_e` (radians; the change itself to within its cube over
/// 24, periodic, so no wrapping), with `w_e = (L_1 + L_2) / (2 (A_1 + A_2))` (`L_f` the sum of
/// face `f`'s squared edge lengths, `A_f` its area; for equilateral faces
/// `3 |e|^2 / (A_1 + A_2)`, the discrete shells' weight) from the frozen face values of the path's
/// ends, like every relative form (docs/method.md "Scale-invariant forms"), and `Phi` each
/// pose's sliver factor (`eta` = 0.05, 0.99 on regular faces). Both of the segment's terms (eq.
/// 12's `G_{P_i}(X_i)` and `G_{P_{i+1}}(X_i)`) are this one value.
///
/// To second order in the step it is the rate form `w_e (dtheta_e / dt)^2` at the segment's
/// midpoint (`c_e = <grad theta(M), b - a> + O(|b - a|^3)`), so the path energy discretizes the
/// integral of the squared rate of change of the curvature over the surface: dimensionless,
/// `G_{sM}(sX) = G_M(X)`, and the same on every refinement of a smooth surface. It vanishes on
/// every rigid motion of the pose, finite or not (the angles do not change), and on isometric
/// motions that keep the dihedral angles, and charges vertex-scale normal wrinkles, which the
/// membrane terms (isometric, conformal) see only through the curvature. Its gradient needs
/// only the angles' first derivatives at the two poses; the path energy computes each pose's
/// angles once ([`Metric::pose_values`]) and each pose's gradient once
/// ([`Metric::pose_gradient`]).
///
/// One residual per interior edge, depending on the edge's two vertices and the two opposite
/// ones (pattern order: the edge's `(min, max)` vertices `i, j`, then `k` opposite in the
/// edge's first face, `l` in its second). Boundary edges (open meshes: the LV surfaces) have no
/// dihedral angle and no residual.
///
/// The angle's gradient: for each wing (the first face about the edge `i -> j` with apex `k`,
/// the second about `j -> i` with apex `l`), `E` the edge from its tail to its head, `K` from
/// the tail to the apex, `N = E x K`, `alpha = <E, K> / |E|^2`: the apex gets `c = |E| N / |N|^2`
/// (the unit normal over the wing's height), the tail `(alpha - 1) c`, the head `-alpha c`.
#[derive(Debug, Clone, Copy, Default)]
pub struct RelativeBending;

/// The interior edges of `topo` with their four vertices `[i, j, k, l]` (`i < j` the edge, `k`
/// opposite in the first face, `l` in the second) and the two faces.
pub(crate) fn hinges(topo: &Topology) -> Vec<([u32; 4], [u32; 2])> {
    let faces = topo.faces();
    let apex = |f: u32, i: u32, j: u32| -> u32 {
        faces[f as usize]
            .iter()
            .copied()
            .find(|&v| v != i && v != j)
            .unwrap_or(i)
    };
    topo.edges()
        .iter()
        .zip(topo.edge_faces())
        .filter(|(_, ef)| ef[0] != NO_FACE && ef[1] != NO_FACE)
        .map(|(&[i, j], &[f1, f2])| ([i, j, apex(f1, i, j), apex(f2, i, j)], [f1, f2]))
        .collect()
}

/// `eta` of the sliver factor of each wing: with `t = |N|^2 / (eta^2 |E|^4) = (h / (eta |E|))^2`
/// (`h = |N| / |E|` the wing's height over the edge), `phi = 1` for `t >= 1` and the smoothstep
/// `phi = t^2 (3 - 2 t)` below (value and slope continuous at `t = 1`). The residual carries
/// `Phi = phi_1 phi_2` of each of its two poses, so that a face collapsing on a path, where the
/// dihedral angle jumps and its gradient blows up like `1 / h`, contributes nothing instead
/// (without it the default solver stalled on the bent tube with a face at 4e-6 of the mean
/// area). Faces higher than `eta |E|` over every edge (all but slivers; an equilateral face has
/// `t = 300`) have `phi = 1` and no factor gradient to compute; rigid motions keep `phi`;
/// dimensionless, so the term stays scale-invariant.
const SLIVER: f64 = 0.05;

/// One hinge at one pose: its signed dihedral angle `theta` as `(sin theta, cos theta)` (as
/// [`dihedral_angles`]), its sliver factor `Phi = phi_1 phi_2` ([`SLIVER`]) and, where asked
/// for, the gradients of `theta` and `Phi` with respect to the hinge's four vertices
/// `[i, j, k, l]`.
#[derive(Clone, Copy, Default)]
struct HingeState {
    angle: [f64; 2],
    phi: f64,
    dtheta: [[f64; 3]; 4],
    dphi: [[f64; 3]; 4],
}

/// Values per hinge in a pose's [`RelativeBending::pose_values`]: `sin theta`, `cos theta`,
/// `Phi`, 1 if a wing is below the sliver threshold (`grad Phi` not zero) else 0, and
/// `grad theta` with respect to `[x_i, x_j, x_k, x_l]` (12): the pose gradient is then a
/// scatter, with no second pass over the positions (but at slivers, for `grad Phi`).
const PER_HINGE: usize = 16;

/// Offset of `grad theta` in a hinge's [`PER_HINGE`] values.
const DTHETA: usize = 4;

/// Coefficients per hinge in a segment's share for [`RelativeBending::pose_gradient`]: of
/// `grad theta` and of `grad Phi`.
const COEFFS_PER_HINGE: usize = 2;

/// The two wings of a hinge at positions `p = [x_i, x_j, x_k, x_l]`: the edge `E = x_j - x_i`,
/// `|E|^2`, `|E|`, each wing's `K` (from its tail to its apex: `x_k - x_i` for the first wing
/// about `i -> j`, `x_l - x_j` for the second about `j -> i`), `N` (`E x K_1` and
/// `(-E) x K_2`) and `|N|^2`; `None` for a degenerate edge or face.
struct Wings {
    e: [f64; 3],
    ee: f64,
    le: f64,
    k: [[f64; 3]; 2],
    n: [[f64; 3]; 2],
    nn: [f64; 2],
}

#[inline(always)]
fn wings(p: &[[f64; 3]; 4]) -> Option<Wings> {
    let [xi, xj, xk, xl] = *p;
    let e = sub(xj, xi);
    let ee = dot(e, e);
    let (k1, k2) = (sub(xk, xi), sub(xl, xj));
    let (n1, n2) = (cross(e, k1), cross(k2, e));
    let (r1, r2) = (dot(n1, n1), dot(n2, n2));
    let ok = |v: f64| v > 0.0 && v.is_finite();
    (ok(ee) && ok(r1) && ok(r2)).then(|| Wings {
        e,
        ee,
        le: ee.sqrt(),
        k: [k1, k2],
        n: [n1, n2],
        nn: [r1, r2],
    })
}

/// The sliver factors `phi(t)` of both wings and their `t = |N|^2 / (eta^2 |E|^4)` ([`SLIVER`]).
#[inline(always)]
fn wing_factors(w: &Wings) -> ([f64; 2], [f64; 2]) {
    let delta = SLIVER * SLIVER * w.ee * w.ee;
    let t = w.nn.map(|r| r / delta);
    (t.map(|t| if t >= 1.0 { 1.0 } else { t * t * (3.0 - 2.0 * t) }), t)
}

/// The hinge's signed dihedral angle `theta` (as [`dihedral_angles`]) as
/// `[sin theta, cos theta]` and its sliver factor `Phi = phi_1 phi_2` at positions `p`;
/// `([0, 1], 0)` for a degenerate hinge.
#[inline(always)]
pub(super) fn hinge_value(p: &[[f64; 3]; 4]) -> ([f64; 2], f64) {
    match wings(p) {
        Some(w) => wings_value(&w),
        None => ([0.0, 1.0], 0.0),
    }
}

/// Whether a wing of the hinge is below the sliver threshold (`t < 1`, [`SLIVER`]), where
/// `grad Phi` is not zero.
#[inline(always)]
fn has_sliver_wing(w: &Wings) -> bool {
    wing_factors(w).1.iter().any(|&t| t < 1.0)
}

/// [`hinge_value`] from the hinge's [`Wings`].
#[inline(always)]
fn wings_value(w: &Wings) -> ([f64; 2], f64) {
    let ([phi1, phi2], _) = wing_factors(w);
    let [n1, n2] = w.n;
    // |N_1| |N_2| (sin theta, cos theta): <N_2 x N_1, E> / |E| with
    // N_2 x N_1 = (K_2 x E) x (E x K_1) = <K_2, N_1> E.
    let (y, x) = (dot(w.k[1], n1) * w.le, dot(n1, n2));
    let rho = (y * y + x * x).sqrt();
    if !(rho > 0.0 && rho.is_finite()) {
        return ([0.0, 1.0], 0.0);
    }
    let inv = 1.0 / rho;
    ([y * inv, x * inv], phi1 * phi2)
}

/// `ct grad theta + cp grad Phi` of the hinge at positions `p`, per vertex `[i, j, k, l]`;
/// zeros for a degenerate hinge.
///
/// The angle's gradient, per wing (tail `t`, head `h`, apex `a`): `c = |E| N / |N|^2` at the
/// apex, `(alpha - 1) c` at the tail, `-alpha c` at the head, `alpha = <E_w, K> / |E|^2` with
/// the wing's own edge `E_w` (`E`, then `-E`). The factor's, per wing below `t = 1` (0 above):
/// `dphi = 6 t (1 - t) dt`, `t = |N|^2 / delta`, `delta = eta^2 |E|^4`,
/// `|N|^2 = |E|^2 |K|^2 - <E, K>^2`: `dt/dE_w = (2 (|K|^2 E_w - <E_w, K> K) - 4 t eta^2 |E|^2 E_w)
/// / delta`, `dt/dK = 2 (|E|^2 K - <E_w, K> E_w) / delta`; the head gets the `E_w` part, the
/// apex the `K` part, the tail minus their sum.
#[inline(always)]
fn hinge_gradient(p: &[[f64; 3]; 4], ct: f64, cp: f64) -> [[f64; 3]; 4] {
    match wings(p) {
        Some(w) => wings_gradient(&w, ct, cp),
        None => [[0.0; 3]; 4],
    }
}

/// [`hinge_gradient`] from the hinge's [`Wings`].
#[inline(always)]
fn wings_gradient(w: &Wings, ct: f64, cp: f64) -> [[f64; 3]; 4] {
    let (phi, t) = wing_factors(w);
    let [h1, a1, t1] = wing_part(w, 0, ct, cp, phi, t);
    let [h2, a2, t2] = wing_part(w, 1, ct, cp, phi, t);
    // Wing 1: tail i, head j, apex k; wing 2: tail j, head i, apex l.
    [add(t1, h2), add(h1, t2), a1, a2]
}

/// Wing `m`'s part of [`wings_gradient`]: its head's, apex's and tail's, given both wings'
/// sliver factors `phi` and their `t` ([`wing_factors`]). Inlined: called through memory, the
/// returned arrays stalled the pose pass on store forwarding.
#[inline(always)]
fn wing_part(w: &Wings, m: usize, ct: f64, cp: f64, phi: [f64; 2], t: [f64; 2]) -> [[f64; 3]; 3] {
    let ew = if m == 0 { w.e } else { scale(w.e, -1.0) };
    let (k, n, nn) = (w.k[m], w.n[m], w.nn[m]);
    let ek = dot(ew, k);
    let alpha = ek / w.ee;
    let c = scale(n, ct * w.le / nn);
    let mut head = scale(c, -alpha);
    let mut apex = c;
    if t[m] < 1.0 && cp != 0.0 {
        // The factor Phi = phi_1 phi_2: this wing's dphi times the other's phi.
        let delta = SLIVER * SLIVER * w.ee * w.ee;
        let q = cp * phi[1 - m] * 6.0 * t[m] * (1.0 - t[m]) / delta;
        let kk = dot(k, k);
        let dt_de = sub(
            scale(sub(scale(ew, kk), scale(k, ek)), 2.0),
            scale(ew, 4.0 * t[m] * SLIVER * SLIVER * w.ee),
        );
        let dt_dk = scale(sub(scale(k, w.ee), scale(ew, ek)), 2.0);
        head = add(head, scale(dt_de, q));
        apex = add(apex, scale(dt_dk, q));
    }
    let tail = scale(add(head, apex), -1.0);
    [head, apex, tail]
}

/// [`HingeState`] of the hinge at positions `p = [x_i, x_j, x_k, x_l]`; the gradients only if
/// `want`. A degenerate edge or face gives the zero state (`Phi = 0`: no residual).
fn hinge_state(p: [[f64; 3]; 4], want: bool) -> HingeState {
    let Some(w) = wings(&p) else {
        return HingeState {
            angle: [0.0, 1.0],
            ..HingeState::default()
        };
    };
    let (angle, phi) = wings_value(&w);
    let mut st = HingeState {
        angle,
        phi,
        ..HingeState::default()
    };
    if want {
        st.dtheta = wings_gradient(&w, 1.0, 0.0);
        if has_sliver_wing(&w) {
            st.dphi = wings_gradient(&w, 0.0, 1.0);
        }
    }
    st
}

/// `[sin, cos]` of the change `theta_b - theta_a` of an angle from `a` to `b` (each
/// `[sin, cos]`).
#[inline(always)]
pub(super) fn angle_change(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [b[0] * a[1] - b[1] * a[0], b[1] * a[1] + b[0] * a[0]]
}

/// The change of an angle from `a` to `b` (each `[sin, cos]`) as the chord
/// `2 sin((theta_b - theta_a) / 2)` (the change itself to within its cube over 24; smooth and
/// periodic, so no wrapping and no arctangent), with its derivative `cos((theta_b - theta_a) /
/// 2)` with respect to `theta_b` (minus that with respect to `theta_a`). At a half turn the
/// chord is taken as 2 and its derivative as 0.
#[inline(always)]
fn angle_chord(a: [f64; 2], b: [f64; 2]) -> (f64, f64) {
    let [sin, cos] = angle_change(a, b);
    // h = 2 cos(delta / 2) >= 0; 2 sin(delta / 2) = 2 sin(delta) / h.
    let h = (2.0 * (1.0 + cos)).max(0.0).sqrt();
    if h > 0.0 {
        (2.0 * sin / h, 0.5 * h)
    } else {
        (2.0, 0.0)
    }
}

/// The weight `w_e = (L_1 + L_2) / (2 (A_1 + A_2)) >= 0` of the hinge between faces `f1`, `f2`
/// from the frozen face values (`[c_f; q_f]`, 2 #F: the area share and the squared-edge-length
/// sum over the total area); 0 for degenerate faces.
fn hinge_weight(faces: &[f64], nf: usize, f1: usize, f2: usize) -> f64 {
    let (area, len) = (faces[f1] + faces[f2], faces[nf + f1] + faces[nf + f2]);
    if area > 0.0 && len.is_finite() && len > 0.0 {
        len / (2.0 * area)
    } else {
        0.0
    }
}

impl Metric for RelativeBending {
    fn name(&self) -> String {
        "bending(relative)".into()
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        Pattern::from_rows(hinges(topo).iter().map(|(v, _)| *v))
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        topo.edge_faces()
            .iter()
            .filter(|ef| ef[0] != NO_FACE && ef[1] != NO_FACE)
            .count()
    }

    /// Every row: a segment's two terms are the same change of the angles.
    fn rows_shared_by_both_terms(&self, topo: &Topology) -> std::ops::Range<usize> {
        0..self.n_residuals(topo)
    }

    face_share_frozen_values!();

    fn residuals(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        mut jac: Option<JacobianMut>,
    ) {
        let want = jac.is_some();
        for_each_hinge(topo, pattern, seg, want, |hi, _, ri, d| {
            r[hi] = ri;
            if let (Some(jm), Some((da, db))) = (jac.as_mut(), d) {
                let first = pattern.offsets[hi] as usize;
                jm.da[first..first + 4].copy_from_slice(da);
                jm.db[first..first + 4].copy_from_slice(db);
            }
        });
    }

    /// One pass that never stores the Jacobian.
    fn gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        _scratch: &mut Scratch,
        sink: &mut GradientSink,
    ) -> f64 {
        gradient_pass(topo, pattern, seg, sink)
    }

    /// Both terms of a segment are the same residuals (the change of the angles from `a` to
    /// `b`): one pass, counted twice.
    fn segment_gradient(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        if !same_frozen(segs) {
            return segment_gradient_per_term(self, topo, pattern, segs, scratch, sink);
        }
        let mut both = GradientSink {
            ga: &mut *sink.ga,
            gb: &mut *sink.gb,
            gaux: &mut [],
            weight: 2.0 * sink.weight,
        };
        gradient_pass(topo, pattern, segs[0], &mut both)
    }

    /// Every hinge's angle, sliver factor and angle gradient at `pose` (`PER_HINGE` = 16 values
    /// per hinge: `sin theta`, `cos theta`, `Phi`, the sliver flag, `grad theta`).
    fn pose_values(&self, _topo: &Topology, pattern: PatternRef, pose: &[[f64; 3]], out: &mut Vec<f64>) {
        let n = pattern.n_residuals();
        // Every value of every hinge is written below: no clearing.
        out.resize(PER_HINGE * n, 0.0);
        for (hi, v) in out.chunks_exact_mut(PER_HINGE).enumerate() {
            let Some(w) = wings(&hinge_positions(pattern, hi, pose)) else {
                // Degenerate: no angle, Phi = 0, no gradient.
                v.fill(0.0);
                v[1] = 1.0;
                continue;
            };
            let ([sin, cos], phi) = wings_value(&w);
            let sliver = if has_sliver_wing(&w) { 1.0 } else { 0.0 };
            v[..DTHETA].copy_from_slice(&[sin, cos, phi, sliver]);
            v[DTHETA..].copy_from_slice(wings_gradient(&w, 1.0, 0.0).as_flattened());
        }
    }

    /// The segment's value from its poses' angles and factors, and per hinge and pose the
    /// coefficients of `grad theta` and `grad Phi` in `2 weight r dr/dP` (both terms counted;
    /// `COEFFS_PER_HINGE` = 2 per hinge).
    fn segment_gradient_with(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        segs: [&Segment; 2],
        share: PoseShare,
        scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        let nh = pattern.n_residuals();
        let PoseShare {
            values: poses,
            coeffs,
        } = share;
        if poses.iter().any(|p| p.len() != PER_HINGE * nh) || !same_frozen(segs) {
            return self.segment_gradient(topo, pattern, segs, scratch, sink);
        }
        let [ca, cb] = coeffs;
        // Every hinge's coefficients are written below: no clearing.
        ca.resize(COEFFS_PER_HINGE * nh, 0.0);
        cb.resize(COEFFS_PER_HINGE * nh, 0.0);
        let weight = 2.0 * sink.weight;
        let mut value = 0.0;
        for_each_weight(topo, segs[0], |hi, sw| {
            let at = PER_HINGE * hi;
            let (va, vb) = (&poses[0][at..at + 3], &poses[1][at..at + 3]);
            let (pa, pb) = (va[2], vb[2]);
            let (chord, slope) = angle_chord([va[0], va[1]], [vb[0], vb[1]]);
            let both = sw * pa * pb;
            let r = both * chord;
            value += r * r;
            // dr/db = sw Phi_a Phi_b slope grad theta_b + sw Phi_a chord grad Phi_b; dr/da with
            // -slope and Phi_b.
            let s = 2.0 * weight * r;
            let c = COEFFS_PER_HINGE * hi;
            ca[c] = -s * both * slope;
            ca[c + 1] = s * sw * pb * chord;
            cb[c] = s * both * slope;
            cb[c + 1] = s * sw * pa * chord;
        });
        weight * value
    }

    /// `g += c_theta grad theta + c_Phi grad Phi` over the hinges at `pose`: `grad theta` from
    /// the pose's values, `grad Phi` (slivers only) from the positions.
    fn pose_gradient(
        &self,
        _topo: &Topology,
        pattern: PatternRef,
        pose: &[[f64; 3]],
        values: &[f64],
        coeffs: &[f64],
        g: &mut [[f64; 3]],
    ) {
        let hinges = values
            .chunks_exact(PER_HINGE)
            .zip(coeffs.chunks_exact(COEFFS_PER_HINGE));
        for (hi, (v, c)) in hinges.enumerate() {
            let (ct, cp) = (c[0], c[1]);
            if ct == 0.0 && cp == 0.0 {
                continue;
            }
            let dtheta = &v[DTHETA..];
            let mut d: [[f64; 3]; 4] =
                std::array::from_fn(|m| std::array::from_fn(|k| ct * dtheta[3 * m + k]));
            if cp != 0.0 && v[3] != 0.0 {
                let dphi = hinge_gradient(&hinge_positions(pattern, hi, pose), 0.0, cp);
                d = std::array::from_fn(|m| add(d[m], dphi[m]));
            }
            let first = pattern.offsets[hi] as usize;
            for (m, dm) in d.iter().enumerate() {
                let u = pattern.vertices[first + m] as usize;
                g[u] = add(g[u], *dm);
            }
        }
    }

    /// One value-only pass for both terms (they are equal, see
    /// [`RelativeBending::segment_gradient`]).
    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        if !same_frozen(segs) {
            return segs.map(|seg| squared_norm_from_residuals(self, topo, pattern, seg));
        }
        let mut value = 0.0;
        for_each_hinge(topo, pattern, segs[0], false, |_, _, ri, _| value += ri * ri);
        [value; 2]
    }
}

/// `weight |r|^2` of a segment and `weight * 2 J^T r` into `sink` ([`Metric::gradient`]).
fn gradient_pass(topo: &Topology, pattern: PatternRef, seg: &Segment, sink: &mut GradientSink) -> f64 {
    let mut value = 0.0;
    for_each_hinge(topo, pattern, seg, true, |_, vs, ri, d| {
        value += ri * ri;
        if let Some((da, db)) = d {
            for m in 0..4 {
                sink.add(vs[m], ri, da[m], db[m]);
            }
        }
    });
    sink.weight * value
}

/// Derivatives of one hinge's residual with respect to its four vertices `[i, j, k, l]` in the
/// segment's first pose `a` and in its second `b`.
type HingeDerivatives = ([[f64; 3]; 4], [[f64; 3]; 4]);

/// The positions of hinge `hi`'s four vertices `[i, j, k, l]` (`pattern`'s row) in `pose`.
#[inline]
fn hinge_positions(pattern: PatternRef, hi: usize, pose: &[[f64; 3]]) -> [[f64; 3]; 4] {
    let first = pattern.offsets[hi] as usize;
    std::array::from_fn(|m| pose[pattern.vertices[first + m] as usize])
}

/// Visits every interior edge of a segment with its `sqrt(w_e)` (from the segment's frozen
/// face values): `visit(hinge, sqrt(w_e))`.
fn for_each_weight(topo: &Topology, seg: &Segment, mut visit: impl FnMut(usize, f64)) {
    let faces = segment_faces(topo, seg);
    let nf = topo.n_faces();
    debug_assert!(faces.len() >= PER_FACE * nf);
    let interior = topo
        .edge_faces()
        .iter()
        .filter(|ef| ef[0] != NO_FACE && ef[1] != NO_FACE);
    for (hi, &[f1, f2]) in interior.enumerate() {
        visit(
            hi,
            hinge_weight(faces.as_ref(), nf, f1 as usize, f2 as usize).sqrt(),
        );
    }
}

/// Visits every interior edge of a segment: `visit(hinge, [i, j, k, l], r, derivatives)` with
/// the residual `r = sqrt(w_e) Phi_a Phi_b c_e` ([`angle_chord`]) and, if `want`, its
/// derivatives. The vertices come from `pattern` (this term's rows), the weights from the
/// segment's frozen face values.
fn for_each_hinge(
    topo: &Topology,
    pattern: PatternRef,
    seg: &Segment,
    want: bool,
    mut visit: impl FnMut(usize, [usize; 4], f64, Option<&HingeDerivatives>),
) {
    for_each_weight(topo, seg, |hi, sw| {
        let first = pattern.offsets[hi] as usize;
        let vs: [usize; 4] = std::array::from_fn(|m| pattern.vertices[first + m] as usize);
        let sa = hinge_state(vs.map(|v| seg.a[v]), want);
        let sb = hinge_state(vs.map(|v| seg.b[v]), want);
        let (chord, slope) = angle_chord(sa.angle, sb.angle);
        let both = sw * sa.phi * sb.phi;
        let r = both * chord;
        if !want {
            visit(hi, vs, r, None);
            return;
        }
        // dr/da = sw (-Phi_a Phi_b slope dtheta_a + Phi_b chord dPhi_a), dr/db likewise with +.
        let (ka, kb) = (sw * sb.phi * chord, sw * sa.phi * chord);
        let bs = both * slope;
        let da = std::array::from_fn(|m| add(scale(sa.dtheta[m], -bs), scale(sa.dphi[m], ka)));
        let db = std::array::from_fn(|m| add(scale(sb.dtheta[m], bs), scale(sb.dphi[m], kb)));
        visit(hi, vs, r, Some(&(da, db)));
    });
}

/// The signed dihedral angle at every interior edge of `pose` (radians in `(-pi, pi]`, in the
/// pattern's hinge order; 0 where the two faces are coplanar or one is degenerate; the term's
/// residual is `sqrt(w_e) Phi_a Phi_b` times the chord of its change along a segment). For tests and studies
/// of the bending term ([`super::Folds`] compares two poses' angles directly).
pub fn dihedral_angles(topo: &Topology, pose: &[[f64; 3]]) -> Vec<f64> {
    hinges(topo)
        .iter()
        .map(|(vs, _)| {
            let ([sin, cos], _) = hinge_value(&vs.map(|v| pose[v as usize]));
            sin.atan2(cos)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{fdcheck, At};

    #[test]
    fn bending_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&RelativeBending, 71);
    }

    /// A pose of icosphere(1) off the sphere and a displacement of size `step` (mean edges).
    fn pose_and_step(step: f64) -> (crate::mesh::Shape, Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let s = crate::synth::icosphere(1);
        let a: Vec<[f64; 3]> = s
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| p.map(|c| c * (1.0 + 0.05 * ((i * 7 % 11) as f64 / 11.0))))
            .collect();
        let b: Vec<[f64; 3]> = a
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let d = [
                    ((i * 3) % 7) as f64 - 3.0,
                    ((i * 5) % 9) as f64 - 4.0,
                    ((i * 2) % 5) as f64 - 2.0,
                ];
                add(*p, scale(d, step))
            })
            .collect();
        (s, a, b)
    }

    /// The residuals of a segment and, per hinge, `sqrt(w_e) Phi_a Phi_b`.
    fn residuals_and_factors(topo: &Topology, a: &[[f64; 3]], b: &[[f64; 3]]) -> (Vec<f64>, Vec<f64>) {
        let m = RelativeBending;
        let frozen = m.frozen_weights(topo, a, b).unwrap();
        let pat = m.pattern(topo);
        let mut r = vec![0.0; pat.n_residuals()];
        let seg = Segment {
            a,
            b,
            at: At::Start,
            aux: &[],
            frozen: Some(&frozen),
        };
        m.residuals(topo, pat.as_ref(), &seg, &mut r, None);
        let nf = topo.n_faces();
        let factors = hinges(topo)
            .iter()
            .map(|(vs, [f1, f2])| {
                let phi = |p: &[[f64; 3]]| hinge_state(vs.map(|v| p[v as usize]), false).phi;
                hinge_weight(&frozen, nf, *f1 as usize, *f2 as usize).sqrt() * phi(a) * phi(b)
            })
            .collect();
        (r, factors)
    }

    /// The residual is the chord `2 sin(dtheta / 2)` of the change of the dihedral angle from `a`
    /// to `b` (times
    /// `sqrt(w_e) Phi_a Phi_b`, `Phi` = 1 on these faces), and to second order the
    /// rate of change at the midpoint (a central difference of [`dihedral_angles`]).
    #[test]
    fn residual_is_the_change_of_the_dihedral_angle() {
        let (s, a, b) = pose_and_step(0.01);
        let topo = &s.topology;
        let (r, factors) = residuals_and_factors(topo, &a, &b);
        let (ta, tb) = (dihedral_angles(topo, &a), dihedral_angles(topo, &b));
        let mut checked = 0;
        for e in 0..r.len() {
            assert!(factors[e] > 0.0, "hinge {e}: factor {}", factors[e]);
            let expected = factors[e] * 2.0 * (0.5 * (tb[e] - ta[e])).sin();
            assert!(
                (r[e] - expected).abs() <= 1e-12 * (1.0 + expected.abs()),
                "hinge {e}: residual {} against the angle's change {expected}",
                r[e]
            );
            checked += (expected.abs() > 1e-3) as usize;
        }
        assert!(checked > r.len() / 2, "the step bends too few hinges ({checked})");
        // A small step: the change is the midpoint rate times the step to O(step^3).
        let (s, a, b) = pose_and_step(1e-4);
        let topo = &s.topology;
        let (r, factors) = residuals_and_factors(topo, &a, &b);
        let h = 1e-3;
        let at = |t: f64| -> Vec<f64> {
            let p: Vec<[f64; 3]> = a
                .iter()
                .zip(&b)
                .map(|(p, q)| add(*p, scale(sub(*q, *p), 0.5 + t)))
                .collect();
            dihedral_angles(topo, &p)
        };
        let (tp, tm) = (at(h), at(-h));
        let largest = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for e in 0..r.len() {
            let rate = factors[e] * (tp[e] - tm[e]) / (2.0 * h);
            assert!(
                (r[e] - rate).abs() <= 1e-6 * largest,
                "hinge {e}: residual {} against the midpoint rate {rate}",
                r[e]
            );
        }
    }

    /// The path energy's passes (pose values, segment coefficients, pose gradients) give the
    /// segment's value bit for bit and its gradient to rounding, on regular faces and with a
    /// sliver at the first pose (the factor's gradient, taken from the positions).
    #[test]
    fn pose_passes_match_the_segment_gradient() {
        let (s, a, b) = pose_and_step(0.02);
        pose_passes_match(&s.topology, &a, &b);
        // Face 0's third vertex moved to 3 % of its height over the opposite edge: t < 1.
        let [i, j, k] = s.topology.faces()[0].map(|v| v as usize);
        let mut thin = a.clone();
        let mid = scale(add(a[i], a[j]), 0.5);
        thin[k] = add(mid, scale(sub(a[k], mid), 0.03));
        let w = wings(&[a[i], a[j], thin[k], thin[k]]).unwrap();
        assert!(wing_factors(&w).1[0] < 1.0);
        pose_passes_match(&s.topology, &thin, &b);
    }

    fn pose_passes_match(topo: &Topology, a: &[[f64; 3]], b: &[[f64; 3]]) {
        let m = RelativeBending;
        let frozen = m.frozen_weights(topo, a, b).unwrap();
        let pat = m.pattern(topo);
        let seg = |at| Segment {
            a,
            b,
            at,
            aux: &[],
            frozen: Some(&frozen),
        };
        let (s0, s1) = (seg(At::Start), seg(At::End));
        let nv = a.len();
        // One segment_gradient call.
        let (mut ga, mut gb) = (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv]);
        let direct = m.segment_gradient(
            topo,
            pat.as_ref(),
            [&s0, &s1],
            &mut Scratch::default(),
            &mut SegmentSink {
                ga: &mut ga,
                gb: &mut gb,
                gaux: &mut [],
                weight: 0.7,
            },
        );
        // The three passes.
        let (mut va, mut vb) = (Vec::new(), Vec::new());
        m.pose_values(topo, pat.as_ref(), a, &mut va);
        m.pose_values(topo, pat.as_ref(), b, &mut vb);
        let (mut ca, mut cb) = (Vec::new(), Vec::new());
        let (mut pa, mut pb) = (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv]);
        let passes = m.segment_gradient_with(
            topo,
            pat.as_ref(),
            [&s0, &s1],
            PoseShare {
                values: [&va, &vb],
                coeffs: [&mut ca, &mut cb],
            },
            &mut Scratch::default(),
            &mut SegmentSink {
                ga: &mut pa,
                gb: &mut pb,
                gaux: &mut [],
                weight: 0.7,
            },
        );
        assert!(direct > 0.0);
        assert_eq!(direct.to_bits(), passes.to_bits());
        assert!(
            pa.iter().chain(&pb).all(|g| *g == [0.0; 3]),
            "the passes add nothing to the sink"
        );
        m.pose_gradient(topo, pat.as_ref(), a, &va, &ca, &mut pa);
        m.pose_gradient(topo, pat.as_ref(), b, &vb, &cb, &mut pb);
        let largest = ga.iter().chain(&gb).flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(largest > 0.0);
        for (x, y) in ga.iter().chain(&gb).flatten().zip(pa.iter().chain(&pb).flatten()) {
            assert!((x - y).abs() <= 1e-13 * largest, "{x} against {y}");
        }
    }

    /// A finite rigid step (a rotation by 0.79 rad and a translation) bends nothing: no
    /// dihedral angle changes, at both of the segment's terms.
    #[test]
    fn rigid_motions_cost_nothing() {
        let s = crate::synth::icosphere(2);
        let topo = &s.topology;
        let omega = [0.3, -0.7, 0.2];
        // Rodrigues: R p = p cos t + (u x p) sin t + u <u, p> (1 - cos t), u = omega / t.
        let t = crate::mesh::geometry::norm(omega);
        let u = scale(omega, 1.0 / t);
        let rotate = |p: [f64; 3]| {
            add(
                add(scale(p, t.cos()), scale(cross(u, p), t.sin())),
                scale(u, dot(u, p) * (1.0 - t.cos())),
            )
        };
        let b: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| add(rotate(*p), [0.5, 0.1, -0.2]))
            .collect();
        let m = RelativeBending;
        let frozen = m.frozen_weights(topo, &s.positions, &b).unwrap();
        let pat = m.pattern(topo);
        let mut r = vec![0.0; pat.n_residuals()];
        let seg = Segment {
            a: &s.positions,
            b: &b,
            at: At::Start,
            aux: &[],
            frozen: Some(&frozen),
        };
        for at in [At::Start, At::End] {
            m.residuals(topo, pat.as_ref(), &Segment { at, ..seg }, &mut r, None);
            let worst = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(worst < 1e-12, "a rigid step bends by {worst:e} ({at:?})");
        }
        assert!(!r.is_empty());
    }

    /// The angle's and the factor's gradients against central differences on a hinge with a
    /// sliver wing (height 0.02 and 0.04 of the edge: `t` = 0.16 and 0.64, the smoothstep
    /// branch) and a regular one.
    #[test]
    fn sliver_gradients_match_finite_differences() {
        for height in [0.02, 0.04, 0.5] {
            let p = [
                [0.0, 0.0, 0.0],
                [1.0, 0.1, 0.0],
                [0.4, height, 0.01],
                [0.6, -0.8, 0.3],
            ];
            let w = wings(&p).unwrap();
            let (_, t) = wing_factors(&w);
            assert!(height > 0.1 || t[0] < 1.0, "t = {t:?}");
            let value = |q: &[[f64; 3]; 4]| {
                let ([sin, cos], phi) = hinge_value(q);
                (sin.atan2(cos), phi)
            };
            let (gt, gp) = (hinge_gradient(&p, 1.0, 0.0), hinge_gradient(&p, 0.0, 1.0));
            for (k, dir) in [[0.3, -0.2, 0.5], [-0.7, 0.1, 0.2], [0.1, 0.9, -0.4]]
                .iter()
                .enumerate()
            {
                // Move one vertex at a time and all together.
                for m in 0..5 {
                    let step = |h: f64| {
                        let mut q = p;
                        for (v, x) in q.iter_mut().enumerate() {
                            if m == 4 || m == v {
                                *x = add(*x, scale(*dir, h * (1.0 + v as f64 * 0.3)));
                            }
                        }
                        value(&q)
                    };
                    let h = 1e-6;
                    let ((tp, pp), (tm, pm)) = (step(h), step(-h));
                    let (fd_t, fd_p) = ((tp - tm) / (2.0 * h), (pp - pm) / (2.0 * h));
                    let (mut an_t, mut an_p) = (0.0, 0.0);
                    for v in 0..4 {
                        if m == 4 || m == v {
                            let d = scale(*dir, 1.0 + v as f64 * 0.3);
                            an_t += dot(gt[v], d);
                            an_p += dot(gp[v], d);
                        }
                    }
                    let tol = |x: f64| 1e-6 * (1.0 + x.abs());
                    assert!(
                        (fd_t - an_t).abs() < tol(fd_t),
                        "height {height}, dir {k}, vertex {m}: theta {fd_t} vs {an_t}"
                    );
                    assert!(
                        (fd_p - an_p).abs() < tol(fd_p),
                        "height {height}, dir {k}, vertex {m}: Phi {fd_p} vs {an_p}"
                    );
                }
            }
        }
    }

    /// Open meshes: boundary edges have no residual, interior ones do.
    #[test]
    fn boundary_edges_have_no_residual() {
        let g = crate::synth::grid(4);
        let topo = &g.topology;
        let interior = topo.edge_faces().iter().filter(|f| f[1] != NO_FACE).count();
        assert!(interior < topo.n_edges());
        assert_eq!(RelativeBending.n_residuals(topo), interior);
        assert_eq!(RelativeBending.pattern(topo).n_residuals(), interior);
    }
}
