//! Deformation data sets: named sequences of poses (meshes with one connectivity), loaded from
//! a manifest CSV or a folder layout.
//!
//! # Layouts
//!
//! - **Manifest**: a CSV file with the header `deformation,label,pose,path` (columns in any
//!   order; extra columns and `#` comment lines are ignored). `label` may be empty; `pose` is
//!   the index of the pose in its deformation, `0, 1, ..., K-1` without gaps or repeats (rows may
//!   come in any order); `path`
//!   is relative to the manifest's folder (or absolute). Deformations keep the order in which
//!   they first appear.
//! - **Folder of folders**: one sub-folder per deformation (named after it, natural order),
//!   each holding its poses as mesh files (`.obj .ply .off .stl .vtk`) whose names sort into
//!   pose order with [`natural_cmp`] (`pose2` before `pose10`). A folder holding a
//!   `manifest.csv` is read through the manifest instead.
//! - **Folder of mesh files**, or an explicit list of files: one deformation
//!   ([`load_sequence`]).
//!
//! Hidden entries (names starting with `.`) are ignored.
//!
//! # Checks
//!
//! Every pose goes through [`crate::io::read_mesh`] and [`Shape::new_checked`] (finite
//! coordinates, no zero-area face) and must have exactly the vertex count and face list of the
//! first pose of its deformation. Deformations whose face lists are equal share one
//! `Arc<Topology>`.

use std::cmp::Ordering;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use rayon::prelude::*;
use thiserror::Error;

use crate::io::table::{Table, TableErrors};
use crate::io::{self, Format, IoError, MeshData};
use crate::mesh::{Shape, Topology};

/// The file name [`Dataset::load`] looks for in a folder before trying the folder layouts.
pub const MANIFEST_NAME: &str = "manifest.csv";

/// Why a data set cannot be loaded or written. Every message starts with the file or folder
/// it is about.
#[derive(Debug, Error)]
pub enum DatasetError {
    /// An output would overwrite one of the data set's files.
    #[error(transparent)]
    Output(#[from] crate::outputs::OutputError),
    /// A mesh file failed to read, parse or validate (the message names the file).
    #[error(transparent)]
    Io(#[from] IoError),
    /// A file or folder of the layout cannot be read.
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        /// The file or folder.
        path: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// A manifest problem on a given line (1-based; the header is line 1).
    #[error("{}: line {line}: {problem}", path.display())]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// Line number.
        line: u64,
        /// What is wrong, with the offending values.
        problem: ManifestProblem,
    },
    /// A pose whose connectivity differs from the first pose of its deformation.
    #[error("{}: {}{}", path.display(), difference.describe(first), in_manifest(.manifest))]
    TopologyMismatch {
        /// The offending pose file.
        path: PathBuf,
        /// The first pose's file.
        first: PathBuf,
        /// What differs.
        difference: PoseDifference,
        /// The manifest and its line listing the pose, when loaded from a manifest.
        manifest: Option<(PathBuf, u64)>,
    },
    /// The folder layout is not one of the accepted ones, or nothing to load.
    #[error("{}: {problem}", path.display())]
    Layout {
        /// The folder (or file).
        path: PathBuf,
        /// What is wrong.
        problem: DatasetLayout,
    },
}

fn in_manifest(manifest: &Option<(PathBuf, u64)>) -> String {
    match manifest {
        Some((path, line)) => format!(" (manifest {} line {line})", path.display()),
        None => String::new(),
    }
}

/// How a pose's connectivity differs from the first pose of its deformation
/// ([`DatasetError::TopologyMismatch`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PoseDifference {
    /// Different vertex counts.
    Vertices {
        /// The pose's.
        found: usize,
        /// The first pose's.
        expected: usize,
    },
    /// Different face counts.
    Faces {
        /// The pose's.
        found: usize,
        /// The first pose's.
        expected: usize,
    },
    /// The first face (by index) whose corners differ.
    Face {
        /// Face index.
        face: usize,
        /// Its corners in the pose.
        found: [u32; 3],
        /// Its corners in the first pose.
        expected: [u32; 3],
    },
}

impl PoseDifference {
    /// The difference in words, naming the first pose's file.
    pub fn describe(&self, first: &Path) -> String {
        let first = first.display();
        match self {
            PoseDifference::Vertices { found, expected } => {
                format!("has {found} vertices, but the first pose of its deformation ({first}) has {expected}")
            }
            PoseDifference::Faces { found, expected } => {
                format!("has {found} faces, but the first pose of its deformation ({first}) has {expected}")
            }
            PoseDifference::Face { face, found, expected } => format!(
                "face {face} is {found:?}, but in the first pose of its deformation ({first}) it is {expected:?}"
            ),
        }
    }
}

