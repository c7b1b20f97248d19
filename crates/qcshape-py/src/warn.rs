//! Warnings through Python's `warnings` module, category `qcshape.QcshapeWarning` (a
//! `UserWarning`), for the conditions the CLI prints `warning:` for: the metric's own warning
//! (lambda = 0 with a conformal metric), an L2 regularizer carrying more than half of a
//! geodesic's energy (of most pairs, for a matrix), the bending term carrying more than half of a
//! geodesic's energy on folding faces, a vertex of a geodesic far off its surface, a solver stopped
//! at its iteration limit and, for a matrix, pairs whose geodesic did not converge.

use std::ffi::CString;

use pyo3::prelude::*;
use qcshape::geodesic::{Geodesic, Interpolated, OffPath, Solver, StopReason};
use qcshape::metric::{Folds, MetricKind, MetricSpec};
use qcshape::similarity::shares::ShareSummary;
use qcshape::similarity::PairDistance;
use qcshape::space::{ShapeSpace, SpaceError};

pyo3::create_exception!(
    qcshape,
    QcshapeWarning,
    pyo3::exceptions::PyUserWarning,
    "The warnings of qcshape (regularizer share, solver limits, metric settings): filter them with \
     warnings.simplefilter(..., qcshape.QcshapeWarning)."
);

/// Issues `msg` as a `QcshapeWarning` (stack level 1: the caller's line).
pub fn warn(py: Python<'_>, msg: &str) -> PyResult<()> {
    let category = py.get_type::<QcshapeWarning>();
    let msg = CString::new(msg.replace('\0', " ")).unwrap_or_default();
    PyErr::warn(py, category.as_any(), &msg, 1)
}

/// What to do about a regularizer share above one half, for the metric at hand. For the
/// isometric, rigid and L2 metrics a smaller lambda lowers it; for the conformal metrics on the
/// invariant scale it does not (issue 50, synth --level 2 sphere-twist: lambda 0.1 / 0.01 /
/// 0.001 gave a share of 73 / 84 / 91 %), so the advice there is not to lower it.
fn advice(kind: MetricKind) -> &'static str {
    // The registry's metrics that need the regularizer (the conformal ones).
    if kind.info().needs_regularizer {
        "for this metric a lower lam raises the share instead of lowering it: the conformal \
         metrics leave the deformation's scaling and their null space to the regularizer"
    } else {
        "a lower lam lowers the share"
    }
}

/// The metric's own warning (lambda = 0 with a conformal metric) in Python's words: the
/// keywords `lam` and `stretch`, not the CLI's flags.
pub fn spec(py: Python<'_>, spec: &MetricSpec) -> PyResult<()> {
    match spec.warning() {
        Some(w) => warn(
            py,
            &w.replace("lambda = 0", "lam=0")
                .replace("unless --stretch charges them", "unless stretch= charges them"),
        ),
        None => Ok(()),
    }
}

/// The warnings of one geodesic of `space` (as `qcshape geodesic`): regularizer share above 0.5,
/// the bending term's share above 0.5 with folding hinges between the ends ([`Folds`]), a
/// vertex far off its straight path ([`OffPath`]), iteration limit.
pub fn geodesic(py: Python<'_>, g: &Geodesic, space: &ShapeSpace) -> PyResult<()> {
    let (spec, solver) = (space.spec(), space.geodesic_options().solver);
    let share = g.regularizer_share();
    if share > 0.5 {
        warn(
            py,
            &format!(
                "the L2 regularizer carries {:.0} % of the energy: this {} distance measures L2 \
                 displacement more than its own geometry; {}",
                100.0 * share,
                spec.kind.label(),
                advice(spec.kind)
            ),
        )?;
    }
    if let (true, Some(a), Some(b)) = (spec.bends(), g.poses.first(), g.poses.last()) {
        if let Some(w) = Folds::between(space.topology(), a, b).warning(g.bending_share(), "bending=0") {
            warn(py, &w)?;
        }
    }
    if let Some(o) = OffPath::find(space.topology(), &g.poses) {
        warn(py, &o.warning(spec.bends()))?;
    }
    if g.stop == StopReason::MaxIterations {
        let hint = format!(" ({})", solver.stall_hint(spec.bends()));
        warn(
            py,
            &format!(
                "the solver stopped at its iteration limit after {} iterations{hint}",
                g.iterations
            ),
        )?;
    } else if !g.stop.is_converged() {
        // No progress (the line search or the damping found no lower energy) or another
        // reason: unconverged, and said so.
        warn(
            py,
            &format!(
                "the solver stopped without converging after {} iterations: {}",
                g.iterations,
                match &g.stop {
                    StopReason::NoProgress => "no step lowered the energy further".to_string(),
                    other => format!("{other:?}"),
                }
            ),
        )?;
    }
    Ok(())
}

