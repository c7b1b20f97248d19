//! Analysis helpers of the left-ventricle application (paper section 4.3, Tables 4 and 5,
//! Fig. 9): closed heart cycles, one mesh connectivity for a whole cohort, the two radial
//! wall-motion baselines of Table 4, and the pose-to-pose geodesic distances of one cycle.
//!
//! Baselines (the "mean systolic radial" and "mean radial" rows of Table 4, after the paper's
//! reference \[41\]): every vertex's radius is its distance to the left ventricle's long axis.
//! - *mean systolic radial displacement*: the mean over vertices of `r(ED) - r(ES)`, with
//!   end-diastole (ED) and end-systole (ES) the frames of largest and smallest mean radius;
//! - *mean radial velocity*: the mean over vertices and consecutive frame pairs of
//!   `|r(t+1) - r(t)| / dt` (`dt` the frame interval; the closing pair last -> first is included
//!   for a closed cycle).

use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;
use thiserror::Error;

use super::tps::{Tps, TpsError};
use qcshape::geodesic::{GeodesicError, GeodesicSolver};
use qcshape::mesh::{geometry, Topology};

pub use qcshape::mesh::Pose;

/// Why an analysis step cannot be done.
#[derive(Debug, Error)]
pub enum LvAnalysisError {
    /// Apex and base centre coincide (or are not finite): no long axis.
    #[error("apex and base coincide: no long axis")]
    NoAxis,
    /// Too few (or non-finite) points to fit an axis.
    #[error("an axis needs at least 4 finite points, got {0}")]
    AxisPoints(usize),
    /// Fewer than two frames.
    #[error("radial features need at least two frames, got {0}")]
    TooFewFrames(usize),
    /// Frames with different (or zero) vertex counts.
    #[error("every frame needs the same, non-zero number of vertices")]
    VertexCounts,
    /// A frame interval that is not positive and finite.
    #[error("frame interval {0} is not positive")]
    FrameInterval(f64),
    /// A vertex position that is not finite.
    #[error("a vertex position is not finite")]
    NonFinite,
    /// A subject surface without triangles.
    #[error("the subject's surface has no triangles")]
    EmptySurface,
    /// The landmark spline between two subjects cannot be fitted.
    #[error("landmark spline between subjects: {0}")]
    Tps(#[from] TpsError),
    /// A geodesic between two poses failed.
    #[error("poses {i} and {j}: {error}")]
    Geodesic {
        /// First pose.
        i: usize,
        /// Second pose.
        j: usize,
        /// Why.
        error: GeodesicError,
    },
    /// Cancelled by the caller.
    #[error("cancelled")]
    Cancelled,
}

/// The poses of a closed cycle ready for interpolation: `poses` followed by `poses[0]`, so
/// that the gap last -> first is interpolated too. With `F` frames and `k` inserted poses per
/// gap, interpolating the result gives `F (k + 1) + 1` poses whose last one is frame 0 again;
/// [`drop_closing_pose`] removes it, leaving `F (k + 1)` (8 x 4 = 32 in section 4.3).
pub fn close_cycle(poses: &[Pose]) -> Vec<Pose> {
    let mut out = poses.to_vec();
    if let Some(first) = poses.first() {
        out.push(first.clone());
    }
    out
}

/// Removes the repeated frame 0 at the end of an interpolated closed cycle (see
/// [`close_cycle`]); does nothing to fewer than two poses.
pub fn drop_closing_pose<T>(seq: &mut Vec<T>) {
    if seq.len() >= 2 {
        seq.pop();
    }
}

/// A straight line in space: the left ventricle's long axis (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axis {
    /// A point on the line.
    pub point: [f64; 3],
    /// Unit direction.
    pub direction: [f64; 3],
}

impl Axis {
    /// The line through the apex and the base centre (mm).
    pub fn through(apex: [f64; 3], base: [f64; 3]) -> Result<Axis, LvAnalysisError> {
        let d = geometry::sub(base, apex);
        let n = geometry::norm(d);
        if !(n > 1e-12 && n.is_finite()) {
            return Err(LvAnalysisError::NoAxis);
        }
        Ok(Axis {
            point: apex,
            direction: geometry::scale(d, 1.0 / n),
        })
    }

