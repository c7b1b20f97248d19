//! End-to-end tests of `qcshape info` on files written to a temporary folder.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use qcshape::io::{encode_mesh, write_mesh, Format, PlyEncoding, VertexAttributes, WriteOptions};
use qcshape::synth;

fn qcshape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(args)
        .output()
        .expect("the qcshape binary runs")
}

fn info(path: &Path, json: bool) -> Output {
    let p = path.to_str().unwrap();
    if json {
        qcshape(&["info", "--json", p])
    } else {
        qcshape(&["info", p])
    }
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn put(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Runs `info` on a bad file: must fail with status 1, name the file and the problem on
/// stderr, and never panic.
fn assert_fails(path: &Path, want: &str) {
    for json in [false, true] {
        let o = info(path, json);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{}: {err}", path.display());
        assert!(!err.contains("panicked"), "{err}");
        assert!(err.starts_with(&format!("error: {}: ", path.display())), "{err}");
        assert!(err.contains(want), "wanted {want:?} in {err}");
    }
}

#[test]
fn good_closed_mesh_text_and_json() {
    let d = tempfile::tempdir().unwrap();
    let s = synth::icosphere(3);
    let p = d.path().join("sphere.ply");
    write_mesh(&p, &s.positions, s.topology.faces(), &VertexAttributes::default()).unwrap();

    let o = info(&p, false);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for want in [
        "sphere.ply (PLY)",
        "vertices              642\n",
        "faces                 1280\n",
        "edges                 1920\n",
        "components            1\n",
        "boundary loops        0 (closed)\n",
        "euler characteristic  2\n",
        "genus                 0\n",
        "bounding box min      [-1, -1, -1]\n",
        "warnings              none\n",
    ] {
        assert!(text.contains(want), "wanted {want:?} in\n{text}");
    }
    assert!(stderr(&o).is_empty());

    let o = info(&p, true);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["vertices"], 642);
    assert_eq!(v["genus"], 0);
    assert_eq!(v["boundary_loops"], 0);
    assert_eq!(v["degenerate_faces"], 0);
    let area = v["total_area"].as_f64().unwrap();
    assert!((area - 4.0 * std::f64::consts::PI).abs() < 0.1, "{area}");
    assert!(v["warnings"].as_array().unwrap().is_empty());
}

#[test]
fn open_mesh_with_quads_and_an_isolated_vertex() {
    let d = tempfile::tempdir().unwrap();
    // A 3 x 2 grid of quads (open disk) plus one unused vertex.
    let mut obj = String::new();
    for j in 0..3 {
        for i in 0..4 {
            obj.push_str(&format!("v {i} {j} 0\n"));
        }
    }
    obj.push_str("v 9 9 9\n");
    for j in 0..2 {
        for i in 0..3 {
            let a = j * 4 + i + 1;
            obj.push_str(&format!("f {} {} {} {}\n", a, a + 1, a + 5, a + 4));
        }
    }
    let p = put(d.path(), "grid.obj", obj.as_bytes());
    let o = info(&p, true);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["faces"], 12);
    assert_eq!(v["boundary_loops"], 1);
    assert_eq!(v["boundary_loop_lengths"][0], 10);
    assert_eq!(v["isolated_vertices"], 1);
    assert_eq!(v["genus"], 0);
    let warnings = v["warnings"].to_string();
    assert!(warnings.contains("fan-triangulated 6 polygon"), "{warnings}");
    assert!(
        warnings.contains("1 isolated vertex(es) belong to no face; first: vertex 12"),
        "{warnings}"
    );

    let text = stdout(&info(&p, false));
    assert!(text.contains("boundary loops        1 (lengths 10)\n"), "{text}");
    assert!(
        text.contains("warnings              2\n  - fan-triangulated"),
        "{text}"
    );
}

#[test]
fn empty_file() {
    let d = tempfile::tempdir().unwrap();
    assert_fails(&put(d.path(), "empty.off", b""), "the file is empty");
}

#[test]
fn truncated_binary_ply() {
    let d = tempfile::tempdir().unwrap();
    let s = synth::icosphere(1);
    let opts = WriteOptions {
        ply_encoding: PlyEncoding::BinaryLittleEndian,
    };
    let b = encode_mesh(
        Format::Ply,
        &s.positions,
        s.topology.faces(),
        &VertexAttributes::default(),
        &opts,
    )
    .unwrap();
    let p = put(d.path(), "cut.ply", &b[..b.len() - 5]);
    assert_fails(&p, "the file is truncated");
}

