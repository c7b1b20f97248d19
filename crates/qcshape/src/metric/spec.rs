//! Building a metric from names (CLI, data files).

use super::{
    Conformal, ConformalForm, FrozenL2, FrozenRigid, Isometric, Metric, QcWeights, QuasiConformal,
    Regularized, Rigid, L2,
};

/// Which metric (paper section 2.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MetricKind {
    /// L2 (eq. 11).
    L2,
    /// As rigid as possible (eq. 1).
    Rigid,
    /// As isometric as possible (eq. 3).
    Isometric,
    /// Conformal (eqs. 7-9).
    Conformal,
    /// Quasi-conformal (eq. 10).
    QuasiConformal,
}

impl MetricKind {
    /// Every metric, in the order of the paper's Table 1 with L2 first.
    pub fn all() -> [MetricKind; 5] {
        use MetricKind::*;
        [L2, Rigid, Isometric, Conformal, QuasiConformal]
    }

    /// The command-line name (`"l2"`, `"rigid"`, `"isometric"`, `"conformal"`,
    /// `"quasi-conformal"`).
    pub fn label(self) -> &'static str {
        match self {
            MetricKind::L2 => "l2",
            MetricKind::Rigid => "rigid",
            MetricKind::Isometric => "isometric",
            MetricKind::Conformal => "conformal",
            MetricKind::QuasiConformal => "quasi-conformal",
        }
    }
}

impl std::str::FromStr for MetricKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "l2" => Ok(MetricKind::L2),
            "rigid" => Ok(MetricKind::Rigid),
            "isometric" => Ok(MetricKind::Isometric),
            "conformal" => Ok(MetricKind::Conformal),
            "quasi-conformal" | "qc" => Ok(MetricKind::QuasiConformal),
            _ => Err(format!(
                "unknown metric '{s}' (expected l2, rigid, isometric, conformal, quasi-conformal)"
            )),
        }
    }
}

/// A metric with its variants (METHOD.md) and regularization `G + lambda * L2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricSpec {
    /// The metric.
    pub kind: MetricKind,
    /// Conformal triangle term (conformal and quasi-conformal).
    pub form: ConformalForm,
    /// Curvature-change weights (quasi-conformal).
    pub weights: QcWeights,
    /// Weight of the L2 regularizer (ignored for the L2 metric itself); 0 disables it.
    pub lambda: f64,
    /// L2 area weights frozen at the path's ends (true) or taken from each pose (false).
    pub frozen_areas: bool,
}

impl MetricSpec {
    /// Defaults: quadratic form, endpoint weights, `lambda` = [`crate::defaults::LAMBDA`]
    /// (0.1), frozen areas.
    pub fn new(kind: MetricKind) -> Self {
        MetricSpec {
            kind,
            form: ConformalForm::Quadratic,
            weights: QcWeights::Endpoints,
            lambda: crate::defaults::LAMBDA,
            frozen_areas: true,
        }
    }

    /// Builds the metric.
    pub fn build(&self) -> Box<dyn Metric> {
        let inner: Box<dyn Metric> = match self.kind {
            MetricKind::L2 => {
                return if self.frozen_areas {
                    Box::new(FrozenL2)
                } else {
                    Box::new(L2)
                };
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
            MetricKind::QuasiConformal => Box::new(QuasiConformal {
                form: self.form,
                weights: self.weights,
            }),
        };
        if self.lambda > 0.0 {
            if self.frozen_areas {
                Box::new(Regularized::new(inner, self.lambda))
            } else {
                Box::new(Regularized::with_pose_areas(inner, self.lambda))
            }
        } else {
            inner
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_build_the_named_metrics() {
        assert_eq!(MetricSpec::new(MetricKind::L2).build().name(), "l2(frozen)");
        let mut s = MetricSpec::new(MetricKind::QuasiConformal);
        s.lambda = 0.0;
        assert_eq!(s.build().name(), "quasi-conformal(quadratic,endpoints)");
        s.lambda = 0.5;
        assert!(s.build().name().contains("+0.5*l2(frozen)"));
        assert!("bogus".parse::<MetricKind>().is_err());
    }
}
