//! k-medoids by PAM (Kaufman and Rousseeuw): BUILD then SWAP, on a distance matrix.
//!
//! The objective is `sum_i min_m d(i, m)` over the medoids `m`. Restart 0 starts from the
//! deterministic BUILD; restarts 1.. start from k-means++ seeds (drawn proportionally to the
//! distance to the nearest chosen medoid). Each start is improved by SWAP, which applies the
//! best medoid/non-medoid exchange while it lowers the objective (by more than `1e-12` of it),
//! at most `max_iterations` times.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::{best_of_restarts, ClusterError, ClusterOptions, Clustering};
use crate::similarity::DistanceMatrix;

/// k-medoids (PAM) clustering of the `n` items of a distance matrix into `opts.k` clusters,
/// best of `opts.restarts` starts (module docs). `Clustering::medoids` holds the medoid item
/// of each cluster; every item belongs to its nearest medoid (ties: the lowest cluster).
pub fn kmedoids(d: &DistanceMatrix, opts: &ClusterOptions) -> Result<Clustering, ClusterError> {
    pam(d, opts, true)
}

/// k-medoids (PAM) with every restart, the first included, started from k-means++ random
/// medoids (no BUILD): runs from different seeds share no start, as the stable protocol
/// ([`crate::cluster::stable`]) needs.
pub fn kmedoids_random_starts(d: &DistanceMatrix, opts: &ClusterOptions) -> Result<Clustering, ClusterError> {
    pam(d, opts, false)
}

/// PAM, best of `opts.restarts` starts; restart 0 from BUILD when `build_first`.
fn pam(d: &DistanceMatrix, opts: &ClusterOptions, build_first: bool) -> Result<Clustering, ClusterError> {
    opts.check(d.len())?;
    best_of_restarts(opts.restarts, opts.seed, |r, rng| {
        let start = if r == 0 && build_first {
            build(d, opts.k)
        } else {
            random_start(d, opts.k, rng)
        };
        Ok(swap(d, start, opts.max_iterations))
    })
}

/// BUILD: the item of least total distance, then repeatedly the item that lowers the
/// objective most (ties: the lowest index).
pub fn build(d: &DistanceMatrix, k: usize) -> Vec<usize> {
    let n = d.len();
    let first = (0..n)
        .map(|i| (i, d.row(i).iter().sum::<f64>()))
        .fold((0, f64::INFINITY), |b, c| if c.1 < b.1 { c } else { b })
        .0;
    let mut medoids = vec![first];
    let mut nearest: Vec<f64> = d.row(first).to_vec();
    while medoids.len() < k {
        let mut best: Option<(usize, f64)> = None;
        for h in (0..n).filter(|h| !medoids.contains(h)) {
            let gain: f64 = (0..n).map(|j| (nearest[j] - d.get(j, h)).max(0.0)).sum();
            if best.is_none_or(|b| gain > b.1) {
                best = Some((h, gain));
            }
        }
        let h = best.expect("k <= n").0;
        medoids.push(h);
        for (j, v) in nearest.iter_mut().enumerate() {
            *v = v.min(d.get(j, h));
        }
    }
    medoids
}

/// k-means++-style random medoids: uniform first, then proportional to the distance to the
/// nearest chosen medoid (uniform among the rest when all are zero).
fn random_start(d: &DistanceMatrix, k: usize, rng: &mut ChaCha8Rng) -> Vec<usize> {
    let n = d.len();
    let mut medoids = vec![rng.random_range(0..n)];
    let mut nearest: Vec<f64> = d.row(medoids[0]).to_vec();
    while medoids.len() < k {
        let free: Vec<usize> = (0..n).filter(|i| !medoids.contains(i)).collect();
        let total: f64 = free.iter().map(|&i| nearest[i]).sum();
        let pick = if total > 0.0 {
            let u = rng.random::<f64>() * total;
            let mut acc = 0.0;
            let mut pick = *free.iter().rfind(|&&i| nearest[i] > 0.0).expect("total > 0");
            for &i in &free {
                acc += nearest[i];
                if nearest[i] > 0.0 && u < acc {
                    pick = i;
                    break;
                }
            }
            pick
        } else {
            free[rng.random_range(0..free.len())]
        };
        medoids.push(pick);
        for (j, v) in nearest.iter_mut().enumerate() {
            *v = v.min(d.get(j, pick));
        }
    }
    medoids
}

/// For each item: its nearest medoid's cluster, the distance to it and to the second nearest.
fn nearest_two(d: &DistanceMatrix, medoids: &[usize]) -> (Vec<usize>, Vec<f64>, Vec<f64>) {
    let n = d.len();
    let (mut near, mut d1, mut d2) = (vec![0; n], vec![f64::INFINITY; n], vec![f64::INFINITY; n]);
    for j in 0..n {
        // A medoid always belongs to its own cluster, even when it duplicates another medoid.
        let own = medoids.iter().position(|&m| m == j);
        for (c, &m) in medoids.iter().enumerate() {
            let v = d.get(j, m);
            let closer = match own {
                Some(o) => c == o,
                None => v < d1[j],
            };
            if closer {
                d2[j] = d2[j].min(d1[j]);
                d1[j] = v;
                near[j] = c;
            } else if v < d2[j] {
                d2[j] = v;
            }
        }
    }
    (near, d1, d2)
}

