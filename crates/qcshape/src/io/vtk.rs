//! Legacy VTK (`.vtk`) POLYDATA and UNSTRUCTURED_GRID, ASCII or BINARY (big endian, as the
//! format requires).
//!
//! POLYDATA: reads `POINTS` and `POLYGONS` (and `TRIANGLE_STRIPS`, converted to triangles);
//! `VERTICES` and `LINES` are skipped. UNSTRUCTURED_GRID (what meshio writes): reads `POINTS`,
//! `CELLS` and `CELL_TYPES`; triangle (5), polygon (7), quad (9) and triangle-strip (6) cells
//! become faces, every other cell type is skipped with a warning. Cells may use the classic
//! layout (`POLYGONS n size` followed by `k i1 .. ik` records) or the VTK 5.1 layout
//! (`OFFSETS` and `CONNECTIVITY` arrays). `POINT_DATA` is read into named arrays: `SCALARS`
//! (with or without `LOOKUP_TABLE`), `VECTORS`, `NORMALS`, `TEXTURE_COORDINATES`, `TENSORS`,
//! `COLOR_SCALARS` and `FIELD` arrays (`CELL_DATA` is read the same way and dropped, in
//! either order). A `METADATA` block (what VTK writes after an array with information keys,
//! e.g. once it has computed the points' range, ending at an empty line) is skipped wherever
//! it comes, as are dataset-level `FIELD` data and any unknown section (up to the next line
//! that starts with a known keyword, with a warning).
//! Writes ASCII UNSTRUCTURED_GRID triangles (version 4.2 layout, readable by ParaView, pyvista
//! and meshio), with `POINT_DATA` `SCALARS`, `VECTORS` and `COLOR_SCALARS`.

use std::io::Write;

mod attributes;

use attributes::{read_attributes, read_field};

use super::number::{Names, Number as Num};
use super::syntax::SyntaxError;
use super::text::{self, Cursor, Float};
use super::{
    check_finite, check_index, CellsError, FaceBuilder, FieldValues, MeshData, ParseError, Payload,
    UnsupportedFeature,
};

struct Reader<'a> {
    c: Cursor<'a>,
    binary: bool,
    len: usize,
}

impl<'a> Reader<'a> {
    fn token(&mut self, expected: &dyn Fn() -> String) -> Result<&'a [u8], ParseError> {
        self.c
            .next_token()
            .ok_or_else(|| ParseError::UnexpectedEnd { expected: expected() })
    }

    fn count(&mut self, what: &str) -> Result<u64, ParseError> {
        let tok = self.token(&|| what.to_string())?;
        text::parse_count(tok).ok_or_else(|| ParseError::Syntax {
            line: self.c.line(),
            problem: SyntaxError::Value {
                what: what.to_string(),
                found: text::clip(tok),
            },
        })
    }

    fn num_type(&mut self, what: &str) -> Result<Num, ParseError> {
        let tok = self.token(&|| format!("the data type of {what}"))?;
        let line = self.c.line();
        Num::parse(Names::Vtk, tok).ok_or_else(|| ParseError::Syntax {
            line,
            problem: SyntaxError::DataType {
                what: what.to_string(),
                found: text::clip(tok),
            },
        })
    }

    /// Reads `n` numbers of type `ty` (tokens, or big-endian bytes starting on the next line).
    fn numbers(&mut self, n: u64, ty: Num, what: &str) -> Result<Vec<f64>, ParseError> {
        if self.binary {
            self.c.skip_line();
            let needed = n.saturating_mul(ty.size() as u64);
            if needed > self.c.remaining() as u64 {
                return Err(ParseError::Truncated {
                    what: format!("{n} values of {what}"),
                    needed,
                    offset: self.c.offset() as u64,
                    len: self.len as u64,
                });
            }
            let raw = self.c.take(needed as usize).unwrap_or_default();
            let out = raw.chunks_exact(ty.size()).map(|b| ty.read(b, true)).collect();
            self.skip_metadata();
            Ok(out)
        } else {
            // Each value takes at least one character and one separator.
            if n > (self.c.remaining() as u64).div_ceil(2) {
                return Err(ParseError::UnexpectedEnd {
                    expected: format!(
                        "{n} values of {what}, but only {} bytes remain",
                        self.c.remaining()
                    ),
                });
            }
            let mut out = Vec::with_capacity(n as usize);
            for k in 0..n {
                let tok = self.token(&|| format!("{n} values of {what}, found {k}"))?;
                out.push(text::parse_f64(tok).ok_or_else(|| ParseError::Syntax {
                    line: self.c.line(),
                    problem: SyntaxError::ArrayValue {
                        index: k,
                        what: what.to_string(),
                        found: text::clip(tok),
                    },
                })?);
            }
            self.skip_metadata();
            Ok(out)
        }
    }

    /// Skips a `METADATA` block if one comes next: VTK writes one after an array that carries
    /// information keys (a computed range, component names) and ends it with an empty line.
    fn skip_metadata(&mut self) {
        let mut peek = self.c.clone();
        if peek
            .next_token()
            .is_some_and(|t| t.eq_ignore_ascii_case(b"METADATA"))
        {
            self.c = peek;
            self.c.skip_line();
            while self.c.remaining() > 0 && !self.c.rest_of_line().trim_ascii().is_empty() {}
        }
    }

    /// Skips an unknown section: moves to the next line that starts with a keyword this reader
    /// knows (without consuming it), or to the end.
    fn skip_unknown(&mut self) {
        loop {
            self.c.skip_line();
            let mut peek = self.c.clone();
            match peek.next_token() {
                None => {
                    self.c = peek;
                    return;
                }
                Some(t) if is_known(t) => return,
                Some(_) => {}
            }
        }
    }

    fn line(&self) -> Option<usize> {
        (!self.binary).then(|| self.c.line())
    }
}

