//! STL, ASCII and binary. STL stores each triangle's three corners separately (in `f32` for
//! binary); corners with bit-identical coordinates are welded into one vertex, in order of
//! first appearance, so the result is an indexed mesh, and then corners closer than
//! [`WELD_REL_TOL`] times the bounding box diagonal are welded too (counted in a warning, which
//! `qcshape info` shows). Facet normals are ignored. An ASCII STL must end with `endsolid`.
//!
//! A file is read as binary when its size is exactly `84 + 50 * count` for the count in its
//! header, or when it does not start with `solid` followed by text; otherwise as ASCII.

use std::collections::HashMap;
use std::io::Write;

use super::syntax::SyntaxError;
use super::text::{self, Cursor};
use super::{FaceBuilder, MeshData, ParseError};
use crate::mesh::geometry;

/// Welds corners with equal coordinates (`-0.0` equals `0.0`).
struct Welder {
    index: HashMap<[u64; 3], u32>,
    positions: Vec<[f64; 3]>,
}

impl Welder {
    fn new(cap: usize) -> Self {
        Welder {
            index: HashMap::with_capacity(cap),
            positions: Vec::with_capacity(cap),
        }
    }

    fn add(&mut self, p: [f64; 3]) -> u32 {
        let key = p.map(|c| (c + 0.0).to_bits());
        let positions = &mut self.positions;
        *self.index.entry(key).or_insert_with(|| {
            positions.push(p);
            (positions.len() - 1) as u32
        })
    }

    fn finish(mut self, mut faces: Vec<[u32; 3]>, mut warnings: Vec<String>) -> MeshData {
        let (map, welded) = weld_within_tolerance(&self.positions);
        if welded > 0 {
            let mut kept = Vec::with_capacity(self.positions.len() - welded);
            let mut new_index = vec![0u32; self.positions.len()];
            for (i, &m) in map.iter().enumerate() {
                if m as usize == i {
                    new_index[i] = kept.len() as u32;
                    kept.push(self.positions[i]);
                }
            }
            for f in &mut faces {
                *f = f.map(|v| new_index[map[v as usize] as usize]);
            }
            self.positions = kept;
            warnings.push(format!(
                "welded {welded} STL corner position(s) into a nearby one (closer than {WELD_REL_TOL:e} x the bounding box diagonal)"
            ));
        }
        let n_degenerate = faces
            .iter()
            .filter(|f| f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
            .count();
        if n_degenerate > 0 {
            warnings.push(format!(
                "{n_degenerate} STL triangle(s) have two identical corners after welding"
            ));
        }
        MeshData {
            positions: self.positions,
            faces,
            warnings,
            point_data: Vec::new(),
        }
    }
}

/// Corner positions of an STL file closer than this times the bounding box diagonal are one
/// vertex (after the exact welding): round-off in the exporter (single precision, or a few
/// printed digits) must not turn a closed surface into loose triangles.
pub const WELD_REL_TOL: f64 = 1e-7;

/// For each position (#V x 3), the first earlier position within [`WELD_REL_TOL`] times the
/// bounding box diagonal (itself if none), and the number of positions so mapped. Grid
/// hashing with cells of the tolerance: each point is compared with the points of the 27
/// cells around it. Nothing is welded when the box is not finite (the area check refuses
/// such meshes later).
fn weld_within_tolerance(p: &[[f64; 3]]) -> (Vec<u32>, usize) {
    let mut map: Vec<u32> = (0..p.len() as u32).collect();
    let (lo, hi) = geometry::bounding_box(p);
    let diag = geometry::norm(geometry::sub(hi, lo));
    let tol = WELD_REL_TOL * diag;
    if p.len() < 2 || !(tol.is_finite() && tol > 0.0) {
        return (map, 0);
    }
    let cell = |q: [f64; 3]| q.map(|c| ((c - lo[0].min(lo[1]).min(lo[2])) / tol).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::with_capacity(p.len());
    let mut welded = 0;
    for (i, &q) in p.iter().enumerate() {
        let c = cell(q);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        if let Some(&j) = list
                            .iter()
                            .find(|&&j| geometry::norm(geometry::sub(p[j as usize], q)) <= tol)
                        {
                            found = Some(j);
                            break 'search;
                        }
                    }
                }
            }
        }
        match found {
            Some(j) => {
                map[i] = j;
                welded += 1;
            }
            None => grid.entry(c).or_default().push(i as u32),
        }
    }
    (map, welded)
}

/// Whether the bytes look like an ASCII STL (`solid` then printable text).
fn looks_ascii(bytes: &[u8]) -> bool {
    let start = bytes
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(bytes.len());
    let b = &bytes[start..];
    if b.len() < 5 || !b[..5].eq_ignore_ascii_case(b"solid") {
        return false;
    }
    b.iter()
        .take(512)
        .all(|&c| c.is_ascii_graphic() || c.is_ascii_whitespace())
}

pub(crate) fn parse(bytes: &[u8]) -> Result<MeshData, ParseError> {
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        if 84 + 50 * n == bytes.len() as u64 {
            return parse_binary(bytes);
        }
    }
    if looks_ascii(bytes) {
        parse_ascii(bytes)
    } else {
        parse_binary(bytes)
    }
}

