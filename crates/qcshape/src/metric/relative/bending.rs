//! The bending term: the rate of change of the dihedral angles (the discrete shells' bending
//! energy of Grinspun et al. 2003 and Heeren et al. 2012, linearized at the pose), weighted so
//! that it is scale-invariant and converges as the mesh is refined (docs/method.md "Bending
//! term").

use super::faces::{segment_faces, PER_FACE};
use crate::mesh::geometry::{add, cross, dot, norm, scale, sub};
use crate::mesh::Topology;
use crate::metric::gradient::{GradientSink, Scratch};
use crate::metric::pattern::{JacobianMut, Pattern, PatternRef};
use crate::metric::segment::{split_segment, Segment};
use crate::metric::traits::Metric;

/// [`Topology::edge_faces`]' mark of a boundary side.
const NO_FACE: u32 = u32::MAX;

/// The scale-invariant bending term: `G_M(X) = sum over interior edges e of w_e (dtheta_e)^2`,
/// `dtheta_e = d/dt theta_e(M + t X)` the rate of change of the dihedral angle at `e` (radians
/// per unit of path parameter), `w_e = (L_1 + L_2) / (2 (A_1 + A_2))` (`L_f` the sum of face
/// `f`'s squared edge lengths, `A_f` its area; for equilateral faces `3 |e|^2 / (A_1 + A_2)`, the
/// discrete shells' weight) from the frozen face values of the path's ends, like every relative
/// form (docs/method.md "Scale-invariant forms"). `sum_e w_e dtheta_e^2` approximates the
/// integral of the squared rate of change of the curvature over the surface: dimensionless,
/// `G_{sM}(sX) = G_M(X)`, and the same on every refinement of a smooth surface. It vanishes on
/// infinitesimal rigid motions and on isometric motions that keep the dihedral angles (a
/// developable bend of a flat sheet does not), and charges vertex-scale normal wrinkles, which
/// the membrane terms (isometric, conformal) see only through the curvature.
///
/// One residual per interior edge, depending on the edge's two vertices and the two opposite
/// ones (pattern order: the edge's `(min, max)` vertices `i, j`, then `k` opposite in the
/// edge's first face, `l` in its second). Boundary edges (open meshes: the LV surfaces) have no
/// dihedral angle and no residual.
///
/// With `dtheta = F_1 + F_2`, each wing `F = |E| ((X_k - X_i) - alpha (X_j - X_i)) . N / |N|^2`
/// is the rate of rotation of one face about the edge: `E` the edge from its tail `i` to its
/// head `j` (reversed for the second face, so that a rigid rotation cancels), `K = k - i`,
/// `N = E x K`, `alpha = <E, K> / |E|^2` (`|N| / |E|` is the face's height over the edge).
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

/// One wing's rotation rate `F` (see [`RelativeBending`]) and its derivatives: with respect to
/// the geometry of the tail, head and apex (`dg`), and to their displacements (`dx`).
struct Wing {
    f: f64,
    dg: [[f64; 3]; 3],
    dx: [[f64; 3]; 3],
    /// The wing's factor `phi = |N|^2 / (|N|^2 + eta^2 |E|^4)` ([`SLIVER`]) and its derivatives
    /// with respect to the tail, head and apex.
    phi: f64,
    dphi: [[f64; 3]; 3],
}

/// The edge shared by a hinge's two wings: `E = h - t`, `|E|^2`, `|E|` and `1 / |E|^2`
/// (the second wing's edge is `-E`, same lengths).
#[derive(Clone, Copy)]
struct Edge {
    ee: f64,
    le: f64,
    inv_ee: f64,
}

impl Edge {
    /// `None` for a degenerate edge (zero or non-finite length).
    fn new(e: [f64; 3]) -> Option<Edge> {
        let ee = dot(e, e);
        (ee > 0.0 && ee.is_finite()).then(|| Edge {
            ee,
            le: ee.sqrt(),
            inv_ee: 1.0 / ee,
        })
    }
}

