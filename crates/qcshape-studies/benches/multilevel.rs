//! Multilevel geodesic benchmark (issue 39): the twisted sphere (`synth::twisted_sphere`)
//! at several resolutions and the bent tube, N = 8, for isometric and conformal at the calibrated
//! defaults: the single-level solve from the straight path (the baseline, measured in the same
//! run) against coarse-to-fine solves on the mesh hierarchy (each level's metric calibrated on
//! that level, the coarse path prolonged as the finer level's start). Prints a Markdown table with
//! time and iteration ratios against the single-level solve and the energy difference.
//!
//! `cargo bench -p qcshape-studies --bench multilevel [-- --sizes 3,4,5 --metrics isometric,conformal
//! --levels 2,3 --lambda 0.01 --tube --solvers preconditioned,pose-kronecker]` (the first solver
//! is the baseline; `--levels 1` runs single-level solves only). Run with `RAYON_NUM_THREADS=1` for single-core figures.

use std::time::Instant;

use qcshape::geodesic::{pair_factor, Geodesic, GeodesicOptions, GeodesicSolver, Solver};
use qcshape::mesh::Shape;
use qcshape::metric::{MetricKind, MetricSpec};
use qcshape::multires::{Hierarchy, DEFAULT_RATIO};
use qcshape::synth::twisted_sphere;
use qcshape_studies::experiment::geometry::tube_pair;

fn arg<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map(String::as_str)
}

/// A level's geodesic with its two ends (that level's vertices).
type Solved = (Geodesic, Vec<[f64; 3]>, Vec<[f64; 3]>);

struct Run {
    geodesic: Geodesic,
    seconds: f64,
    per_level: Vec<(usize, usize, f64)>,
}

fn scaled(p: &[[f64; 3]], f: f64) -> Vec<[f64; 3]> {
    p.iter().map(|v| v.map(|c| c * f)).collect()
}

/// Coarse-to-fine solve with `levels` levels (1 = the single-level solve).
fn solve(spec: &MetricSpec, a: &Shape, b: &Shape, steps: usize, levels: usize, solver: Solver) -> Run {
    let t0 = Instant::now();
    let f = pair_factor(&a.positions, &b.positions, &a.topology).expect("factor");
    let (sa, sb) = (scaled(&a.positions, f), scaled(&b.positions, f));
    let h = Hierarchy::new(&a.topology, &sa, levels, DEFAULT_RATIO).expect("hierarchy");
    let opts = GeodesicOptions {
        steps,
        solver,
        ..GeodesicOptions::default()
    };
    let top = h.n_levels() - 1;
    let mut prev: Option<Solved> = None;
    let mut per_level = Vec::new();
    for l in (0..=top).rev() {
        let t = Instant::now();
        let level = h.level(l);
        let (la, lb) = (level.restrict(&sa), level.restrict(&sb));
        let metric = spec.build_for(&level.topology, &[&la, &lb]).expect("calibration");
        let solver =
            GeodesicSolver::new(metric.as_ref(), level.topology.clone(), opts.clone()).expect("solver");
        let g = match &prev {
            None => solver.solve(&la, &lb).expect("solve"),
            Some((cg, ca, cb)) => {
                let n = cg.poses.len() - 1;
                let start = h.prolongation(l).prolong_path(&la, &lb, ca, cb, &cg.poses[1..n]);
                solver.solve_with_start(&la, &lb, &start).expect("solve")
            }
        };
        per_level.push((level.n_vertices(), g.iterations, t.elapsed().as_secs_f64()));
        prev = Some((g, la, lb));
    }
    Run {
        geodesic: prev.expect("one level").0,
        seconds: t0.elapsed().as_secs_f64(),
        per_level,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if !args.iter().any(|a| a == "--bench") {
        println!("multilevel benchmark: run it with `cargo bench -p qcshape-studies --bench multilevel`");
        return;
    }
    let list = |name: &str, default: &str| -> Vec<String> {
        arg(&args, name)
            .unwrap_or(default)
            .split(',')
            .map(str::to_owned)
            .collect()
    };
    let sizes: Vec<u32> = list("--sizes", "3,4,5")
        .iter()
        .map(|s| s.parse().expect("--sizes takes icosphere levels"))
        .collect();
    let levels: Vec<usize> = list("--levels", "2,3")
        .iter()
        .map(|s| s.parse().expect("--levels takes level counts"))
        .collect();
    let solvers: Vec<Solver> = list("--solvers", "preconditioned")
        .iter()
        .map(|s| s.parse().expect("--solvers takes solver names"))
        .collect();
    let lambda: Option<f64> = arg(&args, "--lambda").map(|s| s.parse().expect("--lambda takes a number"));
    let steps = 8;
    let mut cases: Vec<(String, Shape, Shape)> = sizes
        .iter()
        .map(|&s| {
            let (a, b) = twisted_sphere(s);
            (format!("sphere {}", a.n_vertices()), a, b)
        })
        .collect();
    if args.iter().any(|a| a == "--tube") {
        let (a, b) = tube_pair();
        cases.push((format!("bent tube {}", a.n_vertices()), a, b));
    }
    println!(
        "N = {steps}; baseline: the single-level solve from the straight path with the first solver ({}), same run",
        solvers[0].label()
    );
    println!("| case | metric | solver | levels (vertices) | its per level (coarse..fine) | s | s / single | fine its / single its | energy rel. diff | converged |");
    println!("|---|---|---|---|---|---:|---:|---:|---:|---|");
    for metric in list("--metrics", "isometric,conformal") {
        let kind: MetricKind = metric.parse().expect("--metrics takes metric names");
        let mut spec = MetricSpec::new(kind);
        if let Some(l) = lambda {
            spec.lambda = l;
        }
        for (name, a, b) in &cases {
            let single = solve(&spec, a, b, steps, 1, solvers[0]);
            let row = |r: &Run, solver: Solver, label: String| {
                let its: Vec<String> = r.per_level.iter().map(|x| x.1.to_string()).collect();
                let verts: Vec<String> = r.per_level.iter().map(|x| x.0.to_string()).collect();
                println!(
                    "| {name} | {} | {} | {label} ({}) | {} | {:.3} | {:.2} | {:.2} | {:.1e} | {} |",
                    spec.label(),
                    solver.label(),
                    verts.join(", "),
                    its.join(", "),
                    r.seconds,
                    r.seconds / single.seconds,
                    r.per_level.last().expect("a level").1 as f64 / single.geodesic.iterations.max(1) as f64,
                    (r.geodesic.energy - single.geodesic.energy) / single.geodesic.energy,
                    r.geodesic.converged
                );
            };
            row(&single, solvers[0], "1".into());
            for &solver in &solvers[1..] {
                row(&solve(&spec, a, b, steps, 1, solver), solver, "1".into());
            }
            for &l in levels.iter().filter(|&&l| l > 1) {
                for &solver in &solvers {
                    row(&solve(&spec, a, b, steps, l, solver), solver, l.to_string());
                }
            }
        }
    }
}
