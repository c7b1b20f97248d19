//! End-to-end tests of `qcshape interpolate`.

use std::path::Path;
use std::process::Command;

use qcshape::dataset::Dataset;

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

/// Writes three poses of a twisting, stretching icosphere as `dir/<name>_k.ply`.
fn write_sequence(dir: &Path, name: &str, level: u32) -> Vec<std::path::PathBuf> {
    let s = qcshape::synth::icosphere(level);
    (0..3)
        .map(|k| {
            let a = 0.3 * k as f64;
            let pos = qcshape::synth::twist_along_z(&s.positions, a, 1.0 + a);
            let path = dir.join(format!("{name}_{k}.ply"));
            qcshape::io::write_mesh(&path, &pos, s.topology.faces(), &Default::default()).unwrap();
            path
        })
        .collect()
}

#[test]
fn files_in_densified_data_set_out() {
    let dir = tempfile::tempdir().unwrap();
    let files = write_sequence(dir.path(), "twist", 2);
    let out_dir = dir.path().join("out");
    let out = qcshape()
        .arg("interpolate")
        .args(&files)
        .args([
            "--insert",
            "3",
            "--metric",
            "isometric",
            "--levels",
            "2",
            "--format",
            "obj",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains(",3,9,") && stdout.contains("2/2"), "{stdout}");
    // 162 vertices: a second level of about 41 vertices is built (no note about stopping).
    assert!(!String::from_utf8_lossy(&out.stderr).contains("note:"));
    let data = Dataset::load(&out_dir).unwrap();
    assert_eq!(data.deformations.len(), 1);
    let d = &data.deformations[0];
    assert_eq!(d.n_poses(), 9);
    // Key poses are written exactly (OBJ keeps round-trip decimals).
    for (k, f) in files.iter().enumerate() {
        let key = qcshape::io::load_shape(f).unwrap();
        assert_eq!(d.poses[4 * k], key.positions, "key pose {k}");
    }
    let manifest = std::fs::read_to_string(out_dir.join("manifest.csv")).unwrap();
    assert_eq!(
        manifest.lines().filter(|l| l.ends_with(",true")).count(),
        3,
        "{manifest}"
    );
    let segments = std::fs::read_to_string(out_dir.join("segments.csv")).unwrap();
    let rows: Vec<&str> = segments.lines().skip(1).collect();
    assert_eq!(rows.len(), 8);
    assert!(rows
        .iter()
        .all(|r| r.split(',').nth(4).unwrap().parse::<f64>().unwrap() > 0.0));
}

#[test]
fn insert_zero_copies_a_manifest_data_set() {
    let dir = tempfile::tempdir().unwrap();
    let mut manifest = String::from("deformation,label,pose,path\n");
    for name in ["a", "b"] {
        for (k, f) in write_sequence(dir.path(), name, 1).iter().enumerate() {
            manifest.push_str(&format!(
                "{name},cls,{k},{}\n",
                f.file_name().unwrap().to_str().unwrap()
            ));
        }
    }
    std::fs::write(dir.path().join("manifest.csv"), manifest).unwrap();
    let out_dir = dir.path().join("out");
    let out = qcshape()
        .args([
            "interpolate",
            dir.path().to_str().unwrap(),
            "--insert",
            "0",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let input = Dataset::load(dir.path()).unwrap();
    let output = Dataset::load(&out_dir).unwrap();
    assert_eq!(output.deformations.len(), 2);
    for (i, o) in input.deformations.iter().zip(&output.deformations) {
        assert_eq!(i.name, o.name);
        assert_eq!(o.label.as_deref(), Some("cls"));
        assert_eq!(i.poses, o.poses);
    }
}

#[test]
fn a_single_mesh_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let files = write_sequence(dir.path(), "x", 1);
    let out = qcshape()
        .args([
            "interpolate",
            files[0].to_str().unwrap(),
            "--insert",
            "1",
            "--out",
        ])
        .arg(dir.path().join("o"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("single mesh") && !err.contains("panicked"), "{err}");
}