    /// The long axis fitted to a wall (points #V x 3, at least 4, mm): the direction of largest
    /// spread (principal axis), through the centre of the circle fitted (Kasa's algebraic
    /// least-squares fit) to the points projected on the perpendicular plane, so that an arc
    /// such as the free wall alone gives the cavity's axis rather than the arc's centroid.
    pub fn fit(points: &[[f64; 3]]) -> Result<Axis, LvAnalysisError> {
        if points.len() < 4 || points.iter().flatten().any(|c| !c.is_finite()) {
            return Err(LvAnalysisError::AxisPoints(points.len()));
        }
        let n = points.len() as f64;
        let c = points
            .iter()
            .fold([0.0; 3], |a, p| geometry::add(a, geometry::scale(*p, 1.0 / n)));
        let mut cov = [[0.0; 3]; 3];
        for p in points {
            let q = geometry::sub(*p, c);
            for (i, row) in cov.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v += q[i] * q[j] / n;
                }
            }
        }
        let direction = principal_direction(&cov);
        let (u, w) = plane_basis(direction);
        let xy: Vec<(f64, f64)> = points
            .iter()
            .map(|p| {
                let q = geometry::sub(*p, c);
                (geometry::dot(q, u), geometry::dot(q, w))
            })
            .collect();
        let centre = kasa_centre(&xy).unwrap_or((0.0, 0.0));
        let point = geometry::add(
            c,
            geometry::add(geometry::scale(u, centre.0), geometry::scale(w, centre.1)),
        );
        Ok(Axis { point, direction })
    }

    /// Distance of `p` to the line (mm).
    pub fn radius(&self, p: [f64; 3]) -> f64 {
        let q = geometry::sub(p, self.point);
        let along = geometry::dot(q, self.direction);
        geometry::norm(geometry::sub(q, geometry::scale(self.direction, along)))
    }
}

/// Unit eigenvector of the largest eigenvalue of a symmetric 3 x 3 matrix (power iteration
/// from the coordinate axis of largest diagonal entry).
fn principal_direction(m: &[[f64; 3]; 3]) -> [f64; 3] {
    let k = (0..3).max_by(|&a, &b| m[a][a].total_cmp(&m[b][b])).unwrap_or(0);
    let mut v = [0.0; 3];
    v[k] = 1.0;
    v = geometry::add(v, [1e-3, 2e-3, 3e-3]);
    for _ in 0..500 {
        let next = [
            geometry::dot(m[0], v),
            geometry::dot(m[1], v),
            geometry::dot(m[2], v),
        ];
        let n = geometry::norm(next);
        if !(n > 0.0 && n.is_finite()) {
            break;
        }
        v = geometry::scale(next, 1.0 / n);
    }
    let n = geometry::norm(v);
    if n > 0.0 {
        geometry::scale(v, 1.0 / n)
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// Two unit vectors completing `d` (unit) to an orthonormal basis.
fn plane_basis(d: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let helper = if d[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = geometry::cross(d, helper);
    let u = geometry::scale(u, 1.0 / geometry::norm(u));
    (u, geometry::cross(d, u))
}

/// Centre of the least-squares circle `x^2 + y^2 + D x + E y + F = 0` through 2-D points;
/// `None` when the points are (nearly) collinear.
fn kasa_centre(xy: &[(f64, f64)]) -> Option<(f64, f64)> {
    // Normal equations A^T A [D, E, F] = -A^T b with rows (x, y, 1), b = x^2 + y^2.
    let mut a = [[0.0; 3]; 3];
    let mut r = [0.0; 3];
    for &(x, y) in xy {
        let row = [x, y, 1.0];
        let b = x * x + y * y;
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += row[i] * row[j];
            }
            r[i] -= row[i] * b;
        }
    }
    let det = |m: &[[f64; 3]; 3]| geometry::dot(m[0], geometry::cross(m[1], m[2]));
    let d = det(&a);
    let scale = a[0][0].abs().max(a[1][1].abs()).max(a[2][2].abs()).powi(3);
    if d.abs().is_nan() || d.abs() <= 1e-12 * scale {
        return None;
    }
    let solve = |k: usize| {
        let mut m = a;
        for (i, row) in m.iter_mut().enumerate() {
            row[k] = r[i];
        }
        det(&m) / d
    };
    let (dd, ee) = (solve(0), solve(1));
    let centre = (-dd / 2.0, -ee / 2.0);
    (centre.0.is_finite() && centre.1.is_finite()).then_some(centre)
}

/// The radial wall-motion features of one deformation (the baselines of Table 4).
#[derive(Debug, Clone, PartialEq)]
pub struct RadialFeatures {
    /// Mean radius of each frame (mm; #frames).
    pub mean_radius: Vec<f64>,
    /// End-diastolic frame: the largest mean radius.
    pub ed_frame: usize,
    /// End-systolic frame: the smallest mean radius.
    pub es_frame: usize,
    /// Mean over vertices of `r(ED) - r(ES)` (mm).
    pub systolic_displacement: f64,
    /// Mean over vertices and frame pairs of `|r(t+1) - r(t)| / dt` (mm per unit of `dt`).
    pub mean_velocity: f64,
}

/// Radial features of the frames `poses` (#frames x #V x 3, mm) about `axis`; `dt` is the
/// frame interval (e.g. 1 / #frames of a cycle), `closed` adds the pair last -> first to the
/// velocity. Needs at least two frames of equal, non-zero vertex count and `dt > 0`.
pub fn radial_features(
    poses: &[Pose],
    axis: &Axis,
    dt: f64,
    closed: bool,
) -> Result<RadialFeatures, LvAnalysisError> {
    let f = poses.len();
    if f < 2 {
        return Err(LvAnalysisError::TooFewFrames(f));
    }
    let nv = poses[0].len();
    if nv == 0 || poses.iter().any(|p| p.len() != nv) {
        return Err(LvAnalysisError::VertexCounts);
    }
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(LvAnalysisError::FrameInterval(dt));
    }
    let r: Vec<Vec<f64>> = poses
        .iter()
        .map(|p| p.iter().map(|&x| axis.radius(x)).collect())
        .collect();
    if r.iter().flatten().any(|v| !v.is_finite()) {
        return Err(LvAnalysisError::NonFinite);
    }
    let mean_radius: Vec<f64> = r.iter().map(|v| v.iter().sum::<f64>() / nv as f64).collect();
    let arg = |better: fn(f64, f64) -> bool| {
        (0..f).fold(0, |b, t| {
            if better(mean_radius[t], mean_radius[b]) {
                t
            } else {
                b
            }
        })
    };
    let ed = arg(|a, b| a > b);
    let es = arg(|a, b| a < b);
    let systolic_displacement = (0..nv).map(|v| r[ed][v] - r[es][v]).sum::<f64>() / nv as f64;
    let pairs: Vec<(usize, usize)> = (0..f - 1)
        .map(|t| (t, t + 1))
        .chain(closed.then_some((f - 1, 0)))
        .collect();
    let total: f64 = pairs
        .iter()
        .map(|&(a, b)| (0..nv).map(|v| (r[b][v] - r[a][v]).abs()).sum::<f64>())
        .sum();
    Ok(RadialFeatures {
        ed_frame: ed,
        es_frame: es,
        systolic_displacement,
        mean_velocity: total / (nv * pairs.len()) as f64 / dt,
        mean_radius,
    })
}

