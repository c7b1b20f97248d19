//! Import arrows between the modules of each folder of a crate, and the check of each folder's
//! floors (`crates/*/floors.txt`). Shared by the layer test of every crate (included by path
//! beside `scan.rs`) and by `scripts/layers`, which prints the loops and upward arrows of every
//! folder.
//!
//! An arrow `a -> b` in folder `F` is a path in the non-test code of module `F::a` (or of a
//! module under it) that names `F::b` or something under it: `crate::F::b::X`, `super::b::X`,
//! `super::{b, c}`, `self::...`. A path that names an item of `F` itself (`super::Trait`, an item
//! of `F/mod.rs` or of `lib.rs`, re-exports included) is an arrow `a -> mod`: it runs upward,
//! since `F/mod.rs` declares `a`. With floors, an arrow runs upward when its target is on the
//! same floor or higher.
//!
//! `floors.txt` has one line per folder (`crate` for `src/` itself, `similarity`,
//! `geodesic/research`, ...): `FOLDER = a b | c | d e`, the folder's modules from the ground
//! floor up, floors separated by `|` (modules on one floor may not import each other); or
//! `FOLDER = pending N` for a folder whose floors are not set yet, with the count of its arrows
//! that are upward or on a loop, which may not grow. `#` starts a comment.

#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

use super::scan::{code_only, rust_files, test_only, without_test_modules};

/// One import arrow inside a folder.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Arrow {
    /// The folder (`crate` for `src/`, else its path under `src/` with `/`).
    pub folder: String,
    /// The importing child module.
    pub from: String,
    /// The imported child module, or `mod` for an item of the folder's own file.
    pub to: String,
    /// Where: `file:line`, relative to `src/`.
    pub at: String,
}

/// A folder's floors as written in `floors.txt`.
#[derive(Debug, Clone, PartialEq)]
pub enum Floors {
    /// The modules of each floor, from the ground up.
    Set(Vec<Vec<String>>),
    /// Not set yet: at most this many upward or looping arrows.
    Pending(usize),
}

/// Parses `floors.txt`: folder name -> its floors.
pub fn parse_floors(text: &str) -> Result<BTreeMap<String, Floors>, String> {
    let mut out = BTreeMap::new();
    for (k, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (folder, spec) = line
            .split_once('=')
            .ok_or_else(|| format!("line {}: expected FOLDER = floors, found {raw:?}", k + 1))?;
        let spec = spec.trim();
        let floors = if let Some(n) = spec.strip_prefix("pending") {
            Floors::Pending(
                n.trim()
                    .parse()
                    .map_err(|_| format!("line {}: `pending N` needs a count, found {spec:?}", k + 1))?,
            )
        } else {
            Floors::Set(
                spec.split('|')
                    .map(|f| f.split_whitespace().map(str::to_string).collect())
                    .collect(),
            )
        };
        if out.insert(folder.trim().to_string(), floors).is_some() {
            return Err(format!("line {}: folder {} given twice", k + 1, folder.trim()));
        }
    }
    Ok(out)
}

/// Every path that starts with `crate`, `super` or `self` in `code` (comments, literals and test
/// modules already blanked), expanded over `{ }` groups, with its line.
pub fn paths(code: &str) -> Vec<(usize, Vec<String>)> {
    let c: Vec<char> = code.chars().collect();
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        if !ident(c[i]) || (i > 0 && (ident(c[i - 1]) || c[i - 1] == '$' || c[i - 1] == ':')) {
            i += 1;
            continue;
        }
        let word: String = c[i..].iter().take_while(|&&ch| ident(ch)).collect();
        let next = skip_ws(&c, i + word.len());
        if matches!(word.as_str(), "crate" | "super" | "self")
            && c.get(next) == Some(&':')
            && c.get(next + 1) == Some(&':')
        {
            let line = 1 + c[..i].iter().filter(|&&ch| ch == '\n').count();
            let mut found = Vec::new();
            let end = parse_path(&c, i, Vec::new(), &mut found);
            out.extend(found.into_iter().map(|p| (line, p)));
            i = end.max(i + 1);
        } else {
            i += word.len();
        }
    }
    out
}

fn skip_ws(c: &[char], mut k: usize) -> usize {
    while k < c.len() && c[k].is_whitespace() {
        k += 1;
    }
    k
}