/// Why the files of a data set do not form one ([`DatasetError::Layout`]).
#[derive(Debug, Error)]
pub enum DatasetLayout {
    /// A command that needs class labels, and deformations without one.
    #[error("{what} needs a label for every deformation; {} of {total} have none: {}", missing.len(), shown_names(missing))]
    MissingLabels {
        /// The command (or step) that needs them.
        what: String,
        /// The deformations without a label.
        missing: Vec<String>,
        /// All deformations.
        total: usize,
    },
    /// A mesh file given where a data set (a manifest or a folder) is expected.
    #[error("is a mesh file, not a data set: give a manifest CSV (deformation,label,pose,path) or a folder with one sub-folder of poses per deformation (docs/formats.md)")]
    MeshFile,
    /// A folder given as one sequence without mesh files.
    #[error("contains no mesh files ({})", known_extensions())]
    NoMeshFiles,
    /// An empty list of files.
    #[error("no mesh files given")]
    NoFilesGiven,
    /// A deformation sub-folder without mesh files beside others with them.
    #[error("sub-folder {name} holds no mesh files ({}), while {others} other sub-folder(s) do; every sub-folder is a deformation: add its poses or move it out", known_extensions())]
    EmptySubfolder {
        /// The sub-folder's name.
        name: String,
        /// Sub-folders with mesh files.
        others: usize,
    },
    /// A folder with neither mesh files nor sub-folders of them.
    #[error(
        "contains no mesh files ({}) and no sub-folders with mesh files",
        known_extensions()
    )]
    Nothing,
    /// A folder with mesh files and sub-folders of mesh files.
    #[error("has both mesh files and sub-folders of mesh files; put each deformation in its own sub-folder (or list its files explicitly)")]
    Mixed,
    /// A deformation without poses.
    #[error("the deformation has no poses")]
    NoPoses,
    /// A manifest row whose path is not valid UTF-8 (0-based row).
    #[error("row {row}: path {} is not valid UTF-8", path.display())]
    NonUtf8Path {
        /// The row.
        row: usize,
        /// Its path.
        path: PathBuf,
    },
    /// A manifest row with an empty deformation name (0-based row).
    #[error("row {0}: the deformation name is empty")]
    EmptyName(usize),
    /// The manifest cannot be encoded as CSV.
    #[error("cannot encode the manifest: {0}")]
    Encode(csv::Error),
}

/// At most 20 names, quoted, then how many more.
fn shown_names(names: &[String]) -> String {
    let shown: Vec<String> = names.iter().take(20).map(|n| format!("{n:?}")).collect();
    let more = if names.len() > 20 {
        format!(" and {} more", names.len() - 20)
    } else {
        String::new()
    };
    format!("{}{more}", shown.join(", "))
}

/// One deformation: poses (each #V x 3) sharing one topology.
#[derive(Debug, Clone)]
pub struct Deformation {
    /// Its name (manifest `deformation` column, or folder name).
    pub name: String,
    /// Its class label, if the manifest gives one.
    pub label: Option<String>,
    /// Connectivity shared by all poses (and by other deformations with the same faces).
    pub topology: Arc<Topology>,
    /// Vertex positions of each pose in order (#poses x #V x 3), in the files' length unit.
    pub poses: Vec<Vec<[f64; 3]>>,
    /// The file each pose was read from.
    pub paths: Vec<PathBuf>,
    /// Reader warnings, each prefixed with its file.
    pub warnings: Vec<String>,
}

impl Deformation {
    /// Number of poses.
    pub fn n_poses(&self) -> usize {
        self.poses.len()
    }

    /// Pose `i` as a [`Shape`] (copies the positions). Panics if `i >= n_poses()`.
    pub fn shape(&self, i: usize) -> Shape {
        Shape {
            topology: self.topology.clone(),
            positions: self.poses[i].clone(),
        }
    }
}

/// A collection of deformations.
#[derive(Debug, Clone, Default)]
pub struct Dataset {
    /// The deformations, in manifest or natural folder order.
    pub deformations: Vec<Deformation>,
}

impl Dataset {
    /// Loads a manifest file, or a folder (its `manifest.csv` if present, else the folder
    /// layouts described in the [module docs](self)).
    pub fn load(path: &Path) -> Result<Dataset, DatasetError> {
        let meta = std::fs::metadata(path).map_err(|error| DatasetError::Read {
            path: path.into(),
            error,
        })?;
        if !meta.is_dir() {
            // A mesh file is no data set (its CSV error would only confuse: issue 60).
            if crate::io::Format::from_path(path).is_some() {
                return Err(DatasetError::Layout {
                    path: path.into(),
                    problem: DatasetLayout::MeshFile,
                });
            }
            return Dataset::from_manifest(path);
        }
        let manifest = path.join(MANIFEST_NAME);
        if manifest.is_file() {
            return Dataset::from_manifest(&manifest);
        }
        Dataset::from_folder(path)
    }

    /// Loads the deformations listed by a manifest CSV.
    pub fn from_manifest(path: &Path) -> Result<Dataset, DatasetError> {
        let mut cache = TopologyCache::default();
        let mut deformations = Vec::new();
        for (d, lines) in manifest_files(path)? {
            let files = d.files.clone();
            let d = load_deformation(d.name, d.label, d.files, &mut cache).map_err(|e| match e {
                // Name the manifest line of the pose file, too.
                DatasetError::TopologyMismatch {
                    path: file,
                    first,
                    difference,
                    ..
                } => {
                    let manifest = files
                        .iter()
                        .position(|f| *f == file)
                        .map(|k| (path.to_path_buf(), lines[k]));
                    DatasetError::TopologyMismatch {
                        path: file,
                        first,
                        difference,
                        manifest,
                    }
                }
                e => e,
            })?;
            deformations.push(d);
        }
        Ok(Dataset { deformations })
    }

    /// The deformations of a data set (a manifest, or a folder as [`Dataset::load`] reads it)
    /// with their pose files, checked like [`Dataset::load`] checks the layout, without reading
    /// a mesh: for poses of any triangulation, which [`crate::fit`] fits to one template first.
    pub fn files(path: &Path) -> Result<Vec<DeformationFiles>, DatasetError> {
        let meta = std::fs::metadata(path).map_err(|error| DatasetError::Read {
            path: path.into(),
            error,
        })?;
        if !meta.is_dir() {
            return Ok(manifest_files(path)?.into_iter().map(|(d, _)| d).collect());
        }
        let manifest = path.join(MANIFEST_NAME);
        if manifest.is_file() {
            return Ok(manifest_files(&manifest)?.into_iter().map(|(d, _)| d).collect());
        }
        folder_files(path)
    }
}

/// One deformation's pose files, in pose order, before any mesh is read ([`Dataset::files`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeformationFiles {
    /// Its name (manifest `deformation` column, or folder name).
    pub name: String,
    /// Its class label, if the manifest gives one.
    pub label: Option<String>,
    /// The pose files in pose order.
    pub files: Vec<PathBuf>,
}

