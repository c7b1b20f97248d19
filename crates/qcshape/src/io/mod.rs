//! Mesh files: reading OBJ, PLY, OFF, STL, legacy VTK (POLYDATA and UNSTRUCTURED_GRID), VTK
//! XML PolyData (`.vtp`) and VTK XML UnstructuredGrid (`.vtu`) into a triangle soup
//! ([`MeshData`], with the files' named point data: PLY extra vertex properties, VTK
//! `POINT_DATA`, VTP/VTU `PointData`) or a validated [`Shape`], and writing OBJ, PLY, OFF, STL,
//! VTK, VTP and VTU with
//! optional per-vertex values (heat maps) or several named scalar and vector fields
//! ([`Field`], [`write_mesh_fields`]); [`npy`] writes matrices for NumPy.
//!
//! # Why hand-written parsers
//!
//! The crates that read these formats (tobj, ply-rs, stl_io, vtkio) were considered. They
//! either panic or allocate declared counts on malformed input, report problems without a line
//! or byte position, or pull in large dependency trees for features this crate does not use
//! (materials, cells other than polygons, XML VTK). The formats are small, so each reader here
//! is a few hundred lines written against one rule: **no input may panic or allocate more
//! than the file could hold**. Declared counts are checked against the bytes that remain
//! before anything is reserved, every number is checked, and every error says where (line for
//! text, byte offset for binary) and what. `stress` tests (and the `fuzz/` targets) feed
//! mutated files to [`parse_mesh`] to keep it that way.
//!
//! # Guarantees of [`parse_mesh`]
//!
//! On success every coordinate is finite and every face index is below
//! `positions.len()`. Faces are *not* otherwise validated here (repeated indices,
//! non-manifold edges, orientation, zero area): [`load_shape`] does that through
//! [`Topology::new`] and [`Shape::new_checked`].
//!
//! Polygons with more than three corners are triangulated and reported in
//! [`MeshData::warnings`]: convex ones as a fan (`[a, b, c, d]` becomes `[a, b, c], [a, c, d]`),
//! non-convex ones by ear clipping in their best-fit plane; one that is neither (self-intersecting
//! or degenerate) is an error.

mod color;
mod fields;
pub mod inspect;
#[cfg(test)]
mod interop_tests;
pub mod nifti;
pub mod npy;
mod number;
mod obj;
mod off;
mod ply;
mod polygon;
mod stl;
#[cfg(test)]
mod stress;
mod syntax;
pub mod table;
#[cfg(test)]
mod tests;
mod text;
mod vtk;
mod vtp;
mod vtu;
mod xml;

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use thiserror::Error;

use crate::mesh::{MeshError, Shape, Topology};

pub use color::heat_colors;
pub use fields::{Field, FieldValues, PointArray};
pub use ply::PlyEncoding;
pub use stl::WELD_REL_TOL;
pub use syntax::SyntaxError;

/// Relative area tolerance used by [`load_shape`]: a face whose area is at most
/// `1e-12 * lbar^2` (`lbar` the mean edge length) is rejected as degenerate.
pub const DEGENERATE_REL_TOL: f64 = 1e-12;

/// A triangle soup as read from a file, before any topological validation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions (#V x 3), in the file's length unit; all finite.
    pub positions: Vec<[f64; 3]>,
    /// Triangles (#F x 3) of 0-based indices into `positions`, all in range.
    pub faces: Vec<[u32; 3]>,
    /// Non-fatal remarks from the reader (fan-triangulated polygons, ignored trailing data,
    /// welded STL corners), each one sentence.
    pub warnings: Vec<String>,
    /// Named per-vertex arrays of the file (PLY extra vertex properties, VTK `POINT_DATA`,
    /// VTP and VTU `PointData`), each #V x components, in file order; empty for OBJ, OFF and
    /// STL.
    pub point_data: Vec<PointArray>,
}

impl MeshData {
    /// The point array called `name`, if the file has one.
    pub fn point_array(&self, name: &str) -> Option<&PointArray> {
        self.point_data.iter().find(|a| a.name == name)
    }
}

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Wavefront OBJ (text).
    Obj,
    /// Stanford PLY (ASCII, binary little endian or binary big endian).
    Ply,
    /// Object File Format (text).
    Off,
    /// STL (ASCII or binary; unindexed, single precision).
    Stl,
    /// Legacy VTK POLYDATA or UNSTRUCTURED_GRID (ASCII or big-endian binary).
    Vtk,
    /// VTK XML PolyData (`.vtp`: ascii, inline base64 or appended data, optionally zlib).
    Vtp,
    /// VTK XML UnstructuredGrid (`.vtu`, same encodings as `.vtp`) of surface cells.
    Vtu,
}

