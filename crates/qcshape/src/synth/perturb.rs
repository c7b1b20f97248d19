//! The robustness benchmark's data: the synthetic deformations under the perturbations real data
//! has (issue "Similarity users can trust on real data"): a random rigid placement of every
//! deformation, vertex noise, a spread of amplitudes and monotone time warps of the pose schedule.
//!
//! Everything is drawn from one seed, deformation by deformation in a fixed order, on separate
//! random streams for the amplitude, time warp, placement and noise, so a scenario is
//! reproducible and switching one perturbation on does not change the draws of the others.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::deformations::{deform, DeformParams, DeformationKind};
use super::noise::{sample, NoiseKind};
use super::shapes::{initial_shape, template, InitialShape};
use super::SynthError;
use crate::align::{rotation_about, Motion};
use crate::dataset::Deformation;
use crate::io::DEGENERATE_REL_TOL;
use crate::mesh::geometry::{bounding_box, mean_edge_length, norm, sub};
use crate::mesh::Shape;

/// Vertex noise: independent Gaussian noise on every coordinate of every pose.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "kind", content = "value")]
pub enum VertexNoise {
    /// No noise.
    None,
    /// The paper's Table 3 (docs/method.md "Noise"): per-coordinate variance `v/100 * lbar^2`, `lbar` the
    /// pose's mean edge length; the value is `v` (percent).
    Variance(f64),
    /// Standard deviation as a fraction of the first pose's bounding-box diagonal (the value;
    /// 0.01 = 1 %), the same for every pose of the deformation.
    Diagonal(f64),
}

/// How every deformation of the benchmark is perturbed.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Perturbation {
    /// Largest rotation of the random rigid placement (degrees; 0 = none): each deformation is
    /// rotated about a uniformly random axis by an angle uniform in `[0, max]`, and translated
    /// by up to `rotation > 0 ? 0.5 : 0` times the shape's size per coordinate.
    pub max_rotation_deg: f64,
    /// Vertex noise.
    pub noise: VertexNoise,
    /// Amplitude spread: each instance's amplitude is `1 + spread * u`, `u` uniform in
    /// `[-1, 1]` (at most [`super::MAX_JITTER`]).
    pub amplitude_spread: f64,
    /// Time warp strength `w` in `[0, 1]`: pose `k` is taken at time `tau(k / (P - 1))` with
    /// `tau(t) = t^g`, `g = 2^(w u)` and `u` uniform in `[-1, 1]` (`g` in `[1/2, 2]` at
    /// `w = 1`): a monotone reparametrization with the same first and last pose.
    pub time_warp: f64,
}

impl Default for Perturbation {
    /// No perturbation, except the benchmark's usual amplitude jitter of 10 %.
    fn default() -> Self {
        Perturbation {
            max_rotation_deg: 0.0,
            noise: VertexNoise::None,
            amplitude_spread: 0.1,
            time_warp: 0.0,
        }
    }
}

