//! Where two shapes or deformations differ: the per-vertex split of a path's energy, of its
//! length, and of the similarity of two deformations (eq. 13) (docs/maps.md).
//!
//! Every metric is a sum of squared residuals, `G_M(X) = sum_i r_i^2` (module
//! [`qcshape::metric`]), and each residual belongs to one mesh element: a face (L2, rigid,
//! conformal and quasi-conformal terms), an edge (isometric) or a vertex (frozen-area L2 and
//! rigid). [`Metric::support`] names that element. The contribution of vertex `v` to a term is
//! `c_v = sum over residuals i whose element holds v of r_i^2 / |element_i|`: a face term is
//! shared equally by its 3 corners, an edge term by its 2 ends, a vertex term goes to its
//! vertex. So `sum_v c_v = G_M(X)` exactly (up to rounding).
//!
//! For a path `P_0 .. P_N` (eq. 12) the energy contribution of segment `i` is
//! `e_{i,v} = c_v(G_{P_i}(X_i)) + c_v(G_{P_{i+1}}(X_i))` (#V, sums to the segment's energy
//! `E_i`), the energy contribution of the path is `e_v = sum_i e_{i,v}` (sums to the path
//! energy). The length `L = sum_i sqrt(E_i / 2)` is not a sum over residuals, so each
//! segment's length is split in proportion to its energy split:
//! `l_{i,v} = sqrt(E_i / 2) * e_{i,v} / E_i` (0 where `E_i = 0`), `l_v = sum_i l_{i,v}`. Then
//! `sum_v l_{i,v}` is the segment length and `sum_v l_v = L = dis(A, B)`. Auxiliary unknowns
//! (the rigid motion) are taken at their optimum ([`Metric::best_aux`]), as for the lengths
//! the solvers report, so for the rigid metric the energy split sums to
//! `sum_i (G_{P_i} + G_{P_{i+1}})` at the optimal motion, which can differ slightly from
//! [`qcshape::geodesic::Geodesic::energy`] (taken at the solver's motions).
//!
//! The similarity of two deformations `M`, `N` is `sum_k dis(M_k, N_k)` (eq. 13); its split is
//! `s_v = sum_k l_v(geodesic M_k -> N_k)` ([`pair_contributions`]).

use rayon::prelude::*;
use thiserror::Error;

use qcshape::geodesic::{GeodesicError, GeodesicSolver};
use qcshape::mesh::Topology;
use qcshape::metric::{At, Metric, Pattern, Segment};
use qcshape::similarity::Pose;

mod speeds;
pub use speeds::{pose_speeds, PoseSpeeds};

/// Why contributions cannot be computed.
#[derive(Debug, Error)]
pub enum ContributionError {
    /// A path needs at least two poses.
    #[error("a path needs at least 2 poses, got {0}")]
    TooFewPoses(usize),
    /// A pose does not have one position per vertex of the topology.
    #[error("pose {pose} has {got} vertices, but the topology has {expected}")]
    VertexCount {
        /// Pose index.
        pose: usize,
        /// Number of vertices of the topology.
        expected: usize,
        /// Number of positions of the pose.
        got: usize,
    },
    /// The two deformations do not have the same number of poses.
    #[error("the deformations have {0} and {1} poses")]
    PoseCount(usize, usize),
    /// The geodesic between two corresponding poses failed.
    #[error("pose {pose}: {error}")]
    Geodesic {
        /// Pose index.
        pose: usize,
        /// The solver's error.
        error: GeodesicError,
    },
}

/// Adds the per-vertex split of one term `G_M(b - a)` (`M` chosen by `seg.at`) into `out`
/// (#V): each squared residual `r_i^2` is shared equally by the vertices of row `i` of
/// `support` ([`Metric::support`]); `pattern` is [`Metric::pattern`] on the same topology.
/// Auxiliary unknowns are set to [`Metric::best_aux`] when the metric has any. Returns
/// `G_M(b - a) = |r|^2` (metric units, e.g. length^4 for area-weighted terms).
pub fn term_contribution(
    metric: &dyn Metric,
    topo: &Topology,
    pattern: &Pattern,
    support: &Pattern,
    seg: &Segment,
    out: &mut [f64],
) -> f64 {
    let r = qcshape::metric::residuals_at_best_aux(metric, topo, pattern.as_ref(), seg);
    debug_assert_eq!(support.n_residuals(), r.len());
    let mut total = 0.0;
    for (i, ri) in r.iter().enumerate() {
        let r2 = ri * ri;
        total += r2;
        let row = &support.vertices[support.row(i)];
        if row.is_empty() {
            continue;
        }
        let share = r2 / row.len() as f64;
        for &v in row {
            out[v as usize] += share;
        }
    }
    total
}

