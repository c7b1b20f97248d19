//! The layer the VTK XML readers share (`.vtp` PolyData in `vtp.rs`, `.vtu` UnstructuredGrid in
//! `vtu.rs`): a minimal XML scanner, `DataArray` decoding (`ascii`, inline base64 `binary`,
//! `appended` raw or base64; uncompressed or `vtkZLibDataCompressor`; `UInt32` or `UInt64`
//! headers; either byte order) and a [`Document`] holding the one `Piece` of a file.
//!
//! Every header value (byte counts, block counts, offsets) goes through checked arithmetic and
//! is compared with the bytes present before anything is allocated or sliced, so no input can
//! panic or make the reader reserve more than the file could hold.

mod data;
mod scan;

use data::{read_values, Settings, Source, Ty};
use scan::{line_of, syntax, Event, Scanner, Tag};

use super::syntax::SyntaxError;

#[cfg(test)]
pub(super) use data::b64_encode;
pub(super) use data::{b64_array, Array};

use super::{check_finite, check_index, ParseError, PointArray, UnsupportedFeature};

/// A section of a `Piece` whose `DataArray`s the readers use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Section {
    /// `<Points>`: one 3-component array.
    Points,
    /// `<PointData>`: named per-vertex arrays.
    PointData,
    /// `<Polys>` (PolyData).
    Polys,
    /// `<Strips>` (PolyData).
    Strips,
    /// `<Cells>` (UnstructuredGrid).
    Cells,
}

impl Section {
    fn from_tag(name: &[u8]) -> Option<Section> {
        Some(match name {
            b"Points" => Section::Points,
            b"PointData" => Section::PointData,
            b"Polys" => Section::Polys,
            b"Strips" => Section::Strips,
            b"Cells" => Section::Cells,
            _ => return None,
        })
    }
}

/// Tags that open a section of a `Piece` (their arrays are ignored unless [`Section`] names
/// them).
const SECTION_TAGS: &[&[u8]] = &[
    b"PointData",
    b"CellData",
    b"Points",
    b"Polys",
    b"Strips",
    b"Verts",
    b"Lines",
    b"Cells",
    b"FieldData",
];

/// One parsed VTK XML file of the expected `type`: its settings, the attributes of its one
/// `Piece` and the `DataArray`s of the sections the readers use.
pub(super) struct Document<'a> {
    bytes: &'a [u8],
    settings: Settings,
    /// Start of the appended data (after the `_` marker) and whether it is base64.
    appended: Option<(usize, bool)>,
    piece: Tag<'a>,
    arrays: Vec<(Section, Array)>,
}

