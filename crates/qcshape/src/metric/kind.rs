//! The names a setting chooses a metric by: which metric ([`MetricKind`]), how its terms are
//! scaled ([`MetricScale`]), and two of its variants ([`QcScaling`], [`L2Areas`]).

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

/// How a metric's terms are scaled, which fixes what `lambda` means (docs/method.md "Scale-invariant forms").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MetricScale {
    /// Scale-invariant forms (docs/method.md "Scale-invariant forms"): every term a rate of
    /// relative change weighted by its face's area share
    /// ([`RelativeIsometric`](super::RelativeIsometric),
    /// [`RelativeConformal`](super::RelativeConformal): conformal and quasi-conformal as eq. 6's
    /// relative rates, not eq. 7's; the regularizer [`super::RelativeL2`]), so that `G_{sM}(sX) =
    /// G_M(X)` for every pose: a geodesic gains nothing by shrinking the shape. Dimensionless and
    /// resolution-consistent; `lambda` a plain ratio. The regularizer is the calibrated, flat L2
    /// term by default (frozen areas; its share of the energy is under 1 %), [`super::RelativeL2`]
    /// with per-pose areas ([`MetricSpec::frozen_areas`](super::MetricSpec::frozen_areas) false).
    /// The L2 and rigid metrics, the flat displacement baselines, keep their
    /// [`MetricScale::Calibrated`] forms.
    Invariant,
    /// Every term divided by its own scale at the reference pose(s) of the analysis
    /// ([`Calibration`](super::Calibration)): the geometric term becomes an area-weighted mean of
    /// squared strain rates (isometric: edge strain `<dX_e, e> / |e|^2`; conformal and
    /// quasi-conformal: the difference of the two edge strains at each corner), the L2 term (metric
    /// or regularizer) the mean squared displacement per unit area `sum_p A_p |X_p|^2 / A^2`. Both
    /// are dimensionless and converge as the mesh is refined, so `lambda` is a plain ratio that
    /// does not depend on the resolution, the shapes' size or the coordinates' units. The terms
    /// keep eq. 3's and eq. 7's powers of the pose's size (the conformal terms scale like its sixth
    /// power), so a geodesic can shrink the shape on the way (releases of 2026-12-04 to
    /// 2026-12-06).
    Calibrated,
    /// The paper's sums as written, in coordinates divided by the mean edge length (every
    /// release before 2026-12-04, `lambda` 0.1): the terms scale with the resolution
    /// differently (isometric like `h^2`, conformal like `h^6` relative to L2), so at the
    /// previous default the regularizer carried almost all of the energy.
    Raw,
}

impl MetricScale {
    /// Every scale, the default first.
    pub const ALL: [MetricScale; 3] = [MetricScale::Invariant, MetricScale::Calibrated, MetricScale::Raw];

    /// The command-line name (`"invariant"`, `"calibrated"`, `"raw"`).
    pub fn label(self) -> &'static str {
        match self {
            MetricScale::Invariant => "invariant",
            MetricScale::Calibrated => "calibrated",
            MetricScale::Raw => "raw",
        }
    }
}

impl std::str::FromStr for MetricScale {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        MetricScale::ALL
            .into_iter()
            .find(|m| m.label() == s)
            .ok_or_else(|| format!("unknown metric scale '{s}' (expected invariant, calibrated or raw)"))
    }
}

/// Which quasi-conformal endpoint weights
/// ([`MetricSpec::qc_normalize`](super::MetricSpec::qc_normalize)): the value of the `qc-weights`
/// setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QcScaling {
    /// The curvature-change density over its RMS, floored ([`QcNormalize`](super::QcNormalize)).
    Rms,
    /// The paper's angle-defect change in radians (no normalization).
    Raw,
}

/// Where the L2 area weights come from
/// ([`MetricSpec::frozen_areas`](super::MetricSpec::frozen_areas)): the value of the `l2-areas`
/// setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum L2Areas {
    /// Frozen at the path's ends.
    Frozen,
    /// Taken from each pose.
    Pose,
}
