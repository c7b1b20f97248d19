//! The rigid gauge of the interior poses ([`super::Gauge::Linear`]; docs/method.md "Rigid gauge").
//!
//! The path energy charges a rigid motion of an interior pose only through the L2 regularizer
//! and the membrane terms' second-order part, so a solver is free to turn the middle poses by
//! degrees at almost no change of the energy, and where it stops in those directions depends
//! on its steps, not on the shapes. The gauge removes them: every interior pose `P_i` keeps the
//! rigid placement of the linear interpolation `L_i = (1 - i/N) P_0 + (i/N) P_N`, to first
//! order: `sum_v (P_i - L_i)_v = 0` and `sum_v (L_i - c_i)_v x (P_i - L_i)_v = 0`, `c_i` the
//! centroid of `L_i` (the best rigid motion of `P_i` onto `L_i` in the least-squares sense is
//! the identity to first order). Both constraints are linear and depend only on the ends, so
//! every start path (linear, perturbed, warm) is moved onto the same affine subspace and the
//! orthogonal projector onto it keeps a quasi-Newton history consistent.

use super::energy::Ends;
use super::{dot, norm};

/// The orthogonal projector onto the complement of each interior pose's infinitesimal rigid
/// motions (3 translations, 3 rotations about the centroid) at the linear interpolation of
/// the ends, and the projection of a path onto the gauge's affine subspace.
#[derive(Debug, Clone)]
pub(crate) struct RigidGauge {
    /// Per interior pose `i = 1..N-1`: the linear interpolation `L_i` (`3 #V` values) and an
    /// orthonormal basis of its rigid motions (up to 6 vectors of `3 #V` values).
    poses: Vec<(Vec<f64>, Vec<Vec<f64>>)>,
}

impl RigidGauge {
    /// The gauge of a path with `steps` segments (`N`) and fixed `ends`.
    pub(crate) fn new(ends: &Ends, steps: usize) -> Self {
        let poses = (1..steps)
            .map(|i| {
                let t = i as f64 / steps as f64;
                let l: Vec<f64> = ends
                    .start
                    .iter()
                    .zip(&ends.end)
                    .flat_map(|(a, b)| (0..3).map(move |k| (1.0 - t) * a[k] + t * b[k]))
                    .collect();
                let basis = rigid_basis(&l);
                (l, basis)
            })
            .collect();
        Self { poses }
    }

    /// Removes each interior pose's rigid part from a direction `v` (pose values first, as
    /// the path energy's unknowns; the auxiliary values after them untouched).
    pub(crate) fn project(&self, v: &mut [f64]) {
        let stride = self.poses.first().map_or(0, |(l, _)| l.len());
        for (k, (_, basis)) in self.poses.iter().enumerate() {
            remove(&mut v[k * stride..(k + 1) * stride], basis);
        }
    }

    /// Moves a path `x` onto the gauge's subspace: each interior pose loses the rigid part of
    /// its difference from the linear interpolation (a no-op on the linear path itself).
    pub(crate) fn constrain(&self, x: &mut [f64]) {
        let stride = self.poses.first().map_or(0, |(l, _)| l.len());
        let mut d = vec![0.0; stride];
        for (k, (l, basis)) in self.poses.iter().enumerate() {
            let p = &mut x[k * stride..(k + 1) * stride];
            for ((di, pi), li) in d.iter_mut().zip(p.iter()).zip(l) {
                *di = pi - li;
            }
            remove(&mut d, basis);
            for ((pi, li), di) in p.iter_mut().zip(l).zip(&d) {
                *pi = li + di;
            }
        }
    }
}

/// `v -= sum_b <v, b> b` over an orthonormal `basis`.
fn remove(v: &mut [f64], basis: &[Vec<f64>]) {
    for b in basis {
        let c = dot(v, b);
        for (x, y) in v.iter_mut().zip(b) {
            *x -= c * y;
        }
    }
}

/// Orthonormal basis of the infinitesimal rigid motions of a pose `p` (`3 #V` values, vertex
/// by vertex): the three translations, then the rotations `e_a x (p - c)` about the centroid,
/// orthonormalized (modified Gram-Schmidt; a rotation whose remainder is below 1e-9 of its
/// length is dropped: a pose on a line has two, a point none).
fn rigid_basis(p: &[f64]) -> Vec<Vec<f64>> {
    let nv = p.len() / 3;
    let mut c = [0.0; 3];
    for v in p.chunks_exact(3) {
        for a in 0..3 {
            c[a] += v[a] / nv as f64;
        }
    }
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(6);
    for a in 0..3 {
        let mut t = vec![0.0; 3 * nv];
        for i in 0..nv {
            t[3 * i + a] = 1.0;
        }
        normalize_into(&mut basis, t);
    }
    for a in 0..3 {
        let (b, d) = ((a + 1) % 3, (a + 2) % 3);
        let mut r = vec![0.0; 3 * nv];
        for (i, v) in p.chunks_exact(3).enumerate() {
            // (e_a x q)_d = q_b, (e_a x q)_b = -q_d with q = v - c.
            r[3 * i + d] = v[b] - c[b];
            r[3 * i + b] = -(v[d] - c[d]);
        }
        normalize_into(&mut basis, r);
    }
    basis
}