impl Format {
    /// Every format, in a fixed order.
    pub const ALL: [Format; 7] = [
        Format::Obj,
        Format::Ply,
        Format::Off,
        Format::Stl,
        Format::Vtk,
        Format::Vtp,
        Format::Vtu,
    ];

    /// The format for a file name extension (`obj`, `ply`, `off`, `stl`, `vtk`, `vtp`,
    /// `vtu`; any case).
    pub fn from_extension(ext: &str) -> Option<Format> {
        Format::ALL
            .into_iter()
            .find(|f| f.extension().eq_ignore_ascii_case(ext))
    }

    /// The format named by `path`'s extension (case-insensitive), if it is a known one.
    pub fn from_path(path: &Path) -> Option<Format> {
        Format::from_extension(path.extension()?.to_str()?)
    }

    /// The usual file name extension, lower case, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Obj => "obj",
            Format::Ply => "ply",
            Format::Off => "off",
            Format::Stl => "stl",
            Format::Vtk => "vtk",
            Format::Vtp => "vtp",
            Format::Vtu => "vtu",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Obj => "OBJ",
            Format::Ply => "PLY",
            Format::Off => "OFF",
            Format::Stl => "STL",
            Format::Vtk => "VTK",
            Format::Vtp => "VTP",
            Format::Vtu => "VTU",
        })
    }
}

fn at_line(line: &Option<usize>) -> String {
    match line {
        Some(l) => format!(" (line {l})"),
        None => String::new(),
    }
}

/// Why a byte buffer is not a readable mesh. Face and vertex numbers are 0-based positions in
/// the file (a face is a polygon as written, before triangulation); lines are 1-based.
#[derive(Debug, Error, Clone)]
pub enum ParseError {
    /// The input is empty or only whitespace.
    #[error("the file is empty")]
    Empty,
    /// A malformed line or token in a text file (or text header).
    #[error("line {line}: {problem}")]
    Syntax {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        problem: SyntaxError,
    },
    /// Binary data ends before a declared record does.
    #[error("the file is truncated: {what} needs {needed} bytes from byte offset {offset}, but the file has only {len} bytes")]
    Truncated {
        /// The record being read, e.g. "vertex 17 of 642".
        what: String,
        /// Bytes the record needs.
        needed: u64,
        /// Where it starts.
        offset: u64,
        /// File length in bytes.
        len: u64,
    },
    /// A text file ends before everything its header declared.
    #[error("the file ends early: expected {expected}")]
    UnexpectedEnd {
        /// What was still expected, e.g. "642 vertices, found 100".
        expected: String,
    },
    /// A face index outside `0..n_vertices` (as written: 1-based or negative for OBJ).
    #[error("face {face} refers to vertex {index}, but there are only {n_vertices} vertices{}", at_line(.line))]
    IndexOutOfRange {
        /// Face number in the file.
        face: usize,
        /// The index as written.
        index: i64,
        /// Number of vertices.
        n_vertices: usize,
        /// Line, for text files.
        line: Option<usize>,
    },
    /// A coordinate is NaN or infinite (or overflows `f64`).
    #[error("vertex {vertex} has a non-finite coordinate ({value}){}", at_line(.line))]
    NonFinite {
        /// Vertex number.
        vertex: usize,
        /// The offending value.
        value: f64,
        /// Line, for text files.
        line: Option<usize>,
    },
    /// A face with fewer than three corners.
    #[error("face {face} has {count} vertices, but a face needs at least 3{}", at_line(.line))]
    BadFace {
        /// Face number.
        face: usize,
        /// Its corner count.
        count: u64,
        /// Line, for text files.
        line: Option<usize>,
    },
    /// A polygon that cannot be triangulated.
    #[error("face {face}: its {corners} corners do not form a simple polygon (self-intersecting, or all on one line), so it cannot be triangulated{}", at_line(.line))]
    Polygon {
        /// Face number.
        face: usize,
        /// Its corner count.
        corners: usize,
        /// Line, for text files.
        line: Option<usize>,
    },
    /// A part the format requires is absent: a header line, a section, an element, a
    /// property or a data array.
    #[error("the file has no {what}")]
    Missing {
        /// The absent part, e.g. "format line in its PLY header" or "POINTS section".
        what: String,
    },
    /// More vertices than 32-bit face indices can address.
    #[error("the file declares {count} vertices, more than 32-bit indices can address")]
    TooManyVertices {
        /// The declared vertex count.
        count: u64,
    },
    /// A declared array whose size in values or bytes overflows `u64`.
    #[error("{what} declares more values than can be addressed")]
    SizeOverflow {
        /// The array, e.g. "PointData \"normals\"".
        what: String,
    },
    /// A legacy VTK UNSTRUCTURED_GRID whose CELL_TYPES section lists a different number of
    /// types than its CELLS section has cells.
    #[error("CELL_TYPES lists {types} types for {cells} cells")]
    CellTypeCount {
        /// Types listed.
        types: usize,
        /// Cells in the CELLS section.
        cells: usize,
    },
    /// A list length (PLY) that is not a non-negative integer.
    #[error("{what} is {value}, not a count{}", at_line(.line))]
    BadListLength {
        /// The list, e.g. "the length of property vertex_indices of face 3 (of 10)".
        what: String,
        /// The value read.
        value: f64,
        /// Line, when known (ASCII).
        line: Option<usize>,
    },
    /// A face's vertex index that is not an integer (PLY float index lists).
    #[error("face {face} has the vertex index {value}, not an integer{}", at_line(.line))]
    NonIntegerIndex {
        /// Face number.
        face: usize,
        /// The value read.
        value: f64,
        /// Line, when known (ASCII).
        line: Option<usize>,
    },
    /// A PLY vertex coordinate property declared as a list.
    #[error("the PLY vertex property {axis} is a list")]
    ListCoordinate {
        /// "x", "y" or "z".
        axis: &'static str,
    },
    /// An STL triangle corner with a NaN or infinite coordinate.
    #[error("corner {corner} of triangle {triangle} has a non-finite coordinate ({value}){}", at_line(.line))]
    NonFiniteCorner {
        /// Triangle number.
        triangle: usize,
        /// Corner (0, 1 or 2).
        corner: usize,
        /// The first non-finite coordinate.
        value: f64,
        /// Line, when known (ASCII STL).
        line: Option<usize>,
    },
    /// A PLY file with data after the last element its header declares.
    #[error("the file holds more data than its header declares ({}): data {}", declared_elements(.declared), after_last(.line))]
    TrailingData {
        /// The declared elements: (count, name).
        declared: Vec<(u64, String)>,
        /// Line of the extra data, when known (ASCII).
        line: Option<usize>,
    },
    /// A legacy VTK cell section (POLYGONS, TRIANGLE_STRIPS, CELLS, ...) whose layout is
    /// inconsistent.
    #[error("{}{keyword}: {problem}", line_prefix(.line))]
    Cells {
        /// The section keyword.
        keyword: String,
        /// The section's line, when known (ASCII).
        line: Option<usize>,
        /// What is wrong.
        problem: CellsError,
    },
    /// A VTK XML `DataArray` whose binary encoding is corrupt.
    #[error("{array}: {problem}")]
    DataArray {
        /// The array, e.g. "DataArray \"connectivity\" (line 5)".
        array: String,
        /// What is wrong.
        problem: DataArrayError,
    },
    /// A valid file using a feature this reader does not support.
    #[error("unsupported: {0}")]
    Unsupported(UnsupportedFeature),
}

