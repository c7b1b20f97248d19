//! The report of the deformation-transfer experiment: summaries, comparison with Euclidean
//! transfer, CSV, Markdown, figures and the Fig. 5 meshes.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{ExperimentError, FigureCase, TransferCase};
use crate::plot::{error_bars, BarGroup};
use qcshape::io::{heat_colors, write_atomically, write_mesh, IoError, VertexAttributes};
use qcshape::metric::MetricSpec;
use qcshape::synth::DeformationKind;
use qcshape::transport::Transport;
/// Mean and sample standard deviation of a set of values.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Stat {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (divisor n - 1; 0 for one value).
    pub sd: f64,
    /// Number of values.
    pub n: usize,
}

impl Stat {
    /// The statistics of `values` (`None` if empty).
    pub fn of(values: &[f64]) -> Option<Stat> {
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let sd = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        Some(Stat { mean, sd, n })
    }
}

/// A transport against Euclidean transfer, case by case (same kind and base).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Comparison {
    /// Cases where the transport's last-pose error is below Euclidean's.
    pub wins: usize,
    /// Cases compared.
    pub n: usize,
    /// Mean last-pose error of the transport (mean-edge units).
    pub mean: f64,
    /// Mean last-pose error of Euclidean transfer over the same cases.
    pub euclidean_mean: f64,
}

/// The experiment's results (see the [module docs](super)).
#[derive(Debug, Clone)]
pub struct TransferReport {
    /// The source shape's name.
    pub source: String,
    /// The bases' names.
    pub bases: Vec<String>,
    /// The deformations.
    pub kinds: Vec<DeformationKind>,
    /// The metrics.
    pub specs: Vec<MetricSpec>,
    /// Their labels (the metric's name, with `lambda` when two share a kind).
    pub metrics: Vec<String>,
    /// The transports.
    pub transports: Vec<Transport>,
    /// The times `t_0 .. t_K`.
    pub times: Vec<f64>,
    /// Vertices of the shapes.
    pub n_vertices: usize,
    /// Geodesic steps N (transport steps per segment).
    pub steps: usize,
    /// The common normalization factor (1 / mean edge length of the source).
    pub scale: f64,
    /// Every transfer.
    pub cases: Vec<TransferCase>,
    /// The Fig. 5 case.
    pub figure: FigureCase,
    /// Wall-clock seconds of the whole experiment.
    pub seconds: f64,
}

/// Which error of the last pose a summary uses (mean over vertices, mean-edge units).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// `|N_K - N*_K|` as it is ([`PoseError::mean`](super::PoseError::mean)).
    Raw,
    /// After the best rigid alignment of `N_K` onto `N*_K` ([`PoseError::mean_rigid`](super::PoseError::mean_rigid)).
    Rigid,
}

impl Measure {
    /// The case's last-pose error by this measure.
    pub fn of(self, case: &TransferCase) -> f64 {
        case.errors.last().map_or(0.0, |e| match self {
            Measure::Raw => e.mean,
            Measure::Rigid => e.mean_rigid,
        })
    }
}

impl TransferReport {
    /// The cases of `(metric, transport)`: for Euclidean transfer, the metric-free cases.
    pub fn cases_of(&self, metric: usize, transport: Transport) -> impl Iterator<Item = &TransferCase> {
        self.cases.iter().filter(move |c| {
            c.transport == transport && (transport == Transport::Translate || c.metric == Some(metric))
        })
    }

    /// Mean and SD over cases (of one `kind` if given) of `measure` at the last pose
    /// (mean-edge units); `None` if there are no such cases.
    pub fn summary(
        &self,
        metric: usize,
        transport: Transport,
        kind: Option<DeformationKind>,
        measure: Measure,
    ) -> Option<Stat> {
        let v: Vec<f64> = self
            .cases_of(metric, transport)
            .filter(|c| kind.is_none_or(|k| c.kind == k.name()))
            .map(|c| measure.of(c))
            .collect();
        Stat::of(&v)
    }

