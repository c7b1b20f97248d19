//! The as-rigid-as-possible metric (eq. 1): L2 modulo infinitesimal rigid motions.

use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::segment::{geometry_and_displacement, split_segment, At, Segment};
use super::traits::Metric;
use crate::mesh::geometry::{add, cross, dot, scale, sqrt_third_area_gradient, sub};
use crate::mesh::Topology;

/// The rigid metric (eq. 1): `G_R(X) = min over (t, w) of sum_p A_p |X_p - t - w x p|^2`, the
/// [`super::L2`] norm (eq. 11) of `X` minus its area-weighted least-squares infinitesimal rigid
/// motion `Xbar_p = t + w x p` (`p` the positions of `M`, `A_p` one third of the area of the
/// faces at `p`).
///
/// The rigid motion is carried as 6 auxiliary unknowns per segment term,
/// `aux = [t_x, t_y, t_z, w_x, w_y, w_z]` ([`Metric::n_aux`]; `t` in length units, `w`
/// dimensionless (radians)), so the residuals stay sparse: per face corner and
/// coordinate, `sqrt(area_f / 3) * (X_v - t - w x v)_c` for `v = f[k]` (9 #F residuals, each on
/// the face's 3 vertices, as [`super::L2`]). [`Metric::best_aux`] gives the optimal motion in
/// closed form and [`Metric::squared_norm`] uses it. Units: length^4. Vanishes exactly on
/// infinitesimal rigid motions; `G_R <= G_L2`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Rigid;

/// Relative ridge added to the 3x3 rotational normal matrix so that a degenerate geometry
/// (all points collinear or coincident) still yields a finite motion.
const RIDGE: f64 = 1e-14;

impl Rigid {
    /// Area-weighted least-squares infinitesimal rigid motion `(t, w)` (returned as
    /// `[t_x, t_y, t_z, w_x, w_y, w_z]`) fitted to the displacements `x` (#V x 3) on the
    /// positions `g` (#V x 3): minimizes `sum_p A_p |x_p - t - w x g_p|^2`.
    ///
    /// Solved in centred coordinates (`c` the area-weighted centroid, `d_p = g_p - c`):
    /// `t' = sum A_p x_p / sum A_p`, `(sum A_p (|d_p|^2 I - d_p d_p^T)) w = sum A_p d_p x x_p`,
    /// `t = t' - w x c`; a tiny relative ridge keeps a singular inertia (collinear points)
    /// finite. Returns zeros when the total area is zero.
    pub fn fit_motion(topo: &Topology, g: &[[f64; 3]], x: &[[f64; 3]]) -> [f64; 6] {
        fit_motion_weighted(g, x, &crate::mesh::geometry::vertex_areas(topo, g))
    }
}

/// Weighted least-squares infinitesimal rigid motion `[t_x, t_y, t_z, w_x, w_y, w_z]` fitted to
/// the displacements `x` (#V x 3) on the positions `g` (#V x 3) with per-vertex weights
/// `weights` (#V, area units): minimizes `sum_p weights_p |x_p - t - w x g_p|^2` (see
/// [`Rigid::fit_motion`] for the method). Zeros when the total weight is not positive.
pub fn fit_motion_weighted(g: &[[f64; 3]], x: &[[f64; 3]], weights: &[f64]) -> [f64; 6] {
    let mut total = 0.0;
    let mut cg = [0.0; 3];
    let mut cx = [0.0; 3];
    for ((gp, xp), &a) in g.iter().zip(x).zip(weights) {
        let a = a.max(0.0);
        total += a;
        cg = add(cg, scale(*gp, a));
        cx = add(cx, scale(*xp, a));
    }
    if total <= 0.0 || !total.is_finite() {
        return [0.0; 6];
    }
    let (c, tp) = (scale(cg, 1.0 / total), scale(cx, 1.0 / total));
    let mut m = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    for ((gp, xp), &a) in g.iter().zip(x).zip(weights) {
        let a = a.max(0.0);
        let d = sub(*gp, c);
        let dd = dot(d, d);
        for (r, row) in m.iter_mut().enumerate() {
            for (s, e) in row.iter_mut().enumerate() {
                *e += a * (if r == s { dd } else { 0.0 } - d[r] * d[s]);
            }
        }
        rhs = add(rhs, scale(cross(d, *xp), a));
    }
    let w = solve_spd3(m, rhs);
    let t = sub(tp, cross(w, c));
    [t[0], t[1], t[2], w[0], w[1], w[2]]
}

