//! How much of a similarity matrix the L2 regularizer decides: the distribution over the
//! pairs of [`PairDistance::regularizer_share`]. When the regularizer carries more than half of
//! a path's energy, the distance measures L2 displacement more than the metric's own geometry;
//! the commands print this summary and warn when it is so for most pairs.

use super::types::PairDistance;

/// The distribution of the L2 regularizer's energy share over the pairs of a matrix
/// ([`PairDistance::regularizer_share`], each in [0, 1]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ShareSummary {
    /// Pairs with a known energy split (the summary is over these).
    pub pairs: usize,
    /// Pairs without one (tangent mode, pairs from old journals or shard files).
    pub unknown: usize,
    /// Smallest share (NaN when no pair has a split).
    pub min: f64,
    /// Median share (the mean of the two middle ones for an even count; NaN when no pair has
    /// a split).
    pub median: f64,
    /// Largest share (NaN when no pair has a split).
    pub max: f64,
    /// Pairs whose share is above 0.5: the regularizer carries more than half of their
    /// energy.
    pub above_half: usize,
}

impl ShareSummary {
    /// The summary of `pairs`.
    pub fn of(pairs: &[PairDistance]) -> ShareSummary {
        let mut shares: Vec<f64> = pairs.iter().filter_map(|p| p.regularizer_share()).collect();
        shares.sort_by(f64::total_cmp);
        let n = shares.len();
        let median = match n {
            0 => f64::NAN,
            _ if n % 2 == 1 => shares[n / 2],
            _ => 0.5 * (shares[n / 2 - 1] + shares[n / 2]),
        };
        ShareSummary {
            pairs: n,
            unknown: pairs.len() - n,
            min: shares.first().copied().unwrap_or(f64::NAN),
            median,
            max: shares.last().copied().unwrap_or(f64::NAN),
            above_half: shares.iter().filter(|&&s| s > 0.5).count(),
        }
    }

    /// The fraction of the pairs with a split whose share is above 0.5 (NaN without pairs).
    pub fn fraction_above_half(&self) -> f64 {
        if self.pairs == 0 {
            f64::NAN
        } else {
            self.above_half as f64 / self.pairs as f64
        }
    }

    /// Whether the regularizer carries more than half of the energy for more than half of
    /// the pairs: the matrix then measures L2 displacement more than the metric's geometry.
    pub fn dominated(&self) -> bool {
        2 * self.above_half > self.pairs
    }

    /// One line: `energy share of the L2 regularizer over M pairs: min 1.2 %, median 3.4 %,
    /// max 56.7 %; 2 of M pairs above 50 %` (and the pairs without a split, if any).
    pub fn line(&self) -> String {
        let unknown = if self.unknown > 0 {
            format!(
                " ({} pair(s) without an energy split: tangent mode or an older journal)",
                self.unknown
            )
        } else {
            String::new()
        };
        if self.pairs == 0 {
            return format!("energy share of the L2 regularizer: unknown{unknown}");
        }
        format!(
            "energy share of the L2 regularizer over {} pairs: min {}, median {}, max {}; {} of {} pairs above 50 %{unknown}",
            self.pairs,
            percent(self.min),
            percent(self.median),
            percent(self.max),
            self.above_half,
            self.pairs
        )
    }

    /// The warning when [`ShareSummary::dominated`]: "the L2 regularizer carries more than
    /// half of the energy for N of M pairs: the `metric` distances measure L2 displacement more
    /// than the metric's geometry (lower --lambda)"; `None` otherwise. `metric` names the
    /// metric (e.g. [`crate::metric::MetricKind::label`]).
    pub fn warning(&self, metric: &str) -> Option<String> {
        self.dominated().then(|| {
            format!(
                "the L2 regularizer carries more than half of the energy for {} of {} pairs: the {metric} \
                 distances measure L2 displacement more than the metric's geometry (lower --lambda)",
                self.above_half, self.pairs
            )
        })
    }