fn declared_elements(declared: &[(u64, String)]) -> String {
    let parts: Vec<String> = declared.iter().map(|(n, name)| format!("{n} {name}")).collect();
    parts.join(", ")
}

fn after_last(line: &Option<usize>) -> String {
    match line {
        Some(l) => format!("at line {l}, after the last element"),
        None => "after the last element".into(),
    }
}

fn line_prefix(line: &Option<usize>) -> String {
    match line {
        Some(l) => format!("line {l}: "),
        None => String::new(),
    }
}

/// Why a legacy VTK cell section is inconsistent ([`ParseError::Cells`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CellsError {
    /// The keyword after the OFFSETS array is not CONNECTIVITY.
    #[error("expected CONNECTIVITY after the offsets, found {found:?}")]
    ExpectedConnectivity {
        /// The token found (at most 40 characters).
        found: String,
    },
    /// An offset that is not an integer.
    #[error("offset {offset} is not an integer")]
    OffsetNotInteger {
        /// Offset number.
        offset: usize,
    },
    /// Two consecutive offsets that do not delimit a range of the connectivity array.
    #[error("offsets {offset} and {} ({start}, {end}) do not index the {len} connectivity values", .offset + 1)]
    OffsetsOutOfRange {
        /// The first offset's number.
        offset: usize,
        /// Its value.
        start: i64,
        /// The next offset's value.
        end: i64,
        /// Length of the connectivity array.
        len: usize,
    },
    /// A cell without a valid (non-negative integer) vertex count.
    #[error("cell {cell} has no valid vertex count (the section declares {cells} cells in {size} values)")]
    NoVertexCount {
        /// Cell number.
        cell: u64,
        /// Declared cells.
        cells: u64,
        /// Declared values.
        size: u64,
    },
    /// A cell listing more vertices than the section has values left.
    #[error("cell {cell} lists {count} vertices, but only {remaining} of the declared {size} values remain")]
    TooFewValues {
        /// Cell number.
        cell: u64,
        /// The vertex count it declares.
        count: i64,
        /// Values left.
        remaining: usize,
        /// Declared values.
        size: u64,
    },
    /// The cells use a different number of values than the section declares.
    #[error("the section declares {size} values, but its {cells} cells use {used}")]
    SizeMismatch {
        /// Declared values.
        size: u64,
        /// Declared cells.
        cells: u64,
        /// Values used.
        used: usize,
    },
}

