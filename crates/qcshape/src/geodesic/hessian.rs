//! Gauss-Newton normal equations `J^T J` of the path energy as 3 x 3 vertex blocks per segment
//! ([`Structure`], [`SegmentBlocks`]), with the metric's second-order part on request: what the
//! Kronecker models (`kronecker.rs`, `pose_kronecker.rs`) are fitted to. The tests also
//! assemble them into the full sparse matrix ([`HessianLayout`], test-only since
//! Levenberg-Marquardt, its one solver, was retired).
//!
//! Unknowns are pose-major (`P_1 .. P_{N-1}`, each `3 #V`), then the auxiliary unknowns of the
//! `2N` terms. `J^T J` is block-tridiagonal in the poses; within a pose block, vertex `u` couples
//! with vertex `v` when some residual depends on both (the set `S`, stored column-wise).

// Index loops mirror the formulas (vertex, coordinate, residual indices) in these kernels.
#![allow(clippy::needless_range_loop)]

use rayon::prelude::*;

use super::energy::{Ends, PathEnergy};
use super::pairs::VertexPairs;
use crate::metric::{At, SecondOrderSink};

/// Sparse structure of the upper triangle of `J^T J` for one path problem (the tests' full
/// matrix).
#[cfg(test)]
pub(crate) struct HessianLayout {
    st: Structure,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
}

/// Vertex-pair structure and per-residual slots (no factorization): enough to assemble the
/// blocks of `J^T J` and to multiply with them.
pub(crate) struct Structure {
    pub nv: usize,
    pub steps: usize,
    pub n_aux: usize,
    /// Vertex pairs sharing a residual, and per-residual pair slots.
    pub pairs: VertexPairs,
}

/// One segment's contribution to `J^T r` and `J^T J` (both terms of the segment).
pub(crate) struct SegmentBlocks {
    /// `sum da_u da_v^T` per slot (row u, column v), row-major 3 x 3.
    pub aa: Vec<[f64; 9]>,
    /// `sum db_u db_v^T` per slot.
    pub bb: Vec<[f64; 9]>,
    /// `sum da_u db_v^T` per slot (row: vertex u of the first pose, column: v of the second).
    pub ab: Vec<[f64; 9]>,
    /// `J^T r` for the first and second pose (3 #V each).
    pub ga: Vec<f64>,
    pub gb: Vec<f64>,
    /// Per term (2): coupling of each aux unknown with the first / second pose (3 #V x n_aux),
    /// aux-aux block (n_aux x n_aux), and `J^T r` of the aux unknowns.
    pub aux_a: [Vec<f64>; 2],
    pub aux_b: [Vec<f64>; 2],
    pub aux_aux: [Vec<f64>; 2],
    pub aux_g: [Vec<f64>; 2],
    /// Energy of the two terms.
    pub energy: f64,
    /// The second-order part `sum r_i d2 r_i` of both terms (same slots as `aa`, `ab`, `bb`),
    /// when requested and provided by the metric ([`crate::metric::Metric::add_second_order`]).
    pub second: Option<SecondBlocks>,
}

/// Second-order blocks of one segment, laid out like [`SegmentBlocks`]'s `aa`, `ab`, `bb`.
pub(crate) struct SecondBlocks {
    pub aa: Vec<[f64; 9]>,
    pub ab: Vec<[f64; 9]>,
    pub bb: Vec<[f64; 9]>,
}

impl SegmentBlocks {
    /// Adds the second-order part `so` into `aa`, `ab`, `bb`: the blocks become those of half
    /// the exact Hessian.
    pub fn add_second(&mut self, so: &SecondBlocks) {
        for (dst, src) in [
            (&mut self.aa, &so.aa),
            (&mut self.ab, &so.ab),
            (&mut self.bb, &so.bb),
        ] {
            for (d, v) in dst.iter_mut().zip(src) {
                for k in 0..9 {
                    d[k] += v[k];
                }
            }
        }
    }

    /// Adds the second-order part into the blocks and drops it; returns whether there was one.
    #[cfg(test)]
    pub fn merge_second(&mut self) -> bool {
        match self.second.take() {
            Some(so) => {
                self.add_second(&so);
                true
            }
            None => false,
        }
    }
}