/// Per-vertex split of a path's energy (eq. 12) and length (module docs). All values are in
/// the units of the scaled poses (coordinates times `scale`), like the solvers' energies and
/// lengths.
#[derive(Debug, Clone, PartialEq)]
pub struct PathContributions {
    /// `e_{i,v}`: energy contribution of vertex `v` to segment `i` (N x #V); row `i` sums to
    /// `G_{P_i}(X_i) + G_{P_{i+1}}(X_i)`.
    pub segment_energy: Vec<Vec<f64>>,
    /// `l_{i,v} = sqrt(E_i / 2) e_{i,v} / E_i` (N x #V); row `i` sums to the segment length.
    pub segment_length: Vec<Vec<f64>>,
    /// `e_v = sum_i e_{i,v}` (#V); sums to [`PathContributions::energy_total`].
    pub energy: Vec<f64>,
    /// `l_v = sum_i l_{i,v}` (#V); sums to [`PathContributions::length_total`].
    pub length: Vec<f64>,
    /// Segment energies `E_i = G_{P_i}(X_i) + G_{P_{i+1}}(X_i)` (N), summed in residual order.
    pub segment_energies: Vec<f64>,
    /// Path energy `sum_i E_i` (eq. 12).
    pub energy_total: f64,
    /// Path length `L = sum_i sqrt(E_i / 2)`.
    pub length_total: f64,
}

/// The per-vertex energy and length split (module docs) of the path `poses` (`P_0 .. P_N`,
/// each #V x 3, N >= 1) for `metric` on `topo`, after multiplying all coordinates by `scale`
/// (the solvers' normalization: [`qcshape::geodesic::Geodesic::scale`]; 1 for poses that are
/// already scaled). Frozen weights ([`Metric::frozen_weights`]) come from the path's ends, as
/// in the solvers. Segments are evaluated in parallel and gathered in order (deterministic).
pub fn path_contributions(
    metric: &dyn Metric,
    topo: &Topology,
    poses: &[Vec<[f64; 3]>],
    scale: f64,
) -> Result<PathContributions, ContributionError> {
    if poses.len() < 2 {
        return Err(ContributionError::TooFewPoses(poses.len()));
    }
    let nv = topo.n_vertices();
    if let Some((pose, p)) = poses.iter().enumerate().find(|(_, p)| p.len() != nv) {
        return Err(ContributionError::VertexCount {
            pose,
            expected: nv,
            got: p.len(),
        });
    }
    let scaled: Vec<Vec<[f64; 3]>> = if scale == 1.0 {
        poses.to_vec()
    } else {
        poses
            .iter()
            .map(|p| p.iter().map(|v| v.map(|c| c * scale)).collect())
            .collect()
    };
    let n = scaled.len() - 1;
    let frozen = metric.frozen_weights(topo, &scaled[0], &scaled[n]);
    let pattern = metric.pattern(topo);
    let support = metric.support(topo);
    let parts: Vec<(f64, Vec<f64>)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut e = vec![0.0; nv];
            let mut total = 0.0;
            for at in [At::Start, At::End] {
                let seg = Segment {
                    a: &scaled[i],
                    b: &scaled[i + 1],
                    at,
                    aux: &[],
                    frozen: frozen.as_deref(),
                };
                total += term_contribution(metric, topo, &pattern, &support, &seg, &mut e);
            }
            (total, e)
        })
        .collect();
    let mut energy = vec![0.0; nv];
    let mut length = vec![0.0; nv];
    let mut segment_energy = Vec::with_capacity(n);
    let mut segment_length = Vec::with_capacity(n);
    let mut segment_energies = Vec::with_capacity(n);
    let mut length_total = 0.0;
    for (ei, e) in parts {
        let li = (ei / 2.0).max(0.0).sqrt();
        let f = if ei > 0.0 { li / ei } else { 0.0 };
        let l: Vec<f64> = e.iter().map(|x| x * f).collect();
        for v in 0..nv {
            energy[v] += e[v];
            length[v] += l[v];
        }
        segment_energies.push(ei);
        length_total += li;
        segment_energy.push(e);
        segment_length.push(l);
    }
    Ok(PathContributions {
        segment_energy,
        segment_length,
        energy,
        length,
        energy_total: segment_energies.iter().sum(),
        segment_energies,
        length_total,
    })
}

