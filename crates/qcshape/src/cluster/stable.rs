//! A stable clustering protocol (issue 51): the best objective over seeded restarts, with the
//! number of restarts grown until two independent seed streams give the same best partition.
//!
//! One best-of-`R` run ([`best_of_restarts`](super::best_of_restarts)) is a random search: on a
//! matrix whose classes overlap, two seeds can keep different local optima, and an accuracy
//! read off one of them moves with the seed (by up to 0.3 on the robustness benchmark). The
//! protocol runs the search from two seeds (`seeds[0]`, `seeds[1]`, each its own family of
//! ChaCha8 streams) with `R` restarts each, `R = initial_restarts` first, and doubles `R` (up to
//! `max_restarts`) until both keep the same partition in two successive rounds (`R/2` and `R`:
//! two seeds can meet in the same local optimum by chance at few restarts; that doubling the
//! search changes neither is the evidence that the optimum is the best the search finds). The
//! result is the lower-objective of the two seeds' last round (seed 0's on ties; the same
//! partition when they agree), with the restarts per seed used and whether they agreed. Everything is sequential and seeded: the result depends on the
//! matrix and the options only, not on the thread count.
//!
//! For k-medoids the protocol starts every restart from random (k-means++) medoids
//! ([`kmedoids_random_starts`]): PAM's deterministic BUILD start would be shared by both
//! seeds and make their agreement no evidence.

use super::kmedoids::kmedoids_random_starts;
use super::{kernel_kmeans, ClusterError, ClusterOptions, Clustering};
use crate::similarity::DistanceMatrix;

/// Restarts per seed of the protocol's first round: 20 ([`crate::defaults::RESTARTS`]).
pub const INITIAL_RESTARTS: usize = 20;

/// Most restarts per seed the protocol grows to by default: 1,280 (20 doubled six times).
pub const MAX_STABLE_RESTARTS: usize = 1_280;

/// Options of the stable protocol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StableOptions {
    /// Number of clusters `k` (1 <= k <= n).
    pub k: usize,
    /// The two seeds whose best partitions must agree (must differ).
    pub seeds: [u64; 2],
    /// Restarts per seed in the first round (>= 1).
    pub initial_restarts: usize,
    /// Most restarts per seed (`initial_restarts <= max_restarts <=`
    /// [`crate::limits::MAX_RESTARTS`]); the protocol stops there, agreed or not.
    pub max_restarts: usize,
    /// Maximum Lloyd iterations or PAM swaps per run.
    pub max_iterations: usize,
}

impl Default for StableOptions {
    /// `k` 2, seeds 0 and 1, [`INITIAL_RESTARTS`] growing to [`MAX_STABLE_RESTARTS`], 100
    /// iterations.
    fn default() -> Self {
        StableOptions {
            k: 2,
            seeds: [0, 1],
            initial_restarts: INITIAL_RESTARTS,
            max_restarts: MAX_STABLE_RESTARTS,
            max_iterations: 100,
        }
    }
}

impl StableOptions {
    /// The two seeds `seed` and `seed + 1` (wrapping), the other options at their defaults.
    pub fn from_seed(k: usize, seed: u64) -> StableOptions {
        StableOptions {
            k,
            seeds: [seed, seed.wrapping_add(1)],
            ..Default::default()
        }
    }

    /// Checks `1 <= k <= n`, `1 <= initial_restarts <= max_restarts <=`
    /// [`crate::limits::MAX_RESTARTS`] and that the seeds differ.
    pub fn check(&self, n: usize) -> Result<(), ClusterError> {
        if self.k == 0 || self.k > n {
            return Err(ClusterError::BadK { k: self.k, n });
        }
        if self.initial_restarts == 0 {
            return Err(ClusterError::NoRestarts);
        }
        if self.initial_restarts > self.max_restarts || self.max_restarts > crate::limits::MAX_RESTARTS {
            return Err(ClusterError::RestartRange {
                initial: self.initial_restarts,
                max: self.max_restarts,
                limit: crate::limits::MAX_RESTARTS,
            });
        }
        if self.seeds[0] == self.seeds[1] {
            return Err(ClusterError::SameSeeds(self.seeds[0]));
        }
        Ok(())
    }

    /// The options of one seed's run with `restarts` restarts.
    fn run_options(&self, seed: u64, restarts: usize) -> ClusterOptions {
        ClusterOptions {
            k: self.k,
            restarts,
            seed,
            max_iterations: self.max_iterations,
        }
    }
}

/// The result of the stable protocol.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StableClustering {
    /// The kept clustering: the lower objective of the two seeds' last round.
    pub clustering: Clustering,
    /// Restarts per seed in the last round (each seed ran this many; the kept clustering is the
    /// best of them).
    pub restarts: usize,
    /// Whether the two seeds kept the same partition in the last two rounds (false: stopped at
    /// `max_restarts`).
    pub agreed: bool,
    /// Rounds run (restarts doubled `rounds - 1` times).
    pub rounds: usize,
}

