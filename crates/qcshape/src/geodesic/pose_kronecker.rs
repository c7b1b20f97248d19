//! The pose-wise Kronecker model of the Gauss-Newton matrix `J^T J` of the path energy
//! ([`super::Preconditioning::PoseKronecker`]).
//!
//! The Kronecker model `T_c (x) A` ([`super::kronecker`]) has one spatial matrix for every
//! interior pose; where the metric's cheap directions change along the path (the conformal
//! metrics with a small L2 weight: a deformation that is nearly conformal at one pose is not at
//! the next) the mean `A` makes every such direction expensive and L-BFGS needs hundreds of
//! iterations to learn it back. This model keeps each interior pose's own diagonal block
//! `A_j` (3 #V x 3 #V, the sum of the blocks of the two segments that meet at pose `j`,
//! factorized as `A_j = F_j F_j^T` with `F_j = P^T L_j`, one numeric Cholesky per pose on the
//! shared symbolic factorization) and couples the poses by the normalized second difference:
//!
//! `M = F (T~ (x) I) F^T`, `T~ = D^{-1/2} T_c D^{-1/2}`, `D = diag(T_c)`,
//!
//! with `T_c` the segment-weighted second difference of the Kronecker model. `M`'s diagonal
//! blocks are the `A_j` exactly, and where `A_j = d_j A` (the Kronecker model's assumption) `M`
//! equals `T_c (x) A`. `M^{-1} = F^{-T} (T~^{-1} (x) I) F^{-1}`: `N - 1` forward and `N - 1`
//! backward triangular solves per application, as for the Kronecker model, with `N - 1`
//! numeric factorizations per refit instead of one.

// Index loops mirror the formulas (vertex, coordinate, pose indices) in these kernels.
#![allow(clippy::needless_range_loop)]

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
use faer::sparse::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_lower_triangular_transpose_in_place,
};
use faer::sparse::SparseColMatRef;
use faer::{Conj, MatMut, Par};
use rayon::prelude::*;

use super::energy::{Ends, PathEnergy};
use super::kronecker::{accumulate_pose_block, tridiagonal_inverse, SpatialLayout};
use super::GeodesicError;
use crate::metric::At;

/// One pose's part of [`PoseBlocks`]: slot blocks, per-vertex diagonal blocks, and the traces
/// of the end part of the segment before it and the start part of the segment after it.
type PoseSlots = (Vec<[f64; 9]>, Vec<[f64; 9]>, [f64; 2]);

/// Each interior pose's diagonal block of `J^T J` (upper-triangle vertex-pair slots), the
/// per-segment traces of the pose blocks, and the per-vertex 3 x 3 diagonal blocks
/// (`(N - 1) #V`, pose-major) for the vertex-block term.
pub(crate) struct PoseBlocks {
    /// `blocks[j]`: pose `j`'s slot blocks (only the upper triangle is filled).
    blocks: Vec<Vec<[f64; 9]>>,
    /// Trace of segment `s`'s pose blocks (both parts) and how many parts it has.
    traces: Vec<f64>,
    parts: Vec<usize>,
    /// The per-vertex diagonal blocks, pose-major.
    pub diagonal: Vec<[f64; 9]>,
}

impl PoseBlocks {
    /// From the metric's residual Jacobians at path `x`: interior pose `j` (path pose `j + 1`)
    /// collects the end part of segment `j` and the start part of segment `j + 1`, both terms
    /// (`At::Start`, `At::End`) of each. Poses are assembled in parallel, each by one job in a
    /// fixed order: the sums do not depend on the thread count.
    pub fn assemble(layout: &SpatialLayout, pe: &PathEnergy, x: &[f64], ends: &Ends) -> Self {
        let st = layout.structure();
        let steps = st.steps;
        let m = steps - 1;
        let pat = &pe.pattern;
        let nv = layout.n_vertices();
        let n_slots = st.pairs.n_slots();
        let per_pose: Vec<PoseSlots> = (0..m)
            .into_par_iter()
            .map(|j| {
                let mut acc = vec![[0.0f64; 9]; n_slots];
                let mut dg = vec![[0.0f64; 9]; nv];
                let mut te = pe.new_term_eval();
                let mut traces = [0.0; 2];
                // (segment, whether the pose is that segment's end)
                for (part, (s, is_end)) in [(j, true), (j + 1, false)].into_iter().enumerate() {
                    for at in [At::Start, At::End] {
                        pe.eval_term(x, ends, s, at, &mut te, true);
                        let d = if is_end { &te.jac.db } else { &te.jac.da };
                        traces[part] += accumulate_pose_block(pat, &st.pairs, d, &mut acc, &mut dg);
                    }
                }
                (acc, dg, traces)
            })
            .collect();
        let mut traces = vec![0.0; steps];
        let mut parts = vec![0usize; steps];
        let mut blocks = Vec::with_capacity(m);
        let mut diagonal = Vec::with_capacity(m * nv);
        for (j, (acc, dg, [t_end, t_start])) in per_pose.into_iter().enumerate() {
            traces[j] += t_end;
            parts[j] += 1;
            traces[j + 1] += t_start;
            parts[j + 1] += 1;
            blocks.push(acc);
            diagonal.extend(dg);
        }
        PoseBlocks {
            blocks,
            traces,
            parts,
            diagonal,
        }
    }
}

