// Index loops mirror the formulas (corner, face slot) in these kernels.
#![allow(clippy::needless_range_loop)]

use super::faces::strain_rate_gradient;
use super::faces::{frozen_faces, mean_summary, pose_faces, segment_faces, PER_FACE};
use crate::mesh::geometry::{add, cross, dot, scale, sub};
use crate::mesh::Topology;
use crate::metric::conformal::face_pattern;
use crate::metric::gradient::{same_frozen, Scratch, SegmentSink};
use crate::metric::pattern::{JacobianMut, Pattern, PatternRef};
use crate::metric::quasi_conformal::QuasiConformal;
use crate::metric::segment::{geometry_and_displacement, split_segment, At, Segment};
use crate::metric::traits::{segment_gradient_per_term, Metric};

/// The scale-invariant conformal and quasi-conformal metrics (eq. 6, eq. 10;
/// docs/method.md "Scale-invariant forms").
///
/// Per triangle `(p, q, r)` of `M` and corner `p`, the corner term is the difference of the
/// two edge strain rates,
/// `T_p = <p - q, X_p - X_q> / |p - q|^2 - <p - r, X_p - X_r> / |p - r|^2` (eq. 6: zero for
/// every similarity and conformal field, dimensionless), and `T_q`, `T_r` by cyclic
/// permutation. With curvature-change weights (`qc`: the quasi-conformal metric of eq. 10, with
/// its `endpoints` weights, normalized or not) the corner term is `w_p T_p`. Optionally a
/// stretch term charges the change of area that the conformal terms leave free (uniform
/// scaling): `sigma_f = <N, dN> / |N|^2`, the relative rate of change of the face's area
/// (`N = (q - p) x (r - p)`, `dN` its rate), weighted by `stretch` (the `b1` of the elastic
/// surface metrics' split into shear and stretch).
///
/// `G_M(X) = sum_f c_f ((w_p T_p)^2 + (w_q T_q)^2 + (w_r T_r)^2) / 3 + stretch sum_f c_f sigma_f^2`
/// with `c_f` the face's frozen area share (mean of the path's ends). Dimensionless;
/// `G_{sM}(sX) = G_M(X)`.
///
/// Residuals per face: the three corners `sqrt(c_f / 3) w_v T_v`, then (with `stretch > 0`)
/// `sqrt(stretch c_f) sigma_f`; each depends on the face's three vertices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelativeConformal {
    /// The quasi-conformal weights (its `endpoints` reading with the quadratic form); `None`
    /// for the conformal metric.
    pub qc: Option<QuasiConformal>,
    /// Weight of the stretch term (>= 0; 0: none).
    pub stretch: f64,
}

impl RelativeConformal {
    /// Residuals per face: 3 corners, plus the stretch term.
    fn per_face(&self) -> usize {
        if self.stretch > 0.0 {
            4
        } else {
            3
        }
    }

    /// The curvature-change weights (#V) of a segment: the values after the face shares in
    /// `seg.frozen`, or those of the segment's own ends.
    fn weights<'a>(&self, topo: &Topology, seg: &Segment<'a>) -> Option<std::borrow::Cow<'a, [f64]>> {
        let qc = self.qc?;
        let (nf, nv) = (PER_FACE * topo.n_faces(), topo.n_vertices());
        Some(match seg.frozen {
            Some(f) if f.len() == nf + nv => std::borrow::Cow::Borrowed(&f[nf..]),
            _ => std::borrow::Cow::Owned(qc.frozen_weights(topo, seg.a, seg.b)?),
        })
    }
}

/// `T = <e1, d1> / |e1|^2 - <e2, d2> / |e2|^2` at corner 0 of `(g0, g1, g2)` with
/// `e_i = g0 - g_i`, `d_i = x0 - x_i`, and its gradients with respect to the three positions
/// and displacements.
#[inline]
fn corner(g: [[f64; 3]; 3], x: [[f64; 3]; 3]) -> (f64, [[f64; 3]; 3], [[f64; 3]; 3]) {
    let (e1, e2) = (sub(g[0], g[1]), sub(g[0], g[2]));
    let (d1, d2) = (sub(x[0], x[1]), sub(x[0], x[2]));
    let (l1, l2) = (dot(e1, e1), dot(e2, e2));
    let (p1, p2) = (dot(e1, d1), dot(e2, d2));
    let t = p1 / l1 - p2 / l2;
    // d(p / l)/de = d / l - 2 p e / l^2, d(p / l)/dd = e / l.
    let (ge1, gd1) = strain_rate_gradient(e1, d1, l1, p1, 1.0);
    let (ge2, gd2) = strain_rate_gradient(e2, d2, l2, p2, -1.0);
    (
        t,
        [add(ge1, ge2), scale(ge1, -1.0), scale(ge2, -1.0)],
        [add(gd1, gd2), scale(gd1, -1.0), scale(gd2, -1.0)],
    )
}

