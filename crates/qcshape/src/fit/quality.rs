//! The quality of a fit, per pose: how close the fitted template lies to the target (both
//! ways), the fitted triangles' shape, folds, and the distortion against the template.

use super::closest::SurfaceIndex;
use super::nonrigid::median;
use super::rigid::stride;
use super::target::Prepared;
use crate::mesh::geometry::{
    corner_angles, dot, edge_lengths, face_normals, mean_edge_length, sub, vertex_normals,
};
use crate::mesh::Topology;
use rayon::prelude::*;

/// Target points (an even stride) whose distance to the fitted surface enters the quality, at
/// most.
pub const SAMPLES: usize = 100_000;

/// A fit is poor when the mean symmetric distance exceeds this many template edge lengths.
pub const POOR_MEAN: f64 = 0.2;
/// ... or the 95th percentile of the symmetric distance exceeds this many edge lengths.
pub const POOR_P95: f64 = 0.75;
/// ... or the fit made a sliver: a triangle with an angle below this (degrees) and below half
/// of the same triangle's smallest angle in the template (the template's own slivers are not
/// the fit's fault).
pub const POOR_MIN_ANGLE: f64 = 1.0;
/// ... or [`FitQuality::slide`] exceeds this: a vertex's local map differs this much
/// (Frobenius norm, dimensionless) from its neighbours' mean where the fit slid a patch along
/// the surface. Smooth
/// deformations stay below it: at most 0.24 for the true poses and 0.35 for the fits of the
/// issue-59 benchmark; a patch slid by 1.5 edge lengths gives 0.52 (docs/fit.md).
pub const POOR_SLIDE: f64 = 0.4;
/// [`POOR_SLIDE`] holds for templates whose mean edge is at most this fraction of their rms
/// radius (the 642-vertex templates of the issue-59 benchmark, where it was measured); for
/// coarser templates the limit grows with the square of the ratio, because a smooth
/// deformation's maps then differ between neighbours to second order too (a 42-vertex template
/// bent: 0.54).
pub const SLIDE_REFERENCE_EDGE: f64 = 0.15;
/// Triangles of the template with an angle below this (degrees), and their edge neighbours,
/// are not counted as flipped: a sliver's normal turns over under any small motion.
pub const SLIVER_ANGLE: f64 = 5.0;

/// Faces of the template at or above this angle (degrees) against their neighbours (the angle
/// between the face's normal and the sum of its edge neighbours' normals) are creases or folds
/// of the template itself and are not counted as flipped: a small motion turns them over (the
/// horse gallop's reference pose has 6 folded faces and 30 above 60 degrees; fitted onto its
/// own re-meshed surface at 0.011 edge lengths, one of them was counted, docs/fit.md).
pub const CREASE_ANGLE: f64 = 60.0;

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
    /// Smallest triangle angle of the (aligned) template itself (degrees): the part of a small
    /// `min_angle` that the template brought.
    pub template_min_angle: f64,
    /// Triangles the fit made slivers: fitted angle below [`POOR_MIN_ANGLE`] and below half of
    /// the triangle's smallest angle in the template.
    pub new_slivers: usize,
    /// Triangles folded over by the fit: the fitted normal points against the mean normal of
    /// its edge neighbours (more than 90 degrees from it) while the template's is within
    /// [`CREASE_ANGLE`] of it; triangles that are slivers in the template (an angle below
    /// [`SLIVER_ANGLE`]) or border one are not counted.
    pub flipped: usize,
    /// Local tangential slide: the 99th percentile over vertices of `|A_i - mean_j A_j|_F`, the
    /// difference between a vertex's local linear map and the mean of its neighbours' (each
    /// vertex's map the least-squares map of its rest edge fan, and normal, onto the fitted
    /// ones; dimensionless). A smooth deformation changes the maps smoothly (the difference
    /// vanishes to first order); a patch slid along the surface shears the edges at its
    /// border. Poor above [`FitQuality::slide_limit`].
    pub slide: f64,
    /// The limit of `slide`: [`POOR_SLIDE`] times `max(1, (h / SLIDE_REFERENCE_EDGE)^2)`, `h`
    /// the template's mean edge over its rms radius.
    pub slide_limit: f64,
    /// Root mean square relative edge strain `l_fit / l_template - 1`.
    pub strain_rms: f64,
    /// Largest absolute relative edge strain.
    pub strain_max: f64,
    /// The aligned template's mean edge length (target units): the unit of the distances.
    pub edge_length: f64,
    /// Whether the fit is poor: `mean > POOR_MEAN`, `p95 > POOR_P95`, a flipped triangle, a
    /// new sliver, or `slide > slide_limit`: only what the fit caused, not the template's own
    /// defects.
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
        if self.new_slivers > 0 {
            out.push(format!(
                "{} triangles made slivers (angle < {POOR_MIN_ANGLE} degrees; minimum {:.2}, template's {:.2})",
                self.new_slivers, self.min_angle, self.template_min_angle
            ));
        }
        if self.slide > self.slide_limit {
            out.push(format!(
                "local maps jump by {:.2} > {:.2} between neighbours (a patch slid along the surface)",
                self.slide, self.slide_limit
            ));
        }
        out
    }
}