/// SWAP from the given medoids; returns the clustering (restart bookkeeping left empty).
fn swap(d: &DistanceMatrix, mut medoids: Vec<usize>, max_iterations: usize) -> Clustering {
    let n = d.len();
    let k = medoids.len();
    let mut iterations = 0;
    let mut converged = false;
    let (mut near, mut d1, mut d2) = nearest_two(d, &medoids);
    loop {
        let objective: f64 = d1.iter().sum();
        let mut best: Option<(usize, usize, f64)> = None;
        for h in (0..n).filter(|h| !medoids.contains(h)) {
            // Change of the objective when h replaces the medoid of cluster c, for every c.
            let mut delta = vec![0.0; k];
            for j in 0..n {
                let djh = d.get(j, h);
                // Items whose medoid leaves go to h or to their second nearest.
                delta[near[j]] += djh.min(d2[j]) - d1[j];
                // Items of the other clusters move to h if it is closer.
                let gain = (djh - d1[j]).min(0.0);
                for (c, v) in delta.iter_mut().enumerate() {
                    if c != near[j] {
                        *v += gain;
                    }
                }
            }
            for (c, &v) in delta.iter().enumerate() {
                if best.is_none_or(|b| v < b.2) {
                    best = Some((c, h, v));
                }
            }
        }
        match best {
            Some((c, h, v)) if v < -1e-12 * objective.max(f64::MIN_POSITIVE) => {
                if iterations >= max_iterations {
                    break;
                }
                medoids[c] = h;
                iterations += 1;
                (near, d1, d2) = nearest_two(d, &medoids);
            }
            _ => {
                converged = true;
                break;
            }
        }
    }
    Clustering {
        k,
        objective: d1.iter().sum(),
        assignments: near,
        medoids: Some(medoids),
        iterations,
        converged,
        restart: 0,
        restart_objectives: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Two blocks of sizes 4 and 5: distances ~1 inside, ~10 across (items interleaved).
    fn two_blocks() -> (DistanceMatrix, Vec<usize>) {
        let block = [0, 1, 0, 1, 1, 0, 1, 0, 1];
        let names = (0..9).map(|i| format!("x{i}")).collect();
        let d = DistanceMatrix::from_fn(names, |i, j| {
            let wiggle = 0.1 * ((i * 7 + j * 3) % 5) as f64;
            if block[i] == block[j] {
                1.0 + wiggle
            } else {
                10.0 + wiggle
            }
        })
        .unwrap();
        (d, block.to_vec())
    }

    #[test]
    fn two_obvious_blocks_are_recovered() {
        let (d, block) = two_blocks();
        let c = kmedoids(
            &d,
            &ClusterOptions {
                k: 2,
                restarts: 4,
                seed: 7,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(c.assignments, block);
        let med = c.medoids.clone().unwrap();
        assert_eq!(med.len(), 2);
        for (cl, &m) in med.iter().enumerate() {
            assert_eq!(c.assignments[m], cl, "a medoid lies in its own cluster");
        }
        let expected: f64 = (0..9)
            .map(|i| med.iter().map(|&m| d.get(i, m)).fold(f64::INFINITY, f64::min))
            .sum();
        assert!((c.objective - expected).abs() < 1e-12);
    }

    #[test]
    fn swap_reaches_the_brute_force_optimum() {
        // Random points on a line: try every pair of medoids.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let x: Vec<f64> = (0..12).map(|_| rng.random::<f64>() * 10.0).collect();
        let names = (0..12).map(|i| format!("x{i}")).collect();
        let d = DistanceMatrix::from_fn(names, |i, j| (x[i] - x[j]).abs()).unwrap();
        let mut best = f64::INFINITY;
        for a in 0..12 {
            for b in a + 1..12 {
                for c in b + 1..12 {
                    let cost: f64 = (0..12)
                        .map(|i| d.get(i, a).min(d.get(i, b)).min(d.get(i, c)))
                        .sum();
                    best = best.min(cost);
                }
            }
        }
        let c = kmedoids(
            &d,
            &ClusterOptions {
                k: 3,
                restarts: 6,
                seed: 2,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(c.converged);
        assert!((c.objective - best).abs() < 1e-9, "{} vs {best}", c.objective);
        // Every restart is at least as bad as the kept one, and SWAP never worsens BUILD.
        let build_cost: f64 = {
            let m = build(&d, 3);
            (0..12)
                .map(|i| m.iter().map(|&j| d.get(i, j)).fold(f64::INFINITY, f64::min))
                .sum()
        };
        assert!(c.restart_objectives[0] <= build_cost + 1e-12);
        assert!(c.restart_objectives.iter().all(|&o| o >= c.objective));
    }

    #[test]
    fn duplicate_items_still_give_k_nonempty_clusters() {
        let names = (0..4).map(|i| format!("x{i}")).collect();
        let d = DistanceMatrix::new(names, vec![0.0; 16]).unwrap();
        let c = kmedoids(
            &d,
            &ClusterOptions {
                k: 3,
                restarts: 3,
                ..Default::default()
            },
        )
        .unwrap();
        let sizes: Vec<usize> = c.members().iter().map(Vec::len).collect();
        assert!(sizes.iter().all(|&s| s > 0), "{sizes:?}");
        assert_eq!(c.objective, 0.0);
    }
}
