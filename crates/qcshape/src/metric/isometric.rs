use super::gradient::{GradientSink, Scratch, SegmentSink};
use super::pattern::{JacobianMut, Pattern, PatternRef};
use super::second_order::SecondOrderSink;
use super::segment::{geometry_and_displacement, split_segment, Segment};
use super::traits::Metric;
use crate::mesh::geometry::{dot, sub};
use crate::mesh::Topology;

/// The as-isometric-as-possible metric (eq. 3): `G_M(X) = sum over edges (p, q) of
/// <X_p - X_q, p - q>^2`, one residual per edge (the rate of change of squared edge length / 2).
/// Vanishes on infinitesimal rigid motions. Units: length^4.
#[derive(Debug, Clone, Copy, Default)]
pub struct Isometric;

impl Metric for Isometric {
    fn name(&self) -> String {
        "isometric".into()
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        Pattern::from_rows(topo.edges().iter())
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        topo.n_edges()
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
        for (ei, e) in topo.edges().iter().enumerate() {
            let (p, q) = (e[0] as usize, e[1] as usize);
            let de = sub(g[p], g[q]);
            let dx = sub(x[p], x[q]);
            r[ei] = dot(dx, de);
            if let Some(j) = jac.as_mut() {
                // dr/dg_p = dx, dr/dg_q = -dx; dr/dX_p = de, dr/dX_q = -de.
                let (da, db) = split_segment(seg.at, dx, de);
                j.da[2 * ei] = da;
                j.db[2 * ei] = db;
                let (da, db) = split_segment(seg.at, dx.map(|v| -v), de.map(|v| -v));
                j.da[2 * ei + 1] = da;
                j.db[2 * ei + 1] = db;
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
        let (g, x) = geometry_and_displacement(seg);
        let mut value = 0.0;
        for e in topo.edges() {
            let (p, q) = (e[0] as usize, e[1] as usize);
            let de = sub(g[p], g[q]);
            let dx = sub(x[p], x[q]);
            let r = dot(dx, de);
            value += r * r;
            let (da, db) = split_segment(seg.at, dx, de);
            sink.add(p, r, da, db);
            sink.add(q, -r, da, db);
        }
        sink.weight * value
    }

    /// Both terms in one pass over the edges: they share the displacement `X_p - X_q`; the
    /// `At::Start` term measures it against `a_p - a_q`, the `At::End` term against `b_p - b_q`
    /// (derivatives as in [`Metric::gradient`] through `split_segment`).
    fn segment_gradient(
        &self,
        topo: &Topology,
        _p: PatternRef,
        segs: [&Segment; 2],
        _scratch: &mut Scratch,
        sink: &mut SegmentSink,
    ) -> f64 {
        let (a, b) = (segs[0].a, segs[0].b);
        let s = 2.0 * sink.weight;
        let mut value = 0.0;
        for e in topo.edges() {
            let (p, q) = (e[0] as usize, e[1] as usize);
            let (ea, eb) = (sub(a[p], a[q]), sub(b[p], b[q]));
            let dx = sub(eb, ea);
            let (ra, rb) = (dot(dx, ea), dot(dx, eb));
            value += ra * ra + rb * rb;
            // d/da: ra (dx - ea) - rb eb; d/db: ra ea + rb (dx + eb) (vertex p; q opposite).
            let mut da = [0.0; 3];
            let mut db = [0.0; 3];
            for c in 0..3 {
                da[c] = s * (ra * (dx[c] - ea[c]) - rb * eb[c]);
                db[c] = s * (ra * ea[c] + rb * (dx[c] + eb[c]));
            }
            for c in 0..3 {
                sink.ga[p][c] += da[c];
                sink.gb[p][c] += db[c];
                sink.ga[q][c] -= da[c];
                sink.gb[q][c] -= db[c];
            }
        }
        sink.weight * value
    }

    /// `r = <X_p - X_q, g_p - g_q>` is bilinear: `d2 r / dg_k dX_l = s_k s_l I` (`s_p = 1`,
    /// `s_q = -1`), `d2 r / dg dg = 0`.
    fn add_second_order(
        &self,
        topo: &Topology,
        _p: PatternRef,
        _seg: &Segment,
        r: &[f64],
        sink: &mut SecondOrderSink,
    ) -> bool {
        const ZERO: [f64; 9] = [0.0; 9];
        for (ei, &c) in r.iter().enumerate().take(topo.n_edges()) {
            let id = [c, 0.0, 0.0, 0.0, c, 0.0, 0.0, 0.0, c];
            let neg = id.map(|v| -v);
            sink.add(ei, 0, 0, &ZERO, &id);
            sink.add(ei, 1, 1, &ZERO, &id);
            sink.add(ei, 0, 1, &ZERO, &neg);
            sink.add(ei, 1, 0, &ZERO, &neg);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{fdcheck, At};

    #[test]
    fn isometric_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&Isometric, 11);
    }

    #[test]
    fn isometric_vanishes_on_infinitesimal_rotation() {
        let s = crate::synth::icosphere(2);
        let w = [0.3, -0.2, 0.7];
        let t = 1e-3;
        // X = t * (w x p) + translation: an infinitesimal rigid motion.
        let b: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| {
                let c = crate::mesh::geometry::cross(w, *p);
                [p[0] + t * c[0] + t, p[1] + t * c[1], p[2] + t * c[2]]
            })
            .collect();
        let pat = Isometric.pattern(&s.topology);
        let seg = Segment {
            a: &s.positions,
            b: &b,
            at: At::Start,
            aux: &[],
            frozen: None,
        };
        let g = Isometric.squared_norm(&s.topology, &pat, &seg);
        assert!(g < 1e-28, "{g}");
    }
}
