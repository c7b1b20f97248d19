//! The paper's experiments on synthetic and real deformations (section 3), each a library call
//! with a report (CSV, Markdown, figures).

pub mod interpolation;
pub mod robustness;
pub mod transfer;
