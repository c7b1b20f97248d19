//! Three-dimensional thin-plate splines from corresponding landmarks (Bookstein; the paper's
//! registration step, section 4.2, ref. 47).
//!
//! `f(x) = A x + b + sum_i w_i U(|x - c_i|)` with the 3D biharmonic kernel `U(r) = r`, fitted
//! by solving the `(n + 4)` square system
//!
//! ```text
//! [ K - lambda I   P ] [ W ]   [ Y ]
//! [ P^T            0 ] [ a ] = [ 0 ]      K_ij = |c_i - c_j|,  P_i = [1, c_i]
//! ```
//!
//! (dense LU with full pivoting, faer). `K` is conditionally *negative* definite for `U = r`, so
//! the smoothing term enters with a minus sign (it is `+lambda` for the usual `-r` kernel). With `lambda = 0` the map interpolates the landmarks
//! exactly; `lambda > 0` trades exactness for smoothness. Coordinates are centred and scaled
//! to unit RMS radius before solving (for conditioning), and the coefficients are mapped back,
//! so [`Tps`] evaluates directly in world mm.

use faer::linalg::solvers::Solve;
use faer::Mat;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why a spline cannot be fitted.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TpsError {
    /// Source and target counts differ, or fewer than 4 landmarks.
    #[error(
        "need at least 4 corresponding landmarks, got {source_count} sources and {target_count} targets"
    )]
    Count {
        /// Number of source points.
        source_count: usize,
        /// Number of target points.
        target_count: usize,
    },
    /// A coordinate or the regularization is NaN or infinite, or the regularization is negative.
    #[error("non-finite landmark coordinate or bad regularization {0}")]
    NonFinite(f64),
    /// The source landmarks are (nearly) coplanar, so the affine part is undetermined.
    #[error("the source landmarks are coplanar or collinear: the affine part is undetermined")]
    Coplanar,
    /// Two source landmarks coincide.
    #[error("source landmarks {0} and {1} coincide")]
    Duplicate(usize, usize),
    /// The solve failed (residual too large or non-finite solution).
    #[error("the spline system is singular (relative residual {0:e})")]
    Singular(f64),
}

/// A fitted 3D thin-plate spline `R^3 -> R^3` (world mm to world mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tps {
    /// Kernel centres `c_i` (the source landmarks, #n x 3, mm).
    pub centres: Vec<[f64; 3]>,
    /// Kernel weights `w_i` (#n x 3; output component per column).
    pub weights: Vec<[f64; 3]>,
    /// Linear part `A` (row r gives output component r).
    pub linear: [[f64; 3]; 3],
    /// Translation `b` (mm).
    pub translation: [f64; 3],
    /// The regularization `lambda` used (in the normalized units).
    pub regularization: f64,
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

impl Tps {
    /// The identity map (no kernels).
    pub fn identity() -> Tps {
        Tps {
            centres: Vec::new(),
            weights: Vec::new(),
            linear: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            translation: [0.0; 3],
            regularization: 0.0,
        }
    }

