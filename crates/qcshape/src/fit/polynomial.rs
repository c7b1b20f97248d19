//! A global polynomial warp of space fitted before the non-rigid stages
//! ([`super::FitOptions::global_degree`]): the template `p` (#V x 3) moved by
//! `x_i = p_i + D(p_i)`, `D` a polynomial displacement field of ambient space of degree at most
//! `d` (in coordinates where the template has centroid 0 and rms radius 1; `(d + 1)(d + 2)(d +
//! 3) / 6` monomials per coordinate), fitted to the non-rigid fit's pairs (closest points both
//! ways, same robust weights) degree by degree (1, then 2, ... up to `d`). Each degree is a
//! damped Gauss-Newton (Levenberg-Marquardt) iteration on: each pair's residual along the
//! target's normal (weight 1) and along the axes (weight [`POINT`]), `STAY sum_i |D(p_i)|^2`
//! (the least motion among warps that fit alike) and a tiny pull of the coefficients to 0; a
//! step is kept only if it lowers that objective with the pairs found again at the new
//! positions. A degree ends when no vertex moved more than `1e-3` mean edge lengths, the
//! objective stalls, or after [`ITERATIONS`] steps.
//!
//! *Why*: the data pin each vertex only along the normal, so a fit whose coarse stage cannot
//! represent the motion compromises along the surface, and the later, softer stages keep that
//! slide (docs/fit.md "Why the fit slides, measured"): one affine map fitted to a tapered
//! ellipsoid (an egg) is shifted towards the wide end. A smooth map of space of low degree
//! represents a taper, a shear, a stretch and a gentle bend exactly or nearly. *Limit*: it also
//! fits a dented or rippled surface closely by sliding the whole template, so local motions get
//! worse (docs/fit.md "Global polynomial warp").

use super::error::FitError;
use super::nonrigid::{matches, Matches, Solver};
use super::options::FitOptions;
use super::rigid::stride;
use super::target::Prepared;
use crate::mesh::geometry::{centroid_and_rms_radius, dot, largest_move, mean_edge_length, sub};

use super::options::MAX_GLOBAL_DEGREE as MAX_DEGREE;

/// Steps per degree at most.
pub const ITERATIONS: usize = 50;

/// A degree ends when no vertex moved more than this many mean edge lengths.
const CONVERGED: f64 = 1e-3;

/// Weight of a pair's residual along the axes against its part along the target's normal:
/// mostly point-to-plane, so the warp is not dragged along the surface by the closest points.
/// Chosen on the benchmark and the LV refit of docs/fit.md "Global polynomial warp": 0.01 fits
/// a taper best (0.09 edge lengths against 0.11) but spreads dents and ripples further and
/// lost the LV cohort's agreement (Spearman 0.59 / 0.47 against 0.73 / 0.63 at 0.1); 1 loses the
/// taper (0.85).
pub const POINT: f64 = 0.1;

/// Weight of the displacement `sum_i |D(q_i)|^2` against one pair's: among warps that fit the
/// data alike, the least motion (a drift along a near-symmetry of the surface costs).
const STAY: f64 = 1e-3;

/// First damping of the steps (weight of `|x' - x|^2` per vertex against one pair's), divided
/// by 3 after an accepted step and multiplied by 4 after a rejected one (Levenberg-Marquardt).
const DAMPING: f64 = 0.1;
const MIN_DAMPING: f64 = 1e-4;
const MAX_DAMPING: f64 = 1e4;

/// Pull of the coefficients to 0, relative to the data's total weight.
const RIDGE: f64 = 1e-6;

/// The exponents `[a, b, c]` of the monomials `u^a v^b w^c` of degree 1 to `d`, lowest degree
/// first (the constant is the translation, also fitted: listed first).
fn exponents(d: usize) -> Vec<[u32; 3]> {
    let mut out = vec![[0, 0, 0]];
    for total in 1..=d as u32 {
        for a in (0..=total).rev() {
            for b in (0..=total - a).rev() {
                out.push([a, b, total - a - b]);
            }
        }
    }
    out
}

/// The monomials of `q` for `exps`.
fn basis(q: [f64; 3], exps: &[[u32; 3]], out: &mut [f64]) {
    for (o, e) in out.iter_mut().zip(exps) {
        *o = q[0].powi(e[0] as i32) * q[1].powi(e[1] as i32) * q[2].powi(e[2] as i32);
    }
}

