//! The tangent-space approximation of the pose distances ([`super::Approx::Tangent`]):
//! `dis(M_k, N_k) ~ |y(M_k) - y(N_k)|` with one feature vector `y(P)` per pose, a fixed linear
//! map of the displacement `P - B` from the common base `B` such that `|y(P) - y(Q)|^2` is the
//! metric's squared norm `G_B(P - Q)` at the base (docs/method.md "Metrics"). The metric is
//! linearized once at the base: one sparse product per pose (O(N) work for N deformations) and
//! then one Euclidean distance of two feature vectors per pair and pose, instead of a geodesic.
//!
//! - Metrics whose squared norm is quadratic in the displacement at a fixed geometry (l2,
//!   isometric, conformal, with or without the L2 regularizer): `G_B(X) = |J_X X|^2` with `J_X`
//!   the Jacobian of the residuals with respect to the displacement at `B`, and
//!   `y(P) = J_X (P - B)`.
//! - Metrics with auxiliary unknowns (rigid, each reading, with or without the regularizer):
//!   the residuals at a fixed geometry are `r(X, aux) = J_X X + J_aux aux`, linear in the
//!   displacement and in the motion `aux` (6 values; exactly linear for the rigid metrics, so
//!   linearizing at `aux = 0`, the best motion of a zero displacement, loses nothing), and
//!   `G_B(X) = min_aux |r|^2`. The optimal motion leaves the residual
//!   `y = (I - J_aux (J_aux^T J_aux)^+ J_aux^T) J_X X`: `J_X X` minus its orthogonal
//!   projection onto the range of `J_aux`, again a fixed linear map of `X`, so
//!   `|y(P) - y(Q)|^2 = G_B(P - Q)` exactly as for the other metrics. The projection is built
//!   once from the eigen-decomposition of the (column-scaled) normal matrix
//!   `J_aux^T J_aux` ([`AuxProjection`]); directions with an eigenvalue below
//!   [`AUX_RANK_TOLERANCE`] times the largest (a degenerate base: collinear or zero-area) are
//!   left out, the pseudo-inverse, never a division by zero.
//! - The quasi-conformal metric with `endpoints` weights and the quadratic form (the default):
//!   its residuals are `w_v T_v`, a weight of the pair `(M_k, N_k)` (the normalized curvature
//!   change `K(N_k) - K(M_k)`, [`Metric::frozen_weights`]) times a conformal term. The terms
//!   are linearized once at the base with unit weights ([`Metric::unit_frozen`]), and each
//!   pair weighs the difference of its two feature vectors by its own weights
//!   ([`Metric::residual_factors`]): `|f(M_k, N_k) * (y(M_k) - y(N_k))|`, O(#V) per pair and
//!   pose, still no geodesic. The weights are those the exact geodesic of the pair would use;
//!   only the geometry of the terms is the base's.
//! - The paper form and the `segment` weights of the quasi-conformal metric do not factor
//!   that way and are refused ([`check_metric`]).

use rayon::prelude::*;

use super::error::SimilarityError;
use super::types::Pose;
use crate::geodesic::dot;
use crate::mesh::Topology;
use crate::metric::{At, Jacobian, Metric, Segment};

/// Relative eigenvalue threshold of the column-scaled normal matrix `J_aux^T J_aux`
/// ([`AuxProjection`]): directions of the auxiliary unknowns whose eigenvalue is below this
/// times the largest are treated as absent (pseudo-inverse).
pub const AUX_RANK_TOLERANCE: f64 = 1e-10;

