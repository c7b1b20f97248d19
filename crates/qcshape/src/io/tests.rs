//! Round-trip and bad-input tests for every format.

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::synth;

/// A small closed mesh with "awkward" coordinates (no short decimal expansions).
fn sample() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let s = synth::icosphere(1);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let pos = s
        .positions
        .iter()
        .map(|p| p.map(|c| c * 1.7 + rng.random_range(-1e-3..1e-3) + 1e-9 / 3.0))
        .collect();
    (pos, s.topology.faces().to_vec())
}

fn encode(format: Format, pos: &[[f64; 3]], faces: &[[u32; 3]], enc: PlyEncoding) -> Vec<u8> {
    let opts = WriteOptions { ply_encoding: enc };
    encode_mesh(format, pos, faces, &VertexAttributes::default(), &opts).unwrap()
}

fn assert_same_bits(a: &[[f64; 3]], b: &[[f64; 3]]) {
    assert_eq!(a.len(), b.len());
    for (i, (p, q)) in a.iter().zip(b).enumerate() {
        assert_eq!(
            p.map(f64::to_bits),
            q.map(f64::to_bits),
            "vertex {i}: {p:?} vs {q:?}"
        );
    }
}

#[test]
fn round_trip_exact_formats() {
    let (pos, faces) = sample();
    let cases = [
        (Format::Obj, PlyEncoding::default()),
        (Format::Off, PlyEncoding::default()),
        (Format::Vtk, PlyEncoding::default()),
        (Format::Ply, PlyEncoding::Ascii),
        (Format::Ply, PlyEncoding::BinaryLittleEndian),
        (Format::Ply, PlyEncoding::BinaryBigEndian),
    ];
    for (format, enc) in cases {
        let bytes = encode(format, &pos, &faces, enc);
        let m = parse_mesh(&bytes, format).unwrap_or_else(|e| panic!("{format} {enc:?}: {e}"));
        assert_same_bits(&m.positions, &pos);
        assert_eq!(m.faces, faces, "{format} {enc:?}");
        assert!(m.warnings.is_empty(), "{format} {enc:?}: {:?}", m.warnings);
    }
}

#[test]
fn ply_encodings_are_what_they_say() {
    let (pos, faces) = sample();
    let be = encode(Format::Ply, &pos, &faces, PlyEncoding::BinaryBigEndian);
    let le = encode(Format::Ply, &pos, &faces, PlyEncoding::BinaryLittleEndian);
    let start = |b: &[u8]| b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let (sb, sl) = (start(&be), start(&le));
    assert_eq!(&be[sb..sb + 8], &pos[0][0].to_be_bytes());
    assert_eq!(&le[sl..sl + 8], &pos[0][0].to_le_bytes());
    assert!(String::from_utf8_lossy(&be[..sb]).contains("format binary_big_endian 1.0"));
}

#[test]
fn round_trip_binary_stl_welds_corners() {
    let (pos, faces) = sample();
    // STL stores f32: use f32-representable positions so the round trip is exact.
    let pos: Vec<[f64; 3]> = pos.iter().map(|p| p.map(|c| c as f32 as f64)).collect();
    let bytes = encode(Format::Stl, &pos, &faces, PlyEncoding::default());
    assert_eq!(bytes.len(), 84 + 50 * faces.len());
    let m = parse_mesh(&bytes, Format::Stl).unwrap();
    assert_eq!(m.positions.len(), pos.len(), "welding restores the indexed mesh");
    assert_eq!(m.faces.len(), faces.len());
    for (f, g) in faces.iter().zip(&m.faces) {
        for k in 0..3 {
            assert_eq!(pos[f[k] as usize], m.positions[g[k] as usize]);
        }
    }
    // Welding in order of first appearance makes it a valid closed surface again.
    let topo = Topology::new(m.positions.len(), m.faces.clone()).unwrap();
    assert_eq!(topo.genus(), Some(0));
}

