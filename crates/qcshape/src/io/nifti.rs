//! NIfTI-1 images (single-file `.nii`, gzipped `.nii.gz`), 3D and 4D, read and written by hand.
//!
//! Why not the `nifti` crate: its writer needs `ndarray` and it pulls a dozen further crates
//! (num-derive, byteordered, safe numeric casts, ...), while all qcshape needs is the 348-byte
//! header, a handful of voxel types and the voxel-to-world affine — a few hundred lines with
//! `flate2` for gzip, which also keeps the parser pure and fuzzable ([`parse_nifti`]).
//!
//! Reading honours both byte orders; the voxel types uint8, int8, int16, uint16, int32,
//! uint32, float32 and float64; `scl_slope`/`scl_inter` scaling; the spatial unit (metres and
//! microns are converted to mm); and the orientation: the `sform` when `sform_code > 0`, else
//! the quaternion `qform` when `qform_code > 0` (with `qfac` from `pixdim[0]`), else the plain
//! scaling `diag(pixdim[1..4])` (NIfTI "method 1"). Writing produces float32 voxels, an sform
//! equal to the affine and, when the affine's columns are orthogonal, the matching qform.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::write_atomically;

/// Size of the NIfTI-1 header in bytes.
const HEADER_SIZE: usize = 348;
/// Offset of the voxel data in the files written here (header + 4-byte extension flag).
const DATA_OFFSET: usize = 352;

/// A 3D image: `data[i + nx (j + ny k)]` is voxel `(i, j, k)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume {
    /// Voxel counts `[nx, ny, nz]`, each >= 1.
    pub dims: [usize; 3],
    /// Voxel size in mm along i, j, k (the lengths of the affine's columns).
    pub spacing: [f64; 3],
    /// Voxel-to-world map (mm): `world = affine[..3][..3] * [i, j, k] + affine[..3][3]`;
    /// row 3 is `[0, 0, 0, 1]`.
    pub affine: [[f64; 4]; 4],
    /// Intensities (#nx·ny·nz), x fastest.
    pub data: Vec<f32>,
}

impl Volume {
    /// A volume of constant `value` with the axis-aligned affine `diag(spacing)` + `origin`.
    pub fn filled(dims: [usize; 3], spacing: [f64; 3], origin: [f64; 3], value: f32) -> Volume {
        let mut affine = [[0.0; 4]; 4];
        for a in 0..3 {
            affine[a][a] = spacing[a];
            affine[a][3] = origin[a];
        }
        affine[3][3] = 1.0;
        Volume {
            dims,
            spacing,
            affine,
            data: vec![value; dims[0] * dims[1] * dims[2]],
        }
    }

    /// Number of voxels.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Whether the volume has no voxel (never true for a parsed volume).
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Linear index of voxel `(i, j, k)`.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// World position (mm) of a (possibly fractional) voxel coordinate.
    pub fn to_world(&self, v: [f64; 3]) -> [f64; 3] {
        apply_affine(&self.affine, v)
    }

    /// Voxel coordinate of a world position (mm); `None` if the affine is singular.
    pub fn to_voxel(&self, w: [f64; 3]) -> Option<[f64; 3]> {
        let inv = invert3(&self.affine)?;
        let d = [
            w[0] - self.affine[0][3],
            w[1] - self.affine[1][3],
            w[2] - self.affine[2][3],
        ];
        Some(std::array::from_fn(|r| {
            inv[r][0] * d[0] + inv[r][1] * d[1] + inv[r][2] * d[2]
        }))
    }

    /// The world-to-voxel map (the inverse of `affine`, row 3 `[0, 0, 0, 1]`), for mapping
    /// many points ([`Self::to_voxel`] inverts the affine on every call); `None` if the
    /// affine is singular.
    pub fn inverse_affine(&self) -> Option<[[f64; 4]; 4]> {
        let inv = invert3(&self.affine)?;
        let t = [self.affine[0][3], self.affine[1][3], self.affine[2][3]];
        let mut m = [[0.0; 4]; 4];
        for r in 0..3 {
            let shift = -(inv[r][0] * t[0] + inv[r][1] * t[1] + inv[r][2] * t[2]);
            m[r] = [inv[r][0], inv[r][1], inv[r][2], shift];
        }
        m[3][3] = 1.0;
        Some(m)
    }

    /// Volume of one voxel in mm^3 (|det| of the affine's 3 x 3 part).
    pub fn voxel_volume(&self) -> f64 {
        det3(&self.affine).abs()
    }
}

