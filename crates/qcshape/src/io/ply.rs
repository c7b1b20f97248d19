//! Stanford PLY: ASCII, binary little endian and binary big endian.
//!
//! Reads the `vertex` element's `x`, `y`, `z` (any scalar type) and the `face` element's
//! `vertex_indices` (or `vertex_index`) list (any count and index type). The vertex element's
//! other scalar properties become named point fields (`NAME_x`/`_y`/`_z` and `nx`/`ny`/`nz`
//! triples as vectors; `quality`, colours and the rest as scalars). Every other element and
//! property is skipped; polygons are triangulated (a fan, or ear clipping when not
//! convex). In ASCII files every element is one line, and the counts of the header are exact
//! (a line with more or fewer values, or data after the last element, is an error naming the
//! line and both numbers). Writes `double` coordinates, named `double` properties per vertex
//! (scalar fields under their name, vector fields as `NAME_x`, `NAME_y`, `NAME_z`; the first
//! scalar field also as `quality`, MeshLab's per-vertex quality) and optional `uchar`
//! `red`/`green`/`blue`.

use std::io::Write;

use super::number::{Names, Number as Scalar};
use super::syntax::SyntaxError;
use super::text::{self, Cursor, Float};
use super::{check_finite, check_index, FaceBuilder, MeshData, ParseError, Payload, PointArray};

/// How a PLY file stores its data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlyEncoding {
    /// Text, one element per line.
    Ascii,
    /// Little-endian binary (the usual choice; compact and exact).
    #[default]
    BinaryLittleEndian,
    /// Big-endian binary.
    BinaryBigEndian,
}

#[derive(Debug)]
enum Property {
    Scalar(Scalar),
    List(Scalar, Scalar),
}

#[derive(Debug)]
struct Element {
    name: Vec<u8>,
    count: u64,
    props: Vec<(Vec<u8>, Property)>,
}

impl Element {
    /// Fewest bytes one item can take in binary (lists may be empty).
    fn min_binary_size(&self) -> u64 {
        self.props
            .iter()
            .map(|(_, p)| match p {
                Property::Scalar(s) | Property::List(s, _) => s.size() as u64,
            })
            .sum()
    }
}

struct Header {
    encoding: PlyEncoding,
    elements: Vec<Element>,
    /// Byte offset where the data starts.
    data_start: usize,
    /// Line number of the first data line (for ASCII messages).
    data_line: usize,
    warnings: Vec<String>,
}

fn syntax(line: usize, problem: SyntaxError) -> ParseError {
    ParseError::Syntax { line, problem }
}

fn parse_header(bytes: &[u8]) -> Result<Header, ParseError> {
    let mut pos = 0;
    let mut line = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut warnings = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(ParseError::Missing {
                what: "end_header line in its PLY header (it is truncated, or not PLY)".into(),
            });
        }
        line += 1;
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |k| pos + k);
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        let mut toks = text::tokens(raw);
        let keyword = toks.next().unwrap_or_default();
        if line == 1 {
            if keyword != b"ply" {
                return Err(syntax(1, SyntaxError::NotPly));
            }
            continue;
        }
        match keyword {
            b"format" => {
                let f = toks.next().unwrap_or_default();
                encoding = Some(match f {
                    b"ascii" => PlyEncoding::Ascii,
                    b"binary_little_endian" => PlyEncoding::BinaryLittleEndian,
                    b"binary_big_endian" => PlyEncoding::BinaryBigEndian,
                    _ => {
                        return Err(syntax(
                            line,
                            SyntaxError::Unknown {
                                what: "PLY format",
                                found: text::clip(f),
                            },
                        ))
                    }
                });
            }
            b"element" => {
                let (Some(name), Some(count_tok)) = (toks.next(), toks.next()) else {
                    return Err(syntax(line, SyntaxError::ElementLine));
                };
                let count = text::parse_count(count_tok).ok_or_else(|| {
                    syntax(
                        line,
                        SyntaxError::Count {
                            what: "element",
                            found: text::clip(count_tok),
                        },
                    )
                })?;
                elements.push(Element {
                    name: name.to_vec(),
                    count,
                    props: Vec::new(),
                });
            }
            b"property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(syntax(line, SyntaxError::PropertyBeforeElement));
                };
                let ty = toks.next().unwrap_or_default();
                let scalar = |t: &[u8]| {
                    Scalar::parse(Names::Ply, t).ok_or_else(|| {
                        syntax(
                            line,
                            SyntaxError::Unknown {
                                what: "property type",
                                found: text::clip(t),
                            },
                        )
                    })
                };
                let prop = if ty == b"list" {
                    let c = scalar(toks.next().unwrap_or_default())?;
                    if c.is_float() {
                        return Err(syntax(line, SyntaxError::ListCountType));
                    }
                    Property::List(c, scalar(toks.next().unwrap_or_default())?)
                } else {
                    Property::Scalar(scalar(ty)?)
                };
                let name = toks
                    .next()
                    .ok_or_else(|| syntax(line, SyntaxError::PropertyName))?;
                el.props.push((name.to_vec(), prop));
            }
            b"end_header" => break,
            b"comment" | b"obj_info" | b"" => {}
            other => warnings.push(format!(
                "ignored unknown PLY header line {line} starting with {}",
                text::show(other)
            )),
        }
    }
    let encoding = encoding.ok_or_else(|| ParseError::Missing {
        what: "format line in its PLY header".into(),
    })?;
    Ok(Header {
        encoding,
        elements,
        data_start: pos,
        data_line: line + 1,
        warnings,
    })
}

