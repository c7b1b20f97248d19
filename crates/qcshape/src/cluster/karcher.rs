//! Intrinsic (Karcher) means of poses in shape space, with the discrete log map (docs/method.md
//! "Clustering").

use crate::geodesic::{Geodesic, GeodesicError, GeodesicSolver, SolveContext};

use crate::mesh::Pose;

/// Below this mean log norm, relative to the mean's own norm (both Euclidean norms of #V x 3
/// fields), the members are taken to coincide with the mean (round-off), and the iteration has
/// converged: a real spread of poses is many orders of magnitude above it, round-off of the
/// normalized coordinates about 1e-16.
pub const ROUNDOFF_SPREAD: f64 = 1e-10;

/// The damped step's floor, as a fraction of [`KarcherOptions::step`]: once the step has been
/// halved below it (four halvings) without lowering the variance, the iteration stops at the
/// best mean found (the logs' own inaccuracy, not the step, then limits the residual).
pub const MIN_STEP_FRACTION: f64 = 1.0 / 16.0;

/// A step is kept when it lowers the variance by more than this fraction (round-off of the sum
/// of squared distances; a real step near the tolerance 1e-3 lowers it by about 1e-6).
pub const VARIANCE_ROUNDOFF: f64 = 1e-12;

/// Options of the Karcher mean iteration `mu <- mu + step * mean_k log_mu(P_k)`, damped: a
/// step that does not lower the variance `sum_k dis(mu, P_k)^2` is taken back and retried with half
/// the step.
#[derive(Debug, Clone)]
pub struct KarcherOptions {
    /// Step along the mean log (the first one; halved whenever a step does not lower the
    /// variance).
    /// Default 1 (the Gauss-Newton step of the Karcher functional).
    pub step: f64,
    /// Iteration limit. Default 20.
    pub max_iterations: usize,
    /// Converged when the Euclidean norm of the mean log falls below this fraction of the
    /// mean norm of the logs. Default 1e-3.
    pub tolerance: f64,
}

impl Default for KarcherOptions {
    fn default() -> Self {
        KarcherOptions {
            step: 1.0,
            max_iterations: 20,
            tolerance: 1e-3,
        }
    }
}

/// A Karcher mean and how it was reached.
#[derive(Debug, Clone)]
pub struct KarcherMean {
    /// The mean pose (#V x 3), in the units of the inputs.
    pub mean: Pose,
    /// Iterations taken (each one log map per member, rejected steps included).
    pub iterations: usize,
    /// Final `|mean log| / mean |log|` (Euclidean norms of #V x 3 fields).
    pub residual: f64,
    /// Whether the residual fell below the tolerance.
    pub converged: bool,
    /// `sum_k dis(mean, P_k)^2` at the returned mean (normalized length units squared).
    pub variance: f64,
}

/// The discrete log map `log_mu(P) = N (P_1 - mu)` (#V x 3), with `P_1` the first interior pose of
/// the discrete geodesic from `mu` to `p` with `N` segments; also returns `dis(mu, p)`.
/// With `N = 1` the log is `p - mu`.
pub fn log_map(
    solver: &GeodesicSolver,
    mu: &[[f64; 3]],
    p: &[[f64; 3]],
) -> Result<(Pose, f64), GeodesicError> {
    let (log, d, _) = log_map_in(solver, &mut SolveContext::default(), mu, p, None)?;
    Ok((log, d))
}

/// [`log_map`] through a solve context (the poses of one Karcher iteration share the
/// preconditioner fit; [`SolveContext`]), started from `near` (the geodesic to the same pose
/// from the previous iteration's mean; [`GeodesicSolver::solve_near`]). Also returns the
/// geodesic (`None` when `mu == p`).
fn log_map_in<'s>(
    solver: &'s GeodesicSolver,
    ctx: &mut SolveContext<'s>,
    mu: &[[f64; 3]],
    p: &[[f64; 3]],
    near: Option<&Geodesic>,
) -> Result<(Pose, f64, Option<Geodesic>), GeodesicError> {
    if mu == p {
        return Ok((vec![[0.0; 3]; mu.len()], 0.0, None));
    }
    let g = solver.solve_near(ctx, mu, p, near)?;
    let n = (g.poses.len() - 1) as f64;
    let p1 = &g.poses[1];
    let log = p1
        .iter()
        .zip(mu)
        .map(|(a, b)| [0, 1, 2].map(|c| n * (a[c] - b[c])))
        .collect();
    let d = g.length;
    Ok((log, d, Some(g)))
}

fn field_norm(x: &[[f64; 3]]) -> f64 {
    x.iter().flatten().map(|v| v * v).sum::<f64>().sqrt()
}

/// One evaluation of the Karcher functional at a mean: the mean log, `sum dis^2` and the
/// relative residual `|mean log| / mean |log|`.
struct Evaluation {
    mu: Pose,
    mean_log: Pose,
    variance: f64,
    residual: f64,
}

impl Evaluation {
    fn into_mean(self, iterations: usize, converged: bool) -> KarcherMean {
        KarcherMean {
            mean: self.mu,
            iterations,
            residual: self.residual,
            converged,
            variance: self.variance,
        }
    }
}

