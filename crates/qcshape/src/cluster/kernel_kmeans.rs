//! Kernel k-means: k-means (eq. 14) from a distance matrix alone, on squared distances with
//! implicit centroids (not the intrinsic k-means of [`crate::cluster::intrinsic`]).
//!
//! With `D2 = (d_ij^2)`, the squared distance of item `i` to the (implicit) centroid of a
//! cluster `C` is
//!
//! ```text
//! cost(i, C) = (1/|C|) sum_{j in C} d_ij^2  -  (1/(2 |C|^2)) sum_{j,l in C} d_jl^2,
//! ```
//!
//! exact when the `d_ij` are Euclidean distances between points (the centroid is then their
//! mean), and the usual kernel k-means cost with the kernel `-D2/2` (double-centred) otherwise.
//! The objective, the sum of each item's cost to its own cluster, is
//! `sum_C (1/(2|C|)) sum_{j,l in C} d_jl^2`: the within-cluster sum of squares.

use super::{lloyd_restarts, CentreModel, ClusterError, ClusterOptions, Clustering};
use crate::similarity::DistanceMatrix;

/// The kernel k-means model over a [`DistanceMatrix`] (squared distances cached, n x n).
#[derive(Debug, Clone)]
pub struct KernelKMeans {
    n: usize,
    sq: Vec<f64>,
}

/// An implicit centroid: its members and their constant term
/// `(1/(2|C|^2)) sum_{j,l in C} d_jl^2`.
#[derive(Debug, Clone, PartialEq)]
pub struct ImplicitCentre {
    /// The members (item indices).
    pub members: Vec<usize>,
    /// `(1/(2|C|^2)) sum_{j,l in C} d_jl^2`.
    pub spread: f64,
}

impl KernelKMeans {
    /// The model for a matrix (caches its squared entries).
    pub fn new(d: &DistanceMatrix) -> KernelKMeans {
        KernelKMeans {
            n: d.len(),
            sq: d.values().iter().map(|v| v * v).collect(),
        }
    }

    fn centre(&self, members: &[usize]) -> ImplicitCentre {
        let m = members.len() as f64;
        let total: f64 = members
            .iter()
            .map(|&j| members.iter().map(|&l| self.sq[j * self.n + l]).sum::<f64>())
            .sum();
        ImplicitCentre {
            members: members.to_vec(),
            spread: total / (2.0 * m * m),
        }
    }
}

impl CentreModel for KernelKMeans {
    type Centre = ImplicitCentre;
    type Error = ClusterError;

    fn n_items(&self) -> usize {
        self.n
    }

    fn cost(&self, i: usize, c: &ImplicitCentre) -> f64 {
        let row = &self.sq[i * self.n..(i + 1) * self.n];
        let mean = c.members.iter().map(|&j| row[j]).sum::<f64>() / c.members.len() as f64;
        mean - c.spread
    }

    fn singleton(&self, i: usize) -> ImplicitCentre {
        ImplicitCentre {
            members: vec![i],
            spread: 0.0,
        }
    }

    fn update(&self, members: &[usize], _previous: &ImplicitCentre) -> Result<ImplicitCentre, ClusterError> {
        Ok(self.centre(members))
    }
}

/// Kernel k-means of the `n` items of a distance matrix into `opts.k` clusters: k-means on
/// squared distances with implicit centroids (module docs), k-means++ seeding on squared
/// distances, Lloyd iterations, best of `opts.restarts` seeded runs. The objective is the
/// within-cluster sum of squared distances to the (implicit) centroids.
///
/// This is eq. 14 from the matrix alone; the paper's k-means with intrinsic means (class means
/// that are deformations, Karcher means of poses) is
/// [`crate::cluster::intrinsic_kmeans`], which is usually started from this partition.
/// (Formerly `cluster::kmeans`.)
pub fn kernel_kmeans(d: &DistanceMatrix, opts: &ClusterOptions) -> Result<Clustering, ClusterError> {
    lloyd_restarts(&KernelKMeans::new(d), opts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn points_matrix(p: &[[f64; 2]]) -> DistanceMatrix {
        let names = (0..p.len()).map(|i| format!("p{i}")).collect();
        DistanceMatrix::from_fn(names, |i, j| {
            ((p[i][0] - p[j][0]).powi(2) + (p[i][1] - p[j][1]).powi(2)).sqrt()
        })
        .unwrap()
    }

    #[test]
    fn implicit_cost_is_the_squared_distance_to_the_centroid() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let p: Vec<[f64; 2]> = (0..7).map(|_| [rng.random(), rng.random()]).collect();
        let d = points_matrix(&p);
        let model = KernelKMeans::new(&d);
        let members = [1, 3, 4, 6];
        let c = model.centre(&members);
        let mean = members
            .iter()
            .fold([0.0; 2], |a, &j| [a[0] + p[j][0] / 4.0, a[1] + p[j][1] / 4.0]);
        for (i, q) in p.iter().enumerate() {
            let exact = (q[0] - mean[0]).powi(2) + (q[1] - mean[1]).powi(2);
            assert!((model.cost(i, &c) - exact).abs() < 1e-12, "{i}");
        }
    }

    #[test]
    fn three_blobs_are_found_and_the_objective_is_the_within_sum_of_squares() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let centres = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]];
        let p: Vec<[f64; 2]> = (0..30)
            .map(|i| {
                let c = centres[i % 3];
                [c[0] + rng.random::<f64>() - 0.5, c[1] + rng.random::<f64>() - 0.5]
            })
            .collect();
        let d = points_matrix(&p);
        let opts = ClusterOptions {
            k: 3,
            restarts: 5,
            seed: 1,
            ..Default::default()
        };
        let c = kernel_kmeans(&d, &opts).unwrap();
        assert!(c.converged);
        for i in 0..30 {
            assert_eq!(c.assignments[i], c.assignments[i % 3], "item {i}");
        }
        assert_eq!(&c.assignments[..3], &[0, 1, 2]);
        let mut wss = 0.0;
        for g in c.members() {
            let m = g.len() as f64;
            let mean = g
                .iter()
                .fold([0.0; 2], |a, &j| [a[0] + p[j][0] / m, a[1] + p[j][1] / m]);
            wss += g
                .iter()
                .map(|&j| (p[j][0] - mean[0]).powi(2) + (p[j][1] - mean[1]).powi(2))
                .sum::<f64>();
        }
        assert!((c.objective - wss).abs() < 1e-9 * wss, "{} vs {wss}", c.objective);
        assert_eq!(c.restart_objectives.len(), 5);
        assert!(c.restart_objectives.iter().all(|&o| o >= c.objective));
        // Same seed, same result.
        assert_eq!(kernel_kmeans(&d, &opts).unwrap(), c);
    }

    #[test]
    fn duplicates_and_k_equal_n_leave_no_cluster_empty() {
        let d = points_matrix(&[[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [1.0, 0.0]]);
        for k in 1..=4 {
            let c = kernel_kmeans(
                &d,
                &ClusterOptions {
                    k,
                    restarts: 3,
                    ..Default::default()
                },
            )
            .unwrap();
            let sizes: Vec<usize> = c.members().iter().map(Vec::len).collect();
            assert!(sizes.iter().all(|&s| s > 0), "k = {k}: {sizes:?}");
            assert!(c.objective.is_finite() && c.objective >= -1e-12);
        }
        assert!(matches!(
            kernel_kmeans(
                &d,
                &ClusterOptions {
                    k: 5,
                    ..Default::default()
                }
            ),
            Err(ClusterError::BadK { k: 5, n: 4 })
        ));
    }
}
