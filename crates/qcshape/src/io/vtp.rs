//! VTK XML PolyData (`.vtp`), what ParaView, VTK and pyvista write.
//!
//! Reads one `Piece`: `Points`, `Polys` (and `Strips`, converted to triangles; `Verts` and
//! `Lines` are skipped) and the `PointData` arrays, each `DataArray` in `ascii`, `binary`
//! (inline base64) or `appended` format (`raw` or `base64` encoding), uncompressed or
//! compressed with `vtkZLibDataCompressor`, `header_type` `UInt32` or `UInt64`, either byte
//! order. Every declared size is checked against the bytes present before anything is
//! allocated, and every error names the line (markup) or byte offset (data).
//!
//! Writes (also `.vtu`, an UnstructuredGrid of triangle cells) inline base64 `binary` arrays without compression (`Float64` points and fields,
//! `Int64` connectivity, `UInt64` headers, little endian): exact, and read by VTK, ParaView,
//! pyvista and meshio.

use std::io::Write;

use super::vtk::push_strip;
use super::xml::{b64_array, Document, Section};
use super::{FaceBuilder, Field, MeshData, ParseError};

pub(crate) fn parse(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let doc = Document::parse(bytes, "PolyData", ".vtp")?;
    let positions = doc.positions()?;
    let n = positions.len();
    let mut faces = FaceBuilder::default();
    let mut warnings = Vec::new();
    let n_polys = doc.count("NumberOfPolys")?;
    if n_polys > 0 {
        doc.each_cell(Section::Polys, n_polys, "Polys", n, |_, idx| {
            faces.push(idx, None)
        })?;
    }
    let n_strips = doc.count("NumberOfStrips")?;
    if n_strips > 0 {
        doc.each_cell(Section::Strips, n_strips, "Strips", n, |_, idx| {
            push_strip(&mut faces, idx, None)
        })?;
        warnings.push(format!("converted {n_strips} triangle strip(s) to triangles"));
    }
    let skipped = doc
        .count("NumberOfVerts")?
        .saturating_add(doc.count("NumberOfLines")?);
    if skipped > 0 {
        warnings.push(format!("ignored {skipped} Verts/Lines cell(s)"));
    }
    let point_data = doc.point_data(n)?;
    let faces = faces.finish(&positions, &mut warnings)?;
    Ok(MeshData {
        positions,
        faces,
        warnings,
        point_data,
    })
}

/// XML-escapes an attribute value.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Writes PolyData (`.vtp`), or an UnstructuredGrid (`.vtu`) of triangle cells if `grid`.
pub(crate) fn write(
    w: &mut dyn Write,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    fields: &[Field],
    grid: bool,
) -> std::io::Result<()> {
    let kind = if grid { "UnstructuredGrid" } else { "PolyData" };
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<VTKFile type=\"{kind}\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    )?;
    writeln!(w, "  <{kind}>")?;
    if grid {
        writeln!(
            w,
            "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
            positions.len(),
            faces.len()
        )?;
    } else {
        writeln!(
            w,
            "    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"{}\">",
            positions.len(),
            faces.len()
        )?;
    }
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
    let section = if grid { "Cells" } else { "Polys" };
    writeln!(
        w,
        "      <{section}>\n        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"binary\">\n          {}\n        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"binary\">\n          {}\n        </DataArray>",
        b64_array(&conn),
        b64_array(&offs)
    )?;
    if grid {
        // VTK_TRIANGLE (5) for every cell.
        writeln!(
            w,
            "        <DataArray type=\"UInt8\" Name=\"types\" format=\"binary\">\n          {}\n        </DataArray>",
            b64_array(&vec![5u8; faces.len()])
        )?;
    }
    writeln!(w, "      </{section}>\n    </Piece>\n  </{kind}>\n</VTKFile>")?;
    Ok(())
}
