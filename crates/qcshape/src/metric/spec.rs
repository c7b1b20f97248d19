//! Building a metric from names (CLI, data files).

use thiserror::Error;

use super::bent::Bent;
use super::conformal::{Conformal, ConformalForm};
use super::isometric::Isometric;
use super::kind::{L2Areas, MetricKind, MetricScale, QcScaling, TermKind};
use super::l2::{FrozenL2, L2};
use super::quasi_conformal::{QcNormalize, QcWeights, QuasiConformal};
use super::regularized::Regularized;
use super::relative::{RelativeConformal, RelativeIsometric};
use super::rigid::Rigid;
use super::rigid_frozen::FrozenRigid;
use super::traits::Metric;
use super::weighted::Weighted;
use crate::mesh::geometry::{dot, sub, total_area};
use crate::mesh::Topology;

macro_rules! named_from_str {
    ($t:ty, $what:literal) => {
        impl std::str::FromStr for $t {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                crate::named::parse_named(s, $what)
            }
        }
    };
}
named_from_str!(ConformalForm, "form");
named_from_str!(QcWeights, "weights");
named_from_str!(QcScaling, "qc-weights");
named_from_str!(L2Areas, "l2-areas");

/// The constant factors of one analysis's metric ([`MetricSpec::calibrate`]): the metric is
/// `geometric * G + lambda * l2 * L2` (the L2 metric itself: `l2 * L2`). Computed once from
/// the reference pose(s) in the solver's coordinates, so one analysis uses one metric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// Factor of the geometric term (1 for [`MetricScale::Raw`]; units length^-4 for L2,
    /// rigid and isometric, length^-8 for conformal and quasi-conformal).
    pub geometric: f64,
    /// Factor of every L2 term, `1 / A^2` with `A` the reference's area (1 for
    /// [`MetricScale::Raw`]; units length^-4).
    pub l2: f64,
}

impl Calibration {
    /// Factors 1: the metric as written ([`MetricScale::Raw`]).
    pub const RAW: Calibration = Calibration {
        geometric: 1.0,
        l2: 1.0,
    };
}

/// A reference pose that cannot calibrate a metric.
#[derive(Debug, Error)]
pub enum CalibrationError {
    /// No reference pose, or one without #V vertices.
    #[error("the metric's reference pose has {got} vertices, the mesh {expected}")]
    Reference {
        /// Vertices of the topology.
        expected: usize,
        /// Vertices of the reference (0: no reference).
        got: usize,
    },
    /// The reference's area or edge sums are zero or not finite.
    #[error("the metric's reference pose is degenerate: its {what} is {value}")]
    Degenerate {
        /// Which quantity.
        what: &'static str,
        /// Its value.
        value: f64,
    },
}

/// A metric with its variants (docs/method.md "Metrics") and regularization `G + lambda * L2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricSpec {
    /// The metric.
    pub kind: MetricKind,
    /// Conformal triangle term (conformal and quasi-conformal).
    pub form: ConformalForm,
    /// Curvature-change weights (quasi-conformal).
    pub weights: QcWeights,
    /// Normalization of the quasi-conformal `endpoints` weights (`None`: the paper's raw
    /// angle-defect change).
    pub qc_normalize: Option<QcNormalize>,
    /// Weight of the L2 regularizer (ignored for the L2 metric itself); 0 disables it. Its
    /// meaning depends on [`MetricSpec::scale`].
    pub lambda: f64,
    /// How the terms are scaled (what `lambda` means).
    pub scale: MetricScale,
    /// L2 area weights frozen at the path's ends (true) or taken from each pose (false). On the
    /// [`MetricScale::Invariant`] scale the isometric and conformal metrics' regularizer is
    /// then the flat, calibrated [`FrozenL2`] (true: translations cost the same at every size,
    /// so a geodesic between translated copies is the straight translation) or the
    /// scale-invariant [`super::RelativeL2`], measured against each pose's own size (false).
    pub frozen_areas: bool,
    /// Weight of the stretch term of the conformal and quasi-conformal metrics on the
    /// [`MetricScale::Invariant`] scale (the relative rate of change of each face's area,
    /// [`RelativeConformal`]); 0: none. Ignored by the other metrics and scales.
    pub stretch: f64,
    /// Weight `beta` of the bending term ([`super::RelativeBending`], docs/method.md "Bending
    /// term") added to the isometric, conformal and quasi-conformal metrics on the
    /// [`MetricScale::Invariant`] scale ([`super::Bent`]); 0: none. Ignored by the other metrics
    /// and scales.
    pub bending: f64,
}

