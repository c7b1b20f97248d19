//! The studies' layers, checked as the core's are (`crates/qcshape/tests/layers.rs`; both
//! include the scanner `scripts/test-support/scan.rs`): every study module may import only study
//! modules below it in [`ORDER`] (`crate::X` paths in its non-test code). The core is reached
//! only as `qcshape::...`, through its public API (the compiler refuses anything else), and no
//! module is in both crates: the core's own layer test requires its ORDER to name exactly its
//! `src/` modules, and [`no_study_module_is_in_the_core`] checks that none of them is a study.

#[path = "../../../scripts/test-support/scan.rs"]
mod scan;

use std::path::{Path, PathBuf};

use scan::{top_modules, upward_imports};

/// The study modules from the ground floor up.
const ORDER: &[&str] = &[
    // figures and mesh renderings
    "plot",
    "render",
    // per-vertex maps
    "contribution",
    "explain",
    "localize",
    // the left-ventricle study and the paper's experiments
    "lv",
    "experiment",
];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn no_study_imports_a_study_above_it() {
    let upward = upward_imports(&src(), ORDER);
    assert!(upward.is_empty(), "imports that run upward:\n{upward:#?}");
}

#[test]
fn every_study_is_placed_once() {
    let mut order: Vec<String> = ORDER.iter().map(|s| s.to_string()).collect();
    order.sort();
    assert_eq!(top_modules(&src()), order);
}

#[test]
fn no_study_module_is_in_the_core() {
    let core = top_modules(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../qcshape/src"));
    assert!(core.len() > 10, "the core's modules were not found: {core:?}");
    let both: Vec<&String> = core.iter().filter(|m| ORDER.contains(&m.as_str())).collect();
    assert!(
        both.is_empty(),
        "modules in the core and in the studies: {both:?}"
    );
}
