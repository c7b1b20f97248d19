//! The Kronecker model `T_c (x) A` of the Gauss-Newton matrix `J^T J` of the path energy,
//! shared by the preconditioned L-BFGS and the truncated Gauss-Newton solvers.
//!
//! `J^T J` is block-tridiagonal in the interior poses: pose `j`'s diagonal block is the sum of
//! the blocks of segments `j - 1` and `j`, the off-diagonal block that of segment `j`. Near a
//! path whose metric matrices differ by a scale from segment to segment, it is close to
//! `T_c (x) A`: `A` (3 #V x 3 #V, sparse with the metric's vertex pattern) the mean diagonal
//! pose block halved, and `T_c` (`N - 1` x `N - 1`) the second difference weighted per segment,
//! diagonal `c_{j-1} + c_j` and off-diagonal `-c_j`, with `c_s` the trace of segment `s`'s blocks
//! relative to `A`'s (the metric may grow or shrink along the path). Its inverse
//! `T_c^{-1} (x) A^{-1}` costs one sparse Cholesky of size 3 #V (symbolic factorization once per
//! topology) and `N - 1` triangular solve pairs per application.

// Index loops mirror the formulas (vertex, coordinate, pose indices) in these kernels.
#![allow(clippy::needless_range_loop)]

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, SymbolicCholesky, SymmetricOrdering};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use super::energy::PathEnergy;
use super::hessian::{SegmentBlocks, Structure};
use super::GeodesicError;

/// Structure of the spatial matrix `A` (upper triangle of 3 x 3 vertex blocks on the metric's
/// vertex-pair set), with its symbolic factorization. Built once per (topology, metric).
pub(crate) struct SpatialLayout {
    nv: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// For value `k` of the CSC: (slot in the vertex-pair set, 3 x 3 component).
    src: Vec<(usize, usize)>,
    diag_idx: Vec<usize>,
    /// Slot of each vertex's diagonal pair `(v, v)` (#V).
    diag_slots: Vec<usize>,
    /// The vertex-pair structure of the blocks of `J^T J`.
    st: Structure,
    symbolic: SymbolicCholesky<usize>,
}

