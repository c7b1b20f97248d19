//! Rigid (or similarity) alignment of a deformation to the common base before it is transferred
//! (issue "Similarity users can trust on real data"; not in the paper, which assumes every
//! deformation is already posed like the base).
//!
//! Each deformation `M_0 .. M_K` (poses #V x 3) is moved by the one motion `x -> s R x + t` that
//! best aligns its first pose `M_0` onto the base `N_0` in area-weighted least squares
//! (weighted Procrustes; the rotation from Horn's unit-quaternion method), and the same motion
//! is applied to every pose. The deformation's own motion is kept; only its placement in space
//! (scanner pose) is removed, so that a transfer carries displacements expressed in the base's
//! frame: Euclidean transfer then adds `s R (M_k - M_0)` to the base.

use crate::mesh::geometry::{add, cross, dot, norm, scale, sub, vertex_areas};
use crate::mesh::Topology;

/// What [`align_deformation`] removes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Alignment {
    /// Rotation and translation (the default).
    #[default]
    Rigid,
    /// Rotation, translation and a uniform scale (the deformation is then compared at the
    /// base's size: its displacements are scaled too).
    Similarity,
    /// No alignment (the paper's pipeline).
    None,
}

impl Alignment {
    /// `"rigid"`, `"similarity"` or `"none"`.
    pub fn label(self) -> &'static str {
        match self {
            Alignment::Rigid => "rigid",
            Alignment::Similarity => "similarity",
            Alignment::None => "none",
        }
    }
}

impl std::str::FromStr for Alignment {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rigid" => Ok(Alignment::Rigid),
            "similarity" => Ok(Alignment::Similarity),
            "none" => Ok(Alignment::None),
            _ => Err(format!(
                "unknown alignment '{s}' (expected rigid, similarity or none)"
            )),
        }
    }
}

/// A motion `x -> scale * R x + translation` (R a rotation, row-major 3 x 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// The rotation (row-major; `R x` is `[dot(R[0], x), dot(R[1], x), dot(R[2], x)]`).
    pub rotation: [[f64; 3]; 3],
    /// The uniform scale (1 for a rigid motion).
    pub scale: f64,
    /// The translation (input units).
    pub translation: [f64; 3],
}

impl Motion {
    /// The identity motion.
    pub const IDENTITY: Motion = Motion {
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        scale: 1.0,
        translation: [0.0; 3],
    };

    /// The image of a point.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        add(
            scale(self.rotation.map(|r| dot(r, p)), self.scale),
            self.translation,
        )
    }

    /// The rotation angle (radians, in `[0, pi]`).
    pub fn angle(&self) -> f64 {
        let r = &self.rotation;
        ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
    }
}

/// The motion (rigid, or similarity with `with_scale`) that best maps `from` onto `to` (both
/// #V x 3, corresponding vertex by vertex) in the weighted least-squares sense
/// `sum_i w_i |s R from_i + t - to_i|^2` (`w` #V non-negative weights; equal weights if their
/// sum is not positive). Horn's method: `R` from the leading eigenvector of a 4 x 4 symmetric
/// matrix built from the weighted cross-covariance; `s = sum w <R u, v> / sum w |u|^2` on the
/// centred points. Returns the identity rotation if the eigensolver fails (degenerate input)
/// or the points are all equal.
pub fn best_motion(from: &[[f64; 3]], to: &[[f64; 3]], weights: &[f64], with_scale: bool) -> Motion {
    let n = from.len().min(to.len());
    let total: f64 = weights
        .iter()
        .take(n)
        .filter(|w| w.is_finite() && **w > 0.0)
        .sum();
    let w = |i: usize| -> f64 {
        if total > 0.0 {
            let x = weights.get(i).copied().unwrap_or(0.0);
            if x.is_finite() && x > 0.0 {
                x / total
            } else {
                0.0
            }
        } else {
            1.0 / n.max(1) as f64
        }
    };
    let mut ca = [0.0; 3];
    let mut cb = [0.0; 3];
    for i in 0..n {
        ca = add(ca, scale(from[i], w(i)));
        cb = add(cb, scale(to[i], w(i)));
    }
    let mut m = [[0.0; 3]; 3];
    let mut su = 0.0;
    for i in 0..n {
        let (u, v) = (sub(from[i], ca), sub(to[i], cb));
        su += w(i) * dot(u, u);
        for (a, row) in m.iter_mut().enumerate() {
            for (b, x) in row.iter_mut().enumerate() {
                *x += w(i) * u[a] * v[b];
            }
        }
    }
    let rotation = horn_rotation(&m).unwrap_or(Motion::IDENTITY.rotation);
    let s = if with_scale && su > 0.0 {
        let mut num = 0.0;
        for i in 0..n {
            let ru = rotation.map(|r| dot(r, sub(from[i], ca)));
            num += w(i) * dot(ru, sub(to[i], cb));
        }
        let s = num / su;
        if s.is_finite() && s > 0.0 {
            s
        } else {
            1.0
        }
    } else {
        1.0
    };
    let rca = scale(rotation.map(|r| dot(r, ca)), s);
    Motion {
        rotation,
        scale: s,
        translation: sub(cb, rca),
    }
}

