//! Additive vertex noise for the noise-resistance experiment (paper section 3.5, Table 3,
//! eq. 17; docs/method.md "Noise").

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::mesh::{geometry, Topology};

/// The distribution of the noise. Both have the same per-coordinate variance.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseKind {
    /// Normal with mean 0 and variance `sigma^2`.
    Gaussian,
    /// Uniform on `[-a, a]` with `a = sqrt(3) sigma` (variance `sigma^2`).
    Uniform,
}

impl NoiseKind {
    /// `"gaussian"` or `"uniform"`.
    pub fn name(&self) -> &'static str {
        match self {
            NoiseKind::Gaussian => "gaussian",
            NoiseKind::Uniform => "uniform",
        }
    }
}

impl std::str::FromStr for NoiseKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "gaussian" | "normal" => Ok(NoiseKind::Gaussian),
            "uniform" => Ok(NoiseKind::Uniform),
            _ => Err(format!("unknown noise '{s}' (expected gaussian or uniform)")),
        }
    }
}

/// Standard deviation of the noise for a pose: `sigma^2 = level/100 * lbar^2`, where `level`
/// is the variance in percent (Table 3: 1, 2.5, 5, 10, 20) and `lbar` the pose's mean edge
/// length (same unit as the positions).
pub fn noise_sigma(topo: &Topology, pose: &[[f64; 3]], level_percent: f64) -> f64 {
    let lbar = geometry::mean_edge_length(topo, pose);
    (level_percent.max(0.0) / 100.0).sqrt() * lbar
}

/// Adds independent noise of the given kind to every coordinate of every pose (each #V x 3)
/// of a deformation, with per-pose `sigma` from [`noise_sigma`]. Deterministic in `seed`.
pub fn add_noise(
    topo: &Topology,
    poses: &[Vec<[f64; 3]>],
    kind: NoiseKind,
    level_percent: f64,
    seed: u64,
) -> Vec<Vec<[f64; 3]>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    poses
        .iter()
        .map(|pose| {
            let sigma = noise_sigma(topo, pose, level_percent);
            pose.iter()
                .map(|p| p.map(|c| c + sigma * sample(&mut rng, kind)))
                .collect()
        })
        .collect()
}

/// One draw with mean 0 and variance 1.
pub(crate) fn sample(rng: &mut ChaCha8Rng, kind: NoiseKind) -> f64 {
    match kind {
        NoiseKind::Uniform => 3f64.sqrt() * (2.0 * rng.random::<f64>() - 1.0),
        NoiseKind::Gaussian => {
            // Box-Muller; u1 in (0, 1] keeps the logarithm finite.
            let u1 = 1.0 - rng.random::<f64>();
            let u2 = rng.random::<f64>();
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::icosphere;

    #[test]
    fn variance_matches_the_level_for_both_kinds() {
        let s = icosphere(3);
        let lbar = geometry::mean_edge_length(&s.topology, &s.positions);
        let poses = vec![s.positions.clone(); 4];
        for kind in [NoiseKind::Gaussian, NoiseKind::Uniform] {
            let noisy = add_noise(&s.topology, &poses, kind, 10.0, 3);
            let (mut sum, mut sum2, mut max, mut n) = (0.0, 0.0, 0.0f64, 0.0);
            for (a, b) in noisy.iter().flatten().zip(poses.iter().flatten()) {
                for c in 0..3 {
                    let d = (a[c] - b[c]) / lbar;
                    sum += d;
                    sum2 += d * d;
                    max = max.max(d.abs());
                    n += 1.0;
                }
            }
            let mean = sum / n;
            let var = sum2 / n - mean * mean;
            // 7,704 draws: the sample variance is within a few percent of 0.1.
            assert!((var - 0.1).abs() < 0.01, "{kind:?}: variance {var}");
            assert!(mean.abs() < 0.02, "{kind:?}: mean {mean}");
            let bound = 3f64.sqrt() * 0.1f64.sqrt();
            match kind {
                NoiseKind::Uniform => assert!(max <= bound + 1e-12),
                NoiseKind::Gaussian => assert!(max > bound, "Gaussian tails exceed the uniform bound"),
            }
        }
    }

    #[test]
    fn seeded_and_zero_level_is_identity() {
        let s = icosphere(1);
        let poses = vec![s.positions.clone()];
        let a = add_noise(&s.topology, &poses, NoiseKind::Gaussian, 5.0, 9);
        assert_eq!(a, add_noise(&s.topology, &poses, NoiseKind::Gaussian, 5.0, 9));
        assert_ne!(a, add_noise(&s.topology, &poses, NoiseKind::Gaussian, 5.0, 10));
        assert_eq!(add_noise(&s.topology, &poses, NoiseKind::Uniform, 0.0, 9), poses);
        assert!("cauchy".parse::<NoiseKind>().is_err());
    }
}
