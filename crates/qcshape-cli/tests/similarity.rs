//! End-to-end tests of `qcshape similarity`: the matrix, and interruption + `--resume`.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use qcshape::similarity::DistanceMatrix;
use qcshape::synth::{genus0_benchmark, write_benchmark, SynthOptions};

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

/// Writes the synthetic set at `level` and a manifest of its first `n` deformations.
fn dataset(dir: &Path, level: u32, n: usize) -> std::path::PathBuf {
    let defs = genus0_benchmark(&SynthOptions {
        level,
        ..Default::default()
    })
    .unwrap();
    // Interleave the classes so that the subset has several of each.
    let mut picked: Vec<_> = (0..6).flat_map(|s| (0..8).map(move |c| c * 6 + s)).collect();
    picked.truncate(n);
    let subset: Vec<_> = picked.iter().map(|&i| defs[i].clone()).collect();
    write_benchmark(dir, &subset, qcshape::io::Format::Ply).unwrap()
}

fn args<'a>(manifest: &'a Path, out: &'a Path) -> Vec<&'a str> {
    vec![
        "similarity",
        manifest.to_str().unwrap(),
        "--metric",
        "isometric",
        "--steps",
        "4",
        "--threads",
        "1",
        "-o",
        out.to_str().unwrap(),
    ]
}

#[test]
fn matrix_is_symmetric_with_zero_diagonal_and_bad_input_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dataset(dir.path(), 1, 8);
    let out = dir.path().join("D.csv");
    let details = dir.path().join("poses.csv");
    let mut a = args(&manifest, &out);
    a.extend(["--insert", "1", "--details", details.to_str().unwrap()]);
    let r = qcshape().args(&a).output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let d = DistanceMatrix::read_csv(&out).unwrap();
    assert_eq!(d.len(), 8);
    for i in 0..8 {
        assert_eq!(d.get(i, i), 0.0);
        for j in 0..8 {
            assert_eq!(d.get(i, j), d.get(j, i));
            if i != j {
                assert!(d.get(i, j) > 0.0);
            }
        }
    }
    // 28 pairs x 5 poses (3 key poses, 1 inserted between each), pose 0 at distance 0.
    let text = std::fs::read_to_string(&details).unwrap();
    assert_eq!(text.lines().count(), 1 + 28 * 5);
    assert!(text
        .lines()
        .skip(1)
        .step_by(5)
        .all(|l| l.split(',').nth(3) == Some("0.0")));
    assert!(!dir.path().join("D.csv.journal").exists());

    // An unknown base and a one-deformation set are clear errors.
    let mut a = args(&manifest, &out);
    a.extend(["--base", "nope"]);
    let r = qcshape().args(&a).output().unwrap();
    assert!(!r.status.success());
    assert!(String::from_utf8_lossy(&r.stderr).contains("--base \"nope\""));
}

#[test]
fn an_interrupted_run_resumes_to_the_same_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dataset(dir.path(), 2, 16);
    let full = dir.path().join("full.csv");
    let r = qcshape().args(args(&manifest, &full)).output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));

    // Kill a second run once some pairs are in its journal.
    let out = dir.path().join("D.csv");
    let journal = dir.path().join("D.csv.journal");
    let mut child = qcshape()
        .args(args(&manifest, &out))
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let mut killed_with = 0;
    loop {
        let pairs = std::fs::read_to_string(&journal)
            .map(|t| t.lines().filter(|l| l.starts_with("pair,")).count())
            .unwrap_or(0);
        if pairs >= 3 {
            child.kill().unwrap();
            killed_with = pairs;
            break;
        }
        if child.try_wait().unwrap().is_some() || t0.elapsed() > Duration::from_secs(120) {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    child.wait().unwrap();
    assert!(
        killed_with >= 3,
        "the run finished before it could be interrupted"
    );
    assert!(!out.exists(), "no partial output after a kill");
    assert!(journal.exists());

    let mut a = args(&manifest, &out);
    a.push("--resume");
    let r = qcshape().args(&a).output().unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(stderr.contains("resuming:"), "{stderr}");
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        std::fs::read_to_string(&full).unwrap(),
        "resumed matrix differs from the uninterrupted one"
    );
    assert!(!journal.exists());
}

