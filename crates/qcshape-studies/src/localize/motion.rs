//! Signed motion contrasts: where one group's deformations move more than the other's
//! (docs/maps.md, "Signed motion maps").
//!
//! The similarity split of [`super::contrasts`] is unsigned: it says where two motions differ,
//! not which of them moves more. A hypokinetic wall (moving less than normal) and a
//! hyperkinetic one (moving more) look alike in it. Here every deformation `P_0 .. P_K`
//! (transferred to the common base, eq. 13) gets its own per-vertex amount of motion `m_v`
//! ([`MotionMeasure`]): by default its normal excursion (how far each vertex moves along the
//! surface normal over the steps `P_k -> P_{k+1}`, times its area), or the metric's
//! per-vertex length split of each step ([`crate::contribution::path_contributions`]), and
//! optionally as shares of the deformation's total ([`MotionScale`]). For two labels `A`, `B`
//! the map is
//! `d_v = mean over A of m_v - mean over B of m_v`: positive where `A` moves more, negative
//! where `B` does. The p-value is two-sided, from random relabellings that keep the group
//! sizes: `p_v = (1 + #{|d_v(perm)| >= |d_v|}) / (1 + P)`, then Benjamini-Hochberg at `alpha`.

use rayon::prelude::*;

use super::{benjamini_hochberg, label_pairs, permutation_p_values, LocalizeError, LocalizeOptions};
use crate::contribution::{path_contributions, ContributionError};
use qcshape::mesh::geometry::{dot, sub, vertex_areas, vertex_normals};
use qcshape::mesh::Topology;
use qcshape::metric::Metric;
use qcshape::similarity::Pose;

/// How a deformation's motion at a vertex is measured (module docs).
#[derive(Clone, Copy, Default)]
pub enum MotionMeasure<'m> {
    /// Normal excursion `m_v = A_v sum_k |n_v(P_k) . (P_{k+1,v} - P_{k,v})|`: the motion
    /// along the surface normal (into or out of the shape; for a ventricle, the radial wall
    /// motion), times the vertex's area `A_v` on `P_0` (the common base, so the same weight
    /// for every deformation). Units: length^3 of the scaled poses. Tangential sliding, which
    /// changes no shape, does not count.
    #[default]
    Normal,
    /// The metric's per-vertex length split of every step `P_k -> P_{k+1}`
    /// ([`crate::contribution::path_contributions`] on the two poses; quasi-conformal weights
    /// from the step's poses), summed over the steps (normalized length units).
    Metric(&'m dyn Metric),
}

impl<'m> MotionMeasure<'m> {
    /// The names [`Self::parse`] accepts (the CLI's `--motion`, Python's `measure=`).
    pub const NAMES: [&'static str; 2] = ["normal", "metric"];

    /// The measure named `name` (`normal` or `metric`, the latter with `metric`'s split).
    pub fn parse(name: &str, metric: &'m dyn Metric) -> Result<MotionMeasure<'m>, LocalizeError> {
        match name {
            "normal" => Ok(MotionMeasure::Normal),
            "metric" => Ok(MotionMeasure::Metric(metric)),
            other => Err(LocalizeError::UnknownName {
                name: other.to_string(),
                expected: &Self::NAMES,
            }),
        }
    }
}

impl std::fmt::Debug for MotionMeasure<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MotionMeasure::Normal => f.write_str("Normal"),
            MotionMeasure::Metric(m) => write!(f, "Metric({})", m.name()),
        }
    }
}

/// Whether motion maps are used as they are or as each deformation's shares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MotionScale {
    /// `m_v` as measured.
    #[default]
    Absolute,
    /// `m_v / sum_u m_u`: where a deformation moves, whatever its overall amount of motion
    /// (a group that moves less everywhere then only shows where it moves less than its own
    /// average).
    Share,
}

impl MotionScale {
    /// The names [`str::parse`] accepts (the CLI's `--motion-scale`, Python's `scale=`).
    pub const NAMES: [&'static str; 2] = ["absolute", "share"];
}

impl std::str::FromStr for MotionScale {
    type Err = LocalizeError;

