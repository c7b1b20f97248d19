//! The vertex-pair structure of a metric's Jacobian pattern, shared by the Gauss-Newton
//! normal equations and the spatial preconditioner.

use crate::metric::Pattern;

/// Set `S` of vertex pairs that share a residual (and every vertex with itself), stored
/// column-wise (column `v` holds rows `rows[off[v]..off[v+1]]`, sorted), and for every residual
/// the slot of each of its entry pairs: for residual `i` with entries `e_0..e_{L-1}`,
/// `pair_slots[pair_off[i] + k L + l]` is the slot of (row vertex of `e_k`, column vertex of
/// `e_l`). Built once per (topology, metric).
pub(crate) struct VertexPairs {
    pub off: Vec<usize>,
    pub rows: Vec<usize>,
    pub pair_off: Vec<usize>,
    pub pair_slots: Vec<u32>,
}

impl VertexPairs {
    pub fn new(n_vertices: usize, pat: &Pattern) -> Self {
        let mut cols: Vec<Vec<u32>> = (0..n_vertices as u32).map(|v| vec![v]).collect();
        for i in 0..pat.n_residuals() {
            let row = &pat.vertices[pat.row(i)];
            for &u in row {
                for &v in row {
                    cols[v as usize].push(u);
                }
            }
        }
        let mut off = Vec::with_capacity(n_vertices + 1);
        let mut rows: Vec<usize> = Vec::new();
        off.push(0);
        for mut c in cols {
            c.sort_unstable();
            c.dedup();
            rows.extend(c.iter().map(|&u| u as usize));
            off.push(rows.len());
        }
        let slot = |row: u32, col: u32| -> u32 {
            let r = &rows[off[col as usize]..off[col as usize + 1]];
            (off[col as usize] + r.binary_search(&(row as usize)).expect("pair in S")) as u32
        };
        let mut pair_off = Vec::with_capacity(pat.n_residuals() + 1);
        let mut pair_slots = Vec::new();
        pair_off.push(0);
        for i in 0..pat.n_residuals() {
            let row = &pat.vertices[pat.row(i)];
            for &u in row {
                for &v in row {
                    pair_slots.push(slot(u, v));
                }
            }
            pair_off.push(pair_slots.len());
        }
        VertexPairs {
            off,
            rows,
            pair_off,
            pair_slots,
        }
    }

    /// Number of slots (pairs in `S`).
    pub fn n_slots(&self) -> usize {
        self.rows.len()
    }

    /// Slots of residual `i`'s entry pairs (`L x L`, row-major).
    pub fn slots(&self, i: usize) -> &[u32] {
        &self.pair_slots[self.pair_off[i]..self.pair_off[i + 1]]
    }
}
