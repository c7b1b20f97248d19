//! The rigid metric with area weights frozen along the path (the default reading of `rigid`).

use super::gradient::{GradientSink, Scratch};
use super::l2::FrozenL2;
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::rigid::fit_motion_weighted;
use super::segment::{geometry, geometry_and_displacement, split_segment, Segment};
use super::traits::Metric;
use crate::mesh::geometry::{cross, dot, scale, sub};
use crate::mesh::Topology;

/// The rigid metric (eq. 1) with frozen area weights:
/// `G_R(X) = min over (t, w) of sum_p Abar_p |X_p - t - w x p|^2`, where `p` are the positions
/// of the pose `M` at which the metric is taken and `Abar_p` (one third of the area of the faces
/// at `p`, averaged over the two ends of the path: [`super::FrozenL2::weights`]) stays fixed
/// along the path.
///
/// With the areas of each pose ([`super::Rigid`]) the path energy can be lowered by shrinking
/// triangles, and geodesics degenerate (docs/log/benchmarks.md, its findings);
/// freezing the areas as for [`super::FrozenL2`] keeps the metric "L2 modulo infinitesimal
/// rigid motions" while removing that escape. The motion `aux = [t_x, t_y, t_z, w_x, w_y, w_z]` is carried as 6 auxiliary
/// unknowns per segment term, eliminated in closed form by [`Metric::best_aux`].
/// Residuals: `sqrt(Abar_v) (X_v - t - w x v)_c`, 3 #V of them, each on one vertex.
/// Units: length^4.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrozenRigid;

impl FrozenRigid {
    /// The motion `(t, w)` of the segment's auxiliary unknowns (missing entries count as zero).
    fn motion(seg: &Segment) -> ([f64; 3], [f64; 3]) {
        let aux = |i: usize| seg.aux.get(i).copied().unwrap_or(0.0);
        ([aux(0), aux(1), aux(2)], [aux(3), aux(4), aux(5)])
    }

    fn weights<'a>(topo: &Topology, seg: &'a Segment, own: &'a mut Vec<f64>) -> &'a [f64] {
        match seg.frozen {
            Some(w) if w.len() == topo.n_vertices() => w,
            _ => {
                *own = FrozenL2::weights(topo, seg.a, seg.b);
                own
            }
        }
    }
}

impl Metric for FrozenRigid {
    fn name(&self) -> String {
        "rigid(frozen)".into()
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        Pattern::from_rows((0..topo.n_vertices() as u32).flat_map(|v| std::iter::repeat_n([v], 3)))
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        3 * topo.n_vertices()
    }

