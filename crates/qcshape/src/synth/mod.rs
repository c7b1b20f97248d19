//! Synthetic shapes: template meshes (icosphere, torus, open grid) used by tests, benchmarks
//! and the synthetic benchmark of the paper (section 3).

mod primitives;

pub use primitives::{grid, icosphere, torus};
