//! The L-BFGS inverse Hessian in compact form (Byrd, Nocedal & Schnabel 1994, Theorem 2.2)
//! with a preconditioned initial matrix `H0 = gamma M^{-1}`:
//!
//! `H g = gamma M^{-1} g + S p - gamma (M^{-1} Y) u`, `u = R^{-1} S^T g`,
//! `p = R^{-T} ((D + gamma Y^T M^{-1} Y) u - gamma (M^{-1} Y)^T g)`,
//!
//! with `R` the upper triangle of `S^T Y` and `D` its diagonal. The same direction as the
//! two-loop recursion, but the long vectors are read twice per iteration (the products
//! `S^T g`, `(M^{-1} Y)^T g` in one pass, the combination in another) instead of five times
//! per pair: the history (3 m vectors of 3 #V (N - 1)) does not fit in cache, so the two-loop
//! recursion is bound by memory traffic. The small matrices are updated from those products:
//! `s_i . y_new = s_i . g_new - s_i . g` and `y_new . M^{-1} y_i` likewise.

use std::collections::VecDeque;

use super::dot;

/// One correction pair with its preconditioned `y`.
pub(crate) struct Pair {
    pub s: Vec<f64>,
    pub y: Vec<f64>,
    /// `M^{-1} y` for the current preconditioner `M`.
    pub my: Vec<f64>,
}

/// The last `mem` correction pairs and the small matrices of the compact form.
pub(crate) struct CompactHistory {
    mem: usize,
    pairs: VecDeque<Pair>,
    /// `s_i . y_j` for `i <= j` (oldest first; entries below the diagonal unused).
    sy: VecDeque<VecDeque<f64>>,
    /// `y_i . M^{-1} y_j` (symmetric).
    ymy: VecDeque<VecDeque<f64>>,
    /// `s_i . g` and `(M^{-1} y_i) . g` for the current gradient `g`.
    sg: VecDeque<f64>,
    myg: VecDeque<f64>,
}

/// Block length of the fused passes (a block of every vector involved stays in L1/L2).
const BLOCK: usize = 2048;

impl CompactHistory {
    /// An empty history keeping at most `mem` (>= 1) pairs.
    pub fn new(mem: usize) -> Self {
        CompactHistory {
            mem: mem.max(1),
            pairs: VecDeque::new(),
            sy: VecDeque::new(),
            ymy: VecDeque::new(),
            sg: VecDeque::new(),
            myg: VecDeque::new(),
        }
    }

    /// Number of stored pairs.
    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// Drops every pair.
    pub fn clear(&mut self) {
        self.pairs.clear();
        self.sy.clear();
        self.ymy.clear();
        self.sg.clear();
        self.myg.clear();
    }

    /// `(s_i . v, (M^{-1} y_i) . v)` for every stored pair, in one blocked pass.
    fn products(&self, v: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let k = self.pairs.len();
        let (mut a, mut b) = (vec![0.0; k], vec![0.0; k]);
        for start in (0..v.len()).step_by(BLOCK) {
            let end = (start + BLOCK).min(v.len());
            let vb = &v[start..end];
            for (i, p) in self.pairs.iter().enumerate() {
                a[i] += dot(&p.s[start..end], vb);
                b[i] += dot(&p.my[start..end], vb);
            }
        }
        (a, b)
    }

    /// `d = -H g` for `H0 = gamma M^{-1}`, given `mg = M^{-1} g` (`g` is the gradient last
    /// passed to [`Self::advance`] or [`Self::reset_gradient`]).
    pub fn direction(&self, mg: &[f64], gamma: f64, d: &mut [f64]) {
        let k = self.pairs.len();
        // u = R^{-1} S^T g (back substitution, R upper triangular).
        let mut u = vec![0.0; k];
        for i in (0..k).rev() {
            let s = self.sg[i] - (i + 1..k).map(|j| self.sy[i][j] * u[j]).sum::<f64>();
            u[i] = s / self.sy[i][i];
        }
        // w = (D + gamma Y^T M^{-1} Y) u - gamma (M^{-1} Y)^T g; p = R^{-T} w.
        let w: Vec<f64> = (0..k)
            .map(|i| {
                self.sy[i][i] * u[i] + gamma * (0..k).map(|j| self.ymy[i][j] * u[j]).sum::<f64>()
                    - gamma * self.myg[i]
            })
            .collect();
        let mut p = vec![0.0; k];
        for i in 0..k {
            let s = w[i] - (0..i).map(|j| self.sy[j][i] * p[j]).sum::<f64>();
            p[i] = s / self.sy[i][i];
        }
        let cu: Vec<f64> = u.iter().map(|v| gamma * v).collect();
        for start in (0..d.len()).step_by(BLOCK) {
            let end = (start + BLOCK).min(d.len());
            let db = &mut d[start..end];
            for (di, mi) in db.iter_mut().zip(&mg[start..end]) {
                *di = -gamma * mi;
            }
            for (i, pair) in self.pairs.iter().enumerate() {
                let (pi, ci) = (p[i], cu[i]);
                for ((di, si), mi) in db.iter_mut().zip(&pair.s[start..end]).zip(&pair.my[start..end]) {
                    *di += ci * mi - pi * si;
                }
            }
        }
    }

