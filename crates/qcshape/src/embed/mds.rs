//! Multidimensional scaling: classical (Torgerson) MDS and SMACOF on the raw stress (eq. 16).

use faer::{Mat, Side};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use thiserror::Error;

use crate::similarity::DistanceMatrix;

/// Why an embedding cannot be computed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MdsError {
    /// The target dimension is not 1, 2 or 3.
    #[error("the embedding dimension must be 1, 2 or 3, got {0}")]
    Dims(usize),
    /// The eigensolver did not converge.
    #[error("the eigendecomposition of the centred matrix did not converge")]
    Eigen,
    /// An initial configuration of the wrong shape.
    #[error("the initial configuration must be {n} x {dims}")]
    InitShape {
        /// Items.
        n: usize,
        /// Dimension.
        dims: usize,
    },
}

/// Options of [`smacof`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MdsOptions {
    /// Embedding dimension (2 or 3 for maps; 1 is allowed).
    pub dims: usize,
    /// Maximum Guttman iterations.
    pub max_iterations: usize,
    /// Stop when the raw stress decreases by less than this fraction of itself in one
    /// iteration.
    pub tolerance: f64,
    /// Seed of the tiny jitter added to a classical start whose points coincide (e.g. a
    /// dimension without a positive eigenvalue), so SMACOF can move them apart.
    pub seed: u64,
}

impl Default for MdsOptions {
    fn default() -> Self {
        MdsOptions {
            dims: 2,
            max_iterations: 1000,
            tolerance: 1e-10,
            seed: 0,
        }
    }
}

/// An embedding of `n` items in `dims` dimensions.
#[derive(Debug, Clone, PartialEq)]
pub struct Embedding {
    /// Coordinates (n x dims), centred at the origin, in the distance unit.
    pub coords: Vec<Vec<f64>>,
    /// Raw stress (eq. 16): `sum_{i<j} (|x_i - x_j| - d_ij)^2`.
    pub raw_stress: f64,
    /// Kruskal's stress-1: `sqrt(raw / sum_{i<j} d_ij^2)` (0 when all `d_ij` are 0).
    pub normalized_stress: f64,
    /// Guttman iterations done.
    pub iterations: usize,
    /// Whether the relative decrease fell below the tolerance (or the stress reached 0).
    pub converged: bool,
    /// Raw stress of the start and after each iteration (iterations + 1 values); never
    /// increasing (up to rounding).
    pub history: Vec<f64>,
    /// The `dims` largest eigenvalues of the classical MDS start (decreasing).
    pub eigenvalues: Vec<f64>,
}

fn check_dims(dims: usize) -> Result<(), MdsError> {
    if (1..=3).contains(&dims) {
        Ok(())
    } else {
        Err(MdsError::Dims(dims))
    }
}

/// Classical MDS: the `dims` leading eigenvectors of `B = -1/2 J D^(2) J` (`J` the centring
/// matrix), scaled by the square roots of their eigenvalues (0 for non-positive ones).
/// Returns coordinates (n x dims) and the eigenvalues (dims, decreasing; missing ones 0).
/// Each axis is oriented so that its largest-magnitude coordinate is positive.
pub fn classical_mds(d: &DistanceMatrix, dims: usize) -> Result<(Vec<Vec<f64>>, Vec<f64>), MdsError> {
    check_dims(dims)?;
    let n = d.len();
    let sq = |i: usize, j: usize| d.get(i, j) * d.get(i, j);
    let row_mean: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| sq(i, j)).sum::<f64>() / n as f64)
        .collect();
    let grand = row_mean.iter().sum::<f64>() / n as f64;
    let b = Mat::<f64>::from_fn(n, n, |i, j| -0.5 * (sq(i, j) - row_mean[i] - row_mean[j] + grand));
    let evd = b.self_adjoint_eigen(Side::Lower).map_err(|_| MdsError::Eigen)?;
    let (u, s) = (evd.U(), evd.S().column_vector());
    let mut coords = vec![vec![0.0; dims]; n];
    let mut eig = vec![0.0; dims];
    for k in 0..dims.min(n) {
        // Eigenvalues come in nondecreasing order.
        let col = n - 1 - k;
        let lambda = s[col];
        eig[k] = lambda;
        let scale = lambda.max(0.0).sqrt();
        let mut sign = 1.0;
        let mut big = 0.0;
        for i in 0..n {
            let v: f64 = u[(i, col)];
            if v.abs() > big + 1e-12 {
                big = v.abs();
                sign = v.signum();
            }
        }
        for (i, c) in coords.iter_mut().enumerate() {
            c[k] = sign * scale * u[(i, col)];
        }
    }
    Ok((coords, eig))
}