/// Checks that the tangent approximation applies to `metric` at `base` (#V x 3 on `topo`) and
/// says whether each pair weighs its features ([`Metric::residual_factors`]: `true` for the
/// quasi-conformal metric with `endpoints` weights and the quadratic form). Refuses the
/// quasi-conformal metrics whose weights do not enter as residual factors (the paper form,
/// the `segment` weights); every other metric (l2, rigid, isometric, conformal, each with or
/// without the L2 regularizer) is accepted without pair weights.
pub fn check_metric(
    metric: &dyn Metric,
    topo: &Topology,
    base: &[[f64; 3]],
) -> Result<bool, SimilarityError> {
    let weighted = metric
        .frozen_weights(topo, base, base)
        .and_then(|f| metric.residual_factors(topo, &metric.unit_frozen(topo, f)))
        .is_some();
    let name = metric.name();
    if name.contains("quasi-conformal") && !weighted {
        return Err(SimilarityError::NotTangent {
            metric: name.to_string(),
        });
    }
    Ok(weighted)
}

/// The orthogonal projection onto the range of the auxiliary unknowns' Jacobian `J_aux`
/// (#residuals x n_aux) as an orthonormal basis of that range: `z - sum_k q_k (q_k . z)` is
/// `(I - J_aux (J_aux^T J_aux)^+ J_aux^T) z`.
#[derive(Debug, Clone, Default)]
pub struct AuxProjection {
    /// Orthonormal basis vectors (each #residuals values) of the range of `J_aux`.
    pub basis: Vec<Vec<f64>>,
}

impl AuxProjection {
    /// The projection for `daux` (#residuals x `n_aux`, row-major, as [`Jacobian::daux`]).
    ///
    /// Forms the normal matrix `N = J_aux^T J_aux`, scales it to unit diagonal
    /// (`D^-1 N D^-1`, `D` the column norms, so translations and rotations weigh alike
    /// whatever the units), and diagonalizes it (faer's self-adjoint eigen-decomposition: `V Lambda V^T`). Each
    /// eigenpair with `lambda_k > AUX_RANK_TOLERANCE * lambda_max` gives the basis vector
    /// `q_k = J_aux D^-1 v_k / sqrt(lambda_k)`; zero columns and the other eigenpairs are left
    /// out (the pseudo-inverse of a singular `N`). Errors when `daux` is not finite or its
    /// length is not a multiple of `n_aux`.
    pub fn new(daux: &[f64], n_aux: usize) -> Result<Self, SimilarityError> {
        if n_aux == 0 {
            return Ok(AuxProjection::default());
        }
        if !daux.len().is_multiple_of(n_aux) {
            return Err(SimilarityError::AuxJacobian {
                values: daux.len(),
                n_aux,
            });
        }
        if daux.iter().any(|v| !v.is_finite()) {
            return Err(SimilarityError::AuxNotFinite);
        }
        let rows = daux.len() / n_aux;
        // The upper triangle of N (what the eigen-decomposition reads), scaled to unit diagonal.
        let mut n = faer::Mat::<f64>::zeros(n_aux, n_aux);
        for row in daux.chunks_exact(n_aux) {
            for i in 0..n_aux {
                for j in i..n_aux {
                    n[(i, j)] += row[i] * row[j];
                }
            }
        }
        let scale: Vec<f64> = (0..n_aux)
            .map(|i| {
                if n[(i, i)] > 0.0 {
                    1.0 / n[(i, i)].sqrt()
                } else {
                    0.0
                }
            })
            .collect();
        for i in 0..n_aux {
            for j in i..n_aux {
                n[(i, j)] *= scale[i] * scale[j];
            }
        }
        // faer's EvdError has one variant, NoConvergence, and no std::error::Error impl.
        let evd = n
            .self_adjoint_eigen(faer::Side::Upper)
            .map_err(|_| SimilarityError::AuxEigen)?;
        let (lambda, v) = (evd.S().column_vector(), evd.U());
        let lambda: Vec<f64> = (0..n_aux).map(|k| lambda[k]).collect();
        let max = lambda.iter().copied().fold(0.0, f64::max);
        let mut basis = Vec::new();
        for (k, &l) in lambda.iter().enumerate() {
            if !(l > AUX_RANK_TOLERANCE * max && l > 0.0) {
                continue;
            }
            // Coefficients of q_k on the columns of J_aux: D^-1 v_k / sqrt(lambda_k).
            let c: Vec<f64> = (0..n_aux).map(|i| scale[i] * v[(i, k)] / l.sqrt()).collect();
            let q: Vec<f64> = daux
                .chunks_exact(n_aux)
                .map(|row| row.iter().zip(&c).map(|(a, b)| a * b).sum())
                .collect();
            debug_assert_eq!(q.len(), rows);
            basis.push(q);
        }
        // One pass of Gram-Schmidt against the earlier vectors and renormalization removes the
        // rounding of the eigenvectors (the basis is orthonormal in exact arithmetic).
        let mut ortho: Vec<Vec<f64>> = Vec::with_capacity(basis.len());
        for mut q in basis {
            for p in &ortho {
                let d = dot(p, &q);
                q.iter_mut().zip(p).for_each(|(x, y)| *x -= d * y);
            }
            let norm = dot(&q, &q).sqrt();
            if norm > 0.5 && norm.is_finite() {
                q.iter_mut().for_each(|x| *x /= norm);
                ortho.push(q);
            }
        }
        Ok(AuxProjection { basis: ortho })
    }