/// Work space of [`PoseKronecker::apply_with`], reused across applications.
#[derive(Default)]
pub(crate) struct PoseScratch {
    y: Vec<f32>,
    w: Vec<f32>,
    acc: Vec<f64>,
    mem: Option<(StackReq, MemBuffer)>,
}

/// `F (T~ (x) I) F^T` fitted at one path, factorized (module docs).
pub(crate) struct PoseKronecker {
    /// Cholesky values of each interior pose's block `A_j`, single precision.
    factors: Vec<Vec<f32>>,
    /// `T~^{-1}` (m x m, row-major).
    tinv: Vec<f64>,
}

impl PoseKronecker {
    /// Factorizes every pose block (in parallel; the same ridges as the Kronecker model's
    /// [`SpatialLayout::factorize`]) and the normalized time coupling.
    pub fn fit(layout: &SpatialLayout, pb: &PoseBlocks) -> Result<Self, GeodesicError> {
        let m = pb.blocks.len();
        if m == 0 {
            return Ok(PoseKronecker {
                factors: Vec::new(),
                tinv: Vec::new(),
            });
        }
        let c: Vec<f64> = pb
            .traces
            .iter()
            .zip(&pb.parts)
            .map(|(&t, &p)| t / p.max(1) as f64)
            .collect();
        let cmax = c.iter().cloned().fold(0.0f64, f64::max).max(f64::MIN_POSITIVE);
        let c: Vec<f64> = c.iter().map(|&v| v.max(1e-6 * cmax)).collect();
        let d: Vec<f64> = (0..m).map(|i| c[i] + c[i + 1]).collect();
        let e: Vec<f64> = (0..m.saturating_sub(1))
            .map(|i| -c[i + 1] / (d[i] * d[i + 1]).sqrt())
            .collect();
        let factors = pb
            .blocks
            .par_iter()
            .map(|b| {
                layout
                    .factorize(b)
                    .map(|l| l.iter().map(|&v| v as f32).collect::<Vec<f32>>())
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(PoseKronecker {
            factors,
            tinv: tridiagonal_inverse(&vec![1.0; m], &e),
        })
    }

    /// `q <- factor M^{-1} q` on the pose part (length 3 #V (N - 1), pose-major), or on several
    /// such vectors one after the other. Triangular solves in single precision, the time
    /// mixing accumulated in double.
    pub fn apply_with(&self, layout: &SpatialLayout, q: &mut [f64], factor: f64, scratch: &mut PoseScratch) {
        let n = 3 * layout.n_vertices();
        let m = self.factors.len();
        if m == 0 || q.is_empty() {
            return;
        }
        let symbolic = layout.symbolic();
        let par = Par::Seq;
        let req = symbolic.solve_in_place_scratch::<f32>(1, par);
        if !matches!(&scratch.mem, Some((have, _)) if have.size_bytes() >= req.size_bytes() && have.align_bytes() >= req.align_bytes())
        {
            scratch.mem = Some((req, MemBuffer::new(req)));
        }
        let Some((_, buf)) = scratch.mem.as_mut() else {
            unreachable!("set above")
        };
        let fwd: Option<&[usize]> = symbolic.perm().map(|p| p.arrays().0);
        let (y, w, acc) = (&mut scratch.y, &mut scratch.w, &mut scratch.acc);
        y.resize(n * m, 0.0);
        w.resize(n * m, 0.0);
        acc.resize(n, 0.0);
        for qv in q.chunks_exact_mut(n * m) {
            // y_j = L_j^{-1} P q_j
            for j in 0..m {
                let (src, dst) = (&qv[j * n..(j + 1) * n], &mut y[j * n..(j + 1) * n]);
                match fwd {
                    Some(f) => dst.iter_mut().zip(f).for_each(|(o, &i)| *o = src[i] as f32),
                    None => dst.iter_mut().zip(src).for_each(|(o, &v)| *o = v as f32),
                }
                triangular(symbolic.raw(), &self.factors[j], dst, false, MemStack::new(buf));
            }
            // w_i = sum_j T~^{-1}_ij y_j, then w_i <- L_i^{-T} w_i
            for i in 0..m {
                acc.fill(0.0);
                for j in 0..m {
                    let t = self.tinv[i * m + j];
                    for (a, &v) in acc.iter_mut().zip(&y[j * n..(j + 1) * n]) {
                        *a += t * f64::from(v);
                    }
                }
                let wi = &mut w[i * n..(i + 1) * n];
                wi.iter_mut().zip(acc.iter()).for_each(|(o, &a)| *o = a as f32);
                triangular(symbolic.raw(), &self.factors[i], wi, true, MemStack::new(buf));
                let out = &mut qv[i * n..(i + 1) * n];
                match fwd {
                    Some(f) => f
                        .iter()
                        .zip(wi.iter())
                        .for_each(|(&k, &v)| out[k] = factor * f64::from(v)),
                    None => out
                        .iter_mut()
                        .zip(wi.iter())
                        .for_each(|(o, &v)| *o = factor * f64::from(v)),
                }
            }
        }
    }
}

/// `x <- L^{-1} x` (or `L^{-T} x` with `transpose`) for the factor `values` of `raw`.
fn triangular(
    raw: &SymbolicCholeskyRaw<usize>,
    values: &[f32],
    x: &mut [f32],
    transpose: bool,
    stack: &mut MemStack,
) {
    let n = x.len();
    let rhs = MatMut::from_column_major_slice_mut(x, n, 1);
    match raw {
        SymbolicCholeskyRaw::Simplicial(s) => {
            let l = SparseColMatRef::new(s.factor(), values);
            if transpose {
                solve_lower_triangular_transpose_in_place(l, Conj::No, rhs, Par::Seq);
            } else {
                solve_lower_triangular_in_place(l, Conj::No, rhs, Par::Seq);
            }
        }
        SymbolicCholeskyRaw::Supernodal(s) => {
            let llt = SupernodalLltRef::new(s, values);
            if transpose {
                llt.l_transpose_solve_with_conj(Conj::No, rhs, Par::Seq, stack);
            } else {
                llt.l_solve_with_conj(Conj::No, rhs, Par::Seq, stack);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::geodesic::dot;
    use crate::geodesic::kronecker::{KroneckerModel, PoseSum};
    use crate::metric::{Conformal, ConformalForm, Isometric, Metric, Regularized};

    fn problem<'m>(m: &'m dyn Metric, steps: usize, seed: u64) -> (PathEnergy<'m>, Ends, Vec<f64>) {
        let base = crate::synth::icosphere(1);
        super::super::second_order_tests::random_path(m, &base, steps, &mut ChaCha8Rng::seed_from_u64(seed))
    }

    /// `M^{-1}` is symmetric positive definite, its diagonal blocks invert the assembled pose
    /// blocks (one interior pose: `M = A_0` exactly), and on a path where every pose block is
    /// the same matrix up to a scale it equals the Kronecker model's inverse.
    #[test]
    fn inverse_is_spd_and_reduces_to_the_kronecker_model() {
        let metrics: Vec<Box<dyn Metric>> = vec![
            Box::new(Regularized::new(Box::new(Isometric), 0.1)),
            Box::new(Regularized::new(
                Box::new(Conformal::new(ConformalForm::Quadratic)),
                0.01,
            )),
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for m in &metrics {
            let (pe, ends, x) = problem(m.as_ref(), 4, 3);
            let layout = SpatialLayout::new(&pe).unwrap();
            let pb = PoseBlocks::assemble(&layout, &pe, &x, &ends);
            let model = PoseKronecker::fit(&layout, &pb).unwrap();
            let np = pe.n_pose_vars();
            let u: Vec<f64> = (0..np).map(|_| rng.random_range(-1.0..1.0)).collect();
            let v: Vec<f64> = (0..np).map(|_| rng.random_range(-1.0..1.0)).collect();
            let (mut mu, mut mv) = (u.clone(), v.clone());
            let mut scratch = PoseScratch::default();
            model.apply_with(&layout, &mut mu, 1.0, &mut scratch);
            model.apply_with(&layout, &mut mv, 1.0, &mut scratch);
            let (uv, vu) = (dot(&u, &mv), dot(&v, &mu));
            assert!(
                (uv - vu).abs() <= 1e-4 * uv.abs().max(vu.abs()),
                "not symmetric: {uv} vs {vu}"
            );
            assert!(dot(&u, &mu) > 0.0 && dot(&v, &mv) > 0.0);
            // Two vectors at once give the two single applications.
            let mut both = [u.clone(), v.clone()].concat();
            model.apply_with(&layout, &mut both, 1.0, &mut scratch);
            assert_eq!(&both[..np], &mu[..]);
            assert_eq!(&both[np..], &mv[..]);
        }
        // One interior pose: M = A_0, so M^{-1} (A_0 u) = u (to single precision).
        let m = Regularized::new(Box::new(Isometric), 0.1);
        let (pe, ends, x) = problem(&m, 2, 5);
        let layout = SpatialLayout::new(&pe).unwrap();
        let pb = PoseBlocks::assemble(&layout, &pe, &x, &ends);
        let model = PoseKronecker::fit(&layout, &pb).unwrap();
        let np = pe.n_pose_vars();
        let u: Vec<f64> = (0..np).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut au = sym_mul(&layout, &pb.blocks[0], &u);
        model.apply_with(&layout, &mut au, 1.0, &mut PoseScratch::default());
        let err = u.iter().zip(&au).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 1e-2, "A_0^-1 A_0 u differs from u by {err}");
        // Pose blocks A_j = (c_j + c_{j+1}) B with segment traces c_s tr(B) per part: the
        // Kronecker model's assumption, where both models are T_c (x) B.
        let (pe, ends, x) = problem(&m, 4, 9);
        let layout = SpatialLayout::new(&pe).unwrap();
        let mut pb = PoseBlocks::assemble(&layout, &pe, &x, &ends);
        let c = [1.0, 2.0, 0.5, 1.5];
        let b = pb.blocks[0].clone();
        let trb = layout.trace(&b);
        pb.blocks = (0..3)
            .map(|j| b.iter().map(|blk| blk.map(|v| v * (c[j] + c[j + 1]))).collect())
            .collect();
        for s in 0..4 {
            pb.traces[s] = pb.parts[s] as f64 * c[s] * trb;
        }
        let mut sum = vec![[0.0f64; 9]; b.len()];
        for blocks in &pb.blocks {
            for (acc, blk) in sum.iter_mut().zip(blocks) {
                for k in 0..9 {
                    acc[k] += blk[k];
                }
            }
        }
        let ps = PoseSum::from_parts(sum, pb.traces.clone(), pb.parts.clone(), pb.diagonal.clone());
        let kron = KroneckerModel::fit(&layout, ps).unwrap();
        let pose = PoseKronecker::fit(&layout, &pb).unwrap();
        let u: Vec<f64> = (0..pe.n_pose_vars())
            .map(|_| rng.random_range(-1.0..1.0))
            .collect();
        let (mut a, mut b) = (u.clone(), u.clone());
        kron.apply(&layout, &mut a, 1.0);
        pose.apply_with(&layout, &mut b, 1.0, &mut PoseScratch::default());
        let scale = a.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let err = a.iter().zip(&b).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
        assert!(
            err <= 1e-3 * scale,
            "pose-wise model differs from the Kronecker model: {err} (scale {scale})"
        );
    }

    /// `A u` for the symmetric matrix whose upper-triangle slot blocks are `blk`.
    fn sym_mul(layout: &SpatialLayout, blk: &[[f64; 9]], u: &[f64]) -> Vec<f64> {
        let pairs = &layout.structure().pairs;
        let mut out = vec![0.0; u.len()];
        for v in 0..layout.n_vertices() {
            for slot in pairs.off[v]..pairs.off[v + 1] {
                let w = pairs.rows[slot];
                if w > v {
                    continue;
                }
                // Block (row w, column v), row-major.
                let b = blk[slot];
                for r in 0..3 {
                    for c in 0..3 {
                        out[3 * w + r] += b[3 * r + c] * u[3 * v + c];
                        if w != v {
                            out[3 * v + c] += b[3 * r + c] * u[3 * w + r];
                        }
                    }
                }
            }
        }
        out
    }
}
