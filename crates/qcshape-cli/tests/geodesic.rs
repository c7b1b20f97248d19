//! End-to-end tests of `qcshape geodesic`.

use std::process::Command;

fn qcshape() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qcshape"))
}

fn write_sphere(path: &std::path::Path, level: u32, stretch: f64) {
    let s = qcshape::synth::icosphere(level);
    let pos: Vec<[f64; 3]> = s.positions.iter().map(|p| [p[0], p[1], stretch * p[2]]).collect();
    qcshape::io::write_mesh(path, &pos, s.topology.faces(), &Default::default()).unwrap();
}

#[test]
fn demo_runs_and_reports_a_converged_distance() {
    let out = qcshape()
        .args(["geodesic", "--demo", "--metric", "isometric", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["converged"], true);
    assert!(v["distance"].as_f64().unwrap() > 0.0);
    assert!(v["energy"].as_f64().unwrap() < v["linear_energy"].as_f64().unwrap());
}

#[test]
fn files_in_poses_out() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.ply"), dir.path().join("b.obj"));
    write_sphere(&a, 2, 1.0);
    write_sphere(&b, 2, 1.4);
    let out_dir = dir.path().join("path");
    let out = qcshape()
        .args([
            "geodesic",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--steps",
            "4",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("distance") && stdout.contains("converged   true"),
        "{stdout}"
    );
    for i in 0..=4 {
        let p = out_dir.join(format!("pose{i:03}.ply"));
        let s = qcshape::io::load_shape(&p).unwrap();
        assert_eq!(s.n_vertices(), 162);
    }
}

#[test]
fn mismatched_meshes_and_missing_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.ply"), dir.path().join("b.ply"));
    write_sphere(&a, 1, 1.0);
    write_sphere(&b, 2, 1.0);
    let out = qcshape()
        .args(["geodesic", a.to_str().unwrap(), b.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot be compared") && err.contains("42") && !err.contains("panicked"),
        "{err}"
    );
    let missing = dir.path().join("nope.ply");
    let out = qcshape()
        .args(["geodesic", a.to_str().unwrap(), missing.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nope.ply") && !err.contains("panicked"), "{err}");
}

/// A retired solver (docs/log/solvers.md) or an unknown one is refused with the accepted
/// names, before any work.
#[test]
fn retired_and_unknown_solvers_are_clear_errors() {
    for (name, what) in [
        ("newton", "retired"),
        ("lbfgs", "retired"),
        ("gauss-newton-direct", "retired"),
        ("fast", "unknown"),
    ] {
        let out = qcshape()
            .args(["geodesic", "--demo", "--demo-level", "1", "--solver", name])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(what)
                && err.contains("preconditioned, hessian-kronecker or pose-kronecker")
                && !err.contains("panicked"),
            "{name}: {err}"
        );
    }
}

/// `--energy-tolerance` reaches the solver: a loose one stops on the energy test with a larger
/// gradient, 0 leaves the decision to the gradient test; a negative one is an error.
#[test]
fn energy_tolerance_option_decides_the_energy_test() {
    let run = |et: &str| -> serde_json::Value {
        let out = qcshape()
            .args([
                "geodesic",
                "--demo",
                "--metric",
                "conformal",
                "--json",
                "--energy-tolerance",
                et,
            ])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let (loose, off) = (run("1e-3"), run("0"));
    assert_eq!(loose["stop"], "energy-tolerance", "{loose}");
    assert_eq!(off["stop"], "gradient-tolerance", "{off}");
    let g = |v: &serde_json::Value, k: &str| v[k].as_f64().unwrap();
    assert!(
        g(&off, "gradient_norm") < 1e-2 * g(&loose, "gradient_norm"),
        "{off} {loose}"
    );
    assert!(g(&off, "energy") < g(&loose, "energy"));
    assert!(g(&off, "iterations") > g(&loose, "iterations"));
    let out = qcshape()
        .args(["geodesic", "--demo", "--energy-tolerance=-1"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--energy-tolerance") && !err.contains("panicked"),
        "{err}"
    );
}

/// `--max-iterations` is the solve's limit: a solve stopped there says so in the JSON and warns
/// on stderr with the flag that lifts it; zero is refused by name.
#[test]
fn max_iterations_option_is_the_limit_and_the_warning_names_it() {
    let out = qcshape()
        .args([
            "geodesic",
            "--demo",
            "--demo-level",
            "1",
            "--json",
            "--max-iterations",
            "3",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["iterations"], 3, "{v}");
    assert_eq!(v["stop"], "max-iterations", "{v}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("iteration limit after 3 iterations") && err.contains("--max-iterations"),
        "{err}"
    );
    let out = qcshape()
        .args(["geodesic", "--demo", "--max-iterations", "0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--max-iterations") && !err.contains("panicked"),
        "{err}"
    );
}

/// A vertex pushed through its ring folds the faces around it: the bending term then carries
/// most of the energy, and the warning (and `--json`'s `folding_hinges`) says so and names the
/// way out; `--bending 0` has no bending term, no count and no warning; a smooth motion folds
/// nothing.
#[test]
fn folding_faces_are_counted_and_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let s = qcshape::synth::icosphere(2);
    let mut dented = s.positions.clone();
    dented[0] = dented[0].map(|c| 0.6 * c);
    let (a, b) = (dir.path().join("a.ply"), dir.path().join("b.ply"));
    qcshape::io::write_mesh(&a, &s.positions, s.topology.faces(), &Default::default()).unwrap();
    qcshape::io::write_mesh(&b, &dented, s.topology.faces(), &Default::default()).unwrap();
    let run = |extra: &[&str], b: &std::path::Path| -> serde_json::Value {
        let out = qcshape()
            .args(["geodesic", "--json"])
            .args(extra)
            .arg(&a)
            .arg(b)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let v = run(&[], &b);
    assert_eq!(v["folding_hinges"], 10, "{v}");
    assert!(v["bending_share"].as_f64().unwrap() > 0.5, "{v}");
    let w = v["warnings"].to_string();
    assert!(w.contains("10 of 480 hinges") && w.contains("--bending 0"), "{w}");
    let off = run(&["--bending", "0"], &b);
    assert!(
        off["folding_hinges"].is_null() && off["warnings"] == serde_json::json!([]),
        "{off}"
    );
    let stretched = dir.path().join("c.ply");
    write_sphere(&stretched, 2, 1.5);
    let smooth = run(&[], &stretched);
    assert_eq!(smooth["folding_hinges"], 0, "{smooth}");
}

/// `geodesic A B` and `geodesic B A` give the same distance for every metric, on shapes that
/// are not congruent and differ in size (the normalization factor is symmetric in A and B).
#[test]
fn distance_does_not_depend_on_the_argument_order() {
    let dir = tempfile::tempdir().unwrap();
    let s = qcshape::synth::icosphere(2);
    // Twisted, stretched along z and twice as large.
    let twisted: Vec<[f64; 3]> = qcshape::synth::twist_along_z(&s.positions, 0.8, 1.5)
        .iter()
        .map(|p| p.map(|c| 2.0 * c))
        .collect();
    let (a, b) = (dir.path().join("a.ply"), dir.path().join("b.ply"));
    qcshape::io::write_mesh(&a, &s.positions, s.topology.faces(), &Default::default()).unwrap();
    qcshape::io::write_mesh(&b, &twisted, s.topology.faces(), &Default::default()).unwrap();
    let run = |x: &std::path::Path, y: &std::path::Path, metric: &str| -> (f64, f64) {
        let out = qcshape()
            .args(["geodesic", "--steps", "4", "--json", "--metric", metric])
            .arg(x)
            .arg(y)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(v["normalization"].as_str().unwrap().contains("A and B"));
        (v["distance"].as_f64().unwrap(), v["scale"].as_f64().unwrap())
    };
    for metric in qcshape::metric::MetricKind::ALL.map(|k| k.label()) {
        let (ab, sab) = run(&a, &b, metric);
        let (ba, sba) = run(&b, &a, metric);
        assert_eq!(sab, sba, "{metric}: the factor is symmetric");
        assert!(ab > 0.0 && ab.is_finite(), "{metric}: {ab}");
        // The invariant isometric metric's energy is flat along this large deformation (2x, 3x
        // and a twist): the default solver stops on the energy test 1e-4 from the minimum in
        // one direction (pose-kronecker reaches the same minimum from both, to 1e-10).
        assert!((ab - ba).abs() <= 5e-4 * ab, "{metric}: A B {ab} vs B A {ba}");
    }
}

/// Every file `geodesic --out` writes (poses and maps), by name.
fn written_files(dir: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect()
}

#[test]
fn thread_count_does_not_change_the_output_files() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.ply"), dir.path().join("b.ply"));
    write_sphere(&a, 1, 1.0);
    write_sphere(&b, 1, 1.3);
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out_dir = dir.path().join(format!("path{threads}"));
        let out = qcshape()
            .args([
                "geodesic",
                a.to_str().unwrap(),
                b.to_str().unwrap(),
                "--steps",
                "3",
            ])
            .args(["--threads", threads, "--out"])
            .arg(&out_dir)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let stdout = String::from_utf8_lossy(&out.stdout);
        let distance = stdout
            .lines()
            .find(|l| l.starts_with("distance"))
            .unwrap()
            .to_string();
        outputs.push((distance, written_files(&out_dir)));
    }
    assert!(outputs[0].1.len() >= 4 + 2, "{:?}", outputs[0].1.keys());
    assert_eq!(
        outputs[0].1.keys().collect::<Vec<_>>(),
        outputs[1].1.keys().collect::<Vec<_>>()
    );
    for (name, bytes) in &outputs[0].1 {
        assert!(
            bytes == &outputs[1].1[name],
            "{name} differs between --threads 1 and 2"
        );
    }
    assert_eq!(outputs[0].0, outputs[1].0);
}

#[test]
fn every_geodesic_command_takes_threads() {
    for cmd in [
        &["geodesic"][..],
        &["interpolate"],
        &["transfer"],
        &["experiment", "interpolation"],
    ] {
        let help = qcshape().args(cmd).arg("--help").output().unwrap();
        let text = String::from_utf8_lossy(&help.stdout);
        assert!(text.contains("--threads"), "{cmd:?} --help: {text}");
        let out = qcshape().args(cmd).args(["--threads", "0"]).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{cmd:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--threads") && err.contains("at least 1"),
            "{cmd:?}: {err}"
        );
    }
}

/// Issue 60, items 3 and 5: poses of very different sizes warn naming the units, every warning is
/// in the JSON, and a single solve logs its iterations.
#[test]
fn a_size_mismatch_warns_in_stderr_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.ply"), dir.path().join("b.ply"));
    write_sphere(&a, 1, 1.0);
    let s = qcshape::synth::icosphere(1);
    let big: Vec<[f64; 3]> = s.positions.iter().map(|p| p.map(|c| 1000.0 * c)).collect();
    qcshape::io::write_mesh(&b, &big, s.topology.faces(), &Default::default()).unwrap();
    let out = qcshape()
        .args([
            "geodesic",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--json",
            "--steps",
            "2",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("warning: A's mean edge length") && err.contains("differ by a factor of 1000"),
        "{err}"
    );
    assert!(
        err.contains("in the files' own units") && err.contains("mean-edge units"),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let warnings = v["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().contains("differ by a factor of 1000")),
        "{v}"
    );
    // Same-size poses: no warning, an empty list.
    let out = qcshape()
        .args([
            "geodesic",
            a.to_str().unwrap(),
            a.to_str().unwrap(),
            "--json",
            "--steps",
            "2",
        ])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["warnings"], serde_json::json!([]), "{v}");
}

#[test]
fn an_unconverged_geodesic_says_so_in_every_output() {
    let out = qcshape()
        .args([
            "geodesic",
            "--demo",
            "--demo-level",
            "2",
            "--max-iterations",
            "3",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["converged"], false);
    assert!(
        v["warnings"][0]
            .as_str()
            .unwrap()
            .contains("the distance is not converged"),
        "{v}"
    );
    let out = qcshape()
        .args(["geodesic", "--demo", "--demo-level", "2", "--max-iterations", "3"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("converged   false (MaxIterations): the distance is not converged"),
        "{text}"
    );
}

#[test]
fn a_single_geodesic_logs_its_iterations() {
    // The lines' interval made 0: a line at every redraw (once a second) while the solver runs.
    let out = qcshape()
        // Tolerances 0: the solver runs to its limit, 400 iterations (a few seconds).
        .args([
            "geodesic",
            "--demo",
            "--demo-level",
            "3",
            "--metric",
            "conformal",
            "--tolerance",
            "0",
            "--energy-tolerance",
            "0",
            "--max-iterations",
            "400",
        ])
        .env("QCSHAPE_PROGRESS_SECONDS", "0")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("solving: ")).collect();
    // At least one line while it runs, and a closing line with the count and the time.
    assert!(lines.len() >= 2, "{err}");
    let (last, running) = lines.split_last().unwrap();
    assert!(
        running
            .iter()
            .all(|l| l.contains(" of at most ") && l.contains("iterations/s")),
        "{err}"
    );
    assert!(last.contains("iterations, done in"), "{err}");
}

/// Issue 60, item 2: Ctrl-C (SIGINT) ends a long single geodesic at once (the command installs
/// no handler: the signal ends the process) and leaves no output behind.
#[cfg(unix)]
#[test]
fn sigint_ends_a_long_geodesic_within_a_second() {
    use std::io::BufRead;
    use std::os::unix::process::ExitStatusExt;
    use std::time::{Duration, Instant};
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("path");
    let mut child = qcshape()
        // Without the bending term: minutes at 10,242 vertices (the default takes seconds).
        .args([
            "geodesic",
            "--demo",
            "--demo-level",
            "5",
            "--bending",
            "0",
            "--out",
        ])
        .arg(&out_dir)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // The first line is printed when the solve starts (10,242 vertices: minutes of work).
    let mut first = String::new();
    std::io::BufReader::new(child.stderr.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.starts_with("solving"), "{first}");
    std::thread::sleep(Duration::from_secs(1));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the solve ended before the signal"
    );
    let sent = Instant::now();
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if sent.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            panic!("still running 30 s after SIGINT");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let latency = sent.elapsed();
    assert_eq!(status.signal(), Some(2), "{status:?}");
    assert!(latency < Duration::from_secs(1), "{latency:?}");
    assert!(
        !out_dir.exists(),
        "an interrupted solve wrote {}",
        out_dir.display()
    );
}