/// The matrix and the per-pose details are the same bytes for 1, 2 and 3 worker threads and
/// across repeated runs, for every metric.
#[test]
fn results_are_bit_identical_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dataset(dir.path(), 1, 6);
    for metric in qcshape::metric::MetricKind::ALL.map(|k| k.label()) {
        let mut first: Option<(Vec<u8>, Vec<u8>)> = None;
        for threads in ["1", "2", "3", "2"] {
            let out = dir.path().join(format!("D-{metric}-{threads}.csv"));
            let details = dir.path().join(format!("P-{metric}-{threads}.csv"));
            let r = qcshape()
                .args([
                    "similarity",
                    manifest.to_str().unwrap(),
                    "--steps",
                    "4",
                    "--insert",
                    "1",
                ])
                .args(["--metric", metric, "--threads", threads, "-o"])
                .arg(&out)
                .arg("--details")
                .arg(&details)
                .output()
                .unwrap();
            assert!(
                r.status.success(),
                "{metric}: {}",
                String::from_utf8_lossy(&r.stderr)
            );
            let got = (std::fs::read(&out).unwrap(), std::fs::read(&details).unwrap());
            match &first {
                None => first = Some(got),
                Some(want) => assert!(
                    *want == got,
                    "{metric}: --threads {threads} gives other bytes than --threads 1"
                ),
            }
        }
    }
}

/// Every metric with every solver gives a matrix near the default solver's: nearer than the
/// straight path (`--approx straight`, the start of every solver, no minimization) is, by a
/// quarter of its gap at least, so a solver that stops without minimizing fails. The l2
/// metric's geodesic is the straight line: there every solver must give the default solver's
/// matrix to 1e-12. Measured on 2026-12-07 (largest entry difference over the largest entry):
/// the solvers differ from the default by up to 1.9e-2 (isometric), 3.2e-2 (conformal) and
/// 4.9e-2 (quasi-conformal) at the default tolerances, the straight path by 4.5e-2, 5.9e-2 and
/// 1.0e-1; rigid 3e-8 against 2e-3.
#[test]
fn every_solver_gives_the_default_solvers_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dataset(dir.path(), 0, 4);
    let out = dir.path().join("D.csv");
    let matrix = |extra: &[&str]| -> Vec<f64> {
        let r = qcshape()
            .args([
                "similarity",
                manifest.to_str().unwrap(),
                "--steps",
                "4",
                "--threads",
                "1",
            ])
            .args(extra)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{extra:?}: {stderr}");
        let d = DistanceMatrix::read_csv(&out).unwrap();
        std::fs::remove_file(&out).unwrap();
        (0..4)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| d.get(i, j))
            .collect()
    };
    let gap = |a: &[f64], b: &[f64]| {
        let top = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0f64, f64::max) / top
    };
    let mut report = Vec::new();
    let mut bad = Vec::new();
    for metric in qcshape::metric::MetricKind::ALL.map(|k| k.label()) {
        let reference = matrix(&["--metric", metric]);
        assert!(reference.iter().all(|v| v.is_finite()), "{metric}: {reference:?}");
        let straight = gap(&reference, &matrix(&["--metric", metric, "--approx", "straight"]));
        report.push(format!("{metric} / straight path: {straight:.2e}"));
        // What a solver may miss the default solver's matrix by.
        let allowed = if metric == "l2" { 1e-12 } else { 0.75 * straight };
        for solver in ["pose-kronecker", "hessian-kronecker"] {
            let g = gap(&reference, &matrix(&["--metric", metric, "--solver", solver]));
            report.push(format!("{metric} / {solver}: {g:.2e}"));
            if g.is_nan() || g > allowed {
                bad.push(format!("{metric} / {solver}: {g:.2e}, more than {allowed:.2e}"));
            }
        }
    }
    eprintln!("{}", report.join("\n"));
    assert!(
        bad.is_empty(),
        "solvers off the default solver's matrix:\n{}",
        bad.join("\n")
    );
}

