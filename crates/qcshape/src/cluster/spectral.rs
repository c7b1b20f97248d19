//! Spectral clustering of a distance matrix (Ng, Jordan and Weiss, "On spectral clustering",
//! NIPS 2001) and k-means in the leading classical-MDS coordinates.
//!
//! Spectral: a Gaussian affinity `W_ij = exp(-d_ij^2 / (2 sigma^2))` (`W_ii = 0`), with
//! `sigma` = `scale` x the median of the off-diagonal distances (the median heuristic); the
//! `k` leading eigenvectors of `D^-1/2 W D^-1/2` (`D` the degrees), each row scaled to unit
//! length, clustered by k-means (Euclidean, seeded restarts). A Gaussian affinity discounts
//! large distances, so a few far items (outliers of a nuisance variation) do not pull a
//! cluster the way they pull a squared-distance k-means.

use faer::{Mat, Side};

use super::{kernel_kmeans, ClusterError, ClusterOptions, Clustering};
use crate::similarity::DistanceMatrix;

/// The median of the off-diagonal entries `d_ij, i < j` (0 for fewer than two items).
pub fn median_distance(d: &DistanceMatrix) -> f64 {
    let n = d.len();
    let mut v: Vec<f64> = (0..n)
        .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
        .map(|(i, j)| d.get(i, j))
        .collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len();
    if m % 2 == 1 {
        v[m / 2]
    } else {
        0.5 * (v[m / 2 - 1] + v[m / 2])
    }
}

/// The Euclidean distance matrix of points (n x dims), named like `names`.
fn points_matrix(names: &[String], x: &[Vec<f64>]) -> Result<DistanceMatrix, ClusterError> {
    DistanceMatrix::from_fn(names.to_vec(), |i, j| {
        x[i].iter()
            .zip(&x[j])
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt()
    })
    .map_err(ClusterError::from)
}

/// The spectral embedding (n x k, rows of unit length) of a distance matrix with the Gaussian
/// affinity of bandwidth `sigma` (module docs).
pub fn spectral_embedding(d: &DistanceMatrix, k: usize, sigma: f64) -> Result<Vec<Vec<f64>>, ClusterError> {
    let n = d.len();
    if !(sigma.is_finite() && sigma > 0.0) {
        return Err(ClusterError::Bandwidth(sigma));
    }
    let w = |i: usize, j: usize| {
        if i == j {
            0.0
        } else {
            (-d.get(i, j).powi(2) / (2.0 * sigma * sigma)).exp()
        }
    };
    // Degrees; a tiny floor keeps an isolated item (all affinities underflow) finite.
    let deg: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| w(i, j)).sum::<f64>().max(1e-300))
        .collect();
    let l = Mat::<f64>::from_fn(n, n, |i, j| w(i, j) / (deg[i] * deg[j]).sqrt());
    let evd = l
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| ClusterError::Eigen)?;
    let u = evd.U();
    // Eigenvalues in nondecreasing order: the leading k are the last columns.
    let mut rows = vec![vec![0.0; k]; n];
    for (c, col) in (0..k).map(|c| (c, n - 1 - c)) {
        for (i, r) in rows.iter_mut().enumerate() {
            r[c] = u[(i, col)];
        }
    }
    for r in &mut rows {
        let norm = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 0.0 {
            r.iter_mut().for_each(|v| *v /= norm);
        }
    }
    Ok(rows)
}

/// Spectral clustering (module docs) into `opts.k` clusters: bandwidth `scale` x the median
/// distance, k-means on the unit rows of the spectral embedding with `opts.restarts` seeded
/// restarts. The objective is that k-means objective (in the embedding, dimensionless).
pub fn spectral(d: &DistanceMatrix, scale: f64, opts: &ClusterOptions) -> Result<Clustering, ClusterError> {
    opts.check(d.len())?;
    let x = spectral_embedding(d, opts.k, scale * median_distance(d))?;
    kernel_kmeans(&points_matrix(d.names(), &x)?, opts)
}

/// k-means (seeded restarts) in the `dims` leading classical-MDS coordinates of the matrix:
/// drops the trailing directions (small or negative eigenvalues of `-1/2 J D^(2) J`) that a
/// non-Euclidean matrix adds to kernel k-means. The objective is the within-cluster sum of
/// squares in those coordinates (units of `d` squared).
pub fn mds_kmeans(
    d: &DistanceMatrix,
    dims: usize,
    opts: &ClusterOptions,
) -> Result<Clustering, ClusterError> {
    opts.check(d.len())?;
    let x = mds_coordinates(d, dims)?;
    kernel_kmeans(&points_matrix(d.names(), &x)?, opts)
}