/// `affine * [v, 1]`, first three rows.
pub fn apply_affine(a: &[[f64; 4]; 4], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| a[r][0] * v[0] + a[r][1] * v[1] + a[r][2] * v[2] + a[r][3])
}

/// Determinant of the upper-left 3 x 3 block.
pub fn det3(a: &[[f64; 4]; 4]) -> f64 {
    a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
}

fn invert3(a: &[[f64; 4]; 4]) -> Option<[[f64; 3]; 3]> {
    let d = det3(a);
    if d == 0.0 || !d.is_finite() {
        return None;
    }
    let c = |r0: usize, r1: usize, c0: usize, c1: usize| a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0];
    Some([
        [c(1, 2, 1, 2) / d, -c(0, 2, 1, 2) / d, c(0, 1, 1, 2) / d],
        [-c(1, 2, 0, 2) / d, c(0, 2, 0, 2) / d, -c(0, 1, 0, 2) / d],
        [c(1, 2, 0, 1) / d, -c(0, 2, 0, 1) / d, c(0, 1, 0, 1) / d],
    ])
}

/// What is wrong with a NIfTI byte stream.
#[derive(Debug, Error, Clone)]
pub enum NiftiParseError {
    /// Fewer bytes than a header, `sizeof_hdr` is 348 in neither byte order, or the magic is
    /// not `n+1`.
    #[error("not a NIfTI-1 file: {0}")]
    NotNifti(NotNifti),
    /// A header pair (`.hdr` + `.img`, magic `ni1`) instead of a single file.
    #[error("two-file NIfTI (.hdr/.img) is not supported; convert it to a single .nii file")]
    TwoFile,
    /// `dim` does not describe a 3D or 4D image of positive size.
    #[error("unsupported dimensions dim = {dim:?}: {problem}")]
    Dimensions {
        /// The header's `dim` array.
        dim: [i16; 8],
        /// What is wrong.
        problem: DimensionError,
    },
    /// A voxel type other than the integer and real types listed in the module docs.
    #[error("unsupported datatype {code} ({name})")]
    Datatype {
        /// The `datatype` code.
        code: i16,
        /// Its NIfTI name, or "unknown".
        name: &'static str,
    },
    /// `vox_offset` is not a whole number of bytes at or after the header.
    #[error("bad header: vox_offset {0} is not a whole number >= 348")]
    VoxOffset(f64),
    /// The voxel-to-world affine (from the sform, qform or `pixdim`) is singular or not finite.
    #[error("bad header: the voxel-to-world affine {rows:?} is singular or not finite (pixdim {pixdim:?})")]
    Affine {
        /// Its first three rows (boxed: they would make every error 100 bytes larger).
        rows: Box<[[f64; 4]; 3]>,
        /// `pixdim[1..4]`.
        pixdim: [f64; 3],
    },
    /// The data ends before all voxels.
    #[error("truncated data: {needed} bytes of voxels after offset {offset}, but only {got}")]
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Data offset.
        offset: usize,
        /// Bytes present after it.
        got: usize,
    },
    /// The gzip stream is corrupt.
    #[error("cannot decompress: {0}")]
    Gzip(std::sync::Arc<std::io::Error>),
    /// The gzip stream decompresses to more than the limit (a gzip bomb?).
    #[error("cannot decompress: the data decompresses to more than {limit} bytes (the limit for a NIfTI file; a gzip bomb?)")]
    TooLarge {
        /// The limit in bytes.
        limit: u64,
    },
}

/// Why bytes are not a NIfTI-1 file ([`NiftiParseError::NotNifti`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum NotNifti {
    /// Fewer bytes than a header.
    #[error("{0} bytes, shorter than the 348-byte header")]
    TooShort(usize),
    /// `sizeof_hdr` is 348 in neither byte order.
    #[error("sizeof_hdr is not 348")]
    SizeofHdr,
    /// The magic is not `n+1` (nor the two-file `ni1`).
    #[error("magic {0:?} is not \"n+1\"")]
    Magic(String),
}

/// Why a header's `dim` does not describe a 3D or 4D image ([`NiftiParseError::Dimensions`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DimensionError {
    /// `dim[0]` (the number of axes) is not 1..7.
    #[error("dim[0] = {0} must be 1..7")]
    Rank(i16),
    /// Fewer than three axes.
    #[error("a {0}D image is not a volume (3D or 4D expected)")]
    NotVolume(usize),
    /// An axis of size below 1.
    #[error("dim[{axis}] = {size} must be at least 1")]
    Empty {
        /// The axis (1-based, as in `dim`).
        axis: usize,
        /// Its size.
        size: i16,
    },
    /// An axis after time (5 or more) of size above 1.
    #[error("dim[{axis}] = {size} > 1: only 3D and 4D (time) images are supported")]
    ExtraAxis {
        /// The axis.
        axis: usize,
        /// Its size.
        size: i16,
    },
    /// The voxel count times the voxel size overflows `usize`.
    #[error("the voxel count overflows")]
    Overflow,
}