impl MetricSpec {
    /// Checks the values a user sets (the one validation of the metric settings, used by the
    /// command line, Python and every library entry point): `lambda` and the QC weights' floor
    /// finite, `>= 0` and at most [`crate::limits::MAX_LAMBDA`]; the QC smoothing at most
    /// [`crate::limits::MAX_SWEEPS`]. The error names the setting by its key in
    /// [`crate::settings::SETTINGS`].
    pub fn validate(&self) -> Result<(), crate::limits::LimitError> {
        use crate::limits::{count, non_negative, MAX_LAMBDA, MAX_SWEEPS};
        non_negative("lambda", self.lambda, MAX_LAMBDA)?;
        non_negative("stretch", self.stretch, MAX_LAMBDA)?;
        non_negative("bending", self.bending, MAX_LAMBDA)?;
        if self.relative() && self.kind.takes("form") {
            let unsupported = |what: &str, value: &str| crate::limits::LimitError::Unsupported {
                what: what.into(),
                value: value.into(),
                with: "the invariant scale (use the calibrated or raw scale)".into(),
            };
            if self.form != ConformalForm::Quadratic {
                return Err(unsupported("form", self.form.label()));
            }
            if self.kind.takes("weights") && self.weights != QcWeights::Endpoints {
                return Err(unsupported("weights", self.weights.label()));
            }
        }
        if let Some(q) = self.qc_normalize {
            non_negative("qc-floor", q.floor, MAX_LAMBDA)?;
            count("qc-smooth", q.smooth, 0, MAX_SWEEPS)?;
        }
        Ok(())
    }

    /// A warning for settings that are valid but leave the metric degenerate: `lambda = 0`
    /// with a metric whose null space holds more than rigid motions (conformal and
    /// quasi-conformal: conformal fields, and scalings unless the invariant scale's stretch
    /// term charges them), where geodesics are not unique (docs/method.md "Metrics", the
    /// regularization item).
    pub fn warning(&self) -> Option<String> {
        (self.lambda == 0.0 && self.kind.info().needs_regularizer).then(|| {
            format!(
                "lambda = 0 leaves the {} metric's null space free (rigid motions, conformal \
                 fields, and scalings unless --stretch charges them): geodesics are not unique \
                 (docs/method.md \"Metrics\")",
                self.kind.label()
            )
        })
    }

    /// Defaults: quadratic form, endpoint weights normalized as [`super::defaults::QC_NORMALIZE`],
    /// `lambda` = [`super::defaults::LAMBDA`] on the [`MetricScale::Invariant`] scale
    /// ([`super::defaults::SCALE`]), stretch [`super::defaults::STRETCH`], bending
    /// [`super::defaults::BENDING`], frozen areas.
    pub fn new(kind: MetricKind) -> Self {
        MetricSpec {
            kind,
            form: ConformalForm::Quadratic,
            weights: QcWeights::Endpoints,
            qc_normalize: super::defaults::QC_NORMALIZE,
            lambda: super::defaults::LAMBDA,
            scale: super::defaults::SCALE,
            frozen_areas: true,
            stretch: super::defaults::STRETCH,
            bending: super::defaults::BENDING,
        }
    }

    /// The configuration of every release before 2026-12-04 (and of the README's previous
    /// tables): raw terms in mean-edge units, raw quasi-conformal weights, `lambda`
    /// [`super::defaults::RAW_LAMBDA`] (0.1).
    pub fn previous(kind: MetricKind) -> Self {
        MetricSpec {
            qc_normalize: None,
            lambda: super::defaults::RAW_LAMBDA,
            scale: MetricScale::Raw,
            stretch: 0.0,
            bending: 0.0,
            ..MetricSpec::new(kind)
        }
    }