/// Reads scalars from the data section, in either encoding.
enum Source<'a> {
    Ascii(Cursor<'a>),
    Binary { bytes: &'a [u8], pos: usize, big: bool },
}

impl Source<'_> {
    /// The next scalar of type `ty`; `what` describes it for error messages.
    fn scalar(&mut self, ty: Scalar, what: &dyn Fn() -> String) -> Result<f64, ParseError> {
        match self {
            Source::Ascii(c) => {
                let tok = c
                    .next_token()
                    .ok_or_else(|| ParseError::UnexpectedEnd { expected: what() })?;
                text::parse_f64(tok).ok_or_else(|| {
                    syntax(
                        c.line(),
                        SyntaxError::Value {
                            what: what(),
                            found: text::clip(tok),
                        },
                    )
                })
            }
            Source::Binary { bytes, pos, big } => {
                let n = ty.size();
                if bytes.len() - *pos < n {
                    return Err(ParseError::Truncated {
                        what: what(),
                        needed: n as u64,
                        offset: *pos as u64,
                        len: bytes.len() as u64,
                    });
                }
                let v = ty.read(&bytes[*pos..*pos + n], *big);
                *pos += n;
                Ok(v)
            }
        }
    }

    /// Checks that `count` items of `size` bytes each fit in the rest of a binary file.
    fn ensure(&self, count: u64, size: u64, what: &dyn Fn() -> String) -> Result<(), ParseError> {
        if let Source::Binary { bytes, pos, .. } = self {
            let needed = count.saturating_mul(size);
            if needed > (bytes.len() - pos) as u64 {
                return Err(ParseError::Truncated {
                    what: what(),
                    needed,
                    offset: *pos as u64,
                    len: bytes.len() as u64,
                });
            }
        }
        Ok(())
    }

    /// Skips `n` scalars of type `ty` (after [`Source::ensure`] for binary).
    fn skip(&mut self, ty: Scalar, n: u64, what: &dyn Fn() -> String) -> Result<(), ParseError> {
        self.ensure(n, ty.size() as u64, what)?;
        match self {
            Source::Ascii(_) => {
                for _ in 0..n {
                    self.scalar(ty, what)?;
                }
            }
            Source::Binary { pos, .. } => *pos += n as usize * ty.size(),
        }
        Ok(())
    }

    fn line(&self) -> Option<usize> {
        match self {
            Source::Ascii(c) => Some(c.line()),
            Source::Binary { .. } => None,
        }
    }

    /// For ASCII: checks that element `item` (read from `first_line` on) sat on one line with
    /// nothing after it, naming both the declared and the found numbers otherwise.
    fn end_item(
        &mut self,
        name: &str,
        item: usize,
        count: u64,
        first_line: Option<usize>,
        n_values: usize,
    ) -> Result<(), ParseError> {
        let Source::Ascii(c) = self else {
            return Ok(());
        };
        let Some(first) = first_line else {
            return Ok(());
        };
        if c.line() != first {
            return Err(syntax(
                first,
                SyntaxError::ElementContinues {
                    element: name.to_string(),
                    item,
                    count,
                    next_line: c.line(),
                },
            ));
        }
        let rest = c.rest_of_line();
        let extra = text::tokens(rest).count();
        if extra > 0 {
            return Err(syntax(
                first,
                SyntaxError::ElementValues {
                    element: name.to_string(),
                    item,
                    count,
                    values: n_values + extra,
                    needed: n_values,
                },
            ));
        }
        Ok(())
    }

    /// For ASCII: a face whose list count `n` disagrees with the values left on its line is most
    /// often a vertex line read as a face, because the file holds more elements of the previous
    /// kind than the header declares. Names both numbers and the line; `None` when the line
    /// holds exactly `n` more values (then the face itself is short).
    fn misread_face_hint(
        &self,
        item: usize,
        count: u64,
        n: u64,
        elements: &[Element],
        ei: usize,
    ) -> Option<ParseError> {
        let Source::Ascii(c) = self else {
            return None;
        };
        let line = c.line();
        let mut peek = c.clone();
        let rest = peek.rest_of_line();
        let left = text::tokens(rest).count() as u64;
        if left == n {
            return None;
        }
        let previous = elements[..ei]
            .iter()
            .rev()
            .find(|e| e.count > 0)
            .map(|e| (String::from_utf8_lossy(&e.name).into_owned(), e.count));
        Some(syntax(
            line,
            SyntaxError::FaceValues {
                item,
                count,
                size: n,
                values: left + 1,
                previous,
            },
        ))
    }

    fn has_trailing_data(&mut self) -> bool {
        match self {
            Source::Ascii(c) => c.next_token().is_some(),
            Source::Binary { bytes, pos, .. } => *pos < bytes.len(),
        }
    }
}

