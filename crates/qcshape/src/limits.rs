//! Upper bounds of every count a user or a file can ask for, defined once: the `qcshape`
//! commands' integer options (their `--help` states each maximum), the Python API's keyword
//! arguments and the file readers take their limits from here, so that no option value can
//! wrap, overflow an allocation or run for years, and no file read can exhaust memory or block.
//!
//! The bounds are far above every setting the documentation uses (the README's runs, the
//! paper's): they exist to turn a typo (`--steps 80000000`) or a hostile value into a clear
//! error before anything is allocated. See docs/log/reliability.md.

use std::io::Read;
use std::path::Path;

use thiserror::Error;

/// Segments N of a geodesic (`--steps`, `steps=`): at most 10,000 (the documented settings use
/// 4-16).
pub const MAX_STEPS: usize = 10_000;

/// Poses inserted between two consecutive key poses (`--insert`, `insert=`): at most 1,000.
pub const MAX_INSERT: usize = 1_000;

/// Spatial resolution levels of the multiresolution interpolation (`--levels`): at most 16.
pub const MAX_LEVELS: usize = 16;

/// Icosphere subdivision level (`--level`, `icosphere(level=)`): at most 8 (655,362 vertices).
pub const MAX_ICOSPHERE_LEVEL: u32 = 8;

/// Worker threads (`--threads`): at most 1,024.
pub const MAX_THREADS: usize = 1_024;

/// Clusters `k` (`--k`): at most 10,000.
pub const MAX_CLUSTERS: usize = 10_000;

/// Seeded restarts of a clustering (`--restarts`, `n_init`): at most 10,000.
pub const MAX_RESTARTS: usize = 10_000;

/// Iteration limits of the optimizers and clusterings (`--max-iterations`, `--doubling-iterations`):
/// at most 1,000,000.
pub const MAX_ITERATIONS: usize = 1_000_000;

/// Smoothing, relaxation and similar sweeps (`--smooth`, `--smoothing`, `--relax`,
/// `--qc-smooth`): at most 1,000.
pub const MAX_SWEEPS: usize = 1_000;

/// The smoothing length relative to a pose's area radius (`--smooth-length`, `smooth_length=`):
/// at most 10 (the default is 0.18; at 1 a sphere keeps `exp(-4)` of its own shape, and the
/// filter's cost grows with the length).
pub const MAX_SMOOTH_LENGTH: f64 = 10.0;

/// Poses or frames per deformation that a command generates (`--poses`, `--frames`,
/// `--real-frames`): at most 10,000.
pub const MAX_POSES: usize = 10_000;

/// Frame stride (`lv cycle --every`): at most 10,000.
pub const MAX_EVERY: usize = 10_000;

/// Subjects of a generated cohort (`lv phantom --controls`, `--hcm`): at most 10,000.
pub const MAX_SUBJECTS: usize = 10_000;

/// Voxels per side of a generated image (`lv phantom --size`): at most 1,024.
pub const MAX_IMAGE_SIZE: usize = 1_024;

/// Landmarks of a registration (`--landmarks`, `--landmark-sweep`): at most 10,000.
pub const MAX_LANDMARKS: usize = 10_000;

/// Random relabellings of a permutation test (`--permutations`): at most 1,000,000.
pub const MAX_PERMUTATIONS: usize = 1_000_000;

/// Vertices of a mesh (`--vertices`, `ShapeSpace(n_vertices=)`, face indices): at most
/// 100,000,000.
pub const MAX_VERTICES: usize = 100_000_000;

/// Weight of a regularizer (`--lambda`, `--tps-lambda`, `lambda_=`): at most 1e6.
pub const MAX_LAMBDA: f64 = 1e6;

/// Relative tolerances (`--tolerance`, `--energy-tolerance`, `--length-tolerance`): at most 1.
pub const MAX_TOLERANCE: f64 = 1.0;

/// Largest mesh file read (bytes): 4 GiB.
pub const MAX_MESH_FILE_BYTES: u64 = 4 << 30;

/// Largest table read (bytes): manifests, label and matrix CSV files, journals, shards,
/// landmark and region files: 4 GiB.
pub const MAX_TABLE_FILE_BYTES: u64 = 4 << 30;

/// A count or value outside its bounds, or a file that cannot be read safely.
#[derive(Debug, Error, PartialEq)]
pub enum LimitError {
    /// A count above its maximum.
    #[error("{what} must be at most {max} (got {value})")]
    TooLarge {
        /// The option or argument.
        what: String,
        /// Its maximum.
        max: u128,
        /// The value given.
        value: u128,
    },
    /// A count below its minimum (e.g. 0 steps).
    #[error("{what} must be at least {min} (got {value})")]
    TooSmall {
        /// The option or argument.
        what: String,
        /// Its minimum.
        min: u128,
        /// The value given.
        value: u128,
    },
    /// A real value that is negative, not finite or above its maximum.
    #[error("{what} must be >= 0 and at most {max} (got {value})")]
    OutOfRange {
        /// The option or argument.
        what: String,
        /// Its maximum.
        max: f64,
        /// The value given.
        value: f64,
    },
    /// A value that is valid on its own but not together with another setting.
    #[error("{what} {value} is not available with {with}")]
    Unsupported {
        /// The option or argument.
        what: String,
        /// The value given.
        value: String,
        /// The other setting's value that excludes it (e.g. `--scale invariant`).
        with: String,
    },
}