    /// The configuration of the releases of 2026-12-04 to 2026-12-06: the calibrated scale
    /// (eq. 7's conformal terms), `lambda` [`super::defaults::LAMBDA`], no stretch term.
    pub fn calibrated(kind: MetricKind) -> Self {
        MetricSpec {
            scale: MetricScale::Calibrated,
            stretch: 0.0,
            bending: 0.0,
            ..MetricSpec::new(kind)
        }
    }

    /// The one readable description of the metric, printed by the command line, the reports
    /// and Python's `ShapeSpace.metric`: its name and every setting that applies to it (its
    /// registry entry's [`super::MetricInfo::settings`], those that matter on its scale) by its
    /// option name ([`crate::settings::SETTINGS`]), numbers in one plain format
    /// ([`crate::numfmt::plain`]), e.g. `"quasi-conformal (stretch 0.1, bending 0.0001, qc-weights rms, qc-floor 0.5,
    /// qc-smooth 0, lambda 0.01, l2-areas frozen, scale invariant)"`. Not the built metric's
    /// [`Metric::name`], whose factors depend on the data (`1.6e-10*l2(frozen)`).
    pub fn label(&self) -> String {
        let mut parts: Vec<String> = Vec::new();
        let relative = self.relative();
        // The settings that apply to the metric (its registry entry), those that matter on this
        // scale.
        for &key in self.kind.info().settings {
            match key {
                "form" if !relative => parts.push(format!("form {}", self.form.label())),
                "stretch" if relative => {
                    parts.push(format!("stretch {}", crate::numfmt::plain(self.stretch)))
                }
                "bending" if relative => {
                    parts.push(format!("bending {}", crate::numfmt::plain(self.bending)))
                }
                "weights" if !relative => parts.push(format!("weights {}", self.weights.label())),
                "qc-weights" => parts.push(
                    match self.qc_normalize {
                        Some(_) => "qc-weights rms",
                        None => "qc-weights raw",
                    }
                    .into(),
                ),
                "qc-floor" => {
                    if let Some(q) = self.qc_normalize {
                        parts.push(format!("qc-floor {}", crate::numfmt::plain(q.floor)));
                    }
                }
                "qc-smooth" => {
                    if let Some(q) = self.qc_normalize {
                        parts.push(format!("qc-smooth {}", q.smooth));
                    }
                }
                "lambda" => parts.push(format!("lambda {}", crate::numfmt::plain(self.lambda))),
                "l2-areas" if self.lambda > 0.0 && self.kind.takes("lambda") => {
                    let areas = if self.frozen_areas { "frozen" } else { "pose" };
                    parts.push(format!("l2-areas {areas}"));
                }
                "scale" => parts.push(format!("scale {}", self.scale.label())),
                _ => {}
            }
        }
        format!("{} ({})", self.kind.label(), parts.join(", "))
    }

