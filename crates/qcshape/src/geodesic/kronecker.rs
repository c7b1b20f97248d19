//! The Kronecker model `T_c (x) A` of the Gauss-Newton matrix `J^T J` of the path energy,
//! the preconditioner of the default L-BFGS solver.
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
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use rayon::prelude::*;

use super::energy::{Ends, PathEnergy};
use super::hessian::{outer_add, SegmentBlocks, Structure};
use super::pairs::VertexPairs;
use super::{GeodesicError, LinearAlgebraError};
use crate::mesh::geometry::{dot, scale};
use crate::metric::{At, Pattern};

/// One chunk's part of a [`PoseSum`]: slot sums, `(segment, (trace, parts))`, diagonal blocks.
type ChunkSum = (Vec<[f64; 9]>, Vec<(usize, (f64, usize))>, Vec<[f64; 9]>);

/// Segments per parallel work item of [`PoseSum::assemble`] (a constant, so that the order of
/// the floating-point sums does not depend on the thread count).
const POSE_SUM_CHUNK: usize = 2;

/// Multiple of faer's supernodal flop-ratio threshold used by [`SpatialLayout::new`] (faer's
/// default is 1).
const SUPERNODAL_THRESHOLD: f64 = 0.25;

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
        // faer picks the supernodal factorization when the factor's flops per stored value
        // exceed 40; the 2-ring patterns of the isometric and conformal metrics at 162 vertices
        // (L with 34,000 values for a 486 x 486 matrix) fall just below and run the simplicial
        // kernels, about 30 % slower per geodesic there. A quarter of faer's threshold (10 flops
        // per value) keeps the block-diagonal patterns (rigid, L2: 3 x 3 blocks) simplicial.
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold(SUPERNODAL_THRESHOLD),
            ..Default::default()
        };
        let symbolic = factorize_symbolic_cholesky(sym, Side::Upper, SymmetricOrdering::Amd, params)?;
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

    /// Trace of the 3 #V x 3 #V matrix with vertex-pair blocks `blk` (slots of the structure).
    pub fn trace(&self, blk: &[[f64; 9]]) -> f64 {
        self.diag_slots
            .iter()
            .map(|&i| blk[i][0] + blk[i][4] + blk[i][8])
            .sum()
    }

    /// The vertex-pair structure (assembles the blocks of `J^T J`).
    pub fn structure(&self) -> &Structure {
        &self.st
    }

    /// Number of vertices #V (the matrix is 3 #V x 3 #V).
    pub fn n_vertices(&self) -> usize {
        self.nv
    }

    /// The symbolic Cholesky factorization of `A`'s structure (AMD ordering).
    pub fn symbolic(&self) -> &SymbolicCholesky<usize> {
        &self.symbolic
    }

    /// Cholesky factor values of the 3 #V x 3 #V matrix whose 3 x 3 block at vertex pair slot
    /// `k` (row `u`, column `v`, row-major; slots of [`VertexPairs::new`] on the metric's
    /// pattern) is `blocks[k]`; `1e-8` times the largest diagonal entry is added to the diagonal
    /// (the matrix is only semi-definite for metrics with null spaces, such as rigid motions of
    /// the rigid metric, and `lambda = 0`), and where a pivot is still not positive (round-off on
    /// a singular matrix) the factorization is repeated with ridges `1e-6` and `1e-4` times that
    /// entry (a preconditioner only needs to be positive definite, not exact).
    pub fn factorize(&self, blocks: &[[f64; 9]]) -> Result<Vec<f64>, GeodesicError> {
        let vals: Vec<f64> = self.src.iter().map(|&(slot, k)| blocks[slot][k]).collect();
        let dmax = self.diag_idx.iter().map(|&i| vals[i]).fold(0.0f64, f64::max);
        if !dmax.is_finite() || vals.iter().any(|v| !v.is_finite()) {
            return Err(GeodesicError::LinearAlgebra {
                what: "the spatial preconditioner",
                source: LinearAlgebraError::NonFinite,
            });
        }
        let mut last = None;
        for relative in [1e-8, 1e-6, 1e-4] {
            let ridge = relative * dmax.max(f64::MIN_POSITIVE);
            let mut v = vals.clone();
            for &i in &self.diag_idx {
                v[i] += ridge;
            }
            match self.factorize_values(&v) {
                Ok(l) => return Ok(l),
                Err(e) => last = Some(e),
            }
        }
        Err(GeodesicError::LinearAlgebra {
            what: "the spatial preconditioner",
            source: last.expect("three attempts").into(),
        })
    }

    /// Cholesky factor values of the upper CSC values `vals` (the layout's structure).
    fn factorize_values(
        &self,
        vals: &[f64],
    ) -> Result<Vec<f64>, faer::linalg::cholesky::llt::factor::LltError> {
        let n = 3 * self.nv;
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let mut l_values = vec![0.0; self.symbolic.len_val()];
        let par = Par::Seq;
        let mut mem = MemBuffer::new(
            self.symbolic
                .factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        );
        self.symbolic.factorize_numeric_llt(
            &mut l_values,
            SparseColMatRef::new(sym, vals),
            Side::Upper,
            LltRegularization::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        )?;
        Ok(l_values)
    }

    /// `q <- A^{-1} q` for every column of `q` (column-major, 3 #V rows), `A` factorized by
    /// [`Self::factorize`] into `l_values` (any precision faer supports: the preconditioners
    /// keep the factor in single precision). faer's work space is kept in `mem` between calls
    /// (grown when a call needs more), so a warm solve allocates nothing.
    pub fn solve_with<T: faer::traits::ComplexField>(
        &self,
        l_values: &[T],
        q: &mut [T],
        mem: &mut Option<(faer::dyn_stack::StackReq, MemBuffer)>,
    ) {
        let n = 3 * self.nv;
        let m = q.len() / n;
        let par = Par::Seq;
        let req = self.symbolic.solve_in_place_scratch::<T>(m, par);
        if !matches!(mem, Some((have, _)) if have.size_bytes() >= req.size_bytes() && have.align_bytes() >= req.align_bytes())
        {
            *mem = Some((req, MemBuffer::new(req)));
        }
        let Some((_, buf)) = mem.as_mut() else {
            unreachable!("set above")
        };
        let llt = faer::sparse::linalg::cholesky::LltRef::new(&self.symbolic, l_values);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(q, n, m),
            par,
            MemStack::new(buf),
        );
    }
}

