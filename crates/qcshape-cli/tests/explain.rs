//! End-to-end test of `qcshape similarity --details D --explain A,B`: the per-pose,
//! per-vertex split of one pair, as CSV, VTK, PLY and PNG.

use std::path::{Path, PathBuf};
use std::process::Command;

use qcshape::dataset::{write_manifest, ManifestRow};

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

/// Three deformations of three poses on a 42-vertex sphere: `d0` and `d1` stretch along x,
/// `d2` also grows a bump on the cap z > 0.6 in its last pose.
fn data_set(dir: &Path) -> PathBuf {
    let s = qcshape::synth::icosphere(1);
    let faces = s.topology.faces();
    let mut rows = Vec::new();
    for k in 0..3 {
        let name = format!("d{k}");
        std::fs::create_dir_all(dir.join(&name)).unwrap();
        for pose in 0..3 {
            let a = 0.05 * pose as f64 * (1.0 + 0.1 * k as f64);
            let bump = if k == 2 && pose == 2 { 0.3 } else { 0.0 };
            let p: Vec<[f64; 3]> = s
                .positions
                .iter()
                .map(|p| {
                    let t = ((p[2] - 0.6) / 0.4).max(0.0);
                    let r = 1.0 + bump * t * t;
                    [p[0] * (1.0 + a) * r, p[1] * r, p[2] * r]
                })
                .collect();
            let rel = PathBuf::from(&name).join(format!("p{pose}.ply"));
            qcshape::io::write_mesh(&dir.join(&rel), &p, faces, &Default::default()).unwrap();
            rows.push(ManifestRow {
                deformation: name.clone(),
                label: None,
                pose,
                path: rel,
            });
        }
    }
    let m = dir.join("manifest.csv");
    write_manifest(&m, &rows).unwrap();
    m
}

#[test]
fn explain_writes_the_pair_split_that_sums_to_the_matrix_entry() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = data_set(dir.path());
    let (matrix, details) = (dir.path().join("d.csv"), dir.path().join("details.csv"));
    let out = qcshape()
        .args([
            "similarity",
            manifest.to_str().unwrap(),
            "--steps",
            "3",
            "--smooth",
            "0",
        ])
        .args(["--threads", "1", "-o", matrix.to_str().unwrap()])
        .args(["--details", details.to_str().unwrap(), "--explain", "d0,d2"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // The matrix entry d0-d2.
    let text = std::fs::read_to_string(&matrix).unwrap();
    let row: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[0], "d0");
    let d02: f64 = row[3].parse().unwrap();
    let csv = std::fs::read_to_string(dir.path().join("details.explain_d0_vs_d2.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("vertex,total,pose_000,pose_001,pose_002"));
    let (mut total, mut cap, mut poses) = (0.0, 0.0, [0.0; 3]);
    let s = qcshape::synth::icosphere(1);
    for (v, line) in lines.enumerate() {
        let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(f[0] as usize, v);
        total += f[1];
        if s.positions[v][2] > 0.5 {
            cap += f[1];
        }
        for k in 0..3 {
            poses[k] += f[2 + k];
        }
        assert!((f[1] - (f[2] + f[3] + f[4])).abs() <= 1e-9 * f[1].abs().max(1e-12));
    }
    assert!((total - d02).abs() <= 1e-6 * d02, "{total} vs {d02}");
    // Pose 0 is the common base: no contribution.
    assert_eq!(poses[0], 0.0);
    // The bump dominates pose 2, and it lies on the cap.
    assert!(poses[2] > poses[1], "{poses:?}");
    assert!(cap / total > 0.5, "cap share {}", cap / total);
    // Fields for ParaView and MeshLab, and a picture.
    let vtk = qcshape::io::read_mesh(&dir.path().join("details.explain_d0_vs_d2.vtk")).unwrap();
    for name in ["total", "pose_000", "pose_001", "pose_002"] {
        assert!(vtk.point_array(name).is_some(), "{name}");
    }
    let ply = std::fs::read(dir.path().join("details.explain_d0_vs_d2.ply")).unwrap();
    assert!(String::from_utf8_lossy(&ply).contains("property double quality\nproperty double total\n"));
    let png = std::fs::read(dir.path().join("details.explain_d0_vs_d2.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn explain_refuses_unknown_names_before_computing() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = data_set(dir.path());
    let out = qcshape()
        .args(["similarity", manifest.to_str().unwrap(), "-o"])
        .arg(dir.path().join("d.csv"))
        .args(["--details"])
        .arg(dir.path().join("x.csv"))
        .args(["--explain", "d0,nobody"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no deformation named \"nobody\""), "{err}");
    assert!(!dir.path().join("d.csv").exists());
    // --explain needs --details.
    let out = qcshape()
        .args(["similarity", manifest.to_str().unwrap(), "-o"])
        .arg(dir.path().join("d.csv"))
        .args(["--explain", "d0,d1"])
        .output()
        .unwrap();
    assert!(!out.status.success());
}