#[cfg(test)]
impl HessianLayout {
    /// Builds the structure.
    pub fn new(pe: &PathEnergy) -> Self {
        let st = Structure::new(pe);
        let n = pe.n_vars();
        let mut col_ptr = vec![0usize];
        let mut row_idx = Vec::new();
        st.walk(|col, row, _| {
            while col_ptr.len() <= col {
                col_ptr.push(row_idx.len());
            }
            row_idx.push(row);
        });
        while col_ptr.len() <= n {
            col_ptr.push(row_idx.len());
        }
        HessianLayout { st, col_ptr, row_idx }
    }

    /// The vertex-pair structure.
    pub fn structure(&self) -> &Structure {
        &self.st
    }

    /// Column pointers and row indices of the stored upper triangle.
    pub fn pattern(&self) -> (&[usize], &[usize]) {
        (&self.col_ptr, &self.row_idx)
    }

    /// All segments' blocks (in parallel), the energy, and the half gradient `J^T r`.
    pub fn assemble(&self, pe: &PathEnergy, x: &[f64], ends: &Ends) -> (Vec<SegmentBlocks>, f64, Vec<f64>) {
        self.st.assemble(pe, x, ends)
    }

    /// Values of the upper triangle of `J^T J` in the layout's order.
    pub fn values(&self, blocks: &[SegmentBlocks]) -> Vec<f64> {
        let mut vals = Vec::with_capacity(self.row_idx.len());
        self.st.walk(|_, _, src| {
            vals.push(match src {
                Source::Off { seg, slot, k } => blocks[seg].ab[slot][k],
                // Interior pose j is the second pose of segment j - 1 and the first of segment j.
                Source::Diag { pose, slot, k } => blocks[pose - 1].bb[slot][k] + blocks[pose].aa[slot][k],
                Source::AuxA { seg, term, k } => blocks[seg].aux_a[term][k],
                Source::AuxB { seg, term, k } => blocks[seg].aux_b[term][k],
                Source::AuxAux { seg, term, k } => blocks[seg].aux_aux[term][k],
            })
        });
        vals
    }
}

impl Structure {
    /// The pair set `S` of `pe`'s metric pattern: every pair of vertices sharing a residual
    /// (and every vertex with itself).
    pub fn new(pe: &PathEnergy) -> Self {
        let nv = pe.n_vertices();
        Structure {
            nv,
            steps: pe.steps,
            n_aux: pe.metric.n_aux(),
            pairs: VertexPairs::new(nv, &pe.pattern),
        }
    }

    /// Visits the upper triangle column by column, rows ascending: `f(col, row, source)`.
    #[cfg(test)]
    fn walk(&self, mut f: impl FnMut(usize, usize, Source)) {
        let (nv, n_aux) = (self.nv, self.n_aux);
        let nv3 = 3 * nv;
        let base = |j: usize| (j - 1) * nv3; // first unknown of interior pose j
        for j in 1..self.steps {
            for v in 0..nv {
                let rows = self.pairs.off[v]..self.pairs.off[v + 1];
                for c in 0..3 {
                    let col = base(j) + 3 * v + c;
                    if j >= 2 {
                        for idx in rows.clone() {
                            let u = self.pairs.rows[idx];
                            for cr in 0..3 {
                                f(
                                    col,
                                    base(j - 1) + 3 * u + cr,
                                    Source::Off {
                                        seg: j - 1,
                                        slot: idx,
                                        k: cr * 3 + c,
                                    },
                                );
                            }
                        }
                    }
                    for idx in rows.clone() {
                        let u = self.pairs.rows[idx];
                        if u > v {
                            break;
                        }
                        let last = if u == v { c } else { 2 };
                        for cr in 0..=last {
                            f(
                                col,
                                base(j) + 3 * u + cr,
                                Source::Diag {
                                    pose: j,
                                    slot: idx,
                                    k: cr * 3 + c,
                                },
                            );
                        }
                    }
                }
            }
        }
        let np = nv3 * (self.steps - 1);
        for s in 0..self.steps {
            for e in 0..2 {
                let t = 2 * s + e;
                for m in 0..n_aux {
                    let col = np + t * n_aux + m;
                    if s >= 1 {
                        for q in 0..nv3 {
                            f(
                                col,
                                base(s) + q,
                                Source::AuxA {
                                    seg: s,
                                    term: e,
                                    k: q * n_aux + m,
                                },
                            );
                        }
                    }
                    if s + 1 < self.steps {
                        for q in 0..nv3 {
                            f(
                                col,
                                base(s + 1) + q,
                                Source::AuxB {
                                    seg: s,
                                    term: e,
                                    k: q * n_aux + m,
                                },
                            );
                        }
                    }
                    for m2 in 0..=m {
                        f(
                            col,
                            np + t * n_aux + m2,
                            Source::AuxAux {
                                seg: s,
                                term: e,
                                k: m2 * n_aux + m,
                            },
                        );
                    }
                }
            }
        }
    }

