//! A named, symmetric distance (dissimilarity) matrix between deformations, its CSV format and
//! a class-label loader.
//!
//! # CSV format
//!
//! ```text
//! name,walk,run,jump
//! walk,0.0,1.25,3.5
//! run,1.25,0.0,2.75
//! jump,3.5,2.75,0.0
//! ```
//!
//! The header's first cell is `name` (any text is accepted when reading), followed by the `n`
//! deformation names; then one row per deformation, in the header's order, starting with its
//! name. Numbers are written in Rust's shortest round-trip form (`{:?}`), so a matrix read back
//! is bit-identical. `#` comment lines and blank lines are ignored when reading.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::dataset::{read_manifest, DatasetError};
use crate::io::table::{Table, TableErrors};
use crate::io::{write_atomically, IoError};

use super::types::PairDistance;

/// Relative tolerance of the symmetry and zero-diagonal checks of [`DistanceMatrix::new`]:
/// `|d_ij - d_ji|` and `|d_ii|` may be at most `MATRIX_REL_TOL * max_ij |d_ij|`.
pub const MATRIX_REL_TOL: f64 = 1e-9;

/// Why a matrix is not a valid distance matrix (indices are 0-based rows and columns).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MatrixError {
    /// No deformations.
    #[error("the matrix is empty")]
    Empty,
    /// `values.len()` is not `names.len()^2`.
    #[error("{names} names need {} values (n x n), got {values}", names * names)]
    NotSquare {
        /// Number of names.
        names: usize,
        /// Number of values.
        values: usize,
    },
    /// A name is empty.
    #[error("the name of row {0} is empty")]
    EmptyName(usize),
    /// A name occurs twice.
    #[error("the name {name:?} occurs twice (rows {first} and {second})")]
    DuplicateName {
        /// The name.
        name: String,
        /// First row.
        first: usize,
        /// Second row.
        second: usize,
    },
    /// An entry is NaN or infinite.
    #[error("entry ({i}, {j}) = {value} is not finite")]
    NotFinite {
        /// Row.
        i: usize,
        /// Column.
        j: usize,
        /// The value.
        value: f64,
    },
    /// An entry is negative.
    #[error("entry ({i}, {j}) = {value} is negative")]
    Negative {
        /// Row.
        i: usize,
        /// Column.
        j: usize,
        /// The value.
        value: f64,
    },
    /// A diagonal entry is not zero within tolerance.
    #[error("diagonal entry ({i}, {i}) = {value} is not zero")]
    Diagonal {
        /// Row and column.
        i: usize,
        /// The value.
        value: f64,
    },
    /// `d_ij != d_ji` beyond tolerance.
    #[error("the matrix is not symmetric: entry ({i}, {j}) = {a} but ({j}, {i}) = {b}")]
    Asymmetric {
        /// Row.
        i: usize,
        /// Column.
        j: usize,
        /// `d_ij`.
        a: f64,
        /// `d_ji`.
        b: f64,
    },
}

