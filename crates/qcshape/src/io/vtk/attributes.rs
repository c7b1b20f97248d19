//! The dataset attributes of legacy VTK: `POINT_DATA` and `CELL_DATA` arrays (`SCALARS`,
//! `VECTORS`, `NORMALS`, `TENSORS`, `TEXTURE_COORDINATES`, `COLOR_SCALARS`, `LOOKUP_TABLE`,
//! ids, `FIELD`) and dataset-level `FIELD` data, with the `METADATA` blocks VTK writes after
//! arrays.

use super::{Names, Num, Reader, SECTIONS};
use crate::io::syntax::SyntaxError;
use crate::io::text;
use crate::io::{ParseError, PointArray};

/// Reads the arrays of a `POINT_DATA` or `CELL_DATA` section (`n` tuples each) up to the next
/// keyword that is not one of its own (left for the caller). Arrays go to `out` (`None`:
/// read and dropped, for `CELL_DATA`); an unknown keyword is skipped with a warning.
pub(super) fn read_attributes(
    r: &mut Reader,
    n: u64,
    mut out: Option<&mut Vec<PointArray>>,
    warnings: &mut Vec<String>,
) -> Result<(), ParseError> {
    loop {
        let mut peek = r.c.clone();
        let Some(tok) = peek.next_token() else {
            return Ok(());
        };
        let kw = tok.to_ascii_uppercase();
        if SECTIONS.contains(&kw.as_slice()) && !matches!(kw.as_slice(), b"FIELD" | b"METADATA") {
            return Ok(());
        }
        r.c = peek;
        let line = r.c.line();
        let name = |r: &mut Reader| -> Result<String, ParseError> {
            let t = r.token(&|| "an array name".into())?;
            Ok(String::from_utf8_lossy(t).into_owned())
        };
        let values = |r: &mut Reader, comps: u64, ty: Num, what: &str| {
            let count = n.checked_mul(comps).ok_or_else(|| ParseError::Syntax {
                line,
                problem: SyntaxError::TooManyValues {
                    what: what.to_string(),
                    count: n,
                    components: comps,
                },
            })?;
            r.numbers(count, ty, what)
        };
        let mut keep = |a: PointArray| {
            if let Some(out) = out.as_deref_mut() {
                out.push(a);
            }
        };
        match kw.as_slice() {
            b"SCALARS" => {
                let name = name(r)?;
                let ty = r.num_type(&format!("SCALARS {name}"))?;
                // Optional component count on the same line, optional LOOKUP_TABLE line.
                let mut comps = 1u64;
                let mut peek = r.c.clone();
                if let Some(t) = peek.next_token() {
                    if peek.line() == line {
                        if let Some(k) = text::parse_count(t) {
                            comps = k;
                            r.c = peek;
                        }
                    }
                }
                if !(1..=4).contains(&comps) {
                    return Err(ParseError::Syntax {
                        line,
                        problem: SyntaxError::ScalarComponents {
                            name,
                            components: comps,
                        },
                    });
                }
                let mut peek = r.c.clone();
                if peek
                    .next_token()
                    .is_some_and(|t| t.eq_ignore_ascii_case(b"LOOKUP_TABLE"))
                {
                    r.c = peek;
                    r.token(&|| "the lookup table name".into())?;
                }
                let v = values(r, comps, ty, &format!("SCALARS {name}"))?;
                keep(array(name, comps as usize, v));
            }
            b"VECTORS" | b"NORMALS" | b"TENSORS" => {
                let comps = if kw.as_slice() == b"TENSORS" { 9 } else { 3 };
                let name = name(r)?;
                let what = format!("{} {name}", String::from_utf8_lossy(&kw));
                let ty = r.num_type(&what)?;
                let v = values(r, comps, ty, &what)?;
                keep(array(name, comps as usize, v));
            }
            b"TEXTURE_COORDINATES" => {
                let name = name(r)?;
                let dim = r.count("the texture coordinate dimension")?;
                if !(1..=3).contains(&dim) {
                    return Err(ParseError::Syntax {
                        line,
                        problem: SyntaxError::TextureDimension { name, dimension: dim },
                    });
                }
                let ty = r.num_type(&format!("TEXTURE_COORDINATES {name}"))?;
                let v = values(r, dim, ty, &format!("TEXTURE_COORDINATES {name}"))?;
                keep(array(name, dim as usize, v));
            }
            b"COLOR_SCALARS" => {
                let name = name(r)?;
                let comps = r.count(&format!("the component count of COLOR_SCALARS {name}"))?;
                if !(1..=4).contains(&comps) {
                    return Err(ParseError::Syntax {
                        line,
                        problem: SyntaxError::ColorComponents {
                            name,
                            components: comps,
                        },
                    });
                }
                // ASCII colours are floats in 0..1; binary ones unsigned chars.
                let ty = if r.binary { Num::U8 } else { Num::F64 };
                let v = values(r, comps, ty, &format!("COLOR_SCALARS {name}"))?;
                keep(array(name, comps as usize, v));
            }
            b"LOOKUP_TABLE" => {
                let name = name(r)?;
                let size = r.count(&format!("the size of LOOKUP_TABLE {name}"))?;
                let ty = if r.binary { Num::U8 } else { Num::F64 };
                r.numbers(size.saturating_mul(4), ty, &format!("LOOKUP_TABLE {name}"))?;
            }
            b"GLOBAL_IDS" | b"PEDIGREE_IDS" | b"EDGE_FLAGS" => {
                // Ids, not fields: read and dropped.
                let name = name(r)?;
                let what = format!("{} {name}", String::from_utf8_lossy(&kw));
                let ty = r.num_type(&what)?;
                values(r, 1, ty, &what)?;
            }
            b"FIELD" => {
                let arrays = read_field(r, Some(n))?;
                for a in arrays {
                    keep(a);
                }
            }
            b"METADATA" => {
                r.c.skip_line();
                while r.c.remaining() > 0 && !r.c.rest_of_line().trim_ascii().is_empty() {}
            }
            _ => {
                warnings.push(format!(
                    "skipped the unknown data section {} (line {line})",
                    text::show(tok)
                ));
                r.skip_unknown();
            }
        }
    }
}