/// Horn's closed form: the rotation maximizing `sum <R u_i, v_i>` from the cross-covariance
/// `m[a][b] = sum u_a v_b`, as the unit quaternion of the largest eigenvalue of Horn's 4 x 4
/// matrix. `None` if the eigensolver fails or the result is not finite.
pub(crate) fn horn_rotation(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = *m;
    let k = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let evd = faer::Mat::<f64>::from_fn(4, 4, |i, j| k[i][j])
        .self_adjoint_eigen(faer::Side::Lower)
        .ok()?;
    // Eigenvalues come in nondecreasing order: the last is the largest.
    let u = evd.U();
    let q = [0, 1, 2, 3].map(|i| u[(i, 3)]);
    let len = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    if !(len.is_finite() && len > 0.0) {
        return None;
    }
    let [w, x, y, z] = q.map(|c| c / len);
    let r = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    // A proper rotation: det = +1 (Horn's quaternion always gives one; checked for rounding).
    let det = dot(r[0], cross(r[1], r[2]));
    (r.iter().flatten().all(|c| c.is_finite()) && (det - 1.0).abs() < 1e-6).then_some(r)
}

/// Aligns a deformation (`poses`, each #V x 3 on `topo`) to `base` (#V x 3): the motion of
/// [`best_motion`] from the first pose onto the base, weighted by the base's vertex areas
/// (one third of the adjacent triangles' areas), applied to every pose. Returns the moved
/// poses and the motion; [`Alignment::None`] returns the poses unchanged with the identity.
pub fn align_deformation(
    topo: &Topology,
    poses: &[Vec<[f64; 3]>],
    base: &[[f64; 3]],
    alignment: Alignment,
) -> (Vec<Vec<[f64; 3]>>, Motion) {
    let Some(first) = poses.first() else {
        return (Vec::new(), Motion::IDENTITY);
    };
    if alignment == Alignment::None {
        return (poses.to_vec(), Motion::IDENTITY);
    }
    let weights = vertex_areas(topo, base);
    let motion = best_motion(first, base, &weights, alignment == Alignment::Similarity);
    let moved = poses
        .iter()
        .map(|p| p.iter().map(|x| motion.apply(*x)).collect())
        .collect();
    (moved, motion)
}

/// Root mean square of `|a_i - b_i|` (#V points each; input units).
pub fn rms_distance(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let n = a.len().min(b.len()).max(1) as f64;
    (a.iter()
        .zip(b)
        .map(|(p, q)| norm(sub(*p, *q)).powi(2))
        .sum::<f64>()
        / n)
        .sqrt()
}

/// The rotation about the unit axis `axis` by `angle` radians (Rodrigues; row-major).
pub fn rotation_about(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let l = norm(axis);
    let [x, y, z] = if l > 0.0 {
        scale(axis, 1.0 / l)
    } else {
        [0.0, 0.0, 1.0]
    };
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::icosphere;

    fn moved(p: &[[f64; 3]], m: &Motion) -> Vec<[f64; 3]> {
        p.iter().map(|x| m.apply(*x)).collect()
    }

    #[test]
    fn recovers_a_known_motion_exactly() {
        let s = icosphere(2);
        // A non-symmetric shape (stretched, shifted) so the motion is unique.
        let pts: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| [1.7 * p[0] + 0.3, p[1], 0.6 * p[2] + p[0] * p[0]])
            .collect();
        for with_scale in [false, true] {
            let truth = Motion {
                rotation: rotation_about([0.3, -1.0, 0.5], 2.4),
                scale: if with_scale { 1.8 } else { 1.0 },
                translation: [5.0, -2.0, 0.25],
            };
            let target = moved(&pts, &truth);
            let w = vertex_areas(&s.topology, &target);
            let m = best_motion(&pts, &target, &w, with_scale);
            assert!(rms_distance(&moved(&pts, &m), &target) < 1e-10, "{m:?}");
            assert!((m.scale - truth.scale).abs() < 1e-10);
            assert!((m.angle() - 2.4).abs() < 1e-9, "{}", m.angle());
        }
    }

    #[test]
    fn alignment_removes_the_placement_and_keeps_the_motion() {
        let s = icosphere(1);
        let p0: Vec<[f64; 3]> = s.positions.iter().map(|p| [2.0 * p[0], p[1], p[2]]).collect();
        let p1: Vec<[f64; 3]> = p0.iter().map(|p| [p[0], p[1] + 0.2 * p[2], 1.1 * p[2]]).collect();
        let pose = Motion {
            rotation: rotation_about([1.0, 1.0, 0.0], 0.6),
            scale: 1.0,
            translation: [1.0, 2.0, 3.0],
        };
        let posed = vec![moved(&p0, &pose), moved(&p1, &pose)];
        let (aligned, m) = align_deformation(&s.topology, &posed, &p0, Alignment::Rigid);
        assert!((m.angle() - 0.6).abs() < 1e-9);
        assert!(rms_distance(&aligned[0], &p0) < 1e-10);
        assert!(rms_distance(&aligned[1], &p1) < 1e-10);
        let (same, id) = align_deformation(&s.topology, &posed, &p0, Alignment::None);
        assert_eq!(same, posed);
        assert_eq!(id, Motion::IDENTITY);
    }

    #[test]
    fn names_round_trip() {
        for a in [Alignment::Rigid, Alignment::Similarity, Alignment::None] {
            assert_eq!(a.label().parse::<Alignment>().unwrap(), a);
        }
        assert!("affine".parse::<Alignment>().unwrap_err().contains("rigid"));
    }
}
