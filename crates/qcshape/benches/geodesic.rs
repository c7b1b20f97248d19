//! Geodesic benchmark (engine issue): an icosphere (642 and 2,562 vertices) to a twisted and
//! stretched copy, N = 8, for every metric and every solver: time, iterations, final energy.
//! The preconditioned solver's converged energy `E*` is the reference; every solver is then
//! timed to `E* (1 + 1e-6)`, so the ratios compare the time to the same energy. Prints a
//! Markdown table. Solvers: `preconditioned` (default), `hessian-kronecker` and
//! `pose-kronecker` (the research solvers of earlier tables were retired:
//! docs/log/solvers.md; `bench/solver_study.sh` compares the solvers through the CLI).
//!
//! `cargo bench -p qcshape --bench geodesic [-- --levels 3,4 --metrics all --lambda 0.1
//! --refresh 45 --memory 10 --omega 0.3 --calibrated]` (`--omega`: the preconditioned solver's
//! vertex-block weight;
//! `--calibrated`: the library's metrics as `MetricSpec::new` builds them, calibrated on the two
//! meshes, with `--lambda` on that scale, default `qcshape::defaults::LAMBDA`; without it the
//! raw metrics of the previous releases, `--lambda` default 0.1)
//! Run with `RAYON_NUM_THREADS=1` for single-core figures.

use std::time::Instant;

use qcshape::geodesic::{geodesic, GeodesicOptions, Normalization, Solver};
use qcshape::mesh::Shape;
use qcshape::metric::{
    Conformal, ConformalForm, FrozenRigid, Isometric, Metric, MetricKind, MetricSpec, QcWeights,
    QuasiConformal, Regularized, Rigid, L2,
};
use qcshape::synth::twisted_sphere;

/// The metric, triangle form and quasi-conformal weights a bench name stands for (every name
/// of [`ALL`] but the two raw-only variants `l2-pose` and `rigid-frozen`).
fn variant(name: &str) -> Option<(MetricKind, ConformalForm, QcWeights)> {
    use ConformalForm::{Paper, Quadratic};
    use QcWeights::{Endpoints, Segment};
    Some(match name {
        "l2" => (MetricKind::L2, Quadratic, Endpoints),
        "rigid" => (MetricKind::Rigid, Quadratic, Endpoints),
        "isometric" => (MetricKind::Isometric, Quadratic, Endpoints),
        "conformal-paper" => (MetricKind::Conformal, Paper, Endpoints),
        "conformal-quadratic" => (MetricKind::Conformal, Quadratic, Endpoints),
        "qc-quadratic-endpoints" => (MetricKind::QuasiConformal, Quadratic, Endpoints),
        "qc-paper-endpoints" => (MetricKind::QuasiConformal, Paper, Endpoints),
        "qc-quadratic-segment" => (MetricKind::QuasiConformal, Quadratic, Segment),
        "qc-paper-segment" => (MetricKind::QuasiConformal, Paper, Segment),
        _ => return None,
    })
}

/// The raw metric `name` (the previous releases' terms, no calibration), `+ lambda * L2`
/// except for the L2 metrics themselves.
fn metric(name: &str, lambda: f64) -> Box<dyn Metric> {
    let reg = |m: Box<dyn Metric>| -> Box<dyn Metric> { Box::new(Regularized::new(m, lambda)) };
    match name {
        "l2-pose" => return Box::new(L2),
        "rigid-frozen" => return reg(Box::new(FrozenRigid)),
        _ => {}
    }
    let (kind, form, weights) = variant(name).unwrap_or_else(|| panic!("unknown metric {name}"));
    match kind {
        MetricKind::L2 => Box::new(qcshape::metric::FrozenL2),
        MetricKind::Rigid => reg(Box::new(Rigid)),
        MetricKind::Isometric => reg(Box::new(Isometric)),
        MetricKind::Conformal => reg(Box::new(Conformal { form })),
        MetricKind::QuasiConformal => reg(Box::new(QuasiConformal::new(form, weights))),
    }
}

/// The library's metric `name` (see [`metric`]) as [`MetricSpec::new`] builds it with `lambda`,
/// calibrated on `refs` (the two meshes in the solver's units).
fn calibrated(name: &str, lambda: f64, a: &Shape, refs: &[&[[f64; 3]]]) -> Box<dyn Metric> {
    let (kind, form, weights) = variant(name).unwrap_or_else(|| panic!("{name} has no --calibrated form"));
    let spec = MetricSpec {
        form,
        weights,
        lambda,
        ..MetricSpec::new(kind)
    };
    spec.build_for(&a.topology, refs).unwrap()
}