/// `eta` of the wings' regularized denominator `|N|^2 + eta^2 |E|^4`: the height `h = |N| / |E|`
/// is floored near `eta |E|`, so that a face collapsing on a path cannot make the rate and its
/// gradient blow up (without it the default solver stalled on the bent tube with a face at 4e-6
/// of the mean area). The residual is `G_1 phi_2 + G_2 phi_1`, `G` each wing's regularized rate
/// and `phi = |N|^2 / (|N|^2 + eta^2 |E|^4)`: both wings take the factor `phi_1 phi_2`, so a
/// rigid rotation still cancels. On regular faces (`|N|^2 = 0.75 |E|^4`) the factor is 0.997.
/// Dimensionless, so the term stays scale-invariant.
const SLIVER: f64 = 0.05;

/// The intermediates of one wing: `N = E x K`, `1 / (|N|^2 + eta^2 |E|^4)`, `alpha`,
/// `v = D - alpha DE`, `s = <v, N>` and the factor `phi`.
type WingParts = ([f64; 3], f64, f64, [f64; 3], f64, f64);

/// [`WingParts`] of one wing; `None` for a degenerate face.
fn wing_parts(ed: Edge, e: [f64; 3], k: [f64; 3], d: [f64; 3], de: [f64; 3]) -> Option<WingParts> {
    let n = cross(e, k);
    // |N|^2 + eta^2 |E|^4 (SLIVER): the rate stays finite on a collapsing face.
    let raw = dot(n, n);
    let n2 = raw + SLIVER * SLIVER * ed.ee * ed.ee;
    if !(n2 > 0.0 && n2.is_finite()) {
        return None;
    }
    let alpha = dot(e, k) * ed.inv_ee;
    // v = D - alpha DE: the apex's velocity relative to the hinge point below it.
    let v = sub(d, scale(de, alpha));
    Some((n, 1.0 / n2, alpha, v, dot(v, n), raw / n2))
}

/// The rotation rate `F = |E| <v, N> / |N|^2` of the wing with hinge `t -> h` and apex `k`
/// (positions `g`, displacements `x`), value only.
fn wing_value(ed: Edge, g: [[f64; 3]; 3], x: [[f64; 3]; 3]) -> (f64, f64) {
    let (e, k) = (sub(g[1], g[0]), sub(g[2], g[0]));
    match wing_parts(ed, e, k, sub(x[2], x[0]), sub(x[1], x[0])) {
        Some((_, inv_n2, _, _, s, phi)) => (ed.le * s * inv_n2, phi),
        None => (0.0, 0.0),
    }
}

