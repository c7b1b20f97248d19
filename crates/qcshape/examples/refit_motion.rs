//! Which part of the motion a surface fit carries (issue 49; docs/fit.md, "The LV phantom
//! cohort re-triangulated"): two data sets of the same deformations on one connectivity, the
//! original (e.g. `qcshape lv run`'s `meshes/`, carried by landmark splines) and the fitted
//! (`qcshape fit` of re-triangulated poses with a template of that connectivity), compared
//! vertex by vertex.
//!
//! `cargo run --release -p qcshape --example refit_motion -- ORIGINAL FITTED`
//!
//! Per frame k, root mean square over every vertex of every deformation (in the data's length
//! unit, e.g. mm):
//! - `motion`, `motion_n`, `motion_t`: the original motion `O_k - O_0` and its parts normal and
//!   tangential to the original surface at frame 0 (unit vertex normals);
//! - `offset_n`, `offset_t`: the fitted position minus the original, `F_k - O_k`, normal and
//!   tangential to the original surface at frame k (`offset_n` is about the distance between the
//!   surfaces, `offset_t` how far the correspondence has slid along them);
//! - `err_n`, `err_t`: the error of the fitted motion, `(F_k - F_0) - (O_k - O_0)`, normal and
//!   tangential to the original surface at frame k.
//!
//! With `RIGID=1` each fitted deformation is first moved by the rotation and translation that
//! best map its frame 0 onto the original's (vertex to vertex; the same motion for every frame),
//! for fitted data written in another frame (`qcshape lv mesh --landmark-frame`); the angle of
//! that rotation is printed per deformation. Without it, a fitted deformation turned about the
//! long axis against the original shows as a large tangential offset.
//!
//! The last line is the template's mean edge length (frame 0 of the first original
//! deformation), to read the numbers in edge lengths.
//!
//! With `WRITE=DIR PART=...` it also writes a hybrid data set (DIR/NAME/poseKKK.ply and
//! DIR/manifest.csv, labels kept) on the original's surfaces, `H_k = O_k + part of d_k` with
//! `d_k = F_k - O_k` (after `RIGID=1`'s motion when set), to measure which part of the fit's
//! error changes an analysis (run `qcshape lv run DIR/manifest.csv` on it):
//! - `normal`: `d_k`'s part along the original's normal at frame k (the surface distance);
//! - `tangential`: its part along the surface (where the fit has slid the correspondence);
//! - `slide0`: frame 0's tangential slide `d_0`, projected on the tangent plane of frame k, at
//!   every frame (the correspondence between subjects, tracked perfectly);
//! - `tracking`: the tangential part of `d_k - d_0` (the correspondence within a sequence,
//!   frame 0 exact).

use std::collections::HashMap;
use std::path::Path;

