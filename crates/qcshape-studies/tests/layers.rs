//! The studies' floors, checked as the core's are (`crates/qcshape/tests/layers.rs`, which also
//! shows that planted defects fail; both include `scripts/test-support/scan.rs` and
//! `floors.rs`): in every folder of `src/` a study module imports only modules on lower floors
//! of that folder, as `crates/qcshape-studies/floors.txt` places them, and never an item of the
//! folder's own file; `pending N` folders may not gain upward or looping arrows. The core is
//! reached only as `qcshape::...`, through its public API (the compiler refuses anything else),
//! and no module is in both crates ([`no_study_module_is_in_the_core`]).

#[path = "../../../scripts/test-support/scan.rs"]
mod scan;

#[path = "../../../scripts/test-support/floors.rs"]
mod floors;

use std::path::Path;

use scan::top_modules;

#[test]
fn every_folder_keeps_its_floors() {
    floors::assert_floors(Path::new(env!("CARGO_MANIFEST_DIR")));
}

#[test]
fn no_study_module_is_in_the_core() {
    let studies = top_modules(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let core = top_modules(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../qcshape/src"));
    assert!(core.len() > 10, "the core's modules were not found: {core:?}");
    let both: Vec<&String> = core.iter().filter(|m| studies.contains(m)).collect();
    assert!(
        both.is_empty(),
        "modules in the core and in the studies: {both:?}"
    );
}