/// Dataset-level section keywords of POLYDATA and UNSTRUCTURED_GRID files.
const SECTIONS: &[&[u8]] = &[
    b"POINTS",
    b"CELLS",
    b"CELL_TYPES",
    b"POLYGONS",
    b"TRIANGLE_STRIPS",
    b"VERTICES",
    b"LINES",
    b"POINT_DATA",
    b"CELL_DATA",
    b"FIELD",
    b"METADATA",
];

/// Keywords inside `POINT_DATA` and `CELL_DATA`.
const ATTRIBUTES: &[&[u8]] = &[
    b"SCALARS",
    b"COLOR_SCALARS",
    b"LOOKUP_TABLE",
    b"VECTORS",
    b"NORMALS",
    b"TEXTURE_COORDINATES",
    b"TENSORS",
    b"FIELD",
    b"GLOBAL_IDS",
    b"PEDIGREE_IDS",
    b"EDGE_FLAGS",
    b"METADATA",
];

fn is_known(tok: &[u8]) -> bool {
    let up = tok.to_ascii_uppercase();
    SECTIONS.contains(&up.as_slice()) || ATTRIBUTES.contains(&up.as_slice())
}

/// Whether a token looks like a legacy VTK keyword (upper-case letters, digits, `_`), so that
/// an unknown one is a section to skip rather than garbage.
fn is_keyword_like(tok: &[u8]) -> bool {
    tok.first().is_some_and(u8::is_ascii_uppercase)
        && tok
            .iter()
            .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || *c == b'_')
}

fn as_int(v: f64) -> Option<i64> {
    (v.fract() == 0.0 && v.abs() < 9.2e18).then_some(v as i64)
}