fn parse_binary(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let len = bytes.len() as u64;
    if bytes.len() < 84 {
        return Err(ParseError::Truncated {
            what: "the binary STL header (80 bytes and a triangle count)".into(),
            needed: 84,
            offset: 0,
            len,
        });
    }
    let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
    let needed = 50 * n;
    if 84 + needed > len {
        return Err(ParseError::Truncated {
            what: format!("{n} triangles (the count in the binary STL header)"),
            needed,
            offset: 84,
            len,
        });
    }
    let mut warnings = Vec::new();
    if 84 + needed < len {
        warnings.push(format!(
            "ignored {} bytes after the {n} triangles of the binary STL",
            len - 84 - needed
        ));
    }
    let n = n as usize;
    let mut welder = Welder::new(n / 2 + 3);
    let mut faces = Vec::with_capacity(n);
    for t in 0..n {
        let rec = &bytes[84 + 50 * t..84 + 50 * (t + 1)];
        let mut f = [0u32; 3];
        for (k, slot) in f.iter_mut().enumerate() {
            let mut p = [0.0; 3];
            for (c, v) in p.iter_mut().enumerate() {
                let o = 12 + 12 * k + 4 * c;
                *v = f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]]) as f64;
            }
            if p.iter().any(|v| !v.is_finite()) {
                return Err(corner_error(t, k, p, None));
            }
            *slot = welder.add(p);
        }
        faces.push(f);
    }
    Ok(welder.finish(faces, warnings))
}

fn corner_error(t: usize, k: usize, p: [f64; 3], line: Option<usize>) -> ParseError {
    let value = p.iter().copied().find(|c| !c.is_finite()).unwrap_or(f64::NAN);
    ParseError::NonFiniteCorner {
        triangle: t,
        corner: k,
        value,
        line,
    }
}

fn parse_ascii(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let mut c = Cursor::new(bytes, 1);
    let mut welder = Welder::new(text::capacity(u64::MAX, bytes.len(), 100));
    let mut faces = FaceBuilder::default();
    let mut poly: Vec<u32> = Vec::new();
    let mut in_loop = false;
    let mut loop_line = 0;
    let mut ended = false;
    while let Some(tok) = c.next_token() {
        ended = false;
        match tok {
            b"solid" => {
                c.rest_of_line();
            }
            b"endsolid" => {
                c.rest_of_line();
                ended = true;
            }
            b"outer" | b"loop" if !in_loop => {
                in_loop = true;
                loop_line = c.line();
                poly.clear();
            }
            b"vertex" => {
                if !in_loop {
                    in_loop = true;
                    loop_line = c.line();
                    poly.clear();
                }
                let t = faces.n_polygons();
                let k = poly.len();
                let mut p = [0.0; 3];
                for (v, axis) in p.iter_mut().zip(["x", "y", "z"]) {
                    let tok = c.next_token().ok_or_else(|| ParseError::UnexpectedEnd {
                        expected: format!("the {axis} coordinate of corner {k} of triangle {t}"),
                    })?;
                    *v = text::parse_f64(tok).ok_or_else(|| ParseError::Syntax {
                        line: c.line(),
                        problem: SyntaxError::CornerCoordinate {
                            triangle: t,
                            corner: k,
                            axis,
                            found: text::clip(tok),
                        },
                    })?;
                }
                if p.iter().any(|v| !v.is_finite()) {
                    return Err(corner_error(t, k, p, Some(c.line())));
                }
                poly.push(welder.add(p));
            }
            b"endloop" | b"endfacet" if in_loop => {
                in_loop = false;
                faces.push(&poly, Some(loop_line))?;
            }
            _ => {}
        }
    }
    if in_loop {
        return Err(ParseError::UnexpectedEnd {
            expected: format!("endloop for the facet starting at line {loop_line}"),
        });
    }
    if !ended {
        return Err(ParseError::UnexpectedEnd {
            expected: format!(
                "endsolid after the last facet (line {}): an ASCII STL ends with endsolid, so the file may be cut short",
                c.line()
            ),
        });
    }
    let mut warnings = Vec::new();
    let faces = faces.finish(&welder.positions, &mut warnings)?;
    Ok(welder.finish(faces, warnings))
}

/// Writes binary STL (positions rounded to `f32`, facet normals from the geometry).
pub(crate) fn write(w: &mut dyn Write, positions: &[[f64; 3]], faces: &[[u32; 3]]) -> std::io::Result<()> {
    let mut header = [b' '; 80];
    let tag = b"binary STL written by qcshape";
    header[..tag.len()].copy_from_slice(tag);
    w.write_all(&header)?;
    let n = u32::try_from(faces.len())
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, "too many faces for STL"))?;
    w.write_all(&n.to_le_bytes())?;
    for f in faces {
        let [p, q, r] = f.map(|i| positions[i as usize]);
        let nrm = geometry::cross(geometry::sub(q, p), geometry::sub(r, p));
        let l = geometry::norm(nrm);
        let nrm = if l > 0.0 {
            geometry::scale(nrm, 1.0 / l)
        } else {
            [0.0; 3]
        };
        for v in [nrm, p, q, r] {
            for c in v {
                w.write_all(&(c as f32).to_le_bytes())?;
            }
        }
        w.write_all(&[0, 0])?;
    }
    Ok(())
}
