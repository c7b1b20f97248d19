//! Pairwise deformation distances (eq. 13): `similarity(M, N) = sum_i dis(M_i, N_i)` over
//! corresponding poses of deformations that start from one common base.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::geodesic::{GeodesicError, GeodesicSolver, SolveContext};

use super::error::SimilarityError;
use super::tangent::TangentModel;
use super::types::{Approx, PairDistance, Pose};

/// `dis(M_k, N_k)` for every pose `k` of two deformations given as pose lists (each #V x 3,
/// already multiplied by the common normalization factor). Identical poses (bit for bit, such
/// as the common base after transfer) have distance 0 without a solve. With
/// [`Approx::Straight`] (and [`Approx::Tangent`], which needs every pose at once and is
/// computed by [`crate::similarity::compute`]) each distance is the straight-path length instead of a solve.
///
/// Returns the per-pose lengths, whether all solves converged, and the iterations used.
pub fn pose_distances(
    solver: &GeodesicSolver,
    m: &[Pose],
    n: &[Pose],
    approx: Approx,
) -> Result<(Vec<f64>, bool, usize), (usize, GeodesicError)> {
    pose_distances_with(solver, m, n, approx, None).map(|p| (p.lengths, p.converged, p.iterations))
}

/// Per pose of one deformation, the metric's [`crate::metric::Metric::pose_summary`].
type PoseSummaries = Vec<Vec<f64>>;

/// What [`pose_distances_with`] measures for the poses of one pair.
struct PoseDistances {
    /// `dis(M_k, N_k)` per pose.
    lengths: Vec<f64>,
    /// `[geometric, regularizer]` energy of each pose's path.
    parts: Vec<[f64; 2]>,
    converged: bool,
    iterations: usize,
}

/// [`pose_distances`] with the poses' summaries computed beforehand (exact and straight modes;
/// the same lengths, bit for bit), and the energy split of every pose's path.
fn pose_distances_with(
    solver: &GeodesicSolver,
    m: &[Pose],
    n: &[Pose],
    approx: Approx,
    summaries: Option<(&PoseSummaries, &PoseSummaries)>,
) -> Result<PoseDistances, (usize, GeodesicError)> {
    let mut out = Vec::with_capacity(m.len());
    let mut parts = Vec::with_capacity(m.len());
    let mut converged = true;
    let mut iterations = 0;
    // One preconditioner fit for the pair's poses (consecutive poses are close), and each
    // geodesic started from the previous pose's.
    let mut ctx = SolveContext::default();
    let mut previous = None;
    for (k, (a, b)) in m.iter().zip(n).enumerate() {
        if a == b {
            out.push(0.0);
            parts.push([0.0, 0.0]);
            continue;
        }
        let s = summaries.map(|(sm, sn)| [sm[k].as_slice(), sn[k].as_slice()]);
        if approx != Approx::Exact {
            // Straight (the tangent mode never gets here: it has no per-pose solve).
            let line = solver.straight_path_with(a, b, s).map_err(|e| (k, e))?;
            out.push(line.length);
            parts.push([line.geometric_energy, line.regularizer_energy]);
            continue;
        }
        let g = solver
            .distance_near_with(&mut ctx, a, b, previous.as_ref(), s)
            .map_err(|e| (k, e))?;
        converged &= g.converged;
        iterations += g.iterations;
        out.push(g.length);
        parts.push([g.geometric_energy, g.regularizer_energy]);
        previous = Some(g);
    }
    Ok(PoseDistances {
        lengths: out,
        parts,
        converged,
        iterations,
    })
}

