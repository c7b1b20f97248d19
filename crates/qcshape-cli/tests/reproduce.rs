//! End-to-end test of `qcshape reproduce --quick` (the README's main job).

use std::process::Command;

#[test]
fn quick_reproduction_writes_a_report_with_all_four_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let r = Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(["reproduce", "--quick", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let table1 = report
        .split("## Table 1")
        .nth(1)
        .and_then(|t| t.split("## Table 2").next())
        .expect("Table 1 section");
    // The paper's rows (every metric but the L2 baseline).
    let paper = qcshape::metric::MetricKind::ALL
        .into_iter()
        .filter(|k| qcshape_studies::experiment::reproduce::paper_table1(*k).is_some());
    for metric in paper.map(|k| k.label()) {
        let row = table1
            .lines()
            .find(|l| l.starts_with(&format!("| {metric} |")))
            .unwrap_or_else(|| panic!("no {metric} row in Table 1:\n{table1}"));
        // specificity and sensitivity are percentages; chance level for 8 classes is 12.5 %
        // sensitivity, so a working pipeline is far above it.
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let spec: f64 = cells[2].parse().unwrap();
        let sens: f64 = cells[3].parse().unwrap();
        assert!(
            (0.0..=100.0).contains(&spec) && (0.0..=100.0).contains(&sens),
            "{row}"
        );
        assert!(
            sens > 40.0,
            "{metric}: sensitivity {sens} is near chance\n{report}"
        );
    }
    assert!(report.contains("## Table 2") && report.contains("## Table 3"));
    assert!(table1.contains("Energy share of the L2 regularizer"), "{table1}");
    // The final report is not marked partial, embeds its figures as PNG and has one top-level
    // heading.
    assert!(!report.contains("Partial report"), "{report}");
    for png in [
        "fig6_mds_rigid.png",
        "similarity_rigid.png",
        "fig4/interpolation.png",
        "fig5/transfer.png",
    ] {
        assert!(report.contains(&format!("]({png})")), "{png} not embedded");
        assert!(out.join(png).exists(), "{png} missing");
    }
    assert_eq!(report.lines().filter(|l| l.starts_with("# ")).count(), 1);
    assert!(report.contains("`fig5/fig5/`") && !report.contains(" 1 poses") && !report.contains("1 rounds"));
    assert!(!report.contains("e-17"), "rounding noise printed as a number");
    for f in [
        "fig6_mds_quasi-conformal.svg",
        "fig6_mds_quasi-conformal.png",
        "similarity_rigid.csv",
        "data/manifest.csv",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    // The similarity CSVs are complete square matrices of the 48 deformations.
    let d = qcshape::similarity::DistanceMatrix::read_csv(&out.join("similarity_isometric.csv")).unwrap();
    assert_eq!(d.len(), 48);
}