    /// The factors of this metric for an analysis whose reference pose(s) `refs` (each #V x 3,
    /// in the solver's coordinates, i.e. already multiplied by the normalization factor) are
    /// given: [`Calibration::RAW`] for [`MetricScale::Raw`]; for
    /// [`MetricScale::Calibrated`] the inverse of the geometric term's scale, averaged over
    /// the references (isometric: `1 / sum_e |e|^4`; conformal and quasi-conformal:
    /// `1 / sum over corners |e1|^4 |e2|^4`; L2 and rigid: `1 / A^2`) and `1 / A^2` for L2.
    pub fn calibrate(&self, topo: &Topology, refs: &[&[[f64; 3]]]) -> Result<Calibration, CalibrationError> {
        if self.scale == MetricScale::Raw || (self.relative() && !self.frozen_areas) {
            return Ok(Calibration::RAW);
        }
        let nv = topo.n_vertices();
        if refs.is_empty() || refs.iter().any(|r| r.len() != nv) {
            return Err(CalibrationError::Reference {
                expected: nv,
                got: refs.iter().map(|r| r.len()).find(|&n| n != nv).unwrap_or(0),
            });
        }
        let mean =
            |f: &dyn Fn(&[[f64; 3]]) -> f64| refs.iter().map(|r| f(r)).sum::<f64>() / refs.len() as f64;
        let area = mean(&|r| total_area(topo, r));
        let positive = |what, value: f64| {
            if value > 0.0 && value.is_finite() {
                Ok(value)
            } else {
                Err(CalibrationError::Degenerate { what, value })
            }
        };
        let area = positive("area", area)?;
        let l2 = 1.0 / (area * area);
        let geometric = match self.kind {
            _ if self.relative() => 1.0,
            MetricKind::L2 | MetricKind::Rigid => l2,
            MetricKind::Isometric => {
                1.0 / positive("sum of |e|^4 over the edges", mean(&|r| edge_scale(topo, r)))?
            }
            MetricKind::Conformal | MetricKind::QuasiConformal => {
                1.0 / positive(
                    "sum of |e1|^4 |e2|^4 over the corners",
                    mean(&|r| corner_scale(topo, r)),
                )?
            }
        };
        Ok(Calibration { geometric, l2 })
    }

    /// [`MetricSpec::calibrate`] on `refs` (solver coordinates), then [`MetricSpec::build`].
    pub fn build_for(
        &self,
        topo: &Topology,
        refs: &[&[[f64; 3]]],
    ) -> Result<Box<dyn Metric>, CalibrationError> {
        Ok(self.build(&self.calibrate(topo, refs)?))
    }

    /// [`MetricSpec::build_for`] with the reference given in the input's coordinates and the
    /// normalization `factor` that takes it to the solver's.
    pub fn build_scaled(
        &self,
        topo: &Topology,
        reference: &[[f64; 3]],
        factor: f64,
    ) -> Result<Box<dyn Metric>, CalibrationError> {
        if self.scale == MetricScale::Raw || (self.relative() && !self.frozen_areas) {
            return Ok(self.build(&Calibration::RAW));
        }
        let scaled: Vec<[f64; 3]> = reference.iter().map(|p| p.map(|c| c * factor)).collect();
        self.build_for(topo, &[&scaled])
    }

    /// Whether the metric takes the scale-invariant forms: the isometric, conformal and
    /// quasi-conformal metrics on the [`MetricScale::Invariant`] scale. The L2 and rigid
    /// metrics keep their calibrated forms there: they are the flat baselines (L2 geodesics
    /// are straight lines), and measure displacement, not its rate relative to the shape.
    fn relative(&self) -> bool {
        self.scale == MetricScale::Invariant && self.kind.info().invariant_form
    }

    /// Whether the metric has `term` on its scale ([`MetricKind::has_term`], without the terms
    /// only the invariant scale has on the others).
    /// Whether the metric built from this spec has the bending term ([`super::RelativeBending`]:
    /// a membrane metric on the invariant scale with `bending > 0`).
    pub fn bends(&self) -> bool {
        self.has(TermKind::Bending) && self.bending > 0.0
    }

    fn has(&self, term: TermKind) -> bool {
        self.kind
            .info()
            .terms
            .iter()
            .any(|t| t.term == term && (!t.invariant_only || self.relative()))
    }

