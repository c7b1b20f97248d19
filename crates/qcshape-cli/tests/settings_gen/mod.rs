//! The texts generated from the one declaration of the settings (`qcshape::settings`): the
//! `.pyi` stub's option lists, docs/defaults.md's table and the Python text signatures of the
//! data-set functions. Shared by `examples/gen-settings.rs` (writes them) and
//! `tests/settings.rs` (fails when a file differs from them).

use std::path::{Path, PathBuf};

use qcshape::settings::{pyi_lines, python_signature, Group};

/// The command that rewrites the generated texts.
pub const REFRESH: &str = "cargo run -p qcshape-cli --example gen-settings";

const ALL: &[Group] = &[Group::Metric, Group::Solver, Group::Pipeline];

/// The repository's root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `text` with the lines strictly between the line containing `begin` and the next line
/// containing `end` replaced by `body`.
fn between(text: &str, begin: &str, end: &str, body: &[String]) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let b = lines
        .iter()
        .position(|l| l.contains(begin))
        .unwrap_or_else(|| panic!("no line with {begin:?}"));
    let e = b + lines[b..]
        .iter()
        .position(|l| l.contains(end))
        .unwrap_or_else(|| panic!("no line with {end:?} after {begin:?}"));
    let mut out: Vec<String> = lines[..=b].iter().map(|l| l.to_string()).collect();
    out.extend(body.iter().cloned());
    out.extend(lines[e..].iter().map(|l| l.to_string()));
    out.join("\n") + "\n"
}

/// The `.pyi` stub with its generated blocks: `_PipelineOptions`' entries and `ShapeSpace`'s
/// keyword parameters (the metric and solver settings but `metric`, its positional argument).
fn pyi(text: &str) -> String {
    let t = between(
        text,
        "# BEGIN settings: _PipelineOptions",
        "# END settings",
        &pyi_lines(ALL, "    ", false),
    );
    let space: Vec<String> = pyi_lines(&[Group::Metric, Group::Solver], "        ", true)
        .into_iter()
        .filter(|l| !l.trim_start().starts_with("metric:"))
        .collect();
    between(&t, "# BEGIN settings: ShapeSpace", "# END settings", &space)
}

/// docs/defaults.md with its generated table.
fn defaults_md(text: &str) -> String {
    let table: Vec<String> = qcshape::settings::markdown_table()
        .lines()
        .map(str::to_string)
        .collect();
    between(
        text,
        "<!-- BEGIN settings table",
        "<!-- END settings table",
        &table,
    )
}

/// data.rs with every `text_signature`'s settings (from `metric=` to `, threads=`) generated.
fn data_rs(text: &str) -> String {
    let sig = python_signature(ALL);
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find("text_signature = \"(") {
        let (done, tail) = rest.split_at(i);
        out.push_str(done);
        let m = tail.find("metric=").expect("a text_signature with the settings");
        let t = tail
            .find(", threads=")
            .expect("a text_signature ending with threads");
        out.push_str(&tail[..m]);
        out.push_str(&sig);
        rest = &tail[t..];
    }
    out.push_str(rest);
    out
}

/// Every generated file: (path from the root, expected content).
pub fn expected() -> Vec<(PathBuf, String)> {
    let r = root();
    let read = |p: &str| std::fs::read_to_string(r.join(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let pyi_path = "crates/qcshape-py/python/qcshape/__init__.pyi";
    let md = "docs/defaults.md";
    let data = "crates/qcshape-py/src/data.rs";
    vec![
        (PathBuf::from(pyi_path), pyi(&read(pyi_path))),
        (PathBuf::from(md), defaults_md(&read(md))),
        (PathBuf::from(data), data_rs(&read(data))),
    ]
}