/// [`Wing`] of the wing with hinge `t -> h` and apex `k` (positions `g`, displacements `x`).
fn wing(ed: Edge, g: [[f64; 3]; 3], x: [[f64; 3]; 3]) -> Wing {
    let (e, k) = (sub(g[1], g[0]), sub(g[2], g[0]));
    let de = sub(x[1], x[0]);
    let Some((n, inv_n2, alpha, v, s, phi)) = wing_parts(ed, e, k, sub(x[2], x[0]), de) else {
        return Wing {
            f: 0.0,
            dg: [[0.0; 3]; 3],
            dx: [[0.0; 3]; 3],
            phi: 0.0,
            dphi: [[0.0; 3]; 3],
        };
    };
    let (ee, le, inv_ee) = (ed.ee, ed.le, ed.inv_ee);
    let (ek, kk) = (dot(e, k), dot(k, k));
    // With alpha = <E, K> / |E|^2, s = <v, N>, |N|^2 = |E|^2 |K|^2 - <E, K>^2, F = |E| s / |N|^2:
    // ds/dE = -<DE, N> dalpha/dE + K x v, ds/dK = -<DE, N> E / |E|^2 + v x E,
    // dalpha/dE = K / |E|^2 - 2 <E, K> E / |E|^4, d|N|^2/dE = 2 (|K|^2 E - <E, K> K),
    // d|N|^2/dK = 2 (|E|^2 K - <E, K> E).
    let den = dot(de, n);
    let a = le * inv_n2;
    let b = 2.0 * a * s * inv_n2;
    // dF/dE = s E / (|E| |N|^2) + a ds/dE - b (|K|^2 E - <E, K> K).
    // (|N|^2's regularization adds 4 eta^2 |E|^2 E to its derivative in E.)
    let ce = s * inv_n2 / le + 2.0 * a * den * ek * inv_ee * inv_ee - b * kk - 2.0 * b * SLIVER * SLIVER * ee;
    let cke = -a * den * inv_ee + b * ek;
    let df_de = add(add(scale(e, ce), scale(k, cke)), scale(cross(k, v), a));
    // dF/dK = a ds/dK - b (|E|^2 K - <E, K> E).
    let df_dk = add(add(scale(e, cke), scale(k, -b * ee)), scale(cross(v, e), a));
    let c = scale(n, a);
    // phi = |N|^2 / D, D = |N|^2 + delta, delta = eta^2 |E|^4:
    // dphi = (delta d|N|^2 - |N|^2 d delta) / D^2, d delta/dE = 4 eta^2 |E|^2 E.
    let delta = SLIVER * SLIVER * ee * ee;
    let raw = phi / inv_n2;
    let q = inv_n2 * inv_n2;
    let dphi_de = sub(
        scale(add(scale(e, kk), scale(k, -ek)), 2.0 * delta * q),
        scale(e, 4.0 * SLIVER * SLIVER * ee * raw * q),
    );
    let dphi_dk = scale(add(scale(k, ee), scale(e, -ek)), 2.0 * delta * q);
    Wing {
        f: le * s * inv_n2,
        dg: [scale(add(df_de, df_dk), -1.0), df_de, df_dk],
        dx: [scale(c, alpha - 1.0), scale(c, -alpha), c],
        phi,
        dphi: [scale(add(dphi_de, dphi_dk), -1.0), dphi_de, dphi_dk],
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

    /// The mean face shares of the two ends (2 #F), as the other relative forms.
    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        super::frozen_faces(topo, start, end)
    }

    /// The pose's face shares (2 #F).
    fn pose_summary(&self, topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        super::pose_faces(topo, pose)
    }

    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        summaries: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        super::faces_from(topo, start, end, summaries)
    }

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
            if let (Some(jm), Some((dg, dx))) = (jac.as_mut(), d) {
                let first = pattern.offsets[hi] as usize;
                for m in 0..4 {
                    let (da, db) = split_segment(seg.at, dg[m], dx[m]);
                    jm.da[first + m] = da;
                    jm.db[first + m] = db;
                }
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
        let mut value = 0.0;
        for_each_hinge(topo, pattern, seg, true, |_, vs, ri, d| {
            value += ri * ri;
            if let Some((dg, dx)) = d {
                for m in 0..4 {
                    let (da, db) = split_segment(seg.at, dg[m], dx[m]);
                    sink.add(vs[m], ri, da, db);
                }
            }
        });
        sink.weight * value
    }

    /// Value-only passes.
    fn segment_squared_norms(&self, topo: &Topology, pattern: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        segs.map(|seg| {
            let mut value = 0.0;
            for_each_hinge(topo, pattern, seg, false, |_, _, ri, _| value += ri * ri);
            value
        })
    }
}

/// Derivatives of one hinge's residual with respect to the geometry and the displacement of
/// its four vertices `[i, j, k, l]`.
type HingeDerivatives = ([[f64; 3]; 4], [[f64; 3]; 4]);

