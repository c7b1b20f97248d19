//! Synthetic shapes: template meshes (icosphere, torus, open grid) used by tests, benchmarks
//! and the synthetic benchmark of the paper (section 3).

mod noise;
mod primitives;

pub use noise::{add_noise, noise_sigma, NoiseKind};
pub use primitives::{grid, icosphere, torus};