    fn n_aux(&self) -> usize {
        6
    }

    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        Some(FrozenL2::weights(topo, start, end))
    }

    fn best_aux(&self, topo: &Topology, seg: &Segment) -> Vec<f64> {
        let (g, x) = geometry_and_displacement(seg);
        let mut own = Vec::new();
        fit_motion_weighted(g, &x, Self::weights(topo, seg, &mut own)).to_vec()
    }

    /// Uses `seg.frozen` (#V); without it, the segment's own end poses supply the weights.
    /// Missing entries of `seg.aux` (fewer than 6) count as zero.
    fn residuals(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        mut jac: Option<JacobianMut>,
    ) {
        let mut own = Vec::new();
        let wts = Self::weights(topo, seg, &mut own);
        let (g, x) = geometry_and_displacement(seg);
        let (t, w) = Self::motion(seg);
        for v in 0..topo.n_vertices() {
            let s = wts[v].max(0.0).sqrt();
            let e = sub(sub(x[v], t), cross(w, g[v]));
            for c in 0..3 {
                let row = 3 * v + c;
                r[row] = s * e[c];
                if let Some(j) = jac.as_mut() {
                    let mut unit = [0.0; 3];
                    unit[c] = 1.0;
                    // d(w x g)_c / dg = e_c x w, with the residual's factor -s.
                    let dg = scale(cross(unit, w), -s);
                    let (da, db) = split_segment(seg.at, dg, scale(unit, s));
                    j.da[row] = da;
                    j.db[row] = db;
                    // dr/dt = -s e_c; dr/dw = -s (g x e_c).
                    let d = &mut j.daux[row * 6..row * 6 + 6];
                    d[..3].copy_from_slice(&scale(unit, -s));
                    d[3..].copy_from_slice(&scale(cross(g[v], unit), -s));
                }
            }
        }
    }

    /// The fused gradient of `weight sum_v Abar_v |e_v|^2`, `e_v = X_v - t - w x g_v` (`g` the
    /// term's geometry pose): `2 weight Abar_v e_v` for `X_v`, `2 weight Abar_v (w x e_v)` for
    /// `g_v`, and `-2 weight sum_v Abar_v e_v`, `-2 weight sum_v Abar_v (g_v x e_v)` for the
    /// motion `(t, w)`; the same as the Jacobian form (test
    /// `segment_gradients_match_the_per_term_jacobian_form`) without storing it.
    fn gradient(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        _scratch: &mut Scratch,
        sink: &mut GradientSink,
    ) -> f64 {
        let mut own = Vec::new();
        let wts = Self::weights(topo, seg, &mut own);
        let g = geometry(seg);
        let (t, w) = Self::motion(seg);
        let mut value = 0.0;
        let mut g_aux = [0.0; 6];
        for v in 0..topo.n_vertices() {
            let s2 = wts[v].max(0.0);
            let e = sub(sub(sub(seg.b[v], seg.a[v]), t), cross(w, g[v]));
            value += s2 * dot(e, e);
            let f = 2.0 * sink.weight * s2;
            let dx = scale(e, f);
            let (da, db) = split_segment(seg.at, scale(cross(w, e), f), dx);
            for c in 0..3 {
                sink.ga[v][c] += da[c];
                sink.gb[v][c] += db[c];
            }
            let ge = cross(g[v], e);
            for c in 0..3 {
                g_aux[c] -= dx[c];
                g_aux[3 + c] -= f * ge[c];
            }
        }
        for (out, d) in sink.gaux.iter_mut().zip(g_aux) {
            *out += d;
        }
        sink.weight * value
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::add;
    use crate::metric::{fdcheck, At, FrozenL2, Regularized};

    #[test]
    fn frozen_rigid_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&FrozenRigid, 37);
        fdcheck::check_metric(&Regularized::new(Box::new(FrozenRigid), 0.5), 41);
    }

    #[test]
    fn vanishes_on_rigid_motions_and_is_at_most_frozen_l2() {
        let s = crate::synth::icosphere(2);
        let a: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| [1.5 * p[0] + 3.0, p[1] - 2.0, 0.7 * p[2]])
            .collect();
        let (t0, w0) = ([0.3, -0.1, 0.25], [0.2, 0.5, -0.4]);
        let b: Vec<[f64; 3]> = a.iter().map(|p| add(*p, add(t0, cross(w0, *p)))).collect();
        let pat = FrozenRigid.pattern(&s.topology);
        let l2_pat = FrozenL2.pattern(&s.topology);
        let frozen = FrozenRigid.frozen_weights(&s.topology, &a, &b);
        let seg = Segment {
            a: &a,
            b: &b,
            at: At::Start,
            aux: &[],
            frozen: frozen.as_deref(),
        };
        let aux = FrozenRigid.best_aux(&s.topology, &seg);
        for (got, want) in aux.iter().zip(t0.iter().chain(&w0)) {
            assert!((got - want).abs() < 1e-10, "{aux:?}");
        }
        let g = FrozenRigid.squared_norm(&s.topology, &pat, &seg);
        let g_l2 = FrozenL2.squared_norm(&s.topology, &l2_pat, &seg);
        assert!(g < 1e-20 * g_l2, "{g} vs {g_l2}");
        // A non-rigid field: positive, below L2, and the aux gradient vanishes at best_aux.
        let c: Vec<[f64; 3]> = a.iter().map(|p| [p[0] + 0.3 * p[1], p[1], 1.2 * p[2]]).collect();
        for at in [At::Start, At::End] {
            let seg = Segment {
                b: &c,
                at,
                frozen: None,
                ..seg
            };
            let g = FrozenRigid.squared_norm(&s.topology, &pat, &seg);
            let g_l2 = FrozenL2.squared_norm(&s.topology, &l2_pat, &seg);
            assert!(g > 0.0 && g < g_l2, "{g} vs {g_l2}");
            let aux = FrozenRigid.best_aux(&s.topology, &seg);
            let seg = Segment { aux: &aux, ..seg };
            let mut r = vec![0.0; pat.n_residuals()];
            let mut jac = crate::metric::Jacobian::zeros(&pat, 6);
            FrozenRigid.residuals(&s.topology, pat.as_ref(), &seg, &mut r, Some(jac.as_mut()));
            for m in 0..6 {
                let gm: f64 = r.iter().enumerate().map(|(i, ri)| ri * jac.daux[i * 6 + m]).sum();
                assert!(gm.abs() < 1e-9 * g.sqrt(), "aux gradient {m}: {gm}");
            }
        }
    }
}