#[test]
fn ascii_stl_quad_and_solid_named_vertex() {
    let src = "solid vertex\n\
        facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 1 1 0\n endloop\nendfacet\n\
        facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 1 0\n  vertex 0 1 0\n endloop\nendfacet\n\
        endsolid vertex\n";
    let m = parse_mesh(src.as_bytes(), Format::Stl).unwrap();
    assert_eq!(
        m.positions,
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
    );
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    // A loop with 4 corners is fan-triangulated with a warning.
    let quad = "solid q\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\n\
        vertex 0 1 0\nendloop\nendfacet\nendsolid q\n";
    let m = parse_mesh(quad.as_bytes(), Format::Stl).unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(
        m.warnings[0].contains("fan-triangulated 1 polygon"),
        "{:?}",
        m.warnings
    );
}

const QUAD_POSITIONS: [[f64; 3]; 6] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [2.0, 0.0, 0.0],
    [2.0, 1.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];
/// Two quads sharing an edge, fan-triangulated.
const QUAD_TRIANGLES: [[u32; 3]; 4] = [[0, 1, 4], [0, 4, 5], [1, 2, 3], [1, 3, 4]];

fn check_quads(m: &MeshData, what: &str) {
    assert_eq!(m.positions, QUAD_POSITIONS, "{what}");
    assert_eq!(m.faces, QUAD_TRIANGLES, "{what}");
    assert!(
        m.warnings
            .iter()
            .any(|w| w.contains("fan-triangulated 2 polygon")),
        "{what}: {:?}",
        m.warnings
    );
}

#[test]
fn quads_are_fan_triangulated_in_every_text_format() {
    let obj = "# quads\nmtllib x.mtl\no thing\n\
        v 0 0 0\nv 1 0 0\nv 2 0 0\nvt 0 0\nvn 0 0 1\nv 2 1 0\nv 1 1 0\nv 0 1 0\n\
        g group\ns off\nusemtl m\nf 1/1/1 2/1/1 5/1/1 6/1/1\nf -5//1 -4//1 -3//1 -2//1\nl 1 2\n";
    check_quads(&parse_mesh(obj.as_bytes(), Format::Obj).unwrap(), "obj");

    let off = "OFF\n# comment\n6 2 0\n0 0 0\n1 0 0\n2 0 0 # trailing\n2 1 0\n1 1 0\n0 1 0\n\n\
        4 0 1 4 5\n4 1 2 3 4\n";
    check_quads(&parse_mesh(off.as_bytes(), Format::Off).unwrap(), "off");

    let ply = "ply\nformat ascii 1.0\ncomment c\nelement vertex 6\nproperty float x\nproperty float y\n\
        property float z\nproperty uchar red\nelement edge 1\nproperty int a\nproperty list uchar int b\n\
        element face 2\nproperty int flags\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 9\n1 0 0 9\n2 0 0 9\n2 1 0 9\n1 1 0 9\n0 1 0 9\n7 2 1 2\n0 4 0 1 4 5\n0 4 1 2 3 4\n";
    check_quads(&parse_mesh(ply.as_bytes(), Format::Ply).unwrap(), "ply");

    let vtk = "# vtk DataFile Version 3.0\nquads\nASCII\nDATASET POLYDATA\nPOINTS 6 float\n\
        0 0 0 1 0 0 2 0 0\n2 1 0 1 1 0 0 1 0\nLINES 1 3\n2 0 1\nPOLYGONS 2 10\n4 0 1 4 5\n4 1 2 3 4\n\
        POINT_DATA 6\nSCALARS s float 1\nLOOKUP_TABLE default\n0 0 0 0 0 0\n";
    check_quads(&parse_mesh(vtk.as_bytes(), Format::Vtk).unwrap(), "vtk");

    // VTK 5.1 layout with OFFSETS / CONNECTIVITY.
    let vtk51 = "# vtk DataFile Version 5.1\nquads\nASCII\nDATASET POLYDATA\nPOINTS 6 double\n\
        0 0 0 1 0 0 2 0 0\n2 1 0 1 1 0 0 1 0\nPOLYGONS 3 8\nOFFSETS vtktypeint64\n0 4 8\n\
        CONNECTIVITY vtktypeint64\n0 1 4 5 1 2 3 4\n";
    check_quads(&parse_mesh(vtk51.as_bytes(), Format::Vtk).unwrap(), "vtk 5.1");
}

