//! VTK XML PolyData (`.vtp`), what ParaView, VTK and pyvista write.
//!
//! Reads one `Piece`: `Points`, `Polys` (and `Strips`, converted to triangles; `Verts` and
//! `Lines` are skipped) and the `PointData` arrays, each `DataArray` in `ascii`, `binary`
//! (inline base64) or `appended` format (`raw` or `base64` encoding), uncompressed or
//! compressed with `vtkZLibDataCompressor`, `header_type` `UInt32` or `UInt64`, either byte
//! order. Every declared size is checked against the bytes present before anything is
//! allocated, and every error names the line (markup) or byte offset (data).
//!
//! Writes inline base64 `binary` arrays without compression (`Float64` points and fields,
//! `Int64` connectivity, `UInt64` headers, little endian): exact, and read by VTK, ParaView,
//! pyvista and meshio.

use std::io::{Read, Write};

use super::{check_finite, check_index, FaceBuilder, Field, MeshData, ParseError, PointArray};

/// Line (1-based) of byte `pos`.
fn line_of(bytes: &[u8], pos: usize) -> usize {
    1 + bytes[..pos.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

fn syntax(bytes: &[u8], pos: usize, message: String) -> ParseError {
    ParseError::Syntax {
        line: line_of(bytes, pos),
        message,
    }
}

/// One start tag: its name, attributes, whether it is self-closing, and where it starts.
#[derive(Debug)]
struct Tag<'a> {
    name: &'a [u8],
    attrs: Vec<(&'a [u8], &'a [u8])>,
    empty: bool,
    pos: usize,
}

impl Tag<'_> {
    fn attr(&self, key: &str) -> Option<&[u8]> {
        self.attrs
            .iter()
            .find(|(k, _)| *k == key.as_bytes())
            .map(|(_, v)| *v)
    }
    fn attr_str(&self, key: &str) -> Option<String> {
        self.attr(key).map(|v| String::from_utf8_lossy(v).into_owned())
    }
}

