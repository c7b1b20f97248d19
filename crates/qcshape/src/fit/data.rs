//! Fitting a data set whose poses may have any triangulation: one template fitted to every
//! pose of every deformation ([`fit_deformation`], [`fit_dataset`]), giving a [`Dataset`] on
//! the template's one connectivity that the rest of the library reads, and the fit's quality
//! per pose as a CSV table ([`QUALITY_COLUMNS`], [`write_quality`]). This is the code path of
//! `qcshape fit`, of `--template` on `run`, `similarity`, `interpolate` and `transfer`, and of
//! Python's `Dataset.load(path, template=...)`.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use thiserror::Error;

use super::error::FitError;
use super::options::FitOptions;
use super::run::{fit, fit_sequence, Fitted};
use super::target::Target;
use crate::dataset::{Dataset, Deformation, DeformationFiles};
use crate::io::{self, IoError, MeshData};
use crate::mesh::{MeshError, Shape};

/// Why a data set cannot be fitted. Every message names the file it is about.
#[derive(Debug, Error)]
pub enum FitDataError {
    /// A target file cannot be read or parsed, or the quality table cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The fit of one target file failed.
    #[error("{}: {error}", path.display())]
    Fit {
        /// The target file.
        path: PathBuf,
        /// Why.
        error: FitError,
    },
    /// The fitted pose is not a valid shape (a collapsed triangle).
    #[error("{}: the fitted template is not a valid pose: {error}", path.display())]
    Fitted {
        /// The target file.
        path: PathBuf,
        /// Why.
        error: MeshError,
    },
}

/// Fits `template` (a manifold triangle mesh, #V x 3) to every pose file of one deformation.
/// With `sequence`, pose 0 is fitted from the template and each next pose from the previous
/// fit ([`fit_sequence`], tracking, as `qcshape fit --sequence`); without, every pose from the
/// template ([`fit`]), the poses in parallel (rayon's pool). `on_pose(k)` is called after pose
/// `k` (from the worker that fitted it: in pose order only with `sequence`). Returns the
/// deformation on the template's connectivity (positions in the targets' units; `paths` are
/// the target files) and each pose's fit, the same for any number of threads.
pub fn fit_deformation(
    template: &Shape,
    files: &DeformationFiles,
    opts: &FitOptions,
    sequence: bool,
    on_pose: impl Fn(usize) + Sync,
) -> Result<(Deformation, Vec<Fitted>), FitDataError> {
    let meshes: Vec<MeshData> = files
        .files
        .iter()
        .map(|f| io::read_mesh(f))
        .collect::<Result<_, _>>()?;
    let targets: Vec<Target> = meshes
        .iter()
        .map(|m| Target {
            positions: &m.positions,
            faces: &m.faces,
        })
        .collect();
    let failed = |k: usize, error: FitError| FitDataError::Fit {
        path: files.files.get(k).cloned().unwrap_or_default(),
        error,
    };
    let fitted: Vec<Fitted> = if sequence {
        // The frame that failed is the one after the last reported.
        let mut done = 0usize;
        fit_sequence(template, &targets, opts, |k| {
            done = k + 1;
            on_pose(k)
        })
        .map_err(|e| failed(done, e))?
    } else {
        // Independent poses in parallel; the first failure in pose order is reported.
        let results: Vec<Result<Fitted, FitError>> = targets
            .par_iter()
            .enumerate()
            .map(|(k, t)| {
                let f = fit(template, t, opts);
                on_pose(k);
                f
            })
            .collect();
        results
            .into_iter()
            .enumerate()
            .map(|(k, r)| r.map_err(|e| failed(k, e)))
            .collect::<Result<_, _>>()?
    };
    let mut poses = Vec::with_capacity(fitted.len());
    for (f, path) in fitted.iter().zip(&files.files) {
        let shape = Shape::new_checked(
            template.topology.clone(),
            f.positions.clone(),
            io::DEGENERATE_REL_TOL,
        )
        .map_err(|error| FitDataError::Fitted {
            path: path.clone(),
            error,
        })?;
        poses.push(shape.positions);
    }
    let warnings = meshes
        .iter()
        .zip(&files.files)
        .flat_map(|(m, f)| m.warnings.iter().map(move |w| format!("{}: {w}", f.display())))
        .collect();
    let deformation = Deformation {
        name: files.name.clone(),
        label: files.label.clone(),
        topology: template.topology.clone(),
        poses,
        paths: files.files.clone(),
        warnings,
    };
    Ok((deformation, fitted))
}

