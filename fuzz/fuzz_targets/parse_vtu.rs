//! Fuzz target: `qcshape::io::parse_mesh` on arbitrary bytes as VTK XML UnstructuredGrid (.vtu). It must never panic, and
//! whatever it accepts must keep its guarantees (finite coordinates, face indices in range).
#![no_main]

use libfuzzer_sys::fuzz_target;
use qcshape::io::{parse_mesh, Format};

fuzz_target!(|data: &[u8]| {
    if let Ok(m) = parse_mesh(data, Format::Vtu) {
        assert!(m.positions.iter().flatten().all(|c| c.is_finite()));
        assert!(m
            .faces
            .iter()
            .flatten()
            .all(|&i| (i as usize) < m.positions.len()));
    }
});
