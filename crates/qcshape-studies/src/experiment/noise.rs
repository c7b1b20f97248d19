//! Noise resistance of the classification (paper section 3.5, Table 3, eq. 17).
//!
//! The data set is classified ([`classify_set`]: interpolation, transfer, similarity, k-means
//! with intrinsic means started from seeded kernel k-means); then noise is added to every pose
//! ([`noisy_set`]: per-coordinate variance `level/100 * lbar^2`, `lbar` the pose's mean edge
//! length; Gaussian or uniform with the same variance; docs/method.md "Noise"), the
//! noisy set is classified again, and `tau` (eq. 17) is the share of deformations whose
//! cluster is unchanged, after Hungarian matching of the clusters.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::classification::{classify_set, ClassificationError};
use qcshape::dataset::Deformation;
use qcshape::eval::{tau, EvalError};
use qcshape::io::{write_atomically, IoError};
use qcshape::similarity::{PipelineOptions, Stage};
use qcshape::synth::{add_noise, NoiseKind};

/// Why the noise experiment failed.
#[derive(Debug, Error)]
pub enum NoiseError {
    /// Fewer than two deformations.
    #[error("invalid noise experiment: needs at least two deformations, got {0}")]
    TooFew(usize),
    /// `k` is 0 or above the number of deformations.
    #[error("invalid noise experiment: k must be between 1 and the number of deformations ({n}), got {k}")]
    Classes {
        /// The `k` asked for.
        k: usize,
        /// The number of deformations.
        n: usize,
    },
    /// A noise level is negative or not finite.
    #[error("invalid noise experiment: noise levels must be non-negative percentages, got {0}")]
    Level(f64),
    /// A classification failed.
    #[error(transparent)]
    Classification(#[from] ClassificationError),
    /// `tau` cannot be computed.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// An output file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
}

/// `defs` with noise of `kind` and variance `level` % (docs/method.md "Noise") added to every
/// pose; each deformation gets its own seed derived from `seed`, its index, the level and the kind.
pub fn noisy_set(defs: &[Deformation], kind: NoiseKind, level: f64, seed: u64) -> Vec<Deformation> {
    defs.iter()
        .enumerate()
        .map(|(i, d)| {
            let seed = seed ^ ((i as u64) << 16) ^ ((level * 1000.0) as u64) ^ (kind as u64 * 0x9e37);
            Deformation {
                poses: add_noise(&d.topology, &d.poses, kind, level, seed),
                ..d.clone()
            }
        })
        .collect()
}

/// The experiment's settings (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct NoiseExperiment {
    /// The pipeline of every classification (metric, geodesics, interpolation, transport).
    pub pipeline: PipelineOptions,
    /// Number of classes.
    pub k: usize,
    /// Seeded kernel k-means runs of every classification (the best starts the intrinsic
    /// k-means).
    pub restarts: usize,
    /// Seed of the noise and the clustering.
    pub seed: u64,
    /// Noise variances in percent of `lbar^2` (Table 3: 1, 2.5, 5, 10, 20).
    pub levels: Vec<f64>,
    /// Noise distributions (the columns of Table 3).
    pub kinds: Vec<NoiseKind>,
}

/// One noise level: `tau` per noise kind.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NoiseRow {
    /// Noise variance in percent.
    pub level: f64,
    /// `tau` (eq. 17, in [0, 1]) per kind, in the order of [`NoiseReport::kinds`].
    pub tau: Vec<f64>,
}

/// The experiment's results.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NoiseReport {
    /// The metric's name (as built).
    pub metric: String,
    /// Number of deformations.
    pub n: usize,
    /// Number of classes.
    pub k: usize,
    /// The noise kinds' names (`uniform`, `gaussian`).
    pub kinds: Vec<String>,
    /// One row per noise level, in the order given.
    pub rows: Vec<NoiseRow>,
}