/// The logs of every member at `mu` (through one solve context, each started from the member's
/// previous geodesic in `previous`, which is updated) and what [`karcher_mean`] reads from them.
fn evaluate(
    solver: &GeodesicSolver,
    poses: &[&[[f64; 3]]],
    mu: Pose,
    previous: &mut [Option<Geodesic>],
) -> Result<Evaluation, GeodesicError> {
    let k = poses.len() as f64;
    let mut mean_log = vec![[0.0; 3]; mu.len()];
    let (mut norm_sum, mut variance) = (0.0, 0.0);
    let mut ctx = SolveContext::default();
    for (p, near) in poses.iter().zip(previous.iter_mut()) {
        let (log, d, g) = log_map_in(solver, &mut ctx, &mu, p, near.as_ref())?;
        *near = g;
        norm_sum += field_norm(&log);
        variance += d * d;
        for (m, l) in mean_log.iter_mut().zip(&log) {
            for c in 0..3 {
                m[c] += l[c] / k;
            }
        }
    }
    // Members that all lie within round-off of the mean (the common base that every
    // deformation's first pose becomes after transfer, whose arithmetic mean differs from
    // it in the last bits) have logs of round-off size that all point the same way: their
    // relative residual is 1 however close the mean is, so it is measured as 0.
    let residual = if norm_sum / k > ROUNDOFF_SPREAD * field_norm(&mu) {
        field_norm(&mean_log) / (norm_sum / k)
    } else {
        0.0
    };
    Ok(Evaluation {
        mu,
        mean_log,
        variance,
        residual,
    })
}

/// `mu + step * mean_log`.
fn stepped(e: &Evaluation, step: f64) -> Pose {
    e.mu.iter()
        .zip(&e.mean_log)
        .map(|(m, l)| [0, 1, 2].map(|c| m[c] + step * l[c]))
        .collect()
}