    /// The metric without regularizer or factors.
    fn inner(&self) -> Box<dyn Metric> {
        if self.relative() {
            let qc = || {
                let qc = QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Endpoints);
                match self.qc_normalize {
                    Some(n) => qc.normalized(n),
                    None => qc,
                }
            };
            match self.kind {
                MetricKind::Isometric => return Box::new(RelativeIsometric),
                MetricKind::Conformal => {
                    return Box::new(RelativeConformal {
                        qc: None,
                        stretch: self.stretch,
                    })
                }
                MetricKind::QuasiConformal => {
                    return Box::new(RelativeConformal {
                        qc: Some(qc()),
                        stretch: self.stretch,
                    })
                }
                MetricKind::L2 | MetricKind::Rigid => {}
            }
        }
        match self.kind {
            MetricKind::L2 => {
                if self.frozen_areas {
                    Box::new(FrozenL2)
                } else {
                    Box::new(L2)
                }
            }
            MetricKind::Rigid => {
                if self.frozen_areas {
                    Box::new(FrozenRigid)
                } else {
                    Box::new(Rigid)
                }
            }
            MetricKind::Isometric => Box::new(Isometric),
            MetricKind::Conformal => Box::new(Conformal { form: self.form }),
            MetricKind::QuasiConformal => {
                let qc = QuasiConformal::new(self.form, self.weights);
                Box::new(match self.qc_normalize {
                    Some(n) => qc.normalized(n),
                    None => qc,
                })
            }
        }
    }

    /// Builds the metric `cal.geometric * G + lambda * cal.l2 * L2` (eq. 11 with the factors
    /// of [`MetricSpec::calibrate`]; [`Calibration::RAW`] gives the metric as written).
    pub fn build(&self, cal: &Calibration) -> Box<dyn Metric> {
        let scaled = |m: Box<dyn Metric>, w: f64| -> Box<dyn Metric> {
            if w == 1.0 {
                m
            } else {
                Box::new(Weighted::new(m, w))
            }
        };
        let mut inner = scaled(self.inner(), cal.geometric);
        if self.bends() {
            inner = Box::new(Bent::new(inner, self.bending));
        }
        if !self.kind.takes("lambda") {
            return inner;
        }
        if self.lambda > 0.0 {
            let lambda = self.lambda * cal.l2;
            if self.relative() && !self.frozen_areas {
                Box::new(Regularized::relative(inner, lambda))
            } else if self.frozen_areas {
                Box::new(Regularized::new(inner, lambda))
            } else {
                Box::new(Regularized::with_pose_areas(inner, lambda))
            }
        } else {
            inner
        }
    }
}

/// `sum_e |e|^4` over the edges of `pose` (the isometric metric's scale).
fn edge_scale(topo: &Topology, pose: &[[f64; 3]]) -> f64 {
    topo.edges()
        .iter()
        .map(|&[p, q]| {
            let e = sub(pose[q as usize], pose[p as usize]);
            let l2 = dot(e, e);
            l2 * l2
        })
        .sum()
}