/// Each face's smallest angle (degrees).
fn face_min_angles(topo: &Topology, pos: &[[f64; 3]]) -> Vec<f64> {
    corner_angles(topo, pos)
        .iter()
        .map(|a| a.iter().fold(f64::INFINITY, |m, x| m.min(*x)).to_degrees())
        .collect()
}

/// Per face, the angle (degrees) between its normal and the sum of its edge neighbours'
/// normals: above 90 the face is folded over against its neighbours; 0 without neighbours.
fn fold_angles(topo: &Topology, pos: &[[f64; 3]]) -> Vec<f64> {
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
    n.iter()
        .zip(&sum)
        .map(|(f, s)| {
            let (lf, ls) = (dot(*f, *f).sqrt(), dot(*s, *s).sqrt());
            if lf > 0.0 && ls > 0.0 {
                (dot(*f, *s) / (lf * ls)).clamp(-1.0, 1.0).acos().to_degrees()
            } else {
                0.0
            }
        })
        .collect()
}

/// The triangles the fit folded over ([`FitQuality::flipped`]): folded in `fitted` (more than
/// 90 degrees against their neighbours) where the template `rest` is not creased there (below
/// [`CREASE_ANGLE`]) and is not a sliver or next to one (`rest_min_angles`, degrees, per face,
/// below [`SLIVER_ANGLE`]).
fn count_flipped(topo: &Topology, rest: &[[f64; 3]], fitted: &[[f64; 3]], rest_min_angles: &[f64]) -> usize {
    // Slivers of the template and their edge neighbours.
    let mut near_sliver: Vec<bool> = rest_min_angles.iter().map(|a| *a < SLIVER_ANGLE).collect();
    for ef in topo.edge_faces() {
        let (a, b) = (ef[0] as usize, ef[1] as usize);
        if a < near_sliver.len()
            && b < near_sliver.len()
            && a != b
            && (rest_min_angles[a] < SLIVER_ANGLE || rest_min_angles[b] < SLIVER_ANGLE)
        {
            near_sliver[a] = true;
            near_sliver[b] = true;
        }
    }
    let (ft, fr) = (fold_angles(topo, fitted), fold_angles(topo, rest));
    ft.iter()
        .zip(&fr)
        .zip(&near_sliver)
        .filter(|((f, r), s)| **f > 90.0 && **r < CREASE_ANGLE && !**s)
        .count()
}

/// The local linear map of each vertex (#V of 3 x 3): the least-squares map of its rest edge
/// fan onto the fitted one, with the vertex normal (scaled to the fan's mean edge length) as a
/// fourth pair so that the map is defined off the surface too.
pub fn local_maps(topo: &Topology, rest: &[[f64; 3]], fitted: &[[f64; 3]]) -> Vec<[[f64; 3]; 3]> {
    let (nr, nf) = (vertex_normals(topo, rest), vertex_normals(topo, fitted));
    (0..rest.len())
        .into_par_iter()
        .map(|i| {
            let (mut uu, mut vu) = ([[0.0; 3]; 3], [[0.0; 3]; 3]);
            let mut l = 0.0;
            let nb = topo.neighbors(i);
            let mut add = |u: [f64; 3], v: [f64; 3]| {
                for a in 0..3 {
                    for b in 0..3 {
                        uu[a][b] += u[a] * u[b];
                        vu[a][b] += v[a] * u[b];
                    }
                }
            };
            for &j in nb {
                let (u, v) = (sub(rest[j as usize], rest[i]), sub(fitted[j as usize], fitted[i]));
                l += dot(u, u).sqrt() / nb.len().max(1) as f64;
                add(u, v);
            }
            add(nr[i].map(|c| c * l), nf[i].map(|c| c * l));
            match inverse3(uu) {
                Some(inv) => {
                    let mut a = [[0.0; 3]; 3];
                    for r in 0..3 {
                        for c in 0..3 {
                            a[r][c] = (0..3).map(|k| vu[r][k] * inv[k][c]).sum();
                        }
                    }
                    a
                }
                None => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            }
        })
        .collect()
}

