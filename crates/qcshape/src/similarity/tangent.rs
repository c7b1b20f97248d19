//! The tangent-space approximation of the pose distances ([`super::Approx::Tangent`]):
//! `dis(M_k, N_k) ~ |J_B (M_k - N_k)| = |y(M_k) - y(N_k)|` with `J_B` the Jacobian of the
//! metric's residuals with respect to the displacement at the common base `B` (the squared norm
//! `G_B(X) = |J_B X|^2`, METHOD.md "Metrics"), and `y(P) = J_B (P - B)` one feature vector per
//! pose. The metric is linearized once at the base: one sparse product per pose (O(N) work for N
//! deformations) and then one Euclidean distance of two feature vectors per pair and pose,
//! instead of a geodesic. For metrics whose squared norm is quadratic in the displacement at a
//! fixed geometry (l2, isometric, conformal, with or without the L2 regularizer); the
//! quasi-conformal weights `K(N_k) - K(M_k)` depend on both poses of a pair, and the rigid metric
//! has auxiliary unknowns, so both are refused.

use rayon::prelude::*;

use super::engine::{Pose, SimilarityError};
use crate::mesh::Topology;
use crate::metric::{At, Jacobian, Metric, Segment};

/// Refuses metrics the tangent approximation does not apply to (see the module docs).
pub fn check_metric(metric: &dyn Metric) -> Result<(), SimilarityError> {
    let name = metric.name();
    if name.starts_with("quasi-conformal") || metric.n_aux() > 0 {
        return Err(SimilarityError::Mismatch(format!(
            "the tangent approximation needs a metric whose squared norm is quadratic in the displacement \
             (l2, isometric, conformal); {name} is not (use --approx straight)"
        )));
    }
    Ok(())
}

/// The feature vector `y(P) = J_B (P - B)` of every pose (each #V x 3 on `topo`, in the same
/// normalized units as `base`): #residuals values per pose, one vector per pose in order.
pub fn features(
    metric: &dyn Metric,
    topo: &Topology,
    base: &[[f64; 3]],
    poses: &[&[[f64; 3]]],
) -> Result<Vec<Vec<f64>>, SimilarityError> {
    check_metric(metric)?;
    let pattern = metric.pattern(topo);
    let frozen = metric.frozen_weights(topo, base, base);
    let seg = Segment {
        a: base,
        b: base,
        at: At::Start,
        aux: &[],
        frozen: frozen.as_deref(),
    };
    let mut r = vec![0.0; pattern.n_residuals()];
    let mut jac = Jacobian::zeros(&pattern, 0);
    metric.residuals(topo, pattern.as_ref(), &seg, &mut r, Some(jac.as_mut()));
    // With the geometry at `a`, `b` enters only through X = b - a: dr/db = dr/dX.
    let db = &jac.db;
    Ok(poses
        .par_iter()
        .map(|p| {
            (0..pattern.n_residuals())
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
                .collect()
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

/// `|y - z|`, summed in order.
pub fn distance(y: &[f64], z: &[f64]) -> f64 {
    y.iter()
        .zip(z)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{MetricKind, MetricSpec};

    #[test]
    fn features_give_the_metric_norm_at_the_base_and_quasi_conformal_is_refused() {
        let s = crate::synth::icosphere(1);
        let (topo, v) = (s.topology.clone(), s.positions.clone());
        let p: Vec<[f64; 3]> = v
            .iter()
            .map(|x| [x[0] * 1.01, x[1] + 0.01 * x[2], x[2]])
            .collect();
        let q: Vec<[f64; 3]> = v
            .iter()
            .map(|x| [x[0], x[1] * 0.99, x[2] + 0.02 * x[0]])
            .collect();
        for kind in [MetricKind::L2, MetricKind::Isometric, MetricKind::Conformal] {
            let m = MetricSpec::previous(kind).build(&crate::metric::Calibration::RAW);
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
        for kind in [MetricKind::QuasiConformal, MetricKind::Rigid] {
            let m = MetricSpec::previous(kind).build(&crate::metric::Calibration::RAW);
            let e = features(m.as_ref(), &topo, &v, &[&p]).unwrap_err().to_string();
            assert!(e.contains("straight"), "{e}");
        }
    }
}
