//! The whole analysis of one data set after its similarity matrix (eq. 13): classification
//! (k-means with intrinsic means, eq. 14, started from seeded kernel k-means), scores against
//! the data set's labels (eq. 15), the MDS map (SMACOF, eq. 16), and the report (`qcshape run`).
//!
//! [`analyse`] computes; [`Analysis::write`] writes `assignments.csv`, `confusion.csv` (with
//! labels), `coordinates.csv`, `map.svg` / `map.png` and `heatmap.svg`; [`AnalysisReport`] is
//! `report.md`.

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use thiserror::Error;

use super::classification::{
    cluster_intrinsic, score, write_assignments, write_confusion, ClassificationError, Scores,
};
use super::provenance::Provenance;
use crate::plot::PlotError;
use qcshape::cluster::Clustering;
use qcshape::dataset::Deformation;
use qcshape::embed::{smacof, MdsError, MdsOptions};
use qcshape::io::{write_atomically, IoError};
use qcshape::similarity::{DistanceMatrix, PipelineOptions, Prepared, ShareSummary};

/// Why the analysis failed.
#[derive(Debug, Error)]
pub enum AnalysisError {
    /// Clustering or scoring failed.
    #[error(transparent)]
    Classification(#[from] ClassificationError),
    /// The MDS map cannot be computed.
    #[error(transparent)]
    Mds(#[from] MdsError),
    /// A figure cannot be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
}

/// The labels of the deformations (n), if every one has a non-empty label.
pub fn dataset_labels(defs: &[Deformation]) -> Option<Vec<String>> {
    defs.iter()
        .map(|d| d.label.clone().filter(|l| !l.is_empty()))
        .collect()
}

/// Number of distinct labels (0 without labels).
pub fn class_count(labels: Option<&[String]>) -> usize {
    labels.map_or(0, |l| l.iter().collect::<HashSet<_>>().len())
}

/// The analysis of one similarity matrix.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Analysis {
    /// k-means with intrinsic means (eq. 14).
    pub clustering: Clustering,
    /// Scores against the labels, when there are labels of at least two classes.
    pub scores: Option<Scores>,
    /// MDS coordinates (n x 2, in the distance unit).
    pub coords: Vec<Vec<f64>>,
    /// Kruskal's stress-1 of the map.
    pub stress: f64,
    /// SMACOF iterations.
    pub mds_iterations: usize,
    /// The label of each item on the map and the heat map: its class, or `cluster C`.
    pub plot_labels: Vec<String>,
    /// Elapsed seconds of the clustering.
    pub cluster_seconds: f64,
}

/// Clusters the prepared deformations of `matrix` into `k` classes (kernel k-means with
/// `restarts` seeded runs, then intrinsic k-means), scores the partition against `labels` (n,
/// if given and of at least two classes) and maps the matrix in 2D (SMACOF).
pub fn analyse(
    matrix: &DistanceMatrix,
    prepared: &Prepared,
    opts: &PipelineOptions,
    k: usize,
    restarts: usize,
    seed: u64,
    labels: Option<&[String]>,
) -> Result<Analysis, AnalysisError> {
    let t = Instant::now();
    let (_, clustering) = cluster_intrinsic(matrix, prepared, opts, k, restarts, seed)?;
    let cluster_seconds = t.elapsed().as_secs_f64();
    let scores = labels
        .filter(|l| class_count(Some(l)) >= 2)
        .map(|l| score(matrix, &clustering, l))
        .transpose()?;
    let e = smacof(matrix, &MdsOptions::default())?;
    let plot_labels: Vec<String> = match labels {
        Some(l) => l.to_vec(),
        None => clustering
            .assignments
            .iter()
            .map(|c| format!("cluster {c}"))
            .collect(),
    };
    Ok(Analysis {
        clustering,
        scores,
        coords: e.coords,
        stress: e.normalized_stress,
        mds_iterations: e.iterations,
        plot_labels,
        cluster_seconds,
    })
}

impl Analysis {
    /// The map coordinates as CSV: `name,x,y` per item (full precision).
    pub fn coordinates_csv(&self, names: &[String]) -> String {
        let mut coords = String::from("name,x,y\n");
        for (name, c) in names.iter().zip(&self.coords) {
            let _ = writeln!(coords, "{name},{:?},{:?}", c[0], c[1]);
        }
        coords
    }

    /// Writes `assignments.csv`, `confusion.csv` (with scores), `coordinates.csv`, the map
    /// `map.svg` / `map.png` (titled with `metric`) and `heatmap.svg` (items ordered by plot
    /// label) to `dir`. Returns the paths.
    pub fn write(
        &self,
        dir: &Path,
        matrix: &DistanceMatrix,
        metric: &str,
    ) -> Result<Vec<PathBuf>, AnalysisError> {
        let mut files = vec![dir.join("assignments.csv")];
        write_assignments(&files[0], matrix, &self.clustering, self.scores.as_ref())?;
        if let Some(s) = &self.scores {
            let path = dir.join("confusion.csv");
            write_confusion(&path, s)?;
            files.push(path);
        }
        let path = dir.join("coordinates.csv");
        let coords = self.coordinates_csv(matrix.names());
        write_atomically(&path, |w| w.write_all(coords.as_bytes()))?;
        files.push(path);
        let n = matrix.len();
        for ext in ["svg", "png"] {
            let path = dir.join(format!("map.{ext}"));
            crate::plot::scatter_map(
                &path,
                &self.coords,
                matrix.names(),
                Some(&self.plot_labels),
                &format!("MDS of {n} deformations ({metric})"),
                Some(self.stress),
            )?;
            files.push(path);
        }
        let labels = &self.plot_labels;
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| labels[a].cmp(&labels[b]).then(a.cmp(&b)));
        for ext in ["svg", "png"] {
            let path = dir.join(format!("heatmap.{ext}"));
            crate::plot::heatmap(
                &path,
                matrix,
                &order,
                Some(labels),
                &format!("{metric} distances of {n} deformations (by class)"),
                "distance (mean-edge units)",
            )?;
            files.push(path);
        }
        Ok(files)
    }
}

