//! VTK XML UnstructuredGrid (`.vtu`), the default unstructured format of meshio and pyvista.
//!
//! Reads one `Piece` through the XML layer shared with `.vtp` (`xml.rs`: every `DataArray`
//! format, encoding, compression, header type and byte order it reads): `Points`, the `Cells`
//! arrays `connectivity`, `offsets` and `types`, and the `PointData` arrays. Surface cells
//! become faces: triangles (VTK type 5), triangle strips (6), polygons (7) and quads (9), the
//! larger ones triangulated like every other reader's polygons. Vertex, poly-vertex, line and
//! polyline cells (types 1 to 4) are skipped with a warning, as `.vtp` skips `Verts` and
//! `Lines`; any other cell type (volume cells such as tetrahedra, quadratic cells) is refused
//! with [`ParseError::Unsupported`] ([`UnsupportedFeature::VtuCell`]) naming the first such cell, since qcshape compares
//! surfaces.

use super::vtk::push_strip;
use super::xml::{Document, Section};
use super::{FaceBuilder, MeshData, ParseError, UnsupportedFeature};

const VTK_VERTEX: i64 = 1;
const VTK_POLY_LINE: i64 = 4;
const VTK_TRIANGLE: i64 = 5;
const VTK_TRIANGLE_STRIP: i64 = 6;
const VTK_POLYGON: i64 = 7;
const VTK_QUAD: i64 = 9;

/// The name of a VTK cell type, for messages.
fn type_name(ty: i64) -> &'static str {
    match ty {
        8 => "pixel",
        10 => "tetrahedron",
        11 => "voxel",
        12 => "hexahedron",
        13 => "wedge",
        14 => "pyramid",
        21..=37 => "quadratic or higher-order cell",
        42 => "polyhedron",
        _ => "cell",
    }
}

pub(crate) fn parse(bytes: &[u8]) -> Result<MeshData, ParseError> {
    let doc = Document::parse(bytes, "UnstructuredGrid", ".vtu")?;
    let positions = doc.positions()?;
    let n = positions.len();
    let n_cells = doc.count("NumberOfCells")?;
    let mut faces = FaceBuilder::default();
    let mut warnings = Vec::new();
    if n_cells > 0 {
        let types_array = doc
            .array(Section::Cells, Some("types"))
            .ok_or_else(|| ParseError::Missing {
                what: "types array for its Cells".into(),
            })?;
        let types = doc.values(types_array, n_cells)?;
        let (mut skipped, mut strips) = (0usize, 0usize);
        doc.each_cell(Section::Cells, n_cells, "Cells", n, |k, idx| {
            // `values` returned exactly n_cells types, and there are n_cells cells.
            let t = types[k];
            let ty = if t.fract() == 0.0 && t.abs() < 1e9 {
                t as i64
            } else {
                -1
            };
            match ty {
                VTK_TRIANGLE | VTK_POLYGON | VTK_QUAD => faces.push(idx, None),
                VTK_TRIANGLE_STRIP => {
                    strips += 1;
                    push_strip(&mut faces, idx, None)
                }
                VTK_VERTEX..=VTK_POLY_LINE => {
                    skipped += 1;
                    Ok(())
                }
                _ => Err(ParseError::Unsupported(UnsupportedFeature::VtuCell {
                    cell: k,
                    name: type_name(ty),
                    vtk_type: t,
                })),
            }
        })?;
        if strips > 0 {
            warnings.push(format!("converted {strips} triangle strip(s) to triangles"));
        }
        if skipped > 0 {
            warnings.push(format!("ignored {skipped} vertex/line cell(s)"));
        }
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