    /// Evaluates one segment's two terms with Jacobians and accumulates its blocks (and the
    /// second-order part if `second_order`; `None` when the metric does not provide it).
    fn segment_blocks(
        &self,
        pe: &PathEnergy,
        x: &[f64],
        ends: &Ends,
        s: usize,
        second_order: bool,
    ) -> SegmentBlocks {
        let n_slots = self.pairs.n_slots();
        let nv3 = 3 * self.nv;
        let n_aux = self.n_aux;
        let need_a = s >= 1;
        let need_b = s + 1 < self.steps;
        let mut sb = SegmentBlocks {
            aa: if need_a {
                vec![[0.0; 9]; n_slots]
            } else {
                Vec::new()
            },
            bb: if need_b {
                vec![[0.0; 9]; n_slots]
            } else {
                Vec::new()
            },
            ab: if need_a && need_b {
                vec![[0.0; 9]; n_slots]
            } else {
                Vec::new()
            },
            ga: vec![0.0; nv3],
            gb: vec![0.0; nv3],
            aux_a: [vec![0.0; nv3 * n_aux], vec![0.0; nv3 * n_aux]],
            aux_b: [vec![0.0; nv3 * n_aux], vec![0.0; nv3 * n_aux]],
            aux_aux: [vec![0.0; n_aux * n_aux], vec![0.0; n_aux * n_aux]],
            aux_g: [vec![0.0; n_aux], vec![0.0; n_aux]],
            energy: 0.0,
            second: None,
        };
        let empty_like = |v: &Vec<[f64; 9]>| vec![[0.0; 9]; v.len()];
        let mut second = second_order.then(|| SecondBlocks {
            aa: empty_like(&sb.aa),
            ab: empty_like(&sb.ab),
            bb: empty_like(&sb.bb),
        });
        let pat = &pe.pattern;
        let mut te = pe.new_term_eval();
        for (e, at) in [At::Start, At::End].into_iter().enumerate() {
            sb.energy += pe.eval_term(x, ends, s, at, &mut te, true);
            let (r, jac) = (&te.r, &te.jac);
            for i in 0..pat.n_residuals() {
                let range = pat.row(i);
                let l = range.len();
                let first = range.start;
                let ps = self.pairs.slots(i);
                let ri = r[i];
                for k in 0..l {
                    let vk = pat.vertices[first + k] as usize;
                    let (dak, dbk) = (jac.da[first + k], jac.db[first + k]);
                    for c in 0..3 {
                        sb.ga[3 * vk + c] += dak[c] * ri;
                        sb.gb[3 * vk + c] += dbk[c] * ri;
                    }
                    for (ll, &slot) in ps[k * l..(k + 1) * l].iter().enumerate() {
                        let slot = slot as usize;
                        let (dal, dbl) = (jac.da[first + ll], jac.db[first + ll]);
                        if need_a {
                            outer_add(&mut sb.aa[slot], dak, dal);
                        }
                        if need_b {
                            outer_add(&mut sb.bb[slot], dbk, dbl);
                        }
                        if need_a && need_b {
                            outer_add(&mut sb.ab[slot], dak, dbl);
                        }
                    }
                    if n_aux > 0 {
                        let daux = &jac.daux[i * n_aux..(i + 1) * n_aux];
                        for c in 0..3 {
                            for m in 0..n_aux {
                                sb.aux_a[e][(3 * vk + c) * n_aux + m] += dak[c] * daux[m];
                                sb.aux_b[e][(3 * vk + c) * n_aux + m] += dbk[c] * daux[m];
                            }
                        }
                    }
                }
                if n_aux > 0 {
                    let daux = &jac.daux[i * n_aux..(i + 1) * n_aux];
                    for m in 0..n_aux {
                        sb.aux_g[e][m] += daux[m] * ri;
                        for m2 in 0..n_aux {
                            sb.aux_aux[e][m2 * n_aux + m] += daux[m2] * daux[m];
                        }
                    }
                }
            }
            if let Some(so) = second.as_mut() {
                let seg = pe.segment(x, ends, s, at);
                let mut sink = SecondOrderSink {
                    at,
                    offsets: &pat.offsets,
                    pair_off: &self.pairs.pair_off,
                    pair_slots: &self.pairs.pair_slots,
                    aa: non_empty(&mut so.aa),
                    ab: non_empty(&mut so.ab),
                    bb: non_empty(&mut so.bb),
                };
                if !pe
                    .metric
                    .add_second_order(&pe.topo, pat.as_ref(), &seg, &te.r, &mut sink)
                {
                    second = None;
                }
            }
        }
        sb.second = second;
        sb
    }
}

