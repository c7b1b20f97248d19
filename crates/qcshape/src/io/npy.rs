//! NumPy `.npy` files (format version 1.0): matrices of `f64` that `numpy.load` reads.

use std::io::Write;
use std::path::Path;

use super::{write_atomically, IoError, WriteError};

/// Encodes a row-major `rows x cols` matrix of `f64` as `.npy` bytes (version 1.0, dtype
/// `<f8`, C order, shape `(rows, cols)`). Errors if `data.len() != rows * cols`.
pub fn encode_matrix(data: &[f64], rows: usize, cols: usize) -> Result<Vec<u8>, WriteError> {
    if rows.checked_mul(cols) != Some(data.len()) {
        return Err(WriteError::AttributeLength {
            what: format!("a {rows} x {cols} matrix"),
            got: data.len(),
            expected: rows.saturating_mul(cols),
        });
    }
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({rows}, {cols}), }}");
    // Magic (6) + version (2) + header length (2) + header, padded with spaces and ended by a
    // newline to a multiple of 64 bytes.
    let total = (10 + header.len() + 1).div_ceil(64) * 64;
    while 10 + header.len() + 1 < total {
        header.push(' ');
    }
    header.push('\n');
    let mut out = Vec::with_capacity(total + 8 * data.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    Ok(out)
}

/// Writes a row-major `rows x cols` matrix (e.g. a similarity matrix, #deformations x
/// #deformations, in the metric's normalized length units) to `path` as `.npy`, atomically.
pub fn write_matrix(path: &Path, data: &[f64], rows: usize, cols: usize) -> Result<(), IoError> {
    let bytes = encode_matrix(data, rows, cols).map_err(|error| IoError::Encode {
        path: path.into(),
        error,
    })?;
    write_atomically(path, |w: &mut dyn Write| w.write_all(&bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_aligned_and_data_follows() {
        let b = encode_matrix(&[0.0, 1.5, 1.5, 0.0], 2, 2).unwrap();
        assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
        let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hl) % 64, 0);
        let h = std::str::from_utf8(&b[10..10 + hl]).unwrap();
        assert!(h.contains("'shape': (2, 2)") && h.ends_with('\n'), "{h}");
        assert_eq!(b.len(), 10 + hl + 32);
        assert_eq!(&b[10 + hl + 8..10 + hl + 16], &1.5f64.to_le_bytes());
        assert!(encode_matrix(&[1.0], 2, 2).is_err());
    }
}