/// A file-level NIfTI error: every message starts with the file.
#[derive(Debug, Error)]
pub enum NiftiError {
    /// The file cannot be read.
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// The file's bytes are not a usable NIfTI image.
    #[error("{}: {error}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The problem.
        error: NiftiParseError,
    },
    /// A 3D volume was asked for, but the file holds several frames.
    #[error("{}: expected a 3D volume, found a 4D series of {frames} frames", path.display())]
    NotThreeD {
        /// The file.
        path: PathBuf,
        /// Its frame count.
        frames: usize,
    },
    /// The frames to write do not share dimensions and affine, or there are none.
    #[error("{}: cannot write: {problem}", path.display())]
    Inconsistent {
        /// The file.
        path: PathBuf,
        /// What differs.
        problem: SeriesError,
    },
    /// The file (or its temporary) cannot be written.
    #[error(transparent)]
    Write(#[from] crate::io::IoError),
}

/// Why frames cannot be written as one NIfTI series ([`NiftiError::Inconsistent`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SeriesError {
    /// No frame to write.
    #[error("no frame to write")]
    NoFrames,
    /// More frames or voxels per axis than NIfTI-1's 16-bit `dim` holds, or an empty axis.
    #[error("{frames} frames of {dims:?} voxels exceed NIfTI-1 limits")]
    TooLarge {
        /// Frames.
        frames: usize,
        /// Voxels per axis of the first frame.
        dims: [usize; 3],
    },
    /// A frame whose dimensions, voxel count or affine differ from the first frame's.
    #[error("frame {frame} has dims {dims:?} and {voxels} voxels, unlike frame 0 ({first:?}) or its affine")]
    FrameMismatch {
        /// Frame number.
        frame: usize,
        /// Its dimensions.
        dims: [usize; 3],
        /// Its voxel count.
        voxels: usize,
        /// The first frame's dimensions.
        first: [usize; 3],
    },
    /// The shared affine is singular.
    #[error("the affine is singular")]
    SingularAffine,
}

fn datatype_name(code: i16) -> &'static str {
    match code {
        1 => "binary",
        32 => "complex64",
        128 => "rgb24",
        1024 => "int64",
        1280 => "uint64",
        1536 => "float128",
        1792 => "complex128",
        2048 => "complex256",
        2304 => "rgba32",
        _ => "unknown",
    }
}

struct Reader<'a> {
    b: &'a [u8],
    le: bool,
}

impl Reader<'_> {
    fn raw<const N: usize>(&self, off: usize) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.b[off..off + N]);
        if !self.le {
            a.reverse();
        }
        a
    }
    fn i16(&self, off: usize) -> i16 {
        i16::from_le_bytes(self.raw(off))
    }
    fn f32(&self, off: usize) -> f64 {
        f32::from_le_bytes(self.raw(off)) as f64
    }
}

/// The most bytes a gzipped NIfTI file may decompress to (2 GiB: a 4D cardiac series of
/// float32 voxels is a few hundred MB); more is refused as a likely gzip bomb, before it is
/// all in memory.
pub const MAX_DECOMPRESSED_BYTES: u64 = 2 << 30;

/// Decompresses when `bytes` start with the gzip magic, else borrows them.
fn maybe_gunzip(bytes: &[u8]) -> Result<std::borrow::Cow<'_, [u8]>, NiftiParseError> {
    maybe_gunzip_bounded(bytes, MAX_DECOMPRESSED_BYTES)
}

/// [`maybe_gunzip`] with the bound `limit` on the decompressed size.
fn maybe_gunzip_bounded(bytes: &[u8], limit: u64) -> Result<std::borrow::Cow<'_, [u8]>, NiftiParseError> {
    if bytes.len() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b {
        let mut out = Vec::new();
        flate2::read::MultiGzDecoder::new(bytes)
            .take(limit + 1)
            .read_to_end(&mut out)
            .map_err(|e| NiftiParseError::Gzip(std::sync::Arc::new(e)))?;
        if out.len() as u64 > limit {
            return Err(NiftiParseError::TooLarge { limit });
        }
        Ok(out.into())
    } else {
        Ok(bytes.into())
    }
}

