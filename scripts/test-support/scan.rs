//! The scanner of the layer tests (`crates/*/tests/layers.rs`; each includes this file and
//! `floors.rs` by path, so no crate's tests reach into another's) and of `scripts/layers`: a
//! crate's Rust files, its non-test code, and its `crate::X` imports.
//!
//! Non-test code is the whole file but comments, literals, the bodies of `#[cfg(test)] mod NAME
//! { ... }` (found by brace matching) and files that are test modules (`#[cfg(test)] mod NAME;`,
//! `tests.rs`).

// Each test crate that includes this file uses a part of it.
#![allow(dead_code)]

use std::fs;
use std::path::{Path, PathBuf};

pub fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
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
pub fn test_only(files: &[PathBuf]) -> Vec<PathBuf> {
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

/// `text` with comments and the contents of string and character literals blanked (newlines kept,
/// so line numbers stay): braces and `crate::` are then seen only where they are code.
pub fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let at = |k: usize| c.get(k).copied().unwrap_or('\0');
    let mut out = String::with_capacity(text.len());
    let blank = |out: &mut String, from: usize, to: usize| {
        out.extend(
            c[from..to.min(c.len())]
                .iter()
                .map(|&ch| if ch == '\n' { '\n' } else { ' ' }),
        )
    };
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut i = 0;
    while i < c.len() {
        let end = if c[i] == '/' && at(i + 1) == '/' {
            (i..c.len()).find(|&k| c[k] == '\n').unwrap_or(c.len())
        } else if c[i] == '/' && at(i + 1) == '*' {
            // block comments nest
            let (mut k, mut depth) = (i, 0);
            loop {
                if k >= c.len() {
                    break k;
                } else if c[k] == '/' && at(k + 1) == '*' {
                    depth += 1;
                    k += 2;
                } else if c[k] == '*' && at(k + 1) == '/' {
                    depth -= 1;
                    k += 2;
                    if depth == 0 {
                        break k;
                    }
                } else {
                    k += 1;
                }
            }
        } else if (i == 0 || !ident(c[i - 1])) && (c[i] == 'r' || (c[i] == 'b' && at(i + 1) == 'r')) && {
            let s = if c[i] == 'b' { i + 2 } else { i + 1 };
            at(s + (s..c.len()).take_while(|&k| c[k] == '#').count()) == '"'
        } {
            // a raw string r#"..."#: it ends at a quote followed by as many hashes
            let s = if c[i] == 'b' { i + 2 } else { i + 1 };
            let hashes = (s..c.len()).take_while(|&k| c[k] == '#').count();
            let mut k = s + hashes + 1;
            while k < c.len() && !(c[k] == '"' && (1..=hashes).all(|h| at(k + h) == '#')) {
                k += 1;
            }
            k + 1 + hashes
        } else if c[i] == '"' {
            let mut k = i + 1;
            while k < c.len() && c[k] != '"' {
                k += if c[k] == '\\' { 2 } else { 1 };
            }
            k + 1
        } else if c[i] == '\'' && (at(i + 1) == '\\' || (at(i + 1) != '\'' && at(i + 2) == '\'')) {
            // a character literal ('x', '\n', '\'', '\u{..}'); a lifetime 'a has no closing quote
            let mut k = i + 1;
            while k < c.len() && c[k] != '\'' {
                k += if c[k] == '\\' { 2 } else { 1 };
            }
            k + 1
        } else {
            out.push(c[i]);
            i += 1;
            continue;
        };
        blank(&mut out, i, end);
        i = end;
    }
    out
}

/// `code` (from [`code_only`]) with every `#[cfg(test)] mod NAME { ... }` blanked, found by brace
/// matching; a `#[cfg(test)] mod NAME;` file is left out by [`test_only`] instead. Everything else
/// is kept, including code after a test module.
pub fn without_test_modules(code: &str) -> String {
    let c: Vec<char> = code.chars().collect();
    let mut out = c.clone();
    let skip_ws = |mut k: usize| {
        while k < c.len() && c[k].is_whitespace() {
            k += 1;
        }
        k
    };
    let word = |k: usize| -> String {
        c[k..]
            .iter()
            .take_while(|ch| ch.is_alphanumeric() || **ch == '_')
            .collect()
    };
    // the index just past the bracket that closes the one opened at `k`
    let close = |k: usize, open: char, shut: char| {
        let mut depth = 0usize;
        for (j, &ch) in c.iter().enumerate().skip(k) {
            if ch == open {
                depth += 1;
            } else if ch == shut {
                depth -= 1;
                if depth == 0 {
                    return j + 1;
                }
            }
        }
        c.len()
    };
    let attr: Vec<char> = "#[cfg(test)]".chars().collect();
    let mut i = 0;
    while i + attr.len() <= c.len() {
        if c[i..i + attr.len()] != attr[..] {
            i += 1;
            continue;
        }
        // further attributes, a visibility, then `mod NAME {`
        let mut k = skip_ws(i + attr.len());
        while c.get(k) == Some(&'#') && c.get(k + 1) == Some(&'[') {
            k = skip_ws(close(k + 1, '[', ']'));
        }
        if word(k) == "pub" {
            k = skip_ws(k + 3);
            if c.get(k) == Some(&'(') {
                k = skip_ws(close(k, '(', ')'));
            }
        }
        if word(k) == "mod" {
            k = skip_ws(k + 3);
            k = skip_ws(k + word(k).len());
            if c.get(k) == Some(&'{') {
                let end = close(k, '{', '}');
                for ch in &mut out[i..end] {
                    if *ch != '\n' {
                        *ch = ' ';
                    }
                }
                i = end;
                continue;
            }
        }
        i += attr.len();
    }
    out.into_iter().collect()
}

/// The `crate::X` modules (and each `X` of `crate::{X, Y::Z}`) that the code of `text` names,
/// outside comments, literals and `#[cfg(test)] mod { }` blocks, with their line numbers.
pub fn imports(text: &str) -> Vec<(usize, String)> {
    let code: Vec<char> = without_test_modules(&code_only(text)).chars().collect();
    let line = |k: usize| 1 + code[..k].iter().filter(|&&ch| ch == '\n').count();
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let name = |k: usize| -> String { code[k..].iter().take_while(|&&ch| ident(ch)).collect() };
    let key: Vec<char> = "crate::".chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i + key.len() <= code.len() {
        if code[i..i + key.len()] != key[..] || (i > 0 && ident(code[i - 1])) {
            i += 1;
            continue;
        }
        let k = i + key.len();
        if code.get(k) == Some(&'{') {
            // a group: the first name of each item at its top level
            let (mut depth, mut j, mut first) = (0usize, k, true);
            while j < code.len() {
                match code[j] {
                    '{' => {
                        depth += 1;
                        first = depth == 1;
                    }
                    '}' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    ',' if depth == 1 => first = true,
                    ch if first && depth == 1 && ident(ch) => {
                        out.push((line(j), name(j)));
                        first = false;
                    }
                    _ => {}
                }
                j += 1;
            }
        } else {
            out.push((line(k), name(k)));
        }
        i = k;
    }
    out
}

/// The top-level modules of the crate whose sources are `src` (directories and `.rs` files but
/// `lib.rs`), sorted.
pub fn top_modules(src: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(src)
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
    names
}
