//! End-to-end tests of `qcshape classify`.

use std::path::Path;
use std::process::Command;

use qcshape::similarity::DistanceMatrix;

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

/// Ten deformations in two obvious blocks (interleaved): ~1 apart inside, ~8 across. Writes
/// the matrix and a name,label file; returns the block of each item.
fn write_blocks(dir: &Path) -> Vec<usize> {
    let block: Vec<usize> = (0..10).map(|i| (i * 7 % 10) % 2).collect();
    let names: Vec<String> = (0..10).map(|i| format!("def{i}")).collect();
    let d = DistanceMatrix::from_fn(names.clone(), |i, j| {
        let wiggle = 0.05 * ((3 * i + 5 * j) % 7) as f64;
        if block[i] == block[j] {
            1.0 + wiggle
        } else {
            8.0 + wiggle
        }
    })
    .unwrap();
    d.write_csv(&dir.join("D.csv")).unwrap();
    let mut labels = String::from("name,label\n");
    for (n, b) in names.iter().zip(&block) {
        labels.push_str(&format!("{n},{}\n", ["bend", "twist"][*b]));
    }
    std::fs::write(dir.join("labels.csv"), labels).unwrap();
    block
}

#[test]
fn both_methods_recover_two_blocks_and_score_them() {
    let dir = tempfile::tempdir().unwrap();
    let block = write_blocks(dir.path());
    for method in ["kmeans", "kmedoids"] {
        let out = dir.path().join(format!("{method}.csv"));
        let status = qcshape()
            .current_dir(dir.path())
            .args([
                "classify",
                "D.csv",
                "--k",
                "2",
                "--method",
                method,
                "--labels",
                "labels.csv",
                "--json",
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(
            status.status.success(),
            "{}",
            String::from_utf8_lossy(&status.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&status.stdout).unwrap();
        assert_eq!(v["sensitivity"], 1.0, "{method}: {v}");
        assert_eq!(v["specificity"], 1.0);
        assert_eq!(v["ari"], 1.0);
        assert_eq!(v["nn_accuracy"], 1.0);
        assert_eq!(v["confusion"], serde_json::json!([[5, 0, 0], [0, 5, 0]]));
        let text = std::fs::read_to_string(&out).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("name,cluster,label,matched_label"));
        let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
        assert_eq!(rows.len(), 10);
        for (i, r) in rows.iter().enumerate() {
            assert_eq!(r[0], format!("def{i}"));
            // Same block, same cluster; and the matched label is the true one.
            assert_eq!(r[1] == rows[0][1], block[i] == block[0], "{method}: row {i}");
            assert_eq!(r[2], r[3]);
        }
    }
}

#[test]
fn text_report_without_and_with_labels() {
    let dir = tempfile::tempdir().unwrap();
    write_blocks(dir.path());
    let out = qcshape()
        .current_dir(dir.path())
        .args(["classify", "D.csv", "--k", "2", "-o", "a.csv"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("k = 2") && stdout.contains("[5, 5]") && !stdout.contains("sensitivity"),
        "{stdout}"
    );
    let a = std::fs::read_to_string(dir.path().join("a.csv")).unwrap();
    assert!(a.starts_with("name,cluster\ndef0,0\n"), "{a}");
    // Three clusters for two classes: one cluster is left unmatched, eq. 15 still defined.
    let out = qcshape()
        .current_dir(dir.path())
        .args([
            "classify",
            "D.csv",
            "--k",
            "3",
            "--labels",
            "labels.csv",
            "--confusion",
            "c.csv",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("sensitivity") && stdout.contains("unmatched"),
        "{stdout}"
    );
    let c = std::fs::read_to_string(dir.path().join("c.csv")).unwrap();
    assert!(c.starts_with("actual,bend,twist,unmatched\n"), "{c}");
}

fn classify_err(dir: &Path, file: &str, text: &str) -> String {
    std::fs::write(dir.join(file), text).unwrap();
    let out = qcshape()
        .current_dir(dir)
        .args(["classify", file, "--k", "2"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!err.contains("panicked"), "{err}");
    err
}

#[test]
fn bad_matrices_are_errors_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let e = classify_err(d, "short.csv", "name,a,b,c\na,0,1,2\nb,1,0\nc,2,1,0\n");
    assert!(e.contains("short.csv: line 3") && e.contains("square"), "{e}");
    let e = classify_err(d, "rows.csv", "name,a,b,c\na,0,1,2\nb,1,0,1\n");
    assert!(e.contains("rows.csv") && e.contains("square"), "{e}");
    let e = classify_err(d, "asym.csv", "name,a,b,c\na,0,1,2\nb,1,0,1\nc,2.5,1,0\n");
    assert!(
        e.contains("asym.csv: line 2") && e.contains("symmetric") && e.contains("line 4"),
        "{e}"
    );
    let e = classify_err(d, "nan.csv", "name,a,b,c\na,0,1,2\nb,1,0,NaN\nc,2,NaN,0\n");
    assert!(e.contains("nan.csv: line 3") && e.contains("not finite"), "{e}");
    let e = classify_err(d, "missing.csv", "");
    assert!(e.contains("missing.csv"), "{e}");
    std::fs::remove_file(d.join("missing.csv")).unwrap();
    let out = qcshape()
        .current_dir(d)
        .args(["classify", "missing.csv", "--k", "2"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.csv: cannot read"));
    // k larger than the number of deformations; labels that miss a deformation.
    write_blocks(d);
    let out = qcshape()
        .current_dir(d)
        .args(["classify", "D.csv", "--k", "11"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("11 clusters of 10"), "{e}");
    std::fs::write(d.join("few.csv"), "name,label\ndef0,a\ndef1,b\n").unwrap();
    let out = qcshape()
        .current_dir(d)
        .args(["classify", "D.csv", "--k", "2", "--labels", "few.csv"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && e.contains("few.csv") && e.contains("def2"),
        "{e}"
    );
}

#[test]
fn a_data_set_is_compared_then_classified_with_its_own_labels() {
    let dir = tempfile::tempdir().unwrap();
    let defs = qcshape::synth::genus0_benchmark(&qcshape::synth::SynthOptions {
        level: 1,
        ..Default::default()
    })
    .unwrap();
    let pick: Vec<_> = defs
        .into_iter()
        .filter(|d| matches!(d.label.as_deref(), Some("twist") | Some("bulge")) && !d.name.starts_with("pe"))
        .collect();
    assert_eq!(pick.len(), 8);
    let manifest =
        qcshape::synth::write_benchmark(&dir.path().join("data"), &pick, qcshape::io::Format::Ply).unwrap();
    let out = dir.path().join("a.csv");
    let r = std::process::Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args([
            "classify",
            manifest.to_str().unwrap(),
            "--k",
            "2",
            "--metric",
            "isometric",
            "--steps",
            "2",
        ])
        .args(["--json", "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    assert_eq!(v["n"], 8);
    assert_eq!(v["sensitivity"], 1.0, "{v}");
    assert!(std::fs::read_to_string(&out)
        .unwrap()
        .starts_with("name,cluster,label,matched_label"));
}
