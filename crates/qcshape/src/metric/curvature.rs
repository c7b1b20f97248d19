//! Angle-defect curvature with its exact gradient over each vertex's one-ring, computed in one
//! pass over the faces (used by the `segment` quasi-conformal weights, eq. 10).
//!
//! Layout of the gradient: for vertex `v`, `grad[off[v]]` is `dK_v/dx_v` and
//! `grad[off[v] + 1 + j]` is `dK_v/dx_u` for `u = topo.neighbors(v)[j]` (sorted ascending), with
//! `off` from [`ring_offsets`]. Every other derivative of `K_v` is zero.

use std::f64::consts::PI;

use crate::mesh::geometry::{corner_angle, corner_angle_gradient, sub};
use crate::mesh::Topology;

/// Offsets of the closed one-rings (#V + 1): `off[v] = v + sum_{u < v} deg(u)`.
pub(crate) fn ring_offsets(topo: &Topology) -> Vec<u32> {
    let mut off = Vec::with_capacity(topo.n_vertices() + 1);
    let mut acc = 0u32;
    off.push(0);
    for v in 0..topo.n_vertices() {
        acc += 1 + topo.neighbors(v).len() as u32;
        off.push(acc);
    }
    off
}

/// The closed one-ring of `v`: `v` itself, then its neighbours (the gradient layout).
#[inline]
pub(crate) fn closed_ring(topo: &Topology, v: usize) -> impl Iterator<Item = u32> + '_ {
    std::iter::once(v as u32).chain(topo.neighbors(v).iter().copied())
}

/// Angle defect `K` (#V, radians, same rule as [`crate::mesh::geometry::angle_defect`]) and,
/// if `grad` is given, its gradient in the closed one-ring layout (`off` from
/// [`ring_offsets`]; `grad` is resized to `off[#V]`). Degenerate corners contribute a zero
/// derivative.
pub(crate) fn angle_defect_with_gradient(
    topo: &Topology,
    pos: &[[f64; 3]],
    off: &[u32],
    k: &mut Vec<f64>,
    mut grad: Option<&mut Vec<[f64; 3]>>,
) {
    let nv = topo.n_vertices();
    k.clear();
    k.extend((0..nv).map(|v| {
        if topo.vertex_faces(v).is_empty() {
            0.0
        } else if topo.is_boundary_vertex(v) {
            PI
        } else {
            2.0 * PI
        }
    }));
    if let Some(g) = grad.as_mut() {
        g.clear();
        g.resize(off.last().copied().unwrap_or(0) as usize, [0.0; 3]);
    }
    for f in topo.faces() {
        for c in 0..3 {
            let (v, q, r) = (f[c] as usize, f[(c + 1) % 3], f[(c + 2) % 3]);
            let (pv, pq, pr) = (pos[v], pos[q as usize], pos[r as usize]);
            k[v] -= corner_angle(pv, pq, pr);
            if let Some(g) = grad.as_mut() {
                let d = corner_angle_gradient(pv, pq, pr);
                let base = off[v] as usize;
                let nb = topo.neighbors(v);
                g[base] = sub(g[base], d[0]);
                if let Ok(j) = nb.binary_search(&q) {
                    g[base + 1 + j] = sub(g[base + 1 + j], d[1]);
                }
                if let Ok(j) = nb.binary_search(&r) {
                    g[base + 1 + j] = sub(g[base + 1 + j], d[2]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::angle_defect;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn defect_and_gradient_match_geometry_and_finite_differences() {
        let mut grid = crate::synth::grid(4);
        for p in &mut grid.positions {
            p[2] = 0.4 * (p[0] - 0.3) * (p[1] + 0.1);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for s in [crate::synth::icosphere(1), grid] {
            let topo = &s.topology;
            let pos: Vec<[f64; 3]> = s
                .positions
                .iter()
                .map(|p| p.map(|c| c + 0.05 * (rng.random::<f64>() - 0.5)))
                .collect();
            let off = ring_offsets(topo);
            let (mut k, mut g) = (Vec::new(), Vec::new());
            angle_defect_with_gradient(topo, &pos, &off, &mut k, Some(&mut g));
            let k_ref = angle_defect(topo, &pos);
            for (x, y) in k.iter().zip(&k_ref) {
                assert!((x - y).abs() < 1e-13);
            }
            let h = 1e-6;
            for v in 0..topo.n_vertices() {
                for (j, u) in closed_ring(topo, v).enumerate() {
                    for c in 0..3 {
                        let mut p2 = pos.clone();
                        p2[u as usize][c] += h;
                        let kp = angle_defect(topo, &p2)[v];
                        p2[u as usize][c] -= 2.0 * h;
                        let km = angle_defect(topo, &p2)[v];
                        let fd = (kp - km) / (2.0 * h);
                        let an = g[off[v] as usize + j][c];
                        assert!(
                            (fd - an).abs() < 1e-6 * (1.0 + fd.abs()),
                            "v {v} u {u}: {an} vs {fd}"
                        );
                    }
                }
            }
        }
    }
}