/// A triangle surface given by its positions (#V x 3, mm) and triangles (#F x 3 vertex ids).
pub type SurfaceRef<'a> = (&'a [[f64; 3]], &'a [[u32; 3]]);

/// Carries a template mesh (frame-0 positions #V x 3 of the template subject) to another
/// subject: the landmark thin-plate spline from the template's frame-0 landmarks to the
/// subject's (`lambda` its regularization), then, when `surface` is given (the subject's own
/// frame-0 surface, positions and triangles), each vertex moved to the closest point of that
/// surface. Returns the positions and whether the projection was kept: it is dropped (the
/// spline result returned) when it would flip a triangle of `topo` or shrink one below 5% of
/// its area.
pub fn carry_template(
    template: &[[f64; 3]],
    topo: &Topology,
    from: &[[f64; 3]],
    to: &[[f64; 3]],
    lambda: f64,
    surface: Option<SurfaceRef<'_>>,
) -> Result<(Pose, bool), LvAnalysisError> {
    let tps = Tps::fit(from, to, lambda)?;
    let warped = tps.apply_all(template);
    let Some((pos, faces)) = surface else {
        return Ok((warped, false));
    };
    if faces.is_empty() {
        return Err(LvAnalysisError::EmptySurface);
    }
    let snapped: Pose = warped
        .par_iter()
        .map(|&p| {
            let mut best = (f64::INFINITY, p);
            for f in faces {
                let q = closest_on_triangle(p, pos[f[0] as usize], pos[f[1] as usize], pos[f[2] as usize]);
                let d = geometry::norm(geometry::sub(q, p));
                if d < best.0 {
                    best = (d, q);
                }
            }
            best.1
        })
        .collect();
    let ok = keeps_triangles(topo, &warped, &snapped);
    Ok(if ok { (snapped, true) } else { (warped, false) })
}