/// Work space of [`KroneckerModel::apply_with`], reused across applications.
#[derive(Default)]
pub(crate) struct ApplyScratch {
    q32: Vec<f32>,
    mem: Option<(faer::dyn_stack::StackReq, MemBuffer)>,
}

/// `T_c (x) A` fitted to the blocks of `J^T J` at one path, factorized.
pub(crate) struct KroneckerModel {
    /// Cholesky values of `A`, factorized in double precision and kept in single: the
    /// triangular solves are bound by the factor's arithmetic and memory traffic (about a
    /// million values at 2,562 vertices), and a preconditioner needs no more than single
    /// precision.
    l_values: Vec<f32>,
    /// `T_c^{-1}` (m x m, row-major), `m = N - 1`.
    tinv: Vec<f64>,
}

/// What the preconditioners need from `J^T J`: the sum of every segment's pose blocks
/// (`aa + bb`, 3 x 3 per vertex-pair slot) and per segment the trace of its pose blocks and
/// how many it has (2, or 1 for a segment with a fixed end), for the Kronecker fit; and the
/// diagonal 3 x 3 block of every interior pose's vertex (`(N - 1) #V`, pose-major), for the
/// vertex-block term ([`super::vertex_blocks::VertexBlocks`]).
pub(crate) struct PoseSum {
    sum: Vec<[f64; 9]>,
    traces: Vec<f64>,
    parts: Vec<usize>,
    pub diagonal: Vec<[f64; 9]>,
}