/// Splits a cell section into cells (lists of point indices, as read).
fn read_cells(r: &mut Reader, keyword: &str) -> Result<Vec<Vec<i64>>, ParseError> {
    let n = r.count(&format!("the {keyword} cell count"))?;
    let size = r.count(&format!("the {keyword} size"))?;
    let section_line = (!r.binary).then_some(r.c.line());
    let bad = |problem: CellsError| ParseError::Cells {
        keyword: keyword.to_string(),
        line: section_line,
        problem,
    };
    // VTK 5.1 layout: OFFSETS and CONNECTIVITY arrays follow.
    let next = r.c.clone().next_token();
    if next.is_some_and(|t| t.eq_ignore_ascii_case(b"OFFSETS")) {
        r.c.next_token();
        let ty = r.num_type(&format!("the {keyword} offsets"))?;
        let offsets = r.numbers(n, ty, &format!("the {keyword} offsets"))?;
        let t = r.token(&|| format!("CONNECTIVITY for {keyword}"))?;
        if !t.eq_ignore_ascii_case(b"CONNECTIVITY") {
            return Err(bad(CellsError::ExpectedConnectivity { found: text::clip(t) }));
        }
        let ty = r.num_type(&format!("the {keyword} connectivity"))?;
        let conn = r.numbers(size, ty, &format!("the {keyword} connectivity"))?;
        let mut cells = Vec::with_capacity(offsets.len().saturating_sub(1));
        for (i, w) in offsets.windows(2).enumerate() {
            let (a, b) = (as_int(w[0]), as_int(w[1]));
            let (Some(a), Some(b)) = (a, b) else {
                return Err(bad(CellsError::OffsetNotInteger { offset: i }));
            };
            if a < 0 || b < a || b as u64 > conn.len() as u64 {
                return Err(bad(CellsError::OffsetsOutOfRange {
                    offset: i,
                    start: a,
                    end: b,
                    len: conn.len(),
                }));
            }
            cells.push(
                conn[a as usize..b as usize]
                    .iter()
                    .map(|&v| as_int(v).unwrap_or(-1))
                    .collect(),
            );
        }
        return Ok(cells);
    }
    let flat = r.numbers(size, Num::I32, &format!("the {keyword} cells"))?;
    let mut cells = Vec::with_capacity(text::capacity(n, flat.len(), 1));
    let mut pos = 0usize;
    for i in 0..n {
        let k = flat
            .get(pos)
            .copied()
            .and_then(as_int)
            .filter(|&k| k >= 0)
            .ok_or_else(|| {
                bad(CellsError::NoVertexCount {
                    cell: i,
                    cells: n,
                    size,
                })
            })?;
        pos += 1;
        if k as u64 > (flat.len() - pos) as u64 {
            return Err(bad(CellsError::TooFewValues {
                cell: i,
                count: k,
                remaining: flat.len() - pos,
                size,
            }));
        }
        cells.push(
            flat[pos..pos + k as usize]
                .iter()
                .map(|&v| as_int(v).unwrap_or(-1))
                .collect(),
        );
        pos += k as usize;
    }
    if pos != flat.len() {
        return Err(bad(CellsError::SizeMismatch {
            size,
            cells: n,
            used: pos,
        }));
    }
    Ok(cells)
}

