//! The discrete path energy (eq. 12) and its exact gradient.

// Index loops mirror the formulas (vertex, coordinate, residual indices) in these kernels.
#![allow(clippy::needless_range_loop)]

use std::sync::Arc;

use rayon::prelude::*;

use crate::mesh::Topology;
use crate::metric::{At, Jacobian, Metric, Pattern, PoseShare, Scratch, Segment, SegmentSink};

/// One segment's energy and gradient parts: (energy, d/dP_i, d/dP_{i+1}, d/daux).
/// One segment's energy and its gradient parts: at its start pose, at its end pose, and for its
/// auxiliary unknowns.
#[derive(Default)]
struct SegmentGradient {
    energy: f64,
    ga: Vec<[f64; 3]>,
    gb: Vec<[f64; 3]>,
    gaux: Vec<f64>,
    /// [`Metric::segment_gradient_with`]'s coefficients for its first and last pose.
    ca: Vec<f64>,
    cb: Vec<f64>,
}

/// Reusable per-segment accumulators of [`PathEnergy::energy_gradient_with`].
#[derive(Default)]
pub(crate) struct SegmentWork {
    parts: Vec<SegmentGradient>,
    /// [`Metric::pose_values`] of every pose of the path (`N + 1`; empty for metrics without).
    poses: Vec<Vec<f64>>,
    /// Per interior pose: its two segments' coefficients summed, and its pose gradient.
    pose_grads: Vec<(Vec<f64>, Vec<[f64; 3]>)>,
    /// The end poses (first, last) whose values `poses[0]` and `poses[N]` hold: a solve's ends
    /// do not move, so their values are recomputed only when the positions differ.
    ends_seen: [Vec<[f64; 3]>; 2],
}

/// Fixed data of one path problem: the two end poses and the frozen metric weights.
#[derive(Debug, Clone)]
pub struct Ends {
    /// First pose `P_0` (#V x 3).
    pub start: Vec<[f64; 3]>,
    /// Last pose `P_N` (#V x 3).
    pub end: Vec<[f64; 3]>,
    /// Per-vertex weights frozen along the path ([`Metric::frozen_weights`]).
    pub frozen: Option<Vec<f64>>,
}

/// The path energy `E(P) = sum_i ( G_{P_i}(X_i) + G_{P_{i+1}}(X_i) )` (eq. 12) of a path with
/// `N` segments and fixed ends, as a function of the unknown vector
/// `x = [P_1, ..., P_{N-1} (each #V x 3, flattened), aux_0, ..., aux_{2N-1}]`, where `aux_t`
/// are the metric's auxiliary unknowns of term `t = 2 i + (0 for At::Start, 1 for At::End)`.
///
/// Holds the metric's Jacobian pattern, built once per topology.
#[derive(Debug)]
pub struct PathEnergy<'m> {
    pub(crate) topo: Arc<Topology>,
    pub(crate) metric: &'m dyn Metric,
    pub(crate) pattern: Pattern,
    pub(crate) steps: usize,
}

/// Residuals and Jacobian of one term, reused across evaluations.
pub(crate) struct TermEval {
    pub r: Vec<f64>,
    pub jac: Jacobian,
}

impl<'m> PathEnergy<'m> {
    /// Path energy with `steps = N >= 1` segments for `metric` on `topo`.
    pub fn new(metric: &'m dyn Metric, topo: Arc<Topology>, steps: usize) -> Self {
        assert!(steps >= 1, "a path has at least one segment");
        let pattern = metric.pattern(&topo);
        PathEnergy {
            topo,
            metric,
            pattern,
            steps,
        }
    }

