//! The names a setting chooses a metric by: which metric ([`MetricKind`]), how its terms are
//! scaled ([`MetricScale`]), and two of its variants ([`QcScaling`], [`L2Areas`]).

/// Which metric (paper section 2.1). Everything else about a metric (its names, its terms and
/// their weights, the settings that apply to it) is its entry of the registry [`METRICS`]
/// ([`MetricKind::info`]): the one list of metrics that parsing, `--help`, the settings table,
/// the studies' default lists and Python (`qcshape.METRICS`) read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
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

/// A term of the metrics: a sum of squared residuals that a metric weights (docs/method.md
/// "Metrics"; compare geomstats' `ElasticMetric`, whose coefficients weight an L2, a shear, a
/// stretch and a bending term). Each metric of [`METRICS`] is a set of weights over these
/// ([`MetricInfo::terms`]); each term's entry of [`TERMS`] ([`TermKind::info`]) names it and
/// the files that implement it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TermKind {
    /// Displacement, area-weighted (eq. 11): the L2 metric and every other metric's regularizer.
    L2,
    /// Displacement less its best local rigid motion (eq. 1).
    Rigid,
    /// Edge strain (eq. 3).
    Strain,
    /// Conformal shear: the difference of the two edge strains at each corner (eqs. 6-9).
    Shear,
    /// The conformal shear weighted by the change of curvature (eq. 10).
    WeightedShear,
    /// The relative rate of change of each face's area (the scale the shear leaves free).
    Stretch,
    /// The change of the dihedral angles (docs/method.md "Bending term").
    Bending,
}

/// The part of the path energy a term is reported in ([`Metric::segment_energy_parts`],
/// [`Metric::segment_bending_energy`]; the added term of a [`TermSum`]).
///
/// [`Metric::segment_energy_parts`]: super::Metric::segment_energy_parts
/// [`Metric::segment_bending_energy`]: super::Metric::segment_bending_energy
/// [`TermSum`]: super::TermSum
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnergyPart {
    /// The geometric part: the first value of [`Metric::segment_energy_parts`]
    /// (a metric's own terms).
    ///
    /// [`Metric::segment_energy_parts`]: super::Metric::segment_energy_parts
    Geometric,
    /// The regularizer (eq. 11's L2 term): the second value of
    /// [`Metric::segment_energy_parts`], so the path's regularizer energy.
    ///
    /// [`Metric::segment_energy_parts`]: super::Metric::segment_energy_parts
    Regularizer,
    /// The bending term: geometric in [`Metric::segment_energy_parts`], and the value of
    /// [`Metric::segment_bending_energy`].
    ///
    /// [`Metric::segment_energy_parts`]: super::Metric::segment_energy_parts
    /// [`Metric::segment_bending_energy`]: super::Metric::segment_bending_energy
    Bending,
}

/// The weight of a term in a metric ([`MetricTerm`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Weight {
    /// 1 (times the calibration's factor): the metric's own term.
    One,
    /// The value of the setting with this key (`"lambda"`, `"stretch"`, `"bending"`;
    /// `crate::settings::SETTINGS`).
    Setting(&'static str),
}

/// One term of a metric with its weight ([`MetricInfo::terms`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MetricTerm {
    /// Which term.
    pub term: TermKind,
    /// Its weight.
    pub weight: Weight,
    /// The energy part it is reported in.
    pub part: EnergyPart,
    /// Whether the metric has it only on the [`MetricScale::Invariant`] scale.
    pub invariant_only: bool,
}

/// A metric's entry of the registry [`METRICS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MetricInfo {
    /// The metric.
    pub kind: MetricKind,
    /// Its canonical name (`--metric`, Python's `metric=`, reports, file names).
    pub name: &'static str,
    /// Other names it is parsed from.
    pub aliases: &'static [&'static str],
    /// One line on what it charges.
    pub about: &'static str,
    /// Its terms with their weights, its own term first.
    pub terms: &'static [MetricTerm],
    /// The keys of the metric settings that apply to it (`crate::settings::SETTINGS`), in the
    /// order [`MetricSpec::label`](super::MetricSpec::label) names them.
    pub settings: &'static [&'static str],
    /// Whether it takes the scale-invariant forms on the [`MetricScale::Invariant`] scale (the
    /// L2 and rigid metrics, the flat baselines, keep their calibrated forms there).
    pub invariant_form: bool,
    /// Whether its null space holds more than rigid motions (conformal fields, and scalings
    /// unless the stretch term charges them), so that without the regularizer geodesics are not
    /// unique ([`MetricSpec::warning`](super::MetricSpec::warning)).
    pub needs_regularizer: bool,
}