/// Eq. 16, the raw stress `sum_{i<j} (|x_i - x_j| - d_ij)^2` of coordinates (n x dims).
pub fn raw_stress(d: &DistanceMatrix, coords: &[Vec<f64>]) -> f64 {
    let n = d.len();
    let mut s = 0.0;
    for i in 0..n {
        for j in i + 1..n {
            let e = dist(&coords[i], &coords[j]) - d.get(i, j);
            s += e * e;
        }
    }
    s
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// SMACOF with unit weights on the raw stress (eq. 16), started from classical MDS: repeated
/// Guttman transforms `x_i <- (1/n) sum_{j != i} (d_ij / |x_i - x_j|) (x_i - x_j)` (pairs at
/// distance 0 contribute nothing), each of which cannot increase the stress, until the
/// relative decrease is below `opts.tolerance` or `opts.max_iterations`.
pub fn smacof(d: &DistanceMatrix, opts: &MdsOptions) -> Result<Embedding, MdsError> {
    let (mut start, eigenvalues) = classical_mds(d, opts.dims)?;
    jitter_coincident(d, &mut start, opts.seed);
    let mut e = smacof_from(d, start, opts)?;
    e.eigenvalues = eigenvalues;
    Ok(e)
}

/// If two items with `d_ij > 0` sit at the same point, moves every point by a tiny seeded
/// amount (`1e-6` of the largest distance) so that the Guttman transform can separate them.
fn jitter_coincident(d: &DistanceMatrix, x: &mut [Vec<f64>], seed: u64) {
    let n = d.len();
    let scale = d.max();
    let tiny = 1e-9 * scale;
    let stuck = (0..n).any(|i| (i + 1..n).any(|j| d.get(i, j) > tiny && dist(&x[i], &x[j]) <= tiny));
    if !stuck {
        return;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for p in x.iter_mut() {
        for c in p.iter_mut() {
            *c += 1e-6 * scale * (rng.random::<f64>() - 0.5);
        }
    }
}

/// SMACOF (as [`smacof`]) from a given configuration (n x dims).
pub fn smacof_from(
    d: &DistanceMatrix,
    start: Vec<Vec<f64>>,
    opts: &MdsOptions,
) -> Result<Embedding, MdsError> {
    check_dims(opts.dims)?;
    let n = d.len();
    if start.len() != n || start.iter().any(|p| p.len() != opts.dims) {
        return Err(MdsError::InitShape { n, dims: opts.dims });
    }
    let dims = opts.dims;
    let mut x = start;
    // Centre: the Guttman transform keeps the centroid at the origin.
    for k in 0..dims {
        let m = x.iter().map(|p| p[k]).sum::<f64>() / n as f64;
        x.iter_mut().for_each(|p| p[k] -= m);
    }
    let total: f64 = (0..n)
        .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
        .map(|(i, j)| d.get(i, j).powi(2))
        .sum();
    let mut stress = raw_stress(d, &x);
    let mut history = vec![stress];
    let mut iterations = 0;
    let mut converged = stress <= 1e-30 * total.max(f64::MIN_POSITIVE);
    let mut next = vec![vec![0.0; dims]; n];
    while !converged && iterations < opts.max_iterations {
        for (i, out) in next.iter_mut().enumerate() {
            out.iter_mut().for_each(|v| *v = 0.0);
            for j in 0..n {
                if j == i {
                    continue;
                }
                let r = dist(&x[i], &x[j]);
                if r > 0.0 {
                    let w = d.get(i, j) / r;
                    for k in 0..dims {
                        out[k] += w * (x[i][k] - x[j][k]);
                    }
                }
            }
            out.iter_mut().for_each(|v| *v /= n as f64);
        }
        std::mem::swap(&mut x, &mut next);
        iterations += 1;
        let s = raw_stress(d, &x);
        history.push(s);
        let decrease = stress - s;
        stress = s;
        if decrease <= opts.tolerance * history[history.len() - 2] || s <= 1e-30 * total {
            converged = true;
        }
    }
    Ok(Embedding {
        normalized_stress: if total > 0.0 { (stress / total).sqrt() } else { 0.0 },
        raw_stress: stress,
        coords: x,
        iterations,
        converged,
        history,
        eigenvalues: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn matrix_of(points: &[Vec<f64>]) -> DistanceMatrix {
        let names = (0..points.len()).map(|i| format!("p{i}")).collect();
        DistanceMatrix::from_fn(names, |i, j| dist(&points[i], &points[j])).unwrap()
    }

    fn random_points(n: usize, dims: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| (0..dims).map(|_| 10.0 * rng.random::<f64>()).collect())
            .collect()
    }

    #[test]
    fn classical_mds_recovers_a_planar_configuration() {
        let p = random_points(15, 2, 1);
        let d = matrix_of(&p);
        let (x, eig) = classical_mds(&d, 3).unwrap();
        assert!(eig[0] >= eig[1] && eig[1] > 0.0);
        assert!(
            eig[2].abs() < 1e-9 * eig[0],
            "a planar set has no third dimension: {eig:?}"
        );
        let back = matrix_of(&x);
        for (a, b) in d.values().iter().zip(back.values()) {
            assert!((a - b).abs() < 1e-9 * d.max());
        }
    }

    #[test]
    fn smacof_stress_never_increases_and_is_below_the_classical_start() {
        // Points in 5-D seen in 2-D: a real compromise.
        let p = random_points(20, 5, 2);
        let d = matrix_of(&p);
        let e = smacof(&d, &MdsOptions::default()).unwrap();
        assert_eq!(e.history.len(), e.iterations + 1);
        assert!(e.iterations > 1);
        for w in e.history.windows(2) {
            assert!(
                w[1] <= w[0] * (1.0 + 1e-12),
                "stress went up: {} -> {}",
                w[0],
                w[1]
            );
        }
        assert!(e.raw_stress < e.history[0]);
        assert!((e.raw_stress - raw_stress(&d, &e.coords)).abs() < 1e-12 * e.raw_stress);
        assert!(e.normalized_stress > 0.0 && e.normalized_stress < 1.0);
        // Also from a poor (random) start.
        let start = random_points(20, 2, 3);
        let e = smacof_from(
            &d,
            start,
            &MdsOptions {
                max_iterations: 300,
                ..Default::default()
            },
        )
        .unwrap();
        for w in e.history.windows(2) {
            assert!(w[1] <= w[0] * (1.0 + 1e-12));
        }
    }

    #[test]
    fn smacof_recovers_a_planar_configuration_up_to_rigid_motion() {
        let p = random_points(12, 2, 4);
        let d = matrix_of(&p);
        // From a perturbed start, so that SMACOF has work to do.
        let (mut start, _) = classical_mds(&d, 2).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        start
            .iter_mut()
            .flatten()
            .for_each(|v| *v += 0.5 * (rng.random::<f64>() - 0.5));
        let opts = MdsOptions {
            max_iterations: 5000,
            tolerance: 1e-14,
            ..Default::default()
        };
        let e = smacof_from(&d, start, &opts).unwrap();
        assert!(e.normalized_stress < 1e-6, "stress-1 {}", e.normalized_stress);
        // Same pairwise distances means same configuration up to a rigid motion.
        let back = matrix_of(&e.coords);
        for (a, b) in d.values().iter().zip(back.values()) {
            assert!((a - b).abs() < 1e-5 * d.max(), "{a} vs {b}");
        }
        // And the plain call (classical start) is exact at once.
        let e = smacof(&d, &MdsOptions::default()).unwrap();
        assert!(e.normalized_stress < 1e-9, "{}", e.normalized_stress);
    }

    #[test]
    fn degenerate_inputs() {
        let d = DistanceMatrix::new(vec!["a".into()], vec![0.0]).unwrap();
        let e = smacof(&d, &MdsOptions::default()).unwrap();
        assert_eq!(e.coords, vec![vec![0.0, 0.0]]);
        assert_eq!(e.normalized_stress, 0.0);
        // Three points on a line in 3-D: the missing dimensions stay at 0 stress.
        let d = matrix_of(&[vec![0.0], vec![1.0], vec![3.0]]);
        let e = smacof(
            &d,
            &MdsOptions {
                dims: 3,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(e.normalized_stress < 1e-6, "{}", e.normalized_stress);
        assert!(matches!(
            smacof(
                &d,
                &MdsOptions {
                    dims: 4,
                    ..Default::default()
                }
            ),
            Err(MdsError::Dims(4))
        ));
        // All items identical: zero coordinates, zero stress, no NaN.
        let d = DistanceMatrix::new(vec!["a".into(), "b".into()], vec![0.0; 4]).unwrap();
        let e = smacof(&d, &MdsOptions::default()).unwrap();
        assert!(e.coords.iter().flatten().all(|v| *v == 0.0), "{:?}", e.coords);
        assert_eq!(e.raw_stress, 0.0);
    }
}