/// The analysis report (`report.md`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct AnalysisReport {
    /// Command line, version, machine, total time.
    pub provenance: Provenance,
    /// The data set's path as given.
    pub input: String,
    /// Number of deformations.
    pub deformations: usize,
    /// Key poses per deformation.
    pub key_poses: usize,
    /// Vertices per mesh.
    pub vertices: usize,
    /// The metric's name as built.
    pub metric: String,
    /// Poses inserted between key poses.
    pub insert: usize,
    /// The transport's label.
    pub transport: String,
    /// The name of the deformation whose first pose is the base.
    pub base: String,
    /// Segments N of every geodesic.
    pub steps: usize,
    /// Elapsed seconds of interpolation and transfer.
    pub prepare_seconds: f64,
    /// Elapsed seconds of the similarity matrix.
    pub similarity_seconds: f64,
    /// The L2 regularizer's share of the pairs' energy ([`ShareSummary::of`] the matrix's
    /// pairs).
    pub shares: ShareSummary,
    /// Number of classes.
    pub k: usize,
    /// The analysis.
    pub analysis: Analysis,
}

impl AnalysisReport {
    /// `report.md`: data, time per step, classification scores, map.
    pub fn to_markdown(&self) -> String {
        let mut md = String::new();
        // Writing to a String cannot fail.
        let _ = self.write_markdown(&mut md);
        md
    }

    fn write_markdown(&self, md: &mut String) -> std::fmt::Result {
        let a = &self.analysis;
        let n = self.deformations;
        writeln!(md, "# qcshape analysis of `{}`\n", self.input)?;
        md.push_str(&self.provenance.to_markdown());
        writeln!(
            md,
            "{n} deformations, {} key poses each, {} vertices; metric `{}`; {} between key \
             poses; {} transport to the first pose of `{}`; geodesics with N = {}. Distances are in mean-edge \
             units (coordinates divided by the base pose's mean edge length).\n",
            self.key_poses,
            self.vertices,
            self.metric,
            qcshape::numfmt::count(self.insert, "pose inserted", "poses inserted"),
            self.transport,
            self.base,
            self.steps
        )?;
        writeln!(md, "## Time\n\n| step | seconds |\n|---|---|")?;
        writeln!(md, "| interpolation + transfer | {:.2} |", self.prepare_seconds)?;
        writeln!(
            md,
            "| similarity ({} pairs) | {:.2} |",
            n * (n - 1) / 2,
            self.similarity_seconds
        )?;
        writeln!(
            md,
            "| clustering ({} intrinsic rounds) | {:.2} |",
            a.clustering.iterations, a.cluster_seconds
        )?;
        writeln!(md, "\n## Regularizer\n")?;
        md.push_str(&self.shares.markdown(&format!("`{}`", self.metric)));
        writeln!(md, "\n## Classification (k = {})\n", self.k)?;
        match &a.scores {
            Some(s) => {
                writeln!(md, "| measure | value |\n|---|---|")?;
                let pct = [
                    ("sensitivity (eq. 15)", s.eq15.sensitivity),
                    ("specificity (eq. 15)", s.eq15.specificity),
                    ("mean per-class sensitivity", s.eq15.macro_sensitivity),
                    ("mean per-class specificity", s.eq15.macro_specificity),
                    ("leave-one-out 1-NN accuracy", s.nn_accuracy),
                ];
                for (what, v) in pct {
                    writeln!(md, "| {what} | {:.1} % |", 100.0 * v)?;
                }
                writeln!(md, "| adjusted Rand index | {:.3} |", s.ari)?;
                writeln!(
                    md,
                    "\nConfusion matrix (rows: class; columns: class matched to the cluster): `confusion.csv`."
                )?;
            }
            None => writeln!(md, "No labels: clusters only (`assignments.csv`).")?,
        }
        writeln!(
            md,
            "\n## Map\n\n![MDS map of the similarity matrix (SMACOF), colour and marker the label](map.png)\n\n\
             SMACOF stress-1 {:.4} ({} iterations); `map.svg` beside the PNG.\n\n\
             ![Heat map of the similarity matrix, deformations ordered by label](heatmap.png)",
            a.stress, a.mds_iterations
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_and_classes() {
        use qcshape::synth::{genus0_benchmark, SynthOptions};
        let mut defs = genus0_benchmark(&SynthOptions {
            level: 0,
            ..Default::default()
        })
        .unwrap();
        let l = dataset_labels(&defs).unwrap();
        assert_eq!(class_count(Some(&l)), 8);
        defs[1].label = Some(String::new());
        assert_eq!(dataset_labels(&defs), None);
        defs[1].label = None;
        assert_eq!(dataset_labels(&defs), None);
        assert_eq!(class_count(None), 0);
    }
}