/// The stable protocol on any seeded best-of-restarts clustering: `run(options)` must return
/// the best of `options.restarts` runs seeded by `options.seed` with clusters renumbered in
/// order of first appearance (as [`best_of_restarts`](super::best_of_restarts) does), so that
/// equal partitions have equal assignments. `n` is the number of items.
pub fn stable_clustering<E>(
    n: usize,
    opts: &StableOptions,
    mut run: impl FnMut(&ClusterOptions) -> Result<Clustering, E>,
) -> Result<StableClustering, E>
where
    E: From<ClusterError>,
{
    opts.check(n)?;
    let mut restarts = opts.initial_restarts;
    let mut rounds = 0;
    let mut previous: Option<Vec<usize>> = None;
    loop {
        rounds += 1;
        let a = run(&opts.run_options(opts.seeds[0], restarts))?;
        let b = run(&opts.run_options(opts.seeds[1], restarts))?;
        let same = a.assignments == b.assignments;
        let agreed = same && previous.as_ref() == Some(&a.assignments);
        previous = same.then(|| a.assignments.clone());
        if agreed || restarts >= opts.max_restarts {
            let clustering = if b.objective < a.objective { b } else { a };
            return Ok(StableClustering {
                clustering,
                restarts,
                agreed,
                rounds,
            });
        }
        restarts = restarts.saturating_mul(2).min(opts.max_restarts);
    }
}

/// Kernel k-means ([`kernel_kmeans()`]) under the stable protocol.
pub fn stable_kernel_kmeans(
    d: &DistanceMatrix,
    opts: &StableOptions,
) -> Result<StableClustering, ClusterError> {
    stable_clustering(d.len(), opts, |o| kernel_kmeans(d, o))
}

/// k-medoids (PAM from random starts, [`kmedoids_random_starts`]) under the stable protocol.
pub fn stable_kmedoids(d: &DistanceMatrix, opts: &StableOptions) -> Result<StableClustering, ClusterError> {
    stable_clustering(d.len(), opts, |o| kmedoids_random_starts(d, o))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// 8 overlapping blobs of 6 points in the plane (centres 4 apart, spreads up to 6): a
    /// matrix with many local optima.
    fn overlapping_blobs() -> DistanceMatrix {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut pts = Vec::new();
        for b in 0..8 {
            let (cx, cy) = ((b % 4) as f64 * 4.0, (b / 4) as f64 * 4.0);
            let spread = 2.0 + 0.6 * b as f64;
            for _ in 0..6 {
                pts.push([
                    cx + spread * (rng.random::<f64>() - 0.5),
                    cy + spread * (rng.random::<f64>() - 0.5),
                ]);
            }
        }
        let names = (0..pts.len()).map(|i| format!("p{i}")).collect();
        DistanceMatrix::from_fn(names, |i, j| {
            ((pts[i][0] - pts[j][0]).powi(2) + (pts[i][1] - pts[j][1]).powi(2)).sqrt()
        })
        .unwrap()
    }

    /// Checks, for one method, that single runs from two seeds disagree on the matrix and that
    /// the protocol from those two seeds, and from two other seeds, agrees on one partition.
    fn single_runs_disagree_and_the_protocol_agrees(
        d: &DistanceMatrix,
        method: impl Fn(&DistanceMatrix, &ClusterOptions) -> Result<Clustering, ClusterError>,
        stable: impl Fn(&DistanceMatrix, &StableOptions) -> Result<StableClustering, ClusterError>,
    ) {
        let single = |seed| {
            method(
                d,
                &ClusterOptions {
                    k: 8,
                    restarts: 1,
                    seed,
                    max_iterations: 100,
                },
            )
            .unwrap()
            .assignments
        };
        let first = single(0);
        let other = (1..50u64).find(|&s| single(s) != first);
        let other = other.expect("single runs from different seeds disagree on this matrix");
        let opts = |seeds| StableOptions {
            k: 8,
            seeds,
            initial_restarts: 1,
            ..Default::default()
        };
        let a = stable(d, &opts([0, other])).unwrap();
        let b = stable(d, &opts([100, 101])).unwrap();
        assert!(a.agreed && b.agreed, "{} / {} restarts", a.restarts, b.restarts);
        assert_eq!(a.clustering.assignments, b.clustering.assignments);
        assert!((a.clustering.objective - b.clustering.objective).abs() <= 1e-12 * a.clustering.objective);
        // Deterministic.
        assert_eq!(stable(d, &opts([0, other])).unwrap(), a);
    }

    #[test]
    fn the_protocol_gives_one_partition_where_single_kernel_kmeans_runs_disagree() {
        single_runs_disagree_and_the_protocol_agrees(
            &overlapping_blobs(),
            kernel_kmeans,
            stable_kernel_kmeans,
        );
    }

    #[test]
    fn the_protocol_gives_one_partition_where_single_kmedoids_runs_disagree() {
        single_runs_disagree_and_the_protocol_agrees(
            &overlapping_blobs(),
            kmedoids_random_starts,
            stable_kmedoids,
        );
    }

    #[test]
    fn bad_options_are_refused() {
        let d = overlapping_blobs();
        let bad = |o: StableOptions| stable_kernel_kmeans(&d, &o).unwrap_err();
        let base = StableOptions::from_seed(3, 5);
        assert_eq!(base.seeds, [5, 6]);
        assert_eq!(
            bad(StableOptions { k: 0, ..base }),
            ClusterError::BadK { k: 0, n: 48 }
        );
        assert_eq!(
            bad(StableOptions {
                seeds: [2, 2],
                ..base
            }),
            ClusterError::SameSeeds(2)
        );
        assert_eq!(
            bad(StableOptions {
                initial_restarts: 0,
                ..base
            }),
            ClusterError::NoRestarts
        );
        assert!(matches!(
            bad(StableOptions {
                initial_restarts: 30,
                max_restarts: 20,
                ..base
            }),
            ClusterError::RestartRange { .. }
        ));
        assert!(matches!(
            bad(StableOptions {
                max_restarts: usize::MAX,
                ..base
            }),
            ClusterError::RestartRange { .. }
        ));
    }
}