impl Structure {
    /// All segments' blocks (in parallel), the energy, and the half gradient `J^T r` (the
    /// tests; the solvers use [`Structure::assemble_with`]).
    #[cfg(test)]
    pub fn assemble(&self, pe: &PathEnergy, x: &[f64], ends: &Ends) -> (Vec<SegmentBlocks>, f64, Vec<f64>) {
        self.assemble_with(pe, x, ends, false)
    }

    /// [`Structure::assemble`], with each segment's second-order part in
    /// [`SegmentBlocks::second`] if `second_order` (and the metric provides it).
    pub fn assemble_with(
        &self,
        pe: &PathEnergy,
        x: &[f64],
        ends: &Ends,
        second_order: bool,
    ) -> (Vec<SegmentBlocks>, f64, Vec<f64>) {
        let st = self;
        let blocks: Vec<SegmentBlocks> = (0..st.steps)
            .into_par_iter()
            .map(|s| st.segment_blocks(pe, x, ends, s, second_order))
            .collect();
        let nv3 = 3 * st.nv;
        let np = nv3 * (st.steps - 1);
        let n_aux = st.n_aux;
        let mut g = vec![0.0; pe.n_vars()];
        let mut energy = 0.0;
        for (s, b) in blocks.iter().enumerate() {
            energy += b.energy;
            if s >= 1 {
                for (gi, v) in g[(s - 1) * nv3..s * nv3].iter_mut().zip(&b.ga) {
                    *gi += v;
                }
            }
            if s + 1 < st.steps {
                for (gi, v) in g[s * nv3..(s + 1) * nv3].iter_mut().zip(&b.gb) {
                    *gi += v;
                }
            }
            for e in 0..2 {
                let t = 2 * s + e;
                g[np + t * n_aux..np + (t + 1) * n_aux].copy_from_slice(&b.aux_g[e]);
            }
        }
        (blocks, energy, g)
    }
}

#[cfg(test)]
#[derive(Clone, Copy)]
enum Source {
    Off { seg: usize, slot: usize, k: usize },
    Diag { pose: usize, slot: usize, k: usize },
    AuxA { seg: usize, term: usize, k: usize },
    AuxB { seg: usize, term: usize, k: usize },
    AuxAux { seg: usize, term: usize, k: usize },
}

fn non_empty(v: &mut [[f64; 9]]) -> Option<&mut [[f64; 9]]> {
    if v.is_empty() {
        None
    } else {
        Some(v)
    }
}

