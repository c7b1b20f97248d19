//! `--template T` of `run`, `similarity`, `interpolate` and `transfer`: every input mesh (of any
//! triangulation) fitted with one template first, by the library's data set fit
//! ([`qcshape::fit::data`], the code path and defaults of `qcshape fit --sequence`), the fit's
//! quality written beside the outputs; without it the data set is read as before, and a
//! connectivity mismatch says that `--template` exists ([`hint`]).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use qcshape::dataset::{load_sequence, sequence_files, Dataset, DatasetError, DeformationFiles};
use qcshape::fit::data::{fit_dataset, write_quality};
use qcshape::fit::{FitOptions, Fitted};
use qcshape::io;
use qcshape::mesh::{MeshError, Shape};
use qcshape::similarity::PipelineError;

/// The `--template` option, flattened into every command that reads a mesh set.
#[derive(Debug, Clone, clap::Args)]
pub struct TemplateArgs {
    /// Fit this template mesh to every input mesh first, so that meshes of any triangulation
    /// (segmentations, scans, other tools) can be compared: the method and defaults of `qcshape
    /// fit`, each deformation tracked from pose to pose as with `fit --sequence`. The fit's
    /// quality (the columns of `qcshape fit`'s quality.csv) is written beside the outputs, with
    /// a warning per poor fit (docs/fit.md).
    #[arg(long, value_name = "T")]
    pub template: Option<PathBuf>,
}

/// Where a command's mesh set comes from.
pub(crate) enum Source<'a> {
    /// A data set: a manifest CSV or a folder ([`Dataset::load`]).
    Dataset(&'a Path),
    /// The mesh files of one deformation in pose order, or one folder of them
    /// ([`load_sequence`]).
    Sequence(&'a [PathBuf]),
}

/// A mesh fitted alone (not part of the data set), such as `transfer --to`.
pub(crate) struct Extra<'a> {
    /// Its name in quality.csv's `deformation` column.
    pub name: &'a str,
    /// The mesh file.
    pub path: &'a Path,
}

impl TemplateArgs {
    /// The data set of `source`. Without `--template`: read as before ([`Dataset::load`] or
    /// [`load_sequence`]), a connectivity mismatch with [`hint`]. With it: the inputs checked
    /// against `quality` (the quality table to write), `out_folder` (the command's output
    /// folder, if it has one) and `out_files` (the command's other output files, each with its
    /// option's name) before anything is read or fitted, a line on stderr, every pose fitted
    /// (tracked per deformation, deformations in parallel), `quality` written, a warning per
    /// poor fit. Without it the caller checks `out_files` against the data set. Each of `extra`
    /// is fitted too (unless it already has the template's connectivity) and returned in
    /// order; without `--template` they are returned as read.
    pub(crate) fn load(
        &self,
        source: Source<'_>,
        extra: &[Extra<'_>],
        quality: &Path,
        out_folder: Option<&Path>,
        out_files: &[(PathBuf, &str)],
    ) -> Result<(Dataset, Vec<Shape>)> {
        let Some(template_path) = &self.template else {
            let data = match source {
                Source::Dataset(p) => Dataset::load(p),
                Source::Sequence(files) => load_sequence(files).map(|d| Dataset {
                    deformations: vec![d],
                }),
            }
            .map_err(|e| hint(e.into()))?;
            let extra = extra
                .iter()
                .map(|e| io::load_shape(e.path))
                .collect::<Result<_, _>>()?;
            return Ok((data, extra));
        };
        let (given, mut files): (Vec<&Path>, Vec<DeformationFiles>) = match source {
            Source::Dataset(p) => (vec![p], Dataset::files(p)?),
            Source::Sequence(f) => (f.iter().map(PathBuf::as_path).collect(), vec![sequence_files(f)?]),
        };
        let n_data = files.len();
        let template = io::load_shape(template_path)?;
        let mut extra_shapes: Vec<Option<Shape>> = Vec::with_capacity(extra.len());
        for e in extra {
            let shape = io::load_shape(e.path)?;
            let same = shape.topology.n_vertices() == template.topology.n_vertices()
                && shape.topology.faces() == template.topology.faces();
            if same {
                extra_shapes.push(Some(Shape {
                    topology: template.topology.clone(),
                    positions: shape.positions,
                }));
            } else {
                extra_shapes.push(None);
                files.push(DeformationFiles {
                    name: e.name.to_string(),
                    label: None,
                    files: vec![e.path.to_path_buf()],
                });
            }
        }
        // Refused before anything is computed: an output over an input.
        let mut inputs: Vec<&Path> = given;
        inputs.push(template_path);
        inputs.extend(files.iter().flat_map(|d| d.files.iter().map(PathBuf::as_path)));
        qcshape::outputs::refuse_input_overlap(&inputs, quality, "the fit's quality table")?;
        for (file, what) in out_files {
            qcshape::outputs::refuse_input_overlap(&inputs, file, what)?;
        }
        if let Some(folder) = out_folder {
            crate::input::refuse_out_folder(&inputs, folder, "--out")?;
        }
        let total: usize = files.iter().map(|d| d.files.len()).sum();
        eprintln!(
            "fitting {} ({} vertices) to {total} mesh(es) of {n_data} deformation(s), tracked from pose to pose (qcshape fit's method; docs/fit.md) ...",
            template_path.display(),
            template.n_vertices()
        );
        let opts = FitOptions::default();
        let pb = crate::progress::bar(total, "fitting");
        // The deformations in parallel, results in order ([`fit_dataset`]).
        let (mut data, fits) = fit_dataset(&template, &files, &opts, true, |_, _| pb.inc(1))?;
        let mut tally = FitTally::default();
        for (d, fitted) in files.iter().zip(&fits) {
            for (k, f) in fitted.iter().enumerate() {
                tally.record(&pb, d, k, f);
            }
        }
        pb.finish_and_clear();
        if let Some(dir) = quality.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        }
        write_quality(quality, &data, &fits)?;
        eprintln!(
            "fitted {total} mesh(es): worst mean distance {:.3} edge lengths, {} poor; quality in {}",
            tally.worst,
            tally.poor,
            quality.display()
        );
        // The extra meshes' fits, in order, off the data set.
        let mut fitted_extra = data.deformations.split_off(n_data).into_iter();
        let extra = extra_shapes
            .into_iter()
            .map(|s| s.or_else(|| fitted_extra.next().map(|d| d.shape(0))))
            .collect::<Option<Vec<Shape>>>()
            .context("a mesh given besides the data set was not fitted")?;
        Ok((data, extra))
    }
}