/// `sigma = <N, dN> / |N|^2` of the triangle `(g0, g1, g2)` with displacements `x`
/// (`N = (g1 - g0) x (g2 - g0)`), and its gradients with respect to positions and
/// displacements.
#[inline]
fn stretch(g: [[f64; 3]; 3], x: [[f64; 3]; 3]) -> (f64, [[f64; 3]; 3], [[f64; 3]; 3]) {
    let (ea, eb) = (sub(g[1], g[0]), sub(g[2], g[0]));
    let (da, db) = (sub(x[1], x[0]), sub(x[2], x[0]));
    let n = cross(ea, eb);
    let dn = add(cross(da, eb), cross(ea, db));
    let nn = dot(n, n);
    let s = dot(n, dn) / nn;
    // dsigma/d(dN) = u, dsigma/dN = m.
    let u = scale(n, 1.0 / nn);
    let m = sub(scale(dn, 1.0 / nn), scale(n, 2.0 * s / nn));
    // <u, a x b>: d/da = b x u, d/db = u x a.
    let g_ea = add(cross(db, u), cross(eb, m));
    let g_eb = add(cross(u, da), cross(m, ea));
    let g_da = cross(eb, u);
    let g_db = cross(u, ea);
    (
        s,
        [scale(add(g_ea, g_eb), -1.0), g_ea, g_eb],
        [scale(add(g_da, g_db), -1.0), g_da, g_db],
    )
}

/// Rotates a face's three values so that corner `k` comes first.
#[inline]
fn rot<T: Copy>(v: [T; 3], k: usize) -> [T; 3] {
    [v[k], v[(k + 1) % 3], v[(k + 2) % 3]]
}

impl Metric for RelativeConformal {
    fn name(&self) -> String {
        let base = match self.qc {
            None => "conformal(relative)".to_string(),
            Some(qc) => qc
                .name()
                .replacen('(', "(relative,", 1)
                .replacen("quadratic,", "", 1),
        };
        if self.stretch > 0.0 {
            format!("{}+{}*stretch", base, self.stretch)
        } else {
            base
        }
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        face_pattern(topo, self.per_face())
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        self.per_face() * topo.n_faces()
    }