/// Parses a whole NIfTI-1 file held in memory (gzipped or not) into its frames (1 for a 3D
/// image, `dim[4]` for a 4D one). Pure: no file access, no panic on any input.
pub fn parse_nifti(bytes: &[u8]) -> Result<Vec<Volume>, NiftiParseError> {
    let bytes = maybe_gunzip(bytes)?;
    let b: &[u8] = &bytes;
    if b.len() < HEADER_SIZE {
        return Err(NiftiParseError::NotNifti(NotNifti::TooShort(b.len())));
    }
    let le = if i32::from_le_bytes([b[0], b[1], b[2], b[3]]) == HEADER_SIZE as i32 {
        true
    } else if i32::from_be_bytes([b[0], b[1], b[2], b[3]]) == HEADER_SIZE as i32 {
        false
    } else {
        return Err(NiftiParseError::NotNifti(NotNifti::SizeofHdr));
    };
    let r = Reader { b, le };
    match &b[344..348] {
        b"n+1\0" => {}
        b"ni1\0" => return Err(NiftiParseError::TwoFile),
        m => {
            return Err(NiftiParseError::NotNifti(NotNifti::Magic(
                String::from_utf8_lossy(m).into_owned(),
            )))
        }
    }
    let dim: [i16; 8] = std::array::from_fn(|k| r.i16(40 + 2 * k));
    let bad_dim = |problem: DimensionError| NiftiParseError::Dimensions { dim, problem };
    let nd = dim[0];
    if !(1..=7).contains(&nd) {
        return Err(bad_dim(DimensionError::Rank(nd)));
    }
    let nd = nd as usize;
    if nd < 3 {
        return Err(bad_dim(DimensionError::NotVolume(nd)));
    }
    for (k, &d) in dim.iter().enumerate().take(nd + 1).skip(1) {
        if d < 1 {
            return Err(bad_dim(DimensionError::Empty { axis: k, size: d }));
        }
    }
    if let Some(k) = (5..=nd).find(|&k| dim[k] != 1) {
        return Err(bad_dim(DimensionError::ExtraAxis {
            axis: k,
            size: dim[k],
        }));
    }
    let dims = [dim[1] as usize, dim[2] as usize, dim[3] as usize];
    let frames = if nd >= 4 { dim[4] as usize } else { 1 };
    let datatype = r.i16(70);
    let bytes_per = match datatype {
        2 | 256 => 1,
        4 | 512 => 2,
        8 | 16 | 768 => 4,
        64 => 8,
        code => {
            return Err(NiftiParseError::Datatype {
                code,
                name: datatype_name(code),
            })
        }
    };
    let vox_offset = r.f32(108);
    if !(vox_offset.is_finite() && vox_offset >= HEADER_SIZE as f64 && vox_offset.fract() == 0.0) {
        return Err(NiftiParseError::VoxOffset(vox_offset));
    }
    let offset = vox_offset as usize;
    let per_frame = dims[0] * dims[1] * dims[2];
    let needed = per_frame
        .checked_mul(frames)
        .and_then(|n| n.checked_mul(bytes_per))
        .ok_or_else(|| bad_dim(DimensionError::Overflow))?;
    let got = b.len().saturating_sub(offset);
    if got < needed {
        return Err(NiftiParseError::Truncated { needed, offset, got });
    }
    let unit = match r.b[123] & 0x07 {
        1 => 1000.0,
        3 => 0.001,
        _ => 1.0,
    };
    let pixdim: [f64; 8] = std::array::from_fn(|k| r.f32(76 + 4 * k));
    let affine = header_affine(&r, &pixdim, unit)?;
    let spacing: [f64; 3] = std::array::from_fn(|c| {
        (affine[0][c] * affine[0][c] + affine[1][c] * affine[1][c] + affine[2][c] * affine[2][c]).sqrt()
    });
    let (mut slope, inter) = (r.f32(112), r.f32(116));
    if slope == 0.0 || !slope.is_finite() {
        slope = 1.0;
    }
    let inter = if inter.is_finite() { inter } else { 0.0 };
    let data = &b[offset..offset + needed];
    let value = |k: usize| -> f64 {
        let s = &data[k * bytes_per..(k + 1) * bytes_per];
        let mut a = [0u8; 8];
        a[..bytes_per].copy_from_slice(s);
        if !le {
            a[..bytes_per].reverse();
        }
        match datatype {
            2 => a[0] as f64,
            256 => a[0] as i8 as f64,
            4 => i16::from_le_bytes([a[0], a[1]]) as f64,
            512 => u16::from_le_bytes([a[0], a[1]]) as f64,
            8 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            768 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            16 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            _ => f64::from_le_bytes(a),
        }
    };
    Ok((0..frames)
        .map(|t| Volume {
            dims,
            spacing,
            affine,
            data: (t * per_frame..(t + 1) * per_frame)
                .map(|k| (slope * value(k) + inter) as f32)
                .collect(),
        })
        .collect())
}