/// Why the binary payload of a VTK XML `DataArray` is corrupt ([`ParseError::DataArray`]).
#[derive(Debug, Error, Clone)]
pub enum DataArrayError {
    /// A character that is not base64.
    #[error("bad base64 at byte offset {offset}")]
    Base64 {
        /// Byte offset in the file.
        offset: u64,
    },
    /// The header's byte count differs from the array's size.
    #[error("the header declares {declared} bytes, but the array needs {needed}")]
    HeaderSize {
        /// Bytes the header declares.
        declared: u64,
        /// Bytes the array's type and count need.
        needed: u64,
    },
    /// A compression header declaring more blocks than the bytes after it could describe.
    #[error("the compression header declares {blocks} blocks, more than the {available} bytes after it could describe")]
    TooManyBlocks {
        /// Declared blocks.
        blocks: u64,
        /// Bytes available.
        available: u64,
    },
    /// The compression header's total size differs from the array's size.
    #[error("the compression header declares {declared} bytes, but the array needs {needed}")]
    CompressedSize {
        /// Bytes the header declares.
        declared: u64,
        /// Bytes the array's type and count need.
        needed: u64,
    },
    /// The compression header's sizes overflow `u64`.
    #[error("the compression header's sizes ({blocks} blocks of {block_size} bytes) overflow")]
    BlockSizesOverflow {
        /// Declared blocks.
        blocks: u64,
        /// Declared block size.
        block_size: u64,
    },
    /// The compressed block sizes overflow `u64`.
    #[error("the compressed block sizes overflow")]
    CompressedSizesOverflow,
    /// More output than zlib could inflate from the compressed bytes.
    #[error("{compressed} compressed bytes cannot hold the declared {declared} bytes")]
    Ratio {
        /// Compressed bytes.
        compressed: u64,
        /// Declared uncompressed bytes.
        declared: u64,
    },
    /// A zlib block that cannot be inflated.
    #[error("zlib block {block} cannot be inflated: {error}")]
    Inflate {
        /// Block number.
        block: usize,
        /// The decoder's error.
        error: std::sync::Arc<std::io::Error>,
    },
    /// A zlib block inflating to a different size than the header says.
    #[error("zlib block {block} inflates to {found} bytes, the header says {declared}")]
    BlockSize {
        /// Block number.
        block: usize,
        /// Bytes inflated.
        found: u64,
        /// Bytes declared.
        declared: u64,
    },
}

/// A feature of a valid file that the readers do not support ([`ParseError::Unsupported`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum UnsupportedFeature {
    /// A VTK XML file with several pieces.
    #[error("a {ext} file with more than one Piece")]
    SeveralPieces {
        /// ".vtp" or ".vtu".
        ext: &'static str,
    },
    /// A VTK XML file of another type than the reader's.
    #[error("VTK XML file of type {found:?} (only {expected} is read)")]
    XmlType {
        /// The file's `type` attribute.
        found: String,
        /// The type the reader reads.
        expected: &'static str,
    },
    /// A VTK XML compressor other than zlib.
    #[error("compressor {0:?} (only vtkZLibDataCompressor is read)")]
    Compressor(String),
    /// A legacy VTK dataset type other than POLYDATA and UNSTRUCTURED_GRID.
    #[error("VTK dataset type {0:?} (only POLYDATA and UNSTRUCTURED_GRID are read)")]
    VtkDataset(String),
    /// A `.vtu` cell that is not a surface cell.
    #[error("cell {cell} of the .vtu file is a {name} (VTK cell type {vtk_type}); only surface cells (triangles, quads, polygons, triangle strips) can be read")]
    VtuCell {
        /// Cell number.
        cell: usize,
        /// The cell type's name.
        name: &'static str,
        /// The VTK cell type number as written.
        vtk_type: f64,
    },
    /// An OFF variant other than 3D OFF with C, N, ST prefixes.
    #[error("OFF variant {0:?} (only 3D OFF with optional C, N, ST prefixes is read)")]
    OffVariant(String),
    /// Binary OFF.
    #[error("binary OFF")]
    BinaryOff,
}

