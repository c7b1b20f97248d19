//! The paper's experiments on synthetic and real deformations (section 3), each with its report.

pub mod interpolation;