#[test]
fn index_out_of_range() {
    let d = tempfile::tempdir().unwrap();
    let p = put(
        d.path(),
        "bad.off",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 900\n",
    );
    assert_fails(&p, "face 0 refers to vertex 900, but there are only 3 vertices");
}

#[test]
fn nan_coordinate() {
    let d = tempfile::tempdir().unwrap();
    let p = put(d.path(), "nan.obj", b"v 0 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n");
    assert_fails(&p, "vertex 1 has a non-finite coordinate (NaN) (line 2)");
}

#[test]
fn zero_area_triangle() {
    let d = tempfile::tempdir().unwrap();
    let p = put(
        d.path(),
        "flat.obj",
        // Face 1 (1,0,0), (0,0,0), (2,0,0) is collinear, beside face 0 across edge (0, 1).
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 2 1 4\n",
    );
    assert_fails(&p, "1 face(s) have zero area");
    // The report is still printed before the failure.
    let o = info(&p, false);
    assert!(stdout(&o).contains("faces                 2\n"), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("the first is face 1 [1, 0, 3]"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_connectivity() {
    let d = tempfile::tempdir().unwrap();
    // Two triangles traversing edge (0, 1) in the same direction.
    let p = put(
        d.path(),
        "flip.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nf 1 2 3\nf 1 2 4\n",
    );
    assert_fails(&p, "inconsistently oriented");
}

#[test]
fn missing_file_and_unknown_extension() {
    let d = tempfile::tempdir().unwrap();
    assert_fails(&d.path().join("nothere.stl"), "cannot read");
    assert_fails(&put(d.path(), "mesh.txt", b"v 0 0 0\n"), "unknown mesh format");
}

#[test]
fn help_and_usage_errors() {
    let o = qcshape(&["info", "--help"]);
    assert!(o.status.success());
    let help = stdout(&o);
    assert!(help.contains("boundary loops"), "{help}");
    assert!(help.contains("--json"), "{help}");
    let o = qcshape(&["--help"]);
    assert!(stdout(&o).contains("info"), "{}", stdout(&o));
    let o = qcshape(&["info"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!stderr(&o).contains("panicked"));
}

#[test]
fn point_fields_are_listed_and_help_names_every_format() {
    let d = tempfile::tempdir().unwrap();
    let s = synth::icosphere(1);
    let h: Vec<f64> = s.positions.iter().map(|p| p[2] + 0.5).collect();
    let v: Vec<[f64; 3]> = s.positions.iter().map(|p| p.map(|c| 0.1 * c)).collect();
    let fields = [
        qcshape::io::Field::scalar("height", &h),
        qcshape::io::Field::vector("disp", &v),
    ];
    for ext in ["vtu", "vtp", "vtk", "ply"] {
        let p = d.path().join(format!("m.{ext}"));
        qcshape::io::write_mesh_fields(&p, &s.positions, s.topology.faces(), &fields).unwrap();
        let o = info(&p, false);
        assert!(o.status.success(), "{ext}: {}", stderr(&o));
        let text = stdout(&o);
        assert!(
            text.contains("  - height (scalar): -0.5 .. 1.5\n"),
            "{ext}:\n{text}"
        );
        assert!(
            text.contains("  - disp (3 components): -0.1 .. 0.1\n"),
            "{ext}:\n{text}"
        );
        let o = info(&p, true);
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let names: Vec<&str> = j["point_data"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a["name"].as_str().unwrap())
            .collect();
        assert!(
            names.contains(&"height") && names.contains(&"disp"),
            "{ext}: {names:?}"
        );
        assert_eq!(
            j["point_data"][names.iter().position(|n| *n == "disp").unwrap()]["components"],
            3
        );
    }
    for (args, formats) in [
        (
            &["--help"][..],
            ["OBJ", "PLY", "OFF", "STL", ".vtk", ".vtp", ".vtu"],
        ),
        (
            &["info", "--help"],
            [".obj", ".ply", ".off", ".stl", ".vtk", ".vtp", ".vtu"],
        ),
    ] {
        let help = stdout(&qcshape(args));
        for f in formats {
            assert!(help.contains(f), "{args:?} should name {f}:\n{help}");
        }
    }
}
