//! End-to-end tests of `qcshape synth`.

use std::process::{Command, Output};

use qcshape::dataset::Dataset;

fn qcshape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(args)
        .output()
        .expect("the qcshape binary runs")
}

#[test]
fn writes_48_deformations_that_load_and_that_info_reads() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("bench");
    let out = qcshape(&["synth", "--out", out_dir.to_str().unwrap(), "--level", "1"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    assert!(
        stdout.contains("48 genus-0 deformations (8 classes) x 3 poses, 42 vertices")
            && stdout.contains("manifest.csv"),
        "{stdout}"
    );
    let manifest = out_dir.join("manifest.csv");
    let text = std::fs::read_to_string(&manifest).unwrap();
    assert_eq!(text.lines().count(), 1 + 48 * 3);
    let ds = Dataset::load(&manifest).unwrap();
    assert_eq!(ds.deformations.len(), 48);
    assert!(ds.deformations.iter().all(|d| d.n_poses() == 3));
    assert!(ds.shares_topology());
    let labels: std::collections::BTreeSet<_> = ds.labels().into_iter().flatten().collect();
    assert_eq!(labels.len(), 8);
    assert!(!out_dir.join("genus1").exists());

    // `info` reads a file the manifest lists.
    let pose = out_dir.join("peanut-ripple").join("pose002.ply");
    let info = qcshape(&["info", "--json", pose.to_str().unwrap()]);
    assert!(info.status.success(), "{}", String::from_utf8_lossy(&info.stderr));
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["vertices"], 42);
    assert_eq!(v["genus"], 0);
    assert_eq!(v["degenerate_faces"], 0);

    // Same options, same bytes.
    let again = dir.path().join("again");
    let out = qcshape(&["synth", "--out", again.to_str().unwrap(), "--level", "1"]);
    assert!(out.status.success());
    for rel in [
        "manifest.csv",
        "peanut-ripple/pose002.ply",
        "sphere-twist/pose001.ply",
    ] {
        assert_eq!(
            std::fs::read(out_dir.join(rel)).unwrap(),
            std::fs::read(again.join(rel)).unwrap(),
            "{rel}"
        );
    }
}

#[test]
fn genus_one_and_other_formats() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("b");
    let out = qcshape(&[
        "synth",
        "--out",
        out_dir.to_str().unwrap(),
        "--level",
        "0",
        "--genus",
        "all",
        "--format",
        "obj",
        "--poses",
        "4",
        "--seed",
        "3",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(stdout.lines().count(), 2, "{stdout}");
    assert!(stdout.contains("24 genus-1 deformations"), "{stdout}");
    assert!(out_dir.join("sphere-bend/pose003.obj").is_file());
    let ds = Dataset::load(&out_dir.join("genus1")).unwrap();
    assert_eq!(ds.deformations.len(), 24);
    assert_eq!(ds.deformations[0].n_poses(), 4);
    assert_eq!(ds.deformations[0].topology.genus(), Some(1));
    // The genus-0 set alone is still what the top folder's manifest lists.
    assert_eq!(Dataset::load(&out_dir).unwrap().deformations.len(), 48);
}

#[test]
fn bad_options_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("x");
    let d = d.to_str().unwrap();
    for (args, want, status) in [
        // Above the option's bound: refused by the argument parser (a usage error).
        (vec!["--level", "9"], "--level must be at most 8", 2),
        (vec!["--level", "7"], "level 7 is out of range", 1),
        (vec!["--poses", "1"], "poses must be between 2", 1),
        (vec!["--jitter", "0.9"], "jitter must be between 0 and 0.5", 1),
    ] {
        let mut all = vec!["synth", "--out", d];
        all.extend(args);
        let out = qcshape(&all);
        assert_eq!(out.status.code(), Some(status));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.starts_with("error: ") && err.contains(want) && !err.contains("panicked"),
            "{err}"
        );
    }
    assert!(
        !dir.path().join("x").exists(),
        "nothing is written on bad options"
    );
    let out = qcshape(&["synth", "--out", d, "--format", "stl"]);
    assert_eq!(out.status.code(), Some(2));
}