/// A term's entry of the registry [`TERMS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TermInfo {
    /// The term.
    pub term: TermKind,
    /// Its name.
    pub name: &'static str,
    /// One line on what it charges.
    pub about: &'static str,
    /// The files of `crates/qcshape/src/metric/` that implement it (each with its
    /// finite-difference test).
    pub files: &'static [&'static str],
}

const fn own(term: TermKind) -> MetricTerm {
    MetricTerm {
        term,
        weight: Weight::One,
        part: EnergyPart::Geometric,
        invariant_only: false,
    }
}

const REGULARIZER: MetricTerm = MetricTerm {
    term: TermKind::L2,
    weight: Weight::Setting("lambda"),
    part: EnergyPart::Regularizer,
    invariant_only: false,
};

const STRETCH: MetricTerm = MetricTerm {
    term: TermKind::Stretch,
    weight: Weight::Setting("stretch"),
    part: EnergyPart::Geometric,
    invariant_only: true,
};

const BENDING: MetricTerm = MetricTerm {
    term: TermKind::Bending,
    weight: Weight::Setting("bending"),
    part: EnergyPart::Bending,
    invariant_only: true,
};

/// Every metric, in the order of [`MetricKind`]'s declaration (the paper's Table 1 with L2
/// first): the one list of metrics ([`MetricKind::ALL`] is its kinds).
pub const METRICS: [MetricInfo; 5] = [
    MetricInfo {
        kind: MetricKind::L2,
        name: "l2",
        aliases: &[],
        about: "area-weighted displacement (eq. 11): geodesics are straight lines",
        terms: &[own(TermKind::L2)],
        settings: &["l2-areas", "scale"],
        invariant_form: false,
        needs_regularizer: false,
    },
    MetricInfo {
        kind: MetricKind::Rigid,
        name: "rigid",
        aliases: &[],
        about: "as rigid as possible (eq. 1): displacement less each vertex's best local rigid motion",
        terms: &[own(TermKind::Rigid), REGULARIZER],
        settings: &["lambda", "l2-areas", "scale"],
        invariant_form: false,
        needs_regularizer: false,
    },
    MetricInfo {
        kind: MetricKind::Isometric,
        name: "isometric",
        aliases: &[],
        about: "as isometric as possible (eq. 3): edge strain",
        terms: &[own(TermKind::Strain), BENDING, REGULARIZER],
        settings: &["bending", "lambda", "l2-areas", "scale"],
        invariant_form: true,
        needs_regularizer: false,
    },
    MetricInfo {
        kind: MetricKind::Conformal,
        name: "conformal",
        aliases: &[],
        about: "conformal (eqs. 7-9): the change of the triangles' angles",
        terms: &[own(TermKind::Shear), STRETCH, BENDING, REGULARIZER],
        settings: &["form", "stretch", "bending", "lambda", "l2-areas", "scale"],
        invariant_form: true,
        needs_regularizer: true,
    },
    MetricInfo {
        kind: MetricKind::QuasiConformal,
        name: "quasi-conformal",
        aliases: &["qc"],
        about: "quasi-conformal (eq. 10): the conformal terms weighted by the change of curvature",
        terms: &[own(TermKind::WeightedShear), STRETCH, BENDING, REGULARIZER],
        settings: &[
            "form",
            "stretch",
            "bending",
            "weights",
            "qc-weights",
            "qc-floor",
            "qc-smooth",
            "lambda",
            "l2-areas",
            "scale",
        ],
        invariant_form: true,
        needs_regularizer: true,
    },
];

/// Every term, in the order of [`TermKind`]'s declaration: the one list of terms
/// ([`TermKind::ALL`] is its kinds).
pub const TERMS: [TermInfo; 7] = [
    TermInfo {
        term: TermKind::L2,
        name: "l2",
        about: "area-weighted displacement (eq. 11)",
        files: &["l2.rs", "relative/l2.rs", "regularized.rs"],
    },
    TermInfo {
        term: TermKind::Rigid,
        name: "rigid",
        about: "displacement less its best local rigid motion (eq. 1)",
        files: &["rigid.rs", "rigid_frozen.rs"],
    },
    TermInfo {
        term: TermKind::Strain,
        name: "strain",
        about: "edge strain (eq. 3)",
        files: &["isometric.rs", "relative/isometric.rs"],
    },
    TermInfo {
        term: TermKind::Shear,
        name: "shear",
        about: "the difference of the two edge strains at each corner (eqs. 6-9)",
        files: &["conformal.rs", "relative/conformal.rs"],
    },
    TermInfo {
        term: TermKind::WeightedShear,
        name: "weighted-shear",
        about: "the shear weighted by the change of curvature (eq. 10)",
        files: &["quasi_conformal.rs", "relative/conformal.rs"],
    },
    TermInfo {
        term: TermKind::Stretch,
        name: "stretch",
        about: "the relative rate of change of each face's area",
        files: &["relative/conformal.rs"],
    },
    TermInfo {
        term: TermKind::Bending,
        name: "bending",
        about: "the change of the dihedral angles",
        files: &["relative/bending.rs", "bent.rs"],
    },
];