/// Parses the path at `k` (segments joined by `::`, groups `{a, b::c}`), pushing each complete
/// path (prefixed by `prefix`) to `out`; returns the index after it.
fn parse_path(c: &[char], mut k: usize, mut prefix: Vec<String>, out: &mut Vec<Vec<String>>) -> usize {
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    loop {
        k = skip_ws(c, k);
        if c.get(k) == Some(&'{') {
            k += 1;
            loop {
                k = skip_ws(c, k);
                match c.get(k) {
                    Some('}') => return k + 1,
                    Some(',') => k += 1,
                    None => return k,
                    _ => {
                        let before = k;
                        k = parse_path(c, k, prefix.clone(), out);
                        k = skip_ws(c, k);
                        // `x as y`
                        if c[k..].starts_with(&['a', 's'])
                            && c.get(k + 2).is_some_and(|ch| ch.is_whitespace())
                        {
                            k = skip_ws(c, k + 2);
                            while k < c.len() && ident(c[k]) {
                                k += 1;
                            }
                        }
                        if k == before {
                            k += 1;
                        }
                    }
                }
            }
        }
        if c.get(k) == Some(&'*') {
            prefix.push("*".into());
            out.push(prefix);
            return k + 1;
        }
        let word: String = c[k.min(c.len())..].iter().take_while(|&&ch| ident(ch)).collect();
        if word.is_empty() {
            out.push(prefix);
            return k;
        }
        prefix.push(word.clone());
        k += word.len();
        let n = skip_ws(c, k);
        if c.get(n) == Some(&':') && c.get(n + 1) == Some(&':') {
            k = n + 2;
        } else {
            out.push(prefix);
            return k;
        }
    }
}

/// The module path of a file under `src` (`similarity/engine.rs` -> `[similarity, engine]`,
/// `similarity/mod.rs` -> `[similarity]`, `lib.rs` / `main.rs` -> `[]`).
pub fn module_of(src: &Path, f: &Path) -> Vec<String> {
    let rel = f.strip_prefix(src).unwrap();
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().to_string())
        .collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if !(stem == "mod" || (parts.is_empty() && (stem == "lib" || stem == "main"))) {
        parts.push(stem.to_string());
    }
    parts
}

/// The child modules of a folder (its `.rs` files but `mod.rs` / `lib.rs` / `main.rs`, and its
/// sub-folders holding Rust files), sorted, without test modules (`#[cfg(test)] mod NAME;`,
/// `tests.rs`).
pub fn children(dir: &Path, top: bool) -> Vec<String> {
    let mut here = Vec::new();
    rust_files(dir, &mut here);
    let skip = test_only(&here);
    let mut names = BTreeSet::new();
    for e in fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let n = p.file_name().unwrap().to_string_lossy().to_string();
        if p.is_dir() {
            let mut inner = Vec::new();
            rust_files(&p, &mut inner);
            if !inner.is_empty() && !skip.contains(&p.join("mod.rs")) {
                names.insert(n);
            }
        } else if let Some(stem) = n.strip_suffix(".rs") {
            let special = stem == "mod" || stem == "tests" || (top && (stem == "lib" || stem == "main"));
            if !special && !skip.contains(&p) {
                names.insert(stem.to_string());
            }
        }
    }
    names.into_iter().collect()
}

/// The folder name used in `floors.txt`.
pub fn folder_name(parts: &[String]) -> String {
    if parts.is_empty() {
        "crate".into()
    } else {
        parts.join("/")
    }
}

/// Every arrow between sibling modules of the crate at `src`, in its non-test code.
pub fn arrows(src: &Path) -> Vec<Arrow> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let skip = test_only(&files);
    let mut kids: BTreeMap<Vec<String>, Vec<String>> = BTreeMap::new();
    let mut kids_of = |folder: &[String]| -> Vec<String> {
        kids.entry(folder.to_vec())
            .or_insert_with(|| {
                let dir = folder.iter().fold(src.to_path_buf(), |d, p| d.join(p));
                if dir.is_dir() {
                    children(&dir, folder.is_empty())
                } else {
                    Vec::new()
                }
            })
            .clone()
    };
    let mut out = BTreeSet::new();
    for f in &files {
        let rel = f.strip_prefix(src).unwrap().to_string_lossy().replace('\\', "/");
        if skip.contains(f) || rel.ends_with("tests.rs") {
            continue;
        }
        let me = module_of(src, f);
        let code = without_test_modules(&code_only(&fs::read_to_string(f).unwrap()));
        for (line, path) in paths(&code) {
            // resolve to an absolute module path
            let mut abs: Vec<String> = Vec::new();
            let mut rest = path.as_slice();
            match rest.first().map(String::as_str) {
                Some("crate") => rest = &rest[1..],
                Some("self") => {
                    abs = me.clone();
                    rest = &rest[1..];
                }
                Some("super") => {
                    abs = me.clone();
                    while rest.first().map(String::as_str) == Some("super") {
                        if abs.pop().is_none() {
                            break;
                        }
                        rest = &rest[1..];
                    }
                }
                _ => continue,
            }
            abs.extend(rest.iter().cloned());
            let common = me.iter().zip(&abs).take_while(|(a, b)| a == b).count();
            if common == me.len() {
                continue; // itself or below it
            }
            let folder = &me[..common];
            let from = me[common].clone();
            let to = match abs.get(common) {
                Some(t) if kids_of(folder).contains(t) => t.clone(),
                _ => "mod".to_string(),
            };
            out.insert(Arrow {
                folder: folder_name(folder),
                from,
                to,
                at: format!("{rel}:{line}"),
            });
        }
    }
    out.into_iter().collect()
}