impl SpatialLayout {
    /// The structure of `A` for `pe`'s metric pattern, with its symbolic factorization (AMD).
    pub fn new(pe: &PathEnergy) -> Result<Self, faer::sparse::FaerError> {
        let nv = pe.n_vertices();
        let st = Structure::new(pe);
        let (s_off, s_rows) = (&st.pairs.off, &st.pairs.rows);
        let n = 3 * nv;
        let mut col_ptr = vec![0usize];
        let mut row_idx = Vec::new();
        let mut src = Vec::new();
        let mut diag_idx = Vec::with_capacity(n);
        for v in 0..nv {
            for c in 0..3 {
                for idx in s_off[v]..s_off[v + 1] {
                    let u = s_rows[idx];
                    if u > v {
                        break;
                    }
                    let last = if u == v { c } else { 2 };
                    for cr in 0..=last {
                        if u == v && cr == c {
                            diag_idx.push(row_idx.len());
                        }
                        row_idx.push(3 * u + cr);
                        src.push((idx, cr * 3 + c));
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic =
            factorize_symbolic_cholesky(sym, Side::Upper, SymmetricOrdering::Amd, Default::default())?;
        let diag_slots = (0..nv)
            .map(|v| {
                let r = &s_rows[s_off[v]..s_off[v + 1]];
                s_off[v] + r.binary_search(&v).expect("diagonal pair")
            })
            .collect();
        Ok(SpatialLayout {
            diag_slots,
            nv,
            col_ptr,
            row_idx,
            src,
            diag_idx,
            st,
            symbolic,
        })
    }

    /// The vertex-pair structure (assembles the blocks of `J^T J`).
    pub fn structure(&self) -> &Structure {
        &self.st
    }

    /// Cholesky factor values of the 3 #V x 3 #V matrix whose 3 x 3 block at vertex pair slot
    /// `k` (row `u`, column `v`, row-major; slots of [`VertexPairs::new`] on the metric's
    /// pattern) is `blocks[k]`; the diagonal is floored at `1e-8`
    /// times its largest entry (the matrix is only semi-definite for metrics with null spaces
    /// and `lambda = 0`).
    pub fn factorize(&self, blocks: &[[f64; 9]]) -> Result<Vec<f64>, GeodesicError> {
        let mut vals: Vec<f64> = self.src.iter().map(|&(slot, k)| blocks[slot][k]).collect();
        let dmax = self.diag_idx.iter().map(|&i| vals[i]).fold(0.0f64, f64::max);
        let ridge = 1e-8 * dmax.max(f64::MIN_POSITIVE);
        for &i in &self.diag_idx {
            vals[i] += ridge;
        }
        let n = 3 * self.nv;
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let mut l_values = vec![0.0; self.symbolic.len_val()];
        let par = Par::Seq;
        let mut mem = MemBuffer::new(
            self.symbolic
                .factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        );
        self.symbolic
            .factorize_numeric_llt(
                &mut l_values,
                SparseColMatRef::new(sym, &vals),
                Side::Upper,
                LltRegularization::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| GeodesicError::LinearAlgebra(format!("spatial preconditioner: {e:?}")))?;
        Ok(l_values)
    }

    /// `q <- A^{-1} q` for every column of `q` (column-major, 3 #V rows), `A` factorized by
    /// [`Self::factorize`] into `l_values`.
    pub fn solve(&self, l_values: &[f64], q: &mut [f64]) {
        let n = 3 * self.nv;
        let m = q.len() / n;
        let par = Par::Seq;
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(m, par));
        let llt = faer::sparse::linalg::cholesky::LltRef::new(&self.symbolic, l_values);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(q, n, m),
            par,
            MemStack::new(&mut mem),
        );
    }
}

/// `T_c (x) A` fitted to the blocks of `J^T J` at one path, factorized.
pub(crate) struct KroneckerModel {
    /// Cholesky values of `A`.
    l_values: Vec<f64>,
    /// `T_c^{-1}` (m x m, row-major), `m = N - 1`.
    tinv: Vec<f64>,
}

impl KroneckerModel {
    /// Fits `A` and the segment weights `c_s` to `blocks` (one per segment, from
    /// [`Structure::assemble`]) and factorizes `A`.
    pub fn fit(layout: &SpatialLayout, blocks: &[SegmentBlocks]) -> Result<Self, GeodesicError> {
        let st = &layout.st;
        let steps = st.steps;
        let m = steps - 1;
        // A: mean of the diagonal pose blocks, halved (T has 2 on its diagonal).
        let mut a = vec![[0.0f64; 9]; st.pairs.n_slots()];
        for b in blocks {
            for part in [&b.aa, &b.bb] {
                for (ai, bi) in a.iter_mut().zip(part.iter()) {
                    for k in 0..9 {
                        ai[k] += bi[k];
                    }
                }
            }
        }
        let scale = 0.5 / m as f64;
        a.iter_mut().flatten().for_each(|v| *v *= scale);
        let trace = |blk: &[[f64; 9]]| -> f64 {
            layout
                .diag_slots
                .iter()
                .map(|&i| blk[i][0] + blk[i][4] + blk[i][8])
                .sum()
        };
        let tr_a = trace(&a).max(f64::MIN_POSITIVE);
        // Segment weights: trace of the segment's pose blocks relative to A's.
        let c: Vec<f64> = blocks
            .iter()
            .map(|b| {
                let parts = [&b.aa, &b.bb].iter().filter(|p| !p.is_empty()).count().max(1);
                let t = if b.aa.is_empty() { 0.0 } else { trace(&b.aa) }
                    + if b.bb.is_empty() { 0.0 } else { trace(&b.bb) };
                (t / (parts as f64 * tr_a)).max(1e-6)
            })
            .collect();
        let d: Vec<f64> = (0..m).map(|i| c[i] + c[i + 1]).collect();
        let e: Vec<f64> = (0..m.saturating_sub(1)).map(|i| -c[i + 1]).collect();
        Ok(KroneckerModel {
            l_values: layout.factorize(&a)?,
            tinv: tridiagonal_inverse(&d, &e),
        })
    }

    /// `q <- factor (T_c (x) A)^{-1} q` on the pose part (length 3 #V (N - 1), pose-major).
    pub fn apply(&self, layout: &SpatialLayout, q: &mut [f64], factor: f64) {
        let n = 3 * layout.nv;
        let m = layout.st.steps - 1;
        layout.solve(&self.l_values, q);
        // Time mixing in place, one spatial unknown at a time (no copy of `q`).
        let mut col = vec![0.0; m];
        for k in 0..n {
            for j in 0..m {
                col[j] = q[j * n + k];
            }
            for i in 0..m {
                let row = &self.tinv[i * m..(i + 1) * m];
                q[i * n + k] = factor * row.iter().zip(&col).map(|(t, c)| t * c).sum::<f64>();
            }
        }
    }
}

/// Inverse of the symmetric tridiagonal `T` with diagonal `d` and off-diagonal `e` (m x m,
/// row-major), column by column (Thomas algorithm).
fn tridiagonal_inverse(d: &[f64], e: &[f64]) -> Vec<f64> {
    let m = d.len();
    let mut inv = vec![0.0; m * m];
    for c in 0..m {
        let mut cp = vec![0.0; m];
        let mut rhs: Vec<f64> = (0..m).map(|i| if i == c { 1.0 } else { 0.0 }).collect();
        let mut piv = d[0];
        for i in 0..m {
            if i > 0 {
                piv = d[i] - e[i - 1] * cp[i - 1];
                rhs[i] -= e[i - 1] * rhs[i - 1];
            }
            if i + 1 < m {
                cp[i] = e[i] / piv;
            }
            rhs[i] /= piv;
        }
        for i in (0..m.saturating_sub(1)).rev() {
            rhs[i] -= cp[i] * rhs[i + 1];
        }
        for i in 0..m {
            inv[i * m + c] = rhs[i];
        }
    }
    inv
}
