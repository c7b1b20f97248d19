//! Fuzz target: `qcshape::io::nifti::parse_nifti` on arbitrary bytes (plain or gzipped NIfTI-1).
//! It must never panic, and whatever it accepts must hold one value per voxel in every frame,
//! with positive dimensions and a finite affine.
#![no_main]

use libfuzzer_sys::fuzz_target;
use qcshape::io::nifti::parse_nifti;

fuzz_target!(|data: &[u8]| {
    if let Ok(frames) = parse_nifti(data) {
        assert!(!frames.is_empty());
        for v in &frames {
            assert!(v.dims.iter().all(|&d| d > 0));
            assert_eq!(v.data.len(), v.dims[0] * v.dims[1] * v.dims[2]);
            assert!(v.affine.iter().flatten().all(|c| c.is_finite()));
        }
    }
});