impl NoiseExperiment {
    /// Runs the experiment on `defs`. `progress(run, stage)` is called as each deformation
    /// finishes interpolation and transfer and as each pair finishes, with `run` = `noise-free`
    /// for the reference classification and the noise kind's name for the noisy ones.
    pub fn run(
        &self,
        defs: &[Deformation],
        progress: &(dyn Fn(&str, Stage) + Sync),
    ) -> Result<NoiseReport, NoiseError> {
        if defs.len() < 2 {
            return Err(NoiseError::TooFew(defs.len()));
        }
        if self.k == 0 || self.k > defs.len() {
            return Err(NoiseError::Classes {
                k: self.k,
                n: defs.len(),
            });
        }
        if let Some(&l) = self.levels.iter().find(|l| !(l.is_finite() && **l >= 0.0)) {
            return Err(NoiseError::Level(l));
        }
        let (k, restarts, seed) = (self.k, self.restarts, self.seed);
        let reference = classify_set(defs, &self.pipeline, k, restarts, seed, &|s| {
            progress("noise-free", s)
        })?;
        let mut rows = Vec::with_capacity(self.levels.len());
        for &level in &self.levels {
            let mut taus = Vec::with_capacity(self.kinds.len());
            for &kind in &self.kinds {
                let noisy = noisy_set(defs, kind, level, seed);
                let c = classify_set(&noisy, &self.pipeline, k, restarts, seed, &|s| {
                    progress(kind.name(), s)
                })?;
                taus.push(tau(&reference.clustering.assignments, &c.clustering.assignments)?);
            }
            rows.push(NoiseRow { level, tau: taus });
        }
        Ok(NoiseReport {
            metric: self.pipeline.metric.label(),
            n: defs.len(),
            k,
            kinds: self.kinds.iter().map(|k| k.name().to_string()).collect(),
            rows,
        })
    }
}

impl NoiseReport {
    /// `level,kind,tau` per (level, kind), `tau` in [0, 1] at full precision.
    pub fn to_csv(&self) -> String {
        let mut csv = String::from("level,kind,tau\n");
        for row in &self.rows {
            for (kind, tau) in self.kinds.iter().zip(&row.tau) {
                let _ = writeln!(csv, "{},{kind},{tau:?}", row.level);
            }
        }
        csv
    }

    /// The Table 3 layout: one row per level, one `tau (%)` column per kind.
    pub fn to_markdown(&self) -> String {
        let mut md = format!(
            "# Noise resistance ({}, {} deformations, k = {})\n\n| noise variance (%) | {} |\n|---|{}\n",
            self.metric,
            self.n,
            self.k,
            self.kinds
                .iter()
                .map(|k| format!("{k} tau (%)"))
                .collect::<Vec<_>>()
                .join(" | "),
            "---|".repeat(self.kinds.len())
        );
        for row in &self.rows {
            let mut line = format!("| {} |", row.level);
            for tau in &row.tau {
                let _ = write!(line, " {:.1} |", 100.0 * tau);
            }
            let _ = writeln!(md, "{line}");
        }
        let _ = writeln!(
            md,
            "\ntau (eq. 17): share of deformations whose cluster is unchanged against the noise-free run, \
             after Hungarian matching of the clusters."
        );
        md
    }

    /// Writes `noise.csv` and `noise.md` to `dir` (created); returns their paths.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, NoiseError> {
        std::fs::create_dir_all(dir).map_err(|error| IoError::Write {
            path: dir.to_path_buf(),
            error,
        })?;
        let mut files = Vec::new();
        for (name, text) in [("noise.csv", self.to_csv()), ("noise.md", self.to_markdown())] {
            let path = dir.join(name);
            write_atomically(&path, |w| w.write_all(text.as_bytes()))?;
            files.push(path);
        }
        Ok(files)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_writers() {
        let r = NoiseReport {
            metric: "isometric".into(),
            n: 4,
            k: 2,
            kinds: vec!["uniform".into(), "gaussian".into()],
            rows: vec![
                NoiseRow {
                    level: 0.0,
                    tau: vec![1.0, 1.0],
                },
                NoiseRow {
                    level: 2.5,
                    tau: vec![0.75, 0.5],
                },
            ],
        };
        assert_eq!(
            r.to_csv(),
            "level,kind,tau\n0,uniform,1.0\n0,gaussian,1.0\n2.5,uniform,0.75\n2.5,gaussian,0.5\n"
        );
        let md = r.to_markdown();
        assert!(md.starts_with(
            "# Noise resistance (isometric, 4 deformations, k = 2)\n\n| noise variance (%) | uniform tau (%) | gaussian tau (%) |\n|---|---|---|\n| 0 | 100.0 | 100.0 |\n| 2.5 | 75.0 | 50.0 |\n"
        ), "{md}");
    }

    #[test]
    fn zero_noise_keeps_every_cluster() {
        let (defs, pipeline) = crate::experiment::classification::tests::two_class_set();
        let exp = NoiseExperiment {
            pipeline,
            k: 2,
            restarts: 2,
            seed: 0,
            levels: vec![0.0],
            kinds: vec![NoiseKind::Uniform],
        };
        let r = exp.run(&defs, &|_, _| {}).unwrap();
        assert_eq!(r.rows.len(), 1);
        assert_eq!(r.rows[0].tau, [1.0]);
        assert_eq!(r.kinds, ["uniform"]);
    }
}
