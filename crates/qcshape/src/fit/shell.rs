//! The shell energy of a fitted pose against its rest shape (issue 59): how much the fit
//! stretched and bent the template, without geodesics. With `l_e` an edge's length and
//! `theta_e` an interior edge's dihedral angle ([`crate::metric::dihedral_angles`]), rest
//! values unprimed, fitted primed,
//!
//! `membrane = sum_e a_e (ln(l'_e / l_e))^2`   (`a_e` the edge's share of the rest area: a
//! third of its faces' areas over the total; the area-weighted mean squared log strain)
//!
//! `bending = sum_e w_e (theta'_e - theta_e)^2`   (`w_e = 3 |e|^2 / (A_1 + A_2)` on the rest
//! shape, the discrete shells' weight of Grinspun et al. 2003, also the bending term's)
//!
//! Both are dimensionless and do not change when rest and pose are scaled together; a rigid
//! motion of the pose costs nothing. [`ShellEnergy::total`] adds them with the bending weight
//! [`BENDING`].

use crate::mesh::geometry::{cross, norm, sub};
use crate::mesh::Topology;
use crate::metric::dihedral_angles;

/// Weight of the bending part in [`ShellEnergy::total`] (per unit of membrane part).
pub const BENDING: f64 = 0.01;

/// The two parts of the shell energy (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShellEnergy {
    /// Area-weighted mean squared log strain of the edges.
    pub membrane: f64,
    /// Weighted sum of squared dihedral angle changes.
    pub bending: f64,
}

impl ShellEnergy {
    /// `membrane + BENDING * bending`.
    pub fn total(&self) -> f64 {
        self.membrane + BENDING * self.bending
    }
}

/// The shell energy of `pose` against `rest` (both #V x 3 on `topo`).
pub fn energy(topo: &Topology, rest: &[[f64; 3]], pose: &[[f64; 3]]) -> ShellEnergy {
    let faces = topo.faces();
    let area: Vec<f64> = faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| rest[i as usize]);
            0.5 * norm(cross(sub(b, a), sub(c, a)))
        })
        .collect();
    let total: f64 = area.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    let len = |p: &[[f64; 3]], [i, j]: [u32; 2]| norm(sub(p[i as usize], p[j as usize]));
    let mut membrane = 0.0;
    let mut bending = 0.0;
    let mut hinge_weights = Vec::new();
    for (&e, ef) in topo.edges().iter().zip(topo.edge_faces()) {
        let (l0, l1) = (len(rest, e), len(pose, e));
        let share: f64 = ef
            .iter()
            .filter(|&&f| f != u32::MAX)
            .map(|&f| area[f as usize] / 3.0)
            .sum();
        if l0 > 0.0 && l1 > 0.0 {
            membrane += share / total * (l1 / l0).ln().powi(2);
        }
        if ef.iter().all(|&f| f != u32::MAX) {
            let a = area[ef[0] as usize] + area[ef[1] as usize];
            hinge_weights.push(if a > 0.0 { 3.0 * l0 * l0 / a } else { 0.0 });
        }
    }
    let (t0, t1) = (dihedral_angles(topo, rest), dihedral_angles(topo, pose));
    for ((w, a), b) in hinge_weights.iter().zip(&t0).zip(&t1) {
        let mut d = b - a;
        if d > std::f64::consts::PI {
            d -= 2.0 * std::f64::consts::PI;
        } else if d < -std::f64::consts::PI {
            d += 2.0 * std::f64::consts::PI;
        }
        bending += w * d * d;
    }
    ShellEnergy { membrane, bending }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::icosphere;

    #[test]
    fn rigid_motions_cost_nothing_and_a_scaling_costs_its_log() {
        let s = icosphere(2);
        let topo = &*s.topology;
        let rest: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| [1.5 * p[0], p[1], 0.7 * p[2]])
            .collect();
        let (c, sn) = (0.6f64.cos(), 0.6f64.sin());
        let moved: Vec<[f64; 3]> = rest
            .iter()
            .map(|p| [c * p[0] - sn * p[1] + 3.0, sn * p[0] + c * p[1], p[2] - 1.0])
            .collect();
        let e = energy(topo, &rest, &moved);
        assert!(e.membrane < 1e-20 && e.bending < 1e-18, "{e:?}");
        let scaled: Vec<[f64; 3]> = rest.iter().map(|p| p.map(|v| 2.0 * v)).collect();
        let e = energy(topo, &rest, &scaled);
        assert!(
            (e.membrane - 2f64.ln().powi(2)).abs() < 1e-12 && e.bending < 1e-18,
            "{e:?}"
        );
    }

    #[test]
    fn it_does_not_depend_on_the_unit_and_sees_a_local_bump() {
        let s = icosphere(2);
        let topo = &*s.topology;
        let bumped: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| {
                let k = 1.0 + 0.3 * (-((p[0] - 1.0).powi(2) + p[1] * p[1] + p[2] * p[2]) / 0.1).exp();
                p.map(|v| k * v)
            })
            .collect();
        let e = energy(topo, &s.positions, &bumped);
        assert!(e.membrane > 1e-4 && e.bending > 1e-2, "{e:?}");
        for f in [0.01, 100.0] {
            let r: Vec<[f64; 3]> = s.positions.iter().map(|p| p.map(|v| f * v)).collect();
            let b: Vec<[f64; 3]> = bumped.iter().map(|p| p.map(|v| f * v)).collect();
            let g = energy(topo, &r, &b);
            assert!((g.membrane - e.membrane).abs() < 1e-9 * e.membrane);
            assert!((g.bending - e.bending).abs() < 1e-9 * e.bending);
            assert!((g.total() - e.total()).abs() < 1e-9 * e.total());
        }
    }
}