/// Converts a list length read as `f64` to a count.
fn list_len(v: f64, what: &dyn Fn() -> String, line: Option<usize>) -> Result<u64, ParseError> {
    if v >= 0.0 && v.fract() == 0.0 && v < 1.8e19 {
        Ok(v as u64)
    } else {
        Err(ParseError::BadListLength {
            what: what(),
            value: v,
            line,
        })
    }
}

pub(crate) fn parse(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let header = parse_header(bytes)?;
    let mut warnings = header.warnings;
    let data = &bytes[header.data_start..];
    let mut src = match header.encoding {
        PlyEncoding::Ascii => Source::Ascii(Cursor::new(data, header.data_line)),
        enc => Source::Binary {
            bytes,
            pos: header.data_start,
            big: enc == PlyEncoding::BinaryBigEndian,
        },
    };

    let vertex_el = header
        .elements
        .iter()
        .position(|e| e.name == b"vertex")
        .ok_or_else(|| ParseError::Missing {
            what: "vertex element in its PLY header".into(),
        })?;
    let mut xyz = [usize::MAX; 3];
    for (slot, axis) in xyz.iter_mut().zip(["x", "y", "z"]) {
        let props = &header.elements[vertex_el].props;
        *slot = props
            .iter()
            .position(|(n, _)| n == axis.as_bytes())
            .ok_or_else(|| ParseError::Missing {
                what: format!("{axis} property in its PLY vertex element"),
            })?;
        if matches!(props[*slot].1, Property::List(..)) {
            return Err(ParseError::ListCoordinate { axis });
        }
    }
    let n_vertices = header.elements[vertex_el].count;
    if n_vertices > u32::MAX as u64 {
        return Err(ParseError::TooManyVertices { count: n_vertices });
    }
    let n_vertices = n_vertices as usize;
    let (extra, slots) = vertex_fields(&header.elements[vertex_el].props, &xyz);
    let mut field_values: Vec<Vec<f64>> = vec![Vec::new(); extra.len()];

    let face_el = header.elements.iter().position(|e| e.name == b"face");
    let mut face_list = usize::MAX;
    if let Some(fe) = face_el {
        let props = &header.elements[fe].props;
        let lists: Vec<usize> = (0..props.len())
            .filter(|&k| matches!(props[k].1, Property::List(..)))
            .collect();
        face_list = props
            .iter()
            .position(|(n, p)| {
                (n == b"vertex_indices" || n == b"vertex_index") && matches!(p, Property::List(..))
            })
            .or(if lists.len() == 1 { Some(lists[0]) } else { None })
            .ok_or_else(|| ParseError::Missing {
                what: "vertex_indices list property in its PLY face element".into(),
            })?;
    }

    let per_byte = if header.encoding == PlyEncoding::Ascii {
        2
    } else {
        8
    };
    let mut positions = Vec::new();
    let mut faces = FaceBuilder::default();
    let mut poly: Vec<u32> = Vec::new();
    for (ei, el) in header.elements.iter().enumerate() {
        if el.props.is_empty() || el.count == 0 {
            continue;
        }
        let name = String::from_utf8_lossy(&el.name).into_owned();
        let count = el.count;
        src.ensure(count, el.min_binary_size(), &|| {
            format!("{count} {name} elements")
        })?;
        if ei == vertex_el {
            positions.reserve(text::capacity(count, data.len(), 3 * per_byte));
        } else if Some(ei) == face_el {
            faces = FaceBuilder::with_capacity(text::capacity(count, data.len(), 4 * per_byte));
        }
        for item in 0..count as usize {
            let mut p = [0.0; 3];
            let mut first_line = None;
            let mut n_values: usize = 0;
            for (pi, (pname, prop)) in el.props.iter().enumerate() {
                let what = || {
                    format!(
                        "property {} of {name} {item} (of {count})",
                        String::from_utf8_lossy(pname)
                    )
                };
                match *prop {
                    Property::Scalar(ty) => {
                        let v = src.scalar(ty, &what)?;
                        first_line = first_line.or(src.line());
                        n_values += 1;
                        if ei == vertex_el {
                            if let Some(axis) = xyz.iter().position(|&k| k == pi) {
                                p[axis] = v;
                            } else if let Some((f, _)) = slots[pi] {
                                field_values[f].push(v);
                            }
                        }
                    }
                    Property::List(cty, ity) => {
                        let len_what = || format!("the length of {}", what());
                        let n = list_len(src.scalar(cty, &len_what)?, &len_what, src.line())?;
                        first_line = first_line.or(src.line());
                        n_values = n_values.saturating_add(1).saturating_add(n as usize);
                        if Some(ei) == face_el && pi == face_list {
                            src.ensure(n, ity.size() as u64, &what)?;
                            if n < 3 {
                                if let Some(err) = src.misread_face_hint(item, count, n, &header.elements, ei)
                                {
                                    return Err(err);
                                }
                                return Err(ParseError::BadFace {
                                    face: item,
                                    count: n,
                                    line: src.line(),
                                });
                            }
                            poly.clear();
                            for _ in 0..n {
                                let v = src.scalar(ity, &what)?;
                                if v.fract() != 0.0 || !v.is_finite() {
                                    return Err(ParseError::NonIntegerIndex {
                                        face: item,
                                        value: v,
                                        line: src.line(),
                                    });
                                }
                                poly.push(check_index(item, v as i64, n_vertices, src.line())?);
                            }
                            faces.push(&poly, src.line())?;
                        } else {
                            src.skip(ity, n, &what)?;
                        }
                    }
                }
            }
            src.end_item(&name, item, count, first_line, n_values)?;
            if ei == vertex_el {
                positions.push(check_finite(item, p, src.line())?);
            }
        }
    }
    if src.has_trailing_data() {
        let declared = header
            .elements
            .iter()
            .map(|e| (e.count, String::from_utf8_lossy(&e.name).into_owned()))
            .collect();
        return Err(ParseError::TrailingData {
            declared,
            line: src.line(),
        });
    }
    let faces = faces.finish(&positions, &mut warnings)?;
    // Values were pushed in property order within each vertex; vector fields interleave.
    let point_data = extra
        .into_iter()
        .zip(field_values)
        .map(|((name, components), values)| PointArray {
            name,
            components,
            values,
        })
        .collect();
    Ok(MeshData {
        positions,
        faces,
        warnings,
        point_data,
    })
}

