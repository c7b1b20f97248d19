//! The phantom's abnormal region, known by construction: each HCM subject's free-wall sector
//! of reduced, uneven circumferential strain ([`super::anatomy::LvModel::motion_at`]). It is
//! written by `qcshape lv phantom` as `abnormal.csv` (one row per subject, in material
//! coordinates: degrees from the septum landmark about the apex-to-base axis) and turned into
//! a per-vertex weight on a cohort's template mesh by [`region_weights`] (`qcshape lv run`
//! writes it as `meshes/abnormal_region.csv`, the `--region` file of `qcshape localize`).

use std::fmt::Write as _;
use std::path::Path;

use super::anatomy::sector_weight;
use super::cohort::{LayoutProblem, LvError};
use super::freewall::LvAxis;
use super::phantom::{Group, PhantomSubject};
use qcshape::io::write_atomically;

/// The file `qcshape lv phantom` writes beside `labels.csv`.
pub const ABNORMAL_NAME: &str = "abnormal.csv";
/// The per-vertex region file `qcshape lv run` writes beside the meshes' manifest.
pub const REGION_NAME: &str = "abnormal_region.csv";
/// The header of [`ABNORMAL_NAME`].
pub const ABNORMAL_HEADER: &str = "subject,label,centre_deg,width_deg,taper_deg,free_wall_motion";
/// Normalized heights above this (the valve-plane cap of the cavity surface) are outside the
/// region: the cap is not myocardium.
pub const MAX_HEIGHT: f64 = 0.95;

/// One subject's abnormal sector.
#[derive(Debug, Clone, PartialEq)]
pub struct AbnormalSector {
    /// Subject name.
    pub subject: String,
    /// `control` or `hcm`.
    pub label: String,
    /// Sector centre, degrees from the septum.
    pub centre_deg: f64,
    /// Sector width (degrees, cos² tapers of `taper_deg` on each side of the edges).
    pub width_deg: f64,
    /// Half-width of the tapers (degrees).
    pub taper_deg: f64,
    /// Factor of the circumferential strain in the sector (1: normal, controls).
    pub free_wall_motion: f64,
}

impl AbnormalSector {
    /// The sector of a generated subject.
    pub fn of(s: &PhantomSubject) -> AbnormalSector {
        AbnormalSector {
            subject: s.name.clone(),
            label: s.group.label().to_string(),
            centre_deg: s.model.free_wall_centre_deg,
            width_deg: s.model.free_wall_width_deg,
            taper_deg: super::anatomy::SECTOR_TAPER_DEG,
            free_wall_motion: s.model.free_wall_motion,
        }
    }

    /// Whether this subject's wall motion is abnormal (HCM).
    pub fn is_abnormal(&self) -> bool {
        self.label == Group::Hcm.label() && self.free_wall_motion < 1.0
    }
}

/// Writes `abnormal.csv` ([`ABNORMAL_HEADER`]), atomically.
pub fn write_abnormal(path: &Path, rows: &[AbnormalSector]) -> Result<(), LvError> {
    let mut s = format!("{ABNORMAL_HEADER}\n");
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:.4},{:.4},{:.1},{:.4}",
            r.subject, r.label, r.centre_deg, r.width_deg, r.taper_deg, r.free_wall_motion
        );
    }
    write_atomically(path, |w| w.write_all(s.as_bytes()))?;
    Ok(())
}

/// Reads `abnormal.csv`.
pub fn read_abnormal(path: &Path) -> Result<Vec<AbnormalSector>, LvError> {
    let bad = |problem: LayoutProblem| LvError::Layout {
        path: path.into(),
        problem,
    };
    let text = qcshape::limits::read_regular_text(path, qcshape::limits::MAX_TABLE_FILE_BYTES)
        .map_err(|e| bad(LayoutProblem::Read(e)))?;
    let mut lines = text.lines();
    if lines.next().map(str::trim) != Some(ABNORMAL_HEADER) {
        return Err(bad(LayoutProblem::Header(ABNORMAL_HEADER)));
    }
    let mut out = Vec::new();
    for (k, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let num = |i: usize| -> Result<f64, LvError> {
            f.get(i)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    bad(LayoutProblem::Field {
                        line: k + 2,
                        field: i + 1,
                    })
                })
        };
        if f.len() != 6 {
            return Err(bad(LayoutProblem::FieldCount {
                line: k + 2,
                found: f.len(),
            }));
        }
        out.push(AbnormalSector {
            subject: f[0].to_string(),
            label: f[1].to_string(),
            centre_deg: num(2)?,
            width_deg: num(3)?,
            taper_deg: num(4)?,
            free_wall_motion: num(5)?,
        });
    }
    Ok(out)
}

