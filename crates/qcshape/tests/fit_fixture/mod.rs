//! Fixtures with ground truth for the fit (issue 49), shared by `tests/fit.rs` and
//! `examples/fit_accuracy.rs`: a template (a synthetic initial shape on the level-2 icosphere,
//! 162 vertices) and a target that is the same analytic deformation of the same shape on
//! another triangulation (a turned icosphere of a finer level, so that no template vertex is a
//! target vertex), with noise. The true position of template vertex `i` is the deformation of
//! its rest position.
#![allow(dead_code)]

use std::sync::Arc;

use qcshape::align::{rotation_about, Motion};
use qcshape::fit::closest::SurfaceIndex;
use qcshape::mesh::geometry::{mean_edge_length, norm, sub};
use qcshape::mesh::{Shape, Topology};
use qcshape::synth::{
    add_noise, icosphere, initial_shape, DeformParams, DeformationKind, InitialShape, NoiseKind,
};

/// One fixture.
pub struct Case {
    /// The template at rest (162 vertices).
    pub template: Shape,
    /// Target points (#P x 3).
    pub target: Vec<[f64; 3]>,
    /// Target triangles.
    pub faces: Vec<[u32; 3]>,
    /// True fitted positions of the template's vertices (target frame).
    pub truth: Vec<[f64; 3]>,
}

/// The template of `shape` on the level-2 icosphere and `shape` deformed by `kind` at time `t`
/// on the level-`fine` icosphere turned by 0.7 rad, each target vertex moved by Gaussian noise
/// of variance `noise_percent` % of the target's squared mean edge length (seed `seed`), then
/// the target moved by `placement` (the truth too).
pub fn case(
    shape: InitialShape,
    kind: DeformationKind,
    t: f64,
    fine: u32,
    noise_percent: f64,
    seed: u64,
    placement: Motion,
) -> Case {
    let coarse = icosphere(2);
    let fine_s = icosphere(fine);
    let turn = Motion {
        rotation: rotation_about([0.3, 0.5, 0.8], 0.7),
        scale: 1.0,
        translation: [0.0; 3],
    };
    let nc = coarse.n_vertices();
    // One joint shape, so both parts get the same centring and scaling.
    let mut pos = coarse.positions.clone();
    pos.extend(fine_s.positions.iter().map(|p| turn.apply(*p)));
    let mut faces = coarse.topology.faces().to_vec();
    faces.extend(fine_s.topology.faces().iter().map(|f| f.map(|i| i + nc as u32)));
    let joint = Shape::new(Topology::new(pos.len(), faces).unwrap(), pos).unwrap();
    let s = initial_shape(shape, &joint);
    let template = Shape::new(Arc::clone(&coarse.topology), s.positions[..nc].to_vec()).unwrap();
    let params = DeformParams::of(&template);
    let truth: Vec<[f64; 3]> = template
        .positions
        .iter()
        .map(|p| placement.apply(kind.apply(*p, t, &params)))
        .collect();
    let target: Vec<[f64; 3]> = s.positions[nc..]
        .iter()
        .map(|p| kind.apply(*p, t, &params))
        .collect();
    let target = add_noise(
        &fine_s.topology,
        &[target],
        NoiseKind::Gaussian,
        noise_percent,
        seed,
    )
    .remove(0)
    .into_iter()
    .map(|p| placement.apply(p))
    .collect();
    Case {
        template,
        target,
        faces: fine_s.topology.faces().to_vec(),
        truth,
    }
}

/// Per-vertex distances of `fitted` to the truth, in the true pose's... no: in units of the
/// template's mean edge length scaled by `scale` (the placement's scale).
pub fn errors(case: &Case, fitted: &[[f64; 3]], scale: f64) -> Vec<f64> {
    let lbar = mean_edge_length(&case.template.topology, &case.template.positions) * scale;
    fitted
        .iter()
        .zip(&case.truth)
        .map(|(a, b)| norm(sub(*a, *b)) / lbar)
        .collect()
}

/// The nearest-point baseline: each template vertex moved by `motion` then snapped to its
/// closest target point.
pub fn baseline(case: &Case, motion: &Motion) -> Vec<[f64; 3]> {
    let idx = SurfaceIndex::triangles(&case.target, &case.faces);
    case.template
        .positions
        .iter()
        .map(|p| idx.closest(motion.apply(*p)).unwrap().point)
        .collect()
}

/// Median and mean of a list.
pub fn median_mean(v: &[f64]) -> (f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    (s[s.len() / 2], s.iter().sum::<f64>() / s.len() as f64)
}