/// Reads a `FIELD name k` block (after its keyword): `k` arrays `NAME components tuples type`.
/// With `tuples = Some(n)` each array must have `n` tuples (point data); `None` accepts any
/// count (dataset field data, whose arrays are then dropped: the result is empty).
pub(super) fn read_field(r: &mut Reader, tuples: Option<u64>) -> Result<Vec<PointArray>, ParseError> {
    let _field = r.token(&|| "the FIELD name".into())?;
    let k = r.count("the FIELD array count")?;
    let mut out = Vec::new();
    for _ in 0..k {
        let name = String::from_utf8_lossy(r.token(&|| "a FIELD array name".into())?).into_owned();
        let comps = r.count(&format!("the component count of {name}"))?;
        let n = r.count(&format!("the tuple count of {name}"))?;
        let ty_tok = r.token(&|| format!("the data type of {name}"))?;
        let at = r.c.line();
        if comps == 0 || comps > 1 << 20 {
            return Err(ParseError::Syntax {
                line: at,
                problem: SyntaxError::FieldComponents {
                    name,
                    components: comps,
                },
            });
        }
        if tuples.is_some_and(|t| t != n) {
            return Err(ParseError::Syntax {
                line: at,
                problem: SyntaxError::FieldTuples {
                    name,
                    tuples: n,
                    points: tuples.unwrap_or_default(),
                },
            });
        }
        let count = n.checked_mul(comps).ok_or_else(|| ParseError::Syntax {
            line: at,
            problem: SyntaxError::TooManyValues {
                what: format!("FIELD array {name}"),
                count: n,
                components: comps,
            },
        })?;
        let Some(ty) = Num::parse(Names::Vtk, ty_tok) else {
            // String arrays (ASCII: one token per value) are skipped; anything else is an error.
            if ty_tok.eq_ignore_ascii_case(b"string") && !r.binary {
                for _ in 0..count {
                    r.token(&|| format!("{count} strings of {name}"))?;
                }
                r.skip_metadata();
                continue;
            }
            return Err(ParseError::Syntax {
                line: at,
                problem: SyntaxError::DataType {
                    what: format!("FIELD array {name}"),
                    found: text::clip(ty_tok),
                },
            });
        };
        let values = r.numbers(count, ty, &name)?;
        if tuples.is_some() {
            out.push(array(name, comps as usize, values));
        }
    }
    Ok(out)
}

fn array(name: String, components: usize, values: Vec<f64>) -> PointArray {
    PointArray {
        name,
        components,
        values,
    }
}
