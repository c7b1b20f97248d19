//! End-to-end test of `qcshape run` (the one-command analysis of a data set).

use std::process::Command;

use qcshape::synth::{genus0_benchmark, write_benchmark, SynthOptions};

#[test]
fn run_writes_matrix_classes_map_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let defs = genus0_benchmark(&SynthOptions {
        level: 1,
        ..Default::default()
    })
    .unwrap();
    // Two motions (twist, stretch) on four shapes each.
    let pick: Vec<_> = defs
        .into_iter()
        .filter(|d| {
            matches!(d.label.as_deref(), Some("twist") | Some("stretch"))
                && !d.name.starts_with("pear-")
                && !d.name.starts_with("peanut-")
        })
        .collect();
    assert_eq!(pick.len(), 8);
    let manifest = write_benchmark(&dir.path().join("data"), &pick, qcshape::io::Format::Ply).unwrap();
    let out = dir.path().join("out");
    let r = Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args([
            "run",
            manifest.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--metric",
            "isometric",
            "--insert",
            "1",
            "--steps",
            "2",
        ])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let d = qcshape::similarity::DistanceMatrix::read_csv(&out.join("similarity.csv")).unwrap();
    assert_eq!(d.len(), 8);
    let assignments = std::fs::read_to_string(out.join("assignments.csv")).unwrap();
    assert_eq!(assignments.lines().count(), 9);
    assert!(assignments.starts_with("name,cluster,label,matched_label"));
    // Two very different motions: the classes are recovered.
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("| sensitivity (eq. 15) | 100.0 % |"), "{report}");
    // The regularizer's share of the 28 pairs' energy, printed and reported.
    assert!(
        report.contains("Energy share of the L2 regularizer") && report.contains("pairs above 50 %: "),
        "{report}"
    );
    assert!(
        String::from_utf8_lossy(&r.stderr).contains("energy share of the L2 regularizer over 28 pairs"),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    for f in [
        "map.svg",
        "map.png",
        "heatmap.svg",
        "coordinates.csv",
        "confusion.csv",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    assert!(!out.join("similarity.csv.journal").exists());
}
