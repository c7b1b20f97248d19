//! The documentation, checked: the reference pages (README.md and docs/*.md; not the dated
//! measurement logs in docs/log/) state no retired default, every `docs/...md` path that a page
//! or a source file cites exists, and every section cited by name (`docs/method.md "Metrics"`,
//! `README, "What the measurements say"`) is a heading of that page.

use std::fs;
use std::path::{Path, PathBuf};

/// Phrases that presented a retired default as current (matched without case, backticks and line
/// breaks). Each was the default once: quasi-conformal with `lambda` 0.1 on the raw scale until
/// 2026-12-04, the calibrated scale until 2026-12-06, 10 Taubin iterations of smoothing until
/// issue 51, the fit's ARAP prior with stiffness 20 to 0.1 until 2026-12-06. A dated log may
/// say so; a reference page must not present them as today's.
const RETIRED: &[&str] = &[
    "quasi-conformal + 0.1 l2",
    "quasi-conformal + 0.1*l2",
    "default metric (quasi-conformal",
    "default quasi-conformal",
    "quasi-conformal default",
    "quasi-conformal (default)",
    "calibrated (the default)",
    "--scale calibrated (the default",
    "--scale calibrated, the default",
    "calibrated isometric default",
    "isometric, calibrated, lam=0.01",
    "isometric, calibrated, lambda 0.01",
    "isometric, --scale calibrated",
    "--smooth 10 (default",
    "--lambda 0.1 (default",
    "arap (as-rigid-as-possible, edge strain; the default)",
    "non-rigid fit under an as-rigid-as-possible",
    "geometrically from 20 to 0.1",
];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn files(dir: &Path, ext: &[&str], out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else { return };
    for e in entries {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy();
        if p.is_dir() {
            if name != "target" && !name.starts_with('.') {
                files(&p, ext, out);
            }
        } else if ext.iter().any(|x| name.ends_with(x)) {
            out.push(p);
        }
    }
}

/// The reference pages: README.md and docs/*.md (docs/log/ holds the dated logs).
fn reference_pages() -> Vec<PathBuf> {
    let mut pages = vec![root().join("README.md")];
    for e in fs::read_dir(root().join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            pages.push(p);
        }
    }
    pages.sort();
    pages
}

/// Every page and source file that may cite a page.
fn citing_files() -> Vec<PathBuf> {
    let mut out = vec![root().join("README.md")];
    files(&root().join("docs"), &[".md"], &mut out);
    files(&root().join("crates"), &[".rs", ".py", ".pyi"], &mut out);
    // This file cites on purpose (its own test of the checks).
    out.retain(|p| !p.ends_with("tests/docs.rs"));
    out
}

/// `text` as one line: each line trimmed of its comment marker (`//!`, `///`, `//`, `#`, `>`) and
/// of a string's line-continuation `\`, joined with single spaces, so that a citation broken
/// over two comment lines reads as one.
fn one_line(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut t = line.trim();
        for marker in ["//!", "///", "//", "#", ">"] {
            if let Some(rest) = t.strip_prefix(marker) {
                t = rest.trim();
                break;
            }
        }
        let t = t.trim_end_matches('\\').trim();
        if !t.is_empty() {
            out.push_str(t);
            out.push(' ');
        }
    }
    out
}

/// The headings (any level) of a Markdown page, without their `#`s.
fn headings(page: &Path) -> Vec<String> {
    let text = fs::read_to_string(page).unwrap_or_else(|e| panic!("{}: {e}", page.display()));
    let mut in_code = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.starts_with("```") {
            in_code = !in_code;
        } else if !in_code && line.starts_with('#') {
            out.push(line.trim_start_matches('#').trim().to_string());
        }
    }
    out
}

/// The citations in `text`: every `docs/...md` path, and the section name quoted right after it
/// (or after `README`), if any.
fn citations(text: &str) -> Vec<(String, Option<String>)> {
    let is_path = |c: char| c.is_ascii_alphanumeric() || matches!(c, '/' | '-' | '_' | '.');
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(i) = text[from..].find("docs/").map(|i| from + i) {
        from = i + 5;
        if i > 0 && is_path(text[..i].chars().next_back().unwrap()) {
            continue; // a longer path (`crates/.../docs/`)
        }
        let len = text[i..].find(|c: char| !is_path(c)).unwrap_or(text.len() - i);
        let path = text[i..i + len].trim_end_matches('.');
        if !path.ends_with(".md") {
            continue;
        }
        out.push((path.to_string(), quoted_after(&text[i + path.len()..])));
    }
    let mut from = 0;
    while let Some(i) = text[from..].find("README").map(|i| from + i) {
        from = i + 6;
        if let Some(name) = quoted_after(&text[from..]) {
            out.push(("README.md".into(), Some(name)));
        }
    }
    out
}

