//! The fit's steps in order (initial alignment, non-rigid fit, quality) on one target
//! ([`fit`]) or tracked through a sequence ([`fit_sequence`]).

use super::error::FitError;
use super::options::{FitOptions, Prior};
use super::quality::FitQuality;
use super::target::{check_template, prepare, Prepared, Target};
use super::{affine, nonrigid, polynomial, quality, rigid};
use crate::align::Motion;
use crate::limits::MAX_SWEEPS;
use crate::mesh::{Shape, MAX_COORDINATE};

/// One fitted pose.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    /// The template's vertices at their fitted positions (#V x 3, target units).
    pub positions: Vec<[f64; 3]>,
    /// Distance of each fitted vertex to the target (#V, target units).
    pub residual: Vec<f64>,
    /// The initial alignment mapping the template into the target's frame (identity when
    /// tracking from a previous fit).
    pub motion: Motion,
    /// The fit's quality.
    pub quality: FitQuality,
    /// Non-rigid iterations run (linear solves).
    pub iterations: usize,
}

/// The initial alignment alone ([`FitOptions::alignment`]): the motion placing the template
/// (#V x 3) on the target, as [`fit`] computes it before the non-rigid step.
pub fn initial_alignment(template: &Shape, target: &Target, opts: &FitOptions) -> Result<Motion, FitError> {
    opts.check()?;
    check_template(template)?;
    rigid::initial_alignment(template, &prepare(target)?, opts)
}

/// Fits `template` (a manifold triangle mesh, #V x 3) to `target`: initial alignment, then the
/// non-rigid fit, then its quality. The result has the template's connectivity in the
/// target's frame and units.
pub fn fit(template: &Shape, target: &Target, opts: &FitOptions) -> Result<Fitted, FitError> {
    fit_with_landmarks(template, target, opts, &[])
}

/// [`fit`] with landmarks: template vertex `l.vertex` is pulled onto `l.point` (target units)
/// with weight [`FitOptions::landmark_weight`] (relaxed to a tenth over the stages). Only
/// [`Prior::Affine`] uses them; the other priors ignore them. Landmarks whose vertex is out of
/// range are refused ([`FitError::Landmark`]).
pub fn fit_with_landmarks(
    template: &Shape,
    target: &Target,
    opts: &FitOptions,
    landmarks: &[affine::Landmark],
) -> Result<Fitted, FitError> {
    opts.check()?;
    check_template(template)?;
    check_landmarks(template, landmarks)?;
    let prepared = prepare(target)?;
    let solvers = Solvers::new(&template.topology, opts)?;
    fit_prepared(template, &solvers, &prepared, opts, landmarks)
}

fn check_landmarks(template: &Shape, landmarks: &[affine::Landmark]) -> Result<(), FitError> {
    let nv = template.positions.len();
    for (k, l) in landmarks.iter().enumerate() {
        if l.vertex >= nv || l.point.iter().any(|c| !c.is_finite() || c.abs() > MAX_COORDINATE) {
            return Err(FitError::Landmark {
                landmark: k,
                vertex: l.vertex,
                n_vertices: nv,
            });
        }
    }
    Ok(())
}

/// The linear solvers of a template: the edge-vector priors' and, for [`Prior::Affine`], the
/// affine field's.
pub(crate) struct Solvers {
    edge: nonrigid::Solver,
    affine: Option<affine::AffineSolver>,
}

impl Solvers {
    fn new(topo: &std::sync::Arc<crate::mesh::Topology>, opts: &FitOptions) -> Result<Solvers, FitError> {
        Ok(Solvers {
            edge: nonrigid::Solver::new(topo)?,
            affine: match opts.prior {
                Prior::Affine => Some(affine::AffineSolver::new(topo)?),
                _ => None,
            },
        })
    }

    /// The non-rigid fit from `start` under the prior of `rest` (the aligned template); the
    /// affine prior measures its stiffness from `start` itself.
    fn nonrigid(
        &self,
        rest: &[[f64; 3]],
        start: Vec<[f64; 3]>,
        target: &Prepared,
        opts: &FitOptions,
        landmarks: &[affine::Landmark],
    ) -> Result<(Vec<[f64; 3]>, usize), FitError> {
        let (start, warps) = polynomial::warp(&self.edge, start, target, opts, opts.global_degree)?;
        let (x, solves) = match &self.affine {
            Some(a) => affine::fit(&self.edge, a, start, target, opts, landmarks)?,
            None => nonrigid::fit(&self.edge, rest, start, target, opts)?,
        };
        Ok((x, solves + warps))
    }
}

fn fit_prepared(
    template: &Shape,
    solvers: &Solvers,
    target: &Prepared,
    opts: &FitOptions,
    landmarks: &[affine::Landmark],
) -> Result<Fitted, FitError> {
    let motion = rigid::initial_alignment(template, target, opts)?;
    let rest: Vec<[f64; 3]> = template.positions.iter().map(|p| motion.apply(*p)).collect();
    let (positions, iterations) = solvers.nonrigid(&rest, rest.clone(), target, opts, landmarks)?;
    Ok(finish(
        &solvers.edge,
        &rest,
        positions,
        motion,
        iterations,
        target,
    ))
}

fn finish(
    solver: &nonrigid::Solver,
    rest: &[[f64; 3]],
    positions: Vec<[f64; 3]>,
    motion: Motion,
    iterations: usize,
    target: &Prepared,
) -> Fitted {
    let (quality, residual) = quality::measure(solver.topology(), rest, &positions, target, quality::SAMPLES);
    Fitted {
        positions,
        residual,
        motion,
        quality,
        iterations,
    }
}

/// Tracks a sequence: frame 0 is fitted from the template ([`fit`]), each next frame from the
/// previous frame's fit (no new initial alignment). The edge-vector priors stay measured
/// against the aligned template (errors do not accumulate in the template's shape); the affine
/// prior measures the frame-to-frame deformation (the previous fit is its rest shape), so the
/// correspondence follows the motion from frame to frame. `on_frame(k)` is called after frame
/// `k`.
pub fn fit_sequence(
    template: &Shape,
    targets: &[Target],
    opts: &FitOptions,
    mut on_frame: impl FnMut(usize),
) -> Result<Vec<Fitted>, FitError> {
    opts.check()?;
    check_template(template)?;
    let solvers = Solvers::new(&template.topology, opts)?;
    let mut out: Vec<Fitted> = Vec::with_capacity(targets.len().min(MAX_SWEEPS));
    let mut rest: Vec<[f64; 3]> = Vec::new();
    for (k, t) in targets.iter().enumerate() {
        let prepared = prepare(t)?;
        let fitted = match out.last() {
            None => {
                let f = fit_prepared(template, &solvers, &prepared, opts, &[])?;
                rest = template.positions.iter().map(|p| f.motion.apply(*p)).collect();
                f
            }
            Some(prev) => {
                let (positions, iterations) =
                    solvers.nonrigid(&rest, prev.positions.clone(), &prepared, opts, &[])?;
                finish(
                    &solvers.edge,
                    &rest,
                    positions,
                    Motion::IDENTITY,
                    iterations,
                    &prepared,
                )
            }
        };
        out.push(fitted);
        on_frame(k);
    }
    Ok(out)
}
