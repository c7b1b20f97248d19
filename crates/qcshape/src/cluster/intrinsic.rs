//! k-means with intrinsic means (eq. 14, docs/method.md "Clustering"): class means are
//! deformations whose poses are Karcher means of the members' corresponding poses.

use rayon::prelude::*;
use thiserror::Error;

use crate::geodesic::{GeodesicError, GeodesicSolver, SolveContext};

use super::karcher::{karcher_mean, KarcherOptions};
use crate::mesh::Pose;
#[cfg(doc)]
use crate::similarity::pose_distances;

/// Options of [`intrinsic_kmeans`].
#[derive(Debug, Clone)]
pub struct IntrinsicOptions {
    /// Maximum assignment / mean-update rounds. Default 10.
    pub max_iterations: usize,
    /// Karcher mean iteration of every (class, pose). Default: [`KarcherOptions::default`].
    pub karcher: KarcherOptions,
}

impl Default for IntrinsicOptions {
    fn default() -> Self {
        IntrinsicOptions {
            max_iterations: 10,
            karcher: KarcherOptions::default(),
        }
    }
}

/// Why the intrinsic k-means failed.
#[derive(Debug, Error)]
pub enum IntrinsicError {
    /// The start partition does not have one entry per deformation, or `k` is 0.
    #[error("start partition of {items} items into {k} clusters does not fit {n} deformations")]
    Start {
        /// Entries of the start partition.
        items: usize,
        /// Clusters asked for.
        k: usize,
        /// Deformations.
        n: usize,
    },
    /// The deformations have different pose counts.
    #[error("deformations differ in pose count")]
    PoseCount,
    /// A cluster of the current partition has no member.
    #[error("cluster {0} is empty")]
    EmptyCluster(usize),
    /// A geodesic (distance or log map) failed.
    #[error("geodesic: {0}")]
    Geodesic(#[from] GeodesicError),
}

/// The result of [`intrinsic_kmeans`].
#[derive(Debug, Clone)]
pub struct IntrinsicClustering {
    /// Cluster of each deformation (0..k).
    pub assignments: Vec<usize>,
    /// The class means (k x #poses x #V x 3, solver units).
    pub means: Vec<Vec<Pose>>,
    /// Sum over deformations of `similarity(x, mu)^2` to their class mean (eq. 14 with squared
    /// similarities, the k-means reading of "sum of squared within-cluster distances").
    pub objective: f64,
    /// Rounds taken.
    pub iterations: usize,
    /// Whether the assignment stopped changing.
    pub converged: bool,
}

/// k-means with intrinsic means of `deformations` (each a list of poses #V x 3 on the solver's
/// topology, scaled by the common factor), started from the partition `start` (values 0..k,
/// every cluster non-empty; e.g. the best kernel k-means partition of the similarity matrix).
///
/// Each round computes, for every cluster and pose, the Karcher mean of the members' poses
/// (started from the previous round's mean, in the first round from the members' arithmetic
/// mean; parallel over cluster x pose), then the similarity (eq. 13)
/// of every deformation to the means (parallel over deformations; a mean is abandoned as soon
/// as its partial sum over poses exceeds the closest mean's full similarity, which leaves the
/// assignment and the objective unchanged), and reassigns each deformation to its closest
/// mean. A cluster that loses all its members takes the deformation farthest from its own
/// mean. Stops when the assignment no longer changes.
pub fn intrinsic_kmeans(
    solver: &GeodesicSolver,
    deformations: &[Vec<Pose>],
    start: &[usize],
    k: usize,
    opts: &IntrinsicOptions,
) -> Result<IntrinsicClustering, IntrinsicError> {
    let n = deformations.len();
    if start.len() != n || k == 0 || start.iter().any(|&c| c >= k) {
        return Err(IntrinsicError::Start {
            items: start.len(),
            k,
            n,
        });
    }
    let poses = deformations.first().map_or(0, Vec::len);
    if deformations.iter().any(|d| d.len() != poses) {
        return Err(IntrinsicError::PoseCount);
    }
    let mut assign = start.to_vec();
    let mut means: Vec<Option<Vec<Pose>>> = vec![None; k];
    let mut iterations = 0;
    let mut converged = false;
    let mut objective;
    loop {
        let groups = crate::cluster::members(&assign, k);
        if let Some(c) = groups.iter().position(Vec::is_empty) {
            return Err(IntrinsicError::EmptyCluster(c));
        }
        // Mean update: Karcher mean of every (cluster, pose), warm-started.
        let jobs: Vec<(usize, usize)> = (0..k).flat_map(|c| (0..poses).map(move |p| (c, p))).collect();
        let updated: Vec<Pose> = jobs
            .par_iter()
            .map(|&(c, p)| {
                let members: Vec<&[[f64; 3]]> =
                    groups[c].iter().map(|&i| deformations[i][p].as_slice()).collect();
                let init = match means[c].as_ref() {
                    Some(m) => m[p].clone(),
                    None => arithmetic_mean(&members),
                };
                Ok(karcher_mean(solver, &members, &init, &opts.karcher)?.mean)
            })
            .collect::<Result<_, GeodesicError>>()?;
        let mut it = updated.into_iter();
        for m in means.iter_mut() {
            *m = Some((0..poses).map(|_| it.next().expect("k x poses means")).collect());
        }
        let centres: Vec<&Vec<Pose>> = means.iter().map(|m| m.as_ref().expect("set above")).collect();
        // Assignment: squared similarity of every deformation to every mean it may be closest
        // to (infinite where the mean is provably farther than the best one).
        let mut costs: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|i| assignment_costs(solver, &deformations[i], &centres, assign[i]))
            .collect::<Result<Vec<_>, GeodesicError>>()?
            .concat();
        iterations += 1;
        let mut new: Vec<usize> = (0..n)
            .map(|i| {
                let row = &costs[i * k..(i + 1) * k];
                let mut best = assign[i];
                for c in 0..k {
                    if row[c] < row[best] {
                        best = c;
                    }
                }
                best
            })
            .collect();
        // Refill clusters left empty with the farthest deformations of larger clusters.
        for c in 0..k {
            if new.contains(&c) {
                continue;
            }
            let sizes = crate::cluster::members(&new, k);
            if let Some(i) = (0..n)
                .filter(|&i| sizes[new[i]].len() > 1)
                .max_by(|&a, &b| costs[a * k + new[a]].total_cmp(&costs[b * k + new[b]]))
            {
                new[i] = c;
                if costs[i * k + c].is_infinite() {
                    // An abandoned mean: its objective term is measured in full.
                    let s =
                        squared_similarity(solver, &deformations[i], centres[c], None)?.expect("no bound");
                    costs[i * k + c] = s;
                }
            }
        }
        objective = (0..n).map(|i| costs[i * k + new[i]]).sum();
        if new == assign {
            converged = true;
            break;
        }
        assign = new;
        if iterations >= opts.max_iterations {
            break;
        }
    }
    Ok(IntrinsicClustering {
        assignments: assign,
        means: means.into_iter().map(|m| m.expect("computed")).collect(),
        objective,
        iterations,
        converged,
    })
}

