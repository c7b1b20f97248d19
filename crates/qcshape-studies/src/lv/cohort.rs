//! A cohort folder on disk and the per-subject steps of the pipeline.
//!
//! ```text
//! DIR/labels.csv                 subject,label   (control / hcm; the label may be empty)
//! DIR/<subject>/frame00.nii.gz   one 3D file per frame (natural order of the names) ...
//! DIR/<subject>/image.nii.gz     ... or a single 4D file
//! DIR/<subject>/landmarks.csv    frame,landmark,x,y,z (world mm)
//! DIR/<subject>/tps_n16.json     written by `qcshape lv register` (frame 0 -> frame k maps)
//! ```
//!
//! Without `labels.csv`, every sub-folder holding a `landmarks.csv` is a subject (unlabelled).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::freewall::FreeWallError;
use super::landmarks::{read_landmarks, write_landmarks, LandmarkError, Landmarks};
use super::phantom::PhantomSubject;
use super::surface::SurfaceError;
use super::tps::{Tps, TpsError};
use qcshape::dataset::natural_cmp;
use qcshape::io::nifti::{read_series, write_series, write_volume, NiftiError, Volume};
use qcshape::io::table::{Table, TableErrors};
use qcshape::io::{write_atomically, IoError};

/// The labels file's name.
pub const LABELS_NAME: &str = "labels.csv";
/// The landmark file's name in a subject folder.
pub const LANDMARKS_NAME: &str = "landmarks.csv";