impl PoseSum {
    /// A sum from its parts (tests).
    #[cfg(test)]
    pub fn from_parts(
        sum: Vec<[f64; 9]>,
        traces: Vec<f64>,
        parts: Vec<usize>,
        diagonal: Vec<[f64; 9]>,
    ) -> Self {
        PoseSum {
            sum,
            traces,
            parts,
            diagonal,
        }
    }

    /// From assembled segment blocks ([`Structure::assemble`]).
    pub fn from_blocks(layout: &SpatialLayout, blocks: &[SegmentBlocks]) -> Self {
        let mut sum = vec![[0.0f64; 9]; layout.st.pairs.n_slots()];
        let mut traces = Vec::with_capacity(blocks.len());
        let mut parts = Vec::with_capacity(blocks.len());
        for b in blocks {
            let (mut t, mut p) = (0.0, 0);
            for part in [&b.aa, &b.bb] {
                if part.is_empty() {
                    continue;
                }
                for (si, bi) in sum.iter_mut().zip(part.iter()) {
                    for k in 0..9 {
                        si[k] += bi[k];
                    }
                }
                t += layout.trace(part);
                p += 1;
            }
            traces.push(t);
            parts.push(p);
        }
        // Interior pose j: bb of segment j - 1 plus aa of segment j.
        let nv = layout.nv;
        let mut diagonal = vec![[0.0f64; 9]; blocks.len().saturating_sub(1) * nv];
        for (j, dj) in diagonal.chunks_exact_mut(nv).enumerate() {
            for part in [&blocks[j].bb, &blocks[j + 1].aa] {
                if part.is_empty() {
                    continue;
                }
                for (d, &slot) in dj.iter_mut().zip(&layout.diag_slots) {
                    for k in 0..9 {
                        d[k] += part[slot][k];
                    }
                }
            }
        }
        PoseSum {
            sum,
            traces,
            parts,
            diagonal,
        }
    }

    /// Directly from the metric's residual Jacobians at path `x`, without the segments'
    /// blocks (no off-diagonal blocks, gradients or per-segment storage): what the
    /// preconditioned solver needs at a refit. Only the slots of the upper triangle (row
    /// vertex <= column vertex, what [`SpatialLayout::factorize`] reads) are summed; the
    /// others stay zero.
    pub fn assemble(layout: &SpatialLayout, pe: &PathEnergy, x: &[f64], ends: &Ends) -> Self {
        let st = &layout.st;
        let n_slots = st.pairs.n_slots();
        let steps = st.steps;
        let pat = &pe.pattern;
        let nv = layout.nv;
        let shared = pe.metric().rows_shared_by_both_terms(pe.topology());
        // Accumulates segment s into the slot sums `acc` and the pose-vertex diagonal blocks `dg`.
        // A fixed end (segment 0's start, the last segment's end) has no block: its zeroed
        // Jacobian is skipped rather than multiplied out.
        let per_segment = |acc: &mut Vec<[f64; 9]>, dg: &mut Vec<[f64; 9]>, s: usize| -> (f64, usize) {
            let need_a = s >= 1;
            let need_b = s + 1 < steps;
            let mut te = pe.new_term_eval();
            let mut trace = 0.0;
            for at in [At::Start, At::End] {
                pe.eval_term(x, ends, s, at, &mut te, true);
                if need_a {
                    let dg = &mut dg[(s - 1) * nv..s * nv];
                    trace += accumulate_term_block(pat, &st.pairs, &te.jac.da, &shared, at, acc, dg);
                }
                if need_b {
                    let dg = &mut dg[s * nv..(s + 1) * nv];
                    trace += accumulate_term_block(pat, &st.pairs, &te.jac.db, &shared, at, acc, dg);
                }
            }
            (trace, usize::from(need_a) + usize::from(need_b))
        };
        let n_diag = (steps - 1) * nv;
        // Segments are accumulated in fixed chunks of `POSE_SUM_CHUNK` (in parallel), and the
        // chunks summed in chunk order: the floating-point sums, hence the preconditioner and
        // every solve, are the same for any thread count and scheduling (a rayon `fold` would
        // split the segments where the scheduler happens to).
        let segments: Vec<usize> = (0..steps).collect();
        let chunks: Vec<ChunkSum> = segments
            .par_chunks(POSE_SUM_CHUNK)
            .map(|chunk| {
                let mut acc = vec![[0.0f64; 9]; n_slots];
                let mut dg = vec![[0.0f64; 9]; n_diag];
                let per = chunk
                    .iter()
                    .map(|&s| (s, per_segment(&mut acc, &mut dg, s)))
                    .collect();
                (acc, per, dg)
            })
            .collect();
        let mut chunks = chunks.into_iter();
        let (mut sum, mut per, mut diagonal) = chunks
            .next()
            .unwrap_or_else(|| (vec![[0.0f64; 9]; n_slots], Vec::new(), vec![[0.0f64; 9]; n_diag]));
        for (b, pb, db) in chunks {
            for (x, y) in sum.iter_mut().zip(&b).chain(diagonal.iter_mut().zip(&db)) {
                for k in 0..9 {
                    x[k] += y[k];
                }
            }
            per.extend(pb);
        }
        let mut traces = vec![0.0; steps];
        let mut parts = vec![0; steps];
        for (s, (t, p)) in per {
            traces[s] = t;
            parts[s] = p;
        }
        PoseSum {
            sum,
            traces,
            parts,
            diagonal,
        }
    }
}