/// The warning of an interpolated sequence of `space` (as `qcshape interpolate`): a vertex of
/// an inserted pose far off its straight path between two key poses ([`OffPath::in_sequence`]).
pub fn sequence(py: Python<'_>, r: &Interpolated, space: &ShapeSpace) -> PyResult<()> {
    match OffPath::in_sequence(space.topology(), &r.poses, &r.is_key) {
        Some((from, to, o)) => warn(
            py,
            &format!("poses {from} to {to}: {}", o.warning(space.spec().bends())),
        ),
        None => Ok(()),
    }
}

/// The warnings of a similarity matrix (as `qcshape similarity`): the regularizer carries more
/// than half of the energy for more than half of the pairs; pairs that did not converge.
pub fn pairs(
    py: Python<'_>,
    pairs: &[PairDistance],
    converged: bool,
    spec: &MetricSpec,
    solver: Solver,
) -> PyResult<()> {
    let s = ShareSummary::of(pairs);
    if s.dominated() {
        warn(
            py,
            &format!(
                "the L2 regularizer carries more than half of the energy for {} of {} pairs: the {} \
                 distances measure L2 displacement more than the metric's geometry; {}",
                s.above_half,
                s.pairs,
                spec.kind.label(),
                advice(spec.kind)
            ),
        )?;
    }
    let unconverged = pairs.iter().filter(|p| !p.converged).count();
    if unconverged > 0 || !converged {
        let hint = format!(" ({})", solver.stall_hint(spec.bends()));
        let what = if unconverged > 0 {
            format!("{unconverged} pair(s) with a geodesic that did not converge")
        } else {
            "a geodesic of the preparation (transfer) did not converge".to_string()
        };
        warn(py, &format!("{what}{hint}"))?;
    }
    Ok(())
}

/// [`ShapeSpace::dist`] with its solved path (None for identical shapes): the same checks and
/// calls, so the same number, plus the energy split and stop reason the warnings need.
pub fn dist_path(space: &ShapeSpace, a: &[[f64; 3]], b: &[[f64; 3]]) -> PyResult<Option<Geodesic>> {
    for (what, p) in [("the first shape", a), ("the second shape", b)] {
        qcshape::mesh::Shape::new_checked(
            space.topology().clone(),
            p.to_vec(),
            qcshape::io::DEGENERATE_REL_TOL,
        )
        .map_err(|error| {
            crate::errors::space(SpaceError::Shape {
                what: what.to_string(),
                error,
            })
        })?;
    }
    if a == b {
        return Ok(None);
    }
    let u = space.units(&[a, b]).map_err(crate::errors::space)?;
    let f = u.factor;
    let metric = space.metric(&u);
    let solver = space
        .solver(metric.as_ref(), space.geodesic_options().steps)
        .map_err(crate::errors::space)?;
    let scaled = |p: &[[f64; 3]]| -> Vec<[f64; 3]> { p.iter().map(|v| v.map(|c| c * f)).collect() };
    let g = solver
        .distance_near_with(
            &mut qcshape::geodesic::SolveContext::default(),
            &scaled(a),
            &scaled(b),
            None,
            None,
        )
        .map_err(|e| crate::errors::space(e.into()))?;
    Ok(Some(g))
}

/// The warning of `qcshape geodesic` for two shapes whose mean edge lengths differ by more than
/// [`qcshape::space::SIZE_RATIO_WARNING`] (different units, e.g. metres and millimetres), for the
/// arguments `a` and `b` of `geodesic` and `dist`.
pub fn sizes(py: Python<'_>, space: &ShapeSpace, a: &[[f64; 3]], b: &[[f64; 3]]) -> PyResult<()> {
    let Some((la, lb)) = qcshape::space::size_mismatch(space.topology(), a, b) else {
        return Ok(());
    };
    let num = |x: f64| qcshape::numfmt::significant(x, 3);
    warn(
        py,
        &format!(
            "a's mean edge length ({}) and b's ({}) differ by a factor of {} (more than {}), in the \
             arrays' own units: are they in the same units (e.g. metres and millimetres)? Both are \
             divided by the mean of the two (mean-edge units), so the smaller shape is nearly a \
             point; such a geodesic converges slowly and dist(a, b) and dist(b, a) can differ",
            num(la),
            num(lb),
            num(la.max(lb) / la.min(lb)),
            qcshape::space::SIZE_RATIO_WARNING
        ),
    )
}