/// Why a mesh cannot be encoded as asked (checked before anything is written).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum WriteError {
    /// A per-vertex attribute does not have one entry per vertex.
    #[error("{what} has {got} entries, but there are {expected} vertices")]
    AttributeLength {
        /// Which attribute.
        what: String,
        /// Its length.
        got: usize,
        /// Number of vertices.
        expected: usize,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but there are only {n_vertices} vertices")]
    IndexOutOfRange {
        /// Face index.
        face: usize,
        /// Vertex index.
        index: u32,
        /// Number of vertices.
        n_vertices: usize,
    },
    /// A field with an empty name.
    #[error("field \"\": a field needs a name")]
    UnnamedField,
    /// Two fields with the same name.
    #[error("field {0:?}: two fields have this name")]
    DuplicateField(String),
    /// The format cannot store the given per-vertex attribute.
    #[error("the {format} format cannot store {what}; write .ply, .vtk, .vtp or .vtu instead")]
    Unsupported {
        /// Target format.
        format: Format,
        /// The attribute, e.g. "per-vertex scalars".
        what: &'static str,
    },
}

/// A file-level error: every message starts with the file's path.
#[derive(Debug, Error)]
pub enum IoError {
    /// The file cannot be read (missing, a directory, no permission).
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// The file (or its temporary) cannot be written or renamed.
    #[error("{}: cannot write: {error}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// The extension names no known format.
    #[error("{}: unknown mesh format: the file name must end in .obj, .ply, .off, .stl, .vtk, .vtp or .vtu", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The bytes are not a valid mesh file.
    #[error("{}: {error}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The problem.
        error: ParseError,
    },
    /// The file parses, but its mesh is unusable (bad connectivity, degenerate face).
    #[error("{}: {error}", path.display())]
    Mesh {
        /// The file.
        path: PathBuf,
        /// The problem.
        error: MeshError,
    },
    /// The mesh cannot be encoded as asked.
    #[error("{}: {error}", path.display())]
    Encode {
        /// The file.
        path: PathBuf,
        /// The problem.
        error: WriteError,
    },
}

impl IoError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            IoError::Read { path, .. }
            | IoError::Write { path, .. }
            | IoError::UnknownFormat { path }
            | IoError::Parse { path, .. }
            | IoError::Mesh { path, .. }
            | IoError::Encode { path, .. } => path,
        }
    }
}

/// Parses a whole file held in memory. Pure: no file system access, and no panic or
/// unbounded allocation for any input (this is what the fuzz targets call).
pub fn parse_mesh(bytes: &[u8], format: Format) -> Result<MeshData, ParseError> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(ParseError::Empty);
    }
    // A UTF-8 byte order mark before a text format (not STL, whose binary header is free-form).
    let bytes = match (format, bytes.strip_prefix(b"\xEF\xBB\xBF")) {
        (Format::Obj | Format::Off | Format::Ply | Format::Vtk | Format::Vtp | Format::Vtu, Some(rest)) => {
            rest
        }
        _ => bytes,
    };
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(ParseError::Empty);
    }
    let data = match format {
        Format::Obj => obj::parse(bytes),
        Format::Ply => ply::parse(bytes),
        Format::Off => off::parse(bytes),
        Format::Stl => stl::parse(bytes),
        Format::Vtk => vtk::parse(bytes),
        Format::Vtp => vtp::parse(bytes),
        Format::Vtu => vtu::parse(bytes),
    }?;
    debug_assert!(data
        .point_data
        .iter()
        .all(|a| a.values.len() == a.components * data.positions.len()));
    debug_assert!(data.positions.iter().flatten().all(|c| c.is_finite()));
    debug_assert!(data
        .faces
        .iter()
        .flatten()
        .all(|&i| (i as usize) < data.positions.len()));
    Ok(data)
}

/// Reads and parses a mesh file, choosing the format from its extension.
pub fn read_mesh(path: &Path) -> Result<MeshData, IoError> {
    // A missing path or a folder is reported as such before its name is judged.
    match std::fs::metadata(path) {
        Err(error) => {
            return Err(IoError::Read {
                path: path.into(),
                error,
            })
        }
        Ok(m) if m.is_dir() => {
            return Err(IoError::Read {
                path: path.into(),
                error: std::io::Error::other("a folder, not a mesh file"),
            })
        }
        Ok(_) => {}
    }
    let format = Format::from_path(path).ok_or_else(|| IoError::UnknownFormat { path: path.into() })?;
    let bytes =
        crate::limits::read_regular_file(path, crate::limits::MAX_MESH_FILE_BYTES).map_err(|error| {
            IoError::Read {
                path: path.into(),
                error,
            }
        })?;
    parse_mesh(&bytes, format).map_err(|error| IoError::Parse {
        path: path.into(),
        error,
    })
}

/// Reads a mesh file into a validated [`Shape`]: [`read_mesh`], then [`Topology::new`] and
/// [`Shape::new_checked`] with [`DEGENERATE_REL_TOL`]. Reader warnings are dropped; see
/// [`load_shape_with_warnings`].
pub fn load_shape(path: &Path) -> Result<Shape, IoError> {
    load_shape_with_warnings(path).map(|(s, _)| s)
}