    /// Number of segments `N`.
    pub fn steps(&self) -> usize {
        self.steps
    }
    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.topo.n_vertices()
    }
    /// Number of pose unknowns, `3 #V (N - 1)`.
    pub fn n_pose_vars(&self) -> usize {
        3 * self.n_vertices() * (self.steps - 1)
    }
    /// Number of unknowns (poses and auxiliary).
    pub fn n_vars(&self) -> usize {
        self.n_pose_vars() + 2 * self.steps * self.metric.n_aux()
    }
    /// The metric's Jacobian pattern.
    pub fn pattern(&self) -> &Pattern {
        &self.pattern
    }
    /// The topology the energy is measured on.
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topo
    }
    /// The metric `G` of every segment term.
    pub fn metric(&self) -> &'m dyn Metric {
        self.metric
    }

    /// Pose `i` (0..=N) of the path given by `x` and `ends`.
    pub fn pose<'a>(&self, x: &'a [f64], ends: &'a Ends, i: usize) -> &'a [[f64; 3]] {
        if i == 0 {
            &ends.start
        } else if i == self.steps {
            &ends.end
        } else {
            let n = 3 * self.n_vertices();
            x[(i - 1) * n..i * n].as_chunks::<3>().0
        }
    }

    /// Auxiliary unknowns of term `t`.
    pub fn aux<'a>(&self, x: &'a [f64], t: usize) -> &'a [f64] {
        let k = self.metric.n_aux();
        &x[self.n_pose_vars() + t * k..self.n_pose_vars() + (t + 1) * k]
    }

    pub(crate) fn new_term_eval(&self) -> TermEval {
        TermEval {
            r: vec![0.0; self.pattern.n_residuals()],
            jac: Jacobian::zeros(&self.pattern, self.metric.n_aux()),
        }
    }

    pub(crate) fn segment<'a>(&self, x: &'a [f64], ends: &'a Ends, s: usize, at: At) -> Segment<'a> {
        let t = 2 * s + usize::from(at == At::End);
        Segment {
            a: self.pose(x, ends, s),
            b: self.pose(x, ends, s + 1),
            at,
            aux: self.aux(x, t),
            frozen: ends.frozen.as_deref(),
        }
    }

    /// Evaluates term (`s`, `at`) into `out`; with `jac`, also its Jacobian. Returns `|r|^2`.
    pub(crate) fn eval_term(
        &self,
        x: &[f64],
        ends: &Ends,
        s: usize,
        at: At,
        out: &mut TermEval,
        jac: bool,
    ) -> f64 {
        let seg = self.segment(x, ends, s, at);
        let j = if jac { Some(out.jac.as_mut()) } else { None };
        self.metric
            .residuals(&self.topo, self.pattern.as_ref(), &seg, &mut out.r, j);
        out.r.iter().map(|v| v * v).sum()
    }

    /// The energy `E(x)` (eq. 12). Segments are evaluated in parallel and summed in order, so
    /// the result does not depend on the thread count or scheduling.
    pub fn energy(&self, x: &[f64], ends: &Ends) -> f64 {
        let parts: Vec<f64> = (0..self.steps)
            .into_par_iter()
            .map_init(
                || self.new_term_eval(),
                |te, s| {
                    self.eval_term(x, ends, s, At::Start, te, false)
                        + self.eval_term(x, ends, s, At::End, te, false)
                },
            )
            .collect();
        parts.iter().sum()
    }

    /// `f(G_{P_i} term, G_{P_{i+1}} term)` of every segment `i` in order, segments in
    /// parallel (the two terms of eq. 12's segment `i`, auxiliary unknowns at their optimum).
    fn per_segment<T: Send>(
        &self,
        x: &[f64],
        ends: &Ends,
        f: impl Fn(&Segment, &Segment) -> T + Sync,
    ) -> Vec<T> {
        (0..self.steps)
            .into_par_iter()
            .map(|s| {
                f(
                    &self.segment(x, ends, s, At::Start),
                    &self.segment(x, ends, s, At::End),
                )
            })
            .collect()
    }

    /// Per segment `(G_{P_i}(X_i), G_{P_{i+1}}(X_i))`, with the auxiliary unknowns at their
    /// optimum (so the values are the metric's squared norms).
    pub fn segment_norms(&self, x: &[f64], ends: &Ends) -> Vec<(f64, f64)> {
        self.per_segment(x, ends, |s0, s1| {
            let [g0, g1] = self
                .metric
                .segment_squared_norms(&self.topo, self.pattern.as_ref(), [s0, s1]);
            (g0, g1)
        })
    }

    /// The path energy (eq. 12) split into the geometric term and the L2 regularizer
    /// ([`Metric::segment_energy_parts`]), `[geometric, regularizer]`, each summed over the
    /// segments in order (the auxiliary unknowns at their optimum).
    pub fn energy_parts(&self, x: &[f64], ends: &Ends) -> [f64; 2] {
        let parts: Vec<[f64; 2]> = self.per_segment(x, ends, |s0, s1| {
            self.metric
                .segment_energy_parts(&self.topo, self.pattern.as_ref(), [s0, s1])
        });
        parts
            .iter()
            .fold([0.0, 0.0], |acc, p| [acc[0] + p[0], acc[1] + p[1]])
    }

    /// The bending term's part of the path energy ([`Metric::segment_bending_energy`], summed
    /// over the segments in order): 0 for metrics without one.
    pub fn bending_energy(&self, x: &[f64], ends: &Ends) -> f64 {
        let parts: Vec<f64> = self.per_segment(x, ends, |s0, s1| {
            self.metric
                .segment_bending_energy(&self.topo, self.pattern.as_ref(), [s0, s1])
        });
        parts.iter().sum()
    }

    /// [`Self::segment_norms`] and [`Self::energy_parts`] from one evaluation of each segment
    /// ([`Metric::segment_norms_and_parts`]): the same values, bit for bit.
    pub fn segment_norms_and_energy_parts(&self, x: &[f64], ends: &Ends) -> (Vec<(f64, f64)>, [f64; 2]) {
        let both: Vec<([f64; 2], [f64; 2])> = self.per_segment(x, ends, |s0, s1| {
            self.metric
                .segment_norms_and_parts(&self.topo, self.pattern.as_ref(), [s0, s1])
        });
        let norms = both.iter().map(|(g, _)| (g[0], g[1])).collect();
        let parts = both
            .iter()
            .fold([0.0, 0.0], |acc, (_, p)| [acc[0] + p[0], acc[1] + p[1]]);
        (norms, parts)
    }

    /// The energy and its exact gradient `2 J^T r` (written to `grad`, length [`Self::n_vars`]).
    pub fn energy_gradient(&self, x: &[f64], ends: &Ends, grad: &mut [f64]) -> f64 {
        self.energy_gradient_segments(x, ends, grad, None)
    }

    /// [`Self::energy_gradient`], also writing each segment's energy
    /// `G_{P_i}(X_i) + G_{P_{i+1}}(X_i)` into `segments` (length `N`) when given: with the
    /// auxiliary unknowns at their optimum these are the squared segment lengths times 2, so a
    /// solver's last evaluation gives the path's length without another pass.
    pub(crate) fn energy_gradient_segments(
        &self,
        x: &[f64],
        ends: &Ends,
        grad: &mut [f64],
        segments: Option<&mut [f64]>,
    ) -> f64 {
        self.energy_gradient_with(x, ends, grad, segments, &mut SegmentWork::default())
    }

    /// [`Self::energy_gradient_segments`] with the per-segment accumulators kept in `work`
    /// between calls (a solver's evaluations reuse them: no allocation once warm). The same
    /// arithmetic and the same fixed order of the sums, whatever the thread count.
    pub(crate) fn energy_gradient_with(
        &self,
        x: &[f64],
        ends: &Ends,
        grad: &mut [f64],
        mut segments: Option<&mut [f64]>,
        work: &mut SegmentWork,
    ) -> f64 {
        let nv3 = 3 * self.n_vertices();
        let nv = nv3 / 3;
        let n_aux = self.metric.n_aux();
        work.parts.resize_with(self.steps, SegmentGradient::default);
        // Pass 1: each pose's shared values once (a pose belongs to two segments); none if
        // the metric has none. The ends' only when they are not those of the last call.
        let pattern = self.pattern.as_ref();
        let n = self.steps;
        work.poses.resize_with(n + 1, Vec::new);
        for (seen, i) in work.ends_seen.iter_mut().zip([0, n]) {
            let pose = self.pose(x, ends, i);
            if seen.as_slice() != pose {
                self.metric
                    .pose_values(&self.topo, pattern, pose, &mut work.poses[i]);
                seen.clear();
                seen.extend_from_slice(pose);
            }
        }
        let shared = !work.poses[0].is_empty();
        if shared {
            work.poses[1..n].par_iter_mut().enumerate().for_each(|(i, out)| {
                self.metric
                    .pose_values(&self.topo, pattern, self.pose(x, ends, i + 1), out)
            });
        }
        let poses = &work.poses;
        work.parts
            .par_iter_mut()
            .enumerate()
            .for_each_init(Scratch::default, |scratch, (s, part)| {
                // Per-vertex accumulators, filled by the metric's (fused) gradient kernel.
                part.ga.clear();
                part.ga.resize(nv, [0.0; 3]);
                part.gb.clear();
                part.gb.resize(nv, [0.0; 3]);
                part.gaux.clear();
                part.gaux.resize(2 * n_aux, 0.0);
                let (s0, s1) = (
                    self.segment(x, ends, s, At::Start),
                    self.segment(x, ends, s, At::End),
                );
                let mut sink = SegmentSink {
                    ga: &mut part.ga,
                    gb: &mut part.gb,
                    gaux: &mut part.gaux,
                    weight: 1.0,
                };
                // Pass 2: the segment's value and gradient, and its poses' coefficients.
                let values: [&[f64]; 2] = if shared {
                    [&poses[s], &poses[s + 1]]
                } else {
                    [&[], &[]]
                };
                part.energy = self.metric.segment_gradient_with(
                    &self.topo,
                    pattern,
                    [&s0, &s1],
                    PoseShare {
                        values,
                        coeffs: [&mut part.ca, &mut part.cb],
                    },
                    scratch,
                    &mut sink,
                );
            });
        // Pass 3: each interior pose's gradient from its two segments' coefficients.
        if shared {
            let parts = &work.parts;
            work.pose_grads.resize_with(self.steps - 1, Default::default);
            work.pose_grads
                .par_iter_mut()
                .enumerate()
                .for_each(|(k, (c, g))| {
                    let i = k + 1;
                    c.clear();
                    c.extend(parts[i - 1].cb.iter().zip(&parts[i].ca).map(|(u, v)| u + v));
                    g.clear();
                    g.resize(nv, [0.0; 3]);
                    self.metric
                        .pose_gradient(&self.topo, pattern, self.pose(x, ends, i), &poses[i], c, g);
                });
        }
        grad.fill(0.0);
        let np = self.n_pose_vars();
        let mut e = 0.0;
        for (s, part) in work.parts.iter().enumerate() {
            e += part.energy;
            if let Some(out) = segments.as_deref_mut() {
                out[s] = part.energy;
            }
            if s >= 1 {
                for (g, v) in grad[(s - 1) * nv3..s * nv3]
                    .iter_mut()
                    .zip(part.ga.as_flattened())
                {
                    *g += v;
                }
            }
            if s + 1 < self.steps {
                for (g, v) in grad[s * nv3..(s + 1) * nv3]
                    .iter_mut()
                    .zip(part.gb.as_flattened())
                {
                    *g += v;
                }
            }
            grad[np + 2 * s * n_aux..np + 2 * (s + 1) * n_aux].copy_from_slice(&part.gaux);
        }
        if shared {
            for (k, (_, g)) in work.pose_grads.iter().enumerate() {
                for (out, v) in grad[k * nv3..(k + 1) * nv3].iter_mut().zip(g.as_flattened()) {
                    *out += v;
                }
            }
        }
        e
    }

    /// Unknown vector of the linear interpolation `P_i = (1 - i/N) A + (i/N) B`, with the
    /// auxiliary unknowns at their optimum.
    pub fn linear_start(&self, ends: &Ends) -> Vec<f64> {
        let poses: Vec<Vec<[f64; 3]>> = (1..self.steps)
            .map(|i| {
                let t = i as f64 / self.steps as f64;
                ends.start
                    .iter()
                    .zip(&ends.end)
                    .map(|(p, q)| [0, 1, 2].map(|c| (1.0 - t) * p[c] + t * q[c]))
                    .collect()
            })
            .collect();
        self.pack(&poses, ends)
    }

    /// Start vector from the poses `Q_0 .. Q_N` (each #V x 3) of a path between other, nearby
    /// ends: `P_i = Q_i + (1 - t_i) (A - Q_0) + t_i (B - Q_N)`, `t_i = i / N`, for the ends `A`,
    /// `B` of `ends`. The path's bend (its difference from the straight line between its ends) is
    /// kept and the line moved onto the new ends; with a straight `Q` this is
    /// [`Self::linear_start`]. The caller checks that `near` has N + 1 poses of #V vertices.
    pub fn shifted_start(&self, near: &[Vec<[f64; 3]>], ends: &Ends) -> Vec<f64> {
        let n = self.steps;
        let (q0, qn) = (&near[0], &near[n]);
        let poses: Vec<Vec<[f64; 3]>> = (1..n)
            .map(|i| {
                let t = i as f64 / n as f64;
                (0..ends.start.len())
                    .map(|v| {
                        let (a, b, q) = (ends.start[v], ends.end[v], near[i][v]);
                        [0, 1, 2].map(|c| q[c] + (1.0 - t) * (a[c] - q0[v][c]) + t * (b[c] - qn[v][c]))
                    })
                    .collect()
            })
            .collect();
        self.pack(&poses, ends)
    }

    /// Unknown vector from interior poses `P_1 .. P_{N-1}`, with the auxiliary unknowns at
    /// their optimum for those poses.
    pub fn pack(&self, interior: &[Vec<[f64; 3]>], ends: &Ends) -> Vec<f64> {
        assert_eq!(interior.len(), self.steps - 1);
        let mut x = Vec::with_capacity(self.n_vars());
        for p in interior {
            x.extend_from_slice(p.as_flattened());
        }
        x.resize(self.n_vars(), 0.0);
        self.reset_aux(&mut x, ends);
        x
    }

    /// Sets every term's auxiliary unknowns to their optimum for the current poses.
    pub fn reset_aux(&self, x: &mut [f64], ends: &Ends) {
        let k = self.metric.n_aux();
        if k == 0 {
            return;
        }
        let np = self.n_pose_vars();
        for s in 0..self.steps {
            for (j, at) in [At::Start, At::End].into_iter().enumerate() {
                let seg = Segment {
                    aux: &[],
                    ..self.segment(x, ends, s, at)
                };
                let best = self.metric.best_aux(&self.topo, &seg);
                let t = 2 * s + j;
                x[np + t * k..np + (t + 1) * k].copy_from_slice(&best);
            }
        }
    }
}