pub(crate) fn parse(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let mut c = Cursor::new(bytes, 1);
    let first = c.rest_of_line();
    let first_l = first.to_ascii_lowercase();
    if !(first_l.starts_with(b"# vtk datafile") || first_l.starts_with(b"#vtk datafile")) {
        return Err(ParseError::Syntax {
            line: 1,
            problem: SyntaxError::NotVtk,
        });
    }
    let _title = c.rest_of_line();
    let mut r = Reader {
        c,
        binary: false,
        len: bytes.len(),
    };
    let enc = r.token(&|| "ASCII or BINARY on line 3".into())?;
    r.binary = if enc.eq_ignore_ascii_case(b"ASCII") {
        false
    } else if enc.eq_ignore_ascii_case(b"BINARY") {
        true
    } else {
        return Err(ParseError::Syntax {
            line: r.c.line(),
            problem: SyntaxError::Expected {
                expected: "ASCII or BINARY",
                found: text::clip(enc),
            },
        });
    };
    let kw = r.token(&|| "DATASET POLYDATA".into())?;
    let ds = r.token(&|| "the dataset type".into())?;
    if !kw.eq_ignore_ascii_case(b"DATASET") {
        return Err(ParseError::Syntax {
            line: r.c.line(),
            problem: SyntaxError::Expected {
                expected: "DATASET POLYDATA",
                found: text::clip(kw),
            },
        });
    }
    let grid = ds.eq_ignore_ascii_case(b"UNSTRUCTURED_GRID");
    if !(grid || ds.eq_ignore_ascii_case(b"POLYDATA")) {
        return Err(ParseError::Unsupported(UnsupportedFeature::VtkDataset(
            text::clip(ds),
        )));
    }
    let mut grid_cells: Option<(Vec<Vec<i64>>, usize)> = None;
    let mut cell_types: Option<Vec<f64>> = None;
    let mut point_data = Vec::new();

    let mut positions: Option<Vec<[f64; 3]>> = None;
    let mut faces = FaceBuilder::default();
    let mut warnings = Vec::new();
    let mut skipped = 0usize;
    let mut strips = 0usize;
    while let Some(tok) = r.c.next_token() {
        let line = r.c.line();
        let kw = tok.to_ascii_uppercase();
        match kw.as_slice() {
            b"POINTS" => {
                if positions.is_some() {
                    return Err(ParseError::Syntax {
                        line,
                        problem: SyntaxError::Repeated { section: "POINTS" },
                    });
                }
                let n = r.count("the POINTS count")?;
                if n > u32::MAX as u64 {
                    return Err(ParseError::Syntax {
                        line,
                        problem: SyntaxError::TooManyPoints { count: n },
                    });
                }
                let ty = r.num_type("POINTS")?;
                let vals = r.numbers(n.saturating_mul(3), ty, "POINTS")?;
                let mut pos = Vec::with_capacity(n as usize);
                for (vertex, p) in vals.chunks_exact(3).enumerate() {
                    pos.push(check_finite(vertex, [p[0], p[1], p[2]], None)?);
                }
                positions = Some(pos);
            }
            b"CELLS" if grid => {
                if grid_cells.is_some() {
                    return Err(ParseError::Syntax {
                        line,
                        problem: SyntaxError::Repeated { section: "CELLS" },
                    });
                }
                grid_cells = Some((read_cells(&mut r, "CELLS")?, line));
            }
            b"CELL_TYPES" if grid => {
                let n = r.count("the CELL_TYPES count")?;
                cell_types = Some(r.numbers(n, Num::I32, "CELL_TYPES")?);
            }
            b"POLYGONS" | b"TRIANGLE_STRIPS" | b"VERTICES" | b"LINES" if !grid => {
                let keyword = String::from_utf8_lossy(&kw).into_owned();
                let cells = read_cells(&mut r, &keyword)?;
                if matches!(kw.as_slice(), b"VERTICES" | b"LINES") {
                    skipped += cells.len();
                    continue;
                }
                let Some(pos) = &positions else {
                    return Err(ParseError::Syntax {
                        line,
                        problem: SyntaxError::BeforePoints { keyword },
                    });
                };
                let n = pos.len();
                let cell_line = r.line().map(|_| line);
                for cell in cells {
                    let face = faces.n_polygons();
                    let idx = cell
                        .iter()
                        .map(|&i| check_index(face, i, n, cell_line))
                        .collect::<Result<Vec<u32>, _>>()?;
                    if kw.as_slice() == b"POLYGONS" {
                        faces.push(&idx, cell_line)?;
                    } else {
                        strips += 1;
                        push_strip(&mut faces, &idx, cell_line)?;
                    }
                }
            }
            b"POINT_DATA" => {
                let n_points = positions.as_ref().map_or(0, |p| p.len());
                let n = r.count("the POINT_DATA count")?;
                if n != n_points as u64 {
                    return Err(ParseError::Syntax {
                        line,
                        problem: SyntaxError::PointData {
                            count: n,
                            points: n_points,
                        },
                    });
                }
                read_attributes(&mut r, n, Some(&mut point_data), &mut warnings)?;
            }
            b"CELL_DATA" => {
                // Read to stay in step with the file, then dropped: qcshape has no use for
                // per-cell values (and triangulation would change the cells).
                let n = r.count("the CELL_DATA count")?;
                read_attributes(&mut r, n, None, &mut warnings)?;
            }
            b"FIELD" => {
                // Dataset-level field data (e.g. TIME): arrays of any length, dropped.
                read_field(&mut r, None)?;
            }
            b"METADATA" => {
                r.c.skip_line();
                while r.c.remaining() > 0 && !r.c.rest_of_line().trim_ascii().is_empty() {}
            }
            _ if is_keyword_like(tok) => {
                warnings.push(format!(
                    "skipped the unknown section {} (line {line})",
                    text::show(tok)
                ));
                r.skip_unknown();
            }
            _ => {
                return Err(ParseError::Syntax {
                    line,
                    problem: SyntaxError::Keyword {
                        found: text::clip(tok),
                    },
                })
            }
        }
    }
    let positions = positions.ok_or_else(|| ParseError::Missing {
        what: "POINTS section".into(),
    })?;
    if grid {
        grid_faces(&positions, grid_cells, cell_types, &mut faces, &mut warnings)?;
    }
    if skipped > 0 {
        warnings.push(format!("ignored {skipped} VERTICES/LINES cell(s)"));
    }
    if strips > 0 {
        warnings.push(format!("converted {strips} triangle strip(s) to triangles"));
    }
    let faces = faces.finish(&positions, &mut warnings)?;
    Ok(MeshData {
        positions,
        faces,
        warnings,
        point_data,
    })
}

/// VTK cell type numbers that are surface cells.
const VTK_TRIANGLE: i64 = 5;
const VTK_TRIANGLE_STRIP: i64 = 6;
const VTK_POLYGON: i64 = 7;
const VTK_QUAD: i64 = 9;