const ALL: &[&str] = &[
    "l2",
    "l2-pose",
    "rigid",
    "rigid-frozen",
    "isometric",
    "conformal-paper",
    "conformal-quadratic",
    "qc-quadratic-endpoints",
    "qc-paper-endpoints",
    "qc-quadratic-segment",
    "qc-paper-segment",
];

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let get = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let levels: Vec<u32> = get("--levels")
        .unwrap_or("3,4".into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let names: Vec<String> = match get("--metrics").as_deref() {
        None | Some("all") => ALL.iter().map(|s| s.to_string()).collect(),
        Some(list) => list.split(',').map(String::from).collect(),
    };
    let calibrated_scale = args.iter().any(|a| a == "--calibrated");
    let default_lambda = if calibrated_scale {
        qcshape::defaults::LAMBDA
    } else {
        0.1
    };
    let lambda: f64 = get("--lambda").map_or(default_lambda, |s| s.parse().unwrap());
    let omega: f64 = get("--omega").map_or(GeodesicOptions::default().vertex_block_weight, |s| {
        s.parse().unwrap()
    });
    println!(
        "threads: {} (set RAYON_NUM_THREADS=1 for one core); N = 8; lambda = {lambda} ({}); coordinates scaled by 1/mean edge length; vertex-block weight {omega}",
        rayon::current_num_threads(),
        if calibrated_scale { "calibrated" } else { "raw" }
    );
    let memory: usize =
        get("--memory").map_or(GeodesicOptions::default().lbfgs_memory, |s| s.parse().unwrap());
    let refresh: usize = get("--refresh").map_or(GeodesicOptions::default().preconditioner_refresh, |s| {
        s.parse().unwrap()
    });
    println!(
        "E* = energy of the preconditioned solver run to its own convergence test; every solver is then timed to E* (1 + 1e-6) ('>' = not reached: time and iterations spent)"
    );
    println!("| #V | metric | linear energy | E* | precond converged s (its) | precond to E* s (its) | hessian-kronecker to E* s (its) | pose-kronecker to E* s (its) | hessian-kronecker/precond | pose-kronecker/precond |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for level in levels {
        let (a, b) = twisted_sphere(level);
        // The solver's units (Normalization::MeanEdgeOfFirst), where the calibration is taken.
        let unit = 1.0 / qcshape::mesh::geometry::mean_edge_length(&a.topology, &a.positions);
        let scaled =
            |s: &Shape| -> Vec<[f64; 3]> { s.positions.iter().map(|p| p.map(|c| c * unit)).collect() };
        let (sa, sb) = (scaled(&a), scaled(&b));
        for name in &names {
            let m = if calibrated_scale {
                calibrated(name, lambda, &a, &[&sa, &sb])
            } else {
                metric(name, lambda)
            };
            let run = |o: GeodesicOptions| {
                let t = Instant::now();
                let g = geodesic(m.as_ref(), &a, &b, &o, Normalization::MeanEdgeOfFirst).unwrap();
                (g, t.elapsed().as_secs_f64())
            };
            let (pc, t_pc) = run(GeodesicOptions {
                steps: 8,
                solver: Solver::Preconditioned,
                preconditioner_refresh: refresh,
                lbfgs_memory: memory,
                vertex_block_weight: omega,
                ..Default::default()
            });
            let target = pc.energy * (1.0 + 1e-6);
            // Each solver to the target only: no other stopping test.
            let to_target = |solver: Solver, max_iterations: usize| {
                let (g, t) = run(GeodesicOptions {
                    steps: 8,
                    solver,
                    target_energy: Some(target),
                    max_iterations: Some(max_iterations),
                    gradient_tolerance: 0.0,
                    energy_tolerance: 0.0,
                    preconditioner_refresh: refresh,
                    lbfgs_memory: memory,
                    vertex_block_weight: omega,
                    ..Default::default()
                });
                let reached = g.energy <= target;
                (t, g.iterations, reached)
            };
            let fmt = |(t, its, reached): (f64, usize, bool)| {
                format!("{}{t:.3} ({its})", if reached { "" } else { ">" })
            };
            let pc_t = to_target(Solver::Preconditioned, 1000);
            let hk_t = to_target(Solver::HessianKronecker, 1000);
            let pk_t = to_target(Solver::PoseKronecker, 1000);
            // Time relative to the default's ("<": the default did not reach E* in its limit, so
            // its time is a lower bound).
            let ratio = |x: (f64, usize, bool)| {
                let gt = if pc_t.2 { "" } else { "<" };
                if x.2 {
                    format!("{gt}{:.2}x", x.0 / pc_t.0)
                } else {
                    "-".to_string()
                }
            };
            println!(
                "| {} | {name} | {:.6e} | {:.8e} | {t_pc:.3} ({}) | {} | {} | {} | {} | {} |",
                a.n_vertices(),
                pc.initial_energy,
                pc.energy,
                pc.iterations,
                fmt(pc_t),
                fmt(hk_t),
                fmt(pk_t),
                ratio(hk_t),
                ratio(pk_t),
            );
        }
    }
}