/// Markup events.
enum Event<'a> {
    Start(Tag<'a>),
    End(&'a [u8]),
    Text(usize, usize),
}

/// One scanner step.
enum Step<'a> {
    Event(Event<'a>),
    Skip,
    End,
}

/// A minimal XML scanner: start/end tags with attributes, text runs; skips the declaration,
/// comments, processing instructions and CDATA-free doctype lines.
struct Scanner<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Scanner<'a> {
    fn next(&mut self) -> Result<Option<Event<'a>>, ParseError> {
        loop {
            match self.step()? {
                Step::Skip => continue,
                Step::Event(e) => return Ok(Some(e)),
                Step::End => return Ok(None),
            }
        }
    }

    fn step(&mut self) -> Result<Step<'a>, ParseError> {
        let b = self.b;
        if self.pos >= b.len() {
            return Ok(Step::End);
        }
        if b[self.pos] != b'<' {
            let start = self.pos;
            let end = b[start..]
                .iter()
                .position(|&c| c == b'<')
                .map_or(b.len(), |k| start + k);
            self.pos = end;
            return Ok(Step::Event(Event::Text(start, end)));
        }
        let start = self.pos;
        let find = |from: usize, pat: &[u8]| -> Option<usize> {
            b.get(from..)?
                .windows(pat.len())
                .position(|w| w == pat)
                .map(|k| from + k)
        };
        if b[start..].starts_with(b"<!--") {
            let end =
                find(start + 4, b"-->").ok_or_else(|| syntax(b, start, "a comment is not closed".into()))?;
            self.pos = end + 3;
            return Ok(Step::Skip);
        }
        if b[start..].starts_with(b"<?") || b[start..].starts_with(b"<!") {
            let end = find(start + 2, b">").ok_or_else(|| syntax(b, start, "a tag is not closed".into()))?;
            self.pos = end + 1;
            return Ok(Step::Skip);
        }
        let end = find(start + 1, b">").ok_or_else(|| syntax(b, start, "a tag is not closed".into()))?;
        self.pos = end + 1;
        let inner = &b[start + 1..end];
        if let Some(name) = inner.strip_prefix(b"/") {
            return Ok(Step::Event(Event::End(name.trim_ascii())));
        }
        let (inner, empty) = match inner.strip_suffix(b"/") {
            Some(i) => (i, true),
            None => (inner, false),
        };
        let name_end = inner
            .iter()
            .position(|c| c.is_ascii_whitespace())
            .unwrap_or(inner.len());
        let name = &inner[..name_end];
        if name.is_empty() {
            return Err(syntax(b, start, "a tag without a name".into()));
        }
        let mut attrs = Vec::new();
        let mut i = name_end;
        loop {
            while i < inner.len() && inner[i].is_ascii_whitespace() {
                i += 1;
            }
            if i >= inner.len() {
                break;
            }
            let k0 = i;
            while i < inner.len() && inner[i] != b'=' && !inner[i].is_ascii_whitespace() {
                i += 1;
            }
            let key = &inner[k0..i];
            while i < inner.len() && inner[i].is_ascii_whitespace() {
                i += 1;
            }
            if inner.get(i) != Some(&b'=') {
                return Err(syntax(
                    b,
                    start,
                    format!("attribute {} has no value", String::from_utf8_lossy(key)),
                ));
            }
            i += 1;
            while i < inner.len() && inner[i].is_ascii_whitespace() {
                i += 1;
            }
            let q = *inner.get(i).unwrap_or(&0);
            if q != b'"' && q != b'\'' {
                return Err(syntax(
                    b,
                    start,
                    format!("attribute {} is not quoted", String::from_utf8_lossy(key)),
                ));
            }
            let v0 = i + 1;
            let v1 = inner[v0..]
                .iter()
                .position(|&c| c == q)
                .map(|k| v0 + k)
                .ok_or_else(|| syntax(b, start, "an attribute value is not closed".into()))?;
            attrs.push((key, &inner[v0..v1]));
            i = v1 + 1;
        }
        Ok(Step::Event(Event::Start(Tag {
            name,
            attrs,
            empty,
            pos: start,
        })))
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &[u8]) -> Option<Ty> {
        Some(match s {
            b"Int8" | b"Char" => Ty::I8,
            b"UInt8" | b"UChar" => Ty::U8,
            b"Int16" => Ty::I16,
            b"UInt16" => Ty::U16,
            b"Int32" => Ty::I32,
            b"UInt32" => Ty::U32,
            b"Int64" => Ty::I64,
            b"UInt64" => Ty::U64,
            b"Float32" => Ty::F32,
            b"Float64" => Ty::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::I64 | Ty::U64 | Ty::F64 => 8,
        }
    }
    fn decode(self, b: &[u8], big: bool) -> f64 {
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(b);
                (if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as f64
            }};
        }
        match self {
            Ty::I8 => b[0] as i8 as f64,
            Ty::U8 => b[0] as f64,
            Ty::I16 => num!(i16, 2),
            Ty::U16 => num!(u16, 2),
            Ty::I32 => num!(i32, 4),
            Ty::U32 => num!(u32, 4),
            Ty::I64 => num!(i64, 8),
            Ty::U64 => num!(u64, 8),
            Ty::F32 => num!(f32, 4),
            Ty::F64 => num!(f64, 8),
        }
    }
}

/// File-level settings from the `VTKFile` element.
#[derive(Debug, Clone, Copy)]
struct Settings {
    big: bool,
    header: usize,
    zlib: bool,
}

/// Where a `DataArray`'s values are.
enum Source {
    Ascii(usize, usize),
    Binary(usize, usize),
    Appended(u64),
}

struct Array {
    name: String,
    ty: Ty,
    components: usize,
    source: Source,
    /// Line of the `DataArray` tag.
    line: usize,
}

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

