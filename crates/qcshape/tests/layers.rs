//! The core's layers, checked: every module may import only modules below it in [`ORDER`]
//! (`crate::X` paths in its non-test code), so no import runs upward and there is no cycle
//! between modules. docs/design.md shows the layers. The studies (experiments, the LV pipeline,
//! maps, figures) are a crate of their own, `crates/qcshape-studies`, with the same check
//! (`crates/qcshape-studies/tests/layers.rs`); [`every_module_is_placed_once`] keeps them out of
//! this list, since ORDER must name exactly the modules under `src/`.
//!
//! The scanner is `scripts/test-support/scan.rs` (shared with the studies' layer test). Non-test
//! code is the whole file but comments, literals, the bodies of `#[cfg(test)] mod NAME { ... }`
//! (found by brace matching) and files that are test modules (`#[cfg(test)] mod NAME;`,
//! `tests.rs`). Checked by planting
//! `use crate::space::ShapeSpace;` at the end of numfmt.rs, after its inline test module: this
//! test fails on it ("numfmt -> space"), the earlier scanner, which stopped at a file's first
//! `#[cfg(test)]`, passed; [`the_scanner_reads_past_a_test_module`] keeps such a plant in a
//! string.

#[path = "../../../scripts/test-support/scan.rs"]
mod scan;

use std::path::{Path, PathBuf};

use scan::{code_only, imports, top_modules, upward_imports, without_test_modules};

/// The top-level modules from the ground floor up.
const ORDER: &[&str] = &[
    // foundation: bounds, number formatting, output paths
    "limits",
    "numfmt",
    "named",
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
    // fitting a template to meshes of any triangulation
    "fit",
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
];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn no_module_imports_a_module_above_it() {
    let upward = upward_imports(&src(), ORDER);
    assert!(upward.is_empty(), "imports that run upward:\n{upward:#?}");
}

#[test]
fn every_module_is_placed_once() {
    let mut order: Vec<String> = ORDER.iter().map(|s| s.to_string()).collect();
    order.sort();
    assert_eq!(top_modules(&src()), order);
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
