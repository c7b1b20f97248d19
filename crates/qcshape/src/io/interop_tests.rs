//! Files as other tools write them: legacy VTK with `METADATA` blocks, unknown sections and
//! `CELL_DATA`; `.vtu` in every `DataArray` layout (ascii, inline base64, appended raw and
//! base64, zlib, 32- and 64-bit headers); point fields from PLY, VTK, VTP and VTU; corrupt
//! XML header words that once panicked.

use std::io::Write;

use super::*;

const POINTS: [[f64; 3]; 6] = [
    [1.0, 0.0, 0.0],
    [-1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, -1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0],
];
const FACES: [[u32; 3]; 8] = [
    [0, 2, 4],
    [2, 1, 4],
    [1, 3, 4],
    [3, 0, 4],
    [2, 0, 5],
    [1, 2, 5],
    [3, 1, 5],
    [0, 3, 5],
];

fn height() -> Vec<f64> {
    POINTS.iter().map(|p| p[2] + 0.5).collect()
}

fn disp() -> Vec<[f64; 3]> {
    POINTS
        .iter()
        .map(|p| [0.1 * p[0], 0.2 * p[1], 0.3 * p[2]])
        .collect()
}

fn check(d: &MeshData, what: &str) {
    assert_eq!(d.positions, POINTS, "{what}");
    assert_eq!(d.faces, FACES, "{what}");
    let h = d
        .point_array("height")
        .unwrap_or_else(|| panic!("{what}: no height"));
    assert_eq!((h.components, &h.values), (1, &height()), "{what}");
    let v = d.point_array("disp").unwrap_or_else(|| panic!("{what}: no disp"));
    assert_eq!(v.as_vectors().unwrap(), disp(), "{what}");
}

/// An ASCII legacy VTK POLYDATA octahedron; `after_points` goes right after the points,
/// `before_point_data` before `POINT_DATA`.
fn legacy(after_points: &str, before_point_data: &str) -> String {
    let mut s =
        String::from("# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET POLYDATA\nPOINTS 6 float\n");
    for p in POINTS {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    s += after_points;
    s += "\nPOLYGONS 9 24\nOFFSETS vtktypeint64\n0 3 6 9 12 15 18 21 24\nCONNECTIVITY vtktypeint64\n";
    for f in FACES {
        s += &format!("{} {} {}\n", f[0], f[1], f[2]);
    }
    s += before_point_data;
    s += "\nPOINT_DATA 6\nSCALARS height double 1\nLOOKUP_TABLE default\n";
    for h in height() {
        s += &format!("{h}\n");
    }
    s += "METADATA\nINFORMATION 1\nNAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 0.5 1.5 \n\n";
    s += "NORMALS disp double\n";
    for d in disp() {
        s += &format!("{} {} {}\n", d[0], d[1], d[2]);
    }
    s += "METADATA\nCOMPONENT_NAMES\nX\nY\nZ\nINFORMATION 0\n\n";
    s
}

const METADATA: &str = "\nMETADATA\nINFORMATION 2\nNAME L2_NORM_RANGE LOCATION vtkDataArray\n\
DATA 2 1 1 \nNAME L2_NORM_FINITE_RANGE LOCATION vtkDataArray\nDATA 2 1 1 \n\n";

#[test]
fn vtk_metadata_after_points_and_arrays_is_skipped() {
    let d = parse_mesh(legacy(METADATA, "").as_bytes(), Format::Vtk).unwrap();
    check(&d, "METADATA after POINTS");
    assert!(d.warnings.is_empty(), "{:?}", d.warnings);
    // At the end of the file without the closing empty line, too.
    let mut s = legacy(METADATA, "");
    s.truncate(s.trim_end().len());
    check(
        &parse_mesh(s.as_bytes(), Format::Vtk).unwrap(),
        "METADATA at the end",
    );
}

#[test]
fn vtk_binary_metadata_after_points_is_skipped() {
    let mut b =
        b"# vtk DataFile Version 4.2\nvtk output\nBINARY\nDATASET POLYDATA\nPOINTS 6 float\n".to_vec();
    for p in POINTS {
        for c in p {
            b.extend_from_slice(&(c as f32).to_be_bytes());
        }
    }
    b.extend_from_slice(METADATA.as_bytes());
    b.extend_from_slice(b"POLYGONS 8 32\n");
    for f in FACES {
        for v in [3, f[0], f[1], f[2]] {
            b.extend_from_slice(&(v as i32).to_be_bytes());
        }
    }
    b.extend_from_slice(b"\n");
    let d = parse_mesh(&b, Format::Vtk).unwrap();
    assert_eq!(
        (d.positions.as_slice(), d.faces.as_slice()),
        (&POINTS[..], &FACES[..])
    );
}

#[test]
fn vtk_unknown_sections_cell_data_and_field_data_are_skipped() {
    // Dataset field data before POINTS, an unknown section after them, CELL_DATA before
    // POINT_DATA (the order VTK writes).
    let mut s = legacy(
        "\nFANCY_SECTION 2 float\n1 2\n3 4\n",
        "\nCELL_DATA 8\nSCALARS id int 1\nLOOKUP_TABLE default\n0 1 2 3 4 5 6 7\n\
         FIELD FieldData 1\narea 1 8 double\n1 1 1 1 1 1 1 1\nMETADATA\nINFORMATION 0\n\n",
    );
    s = s.replacen(
        "DATASET POLYDATA\n",
        "DATASET POLYDATA\nFIELD FieldData 2\nTIME 1 1 double\n2.5\nnames 1 2 string\nleft right\n",
        1,
    );
    let d = parse_mesh(s.as_bytes(), Format::Vtk).unwrap();
    check(&d, "unknown sections");
    assert_eq!(d.point_data.len(), 2, "cell data is not point data");
    assert!(
        d.warnings.iter().any(|w| w.contains("FANCY_SECTION")),
        "{:?}",
        d.warnings
    );
    // An unknown section inside POINT_DATA is skipped up to the next known keyword.
    let s = legacy("", "").replacen("\nPOINT_DATA 6\n", "\nPOINT_DATA 6\nBLOB_ARRAY x 3\n1 2 3\n", 1);
    let d = parse_mesh(s.as_bytes(), Format::Vtk).unwrap();
    check(&d, "unknown point data");
    assert!(
        d.warnings.iter().any(|w| w.contains("BLOB_ARRAY")),
        "{:?}",
        d.warnings
    );
    // Garbage is still an error, not a section.
    let s = legacy("", "").replacen("\nPOLYGONS", "\n!!garbage\nPOLYGONS", 1);
    let e = parse_mesh(s.as_bytes(), Format::Vtk).unwrap_err();
    assert!(e.to_string().contains("garbage"), "{e}");
}

/// How the `.vtu` test files store their arrays.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Layout {
    Ascii,
    Binary,
    AppendedRaw,
    AppendedBase64,
}

