//! End-to-end tests of `qcshape experiment interpolation`.

use std::path::PathBuf;
use std::process::Command;

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

#[test]
fn builtin_benchmark_gives_one_row_per_type_and_method() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("exp");
    let out = qcshape()
        .args([
            "experiment",
            "interpolation",
            "--level",
            "0",
            "--metrics",
            "quasi-conformal,isometric",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let csv = std::fs::read_to_string(out_dir.join("interpolation.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    // 8 types x (2 metrics + the linear baseline), 6 shapes each.
    assert_eq!(rows.len(), 8 * 3, "{csv}");
    for ty in [
        "twist", "bend", "taper", "stretch", "bulge", "shear", "dent", "ripple",
    ] {
        for m in ["quasi-conformal", "isometric", "linear"] {
            let r = rows
                .iter()
                .find(|r| r[0] == ty && r[1] == m)
                .unwrap_or_else(|| panic!("no row {ty},{m} in\n{csv}"));
            assert_eq!(r[2], "6");
            let (mean, sd): (f64, f64) = (r[3].parse().unwrap(), r[4].parse().unwrap());
            assert!(mean.is_finite() && mean > 0.0 && sd >= 0.0, "{r:?}");
        }
    }
    let cases = std::fs::read_to_string(out_dir.join("interpolation_cases.csv")).unwrap();
    assert_eq!(cases.lines().count(), 1 + 48 * 3);
    for f in [
        "interpolation.md",
        "interpolation.svg",
        "interpolation.png",
        "interpolation_sphere-bend_quasi-conformal.ply",
        "interpolation_sphere-bend_isometric.ply",
        "interpolation_sphere-bend_linear.ply",
        "interpolation_sphere-bend_truth.ply",
    ] {
        assert!(out_dir.join(f).is_file(), "{f} missing");
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("| type | n | quasi-conformal | isometric | linear |"),
        "{stdout}"
    );
    assert!(stdout.contains("of 8 deformation types"), "{stdout}");
    let map = qcshape::io::read_mesh(&out_dir.join("interpolation_sphere-bend_isometric.ply")).unwrap();
    assert_eq!(map.positions.len(), 12);
}

#[test]
fn bad_options_fail_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| {
        qcshape()
            .args(["experiment", "interpolation", "--level", "0", "--metrics", "l2"])
            .args(extra)
            .arg("--out")
            .arg(dir.path())
            .output()
            .unwrap()
    };
    let out = run(&["--insert", "2"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("odd"));
    let out = run(&["--real", "/nonexistent/folder"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/folder"));
}

/// The shared data folder: `$QCSHAPE_DATA`, else `../../../shared/data` from this crate.
fn shared_data() -> PathBuf {
    std::env::var_os("QCSHAPE_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"))
}

#[test]
fn leave_one_out_on_the_real_sequence() {
    let real = shared_data().join("real/biv-me-patient1");
    if !real.is_dir() {
        eprintln!("skipped: {} is absent (set QCSHAPE_DATA)", real.display());
        return;
    }
    // Keep the first four frames only (three would leave one interior frame).
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("seq");
    std::fs::create_dir(&seq).unwrap();
    for k in 0..4 {
        let name = format!("patient1_LV_ENDOCARDIAL_{k:03}.obj");
        std::fs::copy(real.join(&name), seq.join(&name)).unwrap();
    }
    let out_dir = dir.path().join("exp");
    let out = qcshape()
        .args([
            "experiment",
            "interpolation",
            "--level",
            "0",
            "--metrics",
            "l2",
            "--real-pattern",
            "LV_ENDO",
            "--real",
        ])
        .arg(&seq)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let frames = std::fs::read_to_string(out_dir.join("leave_one_out_frames.csv")).unwrap();
    // Frames 1 and 2, each by l2 and the baseline.
    assert_eq!(frames.lines().count(), 1 + 2 * 2, "{frames}");
    let md = std::fs::read_to_string(out_dir.join("leave_one_out.md")).unwrap();
    assert!(md.contains("1572 vertices") && md.contains("| l2 |"), "{md}");
}