fn inverse3(m: [[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c = |r: usize, k: usize| {
        let (r1, r2, k1, k2) = ((r + 1) % 3, (r + 2) % 3, (k + 1) % 3, (k + 2) % 3);
        m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    let scale: f64 = m
        .iter()
        .flatten()
        .map(|x| x.abs())
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    let bound = 1e-12 * scale.powi(3);
    if det.is_nan() || det.abs() <= bound {
        return None;
    }
    Some([0, 1, 2].map(|r| [0, 1, 2].map(|k| c(k, r) / det)))
}

/// [`FitQuality::slide`]: the 99th percentile over vertices of `|A_i - mean_j A_j|_F`, the
/// map's difference from the mean of its neighbours' ([`local_maps`]): zero to first order for
/// any smooth field of maps (a smooth deformation), about half the jump at the border of a
/// patch slid along the surface.
#[allow(clippy::needless_range_loop)]
pub fn slide(topo: &Topology, rest: &[[f64; 3]], fitted: &[[f64; 3]]) -> f64 {
    let maps = local_maps(topo, rest, fitted);
    let mut jump: Vec<f64> = (0..maps.len())
        .map(|i| {
            let nb = topo.neighbors(i);
            if nb.is_empty() {
                return 0.0;
            }
            let mut s = 0.0;
            for r in 0..3 {
                for c in 0..3 {
                    let mean = nb.iter().map(|&j| maps[j as usize][r][c]).sum::<f64>() / nb.len() as f64;
                    s += (maps[i][r][c] - mean).powi(2);
                }
            }
            s.sqrt()
        })
        .collect();
    if jump.is_empty() {
        return 0.0;
    }
    jump.sort_by(f64::total_cmp);
    jump[((jump.len() as f64 * 0.99).ceil() as usize).clamp(1, jump.len()) - 1]
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
    let (fit_angles, rest_angles) = (face_min_angles(topo, fitted), face_min_angles(topo, rest));
    let min_angle = fit_angles.iter().fold(f64::INFINITY, |m, a| m.min(*a));
    let template_min_angle = rest_angles.iter().fold(f64::INFINITY, |m, a| m.min(*a));
    let new_slivers = fit_angles
        .iter()
        .zip(&rest_angles)
        .filter(|(f, r)| **f < POOR_MIN_ANGLE && **f < 0.5 * **r)
        .count();
    let flipped = count_flipped(topo, rest, fitted, &rest_angles);
    let slide = slide(topo, rest, fitted);
    let slide_limit = {
        let n = rest.len().max(1) as f64;
        let c = rest
            .iter()
            .fold([0.0; 3], |a, p| [0, 1, 2].map(|k| a[k] + p[k] / n));
        let r = (rest.iter().map(|p| dot(sub(*p, c), sub(*p, c))).sum::<f64>() / n).sqrt();
        let h = if r > 0.0 { lbar / r } else { 0.0 };
        POOR_SLIDE * (h / SLIDE_REFERENCE_EDGE).powi(2).max(1.0)
    };
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
        template_min_angle,
        new_slivers,
        flipped,
        slide,
        slide_limit,
        strain_rms,
        strain_max,
        edge_length: lbar,
        poor: false,
    };
    q.poor = !q.problems().is_empty();
    (q, residual)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles on the edge (0, 1), the second turned about it so that the normals are
    /// `angle` degrees apart.
    fn hinge(angle: f64) -> Vec<[f64; 3]> {
        let t = angle.to_radians();
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1.0, 0.0],
            [0.5, -t.cos(), -t.sin()],
        ]
    }

    #[test]
    fn a_fold_counts_where_the_template_is_smooth_not_at_its_own_creases() {
        let topo = Topology::new(4, vec![[0, 1, 2], [1, 0, 3]]).unwrap();
        // The normals' angle is the hinge's: 10 degrees stays, 120 is folded.
        let angles = fold_angles(&topo, &hinge(10.0));
        assert!(angles.iter().all(|a| (a - 10.0).abs() < 1e-9), "{angles:?}");
        let smooth = hinge(10.0);
        let crease = hinge(85.0);
        for (rest, fitted, want) in [
            (&smooth, hinge(120.0), 2),
            (&smooth, hinge(60.0), 0),
            // A template crease of 85 degrees turned to 95: the template's, not the fit's.
            (&crease, hinge(95.0), 0),
            (&crease, hinge(150.0), 0),
        ] {
            let got = count_flipped(&topo, rest, &fitted, &face_min_angles(&topo, rest));
            assert_eq!(got, want, "{rest:?} -> {fitted:?}");
        }
    }
}