    /// `transport` with `metric` against Euclidean transfer, case by case (same kind and base)
    /// by `measure` at the last pose; `None` without Euclidean cases or cases of
    /// `(metric, transport)`.
    pub fn comparison(&self, metric: usize, transport: Transport, measure: Measure) -> Option<Comparison> {
        let euclid: HashMap<(&str, &str), f64> = self
            .cases_of(metric, Transport::Translate)
            .map(|c| ((c.kind.as_str(), c.base.as_str()), measure.of(c)))
            .collect();
        let pairs: Vec<(f64, f64)> = self
            .cases_of(metric, transport)
            .filter_map(|c| {
                euclid
                    .get(&(c.kind.as_str(), c.base.as_str()))
                    .map(|e| (measure.of(c), *e))
            })
            .collect();
        if pairs.is_empty() {
            return None;
        }
        let n = pairs.len();
        Some(Comparison {
            wins: pairs.iter().filter(|(a, e)| a < e).count(),
            n,
            mean: pairs.iter().map(|p| p.0).sum::<f64>() / n as f64,
            euclidean_mean: pairs.iter().map(|p| p.1).sum::<f64>() / n as f64,
        })
    }

    /// One row per transferred pose `k >= 1`: `kind, base, metric, lambda, transport, pose, t,
    /// mean_error, max_error, mean_error_radius, converged, seconds` (errors as in the
    /// [module docs](super); metric `none` for Euclidean transfer).
    pub fn to_csv(&self) -> String {
        let mut s = String::from(
            "kind,base,metric,lambda,transport,pose,t,mean_error,max_error,mean_error_radius,mean_error_rigid,converged,seconds\n",
        );
        for c in &self.cases {
            let (metric, lambda) = match c.metric {
                Some(m) => (self.metrics[m].as_str(), self.specs[m].lambda.to_string()),
                None => ("none", String::new()),
            };
            for (k, e) in c.errors.iter().enumerate() {
                let _ = writeln!(
                    s,
                    "{},{},{},{},{},{},{},{:.6e},{:.6e},{:.6e},{:.6e},{},{:.3}",
                    c.kind,
                    c.base,
                    metric,
                    lambda,
                    c.transport.label(),
                    k + 1,
                    e.t,
                    e.mean,
                    e.max,
                    e.mean_radius,
                    e.mean_rigid,
                    c.converged,
                    c.seconds
                );
            }
        }
        s
    }

    fn cell(stat: Option<Stat>) -> String {
        stat.map_or("-".into(), |s| format!("{:.3} ± {:.3}", s.mean, s.sd))
    }

    /// The report in Markdown: settings, the metric x transport table (mean ± SD over cases of
    /// the last pose's mean per-vertex error), one sentence per metric on parallel transport
    /// (and Schild's ladder) against Euclidean transfer, the same after the best rigid
    /// alignment ([`Measure::Rigid`]), a per-kind table and the two bar charts (embedded PNGs).
    pub fn to_markdown(&self) -> String {
        self.to_markdown_in("")
    }