/// The per-vertex fields of the vertex element's other scalar properties (not `x`, `y`, `z`,
/// not lists): `NAME_x`, `NAME_y`, `NAME_z` in a row become one vector field `NAME` (how
/// qcshape writes vectors), `nx`, `ny`, `nz` in a row the vector field `normals`, every other
/// property a scalar field of its name. Returns the fields (name, components) and, for each
/// property, its (field, component) slot.
#[allow(clippy::type_complexity)]
fn vertex_fields(
    props: &[(Vec<u8>, Property)],
    xyz: &[usize; 3],
) -> (Vec<(String, usize)>, Vec<Option<(usize, usize)>>) {
    let mut fields = Vec::new();
    let mut slots = vec![None; props.len()];
    let scalar = |k: usize| !xyz.contains(&k) && matches!(props.get(k), Some((_, Property::Scalar(_))));
    let name = |k: usize| String::from_utf8_lossy(&props[k].0).into_owned();
    let mut k = 0;
    while k < props.len() {
        if !scalar(k) {
            k += 1;
            continue;
        }
        let n0 = name(k);
        let triple = (k + 2 < props.len() && scalar(k + 1) && scalar(k + 2))
            .then(|| [n0.clone(), name(k + 1), name(k + 2)]);
        let vector = triple.and_then(|[a, b, c]| {
            if [&a, &b, &c] == ["nx", "ny", "nz"] {
                return Some("normals".to_string());
            }
            let base = a.strip_suffix("_x")?;
            (!base.is_empty() && b.strip_suffix("_y") == Some(base) && c.strip_suffix("_z") == Some(base))
                .then(|| base.to_string())
        });
        let f = fields.len();
        match vector {
            Some(base) => {
                fields.push((base, 3));
                for c in 0..3 {
                    slots[k + c] = Some((f, c));
                }
                k += 3;
            }
            None => {
                fields.push((n0, 1));
                slots[k] = Some((f, 0));
                k += 1;
            }
        }
    }
    (fields, slots)
}