    /// Moves to the next iterate's gradient `gn`, first adding `pair` (the step and gradient
    /// change into `gn`, with `s.y` and `y.M^{-1}y` precomputed) when given. Returns the evicted
    /// oldest pair's storage when the history was full.
    pub fn advance(&mut self, gn: &[f64], pair: Option<(Pair, f64, f64)>) -> Option<Pair> {
        let (sgn, mygn) = self.products(gn);
        let mut evicted = None;
        if let Some((pair, sy_new, ymy_new)) = pair {
            let k = self.pairs.len();
            // Column `new` of S^T Y and row `new` of Y^T M^{-1} Y from the two gradients.
            for i in 0..k {
                self.sy[i].push_back(sgn[i] - self.sg[i]);
                let v = mygn[i] - self.myg[i];
                self.ymy[i].push_back(v);
            }
            let mut sy_row: VecDeque<f64> = std::iter::repeat_n(0.0, k).collect();
            sy_row.push_back(sy_new);
            self.sy.push_back(sy_row);
            let mut ymy_row: VecDeque<f64> = (0..k).map(|i| self.ymy[i][k]).collect();
            ymy_row.push_back(ymy_new);
            self.ymy.push_back(ymy_row);
            let (s_gn, my_gn) = (dot(&pair.s, gn), dot(&pair.my, gn));
            self.pairs.push_back(pair);
            self.sg = sgn.into();
            self.myg = mygn.into();
            self.sg.push_back(s_gn);
            self.myg.push_back(my_gn);
            if self.pairs.len() > self.mem {
                evicted = self.pairs.pop_front();
                for m in [&mut self.sy, &mut self.ymy] {
                    m.pop_front();
                    m.iter_mut().for_each(|row| {
                        row.pop_front();
                    });
                }
                self.sg.pop_front();
                self.myg.pop_front();
            }
        } else {
            self.sg = sgn.into();
            self.myg = mygn.into();
        }
        evicted
    }

    /// After a change of the preconditioner `M`: recomputes every `M^{-1} y_i` by one call of
    /// `apply` on all of them (`z <- M^{-1} z` for the vectors stored one after the other in
    /// `z`), `Y^T M^{-1} Y`, and the products with the current gradient `g`.
    pub fn reset_preconditioner(&mut self, g: &[f64], mut apply: impl FnMut(&mut [f64])) {
        let n = g.len();
        let mut all: Vec<f64> = Vec::with_capacity(n * self.pairs.len());
        for p in &self.pairs {
            all.extend_from_slice(&p.y);
        }
        apply(&mut all);
        for (p, my) in self.pairs.iter_mut().zip(all.chunks_exact(n)) {
            p.my.copy_from_slice(my);
        }
        let k = self.pairs.len();
        for i in 0..k {
            for j in 0..=i {
                let v = dot(&self.pairs[i].y, &self.pairs[j].my);
                self.ymy[i][j] = v;
                self.ymy[j][i] = v;
            }
        }
        self.reset_gradient(g);
    }