    /// Replaces `z` (#residuals) by `z` minus its orthogonal projection onto the range of
    /// `J_aux` (nothing when the range is empty).
    pub fn remove_from(&self, z: &mut [f64]) {
        for q in &self.basis {
            let d = dot(q, z);
            z.iter_mut().zip(q).for_each(|(x, y)| *x -= d * y);
        }
    }
}

/// The feature vector `y(P)` of every pose (each #V x 3 on `topo`, in the same normalized
/// units as `base`): `J_X (P - B)`, minus its projection onto the range of the auxiliary
/// unknowns' Jacobian when the metric has any (see the module docs); #residuals values per
/// pose, one vector per pose in order. `|y(P) - y(Q)|^2` is `G_B(P - Q)`, the metric's squared
/// norm at the base with the optimal auxiliary unknowns.
pub fn features(
    metric: &dyn Metric,
    topo: &Topology,
    base: &[[f64; 3]],
    poses: &[&[[f64; 3]]],
) -> Result<Vec<Vec<f64>>, SimilarityError> {
    check_metric(metric, topo, base)?;
    let pattern = metric.pattern(topo);
    // Unit weights where the residuals carry pair factors (applied per pair by
    // [`TangentModel::pose_distances`]); the base's own frozen values elsewhere.
    let frozen = metric
        .frozen_weights(topo, base, base)
        .map(|f| metric.unit_frozen(topo, f));
    let n_aux = metric.n_aux();
    // The linearization point of the auxiliary unknowns: zero, the best motion of a zero
    // displacement (the rigid residuals are linear in them, so any value gives the same
    // Jacobians).
    let aux = vec![0.0; n_aux];
    let seg = Segment {
        a: base,
        b: base,
        at: At::Start,
        aux: &aux,
        frozen: frozen.as_deref(),
    };
    let mut r = vec![0.0; pattern.n_residuals()];
    let mut jac = Jacobian::zeros(&pattern, n_aux);
    metric.residuals(topo, pattern.as_ref(), &seg, &mut r, Some(jac.as_mut()));
    let projection = AuxProjection::new(&jac.daux, n_aux)?;
    // With the geometry at `a`, `b` enters only through X = b - a: dr/db = dr/dX.
    let db = &jac.db;
    Ok(poses
        .par_iter()
        .map(|p| {
            let mut z: Vec<f64> = (0..pattern.n_residuals())
                .map(|i| {
                    pattern
                        .row(i)
                        .map(|k| {
                            let v = pattern.vertices[k] as usize;
                            let x = [p[v][0] - base[v][0], p[v][1] - base[v][1], p[v][2] - base[v][2]];
                            db[k][0] * x[0] + db[k][1] * x[1] + db[k][2] * x[2]
                        })
                        .sum()
                })
                .collect();
            projection.remove_from(&mut z);
            z
        })
        .collect())
}

