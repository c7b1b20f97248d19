//! The second-order part of a segment term's Hessian, `sum_i c_i d2 r_i`, accumulated into
//! 3 x 3 vertex-pair blocks ([`Metric::add_second_order`](super::Metric::add_second_order)).
//!
//! The Hessian of `|r|^2` is `2 (J^T J + sum_i r_i d2 r_i)`. Gauss-Newton keeps only `J^T J`;
//! on a large-residual problem (a geodesic between distant shapes: the residuals are the
//! velocities, never small) that model converges linearly. Newton's method adds the second
//! term, which metrics provide through this sink.

use super::segment::At;

/// Accumulates `sum_i c_i d2 r_i / d(a, b)^2` for one segment term into vertex-pair blocks.
///
/// Metrics whose residuals are linear in the displacement `X = b - a` (all metrics of the
/// paper) describe each residual's second derivatives in the variables `(g, X)`, `g` the pose
/// supplying the geometry: [`SecondOrderSink::add`] takes the blocks `d2/dg_k dg_l` and
/// `d2/dg_k dX_l` for the residual's local vertices `k, l` and applies the chain rule to
/// `(a, b)` (`g = a` or `g = b`).
pub struct SecondOrderSink<'a> {
    /// The pose supplying the geometry of the term.
    pub(crate) at: At,
    /// Pattern row offsets (residual `i` has `offsets[i+1] - offsets[i]` local vertices).
    pub(crate) offsets: &'a [u32],
    /// Per residual: offset of its `L x L` pair slots in `pair_slots`.
    pub(crate) pair_off: &'a [usize],
    /// Slot of each local pair `(k, l)` of each residual (row-major).
    pub(crate) pair_slots: &'a [u32],
    /// Blocks `d2/da_u da_v` per slot (row-major 3 x 3), if the first pose is free.
    pub(crate) aa: Option<&'a mut [[f64; 9]]>,
    /// Blocks `d2/da_u db_v` (row: vertex `u` of `a`, column: `v` of `b`), if both are free.
    pub(crate) ab: Option<&'a mut [[f64; 9]]>,
    /// Blocks `d2/db_u db_v`, if the second pose is free.
    pub(crate) bb: Option<&'a mut [[f64; 9]]>,
}

#[inline]
fn add_to(dst: &mut [f64; 9], src: &[f64; 9], s: f64) {
    for (d, v) in dst.iter_mut().zip(src) {
        *d += s * v;
    }
}

#[inline]
fn add_transposed(dst: &mut [f64; 9], src: &[f64; 9], s: f64) {
    for r in 0..3 {
        for c in 0..3 {
            dst[3 * r + c] += s * src[3 * c + r];
        }
    }
}

impl<'a> SecondOrderSink<'a> {
    #[inline]
    fn slot(&self, i: usize, k: usize, l: usize) -> usize {
        let len = (self.offsets[i + 1] - self.offsets[i]) as usize;
        self.pair_slots[self.pair_off[i] + k * len + l] as usize
    }

    /// Adds the second derivatives of residual `i` (already multiplied by its coefficient)
    /// between its local vertices `k` (row) and `l` (column): `h_gg = d2/dg_k dg_l` and
    /// `h_gx = d2/dg_k dX_l` (3 x 3, row-major). Call it for every ordered pair `(k, l)`,
    /// including `k = l`; `d2/dX dX` is zero (residuals linear in `X`).
    ///
    /// With `g = a`, `X = b - a`: `d/da = d/dg - d/dX`, `d/db = d/dX`, so
    /// `H_aa[k,l] = h_gg[k,l] - h_gx[k,l] - h_gx[l,k]^T`, `H_ab[k,l] = h_gx[k,l]`, `H_bb = 0`.
    /// With `g = b`: `d/da = -d/dX`, `d/db = d/dg + d/dX`, so `H_aa = 0`,
    /// `H_ab[l,k] = -h_gx[k,l]^T`, `H_bb[k,l] = h_gg[k,l] + h_gx[k,l] + h_gx[l,k]^T`.
    #[inline]
    pub fn add(&mut self, i: usize, k: usize, l: usize, h_gg: &[f64; 9], h_gx: &[f64; 9]) {
        let (kl, lk) = (self.slot(i, k, l), self.slot(i, l, k));
        match self.at {
            At::Start => {
                if let Some(aa) = self.aa.as_deref_mut() {
                    add_to(&mut aa[kl], h_gg, 1.0);
                    add_to(&mut aa[kl], h_gx, -1.0);
                    add_transposed(&mut aa[lk], h_gx, -1.0);
                }
                if let Some(ab) = self.ab.as_deref_mut() {
                    add_to(&mut ab[kl], h_gx, 1.0);
                }
            }
            At::End => {
                if let Some(ab) = self.ab.as_deref_mut() {
                    add_transposed(&mut ab[lk], h_gx, -1.0);
                }
                if let Some(bb) = self.bb.as_deref_mut() {
                    add_to(&mut bb[kl], h_gg, 1.0);
                    add_to(&mut bb[kl], h_gx, 1.0);
                    add_transposed(&mut bb[lk], h_gx, 1.0);
                }
            }
        }
    }
}