/// Solves the symmetric positive semi-definite 3x3 system `m w = rhs` by Cholesky with a tiny
/// relative ridge; zero if the matrix is zero or not finite.
pub(crate) fn solve_spd3(mut m: [[f64; 3]; 3], rhs: [f64; 3]) -> [f64; 3] {
    let tr = m[0][0] + m[1][1] + m[2][2];
    if tr <= 0.0 || !tr.is_finite() {
        return [0.0; 3];
    }
    for (i, row) in m.iter_mut().enumerate() {
        row[i] += RIDGE * tr;
    }
    // Cholesky m = L L^T (explicit 3x3), then forward and back substitution.
    if m[0][0] <= 0.0 {
        return [0.0; 3];
    }
    let l00 = m[0][0].sqrt();
    let (l10, l20) = (m[1][0] / l00, m[2][0] / l00);
    let d11 = m[1][1] - l10 * l10;
    if d11 <= 0.0 {
        return [0.0; 3];
    }
    let l11 = d11.sqrt();
    let l21 = (m[2][1] - l20 * l10) / l11;
    let d22 = m[2][2] - l20 * l20 - l21 * l21;
    if d22 <= 0.0 {
        return [0.0; 3];
    }
    let l22 = d22.sqrt();
    let y0 = rhs[0] / l00;
    let y1 = (rhs[1] - l10 * y0) / l11;
    let y2 = (rhs[2] - l20 * y0 - l21 * y1) / l22;
    let w2 = y2 / l22;
    let w1 = (y1 - l21 * w2) / l11;
    let w0 = (y0 - l10 * w1 - l20 * w2) / l00;
    [w0, w1, w2]
}

impl Metric for Rigid {
    fn name(&self) -> String {
        "rigid".into()
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        Pattern::from_rows(topo.faces().iter().flat_map(|f| std::iter::repeat_n(*f, 9)))
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        9 * topo.n_faces()
    }

    fn n_aux(&self) -> usize {
        6
    }

    fn best_aux(&self, topo: &Topology, seg: &Segment) -> Vec<f64> {
        let (g, x) = geometry_and_displacement(seg);
        Rigid::fit_motion(topo, g, &x).to_vec()
    }

