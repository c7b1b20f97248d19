//! Writes the inputs of the fit benchmark (issue 59; `bench/fit_bench.py`, docs/fit.md).
//!
//! `cargo run --release -p qcshape --example fit_bench_data -- OUT [LEVEL]`
//!
//! For every initial shape (6) and deformation (the paper's eight, swing and wring) at t = 1,
//! amplitude 1, it writes `OUT/SHAPE-KIND/`:
//! - `template.ply`: the shape's rest pose on the level-`LEVEL` icosphere (default 3, 642
//!   vertices);
//! - `truth.ply`: the template's vertices deformed (#V x 3, the template's faces): where each
//!   template vertex truly goes;
//! - `fine.ply`: the deformed shape on the level-`LEVEL + 1` icosphere (the deformation's frame
//!   taken from the level-`LEVEL` rest shape), which the bench re-meshes into targets.
//!
//! and, for every ordered pair of different shapes, `OUT/between/A-B/`: `template.ply` (A's
//! rest pose, level `LEVEL`), `truth.ply` (B's rest pose on the same icosphere: the
//! correspondence through the common sphere parametrisation) and `fine.ply` (B at level
//! `LEVEL + 1`).

use std::path::Path;

use qcshape::io::{write_mesh, VertexAttributes};
use qcshape::synth::{deform, initial_shape, template, DeformParams, DeformationKind, InitialShape};

fn write(dir: &Path, name: &str, pos: &[[f64; 3]], faces: &[[u32; 3]]) {
    std::fs::create_dir_all(dir).expect("create the output folder");
    write_mesh(&dir.join(name), pos, faces, &VertexAttributes::default()).expect("write a mesh");
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(out) = args.get(1) else {
        eprintln!("usage: fit_bench_data OUT [LEVEL]");
        std::process::exit(2);
    };
    let level: u32 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(3);
    let out = Path::new(out);
    let (coarse, fine) = (template(level), template(level + 1));
    for shape in InitialShape::all() {
        let rest = initial_shape(shape, &coarse);
        let rest_fine = initial_shape(shape, &fine);
        let params = DeformParams::of(&rest);
        for kind in DeformationKind::extended() {
            let dir = out.join(format!("{}-{}", shape.name(), kind.name()));
            let faces = rest.topology.faces();
            write(&dir, "template.ply", &rest.positions, faces);
            write(&dir, "truth.ply", &deform(&rest, kind, 1.0, &params), faces);
            write(
                &dir,
                "fine.ply",
                &deform(&rest_fine, kind, 1.0, &params),
                rest_fine.topology.faces(),
            );
        }
    }
    for a in InitialShape::all() {
        for b in InitialShape::all() {
            if a == b {
                continue;
            }
            let dir = out.join("between").join(format!("{}-{}", a.name(), b.name()));
            let (ra, rb) = (initial_shape(a, &coarse), initial_shape(b, &coarse));
            let fb = initial_shape(b, &fine);
            write(&dir, "template.ply", &ra.positions, ra.topology.faces());
            write(&dir, "truth.ply", &rb.positions, rb.topology.faces());
            write(&dir, "fine.ply", &fb.positions, fb.topology.faces());
        }
    }
    println!("wrote {}", out.display());
}