/// The kinds of a registry's entries (their field `$field`), in its order; `$first` fills the
/// array before the copy.
macro_rules! kinds_of {
    ($registry:expr, $first:expr, $field:ident) => {{
        let mut all = [$first; $registry.len()];
        let mut i = 0;
        while i < all.len() {
            all[i] = $registry[i].$field;
            i += 1;
        }
        all
    }};
}

impl MetricKind {
    /// Every metric, in the registry's order ([`METRICS`]: the paper's Table 1 with L2 first).
    pub const ALL: [MetricKind; METRICS.len()] = kinds_of!(METRICS, MetricKind::L2, kind);

    /// Every metric ([`MetricKind::ALL`]).
    pub fn all() -> [MetricKind; METRICS.len()] {
        MetricKind::ALL
    }

    /// Its entry of the registry [`METRICS`].
    pub fn info(self) -> &'static MetricInfo {
        // The registry follows the declaration's order (checked by the registry's test).
        &METRICS[self as usize]
    }

    /// The canonical name (`"l2"`, `"rigid"`, `"isometric"`, `"conformal"`,
    /// `"quasi-conformal"`), from [`METRICS`].
    pub fn label(self) -> &'static str {
        self.info().name
    }

    /// Whether the setting with key `key` (`"lambda"`, `"stretch"`, `"qc-weights"`, ...)
    /// applies to this metric ([`MetricInfo::settings`]).
    pub fn takes(self, key: &str) -> bool {
        self.info().settings.contains(&key)
    }

    /// Whether `term` is one of its terms (on some scale; [`MetricInfo::terms`]).
    pub fn has_term(self, term: TermKind) -> bool {
        self.info().terms.iter().any(|t| t.term == term)
    }

    /// The canonical names of `kinds`, comma-separated (`"l2,isometric"`: a command-line list's
    /// spelling).
    pub fn list(kinds: &[MetricKind]) -> String {
        kinds.iter().map(|k| k.label()).collect::<Vec<_>>().join(",")
    }
}

impl std::fmt::Display for MetricKind {
    /// The canonical name ([`MetricKind::label`]).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

impl crate::named::Named for MetricKind {
    const ALL: &'static [Self] = &MetricKind::ALL;
    fn name(self) -> &'static str {
        self.label()
    }
}

/// A name that is not one of a registry's ([`METRICS`], [`TERMS`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} '{name}' (expected {})", expected.join(", "))]
pub struct UnknownName {
    /// What was named (`"metric"`, `"term"`).
    pub what: &'static str,
    /// The name given.
    pub name: String,
    /// The canonical names accepted (aliases are accepted too but not listed).
    pub expected: Vec<&'static str>,
}

impl std::str::FromStr for MetricKind {
    type Err = UnknownName;
    /// The metric whose canonical name or alias is `s` ([`METRICS`]).
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        METRICS
            .iter()
            .find(|m| m.name == s || m.aliases.contains(&s))
            .map(|m| m.kind)
            .ok_or_else(|| UnknownName {
                what: "metric",
                name: s.to_string(),
                expected: METRICS.iter().map(|m| m.name).collect(),
            })
    }
}

impl TermKind {
    /// Every term, in the registry's order ([`TERMS`]).
    pub const ALL: [TermKind; TERMS.len()] = kinds_of!(TERMS, TermKind::L2, term);

    /// Its entry of the registry [`TERMS`].
    pub fn info(self) -> &'static TermInfo {
        // The registry follows the declaration's order (checked by the registry's test).
        &TERMS[self as usize]
    }

    /// Its name (`"l2"`, `"strain"`, `"shear"`, `"bending"`, ...), from [`TERMS`].
    pub fn label(self) -> &'static str {
        self.info().name
    }

    /// The metrics that have it ([`MetricInfo::terms`]), in the registry's order.
    pub fn metrics(self) -> Vec<MetricKind> {
        MetricKind::ALL.into_iter().filter(|k| k.has_term(self)).collect()
    }
}

