//! Fitting one template mesh to surfaces of any triangulation (issue 49): the template's
//! connectivity at positions that lie on each target, so that data from segmentations, scanners
//! and other tools (every pose with its own triangulation) can be compared by the rest of the
//! library, which needs one connectivity per deformation.
//!
//! A fit has three steps:
//! 1. a similarity (or rigid) initial alignment of the template onto the target ([`rigid`]):
//!    area-weighted centroids, scale by the ratio of rms radii, principal axes with their sign
//!    ambiguities tried (and the input orientation), each refined by ICP with scale;
//! 2. a non-rigid fit ([`nonrigid`]): the template's vertices pulled onto the target surface
//!    (point-to-surface) and target samples pulling their nearest template point
//!    (surface-to-point), with robust weights, under a deformation prior ([`Prior`]: smooth
//!    local affine maps by default) whose stiffness is annealed from stiff to soft;
//! 3. the fit's quality ([`quality`]): symmetric surface distance in template edge lengths,
//!    triangle quality, flips and edge strain, with a `poor` flag.
//!
//! Targets without faces are point clouds: only the terms that need no target faces are used
//! (no normal test, no boundary test). Sequences are tracked ([`fit_sequence`]): the first
//! frame is fitted from the template, each next frame from the previous fit, always under the
//! prior of the (aligned) template. A cohort is one template fitted to each subject's first
//! frame, then tracked through the subject's frames.
//!
//! Units: positions are in the target's length unit; the fit's thresholds are in units of the
//! aligned template's mean edge length `lbar`, so the result does not depend on the scale of
//! the data.

pub mod affine;
pub mod closest;
pub mod data;
pub mod local;
pub mod nonrigid;
pub mod quality;
pub mod rigid;
pub mod shell;

use std::collections::HashMap;

use thiserror::Error;

use crate::align::{Alignment, Motion};
use crate::limits::{MAX_SWEEPS, MAX_VERTICES};
use crate::mesh::geometry::{add, cross, mean_edge_length, norm, scale, sub};
use crate::mesh::{Shape, MAX_COORDINATE};
use closest::SurfaceIndex;
pub use quality::FitQuality;

/// Why a template cannot carry a fit ([`FitError::Template`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TemplateProblem {
    /// The template has vertices but no triangles.
    #[error("it has no faces")]
    NoFaces,
    /// Several separate fans of faces meet at one vertex.
    #[error("it is not manifold: vertex {vertex} joins {fans} separate fans of faces")]
    NotManifold {
        /// The vertex.
        vertex: usize,
        /// Fans of faces meeting there.
        fans: usize,
    },
    /// All edges have length zero (or the mean is not finite).
    #[error("its mean edge length is zero")]
    ZeroEdgeLength,
}

