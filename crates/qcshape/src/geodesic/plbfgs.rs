//! L-BFGS preconditioned by the path's Kronecker structure (the default solver).
//!
//! The initial inverse Hessian is `gamma (2 T_c (x) A)^{-1}`, the Kronecker model of the
//! energy's Gauss-Newton Hessian `2 J^T J` ([`super::kronecker`]: one sparse Cholesky of size
//! 3 #V, `N - 1` triangular solve pairs per application), refitted at the current path every
//! [`GeodesicOptions::preconditioner_refresh`] iterations, and scaled by
//! `gamma = s.y / y.H0 y` of the newest correction pair (the model's scale can be off by a
//! large factor where second-order terms dominate). L-BFGS with this initial inverse Hessian
//! learns the rest (the pose-to-pose variation of
//! the metric and the large-residual curvature terms that Gauss-Newton leaves out). Auxiliary
//! unknowns (rigid motions) are eliminated: they are set to their optimum at every evaluation,
//! and by the envelope theorem the pose part of the gradient is then the exact gradient.
//! The history is kept in compact form ([`super::compact`]).
//!
//! The Kronecker part is completed by a vertex-block term ([`super::vertex_blocks`]):
//! `H0 = gamma ((2 T_c (x) A)^{-1} + omega (2 D)^{-1})`, `D` the 3 x 3 diagonal blocks of
//! `J^T J` per interior pose and vertex, refitted with the model
//! ([`GeodesicOptions::vertex_block_weight`]).
//!
//! With [`super::Gauge::Linear`] (the default) the start is moved onto the rigid gauge's
//! affine subspace and every gradient and preconditioned vector is projected onto it
//! ([`super::gauge`]): the iteration is L-BFGS on that subspace, with the preconditioner
//! `Pi H0 Pi` (`Pi` the orthogonal projector), positive definite there.
//!
//! [`super::Solver::PoseKronecker`] runs the same iteration with the pose-wise model
//! ([`super::pose_kronecker`]) in place of `T_c (x) A`: each interior pose's own spatial block.

use super::compact::{CompactHistory, Pair};
use super::energy::{Ends, PathEnergy, SegmentWork};
use super::kronecker::{ApplyScratch, KroneckerModel, PoseSum, SpatialLayout};
use super::pose_kronecker::{PoseBlocks, PoseKronecker, PoseScratch};
use super::vertex_blocks::VertexBlocks;
use super::{dot, norm, GeodesicError, GeodesicOptions, LastEvaluation, SolveOutput, StopReason};

/// Which model of the Hessian the preconditioned L-BFGS fits at its refits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Model {
    /// `T_c (x) A` fitted to `J^T J` ([`super::Solver::Preconditioned`]).
    Kronecker,
    /// `T_c (x) A` fitted to the exact Hessian where positive definite
    /// ([`super::Solver::HessianKronecker`]).
    Hessian,
    /// Each pose's own block of `J^T J` ([`super::Solver::PoseKronecker`]).
    PoseWise,
}

/// Refit interval of [`Model::Hessian`] (iterations; capped by
/// [`GeodesicOptions::preconditioner_refresh`]): the Hessian's model is worth refitting more often
/// than `J^T J`'s, since it changes as the path approaches the geodesic (twisted sphere, isometric,
/// 2,562 vertices: 58 iterations refitting every 45, 39 every 15; docs/log/speed.md).
pub(crate) const HESSIAN_REFRESH: usize = 15;

/// The fitted model of the Hessian's pose part.
enum Fitted {
    /// `T_c (x) A` ([`Model::Kronecker`], [`Model::Hessian`]).
    Kronecker(KroneckerModel),
    /// Each pose's own block ([`Model::PoseWise`]).
    PoseWise(PoseKronecker),
}

/// The factorized preconditioner `(2 T_c (x) A)^{-1} + omega (2 D)^{-1}` (the energy's
/// Gauss-Newton Hessian is `2 J^T J ~ 2 T_c (x) A`; the pose-wise model in place of
/// `T_c (x) A` for [`Model::PoseWise`]), fitted at one path.
pub(crate) struct Preconditioner<'l> {
    layout: &'l SpatialLayout,
    model: Fitted,
    /// The vertex-block term `omega (2 D)^{-1}` added to the model's part (none when
    /// `omega = 0`).
    local: Option<VertexBlocks>,
    /// Work space of the applications, reused (no allocation per iteration once warm).
    scratch: ApplyScratch,
    pose_scratch: PoseScratch,
    copy: Vec<f64>,
    /// [`Model::Hessian`] fitted to a metric without a second-order part (the rigid metric):
    /// the refits fit `J^T J` like [`Model::Kronecker`], at its interval.
    no_second_order: bool,
}