/// Computes the distance of every pair `i < j` of `deformations` (each a list of poses on the
/// solver's topology, #V x 3, already scaled by one common factor; all with the same number of
/// poses) that is not in `done`, in parallel on the current rayon pool; `approx` chooses
/// geodesic or straight-path lengths ([`Approx`]).
///
/// `on_pair` is called from worker threads as soon as a pair is finished (record it in a
/// journal, advance a progress bar); an error it returns stops the run. `cancel`, when set,
/// stops the run between poses with [`SimilarityError::Cancelled`]. Returns the new pairs in
/// row order.
#[cfg(test)]
pub(crate) fn compute_pairs<F>(
    solver: &GeodesicSolver,
    approx: Approx,
    names: &[String],
    deformations: &[Vec<Pose>],
    done: &std::collections::HashSet<(usize, usize)>,
    cancel: Option<&AtomicBool>,
    on_pair: F,
) -> Result<Vec<PairDistance>, SimilarityError>
where
    F: Fn(&PairDistance) -> Result<(), SimilarityError> + Sync,
{
    let todo: Vec<(usize, usize)> = super::types::all_pairs(deformations.len())
        .into_iter()
        .filter(|p| !done.contains(p))
        .collect();
    compute_listed_pairs(solver, approx, names, deformations, &todo, cancel, on_pair)
}

/// [`compute_pairs`] for the listed pairs only (each `(i, j)` with `i < j < n`), in the order
/// given: the batches of a distributed run (`qcshape.dask`). The distances are bit-identical to
/// those of [`compute_pairs`] for the same pairs.
pub(crate) fn compute_listed_pairs<F>(
    solver: &GeodesicSolver,
    approx: Approx,
    names: &[String],
    deformations: &[Vec<Pose>],
    todo: &[(usize, usize)],
    cancel: Option<&AtomicBool>,
    on_pair: F,
) -> Result<Vec<PairDistance>, SimilarityError>
where
    F: Fn(&PairDistance) -> Result<(), SimilarityError> + Sync,
{
    check_shapes(names, deformations)?;
    let n = deformations.len();
    if let Some((i, j)) = todo.iter().find(|(i, j)| i >= j || *j >= n) {
        return Err(SimilarityError::NotAPair { i: *i, j: *j, n });
    }
    // The tangent mode measures feature vectors, computed once for every pose.
    let tangent = match approx {
        Approx::Tangent => {
            let pe = solver.path_energy();
            Some(TangentModel::new(pe.metric, &pe.topo, deformations)?)
        }
        _ => None,
    };
    // The per-pose part of the frozen weights (the quasi-conformal angle defects), once per
    // pose of every deformation in `todo` instead of once per pair and pose: #deformations x
    // #poses x #V values in memory (a third of the poses' own). The tangent mode needs them
    // only for its pair weights.
    let summaries: Vec<Option<PoseSummaries>> = if tangent.as_ref().is_none_or(|t| t.weighted) {
        let pe = solver.path_energy();
        let mut used = vec![false; n];
        for &(i, j) in todo {
            used[i] = true;
            used[j] = true;
        }
        (0..n)
            .into_par_iter()
            .map(|d| {
                if !used[d] {
                    return None;
                }
                deformations[d]
                    .iter()
                    .map(|p| pe.metric.pose_summary(&pe.topo, p))
                    .collect()
            })
            .collect()
    } else {
        Vec::new()
    };
    todo.par_iter()
        .map(|&(i, j)| {
            if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return Err(SimilarityError::Cancelled);
            }
            let t0 = Instant::now();
            let (per_pose, per_pose_energy, converged, iterations) = match &tangent {
                Some(t) => {
                    let pe = solver.path_energy();
                    let s = match (summaries.get(i), summaries.get(j)) {
                        (Some(Some(a)), Some(Some(b))) => Some([a.as_slice(), b.as_slice()]),
                        _ => None,
                    };
                    let d = t.pose_distances(pe.metric, &pe.topo, deformations, i, j, s);
                    // No path: the energy split is unknown.
                    (d, None, true, 0)
                }
                None => {
                    let s = match (summaries.get(i), summaries.get(j)) {
                        (Some(Some(a)), Some(Some(b))) => Some((a, b)),
                        _ => None,
                    };
                    let p = pose_distances_with(solver, &deformations[i], &deformations[j], approx, s)
                        .map_err(|(pose, error)| SimilarityError::Geodesic {
                            a: names[i].clone(),
                            b: names[j].clone(),
                            pose,
                            error: Box::new(error),
                        })?;
                    (p.lengths, Some(p.parts), p.converged, p.iterations)
                }
            };
            let pair = PairDistance {
                i,
                j,
                distance: per_pose.iter().sum(),
                per_pose,
                per_pose_energy,
                converged,
                iterations,
                seconds: t0.elapsed().as_secs_f64(),
            };
            on_pair(&pair)?;
            Ok(pair)
        })
        .collect()
}