/// Why a fit cannot be made. Each message is one line naming what is wrong.
#[derive(Debug, Error, Clone)]
pub enum FitError {
    /// The target has no points.
    #[error("the target is empty: it has no vertices")]
    EmptyTarget,
    /// A coordinate is NaN, infinite or beyond [`MAX_COORDINATE`].
    #[error("the {what} has a non-finite or too large coordinate at vertex {vertex}")]
    NonFinite {
        /// `"template"` or `"target"`.
        what: &'static str,
        /// The vertex.
        vertex: usize,
    },
    /// A target face refers to a vertex that does not exist.
    #[error("target face {face} refers to vertex {index}, but the target has {n_vertices} vertices")]
    FaceIndex {
        /// The face.
        face: usize,
        /// The index.
        index: u32,
        /// Target vertex count.
        n_vertices: usize,
    },
    /// More points than [`MAX_VERTICES`].
    #[error("the {what} has {count} vertices or faces, more than the limit {limit}")]
    TooLarge {
        /// `"template"` or `"target"`.
        what: &'static str,
        /// Its count.
        count: usize,
        /// The limit.
        limit: usize,
    },
    /// The template cannot carry a fit (no faces, zero edge length, non-manifold vertices).
    #[error("the template cannot be fitted: {0}")]
    Template(TemplateProblem),
    /// An option is out of range.
    #[error("fit option {name} = {value} is out of range ({expected})")]
    Option {
        /// The option.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The accepted range.
        expected: &'static str,
    },
    /// After the initial alignment too few template vertices have a plausible match on the
    /// target.
    #[error("no overlap after alignment: only {matched} of {total} template vertices found a target point within the outlier distance")]
    NoOverlap {
        /// Vertices with a correspondence.
        matched: usize,
        /// Template vertices.
        total: usize,
    },
    /// The symbolic analysis of the fit's sparse system failed (out of memory, index overflow).
    #[error("the fit's linear system could not be analysed: {0}")]
    Symbolic(faer::sparse::FaerError),
    /// The numeric Cholesky factorization of the fit's system failed (a non-positive pivot).
    #[error("the fit's linear system could not be factorized: {0}")]
    Factorization(faer::linalg::solvers::LltError),
    /// A solve of the fit's system gave non-finite positions.
    #[error("the fit's linear system gave a non-finite solution")]
    NotFinite,
    /// A landmark names a template vertex that does not exist or a non-finite point.
    #[error("landmark {landmark}: vertex {vertex} is out of range (the template has {n_vertices} vertices) or its point is not finite")]
    Landmark {
        /// The landmark's index.
        landmark: usize,
        /// Its template vertex.
        vertex: usize,
        /// Template vertex count.
        n_vertices: usize,
    },
    /// No candidate of the initial alignment has a finite score or scale.
    #[error("the initial alignment did not converge (no candidate with a finite score and scale)")]
    Alignment,
}

/// A target surface: positions (#P x 3, any length unit) and triangles (#T x 3 indices into
/// them), any triangulation (not necessarily manifold or closed); no faces = a point cloud.
#[derive(Debug, Clone, Copy)]
pub struct Target<'a> {
    /// Points (#P x 3).
    pub positions: &'a [[f64; 3]],
    /// Triangles (#T x 3), possibly empty.
    pub faces: &'a [[u32; 3]],
}

/// The deformation prior of the non-rigid fit ([`affine`], [`nonrigid`], [`local`]): how the
/// fit charges the template's deformation, which decides where vertices go along the surface
/// where the data leave them free.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Prior {
    /// Smooth local affine maps near each vertex fan's best similarity (the default): smooth
    /// deformations of the whole shape cost little and local strain is charged. Better than
    /// [`Prior::Affine`] on tapers, bulges and dents and on the distances measured after a fit
    /// (docs/fit.md), worse on stretches and shears.
    #[default]
    Smooth,
    /// One affine map per vertex with Amberg et al.'s stiffness (differences of neighbouring
    /// maps), annealed from one map for the whole template to edge-scale detail ([`affine`]):
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
    /// multiplied by the template's vertex count (see [`affine`]).
    pub stiffness_start: Option<f64>,
    /// Stiffness at the last stage (`None`: the prior's own); stages in between are
    /// geometric.
    pub stiffness_end: Option<f64>,
    /// Weight of each landmark ([`fit_with_landmarks`]) relative to one vertex's data term, at
    /// the first stage (default 10; it falls with the stiffness to a tenth).
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
}

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

/// A checked target with its search structure, face normals and boundary edges.
pub(crate) struct Prepared<'a> {
    pub positions: &'a [[f64; 3]],
    pub faces: &'a [[u32; 3]],
    pub index: SurfaceIndex,
    /// Unit face normals (#T x 3; zero for degenerate faces); empty for a point cloud.
    pub face_normals: Vec<[f64; 3]>,
    /// Area-weighted unit vertex normals (#P x 3); empty for a point cloud.
    pub vertex_normals: Vec<[f64; 3]>,
    /// Edges (sorted pairs) used by exactly one face.
    pub boundary: HashMap<(u32, u32), ()>,
    /// Per-point weights for moments (a third of the adjacent faces' areas; 1 for a cloud).
    pub weights: Vec<f64>,
}

