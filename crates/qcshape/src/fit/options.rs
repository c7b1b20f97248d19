//! The settings of a fit ([`FitOptions`]) and its deformation prior ([`Prior`]).

use super::error::FitError;
use crate::align::Alignment;
use crate::limits::{MAX_SWEEPS, MAX_VERTICES};

/// The deformation prior of the non-rigid fit ([`affine`](super::affine),
/// [`nonrigid`](super::nonrigid), [`local`](super::local)): how the fit charges the template's
/// deformation, which decides where vertices go along the surface where the data leave them free.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Prior {
    /// Smooth local affine maps near each vertex fan's best similarity (the default): smooth
    /// deformations of the whole shape cost little and local strain is charged. Better than
    /// [`Prior::Affine`] on tapers, bulges and dents and on the distances measured after a fit
    /// (docs/fit.md), worse on stretches and shears.
    #[default]
    Smooth,
    /// One affine map per vertex with Amberg et al.'s stiffness (differences of neighbouring
    /// maps), annealed from one map for the whole template to edge-scale detail ([`affine`](super::affine)):
    /// the gross deformation is found first, globally, then the detail. Lowest mean error on
    /// the issue-59 benchmark (stretch and shear recovered), but it slides tapers and bulges
    /// along their axis and changes the distances measured afterwards more (docs/fit.md).
    Affine,
    /// As-rigid-as-possible with uniform edge weights: every edge strain is charged, the
    /// discrete analogue of the library's isometric metric.
    Arap,
    /// As-similar-as-possible: ARAP with a free local scale per vertex fan (in `[0.5, 2]`).
    Asap,
}

impl Prior {
    /// `"smooth"`, `"arap"` or `"asap"`.
    pub fn label(self) -> &'static str {
        match self {
            Prior::Smooth => "smooth",
            Prior::Arap => "arap",
            Prior::Asap => "asap",
            Prior::Affine => "affine",
        }
    }
}

impl Prior {
    /// The prior's default stiffness at the first and the last stage, chosen on the
    /// ground-truth fixtures (docs/fit.md): 2 to 0.3 for the edge-vector priors (for ARAP as
    /// good as the earlier 20 to 0.1); for [`Prior::Affine`] 1 to 1, the first multiplied by
    /// the template's vertex count (one affine map for the whole template first, edge-scale
    /// detail last).
    pub fn stiffness(self) -> (f64, f64) {
        match self {
            Prior::Affine => (AFFINE_STIFFNESS.0, AFFINE_STIFFNESS.1),
            _ => (2.0, 0.3),
        }
    }
}

/// [`Prior::Affine`]'s default stiffness ends (see [`Prior::stiffness`]).
pub const AFFINE_STIFFNESS: (f64, f64) = (1.0, 1.0);

impl std::str::FromStr for Prior {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "smooth" => Ok(Prior::Smooth),
            "arap" => Ok(Prior::Arap),
            "asap" => Ok(Prior::Asap),
            "affine" => Ok(Prior::Affine),
            _ => Err(format!(
                "unknown prior '{s}' (expected affine, smooth, arap or asap)"
            )),
        }
    }
}