/// Fits `template` to every deformation of `files` ([`fit_deformation`], tracked through each
/// deformation's poses when `sequence`), the deformations in parallel (rayon's pool; each
/// tracked sequence on one worker at a time): the data set on the template's one connectivity
/// (shared by every deformation) and, per deformation, each pose's fit, in the order of
/// `files` and the same for any number of threads. `on_pose(d, k)` is called after pose `k` of
/// deformation `d`, from the worker that fitted it (deformations interleave). On failure, the
/// error of the first failed deformation in the order of `files`.
pub fn fit_dataset(
    template: &Shape,
    files: &[DeformationFiles],
    opts: &FitOptions,
    sequence: bool,
    on_pose: impl Fn(usize, usize) + Sync,
) -> Result<(Dataset, Vec<Vec<Fitted>>), FitDataError> {
    let results: Vec<Result<(Deformation, Vec<Fitted>), FitDataError>> = files
        .par_iter()
        .enumerate()
        .map(|(d, f)| fit_deformation(template, f, opts, sequence, |k| on_pose(d, k)))
        .collect();
    let mut deformations = Vec::with_capacity(files.len());
    let mut fits = Vec::with_capacity(files.len());
    for r in results {
        let (deformation, fitted) = r?;
        deformations.push(deformation);
        fits.push(fitted);
    }
    Ok((Dataset { deformations }, fits))
}

/// The columns of the fit's quality table (quality.csv), one row per fitted pose:
/// deformation, pose (0-based), source (the target file), the symmetric surface distance's
/// mean, 95th percentile and maximum and the fitted vertices' median distance (in the aligned
/// template's mean edge lengths), the smallest angle (degrees), flipped triangles, the rms and
/// largest relative edge strain, the edge length (target units), the initial alignment's scale
/// and whether the fit is poor ([`super::FitQuality`]).
///
/// Then, after `poor`: the template's own smallest angle, the triangles the fit made slivers
/// and the local slide measure ([`super::FitQuality::slide`]).
pub const QUALITY_COLUMNS: [&str; 17] = [
    "deformation",
    "pose",
    "source",
    "mean",
    "p95",
    "hausdorff",
    "median_vertex",
    "min_angle",
    "flipped",
    "strain_rms",
    "strain_max",
    "edge_length",
    "scale",
    "poor",
    "template_min_angle",
    "new_slivers",
    "slide",
];

/// One row of the quality table ([`QUALITY_COLUMNS`]) for pose `pose` of deformation `name`,
/// fitted to the file `source`. Numbers with 6 decimals.
pub fn quality_record(name: &str, pose: usize, source: &Path, f: &Fitted) -> Vec<String> {
    let q = &f.quality;
    let nums = [q.mean, q.p95, q.hausdorff, q.median_vertex, q.min_angle];
    let mut row = vec![name.to_string(), pose.to_string(), source.display().to_string()];
    row.extend(nums.iter().map(|x| format!("{x:.6}")));
    row.push(q.flipped.to_string());
    let more = [q.strain_rms, q.strain_max, q.edge_length, f.motion.scale];
    row.extend(more.iter().map(|x| format!("{x:.6}")));
    row.push(q.poor.to_string());
    row.push(format!("{:.6}", q.template_min_angle));
    row.push(q.new_slivers.to_string());
    row.push(format!("{:.6}", q.slide));
    row
}

/// Writes the quality table ([`QUALITY_COLUMNS`]) of the fitted data set `data` (each
/// deformation's `paths` are its target files) with its fits `fits` (per deformation, per
/// pose) to `path`, through a temporary name.
pub fn write_quality(path: &Path, data: &Dataset, fits: &[Vec<Fitted>]) -> Result<(), FitDataError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let encode = |e: csv::Error| {
        FitDataError::Io(IoError::Write {
            path: path.into(),
            error: std::io::Error::other(e.to_string()),
        })
    };
    w.write_record(QUALITY_COLUMNS).map_err(encode)?;
    for (d, fitted) in data.deformations.iter().zip(fits) {
        for (k, (f, src)) in fitted.iter().zip(&d.paths).enumerate() {
            w.write_record(quality_record(&d.name, k, src, f))
                .map_err(encode)?;
        }
    }
    let bytes = w.into_inner().map_err(|e| {
        FitDataError::Io(IoError::Write {
            path: path.into(),
            error: std::io::Error::other(e.to_string()),
        })
    })?;
    io::write_atomically(path, |out| out.write_all(&bytes))?;
    Ok(())
}