/// The vertex-wise arithmetic mean of poses (each #V x 3, at least one), as the first pose
/// plus the mean difference from it (so that equal poses, such as the common base, give that
/// pose bit for bit): the start of the first round's Karcher means, one Gauss-Newton step or
/// less from them when the poses are close (the Karcher mean of a flat metric).
fn arithmetic_mean(poses: &[&[[f64; 3]]]) -> Pose {
    let k = poses.len() as f64;
    let first = poses[0];
    let mut sum = vec![[0.0; 3]; first.len()];
    for p in &poses[1..] {
        for ((s, v), f) in sum.iter_mut().zip(p.iter()).zip(first) {
            for c in 0..3 {
                s[c] += v[c] - f[c];
            }
        }
    }
    first
        .iter()
        .zip(&sum)
        .map(|(f, s)| [0, 1, 2].map(|c| f[c] + s[c] / k))
        .collect()
}

/// Relative margin by which a partial similarity must exceed the best full one to rule a mean
/// out: partial and full sums are added in different orders, so they may differ by rounding.
const PRUNE_MARGIN: f64 = 1e-9;

/// The squared similarity `(sum_p dis(x_p, mu_p))^2` (eq. 13) of deformation `x` to each of
/// the `means` (k values), or infinity for a mean that cannot be the closest: the mean `first`
/// (the current cluster) is measured first, then the others pose by pose from the last pose
/// (the farthest from the common base, with the largest distances), and a mean is abandoned as
/// soon as its partial sum exceeds the smallest full sum found so far. The distances are
/// non-negative, so an abandoned mean's full similarity is larger: the closest mean (with the
/// same tie-break, the lowest index among equal costs after `first`) and its cost are exactly
/// those of measuring every mean in full, at a fraction of the geodesics. Full sums are added
/// in pose order, as [`pose_distances`] does.
fn assignment_costs(
    solver: &GeodesicSolver,
    x: &[Pose],
    means: &[&Vec<Pose>],
    first: usize,
) -> Result<Vec<f64>, GeodesicError> {
    let mut costs = vec![f64::INFINITY; means.len()];
    let mut best = f64::INFINITY;
    let order = std::iter::once(first).chain((0..means.len()).filter(|&c| c != first));
    for c in order {
        if let Some(cost) = squared_similarity(solver, x, means[c], Some(best))? {
            best = best.min(cost.sqrt());
            costs[c] = cost;
        }
    }
    Ok(costs)
}