/// What is wrong on a line of a matrix or label file ([`MatrixFileError::Line`]).
#[derive(Debug, Error)]
pub enum LineProblem {
    /// Not CSV as qcshape reads it (the csv crate's error).
    #[error("malformed CSV: {0}")]
    Csv(csv::Error),
    /// A matrix header without names.
    #[error("the header names no deformation: expected name,<name_1>,...,<name_n>")]
    NoNames,
    /// A row past the n the header names.
    #[error("extra row: the header names {n} deformations, so there must be {n} rows")]
    ExtraRow {
        /// The header's count.
        n: usize,
    },
    /// A row with another field count than a name and n distances.
    #[error("{fields} fields, expected {} (a name and {n} distances): the matrix must be square", n + 1)]
    FieldCount {
        /// Fields in the row.
        fields: usize,
        /// The header's count.
        n: usize,
    },
    /// A row named otherwise than its column.
    #[error("row {row} is named {name:?}, but column {row} of the header is {expected:?}: rows must follow the header's order")]
    RowName {
        /// The row (1-based).
        row: usize,
        /// Its name.
        name: String,
        /// The header's name for it.
        expected: String,
    },
    /// An entry that is not a number.
    #[error("column {column:?}: {text:?} is not a number")]
    NotANumber {
        /// The column's name.
        column: String,
        /// The field.
        text: String,
        /// The parser's error.
        error: std::num::ParseFloatError,
    },
    /// An entry that is not finite.
    #[error("column {column:?}: {value} is not finite")]
    NotFinite {
        /// The column's name.
        column: String,
        /// The entry.
        value: f64,
    },
    /// A negative entry.
    #[error("column {column:?}: {value} is negative")]
    Negative {
        /// The column's name.
        column: String,
        /// The entry.
        value: f64,
    },
    /// A diagonal entry other than zero.
    #[error("diagonal entry (column {column:?}) is {value}, not zero")]
    Diagonal {
        /// The column's name.
        column: String,
        /// The entry.
        value: f64,
    },
    /// An entry that differs from its mirror.
    #[error("column {column:?} is {a} but line {other_line} (row {column:?}) has {b} in column {row:?}: the matrix is not symmetric")]
    Asymmetric {
        /// The column's name.
        column: String,
        /// This row's name.
        row: String,
        /// The entry here.
        a: f64,
        /// The mirror entry.
        b: f64,
        /// The mirror's line.
        other_line: u64,
    },
    /// A header column without a name (2-based, as in the file).
    #[error("header column {0} has an empty name")]
    EmptyName(usize),
    /// A name given twice in the header.
    #[error("the name {0:?} occurs twice")]
    DuplicateName(String),
    /// A label file giving one name two labels.
    #[error("{name:?} has label {label:?} here but {first:?} on line {first_line}")]
    LabelChanges {
        /// The name.
        name: String,
        /// The label here.
        label: String,
        /// The first label.
        first: String,
        /// The first label's line.
        first_line: u64,
    },
    /// A label file without a name column.
    #[error("no name column: a label file has a header with columns name,label (or is a data set manifest)")]
    NoNameColumn,
    /// A label file without a label column.
    #[error("no label column: a label file has a header with columns name,label")]
    NoLabelColumn,
    /// A label row without a name.
    #[error("the name is empty")]
    EmptyRowName,
    /// A label row without a label.
    #[error("{0:?} has an empty label")]
    EmptyLabel(String),
}

/// A file-level error of the matrix and label readers and writers; every message starts with
/// the file.
#[derive(Debug, Error)]
pub enum MatrixFileError {
    /// The file cannot be read.
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// A problem on a given line (1-based; the header is line 1).
    #[error("{}: line {line}: {problem}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// Line number.
        line: u64,
        /// What is wrong, with the offending values.
        problem: LineProblem,
    },
    /// The matrix cannot be encoded as CSV.
    #[error("{}: cannot encode the matrix: {error}", path.display())]
    Encode {
        /// The file.
        path: PathBuf,
        /// The CSV writer's error.
        error: csv::Error,
    },
    /// A matrix file without a header.
    #[error("{}: the file is empty: expected a header name,<name_1>,...,<name_n>", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// A matrix file with another number of rows than its header names deformations.
    #[error("{}: the header names {names} deformations but there are {rows} rows: the matrix must be square", path.display())]
    NotSquare {
        /// The file.
        path: PathBuf,
        /// Deformations the header names.
        names: usize,
        /// Rows.
        rows: usize,
    },
    /// The values do not form a distance matrix (a problem not tied to one line).
    #[error("{}: {error}", path.display())]
    Matrix {
        /// The file.
        path: PathBuf,
        /// Why.
        error: MatrixError,
    },
    /// A label file without a labelled deformation.
    #[error("{}: no labelled deformation", path.display())]
    NoLabels {
        /// The file.
        path: PathBuf,
    },
    /// A manifest given as a label file is invalid.
    #[error(transparent)]
    Manifest(#[from] DatasetError),
    /// The file cannot be written.
    #[error(transparent)]
    Write(#[from] IoError),
}

/// A symmetric matrix of non-negative distances `d_ij` between `n` named deformations (for
/// example the similarities of eq. 13), stored row-major (n x n) with a zero diagonal.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DistanceMatrix {
    names: Vec<String>,
    values: Vec<f64>,
}

