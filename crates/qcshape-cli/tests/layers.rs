//! This crate's floors, checked as the core's are (`crates/qcshape/tests/layers.rs`, which also
//! shows that planted defects fail): in every folder of `src/` a module imports only modules on
//! lower floors of that folder, as `crates/qcshape-cli/floors.txt` places them, and never an item of the
//! folder's own file; `pending N` folders may not gain upward or looping arrows.
//! `scripts/layers` prints every folder's arrows.

#[path = "../../../scripts/test-support/scan.rs"]
mod scan;

#[path = "../../../scripts/test-support/floors.rs"]
mod floors;

use std::path::Path;

#[test]
fn every_folder_keeps_its_floors() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(dir.join("floors.txt")).unwrap();
    let bad = floors::failures(&dir.join("src"), &floors::parse_floors(&text).unwrap());
    assert!(
        bad.is_empty(),
        "folders that break their floors ({}):\n{bad:#?}",
        dir.join("floors.txt").display()
    );
}