    /// [`TransferReport::to_markdown`] for a Markdown file in another folder: the files of
    /// [`TransferReport::write`] are named as `{prefix}transfer.png`, `{prefix}fig5/` (e.g.
    /// prefix `fig5/` when the report was written to `fig5/`).
    pub fn to_markdown_in(&self, prefix: &str) -> String {
        let mut s = String::new();
        let n_cases = self.kinds.len() * self.bases.len();
        let kinds: Vec<&str> = self.kinds.iter().map(|k| k.name()).collect();
        let times: Vec<String> = self.times.iter().map(|t| format!("{t:.3}")).collect();
        let _ = writeln!(s, "# Deformation transfer (paper section 3.2, Fig. 5)\n");
        let _ = writeln!(
            s,
            "Each analytic deformation is applied to the {} ({} vertices) at t = {} and transferred to \
             each base; the result is compared with the same deformation applied to the base directly.",
            self.source,
            self.n_vertices,
            times.join(", ")
        );
        let _ = writeln!(
            s,
            "Kinds: {}. Bases: {}. {} cases. Geodesics: N = {} steps, in mean-edge units \
             (coordinates divided by {}, the mean edge length of the source).\n",
            kinds.join(", "),
            self.bases.join(", "),
            n_cases,
            self.steps,
            qcshape::numfmt::significant(1.0 / self.scale, 4)
        );
        let _ = writeln!(
            s,
            "Error: mean over vertices of |N_K - N*_K| in mean-edge units (divided by the mean edge \
             length of N*_K) at the last pose; \
             mean ± SD over the {n_cases} cases. Euclidean transfer does not depend on the metric.\n"
        );
        self.metric_table(&mut s, Measure::Raw);
        self.sentences(&mut s, Measure::Raw);
        let _ = writeln!(
            s,
            "\nAfter the best rigid alignment of N_K onto N*_K (rotation and translation, least \
             squares), i.e. the part of the error that is not a rigid motion of the whole pose:\n"
        );
        self.metric_table(&mut s, Measure::Rigid);
        self.sentences(&mut s, Measure::Rigid);
        let failed = self.cases.iter().filter(|c| !c.converged).count();
        if failed > 0 {
            let _ = writeln!(
                s,
                "\n{failed} of {} transfers had a geodesic that did not converge (see the CSV).",
                self.cases.len()
            );
        }
        let _ = writeln!(
            s,
            "\n## Per kind (mean ± SD over the {} bases)\n",
            self.bases.len()
        );
        let columns = self.columns();
        let _ = write!(s, "| kind |");
        for (name, _, _) in &columns {
            let _ = write!(s, " {name} |");
        }
        let _ = write!(s, "\n|---|");
        for _ in &columns {
            let _ = write!(s, "---|");
        }
        s.push('\n');
        for &k in &self.kinds {
            let _ = write!(s, "| {k} |");
            for (_, m, t) in &columns {
                let _ = write!(
                    s,
                    " {} |",
                    Self::cell(self.summary(*m, *t, Some(k), Measure::Raw))
                );
            }
            s.push('\n');
        }
        let _ = writeln!(
            s,
            "\nFig. 5 case: {} of the {} transferred to the {} (PLY files in `{prefix}fig5/`, per-vertex error \
             as the `error` scalar and heat colours on one shared scale). Total time {:.1} s.",
            self.figure.kind, self.source, self.figure.base, self.seconds
        );
        let _ = writeln!(
            s,
            "\n![Transfer error per metric and transport (mean over the {n_cases} cases; whiskers: \
             ± 1 SD, the lower one clipped at 0)]({prefix}transfer.png)\n\n\
             ![Transfer error per deformation kind (mean over the {} bases; whiskers: ± 1 SD, \
             clipped at 0)]({prefix}transfer-kinds.png)",
            self.bases.len()
        );
        s
    }

    /// The metric x transport table of `measure`.
    fn metric_table(&self, s: &mut String, measure: Measure) {
        let _ = write!(s, "| metric | lambda |");
        for t in &self.transports {
            let _ = write!(s, " {} |", t.label());
        }
        let _ = write!(s, "\n|---|---|");
        for _ in &self.transports {
            let _ = write!(s, "---|");
        }
        s.push('\n');
        for (m, label) in self.metrics.iter().enumerate() {
            let _ = write!(s, "| {label} | {} |", self.specs[m].lambda);
            for &t in &self.transports {
                let _ = write!(s, " {} |", Self::cell(self.summary(m, t, None, measure)));
            }
            s.push('\n');
        }
        s.push('\n');
    }

    /// One sentence per metric: each non-Euclidean transport against Euclidean transfer.
    fn sentences(&self, s: &mut String, measure: Measure) {
        for (m, label) in self.metrics.iter().enumerate() {
            let mut parts = Vec::new();
            for &t in self.transports.iter().filter(|t| **t != Transport::Translate) {
                let Some(c) = self.comparison(m, t, measure) else {
                    continue;
                };
                let rel = if c.euclidean_mean > 0.0 {
                    (c.mean - c.euclidean_mean) / c.euclidean_mean * 100.0
                } else {
                    0.0
                };
                let verdict = if c.mean < c.euclidean_mean {
                    format!("{:.1}% lower", -rel)
                } else {
                    format!("{rel:.1}% higher")
                };
                let beats = if c.wins * 2 > c.n {
                    "beats"
                } else {
                    "does not beat"
                };
                parts.push(format!(
                    "{} transport {beats} Euclidean transfer: lower error in {} of {} cases, mean \
                     error {:.4} against {:.4} ({verdict})",
                    t.label(),
                    c.wins,
                    c.n,
                    c.mean,
                    c.euclidean_mean
                ));
            }
            if parts.is_empty() {
                let _ = writeln!(s, "- **{label}**: no comparison with Euclidean transfer was run.");
            } else {
                let _ = writeln!(s, "- **{label}**: {}.", parts.join("; "));
            }
        }
    }

