//! The default settings, defined once: the library's option structs
//! ([`crate::geodesic::GeodesicOptions`], [`crate::geodesic::InterpolationOptions`],
//! [`crate::metric::MetricSpec::new`], [`crate::similarity::PipelineOptions`], the experiments)
//! and every `qcshape` command's `--help` take their defaults from here, so that the same
//! option means the same method in every command. The values that belong to one module are
//! defined there (`metric::defaults`, `geodesic::defaults`, `transport::defaults`,
//! `similarity::defaults`; a module never imports this index, which sits above them all) and
//! re-exported here.
//!
//! The values are the ones docs/defaults.md "How the defaults were chosen" measured; a study
//! command that keeps a different value (the paper's N = 4 for the reproduction, the noise
//! experiment's settings, the LV pipeline's) does so through one of the named exceptions of the
//! studies crate (`qcshape_studies::defaults`), each with the reason, and says so in its
//! `--help`.

pub use crate::geodesic::defaults::{
    ENERGY_TOLERANCE, LENGTH_TOLERANCE, LEVELS, PAPER_INSERT, SOLVER, STEPS, TOLERANCE,
};
pub use crate::metric::defaults::{LAMBDA, METRIC, QC_NORMALIZE, RAW_LAMBDA, SCALE, STRETCH};
pub use crate::similarity::defaults::{INSERT, SMOOTH, SMOOTH_LENGTH};
pub use crate::transport::defaults::{ALIGN, TRANSPORT};

/// Seeded clustering runs (kernel k-means restarts; the best starts the intrinsic k-means).
pub const RESTARTS: usize = 20;

/// Seed of every random choice (data, clustering, noise, MDS jitter).
pub const SEED: u64 = 0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::{GeodesicOptions, InterpolationOptions};
    use crate::similarity::PipelineOptions;

    #[test]
    fn the_library_defaults_are_these_constants() {
        let g = GeodesicOptions::default();
        assert_eq!(g.steps, STEPS);
        assert_eq!(g.solver, SOLVER);
        assert_eq!(g.gradient_tolerance, TOLERANCE);
        assert_eq!(g.energy_tolerance, ENERGY_TOLERANCE);
        assert_eq!(g.length_tolerance, LENGTH_TOLERANCE);
        let i = InterpolationOptions::default();
        assert_eq!((i.insert, i.levels), (PAPER_INSERT, LEVELS));
        // PipelineOptions is defined in the similarity module; its Default must agree.
        let p = PipelineOptions::default();
        assert_eq!(p.metric.kind, METRIC);
        assert_eq!(p.metric.lambda, LAMBDA);
        assert_eq!(p.geodesic.steps, STEPS);
        assert_eq!(p.insert, INSERT);
        assert_eq!(p.levels, LEVELS);
        assert_eq!(p.transport, TRANSPORT);
        assert_eq!(p.align, ALIGN);
        assert_eq!(p.smoothing, crate::mesh::smooth::Smoothing::Length(SMOOTH_LENGTH));
        assert_eq!(crate::metric::MetricSpec::new(METRIC).lambda, LAMBDA);
    }
}