    /// `absolute` or `share`.
    fn from_str(name: &str) -> Result<Self, LocalizeError> {
        match name {
            "absolute" => Ok(MotionScale::Absolute),
            "share" => Ok(MotionScale::Share),
            other => Err(LocalizeError::UnknownName {
                name: other.to_string(),
                expected: &Self::NAMES,
            }),
        }
    }
}

/// Per-vertex motion `m_v` (module docs) of every deformation (each #poses x #V x 3, at least
/// 2 poses, already scaled by the common factor) on `topology`, measured by `measure` and
/// scaled by `scale`: #deformations x #V. Deformations in parallel, each computed alone
/// (deterministic).
pub fn motion_maps(
    measure: MotionMeasure,
    scale: MotionScale,
    topology: &Topology,
    deformations: &[Vec<Pose>],
) -> Result<Vec<Vec<f64>>, LocalizeError> {
    deformations
        .par_iter()
        .enumerate()
        .map(|(deformation, poses)| {
            let nv = topology.n_vertices();
            let fail = |error| LocalizeError::Motion { deformation, error };
            if poses.len() < 2 {
                return Err(fail(ContributionError::TooFewPoses(poses.len())));
            }
            if let Some((pose, p)) = poses.iter().enumerate().find(|(_, p)| p.len() != nv) {
                return Err(fail(ContributionError::VertexCount {
                    pose,
                    expected: nv,
                    got: p.len(),
                }));
            }
            let mut m = vec![0.0; nv];
            match measure {
                MotionMeasure::Normal => {
                    let areas = vertex_areas(topology, &poses[0]);
                    for step in poses.windows(2) {
                        let n = vertex_normals(topology, &step[0]);
                        for v in 0..nv {
                            let d = sub(step[1][v], step[0][v]);
                            m[v] += dot(n[v], d).abs() * areas[v];
                        }
                    }
                }
                MotionMeasure::Metric(metric) => {
                    for step in poses.windows(2) {
                        let c = path_contributions(metric, topology, step, 1.0).map_err(fail)?;
                        m.iter_mut().zip(&c.length).for_each(|(t, x)| *t += x);
                    }
                }
            }
            if scale == MotionScale::Share {
                let total: f64 = m.iter().sum();
                if total > 0.0 {
                    m.iter_mut().for_each(|x| *x /= total);
                }
            }
            Ok(m)
        })
        .collect()
}

/// The signed motion contrast of two labels (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct MotionContrast {
    /// First label.
    pub a: String,
    /// Second label.
    pub b: String,
    /// Mean motion of `a`'s deformations per vertex (#V, normalized length units).
    pub mean_a: Vec<f64>,
    /// Mean motion of `b`'s deformations per vertex (#V).
    pub mean_b: Vec<f64>,
    /// `mean_a - mean_b` (#V): positive where `a` moves more.
    pub difference: Vec<f64>,
    /// Two-sided permutation p-values (#V).
    pub p_value: Vec<f64>,
    /// Benjamini-Hochberg decisions at [`LocalizeOptions::alpha`] (#V).
    pub significant: Vec<bool>,
}

/// Mean of `motion[members[k]]` over the members with `pick(k)` (#V; zeros for none).
fn group_mean(motion: &[Vec<f64>], members: &[usize], pick: impl Fn(usize) -> bool) -> Vec<f64> {
    let nv = motion.first().map_or(0, Vec::len);
    let mut sum = vec![0.0; nv];
    let mut count = 0usize;
    for (k, &i) in members.iter().enumerate() {
        if pick(k) {
            count += 1;
            sum.iter_mut().zip(&motion[i]).for_each(|(s, x)| *s += x);
        }
    }
    if count > 0 {
        sum.iter_mut().for_each(|s| *s /= count as f64);
    }
    sum
}