/// Like [`load_shape`], also returning the reader's warnings.
pub fn load_shape_with_warnings(path: &Path) -> Result<(Shape, Vec<String>), IoError> {
    let data = read_mesh(path)?;
    let shape = shape_from_data(path, data.positions, data.faces)?;
    Ok((shape, data.warnings))
}

/// Builds a validated shape from parsed data, wrapping mesh errors with `path`.
pub(crate) fn shape_from_data(
    path: &Path,
    positions: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
) -> Result<Shape, IoError> {
    let wrap = |error| IoError::Mesh {
        path: path.into(),
        error,
    };
    let topo = Topology::new(positions.len(), faces).map_err(wrap)?;
    Shape::new_checked(topo, positions, DEGENERATE_REL_TOL).map_err(wrap)
}

/// Optional per-vertex values written alongside the geometry.
#[derive(Debug, Clone, Copy, Default)]
pub struct VertexAttributes<'a> {
    /// A named scalar per vertex (#V), e.g. `("error", &errors)`; PLY and VTK only.
    pub scalar: Option<(&'a str, &'a [f64])>,
    /// An RGB colour per vertex (#V x 3, 0..=255), e.g. from [`heat_colors`]; PLY, VTK and OBJ
    /// (as the common `v x y z r g b` extension).
    pub colors: Option<&'a [[u8; 3]]>,
}

/// Choices for encoding that the file name does not determine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WriteOptions {
    /// PLY encoding (default binary little endian).
    pub ply_encoding: PlyEncoding,
}

/// What the writers put beside the geometry: named fields (the [`VertexAttributes`] scalar
/// first, if any) and colours.
#[derive(Debug, Clone, Default)]
pub(crate) struct Payload<'a> {
    pub(crate) fields: Vec<Field<'a>>,
    pub(crate) colors: Option<&'a [[u8; 3]]>,
}

impl<'a> Payload<'a> {
    fn new(attrs: &VertexAttributes<'a>, fields: &[Field<'a>]) -> Self {
        let mut all: Vec<Field<'a>> = attrs
            .scalar
            .map(|(name, s)| Field::scalar(name, s))
            .into_iter()
            .collect();
        all.extend_from_slice(fields);
        Payload {
            fields: all,
            colors: attrs.colors,
        }
    }
}

fn validate(
    format: Format,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    payload: &Payload,
) -> Result<(), WriteError> {
    let n = positions.len();
    for (face, f) in faces.iter().enumerate() {
        if let Some(&index) = f.iter().find(|&&i| i as usize >= n) {
            return Err(WriteError::IndexOutOfRange {
                face,
                index,
                n_vertices: n,
            });
        }
    }
    for (k, f) in payload.fields.iter().enumerate() {
        if f.len() != n {
            return Err(WriteError::AttributeLength {
                what: format!("{} {:?}", f.kind(), f.name),
                got: f.len(),
                expected: n,
            });
        }
        if f.name.trim().is_empty() {
            return Err(WriteError::UnnamedField);
        }
        if payload.fields[..k].iter().any(|g| g.name == f.name) {
            return Err(WriteError::DuplicateField(f.name.into()));
        }
        if matches!(format, Format::Obj | Format::Off | Format::Stl) {
            return Err(WriteError::Unsupported {
                format,
                what: "per-vertex scalars or vectors",
            });
        }
    }
    if let Some(c) = payload.colors {
        if c.len() != n {
            return Err(WriteError::AttributeLength {
                what: "colors".into(),
                got: c.len(),
                expected: n,
            });
        }
        if matches!(format, Format::Off | Format::Stl | Format::Vtp | Format::Vtu) {
            return Err(WriteError::Unsupported {
                format,
                what: "per-vertex colors",
            });
        }
    }
    Ok(())
}

fn encode_to(
    w: &mut dyn Write,
    format: Format,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    payload: &Payload,
    options: &WriteOptions,
) -> std::io::Result<()> {
    match format {
        Format::Obj => obj::write(w, positions, faces, payload.colors),
        Format::Ply => ply::write(w, positions, faces, payload, options.ply_encoding),
        Format::Off => off::write(w, positions, faces),
        Format::Stl => stl::write(w, positions, faces),
        Format::Vtk => vtk::write(w, positions, faces, payload),
        Format::Vtp => vtp::write(w, positions, faces, &payload.fields, false),
        Format::Vtu => vtp::write(w, positions, faces, &payload.fields, true),
    }
}