/// The name in quotes that follows `rest` after at most a backtick, a comma and spaces. A quote
/// right after the path closes a string literal that holds the path (`let md =
/// "docs/defaults.md";`): no section.
fn quoted_after(rest: &str) -> Option<String> {
    if rest.starts_with('"') || rest.starts_with("\\\"") {
        return None;
    }
    let rest = rest.strip_prefix('`').unwrap_or(rest);
    let rest = rest.strip_prefix(',').unwrap_or(rest).trim_start();
    let rest = rest.strip_prefix('\\').unwrap_or(rest);
    let rest = rest.strip_prefix('"')?;
    let end = rest.find('"')?;
    Some(rest[..end].trim_end_matches('\\').to_string())
}

#[test]
fn reference_pages_state_no_retired_default() {
    let mut found = Vec::new();
    for page in reference_pages() {
        let text = one_line(&fs::read_to_string(&page).unwrap())
            .replace('`', "")
            .to_lowercase();
        for phrase in RETIRED {
            if text.contains(phrase) {
                found.push(format!(
                    "{}: {phrase:?}",
                    page.strip_prefix(root()).unwrap().display()
                ));
            }
        }
    }
    assert!(
        found.is_empty(),
        "retired defaults presented on reference pages (move dated measurements to docs/log/):\n{}",
        found.join("\n")
    );
}

#[test]
fn every_cited_page_and_section_exists() {
    let mut missing = Vec::new();
    for file in citing_files() {
        let Ok(text) = fs::read_to_string(&file) else {
            continue;
        };
        let rel = file.strip_prefix(root()).unwrap().display().to_string();
        for (path, section) in citations(&one_line(&text)) {
            let page = root().join(&path);
            if !page.is_file() {
                missing.push(format!("{rel}: {path} does not exist"));
                continue;
            }
            if let Some(name) = section {
                if !headings(&page).iter().any(|h| h.starts_with(&name)) {
                    missing.push(format!("{rel}: {path} has no section {name:?}"));
                }
            }
        }
    }
    assert!(missing.is_empty(), "broken citations:\n{}", missing.join("\n"));
}

/// Relative Markdown links (`[text](page.md)`, images) point at files that exist.
#[test]
fn every_markdown_link_resolves() {
    let mut pages = vec![root().join("README.md")];
    files(&root().join("docs"), &[".md"], &mut pages);
    let mut missing = Vec::new();
    for page in pages {
        let text = fs::read_to_string(&page).unwrap();
        let mut from = 0;
        while let Some(i) = text[from..].find("](").map(|i| from + i) {
            let rest = &text[i + 2..];
            from = i + 2;
            let Some(end) = rest.find(')') else { continue };
            let target = rest[..end].split('#').next().unwrap();
            if target.is_empty() || target.contains("://") {
                continue;
            }
            if !page.parent().unwrap().join(target).exists() {
                missing.push(format!(
                    "{}: {target}",
                    page.strip_prefix(root()).unwrap().display()
                ));
            }
        }
    }
    assert!(missing.is_empty(), "broken links:\n{}", missing.join("\n"));
}

/// The checks themselves, on text with what they must find.
#[test]
fn the_checks_find_what_they_look_for() {
    let text = one_line(
        "/// see docs/method.md \"Metrics\" and (docs/log/speed.md).\n\
         //! broken over lines: docs/method.md\n//! \"Path energy, geodesics, distance\"\n\
         let s = \"(docs/method.md \\\"Noise\\\")\";\n\
         crates/x/docs/not-a-citation.md; README, \"What the measurements say\"\n\
         let md = \"docs/defaults.md\";\n    let data = \"crates/x.rs\";",
    );
    let c = citations(&text);
    let want: Vec<(String, Option<String>)> = vec![
        ("docs/method.md".into(), Some("Metrics".into())),
        ("docs/log/speed.md".into(), None),
        (
            "docs/method.md".into(),
            Some("Path energy, geodesics, distance".into()),
        ),
        ("docs/method.md".into(), Some("Noise".into())),
        ("docs/defaults.md".into(), None),
        ("README.md".into(), Some("What the measurements say".into())),
    ];
    assert_eq!(c, want);
    let page = one_line("| default | quasi-conformal +\n0.1 `l2` (default) |").to_lowercase();
    assert!(
        RETIRED.iter().any(|p| page.replace('`', "").contains(p)),
        "{page}"
    );
}
