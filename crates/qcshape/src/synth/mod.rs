//! Synthetic shapes: template meshes (icosphere, torus, open grid) used by tests, benchmarks
//! and the synthetic benchmark of the paper (section 3): six genus-0 initial shapes
//! ([`InitialShape`]) and three tori ([`TorusShape`]) deformed by eight analytic deformations
//! ([`DeformationKind`]), assembled and written by [`genus0_benchmark`], [`genus1_benchmark`]
//! and [`write_benchmark`].

mod benchmark;
mod deformations;
mod noise;
mod perturb;
mod primitives;
mod shapes;

pub use benchmark::{
    genus0_benchmark, genus1_benchmark, write_benchmark, SynthError, SynthOptions, MAX_JITTER, MAX_POSES,
};
pub use deformations::{deform, DeformParams, DeformationKind, Frame};
pub use noise::{add_noise, noise_sigma, NoiseKind};
pub use perturb::{perturbed_benchmark, Perturbation, VertexNoise};
pub use primitives::{bend_along_x, grid, icosphere, torus, tube, twist_along_z, twisted_sphere};
pub use shapes::{initial_shape, template, torus_shape, torus_template, InitialShape, TorusShape, MAX_LEVEL};