/// The Karcher mean of `poses` (each #V x 3, already scaled by the common normalization factor)
/// started from `init`: repeats `mu <- mu + step * mean_k log_mu(P_k)` until the mean log is
/// small relative to the logs (docs/method.md "Clustering"). A step that does not lower the variance (by more
/// than [`VARIANCE_ROUNDOFF`]) is taken back and
/// retried with half the step (the undamped update overshoots and cycles for the conformal
/// metrics); once the step falls below [`MIN_STEP_FRACTION`] of the first, or at the iteration
/// limit, the best mean found is returned, not converged. A single pose is its own mean.
pub fn karcher_mean(
    solver: &GeodesicSolver,
    poses: &[&[[f64; 3]]],
    init: &[[f64; 3]],
    opts: &KarcherOptions,
) -> Result<KarcherMean, GeodesicError> {
    if poses.is_empty() {
        return Ok(KarcherMean {
            mean: init.to_vec(),
            iterations: 0,
            residual: 0.0,
            converged: true,
            variance: 0.0,
        });
    }
    // Each member's geodesic from the previous mean starts the next iteration's.
    let mut previous: Vec<Option<Geodesic>> = vec![None; poses.len()];
    let mut best = evaluate(solver, poses, init.to_vec(), &mut previous)?;
    let mut step = opts.step;
    let mut iterations = 0;
    loop {
        if best.residual <= opts.tolerance {
            return Ok(best.into_mean(iterations, true));
        }
        if iterations >= opts.max_iterations || step < MIN_STEP_FRACTION * opts.step {
            return Ok(best.into_mean(iterations, false));
        }
        let trial = evaluate(solver, poses, stepped(&best, step), &mut previous)?;
        iterations += 1;
        if trial.residual <= opts.tolerance || trial.variance < best.variance * (1.0 - VARIANCE_ROUNDOFF) {
            best = trial;
        } else {
            step *= 0.5;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::GeodesicOptions;
    use crate::metric::{FrozenL2, Isometric, Regularized};
    use crate::synth::icosphere;

    fn scaled(p: &[[f64; 3]], s: [f64; 3]) -> Pose {
        p.iter()
            .map(|v| [v[0] * s[0], v[1] * s[1], v[2] * s[2]])
            .collect()
    }

    /// The icosphere(1) scaled by 2 and two translates of it (flat-metric tests).
    fn three_poses() -> (crate::mesh::Shape, [Pose; 3]) {
        let s = icosphere(1);
        let a = scaled(&s.positions, [2.0, 2.0, 2.0]);
        let b: Pose = a.iter().map(|v| [v[0] + 1.0, v[1], v[2]]).collect();
        let c: Pose = a.iter().map(|v| [v[0], v[1] - 0.5, v[2] + 0.25]).collect();
        (s, [a, b, c])
    }

    /// The vertex-wise average of `poses`.
    fn arithmetic_mean(poses: &[&Pose]) -> Pose {
        let n = poses.len() as f64;
        (0..poses[0].len())
            .map(|i| [0, 1, 2].map(|k| poses.iter().map(|p| p[i][k]).sum::<f64>() / n))
            .collect()
    }

    /// Every coordinate of `got` within `tol` of `want`'s.
    fn assert_near(got: &Pose, want: &Pose, tol: f64) {
        for (g, w) in got.iter().zip(want) {
            for k in 0..3 {
                assert!((g[k] - w[k]).abs() < tol, "{} vs {}", g[k], w[k]);
            }
        }
    }

    #[test]
    fn flat_metric_mean_is_the_arithmetic_mean() {
        // L2 with frozen areas between poses of equal area weights is flat: geodesics are
        // straight lines, logs are differences and the Karcher mean is the average.
        let (s, [a, b, c]) = three_poses();
        let mean = arithmetic_mean(&[&a, &b, &c]);
        let opts = GeodesicOptions {
            steps: 4,
            ..Default::default()
        };
        let solver = GeodesicSolver::new(&FrozenL2, s.topology.clone(), opts).unwrap();
        let m = karcher_mean(&solver, &[&a, &b, &c], &a, &KarcherOptions::default()).unwrap();
        assert!(m.converged, "{m:?}");
        assert_near(&m.mean, &mean, 1e-6);
    }

    /// A step that overshoots (2.5 times the flat metric's exact step: undamped, the error
    /// would grow 1.5x per iteration) raises the variance, is taken back and halved, and the
    /// iteration converges to the arithmetic mean; a step that never lowers the variance
    /// (the start is already the mean, to round-off, with a tolerance of 0) stops after the
    /// halvings at the start, not at the iteration limit.
    #[test]
    fn overshooting_steps_are_halved() {
        let (s, [a, b, c]) = three_poses();
        let mean = arithmetic_mean(&[&a, &b, &c]);
        let opts = GeodesicOptions {
            steps: 1,
            ..Default::default()
        };
        let solver = GeodesicSolver::new(&FrozenL2, s.topology.clone(), opts).unwrap();
        let kopts = KarcherOptions {
            step: 2.5,
            ..Default::default()
        };
        let m = karcher_mean(&solver, &[&a, &b, &c], &a, &kopts).unwrap();
        assert!(m.converged, "{m:?}");
        assert_near(&m.mean, &mean, 1e-2);
        let exact = KarcherOptions {
            tolerance: 0.0,
            max_iterations: 100,
            ..Default::default()
        };
        let m = karcher_mean(&solver, &[&a, &b, &c], &mean, &exact).unwrap();
        assert!(!m.converged && m.iterations < 100, "{m:?}");
    }

    /// Identical members seen from a start that differs from them by round-off (their
    /// arithmetic mean, computed in floating point): converged at once, not after the iteration
    /// limit (the relative residual of round-off logs that all point the same way is 1).
    #[test]
    fn members_within_roundoff_of_the_start_converge_at_once() {
        let s = icosphere(1);
        let f = 1.0 / crate::mesh::geometry::mean_edge_length(&s.topology, &s.positions);
        let a = scaled(&s.positions, [1.3 * f, f, 0.9 * f]);
        let start: Pose = a
            .iter()
            .map(|v| v.map(|c| c * (1.0 + 4.0 * f64::EPSILON)))
            .collect();
        assert_ne!(start, a);
        let metric = Regularized::new(Box::new(Isometric), 0.1);
        let opts = GeodesicOptions {
            steps: 4,
            ..Default::default()
        };
        let solver = GeodesicSolver::new(&metric, s.topology.clone(), opts).unwrap();
        let m = karcher_mean(&solver, &[&a, &a, &a, &a, &a], &start, &KarcherOptions::default()).unwrap();
        assert!(m.converged && m.iterations == 0, "{m:?}");
        assert_eq!(m.residual, 0.0);
    }

    #[test]
    fn mean_of_two_poses_is_the_geodesic_midpoint_and_lowers_the_variance() {
        let s = icosphere(1);
        let f = 1.0 / crate::mesh::geometry::mean_edge_length(&s.topology, &s.positions);
        let a = scaled(&s.positions, [f, f, f]);
        let b = scaled(&s.positions, [1.4 * f, f, 0.7 * f]);
        let metric = Regularized::new(Box::new(Isometric), 0.1);
        let opts = GeodesicOptions {
            steps: 4,
            gradient_tolerance: 1e-9,
            ..Default::default()
        };
        let solver = GeodesicSolver::new(&metric, s.topology.clone(), opts).unwrap();
        let kopts = KarcherOptions {
            tolerance: 1e-4,
            max_iterations: 50,
            ..Default::default()
        };
        let m = karcher_mean(&solver, &[&a, &b], &a, &kopts).unwrap();
        assert!(m.converged, "{m:?}");
        let g = solver.solve(&a, &b).unwrap();
        // The mean is equidistant from both ends and about half the distance from each.
        let da = solver.solve(&m.mean, &a).unwrap().length;
        let db = solver.solve(&m.mean, &b).unwrap().length;
        assert!(
            (da - db).abs() < 0.02 * g.length,
            "{da} vs {db} (dis(a,b) = {})",
            g.length
        );
        assert!((da + db - g.length).abs() < 0.02 * g.length);
        // It beats the starting guess a in the Karcher functional.
        assert!(m.variance < g.length * g.length);
    }
}