/// Adds one pose's part `d^T d` of a metric term's Gauss-Newton matrix (`d`: the term's
/// Jacobian with respect to that pose, one 3-vector per pattern entry) into the vertex-pair slot
/// blocks `acc` (upper triangle only, row vertex <= column vertex: what
/// [`SpatialLayout::factorize`] reads; the lower blocks are not formed) and the per-vertex 3 x 3
/// diagonal blocks `dg` (#V); returns the trace `sum |d_k|^2` it added.
pub(crate) fn accumulate_pose_block(
    pat: &Pattern,
    pairs: &VertexPairs,
    d: &[[f64; 3]],
    acc: &mut [[f64; 9]],
    dg: &mut [[f64; 9]],
) -> f64 {
    accumulate_pose_rows(pat, pairs, d, 0..pat.n_residuals(), 1.0, acc, dg)
}

/// [`accumulate_pose_block`] of the residual rows `rows` only, each counted `factor` times.
fn accumulate_pose_rows(
    pat: &Pattern,
    pairs: &VertexPairs,
    d: &[[f64; 3]],
    rows: std::ops::Range<usize>,
    factor: f64,
    acc: &mut [[f64; 9]],
    dg: &mut [[f64; 9]],
) -> f64 {
    let mut trace = 0.0;
    for i in rows {
        let range = pat.row(i);
        let (l, first) = (range.len(), range.start);
        let ps = pairs.slots(i);
        for k in 0..l {
            let dk = d[first + k];
            let fk = if factor == 1.0 { dk } else { scale(dk, factor) };
            trace += dot(fk, dk);
            let v = pat.vertices[first + k] as usize;
            outer_add(&mut dg[v], fk, dk);
            for (ll, &slot) in ps[k * l..(k + 1) * l].iter().enumerate() {
                if (pat.vertices[first + ll] as usize) >= v {
                    outer_add(&mut acc[slot as usize], fk, d[first + ll]);
                }
            }
        }
    }
    trace
}

/// [`accumulate_pose_block`] of one term (`at`) of a segment, the rows the two terms share
/// ([`crate::metric::Metric::rows_shared_by_both_terms`]) counted twice at `At::Start` and
/// not at `At::End`: the sum over both terms is that of counting every row once per term.
fn accumulate_term_block(
    pat: &Pattern,
    pairs: &VertexPairs,
    d: &[[f64; 3]],
    shared: &std::ops::Range<usize>,
    at: At,
    acc: &mut [[f64; 9]],
    dg: &mut [[f64; 9]],
) -> f64 {
    let n = pat.n_residuals();
    let mut trace = accumulate_pose_rows(pat, pairs, d, 0..shared.start, 1.0, acc, dg);
    if at == At::Start {
        trace += accumulate_pose_rows(pat, pairs, d, shared.clone(), 2.0, acc, dg);
    }
    trace + accumulate_pose_rows(pat, pairs, d, shared.end..n, 1.0, acc, dg)
}