/// `b += u v^T` (3 x 3, row-major).
#[inline]
pub(super) fn outer_add(b: &mut [f64; 9], u: [f64; 3], v: [f64; 3]) {
    for r in 0..3 {
        for c in 0..3 {
            b[r * 3 + c] += u[r] * v[c];
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::metric::{Isometric, Metric, Regularized, Rigid};

    /// Calls `f(metric, path energy, ends, x)` for a small test problem per metric
    /// (regularized isometric and rigid, with auxiliary unknowns), `steps` segments, at a
    /// perturbed linear path.
    pub(in crate::geodesic) fn for_each_problem(
        steps: usize,
        mut f: impl FnMut(&dyn Metric, &PathEnergy, &Ends, &[f64]),
    ) {
        let a = crate::synth::icosphere(0);
        let b: Vec<[f64; 3]> = a
            .positions
            .iter()
            .map(|p| [p[0] * 1.3, p[1] + 0.2 * p[2], p[2]])
            .collect();
        let metrics: Vec<Box<dyn Metric>> = vec![
            Box::new(Regularized::new(Box::new(Isometric), 0.3)),
            Box::new(Regularized::new(Box::new(Rigid), 0.3)),
        ];
        for m in &metrics {
            let pe = PathEnergy::new(m.as_ref(), a.topology.clone(), steps);
            let frozen = m.frozen_weights(&a.topology, &a.positions, &b);
            let ends = Ends {
                start: a.positions.clone(),
                end: b.clone(),
                frozen,
            };
            let mut x = pe.linear_start(&ends);
            for (i, v) in x.iter_mut().enumerate() {
                *v += 0.05 * ((i * 7919 % 17) as f64 - 8.0) / 8.0;
            }
            f(m.as_ref(), &pe, &ends, &x);
        }
    }

    /// Dense `J^T J` and `J^T r` from the per-term Jacobians, for comparison.
    pub(in crate::geodesic) fn dense(pe: &PathEnergy, x: &[f64], ends: &Ends) -> (Vec<Vec<f64>>, Vec<f64>) {
        let n = pe.n_vars();
        let nv3 = 3 * pe.n_vertices();
        let n_aux = pe.metric.n_aux();
        let np = pe.n_pose_vars();
        let mut h = vec![vec![0.0; n]; n];
        let mut g = vec![0.0; n];
        let mut te = pe.new_term_eval();
        for s in 0..pe.steps {
            for (e, at) in [At::Start, At::End].into_iter().enumerate() {
                pe.eval_term(x, ends, s, at, &mut te, true);
                for i in 0..pe.pattern.n_residuals() {
                    let mut row = vec![0.0; n];
                    for k in pe.pattern.row(i) {
                        let v = pe.pattern.vertices[k] as usize;
                        for c in 0..3 {
                            if s >= 1 {
                                row[(s - 1) * nv3 + 3 * v + c] += te.jac.da[k][c];
                            }
                            if s + 1 < pe.steps {
                                row[s * nv3 + 3 * v + c] += te.jac.db[k][c];
                            }
                        }
                    }
                    for m in 0..n_aux {
                        row[np + (2 * s + e) * n_aux + m] += te.jac.daux[i * n_aux + m];
                    }
                    for a in 0..n {
                        g[a] += row[a] * te.r[i];
                        for b in 0..n {
                            h[a][b] += row[a] * row[b];
                        }
                    }
                }
            }
        }
        (h, g)
    }

    #[test]
    fn assembled_normal_equations_match_dense_products() {
        for_each_problem(3, |m, pe, ends, x| {
            let layout = HessianLayout::new(pe);
            let (blocks, _, g) = layout.assemble(pe, x, ends);
            let vals = layout.values(&blocks);
            let (hd, gd) = dense(pe, x, ends);
            for (i, (u, v)) in g.iter().zip(&gd).enumerate() {
                assert!(
                    (u - v).abs() < 1e-10 * (1.0 + v.abs()),
                    "{}: g[{i}] {u} vs {v}",
                    m.name()
                );
            }
            let mut seen = vec![vec![false; pe.n_vars()]; pe.n_vars()];
            for col in 0..pe.n_vars() {
                for k in layout.col_ptr[col]..layout.col_ptr[col + 1] {
                    let row = layout.row_idx[k];
                    assert!(row <= col);
                    seen[row][col] = true;
                    let want = hd[row][col];
                    assert!(
                        (vals[k] - want).abs() < 1e-10 * (1.0 + want.abs()),
                        "{}: H[{row},{col}] {} vs {want}",
                        m.name(),
                        vals[k]
                    );
                }
            }
            for r in 0..pe.n_vars() {
                for c in r..pe.n_vars() {
                    assert!(
                        seen[r][c] || hd[r][c] == 0.0,
                        "{}: H[{r},{c}] = {} missing from the structure",
                        m.name(),
                        hd[r][c]
                    );
                }
            }
        });
    }
}