#[test]
fn binary_ply_with_mixed_types_and_quads() {
    // Vertex: uchar tag, float x/y/z (big endian); face: list ushort uint + trailing short.
    let header = "ply\nformat binary_big_endian 1.0\nelement vertex 6\nproperty uchar tag\n\
        property float x\nproperty float y\nproperty float z\nelement face 2\n\
        property list ushort uint vertex_index\nproperty short extra\nend_header\n";
    let mut b = header.as_bytes().to_vec();
    for p in QUAD_POSITIONS {
        b.push(1);
        for c in p {
            b.extend_from_slice(&(c as f32).to_be_bytes());
        }
    }
    for q in [[0u32, 1, 4, 5], [1, 2, 3, 4]] {
        b.extend_from_slice(&4u16.to_be_bytes());
        for i in q {
            b.extend_from_slice(&i.to_be_bytes());
        }
        b.extend_from_slice(&(-3i16).to_be_bytes());
    }
    check_quads(&parse_mesh(&b, Format::Ply).unwrap(), "binary ply");
}

#[test]
fn binary_vtk_big_endian() {
    let mut b = b"# vtk DataFile Version 3.0\nbinary\nBINARY\nDATASET POLYDATA\nPOINTS 6 double\n".to_vec();
    for p in QUAD_POSITIONS {
        for c in p {
            b.extend_from_slice(&c.to_be_bytes());
        }
    }
    b.extend_from_slice(b"\nPOLYGONS 2 10\n");
    for q in [[0i32, 1, 4, 5], [1, 2, 3, 4]] {
        b.extend_from_slice(&4i32.to_be_bytes());
        for i in q {
            b.extend_from_slice(&i.to_be_bytes());
        }
    }
    b.extend_from_slice(b"\nCELL_DATA 2\n");
    check_quads(&parse_mesh(&b, Format::Vtk).unwrap(), "binary vtk");
    // Truncated inside the connectivity.
    let err = parse_mesh(&b[..b.len() - 20], Format::Vtk).unwrap_err();
    assert!(matches!(err, ParseError::Truncated { .. }), "{err}");
}