impl<'a> Document<'a> {
    /// Parses the markup of a VTK XML file whose `VTKFile type` must be `kind` (`PolyData`,
    /// `UnstructuredGrid`); `ext` names the file type in messages (`.vtp`). Data arrays are
    /// only located here; [`Document::values`] decodes them.
    pub(super) fn parse(bytes: &'a [u8], kind: &'static str, ext: &'static str) -> Result<Self, ParseError> {
        let mut sc = Scanner { b: bytes, pos: 0 };
        let mut settings: Option<Settings> = None;
        let mut piece: Option<Tag<'a>> = None;
        let mut section: Option<Option<Section>> = None;
        let mut current: Option<(Tag<'a>, Option<(usize, usize)>)> = None;
        let mut appended = None;
        let mut arrays = Vec::new();
        while let Some(ev) = sc.next()? {
            match ev {
                Event::Start(tag) => match tag.name {
                    b"VTKFile" => settings = Some(file_settings(bytes, &tag, kind)?),
                    b"Piece" => {
                        if piece.is_some() {
                            return Err(ParseError::Unsupported(UnsupportedFeature::SeveralPieces { ext }));
                        }
                        piece = Some(tag);
                    }
                    name if SECTION_TAGS.contains(&name) && !tag.empty => {
                        section = Some(Section::from_tag(name));
                    }
                    b"DataArray" => {
                        let empty = tag.empty;
                        current = Some((tag, None));
                        if empty {
                            finish_array(
                                bytes,
                                &mut current,
                                section.flatten(),
                                piece.is_some(),
                                &mut arrays,
                            )?;
                        }
                    }
                    b"AppendedData" => {
                        let base64 = match tag.attr("encoding").unwrap_or(b"raw") {
                            b"raw" => false,
                            b"base64" => true,
                            o => {
                                return Err(syntax(
                                    bytes,
                                    tag.pos,
                                    SyntaxError::Unknown {
                                        what: "AppendedData encoding",
                                        found: String::from_utf8_lossy(o).into_owned(),
                                    },
                                ))
                            }
                        };
                        let us = bytes[sc.pos..]
                            .iter()
                            .position(|&c| c == b'_')
                            .ok_or_else(|| syntax(bytes, tag.pos, SyntaxError::NoMarker))?;
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
                Event::End(name) => {
                    if name == b"DataArray" {
                        finish_array(
                            bytes,
                            &mut current,
                            section.flatten(),
                            piece.is_some(),
                            &mut arrays,
                        )?;
                    } else if SECTION_TAGS.contains(&name) {
                        section = None;
                    }
                }
            }
        }
        let settings = settings.ok_or_else(|| ParseError::Missing {
            what: "VTKFile element (it is not a VTK XML file)".into(),
        })?;
        let piece = piece.ok_or_else(|| ParseError::Missing {
            what: format!("Piece ({ext})"),
        })?;
        Ok(Document {
            bytes,
            settings,
            appended,
            piece,
            arrays,
        })
    }

    /// The count attribute `key` of the `Piece` (0 if absent).
    pub(super) fn count(&self, key: &str) -> Result<u64, ParseError> {
        match self.piece.attr(key) {
            None => Ok(0),
            Some(v) => super::text::parse_count(v.trim_ascii()).ok_or_else(|| {
                syntax(
                    self.bytes,
                    self.piece.pos,
                    SyntaxError::NotACount {
                        key: key.to_string(),
                        value: String::from_utf8_lossy(v).into_owned(),
                    },
                )
            }),
        }
    }

    /// The first array of `section` called `name` (any name if `None`).
    pub(super) fn array(&self, section: Section, name: Option<&str>) -> Option<&Array> {
        self.arrays
            .iter()
            .find(|(s, a)| *s == section && name.is_none_or(|n| a.name == n))
            .map(|(_, a)| a)
    }

    /// The `count` values of an array, converted to `f64`.
    pub(super) fn values(&self, a: &Array, count: u64) -> Result<Vec<f64>, ParseError> {
        read_values(self.bytes, self.settings, self.appended, a, count)
    }

    /// The `NumberOfPoints` vertex positions (#V x 3), all finite.
    pub(super) fn positions(&self) -> Result<Vec<[f64; 3]>, ParseError> {
        let n = self.count("NumberOfPoints")?;
        if n > u32::MAX as u64 {
            return Err(ParseError::TooManyVertices { count: n });
        }
        let points = self
            .array(Section::Points, None)
            .ok_or_else(|| ParseError::Missing {
                what: "Points array in its Piece".into(),
            })?;
        if points.components != 3 {
            return Err(ParseError::Syntax {
                line: points.line,
                problem: SyntaxError::PointComponents {
                    components: points.components,
                },
            });
        }
        let raw = self.values(points, n * 3)?;
        let mut positions = Vec::with_capacity(raw.len() / 3);
        for (vertex, p) in raw.chunks_exact(3).enumerate() {
            positions.push(check_finite(vertex, [p[0], p[1], p[2]], None)?);
        }
        Ok(positions)
    }

    /// The `PointData` arrays (each #V x components values), in file order.
    pub(super) fn point_data(&self, n_points: usize) -> Result<Vec<PointArray>, ParseError> {
        let mut out = Vec::new();
        for (_, a) in self.arrays.iter().filter(|(s, _)| *s == Section::PointData) {
            let count = (n_points as u64)
                .checked_mul(a.components as u64)
                .ok_or_else(|| ParseError::SizeOverflow {
                    what: format!("PointData {:?}", a.name),
                })?;
            let values = self.values(a, count)?;
            out.push(PointArray {
                name: a.name.clone(),
                components: a.components,
                values,
            });
        }
        Ok(out)
    }

    /// Calls `cell(k, indices)` for each of the `count` cells described by the `connectivity`
    /// and `offsets` arrays of `section` (`what` names it in messages); each index is checked
    /// against `n_points`.
    pub(super) fn each_cell(
        &self,
        section: Section,
        count: u64,
        what: &str,
        n_points: usize,
        mut cell: impl FnMut(usize, &[u32]) -> Result<(), ParseError>,
    ) -> Result<(), ParseError> {
        let (Some(conn), Some(offs)) = (
            self.array(section, Some("connectivity")),
            self.array(section, Some("offsets")),
        ) else {
            return Err(ParseError::Missing {
                what: format!("connectivity and offsets arrays for its {what}"),
            });
        };
        let offsets = self.values(offs, count)?;
        let last = offsets.last().copied().unwrap_or(0.0);
        let total = as_count(last).ok_or_else(|| ParseError::Syntax {
            line: offs.line,
            problem: SyntaxError::LastOffset {
                what: what.to_string(),
                last,
            },
        })?;
        let connectivity = self.values(conn, total)?;
        let mut prev = 0usize;
        let mut idx = Vec::new();
        for (i, &o) in offsets.iter().enumerate() {
            let o = as_count(o)
                .filter(|&o| o >= prev as u64 && o <= connectivity.len() as u64)
                .ok_or_else(|| ParseError::Syntax {
                    line: offs.line,
                    problem: SyntaxError::Offset {
                        what: what.to_string(),
                        index: i,
                        offset: o,
                        len: connectivity.len(),
                    },
                })? as usize;
            idx.clear();
            for &v in &connectivity[prev..o] {
                let index = if v.fract() == 0.0 && v.abs() < 9.2e18 {
                    v as i64
                } else {
                    -1
                };
                idx.push(check_index(i, index, n_points, None)?);
            }
            cell(i, &idx)?;
            prev = o;
        }
        Ok(())
    }
}

/// The `VTKFile` element's settings; errors unless its `type` is `kind`.
fn file_settings(bytes: &[u8], tag: &Tag, kind: &'static str) -> Result<Settings, ParseError> {
    let ty = tag.attr("type").unwrap_or_default();
    if ty != kind.as_bytes() {
        return Err(ParseError::Unsupported(UnsupportedFeature::XmlType {
            found: super::text::clip(ty),
            expected: kind,
        }));
    }
    let big = tag.attr("byte_order") == Some(b"BigEndian");
    let header = match tag.attr("header_type") {
        None | Some(b"UInt32") => 4,
        Some(b"UInt64") => 8,
        Some(o) => {
            return Err(syntax(
                bytes,
                tag.pos,
                SyntaxError::Unknown {
                    what: "header_type",
                    found: String::from_utf8_lossy(o).into_owned(),
                },
            ))
        }
    };
    let zlib = match tag.attr("compressor") {
        None | Some(b"") => false,
        Some(b"vtkZLibDataCompressor") => true,
        Some(o) => {
            return Err(ParseError::Unsupported(UnsupportedFeature::Compressor(
                super::text::clip(o),
            )))
        }
    };
    Ok(Settings { big, header, zlib })
}

fn as_count(v: f64) -> Option<u64> {
    (v >= 0.0 && v.fract() == 0.0 && v < 1.8e19).then_some(v as u64)
}

/// Records a finished `DataArray` of a section the readers use (inside the `Piece`).
fn finish_array<'a>(
    bytes: &[u8],
    current: &mut Option<(Tag<'a>, Option<(usize, usize)>)>,
    section: Option<Section>,
    in_piece: bool,
    arrays: &mut Vec<(Section, Array)>,
) -> Result<(), ParseError> {
    let Some((tag, text)) = current.take() else {
        return Ok(());
    };
    let (Some(section), true) = (section, in_piece) else {
        return Ok(());
    };
    let line = line_of(bytes, tag.pos);
    let bad = |problem: SyntaxError| ParseError::Syntax { line, problem };
    let ty_s = tag.attr("type").unwrap_or_default();
    let ty = Ty::parse(crate::io::number::Names::VtkXml, ty_s).ok_or_else(|| {
        bad(SyntaxError::Unknown {
            what: "DataArray type",
            found: String::from_utf8_lossy(ty_s).into_owned(),
        })
    })?;
    let name = tag.attr_str("Name").unwrap_or_default();
    let components = match tag.attr("NumberOfComponents") {
        None => 1,
        Some(v) => super::text::parse_count(v)
            .filter(|&c| (1..=1 << 16).contains(&c))
            .ok_or_else(|| {
                bad(SyntaxError::Attribute {
                    key: "NumberOfComponents",
                    value: String::from_utf8_lossy(v).into_owned(),
                })
            })? as usize,
    };
    let (a, b) = text.unwrap_or((tag.pos, tag.pos));
    let source = match tag.attr("format").unwrap_or(b"ascii") {
        b"ascii" => Source::Ascii(a, b),
        b"binary" => Source::Binary(a, b),
        b"appended" => {
            let off = tag.attr("offset").ok_or_else(|| bad(SyntaxError::NoOffset))?;
            Source::Appended(super::text::parse_count(off.trim_ascii()).ok_or_else(|| {
                bad(SyntaxError::Attribute {
                    key: "offset",
                    value: String::from_utf8_lossy(off).into_owned(),
                })
            })?)
        }
        o => {
            return Err(bad(SyntaxError::Unknown {
                what: "DataArray format",
                found: String::from_utf8_lossy(o).into_owned(),
            }))
        }
    };
    arrays.push((
        section,
        Array {
            name,
            ty,
            components,
            source,
            line,
        },
    ));
    Ok(())
}