impl LimitError {
    /// The same error with the setting's name spelled by `spell` (e.g. `lambda` -> `--lambda` for
    /// the command line, `lam` for Python).
    pub fn renamed(self, spell: impl Fn(&str) -> String) -> LimitError {
        match self {
            LimitError::TooLarge { what, max, value } => LimitError::TooLarge {
                what: spell(&what),
                max,
                value,
            },
            LimitError::TooSmall { what, min, value } => LimitError::TooSmall {
                what: spell(&what),
                min,
                value,
            },
            LimitError::OutOfRange { what, max, value } => LimitError::OutOfRange {
                what: spell(&what),
                max,
                value,
            },
            LimitError::Unsupported { what, value, with } => LimitError::Unsupported {
                what: spell(&what),
                value,
                with,
            },
        }
    }

    /// The name of the setting or argument the error is about.
    pub fn what(&self) -> &str {
        match self {
            LimitError::TooLarge { what, .. }
            | LimitError::TooSmall { what, .. }
            | LimitError::OutOfRange { what, .. }
            | LimitError::Unsupported { what, .. } => what,
        }
    }
}

/// `value` if `min <= value <= max`, else an error naming `what`.
pub fn count(what: &str, value: usize, min: usize, max: usize) -> Result<usize, LimitError> {
    if value < min {
        return Err(LimitError::TooSmall {
            what: what.into(),
            min: min as u128,
            value: value as u128,
        });
    }
    if value > max {
        return Err(LimitError::TooLarge {
            what: what.into(),
            max: max as u128,
            value: value as u128,
        });
    }
    Ok(value)
}

/// `value` if it is finite and `0 <= value <= max`, else an error naming `what`.
pub fn non_negative(what: &str, value: f64, max: f64) -> Result<f64, LimitError> {
    if !(value.is_finite() && (0.0..=max).contains(&value)) {
        return Err(LimitError::OutOfRange {
            what: what.into(),
            max,
            value,
        });
    }
    Ok(value)
}

/// Reads a whole file that must be a regular file (after following symbolic links) of at most
/// `max_bytes` bytes. Devices (`/dev/zero`), FIFOs and sockets are refused from their metadata
/// before the file is opened, so that a read can neither grow without bound nor block; a file
/// that grows past `max_bytes` while it is read is refused too. The errors are
/// [`std::io::Error`]s with a sentence for the callers' own error types.
pub fn read_regular_file(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(std::io::Error::other("a folder, not a file"));
    }
    if !meta.is_file() {
        return Err(std::io::Error::other(
            "not a regular file (a device, FIFO or socket); refusing to read it",
        ));
    }
    if meta.len() > max_bytes {
        return Err(std::io::Error::other(format!(
            "the file has {} bytes, more than the limit of {max_bytes}",
            meta.len()
        )));
    }
    let file = std::fs::File::open(path)?;
    // Checked again on the open file: the path may have been replaced since.
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(std::io::Error::other(
            "not a regular file (a device, FIFO or socket); refusing to read it",
        ));
    }
    let mut bytes = Vec::with_capacity(meta.len().min(max_bytes) as usize);
    file.take(max_bytes.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(std::io::Error::other(format!(
            "the file grew past the limit of {max_bytes} bytes while it was read"
        )));
    }
    Ok(bytes)
}

/// [`read_regular_file`] as UTF-8 text.
pub fn read_regular_text(path: &Path, max_bytes: u64) -> std::io::Result<String> {
    String::from_utf8(read_regular_file(path, max_bytes)?)
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_reals_are_bounded() {
        assert_eq!(count("--steps", 8, 1, MAX_STEPS), Ok(8));
        let e = count("--steps", usize::MAX, 1, MAX_STEPS).unwrap_err();
        assert!(e.to_string().contains("--steps must be at most 10000"), "{e}");
        assert!(count("--steps", 0, 1, MAX_STEPS).is_err());
        assert!(non_negative("--lambda", 1e308, MAX_LAMBDA).is_err());
        assert!(non_negative("--lambda", -1.0, MAX_LAMBDA).is_err());
        assert!(non_negative("--lambda", f64::NAN, MAX_LAMBDA).is_err());
        assert_eq!(non_negative("--lambda", 0.0, MAX_LAMBDA), Ok(0.0));
    }

    #[test]
    fn reads_refuse_devices_and_large_files() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.txt");
        std::fs::write(&f, b"0123456789").unwrap();
        assert_eq!(read_regular_file(&f, 10).unwrap(), b"0123456789");
        assert!(read_regular_file(&f, 9)
            .unwrap_err()
            .to_string()
            .contains("limit"));
        assert!(read_regular_file(dir.path(), 9).is_err());
        #[cfg(unix)]
        {
            let link = dir.path().join("zero.ply");
            std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
            let e = read_regular_file(&link, 1 << 20).unwrap_err();
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
    }
}
