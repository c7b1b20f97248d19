//! Tables, figure and error maps of the interpolation experiment.

use std::path::{Path, PathBuf};

use super::{mean_sd, CaseError, ExperimentError, InterpolationReport, LeaveOneOutReport, Summary, BASELINE};
use crate::plot::{error_bars, BarGroup};
use qcshape::io::{heat_colors, write_atomically, write_mesh, VertexAttributes};

/// The paper's claim checked by [`InterpolationReport::claim`].
const CLAIM: &str = "quasi-conformal error below isometric for all eight deformations";

/// Outcome of comparing two methods type by type.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Types where the first method's mean error is below the second's.
    pub below: usize,
    /// Types compared.
    pub compared: usize,
    /// The other types: (type, first method's mean, second method's mean).
    pub exceptions: Vec<(String, f64, f64)>,
}

/// A number for a table: 3 significant digits ([`qcshape::numfmt::significant`]), and `0` for
/// an error at most `1e-12` mean edge lengths (an exact interpolation computed with rounding).
fn num(v: f64) -> String {
    if v.abs() <= 1e-12 {
        "0".into()
    } else {
        qcshape::numfmt::significant(v, 3)
    }
}

/// `name` with every character outside `[A-Za-z0-9._-]` replaced by `_`.
fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

fn csv_text(header: &[&str], rows: impl Iterator<Item = Vec<String>>) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    // Writing to memory cannot fail.
    w.write_record(header).expect("in-memory CSV");
    for r in rows {
        w.write_record(&r).expect("in-memory CSV");
    }
    String::from_utf8(w.into_inner().expect("in-memory CSV")).expect("UTF-8 fields")
}

fn summary_csv(summary: &[Summary]) -> String {
    csv_text(
        &[
            "type",
            "method",
            "n",
            "mean",
            "sd",
            "mean_abs",
            "sd_abs",
            "unconverged",
        ],
        summary.iter().map(|s| {
            vec![
                s.group.clone(),
                s.method.clone(),
                s.n.to_string(),
                s.mean.to_string(),
                s.sd.to_string(),
                s.mean_abs.to_string(),
                s.sd_abs.to_string(),
                s.unconverged.to_string(),
            ]
        }),
    )
}

fn cases_csv(cases: &[CaseError]) -> String {
    csv_text(
        &[
            "deformation",
            "type",
            "method",
            "pose",
            "mean",
            "rms",
            "max",
            "mean_abs",
            "mean_edge",
            "converged",
            "iterations",
            "seconds",
        ],
        cases.iter().map(|c| {
            vec![
                c.deformation.clone(),
                c.group.clone(),
                c.method.clone(),
                c.pose.to_string(),
                c.mean.to_string(),
                c.rms.to_string(),
                c.max.to_string(),
                c.mean_abs.to_string(),
                c.mean_edge.to_string(),
                c.converged.to_string(),
                c.iterations.to_string(),
                format!("{:.3}", c.seconds),
            ]
        }),
    )
}