impl DistanceMatrix {
    /// Checks and builds a matrix from `n` distinct non-empty names and `n * n` row-major
    /// values: all finite and non-negative, diagonal zero and `d_ij = d_ji` within
    /// [`MATRIX_REL_TOL`] of the largest entry. The stored matrix is exactly symmetric
    /// (`(d_ij + d_ji) / 2`) with an exactly zero diagonal.
    pub fn new(names: Vec<String>, values: Vec<f64>) -> Result<DistanceMatrix, MatrixError> {
        let n = names.len();
        if n == 0 {
            return Err(MatrixError::Empty);
        }
        if values.len() != n * n {
            return Err(MatrixError::NotSquare {
                names: n,
                values: values.len(),
            });
        }
        let mut seen: HashMap<&str, usize> = HashMap::with_capacity(n);
        for (i, name) in names.iter().enumerate() {
            if name.is_empty() {
                return Err(MatrixError::EmptyName(i));
            }
            if let Some(&first) = seen.get(name.as_str()) {
                return Err(MatrixError::DuplicateName {
                    name: name.clone(),
                    first,
                    second: i,
                });
            }
            seen.insert(name, i);
        }
        let mut max = 0.0f64;
        for (k, &v) in values.iter().enumerate() {
            let (i, j) = (k / n, k % n);
            if !v.is_finite() {
                return Err(MatrixError::NotFinite { i, j, value: v });
            }
            if v < 0.0 {
                return Err(MatrixError::Negative { i, j, value: v });
            }
            max = max.max(v);
        }
        let tol = MATRIX_REL_TOL * max;
        for i in 0..n {
            let value = values[i * n + i];
            if value > tol {
                return Err(MatrixError::Diagonal { i, value });
            }
            for j in i + 1..n {
                let (a, b) = (values[i * n + j], values[j * n + i]);
                if (a - b).abs() > tol {
                    return Err(MatrixError::Asymmetric { i, j, a, b });
                }
            }
        }
        let mut values = values;
        for i in 0..n {
            values[i * n + i] = 0.0;
            for j in i + 1..n {
                let m = 0.5 * (values[i * n + j] + values[j * n + i]);
                values[i * n + j] = m;
                values[j * n + i] = m;
            }
        }
        Ok(DistanceMatrix { names, values })
    }

    /// Builds a matrix from a function of the upper triangle: `d(i, j)` is called once for
    /// each `i < j` and mirrored; the result is checked as in [`DistanceMatrix::new`].
    pub fn from_fn(
        names: Vec<String>,
        mut d: impl FnMut(usize, usize) -> f64,
    ) -> Result<DistanceMatrix, MatrixError> {
        let n = names.len();
        let mut values = vec![0.0; n * n];
        for i in 0..n {
            for j in i + 1..n {
                let v = d(i, j);
                values[i * n + j] = v;
                values[j * n + i] = v;
            }
        }
        DistanceMatrix::new(names, values)
    }

    /// Number of deformations `n`.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Always false: a matrix has at least one deformation.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// `d_ij`. Panics if `i` or `j` is out of range.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let n = self.len();
        assert!(i < n && j < n, "index ({i}, {j}) out of range for {n} x {n}");
        self.values[i * n + j]
    }

    /// Row `i` (n values). Panics if `i` is out of range.
    pub fn row(&self, i: usize) -> &[f64] {
        let n = self.len();
        &self.values[i * n..(i + 1) * n]
    }

    /// The deformation names (n).
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// All values, row-major (n x n).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The largest entry (0 for a 1 x 1 matrix).
    pub fn max(&self) -> f64 {
        self.values.iter().copied().fold(0.0, f64::max)
    }

    /// The matrix restricted to `indices` (in that order). Panics on an index out of range;
    /// errors if an index repeats.
    pub fn select(&self, indices: &[usize]) -> Result<DistanceMatrix, MatrixError> {
        let names = indices.iter().map(|&i| self.names[i].clone()).collect();
        let values = indices
            .iter()
            .flat_map(|&i| indices.iter().map(move |&j| (i, j)))
            .map(|(i, j)| self.get(i, j))
            .collect();
        DistanceMatrix::new(names, values)
    }

    /// The label of each deformation (n, in matrix order) from `(name, label)` pairs such as
    /// [`read_labels`] returns. Errors name the first deformation without a label.
    pub fn labels_for(&self, labels: &[(String, String)]) -> Result<Vec<String>, String> {
        let map: HashMap<&str, &str> = labels.iter().map(|(n, l)| (n.as_str(), l.as_str())).collect();
        self.names
            .iter()
            .map(|name| {
                map.get(name.as_str())
                    .map(|l| l.to_string())
                    .ok_or_else(|| format!("no label for deformation {name:?}"))
            })
            .collect()
    }

    /// Reads the CSV format of the [module docs](self). Errors name the file and line.
    pub fn read_csv(path: &Path) -> Result<DistanceMatrix, MatrixFileError> {
        parse_csv(path)
    }

    /// Writes the CSV format of the [module docs](self) atomically, every value in its
    /// shortest round-trip form.
    pub fn write_csv(&self, path: &Path) -> Result<(), MatrixFileError> {
        let mut w = csv::Writer::from_writer(Vec::new());
        let encode = |error: csv::Error| MatrixFileError::Encode {
            path: path.into(),
            error,
        };
        let mut header = vec!["name".to_string()];
        header.extend(self.names.iter().cloned());
        w.write_record(&header).map_err(encode)?;
        for (i, name) in self.names.iter().enumerate() {
            let mut rec = vec![name.clone()];
            rec.extend(self.row(i).iter().map(|v| format!("{v:?}")));
            w.write_record(&rec).map_err(encode)?;
        }
        let bytes = w.into_inner().map_err(|e| encode(e.into_error().into()))?;
        write_atomically(path, |out| out.write_all(&bytes))?;
        Ok(())
    }
}