/// The voxel-to-world affine from the sform, qform or pixdim (in that order of preference).
fn header_affine(r: &Reader, pixdim: &[f64; 8], unit: f64) -> Result<[[f64; 4]; 4], NiftiParseError> {
    let (qform_code, sform_code) = (r.i16(252), r.i16(254));
    let mut a = [[0.0; 4]; 4];
    a[3][3] = 1.0;
    if sform_code > 0 {
        for (row, ar) in a.iter_mut().take(3).enumerate() {
            for (c, x) in ar.iter_mut().enumerate() {
                *x = r.f32(280 + 16 * row + 4 * c) * unit;
            }
        }
    } else {
        let d: [f64; 3] = std::array::from_fn(|k| pixdim[k + 1].abs() * unit);
        if qform_code > 0 {
            let (qb, qc, qd) = (r.f32(256), r.f32(260), r.f32(264));
            let qa = (1.0 - (qb * qb + qc * qc + qd * qd)).max(0.0).sqrt();
            let qfac = if pixdim[0] < 0.0 { -1.0 } else { 1.0 };
            let rot = [
                [
                    qa * qa + qb * qb - qc * qc - qd * qd,
                    2.0 * (qb * qc - qa * qd),
                    2.0 * (qb * qd + qa * qc),
                ],
                [
                    2.0 * (qb * qc + qa * qd),
                    qa * qa + qc * qc - qb * qb - qd * qd,
                    2.0 * (qc * qd - qa * qb),
                ],
                [
                    2.0 * (qb * qd - qa * qc),
                    2.0 * (qc * qd + qa * qb),
                    qa * qa + qd * qd - qc * qc - qb * qb,
                ],
            ];
            let scale = [d[0], d[1], qfac * d[2]];
            for row in 0..3 {
                for c in 0..3 {
                    a[row][c] = rot[row][c] * scale[c];
                }
                a[row][3] = r.f32(268 + 4 * row) * unit;
            }
        } else {
            for k in 0..3 {
                a[k][k] = d[k];
            }
        }
    }
    let det = det3(&a);
    if !a.iter().flatten().all(|v| v.is_finite()) || det == 0.0 || !det.is_finite() {
        return Err(NiftiParseError::Affine {
            rows: Box::new([a[0], a[1], a[2]]),
            pixdim: [pixdim[1], pixdim[2], pixdim[3]],
        });
    }
    Ok(a)
}

/// The quaternion (b, c, d), qfac and offsets of an affine whose columns are orthogonal, or
/// `None` (then only the sform is written).
fn affine_to_quaternion(a: &[[f64; 4]; 4]) -> Option<([f64; 3], f64)> {
    let len: [f64; 3] = std::array::from_fn(|c| (0..3).map(|r| a[r][c] * a[r][c]).sum::<f64>().sqrt());
    let mut m = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] = a[r][c] / len[c];
        }
    }
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let dot: f64 = (0..3).map(|r| m[r][i] * m[r][j]).sum();
        if dot.abs() > 1e-6 {
            return None;
        }
    }
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let qfac = if det < 0.0 { -1.0 } else { 1.0 };
    if qfac < 0.0 {
        for row in &mut m {
            row[2] = -row[2];
        }
    }
    // Shepperd's method on the proper rotation m; keep a >= 0 as NIfTI requires.
    let tr = m[0][0] + m[1][1] + m[2][2];
    let (qa, qb, qc, qd);
    if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        qa = 0.25 * s;
        qb = (m[2][1] - m[1][2]) / s;
        qc = (m[0][2] - m[2][0]) / s;
        qd = (m[1][0] - m[0][1]) / s;
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        qa = (m[2][1] - m[1][2]) / s;
        qb = 0.25 * s;
        qc = (m[0][1] + m[1][0]) / s;
        qd = (m[0][2] + m[2][0]) / s;
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        qa = (m[0][2] - m[2][0]) / s;
        qb = (m[0][1] + m[1][0]) / s;
        qc = 0.25 * s;
        qd = (m[1][2] + m[2][1]) / s;
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        qa = (m[1][0] - m[0][1]) / s;
        qb = (m[0][2] + m[2][0]) / s;
        qc = (m[1][2] + m[2][1]) / s;
        qd = 0.25 * s;
    }
    let sign = if qa < 0.0 { -1.0 } else { 1.0 };
    Some(([sign * qb, sign * qc, sign * qd], qfac))
}