/// One array's bytes as VTK stores them: a header (byte count; or block count, sizes and
/// compressed sizes with zlib), then the data (compressed with zlib).
fn block(data: &[u8], header64: bool, zlib: bool) -> (Vec<u8>, Vec<u8>) {
    let word = |v: u64| {
        if header64 {
            v.to_le_bytes().to_vec()
        } else {
            (v as u32).to_le_bytes().to_vec()
        }
    };
    if !zlib {
        return (word(data.len() as u64), data.to_vec());
    }
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(data).unwrap();
    let comp = z.finish().unwrap();
    let head = [1, data.len() as u64, data.len() as u64, comp.len() as u64]
        .into_iter()
        .flat_map(word)
        .collect();
    (head, comp)
}

fn vtu(layout: Layout, header64: bool, zlib: bool, types: &[u8]) -> Vec<u8> {
    let f64s = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let points: Vec<f64> = POINTS.iter().flatten().copied().collect();
    let conn: Vec<u8> = FACES
        .iter()
        .flatten()
        .flat_map(|&i| (i as i64).to_le_bytes())
        .collect();
    let offs: Vec<u8> = (1..=8i64).flat_map(|k| (3 * k).to_le_bytes()).collect();
    let dispv: Vec<f64> = disp().into_iter().flatten().collect();
    let arrays: Vec<(&str, &str, usize, Vec<u8>, String)> = vec![
        ("Points", "Float64", 3, f64s(&points), format!("{points:?}")),
        ("connectivity", "Int64", 1, conn, format!("{FACES:?}")),
        ("offsets", "Int64", 1, offs, "3 6 9 12 15 18 21 24".into()),
        ("types", "UInt8", 1, types.to_vec(), format!("{types:?}")),
        ("height", "Float64", 1, f64s(&height()), format!("{:?}", height())),
        ("disp", "Float64", 3, f64s(&dispv), format!("{dispv:?}")),
    ];
    let mut appended = Vec::new();
    let mut tags = Vec::new();
    for (name, ty, comps, data, text) in arrays {
        let open = format!("<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{comps}\"");
        let (head, body) = block(&data, header64, zlib);
        tags.push(match layout {
            Layout::Ascii => {
                let text: String = text
                    .chars()
                    .map(|c| if "[](),".contains(c) { ' ' } else { c })
                    .collect();
                format!("{open} format=\"ascii\">\n{text}\n</DataArray>")
            }
            Layout::Binary => {
                let enc = if zlib {
                    xml_b64(&head) + &xml_b64(&body)
                } else {
                    xml_b64(&[head, body].concat())
                };
                format!("{open} format=\"binary\">\n  {enc}\n</DataArray>")
            }
            Layout::AppendedRaw | Layout::AppendedBase64 => {
                let tag = format!("{open} format=\"appended\" offset=\"{}\"/>", appended.len());
                if layout == Layout::AppendedRaw {
                    appended.extend_from_slice(&head);
                    appended.extend_from_slice(&body);
                } else if zlib {
                    appended.extend_from_slice((xml_b64(&head) + &xml_b64(&body)).as_bytes());
                } else {
                    appended.extend_from_slice(xml_b64(&[head, body].concat()).as_bytes());
                }
                tag
            }
        });
    }
    let mut s = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"{}\"{}>\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"6\" NumberOfCells=\"8\">\n",
        if header64 { "UInt64" } else { "UInt32" },
        if zlib { " compressor=\"vtkZLibDataCompressor\"" } else { "" }
    );
    s += &format!(
        "<PointData Scalars=\"height\">\n{}\n{}\n</PointData>\n",
        tags[4], tags[5]
    );
    s += &format!("<Points>\n{}\n</Points>\n", tags[0]);
    s += &format!(
        "<Cells>\n{}\n{}\n{}\n</Cells>\n</Piece>\n</UnstructuredGrid>\n",
        tags[1], tags[2], tags[3]
    );
    let mut out = s.into_bytes();
    if !appended.is_empty() {
        let enc = if layout == Layout::AppendedRaw {
            "raw"
        } else {
            "base64"
        };
        out.extend_from_slice(format!("<AppendedData encoding=\"{enc}\">\n_").as_bytes());
        out.extend_from_slice(&appended);
        out.extend_from_slice(b"\n</AppendedData>\n");
    }
    out.extend_from_slice(b"</VTKFile>\n");
    out
}

