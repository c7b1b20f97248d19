//! End-to-end tests of `qcshape lv phantom | register | mesh`.

use std::path::Path;
use std::process::{Command, Output};

use qcshape::dataset::Dataset;

fn qcshape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: &Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn tiny_cohort(dir: &Path, controls: &str, hcm: &str, extra: &[&str]) {
    let mut args = vec![
        "lv",
        "phantom",
        "--out",
        s(dir),
        "--controls",
        controls,
        "--hcm",
        hcm,
        "--size",
        "24",
    ];
    args.extend_from_slice(extra);
    ok(&qcshape(&args));
}

#[test]
fn phantom_register_mesh_gives_a_loadable_labelled_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    let cohort = tmp.path().join("cohort");
    tiny_cohort(&cohort, "2", "2", &[]);
    let labels = std::fs::read_to_string(cohort.join("labels.csv")).unwrap();
    assert_eq!(labels.matches("control").count(), 2);
    assert_eq!(labels.matches("hcm").count(), 2);
    assert!(cohort.join("subject04/frame07.nii.gz").is_file());
    let out = ok(&qcshape(&["lv", "register", s(&cohort), "--landmarks", "16"]));
    assert_eq!(out.matches("max landmark residual").count(), 4, "{out}");
    assert!(cohort.join("subject01/tps_n16.json").is_file());

    let fw = tmp.path().join("free-wall");
    let out = ok(&qcshape(&[
        "lv",
        "mesh",
        s(&cohort),
        "--out",
        s(&fw),
        "--vertices",
        "400",
    ]));
    assert!(out.contains("(saved maps)"), "{out}");
    // Every frame's mesh is refined on its image by default (8 frames per subject).
    assert_eq!(
        out.matches("8 poses (8 refined on their images)").count(),
        4,
        "{out}"
    );
    let ds = Dataset::load(&fw).unwrap();
    assert_eq!(ds.deformations.len(), 4);
    let mut n_hcm = 0;
    for d in &ds.deformations {
        assert_eq!(d.n_poses(), 8);
        assert_eq!(
            d.topology.boundary_loops().len(),
            1,
            "{}: the free wall is open",
            d.name
        );
        n_hcm += (d.label.as_deref() == Some("hcm")) as usize;
        let label = labels
            .lines()
            .find(|l| l.starts_with(&format!("{},", d.name)))
            .unwrap();
        assert!(label.ends_with(d.label.as_deref().unwrap()));
    }
    assert_eq!(n_hcm, 2);

    // The wall: every angle below the valve plane, a disk with more vertices than the free wall.
    let wall = tmp.path().join("wall");
    ok(&qcshape(&[
        "lv",
        "mesh",
        s(&cohort),
        "--out",
        s(&wall),
        "--vertices",
        "400",
        "--region",
        "wall",
    ]));
    let walls = Dataset::load(&wall).unwrap();
    for (d, f) in walls.deformations.iter().zip(&ds.deformations) {
        assert_eq!(
            d.topology.boundary_loops().len(),
            1,
            "{}: the wall is open at the base",
            d.name
        );
        assert_eq!(d.topology.euler_characteristic(), 1, "{}", d.name);
        assert!(
            d.topology.n_vertices() > f.topology.n_vertices() * 3 / 2,
            "{}",
            d.name
        );
    }

    let whole = tmp.path().join("whole");
    ok(&qcshape(&[
        "lv",
        "mesh",
        s(&cohort),
        "--out",
        s(&whole),
        "--region",
        "whole",
        "--landmarks",
        "8",
    ]));
    let ds = Dataset::load(&whole).unwrap();
    for d in &ds.deformations {
        assert_eq!(d.topology.genus(), Some(0));
        assert!(d.topology.boundary_loops().is_empty());
        // The cavity shrinks towards end-systole (frame 3) and refills by end-diastole (7).
        let span = |p: &Vec<[f64; 3]>| {
            let (lo, hi) = qcshape::mesh::geometry::bounding_box(p);
            (0..3).map(|c| hi[c] - lo[c]).product::<f64>()
        };
        assert!(span(&d.poses[3]) < 0.8 * span(&d.poses[7]), "{}", d.name);
    }
}

#[test]
fn four_d_images_and_missing_registrations_work_too() {
    let tmp = tempfile::tempdir().unwrap();
    let cohort = tmp.path().join("c");
    tiny_cohort(&cohort, "1", "1", &["--4d", "--frames", "6"]);
    assert!(cohort.join("subject01/image.nii.gz").is_file());
    let out_dir = tmp.path().join("m");
    let out = ok(&qcshape(&[
        "lv",
        "mesh",
        s(&cohort),
        "--out",
        s(&out_dir),
        "--landmarks",
        "24",
    ]));
    assert!(!out.contains("saved maps"));
    let ds = Dataset::load(&out_dir).unwrap();
    assert!(ds.deformations.iter().all(|d| d.n_poses() == 6));
}

#[test]
fn bad_landmarks_and_thresholds_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let cohort = tmp.path().join("c");
    tiny_cohort(&cohort, "0", "1", &[]);
    let out_dir = tmp.path().join("m");
    let out = qcshape(&[
        "lv",
        "mesh",
        s(&cohort),
        "--out",
        s(&out_dir),
        "--threshold",
        "5000",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("yields no surface") && err.contains("frame00.nii.gz"),
        "{err}"
    );

    let lm = cohort.join("subject01/landmarks.csv");
    let text = std::fs::read_to_string(&lm).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let row = lines[5].clone();
    let mut fields: Vec<&str> = row.split(',').collect();
    fields[3] = "NaN";
    lines[5] = fields.join(",");
    std::fs::write(&lm, lines.join("\n")).unwrap();
    let out = qcshape(&["lv", "register", s(&cohort)]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("landmarks.csv: line 6") && err.contains("finite"),
        "{err}"
    );

    lines.remove(5);
    std::fs::write(&lm, lines.join("\n")).unwrap();
    let out = qcshape(&["lv", "mesh", s(&cohort), "--out", s(&out_dir)]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("frame 0 is missing landmark(s) [4]"), "{err}");
    assert!(!err.contains("panicked"));

    let out = qcshape(&["lv", "register", s(&tmp.path().join("nowhere"))]);
    assert!(!out.status.success());
}
