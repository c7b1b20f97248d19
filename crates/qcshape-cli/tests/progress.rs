//! Progress on a non-terminal stderr: plain lines (step, done/total, elapsed, ETA) at the
//! interval `QCSHAPE_PROGRESS_SECONDS` (10 s by default), none with `--quiet`.

use std::process::Command;

fn noise_run(dir: &std::path::Path, interval: &str, quiet: bool) -> String {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_qcshape"));
    cmd.args([
        "experiment",
        "noise",
        "--level",
        "0",
        "--levels",
        "1",
        "--kinds",
        "uniform",
        "--steps",
        "2",
        "--restarts",
        "2",
        "--out",
    ])
    .arg(dir)
    .env("QCSHAPE_PROGRESS_SECONDS", interval);
    if quiet {
        cmd.arg("--quiet");
    }
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stderr).unwrap()
}

fn progress_lines(log: &str) -> Vec<&str> {
    log.lines()
        .filter(|l| l.contains("ETA") && l.contains('/'))
        .collect()
}

#[test]
fn a_log_gets_progress_lines_and_quiet_silences_them() {
    let dir = tempfile::tempdir().unwrap();
    let log = noise_run(&dir.path().join("a"), "0", false);
    let lines = progress_lines(&log);
    // The stages of both runs (noise-free and noisy: interpolation, transfer, pairs) report once
    // they have done something (a stage that ends between two redraws may not).
    assert!(lines.len() >= 3, "{log}");
    assert!(
        lines
            .iter()
            .any(|l| l.contains("pairs") || l.contains("noise-free")),
        "{log}"
    );
    assert!(
        lines.iter().all(|l| !l.contains('\u{1b}')),
        "no terminal escapes in a log: {log}"
    );
    // No line before anything is done (no `0/N [00:00:00, ETA 0s]`), unless the solver is
    // iterating on the first item (issue 60: a line while the first pair is solved).
    assert!(
        lines
            .iter()
            .all(|l| !l.split_whitespace().any(|w| w.starts_with("0/")) || l.contains("solver iterations")),
        "{log}"
    );
    // A run shorter than the interval prints no progress line: the first comes one interval after
    // the bar starts.
    let sparse_log = noise_run(&dir.path().join("b"), "1000", false);
    let sparse = progress_lines(&sparse_log);
    assert!(sparse.is_empty(), "{sparse:?}");
    let quiet = noise_run(&dir.path().join("c"), "0", true);
    assert!(progress_lines(&quiet).is_empty(), "{quiet}");
}