/// Visits every interior edge of a segment term: `visit(hinge, [i, j, k, l], r, derivatives)`
/// with the residual `r = sqrt(w_e) dtheta_e` and, if `want`, its derivatives. The vertices
/// come from `pattern` (this term's rows), the weights from the segment's frozen face values.
fn for_each_hinge(
    topo: &Topology,
    pattern: PatternRef,
    seg: &Segment,
    want: bool,
    mut visit: impl FnMut(usize, [usize; 4], f64, Option<&HingeDerivatives>),
) {
    let (g, x) = crate::metric::geometry_and_displacement(seg);
    let faces = segment_faces(topo, seg);
    let nf = topo.n_faces();
    debug_assert!(faces.len() >= PER_FACE * nf);
    let interior = topo
        .edge_faces()
        .iter()
        .filter(|ef| ef[0] != NO_FACE && ef[1] != NO_FACE);
    for (hi, &[f1, f2]) in interior.enumerate() {
        let first = pattern.offsets[hi] as usize;
        let vs: [usize; 4] = std::array::from_fn(|m| pattern.vertices[first + m] as usize);
        let sw = hinge_weight(faces.as_ref(), nf, f1 as usize, f2 as usize).sqrt();
        let [i, j, k, l] = vs;
        let Some(ed) = Edge::new(sub(g[j], g[i])) else {
            visit(hi, vs, 0.0, want.then_some(&([[0.0; 3]; 4], [[0.0; 3]; 4])));
            continue;
        };
        if !want {
            let (f1, p1) = wing_value(ed, [g[i], g[j], g[k]], [x[i], x[j], x[k]]);
            let (f2, p2) = wing_value(ed, [g[j], g[i], g[l]], [x[j], x[i], x[l]]);
            visit(hi, vs, sw * (f1 * p2 + f2 * p1), None);
            continue;
        }
        let w1 = wing(ed, [g[i], g[j], g[k]], [x[i], x[j], x[k]]);
        let w2 = wing(ed, [g[j], g[i], g[l]], [x[j], x[i], x[l]]);
        // r / sw = G_1 phi_2 + G_2 phi_1; local vertices i, j, k, l: wing 1 covers (i, j, k),
        // wing 2 (j, i, l).
        let mut dg = [[0.0; 3]; 4];
        let mut dx = [[0.0; 3]; 4];
        for (slot, src) in [(0, 0), (1, 1), (2, 2)] {
            dg[slot] = add(
                dg[slot],
                add(scale(w1.dg[src], w2.phi), scale(w1.dphi[src], w2.f)),
            );
            dx[slot] = add(dx[slot], scale(w1.dx[src], w2.phi));
        }
        for (slot, src) in [(1, 0), (0, 1), (3, 2)] {
            dg[slot] = add(
                dg[slot],
                add(scale(w2.dg[src], w1.phi), scale(w2.dphi[src], w1.f)),
            );
            dx[slot] = add(dx[slot], scale(w2.dx[src], w1.phi));
        }
        let d = (dg.map(|v| scale(v, sw)), dx.map(|v| scale(v, sw)));
        visit(hi, vs, sw * (w1.f * w2.phi + w2.f * w1.phi), Some(&d));
    }
}