impl TableErrors for MatrixFileError {
    fn unreadable(path: &Path, error: std::io::Error) -> Self {
        MatrixFileError::Read {
            path: path.into(),
            error,
        }
    }
    fn malformed(path: &Path, line: u64, error: csv::Error) -> Self {
        MatrixFileError::Line {
            path: path.into(),
            line,
            problem: LineProblem::Csv(error),
        }
    }
}

fn parse_csv(path: &Path) -> Result<DistanceMatrix, MatrixFileError> {
    let bad = |line: u64, problem: LineProblem| MatrixFileError::Line {
        path: path.into(),
        line,
        problem,
    };
    let mut table = Table::<MatrixFileError>::read(path, true)?;
    let (header, header_line) = (table.header.clone(), table.header_line);
    if header.is_empty() {
        return Err(MatrixFileError::Empty { path: path.into() });
    }
    let names: Vec<String> = header.iter().skip(1).map(str::to_string).collect();
    let n = names.len();
    if n == 0 {
        return Err(bad(header_line, LineProblem::NoNames));
    }
    let mut lines = Vec::with_capacity(n);
    let mut values = Vec::with_capacity(n * n);
    for rec in table.rows() {
        let (line, rec) = rec?;
        let i = lines.len();
        if i == n {
            return Err(bad(line, LineProblem::ExtraRow { n }));
        }
        if rec.len() != n + 1 {
            return Err(bad(line, LineProblem::FieldCount { fields: rec.len(), n }));
        }
        let name = rec.get(0).unwrap_or("");
        if name != names[i] {
            return Err(bad(
                line,
                LineProblem::RowName {
                    row: i + 1,
                    name: name.to_string(),
                    expected: names[i].clone(),
                },
            ));
        }
        for (j, text) in rec.iter().skip(1).enumerate() {
            let v: f64 = text.parse().map_err(|error| {
                bad(
                    line,
                    LineProblem::NotANumber {
                        column: names[j].clone(),
                        text: text.to_string(),
                        error,
                    },
                )
            })?;
            values.push(v);
        }
        lines.push(line);
    }
    if lines.len() != n {
        return Err(MatrixFileError::NotSquare {
            path: path.into(),
            names: n,
            rows: lines.len(),
        });
    }
    DistanceMatrix::new(names.clone(), values).map_err(|e| {
        let col = |j: usize| names.get(j).cloned().unwrap_or_default();
        match e {
            MatrixError::NotFinite { i, j, value } => bad(
                lines[i],
                LineProblem::NotFinite {
                    column: col(j),
                    value,
                },
            ),
            MatrixError::Negative { i, j, value } => bad(
                lines[i],
                LineProblem::Negative {
                    column: col(j),
                    value,
                },
            ),
            MatrixError::Diagonal { i, value } => bad(
                lines[i],
                LineProblem::Diagonal {
                    column: col(i),
                    value,
                },
            ),
            MatrixError::Asymmetric { i, j, a, b } => bad(
                lines[i],
                LineProblem::Asymmetric {
                    column: col(j),
                    row: col(i),
                    a,
                    b,
                    other_line: lines[j],
                },
            ),
            MatrixError::EmptyName(j) => bad(header_line, LineProblem::EmptyName(j + 2)),
            MatrixError::DuplicateName { name, .. } => bad(header_line, LineProblem::DuplicateName(name)),
            other => MatrixFileError::Matrix {
                path: path.into(),
                error: other,
            },
        }
    })
}

