// Index loops mirror the formulas (vertex, coordinate, residual indices) in these kernels.
#![allow(clippy::needless_range_loop)]

use super::gradient::{GradientSink, Scratch};
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::second_order::SecondOrderSink;
use super::segment::{geometry_and_displacement, split_segment, Segment};
use super::traits::Metric;
use crate::mesh::geometry::{scale, sqrt_third_area_gradient};
use crate::mesh::Topology;

/// The L2 metric (eq. 11): `G_M(X) = sum_p A_p |X_p|^2`, `A_p` one third of the area of the
/// faces at `p` in `M`.
///
/// Written per face corner and coordinate as residuals `sqrt(area_f / 3) * X_v^c` (9 #F
/// residuals), so each residual depends on the three vertices of one face. Units: length^4.
#[derive(Debug, Clone, Copy, Default)]
pub struct L2;

impl Metric for L2 {
    fn name(&self) -> String {
        "l2".into()
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        Pattern::from_rows(topo.faces().iter().flat_map(|f| std::iter::repeat_n(*f, 9)))
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        9 * topo.n_faces()
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
        for (fi, f) in topo.faces().iter().enumerate() {
            let [p, q, rr] = f.map(|i| g[i as usize]);
            let (s, ds) = sqrt_third_area_gradient(p, q, rr);
            for k in 0..3 {
                let xv = x[f[k] as usize];
                for c3 in 0..3 {
                    let row = fi * 9 + k * 3 + c3;
                    r[row] = s * xv[c3];
                    if let Some(j) = jac.as_mut() {
                        for (m, dsm) in ds.iter().enumerate() {
                            let dg = scale(*dsm, xv[c3]);
                            let mut dx = [0.0; 3];
                            if m == k {
                                dx[c3] = s;
                            }
                            let (da, db) = split_segment(seg.at, dg, dx);
                            j.da[row * 3 + m] = da;
                            j.db[row * 3 + m] = db;
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::fdcheck;

    #[test]
    fn l2_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&L2, 7);
    }

    #[test]
    fn l2_of_translation_is_area_times_squared_length() {
        let s = crate::synth::icosphere(2);
        let b: Vec<[f64; 3]> = s.positions.iter().map(|p| [p[0] + 0.5, p[1], p[2]]).collect();
        let pat = L2.pattern(&s.topology);
        let seg = Segment {
            a: &s.positions,
            b: &b,
            at: super::super::At::Start,
            aux: &[],
            frozen: None,
        };
        let g = L2.squared_norm(&s.topology, &pat, &seg);
        let area = crate::mesh::geometry::total_area(&s.topology, &s.positions);
        assert!((g - 0.25 * area).abs() < 1e-12 * area);
    }
}

/// The L2 metric with its area weights frozen along a path (default for the L2 metric and for
/// the regularizer of eq. 11): `G(X) = sum_p Abar_p |X_p|^2` with `Abar_p` the mean of the
/// vertex areas (one-third rule) of the path's two end poses.
///
/// Why: with the literal weights of [`L2`] taken from the pose itself, an intermediate pose can
/// collapse triangles so that `A_p -> 0` and its vertices then move at no cost (the discrete
/// face of the vanishing geodesic distance of L2 metrics on immersions, Michor & Mumford
/// 2005); measured on an icosphere of 642 vertices, the minimum face area of the interior
/// poses of an L2 "geodesic" goes to 0 and the energy keeps falling. Frozen weights make the
/// form a fixed positive-definite quadratic form. One residual per vertex and coordinate,
/// `sqrt(Abar_v) X_v^c` (3 #V residuals). Units: length^4.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrozenL2;

impl FrozenL2 {
    /// The frozen weights `Abar` (#V) for a path from `start` to `end`.
    pub fn weights(topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Vec<f64> {
        let a = crate::mesh::geometry::vertex_areas(topo, start);
        let b = crate::mesh::geometry::vertex_areas(topo, end);
        Self::mean_areas(&a, &b)
    }

    /// `Abar = (A(start) + A(end)) / 2` from the two poses' vertex areas (#V each).
    fn mean_areas(a: &[f64], b: &[f64]) -> Vec<f64> {
        a.iter().zip(b).map(|(x, y)| 0.5 * (x + y)).collect()
    }

    /// [`Metric::segment_squared_norms`] (needs no pattern): `sum_v Abar_v |X_v|^2` of each
    /// term, length^4.
    pub(crate) fn values(topo: &Topology, segs: [&Segment; 2]) -> [f64; 2] {
        segs.map(|seg| {
            let w = Self::segment_weights(topo, seg);
            let mut value = 0.0;
            for (v, wv) in w.iter().enumerate() {
                let (p, q) = (seg.a[v], seg.b[v]);
                let x = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                value += wv.max(0.0) * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
            }
            value
        })
    }

    /// `seg.frozen` (#V) if present, else the weights of the segment's own end poses.
    fn segment_weights<'a>(topo: &Topology, seg: &Segment<'a>) -> std::borrow::Cow<'a, [f64]> {
        match seg.frozen {
            Some(w) if w.len() == topo.n_vertices() => std::borrow::Cow::Borrowed(w),
            _ => std::borrow::Cow::Owned(Self::weights(topo, seg.a, seg.b)),
        }
    }
}

impl Metric for FrozenL2 {
    fn name(&self) -> String {
        "l2(frozen)".into()
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        Pattern::from_rows((0..topo.n_vertices() as u32).flat_map(|v| std::iter::repeat_n([v], 3)))
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        3 * topo.n_vertices()
    }

    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        Some(Self::weights(topo, start, end))
    }

    /// The vertex areas of `pose` (#V, length^2), half of [`FrozenL2::weights`].
    fn pose_summary(&self, topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
        (pose.len() == topo.n_vertices()).then(|| crate::mesh::geometry::vertex_areas(topo, pose))
    }

    fn frozen_weights_from(
        &self,
        topo: &Topology,
        start: &[[f64; 3]],
        end: &[[f64; 3]],
        [a, b]: [&[f64]; 2],
    ) -> Option<Vec<f64>> {
        let nv = topo.n_vertices();
        if a.len() != nv || b.len() != nv {
            return self.frozen_weights(topo, start, end);
        }
        Some(Self::mean_areas(a, b))
    }

    /// Uses `seg.frozen` (#V); without it, the segment's own end poses supply the weights.
    fn residuals(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        mut jac: Option<JacobianMut>,
    ) {
        let w = Self::segment_weights(topo, seg);
        for v in 0..topo.n_vertices() {
            let s = w[v].max(0.0).sqrt();
            for c in 0..3 {
                let row = 3 * v + c;
                r[row] = s * (seg.b[v][c] - seg.a[v][c]);
                if let Some(j) = jac.as_mut() {
                    let mut d = [0.0; 3];
                    d[c] = s;
                    j.da[row] = d.map(|x| -x);
                    j.db[row] = d;
                }
            }
        }
    }

    fn gradient(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        _scratch: &mut Scratch,
        sink: &mut GradientSink,
    ) -> f64 {
        let w = Self::segment_weights(topo, seg);
        let mut value = 0.0;
        for v in 0..topo.n_vertices() {
            // r_c = s X_c, dr_c/db = s e_c: the gradient is 2 weight w X (and minus for a).
            let wv = w[v].max(0.0);
            let x = [
                seg.b[v][0] - seg.a[v][0],
                seg.b[v][1] - seg.a[v][1],
                seg.b[v][2] - seg.a[v][2],
            ];
            value += wv * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
            let f = 2.0 * sink.weight * wv;
            for c in 0..3 {
                sink.ga[v][c] -= f * x[c];
                sink.gb[v][c] += f * x[c];
            }
        }
        sink.weight * value
    }

    /// `sum_v Abar_v |X_v|^2` for each term, without storing residuals.
    fn segment_squared_norms(&self, topo: &Topology, _p: PatternRef, segs: [&Segment; 2]) -> [f64; 2] {
        Self::values(topo, segs)
    }

    /// With frozen weights the residuals are linear in the unknowns: no second-order part.
    /// Without them the weights depend on the segment's poses (not provided).
    fn add_second_order(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        _r: &[f64],
        _sink: &mut SecondOrderSink,
    ) -> bool {
        matches!(seg.frozen, Some(w) if w.len() == topo.n_vertices())
    }
}

#[cfg(test)]
mod frozen_tests {
    use super::*;
    use crate::metric::{fdcheck, At};

    #[test]
    fn frozen_l2_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&FrozenL2, 3);
    }

    #[test]
    fn frozen_l2_equals_l2_when_the_ends_coincide_in_area() {
        let s = crate::synth::icosphere(2);
        let b: Vec<[f64; 3]> = s.positions.iter().map(|p| [p[0] + 0.5, p[1], p[2]]).collect();
        let w = FrozenL2.frozen_weights(&s.topology, &s.positions, &b);
        let seg = Segment {
            a: &s.positions,
            b: &b,
            at: At::Start,
            aux: &[],
            frozen: w.as_deref(),
        };
        let g1 = FrozenL2.squared_norm(&s.topology, &FrozenL2.pattern(&s.topology), &seg);
        let g0 = L2.squared_norm(&s.topology, &L2.pattern(&s.topology), &seg);
        assert!((g1 - g0).abs() < 1e-12 * g0);
    }
}