/// The deformations a manifest lists, each with the manifest line of each pose.
fn manifest_files(path: &Path) -> Result<Vec<(DeformationFiles, Vec<u64>)>, DatasetError> {
    let rows = read_manifest(path)?;
    let base = path.parent().unwrap_or(Path::new(""));
    // Group by deformation in order of first appearance.
    let mut order: Vec<String> = Vec::new();
    let mut groups: HashMap<String, Vec<(u64, ManifestRow)>> = HashMap::new();
    for (line, row) in rows {
        let group = groups.entry(row.deformation.clone()).or_insert_with(|| {
            order.push(row.deformation.clone());
            Vec::new()
        });
        group.push((line, row));
    }
    let bad = |line: u64, problem: ManifestProblem| DatasetError::Manifest {
        path: path.into(),
        line,
        problem,
    };
    let mut deformations = Vec::with_capacity(order.len());
    for name in order {
        let mut group = groups.remove(&name).unwrap_or_default();
        group.sort_by_key(|(line, row)| (row.pose, *line));
        for w in group.windows(2) {
            if w[0].1.pose == w[1].1.pose {
                return Err(bad(
                    w[1].0,
                    ManifestProblem::DuplicatePose {
                        name: name.clone(),
                        pose: w[0].1.pose,
                        first_line: w[0].0,
                        line: w[1].0,
                    },
                ));
            }
        }
        // Poses are numbered 0..K-1 without gaps.
        for (k, (line, row)) in group.iter().enumerate() {
            if row.pose < 0 {
                return Err(bad(
                    *line,
                    ManifestProblem::NegativePose {
                        name: name.clone(),
                        pose: row.pose,
                    },
                ));
            }
            if row.pose != k as i64 {
                return Err(bad(
                    *line,
                    ManifestProblem::PoseGap {
                        name: name.clone(),
                        missing: k,
                        found: row.pose,
                    },
                ));
            }
        }
        let (first_line, first) = &group[0];
        let label = first.label.clone();
        for (line, row) in &group {
            if row.label != label {
                return Err(bad(
                    *line,
                    ManifestProblem::LabelChanges {
                        name: name.clone(),
                        label: row.label.clone(),
                        first: label.clone(),
                        first_line: *first_line,
                    },
                ));
            }
        }
        let mut files = Vec::with_capacity(group.len());
        for (line, row) in &group {
            let file = base.join(&row.path);
            if !file.is_file() {
                return Err(bad(
                    *line,
                    ManifestProblem::MissingFile {
                        name: name.clone(),
                        pose: row.pose,
                        file,
                    },
                ));
            }
            files.push(file);
        }
        let lines: Vec<u64> = group.iter().map(|(line, _)| *line).collect();
        deformations.push((DeformationFiles { name, label, files }, lines));
    }
    Ok(deformations)
}

impl Dataset {
    /// Every file this data set was read from: `source` (the manifest or folder) and each
    /// pose file, for [`crate::outputs::refuse_input_overlap`] and
    /// [`crate::outputs::refuse_folder_overlap`].
    pub fn input_paths<'a>(&'a self, source: &'a Path) -> Vec<&'a Path> {
        std::iter::once(source)
            .chain(
                self.deformations
                    .iter()
                    .flat_map(|d| d.paths.iter().map(PathBuf::as_path)),
            )
            .collect()
    }

    /// Errors unless `output` is a file other than the data set `input` (manifest or folder)
    /// and every pose file: writing it must not overwrite an input
    /// ([`crate::outputs::refuse_input_overlap`]).
    pub fn refuse_overwrite(&self, input: &Path, output: &Path, what: &str) -> Result<(), DatasetError> {
        crate::outputs::refuse_input_overlap(&self.input_paths(input), output, what)?;
        Ok(())
    }

    /// Refuses a partly labelled data set: when any deformation has a (non-empty) label, every
    /// one must have one ([`Dataset::require_labels`], whose error lists those without). A data
    /// set without any label passes (`what` names the command).
    pub fn refuse_partial_labels(&self, source: &Path, what: &str) -> Result<(), DatasetError> {
        if self
            .deformations
            .iter()
            .any(|d| d.label.as_deref().is_some_and(|l| !l.is_empty()))
        {
            self.require_labels(source, what)?;
        }
        Ok(())
    }

    /// The labels of all deformations, or one error listing every deformation without one
    /// (`what` names the command that needs them).
    pub fn require_labels(&self, source: &Path, what: &str) -> Result<Vec<&str>, DatasetError> {
        let missing: Vec<&str> = self
            .deformations
            .iter()
            .filter(|d| d.label.as_deref().is_none_or(str::is_empty))
            .map(|d| d.name.as_str())
            .collect();
        if !missing.is_empty() {
            return Err(DatasetError::Layout {
                path: source.to_path_buf(),
                problem: DatasetLayout::MissingLabels {
                    what: what.to_string(),
                    missing: missing.iter().map(|n| n.to_string()).collect(),
                    total: self.deformations.len(),
                },
            });
        }
        Ok(self
            .deformations
            .iter()
            .filter_map(|d| d.label.as_deref())
            .collect())
    }

    /// Loads a folder with one sub-folder of mesh files per deformation, or a folder of mesh
    /// files as a single deformation.
    pub fn from_folder(dir: &Path) -> Result<Dataset, DatasetError> {
        let mut cache = TopologyCache::default();
        let deformations = folder_files(dir)?
            .into_iter()
            .map(|d| load_deformation(d.name, d.label, d.files, &mut cache))
            .collect::<Result<_, _>>()?;
        Ok(Dataset { deformations })
    }

    /// Each deformation's label (`None` where the manifest leaves it empty), in order.
    pub fn labels(&self) -> Vec<Option<&str>> {
        self.deformations.iter().map(|d| d.label.as_deref()).collect()
    }