    /// A Markdown paragraph for a report: "Energy share of the L2 regularizer: min / median /
    /// max ..., pairs above 50 % ..." and the warning sentence when it applies.
    pub fn markdown(&self, metric: &str) -> String {
        let mut md = if self.pairs == 0 {
            "Energy share of the L2 regularizer: unknown (no pair has an energy split)".to_string()
        } else {
            format!(
                "Energy share of the L2 regularizer (its part of each pair's path energy, eq. 11): \
                 min / median / max {} / {} / {}, pairs above 50 %: {} of {}",
                percent(self.min),
                percent(self.median),
                percent(self.max),
                self.above_half,
                self.pairs
            )
        };
        if self.unknown > 0 && self.pairs > 0 {
            md.push_str(&format!(" ({} pair(s) without an energy split)", self.unknown));
        }
        md.push('.');
        if let Some(w) = self.warning(metric) {
            md.push_str(&format!("\n\n**Warning:** {w}."));
        }
        md.push('\n');
        md
    }
}

/// `x` in [0, 1] as a percentage with one decimal.
fn percent(x: f64) -> String {
    format!("{:.1} %", 100.0 * x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(geometric: f64, regularizer: f64) -> PairDistance {
        PairDistance {
            i: 0,
            j: 1,
            distance: 1.0,
            per_pose: vec![0.0, 1.0],
            per_pose_energy: Some(vec![[0.0, 0.0], [geometric, regularizer]]),
            converged: true,
            iterations: 1,
            seconds: 0.0,
        }
    }

    #[test]
    fn summary_counts_the_pairs_above_half_and_warns_for_most() {
        let pairs = vec![pair(3.0, 1.0), pair(1.0, 3.0), pair(0.0, 2.0), pair(1.0, 1.0)];
        let s = ShareSummary::of(&pairs);
        assert_eq!((s.pairs, s.unknown, s.above_half), (4, 0, 2));
        assert_eq!((s.min, s.median, s.max), (0.25, 0.625, 1.0));
        assert_eq!(s.fraction_above_half(), 0.5);
        // Exactly half is not more than half.
        assert!(!s.dominated() && s.warning("isometric").is_none());
        assert!(s
            .line()
            .contains("min 25.0 %, median 62.5 %, max 100.0 %; 2 of 4 pairs above 50 %"));
        assert!(!s.markdown("isometric").contains("Warning"));

        let mut more = pairs.clone();
        more.push(pair(0.1, 0.9));
        more.push(PairDistance {
            per_pose_energy: None,
            ..pair(1.0, 0.0)
        });
        let s = ShareSummary::of(&more);
        assert_eq!((s.pairs, s.unknown, s.above_half), (5, 1, 3));
        assert_eq!(s.median, 0.75);
        let w = s.warning("quasi-conformal").unwrap();
        assert!(
            w.contains("for 3 of 5 pairs: the quasi-conformal distances measure L2 displacement")
                && w.ends_with("(lower --lambda)"),
            "{w}"
        );
        let md = s.markdown("quasi-conformal");
        assert!(
            md.contains("pairs above 50 %: 3 of 5") && md.contains("**Warning:**"),
            "{md}"
        );
        assert!(s.line().contains("1 pair(s) without an energy split"));
    }

    #[test]
    fn no_split_is_unknown_not_zero() {
        let s = ShareSummary::of(&[PairDistance {
            per_pose_energy: None,
            ..pair(1.0, 0.0)
        }]);
        assert_eq!((s.pairs, s.unknown, s.above_half), (0, 1, 0));
        assert!(s.median.is_nan() && s.fraction_above_half().is_nan());
        assert!(!s.dominated());
        assert!(s.line().contains("unknown"));
        assert!(s.markdown("l2").contains("unknown"));
        // A pair of zero energy (identical deformations) has share 0.
        assert_eq!(ShareSummary::of(&[pair(0.0, 0.0)]).max, 0.0);
    }
}