/// Classical MDS in any dimension: the `dims` leading eigenvectors of `B = -1/2 J D^(2) J`
/// scaled by the square roots of their eigenvalues (0 for non-positive ones); n x dims (dims
/// capped at n). [`crate::embed::classical_mds`] is the 1-3 dimensional version for plots.
pub fn mds_coordinates(d: &DistanceMatrix, dims: usize) -> Result<Vec<Vec<f64>>, ClusterError> {
    let n = d.len();
    let dims = dims.min(n);
    let sq = |i: usize, j: usize| d.get(i, j) * d.get(i, j);
    let row_mean: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| sq(i, j)).sum::<f64>() / n as f64)
        .collect();
    let grand = row_mean.iter().sum::<f64>() / n as f64;
    let b = Mat::<f64>::from_fn(n, n, |i, j| -0.5 * (sq(i, j) - row_mean[i] - row_mean[j] + grand));
    let evd = b
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| ClusterError::Eigen)?;
    let (u, s) = (evd.U(), evd.S().column_vector());
    let mut x = vec![vec![0.0; dims]; n];
    for k in 0..dims {
        let col = n - 1 - k;
        let scale = s[col].max(0.0).sqrt();
        for (i, r) in x.iter_mut().enumerate() {
            r[k] = scale * u[(i, col)];
        }
    }
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Two interleaved half-moons-like groups: a tight ring of 8 around a far, spread arc of
    /// 12 whose ends reach past the ring's own diameter, so squared-distance k-means cuts the
    /// arc while a local affinity keeps it whole.
    fn ring_and_arc() -> (DistanceMatrix, Vec<usize>) {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut p = Vec::new();
        let mut truth = Vec::new();
        for i in 0..8 {
            let a = i as f64 / 8.0 * std::f64::consts::TAU;
            p.push([0.3 * a.cos(), 0.3 * a.sin()]);
            truth.push(0);
        }
        for i in 0..12 {
            let a = -1.2 + 2.4 * i as f64 / 11.0;
            let r = 3.0 + 0.05 * rng.random::<f64>();
            p.push([r * a.cos(), r * a.sin()]);
            truth.push(1);
        }
        let names = (0..p.len()).map(|i| format!("p{i}")).collect::<Vec<_>>();
        let x: Vec<Vec<f64>> = p.iter().map(|q| q.to_vec()).collect();
        (points_matrix(&names, &x).unwrap(), truth)
    }

    #[test]
    fn the_median_is_of_the_upper_triangle() {
        let names = (0..3).map(|i| i.to_string()).collect();
        let d = DistanceMatrix::new(names, vec![0., 1., 5., 1., 0., 2., 5., 2., 0.]).unwrap();
        assert_eq!(median_distance(&d), 2.0);
    }

    #[test]
    fn spectral_keeps_a_curved_group_whole_that_kmeans_cuts() {
        let (d, truth) = ring_and_arc();
        let opts = ClusterOptions {
            k: 2,
            restarts: 10,
            seed: 0,
            ..Default::default()
        };
        let s = spectral(&d, 0.5, &opts).unwrap();
        assert_eq!(s.assignments, truth);
        // The same seed gives the same result.
        assert_eq!(spectral(&d, 0.5, &opts).unwrap(), s);
        let km = kernel_kmeans(&d, &opts).unwrap();
        assert_ne!(km.assignments, truth, "the example must defeat plain k-means");
    }

    #[test]
    fn mds_kmeans_in_all_dimensions_is_kernel_kmeans_on_euclidean_distances() {
        let (d, _) = ring_and_arc();
        let opts = ClusterOptions::default();
        let a = mds_kmeans(&d, d.len(), &opts).unwrap();
        let b = kernel_kmeans(&d, &opts).unwrap();
        assert_eq!(a.assignments, b.assignments);
        assert!((a.objective - b.objective).abs() < 1e-8 * b.objective);
    }

    #[test]
    fn a_bad_bandwidth_is_an_error() {
        let (d, _) = ring_and_arc();
        assert!(matches!(
            spectral_embedding(&d, 2, 0.0),
            Err(ClusterError::Bandwidth(_))
        ));
    }
}
