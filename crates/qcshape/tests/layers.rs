//! The core's floors, checked: in every folder of `src/` (the crate's top level, `similarity/`,
//! `io/xml/`, ...) a module imports only modules on lower floors of that folder, as
//! `crates/qcshape/floors.txt` places them, and never an item of the folder's own `mod.rs`; a
//! folder whose floors are not set yet is listed there as `pending N` (its count of upward or
//! looping arrows, which may not grow). docs/design.md shows the top-level layers;
//! `scripts/layers` prints every folder's arrows, loops and upward arrows. The studies, the CLI
//! and the Python crate have the same test over their own `floors.txt`.
//!
//! The scanner is `scripts/test-support/scan.rs` with `floors.rs` (shared by every crate's layer
//! test and by `scripts/layers`). Non-test code is the whole file but comments, literals, the
//! bodies of `#[cfg(test)] mod NAME { ... }` (found by brace matching) and files that are test
//! modules (`#[cfg(test)] mod NAME;`, `tests.rs`). [`planted_defects_fail`] plants an upward
//! import, a loop, an import of a folder's own file and an unplaced module into a copy of `src/`
//! and checks that each fails.

#[path = "../../../scripts/test-support/scan.rs"]
mod scan;

#[path = "../../../scripts/test-support/floors.rs"]
mod floors;

use std::fs;
use std::path::{Path, PathBuf};

use floors::{failures, parse_floors};
use scan::{code_only, imports, rust_files, without_test_modules};

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn floors_of(dir: &Path) -> std::collections::BTreeMap<String, floors::Floors> {
    parse_floors(&fs::read_to_string(dir.join("floors.txt")).unwrap()).unwrap()
}

#[test]
fn every_folder_keeps_its_floors() {
    floors::assert_floors(&crate_dir());
}

/// A copy of `src/` with `plant` applied, checked against the real floors.
fn check_planted(plant: impl Fn(&Path)) -> std::collections::BTreeMap<String, String> {
    let dir = crate_dir();
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("src");
    let mut files = Vec::new();
    rust_files(&dir.join("src"), &mut files);
    for f in files {
        let to = src.join(f.strip_prefix(dir.join("src")).unwrap());
        fs::create_dir_all(to.parent().unwrap()).unwrap();
        fs::copy(&f, &to).unwrap();
    }
    plant(&src);
    failures(&src, &floors_of(&dir))
}

fn append(path: &Path, text: &str) {
    let mut t = fs::read_to_string(path).unwrap();
    t.push_str(text);
    fs::write(path, t).unwrap();
}

/// Each defect the floors exist for, planted into a copy of `src/`, fails the check with the
/// folder and the arrow named; the unplanted copy passes.
#[test]
fn planted_defects_fail() {
    assert!(check_planted(|_| {}).is_empty());
    // the compute kernel importing the runner (after engine.rs's test module)
    let bad = check_planted(|src| {
        append(
            &src.join("similarity/engine.rs"),
            "\nuse crate::similarity::run::Run;\n",
        )
    });
    assert!(bad["similarity"].contains("engine -> run"), "{bad:#?}");
    // a loop: the journal imported by the shard spec it imports
    let bad = check_planted(|src| {
        append(
            &src.join("similarity/shard.rs"),
            "\nuse super::journal::Journal;\n",
        )
    });
    assert!(bad["similarity"].contains("shard -> journal"), "{bad:#?}");
    // a child importing its folder's own file
    let bad = check_planted(|src| append(&src.join("similarity/types.rs"), "\nuse super::Smoothing;\n"));
    assert!(bad["similarity"].contains("types -> mod"), "{bad:#?}");
    // a top-level module importing one above it
    let bad = check_planted(|src| append(&src.join("numfmt.rs"), "\npub use crate::space::ShapeSpace;\n"));
    assert!(bad["crate"].contains("numfmt -> space"), "{bad:#?}");
    // a module on no floor
    let bad = check_planted(|src| fs::write(src.join("similarity/extra.rs"), "pub fn f() {}\n").unwrap());
    assert!(bad["similarity"].contains("extra is on no floor"), "{bad:#?}");
    // an import of a higher floor in another folder with floors
    let bad = check_planted(|src| {
        append(
            &src.join("multires/prolong.rs"),
            "\nuse super::hierarchy::Level;\n",
        )
    });
    assert!(bad["multires"].contains("prolong -> hierarchy"), "{bad:#?}");
    // one more upward arrow in a pending folder (synth = pending 1)
    let bad = check_planted(|src| {
        append(
            &src.join("synth/noise.rs"),
            "\nuse super::icosphere as planted;\n",
        )
    });
    assert!(bad["synth"].contains("more than the 1 pending"), "{bad:#?}");
    assert!(bad["synth"].contains("noise -> mod"), "{bad:#?}");
    // a folder missing from floors.txt
    let bad = check_planted(|src| {
        fs::create_dir_all(src.join("similarity/more")).unwrap();
        fs::write(src.join("similarity/more/a.rs"), "pub fn f() {}\n").unwrap();
    });
    assert!(bad["similarity/more"].contains("not in floors.txt"), "{bad:#?}");
}

/// The arrows of a text with every form of path: `super::{a, b::c}`, `self::`, `crate::x::y`,
/// nested groups, `as` renames, and the places that are not code.
#[test]
fn the_arrow_parser_reads_every_path_form() {
    let code = without_test_modules(&code_only(
        r#"
use super::{alpha, beta::{Gamma, delta as d}};
use self::inner::X;
fn f() { crate::one::two::three(); super::super::up::Y::new(); }
// super::comment::Z
const S: &str = "super::string::Z";
#[cfg(test)]
mod tests { use super::tested::T; }
"#,
    ));
    let found: Vec<(usize, String)> = floors::paths(&code)
        .into_iter()
        .map(|(l, p)| (l, p.join("::")))
        .collect();
    let want = [
        (2, "super::alpha"),
        (2, "super::beta::Gamma"),
        (2, "super::beta::delta"),
        (3, "self::inner::X"),
        (4, "crate::one::two::three"),
        (4, "super::super::up::Y::new"),
    ];
    assert_eq!(found, want.map(|(l, p)| (l, p.to_string())));
}

/// The scanner itself, on text with the cases the guard must see: an upward import after an inline
/// test module (the earlier scanner stopped at the first `#[cfg(test)]` and missed it), a grouped
/// import, and the places it must not look (the test module, comments, strings).
#[test]
fn the_scanner_reads_past_a_test_module() {
    let text = r#"
use crate::mesh::Mesh;

#[cfg(test)]
mod tests {
    use crate::experiment::Study; // test code: not an import of the library
    fn f() { let s = "}"; let c = '}'; let _ = (s, c); }
    /* a } in a comment */
}

// crate::space in a comment
const S: &str = "crate::lv in a string";

pub use crate::space::ShapeSpace;

use crate::{io::read, similarity::{matrix, engine}};

#[cfg(test)]
pub(crate) mod helpers;

pub fn after<'a>(x: &'a str) -> &'a str { crate::eval::f(); x }
"#;
    let found = imports(text);
    let names: Vec<(usize, &str)> = found.iter().map(|(l, n)| (*l, n.as_str())).collect();
    assert_eq!(
        names,
        [
            (2, "mesh"),
            (14, "space"),
            (16, "io"),
            (16, "similarity"),
            (21, "eval")
        ],
        "{}",
        without_test_modules(&code_only(text))
    );
}
