//! Low-pass filtering of vertex positions (Taubin's lambda|mu smoothing with the uniform graph
//! Laplacian), used to take vertex noise out of real data before it is compared.
//!
//! The filter depends on the topology only, so it is linear and the same for every pose on one
//! topology: filtering every pose of a deformation filters its displacement fields `M_k - M_0`
//! by the same operator, and it commutes with rigid motions and with Euclidean transfer.
//! Taubin's pair of steps (`lambda = 0.5`, `mu = -0.53`, pass-band frequency about 0.11 of the
//! graph Laplacian's) removes high frequencies without the shrinkage of plain Laplacian
//! smoothing.

use super::Topology;

/// Taubin's positive step.
pub const TAUBIN_LAMBDA: f64 = 0.5;
/// Taubin's negative (inflating) step.
pub const TAUBIN_MU: f64 = -0.53;

/// One umbrella step `p_i += step * (mean of the neighbours of i - p_i)` (uniform weights;
/// isolated vertices stay), from `src` into `dst` (#V x 3 each).
fn umbrella(topo: &Topology, src: &[[f64; 3]], dst: &mut [[f64; 3]], step: f64) {
    for (v, out) in dst.iter_mut().enumerate() {
        let nb = topo.neighbors(v);
        let p = src[v];
        if nb.is_empty() {
            *out = p;
            continue;
        }
        // The neighbours' mean summed as `q / n` (the arithmetic lv::meshing's meshes were made with).
        let n = nb.len() as f64;
        let mut m = [0.0; 3];
        for &u in nb {
            let q = src[u as usize];
            for c in 0..3 {
                m[c] += q[c] / n;
            }
        }
        for c in 0..3 {
            out[c] = p[c] + step * (m[c] - p[c]);
        }
    }
}

/// `iterations` Taubin lambda|mu iterations (each a [`TAUBIN_LAMBDA`] step then a
/// [`TAUBIN_MU`] step of the uniform Laplacian) of the positions `pos` (#V x 3, any unit) on
/// `topo`; returns the filtered positions (`pos` itself for 0 iterations). Deterministic
/// (no reductions across threads).
pub fn taubin(topo: &Topology, pos: &[[f64; 3]], iterations: usize) -> Vec<[f64; 3]> {
    let mut a = pos.to_vec();
    let mut b = pos.to_vec();
    for _ in 0..iterations {
        umbrella(topo, &a, &mut b, TAUBIN_LAMBDA);
        umbrella(topo, &b, &mut a, TAUBIN_MU);
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::{angle_defect, mean_edge_length, norm};
    use crate::synth::{add_noise, icosphere, NoiseKind};

    #[test]
    fn removes_noise_keeps_the_shape_and_is_linear() {
        let s = icosphere(3);
        let t = &s.topology;
        let clean = &s.positions;
        let noisy = add_noise(t, std::slice::from_ref(clean), NoiseKind::Gaussian, 10.0, 5).remove(0);
        let rms = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            (a.iter()
                .zip(b)
                .map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>())
                .sum::<f64>()
                / a.len() as f64)
                .sqrt()
        };
        let smoothed = taubin(t, &noisy, 10);
        let before = rms(&noisy, clean);
        let after = rms(&smoothed, clean);
        assert!(after < 0.45 * before, "{before} -> {after}");
        // Little shrinkage: the mean radius stays within 1 %.
        let radius = smoothed.iter().map(|p| norm(*p)).sum::<f64>() / smoothed.len() as f64;
        assert!((radius - 1.0).abs() < 0.01, "{radius}");
        // The curvature (angle defect) noise falls by more than half (rms over the vertices).
        let k0 = angle_defect(t, clean);
        let err = |p: &[[f64; 3]]| {
            let s: f64 = angle_defect(t, p)
                .iter()
                .zip(&k0)
                .map(|(a, b)| (a - b).powi(2))
                .sum();
            (s / k0.len() as f64).sqrt()
        };
        assert!(
            err(&smoothed) < 0.5 * err(&noisy),
            "{} -> {}",
            err(&noisy),
            err(&smoothed)
        );
        // Linear: filtering a sum is the sum of the filtered.
        let twice: Vec<[f64; 3]> = noisy
            .iter()
            .zip(clean)
            .map(|(a, b)| [0, 1, 2].map(|c| a[c] + 2.0 * b[c]))
            .collect();
        let lhs = taubin(t, &twice, 10);
        let fc = taubin(t, clean, 10);
        for ((l, a), b) in lhs.iter().zip(&smoothed).zip(&fc) {
            for c in 0..3 {
                assert!((l[c] - a[c] - 2.0 * b[c]).abs() < 1e-12);
            }
        }
        assert_eq!(taubin(t, &noisy, 0), noisy);
        assert!(mean_edge_length(t, &smoothed) > 0.0);
    }
}
