//! Files written by meshio and pyvista (tests/fixtures, made by make_fixtures.py) are read with
//! the right vertices, faces and point arrays; qcshape's own VTK, VTP and PLY fields read back.

use std::path::PathBuf;

use qcshape::io::{self, Field, Format, MeshData, ParseError};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

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

fn check_octahedron(d: &MeshData, what: &str) {
    assert_eq!(d.positions, POINTS, "{what}");
    assert_eq!(d.faces, FACES, "{what}");
    let h = d
        .point_array("height")
        .unwrap_or_else(|| panic!("{what}: no height"));
    assert_eq!(h.components, 1, "{what}");
    let want: Vec<f64> = POINTS.iter().map(|p| p[2] + 0.5).collect();
    assert_eq!(h.values, want, "{what}");
    let disp = d.point_array("disp").unwrap_or_else(|| panic!("{what}: no disp"));
    let want: Vec<[f64; 3]> = POINTS
        .iter()
        .map(|p| [0.1 * p[0], 0.2 * p[1], 0.3 * p[2]])
        .collect();
    assert_eq!(disp.as_vectors().unwrap(), want, "{what}");
}

#[test]
fn meshio_and_pyvista_fixtures_read_with_points_faces_and_arrays() {
    for name in [
        "octa_meshio_ascii.vtk",
        "octa_meshio_binary.vtk",
        "octa_meshio_42.vtk",
        "octa_pyvista_ascii.vtp",
        "octa_pyvista_binary.vtp",
        "octa_vtk_binary_raw.vtp",
        "octa_vtk_appended_zlib.vtp",
        "octa_vtk_appended_base64_zlib.vtp",
        "octa_meshio.vtu",
        "octa_meshio_ascii.vtu",
        "octa_vtk_appended_zlib.vtu",
        "octa_pyvista_metadata_ascii.vtk",
        "octa_pyvista_metadata_binary.vtk",
    ] {
        let d = io::read_mesh(&fixture(name)).unwrap_or_else(|e| panic!("{e}"));
        check_octahedron(&d, name);
        let s = io::load_shape(&fixture(name)).unwrap();
        assert_eq!(s.n_vertices(), 6);
    }
}

#[test]
fn written_fields_read_back_from_vtk_and_vtp_and_ply_has_quality() {
    let height: Vec<f64> = POINTS.iter().map(|p| p[2] + 0.5).collect();
    let disp: Vec<[f64; 3]> = POINTS
        .iter()
        .map(|p| [0.1 * p[0], 0.2 * p[1], 0.3 * p[2]])
        .collect();
    let fields = [Field::scalar("height", &height), Field::vector("disp", &disp)];
    let dir = tempfile::tempdir().unwrap();
    for ext in ["vtk", "vtp"] {
        let path = dir.path().join(format!("o.{ext}"));
        io::write_mesh_fields(&path, &POINTS, &FACES, &fields).unwrap();
        check_octahedron(&io::read_mesh(&path).unwrap(), ext);
    }
    let path = dir.path().join("o.ply");
    io::write_mesh_fields(&path, &POINTS, &FACES, &fields).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.contains(
        "property double quality\nproperty double height\nproperty double disp_x\nproperty double disp_y\nproperty double disp_z\n"
    ));
    assert_eq!(io::read_mesh(&path).unwrap().positions, POINTS);
    // OBJ cannot hold fields; duplicate names are refused.
    let e = io::write_mesh_fields(&dir.path().join("o.obj"), &POINTS, &FACES, &fields).unwrap_err();
    assert!(e.to_string().contains("cannot store"), "{e}");
    let dup = [Field::scalar("a", &height), Field::scalar("a", &height)];
    let e = io::write_mesh_fields(&dir.path().join("d.vtk"), &POINTS, &FACES, &dup).unwrap_err();
    assert!(e.to_string().contains("two fields"), "{e}");
}

#[test]
fn broken_vtp_and_unstructured_grids_are_typed_errors_with_positions() {
    let good = std::fs::read(fixture("octa_pyvista_binary.vtp")).unwrap();
    let text = String::from_utf8(good.clone()).unwrap();
    // A corrupted base64 character inside the points.
    let bad = text.replacen("eF5jYACBD", "eF5*YACBD", 1);
    let e = io::parse_mesh(bad.as_bytes(), Format::Vtp).unwrap_err();
    assert!(e.to_string().contains("byte offset"), "{e}");
    // Declaring more points than the data holds.
    let bad = text.replacen("NumberOfPoints=\"6\"", "NumberOfPoints=\"7\"", 1);
    let e = io::parse_mesh(bad.as_bytes(), Format::Vtp).unwrap_err();
    assert!(matches!(e, ParseError::DataArray { .. }), "{e}");
    // An unterminated tag names its line.
    let e = io::parse_mesh(&good[..good.len() / 3], Format::Vtp).unwrap_err();
    assert!(
        matches!(e, ParseError::Syntax { .. } | ParseError::Missing { .. }),
        "{e}"
    );
    // Appended raw zlib data cut short.
    let app = std::fs::read(fixture("octa_vtk_appended_zlib.vtp")).unwrap();
    let e = io::parse_mesh(&app[..app.len() - 60], Format::Vtp).unwrap_err();
    assert!(
        matches!(e, ParseError::Truncated { .. } | ParseError::DataArray { .. }),
        "{e}"
    );
    // Every prefix of every fixture is an error or a mesh, never a panic.
    for name in [
        "octa_vtk_appended_base64_zlib.vtp",
        "octa_meshio_binary.vtk",
        "octa_pyvista_ascii.vtp",
    ] {
        let b = std::fs::read(fixture(name)).unwrap();
        let f = Format::from_path(std::path::Path::new(name)).unwrap();
        for k in 0..b.len() {
            let _ = io::parse_mesh(&b[..k], f);
        }
    }
    // An UNSTRUCTURED_GRID without CELL_TYPES.
    let s = "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 double\n0 0 0 1 0 0 0 1 0\nCELLS 1 4\n3 0 1 2\n";
    let e = io::parse_mesh(s.as_bytes(), Format::Vtk).unwrap_err();
    assert!(e.to_string().contains("CELL_TYPES"), "{e}");
    // Tetrahedra are skipped with a warning, triangles kept.
    let s = "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 2 9\n3 0 1 2\n4 0 1 2 3\nCELL_TYPES 2\n5\n10\n";
    let d = io::parse_mesh(s.as_bytes(), Format::Vtk).unwrap();
    assert_eq!(d.faces, vec![[0, 1, 2]]);
    assert!(d.warnings[0].contains("1 of type 10"), "{:?}", d.warnings);
}