    /// Whether every deformation has the same connectivity (one shared `Arc<Topology>`), as
    /// comparing deformations across the data set requires. True for an empty data set.
    pub fn shares_topology(&self) -> bool {
        match self.deformations.first() {
            None => true,
            Some(d0) => self
                .deformations
                .iter()
                .all(|d| Arc::ptr_eq(&d.topology, &d0.topology)),
        }
    }
}

/// Loads one deformation from mesh files in pose order, or from a single folder of mesh files
/// (sorted with [`natural_cmp`]). Its name is the folder's name (the common parent folder of
/// the files, else the first file's stem).
pub fn load_sequence(files: &[PathBuf]) -> Result<Deformation, DatasetError> {
    let d = sequence_files(files)?;
    load_deformation(d.name, d.label, d.files, &mut TopologyCache::default())
}

/// The one deformation [`load_sequence`] reads from `files` (its name and pose files), without
/// reading a mesh.
pub fn sequence_files(files: &[PathBuf]) -> Result<DeformationFiles, DatasetError> {
    if let [dir] = files {
        if dir.is_dir() {
            let meshes = mesh_files(dir)?;
            if meshes.is_empty() {
                return Err(DatasetError::Layout {
                    path: dir.clone(),
                    problem: DatasetLayout::NoMeshFiles,
                });
            }
            return Ok(DeformationFiles {
                name: folder_name(dir),
                label: None,
                files: meshes,
            });
        }
    }
    let Some(first) = files.first() else {
        return Err(DatasetError::Layout {
            path: PathBuf::new(),
            problem: DatasetLayout::NoFilesGiven,
        });
    };
    let parent = first.parent().unwrap_or(Path::new(""));
    let name = if files
        .iter()
        .all(|f| f.parent().unwrap_or(Path::new("")) == parent)
        && parent.file_name().is_some()
    {
        folder_name(parent)
    } else {
        first
            .file_stem()
            .map_or_else(|| "sequence".into(), |s| s.to_string_lossy().into_owned())
    };
    Ok(DeformationFiles {
        name,
        label: None,
        files: files.to_vec(),
    })
}

/// The deformations of a folder of deformation folders, or of a folder of mesh files (one
/// deformation named after the folder).
fn folder_files(dir: &Path) -> Result<Vec<DeformationFiles>, DatasetError> {
    let (subdirs, files) = list_dir(dir)?;
    let mut groups = Vec::new();
    let mut empty = Vec::new();
    for sub in subdirs {
        let meshes = mesh_files(&sub)?;
        if meshes.is_empty() {
            empty.push(sub);
        } else {
            groups.push((folder_name(&sub), meshes));
        }
    }
    let layout = |problem: DatasetLayout| DatasetError::Layout {
        path: dir.into(),
        problem,
    };
    // Every sub-folder is a deformation: one without poses among others is a mistake (a
    // failed export, a typo), not something to drop silently.
    if let (false, Some(sub)) = (groups.is_empty(), empty.first()) {
        return Err(layout(DatasetLayout::EmptySubfolder {
            name: folder_name(sub),
            others: groups.len(),
        }));
    }
    match (groups.is_empty(), files.is_empty()) {
        (true, true) => Err(layout(DatasetLayout::Nothing)),
        (false, false) => Err(layout(DatasetLayout::Mixed)),
        (true, false) => Ok(vec![DeformationFiles {
            name: folder_name(dir),
            label: None,
            files,
        }]),
        (false, true) => Ok(groups
            .into_iter()
            .map(|(name, files)| DeformationFiles {
                name,
                label: None,
                files,
            })
            .collect()),
    }
}

/// The mesh files (known extensions, not hidden) directly in `dir`, in natural order.
pub fn mesh_files(dir: &Path) -> Result<Vec<PathBuf>, DatasetError> {
    Ok(list_dir(dir)?.1)
}

/// Compares names "naturally": runs of digits compare as numbers (`pose2 < pose10`), other
/// text compares case-insensitively, with a plain byte comparison as the final tie-break.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    fn chunks(s: &str) -> Vec<(bool, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        let bytes = s.as_bytes();
        for i in 1..=bytes.len() {
            if i == bytes.len() || bytes[i].is_ascii_digit() != bytes[start].is_ascii_digit() {
                out.push((bytes[start].is_ascii_digit(), &s[start..i]));
                start = i;
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for (x, y) in ca.iter().zip(&cb) {
        let ord = match (x, y) {
            ((true, p), (true, q)) => {
                let (p, q) = (p.trim_start_matches('0'), q.trim_start_matches('0'));
                p.len().cmp(&q.len()).then_with(|| p.cmp(q))
            }
            ((_, p), (_, q)) => p.to_lowercase().cmp(&q.to_lowercase()),
        };
        if ord != Ordering::Equal {
            return ord;
        }
    }
    ca.len().cmp(&cb.len()).then_with(|| a.cmp(b))
}

/// One manifest line: a pose of a deformation and the file it is stored in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ManifestRow {
    /// Deformation name (non-empty).
    pub deformation: String,
    /// Class label, if any.
    pub label: Option<String>,
    /// Pose number; orders the poses of a deformation.
    pub pose: i64,
    /// Mesh file, relative to the manifest's folder (or absolute).
    pub path: PathBuf,
}

impl TableErrors for DatasetError {
    fn unreadable(path: &Path, error: std::io::Error) -> Self {
        DatasetError::Read {
            path: path.into(),
            error,
        }
    }
    fn malformed(path: &Path, line: u64, error: csv::Error) -> Self {
        DatasetError::Manifest {
            path: path.into(),
            line,
            problem: ManifestProblem::Csv(error),
        }
    }
}