/// Whether moving a mesh on `topo` from `before` to `after` (#V x 3 each) keeps every
/// triangle's orientation (normals with a positive dot product) and at least 5 % of its area:
/// the guard of every surface projection here ([`carry_template`],
/// [`super::refine::refine_to_image`]).
pub fn keeps_triangles(topo: &Topology, before: &[[f64; 3]], after: &[[f64; 3]]) -> bool {
    let (n0, n1) = (
        geometry::face_normals(topo, before),
        geometry::face_normals(topo, after),
    );
    let (a0, a1) = (
        geometry::face_areas(topo, before),
        geometry::face_areas(topo, after),
    );
    (0..n0.len()).all(|f| geometry::dot(n0[f], n1[f]) > 0.0 && a1[f] >= 0.05 * a0[f])
}

/// The point of triangle `abc` closest to `p` (Ericson, Real-Time Collision Detection 5.1.5).
pub fn closest_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    use geometry::{add, dot, scale, sub};
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return add(a, scale(ab, d1 / (d1 - d3)));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return add(a, scale(ac, d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return add(b, scale(sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = va + vb + vc;
    if denom.is_nan() || denom == 0.0 {
        return a;
    }
    let (v, w) = (vb / denom, vc / denom);
    add(a, add(scale(ab, v), scale(ac, w)))
}

/// The geodesic distances `dis(P_i, P_j)` between all poses of one sequence (each #V x 3,
/// already multiplied by the normalization factor; one solver for all pairs, pairs in
/// parallel). Returns the n x n matrix (row-major, zero diagonal) and whether every geodesic
/// converged; `on_pair` is called as each pair finishes; `cancel` stops early.
pub fn pose_distance_matrix(
    solver: &GeodesicSolver,
    poses: &[Pose],
    cancel: Option<&AtomicBool>,
    on_pair: &(dyn Fn() + Sync),
) -> Result<(Vec<f64>, bool), LvAnalysisError> {
    let n = poses.len();
    let pairs: Vec<(usize, usize)> = (0..n).flat_map(|i| (i + 1..n).map(move |j| (i, j))).collect();
    let results: Vec<(usize, usize, f64, bool)> = pairs
        .par_iter()
        .map(|&(i, j)| {
            if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return Err(LvAnalysisError::Cancelled);
            }
            let (d, ok) = if poses[i] == poses[j] {
                (0.0, true)
            } else {
                let g = solver
                    .solve(&poses[i], &poses[j])
                    .map_err(|error| LvAnalysisError::Geodesic { i, j, error })?;
                (g.length, g.converged)
            };
            on_pair();
            Ok((i, j, d, ok))
        })
        .collect::<Result<_, _>>()?;
    let mut m = vec![0.0; n * n];
    let mut converged = true;
    for (i, j, d, ok) in results {
        m[i * n + j] = d;
        m[j * n + i] = d;
        converged &= ok;
    }
    Ok((m, converged))
}

#[cfg(test)]
mod tests {
    use super::*;
    use qcshape::geodesic::GeodesicOptions;
    use qcshape::metric::{MetricKind, MetricSpec};
    use qcshape::synth::icosphere;

    /// An open cylinder of radius `r` about the z axis through (cx, cy), heights 0..h.
    fn cylinder(r: f64, h: f64, centre: (f64, f64), arc: f64) -> Pose {
        let mut p = Vec::new();
        for k in 0..6 {
            for a in 0..24 {
                let t = arc * a as f64 / 24.0;
                p.push([centre.0 + r * t.cos(), centre.1 + r * t.sin(), h * k as f64 / 5.0]);
            }
        }
        p
    }

    #[test]
    fn axis_fit_recovers_a_cylinder_axis_from_a_half_arc() {
        let pts = cylinder(20.0, 80.0, (3.0, -5.0), std::f64::consts::PI);
        let ax = Axis::fit(&pts).unwrap();
        assert!(ax.direction[2].abs() > 0.999, "{ax:?}");
        for p in &pts {
            assert!((ax.radius(*p) - 20.0).abs() < 1e-6, "{}", ax.radius(*p));
        }
        assert!(Axis::fit(&pts[..3]).is_err());
        assert!(Axis::through([0.0; 3], [0.0; 3]).is_err());
    }

    #[test]
    fn radial_features_of_a_known_contraction() {
        // 8 frames: radius 20 mm contracting to 14 mm at frame 3 and back (cosine), rigid axis.
        let radii: Vec<f64> = (0..8)
            .map(|t| {
                17.0 + 3.0
                    * (2.0 * std::f64::consts::PI * (t as f64 - 3.0) / 8.0 + std::f64::consts::PI).cos()
            })
            .collect();
        let poses: Vec<Pose> = radii
            .iter()
            .map(|&r| cylinder(r, 80.0, (0.0, 0.0), 3.0))
            .collect();
        let axis = Axis::through([0.0, 0.0, 0.0], [0.0, 0.0, 80.0]).unwrap();
        let f = radial_features(&poses, &axis, 1.0 / 8.0, true).unwrap();
        assert_eq!(f.es_frame, 3);
        assert_eq!(f.ed_frame, 7);
        assert!((f.systolic_displacement - 6.0).abs() < 1e-9, "{f:?}");
        let path: f64 = (0..8).map(|t| (radii[(t + 1) % 8] - radii[t]).abs()).sum();
        assert!((f.mean_velocity - path / 8.0 * 8.0).abs() < 1e-9, "{f:?}");
        // An open sequence leaves out the closing pair; the fitted axis gives the same answer.
        let open = radial_features(&poses, &axis, 1.0, false).unwrap();
        let path_open: f64 = (0..7).map(|t| (radii[t + 1] - radii[t]).abs()).sum();
        assert!((open.mean_velocity - path_open / 7.0).abs() < 1e-9);
        let fitted = Axis::fit(&poses[0]).unwrap();
        let g = radial_features(&poses, &fitted, 1.0 / 8.0, true).unwrap();
        assert!((g.systolic_displacement - 6.0).abs() < 1e-6, "{g:?}");
        assert!(radial_features(&poses[..1], &axis, 1.0, true).is_err());
        assert!(radial_features(&poses, &axis, 0.0, true).is_err());
    }

    #[test]
    fn closed_cycles_append_and_drop_frame_zero() {
        let poses: Vec<Pose> = (0..3).map(|k| vec![[k as f64, 0.0, 0.0]]).collect();
        let mut c = close_cycle(&poses);
        assert_eq!(c.len(), 4);
        assert_eq!(c[3], poses[0]);
        drop_closing_pose(&mut c);
        assert_eq!(c, poses);
    }

    #[test]
    fn closest_point_and_template_carrying() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let q = closest_on_triangle([0.2, 0.2, 5.0], a, b, c);
        assert!(geometry::norm(geometry::sub(q, [0.2, 0.2, 0.0])) < 1e-12, "{q:?}");
        assert_eq!(closest_on_triangle([-1.0, -1.0, 0.0], a, b, c), a);
        let q = closest_on_triangle([1.0, 1.0, 0.0], a, b, c);
        assert!((q[0] - 0.5).abs() < 1e-12 && (q[1] - 0.5).abs() < 1e-12);
        // A unit sphere carried by landmarks scaled x2 onto a radius-2.2 sphere lands on it.
        let s = icosphere(2);
        let lm: Vec<[f64; 3]> = s.positions.iter().step_by(17).copied().collect();
        let lm2: Vec<[f64; 3]> = lm.iter().map(|p| p.map(|c| 2.0 * c)).collect();
        let target: Vec<[f64; 3]> = s.positions.iter().map(|p| p.map(|c| 2.2 * c)).collect();
        let (p, snapped) = carry_template(
            &s.positions,
            &s.topology,
            &lm,
            &lm2,
            0.0,
            Some((&target, s.topology.faces())),
        )
        .unwrap();
        assert!(snapped);
        for x in &p {
            let r = geometry::norm(*x);
            assert!(r > 2.15 && r <= 2.2 + 1e-9, "{r}");
        }
        let (w, snapped) = carry_template(&s.positions, &s.topology, &lm, &lm2, 0.0, None).unwrap();
        assert!(!snapped);
        assert!((geometry::norm(w[5]) - 2.0).abs() < 1e-6);
    }

    #[test]
    fn pose_distances_are_symmetric_and_grow_with_the_deformation() {
        let s = icosphere(1);
        let poses: Vec<Pose> = (0..3)
            .map(|k| {
                s.positions
                    .iter()
                    .map(|p| [p[0] * (1.0 + 0.2 * k as f64), p[1], p[2]])
                    .collect()
            })
            .collect();
        let metric =
            MetricSpec::previous(MetricKind::QuasiConformal).build(&qcshape::metric::Calibration::RAW);
        let solver = GeodesicSolver::new(
            metric.as_ref(),
            s.topology.clone(),
            GeodesicOptions {
                steps: 2,
                ..Default::default()
            },
        )
        .unwrap();
        let (m, _) = pose_distance_matrix(&solver, &poses, None, &|| {}).unwrap();
        assert_eq!(m[0], 0.0);
        assert_eq!(m[1], m[3]);
        assert!(m[2] > m[1] && m[1] > 0.0, "{m:?}");
    }
}
