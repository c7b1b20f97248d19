//! The output files of `qcshape similarity` and `similarity-merge`: the matrix (CSV, or .npy
//! with the names beside it) and the per-pose details.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use qcshape::similarity::{DistanceMatrix, PairDistance};

/// The files `write_matrix` writes for output `path`: the matrix, and for `.npy` the names.
pub(crate) fn matrix_files(path: &Path) -> Vec<(PathBuf, &'static str)> {
    let npy = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("npy"));
    let names = npy.then(|| (path.with_extension("names.txt"), "the names file of -o"));
    std::iter::once((path.to_path_buf(), "-o")).chain(names).collect()
}

/// Writes the matrix as CSV, or as a NumPy (n, n) float64 array when the name ends in .npy
/// (the names, which .npy cannot hold, go to NAME.names.txt).
pub(crate) fn write_matrix(path: &Path, matrix: &DistanceMatrix) -> Result<()> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("npy")) {
        let n = matrix.len();
        qcshape::io::npy::write_matrix(path, matrix.values(), n, n)?;
        let names = path.with_extension("names.txt");
        let text: String = matrix.names().iter().map(|s| format!("{s}\n")).collect();
        qcshape::io::write_atomically(&names, |w: &mut dyn std::io::Write| w.write_all(text.as_bytes()))?;
    } else {
        matrix.write_csv(path)?;
    }
    Ok(())
}

/// Writes the per-pose distances of every pair (`--details`).
pub(crate) fn write_details(path: &Path, names: &[String], pairs: &[PairDistance]) -> Result<()> {
    let text = qcshape::similarity::details_csv(names, pairs);
    qcshape::io::write_atomically(path, |w| w.write_all(text.as_bytes()))
        .with_context(|| format!("cannot write {}", path.display()))
}