/// Encodes frames sharing dimensions and affine as one NIfTI-1 file (float32 voxels, mm,
/// sform and, when possible, qform). One frame gives a 3D image, several a 4D one.
/// `frames` must be non-empty and consistent (checked by the writers).
fn encode(frames: &[Volume]) -> Vec<u8> {
    let v0 = &frames[0];
    let mut h = vec![0u8; DATA_OFFSET];
    let put = |h: &mut Vec<u8>, off: usize, bytes: &[u8]| h[off..off + bytes.len()].copy_from_slice(bytes);
    put(&mut h, 0, &(HEADER_SIZE as i32).to_le_bytes());
    h[38] = b'r';
    let nd: i16 = if frames.len() > 1 { 4 } else { 3 };
    let mut dim = [1i16; 8];
    dim[0] = nd;
    for k in 0..3 {
        dim[k + 1] = v0.dims[k] as i16;
    }
    dim[4] = frames.len() as i16;
    for (k, d) in dim.iter().enumerate() {
        put(&mut h, 40 + 2 * k, &d.to_le_bytes());
    }
    put(&mut h, 70, &16i16.to_le_bytes());
    put(&mut h, 72, &32i16.to_le_bytes());
    let quat = affine_to_quaternion(&v0.affine);
    let mut pixdim = [1f32; 8];
    pixdim[0] = quat.map_or(1.0, |q| q.1 as f32);
    for k in 0..3 {
        pixdim[k + 1] = v0.spacing[k] as f32;
    }
    for (k, p) in pixdim.iter().enumerate() {
        put(&mut h, 76 + 4 * k, &p.to_le_bytes());
    }
    put(&mut h, 108, &(DATA_OFFSET as f32).to_le_bytes());
    put(&mut h, 112, &1f32.to_le_bytes());
    h[123] = 2 | 8; // mm, seconds
    let descrip = b"qcshape";
    put(&mut h, 148, descrip);
    if let Some((q, _)) = quat {
        put(&mut h, 252, &2i16.to_le_bytes());
        for (k, v) in q.iter().enumerate() {
            put(&mut h, 256 + 4 * k, &(*v as f32).to_le_bytes());
        }
        for k in 0..3 {
            put(&mut h, 268 + 4 * k, &(v0.affine[k][3] as f32).to_le_bytes());
        }
    }
    put(&mut h, 254, &2i16.to_le_bytes());
    for row in 0..3 {
        for c in 0..4 {
            put(
                &mut h,
                280 + 16 * row + 4 * c,
                &(v0.affine[row][c] as f32).to_le_bytes(),
            );
        }
    }
    put(&mut h, 344, b"n+1\0");
    h.reserve(frames.iter().map(|f| f.data.len() * 4).sum());
    for f in frames {
        for v in &f.data {
            h.extend_from_slice(&v.to_le_bytes());
        }
    }
    h
}

fn is_gz(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz"))
}

/// Reads every frame of a 3D or 4D NIfTI-1 file (`.nii` or `.nii.gz`; gzip is recognized
/// by its magic bytes).
pub fn read_series(path: &Path) -> Result<Vec<Volume>, NiftiError> {
    let bytes =
        crate::limits::read_regular_file(path, crate::limits::MAX_MESH_FILE_BYTES).map_err(|error| {
            NiftiError::Read {
                path: path.into(),
                error,
            }
        })?;
    parse_nifti(&bytes).map_err(|error| NiftiError::Parse {
        path: path.into(),
        error,
    })
}

/// Reads a 3D NIfTI-1 volume; a 4D file with more than one frame is an error.
pub fn read_volume(path: &Path) -> Result<Volume, NiftiError> {
    let mut frames = read_series(path)?;
    if frames.len() != 1 {
        return Err(NiftiError::NotThreeD {
            path: path.into(),
            frames: frames.len(),
        });
    }
    Ok(frames.remove(0))
}