impl Prepared<'_> {
    /// Whether the target has faces.
    pub fn is_surface(&self) -> bool {
        !self.faces.is_empty()
    }

    /// Whether the point with barycentric coordinates `bary` on face `f` lies on a boundary
    /// edge of the target.
    pub fn on_boundary(&self, f: usize, bary: [f64; 3]) -> bool {
        let face = self.faces[f];
        (0..3).any(|k| {
            bary[k] <= 1e-9 && {
                let (a, b) = (face[(k + 1) % 3], face[(k + 2) % 3]);
                self.boundary.contains_key(&(a.min(b), a.max(b)))
            }
        })
    }
}

fn check_points(what: &'static str, p: &[[f64; 3]]) -> Result<(), FitError> {
    if p.len() > MAX_VERTICES {
        return Err(FitError::TooLarge {
            what,
            count: p.len(),
            limit: MAX_VERTICES,
        });
    }
    match p
        .iter()
        .position(|x| x.iter().any(|c| !c.is_finite() || c.abs() > MAX_COORDINATE))
    {
        Some(vertex) => Err(FitError::NonFinite { what, vertex }),
        None => Ok(()),
    }
}

/// Checks a target and builds its search structure.
pub(crate) fn prepare<'a>(target: &Target<'a>) -> Result<Prepared<'a>, FitError> {
    let (pos, faces) = (target.positions, target.faces);
    if pos.is_empty() {
        return Err(FitError::EmptyTarget);
    }
    check_points("target", pos)?;
    if faces.len() > MAX_VERTICES {
        return Err(FitError::TooLarge {
            what: "target",
            count: faces.len(),
            limit: MAX_VERTICES,
        });
    }
    for (face, f) in faces.iter().enumerate() {
        if let Some(&index) = f.iter().find(|&&i| i as usize >= pos.len()) {
            return Err(FitError::FaceIndex {
                face,
                index,
                n_vertices: pos.len(),
            });
        }
    }
    let mut face_normals = Vec::with_capacity(faces.len());
    let mut vertex_normals = vec![[0.0; 3]; if faces.is_empty() { 0 } else { pos.len() }];
    let mut weights = vec![if faces.is_empty() { 1.0 } else { 0.0 }; pos.len()];
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for f in faces {
        let [a, b, c] = f.map(|i| pos[i as usize]);
        let n2 = cross(sub(b, a), sub(c, a));
        let l = norm(n2);
        face_normals.push(if l > 0.0 { scale(n2, 1.0 / l) } else { [0.0; 3] });
        for &i in f {
            vertex_normals[i as usize] = add(vertex_normals[i as usize], n2);
            weights[i as usize] += l / 6.0;
        }
        for k in 0..3 {
            let (u, v) = (f[k], f[(k + 1) % 3]);
            *edges.entry((u.min(v), u.max(v))).or_insert(0) += 1;
        }
    }
    for n in &mut vertex_normals {
        let l = norm(*n);
        if l > 0.0 {
            *n = scale(*n, 1.0 / l);
        }
    }
    let boundary = edges
        .into_iter()
        .filter(|e| e.1 == 1)
        .map(|e| (e.0, ()))
        .collect();
    let index = if faces.is_empty() {
        SurfaceIndex::points(pos)
    } else {
        SurfaceIndex::triangles(pos, faces)
    };
    Ok(Prepared {
        positions: pos,
        faces,
        index,
        face_normals,
        vertex_normals,
        boundary,
        weights,
    })
}

fn check_template(template: &Shape) -> Result<f64, FitError> {
    check_points("template", &template.positions)?;
    let topo = &template.topology;
    if topo.n_faces() == 0 {
        return Err(FitError::Template(TemplateProblem::NoFaces));
    }
    if let Some((v, _, fans)) = topo.nonmanifold_vertices().first() {
        return Err(FitError::Template(TemplateProblem::NotManifold {
            vertex: *v,
            fans: *fans,
        }));
    }
    let lbar = mean_edge_length(topo, &template.positions);
    if !(lbar.is_finite() && lbar > 0.0) {
        return Err(FitError::Template(TemplateProblem::ZeroEdgeLength));
    }
    Ok(lbar)
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
        match &self.affine {
            Some(a) => affine::fit(&self.edge, a, start, target, opts, landmarks),
            None => nonrigid::fit(&self.edge, rest, start, target, opts),
        }
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

#[cfg(test)]
mod tests;