/// A journal cut at any byte of its last record resumes (with another thread count) to the
/// bytes of the uninterrupted run, `--details` included; a torn record is reported.
#[test]
fn a_torn_last_journal_record_is_recomputed() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dataset(dir.path(), 0, 4);
    let full = dir.path().join("full.csv");
    let full_details = dir.path().join("full-poses.csv");
    let base = |out: &Path, details: &Path, threads: &str| {
        let mut c = qcshape();
        c.args([
            "similarity",
            manifest.to_str().unwrap(),
            "--steps",
            "4",
            "--metric",
            "isometric",
        ])
        .args(["--threads", threads, "-o"])
        .arg(out)
        .arg("--details")
        .arg(details);
        c
    };
    let r = base(&full, &full_details, "1").output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));

    // A run whose details cannot be written (their folder is missing) leaves a complete
    // journal behind. (An output path naming a folder is refused before computing.)
    let out = dir.path().join("D.csv");
    let details = dir.path().join("poses.csv");
    let r = base(&out, &dir.path().join("missing/poses.csv"), "1")
        .output()
        .unwrap();
    assert!(!r.status.success());
    let _ = std::fs::remove_file(&out);
    let journal = dir.path().join("D.csv.journal");
    let whole = std::fs::read(&journal).unwrap();
    let text = String::from_utf8(whole.clone()).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("pair,")).count(), 6);
    let last_start = text[..text.len() - 1].rfind('\n').unwrap() + 1;
    for cut in last_start..whole.len() {
        std::fs::write(&journal, &whole[..cut]).unwrap();
        let r = base(&out, &details, "2").arg("--resume").output().unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "cut at {cut}: {stderr}");
        assert_eq!(
            stderr.contains("torn or changed (it fails its checksum); dropped, its pair is recomputed"),
            cut > last_start && cut + 1 < whole.len(),
            "cut at {cut}: {stderr}"
        );
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(&full).unwrap(),
            "cut at {cut}"
        );
        assert_eq!(
            std::fs::read(&details).unwrap(),
            std::fs::read(&full_details).unwrap(),
            "cut at {cut}"
        );
        assert!(!journal.exists());
    }

    // A forged record with a valid checksum: pair (0, 1) with one pose distance where the run
    // has K, and pair (0, 2) with a distance that is not its poses' sum. Both are dropped with
    // a warning naming them, and recomputed: the same matrix as the uninterrupted run.
    let lines: Vec<&str> = text.lines().collect();
    let first = lines.iter().position(|l| l.starts_with("pair,")).unwrap();
    let k = lines[first].split(',').nth(7).unwrap().split(';').count();
    assert!(k > 1, "{}", lines[first]);
    let forged = [
        "pair,0,1,1.5,true,3,0.5,1.5,0.5:0.5".to_string(),
        format!(
            "pair,0,2,9.5,true,3,0.5,{},{}",
            vec!["1.0"; k].join(";"),
            vec!["0.5:0.5"; k].join(";")
        ),
    ];
    let mut text_forged: Vec<String> = lines[..first].iter().map(|l| l.to_string()).collect();
    for body in &forged {
        text_forged.push(format!("{body},#{:016x}", fnv1a(body)));
    }
    text_forged.extend(
        lines[first..]
            .iter()
            .filter(|l| !(l.starts_with("pair,0,1,") || l.starts_with("pair,0,2,")))
            .map(|l| l.to_string()),
    );
    std::fs::write(&journal, text_forged.join("\n") + "\n").unwrap();
    let r = base(&out, &details, "1").arg("--resume").output().unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    let want = format!(
        "the record on line {} (pair 0, 1): 1 pose distance(s) where the run has {k} poses",
        first + 1
    );
    assert!(stderr.contains(&want), "{want}\n{stderr}");
    assert!(
        stderr.contains("(pair 0, 2): distance 9.5 is not the sum"),
        "{stderr}"
    );
    assert!(
        stderr.contains(&format!("resuming: {} of 6 pairs already done", 6 - 2)),
        "{stderr}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&full).unwrap());
    assert_eq!(
        std::fs::read(&details).unwrap(),
        std::fs::read(&full_details).unwrap()
    );
}