/// Writes frames (same dims, spacing and affine; at most 32767) as one 3D (one frame) or 4D
/// NIfTI-1 file, gzipped when the name ends in `.gz`, atomically.
pub fn write_series(path: &Path, frames: &[Volume]) -> Result<(), NiftiError> {
    let bad = |problem: SeriesError| NiftiError::Inconsistent {
        path: path.into(),
        problem,
    };
    let Some(v0) = frames.first() else {
        return Err(bad(SeriesError::NoFrames));
    };
    if frames.len() > i16::MAX as usize || v0.dims.iter().any(|&d| d == 0 || d > i16::MAX as usize) {
        return Err(bad(SeriesError::TooLarge {
            frames: frames.len(),
            dims: v0.dims,
        }));
    }
    for (t, f) in frames.iter().enumerate() {
        if f.dims != v0.dims || f.affine != v0.affine || f.data.len() != f.dims.iter().product::<usize>() {
            return Err(bad(SeriesError::FrameMismatch {
                frame: t,
                dims: f.dims,
                voxels: f.data.len(),
                first: v0.dims,
            }));
        }
    }
    if det3(&v0.affine) == 0.0 {
        return Err(bad(SeriesError::SingularAffine));
    }
    let bytes = encode(frames);
    write_atomically(path, |w| {
        if is_gz(path) {
            let mut gz = flate2::write::GzEncoder::new(w, flate2::Compression::fast());
            gz.write_all(&bytes)?;
            gz.finish()?;
            Ok(())
        } else {
            w.write_all(&bytes)
        }
    })?;
    Ok(())
}