/// The robustness benchmark: every shape of `shapes` (on the icosphere of `level`) deformed by
/// every kind of `kinds`, `poses` poses each, perturbed by `p`, drawn from `seed`. Names
/// `"{shape}-{kind}"`, labels the kind's name, grouped by kind.
pub fn perturbed_benchmark(
    level: u32,
    shapes: &[InitialShape],
    kinds: &[DeformationKind],
    poses: usize,
    p: &Perturbation,
    seed: u64,
) -> Result<Vec<Deformation>, SynthError> {
    super::SynthOptions {
        level,
        seed,
        poses,
        jitter: p.amplitude_spread,
    }
    .validate()?;
    if !(0.0..=1.0).contains(&p.time_warp) {
        return Err(SynthError::Jitter(p.time_warp));
    }
    let t = template(level);
    let initial: Vec<Shape> = shapes.iter().map(|s| initial_shape(*s, &t)).collect();
    let stream = |s: u64| {
        let mut r = ChaCha8Rng::seed_from_u64(seed);
        r.set_stream(s);
        r
    };
    let (mut amp_rng, mut warp_rng, mut pose_rng, mut noise_rng) =
        (stream(1), stream(2), stream(3), stream(4));
    let mut out = Vec::with_capacity(shapes.len() * kinds.len());
    for kind in kinds {
        for (shape, init) in shapes.iter().zip(&initial) {
            // Every draw is made whether or not its perturbation is on (fixed streams).
            let amplitude = 1.0 + p.amplitude_spread * amp_rng.random_range(-1.0..=1.0);
            let g = 2f64.powf(p.time_warp * warp_rng.random_range(-1.0..=1.0));
            let axis: [f64; 3] = [0, 1, 2].map(|_| sample(&mut pose_rng, NoiseKind::Gaussian));
            let angle = p.max_rotation_deg.to_radians() * pose_rng.random_range(0.0..=1.0);
            let shift: [f64; 3] = [0, 1, 2].map(|_| pose_rng.random_range(-0.5..=0.5));
            let params = DeformParams::of(init).with_amplitude(amplitude);
            let size = params.frame.size;
            let placement = Motion {
                rotation: rotation_about(axis, angle),
                scale: 1.0,
                translation: if p.max_rotation_deg > 0.0 {
                    shift.map(|c| c * size)
                } else {
                    [0.0; 3]
                },
            };
            let name = format!("{}-{}", shape.name(), kind.name());
            let mut posed = Vec::with_capacity(poses);
            let mut diag = 0.0;
            for k in 0..poses {
                let time = (k as f64 / (poses - 1) as f64).powf(g);
                let clean = if k == 0 {
                    init.positions.clone()
                } else {
                    deform(init, *kind, time, &params)
                };
                if k == 0 {
                    let (lo, hi) = bounding_box(&clean);
                    diag = norm(sub(hi, lo));
                }
                let sigma = match p.noise {
                    VertexNoise::None => 0.0,
                    VertexNoise::Variance(v) => {
                        (v.max(0.0) / 100.0).sqrt() * mean_edge_length(&init.topology, &clean)
                    }
                    VertexNoise::Diagonal(f) => f.max(0.0) * diag,
                };
                let pos: Vec<[f64; 3]> = clean
                    .iter()
                    .map(|x| {
                        let n: [f64; 3] = [0, 1, 2].map(|_| sample(&mut noise_rng, NoiseKind::Gaussian));
                        placement.apply([0, 1, 2].map(|c| x[c] + sigma * n[c]))
                    })
                    .collect();
                let shape = Shape::new_checked(Arc::clone(&init.topology), pos, DEGENERATE_REL_TOL).map_err(
                    |error| SynthError::Degenerate {
                        name: name.clone(),
                        pose: k,
                        error,
                    },
                )?;
                posed.push(shape.positions);
            }
            out.push(Deformation {
                name,
                label: Some(kind.name().to_string()),
                topology: Arc::clone(&init.topology),
                poses: posed,
                paths: Vec::new(),
                warnings: Vec::new(),
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::{best_motion, rms_distance};

    fn set(p: &Perturbation, seed: u64) -> Vec<Deformation> {
        perturbed_benchmark(
            1,
            &InitialShape::all()[..3],
            &DeformationKind::extended(),
            4,
            p,
            seed,
        )
        .unwrap()
    }

    #[test]
    fn seeded_and_deterministic() {
        let p = Perturbation {
            max_rotation_deg: 35.0,
            noise: VertexNoise::Diagonal(0.02),
            amplitude_spread: 0.5,
            time_warp: 1.0,
        };
        let a = set(&p, 7);
        assert_eq!(a.len(), 30);
        let poses = |d: &[Deformation]| d.iter().map(|x| x.poses.clone()).collect::<Vec<_>>();
        assert_eq!(poses(&a), poses(&set(&p, 7)));
        assert_ne!(poses(&a), poses(&set(&p, 8)));
    }

    #[test]
    fn each_perturbation_does_what_it_says() {
        let clean = set(&Perturbation::default(), 1);
        // The placement is a rigid motion of the whole deformation, within the angle.
        let posed = set(
            &Perturbation {
                max_rotation_deg: 35.0,
                ..Default::default()
            },
            1,
        );
        for (c, p) in clean.iter().zip(&posed) {
            let m = best_motion(&c.poses[0], &p.poses[0], &[], false);
            assert!(m.angle() <= 35f64.to_radians() + 1e-9);
            for (a, b) in c.poses.iter().zip(&p.poses) {
                let moved: Vec<[f64; 3]> = a.iter().map(|x| m.apply(*x)).collect();
                assert!(rms_distance(&moved, b) < 1e-9, "{}", c.name);
            }
        }
        // Noise: the residual has the requested standard deviation (2 % of the diagonal).
        let noisy = set(
            &Perturbation {
                noise: VertexNoise::Diagonal(0.02),
                ..Default::default()
            },
            1,
        );
        let (lo, hi) = bounding_box(&clean[0].poses[0]);
        let want = 0.02 * norm(sub(hi, lo));
        let got = rms_distance(&clean[0].poses[2], &noisy[0].poses[2]) / 3f64.sqrt();
        assert!((got / want - 1.0).abs() < 0.15, "{got} vs {want}");
        // The time warp keeps the ends and moves the middle poses.
        let warped = set(
            &Perturbation {
                time_warp: 1.0,
                ..Default::default()
            },
            1,
        );
        let moved = clean
            .iter()
            .zip(&warped)
            .filter(|(c, w)| rms_distance(&c.poses[1], &w.poses[1]) > 1e-6)
            .count();
        assert!(moved >= 25, "{moved}");
        for (c, w) in clean.iter().zip(&warped) {
            assert_eq!(c.poses[0], w.poses[0]);
            assert!(rms_distance(&c.poses[3], &w.poses[3]) < 1e-12);
        }
    }
}
