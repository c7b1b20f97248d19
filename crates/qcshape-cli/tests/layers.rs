//! This crate's floors, checked as the core's are (`crates/qcshape/tests/layers.rs`, which also
//! shows that planted defects fail): in every folder of `src/` a module imports only modules on
//! lower floors of that folder, as `crates/qcshape-cli/floors.txt` places them, and never an item of the
//! folder's own file; `pending N` folders may not gain upward or looping arrows.
//! `scripts/layers` prints every folder's arrows.

#[path = "../../../scripts/test-support/scan.rs"]
mod scan;

#[path = "../../../scripts/test-support/floors.rs"]
mod floors;

#[test]
fn every_folder_keeps_its_floors() {
    floors::assert_floors(std::path::Path::new(env!("CARGO_MANIFEST_DIR")));
}