impl<'l> Preconditioner<'l> {
    /// Fits `layout`'s [`Model`] at `x` ([`KroneckerModel::fit`], [`KroneckerModel::fit_hessian`]
    /// or [`PoseKronecker::fit`]) and, for `vertex_block_weight > 0`, the vertex-block term from
    /// the same assembly.
    pub(super) fn new(
        (layout, model): (&'l SpatialLayout, Model),
        pe: &PathEnergy,
        x: &[f64],
        ends: &Ends,
        vertex_block_weight: f64,
    ) -> Result<Self, GeodesicError> {
        let mut no_second_order = false;
        let (fitted, diagonal) = match model {
            Model::PoseWise => {
                let pb = PoseBlocks::assemble(layout, pe, x, ends);
                (Fitted::PoseWise(PoseKronecker::fit(layout, &pb)?), pb.diagonal)
            }
            Model::Hessian => {
                let (kron, diagonal, second_order) = KroneckerModel::fit_hessian(layout, pe, x, ends)?;
                no_second_order = !second_order;
                (Fitted::Kronecker(kron), diagonal)
            }
            Model::Kronecker => {
                let mut ps = PoseSum::assemble(layout, pe, x, ends);
                let diagonal = std::mem::take(&mut ps.diagonal);
                (Fitted::Kronecker(KroneckerModel::fit(layout, ps)?), diagonal)
            }
        };
        Ok(Preconditioner {
            layout,
            model: fitted,
            local: (vertex_block_weight > 0.0).then(|| VertexBlocks::new(&diagonal, vertex_block_weight)),
            scratch: ApplyScratch::default(),
            pose_scratch: PoseScratch::default(),
            copy: Vec::new(),
            no_second_order,
        })
    }

    /// `q <- ((2 T_c (x) A)^{-1} + omega (2 D)^{-1}) q` on the pose part (length 3 #V (N - 1),
    /// or several such vectors one after the other).
    pub(super) fn apply(&mut self, q: &mut [f64]) {
        if self.local.is_some() {
            self.copy.clear();
            self.copy.extend_from_slice(q);
        }
        match &self.model {
            Fitted::Kronecker(model) => model.apply_with(self.layout, q, 0.5, &mut self.scratch),
            Fitted::PoseWise(model) => model.apply_with(self.layout, q, 0.5, &mut self.pose_scratch),
        }
        if let Some(local) = &self.local {
            local.add_apply(&self.copy, q);
        }
    }

    /// Moves the work space of `old` (a preconditioner this one replaces) into this one.
    fn take_scratch(&mut self, old: Preconditioner) {
        self.scratch = old.scratch;
        self.pose_scratch = old.pose_scratch;
        self.copy = old.copy;
    }
}

/// Energy and pose gradient (into `out`) with the auxiliary unknowns at their optimum
/// (variable projection).
/// Each segment's energy goes to `segments` (length `N`).
/// The full unknown vector and the gradient and segment work space are kept in `ev` and reused.
fn eval(
    pe: &PathEnergy,
    ends: &Ends,
    xp: &[f64],
    ev: &mut Evaluation,
    out: &mut [f64],
    segments: &mut [f64],
) -> f64 {
    let np = pe.n_pose_vars();
    ev.full[..np].copy_from_slice(xp);
    pe.reset_aux(&mut ev.full, ends);
    let e = pe.energy_gradient_with(&ev.full, ends, &mut ev.grad, Some(segments), &mut ev.work);
    out.copy_from_slice(&ev.grad[..np]);
    e
}

/// Work space of [`eval`]: the full unknown vector (poses and auxiliary unknowns), its
/// gradient, and the per-segment accumulators.
struct Evaluation {
    full: Vec<f64>,
    grad: Vec<f64>,
    work: SegmentWork,
}

/// The path's length `L = sum_i sqrt(E_i / 2)` from its segments' energies
/// `E_i = G_{P_i}(X_i) + G_{P_{i+1}}(X_i)` (eq. 12's discretization; the same sum as
/// [`super::Geodesic::length`]).
fn path_length(segments: &[f64]) -> f64 {
    segments.iter().map(|&e| super::segment_length(e)).sum()
}

/// Minimizes the path energy from `x0` (see the module docs); `layout`'s [`Model`] chooses what
/// the preconditioner is fitted to.
///
/// `length_tolerance > 0` adds a stop once two consecutive accepted steps each change the
/// path's length by at most that fraction of it ([`StopReason::LengthTolerance`]; distance
/// solves, [`super::GeodesicOptions::length_tolerance`]); 0 disables it.
///
/// With `shared`, the preconditioner in it (if any) is used instead of fitting one at `x0`,
/// and the one in use at the end (the last refit) is left in it for the next solve: the
/// geodesics of one pair of deformations (consecutive poses) share one fit.
pub(crate) fn minimize<'l>(
    pe: &PathEnergy,
    layout: (&'l SpatialLayout, Model),
    ends: &Ends,
    x0: Vec<f64>,
    opts: &GeodesicOptions,
    length_tolerance: f64,
    mut shared: Option<&mut Option<Preconditioner<'l>>>,
) -> Result<SolveOutput, GeodesicError> {
    let np = pe.n_pose_vars();
    let mut ev = Evaluation {
        full: x0.clone(),
        grad: vec![0.0; pe.n_vars()],
        work: SegmentWork::default(),
    };
    let mut x = x0[..np].to_vec();
    let mut g = vec![0.0; np];
    let (mut seg, mut seg_new) = (vec![0.0; pe.steps()], vec![0.0; pe.steps()]);
    // The rigid gauge (docs/method.md "Rigid gauge"): the start moved onto its subspace, and
    // every gradient and preconditioned direction projected onto it, so that the iterates, the
    // steps and the secant pairs stay there.
    let gauge = (opts.gauge == super::Gauge::Linear && np > 0)
        .then(|| super::gauge::RigidGauge::new(ends, pe.steps()));
    let project = |v: &mut [f64]| {
        if let Some(gauge) = &gauge {
            gauge.project(v);
        }
    };
    if let Some(gauge) = &gauge {
        gauge.constrain(&mut x);
    }
    let mut e = eval(pe, ends, &x, &mut ev, &mut g, &mut seg);
    project(&mut g);
    if !e.is_finite() {
        return Err(GeodesicError::NonFinite {
            what: "initial energy",
            value: e,
        });
    }
    let initial_energy = e;
    let g0 = norm(&g);
    let mut pre = match shared.as_deref_mut().and_then(Option::take) {
        Some(p) => p,
        None => Preconditioner::new(layout, pe, &ev.full, ends, opts.vertex_block_weight)?,
    };
    // A metric without second derivatives gets the Gauss-Newton model at its own interval.
    let layout = match layout {
        (l, Model::Hessian) if pre.no_second_order => (l, Model::Kronecker),
        other => other,
    };
    let refresh = match layout {
        (_, Model::Hessian) if opts.preconditioner_refresh > 0 => {
            opts.preconditioner_refresh.min(HESSIAN_REFRESH)
        }
        _ => opts.preconditioner_refresh,
    };
    // The first step is the model's Gauss-Newton step.
    let mut gamma = 1.0f64;
    // M^{-1} g for the current gradient; the history in compact form keeps M^{-1} y per pair,
    // so one preconditioner application per iteration suffices.
    let precondition = |pre: &mut Preconditioner, v: &[f64], z: &mut Vec<f64>| {
        z.clear();
        z.extend_from_slice(v);
        pre.apply(z);
        project(z);
    };
    let mut mg = Vec::with_capacity(np);
    precondition(&mut pre, &g, &mut mg);
    // Work vectors reused across iterations (no allocation in the loop but for new pairs).
    let mut d = vec![0.0; np];
    let (mut xn, mut gn, mut mg_new) = (vec![0.0; np], vec![0.0; np], Vec::with_capacity(np));
    let mut spare: Option<Pair> = None;
    let mut hist = CompactHistory::new(opts.lbfgs_memory);
    hist.reset_gradient(&g);
    let mut iterations = 0;
    let max_iterations = opts.iteration_limit(pe.n_vertices());
    let mut stop = StopReason::MaxIterations;
    // The length test: the path's length after the last accepted step, and how many
    // consecutive steps changed it by at most `length_tolerance` of it.
    let mut length = path_length(&seg);
    let mut settled = 0;
    if np == 0 || super::at_roundoff(g0, e) {
        if let Some(slot) = shared {
            *slot = Some(pre);
        }
        return Ok(SolveOutput {
            x: ev.full,
            iterations,
            stop: StopReason::GradientTolerance,
            last: Some(LastEvaluation {
                energy: e,
                initial_energy,
                gradient_norm: g0,
                segments: seg,
            }),
        });
    }
    while iterations < max_iterations {
        if let Some(reason) = opts.stop_before_iteration(e, norm(&g), g0) {
            stop = reason;
            break;
        }
        iterations += 1;
        opts.monitor(iterations, e)?;
        // Refit `T_c (x) A` at the current path (the history stays: its pairs are still
        // valid secant information; their `M^{-1} y` are recomputed).
        if refresh > 0 && iterations % refresh == 0 {
            ev.full[..np].copy_from_slice(&x);
            pe.reset_aux(&mut ev.full, ends);
            let fresh = Preconditioner::new(layout, pe, &ev.full, ends, opts.vertex_block_weight)?;
            let old = std::mem::replace(&mut pre, fresh);
            pre.take_scratch(old);
            precondition(&mut pre, &g, &mut mg);
            hist.reset_preconditioner(&g, |z| {
                pre.apply(z);
                project(z);
            });
        }
        hist.direction(&mg, gamma, &mut d);
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Not a descent direction (can happen with a stale history): restart.
            hist.clear();
            for (di, mi) in d.iter_mut().zip(&mg) {
                *di = -gamma * mi;
            }
            slope = dot(&g, &d);
        }
        // Backtracking line search (Armijo), full step first.
        let mut t = 1.0;
        let accepted = loop {
            for ((xi, a), b) in xn.iter_mut().zip(&x).zip(&d) {
                *xi = a + t * b;
            }
            let en = eval(pe, ends, &xn, &mut ev, &mut gn, &mut seg_new);
            project(&mut gn);
            if en.is_finite() && en <= e + 1e-4 * t * slope {
                break Some(en);
            }
            t *= 0.5;
            if t < 1e-12 {
                break None;
            }
        };
        let Some(en) = accepted else {
            stop = StopReason::NoProgress;
            break;
        };
        precondition(&mut pre, &gn, &mut mg_new);
        let mut pair = spare.take().unwrap_or_else(|| Pair {
            s: vec![0.0; np],
            y: vec![0.0; np],
            my: vec![0.0; np],
        });
        let (mut sy, mut ymy, mut ss, mut yy) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..np {
            let (s, y, my) = (xn[k] - x[k], gn[k] - g[k], mg_new[k] - mg[k]);
            pair.s[k] = s;
            pair.y[k] = y;
            pair.my[k] = my;
            sy += s * y;
            ymy += y * my;
            ss += s * s;
            yy += y * y;
        }
        let new_pair = if sy > 1e-12 * (yy * ss).sqrt() {
            // Scale H0 to the newest pair's curvature along y: gamma = s.y / y.M^{-1} y (the
            // preconditioned form of Nocedal & Wright's eq. 7.20).
            if ymy > 0.0 {
                gamma = sy / ymy;
            }
            Some((pair, sy, ymy))
        } else {
            spare = Some(pair);
            None
        };
        // The evicted oldest pair's storage becomes the next work vectors.
        if let Some(old) = hist.advance(&gn, new_pair) {
            spare = Some(old);
        }
        let decrease = e - en;
        std::mem::swap(&mut x, &mut xn);
        std::mem::swap(&mut g, &mut gn);
        std::mem::swap(&mut mg, &mut mg_new);
        std::mem::swap(&mut seg, &mut seg_new);
        e = en;
        if decrease <= opts.energy_tolerance * e.abs() {
            stop = StopReason::EnergyTolerance;
            break;
        }
        if length_tolerance > 0.0 {
            let new_length = path_length(&seg);
            if (new_length - length).abs() <= length_tolerance * new_length {
                settled += 1;
            } else {
                settled = 0;
            }
            length = new_length;
            if settled >= 2 {
                stop = StopReason::LengthTolerance;
                break;
            }
        }
    }
    let gnorm = norm(&g);
    let stop = opts.final_stop(stop, gnorm, g0);
    ev.full[..np].copy_from_slice(&x);
    pe.reset_aux(&mut ev.full, ends);
    if let Some(slot) = shared {
        *slot = Some(pre);
    }
    Ok(SolveOutput {
        x: ev.full,
        iterations,
        stop,
        last: Some(LastEvaluation {
            energy: e,
            initial_energy,
            gradient_norm: gnorm,
            segments: seg,
        }),
    })
}
