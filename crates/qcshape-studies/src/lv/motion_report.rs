//! The LV report's map of where the two groups move differently: the signed normal-motion
//! contrast of [`crate::localize::motion_contrasts`] on the transferred cycles, rendered on the base
//! mesh, with the phantom's abnormal region outlined and its share of the map when known
//! (docs/maps.md, "Signed motion maps").

use std::fmt::Write as _;
use std::path::Path;

use super::study::{Analysis, StudyError};
use crate::localize::{
    motion_contrasts, motion_maps, region_share, write_map, LocalizeOptions, MotionMeasure, MotionScale,
    VertexMap,
};
use crate::render::RenderOptions;
use qcshape::io::Field;

/// Writes `OUT/motion_map.csv` (`vertex,difference,p_value,significant`), `motion_map.vtk`
/// (the same as point data plus both group means) and `motion_map.png`, and returns the
/// report's section. The map is `mean over negative of m_v - mean over positive of m_v`
/// (`m_v` the normal excursion of the vertex over the cycle times its area on the base, in
/// normalized length^3): red where the `positive` class moves less along the normal
/// (hypokinetic), blue where it moves more. p-values: 999 relabellings seeded by `seed`,
/// Benjamini-Hochberg at 0.05. `region` (#V, the phantom's abnormal region) is outlined and
/// its share of the red mass reported.
pub fn motion_section(
    out: &Path,
    main: &Analysis,
    labels: &[String],
    positive: &str,
    region: Option<&[bool]>,
    seed: u64,
) -> Result<String, StudyError> {
    let p = &main.prepared;
    let opts = LocalizeOptions {
        seed,
        ..Default::default()
    };
    let m = motion_maps(
        MotionMeasure::Normal,
        MotionScale::Absolute,
        &p.topology,
        &p.scaled(),
    )?;
    let Some(c) = motion_contrasts(&m, labels, &opts)?.into_iter().next() else {
        return Ok(String::new());
    };
    // Orient it: negative class minus positive class.
    let flip = c.a == positive;
    let sign = if flip { -1.0 } else { 1.0 };
    let (neg, pos) = if flip { (&c.b, &c.a) } else { (&c.a, &c.b) };
    let (mean_neg, mean_pos) = if flip {
        (&c.mean_b, &c.mean_a)
    } else {
        (&c.mean_a, &c.mean_b)
    };
    let d: Vec<f64> = c.difference.iter().map(|x| sign * x).collect();
    let base = &p.transferred[0][0];
    let faces = p.topology.faces();
    let map = VertexMap {
        name: "difference",
        values: &d,
        p_value: &c.p_value,
        significant: &c.significant,
    };
    let n_sig = map.n_significant();
    let picture = RenderOptions {
        title: format!(
            "Normal wall motion, {neg} minus {pos}; {n_sig} of {} vertices significant (FDR 0.05)",
            d.len()
        ),
        label: format!(
            "red: {pos} moves less, blue: {pos} moves more{}{}",
            if n_sig > 0 { "; grey: not significant" } else { "" },
            if region.is_some() {
                "; black line: abnormal region"
            } else {
                ""
            }
        ),
        outline: region.map(<[bool]>::to_vec),
        ..Default::default()
    };
    write_map(
        out,
        "motion_map",
        base,
        faces,
        &map,
        &[
            Field::scalar(&format!("mean_{neg}"), mean_neg),
            Field::scalar(&format!("mean_{pos}"), mean_pos),
        ],
        &["vtk"],
        picture,
    )?;

    let mut md = String::from("## Where the groups move differently\n\n");
    writeln!(
        md,
        "Each subject's motion per vertex: how far the vertex moves along the surface normal over \
         the transferred cycle (sum of |normal . step| over the poses), times its area on the base \
         (mean-edge units). The map is the mean of the {neg} subjects minus the mean of the {pos} \
         subjects: red where {pos} moves less (hypokinetic), blue where it moves more. Two-sided \
         p-values from 999 relabellings (seed {seed}), Benjamini-Hochberg at 0.05: {n_sig} of {} \
         vertices significant. The similarity itself (eq. 13) does not say where: this map does \
         (`qcshape localize` gives it, and the unsigned similarity split, for any labelled data \
         set).\n",
        d.len()
    )?;
    if let Some(r) = region {
        let share = region_share(&p.topology, base, &d, &c.significant, r);
        // The positive mass is the red part of the map.
        writeln!(md, "The phantom's abnormal region (black line), {share}.\n")?;
    }
    writeln!(
        md,
        "![Signed normal-motion map on the base mesh, six views](motion_map.png)\n\nFiles: \
         `motion_map.csv`, `motion_map.vtk` (ParaView: difference, p_value, significant and both \
         group means).\n"
    )?;
    Ok(md)
}