/// The signed dihedral angle at every interior edge of `pose` (radians, in the pattern's hinge
/// order; 0 where the two faces are coplanar; its rate of change along a displacement is the
/// term's residual over `sqrt(w_e)`). For tests and studies of the bending term.
pub fn dihedral_angles(topo: &Topology, pose: &[[f64; 3]]) -> Vec<f64> {
    hinges(topo)
        .iter()
        .map(|(vs, _)| {
            let [i, j, k, l] = vs.map(|v| pose[v as usize]);
            let e = sub(j, i);
            let n1 = cross(e, sub(k, i));
            let n2 = cross(scale(e, -1.0), sub(l, j));
            let t = scale(e, 1.0 / norm(e).max(f64::MIN_POSITIVE));
            dot(cross(n2, n1), t).atan2(dot(n1, n2))
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

    /// The residual is the rate of change of the dihedral angle (times `sqrt(w_e)`): checked
    /// against a central difference of [`dihedral_angles`] along a random displacement.
    #[test]
    fn residual_is_the_dihedral_angle_rate() {
        let s = crate::synth::icosphere(1);
        let topo = &s.topology;
        let a: Vec<[f64; 3]> = s
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| p.map(|c| c * (1.0 + 0.05 * ((i * 7 % 11) as f64 / 11.0))))
            .collect();
        let x: Vec<[f64; 3]> = (0..a.len())
            .map(|i| {
                [
                    ((i * 3) % 7) as f64 - 3.0,
                    ((i * 5) % 9) as f64 - 4.0,
                    ((i * 2) % 5) as f64 - 2.0,
                ]
            })
            .map(|v| v.map(|c| 0.01 * c))
            .collect();
        let b: Vec<[f64; 3]> = a.iter().zip(&x).map(|(p, d)| add(*p, *d)).collect();
        let m = RelativeBending;
        let frozen = m.frozen_weights(topo, &a, &b).unwrap();
        let nf = topo.n_faces();
        let w: Vec<f64> = hinges(topo)
            .iter()
            .map(|(_, [f1, f2])| hinge_weight(&frozen, nf, *f1 as usize, *f2 as usize))
            .collect();
        let pat = m.pattern(topo);
        let mut r = vec![0.0; pat.n_residuals()];
        let seg = Segment {
            a: &a,
            b: &b,
            at: At::Start,
            aux: &[],
            frozen: Some(&frozen),
        };
        m.residuals(topo, pat.as_ref(), &seg, &mut r, None);
        let h = 1e-6;
        let shifted = |t: f64| -> Vec<f64> {
            let p: Vec<[f64; 3]> = a.iter().zip(&x).map(|(p, d)| add(*p, scale(*d, t))).collect();
            dihedral_angles(topo, &p)
        };
        let (tp, tm) = (shifted(h), shifted(-h));
        // The sliver factor phi_1 phi_2 of each hinge at the pose (0.99-1 on these faces).
        let phis: Vec<f64> = hinges(topo)
            .iter()
            .map(|(vs, _)| {
                let [i, j, k, l] = vs.map(|v| a[v as usize]);
                let e = sub(j, i);
                let ee = dot(e, e);
                let phi = |n: [f64; 3]| dot(n, n) / (dot(n, n) + SLIVER * SLIVER * ee * ee);
                phi(cross(e, sub(k, i))) * phi(cross(scale(e, -1.0), sub(l, j)))
            })
            .collect();
        let mut checked = 0;
        for e in 0..r.len() {
            let rate = (tp[e] - tm[e]) / (2.0 * h);
            assert!(phis[e] > 0.99 && phis[e] <= 1.0, "hinge {e}: factor {}", phis[e]);
            let expected = w[e].sqrt() * phis[e] * rate;
            assert!(
                (r[e] - expected).abs() <= 1e-6 * (1.0 + expected.abs()),
                "hinge {e}: residual {} against sqrt(w) phi dtheta/dt {expected}",
                r[e]
            );
            checked += (expected.abs() > 1e-3) as usize;
        }
        assert!(
            checked > r.len() / 2,
            "the displacement bends too few hinges ({checked})"
        );
    }

    /// A rigid motion (a rotation rate and a translation) does not bend anything.
    #[test]
    fn rigid_motions_cost_nothing() {
        let s = crate::synth::icosphere(2);
        let topo = &s.topology;
        let omega = [0.3, -0.7, 0.2];
        let b: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| add(add(*p, cross(omega, *p)), [0.5, 0.1, -0.2]))
            .collect();
        let m = RelativeBending;
        let frozen = m.frozen_weights(topo, &s.positions, &b).unwrap();
        let pat = m.pattern(topo);
        let mut r = vec![0.0; pat.n_residuals()];
        // The rate at the start pose: X = omega x p + t is an infinitesimal rigid motion there.
        let seg = Segment {
            a: &s.positions,
            b: &b,
            at: At::Start,
            aux: &[],
            frozen: Some(&frozen),
        };
        m.residuals(topo, pat.as_ref(), &seg, &mut r, None);
        let worst = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(worst < 1e-12, "a rigid motion bends by {worst:e}");
        assert!(!r.is_empty());
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