impl KroneckerModel {
    /// Fits the model to the exact Hessian's blocks at `x` (half of it: `J^T J` plus the
    /// metric's second-order part `sum r_i d2 r_i`, [`crate::metric::Metric::add_second_order`])
    /// instead of `J^T J` alone ([`super::Solver::HessianKronecker`]); to `J^T J` where the metric
    /// has no second-order part or the Hessian's model is not positive definite (far from the
    /// geodesic). Also returns the 3 x 3 per-vertex diagonal blocks the model was fitted to
    /// (`(N - 1) #V`, pose-major), for the vertex-block term, and whether the metric has a
    /// second-order part at all (without one, later refits can fit `J^T J` directly).
    pub fn fit_hessian(
        layout: &SpatialLayout,
        pe: &PathEnergy,
        x: &[f64],
        ends: &Ends,
    ) -> Result<(Self, Vec<[f64; 9]>, bool), GeodesicError> {
        let (mut blocks, _, _) = layout.st.assemble_with(pe, x, ends, true);
        Self::fit_merging_second(layout, &mut blocks)
    }

    /// Merges each segment's second-order part ([`SegmentBlocks::second`]) into its blocks and
    /// fits the model to the result (the exact half Hessian); where that model is not positive
    /// definite, to the Gauss-Newton blocks (without the second-order parts) instead. `blocks`
    /// keep the merged parts. Returns the model, the per-vertex diagonal blocks it was fitted to
    /// and whether any segment had a second-order part.
    pub fn fit_merging_second(
        layout: &SpatialLayout,
        blocks: &mut [SegmentBlocks],
    ) -> Result<(Self, Vec<[f64; 9]>, bool), GeodesicError> {
        let seconds: Vec<_> = blocks.iter_mut().map(|b| b.second.take()).collect();
        let gauss_newton = PoseSum::from_blocks(layout, blocks);
        if seconds.iter().all(Option::is_none) {
            let diagonal = gauss_newton.diagonal.clone();
            return Ok((Self::fit(layout, gauss_newton)?, diagonal, false));
        }
        for (b, so) in blocks.iter_mut().zip(&seconds) {
            if let Some(so) = so {
                b.add_second(so);
            }
        }
        let hessian = PoseSum::from_blocks(layout, blocks);
        let diagonal = hessian.diagonal.clone();
        match Self::fit(layout, hessian) {
            Ok(model) => Ok((model, diagonal, true)),
            Err(_) => {
                let diagonal = gauss_newton.diagonal.clone();
                Ok((Self::fit(layout, gauss_newton)?, diagonal, true))
            }
        }
    }

    /// Fits `A` and the segment weights `c_s` to the blocks of `J^T J` (`ps`) and factorizes
    /// `A`.
    pub fn fit(layout: &SpatialLayout, ps: PoseSum) -> Result<Self, GeodesicError> {
        let st = &layout.st;
        let steps = st.steps;
        let m = steps - 1;
        if m == 0 {
            // One segment: no interior poses, only auxiliary unknowns (rigid metric), nothing to
            // precondition (the mean over no poses would be 0 / 0).
            return Ok(KroneckerModel {
                l_values: Vec::new(),
                tinv: Vec::new(),
            });
        }
        // A: mean of the diagonal pose blocks, halved (T has 2 on its diagonal).
        let mut a = ps.sum;
        let scale = 0.5 / m as f64;
        a.iter_mut().flatten().for_each(|v| *v *= scale);
        let tr_a = layout.trace(&a).max(f64::MIN_POSITIVE);
        // Segment weights: trace of the segment's pose blocks relative to A's.
        let c: Vec<f64> = ps
            .traces
            .iter()
            .zip(&ps.parts)
            .map(|(&t, &p)| (t / (p.max(1) as f64 * tr_a)).max(1e-6))
            .collect();
        let d: Vec<f64> = (0..m).map(|i| c[i] + c[i + 1]).collect();
        let e: Vec<f64> = (0..m.saturating_sub(1)).map(|i| -c[i + 1]).collect();
        Ok(KroneckerModel {
            l_values: layout.factorize(&a)?.iter().map(|&v| v as f32).collect(),
            tinv: tridiagonal_inverse(&d, &e),
        })
    }

