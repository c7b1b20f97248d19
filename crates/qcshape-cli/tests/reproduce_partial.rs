//! `qcshape reproduce` writes report.md after every step: killed after Table 1, it leaves a
//! report holding Table 1, marked as partial (issue 21).

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// `qcshape --quiet reproduce --quick --metrics l2,rigid EXTRA --out OUT`.
fn quick_reproduction(out: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_qcshape"));
    cmd.args(["--quiet", "reproduce", "--quick", "--metrics", "l2,rigid"])
        .args(extra)
        .arg("--out")
        .arg(out);
    cmd
}

#[test]
fn a_killed_reproduction_leaves_a_partial_report_with_table_1() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    // The smallest run: --quick with one cheap metric first (Table 1's first row in a second
    // or two); Fig. 4, Fig. 5 and Table 3 follow and take longer.
    let mut child = quick_reproduction(&out, &[])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let report = out.join("report.md");
    let start = Instant::now();
    let text = loop {
        if let Ok(t) = std::fs::read_to_string(&report) {
            if t.contains("## Table 1") && t.contains("| l2 |") {
                break t;
            }
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!("reproduce ended ({status}) before a report with Table 1 was seen");
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no report with Table 1 after 300 s"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        text.contains("Partial report: still running (written after Table 1"),
        "{text}"
    );
    // The file on disk is a whole report (written to a temporary name, then renamed).
    let on_disk = std::fs::read_to_string(&report).unwrap();
    assert!(on_disk.starts_with("# qcshape reproduction") && on_disk.contains("## Table 1"));
    assert!(on_disk.contains("Partial report"));
}

/// `--noise-metrics` must name metrics of `--metrics` (its Table 1 run is Table 3's reference):
/// refused before any work, with the reason and no output folder.
#[test]
fn a_noise_metric_outside_the_metrics_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = quick_reproduction(&out, &["--noise-metrics", "l2,isometric"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--noise-metrics isometric is not among --metrics"),
        "{err}"
    );
    assert!(!out.join("report.md").exists());
}
