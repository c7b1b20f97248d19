// Index loops mirror the formulas (face slot, coordinate) in this kernel.
#![allow(clippy::needless_range_loop)]

use super::faces::{face_share_frozen_values, segment_faces};
use crate::mesh::geometry::{dot, scale, sub};
use crate::mesh::Topology;
use crate::metric::pattern::{JacobianMut, Pattern, PatternRef};
use crate::metric::segment::{geometry_and_displacement, split_segment, Segment};
use crate::metric::traits::Metric;

/// The scale-invariant L2 metric (eq. 11, docs/method.md "Scale-invariant forms"): the mean
/// squared displacement per unit area, measured against the local size of the pose,
/// `G_M(X) = sum_f sum_{v in f} (c_f q_f / 3) |X_v|^2 / L_f(M)`, with `L_f(M)` the sum of the
/// face's squared edge lengths in `M` and `c_f`, `q_f` its frozen area and size shares
/// (`A_f / A`, `L_f / A`, means of the path's ends). Where `M` is the frozen geometry this is
/// `sum_p A_p |X_p|^2 / A^2`, the calibrated L2 term; scaling `M` and `X` together leaves it
/// unchanged. Dimensionless.
///
/// Residuals per face corner and coordinate, `sqrt(c_f q_f / (3 L_f(M))) X_v^c` (9 #F), each
/// depending on the face's three vertices.
#[derive(Debug, Clone, Copy, Default)]
pub struct RelativeL2;

/// `t = sqrt(k / L)` with `L = |g1 - g0|^2 + |g2 - g1|^2 + |g0 - g2|^2`, and `dt/dg_m`.
#[inline]
fn size_factor(g: [[f64; 3]; 3], k: f64) -> (f64, [[f64; 3]; 3]) {
    let (e0, e1, e2) = (sub(g[1], g[0]), sub(g[2], g[1]), sub(g[0], g[2]));
    let l = dot(e0, e0) + dot(e1, e1) + dot(e2, e2);
    let t = (k.max(0.0) / l).sqrt();
    // dL/dg0 = 2 (e2 - e0), dL/dg1 = 2 (e0 - e1), dL/dg2 = 2 (e1 - e2); dt = -t dL / (2 L).
    let c = -t / l;
    (
        t,
        [
            scale(sub(e2, e0), c),
            scale(sub(e0, e1), c),
            scale(sub(e1, e2), c),
        ],
    )
}

impl Metric for RelativeL2 {
    fn name(&self) -> String {
        "l2(relative)".into()
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        Pattern::from_rows(topo.faces().iter().flat_map(|f| std::iter::repeat_n(*f, 9)))
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        9 * topo.n_faces()
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
        let nf = topo.n_faces();
        for (fi, f) in topo.faces().iter().enumerate() {
            let gf = f.map(|i| g[i as usize]);
            let (t, dt) = size_factor(gf, faces[fi] * faces[nf + fi] / 3.0);
            for k in 0..3 {
                let xv = x[f[k] as usize];
                for c in 0..3 {
                    let row = fi * 9 + k * 3 + c;
                    r[row] = t * xv[c];
                    if let Some(j) = jac.as_mut() {
                        for m in 0..3 {
                            let mut dx = [0.0; 3];
                            if m == k {
                                dx[c] = t;
                            }
                            let (da, db) = split_segment(seg.at, scale(dt[m], xv[c]), dx);
                            j.da[row * 3 + m] = da;
                            j.db[row * 3 + m] = db;
                        }
                    }
                }
            }
        }
    }
}
