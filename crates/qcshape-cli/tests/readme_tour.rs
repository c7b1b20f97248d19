//! The README's five-minute tour, run as written: the `sh` block after the `<!-- tour -->` marker,
//! line by line in a fresh folder, with `qcshape` on the PATH. Each line must exit 0 and leave the
//! files the next lines and the README's Python example use.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The tour's command lines (comments and blank lines dropped), in order.
fn tour_lines(readme: &str) -> Vec<String> {
    let start = readme
        .find("<!-- tour -->")
        .expect("README.md has no `<!-- tour -->` marker");
    let rest = &readme[start..];
    let open = rest
        .find("```sh\n")
        .expect("no ```sh block after the tour marker")
        + "```sh\n".len();
    let close = rest[open..].find("```").expect("the tour's block is not closed") + open;
    rest[open..close]
        .lines()
        .map(|l| l.trim())
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(str::to_owned)
        .collect()
}

fn readme() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn the_tour_block_is_found_and_starts_from_nothing() {
    let lines = tour_lines(&readme());
    assert!(lines.len() >= 8, "the tour has {} commands", lines.len());
    assert!(
        lines[0].starts_with("qcshape synth"),
        "the tour must start by making its data: {}",
        lines[0]
    );
    for l in &lines {
        assert!(l.starts_with("qcshape "), "every tour line runs qcshape: {l}");
    }
}

#[test]
fn the_readme_tour_runs_as_written() {
    let lines = tour_lines(&readme());
    let dir = tempfile::tempdir().unwrap();
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_qcshape"));
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    for line in &lines {
        let out = Command::new("bash")
            .args(["-eo", "pipefail", "-c", line])
            .current_dir(dir.path())
            .env("PATH", &path)
            .env("RAYON_NUM_THREADS", "2")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "README tour line failed ({}): {line}\nstderr:\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        for text in [&out.stdout, &out.stderr] {
            assert_no_coefficient_string(line, &String::from_utf8_lossy(text));
        }
    }
    for report in ["analysis/report.md", "R/report.md"] {
        let text = std::fs::read_to_string(dir.path().join(report)).unwrap();
        assert_no_coefficient_string(report, &text);
    }
    // What the lines promise, and what the README's Python example reads.
    for f in [
        "syn/manifest.csv",
        "syn/sphere-twist/pose000.ply",
        "syn/sphere-twist/pose002.ply",
        "D.csv",
        "pairs.csv",
        "map.svg",
        "analysis/report.md",
        "R/report.md",
        "fitted/fit/pose2.ply",
        "fitted/quality.csv",
    ] {
        assert!(dir.path().join(f).is_file(), "the tour did not write {f}");
    }
    // The remeshed poses' fit: a quality row per pose, none poor.
    let quality = std::fs::read_to_string(dir.path().join("fitted/quality.csv")).unwrap();
    assert_eq!(quality.lines().count(), 1 + 3, "{quality}");
    assert!(
        quality.lines().skip(1).all(|l| l.ends_with(",false")),
        "{quality}"
    );
    let header = std::fs::read_to_string(dir.path().join("pairs.csv")).unwrap();
    assert!(header.lines().next().unwrap().contains("regularizer_share"));
}

/// The metric is described by its name and settings (`isometric (lambda 0.01, ...)`), never by
/// the built metric's internal coefficient string (`8.07e-4*conformal(quadratic)+...*l2(frozen)`).
fn assert_no_coefficient_string(what: &str, text: &str) {
    for bad in [
        "*l2(",
        "l2(frozen)",
        "*stretch",
        "(relative)",
        "conformal(quadratic",
    ] {
        assert!(
            !text.contains(bad),
            "{what}: the output names the metric by its internal coefficients ({bad}):\n{text}"
        );
    }
}