    /// `q <- factor (T_c (x) A)^{-1} q` on the pose part (length 3 #V (N - 1), pose-major), or
    /// on several such vectors stored one after the other (one multi-column spatial solve).
    /// The spatial solves run in single precision, the time mixing accumulates in double.
    /// (The solvers use [`Self::apply_with`]; the tests use this.)
    #[cfg(test)]
    pub fn apply(&self, layout: &SpatialLayout, q: &mut [f64], factor: f64) {
        self.apply_with(layout, q, factor, &mut ApplyScratch::default());
    }

    /// [`Self::apply`] with its work space (the single-precision copy, the solver's scratch)
    /// kept in `scratch` between calls: the same arithmetic, no allocation once warm.
    pub fn apply_with(&self, layout: &SpatialLayout, q: &mut [f64], factor: f64, scratch: &mut ApplyScratch) {
        let n = 3 * layout.nv;
        let m = layout.st.steps - 1;
        if m == 0 || q.is_empty() {
            return;
        }
        let q32 = &mut scratch.q32;
        q32.clear();
        q32.extend(q.iter().map(|&v| v as f32));
        // Every pose of every vector is one column of the spatial solve.
        layout.solve_with(&self.l_values, q32, &mut scratch.mem);
        // out_i = factor sum_j Tinv_ij q_j, in blocks of the spatial index so that a block of
        // out_i stays in cache while the m poses stream past it (the same sums, in the same
        // order, as one pass per pose).
        const BLOCK: usize = 512;
        for (qv, qv32) in q.chunks_exact_mut(n * m).zip(q32.chunks_exact(n * m)) {
            for i in 0..m {
                let row = &self.tinv[i * m..(i + 1) * m];
                let out = &mut qv[i * n..(i + 1) * n];
                for start in (0..n).step_by(BLOCK) {
                    let end = (start + BLOCK).min(n);
                    let ob = &mut out[start..end];
                    ob.fill(0.0);
                    for (j, t) in row.iter().enumerate() {
                        let t = factor * t;
                        for (o, v) in ob.iter_mut().zip(&qv32[j * n + start..j * n + end]) {
                            *o += t * f64::from(*v);
                        }
                    }
                }
            }
        }
    }
}

