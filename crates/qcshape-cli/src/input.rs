//! Reading the inputs of the commands that start from a distance matrix.

use std::path::{Path, PathBuf};

use anyhow::Result;
use qcshape::similarity::{read_labels, DistanceMatrix};

/// Whether INPUT is a distance matrix CSV rather than a data set (a folder, or a manifest whose
/// header names the `deformation` column).
pub(crate) fn is_matrix(path: &Path) -> Result<bool> {
    if path.is_dir() {
        return Ok(false);
    }
    // A FIFO or device is never opened here (it could block); the matrix reader refuses it.
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return Ok(true);
    }
    // An unreadable file is left to the matrix reader, whose error names the file.
    let Ok(file) = std::fs::File::open(path) else {
        return Ok(true);
    };
    let mut first = String::new();
    if std::io::BufRead::read_line(&mut std::io::BufReader::new(file), &mut first).is_err() {
        return Ok(true);
    }
    let first = first.trim_start_matches('\u{feff}');
    Ok(first.starts_with("name,") || !first.contains("deformation"))
}

/// Reads the distance matrix of the deformations to classify.
pub(crate) fn load_matrix(path: &Path) -> Result<DistanceMatrix> {
    Ok(DistanceMatrix::read_csv(path)?)
}

/// The label of each deformation of `d` (matrix order) from a label file.
pub(crate) fn load_labels(path: &Path, d: &DistanceMatrix) -> Result<Vec<String>> {
    let pairs = read_labels(path)?;
    d.labels_for(&pairs)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// Refuses, before anything is computed, every output file in `outputs` (`(path, option)`,
/// absent ones skipped) that is one of `inputs` or an existing folder
/// ([`qcshape::outputs::refuse_input_overlap`]).
pub(crate) fn refuse_outputs(inputs: &[&Path], outputs: &[(Option<&Path>, &str)]) -> Result<()> {
    for (out, what) in outputs {
        if let Some(out) = out {
            qcshape::outputs::refuse_input_overlap(inputs, out, what)?;
        }
    }
    Ok(())
}

/// Refuses, before anything is computed, an output folder that holds (or is) one of `inputs`
/// ([`qcshape::outputs::refuse_folder_overlap`]).
pub(crate) fn refuse_out_folder(inputs: &[&Path], folder: &Path, what: &str) -> Result<()> {
    Ok(qcshape::outputs::refuse_folder_overlap(inputs, folder, what)?)
}

/// The given input paths and every pose file of `data`.
pub(crate) fn all_inputs<'a>(given: &'a [PathBuf], data: &'a qcshape::dataset::Dataset) -> Vec<&'a Path> {
    given
        .iter()
        .map(PathBuf::as_path)
        .chain(
            data.deformations
                .iter()
                .flat_map(|d| d.paths.iter().map(PathBuf::as_path)),
        )
        .collect()
}

/// A file-name-safe folder name for a deformation (`interpolate`, `fit`): letters, digits,
/// `-`, `_`, `.` kept, the rest `_`; a name that is empty or starts with `.` gets a `d` in
/// front (no hidden folder, no `..`).
pub(crate) fn folder_for(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with('.') {
        format!("d{s}")
    } else {
        s
    }
}
