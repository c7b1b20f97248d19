//! Wavefront OBJ: `v` and `f` statements; the other statements of the format (normals,
//! texture coordinates, groups, materials, lines, free-form geometry) are ignored, and lines
//! with a keyword the format does not have are counted in a warning that names the first one
//! (an error when the file has no faces at all: then it is not an OBJ file).
//!
//! Face corners may be written `i`, `i/t`, `i//n` or `i/t/n`; only `i` is used. Indices are
//! 1-based, and negative indices count back from the last vertex defined so far. Positive
//! indices are checked against the final vertex count, so faces may precede their vertices.
//! Extra numbers on a `v` line (a `w` weight or `r g b` colours) are ignored.

use std::io::Write;

use super::syntax::SyntaxError;
use super::text::{self, Float};
use super::{read_vertex, FaceBuilder, MeshData, ParseError};

/// OBJ keywords that are read (`v`, `f`, `fo`) or knowingly ignored (everything else here).
const KNOWN: [&[u8]; 36] = [
    b"v",
    b"f",
    b"fo",
    b"vt",
    b"vn",
    b"vp",
    b"l",
    b"p",
    b"g",
    b"o",
    b"s",
    b"mg",
    b"mtllib",
    b"usemtl",
    b"cstype",
    b"deg",
    b"bmat",
    b"step",
    b"curv",
    b"curv2",
    b"surf",
    b"parm",
    b"trim",
    b"hole",
    b"scrv",
    b"sp",
    b"end",
    b"con",
    b"lod",
    b"bevel",
    b"c_interp",
    b"d_interp",
    b"trace_obj",
    b"shadow_obj",
    b"ctech",
    b"stech",
];

/// A face corner that refers forward to a vertex not yet defined, checked at the end.
struct Pending {
    face: usize,
    written: i64,
    resolved: u32,
    line: usize,
}

pub(crate) fn parse(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut faces = FaceBuilder::default();
    let mut pending: Vec<Pending> = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    let mut n_ignored_v = 0usize;
    let mut n_unknown = 0usize;
    let mut first_unknown: Option<(usize, String)> = None;
    for (line, raw) in text::lines(bytes) {
        let mut toks = text::tokens(raw);
        let Some(keyword) = toks.next() else { continue };
        match keyword {
            b"v" => {
                let (p, extra) = read_vertex(&mut toks, positions.len(), line)?;
                n_ignored_v += usize::from(extra);
                positions.push(p);
            }
            b"f" | b"fo" => {
                let face = faces.n_polygons();
                poly.clear();
                for tok in toks {
                    let idx_tok = tok.split(|&b| b == b'/').next().unwrap_or(tok);
                    let written = text::parse_i64(idx_tok).ok_or_else(|| ParseError::Syntax {
                        line,
                        problem: SyntaxError::VertexIndex {
                            face,
                            found: text::clip(tok),
                        },
                    })?;
                    let n = positions.len() as i64;
                    let zero_based = match written {
                        0 => {
                            return Err(ParseError::Syntax {
                                line,
                                problem: SyntaxError::IndexZero { face },
                            })
                        }
                        w if w > 0 => w - 1,
                        w => n + w,
                    };
                    if zero_based < 0 || zero_based > u32::MAX as i64 {
                        return Err(ParseError::IndexOutOfRange {
                            face,
                            index: written,
                            n_vertices: positions.len(),
                            line: Some(line),
                        });
                    }
                    if zero_based >= n {
                        pending.push(Pending {
                            face,
                            written,
                            resolved: zero_based as u32,
                            line,
                        });
                    }
                    poly.push(zero_based as u32);
                }
                faces.push(&poly, Some(line))?;
            }
            k if KNOWN.contains(&k) || k.starts_with(b"#") => {}
            _ => {
                n_unknown += 1;
                first_unknown.get_or_insert((line, text::clip(raw)));
            }
        }
    }
    if let Some((line, shown)) = &first_unknown {
        if faces.n_polygons() == 0 {
            return Err(ParseError::Syntax {
                line: *line,
                problem: SyntaxError::NotObj {
                    unknown: n_unknown,
                    first: shown.clone(),
                },
            });
        }
    }
    for p in &pending {
        if p.resolved as usize >= positions.len() {
            if let Some((unknown_line, shown)) = &first_unknown {
                return Err(ParseError::Syntax {
                    line: p.line,
                    problem: SyntaxError::SkippedVertex {
                        face: p.face,
                        index: p.written,
                        n_vertices: positions.len(),
                        unknown: n_unknown,
                        unknown_line: *unknown_line,
                        first: shown.clone(),
                    },
                });
            }
            return Err(ParseError::IndexOutOfRange {
                face: p.face,
                index: p.written,
                n_vertices: positions.len(),
                line: Some(p.line),
            });
        }
    }
    let mut warnings = Vec::new();
    let faces = faces.finish(&positions, &mut warnings)?;
    if let Some((line, shown)) = first_unknown {
        warnings.push(format!(
            "ignored {n_unknown} line(s) with a keyword OBJ does not know; the first is line {line}: {shown}"
        ));
    }
    if n_ignored_v > 0 {
        warnings.push(format!(
            "ignored extra values (weights or colours) on {n_ignored_v} vertex line(s)"
        ));
    }
    Ok(MeshData {
        positions,
        faces,
        warnings,
        point_data: Vec::new(),
    })
}

pub(crate) fn write(
    w: &mut dyn Write,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    colors: Option<&[[u8; 3]]>,
) -> std::io::Result<()> {
    writeln!(
        w,
        "# written by qcshape: {} vertices, {} faces",
        positions.len(),
        faces.len()
    )?;
    for (i, p) in positions.iter().enumerate() {
        write!(w, "v {} {} {}", Float(p[0]), Float(p[1]), Float(p[2]))?;
        if let Some(c) = colors {
            let c = c[i];
            write!(
                w,
                " {} {} {}",
                Float(c[0] as f64 / 255.0),
                Float(c[1] as f64 / 255.0),
                Float(c[2] as f64 / 255.0)
            )?;
        }
        writeln!(w)?;
    }
    for f in faces {
        writeln!(w, "f {} {} {}", f[0] as u64 + 1, f[1] as u64 + 1, f[2] as u64 + 1)?;
    }
    Ok(())
}