/// Settings of a fit. [`FitOptions::default`] is what `qcshape fit` and `qs.fit` use.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Initial alignment: similarity (default; the template is scaled to the target), rigid, or
    /// none (the template is already placed on the target).
    pub alignment: Alignment,
    /// The deformation prior (default [`Prior::Smooth`]).
    pub prior: Prior,
    /// Stiffness stages of the non-rigid fit (1-1,000; default 6).
    pub stages: usize,
    /// Iterations (closest points, weights, rotations, one solve) per stage at most (1-1,000;
    /// default 12).
    pub iterations: usize,
    /// Stiffness of the prior at the first stage, relative to the data term; `None` (the
    /// default) is the prior's own ([`Prior::stiffness`]). For [`Prior::Affine`] it is
    /// multiplied by the template's vertex count (see [`affine`](super::affine)).
    pub stiffness_start: Option<f64>,
    /// Stiffness at the last stage (`None`: the prior's own); stages in between are
    /// geometric.
    pub stiffness_end: Option<f64>,
    /// Weight of each landmark ([`fit_with_landmarks`](super::fit_with_landmarks)) relative to one
    /// vertex's data term, at the first stage (default 10; it falls with the stiffness to a tenth).
    pub landmark_weight: f64,
    /// Weight of the surface-to-point term relative to the point-to-surface term, in total
    /// (default 2; 0 turns it off).
    pub surface_to_point: f64,
    /// Target points used as surface-to-point samples at most (default 1,000; an even stride
    /// over the target's vertices), raised to twice the template's vertex count when that is
    /// larger, so that every template triangle is pulled. Measured with the 162-vertex
    /// template of docs/fit.md at 2,562 to 40,962 target vertices: 1,000 samples fit as well
    /// as 3,000 (mean median error 0.254 against 0.254 at 10,242) in two thirds of the time.
    pub max_samples: usize,
    /// Correspondences farther than this many template edge lengths (and farther than 3 times
    /// the median) are rejected as outliers (default 2).
    pub outlier_distance: f64,
    /// Correspondences whose normals differ by more than this angle (degrees) are rejected
    /// (default 70; surfaces only).
    pub normal_angle: f64,
    /// Pull along the normal only (point-to-plane): each closest target point is replaced by
    /// the foot of the vertex on the target's tangent plane there (and each surface-to-point
    /// sample by its foot on the template's tangent plane), so the data do not drag vertices
    /// along the surface and the prior alone places them there. Surfaces only.
    pub point_to_plane: bool,
    /// [`Prior::Affine`] only: weight of the isometric term `sum_i |A_i - R_i|_F^2` (`A_i` the
    /// linear part of vertex `i`'s affine map, `R_i` its nearest rotation, updated at every
    /// iteration) relative to one vertex's data term (0 turns it off): rigid local motion is
    /// free, local stretch and shear cost it.
    pub isometric: f64,
    /// Degree of a polynomial warp of space fitted before the non-rigid stages (module
    /// `fit::polynomial`; 0 = none, the default; at most [`MAX_GLOBAL_DEGREE`]). Degree 2
    /// follows global motions of closed surfaces (taper, bend, swing, stretch) far better than
    /// the stages alone, spreads a local one (dent, bulge, ripple) over the whole shape, and
    /// made the tracked LV phantom cohort worse (docs/fit.md "Global polynomial warp").
    pub global_degree: usize,
}

/// Largest [`FitOptions::global_degree`] accepted (56 monomials per coordinate).
pub const MAX_GLOBAL_DEGREE: usize = 5;

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            alignment: Alignment::Similarity,
            prior: Prior::Smooth,
            stages: 6,
            iterations: 12,
            stiffness_start: None,
            stiffness_end: None,
            landmark_weight: 10.0,
            surface_to_point: 2.0,
            max_samples: 1_000,
            outlier_distance: 2.0,
            normal_angle: 70.0,
            point_to_plane: false,
            isometric: 0.0,
            global_degree: 0,
        }
    }
}

impl FitOptions {
    /// The stiffness schedule's ends (first, last stage): the options, or the prior's own.
    pub fn stiffness(&self) -> (f64, f64) {
        let (a, b) = self.prior.stiffness();
        (self.stiffness_start.unwrap_or(a), self.stiffness_end.unwrap_or(b))
    }

    /// Errors on the first option out of range.
    pub fn check(&self) -> Result<(), FitError> {
        let bad = |name, value: f64, expected| {
            Err(FitError::Option {
                name,
                value,
                expected,
            })
        };
        if !(1..=MAX_SWEEPS).contains(&self.stages) {
            return bad("stages", self.stages as f64, "1 to 1000");
        }
        if !(1..=MAX_SWEEPS).contains(&self.iterations) {
            return bad("iterations", self.iterations as f64, "1 to 1000");
        }
        let (s0, s1) = self.stiffness();
        for (name, v) in [("stiffness_start", s0), ("stiffness_end", s1)] {
            if !(v.is_finite() && v > 0.0 && v <= 1e6) {
                return bad(name, v, "positive, at most 1e6");
            }
        }
        if self.global_degree > MAX_GLOBAL_DEGREE {
            return bad("global_degree", self.global_degree as f64, "0 to 5");
        }
        if !(self.landmark_weight.is_finite() && (0.0..=1e6).contains(&self.landmark_weight)) {
            return bad("landmark_weight", self.landmark_weight, "0 to 1e6");
        }
        if !(self.isometric.is_finite() && (0.0..=1e6).contains(&self.isometric)) {
            return bad("isometric", self.isometric, "0 to 1e6");
        }
        if !(self.surface_to_point.is_finite() && (0.0..=1e6).contains(&self.surface_to_point)) {
            return bad("surface_to_point", self.surface_to_point, "0 to 1e6");
        }
        if !(1..=MAX_VERTICES).contains(&self.max_samples) {
            return bad("max_samples", self.max_samples as f64, "1 to 100,000,000");
        }
        if !(self.outlier_distance.is_finite() && self.outlier_distance > 0.0) {
            return bad("outlier_distance", self.outlier_distance, "positive");
        }
        if !(self.normal_angle.is_finite() && (0.0..=180.0).contains(&self.normal_angle)) {
            return bad("normal_angle", self.normal_angle, "0 to 180 degrees");
        }
        Ok(())
    }
}