    /// Residuals `sqrt(area_f / 3) * (X_v - t - w x v)_c`; missing entries of `seg.aux`
    /// (fewer than 6) count as zero.
    fn residuals(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        mut jac: Option<JacobianMut>,
    ) {
        let (g, x) = geometry_and_displacement(seg);
        let aux = |i: usize| seg.aux.get(i).copied().unwrap_or(0.0);
        let t = [aux(0), aux(1), aux(2)];
        let w = [aux(3), aux(4), aux(5)];
        let at: At = seg.at;
        for (fi, f) in topo.faces().iter().enumerate() {
            let [p, q, rr] = f.map(|i| g[i as usize]);
            let (s, ds) = sqrt_third_area_gradient(p, q, rr);
            for k in 0..3 {
                let gv = g[f[k] as usize];
                let e = sub(sub(x[f[k] as usize], t), cross(w, gv));
                for c3 in 0..3 {
                    let row = fi * 9 + k * 3 + c3;
                    r[row] = s * e[c3];
                    if let Some(j) = jac.as_mut() {
                        let mut unit = [0.0; 3];
                        unit[c3] = 1.0;
                        for (m, dsm) in ds.iter().enumerate() {
                            let mut dg = scale(*dsm, e[c3]);
                            let mut dx = [0.0; 3];
                            if m == k {
                                // d(w x g)_c / dg = e_c x w; the residual has -s times it.
                                dg = sub(dg, scale(cross(unit, w), s));
                                dx[c3] = s;
                            }
                            let (da, db) = split_segment(at, dg, dx);
                            j.da[row * 3 + m] = da;
                            j.db[row * 3 + m] = db;
                        }
                        // dr/dt = -s e_c; dr/dw = -s (g x e_c).
                        let dw = scale(cross(gv, unit), -s);
                        let d = &mut j.daux[row * 6..row * 6 + 6];
                        d[..3].copy_from_slice(&scale(unit, -s));
                        d[3..].copy_from_slice(&dw);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{fdcheck, L2};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn rigid_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&Rigid, 29);
        fdcheck::check_metric(&crate::metric::Regularized::new(Box::new(Rigid), 0.5), 31);
    }

    fn seg<'a>(a: &'a [[f64; 3]], b: &'a [[f64; 3]], at: At) -> Segment<'a> {
        Segment {
            a,
            b,
            at,
            aux: &[],
            frozen: None,
        }
    }

    /// Irregular sphere moved off the origin (the fit must handle the coupling of t and w).
    fn shape(seed: u64) -> (crate::mesh::Shape, Vec<[f64; 3]>, ChaCha8Rng) {
        let s = crate::synth::icosphere(2);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let a: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| {
                [1.5 * p[0] + 3.0, p[1] - 2.0, 0.7 * p[2] + 1.0]
                    .map(|c| c + 0.05 * (rng.random::<f64>() - 0.5))
            })
            .collect();
        (s, a, rng)
    }

    #[test]
    fn best_aux_recovers_a_rigid_field_and_the_norm_vanishes() {
        let (s, a, _) = shape(1);
        let (t0, w0) = ([0.3, -0.1, 0.25], [0.2, 0.5, -0.4]);
        let b: Vec<[f64; 3]> = a.iter().map(|p| add(*p, add(t0, cross(w0, *p)))).collect();
        let pat = Rigid.pattern(&s.topology);
        let l2_pat = L2.pattern(&s.topology);
        // At the start the field is exactly t0 + w0 x a.
        let sg = seg(&a, &b, At::Start);
        let aux = Rigid.best_aux(&s.topology, &sg);
        for (got, want) in aux.iter().zip(t0.iter().chain(&w0)) {
            assert!((got - want).abs() < 1e-10, "{aux:?}");
        }
        let g = Rigid.squared_norm(&s.topology, &pat, &sg);
        let g_l2 = L2.squared_norm(&s.topology, &l2_pat, &sg);
        assert!(g < 1e-20 * g_l2, "{g} vs {g_l2}");
    }

    #[test]
    fn rigid_is_at_most_l2_and_best_aux_is_optimal() {
        let (s, a, mut rng) = shape(2);
        let b: Vec<[f64; 3]> = a
            .iter()
            .map(|p| [p[0] + 0.3 * p[1], p[1], p[2] + 0.1].map(|c| c + 0.1 * (rng.random::<f64>() - 0.5)))
            .collect();
        let pat = Rigid.pattern(&s.topology);
        let l2_pat = L2.pattern(&s.topology);
        for at in [At::Start, At::End] {
            let sg = seg(&a, &b, at);
            let g = Rigid.squared_norm(&s.topology, &pat, &sg);
            let g_l2 = L2.squared_norm(&s.topology, &l2_pat, &sg);
            assert!(g > 0.0 && g <= g_l2, "{g} vs {g_l2}");
            // The gradient with respect to aux vanishes at best_aux: J_aux^T r = 0.
            let aux = Rigid.best_aux(&s.topology, &sg);
            let sg = Segment { aux: &aux, ..sg };
            let mut r = vec![0.0; pat.n_residuals()];
            let mut jac = super::super::Jacobian::zeros(&pat, 6);
            Rigid.residuals(&s.topology, pat.as_ref(), &sg, &mut r, Some(jac.as_mut()));
            for m in 0..6 {
                let gm: f64 = r.iter().enumerate().map(|(i, ri)| ri * jac.daux[i * 6 + m]).sum();
                assert!(gm.abs() < 1e-10 * g.sqrt(), "aux gradient {m}: {gm}");
            }
        }
    }

    #[test]
    fn collinear_or_flat_geometry_stays_finite() {
        let s = crate::synth::icosphere(1);
        // All points on the x axis: zero area, and a singular inertia if it were not.
        let a: Vec<[f64; 3]> = s.positions.iter().map(|p| [p[0], 0.0, 0.0]).collect();
        let b: Vec<[f64; 3]> = s.positions.clone();
        let pat = Rigid.pattern(&s.topology);
        for at in [At::Start, At::End] {
            let sg = seg(&a, &b, at);
            let aux = Rigid.best_aux(&s.topology, &sg);
            assert!(aux.iter().all(|v| v.is_finite()));
            let g = Rigid.squared_norm(&s.topology, &pat, &sg);
            assert!(g.is_finite());
        }
        // A singular inertia (possible only up to rounding with positive area) is ridged.
        let w = solve_spd3(
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]],
            [1.0, 2.0, 0.0],
        );
        assert!(w.iter().all(|v| v.is_finite()));
        assert!((w[0] - 1.0).abs() < 1e-12 && (w[1] - 2.0).abs() < 1e-12 && w[2] == 0.0);
    }
}