    /// Recomputes the products with the current gradient `g`.
    pub fn reset_gradient(&mut self, g: &[f64]) {
        let (a, b) = self.products(g);
        self.sg = a.into();
        self.myg = b.into();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn matvec(m: &[Vec<f64>], v: &[f64]) -> Vec<f64> {
        m.iter().map(|row| dot(row, v)).collect()
    }

    fn spd(rng: &mut ChaCha8Rng, n: usize) -> Vec<Vec<f64>> {
        let b: Vec<Vec<f64>> = (0..n)
            .map(|_| (0..n).map(|_| rng.random_range(-1.0..1.0)).collect())
            .collect();
        (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..n).map(|k| b[k][i] * b[k][j]).sum::<f64>() + if i == j { 0.5 } else { 0.0 })
                    .collect()
            })
            .collect()
    }

    /// Adds the pair `(s, y, my)` to the history after the step into gradient `gn`, and to the
    /// reference list (kept to `mem` pairs).
    fn push(
        hist: &mut CompactHistory,
        reference: &mut Vec<(Vec<f64>, Vec<f64>)>,
        mem: usize,
        gn: &[f64],
        (s, y, my): (Vec<f64>, Vec<f64>, Vec<f64>),
    ) {
        let (sy, ymy) = (dot(&s, &y), dot(&y, &my));
        assert!(sy > 0.0);
        hist.advance(
            gn,
            Some((
                Pair {
                    s: s.clone(),
                    y: y.clone(),
                    my,
                },
                sy,
                ymy,
            )),
        );
        reference.push((s, y));
        if reference.len() > mem {
            reference.remove(0);
        }
    }

    /// The textbook two-loop recursion with `H0 = gamma Minv`.
    fn two_loop(
        pairs: &[(Vec<f64>, Vec<f64>)],
        minv: &dyn Fn(&[f64]) -> Vec<f64>,
        gamma: f64,
        g: &[f64],
    ) -> Vec<f64> {
        let mut q = g.to_vec();
        let mut alphas = Vec::new();
        for (s, y) in pairs.iter().rev() {
            let a = dot(s, &q) / dot(s, y);
            q.iter_mut().zip(y).for_each(|(qi, yi)| *qi -= a * yi);
            alphas.push(a);
        }
        let mut r: Vec<f64> = minv(&q).iter().map(|v| gamma * v).collect();
        for ((s, y), a) in pairs.iter().zip(alphas.iter().rev()) {
            let b = dot(y, &r) / dot(s, y);
            r.iter_mut().zip(s).for_each(|(ri, si)| *ri += (a - b) * si);
        }
        r.iter().map(|v| -v).collect()
    }

    #[test]
    fn compact_direction_matches_the_two_loop_recursion() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // Long enough for several blocks of the fused passes.
        let n = 2 * BLOCK + 37;
        let mem = 4;
        // A diagonal SPD Hessian and preconditioner keep the reference cheap at this size.
        let hess: Vec<f64> = (0..n).map(|_| rng.random_range(0.5..5.0)).collect();
        let mut minv_diag: Vec<f64> = (0..n).map(|_| rng.random_range(0.2..2.0)).collect();
        let mut hist = CompactHistory::new(mem);
        let mut reference: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
        let mut g: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        hist.reset_gradient(&g);
        for step in 0..9 {
            if step == 5 {
                // A new preconditioner: every M^{-1} y changes.
                minv_diag = (0..n).map(|_| rng.random_range(0.2..2.0)).collect();
                hist.reset_preconditioner(&g, |z| {
                    for zv in z.chunks_exact_mut(n) {
                        zv.iter_mut().zip(&minv_diag).for_each(|(v, m)| *v *= m);
                    }
                });
            }
            let gamma = 0.5 + 0.1 * step as f64;
            let mg: Vec<f64> = g.iter().zip(&minv_diag).map(|(a, b)| a * b).collect();
            let mut d = vec![0.0; n];
            hist.direction(&mg, gamma, &mut d);
            let diag = minv_diag.clone();
            let apply = move |v: &[f64]| -> Vec<f64> { v.iter().zip(&diag).map(|(a, b)| a * b).collect() };
            let want = two_loop(&reference, &apply, gamma, &g);
            let scale = want.iter().map(|v| v.abs()).fold(0.0, f64::max);
            for (a, b) in d.iter().zip(&want) {
                assert!((a - b).abs() <= 1e-10 * scale, "step {step}: {a} vs {b}");
            }
            // Step along d (scaled), a quadratic model's gradient change y = H s (+ a small
            // non-quadratic perturbation), then advance.
            let s: Vec<f64> = d.iter().map(|v| 0.3 * v).collect();
            let y: Vec<f64> = s
                .iter()
                .zip(&hess)
                .map(|(si, h)| h * si + 1e-3 * rng.random_range(-1.0..1.0) * si.abs())
                .collect();
            let gn: Vec<f64> = g.iter().zip(&y).map(|(a, b)| a + b).collect();
            let my: Vec<f64> = y.iter().zip(&minv_diag).map(|(a, b)| a * b).collect();
            push(&mut hist, &mut reference, mem, &gn, (s, y, my));
            assert_eq!(hist.len(), reference.len());
            g = gn;
        }
    }

    #[test]
    fn compact_direction_with_a_dense_preconditioner() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let n = 9;
        let minv = spd(&mut rng, n);
        let hess = spd(&mut rng, n);
        let mut hist = CompactHistory::new(3);
        let mut reference: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
        let mut g: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        hist.reset_gradient(&g);
        for step in 0..6 {
            let mg = matvec(&minv, &g);
            let mut d = vec![0.0; n];
            hist.direction(&mg, 0.7, &mut d);
            let want = two_loop(&reference, &|v: &[f64]| matvec(&minv, v), 0.7, &g);
            let scale = want.iter().map(|v| v.abs()).fold(0.0, f64::max);
            for (a, b) in d.iter().zip(&want) {
                assert!((a - b).abs() <= 1e-9 * scale, "step {step}: {a} vs {b}");
            }
            // Rejected pairs (no curvature update) leave the history as it is.
            if step == 2 {
                let gn: Vec<f64> = g.iter().map(|v| 0.9 * v).collect();
                hist.advance(&gn, None);
                g = gn;
                continue;
            }
            let s: Vec<f64> = d.iter().map(|v| 0.5 * v).collect();
            let y = matvec(&hess, &s);
            let gn: Vec<f64> = g.iter().zip(&y).map(|(a, b)| a + b).collect();
            let my = matvec(&minv, &y);
            push(&mut hist, &mut reference, 3, &gn, (s, y, my));
            g = gn;
        }
    }
}
