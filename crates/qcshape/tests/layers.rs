//! The library's layers, checked: every module may import only modules below it in [`ORDER`]
//! (`crate::X` paths in its non-test code), so no import runs upward and there is no cycle
//! between modules. docs/design.md shows the layers.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

/// The top-level modules from the ground floor up.
const ORDER: &[&str] = &[
    // foundation: bounds, number formatting, output paths
    "limits",
    "numfmt",
    "outputs",
    // meshes, their rigid alignment and their files
    "mesh",
    "align",
    "io",
    "multires",
    "dataset",
    // the shape space: metrics, geodesics, transport
    "metric",
    "geodesic",
    "transport",
    // generated data sets
    "synth",
    // the similarity engine (eq. 13) and what works on its matrices
    "similarity",
    "cluster",
    "embed",
    "eval",
    // the facade: defaults, the settings table, the shape space
    "defaults",
    "settings",
    "space",
    // studies and maps built on the facade
    "plot",
    "render",
    "contribution",
    "explain",
    "localize",
    "lv",
    "experiment",
];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Module files declared `#[cfg(test)] mod NAME;` (test support, not library code).
fn test_only(files: &[PathBuf]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for f in files {
        let text = fs::read_to_string(f).unwrap();
        let lines: Vec<&str> = text.lines().map(str::trim).collect();
        for w in lines.windows(2) {
            if w[0] == "#[cfg(test)]" && w[1].ends_with(';') && w[1].contains("mod ") {
                let name = w[1].trim_end_matches(';').rsplit(' ').next().unwrap();
                let dir = if f.file_name().unwrap() == "mod.rs" || f.file_name().unwrap() == "lib.rs" {
                    f.parent().unwrap().to_path_buf()
                } else {
                    f.with_extension("")
                };
                out.push(dir.join(format!("{name}.rs")));
                out.push(dir.join(name).join("mod.rs"));
            }
        }
    }
    out
}

/// The `crate::X` modules the non-test, non-comment code of `text` names.
fn imports(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.starts_with("#[cfg(test)]") {
            break; // the test module closes every file that has one
        }
        if t.starts_with("//") {
            continue;
        }
        let code = t.split("//").next().unwrap();
        let mut rest = code;
        while let Some(i) = rest.find("crate::") {
            rest = &rest[i + 7..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_lowercase() || *c == '_')
                .collect();
            out.push((n + 1, name));
        }
    }
    out
}

#[test]
fn no_module_imports_a_module_above_it() {
    let root = src();
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    let skip = test_only(&files);
    let rank = |m: &str| ORDER.iter().position(|x| *x == m);
    let mut upward: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for f in &files {
        let rel = f.strip_prefix(&root).unwrap();
        let top = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        if top == "lib" || skip.contains(f) || rel.to_string_lossy().ends_with("tests.rs") {
            continue;
        }
        let me = rank(&top).unwrap_or_else(|| panic!("module {top} is not in ORDER: place it in its layer"));
        for (line, m) in imports(&fs::read_to_string(f).unwrap()) {
            let Some(other) = rank(&m) else { continue };
            if m != top && other > me {
                upward
                    .entry(format!("{top} -> {m}"))
                    .or_default()
                    .push(format!("{}:{line}", rel.display()));
            }
        }
    }
    assert!(upward.is_empty(), "imports that run upward:\n{upward:#?}");
}

#[test]
fn every_module_is_placed_once() {
    let mut names: Vec<String> = fs::read_dir(src())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter_map(|p| {
            let n = p.file_name()?.to_string_lossy().to_string();
            (p.is_dir() || n.ends_with(".rs")).then(|| n.trim_end_matches(".rs").to_string())
        })
        .filter(|n| n != "lib")
        .collect();
    names.sort();
    names.dedup();
    let mut order: Vec<String> = ORDER.iter().map(|s| s.to_string()).collect();
    order.sort();
    assert_eq!(names, order);
}