/// Every folder of the crate at `src` that has child modules (`crate` for `src/` itself).
pub fn folders(src: &Path) -> Vec<String> {
    let mut out = Vec::new();
    fn walk(src: &Path, dir: &Path, out: &mut Vec<String>) {
        let rel: Vec<String> = dir
            .strip_prefix(src)
            .unwrap()
            .components()
            .map(|c| c.as_os_str().to_string_lossy().to_string())
            .collect();
        if !children(dir, rel.is_empty()).is_empty() {
            out.push(folder_name(&rel));
        }
        let mut subs: Vec<PathBuf> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_dir())
            .collect();
        subs.sort();
        for s in subs {
            walk(src, &s, out);
        }
    }
    walk(src, src, &mut out);
    out
}

/// The loops among the child modules of a folder (strongly connected sets of two or more), each
/// sorted, given the folder's arrows.
pub fn loops(arrows: &[&Arrow]) -> Vec<Vec<String>> {
    let mut edges: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for a in arrows {
        if a.to != "mod" && a.from != a.to {
            edges.entry(&a.from).or_default().insert(&a.to);
        }
    }
    let nodes: BTreeSet<&str> = edges
        .iter()
        .flat_map(|(k, v)| std::iter::once(*k).chain(v.iter().copied()))
        .collect();
    // reachability by depth-first search (folders are small)
    let reach = |s: &str| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![s];
        while let Some(x) = stack.pop() {
            for y in edges.get(x).into_iter().flatten() {
                if seen.insert(y.to_string()) {
                    stack.push(y);
                }
            }
        }
        seen
    };
    let r: BTreeMap<&str, BTreeSet<String>> = nodes.iter().map(|n| (*n, reach(n))).collect();
    let mut out: BTreeSet<Vec<String>> = BTreeSet::new();
    for n in &nodes {
        let comp: Vec<String> = nodes
            .iter()
            .filter(|m| r[n].contains(**m) && r[*m].contains(*n))
            .map(|m| m.to_string())
            .collect();
        if comp.len() > 1 {
            out.insert(comp);
        }
    }
    out.into_iter().collect()
}

/// What one folder's check found.
#[derive(Debug, Default)]
pub struct FolderReport {
    /// Distinct `from -> to` arrows.
    pub arrows: usize,
    /// The loops ([`loops`]).
    pub loops: Vec<Vec<String>>,
    /// Upward arrows, `from -> to` with their places: to the folder's own file, or (with floors)
    /// to the same floor or higher.
    pub upward: BTreeMap<String, Vec<String>>,
    /// Arrows on a loop (both ends in one loop), counted once per `from -> to`.
    pub on_loops: usize,
    /// Distinct `from -> to` arrows that are upward or on a loop (what `pending N` counts).
    pub flagged: usize,
    /// Problems with the floors themselves (a module not placed, placed twice, unknown).
    pub misplaced: Vec<String>,
}

/// Checks a folder's arrows against its floors (`None`: no floors, so only arrows to the
/// folder's own file count as upward). `modules` are the folder's children.
pub fn check_folder(arrows: &[&Arrow], modules: &[String], floors: Option<&Floors>) -> FolderReport {
    let mut rep = FolderReport {
        loops: loops(arrows),
        ..Default::default()
    };
    let rank: Option<BTreeMap<&str, usize>> = match floors {
        Some(Floors::Set(fl)) => {
            let mut r = BTreeMap::new();
            for (k, floor) in fl.iter().enumerate() {
                for m in floor {
                    if r.insert(m.as_str(), k).is_some() {
                        rep.misplaced.push(format!("{m} is on two floors"));
                    }
                    if !modules.contains(m) {
                        rep.misplaced.push(format!("{m} is not a module of the folder"));
                    }
                }
            }
            for m in modules {
                if !r.contains_key(m.as_str()) {
                    rep.misplaced.push(format!("{m} is on no floor: place it"));
                }
            }
            Some(r)
        }
        _ => None,
    };
    let mut distinct = BTreeSet::new();
    let mut looped = BTreeSet::new();
    let mut flagged = BTreeSet::new();
    for a in arrows {
        distinct.insert((a.from.as_str(), a.to.as_str()));
        let on_loop = rep.loops.iter().any(|l| l.contains(&a.from) && l.contains(&a.to));
        if on_loop {
            looped.insert((a.from.as_str(), a.to.as_str()));
        }
        let up = a.to == "mod"
            || rank
                .as_ref()
                .is_some_and(|r| match (r.get(a.from.as_str()), r.get(a.to.as_str())) {
                    (Some(f), Some(t)) => t >= f,
                    _ => false,
                });
        if up || on_loop {
            flagged.insert((a.from.as_str(), a.to.as_str()));
        }
        if up {
            rep.upward
                .entry(format!("{} -> {}", a.from, a.to))
                .or_default()
                .push(a.at.clone());
        }
    }
    rep.arrows = distinct.len();
    rep.on_loops = looped.len();
    rep.flagged = flagged.len();
    rep
}