/// What is wrong on a line of a manifest ([`DatasetError::Manifest`]).
#[derive(Debug, Error)]
pub enum ManifestProblem {
    /// Not CSV as qcshape reads it (the csv crate's error).
    #[error("malformed CSV: {0}")]
    Csv(csv::Error),
    /// A column the manifest needs is not in its header.
    #[error("missing column {name:?}: the header must name the columns {}{hint}", MANIFEST_COLUMNS.join(","))]
    MissingColumn {
        /// The column.
        name: &'static str,
        /// What the header looks like instead, when it is one column holding another
        /// separator (empty otherwise).
        hint: String,
    },
    /// An empty `deformation` field.
    #[error("the deformation name is empty")]
    EmptyName,
    /// A `pose` field that is not an integer.
    #[error("pose {text:?} is not an integer")]
    PoseNotInteger {
        /// The field.
        text: String,
        /// The parser's error.
        error: std::num::ParseIntError,
    },
    /// An empty `path` field.
    #[error("the path is empty")]
    EmptyPath,
    /// A header and no row.
    #[error("the manifest lists no poses")]
    NoPoses,
    /// A pose index listed twice for one deformation.
    #[error("deformation {name:?} has pose {pose} twice (lines {first_line} and {line})")]
    DuplicatePose {
        /// The deformation.
        name: String,
        /// The pose index.
        pose: i64,
        /// The line of its first listing.
        first_line: u64,
        /// This line.
        line: u64,
    },
    /// A negative pose index.
    #[error("deformation {name:?} has the negative pose index {pose}: poses are numbered 0, 1, ..., K-1")]
    NegativePose {
        /// The deformation.
        name: String,
        /// The index.
        pose: i64,
    },
    /// A gap in the pose indices.
    #[error("deformation {name:?} has no pose {missing} (the next one is pose {found} here): poses are numbered 0, 1, ..., K-1 without gaps")]
    PoseGap {
        /// The deformation.
        name: String,
        /// The missing index.
        missing: usize,
        /// The index found instead.
        found: i64,
    },
    /// A label that changes within a deformation.
    #[error("deformation {name:?} has label {:?} here but {:?} on line {first_line}", .label.as_deref().unwrap_or(""), .first.as_deref().unwrap_or(""))]
    LabelChanges {
        /// The deformation.
        name: String,
        /// The label on this line.
        label: Option<String>,
        /// The label on its first line.
        first: Option<String>,
        /// Its first line.
        first_line: u64,
    },
    /// A pose file that does not exist.
    #[error("pose {pose} of deformation {name:?}: file {} does not exist", file.display())]
    MissingFile {
        /// The deformation.
        name: String,
        /// The pose index.
        pose: i64,
        /// The file, as resolved.
        file: PathBuf,
    },
}

/// The manifest's columns, in the order [`write_manifest`] writes them.
pub const MANIFEST_COLUMNS: [&str; 4] = ["deformation", "label", "pose", "path"];

/// Reads and checks a manifest's rows (with their line numbers); files are not opened.
pub fn read_manifest(path: &Path) -> Result<Vec<(u64, ManifestRow)>, DatasetError> {
    let bad = |line: u64, problem: ManifestProblem| DatasetError::Manifest {
        path: path.into(),
        line,
        problem,
    };
    let mut table = Table::<DatasetError>::read(path, false)?;
    let header_line = table.header_line;
    // A header read as one column that holds another separator: say which (issue 60).
    let separator = match table.header.len() {
        1 => [';', '\t', '|']
            .into_iter()
            .find(|c| table.header.get(0).is_some_and(|h| h.contains(*c))),
        _ => None,
    };
    let hint = match separator {
        Some(c) => format!(
            " (the header is one column, {:?}: the manifest's separator is a comma, not {c:?})",
            table.header.get(0).unwrap_or("")
        ),
        None => String::new(),
    };
    let mut col = [0usize; 4];
    for (slot, name) in col.iter_mut().zip(MANIFEST_COLUMNS) {
        *slot = table.column(name).ok_or_else(|| {
            bad(
                header_line,
                ManifestProblem::MissingColumn {
                    name,
                    hint: hint.clone(),
                },
            )
        })?;
    }
    let mut rows = Vec::new();
    for rec in table.rows() {
        let (line, rec) = rec?;
        let field = |k: usize| rec.get(col[k]).unwrap_or("");
        let deformation = field(0);
        if deformation.is_empty() {
            return Err(bad(line, ManifestProblem::EmptyName));
        }
        let pose_text = field(2);
        let pose = pose_text.parse::<i64>().map_err(|error| {
            bad(
                line,
                ManifestProblem::PoseNotInteger {
                    text: pose_text.to_string(),
                    error,
                },
            )
        })?;
        let file = field(3);
        if file.is_empty() {
            return Err(bad(line, ManifestProblem::EmptyPath));
        }
        let label = Some(field(1)).filter(|l| !l.is_empty()).map(str::to_string);
        rows.push((
            line,
            ManifestRow {
                deformation: deformation.to_string(),
                label,
                pose,
                path: PathBuf::from(file),
            },
        ));
    }
    if rows.is_empty() {
        return Err(bad(header_line, ManifestProblem::NoPoses));
    }
    Ok(rows)
}

/// Writes a manifest CSV (header `deformation,label,pose,path`) atomically. Paths are written
/// as given (use paths relative to the manifest's folder) and must be valid UTF-8.
pub fn write_manifest(path: &Path, rows: &[ManifestRow]) -> Result<(), DatasetError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let bad = |problem: DatasetLayout| DatasetError::Layout {
        path: path.into(),
        problem,
    };
    let write_err = |e: csv::Error| bad(DatasetLayout::Encode(e));
    w.write_record(MANIFEST_COLUMNS).map_err(write_err)?;
    for (i, r) in rows.iter().enumerate() {
        let p = r.path.to_str().ok_or_else(|| {
            bad(DatasetLayout::NonUtf8Path {
                row: i,
                path: r.path.clone(),
            })
        })?;
        if r.deformation.is_empty() {
            return Err(bad(DatasetLayout::EmptyName(i)));
        }
        let pose = r.pose.to_string();
        w.write_record([&r.deformation, r.label.as_deref().unwrap_or(""), &pose, p])
            .map_err(write_err)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| bad(DatasetLayout::Encode(e.into_error().into())))?;
    io::write_atomically(path, |out| out.write_all(&bytes))?;
    Ok(())
}