/// The features of every pose of every deformation (n x K, each #residuals values), linearized
/// at `deformations[0][0]` (the common base after transfer).
pub fn deformation_features(
    metric: &dyn Metric,
    topo: &Topology,
    deformations: &[Vec<Pose>],
) -> Result<Vec<Vec<Vec<f64>>>, SimilarityError> {
    let Some(base) = deformations.first().and_then(|d| d.first()) else {
        return Ok(Vec::new());
    };
    let flat: Vec<&[[f64; 3]]> = deformations.iter().flatten().map(|p| p.as_slice()).collect();
    let mut all = features(metric, topo, base, &flat)?.into_iter();
    Ok(deformations
        .iter()
        .map(|d| all.by_ref().take(d.len()).collect())
        .collect())
}

/// What the tangent approximation keeps of a data set: the features of every pose
/// ([`deformation_features`]) and whether each pair weighs them by its own frozen weights
/// ([`check_metric`]: the quasi-conformal metric's residual factors).
#[derive(Debug, Clone)]
pub struct TangentModel {
    /// `y(P)` per deformation and pose (n x K, each #residuals values).
    pub features: Vec<Vec<Vec<f64>>>,
    /// Whether the metric's residuals carry pair factors ([`Metric::residual_factors`]).
    pub weighted: bool,
}

impl TangentModel {
    /// The model of `deformations` (n x K poses, each #V x 3 on `topo`), linearized at
    /// `deformations[0][0]`.
    pub fn new(
        metric: &dyn Metric,
        topo: &Topology,
        deformations: &[Vec<Pose>],
    ) -> Result<Self, SimilarityError> {
        let weighted = match deformations.first().and_then(|d| d.first()) {
            Some(base) => check_metric(metric, topo, base)?,
            None => false,
        };
        let features = deformation_features(metric, topo, deformations)?;
        Ok(TangentModel { features, weighted })
    }

    /// The approximate pose distances of deformations `i` and `j` (K values): `|y - z|`, or,
    /// with pair factors, `|f * (y - z)|` with `f` the residual factors of the frozen weights
    /// of the pair of poses (the weights the exact geodesic from pose `k` of `i` to pose `k` of
    /// `j` uses), computed from the two deformations' [`Metric::pose_summary`] per pose when
    /// `summaries` holds them.
    pub fn pose_distances(
        &self,
        metric: &dyn Metric,
        topo: &Topology,
        deformations: &[Vec<Pose>],
        i: usize,
        j: usize,
        summaries: Option<[&[Vec<f64>]; 2]>,
    ) -> Vec<f64> {
        let (yi, yj) = (&self.features[i], &self.features[j]);
        if !self.weighted {
            return yi.iter().zip(yj).map(|(a, b)| distance(a, b)).collect();
        }
        (0..yi.len())
            .map(|k| {
                let (p, q) = (&deformations[i][k], &deformations[j][k]);
                let w = match summaries {
                    Some([a, b]) => metric.frozen_weights_from(topo, p, q, [&a[k], &b[k]]),
                    None => metric.frozen_weights(topo, p, q),
                };
                match w.and_then(|w| metric.residual_factors(topo, &w)) {
                    Some(f) => weighted_distance(&yi[k], &yj[k], &f),
                    None => distance(&yi[k], &yj[k]),
                }
            })
            .collect()
    }
}

/// `|y - z|`, summed in order.
pub fn distance(y: &[f64], z: &[f64]) -> f64 {
    y.iter()
        .zip(z)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt()
}

