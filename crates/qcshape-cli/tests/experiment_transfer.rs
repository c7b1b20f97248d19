//! End-to-end tests of `qcshape experiment transfer`.

use std::process::Command;

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

#[test]
fn small_experiment_writes_tables_figures_and_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("transfer");
    let out = qcshape()
        .args([
            "experiment",
            "transfer",
            "--level",
            "1",
            "--kinds",
            "stretch,twist",
            "--bases",
            "ellipsoid",
            "--steps",
            "4",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    for name in [
        "quasi-conformal",
        "isometric",
        "conformal",
        "parallel",
        "schild",
        "euclidean",
    ] {
        assert!(stdout.contains(name), "{name} missing from\n{stdout}");
    }
    assert_eq!(
        std::fs::read_to_string(out_dir.join("transfer.md")).unwrap(),
        stdout
    );

    // One CSV row per transferred pose: 2 kinds x 1 base x (3 metrics x 2 transports + 1
    // Euclidean) transfers, 2 poses each; finite, non-negative errors.
    let csv = std::fs::read_to_string(out_dir.join("transfer.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2 * 7 * 2);
    for r in &rows {
        for c in ["mean_error", "max_error", "mean_error_rigid"] {
            let v: f64 = r[col(c)].parse().unwrap();
            assert!(v.is_finite() && v >= 0.0, "{r:?}");
        }
        assert!(r[col("mean_error")].parse::<f64>().unwrap() <= r[col("max_error")].parse::<f64>().unwrap());
    }
    // Euclidean transfer is metric-free: listed once per case.
    let euclid = rows.iter().filter(|r| r[col("transport")] == "euclidean").count();
    assert_eq!(euclid, 2 * 2);

    for f in [
        "transfer.svg",
        "transfer.png",
        "transfer-kinds.svg",
        "transfer-kinds.png",
    ] {
        assert!(std::fs::metadata(out_dir.join(f)).unwrap().len() > 0, "{f}");
    }
    // Fig. 5 meshes: stretch of the sphere to the ellipsoid; the ideal pose and a transferred
    // pose on the same connectivity, the Euclidean one exactly N_0 + M_K - M_0.
    let fig = out_dir.join("fig5");
    let load = |n: &str| qcshape::io::load_shape(&fig.join(n)).unwrap();
    let (m0, mk, n0) = (load("source-initial.ply"), load("source.ply"), load("base.ply"));
    let ideal = load("ideal.ply");
    assert_eq!(ideal.n_vertices(), 42);
    let eu = load("euclidean.ply");
    for i in 0..42 {
        for c in 0..3 {
            let want = n0.positions[i][c] + mk.positions[i][c] - m0.positions[i][c];
            assert!((eu.positions[i][c] - want).abs() < 1e-12);
        }
    }
    let qc = qcshape::io::read_mesh(&fig.join("quasi-conformal-parallel.ply")).unwrap();
    assert_eq!(qc.positions.len(), 42);
    assert_ne!(qc.positions, eu.positions);
}

#[test]
fn bad_options_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = qcshape()
        .args(["experiment", "transfer", "--kinds", "wiggle", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("ripple"));
    let out = qcshape()
        .args(["experiment", "transfer", "--level", "1", "--poses", "1", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("poses must be"));
}