/// A problem with a cohort folder or one of its subjects. Messages name the file.
#[derive(Debug, Error)]
pub enum LvError {
    /// An image problem.
    #[error(transparent)]
    Nifti(#[from] NiftiError),
    /// A landmark-file problem.
    #[error(transparent)]
    Landmarks(#[from] LandmarkError),
    /// A file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A folder or file of the layout is missing or unreadable, or malformed.
    #[error("{}: {problem}", path.display())]
    Layout {
        /// The file or folder.
        path: PathBuf,
        /// What is wrong.
        problem: LayoutProblem,
    },
    /// The spline for one frame cannot be fitted.
    #[error("{}: frame {frame}: {error}", path.display())]
    Tps {
        /// The landmark file.
        path: PathBuf,
        /// The frame.
        frame: usize,
        /// Why.
        error: TpsError,
    },
    /// No usable surface in frame 0.
    #[error("{}: {error}", path.display())]
    Surface {
        /// The frame-0 image.
        path: PathBuf,
        /// Why.
        error: SurfaceError,
    },
    /// The free wall cannot be selected.
    #[error("{}: {error}", path.display())]
    FreeWall {
        /// The subject folder.
        path: PathBuf,
        /// Why.
        error: FreeWallError,
    },
}

impl TableErrors for LvError {
    fn unreadable(path: &Path, error: std::io::Error) -> Self {
        layout(path, LayoutProblem::Read(error))
    }
    fn malformed(path: &Path, line: u64, error: qcshape::io::table::CsvError) -> Self {
        layout(path, LayoutProblem::Row { line, error })
    }
}

fn layout(path: &Path, problem: LayoutProblem) -> LvError {
    LvError::Layout {
        path: path.into(),
        problem,
    }
}

/// What is wrong with a file or folder of a cohort ([`LvError::Layout`]).
#[derive(Debug, Error)]
pub enum LayoutProblem {
    /// The file or folder cannot be read.
    #[error("cannot read: {0}")]
    Read(std::io::Error),
    /// The folder cannot be created.
    #[error("cannot create: {0}")]
    Create(std::io::Error),
    /// A malformed row of a CSV file (on a 1-based line), with the CSV reader's error.
    #[error("line {line}: malformed CSV: {error}")]
    Row {
        /// Line number.
        line: u64,
        /// The CSV reader's error.
        error: qcshape::io::table::CsvError,
    },
    /// A CSV header without the expected columns.
    #[error("the header must be {0}")]
    Header(&'static str),
    /// A subject name that is empty, holds a path separator or starts with a dot.
    #[error("line {line}: bad subject name {name:?}")]
    SubjectName {
        /// Line number.
        line: u64,
        /// The name.
        name: String,
    },
    /// A subject listed twice.
    #[error("line {line}: subject {name:?} is listed twice")]
    DuplicateSubject {
        /// Line number.
        line: u64,
        /// The name.
        name: String,
    },
    /// A labels file listing no subject.
    #[error("lists no subject")]
    NoSubjects,
    /// A listed subject without a folder.
    #[error("subject {name:?}: folder {} does not exist", folder.display())]
    NoSubjectFolder {
        /// The subject.
        name: String,
        /// Its folder.
        folder: PathBuf,
    },
    /// A folder that is not a cohort (no labels file, no subject folder).
    #[error("no {LABELS_NAME} and no sub-folder with a {LANDMARKS_NAME}")]
    NotACohort,
    /// A subject folder without images.
    #[error("holds no .nii or .nii.gz image")]
    NoImages,
    /// A file of several frames among one-file-per-frame images.
    #[error("holds {0} frames, but the folder has one file per frame")]
    SeveralFrames(usize),
    /// A frame whose dimensions or affine differ from the first frame's.
    #[error("dims {dims:?} or affine differ from the first frame {first:?}")]
    FrameMismatch {
        /// Its dimensions.
        dims: [usize; 3],
        /// The first frame's.
        first: [usize; 3],
    },
    /// Fewer landmarks per frame than asked for.
    #[error("has {found} landmarks per frame, fewer than the {asked} asked for")]
    TooFewLandmarks {
        /// Landmarks per frame.
        found: usize,
        /// Landmarks asked for.
        asked: usize,
    },
    /// A registration cannot be encoded as JSON.
    #[error("cannot encode: {0}")]
    Encode(serde_json::Error),
    /// A registration file that is not valid JSON of a registration.
    #[error("bad JSON: {0}")]
    Json(serde_json::Error),
    /// A registration without maps, or with centres and weights of different lengths.
    #[error("no maps, or centres and weights of different lengths")]
    Registration,
    /// A row of `abnormal.csv` whose field is not a finite number (1-based line and field).
    #[error("line {line}: field {field} is not a number")]
    Field {
        /// Line number.
        line: usize,
        /// Field number.
        field: usize,
    },
    /// A row of `abnormal.csv` without six fields.
    #[error("line {line}: {found} fields, expected 6")]
    FieldCount {
        /// Line number.
        line: usize,
        /// Fields found.
        found: usize,
    },
    /// A landmark missing in frame 0 of the template subject.
    #[error("landmark {0} is missing in frame 0")]
    MissingLandmark(u32),
}

/// A subject of a cohort folder.
#[derive(Debug, Clone, PartialEq)]
pub struct SubjectDir {
    /// Its name (folder name).
    pub name: String,
    /// Its folder.
    pub path: PathBuf,
    /// Its label, if `labels.csv` gives one.
    pub label: Option<String>,
}

/// Reads `labels.csv` (`subject,label`, `#` comments): the subjects in file order.
pub fn read_labels(path: &Path) -> Result<Vec<(String, Option<String>)>, LvError> {
    let mut table = Table::<LvError>::read(path, false)?;
    let (Some(cs), Some(cl)) = (table.column("subject"), table.column("label")) else {
        return Err(layout(path, LayoutProblem::Header("subject,label")));
    };
    let mut out: Vec<(String, Option<String>)> = Vec::new();
    for rec in table.rows() {
        let (line, rec) = rec?;
        let name = rec.get(cs).unwrap_or("").to_string();
        if name.is_empty() || name.contains(['/', '\\']) || name.starts_with('.') {
            return Err(layout(path, LayoutProblem::SubjectName { line, name }));
        }
        if out.iter().any(|(n, _)| *n == name) {
            return Err(layout(path, LayoutProblem::DuplicateSubject { line, name }));
        }
        let label = Some(rec.get(cl).unwrap_or("").to_string()).filter(|l| !l.is_empty());
        out.push((name, label));
    }
    if out.is_empty() {
        return Err(layout(path, LayoutProblem::NoSubjects));
    }
    Ok(out)
}

/// Writes `labels.csv` atomically.
pub fn write_labels(path: &Path, rows: &[(String, Option<String>)]) -> Result<(), LvError> {
    let mut s = String::from("subject,label\n");
    for (n, l) in rows {
        s.push_str(&format!("{n},{}\n", l.as_deref().unwrap_or("")));
    }
    write_atomically(path, |w| w.write_all(s.as_bytes()))?;
    Ok(())
}

/// The subjects of a cohort folder (see the module docs).
pub fn subjects(dir: &Path) -> Result<Vec<SubjectDir>, LvError> {
    let labels = dir.join(LABELS_NAME);
    if labels.is_file() {
        return read_labels(&labels)?
            .into_iter()
            .map(|(name, label)| {
                let path = dir.join(&name);
                if !path.is_dir() {
                    return Err(layout(
                        &labels,
                        LayoutProblem::NoSubjectFolder { name, folder: path },
                    ));
                }
                Ok(SubjectDir { name, path, label })
            })
            .collect();
    }
    let entries = std::fs::read_dir(dir).map_err(|e| layout(dir, LayoutProblem::Read(e)))?;
    let mut names: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join(LANDMARKS_NAME).is_file())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .filter(|n| !n.starts_with('.'))
        .collect();
    names.sort_by(|a, b| natural_cmp(a, b));
    if names.is_empty() {
        return Err(layout(dir, LayoutProblem::NotACohort));
    }
    Ok(names
        .into_iter()
        .map(|name| SubjectDir {
            path: dir.join(&name),
            name,
            label: None,
        })
        .collect())
}

/// The NIfTI files of a subject folder in natural name order.
pub fn image_files(subject: &Path) -> Result<Vec<PathBuf>, LvError> {
    let entries = std::fs::read_dir(subject).map_err(|e| layout(subject, LayoutProblem::Read(e)))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| {
            let n = p
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or("")
                .to_ascii_lowercase();
            !n.starts_with('.') && (n.ends_with(".nii") || n.ends_with(".nii.gz"))
        })
        .collect();
    files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    if files.is_empty() {
        return Err(layout(subject, LayoutProblem::NoImages));
    }
    Ok(files)
}

/// All frames of a subject: one 4D file, or one 3D file per frame (same dims and affine).
pub fn read_frames(subject: &Path) -> Result<Vec<Volume>, LvError> {
    let files = image_files(subject)?;
    if files.len() == 1 {
        return Ok(read_series(&files[0])?);
    }
    let mut frames = Vec::with_capacity(files.len());
    for f in &files {
        let mut s = read_series(f)?;
        if s.len() != 1 {
            return Err(layout(f, LayoutProblem::SeveralFrames(s.len())));
        }
        let v = s.remove(0);
        if let Some(v0) = frames.first().map(|v0: &Volume| (v0.dims, v0.affine)) {
            if v0 != (v.dims, v.affine) {
                return Err(layout(
                    f,
                    LayoutProblem::FrameMismatch {
                        dims: v.dims,
                        first: v0.0,
                    },
                ));
            }
        }
        frames.push(v);
    }
    Ok(frames)
}

/// Frame 0 of a subject and the file it came from.
pub fn read_frame0(subject: &Path) -> Result<(Volume, PathBuf), LvError> {
    let files = image_files(subject)?;
    let mut s = read_series(&files[0])?;
    Ok((s.remove(0), files[0].clone()))
}

/// Writes a phantom subject: `frameNN.nii.gz` files (or one 4D `image.nii.gz`) and
/// `landmarks.csv` into `dir/<name>/`.
pub fn write_subject(dir: &Path, s: &PhantomSubject, four_d: bool) -> Result<PathBuf, LvError> {
    let sub = dir.join(&s.name);
    std::fs::create_dir_all(&sub).map_err(|e| layout(&sub, LayoutProblem::Create(e)))?;
    if four_d {
        write_series(&sub.join("image.nii.gz"), &s.frames)?;
    } else {
        for (t, f) in s.frames.iter().enumerate() {
            write_volume(&sub.join(format!("frame{t:02}.nii.gz")), f)?;
        }
    }
    write_landmarks(&sub.join(LANDMARKS_NAME), &s.landmarks)?;
    Ok(sub)
}

/// Thin-plate-spline maps from frame 0 to every frame (frame 0's is the identity fit),
/// from the first `n` landmarks, on one subject.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Registration {
    /// Number of landmarks used.
    pub landmarks: usize,
    /// Regularization lambda.
    pub regularization: f64,
    /// `maps[k]` takes frame-0 world positions to frame `k` (#frames).
    pub maps: Vec<Tps>,
}