/// Topologies already built, reused when a deformation has an equal face list.
#[derive(Default)]
struct TopologyCache(Vec<Arc<Topology>>);

impl TopologyCache {
    fn get(&mut self, path: &Path, data: &MeshData) -> Result<Arc<Topology>, DatasetError> {
        if let Some(t) = self
            .0
            .iter()
            .find(|t| t.n_vertices() == data.positions.len() && t.faces() == data.faces.as_slice())
        {
            return Ok(t.clone());
        }
        let t = Topology::new(data.positions.len(), data.faces.clone()).map_err(|error| IoError::Mesh {
            path: path.into(),
            error,
        })?;
        self.0.push(t.clone());
        Ok(t)
    }
}

/// What differs between a pose's connectivity and the first pose's, if anything.
fn mismatch(topo: &Topology, data: &MeshData) -> Option<PoseDifference> {
    let (n0, n) = (topo.n_vertices(), data.positions.len());
    if n != n0 {
        return Some(PoseDifference::Vertices {
            found: n,
            expected: n0,
        });
    }
    let (f0, f) = (topo.faces(), data.faces.as_slice());
    if f.len() != f0.len() {
        return Some(PoseDifference::Faces {
            found: f.len(),
            expected: f0.len(),
        });
    }
    let i = f.iter().zip(f0).position(|(a, b)| a != b)?;
    Some(PoseDifference::Face {
        face: i,
        found: f[i],
        expected: f0[i],
    })
}

fn load_deformation(
    name: String,
    label: Option<String>,
    files: Vec<PathBuf>,
    cache: &mut TopologyCache,
) -> Result<Deformation, DatasetError> {
    let parsed: Vec<Result<MeshData, IoError>> = files.par_iter().map(|f| io::read_mesh(f)).collect();
    let mut topology: Option<Arc<Topology>> = None;
    let mut poses = Vec::with_capacity(files.len());
    let mut warnings = Vec::new();
    for (file, data) in files.iter().zip(parsed) {
        let data = data?;
        let topo = match &topology {
            Some(t) => {
                if let Some(difference) = mismatch(t, &data) {
                    return Err(DatasetError::TopologyMismatch {
                        path: file.clone(),
                        first: files[0].clone(),
                        difference,
                        manifest: None,
                    });
                }
                t.clone()
            }
            None => {
                let t = cache.get(file, &data)?;
                topology = Some(t.clone());
                t
            }
        };
        warnings.extend(data.warnings.iter().map(|w| format!("{}: {w}", file.display())));
        let shape = Shape::new_checked(topo, data.positions, io::DEGENERATE_REL_TOL).map_err(|error| {
            IoError::Mesh {
                path: file.clone(),
                error,
            }
        })?;
        poses.push(shape.positions);
    }
    let topology = topology.ok_or_else(|| DatasetError::Layout {
        path: PathBuf::from(&name),
        problem: DatasetLayout::NoPoses,
    })?;
    Ok(Deformation {
        name,
        label,
        topology,
        poses,
        paths: files,
        warnings,
    })
}

fn folder_name(dir: &Path) -> String {
    dir.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .or_else(|| {
            std::fs::canonicalize(dir)
                .ok()
                .and_then(|p| p.file_name().map(|s| s.to_string_lossy().into_owned()))
        })
        .unwrap_or_else(|| "sequence".into())
}

