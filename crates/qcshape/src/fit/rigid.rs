//! The initial alignment of a fit: the similarity (or rigid) motion that places the template
//! on the target before the non-rigid fit.
//!
//! The similarity's scale: for a surface target the square root of the ratio of the surface
//! areas, held fixed (a posed target's closest points pull a fitted scale down: 0.85-0.87 on
//! the horse gallop, 0.59 on a cactus pose; docs/fit.md "Area-scaled alignment"); for a point
//! cloud the ratio of rms radii, refined by the ICP rounds.
//!
//! Candidates: the template as given (centroids matched, scaled as above),
//! and the four proper rotations mapping the template's principal axes onto the target's (the
//! axes' signs are ambiguous; the four sign choices with determinant +1). Each candidate is
//! refined by [`ICP_ITERATIONS`] rounds of ICP with [`crate::align::best_motion`] (Horn's
//! method, with scale for a point cloud's similarity) on trimmed closest-point pairs, and scored by the
//! symmetric mean squared distance (template vertices to the target, target samples to the
//! template's vertices). The lowest score wins, except that the as-given candidate is kept when
//! it scores within [`KEEP_AS_GIVEN`] of the best: symmetric shapes (a sphere, an ellipsoid)
//! fit equally well under a flip, and data that arrive posed should stay so.

use super::closest::SurfaceIndex;
use super::error::FitError;
use super::options::FitOptions;
use super::target::Prepared;
use crate::align::{best_motion, Alignment, Motion};
use crate::mesh::geometry::{add, dot, scale, sub, vertex_areas};
use crate::mesh::Shape;

/// ICP rounds per candidate.
pub const ICP_ITERATIONS: usize = 30;

/// Candidates scoring at most this factor times the best compete on their rotation angle.
pub const KEEP_AS_GIVEN: f64 = 1.6;

/// Fraction of closest-point pairs kept by the ICP (the farthest are dropped).
const TRIM: f64 = 0.9;

/// Samples of the target used to score a candidate at most.
const SCORE_SAMPLES: usize = 5_000;

/// Weighted centroid, rms radius and principal axes (columns of the returned matrix, by
/// decreasing variance) of a point set.
fn moments(p: &[[f64; 3]], w: &[f64]) -> ([f64; 3], f64, [[f64; 3]; 3]) {
    let total: f64 = w.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    let mut c = [0.0; 3];
    for (x, &wi) in p.iter().zip(w) {
        c = add(c, scale(*x, wi / total));
    }
    let mut cov = [[0.0; 3]; 3];
    let mut r2 = 0.0;
    for (x, &wi) in p.iter().zip(w) {
        let d = sub(*x, c);
        r2 += wi / total * dot(d, d);
        for a in 0..3 {
            for b in 0..3 {
                cov[a][b] += wi / total * d[a] * d[b];
            }
        }
    }
    let axes = faer::Mat::<f64>::from_fn(3, 3, |i, j| cov[i][j])
        .self_adjoint_eigen(faer::Side::Lower)
        .ok()
        .map(|e| {
            let u = e.U();
            // Eigenvalues ascend: column 2 is the largest.
            let mut m = [[0.0; 3]; 3];
            for r in 0..3 {
                for k in 0..3 {
                    m[r][k] = u[(r, 2 - k)];
                }
            }
            m
        })
        .filter(|m| m.iter().flatten().all(|x| x.is_finite()))
        .unwrap_or(Motion::IDENTITY.rotation);
    (c, r2.sqrt(), axes)
}

fn matmul_bt(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| a[i][k] * b[j][k]).sum();
        }
    }
    m
}

fn det(m: &[[f64; 3]; 3]) -> f64 {
    dot(m[0], crate::mesh::geometry::cross(m[1], m[2]))
}

/// Evenly strided indices, at most `max` of `0..n`.
pub(crate) fn stride(n: usize, max: usize) -> impl Iterator<Item = usize> {
    let step = n.div_ceil(max.max(1)).max(1);
    (0..n).step_by(step)
}