/// Encodes a mesh (positions #V x 3, faces #F x 3) in memory. Errors if an attribute's length
/// is not #V, a face index is out of range, or the format cannot hold an attribute.
pub fn encode_mesh(
    format: Format,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    attrs: &VertexAttributes,
    options: &WriteOptions,
) -> Result<Vec<u8>, WriteError> {
    encode_mesh_fields(format, positions, faces, &Payload::new(attrs, &[]), options)
}

/// Encodes a mesh with named per-vertex fields (each #V scalars or #V x 3 vectors) in memory:
/// PLY, VTK and VTP only (see [`write_mesh_fields`]).
pub fn encode_mesh_with_fields(
    format: Format,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    fields: &[Field],
    options: &WriteOptions,
) -> Result<Vec<u8>, WriteError> {
    let payload = Payload::new(&VertexAttributes::default(), fields);
    encode_mesh_fields(format, positions, faces, &payload, options)
}

fn encode_mesh_fields(
    format: Format,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    payload: &Payload,
    options: &WriteOptions,
) -> Result<Vec<u8>, WriteError> {
    validate(format, positions, faces, payload)?;
    let mut out = Vec::new();
    encode_to(&mut out, format, positions, faces, payload, options).expect("writing to a Vec cannot fail");
    Ok(out)
}

/// Writes a mesh (positions #V x 3, faces #F x 3) with several named per-vertex fields, in the
/// format named by `path`'s extension, atomically:
/// - PLY: each scalar field as a `double` vertex property of its name, each vector field as
///   `NAME_x`, `NAME_y`, `NAME_z`, and the first scalar field also as `quality` (what MeshLab
///   shows as vertex quality);
/// - legacy VTK: `POINT_DATA` with `SCALARS` and `VECTORS` sections of those names (ParaView);
/// - VTP: `PointData` arrays of those names (`NumberOfComponents` 1 or 3).
///
/// OBJ, OFF and STL cannot hold fields ([`WriteError::Unsupported`]); names must be unique
/// and non-empty.
pub fn write_mesh_fields(
    path: &Path,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    fields: &[Field],
) -> Result<(), IoError> {
    let format = Format::from_path(path).ok_or_else(|| IoError::UnknownFormat { path: path.into() })?;
    let payload = Payload::new(&VertexAttributes::default(), fields);
    write_payload(path, format, positions, faces, &payload, &WriteOptions::default())
}

fn write_payload(
    path: &Path,
    format: Format,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    payload: &Payload,
    options: &WriteOptions,
) -> Result<(), IoError> {
    validate(format, positions, faces, payload).map_err(|error| IoError::Encode {
        path: path.into(),
        error,
    })?;
    write_atomically(path, |w| encode_to(w, format, positions, faces, payload, options))
}

/// Writes a mesh (positions #V x 3, faces #F x 3) in the format named by `path`'s extension,
/// atomically (see [`write_atomically`]). PLY is binary little endian; text formats print
/// shortest round-trip decimals, so reading the file back gives the same `f64`s (STL stores
/// `f32`).
pub fn write_mesh(
    path: &Path,
    shape_positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    attrs: &VertexAttributes,
) -> Result<(), IoError> {
    let format = Format::from_path(path).ok_or_else(|| IoError::UnknownFormat { path: path.into() })?;
    write_mesh_with(
        path,
        format,
        shape_positions,
        faces,
        attrs,
        &WriteOptions::default(),
    )
}

/// [`write_mesh`] with an explicit format and options.
pub fn write_mesh_with(
    path: &Path,
    format: Format,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    attrs: &VertexAttributes,
    options: &WriteOptions,
) -> Result<(), IoError> {
    write_payload(path, format, positions, faces, &Payload::new(attrs, &[]), options)
}

/// Writes a file so that it is either complete or absent: `write` fills a temporary file in
/// the same folder (`.NAME.PID-N.tmp`), which is flushed, synced and renamed over `path`.
/// On any error the temporary is removed and `path` is untouched.
pub fn write_atomically<F>(path: &Path, write: F) -> Result<(), IoError>
where
    F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
{
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let err = |error| IoError::Write {
        path: path.into(),
        error,
    };
    let name = path.file_name().ok_or_else(|| {
        err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "the path has no file name",
        ))
    })?;
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}-{n}.tmp", std::process::id()));
    let tmp = path.with_file_name(tmp_name);
    let result = (|| {
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        let mut w = std::io::BufWriter::with_capacity(1 << 16, file);
        write(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(e));
    }
    Ok(())
}

/// Collects polygons as triangles, fan-triangulating larger ones and remembering enough to
/// write one warning about it.
#[derive(Default)]
pub(crate) struct FaceBuilder {
    pub(crate) faces: Vec<[u32; 3]>,
    n_polygons: usize,
    n_fanned: usize,
    first_fanned: Option<(usize, Option<usize>)>,
    /// Polygons with more than 3 corners: (face, line, first triangle in `faces`, corners),
    /// fanned at `push` and re-triangulated at `finish` when not convex.
    polygons: Vec<(usize, Option<usize>, usize, Vec<u32>)>,
}
impl FaceBuilder {
    /// A builder expecting about `cap` triangles.
    pub(crate) fn with_capacity(cap: usize) -> Self {
        FaceBuilder {
            faces: Vec::with_capacity(cap),
            ..Default::default()
        }
    }

