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
//! weight).

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