/// The check of every folder of the crate at `src` against `floors`: the folders that fail, with
/// what is wrong. A folder fails when it is not in `floors`, when its floors misplace a module
/// or when an arrow runs upward or loops (set floors), or when it has more upward or looping
/// arrows than its `pending` count.
pub fn failures(src: &Path, floors: &BTreeMap<String, Floors>) -> BTreeMap<String, String> {
    let all = arrows(src);
    let mut out = BTreeMap::new();
    let names = folders(src);
    for f in floors.keys() {
        if !names.contains(f) {
            out.insert(
                f.clone(),
                "listed in floors.txt but not a folder of src/".to_string(),
            );
        }
    }
    for folder in names {
        let dir = if folder == "crate" {
            src.to_path_buf()
        } else {
            src.join(&folder)
        };
        let mine: Vec<&Arrow> = all.iter().filter(|a| a.folder == folder).collect();
        let modules = children(&dir, folder == "crate");
        let Some(fl) = floors.get(&folder) else {
            out.insert(
                folder,
                format!("not in floors.txt: give its floors ({})", modules.join(" ")),
            );
            continue;
        };
        let rep = check_folder(&mine, &modules, Some(fl));
        let problem = match fl {
            Floors::Set(_) if !(rep.misplaced.is_empty() && rep.upward.is_empty() && rep.loops.is_empty()) => {
                Some(format!(
                    "misplaced: {:?}; loops: {:?}; upward: {:#?}",
                    rep.misplaced, rep.loops, rep.upward
                ))
            }
            Floors::Pending(n) if rep.flagged > *n => Some(format!(
                "{} arrows upward or on a loop, more than the {n} pending in floors.txt: loops {:?}, upward {:#?}",
                rep.flagged,
                rep.loops,
                rep.upward
            )),
            _ => None,
        };
        if let Some(p) = problem {
            out.insert(folder, p);
        }
    }
    out
}

/// A `floors.txt` line for a folder from its arrows: each module on the floor above the highest
/// module it imports (`pending N` when the folder has loops or arrows to its own file).
pub fn suggest(folder: &str, arrows: &[&Arrow], modules: &[String]) -> String {
    let rep = check_folder(arrows, modules, None);
    if rep.flagged > 0 {
        return format!("{folder} = pending {}", rep.flagged);
    }
    let mut floor: BTreeMap<&str, usize> = BTreeMap::new();
    // relax until stable (no loops, so at most #modules rounds)
    for _ in 0..=modules.len() {
        for m in modules {
            let f = arrows
                .iter()
                .filter(|a| a.from == *m && a.to != *m)
                .map(|a| floor.get(a.to.as_str()).copied().unwrap_or(0) + 1)
                .max()
                .unwrap_or(0);
            floor.insert(m, f);
        }
    }
    let top = floor.values().copied().max().unwrap_or(0);
    let floors: Vec<String> = (0..=top)
        .map(|k| {
            let on: Vec<&str> = modules
                .iter()
                .map(String::as_str)
                .filter(|m| floor[m] == k)
                .collect();
            on.join(" ")
        })
        .filter(|s| !s.is_empty())
        .collect();
    format!("{folder} = {}", floors.join(" | "))
}

/// The layer test of the crate at `dir` (its `src/` against its `floors.txt`): panics with every
/// folder that breaks its floors.
pub fn assert_floors(dir: &Path) {
    let path = dir.join("floors.txt");
    let text = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let floors = parse_floors(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let bad = failures(&dir.join("src"), &floors);
    assert!(
        bad.is_empty(),
        "folders that break their floors ({}):\n{bad:#?}",
        path.display()
    );
}