/// `sum over the corners (p, q, r) of |q - p|^4 |r - p|^4` (the conformal metrics' scale: the
/// corner term `T_p` is `|q - p|^2 |r - p|^2` times a difference of two edge strains).
fn corner_scale(topo: &Topology, pose: &[[f64; 3]]) -> f64 {
    topo.faces()
        .iter()
        .map(|f| {
            (0..3)
                .map(|c| {
                    let p = pose[f[c] as usize];
                    let (e1, e2) = (
                        sub(pose[f[(c + 1) % 3] as usize], p),
                        sub(pose[f[(c + 2) % 3] as usize], p),
                    );
                    let m = dot(e1, e1) * dot(e2, e2);
                    m * m
                })
                .sum::<f64>()
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The description names the metric and its settings by their option names, in one plain
    /// number format, never the built metric's data-dependent factors.
    #[test]
    fn the_label_names_the_settings_not_the_factors() {
        let qc = MetricSpec::new(MetricKind::QuasiConformal);
        assert_eq!(
            qc.label(),
            "quasi-conformal (stretch 0.1, bending 0.0001, qc-weights rms, qc-floor 0.5, qc-smooth 0, lambda 0.01, \
             l2-areas frozen, scale invariant)"
        );
        assert_eq!(
            MetricSpec::calibrated(MetricKind::Isometric).label(),
            "isometric (lambda 0.01, l2-areas frozen, scale calibrated)"
        );
        assert_eq!(
            MetricSpec::previous(MetricKind::QuasiConformal).label(),
            "quasi-conformal (form quadratic, weights endpoints, qc-weights raw, lambda 0.1, \
             l2-areas frozen, scale raw)"
        );
        assert_eq!(MetricSpec::new(MetricKind::L2).label(), "l2 (scale invariant)");
        let tiny = MetricSpec {
            lambda: 1e-5,
            ..MetricSpec::new(MetricKind::Conformal)
        };
        assert_eq!(
            tiny.label(),
            "conformal (stretch 0.1, bending 0.0001, lambda 1e-5, l2-areas frozen, scale invariant)"
        );
        // Every setting named in a label is a setting key.
        for kind in MetricKind::all() {
            for spec in [
                MetricSpec::new(kind),
                MetricSpec::previous(kind),
                MetricSpec::calibrated(kind),
            ] {
                let label = spec.label();
                assert!(!label.contains('*'), "{label}");
                let inside = label.split_once('(').unwrap().1.trim_end_matches(')');
                for part in inside.split(", ") {
                    let key = part.split(' ').next().unwrap();
                    assert!(crate::settings::by_key(key).is_some(), "{key} in {label}");
                }
            }
        }
    }

    #[test]
    fn specs_build_the_named_metrics() {
        let raw = Calibration::RAW;
        let mut s = MetricSpec::new(MetricKind::L2);
        s.scale = MetricScale::Raw;
        assert_eq!(s.build(&raw).name(), "l2(frozen)");
        let mut s = MetricSpec::previous(MetricKind::QuasiConformal);
        s.lambda = 0.0;
        assert_eq!(s.build(&raw).name(), "quasi-conformal(quadratic,endpoints)");
        s.lambda = 0.5;
        assert!(s.build(&raw).name().contains("+0.5*l2(frozen)"));
        assert!("bogus".parse::<MetricKind>().is_err());
        assert_eq!("raw".parse::<MetricScale>(), Ok(MetricScale::Raw));
        assert!("size".parse::<MetricScale>().is_err());
    }

    /// The calibrated factors make every metric invariant under a change of units: the same
    /// shapes in coordinates scaled by 7 give the same squared norms.
    #[test]
    fn calibrated_metrics_do_not_depend_on_the_coordinates_units() {
        use crate::metric::{At, Segment};
        let s = crate::synth::icosphere(2);
        let b: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| [p[0] * 1.1 + 0.05 * p[1] * p[2], p[1] - 0.1 * p[2] * p[2], p[2]])
            .collect();
        for kind in MetricKind::all() {
            let spec = MetricSpec::new(kind);
            let value = |f: f64| {
                let a: Vec<[f64; 3]> = s.positions.iter().map(|p| p.map(|c| c * f)).collect();
                let bb: Vec<[f64; 3]> = b.iter().map(|p| p.map(|c| c * f)).collect();
                let cal = spec.calibrate(&s.topology, &[&a]).unwrap();
                let m = spec.build(&cal);
                let frozen = m.frozen_weights(&s.topology, &a, &bb);
                let seg = |at| Segment {
                    a: &a,
                    b: &bb,
                    at,
                    aux: &[],
                    frozen: frozen.as_deref(),
                };
                let pat = m.pattern(&s.topology);
                let [g0, g1] =
                    m.segment_squared_norms(&s.topology, pat.as_ref(), [&seg(At::Start), &seg(At::End)]);
                g0 + g1
            };
            let (v1, v7) = (value(1.0), value(7.0));
            assert!(
                v1 > 0.0 && (v1 - v7).abs() <= 1e-10 * v1,
                "{kind:?}: {v1} vs {v7}"
            );
        }
    }

    /// The property of the invariant scale (issue 47): for every metric whose default form is
    /// on it (isometric, conformal, quasi-conformal), a pose scaled by `s` with its
    /// displacement scaled by `s` (the metric's frozen values fixed, as on a path's interior)
    /// gives the same squared norm, `G_{sM}(sX) = G_M(X)`, to 1e-10 for s from 0.01 to 100:
    /// the default's geometric term, and the whole metric with the per-pose (relative)
    /// regularizer. The default's flat L2 regularizer (and the L2 and rigid baselines) scale
    /// like `s^2`; the calibrated eq. 7 form of the conformal metrics like `s^8` (T_p is quartic).
    #[test]
    fn invariant_metrics_are_scale_invariant() {
        use crate::metric::{At, Segment};
        let s = crate::synth::icosphere(2);
        let topo = &s.topology;
        let a: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| [p[0] * 1.2, p[1], p[2] * 0.9])
            .collect();
        let b: Vec<[f64; 3]> = a
            .iter()
            .map(|p| {
                [
                    p[0] + 0.1 * p[1] * p[2],
                    p[1] * 1.1 - 0.05 * p[0],
                    p[2] + 0.1 * p[0] * p[0],
                ]
            })
            .collect();
        // [geometric, regularizer] summed over both ends of the segment (a, b) scaled by f.
        let parts = |spec: &MetricSpec, f: f64| {
            let m = spec.build_for(topo, &[&a]).unwrap();
            let frozen = m.frozen_weights(topo, &a, &b);
            let (sa, sb): (Vec<[f64; 3]>, Vec<[f64; 3]>) = (
                a.iter().map(|p| p.map(|c| c * f)).collect(),
                b.iter().map(|p| p.map(|c| c * f)).collect(),
            );
            let seg = |at| Segment {
                a: &sa,
                b: &sb,
                at,
                aux: &[],
                frozen: frozen.as_deref(),
            };
            let pat = m.pattern(topo);
            m.segment_energy_parts(topo, pat.as_ref(), [&seg(At::Start), &seg(At::End)])
        };
        for kind in MetricKind::ALL.into_iter().filter(|k| k.info().invariant_form) {
            let spec = MetricSpec::new(kind);
            assert_eq!(spec.scale, MetricScale::Invariant);
            let relative = MetricSpec {
                frozen_areas: false,
                ..spec
            };
            let ([g1, r1], [t1, u1]) = (parts(&spec, 1.0), parts(&relative, 1.0));
            assert!(g1 > 0.0 && r1 > 0.0 && u1 > 0.0);
            for f in [0.01, 0.1, 3.0, 100.0] {
                let ([gf, rf], [tf, uf]) = (parts(&spec, f), parts(&relative, f));
                assert!((gf - g1).abs() <= 1e-10 * g1, "{kind:?} x {f}: {gf} vs {g1}");
                assert!(
                    (tf + uf - t1 - u1).abs() <= 1e-10 * (t1 + u1),
                    "{kind:?} relative x {f}: {} vs {}",
                    tf + uf,
                    t1 + u1
                );
                // The flat regularizer: s^2.
                assert!((rf - f * f * r1).abs() <= 1e-10 * f * f * r1, "{kind:?} x {f}");
            }
            if kind != MetricKind::Isometric {
                let old = MetricSpec::calibrated(kind);
                let ([o1, _], [o2, _]) = (parts(&old, 1.0), parts(&old, 2.0));
                assert!((o2 / o1 - 256.0).abs() < 1e-6, "{kind:?} calibrated: {}", o2 / o1);
            }
        }
    }

    #[test]
    fn calibration_refuses_degenerate_references() {
        let s = crate::synth::icosphere(1);
        let spec = MetricSpec::calibrated(MetricKind::Isometric);
        let flat = vec![[0.0; 3]; s.n_vertices()];
        assert!(matches!(
            spec.calibrate(&s.topology, &[&flat]),
            Err(CalibrationError::Degenerate { .. })
        ));
        assert!(matches!(
            spec.calibrate(&s.topology, &[&s.positions[1..]]),
            Err(CalibrationError::Reference { .. })
        ));
        assert!(matches!(
            spec.calibrate(&s.topology, &[]),
            Err(CalibrationError::Reference { got: 0, .. })
        ));
        // The raw scale needs no reference.
        let raw = MetricSpec::previous(MetricKind::Isometric);
        assert_eq!(raw.calibrate(&s.topology, &[]).unwrap(), Calibration::RAW);
    }
}