/// `(sum_p dis(x_p, mu_p))^2` of deformation `x` to mean `mu` (pose lists of equal length),
/// the poses measured from the last to the first and summed in pose order; `None` as soon as
/// the partial sum exceeds `bound` (a similarity, not squared) by [`PRUNE_MARGIN`].
fn squared_similarity(
    solver: &GeodesicSolver,
    x: &[Pose],
    mu: &[Pose],
    bound: Option<f64>,
) -> Result<Option<f64>, GeodesicError> {
    let limit = bound.map_or(f64::INFINITY, |b| b * (1.0 + PRUNE_MARGIN));
    let mut d = vec![0.0; x.len()];
    let mut partial = 0.0;
    // The poses of one deformation share a preconditioner fit ([`SolveContext`]), and each
    // geodesic starts from the previous pose's.
    let mut ctx = SolveContext::default();
    let mut previous = None;
    for p in (0..x.len()).rev() {
        if x[p] != mu[p] {
            let g = solver.distance_near_with(&mut ctx, &x[p], &mu[p], previous.as_ref(), None)?;
            d[p] = g.length;
            previous = Some(g);
        }
        partial += d[p];
        if partial > limit {
            return Ok(None);
        }
    }
    let s: f64 = d.iter().sum();
    Ok(Some(s * s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::GeodesicOptions;
    use crate::metric::{Isometric, Regularized};
    use crate::synth::icosphere;

    /// The level-1 icosphere and its positions scaled to unit mean edge length (#V x 3).
    fn unit_icosphere() -> (crate::mesh::Shape, Pose) {
        let s = icosphere(1);
        let f = 1.0 / crate::mesh::geometry::mean_edge_length(&s.topology, &s.positions);
        let base = s.positions.iter().map(|p| p.map(|c| c * f)).collect();
        (s, base)
    }

    /// `base` (#V x 3) with coordinate `axis` multiplied by `1 + amp`.
    fn stretched(base: &[[f64; 3]], axis: usize, amp: f64) -> Pose {
        base.iter()
            .map(|p| {
                let mut q = *p;
                q[axis] *= 1.0 + amp;
                q
            })
            .collect()
    }

    /// The 2-segment geodesic solver of `metric` on `s`'s topology.
    fn two_step_solver<'m>(metric: &'m Regularized, s: &crate::mesh::Shape) -> GeodesicSolver<'m> {
        GeodesicSolver::new(
            metric,
            s.topology.clone(),
            GeodesicOptions {
                steps: 2,
                ..Default::default()
            },
        )
        .unwrap()
    }

    /// The first round's Karcher start: the arithmetic mean is exact for equal poses and, for
    /// poses that differ, is fewer Karcher iterations from the mean than the first member.
    #[test]
    fn karcher_means_start_from_the_arithmetic_mean() {
        let (s, base) = unit_icosphere();
        assert_eq!(arithmetic_mean(&[&base, &base, &base]), base);
        let poses = [
            stretched(&base, 0, 0.3),
            stretched(&base, 1, 0.25),
            stretched(&base, 2, 0.35),
        ];
        let members: Vec<&[[f64; 3]]> = poses.iter().map(Vec::as_slice).collect();
        let mid = arithmetic_mean(&members[..2]);
        for ((m, a), b) in mid.iter().zip(&poses[0]).zip(&poses[1]) {
            for c in 0..3 {
                assert!((m[c] - 0.5 * (a[c] + b[c])).abs() < 1e-12);
            }
        }
        let metric = Regularized::new(Box::new(Isometric), 0.1);
        let solver = two_step_solver(&metric, &s);
        let opts = KarcherOptions::default();
        let from_first = karcher_mean(&solver, &members, members[0], &opts).unwrap();
        let from_mean = karcher_mean(&solver, &members, &arithmetic_mean(&members), &opts).unwrap();
        assert!(from_first.converged && from_mean.converged);
        assert!(
            from_mean.iterations < from_first.iterations,
            "{} iterations from the arithmetic mean, {} from the first member",
            from_mean.iterations,
            from_first.iterations
        );
        let rel = (from_mean.variance - from_first.variance).abs() / from_first.variance;
        assert!(
            rel < 1e-4,
            "variances {} and {}",
            from_mean.variance,
            from_first.variance
        );
    }

    #[test]
    fn recovers_two_families_from_a_bad_start() {
        let (s, base) = unit_icosphere();
        // Family 0 stretches along x, family 1 along z, with small amplitude differences.
        let def = |axis: usize, amp: f64| -> Vec<Pose> {
            (0..3)
                .map(|t| stretched(&base, axis, amp * t as f64 / 2.0))
                .collect()
        };
        let defs = vec![
            def(0, 0.3),
            def(0, 0.35),
            def(0, 0.25),
            def(2, 0.3),
            def(2, 0.33),
            def(2, 0.27),
        ];
        let metric = Regularized::new(Box::new(Isometric), 0.1);
        let solver = two_step_solver(&metric, &s);
        // Start with one item of each family misplaced.
        let start = vec![0, 0, 1, 1, 1, 0];
        let r = intrinsic_kmeans(&solver, &defs, &start, 2, &IntrinsicOptions::default()).unwrap();
        assert!(r.converged, "{r:?}");
        let a = &r.assignments;
        assert!(
            a[0] == a[1] && a[1] == a[2] && a[3] == a[4] && a[4] == a[5] && a[0] != a[3],
            "{a:?}"
        );
        // Every mean starts at the common base and lies between its members at the end.
        for m in &r.means {
            assert_eq!(m[0], base);
        }
        assert!(r.objective.is_finite() && r.objective > 0.0);
        assert!(intrinsic_kmeans(&solver, &defs, &[0, 1], 2, &IntrinsicOptions::default()).is_err());

        // The pruned assignment costs pick the mean and the cost of the full ones, whichever
        // mean is measured first.
        let means: Vec<&Vec<Pose>> = defs.iter().collect();
        for (i, x) in defs.iter().enumerate() {
            let full: Vec<f64> = means
                .iter()
                .map(|m| squared_similarity(&solver, x, m, None).unwrap().unwrap())
                .collect();
            for first in [0, 3, 5] {
                let pruned = assignment_costs(&solver, x, &means, first).unwrap();
                assert_eq!(pruned[i], 0.0);
                assert_eq!(pruned[first], full[first]);
                for (c, (p, f)) in pruned.iter().zip(&full).enumerate() {
                    assert!(
                        *p == *f || (p.is_infinite() && *f > 0.0),
                        "{i} {first} {c}: {p} vs {f}"
                    );
                }
            }
        }
    }
}