/// `|f * (y - z)|` (element-wise product), summed in order.
pub fn weighted_distance(y: &[f64], z: &[f64], f: &[f64]) -> f64 {
    y.iter()
        .zip(z)
        .zip(f)
        .map(|((a, b), w)| (w * (a - b)) * (w * (a - b)))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{Calibration, MetricKind, MetricSpec};

    /// Two small non-rigid displacements of the icosphere(1) base `v`.
    fn poses(v: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let p = v
            .iter()
            .map(|x| [x[0] * 1.01, x[1] + 0.01 * x[2], x[2]])
            .collect();
        let q = v
            .iter()
            .map(|x| [x[0], x[1] * 0.99, x[2] + 0.02 * x[0]])
            .collect();
        (p, q)
    }

    /// `G_B(X)` with the geometry (and the frozen weights) of the base `b` and the optimal
    /// auxiliary unknowns ([`Metric::squared_norm`] goes through [`Metric::best_aux`]).
    fn norm_at_base(m: &dyn Metric, topo: &Topology, b: &[[f64; 3]], x: &[[f64; 3]]) -> f64 {
        let moved: Vec<[f64; 3]> = b
            .iter()
            .zip(x)
            .map(|(p, d)| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
            .collect();
        let frozen = m.frozen_weights(topo, b, b);
        let seg = Segment {
            a: b,
            b: &moved,
            at: At::Start,
            aux: &[],
            frozen: frozen.as_deref(),
        };
        m.squared_norm(topo, &m.pattern(topo), &seg)
    }

    fn minus(p: &[[f64; 3]], q: &[[f64; 3]]) -> Vec<[f64; 3]> {
        p.iter()
            .zip(q)
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
            .collect()
    }

    #[test]
    fn features_give_the_metric_norm_at_the_base() {
        let s = crate::synth::icosphere(1);
        let (topo, v) = (s.topology.clone(), s.positions.clone());
        let (p, q) = poses(&v);
        // Every metric but the quasi-conformal one, whose raw weights have no features.
        for kind in MetricKind::ALL
            .into_iter()
            .filter(|k| *k != MetricKind::QuasiConformal)
        {
            let m = MetricSpec::previous(kind).build(&Calibration::RAW);
            let y = features(m.as_ref(), &topo, &v, &[&p, &q, &v]).unwrap();
            assert!(y[2].iter().all(|x| *x == 0.0), "the base itself is the origin");
            // |y(P) - y(B)|^2 is G_B(P - B) up to the linearization (exact for quadratic norms).
            let pat = m.pattern(&topo);
            let frozen = m.frozen_weights(&topo, &v, &p);
            let g = m.squared_norm(
                &topo,
                &pat,
                &Segment {
                    a: &v,
                    b: &p,
                    at: At::Start,
                    aux: &[],
                    frozen: frozen.as_deref(),
                },
            );
            let d = distance(&y[0], &y[2]).powi(2);
            assert!((d - g).abs() <= 0.05 * g, "{kind:?}: {d} vs {g}");
            assert!(distance(&y[0], &y[1]) > 0.0);
        }
    }

    /// The quasi-conformal metric (quadratic form, endpoint weights; raw and calibrated): each
    /// pair weighs the unit-weight features by its own curvature-change weights, which gives
    /// the metric's squared norm of `Q - P` at the base's geometry with the pair's weights
    /// (and the base's regularizer areas). The paper form and the segment weights are refused.
    #[test]
    fn quasi_conformal_pairs_weigh_the_features_by_their_own_weights() {
        let s = crate::synth::icosphere(1);
        let (topo, v) = (s.topology.clone(), s.positions.clone());
        let nv = topo.n_vertices();
        let (p, q) = poses(&v);
        // Without the bending term the metric is a quadratic form in the displacement and the
        // features give its squared norm exactly; the bending term enters the features through
        // its linearization at the base (the angles' gradients), against the change of the
        // angles from the base to the base + (Q - P) in the reference: equal to second order.
        for (spec, tolerance) in [
            (MetricSpec::previous(MetricKind::QuasiConformal), 1e-9),
            (
                MetricSpec {
                    bending: 0.0,
                    ..MetricSpec::new(MetricKind::QuasiConformal)
                },
                1e-9,
            ),
            (MetricSpec::new(MetricKind::QuasiConformal), 1e-3),
        ] {
            let m = spec.build_for(&topo, &[&v]).unwrap();
            assert!(check_metric(m.as_ref(), &topo, &v).unwrap(), "{}", m.name());
            let defs = vec![vec![v.clone(), p.clone()], vec![v.clone(), q.clone()]];
            let model = TangentModel::new(m.as_ref(), &topo, &defs).unwrap();
            let d = model.pose_distances(m.as_ref(), &topo, &defs, 0, 1, None);
            // The same weights from the poses' cached summaries (as the engine passes them).
            let s: Vec<Vec<Vec<f64>>> = defs
                .iter()
                .map(|d| d.iter().map(|p| m.pose_summary(&topo, p).unwrap()).collect())
                .collect();
            let cached = model.pose_distances(m.as_ref(), &topo, &defs, 0, 1, Some([&s[0], &s[1]]));
            assert_eq!(d, cached);
            assert_eq!(d[0], 0.0, "both start at the base");
            // The reference: G at the base's geometry, displacement Q - P, the pair's QC
            // weights (the first #V frozen values) and the base's L2 areas (the last #V).
            // On the invariant scale the QC weights follow the face shares (2 #F values).
            let off = if spec.scale == crate::metric::MetricScale::Invariant {
                2 * topo.n_faces()
            } else {
                0
            };
            let pair = m.frozen_weights(&topo, &p, &q).unwrap();
            let mut frozen = m.frozen_weights(&topo, &v, &v).unwrap();
            frozen[off..off + nv].copy_from_slice(&pair[off..off + nv]);
            let moved: Vec<[f64; 3]> = v
                .iter()
                .zip(minus(&q, &p))
                .map(|(b, x)| [b[0] + x[0], b[1] + x[1], b[2] + x[2]])
                .collect();
            let g = m.squared_norm(
                &topo,
                &m.pattern(&topo),
                &Segment {
                    a: &v,
                    b: &moved,
                    at: At::Start,
                    aux: &[],
                    frozen: Some(&frozen),
                },
            );
            assert!(g > 0.0);
            let rel = (d[1] * d[1] - g).abs() / g;
            assert!(rel < tolerance, "{}: {} vs {g} ({rel:e})", m.name(), d[1] * d[1]);
            // The weights matter: the unweighted feature distance is another number.
            let plain = distance(&model.features[0][1], &model.features[1][1]);
            assert!((plain - d[1]).abs() > 1e-3 * d[1], "{plain} vs {}", d[1]);
        }
        // Refused: the paper form and the segment weights (calibrated names carry a factor).
        for spec in [
            MetricSpec {
                form: crate::metric::ConformalForm::Paper,
                ..MetricSpec::calibrated(MetricKind::QuasiConformal)
            },
            MetricSpec {
                weights: crate::metric::QcWeights::Segment,
                ..MetricSpec::previous(MetricKind::QuasiConformal)
            },
        ] {
            let m = spec.build_for(&topo, &[&v]).unwrap();
            let e = features(m.as_ref(), &topo, &v, &[&p]).unwrap_err().to_string();
            assert!(e.contains("straight") && e.contains("endpoint"), "{e}");
        }
    }

    /// The rigid metric at the library defaults (frozen areas, calibrated, regularized), the
    /// previous spec (raw, lambda 0.1), the per-pose areas and without the regularizer.
    fn rigid_specs() -> Vec<MetricSpec> {
        let mut pose_areas = MetricSpec::previous(MetricKind::Rigid);
        pose_areas.frozen_areas = false;
        let mut bare = MetricSpec::new(MetricKind::Rigid);
        bare.lambda = 0.0;
        let mut bare_pose = pose_areas;
        bare_pose.lambda = 0.0;
        vec![
            MetricSpec::new(MetricKind::Rigid),
            MetricSpec::previous(MetricKind::Rigid),
            pose_areas,
            bare,
            bare_pose,
        ]
    }

    #[test]
    fn rigid_features_give_the_norm_with_the_optimal_motion_exactly() {
        use rand::{Rng, SeedableRng};
        let s = crate::synth::icosphere(1);
        let topo = s.topology.clone();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        // A base off the origin and not a round sphere (t and w are coupled).
        let v: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|x| [1.3 * x[0] + 2.0, x[1] - 1.0, 0.8 * x[2] + 0.5])
            .collect();
        let mut random = |scale: f64| -> Vec<[f64; 3]> {
            v.iter()
                .map(|x| x.map(|c| c + scale * (rng.random::<f64>() - 0.5)))
                .collect()
        };
        let (p, q) = (random(0.02), random(0.02));
        for spec in rigid_specs() {
            let m = spec.build_for(&topo, &[&v]).unwrap();
            assert_eq!(m.n_aux(), 6, "{}", m.name());
            let y = features(m.as_ref(), &topo, &v, &[&p, &q]).unwrap();
            assert!(y.iter().flatten().all(|x| x.is_finite()));
            let d = distance(&y[0], &y[1]).powi(2);
            let g = norm_at_base(m.as_ref(), &topo, &v, &minus(&p, &q));
            assert!(g > 0.0);
            assert!((d - g).abs() <= 1e-9 * g, "{}: {d} vs {g}", m.name());
            // Below the norm without the motion (the same residuals at aux = 0).
            let pat = m.pattern(&topo);
            let moved: Vec<[f64; 3]> = v
                .iter()
                .zip(minus(&p, &q))
                .map(|(b, x)| [b[0] + x[0], b[1] + x[1], b[2] + x[2]])
                .collect();
            let frozen = m.frozen_weights(&topo, &v, &v);
            let aux = [0.0; 6];
            let mut r = vec![0.0; pat.n_residuals()];
            let seg = Segment {
                a: &v,
                b: &moved,
                at: At::Start,
                aux: &aux,
                frozen: frozen.as_deref(),
            };
            m.residuals(&topo, pat.as_ref(), &seg, &mut r, None);
            let g0: f64 = r.iter().map(|x| x * x).sum();
            assert!(d < g0, "{}: {d} vs {g0} without the motion", m.name());
        }
    }

    #[test]
    fn rigid_motions_of_the_base_have_zero_features() {
        let s = crate::synth::icosphere(1);
        let topo = s.topology.clone();
        let v: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|x| [1.3 * x[0] + 2.0, x[1] - 1.0, 0.8 * x[2] + 0.5])
            .collect();
        let (t, axis, angle) = ([0.01, -0.02, 0.015], [0.36, 0.48, 0.8], 1e-3_f64);
        // The finite rotation by `angle` about the unit `axis` (Rodrigues), plus `t`.
        let rotated: Vec<[f64; 3]> = v
            .iter()
            .map(|x| {
                let (c, s) = (angle.cos(), angle.sin());
                let k = axis;
                let kx = [
                    k[1] * x[2] - k[2] * x[1],
                    k[2] * x[0] - k[0] * x[2],
                    k[0] * x[1] - k[1] * x[0],
                ];
                let kd = k[0] * x[0] + k[1] * x[1] + k[2] * x[2];
                [0, 1, 2].map(|i| x[i] * c + kx[i] * s + k[i] * kd * (1.0 - c) + t[i])
            })
            .collect();
        // The infinitesimal motion t + w x v with w = angle * axis (exactly rigid for the metric).
        let w = axis.map(|a| a * angle);
        let infinitesimal: Vec<[f64; 3]> = v
            .iter()
            .map(|x| {
                let wx = [
                    w[1] * x[2] - w[2] * x[1],
                    w[2] * x[0] - w[0] * x[2],
                    w[0] * x[1] - w[1] * x[0],
                ];
                [0, 1, 2].map(|i| x[i] + t[i] + wx[i])
            })
            .collect();
        // A non-rigid displacement of the same size (root mean square per vertex).
        let rms = |p: &[[f64; 3]]| {
            (minus(p, &v)
                .iter()
                .map(|d| d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
                .sum::<f64>()
                / v.len() as f64)
                .sqrt()
        };
        let shear: Vec<[f64; 3]> = v.iter().map(|x| [x[0] + (x[1] + 1.0), x[1], x[2]]).collect();
        let f = rms(&rotated) / rms(&shear);
        let nonrigid: Vec<[f64; 3]> = v
            .iter()
            .zip(&shear)
            .map(|(b, s)| [0, 1, 2].map(|i| b[i] + f * (s[i] - b[i])))
            .collect();
        assert!((rms(&nonrigid) / rms(&rotated) - 1.0).abs() < 1e-12);
        for spec in rigid_specs() {
            let m = spec.build_for(&topo, &[&v]).unwrap();
            let y = features(m.as_ref(), &topo, &v, &[&rotated, &infinitesimal, &nonrigid, &v]).unwrap();
            let norm = |y: &[f64]| dot(y, y).sqrt();
            let (yr, yi, yn) = (norm(&y[0]), norm(&y[1]), norm(&y[2]));
            assert!(yn > 0.0);
            if spec.lambda == 0.0 {
                // The rigid metric alone vanishes on infinitesimal motions, and a finite
                // rotation leaves only its second-order part (about angle / 2 of the motion).
                assert!(yi <= 1e-10 * yn, "{}: {yi} vs {yn}", m.name());
                assert!(yr <= 2.0 * angle * yn, "{}: {yr} vs {yn}", m.name());
            } else {
                // The L2 regularizer sees the motion: its part alone remains.
                let mut bare = spec;
                bare.lambda = 0.0;
                let mb = bare.build_for(&topo, &[&v]).unwrap();
                let yb = features(mb.as_ref(), &topo, &v, &[&infinitesimal]).unwrap();
                assert!(norm(&yb[0]) <= 1e-10 * yn, "{}", mb.name());
                let g = norm_at_base(m.as_ref(), &topo, &v, &minus(&infinitesimal, &v));
                assert!(
                    (yi * yi - g).abs() <= 1e-9 * g,
                    "{}: {} vs {g}",
                    m.name(),
                    yi * yi
                );
                assert!(yi < yn, "{}: {yi} vs {yn}", m.name());
            }
        }
    }

    #[test]
    fn the_aux_projection_is_a_pseudo_inverse_for_a_degenerate_base() {
        // Collinear points: the rotation about the line is absent; zero area: nothing at all.
        let s = crate::synth::icosphere(1);
        let line: Vec<[f64; 3]> = s.positions.iter().map(|p| [p[0], 0.0, 0.0]).collect();
        let (p, _) = poses(&s.positions);
        for spec in rigid_specs() {
            let m = spec.build(&Calibration::RAW);
            let y = features(m.as_ref(), &s.topology, &line, &[&p]).unwrap();
            assert!(y[0].iter().all(|x| x.is_finite()), "{}", m.name());
        }
        // Two equal columns and a zero column: rank 1, orthonormal basis, no NaN.
        let daux: Vec<f64> = (0..10).flat_map(|i| [i as f64, i as f64, 0.0]).collect();
        let proj = AuxProjection::new(&daux, 3).unwrap();
        assert_eq!(proj.basis.len(), 1);
        let mut z: Vec<f64> = (0..10).map(|i| i as f64).collect();
        proj.remove_from(&mut z);
        assert!(z.iter().all(|x| x.abs() < 1e-12), "{z:?}");
        assert!(AuxProjection::new(&[f64::NAN; 6], 6).is_err());
        assert!(AuxProjection::new(&[1.0; 7], 6).is_err());
    }
}