/// Writes one 3D volume (see [`write_series`]).
pub fn write_volume(path: &Path, volume: &Volume) -> Result<(), NiftiError> {
    write_series(path, std::slice::from_ref(volume))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn oblique() -> Volume {
        let mut v = Volume::filled([3, 4, 5], [0.5, 0.5, 0.625], [10.0, -20.0, 5.0], 0.0);
        // Rotate 30 degrees about z and flip z (negative determinant: qfac = -1). (A flip of
        // x instead makes a half-turn quaternion, whose a = 0 is only float32-accurate.)
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let r = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, -1.0]];
        for (row, rr) in r.iter().enumerate() {
            for (col, x) in rr.iter().enumerate() {
                v.affine[row][col] = x * v.spacing[col];
            }
        }
        for (k, x) in v.data.iter_mut().enumerate() {
            *x = k as f32 * 0.5 - 3.0;
        }
        v
    }

    #[test]
    fn qform_alone_gives_the_same_affine() {
        let v = oblique();
        let mut bytes = encode(std::slice::from_ref(&v));
        bytes[254..256].copy_from_slice(&0i16.to_le_bytes()); // drop the sform
        let back = parse_nifti(&bytes).unwrap().remove(0);
        for r in 0..3 {
            for c in 0..4 {
                assert!(
                    (back.affine[r][c] - v.affine[r][c]).abs() < 1e-5,
                    "{:?}",
                    back.affine
                );
            }
        }
        assert!(det3(&back.affine) < 0.0);
        let w = v.to_world([1.0, 2.0, 3.0]);
        let p = v.to_voxel(w).unwrap();
        assert!((p[0] - 1.0).abs() < 1e-12 && (p[2] - 3.0).abs() < 1e-12);
    }

    /// A valid little-endian 2 x 2 x 2 uint8 header and data (352 + 8 bytes).
    fn small() -> Vec<u8> {
        let mut h = vec![0u8; 352 + 8];
        h[0..4].copy_from_slice(&348i32.to_le_bytes());
        for (k, d) in [3i16, 2, 2, 2, 1, 1, 1, 1].iter().enumerate() {
            h[40 + 2 * k..42 + 2 * k].copy_from_slice(&d.to_le_bytes());
        }
        h[70..72].copy_from_slice(&2i16.to_le_bytes());
        for (k, p) in [1f32, 1.0, 1.0, 1.0].iter().enumerate() {
            h[76 + 4 * k..80 + 4 * k].copy_from_slice(&p.to_le_bytes());
        }
        h[108..112].copy_from_slice(&352f32.to_le_bytes());
        h[344..348].copy_from_slice(b"n+1\0");
        h
    }

    #[test]
    fn bad_headers_are_named_errors() {
        let good = small();
        assert_eq!(parse_nifti(&good).unwrap()[0].dims, [2, 2, 2]);
        let msg = |b: &[u8]| parse_nifti(b).unwrap_err().to_string();
        // Truncated header, at several lengths.
        for n in [0, 4, 100, 347] {
            assert!(
                msg(&good[..n]).contains("shorter than the 348-byte header"),
                "{n}"
            );
        }
        // Truncated data.
        assert!(msg(&good[..355]).contains("truncated data: 8 bytes"));
        // vox_offset not whole, below the header, beyond the file, not finite.
        for (v, want) in [
            (352.5f32, "vox_offset 352.5"),
            (100.0, "vox_offset 100"),
            (f32::NAN, "vox_offset NaN"),
            (1e30, "truncated data"),
        ] {
            let mut b = good.clone();
            b[108..112].copy_from_slice(&v.to_le_bytes());
            assert!(msg(&b).contains(want), "{v}: {}", msg(&b));
        }
        // Dimensions that overflow or are not positive.
        let mut b = good.clone();
        for k in 1..=4 {
            b[40 + 2 * k..42 + 2 * k].copy_from_slice(&i16::MAX.to_le_bytes());
        }
        b[40..42].copy_from_slice(&4i16.to_le_bytes());
        b[70..72].copy_from_slice(&64i16.to_le_bytes());
        let m = msg(&b);
        assert!(m.contains("truncated data") || m.contains("overflows"), "{m}");
        let mut b = good.clone();
        b[42..44].copy_from_slice(&(-2i16).to_le_bytes());
        assert!(msg(&b).contains("dim[1] = -2"));
        // Wrong magic, two-file header.
        let mut b = good.clone();
        b[344..348].copy_from_slice(b"xyz\0");
        assert!(msg(&b).contains("magic"));
        b[344..348].copy_from_slice(b"ni1\0");
        assert!(msg(&b).contains("two-file"));
        // A corrupt gzip stream.
        let mut z = Vec::new();
        {
            let mut e = flate2::write::GzEncoder::new(&mut z, flate2::Compression::default());
            std::io::Write::write_all(&mut e, &good).unwrap();
        }
        assert_eq!(parse_nifti(&z).unwrap()[0].dims, [2, 2, 2]);
        let n = z.len();
        z[n / 2] ^= 0xff;
        z.truncate(n - 3);
        assert!(msg(&z).contains("cannot decompress"));
    }

    #[test]
    fn a_gzip_bomb_is_refused_at_the_size_bound() {
        // 1 MB of zeros compresses to about 1 kB; with a 64 kB bound it is refused.
        let mut z = Vec::new();
        {
            let mut e = flate2::write::GzEncoder::new(&mut z, flate2::Compression::best());
            std::io::Write::write_all(&mut e, &vec![0u8; 1 << 20]).unwrap();
        }
        assert!(z.len() < 10_000);
        let e = maybe_gunzip_bounded(&z, 1 << 16).unwrap_err();
        assert!(e.to_string().contains("more than 65536 bytes"), "{e}");
        assert_eq!(maybe_gunzip_bounded(&z, 1 << 20).unwrap().len(), 1 << 20);
    }

    #[test]
    fn big_endian_int16_with_scaling_and_metres() {
        let mut h = vec![0u8; 352 + 2 * 8];
        h[0..4].copy_from_slice(&348i32.to_be_bytes());
        let dim = [3i16, 2, 2, 2, 1, 1, 1, 1];
        for (k, d) in dim.iter().enumerate() {
            h[40 + 2 * k..42 + 2 * k].copy_from_slice(&d.to_be_bytes());
        }
        h[70..72].copy_from_slice(&4i16.to_be_bytes());
        for (k, p) in [1f32, 0.001, 0.002, 0.003].iter().enumerate() {
            h[76 + 4 * k..80 + 4 * k].copy_from_slice(&p.to_be_bytes());
        }
        h[108..112].copy_from_slice(&352f32.to_be_bytes());
        h[112..116].copy_from_slice(&2f32.to_be_bytes());
        h[116..120].copy_from_slice(&(-1f32).to_be_bytes());
        h[123] = 1; // metres
        h[344..348].copy_from_slice(b"n+1\0");
        for k in 0..8i16 {
            h[352 + 2 * k as usize..354 + 2 * k as usize].copy_from_slice(&(k - 4).to_be_bytes());
        }
        let v = parse_nifti(&h).unwrap().remove(0);
        assert_eq!(v.dims, [2, 2, 2]);
        assert!((v.spacing[2] - 3.0).abs() < 1e-4, "{:?}", v.spacing);
        assert_eq!(v.data[0], -9.0);
        assert_eq!(v.data[7], 5.0);
        h[70..72].copy_from_slice(&32i16.to_be_bytes());
        assert!(matches!(
            parse_nifti(&h),
            Err(NiftiParseError::Datatype { code: 32, .. })
        ));
    }
}