/// Reads class labels as `(deformation name, label)` pairs, in file order, from either
///
/// - a data set manifest (header with `deformation`, `label`, `pose` and `path` columns, read
///   with [`read_manifest`]): one pair per labelled deformation (unlabelled ones are skipped),
///   or
/// - a CSV with a header naming a `name` (or `deformation`) column and a `label` column (other
///   columns ignored), one row per deformation.
///
/// Errors name the file and line: no such columns, an empty name or label, a name given two
/// different labels, or no label at all.
pub fn read_labels(path: &Path) -> Result<Vec<(String, String)>, MatrixFileError> {
    let bad = |line: u64, problem: LineProblem| MatrixFileError::Line {
        path: path.into(),
        line,
        problem,
    };
    let mut table = Table::<MatrixFileError>::read(path, true)?;
    let header_line = table.header_line;
    let mut pairs: Vec<(String, String)> = Vec::new();
    let mut seen: HashMap<String, (usize, u64)> = HashMap::new();
    let mut push = |line: u64, name: String, label: String| -> Result<(), MatrixFileError> {
        match seen.get(&name) {
            Some(&(k, first_line)) => {
                if pairs[k].1 != label {
                    return Err(bad(
                        line,
                        LineProblem::LabelChanges {
                            name,
                            label,
                            first: pairs[k].1.clone(),
                            first_line,
                        },
                    ));
                }
            }
            None => {
                seen.insert(name.clone(), (pairs.len(), line));
                pairs.push((name, label));
            }
        }
        Ok(())
    };
    let find = |name: &str| table.column(name);
    if find("pose").is_some() && find("path").is_some() && find("deformation").is_some() {
        for (line, row) in read_manifest(path)? {
            if let Some(label) = row.label {
                push(line, row.deformation, label)?;
            }
        }
    } else {
        let name_col = find("name")
            .or_else(|| find("deformation"))
            .ok_or_else(|| bad(header_line, LineProblem::NoNameColumn))?;
        let label_col = find("label").ok_or_else(|| bad(header_line, LineProblem::NoLabelColumn))?;
        for rec in table.rows() {
            let (line, rec) = rec?;
            let name = rec.get(name_col).unwrap_or("");
            let label = rec.get(label_col).unwrap_or("");
            if name.is_empty() {
                return Err(bad(line, LineProblem::EmptyRowName));
            }
            if label.is_empty() {
                return Err(bad(line, LineProblem::EmptyLabel(name.to_string())));
            }
            push(line, name.to_string(), label.to_string())?;
        }
    }
    if pairs.is_empty() {
        return Err(MatrixFileError::NoLabels { path: path.into() });
    }
    Ok(pairs)
}

/// The symmetric `n x n` matrix (row-major, zero diagonal) of the pair distances.
pub(crate) fn assemble(n: usize, pairs: &[PairDistance]) -> Vec<f64> {
    let mut d = vec![0.0; n * n];
    for p in pairs {
        d[p.i * n + p.j] = p.distance;
        d[p.j * n + p.i] = p.distance;
    }
    d
}

