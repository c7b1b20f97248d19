//! Stable-Rust stand-in for the `fuzz/` targets: thousands of seeded random mutations of valid
//! files (bit flips, byte changes, truncations, inserted huge or invalid numbers, duplicated and
//! deleted runs) go through [`parse_mesh`]; none may panic, and every success must keep the
//! documented guarantees (finite coordinates, face indices in range).

use std::panic::{catch_unwind, AssertUnwindSafe};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::synth;

/// Mutations per seed file (times `QCSHAPE_STRESS_SCALE`, default 1: a long run sets it, e.g.
/// `QCSHAPE_STRESS_SCALE=2000 QCSHAPE_STRESS_FORMAT=ply cargo test --release -p qcshape stress`).
const MUTATIONS: usize = 1000;

/// The run's scale factor (`QCSHAPE_STRESS_SCALE`, at least 1).
fn scale() -> usize {
    std::env::var("QCSHAPE_STRESS_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1usize)
        .max(1)
}

/// Whether the seeds of `family` (`obj`, `ply`, `off`, `stl`, `vtk`, `nifti`) take part: all
/// unless `QCSHAPE_STRESS_FORMAT` names one.
fn selected(family: &str) -> bool {
    std::env::var("QCSHAPE_STRESS_FORMAT").map_or(true, |f| f.is_empty() || f.eq_ignore_ascii_case(family))
}

fn seeds() -> Vec<(Format, Vec<u8>)> {
    let s = synth::icosphere(0);
    let pos: Vec<[f64; 3]> = s.positions.iter().map(|p| p.map(|c| c * 0.75 + 0.125)).collect();
    let faces = s.topology.faces().to_vec();
    let vals: Vec<f64> = pos.iter().map(|p| p[0]).collect();
    let colors = heat_colors(&vals, -1.0, 1.0);
    let attrs = VertexAttributes {
        scalar: Some(("v", &vals)),
        colors: Some(&colors),
    };
    let enc = |format, attrs: &VertexAttributes, ply_encoding| {
        encode_mesh(format, &pos, &faces, attrs, &WriteOptions { ply_encoding }).unwrap()
    };
    let none = VertexAttributes::default();
    let mut out = vec![
        (Format::Obj, enc(Format::Obj, &none, PlyEncoding::Ascii)),
        (
            Format::Obj,
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1 4/1\nf -4//1 -2//1 -1//1\n".to_vec(),
        ),
        (Format::Off, enc(Format::Off, &none, PlyEncoding::Ascii)),
        (
            Format::Off,
            b"COFF\n4 1 0\n0 0 0 1 1 1\n1 0 0 1 1 1\n1 1 0 1 1 1\n0 1 0 1 1 1\n4 0 1 2 3\n".to_vec(),
        ),
        (Format::Ply, enc(Format::Ply, &attrs, PlyEncoding::Ascii)),
        (
            Format::Ply,
            enc(Format::Ply, &attrs, PlyEncoding::BinaryLittleEndian),
        ),
        (Format::Ply, enc(Format::Ply, &none, PlyEncoding::BinaryBigEndian)),
        (Format::Stl, enc(Format::Stl, &none, PlyEncoding::Ascii)),
        (Format::Vtk, enc(Format::Vtk, &attrs, PlyEncoding::Ascii)),
    ];
    // ASCII STL.
    let mut stl = String::from("solid s\n");
    for f in &faces {
        stl.push_str("facet normal 0 0 1\nouter loop\n");
        for &i in f {
            let p = pos[i as usize];
            stl.push_str(&format!("vertex {} {} {}\n", p[0], p[1], p[2]));
        }
        stl.push_str("endloop\nendfacet\n");
    }
    stl.push_str("endsolid s\n");
    out.push((Format::Stl, stl.into_bytes()));
    // Binary VTK (legacy cells) and ASCII VTK 5.1 (offsets).
    let mut vtk = b"# vtk DataFile Version 3.0\nb\nBINARY\nDATASET POLYDATA\n".to_vec();
    vtk.extend_from_slice(format!("POINTS {} float\n", pos.len()).as_bytes());
    for c in pos.iter().flatten() {
        vtk.extend_from_slice(&(*c as f32).to_be_bytes());
    }
    vtk.extend_from_slice(format!("\nPOLYGONS {} {}\n", faces.len(), 4 * faces.len()).as_bytes());
    for f in &faces {
        vtk.extend_from_slice(&3i32.to_be_bytes());
        for &i in f {
            vtk.extend_from_slice(&(i as i32).to_be_bytes());
        }
    }
    out.push((Format::Vtk, vtk));
    out.push((
        Format::Vtk,
        b"# vtk DataFile Version 5.1\nq\nASCII\nDATASET POLYDATA\nPOINTS 4 double\n0 0 0 1 0 0 1 1 0 0 1 0\n\
          POLYGONS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 2 3\n\
          TRIANGLE_STRIPS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 3 2\n"
            .to_vec(),
    ));
    // qcshape's VTP and VTU, and the meshio / pyvista fixtures (UNSTRUCTURED_GRID, METADATA,
    // every VTP layout, VTU).
    out.push((
        Format::Vtu,
        super::encode_mesh_with_fields(
            Format::Vtu,
            &pos,
            &faces,
            &[super::Field::scalar("v", &vals)],
            &WriteOptions::default(),
        )
        .unwrap(),
    ));
    out.push((
        Format::Vtp,
        super::encode_mesh_with_fields(
            Format::Vtp,
            &pos,
            &faces,
            &[super::Field::scalar("v", &vals)],
            &WriteOptions::default(),
        )
        .unwrap(),
    ));
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    for name in [
        "octa_meshio_ascii.vtk",
        "octa_meshio_binary.vtk",
        "octa_meshio_42.vtk",
        "octa_pyvista_ascii.vtp",
        "octa_pyvista_binary.vtp",
        "octa_vtk_binary_raw.vtp",
        "octa_vtk_appended_zlib.vtp",
        "octa_vtk_appended_base64_zlib.vtp",
        "octa_meshio.vtu",
        "octa_meshio_ascii.vtu",
        "octa_vtk_appended_zlib.vtu",
        "octa_pyvista_metadata_ascii.vtk",
        "octa_pyvista_metadata_binary.vtk",
    ] {
        let f = Format::from_path(std::path::Path::new(name)).unwrap();
        out.push((f, std::fs::read(dir.join(name)).unwrap()));
    }
    for (f, b) in &out {
        parse_mesh(b, *f).unwrap_or_else(|e| panic!("seed {f} does not parse: {e}"));
    }
    out
}

const NASTY: [&[u8]; 16] = [
    b"4294967295",
    b"4294967296",
    b"18446744073709551615",
    b"99999999999999999999999",
    b"-1",
    b"-2147483648",
    b"0",
    b"nan",
    b"inf",
    b"1e999",
    b"3.5",
    b" ",
    b"\n",
    b"#",
    b"/",
    b"end_header\n",
];

fn mutate(rng: &mut ChaCha8Rng, src: &[u8]) -> Vec<u8> {
    let mut b = src.to_vec();
    for _ in 0..rng.random_range(1..=3) {
        if b.is_empty() {
            b.push(b'0');
        }
        let at = rng.random_range(0..b.len());
        match rng.random_range(0..9) {
            0 => b[at] ^= 1 << rng.random_range(0..8),
            1 => b[at] = rng.random(),
            2 => b.truncate(at),
            3 => {
                let tok = NASTY[rng.random_range(0..NASTY.len())];
                b.splice(at..at, tok.iter().copied());
            }
            4 => {
                // Replace the run of digits around `at` with a nasty number.
                let is_d = |c: u8| c.is_ascii_digit();
                let (mut s, mut e) = (at, at);
                while s > 0 && is_d(b[s - 1]) {
                    s -= 1;
                }
                while e < b.len() && is_d(b[e]) {
                    e += 1;
                }
                let tok = NASTY[rng.random_range(0..10)];
                b.splice(s..e, tok.iter().copied());
            }
            5 => {
                let v: [u8; 4] = [
                    [0xff; 4],
                    [0x7f, 0xff, 0xff, 0xff],
                    [0xff, 0xff, 0xff, 0x7f],
                    [0; 4],
                ][rng.random_range(0..4)];
                let end = (at + 4).min(b.len());
                b[at..end].copy_from_slice(&v[..end - at]);
            }
            6 => {
                let end = rng.random_range(at..=b.len().min(at + 64));
                let run = b[at..end].to_vec();
                b.splice(at..at, run);
            }
            7 => {
                let end = rng.random_range(at..=b.len().min(at + 64));
                b.drain(at..end);
            }
            _ => b[at] = b" \n0123456789-.e"[rng.random_range(0..15)],
        }
    }
    b
}

fn check(bytes: &[u8], format: Format, what: &str) {
    let r = catch_unwind(AssertUnwindSafe(|| parse_mesh(bytes, format)));
    match r {
        Err(_) => panic!(
            "{format} parser panicked on {what} ({} bytes): {:?}",
            bytes.len(),
            String::from_utf8_lossy(&bytes[..bytes.len().min(400)])
        ),
        Ok(Ok(m)) => {
            assert!(m.positions.iter().flatten().all(|c| c.is_finite()), "{what}");
            assert!(
                m.faces
                    .iter()
                    .flatten()
                    .all(|&i| (i as usize) < m.positions.len()),
                "{what}"
            );
            // The topology and shape checks of every loader must not panic either.
            let r = catch_unwind(AssertUnwindSafe(|| {
                if let Ok(t) = Topology::allowing_nonmanifold_vertices(m.positions.len(), m.faces.clone()) {
                    let _ = t.nonmanifold_vertices();
                    let _ = t.genus();
                    if let Ok(s) = Shape::new(t, m.positions.clone()) {
                        let _ = s.check_degenerate(DEGENERATE_REL_TOL);
                    }
                }
            }));
            assert!(r.is_ok(), "{format}: the topology checks panicked on {what}");
        }
        Ok(Err(e)) => assert!(!e.to_string().is_empty()),
    }
}

#[test]
fn mutated_files_never_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5eed);
    let t = std::time::Instant::now();
    let mut n = 0;
    let scale = scale();
    if !Format::ALL.iter().any(|f| selected(f.extension())) {
        return; // QCSHAPE_STRESS_FORMAT names a non-mesh family (nifti).
    }
    for (k, (format, seed)) in seeds().iter().enumerate() {
        if !selected(format.extension()) {
            continue;
        }
        for m in 0..MUTATIONS * scale {
            let bytes = mutate(&mut rng, seed);
            check(&bytes, *format, &format!("seed {k} mutation {m}"));
            // The same bytes through another parser (wrong-format input must fail cleanly too).
            let other = Format::ALL[rng.random_range(0..Format::ALL.len())];
            check(&bytes, other, &format!("seed {k} mutation {m} as {other}"));
            n += 2;
        }
    }
    assert!(n >= 2 * MUTATIONS * scale);
    assert!(
        t.elapsed().as_secs_f64() < 10.0 * scale as f64,
        "stress test too slow: {:?}",
        t.elapsed()
    );
    println!(
        "{n} mutated files parsed in {:.1} s, no panic",
        t.elapsed().as_secs_f64()
    );
}

