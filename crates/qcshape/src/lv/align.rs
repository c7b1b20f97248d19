//! Rigid alignment of a cohort's deformations to a common base before transfer: each
//! subject's frame 0 is fitted to the base subject's frame 0 (same vertices, equal weights) by
//! Horn's closed-form quaternion method (B. K. P. Horn, "Closed-form solution of absolute
//! orientation using unit quaternions", J. Opt. Soc. Am. A 4:629-642, 1987), and the same
//! rotation and translation move all of the subject's frames. Its motion over the cycle is
//! then expressed in the base's frame, so that a subject's pose in the scanner (the phantom's
//! random spin about the long axis, a patient's position) is not read as a difference of
//! motion.

use faer::{Mat, Side};
use serde::Serialize;

use super::analysis::Pose;
use crate::dataset::Deformation;

/// How deformations are aligned to the base before transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Align {
    /// Not at all (the paper).
    None,
    /// A rigid motion per subject, fitted on frame 0 (module docs).
    Rigid,
}

impl Align {
    /// `none` or `rigid`.
    pub fn name(self) -> &'static str {
        match self {
            Align::None => "none",
            Align::Rigid => "rigid",
        }
    }
}

/// A rigid motion `x -> R x + t` (R 3 x 3 rotation, row-major; t in input units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RigidMotion {
    /// The rotation.
    pub rotation: [[f64; 3]; 3],
    /// The translation.
    pub translation: [f64; 3],
}

impl RigidMotion {
    /// The identity.
    pub const IDENTITY: RigidMotion = RigidMotion {
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [0.0; 3],
    };

    /// `R p + t`.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        std::array::from_fn(|i| r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + self.translation[i])
    }

    /// The rotation angle (degrees).
    pub fn angle_deg(&self) -> f64 {
        let r = &self.rotation;
        (((r[0][0] + r[1][1] + r[2][2]) - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
    }
}

fn centroid(p: &[[f64; 3]]) -> [f64; 3] {
    let n = p.len().max(1) as f64;
    let mut c = [0.0; 3];
    for q in p {
        for k in 0..3 {
            c[k] += q[k] / n;
        }
    }
    c
}

/// The rigid motion minimizing `sum_i |R a_i + t - b_i|^2` over corresponding points
/// (#V x 3 each, #V >= 3 not all collinear for a unique answer; the identity for fewer than
/// one point). Horn's method: the leading eigenvector of a 4 x 4 symmetric matrix is the
/// rotation's unit quaternion.
pub fn fit_rigid(a: &[[f64; 3]], b: &[[f64; 3]]) -> RigidMotion {
    if a.is_empty() || a.len() != b.len() {
        return RigidMotion::IDENTITY;
    }
    let (ca, cb) = (centroid(a), centroid(b));
    let mut s = [[0.0; 3]; 3];
    for (p, q) in a.iter().zip(b) {
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] += (p[i] - ca[i]) * (q[j] - cb[j]);
            }
        }
    }
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = s;
    let n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let m = Mat::<f64>::from_fn(4, 4, |i, j| n[i][j]);
    let Ok(evd) = m.self_adjoint_eigen(Side::Lower) else {
        return RigidMotion::IDENTITY;
    };
    let u = evd.U();
    // Eigenvalues in nondecreasing order: the last column is the leading one.
    let (w, x, y, z) = (u[(0, 3)], u[(1, 3)], u[(2, 3)], u[(3, 3)]);
    let rotation = [
        [w * w + x * x - y * y - z * z, 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), w * w - x * x + y * y - z * z, 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z],
    ];
    let rc = RigidMotion {
        rotation,
        translation: [0.0; 3],
    }
    .apply(ca);
    RigidMotion {
        rotation,
        translation: std::array::from_fn(|k| cb[k] - rc[k]),
    }
}

/// Aligns every deformation to `defs[base]` (module docs; `Align::None` changes nothing).
/// Returns the motion applied to each (the identity for the base). All deformations must
/// have the same vertex count (one connectivity).
pub fn align_to_base(defs: &mut [Deformation], base: usize, align: Align) -> Vec<RigidMotion> {
    if align == Align::None || base >= defs.len() {
        return vec![RigidMotion::IDENTITY; defs.len()];
    }
    let target: Pose = defs[base].poses[0].clone();
    defs.iter_mut()
        .enumerate()
        .map(|(i, d)| {
            if i == base || d.poses.is_empty() {
                return RigidMotion::IDENTITY;
            }
            let m = fit_rigid(&d.poses[0], &target);
            for p in &mut d.poses {
                for v in p.iter_mut() {
                    *v = m.apply(*v);
                }
            }
            m
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let [x, y, z] = axis.map(|c| c / n);
        let (s, c) = angle.sin_cos();
        let t = 1.0 - c;
        [
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ]
    }

    #[test]
    fn a_known_motion_is_recovered() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let a: Vec<[f64; 3]> = (0..40)
            .map(|_| std::array::from_fn(|_| rng.random::<f64>() * 50.0 - 25.0))
            .collect();
        for (axis, angle) in [([0.3, -1.0, 0.4], 2.8), ([0.0, 0.0, 1.0], 0.5), ([1.0, 1.0, 0.0], 3.1)] {
            let truth = RigidMotion {
                rotation: rotation(axis, angle),
                translation: [4.0, -7.0, 2.5],
            };
            let b: Vec<[f64; 3]> = a.iter().map(|&p| truth.apply(p)).collect();
            let m = fit_rigid(&a, &b);
            for i in 0..3 {
                for j in 0..3 {
                    assert!((m.rotation[i][j] - truth.rotation[i][j]).abs() < 1e-9, "{axis:?} {angle}");
                }
                assert!((m.translation[i] - truth.translation[i]).abs() < 1e-8);
            }
            assert!((m.angle_deg() - angle.to_degrees()).abs() < 1e-6);
        }
    }

    #[test]
    fn aligned_cohorts_do_not_depend_on_each_subjects_pose() {
        use crate::mesh::Topology;
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let faces = vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]];
        let topo = Topology::new(4, faces).unwrap();
        let tet = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]];
        let poses = |s: f64| -> Vec<Pose> {
            (0..3)
                .map(|k| tet.iter().map(|p| p.map(|c| c * (1.0 + s * k as f64))).collect())
                .collect()
        };
        let def = |name: &str, p: Vec<Pose>| Deformation {
            name: name.into(),
            label: None,
            topology: topo.clone(),
            poses: p,
            paths: Vec::new(),
            warnings: Vec::new(),
        };
        let clean = vec![def("a", poses(0.1)), def("b", poses(0.2))];
        let moved = RigidMotion {
            rotation: rotation([rng.random(), rng.random(), 1.0], 1.0),
            translation: [10.0, 0.0, -3.0],
        };
        let mut posed = clean.clone();
        for p in &mut posed[1].poses {
            p.iter_mut().for_each(|v| *v = moved.apply(*v));
        }
        let motions = align_to_base(&mut posed, 0, Align::Rigid);
        assert!((motions[1].angle_deg() - 1.0f64.to_degrees()).abs() < 1e-6);
        for (p, q) in posed[1].poses.iter().zip(&clean[1].poses) {
            for (u, v) in p.iter().zip(q) {
                for k in 0..3 {
                    assert!((u[k] - v[k]).abs() < 1e-9);
                }
            }
        }
        // Without alignment the pose stays.
        let mut unaligned = clean.clone();
        unaligned[1].poses[0][1][0] += 1.0;
        let before = unaligned.clone();
        align_to_base(&mut unaligned, 0, Align::None);
        assert_eq!(unaligned[1].poses, before[1].poses);
    }
}