/// The faces of an UNSTRUCTURED_GRID: its surface cells (triangles, strips, polygons, quads);
/// other cells are counted in a warning.
fn grid_faces(
    positions: &[[f64; 3]],
    cells: Option<(Vec<Vec<i64>>, usize)>,
    types: Option<Vec<f64>>,
    faces: &mut FaceBuilder,
    warnings: &mut Vec<String>,
) -> Result<(), ParseError> {
    let Some((cells, line)) = cells else {
        return Err(ParseError::Missing {
            what: "CELLS section for its UNSTRUCTURED_GRID".into(),
        });
    };
    let Some(types) = types else {
        return Err(ParseError::Missing {
            what: "CELL_TYPES section for the CELLS of its UNSTRUCTURED_GRID".into(),
        });
    };
    if types.len() != cells.len() {
        return Err(ParseError::CellTypeCount {
            types: types.len(),
            cells: cells.len(),
        });
    }
    let n = positions.len();
    let mut skipped = std::collections::BTreeMap::<i64, usize>::new();
    for (cell, ty) in cells.iter().zip(&types) {
        let ty = as_int(*ty).unwrap_or(-1);
        if !matches!(ty, VTK_TRIANGLE | VTK_TRIANGLE_STRIP | VTK_POLYGON | VTK_QUAD) {
            *skipped.entry(ty).or_default() += 1;
            continue;
        }
        let face = faces.n_polygons();
        let idx = cell
            .iter()
            .map(|&i| check_index(face, i, n, Some(line)))
            .collect::<Result<Vec<u32>, _>>()?;
        if ty == VTK_TRIANGLE_STRIP {
            push_strip(faces, &idx, Some(line))?;
        } else {
            faces.push(&idx, Some(line))?;
        }
    }
    if !skipped.is_empty() {
        let list: Vec<String> = skipped.iter().map(|(t, k)| format!("{k} of type {t}")).collect();
        warnings.push(format!(
            "ignored {} cell(s) that are not triangles, quads, polygons or strips ({})",
            skipped.values().sum::<usize>(),
            list.join(", ")
        ));
    }
    Ok(())
}

/// Adds the triangles of a strip (alternating orientation, as VTK defines it).
pub(super) fn push_strip(
    faces: &mut FaceBuilder,
    idx: &[u32],
    line: Option<usize>,
) -> Result<(), ParseError> {
    if idx.len() < 3 {
        return Err(ParseError::BadFace {
            face: faces.n_polygons(),
            count: idx.len() as u64,
            line,
        });
    }
    for k in 0..idx.len() - 2 {
        let t = if k % 2 == 0 {
            [idx[k], idx[k + 1], idx[k + 2]]
        } else {
            [idx[k + 1], idx[k], idx[k + 2]]
        };
        faces.push(&t, line)?;
    }
    Ok(())
}

/// A VTK array name: no whitespace.
fn sanitize(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| if c.is_ascii_graphic() { c } else { '_' })
        .collect();
    if s.is_empty() {
        "scalar".into()
    } else {
        s
    }
}

pub(crate) fn write(
    w: &mut dyn Write,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    payload: &Payload,
) -> std::io::Result<()> {
    // UNSTRUCTURED_GRID of triangles (VTK_TRIANGLE cells) rather than POLYDATA: ParaView and
    // pyvista read both, meshio only the former.
    writeln!(
        w,
        "# vtk DataFile Version 4.2\nwritten by qcshape\nASCII\nDATASET UNSTRUCTURED_GRID"
    )?;
    writeln!(w, "POINTS {} double", positions.len())?;
    for p in positions {
        writeln!(w, "{} {} {}", Float(p[0]), Float(p[1]), Float(p[2]))?;
    }
    writeln!(w, "CELLS {} {}", faces.len(), 4 * faces.len())?;
    for f in faces {
        writeln!(w, "3 {} {} {}", f[0], f[1], f[2])?;
    }
    writeln!(w, "CELL_TYPES {}", faces.len())?;
    for _ in faces {
        writeln!(w, "{VTK_TRIANGLE}")?;
    }
    if !payload.fields.is_empty() || payload.colors.is_some() {
        writeln!(w, "POINT_DATA {}", positions.len())?;
    }
    for f in &payload.fields {
        match f.values {
            FieldValues::Scalar(s) => {
                writeln!(w, "SCALARS {} double 1\nLOOKUP_TABLE default", sanitize(f.name))?;
                for &v in s {
                    writeln!(w, "{}", Float(v))?;
                }
            }
            FieldValues::Vector(x) => {
                writeln!(w, "VECTORS {} double", sanitize(f.name))?;
                for v in x {
                    writeln!(w, "{} {} {}", Float(v[0]), Float(v[1]), Float(v[2]))?;
                }
            }
        }
    }
    if let Some(c) = payload.colors {
        writeln!(w, "COLOR_SCALARS colors 3")?;
        for c in c {
            let [r, g, b] = c.map(|v| Float(v as f64 / 255.0));
            writeln!(w, "{r} {g} {b}")?;
        }
    }
    Ok(())
}