    /// The (name, metric, transport) series: every metric with every non-Euclidean transport,
    /// then Euclidean once.
    fn columns(&self) -> Vec<(String, usize, Transport)> {
        let mut cols = Vec::new();
        for (m, label) in self.metrics.iter().enumerate() {
            for &t in self.transports.iter().filter(|t| **t != Transport::Translate) {
                cols.push((format!("{label} {}", t.label()), m, t));
            }
        }
        if self.transports.contains(&Transport::Translate) {
            cols.push(("euclidean".into(), 0, Transport::Translate));
        }
        cols
    }

    /// Writes into `dir` (created if needed), atomically: `transfer.csv`, `transfer.md`,
    /// `transfer.svg`/`.png` (groups = metrics, bars = transports), `transfer-kinds.svg`/`.png`
    /// (groups = kinds, bars = metric and transport), and the Fig. 5 PLYs in `dir/fig5/`:
    /// `source-initial.ply` (`M_0`), `source.ply` (`M_K`), `base.ply` (`N_0`), `ideal.ply`
    /// (`N*_K`), and `<metric>-<transport>.ply` / `euclidean.ply` (`N_K`) with the per-vertex
    /// error as the `error` scalar and heat colours from 0 to the largest error of the figure.
    /// Returns the files written.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, ExperimentError> {
        let mkdir = |d: &Path| {
            std::fs::create_dir_all(d).map_err(|error| IoError::Write {
                path: d.into(),
                error,
            })
        };
        mkdir(dir)?;
        let mut files = Vec::new();
        let text = |name: &str, body: String, files: &mut Vec<PathBuf>| -> Result<(), ExperimentError> {
            let p = dir.join(name);
            write_atomically(&p, |w| w.write_all(body.as_bytes()))?;
            files.push(p);
            Ok(())
        };
        text("transfer.csv", self.to_csv(), &mut files)?;
        text("transfer.md", self.to_markdown(), &mut files)?;

        let by_metric: Vec<BarGroup> = self
            .metrics
            .iter()
            .enumerate()
            .map(|(m, label)| {
                let bars = self
                    .transports
                    .iter()
                    .filter_map(|&t| {
                        self.summary(m, t, None, Measure::Raw)
                            .map(|s| (t.label().to_string(), s.mean, s.sd))
                    })
                    .collect();
                (label.clone(), bars)
            })
            .collect();
        let columns = self.columns();
        let by_kind: Vec<BarGroup> = self
            .kinds
            .iter()
            .map(|&k| {
                let bars = columns
                    .iter()
                    .filter_map(|(name, m, t)| {
                        self.summary(*m, *t, Some(k), Measure::Raw)
                            .map(|s| (name.clone(), s.mean, s.sd))
                    })
                    .collect();
                (k.name().to_string(), bars)
            })
            .collect();
        let y = "last-pose error (mean-edge units)";
        for ext in ["svg", "png"] {
            let p = dir.join(format!("transfer.{ext}"));
            error_bars(
                &p,
                &by_metric,
                &format!("Deformation transfer from the {}: error per metric", self.source),
                y,
            )?;
            files.push(p);
            let p = dir.join(format!("transfer-kinds.{ext}"));
            error_bars(&p, &by_kind, "Deformation transfer: error per deformation", y)?;
            files.push(p);
        }

        let fig = &self.figure;
        let fdir = dir.join("fig5");
        mkdir(&fdir)?;
        let faces = fig.topology.faces();
        let last = fig.source.len() - 1;
        for (name, pos) in [
            ("source-initial.ply", &fig.source[0]),
            ("source.ply", &fig.source[last]),
            ("base.ply", &fig.ideal[0]),
            ("ideal.ply", &fig.ideal[last]),
        ] {
            let p = fdir.join(name);
            write_mesh(&p, pos, faces, &VertexAttributes::default())?;
            files.push(p);
        }
        let vmax = fig
            .transferred
            .iter()
            .flat_map(|f| f.errors.iter().copied())
            .fold(0.0, f64::max);
        for f in &fig.transferred {
            let colors = heat_colors(&f.errors, 0.0, vmax);
            let p = fdir.join(format!("{}.ply", f.label));
            write_mesh(
                &p,
                &f.positions,
                faces,
                &VertexAttributes {
                    scalar: Some(("error", &f.errors)),
                    colors: Some(&colors),
                },
            )?;
            files.push(p);
        }
        Ok(files)
    }
}