/// Per-vertex split of the similarity `sum_k dis(M_k, N_k)` (eq. 13) of two deformations.
#[derive(Debug, Clone, PartialEq)]
pub struct PairContributions {
    /// `l_v` of the geodesic `M_k -> N_k` for every pose `k` (#poses x #V); all zero for
    /// identical poses (no solve, as in [`qcshape::similarity::pose_distances`]).
    pub per_pose: Vec<Vec<f64>>,
    /// `s_v = sum_k l_v` (#V); sums to [`PairContributions::distance`].
    pub total: Vec<f64>,
    /// `dis(M_k, N_k)` recomputed from the split (#poses).
    pub pose_distances: Vec<f64>,
    /// `sum_k dis(M_k, N_k)` (the metric's units).
    pub distance: f64,
    /// Whether every geodesic converged.
    pub converged: bool,
}

/// Solves the geodesic between corresponding poses of `m` and `n` (each a list of poses of
/// #V x 3, already scaled by the common factor, as for
/// [`qcshape::similarity::compute`]) and splits the similarity per vertex.
pub fn pair_contributions(
    solver: &GeodesicSolver,
    m: &[Pose],
    n: &[Pose],
) -> Result<PairContributions, ContributionError> {
    if m.len() != n.len() {
        return Err(ContributionError::PoseCount(m.len(), n.len()));
    }
    let pe = solver.path_energy();
    let topo = pe.topology().as_ref();
    let nv = topo.n_vertices();
    let mut per_pose = Vec::with_capacity(m.len());
    let mut pose_distances = Vec::with_capacity(m.len());
    let mut converged = true;
    for (k, (a, b)) in m.iter().zip(n).enumerate() {
        if a == b {
            per_pose.push(vec![0.0; nv]);
            pose_distances.push(0.0);
            continue;
        }
        let g = solver
            .solve(a, b)
            .map_err(|error| ContributionError::Geodesic { pose: k, error })?;
        converged &= g.converged;
        let c = path_contributions(pe.metric(), topo, &g.poses, 1.0)?;
        pose_distances.push(c.length_total);
        per_pose.push(c.length);
    }
    let mut total = vec![0.0; nv];
    for p in &per_pose {
        for (t, x) in total.iter_mut().zip(p) {
            *t += x;
        }
    }
    Ok(PairContributions {
        per_pose,
        total,
        distance: pose_distances.iter().sum(),
        pose_distances,
        converged,
    })
}

/// Fraction of the total mass of `values` (#V, non-negative) on the vertices where `mask` is
/// true; 0 when the total is 0.
pub fn mass_fraction(values: &[f64], mask: &[bool]) -> f64 {
    let total: f64 = values.iter().sum();
    if total <= 0.0 {
        return 0.0;
    }
    values
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .map(|(v, _)| v)
        .sum::<f64>()
        / total
}

#[cfg(test)]
mod tests {
    use super::*;
    use qcshape::geodesic::{GeodesicOptions, Normalization};
    use qcshape::metric::{
        Conformal, ConformalForm, FrozenL2, FrozenRigid, Isometric, MetricKind, MetricSpec, QcWeights,
        QuasiConformal, Regularized, Rigid, L2,
    };
    use qcshape::synth::icosphere;

