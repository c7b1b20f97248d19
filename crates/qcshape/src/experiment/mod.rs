//! The paper's experiments on synthetic and real deformations (section 3), each a library call
//! with a report (CSV, Markdown, figures).
//!
//! - [`classification`]: similarity matrix, kernel k-means, k-means with intrinsic means
//!   (eq. 14) and the scores of eq. 15 (Table 1's classification step);
//! - [`noise`]: noise resistance of the classification (Table 3, eq. 17);
//! - [`interpolation`]: interpolation accuracy (Fig. 4);
//! - [`transfer`]: deformation transfer (Fig. 5);
//! - [`robustness`]: classification under realistic perturbations against baselines;
//! - [`approx`]: the cost and the error of approximate similarity matrices;
//! - [`reproduce`]: all synthetic tables and figures in one report;
//! - [`analysis`]: the whole analysis of one data set (`qcshape run`);
//! - [`provenance`]: the command line, version and machine of a report.

pub mod analysis;
pub mod approx;
pub mod classification;
pub mod interpolation;
pub mod noise;
pub mod provenance;
pub mod reproduce;
pub mod robustness;
pub mod transfer;
