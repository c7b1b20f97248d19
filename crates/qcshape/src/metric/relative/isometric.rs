use super::faces::strain_rate_gradient;
use super::faces::{edge_shares, face_share_frozen_values, segment_faces};
use crate::mesh::geometry::{add, dot, sub};
use crate::mesh::Topology;
use crate::metric::gradient::{same_frozen, Scratch, SegmentSink};
use crate::metric::pattern::{JacobianMut, Pattern, PatternRef};
use crate::metric::second_order::SecondOrderSink;
use crate::metric::segment::{geometry_and_displacement, split_segment, At, Segment};
use crate::metric::traits::{segment_gradient_per_term, Metric};

/// The scale-invariant isometric metric (eq. 3 as a strain, docs/method.md "Scale-invariant
/// forms"): `G_M(X) = sum over edges (p, q) of w_e (<X_p - X_q, p - q> / |p - q|^2)^2`, the
/// area-weighted mean squared edge strain rate (`w_e` a third of the frozen area shares of the
/// edge's faces; the shares sum to one). Vanishes on infinitesimal rigid motions; a uniform
/// scaling `X = t M` costs `t^2`. Dimensionless; `G_{sM}(sX) = G_M(X)`.
///
/// One residual per edge, depending on its two vertices.
#[derive(Debug, Clone, Copy, Default)]
pub struct RelativeIsometric;

impl Metric for RelativeIsometric {
    fn name(&self) -> String {
        "isometric(relative)".into()
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        Pattern::from_rows(topo.edges().iter())
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        topo.n_edges()
    }

    face_share_frozen_values!();

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
        let shares = edge_shares(topo, &faces);
        for (ei, e) in topo.edges().iter().enumerate() {
            let (p, q) = (e[0] as usize, e[1] as usize);
            let de = sub(g[p], g[q]);
            let dx = sub(x[p], x[q]);
            let (l, pr) = (dot(de, de), dot(de, dx));
            let s = shares[ei].max(0.0).sqrt();
            r[ei] = s * pr / l;
            if let Some(j) = jac.as_mut() {
                let (dg, dd) = strain_rate_gradient(de, dx, l, pr, s);
                let (da, db) = split_segment(seg.at, dg, dd);
                j.da[2 * ei] = da;
                j.db[2 * ei] = db;
                let (da, db) = split_segment(seg.at, dg.map(|v| -v), dd.map(|v| -v));
                j.da[2 * ei + 1] = da;
                j.db[2 * ei + 1] = db;
            }
        }
    }

    /// Both terms of the segment in one pass over the edges (one displacement, one set of
    /// area shares; never stores the Jacobian; per term if the terms' frozen values differ): `weight sum (r_start^2 + r_end^2)`, and
    /// `2 weight r dr/da`, `2 weight r dr/db` into `sink`.
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
        let shares = edge_shares(topo, &faces);
        let w2 = 2.0 * sink.weight;
        let mut value = 0.0;
        for (ei, e) in topo.edges().iter().enumerate() {
            let (p, q) = (e[0] as usize, e[1] as usize);
            let dx = sub(sub(b[p], b[q]), sub(a[p], a[q]));
            let s = shares[ei].max(0.0).sqrt();
            // The start term (geometry a) and the end term (geometry b): r = s <e, d> / |e|^2,
            // dr/de = s (d / l - 2 pr e / l^2), dr/dd = s e / l.
            let mut ga = [0.0; 3];
            let mut gb = [0.0; 3];
            for (at, g) in [(At::Start, a), (At::End, b)] {
                let de = sub(g[p], g[q]);
                let (l, pr) = (dot(de, de), dot(de, dx));
                let r = s * pr / l;
                value += r * r;
                let c = w2 * r;
                let (dg, dd) = strain_rate_gradient(de, dx, l, pr, s * c);
                let (da, db) = split_segment(at, dg, dd);
                ga = add(ga, da);
                gb = add(gb, db);
            }
            sink.ga[p] = add(sink.ga[p], ga);
            sink.gb[p] = add(sink.gb[p], gb);
            sink.ga[q] = sub(sink.ga[q], ga);
            sink.gb[q] = sub(sink.gb[q], gb);
        }
        sink.weight * value
    }

    /// `r = s <d, e> / |e|^2` (`e = g_p - g_q`, `d = X_p - X_q`): `d2r/dd dd = 0`,
    /// `d2r/de dd = s (I / l - 2 e e^T / l^2)`, `d2r/de de = s (8 pr e e^T / l^3 - 2 (d e^T +
    /// e d^T) / l^2 - 2 pr I / l^2)` (`l = |e|^2`, `pr = <d, e>`), mapped to the edge's two
    /// vertices with signs `+1, -1`.
    fn add_second_order(
        &self,
        topo: &Topology,
        _p: PatternRef,
        seg: &Segment,
        r: &[f64],
        sink: &mut SecondOrderSink,
    ) -> bool {
        let (g, x) = geometry_and_displacement(seg);
        let faces = segment_faces(topo, seg);
        let shares = edge_shares(topo, &faces);
        for (ei, e) in topo.edges().iter().enumerate() {
            let (p, q) = (e[0] as usize, e[1] as usize);
            let (de, dx) = (sub(g[p], g[q]), sub(x[p], x[q]));
            let (l, pr) = (dot(de, de), dot(de, dx));
            let c = r[ei] * shares[ei].max(0.0).sqrt();
            let mut hee = [0.0; 9];
            let mut hed = [0.0; 9];
            for i in 0..3 {
                for k in 0..3 {
                    let delta = if i == k { 1.0 } else { 0.0 };
                    hed[3 * i + k] = c * (delta / l - 2.0 * de[i] * de[k] / (l * l));
                    hee[3 * i + k] = c
                        * (8.0 * pr * de[i] * de[k] / (l * l * l)
                            - 2.0 * (dx[i] * de[k] + de[i] * dx[k]) / (l * l)
                            - 2.0 * pr * delta / (l * l));
                }
            }
            let (neg_ee, neg_ed) = (hee.map(|v| -v), hed.map(|v| -v));
            sink.add(ei, 0, 0, &hee, &hed);
            sink.add(ei, 1, 1, &hee, &hed);
            sink.add(ei, 0, 1, &neg_ee, &neg_ed);
            sink.add(ei, 1, 0, &neg_ee, &neg_ed);
        }
        true
    }
}
