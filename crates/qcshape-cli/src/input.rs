//! Reading the inputs of the commands that start from a distance matrix.

use std::path::Path;

use anyhow::Result;
use qcshape::similarity::{read_labels, DistanceMatrix};

/// Whether INPUT is a distance matrix CSV rather than a data set (a folder, or a manifest whose
/// header names the `deformation` column).
pub(crate) fn is_matrix(path: &Path) -> Result<bool> {
    if path.is_dir() {
        return Ok(false);
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