fn check_shapes(names: &[String], deformations: &[Vec<Pose>]) -> Result<(), SimilarityError> {
    if names.len() != deformations.len() {
        return Err(SimilarityError::NameCount {
            names: names.len(),
            deformations: deformations.len(),
        });
    }
    let Some(first) = deformations.first() else {
        return Ok(());
    };
    for (name, d) in names.iter().zip(deformations) {
        if d.len() != first.len() {
            return Err(SimilarityError::PoseCount {
                name: name.to_string(),
                poses: d.len(),
                first: names[0].to_string(),
                first_poses: first.len(),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::GeodesicOptions;
    use crate::metric::{Isometric, Metric, Regularized};
    use crate::synth::icosphere;
    use std::collections::HashSet;

    fn deformation(base: &[[f64; 3]], amp: f64, poses: usize) -> Vec<Pose> {
        (0..poses)
            .map(|k| {
                let t = amp * k as f64 / (poses - 1).max(1) as f64;
                base.iter()
                    .map(|p| [p[0] * (1.0 + t), p[1], p[2] * (1.0 - 0.5 * t)])
                    .collect()
            })
            .collect()
    }

    #[test]
    fn matrix_is_symmetric_with_zero_diagonal_and_separates_amplitudes() {
        let s = icosphere(1);
        let scale = 1.0 / crate::mesh::geometry::mean_edge_length(&s.topology, &s.positions);
        let base: Vec<[f64; 3]> = s.positions.iter().map(|p| p.map(|c| c * scale)).collect();
        let metric = Regularized::new(Box::new(Isometric), 0.1);
        let m: &dyn Metric = &metric;
        let opts = GeodesicOptions {
            steps: 3,
            ..Default::default()
        };
        let solver = GeodesicSolver::new(m, s.topology.clone(), opts).unwrap();
        let defs = vec![
            deformation(&base, 0.1, 3),
            deformation(&base, 0.12, 3),
            deformation(&base, 0.4, 3),
        ];
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let pairs = compute_pairs(
            &solver,
            Approx::Exact,
            &names,
            &defs,
            &HashSet::new(),
            None,
            |_| {
                calls.fetch_add(1, Ordering::Relaxed);
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(calls.load(Ordering::Relaxed), 3);
        let d = crate::similarity::matrix::assemble(3, &pairs);
        for i in 0..3 {
            assert_eq!(d[i * 3 + i], 0.0);
            for j in 0..3 {
                assert_eq!(d[i * 3 + j], d[j * 3 + i]);
            }
        }
        // Pose 0 is shared: zero without a solve.
        assert!(pairs.iter().all(|p| p.per_pose[0] == 0.0 && p.converged));
        // Close amplitudes are closer than far ones.
        assert!(d[1] > 0.0 && d[1] < d[2] && d[5] < d[2]);

        // Reversing the order of a pair gives the same distance (symmetry of dis, to solver
        // tolerance).
        let (fwd, _, _) = pose_distances(&solver, &defs[0], &defs[2], Approx::Exact).unwrap();
        let (bwd, _, _) = pose_distances(&solver, &defs[2], &defs[0], Approx::Exact).unwrap();
        for (a, b) in fwd.iter().zip(&bwd) {
            assert!((a - b).abs() <= 1e-6 * a.max(1.0), "{a} vs {b}");
        }

        // Skipping finished pairs.
        let done: HashSet<_> = [(0, 1), (0, 2)].into_iter().collect();
        let rest = compute_pairs(&solver, Approx::Exact, &names, &defs, &done, None, |_| Ok(())).unwrap();
        assert_eq!(rest.len(), 1);
        assert_eq!((rest[0].i, rest[0].j), (1, 2));
        assert!((rest[0].distance - pairs[2].distance).abs() < 1e-12);
    }

    /// The straight and exact modes' matrices, with the angle defects computed once per pose,
    /// equal the per-pair lengths bit for bit, for every metric (the quasi-conformal ones have a
    /// pose summary, the others none).
    #[test]
    fn lengths_from_pose_summaries_are_bit_identical() {
        use crate::metric::{MetricKind, MetricSpec};
        let s = icosphere(2);
        let bumpy = |amp: f64| -> Vec<[f64; 3]> {
            s.positions
                .iter()
                .map(|p| p.map(|c| c * (1.0 + amp * p[0] * p[1] + 0.1 * amp * p[2])))
                .collect()
        };
        let defs: Vec<Vec<Pose>> = [0.1, 0.2, 0.35]
            .iter()
            .map(|&amp| vec![s.positions.clone(), bumpy(amp), bumpy(1.5 * amp)])
            .collect();
        let names: Vec<String> = ["a", "b", "c"].iter().map(|n| n.to_string()).collect();
        for kind in [MetricKind::QuasiConformal, MetricKind::Conformal, MetricKind::L2] {
            let metric = MetricSpec::previous(kind).build(&crate::metric::Calibration::RAW);
            if kind == MetricKind::QuasiConformal {
                assert!(metric.pose_summary(&s.topology, &s.positions).is_some());
            }
            let opts = GeodesicOptions {
                steps: 2,
                ..Default::default()
            };
            let solver = GeodesicSolver::new(metric.as_ref(), s.topology.clone(), opts).unwrap();
            for approx in [Approx::Straight, Approx::Exact] {
                let pairs =
                    compute_pairs(&solver, approx, &names, &defs, &HashSet::new(), None, |_| Ok(())).unwrap();
                assert_eq!(pairs.len(), 3);
                for p in &pairs {
                    let exact = pose_distances(&solver, &defs[p.i], &defs[p.j], Approx::Exact)
                        .unwrap()
                        .0;
                    for (k, d) in p.per_pose.iter().enumerate() {
                        let (a, b) = (&defs[p.i][k], &defs[p.j][k]);
                        let want = match approx {
                            _ if a == b => 0.0,
                            Approx::Straight => solver.straight_length(a, b).unwrap(),
                            _ => exact[k],
                        };
                        assert_eq!(
                            d.to_bits(),
                            want.to_bits(),
                            "{kind:?} {approx:?} ({}, {}) pose {k}",
                            p.i,
                            p.j
                        );
                    }
                    assert!(p.distance > 0.0);
                }
            }
        }
    }

    /// Every pose of a pair carries the energy split of its path, for every metric: in the
    /// exact mode the geodesic's (the same solves, bit for bit), summing to its energy; in the
    /// straight mode the linear path's, summing to its energy; none in the tangent mode. The
    /// pair's share is the regularizer's part of the summed energy.
    #[test]
    fn pairs_carry_the_energy_split_of_every_pose() {
        use crate::geodesic::Ends;
        use crate::metric::{MetricKind, MetricSpec};
        let s = icosphere(2);
        let f = 1.0 / crate::mesh::geometry::mean_edge_length(&s.topology, &s.positions);
        let base: Pose = s.positions.iter().map(|p| p.map(|c| c * f)).collect();
        let bumpy = |amp: f64| -> Pose {
            base.iter()
                .map(|p| [p[0] * (1.0 + amp * p[1] / f), p[1], p[2] * (1.0 - 0.5 * amp)])
                .collect()
        };
        let defs: Vec<Vec<Pose>> = [0.1, 0.3]
            .iter()
            .map(|&amp| vec![base.clone(), bumpy(amp), bumpy(1.5 * amp)])
            .collect();
        let names: Vec<String> = ["a", "b"].iter().map(|n| n.to_string()).collect();
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y;
        for kind in MetricKind::all() {
            let spec = MetricSpec::new(kind);
            let cal = spec.calibrate(&s.topology, &[&base]).unwrap();
            let metric = spec.build(&cal);
            let opts = GeodesicOptions {
                steps: 3,
                ..Default::default()
            };
            let solver = GeodesicSolver::new(metric.as_ref(), s.topology.clone(), opts).unwrap();
            let run = |approx| {
                let mut p =
                    compute_pairs(&solver, approx, &names, &defs, &HashSet::new(), None, |_| Ok(())).unwrap();
                assert_eq!(p.len(), 1);
                p.remove(0)
            };
            let exact = run(Approx::Exact);
            let parts = exact.per_pose_energy.clone().unwrap();
            assert_eq!(parts.len(), 3);
            assert_eq!(parts[0], [0.0, 0.0], "{kind:?}: identical poses");
            // The same sequence of solves as the pair's (each started from the previous).
            let mut ctx = SolveContext::default();
            let mut previous = None;
            for k in 1..3 {
                let (a, b) = (&defs[0][k], &defs[1][k]);
                let g = solver
                    .distance_near_with(&mut ctx, a, b, previous.as_ref(), None)
                    .unwrap();
                assert_eq!(
                    g.length.to_bits(),
                    exact.per_pose[k].to_bits(),
                    "{kind:?} pose {k}"
                );
                assert_eq!(
                    parts[k],
                    [g.geometric_energy, g.regularizer_energy],
                    "{kind:?} pose {k}"
                );
                let sum = parts[k][0] + parts[k][1];
                assert!(close(sum, g.energy), "{kind:?} pose {k}: {sum} vs {}", g.energy);
                previous = Some(g);
            }
            let [geo, reg] = exact.energy_parts().unwrap();
            assert_eq!(exact.regularizer_share(), Some(crate::geodesic::share(geo, reg)));
            assert_eq!(reg > 0.0, kind.takes("lambda"), "{kind:?}");

            let straight = run(Approx::Straight);
            let parts = straight.per_pose_energy.clone().unwrap();
            assert_eq!(parts[0], [0.0, 0.0]);
            let pe = solver.path_energy();
            for k in 1..3 {
                let (a, b) = (&defs[0][k], &defs[1][k]);
                let ends = Ends {
                    start: a.clone(),
                    end: b.clone(),
                    frozen: metric.frozen_weights(&s.topology, a, b),
                };
                let x0 = pe.linear_start(&ends);
                let e0 = pe.energy(&x0, &ends);
                let sum = parts[k][0] + parts[k][1];
                assert!(close(sum, e0), "{kind:?} straight pose {k}: {sum} vs {e0}");
                // The straight path is no shorter in energy than the geodesic.
                assert!(sum >= exact.per_pose_energy.as_ref().unwrap()[k].iter().sum::<f64>() * (1.0 - 1e-9));
            }
            if matches!(
                kind,
                MetricKind::L2 | MetricKind::Isometric | MetricKind::Conformal
            ) {
                let tangent = run(Approx::Tangent);
                assert_eq!(tangent.per_pose_energy, None);
                assert_eq!(tangent.regularizer_share(), None);
            }
        }
    }

    #[test]
    fn unequal_pose_counts_and_cancellation_are_errors() {
        let s = icosphere(0);
        let metric = Isometric;
        let solver = GeodesicSolver::new(&metric, s.topology.clone(), GeodesicOptions::default()).unwrap();
        let names: Vec<String> = vec!["a".into(), "b".into()];
        let defs = vec![
            deformation(&s.positions, 0.1, 3),
            deformation(&s.positions, 0.1, 2),
        ];
        let e = compute_pairs(
            &solver,
            Approx::Exact,
            &names,
            &defs,
            &HashSet::new(),
            None,
            |_| Ok(()),
        )
        .unwrap_err();
        assert!(e.to_string().contains("'b' has 2 poses"), "{e}");
        let defs = vec![
            deformation(&s.positions, 0.1, 3),
            deformation(&s.positions, 0.2, 3),
        ];
        let cancel = AtomicBool::new(true);
        let e = compute_pairs(
            &solver,
            Approx::Exact,
            &names,
            &defs,
            &HashSet::new(),
            Some(&cancel),
            |_| Ok(()),
        )
        .unwrap_err();
        assert!(matches!(e, SimilarityError::Cancelled));
    }
}