/// The initial motion of the template (#V x 3) into the target's frame ([`FitOptions::alignment`]).
pub(crate) fn initial_alignment(
    template: &Shape,
    target: &Prepared,
    opts: &FitOptions,
) -> Result<Motion, FitError> {
    if opts.alignment == Alignment::None {
        return Ok(Motion::IDENTITY);
    }
    let with_scale = opts.alignment == Alignment::Similarity;
    let tw = vertex_areas(&template.topology, &template.positions);
    let (cs, rs, es) = moments(&template.positions, &tw);
    let (ct, rt, et) = moments(target.positions, &target.weights);
    // The scale (module docs): a surface's from the area ratio, held; a cloud's fitted.
    let area = |w: &[f64]| w.iter().filter(|a| a.is_finite() && **a > 0.0).sum::<f64>();
    let (at, as_) = (area(&target.weights), area(&tw));
    let area_scale = (with_scale && target.is_surface() && at > 0.0 && as_ > 0.0).then(|| (at / as_).sqrt());
    let s0 = if let Some(s) = area_scale {
        s
    } else if with_scale && rs > 0.0 && rt > 0.0 {
        rt / rs
    } else {
        1.0
    };
    let fit_scale = with_scale && area_scale.is_none();
    let from: std::borrow::Cow<[[f64; 3]]> = match area_scale {
        Some(s) => template.positions.iter().map(|p| scale(*p, s)).collect(),
        None => (&template.positions[..]).into(),
    };
    let mut candidates = vec![Motion::IDENTITY.rotation];
    // The eight sign choices of the axes; the four that give a proper rotation are kept.
    for k in 0..8 {
        let signs = [0, 1, 2].map(|b| if k >> b & 1 == 1 { -1.0 } else { 1.0 });
        // R = E_t D E_s^T maps the template's axes onto the target's.
        let mut etd = et;
        for row in &mut etd {
            for k in 0..3 {
                row[k] *= signs[k];
            }
        }
        let r = matmul_bt(&etd, &es);
        if det(&r) > 0.0 {
            candidates.push(r);
        }
    }
    let samples: Vec<[f64; 3]> = stride(target.positions.len(), SCORE_SAMPLES)
        .map(|i| target.positions[i])
        .collect();
    let mut best: Vec<(f64, Motion)> = Vec::new();
    for rotation in candidates {
        let rc = scale(rotation.map(|r| dot(r, cs)), s0);
        let mut m = Motion {
            rotation,
            scale: s0,
            translation: sub(ct, rc),
        };
        for _ in 0..ICP_ITERATIONS {
            let moved: Vec<[f64; 3]> = template.positions.iter().map(|p| m.apply(*p)).collect();
            let pairs: Vec<([f64; 3], f64)> = moved
                .iter()
                .map(|q| {
                    target
                        .index
                        .closest(*q)
                        .map_or(([0.0; 3], f64::INFINITY), |c| (c.point, c.distance_sq))
                })
                .collect();
            let cut = trim_level(pairs.iter().map(|p| p.1));
            let w: Vec<f64> = pairs
                .iter()
                .zip(&tw)
                .map(|(p, &a)| if p.1 <= cut { a } else { 0.0 })
                .collect();
            let to: Vec<[f64; 3]> = pairs.iter().map(|p| p.0).collect();
            let mut next = best_motion(&from, &to, &w, fit_scale);
            if area_scale.is_some() {
                next.scale = s0;
            }
            let change = (0..3)
                .map(|k| (next.translation[k] - m.translation[k]).abs())
                .sum::<f64>()
                + (next.scale - m.scale).abs() * rt.max(f64::MIN_POSITIVE)
                + (0..3)
                    .flat_map(|i| (0..3).map(move |j| (i, j)))
                    .map(|(i, j)| (next.rotation[i][j] - m.rotation[i][j]).abs())
                    .sum::<f64>()
                    * rt;
            m = next;
            if change < 1e-9 * rt.max(f64::MIN_POSITIVE) {
                break;
            }
        }
        let moved: Vec<[f64; 3]> = template.positions.iter().map(|p| m.apply(*p)).collect();
        best.push((score(&moved, target, &samples), m));
    }
    let min = best.iter().map(|b| b.0).fold(f64::INFINITY, f64::min);
    // Among the candidates scoring within KEEP_AS_GIVEN of the best, the smallest turn.
    // Ties (a target with a mirror symmetry gives two candidates of equal score and angle)
    // go to the first candidate in the fixed order, whatever the rounding at this scale.
    let kept = || best.iter().filter(|b| b.0 <= KEEP_AS_GIVEN * min);
    let smallest = kept().map(|b| b.1.angle()).fold(f64::INFINITY, f64::min);
    let (s, m) = kept()
        .find(|b| b.1.angle() <= smallest + 1e-6)
        .copied()
        .ok_or(FitError::Alignment)?;
    if !(s.is_finite() && m.scale.is_finite() && m.scale > 0.0) {
        return Err(FitError::Alignment);
    }
    Ok(m)
}