/// Solves the symmetric positive definite `k x k` system `a x = b` (row-major `a`, its lower
/// triangle read) by Cholesky in place (`b` becomes `x`); `None` if not positive definite.
fn cholesky_solve(a: &mut [f64], b: &mut [f64], k: usize) -> Option<()> {
    for j in 0..k {
        let mut d = a[j * k + j];
        for m in 0..j {
            d -= a[j * k + m] * a[j * k + m];
        }
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let d = d.sqrt();
        a[j * k + j] = d;
        for i in j + 1..k {
            let mut s = a[i * k + j];
            for m in 0..j {
                s -= a[i * k + m] * a[j * k + m];
            }
            a[i * k + j] = s / d;
        }
    }
    for i in 0..k {
        let mut s = b[i];
        for m in 0..i {
            s -= a[i * k + m] * b[m];
        }
        b[i] = s / a[i * k + i];
    }
    for i in (0..k).rev() {
        let mut s = b[i];
        for m in i + 1..k {
            s -= a[m * k + i] * b[m];
        }
        b[i] = s / a[i * k + i];
    }
    Some(())
}

/// The template `start` (#V x 3, target units) warped by the polynomial field of degree at
/// most `degree` fitted to `target` (see the module docs), and the number of fits made.
/// `degree = 0` returns `start` unchanged.
pub(crate) fn warp(
    solver: &Solver,
    start: Vec<[f64; 3]>,
    target: &Prepared,
    opts: &FitOptions,
    degree: usize,
) -> Result<(Vec<[f64; 3]>, usize), FitError> {
    if degree == 0 {
        return Ok((start, 0));
    }
    let topo = &**solver.topology();
    let nv = start.len();
    let lbar = mean_edge_length(topo, &start);
    let (center, radius) = centroid_and_rms_radius(&start);
    // Normalized template positions and their monomials (#V x k), for the highest degree.
    let q: Vec<[f64; 3]> = start
        .iter()
        .map(|p| sub(*p, center).map(|v| v / radius))
        .collect();
    let all = exponents(degree.min(MAX_DEGREE));
    let kmax = all.len();
    let mut phi = vec![0.0; nv * kmax];
    for (i, qi) in q.iter().enumerate() {
        basis(*qi, &all, &mut phi[i * kmax..(i + 1) * kmax]);
    }
    let samples: Vec<usize> = stride(target.positions.len(), opts.max_samples.max(2 * nv)).collect();
    let frame = Frame {
        center,
        radius,
        q: &q,
        phi: &phi,
        kmax,
    };
    let mut x = start;
    let mut fits = 0;
    for d in 1..=degree.min(MAX_DEGREE) {
        let k = exponents(d).len();
        let mut m = matches(solver, &x, target, &samples, opts, lbar);
        if fits == 0 && m.matched * 10 < nv {
            return Err(FitError::NoOverlap {
                matched: m.matched,
                total: nv,
            });
        }
        let mut fx = frame.objective(&m, &x);
        let mut damping = DAMPING;
        for _ in 0..ITERATIONS {
            let next = frame.step(&m, &x, k, damping)?;
            fits += 1;
            let mn = matches(solver, &next, target, &samples, opts, lbar);
            let fnext = frame.objective(&mn, &next);
            if fnext < fx {
                let moved = largest_move(&next, &x);
                let gain = fx - fnext;
                x = next;
                m = mn;
                fx = fnext;
                damping = (damping / 3.0).max(MIN_DAMPING);
                if moved < CONVERGED * lbar || gain <= 1e-9 * fx {
                    break;
                }
            } else {
                damping *= 4.0;
                if damping > MAX_DAMPING {
                    break;
                }
            }
        }
    }
    Ok((x, fits))
}

/// The template's normalized frame and monomials (#V x `kmax`) shared by the steps.
struct Frame<'a> {
    center: [f64; 3],
    radius: f64,
    q: &'a [[f64; 3]],
    phi: &'a [f64],
    kmax: usize,
}