/// Base64 of `data` (the XML layer's own encoder adds a length word).
fn xml_b64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in data.chunks(3) {
        let v = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            s.push(if k <= c.len() {
                T[(v >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    s
}

#[test]
fn vtu_in_every_layout_reads_points_triangles_and_point_data() {
    let tri = [5u8; 8];
    for layout in [
        Layout::Ascii,
        Layout::Binary,
        Layout::AppendedRaw,
        Layout::AppendedBase64,
    ] {
        for header64 in [false, true] {
            for zlib in [false, true] {
                if layout == Layout::Ascii && (zlib || header64) {
                    continue;
                }
                let what = format!("{layout:?}, 64-bit header {header64}, zlib {zlib}");
                let d = parse_mesh(&vtu(layout, header64, zlib, &tri), Format::Vtu)
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
                check(&d, &what);
            }
        }
    }
}

#[test]
fn vtu_written_by_qcshape_reads_back_with_fields() {
    let h = height();
    let v = disp();
    let fields = [Field::scalar("height", &h), Field::vector("disp", &v)];
    let bytes =
        encode_mesh_with_fields(Format::Vtu, &POINTS, &FACES, &fields, &WriteOptions::default()).unwrap();
    assert!(String::from_utf8_lossy(&bytes).contains("type=\"UnstructuredGrid\""));
    check(&parse_mesh(&bytes, Format::Vtu).unwrap(), "qcshape .vtu");
}

#[test]
fn vtu_cells_other_than_surfaces_are_refused_or_skipped() {
    // A tetrahedron cell (type 10) is refused, naming the cell and its type.
    let mut types = [5u8; 8];
    types[3] = 10;
    let e = parse_mesh(&vtu(Layout::Ascii, false, false, &types), Format::Vtu).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, ParseError::Unsupported(_)), "{msg}");
    assert!(
        msg.contains("cell 3") && msg.contains("tetrahedron") && msg.contains("type 10"),
        "{msg}"
    );
    // A polyline (type 4) is skipped with a warning; a polygon (7) is read as a face.
    types[3] = 4;
    types[4] = 7;
    let d = parse_mesh(&vtu(Layout::Binary, false, true, &types), Format::Vtu).unwrap();
    assert_eq!(d.faces.len(), 7);
    assert!(
        d.warnings.iter().any(|w| w.contains("1 vertex/line")),
        "{:?}",
        d.warnings
    );
    // Not an UnstructuredGrid.
    let pd = String::from_utf8(vtu(Layout::Ascii, false, false, &[5; 8]))
        .unwrap()
        .replace("UnstructuredGrid", "PolyData");
    let e = parse_mesh(pd.as_bytes(), Format::Vtu).unwrap_err();
    assert!(e.to_string().contains("only UnstructuredGrid"), "{e}");
}

#[test]
fn huge_xml_header_words_are_errors_not_panics() {
    // The byte count word of an uncompressed array, and the block count of a compressed one,
    // set to values near 2^64 (which overflowed the sums of the header arithmetic).
    for (zlib, word) in [
        (false, u64::MAX),
        (true, u64::MAX - 2),
        (true, u64::MAX),
        (true, 1 << 62),
    ] {
        for layout in [Layout::Binary, Layout::AppendedRaw] {
            let good = vtu(layout, true, zlib, &[5; 8]);
            // The first array's first header word.
            let mut bad = good.clone();
            if layout == Layout::AppendedRaw {
                let at = bad.windows(2).position(|w| w == b"\n_").unwrap() + 2;
                bad[at..at + 8].copy_from_slice(&word.to_le_bytes());
            } else {
                let text = String::from_utf8(bad).unwrap();
                let start = text.find("format=\"binary\">\n  ").unwrap() + 19;
                // Replace the first 12 characters (the 8-byte word and one more byte), keeping
                // the stream aligned.
                let mut raw = [0u8; 9];
                raw[..8].copy_from_slice(&word.to_le_bytes());
                bad = format!("{}{}{}", &text[..start], xml_b64(&raw), &text[start + 12..]).into_bytes();
            }
            let r = std::panic::catch_unwind(|| parse_mesh(&bad, Format::Vtu));
            let r = r.unwrap_or_else(|_| panic!("{layout:?} zlib {zlib} word {word}: panicked"));
            assert!(r.is_err(), "{layout:?} zlib {zlib} word {word}: accepted");
        }
    }
}

#[test]
fn point_fields_come_back_from_ply_vtk_vtp_and_vtu() {
    let h = height();
    let v = disp();
    let fields = [Field::scalar("height", &h), Field::vector("disp", &v)];
    for format in [Format::Ply, Format::Vtk, Format::Vtp, Format::Vtu] {
        for ply_encoding in [PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian] {
            let options = WriteOptions { ply_encoding };
            let bytes = encode_mesh_with_fields(format, &POINTS, &FACES, &fields, &options).unwrap();
            let d = parse_mesh(&bytes, format).unwrap();
            check(&d, &format!("{format} {ply_encoding:?}"));
            if format == Format::Ply {
                // PLY also holds the first scalar as `quality` (MeshLab).
                let names: Vec<&str> = d.point_data.iter().map(|a| a.name.as_str()).collect();
                assert_eq!(names, ["quality", "height", "disp"], "{ply_encoding:?}");
            }
        }
    }
    // PLY: normals and colours as trimesh writes them, a list property is ignored.
    let ply =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty list uchar int extra\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0 0 0 1 10 2 7 8\n1 0 0 0 0 1 20 0\n0 1 0 0 0 1 30 1 9\n3 0 1 2\n";
    let d = parse_mesh(ply.as_bytes(), Format::Ply).unwrap();
    let names: Vec<(&str, usize)> = d
        .point_data
        .iter()
        .map(|a| (a.name.as_str(), a.components))
        .collect();
    assert_eq!(names, [("normals", 3), ("red", 1)]);
    assert_eq!(d.point_data[0].values, [0., 0., 1., 0., 0., 1., 0., 0., 1.]);
    assert_eq!(d.point_data[1].values, [10., 20., 30.]);
}