use qcshape::align::best_motion;
use qcshape::dataset::{write_manifest, Dataset, ManifestRow};
use qcshape::io::{write_mesh, VertexAttributes};
use qcshape::mesh::geometry::{mean_edge_length, vertex_normals};

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a + s b`.
fn axpy(a: [f64; 3], s: f64, b: [f64; 3]) -> [f64; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

/// The parts of the fit's error a hybrid data set can carry (`PART`).
const PARTS: [&str; 4] = ["normal", "tangential", "slide0", "tracking"];

/// The hybrid position of vertex `v` at frame `k` (see the module's `WRITE`/`PART`).
fn hybrid(part: &str, o: &[Vec<[f64; 3]>], f: &[Vec<[f64; 3]>], k: usize, v: usize, n: [f64; 3]) -> [f64; 3] {
    let d = sub(f[k][v], o[k][v]);
    let tangential = |d: [f64; 3]| axpy(d, -dot(d, n), n);
    let add = match part {
        "normal" => axpy([0.0; 3], dot(d, n), n),
        "tangential" => tangential(d),
        "slide0" => tangential(sub(f[0][v], o[0][v])),
        "tracking" => tangential(sub(d, sub(f[0][v], o[0][v]))),
        _ => unreachable!("PART is checked against PARTS before writing"),
    };
    axpy(o[k][v], 1.0, add)
}

/// Squared normal and tangential parts of `v` against the unit normal `n`.
fn split(v: [f64; 3], n: [f64; 3]) -> (f64, f64) {
    let vn = dot(v, n);
    (vn * vn, (dot(v, v) - vn * vn).max(0.0))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 3 {
        eprintln!("usage: refit_motion ORIGINAL FITTED (data sets on one connectivity each)");
        std::process::exit(2);
    }
    let load = |p: &str| Dataset::load(Path::new(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let (orig, fitted) = (load(&args[1]), load(&args[2]));
    let by_name: HashMap<&str, _> = fitted.deformations.iter().map(|d| (d.name.as_str(), d)).collect();
    // Per frame: sums of motion, motion_n, motion_t, offset_n, offset_t, err_n, err_t; count.
    let mut sums: Vec<[f64; 8]> = Vec::new();
    let write = std::env::var("WRITE").ok().map(std::path::PathBuf::from);
    let part = std::env::var("PART").unwrap_or_default();
    if write.is_some() && !PARTS.contains(&part.as_str()) {
        panic!("WRITE needs PART, one of {PARTS:?}");
    }
    let mut rows = Vec::new();
    for o in &orig.deformations {
        let f = by_name
            .get(o.name.as_str())
            .unwrap_or_else(|| panic!("{} is not in {}", o.name, args[2]));
        assert_eq!(o.topology.n_vertices(), f.topology.n_vertices(), "{}", o.name);
        assert_eq!(o.poses.len(), f.poses.len(), "{}", o.name);
        let mut f = (*f).clone();
        if std::env::var("RIGID").is_ok_and(|v| v == "1") {
            let m = best_motion(&f.poses[0], &o.poses[0], &vec![1.0; o.poses[0].len()], false);
            println!("{}: rotated by {:.1} degrees", o.name, m.angle().to_degrees());
            for p in &mut f.poses {
                p.iter_mut().for_each(|q| *q = m.apply(*q));
            }
        }
        if let Some(dir) = &write {
            std::fs::create_dir_all(dir.join(&o.name)).unwrap();
        }
        let n0 = vertex_normals(&o.topology, &o.poses[0]);
        for k in 0..o.poses.len() {
            if sums.len() <= k {
                sums.push([0.0; 8]);
            }
            let nk = vertex_normals(&o.topology, &o.poses[k]);
            if let Some(dir) = &write {
                let h: Vec<[f64; 3]> = (0..nk.len())
                    .map(|v| hybrid(&part, &o.poses, &f.poses, k, v, nk[v]))
                    .collect();
                let rel = Path::new(&o.name).join(format!("pose{k:03}.ply"));
                write_mesh(
                    &dir.join(&rel),
                    &h,
                    o.topology.faces(),
                    &VertexAttributes::default(),
                )
                .unwrap();
                rows.push(ManifestRow {
                    deformation: o.name.clone(),
                    label: o.label.clone(),
                    pose: k as i64,
                    path: rel,
                });
            }
            let s = &mut sums[k];
            for v in 0..o.poses[k].len() {
                let m = sub(o.poses[k][v], o.poses[0][v]);
                let (mn, mt) = split(m, n0[v]);
                let (on, ot) = split(sub(f.poses[k][v], o.poses[k][v]), nk[v]);
                let e = sub(sub(f.poses[k][v], f.poses[0][v]), m);
                let (en, et) = split(e, nk[v]);
                for (c, x) in [dot(m, m), mn, mt, on, ot, en, et, 1.0].into_iter().enumerate() {
                    s[c] += x;
                }
            }
        }
    }
    if let Some(dir) = &write {
        write_manifest(&dir.join("manifest.csv"), &rows).unwrap();
    }
    println!("frame,motion,motion_n,motion_t,offset_n,offset_t,err_n,err_t");
    let mut all = [0.0; 8];
    for (k, s) in sums.iter().enumerate() {
        let r: Vec<String> = (0..7).map(|c| format!("{:.3}", (s[c] / s[7]).sqrt())).collect();
        println!("{k},{}", r.join(","));
        if k > 0 {
            for c in 0..8 {
                all[c] += s[c];
            }
        }
    }
    let r: Vec<String> = (0..7)
        .map(|c| format!("{:.3}", (all[c] / all[7]).sqrt()))
        .collect();
    println!("1-{},{}", sums.len() - 1, r.join(","));
    let d0 = &orig.deformations[0];
    println!("edge_length {:.3}", mean_edge_length(&d0.topology, &d0.poses[0]));
}