/// The journal's record check (FNV-1a 64 of the record's text), to forge records.
fn fnv1a(text: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// `-o D.npy` writes the same matrix as the CSV, as a NumPy float64 array (n, n) in C order, with
/// the names beside it in D.names.txt.
#[test]
fn npy_output_holds_the_csv_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dataset(&dir.path().join("S"), 0, 4);
    let csv = dir.path().join("D.csv");
    let npy = dir.path().join("D.npy");
    for out in [&csv, &npy] {
        let status = qcshape()
            .args(args(&manifest, out))
            .stderr(Stdio::null())
            .status()
            .unwrap();
        assert!(status.success());
    }
    let d = DistanceMatrix::read_csv(&csv).unwrap();
    let bytes = std::fs::read(&npy).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
    assert!(
        header.contains("'descr': '<f8'") && header.contains("'fortran_order': False"),
        "{header}"
    );
    assert!(header.contains("'shape': (4, 4)"), "{header}");
    let data = &bytes[10 + header_len..];
    assert_eq!(data.len(), 16 * 8);
    let values: Vec<f64> = data
        .chunks(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(values, d.values());
    let names = std::fs::read_to_string(dir.path().join("D.names.txt")).unwrap();
    assert_eq!(names.lines().collect::<Vec<_>>(), d.names());
}

/// `--details` holds the energy split of every pose's path and the pair's regularizer share
/// (the regularizer's part of the pair's summed energy, checked against the split); the distribution of the
/// shares is printed, with a warning when the regularizer carries most of the energy of most
/// pairs: with `--lambda 100`, not with `--lambda 0.001`.
#[test]
fn details_hold_the_energy_split_and_a_dominant_regularizer_is_warned() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dataset(dir.path(), 1, 6);
    for (lambda, warned) in [("100", true), ("0.001", false)] {
        let out = dir.path().join(format!("D-{lambda}.csv"));
        let details = dir.path().join(format!("P-{lambda}.csv"));
        let mut a = args(&manifest, &out);
        a.extend(["--lambda", lambda, "--details", details.to_str().unwrap()]);
        let r = qcshape().args(&a).output().unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{stderr}");
        assert!(
            stderr.contains("energy share of the L2 regularizer over 15 pairs: min "),
            "{stderr}"
        );
        let warning = "warning: the L2 regularizer carries more than half of the energy for ";
        assert_eq!(stderr.contains(warning), warned, "--lambda {lambda}: {stderr}");
        if warned {
            assert!(
                stderr.contains(
                    "of 15 pairs: the isometric distances measure L2 displacement more than the \
                     metric's geometry (lower --lambda)"
                ),
                "{stderr}"
            );
        }
        let text = std::fs::read_to_string(&details).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some("a,b,pose,distance,converged,geometric_energy,regularizer_energy,regularizer_share")
        );
        // Per pair: summed geometric and regularizer energies, and the share of its rows.
        let mut pairs: std::collections::BTreeMap<(String, String), (f64, f64, Vec<f64>)> =
            Default::default();
        for line in lines {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f.len(), 8, "{line}");
            let num = |k: usize| -> f64 { f[k].parse().unwrap_or_else(|_| panic!("{line}")) };
            let (d, g, reg, share) = (num(3), num(5), num(6), num(7));
            assert!(g >= 0.0 && reg >= 0.0, "{line}");
            if f[2] == "0" {
                assert_eq!((d, g, reg), (0.0, 0.0, 0.0), "{line}");
            } else {
                assert!(d > 0.0 && g > 0.0 && reg > 0.0, "{line}");
            }
            let e = pairs.entry((f[0].into(), f[1].into())).or_default();
            e.0 += g;
            e.1 += reg;
            e.2.push(share);
        }
        assert_eq!(pairs.len(), 15);
        for (ab, (g, reg, shares)) in &pairs {
            let want = reg / (g + reg);
            assert!(
                shares.iter().all(|s| (s - want).abs() <= 1e-12),
                "{ab:?}: {shares:?} vs {want}"
            );
            assert_eq!(want > 0.5, warned, "--lambda {lambda}: {ab:?} share {want}");
        }
    }
}