    /// Number of polygons pushed so far (the next polygon's face number).
    pub(crate) fn n_polygons(&self) -> usize {
        self.n_polygons
    }

    /// Adds one polygon (indices already range-checked). Errors if it has fewer than 3 corners.
    pub(crate) fn push(&mut self, poly: &[u32], line: Option<usize>) -> Result<(), ParseError> {
        let face = self.n_polygons;
        if poly.len() < 3 {
            return Err(ParseError::BadFace {
                face,
                count: poly.len() as u64,
                line,
            });
        }
        if poly.len() > 3 {
            self.n_fanned += 1;
            self.first_fanned.get_or_insert((face, line));
            self.polygons.push((face, line, self.faces.len(), poly.to_vec()));
        }
        for k in 1..poly.len() - 1 {
            self.faces.push([poly[0], poly[k], poly[k + 1]]);
        }
        self.n_polygons += 1;
        Ok(())
    }

    /// The faces and the triangulation warning, if any polygon had more than 3 corners:
    /// convex polygons (on `positions`, #V x 3) are fans from their first corner, non-convex
    /// ones are triangulated by ear clipping; a polygon that can be neither (self-intersecting,
    /// or its corners on one line) is an error.
    pub(crate) fn finish(
        mut self,
        positions: &[[f64; 3]],
        warnings: &mut Vec<String>,
    ) -> Result<Vec<[u32; 3]>, ParseError> {
        let mut n_clipped = 0;
        for (face, line, start, poly) in &self.polygons {
            let tris = polygon::triangulate(poly, positions).ok_or(ParseError::Polygon {
                face: *face,
                corners: poly.len(),
                line: *line,
            })?;
            let fan = &mut self.faces[*start..*start + tris.len()];
            if fan != tris.as_slice() {
                n_clipped += 1;
                fan.copy_from_slice(&tris);
            }
        }
        if let Some((face, line)) = self.first_fanned {
            let clipped = if n_clipped > 0 {
                format!("; {n_clipped} non-convex one(s) by ear clipping instead of a fan")
            } else {
                String::new()
            };
            warnings.push(format!(
                "fan-triangulated {} polygon(s) with more than 3 vertices into triangles \
                 ({} triangles from {} faces in all; first polygon: face {face}{}){clipped}",
                self.n_fanned,
                self.faces.len(),
                self.n_polygons,
                at_line(&line)
            ));
        }
        Ok(self.faces)
    }
}

/// Checks one coordinate triple, reporting the first non-finite value.
/// Vertex `vertex`'s x, y and z from the next three tokens of its line `line` (the OBJ `v` and
/// OFF vertex lines), finite ([`check_finite`]), and whether more tokens follow (a colour, a
/// weight: ignored, counted by the caller).
pub(crate) fn read_vertex<'a>(
    toks: &mut impl Iterator<Item = &'a [u8]>,
    vertex: usize,
    line: usize,
) -> Result<([f64; 3], bool), ParseError> {
    let mut p = [0.0; 3];
    for (c, axis) in p.iter_mut().zip(["x", "y", "z"]) {
        let tok = toks.next().ok_or(ParseError::Syntax {
            line,
            problem: SyntaxError::NoCoordinate { vertex, axis },
        })?;
        *c = text::parse_f64(tok).ok_or_else(|| ParseError::Syntax {
            line,
            problem: SyntaxError::Coordinate {
                vertex,
                axis,
                found: text::clip(tok),
            },
        })?;
    }
    Ok((check_finite(vertex, p, Some(line))?, toks.next().is_some()))
}

pub(crate) fn check_finite(vertex: usize, p: [f64; 3], line: Option<usize>) -> Result<[f64; 3], ParseError> {
    match p.iter().find(|c| !c.is_finite()) {
        Some(&value) => Err(ParseError::NonFinite { vertex, value, line }),
        None => Ok(p),
    }
}

/// Converts a 0-based index to `u32` if it is within `0..n_vertices`.
pub(crate) fn check_index(
    face: usize,
    index: i64,
    n_vertices: usize,
    line: Option<usize>,
) -> Result<u32, ParseError> {
    if index >= 0 && (index as u64) < n_vertices as u64 && index <= u32::MAX as i64 {
        Ok(index as u32)
    } else {
        Err(ParseError::IndexOutOfRange {
            face,
            index,
            n_vertices,
            line,
        })
    }
}