/// A property name: ASCII letters, digits and `_` only (PLY names cannot hold spaces).
fn sanitize(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || matches!(s.as_str(), "x" | "y" | "z" | "red" | "green" | "blue") {
        format!("scalar_{s}")
    } else {
        s
    }
}

/// The vertex properties written for `payload`'s fields: (name, field index, component).
fn properties(payload: &Payload) -> Vec<(String, usize, usize)> {
    let mut props: Vec<(String, usize, usize)> = Vec::new();
    for (k, f) in payload.fields.iter().enumerate() {
        let name = sanitize(f.name);
        if f.components() == 1 {
            props.push((name, k, 0));
        } else {
            for (c, axis) in ["x", "y", "z"].iter().enumerate() {
                props.push((format!("{name}_{axis}"), k, c));
            }
        }
    }
    if let Some(k) = payload.fields.iter().position(|f| f.components() == 1) {
        if !props.iter().any(|(n, _, _)| n == "quality") {
            props.insert(0, ("quality".into(), k, 0));
        }
    }
    // Names made equal by sanitizing get a numeric suffix (PLY needs unique property names).
    for i in 1..props.len() {
        let mut n = 1;
        while props[..i].iter().any(|(p, _, _)| *p == props[i].0) {
            props[i].0 = format!("{}_{n}", props[i].0);
            n += 1;
        }
    }
    props
}

pub(crate) fn write(
    w: &mut dyn Write,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    payload: &Payload,
    encoding: PlyEncoding,
) -> std::io::Result<()> {
    let big_index = positions.len() > i32::MAX as usize;
    let format = match encoding {
        PlyEncoding::Ascii => "ascii",
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
        PlyEncoding::BinaryBigEndian => "binary_big_endian",
    };
    let props = properties(payload);
    let colors = payload.colors;
    writeln!(w, "ply\nformat {format} 1.0\ncomment written by qcshape")?;
    writeln!(w, "element vertex {}", positions.len())?;
    writeln!(w, "property double x\nproperty double y\nproperty double z")?;
    for (name, _, _) in &props {
        writeln!(w, "property double {name}")?;
    }
    if colors.is_some() {
        writeln!(w, "property uchar red\nproperty uchar green\nproperty uchar blue")?;
    }
    writeln!(w, "element face {}", faces.len())?;
    let ity = if big_index { "uint" } else { "int" };
    writeln!(w, "property list uchar {ity} vertex_indices\nend_header")?;
    let value = |i: usize, &(_, k, c): &(String, usize, usize)| payload.fields[k].get(i, c);
    match encoding {
        PlyEncoding::Ascii => {
            for (i, p) in positions.iter().enumerate() {
                write!(w, "{} {} {}", Float(p[0]), Float(p[1]), Float(p[2]))?;
                for prop in &props {
                    write!(w, " {}", Float(value(i, prop)))?;
                }
                if let Some(c) = colors {
                    write!(w, " {} {} {}", c[i][0], c[i][1], c[i][2])?;
                }
                writeln!(w)?;
            }
            for f in faces {
                writeln!(w, "3 {} {} {}", f[0], f[1], f[2])?;
            }
        }
        PlyEncoding::BinaryLittleEndian | PlyEncoding::BinaryBigEndian => {
            let big = encoding == PlyEncoding::BinaryBigEndian;
            let f64b = |x: f64| if big { x.to_be_bytes() } else { x.to_le_bytes() };
            let u32b = |x: u32| if big { x.to_be_bytes() } else { x.to_le_bytes() };
            for (i, p) in positions.iter().enumerate() {
                for &c in p {
                    w.write_all(&f64b(c))?;
                }
                for prop in &props {
                    w.write_all(&f64b(value(i, prop)))?;
                }
                if let Some(c) = colors {
                    w.write_all(&c[i])?;
                }
            }
            for f in faces {
                w.write_all(&[3])?;
                for &i in f {
                    w.write_all(&u32b(i))?;
                }
            }
        }
    }
    Ok(())
}