/// The distance matrix (eq. 13) of every pair `i < j` of the deformations `names`.
pub(crate) fn matrix_of(names: &[String], pairs: &[PairDistance]) -> Result<DistanceMatrix, MatrixError> {
    DistanceMatrix::new(names.to_vec(), assemble(names.len(), pairs))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("d{i}")).collect()
    }

    #[test]
    fn new_checks_and_symmetrizes() {
        let m = DistanceMatrix::new(names(2), vec![0.0, 1.0, 1.0 + 1e-12, 1e-13]).unwrap();
        assert_eq!(m.get(0, 1), m.get(1, 0));
        assert_eq!(m.get(1, 1), 0.0);
        assert!(matches!(
            DistanceMatrix::new(names(2), vec![0.0, 1.0, 1.1, 0.0]),
            Err(MatrixError::Asymmetric { i: 0, j: 1, .. })
        ));
        assert!(matches!(
            DistanceMatrix::new(names(2), vec![0.0, f64::NAN, 1.0, 0.0]),
            Err(MatrixError::NotFinite { i: 0, j: 1, .. })
        ));
        assert!(matches!(
            DistanceMatrix::new(names(2), vec![0.0, -1.0, -1.0, 0.0]),
            Err(MatrixError::Negative { .. })
        ));
        assert!(matches!(
            DistanceMatrix::new(names(2), vec![0.5, 1.0, 1.0, 0.0]),
            Err(MatrixError::Diagonal { i: 0, .. })
        ));
        assert!(matches!(
            DistanceMatrix::new(names(2), vec![0.0; 3]),
            Err(MatrixError::NotSquare { .. })
        ));
        assert!(matches!(
            DistanceMatrix::new(vec!["a".into(), "a".into()], vec![0.0; 4]),
            Err(MatrixError::DuplicateName { .. })
        ));
        assert!(matches!(
            DistanceMatrix::new(vec![], vec![]),
            Err(MatrixError::Empty)
        ));
    }

    #[test]
    fn csv_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.csv");
        let n = 5;
        let mut names = names(n);
        names[2] = "with, comma".into();
        let m = DistanceMatrix::from_fn(names, |i, j| {
            (1.0 / 3.0) * (i as f64 + 1.0).powf(1.7) * (j as f64 + 0.1).sqrt() * 1e-7
        })
        .unwrap();
        m.write_csv(&p).unwrap();
        let back = DistanceMatrix::read_csv(&p).unwrap();
        assert_eq!(m, back);
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("name,d0,d1,\"with, comma\",d3,d4\n"), "{text}");
    }

    fn read_err(text: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.csv");
        std::fs::write(&p, text).unwrap();
        DistanceMatrix::read_csv(&p).unwrap_err().to_string()
    }

    #[test]
    fn bad_csv_errors_name_file_and_line() {
        let e = read_err("name,a,b\na,0,1\nb,1\n");
        assert!(e.contains("bad.csv: line 3") && e.contains("square"), "{e}");
        let e = read_err("name,a,b\na,0,1\nb,2,0\n");
        assert!(
            e.contains("bad.csv: line 2") && e.contains("symmetric") && e.contains("line 3"),
            "{e}"
        );
        let e = read_err("name,a,b\na,0,NaN\nb,NaN,0\n");
        assert!(e.contains("line 2") && e.contains("not finite"), "{e}");
        let e = read_err("name,a,b\na,0,x\nb,1,0\n");
        assert!(e.contains("line 2") && e.contains("not a number"), "{e}");
        let e = read_err("name,a,b\nb,0,1\na,1,0\n");
        assert!(e.contains("line 2") && e.contains("order"), "{e}");
        let e = read_err("name,a,b\na,0,1\n");
        assert!(e.contains("bad.csv") && e.contains("1 rows"), "{e}");
        let e = read_err("");
        assert!(e.contains("empty"), "{e}");
    }

    #[test]
    fn labels_from_two_columns_and_manifest() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("labels.csv");
        std::fs::write(&p, "name,label\na,x\nb,y\na,x\n").unwrap();
        let l = read_labels(&p).unwrap();
        assert_eq!(l, vec![("a".into(), "x".into()), ("b".into(), "y".into())]);
        std::fs::write(&p, "name,label\na,x\na,y\n").unwrap();
        let e = read_labels(&p).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("line 2"), "{e}");
        std::fs::write(&p, "name,class\na,x\n").unwrap();
        assert!(read_labels(&p)
            .unwrap_err()
            .to_string()
            .contains("no label column"));

        let mf = dir.path().join("manifest.csv");
        std::fs::write(
            &mf,
            "deformation,label,pose,path\nw1,walk,0,a.obj\nw1,walk,1,b.obj\nr1,run,0,c.obj\nu,,0,d.obj\n",
        )
        .unwrap();
        let l = read_labels(&mf).unwrap();
        assert_eq!(l, vec![("w1".into(), "walk".into()), ("r1".into(), "run".into())]);
        let m = DistanceMatrix::new(vec!["r1".into(), "w1".into()], vec![0.0, 1.0, 1.0, 0.0]).unwrap();
        assert_eq!(m.labels_for(&l).unwrap(), vec!["run", "walk"]);
        let m = DistanceMatrix::new(vec!["r1".into(), "u".into()], vec![0.0, 1.0, 1.0, 0.0]).unwrap();
        assert!(m.labels_for(&l).unwrap_err().contains("\"u\""));
    }
}