/// NIfTI: mutations of small plain and gzipped files through
/// [`crate::io::nifti::parse_nifti`]; no panic, and every success has one value per voxel.
#[test]
fn mutated_nifti_never_panics() {
    use crate::io::nifti::parse_nifti;
    if !selected("nifti") {
        return;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(0x0dd);
    let mut plain = vec![0u8; 352 + 24];
    plain[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (k, d) in [4i16, 2, 3, 2, 2, 1, 1, 1].iter().enumerate() {
        plain[40 + 2 * k..42 + 2 * k].copy_from_slice(&d.to_le_bytes());
    }
    plain[70..72].copy_from_slice(&2i16.to_le_bytes());
    for (k, p) in [1f32, 0.5, 1.0, 2.0].iter().enumerate() {
        plain[76 + 4 * k..80 + 4 * k].copy_from_slice(&p.to_le_bytes());
    }
    plain[108..112].copy_from_slice(&352f32.to_le_bytes());
    plain[344..348].copy_from_slice(b"n+1\0");
    let mut gz = Vec::new();
    {
        let mut e = flate2::write::GzEncoder::new(&mut gz, flate2::Compression::default());
        std::io::Write::write_all(&mut e, &plain).unwrap();
    }
    let t = std::time::Instant::now();
    let mut n = 0;
    for seed in [&plain, &gz] {
        assert_eq!(parse_nifti(seed).unwrap().len(), 2);
        for m in 0..2 * MUTATIONS * scale() {
            let bytes = mutate(&mut rng, seed);
            let r = catch_unwind(AssertUnwindSafe(|| parse_nifti(&bytes)));
            match r {
                Err(_) => panic!("NIfTI parser panicked on mutation {m} ({} bytes)", bytes.len()),
                Ok(Ok(frames)) => {
                    for v in &frames {
                        assert_eq!(v.data.len(), v.dims[0] * v.dims[1] * v.dims[2], "mutation {m}");
                        assert!(v.affine.iter().flatten().all(|c| c.is_finite()), "mutation {m}");
                    }
                }
                Ok(Err(e)) => assert!(!e.to_string().is_empty()),
            }
            n += 1;
        }
    }
    println!(
        "{n} mutated NIfTI files parsed in {:.1} s, no panic",
        t.elapsed().as_secs_f64()
    );
}

#[test]
fn garbage_never_panics() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for k in 0..500 {
        let len = rng.random_range(0..300);
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.random()).collect();
        // Give some of them a plausible start so the parsers get past the magic.
        let heads: [&[u8]; 5] = [
            b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
            b"OFF\n3 1 0\n",
            b"solid x\n",
            b"# vtk DataFile Version 3.0\nx\nBINARY\nDATASET POLYDATA\nPOINTS 3 float\n",
            b"v 0 0 0\nf ",
        ];
        if k % 2 == 0 {
            let h = heads[rng.random_range(0..heads.len())];
            bytes.splice(0..0, h.iter().copied());
        }
        for f in Format::ALL {
            check(&bytes, f, &format!("garbage {k}"));
        }
    }
}
