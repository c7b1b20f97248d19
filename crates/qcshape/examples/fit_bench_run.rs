//! Runs `qcshape::fit` on the targets written by `bench/fit_bench.py --write-targets DIR` and
//! prints, per deformation type and meshing, the median over the cases of each fit's median
//! error against the truth (template mean edge lengths), and the mean over types: a fast loop
//! for choosing the fit's options (no Python build needed). nricp's numbers come from the
//! Python bench.
//!
//! `cargo run --release -p qcshape --example fit_bench_run -- DIR [MESHING,...]`
//!
//! Environment: `PRIOR`, `ALIGN`, `STAGES`, `ITER`, `STIFF_START`, `STIFF_END`, `PLANE` (0/1),
//! `S2P`, `ANGLE`, `SCALE` (the target multiplied by it), `ISO` (the affine prior's isometric
//! weight), `DEGREE` (the global polynomial warp's), `CASES` (one `ERR case meshing error` line
//! per fit on stderr), `DIAG` (per fit: the error split normal / tangential to the truth's surface, the
//! mean error vector, the axial error by height band, the surface distance, the shell energy
//! of the truth and of the fit against the aligned template ([`qcshape::fit::shell`]) and the
//! roughness of the local maps; docs/fit.md, 2026-12-07).

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use qcshape::fit::{fit, FitOptions, Target};
use qcshape::io::read_mesh;
use qcshape::mesh::geometry::mean_edge_length;
use qcshape::mesh::{Shape, Topology};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Per-vertex error split (`DIAG=1`): normal / tangential to the truth's surface, the
/// mean error vector, and the axial (z) error by height band (lower, middle, upper third).
fn diagnose(
    name: &str,
    m: &str,
    topo: &Topology,
    truth: &[[f64; 3]],
    fitted: &[[f64; 3]],
    s: f64,
    lbar: f64,
) {
    let normals = qcshape::mesh::geometry::vertex_normals(topo, truth);
    let nv = truth.len() as f64;
    let (mut en, mut et, mut mean) = (0.0, 0.0, [0.0; 3]);
    let (zmin, zmax) = truth
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p[2]), b.max(p[2])));
    let mut bands = [(0.0, 0.0); 3];
    for ((a, b), n) in fitted.iter().zip(truth).zip(&normals) {
        let d = [0, 1, 2].map(|k| (a[k] / s - b[k]) / lbar);
        let dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
        let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        en += dn.abs() / nv;
        et += (dd - dn * dn).max(0.0).sqrt() / nv;
        for k in 0..3 {
            mean[k] += d[k] / nv;
        }
        let band = (((b[2] - zmin) / (zmax - zmin) * 3.0) as usize).min(2);
        bands[band].0 += d[2];
        bands[band].1 += 1.0;
    }
    let bz = bands.map(|(sum, n)| sum / f64::max(n, 1.0));
    println!(
        "{name:24} {m:8} normal {en:.3} tangential {et:.3} mean ({:+.3} {:+.3} {:+.3}) z-err by height {:+.3} {:+.3} {:+.3}",
        mean[0], mean[1], mean[2], bz[0], bz[1], bz[2]
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(dir) = args.get(1) else {
        eprintln!("usage: fit_bench_run DIR [MESHING,...]");
        std::process::exit(2);
    };
    let meshings: Vec<String> = args.get(2).map_or(vec!["jitter".into(), "decimate".into()], |m| {
        m.split(',').map(str::to_string).collect()
    });
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let mut opts = FitOptions::default();
    if let Ok(p) = std::env::var("PRIOR") {
        opts.prior = p.parse().expect("prior");
    }
    if let Ok(a) = std::env::var("ALIGN") {
        opts.alignment = a.parse().expect("alignment");
    }
    if let Some(v) = env("STAGES") {
        opts.stages = v as usize;
    }
    if let Some(v) = env("ITER") {
        opts.iterations = v as usize;
    }
    if let Some(v) = env("STIFF_START") {
        opts.stiffness_start = Some(v);
    }
    if let Some(v) = env("STIFF_END") {
        opts.stiffness_end = Some(v);
    }
    if let Some(v) = env("PLANE") {
        opts.point_to_plane = v != 0.0;
    }
    if let Some(v) = env("S2P") {
        opts.surface_to_point = v;
    }
    if let Some(v) = env("ANGLE") {
        opts.normal_angle = v;
    }
    if let Some(v) = env("OUT") {
        opts.outlier_distance = v;
    }
    if let Some(v) = env("DEGREE") {
        opts.global_degree = v as usize;
    }
    if let Some(v) = env("ISO") {
        opts.isometric = v;
    }
    let s = env("SCALE").unwrap_or(1.0);
    let only: Option<Vec<String>> = std::env::var("KINDS")
        .ok()
        .map(|k| k.split(',').map(str::to_string).collect());
    let mut table: BTreeMap<(String, String), Vec<f64>> = BTreeMap::new();
    let mut time = 0.0;
    let mut slides = Vec::new();
    let mut poor = 0;
    let mut truth_slides: Vec<(f64, String)> = Vec::new();
    let mut fits = 0;
    let mut cases: Vec<_> = std::fs::read_dir(dir)
        .expect("DIR")
        .flatten()
        .map(|e| e.path())
        .collect();
    cases.sort();
    for case in cases {
        let name = case.file_name().unwrap().to_string_lossy().to_string();
        let kind = if name.starts_with("between") {
            "between".to_string()
        } else {
            name.rsplit('-').next().unwrap().to_string()
        };
        if only.as_ref().is_some_and(|o| !o.contains(&kind)) {
            continue;
        }
        let t = read_mesh(&case.join("template.ply")).expect("template");
        let x = read_mesh(&case.join("truth.ply")).expect("truth");
        let topo = Topology::new(t.positions.len(), t.faces.clone()).expect("template faces");
        let template = Shape::new(topo.clone(), t.positions.clone()).expect("shape");
        let lbar = mean_edge_length(&topo, &t.positions);
        truth_slides.push((
            qcshape::fit::quality::slide(&topo, &t.positions, &x.positions),
            name.clone(),
        ));
        for m in &meshings {
            let p = case.join(format!("{m}.ply"));
            if !Path::new(&p).exists() {
                continue;
            }
            let g = read_mesh(&p).expect("target");
            let w: Vec<[f64; 3]> = g.positions.iter().map(|q| q.map(|c| c * s)).collect();
            let t0 = Instant::now();
            let f = fit(
                &template,
                &Target {
                    positions: &w,
                    faces: &g.faces,
                },
                &opts,
            );
            time += t0.elapsed().as_secs_f64();
            fits += 1;
            if let Ok(f) = &f {
                slides.push(f.quality.slide);
                poor += usize::from(f.quality.poor);
                if f.quality.poor && std::env::var_os("VERBOSE").is_some() {
                    eprintln!("{name} {m}: {}", f.quality.problems().join(", "));
                }
            }
            if let (Ok(f), true) = (&f, std::env::var_os("DIAG").is_some()) {
                diagnose(&name, m, &topo, &x.positions, &f.positions, s, lbar);
                println!(
                    "{name:24} {m:8} distance mean {:.4} p95 {:.4} hausdorff {:.4}",
                    f.quality.mean, f.quality.p95, f.quality.hausdorff
                );
                // The shell energy against the aligned template: the truth's and the fit's.
                let rest: Vec<[f64; 3]> = t.positions.iter().map(|p| f.motion.apply(*p)).collect();
                let truth: Vec<[f64; 3]> = x.positions.iter().map(|p| p.map(|c| c * s)).collect();
                let (et, ef) = (
                    qcshape::fit::shell::energy(&topo, &rest, &truth),
                    qcshape::fit::shell::energy(&topo, &rest, &f.positions),
                );
                let rough = |pose: &[[f64; 3]]| {
                    let maps = qcshape::fit::quality::local_maps(&topo, &rest, pose);
                    let mut sum = 0.0;
                    for (i, map) in maps.iter().enumerate() {
                        let nb = topo.neighbors(i);
                        for (r, row) in map.iter().enumerate() {
                            for (c, v) in row.iter().enumerate() {
                                let mean = nb.iter().map(|&j| maps[j as usize][r][c]).sum::<f64>()
                                    / nb.len().max(1) as f64;
                                sum += (v - mean).powi(2);
                            }
                        }
                    }
                    sum / maps.len() as f64
                };
                println!(
                    "{name:24} {m:8} shell truth {:.4} / {:.2} fit {:.4} / {:.2} rough truth {:.5} fit {:.5}",
                    et.membrane,
                    et.bending,
                    ef.membrane,
                    ef.bending,
                    rough(&truth),
                    rough(&f.positions)
                );
            }
            let med = match f {
                Ok(f) => median(
                    f.positions
                        .iter()
                        .zip(&x.positions)
                        .map(|(a, b)| {
                            let d = [0, 1, 2].map(|k| a[k] / s - b[k]);
                            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / lbar
                        })
                        .collect(),
                ),
                Err(e) => {
                    eprintln!("{name} {m}: {e}");
                    f64::NAN
                }
            };
            if std::env::var_os("CASES").is_some() {
                // One line per fit: `ERR case meshing median-error`.
                eprintln!("ERR {name} {m} {med:.4}");
            }
            table.entry((kind.clone(), m.clone())).or_default().push(med);
        }
    }
    let mut all = Vec::new();
    let mut line = String::new();
    for ((k, m), v) in &table {
        let med = median(v.clone());
        all.push(med);
        line.push_str(&format!("{}/{} {:.3} | ", &k[..k.len().min(5)], &m[..1], med));
    }
    println!("{line}");
    slides.sort_by(f64::total_cmp);
    truth_slides.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let Some(t) = truth_slides.last() {
        println!("quality.slide of the true poses: largest {:.3} ({})", t.0, t.1);
    }
    println!(
        "quality.slide over the fits: median {:.3}, largest {:.3}; poor fits {poor} of {}",
        median(slides.clone()),
        slides.last().copied().unwrap_or(f64::NAN),
        slides.len()
    );
    println!(
        "mean of medians {:.3}; {:.2} s per fit",
        all.iter().sum::<f64>() / all.len().max(1) as f64,
        time / fits.max(1) as f64
    );
}