/// Inverse of the symmetric tridiagonal `T` with diagonal `d` and off-diagonal `e` (m x m,
/// row-major), column by column (Thomas algorithm).
pub(crate) fn tridiagonal_inverse(d: &[f64], e: &[f64]) -> Vec<f64> {
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

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::geodesic::hessian::tests::dense;
    use crate::metric::{Conformal, ConformalForm, Isometric, Metric, Regularized, Rigid};

    fn problem<'m>(m: &'m dyn Metric, steps: usize, seed: u64) -> (PathEnergy<'m>, Ends, Vec<f64>) {
        let base = crate::synth::icosphere(1);
        super::super::second_order_tests::random_path(m, &base, steps, &mut ChaCha8Rng::seed_from_u64(seed))
    }

    fn metrics() -> Vec<Box<dyn Metric>> {
        vec![
            Box::new(Regularized::new(Box::new(Isometric), 0.1)),
            Box::new(Regularized::new(
                Box::new(Conformal::new(ConformalForm::Quadratic)),
                0.1,
            )),
            Box::new(Regularized::new(Box::new(Rigid), 0.1)),
            // The default: invariant isometric form, regularizer and bending term (rows the
            // segment's two terms share, counted once and doubled by the direct assembly).
            crate::metric::MetricSpec::new(crate::metric::MetricKind::Isometric)
                .build(&crate::metric::Calibration::RAW),
        ]
    }

    /// A failed factorization says which part failed and keeps faer's error as its source:
    /// non-finite blocks are refused before factorizing, and a negative definite matrix fails
    /// with the Cholesky error even after the ridges.
    #[test]
    fn failed_factorizations_keep_their_source_error() {
        use std::error::Error;
        let m = Regularized::new(Box::new(Isometric), 0.1);
        let (pe, _, _) = problem(&m, 2, 3);
        let layout = SpatialLayout::new(&pe).unwrap();
        let pairs = &layout.structure().pairs;
        let n_slots = pairs.rows.len();
        let mut blocks = vec![[0.0f64; 9]; n_slots];
        for v in 0..pe.n_vertices() {
            for slot in pairs.off[v]..pairs.off[v + 1] {
                if pairs.rows[slot] == v {
                    blocks[slot] = [-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0];
                }
            }
        }
        let err = layout.factorize(&blocks).unwrap_err();
        assert!(
            matches!(
                &err,
                GeodesicError::LinearAlgebra {
                    what: "the spatial preconditioner",
                    source: LinearAlgebraError::Cholesky(_),
                }
            ),
            "{err:?}"
        );
        let source = err.source().expect("the source error is kept");
        assert!(source.to_string().contains("NonPositivePivot"), "{source}");
        assert!(err.to_string().contains("spatial preconditioner"), "{err}");

        blocks[0][0] = f64::NAN;
        let err = layout.factorize(&blocks).unwrap_err();
        assert!(matches!(
            err,
            GeodesicError::LinearAlgebra {
                source: LinearAlgebraError::NonFinite,
                ..
            }
        ));
        assert_eq!(
            err.to_string(),
            "linear algebra failure in the spatial preconditioner: the Gauss-Newton blocks are not finite"
        );
    }

    /// The direct assembly of the pose-block sum (preconditioned solver) equals the sum of
    /// the assembled segment blocks (the Hessian model's assembly).
    #[test]
    fn direct_pose_sum_matches_the_segment_blocks() {
        for m in metrics() {
            for steps in [2, 4] {
                let (pe, ends, x) = problem(m.as_ref(), steps, 3);
                let layout = SpatialLayout::new(&pe).unwrap();
                let (blocks, _, _) = layout.structure().assemble(&pe, &x, &ends);
                let want = PoseSum::from_blocks(&layout, &blocks);
                let got = PoseSum::assemble(&layout, &pe, &x, &ends);
                let scale = want.sum.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
                assert!(scale > 0.0);
                // The direct assembly forms the upper triangle only (slot of row u in column v).
                let pairs = &layout.structure().pairs;
                let mut upper = 0;
                for v in 0..pe.n_vertices() {
                    for slot in pairs.off[v]..pairs.off[v + 1] {
                        if pairs.rows[slot] > v {
                            assert!(got.sum[slot].iter().all(|&g| g == 0.0));
                            continue;
                        }
                        upper += 1;
                        for (w, g) in want.sum[slot].iter().zip(&got.sum[slot]) {
                            assert!((w - g).abs() <= 1e-12 * scale, "{}: {w} vs {g}", m.name());
                        }
                    }
                }
                assert!(upper > pe.n_vertices());
                assert_eq!(want.parts, got.parts);
                for (w, g) in want.traces.iter().zip(&got.traces) {
                    assert!(
                        (w - g).abs() <= 1e-12 * w.abs().max(1.0),
                        "{}: {w} vs {g}",
                        m.name()
                    );
                }
                // The pose-vertex diagonal blocks: both constructors, and the diagonal 3 x 3
                // blocks of the dense J^T J.
                let (h, _) = dense(&pe, &x, &ends);
                let nv = pe.n_vertices();
                assert_eq!(want.diagonal.len(), (steps - 1) * nv);
                assert_eq!(got.diagonal.len(), (steps - 1) * nv);
                for (i, (w, g)) in want.diagonal.iter().zip(&got.diagonal).enumerate() {
                    let (j, v) = (i / nv, i % nv);
                    let row = 3 * (j * nv + v);
                    for k in 0..9 {
                        let d = h[row + k / 3][row + k % 3];
                        assert!((w[k] - d).abs() <= 1e-12 * scale, "{}: {} vs {d}", m.name(), w[k]);
                        assert!((g[k] - d).abs() <= 1e-12 * scale, "{}: {} vs {d}", m.name(), g[k]);
                    }
                }
            }
        }
    }

    /// The pose sum (hence the preconditioner) is the same to the bit for any thread count:
    /// the segments are reduced in fixed chunks, in order.
    #[test]
    fn pose_sum_is_bit_identical_for_any_thread_count() {
        for m in metrics() {
            let (pe, ends, x) = problem(m.as_ref(), 8, 4);
            let layout = SpatialLayout::new(&pe).unwrap();
            let run = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let ps = pool.install(|| PoseSum::assemble(&layout, &pe, &x, &ends));
                let bits = |v: &[[f64; 9]]| v.iter().flatten().map(|c| c.to_bits()).collect::<Vec<_>>();
                (
                    bits(&ps.sum),
                    bits(&ps.diagonal),
                    ps.traces.iter().map(|t| t.to_bits()).collect::<Vec<_>>(),
                )
            };
            let want = run(1);
            for threads in [2, 3, 4, 2, 3] {
                assert!(run(threads) == want, "{}: {threads} threads", m.name());
            }
        }
    }

    /// `apply` inverts `T_c (x) A` as documented (A the mean diagonal pose block halved, c_s
    /// the segments' trace ratios), to single precision.
    #[test]
    fn apply_inverts_the_fitted_model() {
        for m in metrics() {
            let steps = 5;
            let (pe, ends, x) = problem(m.as_ref(), steps, 5);
            let layout = SpatialLayout::new(&pe).unwrap();
            let ps = PoseSum::assemble(&layout, &pe, &x, &ends);
            let mm = steps - 1;
            let a: Vec<[f64; 9]> = ps.sum.iter().map(|b| b.map(|v| v * 0.5 / mm as f64)).collect();
            let tr_a = layout.trace(&a);
            let c: Vec<f64> = ps
                .traces
                .iter()
                .zip(&ps.parts)
                .map(|(t, &p)| (t / (p as f64 * tr_a)).max(1e-6))
                .collect();
            let model = KroneckerModel::fit(&layout, ps).unwrap();
            let st = layout.structure();
            let n = 3 * st.nv;
            let mut rng = ChaCha8Rng::seed_from_u64(9);
            let v: Vec<f64> = (0..n * mm).map(|_| rng.random::<f64>() - 0.5).collect();
            // A v per pose (A symmetric, its upper blocks assembled), then the time stencil
            // of T_c.
            let av: Vec<Vec<f64>> = (0..mm)
                .map(|j| {
                    let xj = &v[j * n..(j + 1) * n];
                    let mut y = vec![0.0; n];
                    for col in 0..st.nv {
                        for idx in st.pairs.off[col]..st.pairs.off[col + 1] {
                            let row = st.pairs.rows[idx];
                            if row > col {
                                continue;
                            }
                            for r in 0..3 {
                                for cc in 0..3 {
                                    y[3 * row + r] += a[idx][3 * r + cc] * xj[3 * col + cc];
                                    if row < col {
                                        y[3 * col + cc] += a[idx][3 * r + cc] * xj[3 * row + r];
                                    }
                                }
                            }
                        }
                    }
                    y
                })
                .collect();
            let mut mv = vec![0.0; n * mm];
            for j in 0..mm {
                for k in 0..n {
                    let mut s = (c[j] + c[j + 1]) * av[j][k];
                    if j > 0 {
                        s -= c[j] * av[j - 1][k];
                    }
                    if j + 1 < mm {
                        s -= c[j + 1] * av[j + 1][k];
                    }
                    mv[j * n + k] = s;
                }
            }
            model.apply(&layout, &mut mv, 2.0);
            let err = mv
                .iter()
                .zip(&v)
                .map(|(a, b)| (a - 2.0 * b).abs())
                .fold(0.0f64, f64::max);
            assert!(err < 1e-3, "{}: max error {err}", m.name());
        }
    }
}