/// The fit's quality over the poses fitted so far, for `qcshape fit` and `--template`: the
/// largest mean distance (template mean edge lengths) and the poor fits, each warned about on
/// stderr as it is recorded.
#[derive(Debug, Default)]
pub(crate) struct FitTally {
    /// Largest mean surface distance of a pose.
    pub worst: f64,
    /// Poses whose fit is poor.
    pub poor: usize,
}

impl FitTally {
    /// Records pose `k` of the deformation `d` fitted as `f`, warning above the bar `pb` if the
    /// fit is poor.
    pub(crate) fn record(&mut self, pb: &indicatif::ProgressBar, d: &DeformationFiles, k: usize, f: &Fitted) {
        self.worst = self.worst.max(f.quality.mean);
        if f.quality.poor {
            self.poor += 1;
            pb.suspend(|| {
                eprintln!(
                    "warning: poor fit of {} (deformation {}, pose {k}): {}",
                    d.files[k].display(),
                    d.name,
                    f.quality.problems().join(", ")
                )
            });
        }
    }
}

/// The quality table of a command whose output is the file `output`: `OUTPUT_STEM.quality.csv`
/// beside it (`D.csv` -> `D.quality.csv`).
pub(crate) fn quality_beside(output: &Path) -> PathBuf {
    let stem = output
        .file_stem()
        .map_or_else(|| "similarity".into(), |s| s.to_string_lossy().into_owned());
    output.with_file_name(format!("{stem}.quality.csv"))
}

/// `e` with a suggestion of `--template` when it is a connectivity mismatch (poses or
/// deformations on different triangulations); other errors unchanged.
pub(crate) fn hint(e: anyhow::Error) -> anyhow::Error {
    let meshes = |m: &MeshError| {
        matches!(
            m,
            MeshError::TopologyMismatch(_) | MeshError::VertexCountMismatch { .. }
        )
    };
    let mismatch = e.chain().any(|c| {
        matches!(
            c.downcast_ref::<DatasetError>(),
            Some(DatasetError::TopologyMismatch { .. })
        ) || matches!(c.downcast_ref::<PipelineError>(), Some(PipelineError::Mesh { error, .. }) if meshes(error))
            || c.downcast_ref::<MeshError>().is_some_and(meshes)
    });
    if mismatch {
        anyhow::anyhow!(
            "{e:#}; meshes of different triangulations: give --template T to fit one template mesh to every input first (docs/fit.md)"
        )
    } else {
        e
    }
}
