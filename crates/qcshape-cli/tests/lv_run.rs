//! End-to-end tests of `qcshape lv run` and `qcshape lv cycle` (paper section 4.3).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use qcshape::dataset::Dataset;
use qcshape::similarity::DistanceMatrix;

fn qcshape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: &Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Rows of a CSV file without its header, split at commas.
fn rows(path: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// Checks a Fig. 9 output: `n` poses of which `keys` are frames; a symmetric distance matrix
/// with a zero diagonal and positive off-diagonal entries.
fn check_fig9(dir: &Path, n: usize, keys: usize) {
    let r = rows(&dir.join("fig9_mds.csv"));
    assert_eq!(r.len(), n);
    assert_eq!(r.iter().filter(|r| r[2] == "key").count(), keys);
    assert_eq!(r.iter().filter(|r| r[2] == "interpolated").count(), n - keys);
    let d = DistanceMatrix::read_csv(&dir.join("fig9_distances.csv")).unwrap();
    assert_eq!(d.len(), n);
    for i in 0..n {
        assert_eq!(d.get(i, i), 0.0);
        for j in 0..n {
            assert_eq!(d.get(i, j), d.get(j, i));
            if i != j {
                assert!(d.get(i, j) > 0.0, "poses {i} and {j} at distance 0");
            }
        }
    }
    assert!(dir.join("fig9_mds.svg").is_file() && dir.join("fig9_mds.png").is_file());
}

#[test]
fn phantom_images_to_a_classification_report_and_the_meshes_back_in() {
    let tmp = tempfile::tempdir().unwrap();
    let cohort = tmp.path().join("cohort");
    let out = qcshape(&[
        "lv",
        "phantom",
        "--out",
        s(&cohort),
        "--controls",
        "3",
        "--hcm",
        "3",
        "--size",
        "24",
        "--frames",
        "6",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let res = tmp.path().join("run");
    let common = [
        "--vertices",
        "150",
        "--insert",
        "1",
        "--steps",
        "2",
        "--restarts",
        "5",
    ];
    let mut args = vec![
        "lv",
        "run",
        s(&cohort),
        "--out",
        s(&res),
        "--landmark-sweep",
        "8,16",
    ];
    args.extend_from_slice(&common);
    let log = ok(&qcshape(&args));
    assert!(log.contains("our method sensitivity"), "{log}");

    // Table 4: three rows whose rates agree with their counts (3 hcm, 3 controls).
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    // The final report (written after each step, partial until the last) embeds its figures.
    assert!(!report.contains("Partial report"), "{report}");
    for png in [
        "subjects_mds.png",
        "similarity.png",
        "fig9_mds.png",
        "motion_map.png",
    ] {
        assert!(
            report.contains(&format!("]({png})")) && res.join(png).is_file(),
            "{png}"
        );
    }
    assert!(
        report.contains("## Table 4") && report.contains("## Table 5"),
        "{report}"
    );
    assert!(report.contains("| Our method | 88.8 | 85.7 |"), "{report}");
    // The default registration filters the landmark trajectories, and the report says so.
    assert!(
        report.contains("low-pass filtered to the Fourier harmonics 0-2 of the cycle"),
        "{report}"
    );
    // ... and refines the frames' meshes on their images (6 subjects x 6 frames here).
    assert!(
        report.contains("refined on its own image")
            && report.contains(" of 36 frames, root mean square move"),
        "{report}"
    );
    // The signed motion map, with the phantom's abnormal region (known to the cohort).
    assert!(
        report.contains("## Where the groups move differently"),
        "{report}"
    );
    assert!(
        report.contains("The phantom's abnormal region (black line), region of "),
        "{report}"
    );
    let motion = rows(&res.join("motion_map.csv"));
    let nv = Dataset::load(&res.join("meshes/manifest.csv"))
        .unwrap()
        .deformations[0]
        .topology
        .n_vertices();
    assert_eq!(motion.len(), nv);
    assert!(motion.iter().all(|r| r[1].parse::<f64>().unwrap().is_finite()));
    assert!(res.join("motion_map.vtk").is_file());
    let t4 = rows(&res.join("table4.csv"));
    assert_eq!(t4.len(), 3);
    for r in &t4 {
        let v: Vec<f64> = r[1..].iter().map(|x| x.parse().unwrap()).collect();
        let (sens, spec, tp, fn_, fp, tn) = (v[0], v[1], v[4], v[5], v[6], v[7]);
        assert_eq!(tp + fn_, 3.0, "{r:?}");
        assert_eq!(fp + tn, 3.0, "{r:?}");
        assert!(
            (sens - tp / 3.0).abs() < 1e-3 && (spec - tn / 3.0).abs() < 1e-3,
            "{r:?}"
        );
    }
    // Every clustering method of --compare on the similarity and on both baselines.
    assert!(report.contains("## Clustering methods"), "{report}");
    assert!(report.contains("Energy share of the L2 regularizer"), "{report}");
    let methods = rows(&res.join("clustering.csv"));
    assert_eq!(methods.len(), 3 * 5);
    assert_eq!(methods[0][..2], ["similarity", "kmeans"]);
    for r in &methods {
        let (sens, spec): (f64, f64) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        assert!(
            (0.0..=1.0).contains(&sens) && (0.0..=1.0).contains(&spec),
            "{r:?}"
        );
    }
    // The main split is the kmeans row.
    assert_eq!(methods[0][2], format!("{:.4}", t4[0][1].parse::<f64>().unwrap()));
    // Table 5: one row per landmark count.
    let t5 = rows(&res.join("table5.csv"));
    assert_eq!(t5.iter().map(|r| r[0].as_str()).collect::<Vec<_>>(), ["8", "16"]);
    // Six subjects with their baselines; a closed cycle of 6 frames + 6 interpolated poses.
    let subjects = rows(&res.join("subjects.csv"));
    assert_eq!(subjects.len(), 6);
    for r in &subjects {
        let sys: f64 = r[3].parse().unwrap();
        let vel: f64 = r[5].parse().unwrap();
        assert!(sys > 0.0 && vel > 0.0, "the cavity wall moves: {r:?}");
    }
    check_fig9(&res, 12, 6);
    let m = DistanceMatrix::read_csv(&res.join("similarity.csv")).unwrap();
    assert_eq!(m.len(), 6);

    // The meshes share one connectivity across subjects, so they go back in as a manifest
    // (item 7: meshing skipped) and give the same similarities.
    let manifest = res.join("meshes/manifest.csv");
    let data = Dataset::load(&manifest).unwrap();
    assert_eq!(data.deformations.len(), 6);
    assert!(data.shares_topology());
    let again = tmp.path().join("again");
    let mut args = vec!["lv", "run", s(&manifest), "--out", s(&again)];
    args.extend_from_slice(&common);
    ok(&qcshape(&args));
    let report = std::fs::read_to_string(again.join("report.md")).unwrap();
    assert!(report.contains("registration and meshing skipped"), "{report}");
    assert!(!report.contains("## Table 5"));
    let m2 = DistanceMatrix::read_csv(&again.join("similarity.csv")).unwrap();
    for i in 0..6 {
        for j in 0..6 {
            let (a, b) = (m.get(i, j), m2.get(i, j));
            assert!((a - b).abs() <= 1e-3 * a.max(1.0), "{i},{j}: {a} vs {b}");
        }
    }

    // Without class labels there is nothing to classify: a clear error before any solve.
    let text = std::fs::read_to_string(&manifest).unwrap();
    let unlabelled: String = text.replace(",control,", ",,").replace(",hcm,", ",,");
    let bare = res.join("meshes/unlabelled.csv");
    std::fs::write(&bare, unlabelled).unwrap();
    let out = qcshape(&["lv", "run", s(&bare), "--out", s(&tmp.path().join("bare"))]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("has no class label"), "{err}");
    // An unknown clustering method is a usage error naming the choices.
    let out = qcshape(&[
        "lv",
        "run",
        s(&manifest),
        "--out",
        s(&again),
        "--cluster",
        "kmeams",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("spectral[:SCALE]"), "{err}");
    // A bad harmonics count is a usage error; a spline regularization on meshes is refused
    // (it acts on the landmark registration of a cohort folder).
    let out = qcshape(&["lv", "run", s(&cohort), "--out", s(&again), "--harmonics", "two"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("or none"));
    let out = qcshape(&["lv", "run", s(&cohort), "--out", s(&again), "--refine=-1"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected a search reach in mm (> 0) or none"));
    let out = qcshape(&[
        "lv",
        "run",
        s(&manifest),
        "--out",
        s(&again),
        "--tps-lambda",
        "0.5",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--tps-lambda acts on the landmark registration"),
        "{err}"
    );
}

/// `lv run --approx straight`: the same subjects, every distance an upper bound of the exact
/// one (a straight path is a path) and close to it on these mild deformations.
#[test]
fn lv_run_takes_a_cheaper_pose_distance() {
    let tmp = tempfile::tempdir().unwrap();
    let cohort = tmp.path().join("cohort");
    ok(&qcshape(&[
        "lv",
        "phantom",
        "--out",
        s(&cohort),
        "--controls",
        "2",
        "--hcm",
        "2",
        "--size",
        "24",
        "--frames",
        "4",
    ]));
    let run = |approx: &str| {
        let out = tmp.path().join(approx);
        let mut args = vec![
            "lv",
            "run",
            s(&cohort),
            "--out",
            s(&out),
            "--no-sweep",
            "--vertices",
            "120",
        ];
        args.extend_from_slice(&[
            "--insert",
            "1",
            "--steps",
            "2",
            "--restarts",
            "3",
            "--approx",
            approx,
        ]);
        ok(&qcshape(&args));
        DistanceMatrix::read_csv(&out.join("similarity.csv")).unwrap()
    };
    let (exact, straight) = (run("exact"), run("straight"));
    assert_eq!(exact.names(), straight.names());
    for (e, a) in exact.values().iter().zip(straight.values()) {
        assert!(
            *a >= e * (1.0 - 1e-6) && *a <= e * 1.2 + 1e-12,
            "{a} vs exact {e}"
        );
    }
    let bad = qcshape(&[
        "lv",
        "run",
        s(&cohort),
        "--out",
        s(&tmp.path().join("x")),
        "--approx",
        "fast",
    ]);
    assert!(!bad.status.success());
}

/// The shared data folder: `$QCSHAPE_DATA`, else `../../../shared/data` from this crate.
fn data_dir() -> PathBuf {
    std::env::var_os("QCSHAPE_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"))
}

#[test]
fn real_lv_cycle_map_from_a_few_frames() {
    let real = data_dir().join("real/biv-me-patient1");
    if !real.join("patient1_LV_ENDOCARDIAL_000.obj").is_file() {
        eprintln!("skipped: {} is absent (set QCSHAPE_DATA)", real.display());
        return;
    }
    // `lv cycle` on the folder: 25 frames, every 5th (0, 5, 10, 15, 20), open.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("cycle");
    let cheap = ["--vertices", "150", "--insert", "1", "--steps", "2"];
    let mut args = vec![
        "lv",
        "cycle",
        s(&real),
        "--pattern",
        "LV_ENDO",
        "--every",
        "5",
        "--open",
        "--out",
        s(&out),
    ];
    args.extend_from_slice(&cheap);
    ok(&qcshape(&args));
    // Open: 5 frames + 4 interpolated, named by their original frame numbers.
    check_fig9(&out, 9, 5);
    let keys: Vec<String> = rows(&out.join("fig9_mds.csv"))
        .into_iter()
        .filter(|r| r[2] == "key")
        .map(|r| r[1].clone())
        .collect();
    assert_eq!(keys, ["0", "5", "10", "15", "20"]);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("coarsened from 1572"), "{report}");

    // `lv run` on a folder of one subject's frames: the same map, closed (6 frames + 6).
    let dir = tmp.path().join("frames");
    std::fs::create_dir_all(&dir).unwrap();
    for k in [0, 4, 8, 12, 16, 20] {
        let name = format!("patient1_LV_ENDOCARDIAL_{k:03}.obj");
        std::fs::copy(real.join(&name), dir.join(&name)).unwrap();
    }
    let res = tmp.path().join("run");
    let mut args = vec!["lv", "run", s(&dir), "--pattern", "LV_ENDO", "--out", s(&res)];
    args.extend_from_slice(&cheap);
    ok(&qcshape(&args));
    check_fig9(&res, 12, 6);
    // End-systole is far from end-diastole: frame 0 is farther from frame 8 than from frame 4.
    let d = DistanceMatrix::read_csv(&res.join("fig9_distances.csv")).unwrap();
    assert!(d.get(0, 4) > d.get(0, 2), "{:?}", d.row(0));
}