impl std::fmt::Display for TermKind {
    /// Its name ([`TermKind::label`]).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

impl std::str::FromStr for TermKind {
    type Err = UnknownName;
    /// The term named `s` ([`TERMS`]).
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        TERMS
            .iter()
            .find(|t| t.name == s)
            .map(|t| t.term)
            .ok_or_else(|| UnknownName {
                what: "term",
                name: s.to_string(),
                expected: TERMS.iter().map(|t| t.name).collect(),
            })
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The registry is complete and consistent: every kind has one entry, at its declaration's
    /// index; no two names (canonical or alias) collide; each name and alias parses back to its
    /// kind; the error lists the canonical names.
    #[test]
    fn the_registry_holds_every_kind_once_under_distinct_names() {
        use MetricKind::*;
        // Every variant, written out: the exhaustive match stops this test from compiling
        // until a new variant is listed here too, and then it must be in the registry.
        let _exhaustive = |k: MetricKind| match k {
            L2 | Rigid | Isometric | Conformal | QuasiConformal => (),
        };
        let variants = [L2, Rigid, Isometric, Conformal, QuasiConformal];
        assert_eq!(METRICS.len(), variants.len(), "a metric is missing from METRICS");
        for k in variants {
            assert_eq!(
                METRICS.iter().filter(|m| m.kind == k).count(),
                1,
                "{k:?} in METRICS"
            );
        }
        for (i, m) in METRICS.iter().enumerate() {
            assert_eq!(
                m.kind as usize, i,
                "{}: METRICS follows MetricKind's order",
                m.name
            );
            assert_eq!(m.kind.info(), m);
            assert_eq!(MetricKind::ALL[i], m.kind);
            assert_eq!(m.name.parse::<MetricKind>(), Ok(m.kind));
            assert_eq!(m.kind.to_string(), m.name);
            for a in m.aliases {
                assert_eq!(a.parse::<MetricKind>(), Ok(m.kind), "alias {a}");
            }
            assert!(!m.about.is_empty() && !m.settings.is_empty());
            assert_eq!(m.terms[0].weight, Weight::One, "{}: its own term first", m.name);
            for t in m.terms {
                if let Weight::Setting(key) = t.weight {
                    assert!(m.kind.takes(key), "{}: {key} weights a term", m.name);
                }
            }
        }
        let mut names: Vec<&str> = METRICS
            .iter()
            .flat_map(|m| std::iter::once(m.name).chain(m.aliases.iter().copied()))
            .collect();
        let n = names.len();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), n, "two metrics share a name");
        let e = "bogus".parse::<MetricKind>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown metric 'bogus' (expected l2, rigid, isometric, conformal, quasi-conformal)"
        );
        assert_eq!("qc".parse::<MetricKind>(), Ok(MetricKind::QuasiConformal));
        assert_eq!(
            MetricKind::list(&[MetricKind::L2, MetricKind::QuasiConformal]),
            "l2,quasi-conformal"
        );
    }

    /// The same for the terms: one entry per kind at its index, distinct names that parse
    /// back, files that exist; every term belongs to some metric.
    #[test]
    fn the_term_registry_holds_every_term_once() {
        use TermKind::*;
        let _exhaustive = |t: TermKind| match t {
            L2 | Rigid | Strain | Shear | WeightedShear | Stretch | Bending => (),
        };
        let variants = [L2, Rigid, Strain, Shear, WeightedShear, Stretch, Bending];
        assert_eq!(TERMS.len(), variants.len(), "a term is missing from TERMS");
        for t in variants {
            assert_eq!(TERMS.iter().filter(|e| e.term == t).count(), 1, "{t:?} in TERMS");
        }
        let mut names: Vec<&str> = Vec::new();
        for (i, t) in TERMS.iter().enumerate() {
            assert_eq!(t.term as usize, i, "{}: TERMS follows TermKind's order", t.name);
            assert_eq!(t.term.info(), t);
            assert_eq!(TermKind::ALL[i], t.term);
            assert_eq!(t.name.parse::<TermKind>(), Ok(t.term));
            assert_eq!(t.term.to_string(), t.name);
            assert!(!t.term.metrics().is_empty(), "{}: no metric has it", t.name);
            let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/metric");
            for f in t.files {
                assert!(dir.join(f).is_file(), "{}: {f}", t.name);
            }
            names.push(t.name);
        }
        let n = names.len();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), n, "two terms share a name");
        assert!("bogus"
            .parse::<TermKind>()
            .unwrap_err()
            .to_string()
            .contains("expected l2, rigid, strain"));
    }
}