#[test]
fn obj_negative_and_forward_indices() {
    let obj = "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n";
    let m = parse_mesh(obj.as_bytes(), Format::Obj).unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 1, 2]]);
    let err = parse_mesh(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", Format::Obj).unwrap_err();
    assert_eq!(
        err.to_string(),
        "face 0 refers to vertex -4, but there are only 3 vertices (line 4)"
    );
    let err = parse_mesh(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", Format::Obj).unwrap_err();
    assert!(err.to_string().contains("OBJ indices start at 1"), "{err}");
}

fn dir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn put(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn write_mesh_by_extension_round_trips_and_leaves_no_temporaries() {
    let (pos, faces) = sample();
    let d = dir();
    for ext in ["obj", "PLY", "off", "vtk"] {
        let path = d.path().join(format!("m.{ext}"));
        write_mesh(&path, &pos, &faces, &VertexAttributes::default()).unwrap();
        let s = load_shape(&path).unwrap();
        assert_same_bits(&s.positions, &pos);
        assert_eq!(s.topology.faces(), &faces[..]);
    }
    let ply = std::fs::read(d.path().join("m.PLY")).unwrap();
    assert!(String::from_utf8_lossy(&ply[..60]).contains("binary_little_endian"));
    let names: Vec<String> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 4, "{names:?}");
    // Overwriting replaces the file whole.
    let path = d.path().join("m.obj");
    write_mesh(&path, &pos[..3], &[[0, 1, 2]], &VertexAttributes::default()).unwrap();
    assert_eq!(read_mesh(&path).unwrap().positions.len(), 3);
}

#[test]
fn write_errors_name_the_file() {
    let (pos, faces) = sample();
    let d = dir();
    let missing_dir = d.path().join("nope").join("m.ply");
    let err = write_mesh(&missing_dir, &pos, &faces, &VertexAttributes::default()).unwrap_err();
    assert!(matches!(err, IoError::Write { .. }), "{err}");
    assert!(err.to_string().contains("nope"), "{err}");
    assert!(!d.path().join("nope").exists());

    let bad_faces = [[0, 1, 9999]];
    let err = write_mesh(
        &d.path().join("m.ply"),
        &pos,
        &bad_faces,
        &VertexAttributes::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("face 0 refers to vertex 9999"), "{err}");

    let s = vec![0.0; pos.len()];
    let attrs = VertexAttributes {
        scalar: Some(("err", &s)),
        colors: None,
    };
    let err = write_mesh(&d.path().join("m.obj"), &pos, &faces, &attrs).unwrap_err();
    assert!(
        matches!(
            err,
            IoError::Encode {
                error: WriteError::Unsupported { .. },
                ..
            }
        ),
        "{err}"
    );
    let short = [1.0, 2.0];
    let attrs = VertexAttributes {
        scalar: Some(("err", &short)),
        colors: None,
    };
    let err = write_mesh(&d.path().join("m.vtk"), &pos, &faces, &attrs).unwrap_err();
    assert!(
        err.to_string()
            .contains("has 2 entries, but there are 42 vertices"),
        "{err}"
    );
    assert!(
        std::fs::read_dir(d.path()).unwrap().next().is_none(),
        "nothing written"
    );

    let err = write_mesh(
        &d.path().join("m.xyz"),
        &pos,
        &faces,
        &VertexAttributes::default(),
    )
    .unwrap_err();
    assert!(matches!(err, IoError::UnknownFormat { .. }), "{err}");
}

#[test]
fn heat_map_attributes_in_ply_and_vtk() {
    let (pos, faces) = sample();
    let err: Vec<f64> = pos.iter().map(|p| p[2]).collect();
    let colors = heat_colors(&err, -1.0, 1.0);
    let attrs = VertexAttributes {
        scalar: Some(("error map", &err)),
        colors: Some(&colors),
    };
    for enc in [
        PlyEncoding::Ascii,
        PlyEncoding::BinaryLittleEndian,
        PlyEncoding::BinaryBigEndian,
    ] {
        let opts = WriteOptions { ply_encoding: enc };
        let b = encode_mesh(Format::Ply, &pos, &faces, &attrs, &opts).unwrap();
        let text = String::from_utf8_lossy(&b[..400]);
        assert!(
            text.contains("property double error_map\nproperty uchar red\n"),
            "{text}"
        );
        let m = parse_mesh(&b, Format::Ply).unwrap();
        assert_same_bits(&m.positions, &pos);
        assert_eq!(m.faces, faces);
    }
    let b = encode_mesh(Format::Vtk, &pos, &faces, &attrs, &WriteOptions::default()).unwrap();
    let text = String::from_utf8(b.clone()).unwrap();
    assert!(text.contains("POINT_DATA 42\nSCALARS error_map double 1\nLOOKUP_TABLE default\n"));
    assert!(text.contains("COLOR_SCALARS colors 3\n"));
    let m = parse_mesh(&b, Format::Vtk).unwrap();
    assert_same_bits(&m.positions, &pos);
    // OBJ keeps colours as the `v x y z r g b` extension, read back with a warning.
    let attrs = VertexAttributes {
        scalar: None,
        colors: Some(&colors),
    };
    let b = encode_mesh(Format::Obj, &pos, &faces, &attrs, &WriteOptions::default()).unwrap();
    let m = parse_mesh(&b, Format::Obj).unwrap();
    assert_same_bits(&m.positions, &pos);
    assert_eq!(m.warnings.len(), 1);
}

// ---- bad inputs: every error names the file and the problem ----

fn load_err(dir: &Path, name: &str, bytes: &[u8]) -> (IoError, String) {
    let p = put(dir, name, bytes);
    let e = load_shape(&p).unwrap_err();
    let msg = e.to_string();
    assert!(msg.starts_with(&p.display().to_string()), "{msg}");
    (e, msg)
}

#[test]
fn empty_files() {
    let d = dir();
    for f in Format::ALL {
        for bytes in [&b""[..], b"  \n\r\n"] {
            let (e, msg) = load_err(d.path(), &format!("empty.{}", f.extension()), bytes);
            assert!(
                matches!(
                    e,
                    IoError::Parse {
                        error: ParseError::Empty,
                        ..
                    }
                ),
                "{msg}"
            );
            assert!(
                msg.ends_with(&format!("empty.{}: the file is empty", f.extension())),
                "{msg}"
            );
        }
    }
}

#[test]
fn truncated_binary_files() {
    let (pos, faces) = sample();
    let d = dir();
    let ply = encode(Format::Ply, &pos, &faces, PlyEncoding::BinaryLittleEndian);
    let (e, msg) = load_err(d.path(), "cut.ply", &ply[..ply.len() - 7]);
    assert!(
        matches!(
            e,
            IoError::Parse {
                error: ParseError::Truncated { .. },
                ..
            }
        ),
        "{msg}"
    );
    assert!(
        msg.contains("cut.ply: the file is truncated: property vertex_indices of face 79 (of 80)"),
        "{msg}"
    );
    // Cut inside the vertices: the up-front size check reports the whole element.
    let (_, msg) = load_err(d.path(), "cut2.ply", &ply[..300]);
    assert!(
        msg.contains("the file is truncated: 42 vertex elements need"),
        "{msg}"
    );

    let stl = encode(Format::Stl, &pos, &faces, PlyEncoding::default());
    let (e, msg) = load_err(d.path(), "cut.stl", &stl[..stl.len() - 10]);
    assert!(
        matches!(
            e,
            IoError::Parse {
                error: ParseError::Truncated { .. },
                ..
            }
        ),
        "{msg}"
    );
    assert!(
        msg.contains("80 triangles (the count in the binary STL header)"),
        "{msg}"
    );
    let (_, msg) = load_err(d.path(), "tiny.stl", &stl[..40]);
    assert!(msg.contains("truncated: the binary STL header"), "{msg}");
}

#[test]
fn bad_numbers() {
    let d = dir();
    let cases: [(&str, &[u8], &str); 6] = [
        ("a.obj", b"v 0 0 0\nv 1 zero 0\n", "line 2: cannot read the y coordinate of vertex 1 from \"zero\""),
        ("b.obj", b"v 0 0 0\nf 1 x 2\n", "line 2: cannot read a vertex index of face 0 from \"x\""),
        ("c.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1.0.0 0\n3 0 1 2\n", "line 5: cannot read the y coordinate of vertex 2"),
        ("d.off", b"OFF\nthree 1 0\n", "line 2: cannot read the vertex count from \"three\""),
        (
            "e.ply",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 q\n",
            "line 8: cannot read property z of vertex 0 (of 1) from \"q\"",
        ),
        (
            "f.vtk",
            b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 #\n",
            "line 6: cannot read value 2 of POINTS from \"#\"",
        ),
    ];
    for (name, bytes, want) in cases {
        let (_, msg) = load_err(d.path(), name, bytes);
        assert!(msg.contains(want), "{name}: {msg}");
    }
}

/// A syntax error keeps what went wrong and the offending token as values, not only as text.
#[test]
fn syntax_errors_keep_their_values() {
    let e = parse_mesh(b"v 0 0 0\nf 1 x 2\n", Format::Obj).unwrap_err();
    let ParseError::Syntax { line, problem } = &e else {
        panic!("{e:?}");
    };
    assert_eq!(*line, 2);
    assert_eq!(
        *problem,
        SyntaxError::VertexIndex {
            face: 0,
            found: "x".into()
        }
    );
    assert_eq!(
        e.to_string(),
        "line 2: cannot read a vertex index of face 0 from \"x\""
    );
    let e = parse_mesh(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", Format::Off).unwrap_err();
    assert!(
        matches!(
            e,
            ParseError::Syntax {
                line: 6,
                problem: SyntaxError::ShortFace {
                    face: 0,
                    declared: 4,
                    listed: 3
                }
            }
        ),
        "{e:?}"
    );
}

#[test]
fn index_out_of_range() {
    let d = dir();
    let cases: [(&str, &[u8], &str); 4] = [
        ("a.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 900\n", "face 0 refers to vertex 900, but there are only 3 vertices (line 4)"),
        ("b.off", b"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 7\n", "face 1 refers to vertex 7, but there are only 3 vertices (line 7)"),
        (
            "c.ply",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
              element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n",
            "face 0 refers to vertex -1, but there are only 3 vertices (line 13)",
        ),
        (
            "d.vtk",
            b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 3\n",
            "face 0 refers to vertex 3, but there are only 3 vertices",
        ),
    ];
    for (name, bytes, want) in cases {
        let (e, msg) = load_err(d.path(), name, bytes);
        assert!(
            matches!(
                e,
                IoError::Parse {
                    error: ParseError::IndexOutOfRange { .. },
                    ..
                }
            ),
            "{msg}"
        );
        assert!(msg.contains(want), "{name}: {msg}");
    }
    // Binary PLY: index checked against the declared vertex count.
    let (pos, mut faces) = sample();
    faces[17][1] = 900;
    let b = encode_mesh_unchecked_ply(&pos, &faces);
    let (_, msg) = load_err(d.path(), "e.ply", &b);
    assert!(
        msg.ends_with("e.ply: face 17 refers to vertex 900, but there are only 42 vertices"),
        "{msg}"
    );
}

/// Binary PLY bytes without the writer's index validation (to make bad files).
fn encode_mesh_unchecked_ply(pos: &[[f64; 3]], faces: &[[u32; 3]]) -> Vec<u8> {
    let mut out = Vec::new();
    ply::write(
        &mut out,
        pos,
        faces,
        &super::Payload::default(),
        PlyEncoding::BinaryLittleEndian,
    )
    .unwrap();
    out
}

#[test]
fn non_finite_coordinates() {
    let d = dir();
    let (mut pos, faces) = sample();
    pos[5][1] = f64::NAN;
    let b = encode_mesh_unchecked_ply(&pos, &faces);
    let (e, msg) = load_err(d.path(), "nan.ply", &b);
    assert!(
        matches!(
            e,
            IoError::Parse {
                error: ParseError::NonFinite { vertex: 5, .. },
                ..
            }
        ),
        "{msg}"
    );
    assert!(
        msg.ends_with("nan.ply: vertex 5 has a non-finite coordinate (NaN)"),
        "{msg}"
    );
    let cases: [(&str, &[u8], &str); 5] = [
        ("a.obj", b"v 0 0 0\nv nan 0 0\n", "vertex 1 has a non-finite coordinate (NaN) (line 2)"),
        ("b.obj", b"v 0 1e400 0\n", "vertex 0 has a non-finite coordinate (inf) (line 1)"),
        ("c.off", b"OFF\n1 0 0\n-inf 0 0\n", "vertex 0 has a non-finite coordinate (-inf) (line 3)"),
        (
            "d.vtk",
            b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 NaN 0\n",
            "vertex 0 has a non-finite coordinate (NaN)",
        ),
        (
            "e.stl",
            b"solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 nan 0\nendloop\nendfacet\nendsolid\n",
            "corner 2 of triangle 0 has a non-finite coordinate (NaN) (line 6)",
        ),
    ];
    for (name, bytes, want) in cases {
        let (_, msg) = load_err(d.path(), name, bytes);
        assert!(msg.contains(want), "{name}: {msg}");
    }
}

#[test]
fn zero_area_triangle_is_rejected_at_load() {
    let d = dir();
    // Face 1 is collinear: (1,0,0), (0,0,0), (2,0,0) (beside face 0 across their shared edge).
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 2 1 4\n";
    let p = put(d.path(), "flat.obj", obj);
    assert!(read_mesh(&p).is_ok(), "parsing does not judge geometry");
    let (e, msg) = load_err(d.path(), "flat.obj", obj);
    assert!(
        matches!(
            e,
            IoError::Mesh {
                error: MeshError::DegenerateFace { face: 1, .. },
                ..
            }
        ),
        "{msg}"
    );
    assert!(msg.contains("flat.obj: face 1 [1, 0, 3] is degenerate"), "{msg}");
}

#[test]
fn missing_and_unknown_files() {
    let d = dir();
    let p = d.path().join("absent.ply");
    let e = load_shape(&p).unwrap_err();
    assert!(matches!(e, IoError::Read { .. }));
    assert!(
        e.to_string()
            .starts_with(&format!("{}: cannot read: ", p.display())),
        "{e}"
    );
    let p = put(d.path(), "mesh.txt", b"v 0 0 0\n");
    let e = read_mesh(&p).unwrap_err();
    assert!(e.to_string().contains("mesh.txt: unknown mesh format"), "{e}");
    assert_eq!(Format::from_path(Path::new("a/B.StL")), Some(Format::Stl));
    assert_eq!(Format::from_path(Path::new("a/b")), None);
}

#[test]
fn structural_errors_are_specific() {
    let cases: [(Format, &[u8], &str); 9] = [
        (Format::Ply, b"plx\n", "line 1: not a PLY file"),
        (Format::Ply, b"ply\nformat ascii 1.0\nelement vertex 1\n", "no end_header"),
        (Format::Ply, b"ply\nelement vertex 1\nend_header\n", "no format line"),
        (
            Format::Ply,
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
            "no z property",
        ),
        (Format::Off, b"OFF\n3 1\n0 0 0\n1 0 0\n", "the file ends early: expected 3 vertices, found 2"),
        (Format::Off, b"OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "face 0 has 2 vertices, but a face needs at least 3 (line 6)"),
        (Format::Vtk, b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\n", "unsupported: VTK dataset type"),
        (Format::Obj, b"v 0 0 0\nv 1 0 0\nf 1 2\n", "face 0 has 2 vertices"),
        (
            Format::Vtk,
            b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 5\n3 0 1 2\n",
            "the file ends early",
        ),
    ];
    for (format, bytes, want) in cases {
        let e = parse_mesh(bytes, format).unwrap_err().to_string();
        assert!(e.contains(want), "{format}: {e}");
    }
}

#[test]
fn huge_declared_counts_fail_fast() {
    let cases: [(Format, &[u8]); 4] = [
        (Format::Off, b"OFF\n4000000000 4000000000 0\n0 0 0\n"),
        (
            Format::Ply,
            b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty double x\n\
              property double y\nproperty double z\nend_header\n\0\0\0\0",
        ),
        (
            Format::Vtk,
            b"# vtk DataFile Version 3.0\nt\nBINARY\nDATASET POLYDATA\nPOINTS 4000000000 double\n\0\0",
        ),
        (
            Format::Vtk,
            b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 4000000000 double\n0 0 0\n",
        ),
    ];
    for (format, bytes) in cases {
        let t = std::time::Instant::now();
        let e = parse_mesh(bytes, format).unwrap_err();
        assert!(t.elapsed().as_secs_f64() < 0.1, "{format}: {e}");
    }
    let mut stl = vec![0u8; 84];
    stl[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
    let e = parse_mesh(&stl, Format::Stl).unwrap_err();
    assert!(matches!(e, ParseError::Truncated { .. }), "{e}");
}

/// A `.vtp` triangle whose Polys connectivity is an inline base64 array with `conn` as its
/// (already encoded) payload, and whose last offset is `last_offset`.
fn vtp_with_connectivity(conn: &str, last_offset: u64, compressed: bool) -> Vec<u8> {
    format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"{}>\n\
         <PolyData><Piece NumberOfPoints=\"3\" NumberOfPolys=\"1\">\n\
         <Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 0 1 0</DataArray></Points>\n\
         <Polys><DataArray type=\"Int64\" Name=\"connectivity\" format=\"binary\">{conn}</DataArray>\n\
         <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">{last_offset}</DataArray></Polys>\n\
         </Piece></PolyData></VTKFile>\n",
        if compressed { " compressor=\"vtkZLibDataCompressor\"" } else { "" }
    )
    .into_bytes()
}

/// Issue 40's VTP seeds: a base64 header word of 2^64 - 1 (with a last offset of 2^61, so
/// that the expected byte count saturates to the same value) and a zlib block count of
/// 2^64 - 3 are errors, not arithmetic overflows.
#[test]
fn vtp_header_words_near_u64_max_are_refused() {
    let mut word = u64::MAX.to_le_bytes().to_vec();
    word.extend([0u8; 16]);
    let bytes = vtp_with_connectivity(&super::xml::b64_encode(&word), 1 << 61, false);
    let e = parse_mesh(&bytes, Format::Vtp).unwrap_err();
    assert!(e.to_string().contains("connectivity"), "{e}");

    let mut head = (u64::MAX - 2).to_le_bytes().to_vec();
    head.extend(8u64.to_le_bytes());
    head.extend(8u64.to_le_bytes());
    let bytes = vtp_with_connectivity(&super::xml::b64_encode(&head), 3, true);
    let e = parse_mesh(&bytes, Format::Vtp).unwrap_err();
    assert!(e.to_string().contains("connectivity"), "{e}");
}