fn b64_value(c: u8) -> Option<u32> {
    match c {
        b'A'..=b'Z' => Some((c - b'A') as u32),
        b'a'..=b'z' => Some((c - b'a') as u32 + 26),
        b'0'..=b'9' => Some((c - b'0') as u32 + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    }
}

/// Decodes base64 text (no whitespace; `=` padding allowed at the end of each quartet group);
/// `Err(k)` names the offending character's index.
fn b64_decode(t: &[u8]) -> Result<Vec<u8>, usize> {
    let mut out = Vec::with_capacity(t.len() / 4 * 3);
    for (q, chunk) in t.chunks(4).enumerate() {
        let mut v = 0u32;
        let mut n = 0;
        for (k, &c) in chunk.iter().enumerate() {
            if c == b'=' {
                if k < 2 || chunk[k..].iter().any(|&d| d != b'=') {
                    return Err(4 * q + k);
                }
                break;
            }
            v |= b64_value(c).ok_or(4 * q + k)? << (18 - 6 * k);
            n += 1;
        }
        if n < 2 {
            return Err(4 * q);
        }
        let bytes = [(v >> 16) as u8, (v >> 8) as u8, v as u8];
        out.extend_from_slice(&bytes[..n - 1]);
    }
    Ok(out)
}

/// Base64 of `data` with `=` padding.
pub(crate) fn b64_encode(data: &[u8]) -> String {
    let mut s = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let v = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(B64[(v >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// Number of base64 characters that encode `n` bytes.
fn b64_len(n: u64) -> u64 {
    n.div_ceil(3).saturating_mul(4)
}

/// Reads the bytes of one array from a byte stream (raw appended data, or decoded base64).
struct Decoder<'a> {
    bytes: &'a [u8],
    s: Settings,
    /// Offset of `bytes[0]` in the file (for messages).
    base: usize,
    file_len: usize,
    /// Whether `bytes` is base64 text.
    base64: bool,
    what: String,
}

impl Decoder<'_> {
    fn truncated(&self, needed: u64, offset: u64) -> ParseError {
        ParseError::Truncated {
            what: self.what.clone(),
            needed,
            offset: self.base as u64 + offset,
            len: self.file_len as u64,
        }
    }

    /// `n` bytes starting at text/byte position `at`, as stored (raw) or decoded (base64:
    /// `b64_len(n)` characters).
    fn take(&self, at: u64, n: u64) -> Result<Vec<u8>, ParseError> {
        let len = if self.base64 { b64_len(n) } else { n };
        let end = at.saturating_add(len);
        if end > self.bytes.len() as u64 {
            return Err(self.truncated(len, at));
        }
        let chunk = &self.bytes[at as usize..end as usize];
        if self.base64 {
            let mut d = b64_decode(chunk).map_err(|k| {
                ParseError::Invalid(format!(
                    "{}: bad base64 at byte offset {}",
                    self.what,
                    self.base as u64 + at + k as u64
                ))
            })?;
            if (d.len() as u64) < n {
                return Err(self.truncated(len, at));
            }
            d.truncate(n as usize);
            Ok(d)
        } else {
            Ok(chunk.to_vec())
        }
    }

    fn word(&self, b: &[u8]) -> u64 {
        if self.s.header == 4 {
            Ty::U32.decode(b, self.s.big) as u64
        } else {
            let mut a = [0u8; 8];
            a.copy_from_slice(b);
            if self.s.big {
                u64::from_be_bytes(a)
            } else {
                u64::from_le_bytes(a)
            }
        }
    }

    /// The array's raw bytes (exactly `expected` of them), starting at `at`.
    fn array(&self, at: u64, expected: u64) -> Result<Vec<u8>, ParseError> {
        let h = self.s.header as u64;
        if !self.s.zlib {
            // One header word (the byte count), then the data; base64 encodes them together.
            let head = self.take(at, h)?;
            let n = self.word(&head);
            if n != expected {
                return Err(ParseError::Invalid(format!(
                    "{}: the header declares {n} bytes, but the array needs {expected}",
                    self.what
                )));
            }
            let all = self.take(at, h.checked_add(n).ok_or_else(|| self.truncated(n, at))?)?;
            return Ok(all[h as usize..].to_vec());
        }
        // Compressed: [nblocks, block size, last block size, compressed sizes...], then the
        // blocks; base64 encodes the header and the blocks separately.
        let first = self.take(at, h)?;
        let nb = self.word(&first);
        let head_len = nb.saturating_add(3).saturating_mul(h);
        let avail = if self.base64 {
            (self.bytes.len() as u64).saturating_sub(at) / 4 * 3
        } else {
            (self.bytes.len() as u64).saturating_sub(at)
        };
        if head_len > avail {
            return Err(self.truncated(head_len, at));
        }
        let head = self.take(at, head_len)?;
        let w: Vec<u64> = head.chunks_exact(h as usize).map(|c| self.word(c)).collect();
        let (bs, last) = (w[1], w[2]);
        let sizes = &w[3..];
        let total = if nb == 0 {
            0
        } else {
            (nb - 1)
                .saturating_mul(bs)
                .saturating_add(if last == 0 { bs } else { last })
        };
        if total != expected {
            return Err(ParseError::Invalid(format!(
                "{}: the compression header declares {total} bytes, but the array needs {expected}",
                self.what
            )));
        }
        let comp_total = sizes.iter().fold(0u64, |a, &s| a.saturating_add(s));
        // zlib cannot inflate more than about 1032:1; a header claiming more is corrupt (and
        // must not make us reserve its size).
        if total > comp_total.saturating_mul(1100).saturating_add(64) {
            return Err(ParseError::Invalid(format!(
                "{}: {comp_total} compressed bytes cannot hold the declared {total} bytes",
                self.what
            )));
        }
        let data_at = at.saturating_add(if self.base64 { b64_len(head_len) } else { head_len });
        let comp = self.take(data_at, comp_total)?;
        let mut out = Vec::new();
        let mut pos = 0usize;
        for (k, &cs) in sizes.iter().enumerate() {
            let want = if k as u64 + 1 == nb && last != 0 { last } else { bs };
            let block = &comp[pos..pos + cs as usize];
            pos += cs as usize;
            let before = out.len();
            flate2::read::ZlibDecoder::new(block)
                .take(want + 1)
                .read_to_end(&mut out)
                .map_err(|e| {
                    ParseError::Invalid(format!("{}: zlib block {k} cannot be inflated: {e}", self.what))
                })?;
            if (out.len() - before) as u64 != want {
                return Err(ParseError::Invalid(format!(
                    "{}: zlib block {k} inflates to {} bytes, the header says {want}",
                    self.what,
                    out.len() - before
                )));
            }
        }
        Ok(out)
    }
}

struct Piece {
    n_points: u64,
    points: Option<Array>,
    polys: [Option<Array>; 2],
    strips: [Option<Array>; 2],
    n_polys: u64,
    n_strips: u64,
    point_data: Vec<Array>,
    skipped: u64,
}

pub(crate) fn parse(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let mut sc = Scanner { b: bytes, pos: 0 };
    let mut settings: Option<Settings> = None;
    let mut piece: Option<Piece> = None;
    let mut n_pieces = 0;
    // Which section the current DataArray belongs to.
    let mut section: Option<Vec<u8>> = None;
    let mut current: Option<(Tag, Option<(usize, usize)>)> = None;
    let mut appended: Option<(usize, bool)> = None;
    while let Some(ev) = sc.next()? {
        match ev {
            Event::Start(tag) => match tag.name {
                b"VTKFile" => {
                    let ty = tag.attr("type").unwrap_or_default();
                    if ty != b"PolyData" {
                        return Err(ParseError::Unsupported(format!(
                            "VTK XML file of type {:?} (only PolyData is read)",
                            String::from_utf8_lossy(ty)
                        )));
                    }
                    let big = tag.attr("byte_order") == Some(b"BigEndian");
                    let header = match tag.attr("header_type") {
                        None | Some(b"UInt32") => 4,
                        Some(b"UInt64") => 8,
                        Some(o) => {
                            return Err(syntax(
                                bytes,
                                tag.pos,
                                format!("unknown header_type {:?}", String::from_utf8_lossy(o)),
                            ))
                        }
                    };
                    let zlib = match tag.attr("compressor") {
                        None | Some(b"") => false,
                        Some(b"vtkZLibDataCompressor") => true,
                        Some(o) => {
                            return Err(ParseError::Unsupported(format!(
                                "compressor {:?} (only vtkZLibDataCompressor is read)",
                                String::from_utf8_lossy(o)
                            )))
                        }
                    };
                    settings = Some(Settings { big, header, zlib });
                }
                b"Piece" => {
                    n_pieces += 1;
                    if n_pieces > 1 {
                        return Err(ParseError::Unsupported(
                            "a .vtp file with more than one Piece".into(),
                        ));
                    }
                    let count = |k: &str| -> Result<u64, ParseError> {
                        match tag.attr(k) {
                            None => Ok(0),
                            Some(v) => super::text::parse_count(v).ok_or_else(|| {
                                syntax(
                                    bytes,
                                    tag.pos,
                                    format!("{k}={:?} is not a count", String::from_utf8_lossy(v)),
                                )
                            }),
                        }
                    };
                    piece = Some(Piece {
                        n_points: count("NumberOfPoints")?,
                        n_polys: count("NumberOfPolys")?,
                        n_strips: count("NumberOfStrips")?,
                        skipped: count("NumberOfVerts")?.saturating_add(count("NumberOfLines")?),
                        points: None,
                        polys: [None, None],
                        strips: [None, None],
                        point_data: Vec::new(),
                    });
                }
                b"PointData" | b"CellData" | b"Points" | b"Polys" | b"Strips" | b"Verts" | b"Lines"
                | b"FieldData"
                    if !tag.empty =>
                {
                    section = Some(tag.name.to_vec());
                }
                b"DataArray" => {
                    if tag.empty {
                        current = Some((tag, None));
                        finish_array(bytes, &mut current, section.as_deref(), piece.as_mut())?;
                    } else {
                        current = Some((tag, None));
                    }
                }
                b"AppendedData" => {
                    let enc = tag.attr("encoding").unwrap_or(b"raw");
                    let base64 = match enc {
                        b"raw" => false,
                        b"base64" => true,
                        o => {
                            return Err(syntax(
                                bytes,
                                tag.pos,
                                format!("unknown AppendedData encoding {:?}", String::from_utf8_lossy(o)),
                            ))
                        }
                    };
                    let us = bytes[sc.pos..]
                        .iter()
                        .position(|&c| c == b'_')
                        .ok_or_else(|| syntax(bytes, tag.pos, "AppendedData has no '_' marker".into()))?;
                    appended = Some((sc.pos + us + 1, base64));
                    break;
                }
                _ => {}
            },
            Event::Text(a, b) => {
                if let Some((_, text @ None)) = current.as_mut() {
                    *text = Some((a, b));
                }
            }
            Event::End(name) => match name {
                b"DataArray" => finish_array(bytes, &mut current, section.as_deref(), piece.as_mut())?,
                b"PointData" | b"CellData" | b"Points" | b"Polys" | b"Strips" | b"Verts" | b"Lines"
                | b"FieldData" => section = None,
                _ => {}
            },
        }
    }
    let settings =
        settings.ok_or_else(|| ParseError::Invalid("not a VTK XML file: no VTKFile element".into()))?;
    let piece = piece.ok_or_else(|| ParseError::Invalid("the .vtp file has no Piece".into()))?;
    let values = |a: &Array, count: u64| -> Result<Vec<f64>, ParseError> {
        read_values(bytes, settings, appended, a, count)
    };
    let n = piece.n_points;
    if n > u32::MAX as u64 {
        return Err(ParseError::Invalid(format!(
            "{n} points are more than 32-bit indices can address"
        )));
    }
    let points = piece
        .points
        .as_ref()
        .ok_or_else(|| ParseError::Invalid("the Piece has no Points array".into()))?;
    if points.components != 3 {
        return Err(ParseError::Syntax {
            line: points.line,
            message: format!("Points have {} components, not 3", points.components),
        });
    }
    let raw = values(points, n * 3)?;
    let mut positions = Vec::with_capacity(n as usize);
    for (vertex, p) in raw.chunks_exact(3).enumerate() {
        positions.push(check_finite(vertex, [p[0], p[1], p[2]], None)?);
    }
    let mut faces = FaceBuilder::default();
    let mut warnings = Vec::new();
    for (cells, count, strip) in [
        (&piece.polys, piece.n_polys, false),
        (&piece.strips, piece.n_strips, true),
    ] {
        if count == 0 {
            continue;
        }
        let what = if strip { "Strips" } else { "Polys" };
        let (Some(conn), Some(offs)) = (&cells[0], &cells[1]) else {
            return Err(ParseError::Invalid(format!(
                "{what} needs connectivity and offsets arrays"
            )));
        };
        let offsets = values(offs, count)?;
        let total = offsets.last().copied().unwrap_or(0.0);
        let total = as_count(total).ok_or_else(|| ParseError::Syntax {
            line: offs.line,
            message: format!("the last {what} offset {total} is not a count"),
        })?;
        let connectivity = values(conn, total)?;
        let mut prev = 0u64;
        for (i, &o) in offsets.iter().enumerate() {
            let o = as_count(o)
                .filter(|&o| o >= prev && o <= connectivity.len() as u64)
                .ok_or_else(|| ParseError::Syntax {
                    line: offs.line,
                    message: format!(
                        "{what} offset {i} ({o}) is not a count between the one before and the {} connectivity values",
                        connectivity.len()
                    ),
                })?;
            let face = faces.n_polygons();
            let idx = connectivity[prev as usize..o as usize]
                .iter()
                .map(|&v| {
                    check_index(
                        face,
                        if v.fract() == 0.0 { v as i64 } else { -1 },
                        n as usize,
                        None,
                    )
                })
                .collect::<Result<Vec<u32>, _>>()?;
            if strip {
                if idx.len() < 3 {
                    return Err(ParseError::BadFace {
                        face,
                        count: idx.len() as u64,
                        line: None,
                    });
                }
                for k in 0..idx.len() - 2 {
                    let t = if k % 2 == 0 {
                        [idx[k], idx[k + 1], idx[k + 2]]
                    } else {
                        [idx[k + 1], idx[k], idx[k + 2]]
                    };
                    faces.push(&t, None)?;
                }
            } else {
                faces.push(&idx, None)?;
            }
            prev = o;
        }
        if strip {
            warnings.push(format!("converted {count} triangle strip(s) to triangles"));
        }
    }
    if piece.skipped > 0 {
        warnings.push(format!("ignored {} Verts/Lines cell(s)", piece.skipped));
    }
    let mut point_data = Vec::with_capacity(piece.point_data.len());
    for a in &piece.point_data {
        let v = values(a, n.saturating_mul(a.components as u64))?;
        point_data.push(PointArray {
            name: a.name.clone(),
            components: a.components,
            values: v,
        });
    }
    let faces = faces.finish(&positions, &mut warnings)?;
    Ok(MeshData {
        positions,
        faces,
        warnings,
        point_data,
    })
}

fn as_count(v: f64) -> Option<u64> {
    (v >= 0.0 && v.fract() == 0.0 && v < 1.8e19).then_some(v as u64)
}

/// Records a finished `DataArray` in its section of the piece.
fn finish_array(
    bytes: &[u8],
    current: &mut Option<(Tag, Option<(usize, usize)>)>,
    section: Option<&[u8]>,
    piece: Option<&mut Piece>,
) -> Result<(), ParseError> {
    let Some((tag, text)) = current.take() else {
        return Ok(());
    };
    let Some(piece) = piece else {
        return Ok(());
    };
    let line = line_of(bytes, tag.pos);
    let bad = |message: String| ParseError::Syntax { line, message };
    let ty_s = tag.attr("type").unwrap_or_default();
    let ty = Ty::parse(ty_s).ok_or_else(|| {
        bad(format!(
            "unknown DataArray type {:?}",
            String::from_utf8_lossy(ty_s)
        ))
    })?;
    let name = tag.attr_str("Name").unwrap_or_default();
    let components = match tag.attr("NumberOfComponents") {
        None => 1,
        Some(v) => super::text::parse_count(v)
            .filter(|&c| (1..=1 << 16).contains(&c))
            .ok_or_else(|| bad(format!("NumberOfComponents={:?}", String::from_utf8_lossy(v))))?
            as usize,
    };
    let (a, b) = text.unwrap_or((tag.pos, tag.pos));
    let source = match tag.attr("format").unwrap_or(b"ascii") {
        b"ascii" => Source::Ascii(a, b),
        b"binary" => Source::Binary(a, b),
        b"appended" => {
            let off = tag
                .attr("offset")
                .ok_or_else(|| bad("an appended DataArray has no offset".into()))?;
            Source::Appended(
                super::text::parse_count(off.trim_ascii())
                    .ok_or_else(|| bad(format!("offset={:?}", String::from_utf8_lossy(off))))?,
            )
        }
        o => {
            return Err(bad(format!(
                "unknown DataArray format {:?}",
                String::from_utf8_lossy(o)
            )))
        }
    };
    let arr = Array {
        name,
        ty,
        components,
        source,
        line,
    };
    match section {
        Some(b"Points") => piece.points = Some(arr),
        Some(s @ (b"Polys" | b"Strips")) => {
            let slot = if s == b"Polys" {
                &mut piece.polys
            } else {
                &mut piece.strips
            };
            match arr.name.as_str() {
                "connectivity" => slot[0] = Some(arr),
                "offsets" => slot[1] = Some(arr),
                _ => {}
            }
        }
        Some(b"PointData") => piece.point_data.push(arr),
        _ => {}
    }
    Ok(())
}

/// The `count` values of an array.
fn read_values(
    bytes: &[u8],
    s: Settings,
    appended: Option<(usize, bool)>,
    a: &Array,
    count: u64,
) -> Result<Vec<f64>, ParseError> {
    let what = format!("DataArray {:?} (line {})", a.name, a.line);
    let expected = count.saturating_mul(a.ty.size() as u64);
    let raw = match a.source {
        Source::Ascii(x, y) => {
            let text = &bytes[x..y];
            if count > (text.len() as u64).div_ceil(2) {
                return Err(ParseError::UnexpectedEnd {
                    expected: format!("{count} values in {what}, but it holds only {} bytes", text.len()),
                });
            }
            let mut out = Vec::with_capacity(count as usize);
            for (line, l) in (line_of(bytes, x)..).zip(text.split(|&c| c == b'\n')) {
                for tok in super::text::tokens(l) {
                    let v = super::text::parse_f64(tok).ok_or_else(|| ParseError::Syntax {
                        line,
                        message: format!("cannot read a number of {what} from {}", super::text::show(tok)),
                    })?;
                    out.push(v);
                }
            }
            if out.len() as u64 != count {
                return Err(ParseError::Syntax {
                    line: a.line,
                    message: format!("{what} has {} values, expected {count}", out.len()),
                });
            }
            return Ok(out);
        }
        Source::Binary(x, y) => {
            let text: Vec<u8> = bytes[x..y]
                .iter()
                .copied()
                .filter(|c| !c.is_ascii_whitespace())
                .collect();
            let d = Decoder {
                bytes: &text,
                s,
                base: x,
                file_len: bytes.len(),
                base64: true,
                what: what.clone(),
            };
            d.array(0, expected)?
        }
        Source::Appended(off) => {
            let (start, base64) = appended.ok_or_else(|| {
                ParseError::Invalid(format!("{what} is appended, but the file has no AppendedData"))
            })?;
            let d = Decoder {
                bytes: &bytes[start..],
                s,
                base: start,
                file_len: bytes.len(),
                base64,
                what: what.clone(),
            };
            d.array(off, expected)?
        }
    };
    Ok(raw
        .chunks_exact(a.ty.size())
        .map(|c| a.ty.decode(c, s.big))
        .collect())
}

/// XML-escapes an attribute value.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// One inline base64 array: `UInt64` byte count, then the data, encoded together.
fn b64_array(data: &[u8]) -> String {
    let mut buf = Vec::with_capacity(8 + data.len());
    buf.extend_from_slice(&(data.len() as u64).to_le_bytes());
    buf.extend_from_slice(data);
    b64_encode(&buf)
}

pub(crate) fn write(
    w: &mut dyn Write,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    fields: &[Field],
) -> std::io::Result<()> {
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    )?;
    writeln!(w, "  <PolyData>")?;
    writeln!(
        w,
        "    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"{}\">",
        positions.len(),
        faces.len()
    )?;
    let first_scalar = fields.iter().find(|f| f.components() == 1);
    let first_vector = fields.iter().find(|f| f.components() == 3);
    write!(w, "      <PointData")?;
    if let Some(f) = first_scalar {
        write!(w, " Scalars=\"{}\"", escape(f.name))?;
    }
    if let Some(f) = first_vector {
        write!(w, " Vectors=\"{}\"", escape(f.name))?;
    }
    writeln!(w, ">")?;
    for f in fields {
        let mut data = Vec::with_capacity(8 * f.components() * f.len());
        for v in 0..f.len() {
            for c in 0..f.components() {
                data.extend_from_slice(&f.get(v, c).to_le_bytes());
            }
        }
        writeln!(
            w,
            "        <DataArray type=\"Float64\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"binary\">\n          {}\n        </DataArray>",
            escape(f.name),
            f.components(),
            b64_array(&data)
        )?;
    }
    writeln!(w, "      </PointData>")?;
    let mut data = Vec::with_capacity(24 * positions.len());
    for p in positions {
        for c in p {
            data.extend_from_slice(&c.to_le_bytes());
        }
    }
    writeln!(
        w,
        "      <Points>\n        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"binary\">\n          {}\n        </DataArray>\n      </Points>",
        b64_array(&data)
    )?;
    let mut conn = Vec::with_capacity(24 * faces.len());
    let mut offs = Vec::with_capacity(8 * faces.len());
    for (k, f) in faces.iter().enumerate() {
        for &i in f {
            conn.extend_from_slice(&(i as i64).to_le_bytes());
        }
        offs.extend_from_slice(&(3 * (k as i64 + 1)).to_le_bytes());
    }
    writeln!(
        w,
        "      <Polys>\n        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"binary\">\n          {}\n        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"binary\">\n          {}\n        </DataArray>\n      </Polys>",
        b64_array(&conn),
        b64_array(&offs)
    )?;
    writeln!(w, "    </Piece>\n  </PolyData>\n</VTKFile>")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_and_rejects_garbage() {
        for n in 0..20u8 {
            let data: Vec<u8> = (0..n).map(|k| k.wrapping_mul(37).wrapping_add(n)).collect();
            let t = b64_encode(&data);
            assert_eq!(t.len() as u64, b64_len(n as u64));
            assert_eq!(b64_decode(t.as_bytes()).unwrap(), data);
        }
        assert_eq!(b64_encode(b"Man"), "TWFu");
        assert_eq!(b64_decode(b"TWE=").unwrap(), b"Ma");
        assert_eq!(b64_decode(b"TW*u"), Err(2));
        assert_eq!(b64_decode(b"T==="), Err(1));
    }
}