/// The signed motion contrast of every pair of distinct labels (in order of first
/// appearance); `motion` from [`motion_maps`], `labels` one per deformation.
pub fn motion_contrasts(
    motion: &[Vec<f64>],
    labels: &[String],
    opts: &LocalizeOptions,
) -> Result<Vec<MotionContrast>, LocalizeError> {
    let difference = |members: &[usize], in_a: &[bool]| -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let ma = group_mean(motion, members, |k| in_a[k]);
        let mb = group_mean(motion, members, |k| !in_a[k]);
        let d = ma.iter().zip(&mb).map(|(a, b)| a - b).collect();
        (ma, mb, d)
    };
    let mut out = Vec::new();
    for lp in label_pairs(labels, motion.len(), opts)? {
        let (mean_a, mean_b, d) = difference(&lp.members, &lp.in_a);
        let observed: Vec<f64> = d.iter().map(|x| x.abs()).collect();
        let p_value = permutation_p_values(
            &lp.in_a,
            opts,
            lp.stream,
            &observed,
            |s, o| s >= o,
            |perm| difference(&lp.members, perm).2.iter().map(|x| x.abs()).collect(),
        );
        let significant = benjamini_hochberg(&p_value, opts.alpha);
        out.push(MotionContrast {
            a: lp.a.clone(),
            b: lp.b.clone(),
            mean_a,
            mean_b,
            difference: d,
            p_value,
            significant,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use qcshape::metric::{MetricKind, MetricSpec};

    #[test]
    fn measure_and_scale_names_parse_and_bad_names_are_input_errors() {
        let metric = MetricSpec::previous(MetricKind::L2).build(&qcshape::metric::Calibration::RAW);
        assert!(matches!(
            MotionMeasure::parse("normal", metric.as_ref()),
            Ok(MotionMeasure::Normal)
        ));
        assert!(matches!(
            MotionMeasure::parse("metric", metric.as_ref()),
            Ok(MotionMeasure::Metric(_))
        ));
        for name in MotionMeasure::NAMES {
            assert!(MotionMeasure::parse(name, metric.as_ref()).is_ok(), "{name}");
        }
        let e = MotionMeasure::parse("radial", metric.as_ref()).unwrap_err();
        assert_eq!(e.to_string(), "expected 'normal' or 'metric', got \"radial\"");
        assert_eq!("absolute".parse::<MotionScale>().unwrap(), MotionScale::Absolute);
        assert_eq!("share".parse::<MotionScale>().unwrap(), MotionScale::Share);
        assert_eq!(
            MotionScale::NAMES.map(|n| n.parse::<MotionScale>().is_ok()),
            [true; 2]
        );
        assert!(matches!(
            "relative".parse::<MotionScale>(),
            Err(LocalizeError::UnknownName { .. })
        ));
    }

    /// Two groups of 5 deformations of a sphere: in group `a` the cap `z > 0.5` bulges out and
    /// back (amplitude 0.2), in group `b` by only 0.05; the rest of the sphere breathes by
    /// the same 2 % in both. The map is positive on the cap (a moves more there), near zero
    /// elsewhere, and the cap is what is significant.
    #[test]
    fn a_cap_that_moves_more_in_one_group_is_found_with_its_sign() {
        let s = qcshape::synth::icosphere(2);
        let cap: Vec<bool> = s.positions.iter().map(|p| p[2] > 0.5).collect();
        let deformation = |amp: f64, jitter: f64| -> Vec<Pose> {
            [0.0, 1.0, 0.0]
                .iter()
                .map(|&t| {
                    s.positions
                        .iter()
                        .zip(&cap)
                        .map(|(p, &c)| {
                            let f =
                                1.0 + 0.02 * t + if c { amp * t * (p[2] - 0.5) } else { 0.0 } + jitter * t;
                            p.map(|x| x * f)
                        })
                        .collect()
                })
                .collect()
        };
        let mut defs = Vec::new();
        let mut labels = Vec::new();
        for k in 0..10 {
            let jitter = 0.002 * (k % 5) as f64;
            defs.push(deformation(if k < 5 { 0.4 } else { 0.1 }, jitter));
            labels.push(if k < 5 { "a" } else { "b" }.to_string());
        }
        // (by the metric?, scale, metric kind; the normal excursion uses no metric).
        let variants = [
            (false, MotionScale::Absolute, MetricKind::L2),
            (false, MotionScale::Share, MetricKind::L2),
            (true, MotionScale::Absolute, MetricKind::L2),
            (true, MotionScale::Absolute, MetricKind::QuasiConformal),
            (true, MotionScale::Share, MetricKind::QuasiConformal),
        ];
        for (by_metric, scale, kind) in variants {
            let metric = MetricSpec::previous(kind).build(&qcshape::metric::Calibration::RAW);
            let measure = if by_metric {
                MotionMeasure::Metric(metric.as_ref())
            } else {
                MotionMeasure::Normal
            };
            let motion = motion_maps(measure, scale, &s.topology, &defs).unwrap();
            let opts = LocalizeOptions {
                permutations: 199,
                seed: 3,
                alpha: 0.05,
            };
            let c = &motion_contrasts(&motion, &labels, &opts).unwrap()[0];
            let positive: Vec<f64> = c.difference.iter().map(|d| d.max(0.0)).collect();
            let share = crate::contribution::mass_fraction(&positive, &cap);
            assert!(share > 0.9, "{measure:?} {scale:?} {kind:?}: cap share {share}");
            let sig_cap = c.significant.iter().zip(&cap).filter(|(&g, &c)| g && c).count();
            assert!(sig_cap > 0, "{kind:?}: nothing significant on the cap");
            // The group means are what the difference is made of.
            for v in 0..cap.len() {
                assert!((c.mean_a[v] - c.mean_b[v] - c.difference[v]).abs() < 1e-15);
            }
            // Swapping the labels flips the sign.
            let swapped: Vec<String> = labels.iter().rev().cloned().collect();
            let motion_rev: Vec<Vec<f64>> = motion.iter().rev().cloned().collect();
            let r = &motion_contrasts(&motion_rev, &swapped, &opts).unwrap()[0];
            assert_eq!(r.a, "b");
            for v in 0..cap.len() {
                assert!((r.difference[v] + c.difference[v]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_deformation_with_one_pose_or_too_few_vertices_is_an_error() {
        let s = qcshape::synth::icosphere(1);
        let metric = MetricSpec::previous(MetricKind::L2).build(&qcshape::metric::Calibration::RAW);
        let one = [vec![s.positions.clone()]];
        for measure in [MotionMeasure::Normal, MotionMeasure::Metric(metric.as_ref())] {
            let e = motion_maps(measure, MotionScale::Absolute, &s.topology, &one).unwrap_err();
            assert!(e.to_string().contains("at least 2 poses"), "{e}");
        }
        let short = [vec![s.positions.clone(), s.positions[1..].to_vec()]];
        let e = motion_maps(MotionMeasure::Normal, MotionScale::Absolute, &s.topology, &short).unwrap_err();
        assert!(e.to_string().contains("vertices"), "{e}");
    }
}
