//! The fit's accuracy against ground truth (issue 49; docs/fit.md): for each synthetic
//! deformation, a 162-vertex template fitted to the deformed shape on another, finer
//! triangulation with noise, against the nearest-point baseline (the same initial alignment,
//! then each vertex snapped to its closest target point). Errors are distances to the true
//! positions in template mean edge lengths.
//!
//! `cargo run --release -p qcshape --example fit_accuracy [-- FINE_LEVEL [NOISE_PERCENT]]`
//! (target icosphere level, default 4 = 2,562 vertices; noise variance in % of the squared
//! target edge, default 1). Environment: `SHAPE` (an initial shape, default rounded-box),
//! `ALIGN` (similarity, rigid or none), `PRIOR` (smooth, arap or asap), `STIFF_START`, `STIFF_END`,
//! `S2P`, `SAMPLES` (the options of the same names). Time is wall-clock per fit (`ms`); `sym`
//! is the fit's symmetric surface distance, `strain` its rms edge strain. `WRITE_DIR=D` also
//! writes each fixture to D (template.ply, MOTION-target.ply, MOTION-truth.ply) for
//! `scripts/fit_compare.py`; with `WRITE_ONLY` set as well, nothing is fitted.

#[path = "../tests/fit_fixture/mod.rs"]
mod fixture;

use std::time::Instant;

use qcshape::align::Motion;
use qcshape::fit::{fit, initial_alignment, FitOptions, Target};
use qcshape::io::{write_mesh, VertexAttributes};
use qcshape::synth::{DeformationKind, InitialShape};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let fine: u32 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(4);
    let noise: f64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(1.0);
    let shape: InitialShape = std::env::var("SHAPE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(InitialShape::RoundedBox);
    let mut opts = FitOptions::default();
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(v) = env("STIFF_END") {
        opts.stiffness_end = Some(v);
    }
    if let Some(v) = env("STIFF_START") {
        opts.stiffness_start = Some(v);
    }
    if let Some(v) = env("SAMPLES") {
        opts.max_samples = v as usize;
    }
    if let Some(v) = env("S2P") {
        opts.surface_to_point = v;
    }
    if let Some(v) = env("PLANE") {
        opts.point_to_plane = v != 0.0;
    }
    if let Ok(a) = std::env::var("PRIOR") {
        opts.prior = a.parse().expect("smooth, arap or asap");
    }
    if let Ok(a) = std::env::var("ALIGN") {
        opts.alignment = a.parse().expect("rigid, similarity or none");
    }
    println!(
        "{shape:?}, target level {fine}, noise {noise} %, alignment {}",
        opts.alignment.label()
    );
    println!(
        "{:<9} {:>7} | {:>8} {:>8} {:>8} | {:>8} {:>8} | {:>7} {:>5} {:>7} {:>6}",
        "motion",
        "targetV",
        "fit med",
        "fit mean",
        "fit p95",
        "base med",
        "base mean",
        "sym",
        "flip",
        "strain",
        "ms"
    );
    let mut all = (Vec::new(), Vec::new());
    for kind in DeformationKind::all() {
        let c = fixture::case(shape, kind, 1.0, fine, noise, 7, Motion::IDENTITY);
        let target = Target {
            positions: &c.target,
            faces: &c.faces,
        };
        // WRITE_DIR: the fixture as files for scripts/fit_compare.py (template, target, truth).
        if let Ok(dir) = std::env::var("WRITE_DIR") {
            let dir = std::path::Path::new(&dir);
            std::fs::create_dir_all(dir).expect("WRITE_DIR");
            let none = VertexAttributes::default();
            let faces = c.template.topology.faces();
            write_mesh(&dir.join("template.ply"), &c.template.positions, faces, &none).expect("write");
            write_mesh(&dir.join(format!("{kind:?}-truth.ply")), &c.truth, faces, &none).expect("write");
            write_mesh(
                &dir.join(format!("{kind:?}-target.ply")),
                &c.target,
                &c.faces,
                &none,
            )
            .expect("write");
            if std::env::var_os("WRITE_ONLY").is_some() {
                continue;
            }
        }
        let t0 = Instant::now();
        let f = fit(&c.template, &target, &opts).expect("fit");
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let m = initial_alignment(&c.template, &target, &opts).expect("alignment");
        let e = fixture::errors(&c, &f.positions, m.scale);
        let b = fixture::errors(&c, &fixture::baseline(&c, &m), m.scale);
        let (em, ea) = fixture::median_mean(&e);
        let (bm, ba) = fixture::median_mean(&b);
        let mut s = e.clone();
        s.sort_by(f64::total_cmp);
        println!(
            "{:<9} {:>7} | {:>8.3} {:>8.3} {:>8.3} | {:>8.3} {:>8.3} | {:>7.3} {:>5} {:>7.3} {:>6.0}",
            format!("{kind:?}"),
            c.target.len(),
            em,
            ea,
            s[s.len() * 95 / 100],
            bm,
            ba,
            f.quality.mean,
            f.quality.flipped,
            f.quality.strain_rms,
            ms
        );
        all.0.extend(e);
        all.1.extend(b);
    }
    if all.0.is_empty() {
        return;
    }
    let (em, ea) = fixture::median_mean(&all.0);
    let (bm, ba) = fixture::median_mean(&all.1);
    println!("all: fit median {em:.3} mean {ea:.3}; baseline median {bm:.3} mean {ba:.3}");
    // Peak resident memory of the whole run (Linux).
    if let Some(line) = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("VmHWM")).map(str::to_string))
    {
        println!("peak memory: {}", line.trim_start_matches("VmHWM:").trim());
    }
}