impl Registration {
    /// The file name `tps_nNN.json` for `n` landmarks.
    pub fn file_name(n: usize) -> String {
        format!("tps_n{n:02}.json")
    }

    /// Fits the maps from a subject's landmarks (`path` is named in errors).
    pub fn fit(lm: &Landmarks, n: usize, lambda: f64, path: &Path) -> Result<Registration, LvError> {
        let sub = lm.first(n).ok_or_else(|| {
            layout(
                path,
                LayoutProblem::TooFewLandmarks {
                    found: lm.ids.len(),
                    asked: n,
                },
            )
        })?;
        let maps = sub
            .frames
            .iter()
            .enumerate()
            .map(|(k, f)| {
                Tps::fit(&sub.frames[0], f, lambda).map_err(|error| LvError::Tps {
                    path: path.into(),
                    frame: k,
                    error,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Registration {
            landmarks: n,
            regularization: lambda,
            maps,
        })
    }

    /// The largest distance (world mm) between a landmark carried by a map and its position in
    /// that frame, over the first [`Registration::landmarks`] landmarks of `lm` and every
    /// frame (0 up to rounding when the regularization is 0); `None` if `lm` has fewer
    /// landmarks.
    pub fn max_landmark_residual(&self, lm: &Landmarks) -> Option<f64> {
        let sub = lm.first(self.landmarks)?;
        let mut worst = 0.0f64;
        for (m, f) in self.maps.iter().zip(&sub.frames) {
            for (p, q) in sub.frames[0].iter().zip(f) {
                let r = m.apply(*p);
                worst =
                    worst.max(((r[0] - q[0]).powi(2) + (r[1] - q[1]).powi(2) + (r[2] - q[2]).powi(2)).sqrt());
            }
        }
        Some(worst)
    }

    /// Writes the registration as JSON, atomically.
    pub fn write(&self, path: &Path) -> Result<(), LvError> {
        let text = serde_json::to_string_pretty(self).map_err(|e| layout(path, LayoutProblem::Encode(e)))?;
        write_atomically(path, |w| w.write_all(text.as_bytes()))?;
        Ok(())
    }

    /// Reads a registration written by [`Registration::write`].
    pub fn read(path: &Path) -> Result<Registration, LvError> {
        let text = qcshape::limits::read_regular_text(path, qcshape::limits::MAX_TABLE_FILE_BYTES)
            .map_err(|e| layout(path, LayoutProblem::Read(e)))?;
        let r: Registration =
            serde_json::from_str(&text).map_err(|e| layout(path, LayoutProblem::Json(e)))?;
        if r.maps.is_empty() || r.maps.iter().any(|m| m.centres.len() != m.weights.len()) {
            return Err(layout(path, LayoutProblem::Registration));
        }
        Ok(r)
    }

    /// The mesh carried to every frame: `result[k] = maps[k](positions)` (#frames x #V x 3).
    pub fn carry(&self, positions: &[[f64; 3]]) -> Vec<Vec<[f64; 3]>> {
        self.maps.iter().map(|m| m.apply_all(positions)).collect()
    }
}

/// Reads a subject's `landmarks.csv`.
pub fn read_subject_landmarks(subject: &Path) -> Result<(Landmarks, PathBuf), LvError> {
    let p = subject.join(LANDMARKS_NAME);
    Ok((read_landmarks(&p)?, p))
}