impl Frame<'_> {
    fn to(&self, p: [f64; 3]) -> [f64; 3] {
        sub(p, self.center).map(|v| v / self.radius)
    }

    /// The warp's objective at `x` (target units) with the correspondences `m` (found at `x`),
    /// in the frame's coordinates (centroid 0, rms radius 1): the pairs' squared distances plus
    /// `STAY` times the squared displacements from the template.
    fn objective(&self, m: &Matches, x: &[[f64; 3]]) -> f64 {
        let xn: Vec<[f64; 3]> = x.iter().map(|p| self.to(*p)).collect();
        let mut f = 0.0;
        for (i, xi) in xn.iter().enumerate() {
            let r = sub(*xi, self.to(m.y[i]));
            f += m.c[i] * dot(r, r);
            let dsp = sub(*xi, self.q[i]);
            f += STAY * dot(dsp, dsp);
        }
        for s in &m.samples {
            let mut p = [0.0; 3];
            for (corner, &bm) in s.face.iter().zip(&s.bary) {
                for c in 0..3 {
                    p[c] += bm * xn[*corner as usize][c];
                }
            }
            let r = sub(p, self.to(s.s));
            f += s.weight * dot(r, r);
        }
        f
    }

    /// One damped Gauss-Newton step of the degree-`k`-monomial warp from `x` with the
    /// correspondences `m`: the pairs' residuals along the target's normal (weight 1) and along
    /// the axes (weight [`POINT`]), `STAY |D|^2`, `damping |x' - x|^2` and `RIDGE |C|^2`.
    fn step(&self, m: &Matches, x: &[[f64; 3]], k: usize, damping: f64) -> Result<Vec<[f64; 3]>, FitError> {
        let (q, phi, kmax) = (self.q, self.phi, self.kmax);
        let nv = q.len();
        // Normal equations in the displacement's coefficients C (3k: coordinate-major).
        let n3 = 3 * k;
        let mut a = vec![0.0; n3 * n3];
        let mut b = vec![0.0; n3];
        let mut total = 0.0;
        let mut add = |f: &[f64], w: f64, n: [f64; 3], r: [f64; 3], a: &mut [f64], b: &mut [f64]| {
            // The residual along the normal (weight 1) and along the axes (weight POINT);
            // along the axes only (weight 1) where there is no normal (a point cloud).
            let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            let has_normal = dot(n, n) > 0.0;
            let axis_weight = if has_normal { POINT } else { 1.0 };
            let dirs = [(n, 1.0)].into_iter().filter(|_| has_normal);
            for (d, wd) in dirs.chain(axes.map(|e| (e, axis_weight))) {
                let ww = w * wd;
                let t = -dot(d, r);
                for ci in (0..3).filter(|&c| d[c] != 0.0) {
                    for i in 0..k {
                        let gi = d[ci] * f[i];
                        b[ci * k + i] += ww * gi * t;
                        for cj in (0..=ci).filter(|&c| d[c] != 0.0) {
                            // Lower triangle only (row >= column).
                            let top = if cj == ci { i + 1 } else { k };
                            for j in 0..top {
                                a[(ci * k + i) * n3 + cj * k + j] += ww * gi * d[cj] * f[j];
                            }
                        }
                    }
                }
            }
            total += w;
        };
        for i in 0..nv {
            if m.c[i] > 0.0 {
                add(
                    &phi[i * kmax..i * kmax + k],
                    m.c[i],
                    m.n[i],
                    sub(q[i], self.to(m.y[i])),
                    &mut a,
                    &mut b,
                );
            }
        }
        let mut f = vec![0.0; k];
        for s in &m.samples {
            let mut rest = [0.0; 3];
            f.iter_mut().for_each(|v| *v = 0.0);
            for (corner, &bm) in s.face.iter().zip(&s.bary) {
                let v = *corner as usize;
                for c in 0..3 {
                    rest[c] += bm * q[v][c];
                }
                for (fj, pj) in f.iter_mut().zip(&phi[v * kmax..v * kmax + k]) {
                    *fj += bm * pj;
                }
            }
            add(&f, s.weight, s.n, sub(rest, self.to(s.s)), &mut a, &mut b);
        }
        // STAY |D(q_i)|^2 and damping |q_i + D(q_i) - x_i|^2 (the previous iterate).
        for i in 0..nv {
            let fi = &phi[i * kmax..i * kmax + k];
            let dprev = sub(self.to(x[i]), q[i]);
            for c in 0..3 {
                for r in 0..k {
                    b[c * k + r] += damping * fi[r] * dprev[c];
                    for j in 0..=r {
                        a[(c * k + r) * n3 + c * k + j] += (STAY + damping) * fi[r] * fi[j];
                    }
                }
            }
        }
        let ridge = RIDGE * total.max(1.0);
        for i in 0..n3 {
            a[i * n3 + i] += ridge;
            for j in i + 1..n3 {
                a[i * n3 + j] = a[j * n3 + i];
            }
        }
        if cholesky_solve(&mut a, &mut b, n3).is_none() {
            return Err(FitError::NotFinite);
        }
        let next: Vec<[f64; 3]> = (0..nv)
            .map(|i| {
                let mut p = q[i];
                for j in 0..k {
                    for c in 0..3 {
                        p[c] += phi[i * kmax + j] * b[c * k + j];
                    }
                }
                [0, 1, 2].map(|c| self.center[c] + self.radius * p[c])
            })
            .collect();
        if next.iter().flatten().any(|v| !v.is_finite()) {
            return Err(FitError::NotFinite);
        }
        Ok(next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponents_count_the_monomials() {
        for d in 0..=MAX_DEGREE {
            assert_eq!(exponents(d).len(), (d + 1) * (d + 2) * (d + 3) / 6);
        }
        assert_eq!(exponents(1), vec![[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]);
    }

    #[test]
    fn cholesky_solves_a_small_system() {
        let orig = [4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0];
        let x = [1.0, -2.0, 0.5];
        let mut b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| orig[i * 3 + j] * x[j]).sum())
            .collect();
        let mut a = orig.to_vec();
        cholesky_solve(&mut a, &mut b, 3).unwrap();
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-12, "{b:?}");
        }
        let mut singular = vec![1.0, 1.0, 1.0, 1.0];
        assert!(cholesky_solve(&mut singular, &mut [1.0, 2.0], 2).is_none());
    }
}