    /// Fits the spline taking `source[i]` to `target[i]` (#n x 3 each, n >= 4, sources not
    /// coplanar and distinct), with regularization `lambda >= 0` (0: exact interpolation).
    pub fn fit(source: &[[f64; 3]], target: &[[f64; 3]], lambda: f64) -> Result<Tps, TpsError> {
        let n = source.len();
        if n != target.len() || n < 4 {
            return Err(TpsError::Count {
                source_count: n,
                target_count: target.len(),
            });
        }
        if !(lambda.is_finite() && lambda >= 0.0) {
            return Err(TpsError::NonFinite(lambda));
        }
        if let Some(v) = source.iter().chain(target).flatten().find(|v| !v.is_finite()) {
            return Err(TpsError::NonFinite(*v));
        }
        // Normalize: centre and unit RMS radius.
        let mut centre = [0.0; 3];
        for p in source {
            for c in 0..3 {
                centre[c] += p[c] / n as f64;
            }
        }
        let rms = (source.iter().map(|p| dist(*p, centre).powi(2)).sum::<f64>() / n as f64).sqrt();
        if rms == 0.0 {
            return Err(TpsError::Coplanar);
        }
        let u: Vec<[f64; 3]> = source
            .iter()
            .map(|p| std::array::from_fn(|c| (p[c] - centre[c]) / rms))
            .collect();
        // Coplanarity: the normalized covariance must have a determinant well above zero.
        let mut cov = [[0.0; 3]; 3];
        for p in &u {
            for r in 0..3 {
                for c in 0..3 {
                    cov[r][c] += p[r] * p[c] / n as f64;
                }
            }
        }
        let det = cov[0][0] * (cov[1][1] * cov[2][2] - cov[1][2] * cov[2][1])
            - cov[0][1] * (cov[1][0] * cov[2][2] - cov[1][2] * cov[2][0])
            + cov[0][2] * (cov[1][0] * cov[2][1] - cov[1][1] * cov[2][0]);
        // trace = 1, so det <= 1/27; below 1e-9 of that the points are practically coplanar.
        if det < 1e-9 / 27.0 {
            return Err(TpsError::Coplanar);
        }
        for i in 0..n {
            for j in i + 1..n {
                if dist(u[i], u[j]) < 1e-9 {
                    return Err(TpsError::Duplicate(i, j));
                }
            }
        }
        let m = n + 4;
        let mut a = Mat::<f64>::zeros(m, m);
        let mut rhs = Mat::<f64>::zeros(m, 3);
        for i in 0..n {
            for j in 0..n {
                // U(r) = r is minus the (conditionally positive definite) biharmonic Green's
                // function, so smoothing subtracts lambda on the diagonal.
                a[(i, j)] = dist(u[i], u[j]) - if i == j { lambda } else { 0.0 };
            }
            a[(i, n)] = 1.0;
            a[(n, i)] = 1.0;
            for c in 0..3 {
                a[(i, n + 1 + c)] = u[i][c];
                a[(n + 1 + c, i)] = u[i][c];
                rhs[(i, c)] = target[i][c];
            }
        }
        let x = a.full_piv_lu().solve(&rhs);
        // Residual check in the normalized system.
        let r = &a * &x - &rhs;
        let scale = rhs.norm_l2().max(1e-300);
        let rel = r.norm_l2() / scale;
        if !rel.is_finite() || rel > 1e-8 || (0..m).any(|i| (0..3).any(|c| !x[(i, c)].is_finite())) {
            return Err(TpsError::Singular(rel));
        }
        // Back to world units: |u - u_i| = |x - c_i| / rms, u = (x - centre) / rms.
        let weights: Vec<[f64; 3]> = (0..n).map(|i| std::array::from_fn(|c| x[(i, c)] / rms)).collect();
        let mut linear = [[0.0; 3]; 3];
        let mut translation = [0.0; 3];
        for out in 0..3 {
            translation[out] = x[(n, out)];
            for k in 0..3 {
                linear[out][k] = x[(n + 1 + k, out)] / rms;
                translation[out] -= linear[out][k] * centre[k];
            }
        }
        Ok(Tps {
            centres: source.to_vec(),
            weights,
            linear,
            translation,
            regularization: lambda,
        })
    }

    /// The image `f(p)` of a point (mm).
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let mut out: [f64; 3] = std::array::from_fn(|r| {
            self.translation[r]
                + self.linear[r][0] * p[0]
                + self.linear[r][1] * p[1]
                + self.linear[r][2] * p[2]
        });
        for (c, w) in self.centres.iter().zip(&self.weights) {
            let d = dist(p, *c);
            for r in 0..3 {
                out[r] += w[r] * d;
            }
        }
        out
    }

    /// Applies the map to every point (#V x 3).
    pub fn apply_all(&self, points: &[[f64; 3]]) -> Vec<[f64; 3]> {
        points.iter().map(|p| self.apply(*p)).collect()
    }

    /// Bending energy `-sum_ij w_i . w_j U(|c_i - c_j|)` summed over the output components
    /// (>= 0, up to the kernel's constant `1 / 8 pi`; 0 for an affine map).
    pub fn bending_energy(&self) -> f64 {
        let mut e = 0.0;
        for (ci, wi) in self.centres.iter().zip(&self.weights) {
            for (cj, wj) in self.centres.iter().zip(&self.weights) {
                e += dist(*ci, *cj) * (wi[0] * wj[0] + wi[1] * wj[1] + wi[2] * wj[2]);
            }
        }
        (-e).max(0.0)
    }
}
