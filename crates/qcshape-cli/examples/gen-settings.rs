//! Rewrites the texts generated from `qcshape::settings` (the `.pyi` stub's option lists,
//! docs/defaults.md's settings table, the Python text signatures in `crates/qcshape-py/src/data.rs`):
//! `cargo run -p qcshape-cli --example gen-settings`. `tests/settings.rs` fails until they agree.

#[path = "../tests/settings_gen/mod.rs"]
mod settings_gen;

fn main() {
    let root = settings_gen::root();
    println!(
        "{}: the texts generated from qcshape::settings",
        settings_gen::REFRESH
    );
    for (path, text) in settings_gen::expected() {
        let full = root.join(&path);
        let old = std::fs::read_to_string(&full).unwrap_or_default();
        if old != text {
            std::fs::write(&full, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            println!("rewrote {}", path.display());
        }
    }
}
