//! The vertex-block term of the default solver's preconditioner.
//!
//! The Kronecker model `T_c (x) A` ([`super::kronecker`]) has one spatial matrix for the whole
//! path; what it cannot represent is how the stiffness of each vertex changes from pose to
//! pose. On fine meshes that is where the default solver spent most of its iterations: after the
//! energy is within about 2e-5 of its minimum, the remaining change of the path is a
//! vertex-scale adjustment, mostly normal to the surface (docs/log/benchmarks.md), in directions the
//! conformal and isometric forms barely resist. The term added here is the block-Jacobi inverse of
//! the Gauss-Newton Hessian: per interior pose `j` and vertex `v`, the inverse of the 3 x 3
//! diagonal block `D_{j,v}` of `J^T J`. The preconditioner becomes the additive (two-level)
//! combination
//!
//! `M^{-1} = (2 T_c (x) A)^{-1} + omega (2 D)^{-1}`,
//!
//! symmetric positive definite whenever the Kronecker part is (each `D_{j,v}` is positive
//! semi-definite; blocks without stiffness are left out).

/// Inverses of the diagonal 3 x 3 blocks of `J^T J`, one per interior pose and vertex
/// (`(N - 1) #V`, pose-major, row-major 3 x 3 each), scaled by the term's weight.
pub(crate) struct VertexBlocks {
    inv: Vec<[f64; 9]>,
}

/// Inverse of a symmetric positive semi-definite 3 x 3 block (row-major) with a relative ridge
/// of `1e-8` of its trace; `None` when the trace is not above `floor` (no stiffness to invert).
fn spd_inverse3(b: &[f64; 9], floor: f64) -> Option<[f64; 9]> {
    let tr = b[0] + b[4] + b[8];
    if tr.is_nan() || tr <= floor {
        return None;
    }
    let r = 1e-8 * tr;
    let (a00, a11, a22) = (b[0] + r, b[4] + r, b[8] + r);
    let (a01, a02, a12) = (0.5 * (b[1] + b[3]), 0.5 * (b[2] + b[6]), 0.5 * (b[5] + b[7]));
    // Adjugate over determinant (the block is symmetric).
    let c00 = a11 * a22 - a12 * a12;
    let c01 = a02 * a12 - a01 * a22;
    let c02 = a01 * a12 - a02 * a11;
    let c11 = a00 * a22 - a02 * a02;
    let c12 = a01 * a02 - a00 * a12;
    let c22 = a00 * a11 - a01 * a01;
    let det = a00 * c00 + a01 * c01 + a02 * c02;
    if !det.is_finite() || det <= 0.0 {
        return None;
    }
    let d = 1.0 / det;
    Some([
        c00 * d,
        c01 * d,
        c02 * d,
        c01 * d,
        c11 * d,
        c12 * d,
        c02 * d,
        c12 * d,
        c22 * d,
    ])
}

impl VertexBlocks {
    /// The term `weight (2 D)^{-1}` from the diagonal blocks `D` of `J^T J` (`(N - 1) #V`
    /// blocks, [`super::kronecker::PoseSum::diagonal`]). Blocks whose trace is below `1e-12`
    /// of the mean trace (a vertex without stiffness) contribute nothing.
    pub fn new(diagonal: &[[f64; 9]], weight: f64) -> Self {
        let mean_trace =
            diagonal.iter().map(|b| b[0] + b[4] + b[8]).sum::<f64>() / diagonal.len().max(1) as f64;
        let floor = 1e-12 * mean_trace.max(f64::MIN_POSITIVE);
        let scale = 0.5 * weight;
        let inv = diagonal
            .iter()
            .map(|b| spd_inverse3(b, floor).map_or([0.0; 9], |m| m.map(|v| v * scale)))
            .collect();
        VertexBlocks { inv }
    }

    /// `q += omega (2 D)^{-1} x` for every vector stored one after the other in `x` and `q`
    /// (each of length `3 (N - 1) #V`, pose-major).
    pub fn add_apply(&self, x: &[f64], q: &mut [f64]) {
        let per = 3 * self.inv.len();
        if per == 0 {
            // No interior poses (one segment): nothing to precondition.
            return;
        }
        for (qv, xv) in q.chunks_exact_mut(per).zip(x.chunks_exact(per)) {
            for ((qb, xb), m) in qv.chunks_exact_mut(3).zip(xv.chunks_exact(3)).zip(&self.inv) {
                for r in 0..3 {
                    qb[r] += m[3 * r] * xb[0] + m[3 * r + 1] * xb[1] + m[3 * r + 2] * xb[2];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_inverse_inverts_and_skips_empty_blocks() {
        let b = [4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0];
        let inv = spd_inverse3(&b, 0.0).unwrap();
        for r in 0..3 {
            for c in 0..3 {
                let v: f64 = (0..3).map(|k| b[3 * r + k] * inv[3 * k + c]).sum();
                let want = if r == c { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-7, "({r}, {c}): {v}");
            }
        }
        assert!(spd_inverse3(&[0.0; 9], 1e-20).is_none());
        // A rank-one block is made invertible by the ridge (positive definite inverse).
        let n = [0.0, 0.6, 0.8];
        let mut rank1 = [0.0; 9];
        for r in 0..3 {
            for c in 0..3 {
                rank1[3 * r + c] = n[r] * n[c];
            }
        }
        let inv = spd_inverse3(&rank1, 0.0).unwrap();
        assert!(inv[0] > 0.0 && inv[4] > 0.0 && inv[8] > 0.0);
    }

    #[test]
    fn add_apply_adds_the_weighted_half_inverse_to_every_vector() {
        let d = [2.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 8.0];
        let vb = VertexBlocks::new(&[d, d], 0.5);
        // Two vectors of two blocks each.
        let x: Vec<f64> = (1..=12).map(f64::from).collect();
        let mut q = vec![1.0; 12];
        vb.add_apply(&x, &mut q);
        for (i, (qi, xi)) in q.iter().zip(&x).enumerate() {
            let want = 1.0 + 0.5 * 0.5 * xi / d[4 * (i % 3)];
            assert!((qi - want).abs() < 1e-7, "{i}: {qi} vs {want}");
        }
    }
}
