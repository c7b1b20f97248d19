//! The quality of a fit, per pose: how close the fitted template lies to the target (both
//! ways), the fitted triangles' shape, folds, and the distortion against the template.

use super::closest::SurfaceIndex;
use super::nonrigid::median;
use super::rigid::stride;
use super::Prepared;
use crate::mesh::geometry::{corner_angles, dot, edge_lengths, face_normals, mean_edge_length};
use crate::mesh::Topology;
use rayon::prelude::*;

/// Target points (an even stride) whose distance to the fitted surface enters the quality, at
/// most.
pub const SAMPLES: usize = 100_000;

/// A fit is poor when the mean symmetric distance exceeds this many template edge lengths.
pub const POOR_MEAN: f64 = 0.2;
/// ... or the 95th percentile of the symmetric distance exceeds this many edge lengths.
pub const POOR_P95: f64 = 0.75;
/// ... or a fitted triangle has an angle below this (degrees).
pub const POOR_MIN_ANGLE: f64 = 1.0;

/// Quality of one fitted pose. Distances are in units of the aligned template's mean edge
/// length [`FitQuality::edge_length`] (so a value of 0.1 is a tenth of an edge).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FitQuality {
    /// Mean of the symmetric surface distance: the distances of the fitted vertices to the
    /// target and of the target's points (at most [`SAMPLES`]) to the fitted surface, pooled.
    pub mean: f64,
    /// Its 95th percentile.
    pub p95: f64,
    /// Its maximum (the Hausdorff distance, sampled at vertices).
    pub hausdorff: f64,
    /// Median distance of the fitted vertices to the target alone.
    pub median_vertex: f64,
    /// Smallest triangle angle of the fitted mesh (degrees).
    pub min_angle: f64,
    /// Triangles folded over: the fitted normal points against the mean normal of its edge
    /// neighbours while the template's does not.
    pub flipped: usize,
    /// Root mean square relative edge strain `l_fit / l_template - 1`.
    pub strain_rms: f64,
    /// Largest absolute relative edge strain.
    pub strain_max: f64,
    /// The aligned template's mean edge length (target units): the unit of the distances.
    pub edge_length: f64,
    /// Whether the fit is poor: `mean > POOR_MEAN`, `p95 > POOR_P95`, a flipped triangle, or
    /// `min_angle < POOR_MIN_ANGLE`.
    pub poor: bool,
}

impl FitQuality {
    /// What makes the fit poor, one phrase each (empty when it is not).
    pub fn problems(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.mean > POOR_MEAN {
            out.push(format!(
                "mean distance {:.3} edge lengths > {POOR_MEAN}",
                self.mean
            ));
        }
        if self.p95 > POOR_P95 {
            out.push(format!(
                "95th percentile {:.3} edge lengths > {POOR_P95}",
                self.p95
            ));
        }
        if self.flipped > 0 {
            out.push(format!("{} flipped triangles", self.flipped));
        }
        if self.min_angle < POOR_MIN_ANGLE {
            out.push(format!(
                "minimum angle {:.2} degrees < {POOR_MIN_ANGLE}",
                self.min_angle
            ));
        }
        out
    }
}

/// Faces whose normal has a negative dot product with the sum of their edge neighbours' normals.
fn folded(topo: &Topology, pos: &[[f64; 3]]) -> Vec<bool> {
    let n = face_normals(topo, pos);
    let mut sum = vec![[0.0; 3]; topo.n_faces()];
    for ef in topo.edge_faces() {
        let (a, b) = (ef[0] as usize, ef[1] as usize);
        if a < n.len() && b < n.len() && a != b {
            for k in 0..3 {
                sum[a][k] += n[b][k];
                sum[b][k] += n[a][k];
            }
        }
    }
    n.iter().zip(&sum).map(|(f, s)| dot(*f, *s) < 0.0).collect()
}

/// The quality of `fitted` (#V x 3) against `target`, with `rest` the aligned template; also
/// the per-vertex residual (distance to the target, target units).
pub(crate) fn measure(
    topo: &Topology,
    rest: &[[f64; 3]],
    fitted: &[[f64; 3]],
    target: &Prepared,
    max_samples: usize,
) -> (FitQuality, Vec<f64>) {
    let lbar = mean_edge_length(topo, rest).max(f64::MIN_POSITIVE);
    let residual: Vec<f64> = fitted
        .par_iter()
        .map(|q| {
            target
                .index
                .closest(*q)
                .map_or(f64::INFINITY, |c| c.distance_sq.sqrt())
        })
        .collect();
    let surface = SurfaceIndex::triangles(fitted, topo.faces());
    let samples: Vec<usize> = stride(target.positions.len(), max_samples).collect();
    let back: Vec<f64> = samples
        .par_iter()
        .map(|&k| {
            surface
                .closest(target.positions[k])
                .map_or(f64::INFINITY, |c| c.distance_sq.sqrt())
        })
        .collect();
    let mut all: Vec<f64> = residual.iter().chain(&back).map(|d| d / lbar).collect();
    all.sort_by(f64::total_cmp);
    let mean = all.iter().sum::<f64>() / all.len().max(1) as f64;
    let p95 = all
        .get(((all.len() as f64 * 0.95).ceil() as usize).saturating_sub(1))
        .copied()
        .unwrap_or(0.0);
    let hausdorff = all.last().copied().unwrap_or(0.0);
    let min_angle = corner_angles(topo, fitted)
        .iter()
        .flatten()
        .fold(f64::INFINITY, |m, a| m.min(*a))
        .to_degrees();
    let (ft, fr) = (folded(topo, fitted), folded(topo, rest));
    let flipped = ft.iter().zip(&fr).filter(|(a, b)| **a && !**b).count();
    let (lf, lr) = (edge_lengths(topo, fitted), edge_lengths(topo, rest));
    let strain: Vec<f64> = lf
        .iter()
        .zip(&lr)
        .map(|(a, b)| if *b > 0.0 { a / b - 1.0 } else { 0.0 })
        .collect();
    let strain_rms = (strain.iter().map(|s| s * s).sum::<f64>() / strain.len().max(1) as f64).sqrt();
    let strain_max = strain.iter().fold(0.0f64, |m, s| m.max(s.abs()));
    let mut q = FitQuality {
        mean,
        p95,
        hausdorff,
        median_vertex: median(residual.iter().map(|d| d / lbar)),
        min_angle,
        flipped,
        strain_rms,
        strain_max,
        edge_length: lbar,
        poor: false,
    };
    q.poor = !q.problems().is_empty();
    (q, residual)
}