fn known_extensions() -> String {
    Format::ALL
        .iter()
        .map(|f| format!(".{}", f.extension()))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Sub-folders and mesh files directly in `dir` (hidden ones skipped), each naturally sorted.
fn list_dir(dir: &Path) -> Result<(Vec<PathBuf>, Vec<PathBuf>), DatasetError> {
    let read_err = |error| DatasetError::Read {
        path: dir.into(),
        error,
    };
    let mut subdirs = Vec::new();
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(read_err)? {
        let entry = entry.map_err(read_err)?;
        let name = entry.file_name();
        if name.to_string_lossy().starts_with('.') {
            continue;
        }
        let path = entry.path();
        if path.is_dir() {
            subdirs.push(path);
        } else if Format::from_path(&path).is_some() {
            files.push(path);
        }
    }
    let key = |p: &PathBuf| {
        p.file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    subdirs.sort_by(|a, b| natural_cmp(&key(a), &key(b)));
    files.sort_by(|a, b| natural_cmp(&key(a), &key(b)));
    Ok((subdirs, files))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{write_mesh, VertexAttributes};
    use crate::synth;

    /// A wobbling sphere: pose `k` scales z by `1 + 0.1 k`.
    fn poses(n: usize) -> (Vec<[u32; 3]>, Vec<Vec<[f64; 3]>>) {
        let s = synth::icosphere(1);
        let faces = s.topology.faces().to_vec();
        let poses = (0..n)
            .map(|k| {
                s.positions
                    .iter()
                    .map(|p| [p[0], p[1], p[2] * (1.0 + 0.1 * k as f64)])
                    .collect()
            })
            .collect();
        (faces, poses)
    }

    fn write(dir: &Path, rel: &str, pos: &[[f64; 3]], faces: &[[u32; 3]]) -> PathBuf {
        let p = dir.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        write_mesh(&p, pos, faces, &VertexAttributes::default()).unwrap();
        p
    }

    #[test]
    fn natural_order() {
        let mut v = vec![
            "pose10.ply",
            "pose2.ply",
            "Pose1.ply",
            "pose02.ply",
            "a",
            "pose2a.ply",
        ];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            v,
            [
                "a",
                "Pose1.ply",
                "pose02.ply",
                "pose2.ply",
                "pose2a.ply",
                "pose10.ply"
            ]
        );
        assert_eq!(natural_cmp("x9", "x10"), Ordering::Less);
        assert_eq!(natural_cmp("", "a"), Ordering::Less);
    }

    #[test]
    fn manifest_round_trip_shared_topology_and_pose_order() {
        let d = tempfile::tempdir().unwrap();
        let (faces, poses) = poses(3);
        let mut rows = Vec::new();
        for (def, label) in [("walk", Some("a")), ("jump", None)] {
            // Poses written out of order.
            for k in [2usize, 0, 1] {
                let rel = format!("meshes/{def}_{k}.{}", if k == 1 { "obj" } else { "ply" });
                write(d.path(), &rel, &poses[k], &faces);
                rows.push(ManifestRow {
                    deformation: def.into(),
                    label: label.map(Into::into),
                    pose: k as i64,
                    path: rel.into(),
                });
            }
        }
        let m = d.path().join("set.csv");
        write_manifest(&m, &rows).unwrap();
        let text = std::fs::read_to_string(&m).unwrap();
        assert!(
            text.starts_with("deformation,label,pose,path\nwalk,a,2,meshes/walk_2.ply\n"),
            "{text}"
        );
        let ds = Dataset::load(&m).unwrap();
        assert_eq!(ds.deformations.len(), 2);
        assert_eq!(ds.labels(), vec![Some("a"), None]);
        assert!(ds.shares_topology());
        let w = &ds.deformations[0];
        assert_eq!(w.name, "walk");
        assert_eq!(w.n_poses(), 3);
        assert_eq!(w.poses, poses);
        assert!(w.paths[1].ends_with("meshes/walk_1.obj"));
        assert_eq!(w.shape(2).positions, poses[2]);
        // A folder holding manifest.csv loads through it.
        std::fs::rename(&m, d.path().join(MANIFEST_NAME)).unwrap();
        assert_eq!(Dataset::load(d.path()).unwrap().deformations.len(), 2);
    }

    #[test]
    fn folder_of_folders_and_single_sequences() {
        let d = tempfile::tempdir().unwrap();
        let (faces, poses) = poses(3);
        for def in ["b_def", "a_def"] {
            for (k, name) in ["pose2.off", "pose10.vtk", "pose1.ply"].iter().enumerate() {
                let pose = [1, 2, 0][k];
                write(d.path(), &format!("{def}/{name}"), &poses[pose], &faces);
            }
            std::fs::write(d.path().join(def).join("notes.txt"), "not a mesh").unwrap();
        }
        // An empty sub-folder among deformations is refused by name, not dropped.
        std::fs::create_dir(d.path().join("empty")).unwrap();
        let e = Dataset::load(d.path()).unwrap_err().to_string();
        assert!(e.contains("sub-folder empty holds no mesh files"), "{e}");
        std::fs::remove_dir(d.path().join("empty")).unwrap();
        let ds = Dataset::load(d.path()).unwrap();
        let names: Vec<&str> = ds.deformations.iter().map(|d| d.name.as_str()).collect();
        assert_eq!(names, ["a_def", "b_def"]);
        assert!(ds.shares_topology());
        assert!(Arc::ptr_eq(
            &ds.deformations[0].topology,
            &ds.deformations[1].topology
        ));
        assert_eq!(
            ds.deformations[1].poses, poses,
            "natural order pose1, pose2, pose10"
        );

        let seq = load_sequence(&[d.path().join("a_def")]).unwrap();
        assert_eq!(seq.name, "a_def");
        assert_eq!(seq.poses, poses);
        let one = Dataset::load(&d.path().join("a_def")).unwrap();
        assert_eq!(one.deformations.len(), 1);
        // An explicit list keeps the given order.
        let files = [
            d.path().join("a_def/pose10.vtk"),
            d.path().join("a_def/pose1.ply"),
        ];
        let seq = load_sequence(&files).unwrap();
        assert_eq!(seq.name, "a_def");
        assert_eq!(seq.poses, vec![poses[2].clone(), poses[0].clone()]);
    }

    #[test]
    fn different_topologies_are_not_shared() {
        let d = tempfile::tempdir().unwrap();
        let (faces, poses) = poses(2);
        let g = synth::grid(4);
        for (k, pose) in poses.iter().enumerate() {
            write(d.path(), &format!("s/{k}.ply"), pose, &faces);
            write(d.path(), &format!("t/{k}.ply"), &g.positions, g.topology.faces());
        }
        let ds = Dataset::load(d.path()).unwrap();
        assert!(!ds.shares_topology());
    }

    /// `Dataset::files` lists what `Dataset::load` reads (names, labels, files in pose order),
    /// and lists poses of different connectivity, which `load` refuses, without reading them.
    #[test]
    fn files_list_the_layout_without_reading_the_meshes() {
        let d = tempfile::tempdir().unwrap();
        let (faces, poses) = poses(2);
        let g = synth::grid(3);
        for def in ["b", "a"] {
            write(d.path(), &format!("{def}/pose10.ply"), &poses[1], &faces);
            write(d.path(), &format!("{def}/pose2.ply"), &poses[0], &faces);
        }
        let same = |p: &Path| {
            let listed = Dataset::files(p).unwrap();
            let loaded = Dataset::load(p).unwrap();
            assert_eq!(listed.len(), loaded.deformations.len());
            for (f, l) in listed.iter().zip(&loaded.deformations) {
                assert_eq!((&f.name, &f.label, &f.files), (&l.name, &l.label, &l.paths));
            }
        };
        same(d.path());
        same(&d.path().join("a"));
        let manifest = d.path().join(MANIFEST_NAME);
        std::fs::write(
            &manifest,
            "deformation,label,pose,path\nb,x,1,b/pose10.ply\nb,x,0,b/pose2.ply\na,y,0,a/pose2.ply\na,y,1,a/pose10.ply\n",
        )
        .unwrap();
        same(&manifest);
        same(d.path());
        // Another triangulation in a pose: listed, refused by load.
        write(d.path(), "a/pose10.ply", &g.positions, g.topology.faces());
        assert_eq!(Dataset::files(&manifest).unwrap()[1].files.len(), 2);
        assert!(Dataset::load(&manifest).is_err());
        let seq = sequence_files(&[d.path().join("a")]).unwrap();
        assert_eq!(seq.name, "a");
        assert_eq!(
            seq.files,
            [d.path().join("a/pose2.ply"), d.path().join("a/pose10.ply")]
        );
    }

    #[test]
    fn mismatched_poses_name_the_file_and_the_difference() {
        let d = tempfile::tempdir().unwrap();
        let (faces, poses) = poses(2);
        write(d.path(), "x/p0.ply", &poses[0], &faces);
        let mut flipped = faces.clone();
        flipped[12] = [faces[12][1], faces[12][2], faces[12][0]];
        let bad = write(d.path(), "x/p1.ply", &poses[1], &flipped);
        let e = Dataset::load(d.path()).unwrap_err().to_string();
        assert!(e.starts_with(&bad.display().to_string()), "{e}");
        assert!(e.contains(&format!("face 12 is {:?}", flipped[12])), "{e}");
        assert!(e.contains("p0.ply) it is"), "{e}");

        let g = synth::grid(3);
        let bad = write(d.path(), "x/p1.ply", &g.positions, g.topology.faces());
        let e = Dataset::load(d.path()).unwrap_err().to_string();
        assert!(e.starts_with(&bad.display().to_string()), "{e}");
        assert!(
            e.contains("has 9 vertices, but the first pose of its deformation"),
            "{e}"
        );
        assert!(e.contains("has 42"), "{e}");
    }

    #[test]
    fn manifest_errors_name_the_manifest_and_line() {
        let d = tempfile::tempdir().unwrap();
        let (faces, poses) = poses(1);
        write(d.path(), "a.ply", &poses[0], &faces);
        let cases = [
            (
                "deformation,pose,path\nw,0,a.ply\n",
                1,
                "missing column \"label\"",
            ),
            (
                "deformation,label,pose,path\nw,,0,a.ply\nw,,x1,a.ply\n",
                3,
                "pose \"x1\" is not an integer",
            ),
            (
                "deformation,label,pose,path\nw,,0,a.ply\nw,,0,a.ply\n",
                3,
                "has pose 0 twice (lines 2 and 3)",
            ),
            (
                "deformation,label,pose,path\nw,,0,a.ply\nw,,1,b.ply\n",
                3,
                "b.ply does not exist",
            ),
            (
                "deformation,label,pose,path\nw,A,0,a.ply\nw,B,1,a.ply\n",
                3,
                "label \"B\" here but \"A\" on line 2",
            ),
            ("deformation,label,pose,path\nw,,0\n", 2, "malformed CSV"),
            ("deformation,label,pose,path\n", 1, "lists no poses"),
            (
                "deformation,label,pose,path\n,,0,a.ply\n",
                2,
                "deformation name is empty",
            ),
        ];
        for (i, (text, line, want)) in cases.into_iter().enumerate() {
            let m = d.path().join(format!("m{i}.csv"));
            std::fs::write(&m, text).unwrap();
            let e = Dataset::load(&m).unwrap_err();
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!("{}: line {line}: ", m.display())),
                "case {i}: {msg}"
            );
            assert!(msg.contains(want), "case {i}: {msg}");
        }
        let e = Dataset::load(&d.path().join("nope.csv")).unwrap_err().to_string();
        assert!(e.contains("nope.csv: cannot read"), "{e}");
    }

    #[test]
    fn bad_meshes_and_layouts() {
        let d = tempfile::tempdir().unwrap();
        let (faces, poses) = poses(1);
        write(d.path(), "w/0.ply", &poses[0], &faces);
        let bad = d.path().join("w/1.obj");
        std::fs::write(&bad, "v 0 0 0\nf 1 2 3\n").unwrap();
        let e = Dataset::load(d.path()).unwrap_err();
        assert!(matches!(e, DatasetError::Io(_)), "{e}");
        assert!(e.to_string().starts_with(&bad.display().to_string()), "{e}");

        let e = Dataset::load(&d.path().join("w")).unwrap_err().to_string();
        assert!(e.contains("1.obj: face 0 refers to vertex 2"), "{e}");

        write(d.path(), "loose.ply", &poses[0], &faces);
        let e = Dataset::load(d.path()).unwrap_err().to_string();
        assert!(e.contains("has both mesh files and sub-folders"), "{e}");

        let empty = d.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        let e = Dataset::load(&empty).unwrap_err().to_string();
        assert!(e.contains("contains no mesh files"), "{e}");
        let e = load_sequence(&[]).unwrap_err().to_string();
        assert!(e.contains("no mesh files given"), "{e}");
    }

    #[test]
    fn a_mesh_file_or_a_semicolon_manifest_is_named_as_such() {
        // Issue 60: both gave "missing column deformation" without a word on why.
        let d = tempfile::tempdir().unwrap();
        let (faces, poses) = poses(1);
        let mesh = write(d.path(), "a.ply", &poses[0], &faces);
        let e = Dataset::load(&mesh).unwrap_err().to_string();
        assert!(e.contains("is a mesh file, not a data set"), "{e}");
        let m = d.path().join("m.csv");
        std::fs::write(&m, "deformation;label;pose;path\nw;x;0;a.ply\n").unwrap();
        let e = Dataset::load(&m).unwrap_err().to_string();
        assert!(e.contains("missing column \"deformation\""), "{e}");
        assert!(e.contains("the manifest's separator is a comma, not ';'"), "{e}");
    }
}