    fn metrics() -> Vec<Box<dyn Metric>> {
        let mut v: Vec<Box<dyn Metric>> = vec![
            Box::new(L2),
            Box::new(FrozenL2),
            Box::new(Rigid),
            Box::new(FrozenRigid),
            Box::new(Isometric),
        ];
        for form in [ConformalForm::Quadratic, ConformalForm::Paper] {
            v.push(Box::new(Conformal { form }));
            for weights in [QcWeights::Endpoints, QcWeights::Segment] {
                v.push(Box::new(QuasiConformal::new(form, weights)));
            }
        }
        v.push(Box::new(Regularized::new(
            Box::new(QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Segment)),
            0.1,
        )));
        v.push(Box::new(Regularized::with_pose_areas(Box::new(Isometric), 0.3)));
        v
    }

    /// `base` with a smooth radial bump on the cap `z > 0.6` (height `h` at the pole).
    fn bumped(base: &[[f64; 3]], h: f64) -> Vec<[f64; 3]> {
        base.iter()
            .map(|p| {
                let t = ((p[2] - 0.6) / 0.4).max(0.0);
                let s = 1.0 + h * t * t;
                p.map(|c| c * s)
            })
            .collect()
    }

    fn stretched(base: &[[f64; 3]], a: f64) -> Vec<[f64; 3]> {
        base.iter()
            .map(|p| [p[0] * (1.0 + a), p[1], p[2] * (1.0 - 0.5 * a)])
            .collect()
    }

    #[test]
    fn contributions_sum_to_energy_and_length_for_every_metric() {
        let s = icosphere(1);
        let b = qcshape::mesh::Shape::new(s.topology.clone(), bumped(&stretched(&s.positions, 0.3), 0.3))
            .unwrap();
        let opts = GeodesicOptions {
            steps: 3,
            max_iterations: Some(5),
            ..Default::default()
        };
        for m in metrics() {
            let g = qcshape::geodesic::geodesic(m.as_ref(), &s, &b, &opts, Normalization::MeanEdgeOfBoth)
                .unwrap();
            let c = path_contributions(m.as_ref(), &s.topology, &g.poses, g.scale).unwrap();
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
            let e: f64 = c.energy.iter().sum();
            let l: f64 = c.length.iter().sum();
            assert!(
                rel(e, c.energy_total) < 1e-10,
                "{}: {e} vs {}",
                m.name(),
                c.energy_total
            );
            assert!(rel(l, g.length) < 1e-10, "{}: {l} vs {}", m.name(), g.length);
            for (i, row) in c.segment_length.iter().enumerate() {
                let si: f64 = row.iter().sum();
                assert!(rel(si, g.segment_lengths[i]) < 1e-10, "{} segment {i}", m.name());
            }
            // The solver's energy comes from the metrics' fused gradient kernels (another
            // summation order; near-conformal paths have energies ~1e-12 with cancellation).
            if m.n_aux() == 0 {
                assert!(rel(e, g.energy) < 1e-8, "{}: {e} vs {}", m.name(), g.energy);
            }
            assert!(c.energy.iter().chain(&c.length).all(|x| *x >= 0.0));
        }
    }

    #[test]
    fn a_bump_on_one_cap_puts_the_similarity_mass_on_that_cap() {
        let s = icosphere(2);
        let scale = 1.0 / qcshape::mesh::geometry::mean_edge_length(&s.topology, &s.positions);
        let base: Vec<[f64; 3]> = s.positions.iter().map(|p| p.map(|c| c * scale)).collect();
        let unit = &s.positions;
        let sc = |p: Vec<[f64; 3]>| -> Vec<[f64; 3]> { p.iter().map(|v| v.map(|c| c * scale)).collect() };
        // Two deformations of 3 poses from the common base; the second adds a bump on the cap.
        let m: Vec<Pose> = vec![base.clone(), sc(stretched(unit, 0.15)), sc(stretched(unit, 0.3))];
        let n: Vec<Pose> = vec![
            base.clone(),
            sc(bumped(&stretched(unit, 0.15), 0.1)),
            sc(bumped(&stretched(unit, 0.3), 0.2)),
        ];
        let cap: Vec<bool> = unit.iter().map(|p| p[2] > 0.5).collect();
        let n_cap = cap.iter().filter(|&&c| c).count();
        for kind in MetricKind::all() {
            let metric = MetricSpec::previous(kind).build(&qcshape::metric::Calibration::RAW);
            let opts = GeodesicOptions {
                steps: 4,
                ..Default::default()
            };
            let solver = GeodesicSolver::new(metric.as_ref(), s.topology.clone(), opts).unwrap();
            let c = pair_contributions(&solver, &m, &n).unwrap();
            let sum: f64 = c.total.iter().sum();
            assert!((sum - c.distance).abs() <= 1e-10 * c.distance, "{kind:?}");
            assert_eq!(c.pose_distances[0], 0.0);
            let frac = mass_fraction(&c.total, &cap);
            eprintln!(
                "{}: distance {:.4e}, cap ({n_cap} of {} vertices) holds {frac:.4} of the mass",
                metric.name(),
                c.distance,
                cap.len()
            );
            assert!(frac > 0.9, "{}: cap fraction {frac}", metric.name());
        }
    }
}