    /// The mean face shares of the two ends (2 #F), then the quasi-conformal weights (#V).
    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        let mut f = frozen_faces(topo, start, end)?;
        if let Some(qc) = self.qc {
            f.extend(qc.frozen_weights(topo, start, end)?);
        }
        Some(f)
    }

    /// The pose's face shares (2 #F), then the quasi-conformal pose summary.
    fn pose_summary(&self, topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        let mut s = pose_faces(topo, pose)?;
        if let Some(qc) = self.qc {
            s.extend(qc.pose_summary(topo, pose)?);
        }
        Some(s)
    }

    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        [a, b]: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        let n = PER_FACE * topo.n_faces();
        if a.len() < n || b.len() < n {
            return self.frozen_weights(topo, start, end);
        }
        let mut f = mean_summary(&a[..n], &b[..n]);
        if let Some(qc) = self.qc {
            f.extend(qc.frozen_weights_from(topo, start, end, [&a[n..], &b[n..]])?);
        }
        Some(f)
    }

    /// With curvature weights: `w_v` for each corner residual and 1 for the stretch term.
    fn residual_factors(&self, topo: &Topology, frozen: &[f64]) -> Option<Vec<f64>> {
        self.qc?;
        let (nf, nv) = (PER_FACE * topo.n_faces(), topo.n_vertices());
        if frozen.len() != nf + nv {
            return None;
        }
        let w = &frozen[nf..];
        let stretch = self.stretch > 0.0;
        let mut out = Vec::with_capacity(self.n_residuals(topo));
        for f in topo.faces() {
            out.extend(f.map(|v| w[v as usize]));
            if stretch {
                out.push(1.0);
            }
        }
        Some(out)
    }

    /// The curvature weights set to one, the face shares unchanged.
    fn unit_frozen(&self, topo: &Topology, mut frozen: Vec<f64>) -> Vec<f64> {
        let nf = PER_FACE * topo.n_faces();
        if self.qc.is_some() && frozen.len() == nf + topo.n_vertices() {
            frozen[nf..].fill(1.0);
        }
        frozen
    }

    /// Both terms of the segment in one pass over the faces (one displacement, one set of face
    /// shares and weights; never stores the Jacobian; per term if the terms' frozen values
    /// differ): `weight sum (r_start^2 + r_end^2)`, and `2 weight r dr/da`, `2 weight r dr/db`
    /// into `sink`. The residuals and their derivatives are [`Metric::residuals`]'.
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
        let (a, b) = (segs[0].a, segs[0].b);
        let faces = segment_faces(topo, segs[0]);
        let weights = self.weights(topo, segs[0]);
        let stretch = self.stretch.max(0.0);
        let w2 = 2.0 * sink.weight;
        let mut value = 0.0;
        for (fi, f) in topo.faces().iter().enumerate() {
            let vs = f.map(|i| i as usize);
            let xf = vs.map(|v| sub(b[v], a[v]));
            let share = faces[fi].max(0.0);
            let base = (share / 3.0).sqrt();
            let cw = vs.map(|v| base * weights.as_ref().map_or(1.0, |w| w[v]));
            let mut ga = [[0.0; 3]; 3];
            let mut gb = [[0.0; 3]; 3];
            for (at, g) in [(At::Start, a), (At::End, b)] {
                let gf = vs.map(|v| g[v]);
                // Corner k's term is q(k, k+1) - q(k, k+2) with the edge ratios
                // q(i, j) = <g_i - g_j, X_i - X_j> / |g_i - g_j|^2 (the same both ways), so
                // each of the face's three edges is computed once: edge m joins m and m+1.
                let edge = |m: usize| {
                    let (i, j) = (m, (m + 1) % 3);
                    let e = sub(gf[i], gf[j]);
                    let d = sub(xf[i], xf[j]);
                    let (l, p) = (dot(e, e), dot(e, d));
                    (e, d, l, p, p / l)
                };
                let eds = [edge(0), edge(1), edge(2)];
                // T_k = q(k, k+1) - q(k-1, k): corner 0 uses edges 0 and 2.
                let t: [f64; 3] = std::array::from_fn(|k| eds[k].4 - eds[(k + 2) % 3].4);
                let mut sk = [0.0; 3];
                for k in 0..3 {
                    let r = cw[k] * t[k];
                    value += r * r;
                    sk[k] = w2 * r * cw[k];
                }
                for m in 0..3 {
                    // Edge m is the first edge of corner m and the second of corner m + 1.
                    let gq = sk[m] - sk[(m + 1) % 3];
                    let (e, d, l, p, _) = eds[m];
                    let (dg, dx) = strain_rate_gradient(e, d, l, p, gq);
                    let (da, db) = split_segment(at, dg, dx);
                    let (i, j) = (m, (m + 1) % 3);
                    ga[i] = add(ga[i], da);
                    gb[i] = add(gb[i], db);
                    ga[j] = sub(ga[j], da);
                    gb[j] = sub(gb[j], db);
                }
                if stretch > 0.0 {
                    let s = (stretch * share).sqrt();
                    let (sigma, dg, dx) = self::stretch(gf, xf);
                    let r = s * sigma;
                    value += r * r;
                    let c = w2 * r * s;
                    for m in 0..3 {
                        let (da, db) = split_segment(at, scale(dg[m], c), scale(dx[m], c));
                        ga[m] = add(ga[m], da);
                        gb[m] = add(gb[m], db);
                    }
                }
            }
            for m in 0..3 {
                sink.ga[vs[m]] = add(sink.ga[vs[m]], ga[m]);
                sink.gb[vs[m]] = add(sink.gb[vs[m]], gb[m]);
            }
        }
        sink.weight * value
    }

    fn residuals(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        mut jac: Option<JacobianMut>,
    ) {
        let (g, x) = geometry_and_displacement(seg);
        let faces = segment_faces(topo, seg);
        let weights = self.weights(topo, seg);
        let per = self.per_face();
        let stretch = self.stretch.max(0.0);
        for (fi, f) in topo.faces().iter().enumerate() {
            let gf = f.map(|i| g[i as usize]);
            let xf = f.map(|i| x[i as usize]);
            let share = faces[fi].max(0.0);
            let base = (share / 3.0).sqrt();
            for k in 0..3 {
                let w = weights.as_ref().map_or(1.0, |w| w[f[k] as usize]);
                let s = base * w;
                let (t, dg, dx) = corner(rot(gf, k), rot(xf, k));
                let row = fi * per + k;
                r[row] = s * t;
                if let Some(j) = jac.as_mut() {
                    for i in 0..3 {
                        // Local slot i of the rotated corner is face slot (k + i) mod 3.
                        let m = (k + i) % 3;
                        let (da, db) = split_segment(seg.at, scale(dg[i], s), scale(dx[i], s));
                        j.da[row * 3 + m] = da;
                        j.db[row * 3 + m] = db;
                    }
                }
            }
            if per == 4 {
                let s = (stretch * share).sqrt();
                let (sigma, dg, dx) = self::stretch(gf, xf);
                let row = fi * per + 3;
                r[row] = s * sigma;
                if let Some(j) = jac.as_mut() {
                    for m in 0..3 {
                        let (da, db) = split_segment(seg.at, scale(dg[m], s), scale(dx[m], s));
                        j.da[row * 3 + m] = da;
                        j.db[row * 3 + m] = db;
                    }
                }
            }
        }
    }
}