/// Appends `r` to an orthonormal `basis` after removing its part in it, unless what is left
/// is below 1e-9 of its length (or zero).
fn normalize_into(basis: &mut Vec<Vec<f64>>, mut r: Vec<f64>) {
    let n0 = norm(&r);
    remove(&mut r, basis);
    let n = norm(&r);
    if n > 1e-9 * n0 && n > 0.0 {
        r.iter_mut().for_each(|x| *x /= n);
        basis.push(r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ends() -> Ends {
        // An irregular tetrahedron-like point set and a moved, deformed copy.
        let start = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.1, 0.0],
            [0.2, 1.1, 0.1],
            [0.1, 0.2, 0.9],
            [0.7, 0.6, 0.5],
        ];
        let end = start
            .iter()
            .map(|v| [v[0] + 0.3 * v[2], v[1] * 1.2 + 0.5, v[2] - 0.1])
            .collect();
        Ends {
            start,
            end,
            frozen: None,
        }
    }

    /// The rigid part of pose `k`'s difference from the linear interpolation: its 6 moments.
    fn moments(g: &RigidGauge, x: &[f64], k: usize) -> [f64; 6] {
        let (l, _) = &g.poses[k];
        let s = l.len();
        let p = &x[k * s..(k + 1) * s];
        let nv = s / 3;
        let mut c = [0.0; 3];
        for v in l.chunks_exact(3) {
            (0..3).for_each(|a| c[a] += v[a] / nv as f64);
        }
        let mut m = [0.0; 6];
        for i in 0..nv {
            let d: Vec<f64> = (0..3).map(|a| p[3 * i + a] - l[3 * i + a]).collect();
            let q: Vec<f64> = (0..3).map(|a| l[3 * i + a] - c[a]).collect();
            (0..3).for_each(|a| m[a] += d[a]);
            m[3] += q[1] * d[2] - q[2] * d[1];
            m[4] += q[2] * d[0] - q[0] * d[2];
            m[5] += q[0] * d[1] - q[1] * d[0];
        }
        m
    }

    #[test]
    fn constrained_paths_have_no_rigid_part_and_projection_is_idempotent() {
        let e = ends();
        let g = RigidGauge::new(&e, 4);
        let n = 3 * e.start.len() * 3;
        // A path far from the constraint: arbitrary values.
        let mut x: Vec<f64> = (0..n).map(|i| ((i * 37 % 11) as f64 - 5.0) * 0.13).collect();
        g.constrain(&mut x);
        for k in 0..3 {
            for m in moments(&g, &x, k) {
                assert!(m.abs() < 1e-12, "pose {k}: rigid moment {m}");
            }
        }
        let before = x.clone();
        g.constrain(&mut x);
        for (a, b) in x.iter().zip(&before) {
            assert!((a - b).abs() < 1e-14);
        }
        // A projected direction keeps a constrained path constrained, and projecting twice
        // changes nothing.
        let mut d: Vec<f64> = (0..n).map(|i| ((i * 13 % 7) as f64 - 3.0) * 0.2).collect();
        g.project(&mut d);
        let once = d.clone();
        g.project(&mut d);
        for (a, b) in d.iter().zip(&once) {
            assert!((a - b).abs() < 1e-14);
        }
        let moved: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + 0.7 * b).collect();
        for k in 0..3 {
            for m in moments(&g, &moved, k) {
                assert!(m.abs() < 1e-12, "pose {k} after a step: rigid moment {m}");
            }
        }
    }

    #[test]
    fn the_linear_path_is_in_the_gauge_and_a_rotated_pose_is_not() {
        let e = ends();
        let g = RigidGauge::new(&e, 2);
        let mut x = g.poses[0].0.clone();
        let linear = x.clone();
        g.constrain(&mut x);
        assert_eq!(x, linear);
        // A small rotation about z of the middle pose is removed to first order.
        let (s, c) = (0.01f64.sin(), 0.01f64.cos());
        let mut r = linear.clone();
        for v in r.chunks_exact_mut(3) {
            let (a, b) = (v[0], v[1]);
            v[0] = c * a - s * b;
            v[1] = s * a + c * b;
        }
        let off: f64 = r
            .iter()
            .zip(&linear)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        g.constrain(&mut r);
        let left: f64 = r
            .iter()
            .zip(&linear)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(left < 0.02 * off, "left {left} of {off}");
    }
}