fn write_text(path: &Path, text: &str) -> Result<(), ExperimentError> {
    write_atomically(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

fn create_dir(dir: &Path) -> Result<(), ExperimentError> {
    std::fs::create_dir_all(dir).map_err(|error| ExperimentError::CreateDir {
        path: dir.into(),
        error,
    })
}

/// Mean and SD over all cases of `method` (relative errors).
fn overall(cases: &[CaseError], method: &str) -> (f64, f64) {
    mean_sd(
        &cases
            .iter()
            .filter(|c| c.method == method)
            .map(|c| c.mean)
            .collect::<Vec<_>>(),
    )
}

fn unconverged_note(cases: &[CaseError]) -> String {
    let solved: Vec<&CaseError> = cases.iter().filter(|c| c.method != BASELINE).collect();
    let bad = solved.iter().filter(|c| !c.converged).count();
    if bad == 0 {
        format!("All {} geodesic interpolations converged.\n", solved.len())
    } else {
        format!(
            "{bad} of {} geodesic interpolations stopped before converging (their best path is used).\n",
            solved.len()
        )
    }
}

impl InterpolationReport {
    /// The summary row of (type, method), if any.
    pub fn get(&self, group: &str, method: &str) -> Option<&Summary> {
        self.summary
            .iter()
            .find(|s| s.group == group && s.method == method)
    }

    /// Compares the mean errors of methods `a` and `b` type by type (`None` if either method
    /// is not in the report).
    pub fn compare(&self, a: &str, b: &str) -> Option<Comparison> {
        if !(self.methods.iter().any(|m| m == a) && self.methods.iter().any(|m| m == b)) {
            return None;
        }
        let mut c = Comparison {
            below: 0,
            compared: 0,
            exceptions: Vec::new(),
        };
        for g in &self.groups {
            if let (Some(x), Some(y)) = (self.get(g, a), self.get(g, b)) {
                c.compared += 1;
                if x.mean < y.mean {
                    c.below += 1;
                } else {
                    c.exceptions.push((g.clone(), x.mean, y.mean));
                }
            }
        }
        Some(c)
    }

    /// The paper's claim (quasi-conformal below isometric for every type), checked against the
    /// numbers: one sentence saying confirmed or refuted.
    pub fn claim(&self) -> String {
        let Some(c) = self.compare("quasi-conformal", "isometric") else {
            return format!("Paper's claim ({CLAIM}): not checked (needs both metrics).");
        };
        let verdict = if c.below == c.compared && c.compared == 8 {
            "confirmed".to_string()
        } else if c.below == c.compared {
            format!("holds for all {} types here (the paper has eight)", c.compared)
        } else {
            "refuted".to_string()
        };
        let mut s = format!(
            "Paper's claim ({CLAIM}): quasi-conformal's mean error is below isometric's for {} of {} \
             deformation types: **{verdict}**.",
            c.below, c.compared
        );
        if !c.exceptions.is_empty() {
            let list: Vec<String> = c
                .exceptions
                .iter()
                .map(|(g, x, y)| format!("{g} ({} vs {})", num(*x), num(*y)))
                .collect();
            s.push_str(&format!(" Not below for: {}.", list.join(", ")));
        }
        s
    }

    /// The summary as CSV: `type,method,n,mean,sd,mean_abs,sd_abs,unconverged`, one row per
    /// (type, method) (metrics and the baseline); `mean`/`sd` are relative to the mean edge
    /// length, `*_abs` in input units.
    pub fn to_csv(&self) -> String {
        summary_csv(&self.summary)
    }

    /// Every case as CSV (`deformation,type,method,pose,mean,rms,max,mean_abs,mean_edge,
    /// converged,iterations,seconds`).
    pub fn cases_csv(&self) -> String {
        cases_csv(&self.cases)
    }

    /// A Markdown table: rows = deformation types (and all cases together), columns = methods
    /// as `mean ± sd` of the relative error, followed by the paper's claim checked and the bar
    /// chart (`interpolation.png`, embedded).
    pub fn to_markdown(&self) -> String {
        self.to_markdown_in("")
    }

    /// [`InterpolationReport::to_markdown`] for a Markdown file in another folder: the figure
    /// is linked as `{prefix}interpolation.png` (e.g. prefix `fig4/`).
    pub fn to_markdown_in(&self, prefix: &str) -> String {
        use qcshape::numfmt::count;
        let mut s =
            String::from("## Interpolation error per deformation type (paper section 3.1, Fig. 4c)\n\n");
        s.push_str(&format!(
            "The middle pose of each deformation is interpolated from its first and last pose ({}, \
             {}). Error of a case: mean over vertices of \
             |predicted - true| in mean-edge units (divided by the mean edge length of the true \
             middle pose). Cells: mean ± sample SD over the n deformations of each type \
             (0: exact up to rounding, at most 1e-12); \
             `{BASELINE}` is the average of the first and last pose.\n\n",
            count(self.insert, "inserted pose", "inserted poses"),
            count(self.levels, "spatial level", "spatial levels")
        ));
        s.push_str("| type | n |");
        for m in &self.methods {
            s.push_str(&format!(" {m} |"));
        }
        s.push_str("\n|---|---|");
        s.push_str(&"---|".repeat(self.methods.len()));
        s.push('\n');
        for g in &self.groups {
            let n = self
                .cases
                .iter()
                .filter(|c| &c.group == g && c.method == BASELINE)
                .count();
            s.push_str(&format!("| {g} | {n} |"));
            for m in &self.methods {
                match self.get(g, m) {
                    Some(r) => s.push_str(&format!(" {} ± {} |", num(r.mean), num(r.sd))),
                    None => s.push_str(" - |"),
                }
            }
            s.push('\n');
        }
        let n = self.cases.iter().filter(|c| c.method == BASELINE).count();
        s.push_str(&format!("| **all** | {n} |"));
        for m in &self.methods {
            let (mean, sd) = overall(&self.cases, m);
            s.push_str(&format!(" {} ± {} |", num(mean), num(sd)));
        }
        s.push_str("\n\n");
        s.push_str(&self.claim());
        s.push_str("\n\n");
        s.push_str(&format!(
            "![Fig. 4c: interpolation error of the middle pose per deformation type and metric; \
             bars: mean, whiskers: ± 1 SD, the lower one clipped at 0]({prefix}interpolation.png)\n\n"
        ));
        s.push_str(&unconverged_note(&self.cases));
        if !self.skipped.is_empty() {
            s.push_str(&format!("\nSkipped: {}.\n", self.skipped.join("; ")));
        }
        s
    }

    /// Writes into `dir` (created if needed, files atomically): `interpolation.csv`
    /// ([`InterpolationReport::to_csv`]), `interpolation_cases.csv`, `interpolation.md`, the
    /// bars of Fig. 4c as `interpolation.svg` and `interpolation.png` (groups = types, bars =
    /// methods, mean ± SD), and per error map `interpolation_<deformation>_<method>.ply` (the
    /// predicted pose with the relative error as the scalar `error` and as viridis colours on
    /// one scale, 0 to the largest error of all maps) plus `interpolation_<deformation>_truth.ply`.
    /// Returns the paths written.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, ExperimentError> {
        create_dir(dir)?;
        let mut out = Vec::new();
        for (name, text) in [
            ("interpolation.csv", self.to_csv()),
            ("interpolation_cases.csv", self.cases_csv()),
            ("interpolation.md", self.to_markdown()),
        ] {
            let p = dir.join(name);
            write_text(&p, &text)?;
            out.push(p);
        }
        let groups: Vec<BarGroup> = self
            .groups
            .iter()
            .map(|g| {
                let bars = self
                    .methods
                    .iter()
                    .filter_map(|m| self.get(g, m).map(|r| (m.clone(), r.mean, r.sd)))
                    .collect();
                (g.clone(), bars)
            })
            .collect();
        for ext in ["svg", "png"] {
            let p = dir.join(format!("interpolation.{ext}"));
            error_bars(
                &p,
                &groups,
                "Interpolation error of the middle pose",
                "mean error (mean-edge units)",
            )?;
            out.push(p);
        }
        let vmax = self
            .maps
            .iter()
            .flat_map(|m| m.errors.iter().copied())
            .fold(0.0, f64::max);
        let mut truths: Vec<&str> = Vec::new();
        for m in &self.maps {
            let base = format!("interpolation_{}", file_safe(&m.deformation));
            let colors = heat_colors(&m.errors, 0.0, vmax);
            let p = dir.join(format!("{base}_{}.ply", file_safe(&m.method)));
            let attrs = VertexAttributes {
                scalar: Some(("error", &m.errors)),
                colors: Some(&colors),
            };
            write_mesh(&p, &m.predicted, m.topology.faces(), &attrs)?;
            out.push(p);
            if !truths.contains(&m.deformation.as_str()) {
                truths.push(&m.deformation);
                let p = dir.join(format!("{base}_truth.ply"));
                write_mesh(&p, &m.truth, m.topology.faces(), &VertexAttributes::default())?;
                out.push(p);
            }
        }
        Ok(out)
    }
}

impl LeaveOneOutReport {
    /// One row per method: `type,method,n,mean,sd,mean_abs,sd_abs,unconverged` (type = the
    /// sequence name; `mean`/`sd` relative to the mean edge length, `*_abs` in input units).
    pub fn to_csv(&self) -> String {
        summary_csv(&self.summary)
    }

    /// Every (frame, method) as CSV, as [`InterpolationReport::cases_csv`].
    pub fn cases_csv(&self) -> String {
        cases_csv(&self.cases)
    }

    /// A Markdown table: rows = methods, columns = the mean error in input units and relative
    /// to the mean edge length (mean ± SD over the frames).
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "## Leave-one-frame-out interpolation error: {} ({} vertices, {} poses)\n\n",
            self.sequence, self.vertices, self.poses
        );
        let frames: Vec<String> = self.frames.iter().map(|k| k.to_string()).collect();
        s.push_str(&format!(
            "Frame k is interpolated from frames k - 1 and k + 1 (frames {}). Cells: mean ± sample \
             SD over the frames of the per-frame mean vertex error.\n\n",
            frames.join(", ")
        ));
        s.push_str("| method | error (input units) | error / mean edge length |\n|---|---|---|\n");
        for r in &self.summary {
            s.push_str(&format!(
                "| {} | {} ± {} | {} ± {} |\n",
                r.method,
                num(r.mean_abs),
                num(r.sd_abs),
                num(r.mean),
                num(r.sd)
            ));
        }
        s.push('\n');
        s.push_str(&unconverged_note(&self.cases));
        s
    }

    /// Writes `leave_one_out.csv`, `leave_one_out_frames.csv` and `leave_one_out.md` into
    /// `dir` (created if needed). Returns the paths written.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, ExperimentError> {
        create_dir(dir)?;
        let mut out = Vec::new();
        for (name, text) in [
            ("leave_one_out.csv", self.to_csv()),
            ("leave_one_out_frames.csv", self.cases_csv()),
            ("leave_one_out.md", self.to_markdown()),
        ] {
            let p = dir.join(name);
            write_text(&p, &text)?;
            out.push(p);
        }
        Ok(out)
    }
}