/// The squared distance below which [`TRIM`] of the pairs lie.
fn trim_level(d: impl Iterator<Item = f64>) -> f64 {
    let mut d: Vec<f64> = d.filter(|x| x.is_finite()).collect();
    if d.is_empty() {
        return f64::INFINITY;
    }
    let k = ((d.len() as f64 * TRIM).ceil() as usize).clamp(1, d.len()) - 1;
    *d.select_nth_unstable_by(k, f64::total_cmp).1
}

/// Symmetric trimmed mean squared distance between the moved template's vertices and the
/// target (vertices to surface, samples to vertices).
fn score(moved: &[[f64; 3]], target: &Prepared, samples: &[[f64; 3]]) -> f64 {
    let trimmed_mean = |d: Vec<f64>| {
        let cut = trim_level(d.iter().copied());
        let kept: Vec<f64> = d.into_iter().filter(|x| *x <= cut).collect();
        kept.iter().sum::<f64>() / kept.len().max(1) as f64
    };
    let a = trimmed_mean(
        moved
            .iter()
            .map(|q| target.index.closest(*q).map_or(f64::INFINITY, |c| c.distance_sq))
            .collect(),
    );
    let verts = SurfaceIndex::points(moved);
    let b = trimmed_mean(
        samples
            .iter()
            .map(|q| verts.closest(*q).map_or(f64::INFINITY, |c| c.distance_sq))
            .collect(),
    );
    a + b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::rotation_about;
    use crate::fit::target::{prepare, Target};
    use crate::synth::icosphere;

    /// An asymmetric blob (no rotation maps it onto itself).
    fn blob(level: u32) -> Shape {
        let s = icosphere(level);
        let p = s
            .positions
            .iter()
            .map(|p| [1.7 * p[0] + 0.3, p[1], 0.6 * p[2] + p[0] * p[0]])
            .collect();
        Shape::new(s.topology, p).unwrap()
    }

    #[test]
    fn recovers_a_similarity_of_a_finer_mesh() {
        let coarse = blob(2);
        let fine = blob(3);
        let truth = Motion {
            rotation: rotation_about([0.2, 1.0, -0.4], 2.0),
            scale: 37.0,
            translation: [100.0, -4.0, 9.0],
        };
        let moved: Vec<[f64; 3]> = fine.positions.iter().map(|p| truth.apply(*p)).collect();
        let t = Target {
            positions: &moved,
            faces: fine.topology.faces(),
        };
        let m = initial_alignment(&coarse, &prepare(&t).unwrap(), &FitOptions::default()).unwrap();
        assert!((m.scale / 37.0 - 1.0).abs() < 0.02, "{m:?}");
        for p in &coarse.positions {
            let e = sub(m.apply(*p), truth.apply(*p));
            assert!(dot(e, e).sqrt() < 0.05 * 37.0, "{m:?}");
        }
    }

    /// A posed surface (half of it bent away, then scaled by 5) is scaled by the square root
    /// of the area ratio, not by the closest-point fit's scale (which the bent half pulls
    /// down); the rotation and translation are still fitted.
    #[test]
    fn the_scale_of_a_posed_surface_is_the_area_ratio() {
        let template = blob(3);
        let posed: Vec<[f64; 3]> = crate::synth::bend_along_x(&template.positions, 1.5)
            .into_iter()
            .map(|p| scale(p, 5.0))
            .collect();
        let t = Target {
            positions: &posed,
            faces: template.topology.faces(),
        };
        let prepared = prepare(&t).unwrap();
        let m = initial_alignment(&template, &prepared, &FitOptions::default()).unwrap();
        let area = |p: &[[f64; 3]]| vertex_areas(&template.topology, p).iter().sum::<f64>();
        let want = (area(&posed) / area(&template.positions)).sqrt();
        assert!(
            (m.scale - want).abs() <= 1e-12 * want,
            "{} against {want}",
            m.scale
        );
        assert!((m.scale / 5.0 - 1.0).abs() < 0.1, "{m:?}");
        // The fit's own scale (rigid rounds on a template scaled by the fitted scale) is
        // what the area ratio replaces: it lands below it here.
        let icp = initial_alignment(
            &template,
            &prepare(&Target {
                positions: &posed,
                faces: &[],
            })
            .unwrap(),
            &FitOptions::default(),
        )
        .unwrap();
        assert!(icp.scale < m.scale, "{} against {}", icp.scale, m.scale);
    }
}
