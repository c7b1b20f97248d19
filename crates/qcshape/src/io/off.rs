//! Object File Format (OFF), text only.
//!
//! ```text
//! OFF                 # keyword (also COFF, NOFF, CNOFF, STOFF...; may be omitted)
//! nv nf ne            # counts (may follow the keyword on its line; ne is ignored)
//! x y z [extra...]    # nv vertex lines; extra values (colours, normals) are ignored
//! k i1 ... ik [rgb]   # nf faces, 0-based indices; k > 3 is triangulated (fan, or ear clipping)
//! ```
//! `#` starts a comment anywhere; blank lines are skipped. One record per line; data after the
//! declared faces is an error.

use std::io::Write;

use super::syntax::SyntaxError;
use super::text::{self, Float};
use super::{check_index, read_vertex, FaceBuilder, MeshData, ParseError, UnsupportedFeature};

/// Content lines: comments stripped, blank lines skipped.
fn content_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    text::lines(bytes).filter_map(|(n, l)| {
        let l = match l.iter().position(|&b| b == b'#') {
            Some(k) => &l[..k],
            None => l,
        };
        (!l.iter().all(|b| b.is_ascii_whitespace())).then_some((n, l))
    })
}

fn count(tok: Option<&[u8]>, what: &'static str, line: usize) -> Result<u64, ParseError> {
    let tok = tok.ok_or(ParseError::Syntax {
        line,
        problem: SyntaxError::NoCount { what },
    })?;
    text::parse_count(tok).ok_or_else(|| ParseError::Syntax {
        line,
        problem: SyntaxError::Count {
            what,
            found: text::clip(tok),
        },
    })
}

pub(crate) fn parse(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let mut lines = content_lines(bytes);
    let mut warnings = Vec::new();
    let (first_line, first) = lines.next().ok_or(ParseError::Empty)?;
    let mut toks = text::tokens(first).peekable();
    let keyword = toks.peek().copied().unwrap_or_default();
    let (line, mut count_toks): (usize, Vec<&[u8]>) = if keyword.ends_with(b"OFF") {
        let prefix = &keyword[..keyword.len() - 3];
        if prefix.iter().any(|b| !b"CNST".contains(b)) {
            return Err(ParseError::Unsupported(UnsupportedFeature::OffVariant(
                text::clip(keyword),
            )));
        }
        toks.next();
        if toks.peek() == Some(&&b"BINARY"[..]) {
            return Err(ParseError::Unsupported(UnsupportedFeature::BinaryOff));
        }
        let rest: Vec<&[u8]> = toks.collect();
        if rest.is_empty() {
            let (n, l) = lines.next().ok_or_else(|| ParseError::UnexpectedEnd {
                expected: "the vertex, face and edge counts after the OFF keyword".into(),
            })?;
            (n, text::tokens(l).collect())
        } else {
            (first_line, rest)
        }
    } else if text::parse_count(keyword).is_some() {
        warnings.push("the file has no OFF keyword; read the first line as the counts".into());
        (first_line, toks.collect())
    } else {
        return Err(ParseError::Syntax {
            line: first_line,
            problem: SyntaxError::Expected {
                expected: "the OFF keyword",
                found: text::clip(keyword),
            },
        });
    };
    count_toks.truncate(3);
    let mut ct = count_toks.into_iter();
    let nv = count(ct.next(), "vertex", line)?;
    let nf = count(ct.next(), "face", line)?;
    if nv > u32::MAX as u64 {
        return Err(ParseError::Syntax {
            line,
            problem: SyntaxError::TooManyVertices { count: nv },
        });
    }

    let mut positions = Vec::with_capacity(text::capacity(nv, bytes.len(), 6));
    let mut extra = 0usize;
    for vertex in 0..nv as usize {
        let (line, l) = lines.next().ok_or_else(|| ParseError::UnexpectedEnd {
            expected: format!("{nv} vertices, found {vertex}"),
        })?;
        let (p, more) = read_vertex(&mut text::tokens(l), vertex, line)?;
        extra += usize::from(more);
        positions.push(p);
    }
    let expects_extra = keyword.ends_with(b"OFF") && keyword.len() > 3;
    if extra > 0 && !expects_extra {
        warnings.push(format!("ignored extra values on {extra} vertex line(s)"));
    }

    let mut faces = FaceBuilder::with_capacity(text::capacity(nf, bytes.len(), 6));
    let mut poly = Vec::new();
    for face in 0..nf as usize {
        let (line, l) = lines.next().ok_or_else(|| ParseError::UnexpectedEnd {
            expected: format!("{nf} faces, found {face}"),
        })?;
        let mut toks = text::tokens(l);
        let k_tok = toks.next().unwrap_or_default();
        let k = text::parse_count(k_tok).ok_or_else(|| ParseError::Syntax {
            line,
            problem: SyntaxError::FaceSize {
                face,
                found: text::clip(k_tok),
            },
        })?;
        if k < 3 {
            return Err(ParseError::BadFace {
                face,
                count: k,
                line: Some(line),
            });
        }
        poly.clear();
        for j in 0..k {
            let tok = toks.next().ok_or(ParseError::Syntax {
                line,
                problem: SyntaxError::ShortFace {
                    face,
                    declared: k,
                    listed: j,
                },
            })?;
            let index = text::parse_i64(tok).ok_or_else(|| ParseError::Syntax {
                line,
                problem: SyntaxError::VertexIndex {
                    face,
                    found: text::clip(tok),
                },
            })?;
            poly.push(check_index(face, index, positions.len(), Some(line))?);
        }
        faces.push(&poly, Some(line))?;
    }
    if let Some((line, _)) = lines.next() {
        return Err(ParseError::Syntax {
            line,
            problem: SyntaxError::ExtraData {
                vertices: nv as usize,
                faces: nf as usize,
            },
        });
    }
    let faces = faces.finish(&positions, &mut warnings)?;
    Ok(MeshData {
        positions,
        faces,
        warnings,
        point_data: Vec::new(),
    })
}

pub(crate) fn write(w: &mut dyn Write, positions: &[[f64; 3]], faces: &[[u32; 3]]) -> std::io::Result<()> {
    writeln!(w, "OFF")?;
    writeln!(w, "# written by qcshape")?;
    writeln!(w, "{} {} 0", positions.len(), faces.len())?;
    for p in positions {
        writeln!(w, "{} {} {}", Float(p[0]), Float(p[1]), Float(p[2]))?;
    }
    for f in faces {
        writeln!(w, "3 {} {} {}", f[0], f[1], f[2])?;
    }
    Ok(())
}