/// The abnormal weight (#V, in [0, 1]) of every vertex of `positions` (#V x 3, mm, a frame-0
/// surface in the coordinates of `axis`, built from the same subject's frame-0 apex,
/// base-centre and septum landmarks): the mean over the abnormal subjects of their sector
/// weight at the vertex's angle about the axis; 0 above [`MAX_HEIGHT`]. Vertices of a cohort
/// template correspond across subjects through the landmark splines, which fix the material
/// angle, so one weight per vertex serves the cohort. All zero without abnormal subjects.
pub fn region_weights(sectors: &[AbnormalSector], axis: &LvAxis, positions: &[[f64; 3]]) -> Vec<f64> {
    let ab: Vec<&AbnormalSector> = sectors.iter().filter(|s| s.is_abnormal()).collect();
    positions
        .iter()
        .map(|&p| {
            let (h, ang, _) = axis.cylindrical(p);
            if ab.is_empty() || h > MAX_HEIGHT {
                return 0.0;
            }
            ab.iter()
                .map(|s| sector_weight(s.centre_deg, s.width_deg, s.taper_deg, ang))
                .sum::<f64>()
                / ab.len() as f64
        })
        .collect()
}

/// Writes the per-vertex region file: `vertex,weight,region` (`region` = 1 where the weight is
/// at least 0.5), atomically.
pub fn write_region(path: &Path, weights: &[f64]) -> Result<(), LvError> {
    let mut s = String::from("vertex,weight,region\n");
    for (v, w) in weights.iter().enumerate() {
        let _ = writeln!(s, "{v},{w:.6},{}", u8::from(*w >= 0.5));
    }
    write_atomically(path, |w| w.write_all(s.as_bytes()))?;
    Ok(())
}

/// The region weights ([`region_weights`]) of a cohort template: `frame0` (#V x 3, mm) is
/// subject `template`'s frame-0 mesh, `dir` the cohort folder. `None` when the cohort has no
/// [`ABNORMAL_NAME`] (not a phantom).
pub fn cohort_region(dir: &Path, template: &str, frame0: &[[f64; 3]]) -> Result<Option<Vec<f64>>, LvError> {
    let file = dir.join(ABNORMAL_NAME);
    if !file.is_file() {
        return Ok(None);
    }
    let sectors = read_abnormal(&file)?;
    let (lm, path) = super::cohort::read_subject_landmarks(&dir.join(template))?;
    let get = |id: u32| {
        lm.get(0, id).ok_or_else(|| LvError::Layout {
            path: path.clone(),
            problem: LayoutProblem::MissingLandmark(id),
        })
    };
    use super::landmarks::{APEX, BASE_CENTRE, SEPTUM};
    let axis =
        LvAxis::new(get(APEX)?, get(BASE_CENTRE)?, get(SEPTUM)?).map_err(|error| LvError::FreeWall {
            path: path.clone(),
            error,
        })?;
    Ok(Some(region_weights(&sectors, &axis, frame0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sector(label: &str, centre: f64, width: f64) -> AbnormalSector {
        AbnormalSector {
            subject: "s".into(),
            label: label.into(),
            centre_deg: centre,
            width_deg: width,
            taper_deg: 15.0,
            free_wall_motion: if label == "hcm" { 0.5 } else { 1.0 },
        }
    }

    #[test]
    fn weights_follow_the_sector_and_round_trip() {
        let axis = LvAxis::new([0.0, 0.0, 0.0], [0.0, 0.0, 10.0], [1.0, 0.0, 5.0]).unwrap();
        let s = vec![sector("hcm", 180.0, 120.0), sector("control", 0.0, 120.0)];
        let at = |deg: f64, h: f64| {
            let a = deg.to_radians();
            [a.cos(), a.sin(), 10.0 * h]
        };
        let p = vec![
            at(180.0, 0.5),
            at(0.0, 0.5),
            at(90.0, 0.5),
            at(180.0, 0.99),
            at(-120.0, 0.5),
        ];
        let w = region_weights(&s, &axis, &p);
        assert_eq!(w[0], 1.0);
        assert_eq!(w[1], 0.0);
        assert_eq!(w[2], 0.0);
        assert_eq!(w[3], 0.0, "the cap is outside");
        assert!((w[4] - 0.5).abs() < 1e-9, "edge of the sector: {}", w[4]);
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join(ABNORMAL_NAME);
        write_abnormal(&f, &s).unwrap();
        assert_eq!(read_abnormal(&f).unwrap(), s);
        std::fs::write(&f, "subject,label\n").unwrap();
        assert!(read_abnormal(&f).is_err());
    }
}
