//! `qcshape localize` as one library call: a labelled data set prepared as for the similarity
//! (eq. 13), the per-vertex similarity split of every pair, the label contrasts and the signed
//! motion contrasts (module docs of [`super`]); plus the names and rows of its output files.

use std::fmt::Write as _;

use thiserror::Error;

use super::{
    contrasts, motion_contrasts, motion_maps, pair_maps, Contrast, LocalizeError, LocalizeOptions,
    MotionContrast, MotionMeasure, MotionScale, PairMaps, RegionShare,
};
use qcshape::dataset::Deformation;
use qcshape::geodesic::{GeodesicError, GeodesicSolver};
use qcshape::similarity::{prepare, PipelineError, PipelineOptions, Prepared};

/// Why [`localize`] failed.
#[derive(Debug, Error)]
pub enum LocalizeStudyError {
    /// A deformation has no label.
    #[error("deformation {0:?} has no label: localize needs a labelled data set")]
    Unlabelled(String),
    /// Smoothing, alignment, interpolation or transfer failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The geodesic solver cannot be built.
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// A split, contrast or motion map failed.
    #[error(transparent)]
    Localize(#[from] LocalizeError),
}

/// Everything `qcshape localize` writes.
#[derive(Debug)]
pub struct Localization {
    /// The data set interpolated and transferred to one base (`transferred[0][0]` is the base
    /// mesh the maps live on, #V x 3, input units).
    pub prepared: Prepared,
    /// The per-vertex similarity split of every pair.
    pub maps: PairMaps,
    /// One contrast per pair of labels.
    pub contrasts: Vec<Contrast>,
    /// One signed motion contrast per pair of labels.
    pub motion: Vec<MotionContrast>,
    /// The metric's name (`isometric`, for the maps' titles; the full description with its
    /// settings is [`qcshape::metric::MetricSpec::label`]).
    pub metric_name: String,
}

/// The label of every deformation (non-empty), in order.
pub fn group_labels(defs: &[Deformation]) -> Result<Vec<String>, LocalizeStudyError> {
    defs.iter()
        .map(|d| match &d.label {
            Some(l) if !l.is_empty() => Ok(l.clone()),
            _ => Err(LocalizeStudyError::Unlabelled(d.name.clone())),
        })
        .collect()
}

/// Prepares `defs` with `opts` ([`prepare`]), splits every pair's similarity per vertex
/// ([`pair_maps`]), contrasts the groups of `labels` ([`contrasts`]) and their motion maps
/// measured by `motion` (`normal` or `metric`, [`MotionMeasure::parse`]) at `scale`
/// ([`motion_contrasts`]). Runs in the current rayon pool.
pub fn localize(
    defs: &[Deformation],
    labels: &[String],
    opts: &PipelineOptions,
    lopts: &LocalizeOptions,
    motion: &str,
    scale: MotionScale,
) -> Result<Localization, LocalizeStudyError> {
    let prepared = prepare(defs, opts, &|_| {})?;
    let metric = prepared.metric(&opts.metric);
    let solver = GeodesicSolver::new(metric.as_ref(), prepared.topology.clone(), opts.geodesic.clone())?;
    let scaled = prepared.scaled();
    let maps = pair_maps(&solver, &scaled)?;
    let result = contrasts(&maps, labels, lopts)?;
    let measure = MotionMeasure::parse(motion, metric.as_ref())?;
    let m = motion_maps(measure, scale, &prepared.topology, &scaled)?;
    let motion = motion_contrasts(&m, labels, lopts)?;
    Ok(Localization {
        metric_name: opts.metric.kind.label().to_string(),
        prepared,
        maps,
        contrasts: result,
        motion,
    })
}

/// What a motion map measures, for titles: `normal excursion` or the metric's length, with
/// `, shares` for [`MotionScale::Share`].
pub fn motion_title(motion: &str, scale: MotionScale, metric_name: &str) -> String {
    let what = match motion {
        "metric" => format!("{metric_name} length"),
        _ => "normal excursion".to_string(),
    };
    match scale {
        MotionScale::Share => format!("{what}, shares"),
        MotionScale::Absolute => what,
    }
}

/// A file name part for a label: letters, digits, `-`, `_` kept, the rest `_`.
pub fn file_part(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || matches!(c, '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if t.is_empty() {
        "_".into()
    } else {
        t
    }
}

/// The header of OUT/region_summary.csv.
pub const REGION_SUMMARY_HEADER: &str =
    "map,a,b,region_vertices,vertices,area_share,positive_mass_share,ratio,significant_in_region,significant\n";

/// Appends the region summary row of a map (`contrast` or `motion`) of labels `a`, `b` over
/// `vertices` vertices to `csv`.
pub fn push_region_row(csv: &mut String, map: &str, a: &str, b: &str, vertices: usize, share: &RegionShare) {
    writeln!(
        csv,
        "{map},{a},{b},{},{vertices},{:.6},{:.6},{:.4},{},{}",
        share.vertices,
        share.area_share,
        share.positive_mass_share,
        share.ratio,
        share.significant_in_region,
        share.significant
    )
    .expect("writing to a String cannot fail");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_titles() {
        assert_eq!(file_part("a b/c"), "a_b_c");
        assert_eq!(file_part(""), "_");
        assert_eq!(
            motion_title("normal", MotionScale::Absolute, "M"),
            "normal excursion"
        );
        assert_eq!(
            motion_title("metric", MotionScale::Share, "M"),
            "M length, shares"
        );
    }

    #[test]
    fn a_region_row_has_every_column() {
        let share = RegionShare {
            vertices: 3,
            area_share: 0.25,
            positive_mass_share: 0.5,
            ratio: 2.0,
            significant_in_region: 1,
            significant: 2,
        };
        let mut csv = String::from(REGION_SUMMARY_HEADER);
        push_region_row(&mut csv, "contrast", "a", "b", 10, &share);
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows[1], "contrast,a,b,3,10,0.250000,0.500000,2.0000,1,2");
        assert_eq!(rows[0].split(',').count(), rows[1].split(',').count());
    }

    #[test]
    fn an_unlabelled_deformation_is_named() {
        let shape = qcshape::synth::icosphere(0);
        let d = Deformation {
            name: "d0".into(),
            label: None,
            topology: shape.topology,
            poses: vec![shape.positions],
            paths: Vec::new(),
            warnings: Vec::new(),
        };
        let e = group_labels(&[d]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "deformation \"d0\" has no label: localize needs a labelled data set"
        );
    }
}
