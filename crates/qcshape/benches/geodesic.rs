//! Geodesic benchmark (engine issue): an icosphere (642 and 2,562 vertices) to a twisted and
//! stretched copy, N = 8, for every metric and both solvers: time, iterations, final energy.
//! L-BFGS is stopped at the best energy of the other solvers (+1e-6 relative) so the ratio
//! compares the time to the same energy. Prints a Markdown table. Solvers: `preconditioned`
//! (default), `gauss-newton` (truncated, conjugate gradients), and with `--gn-direct` the
//! Levenberg-Marquardt with a factorization of the full system (minutes at 642 vertices).
//!
//! `cargo bench -p qcshape --bench geodesic [-- --levels 3,4 --metrics all --lbfgs-cap 3000]`
//! Run with `RAYON_NUM_THREADS=1` for single-core figures.

use std::time::Instant;

use qcshape::mesh::Shape;
use qcshape::metric::{
    Conformal, ConformalForm, Isometric, Metric, QcWeights, QuasiConformal, Regularized, Rigid, L2,
};
use qcshape::path::{geodesic, GeodesicOptions, Normalization, Solver};
use qcshape::synth::icosphere;

fn twist_stretch(s: &Shape) -> Shape {
    let pos = s
        .positions
        .iter()
        .map(|p| {
            let a = 1.2 * p[2];
            let (c, si) = (a.cos(), a.sin());
            [c * p[0] - si * p[1], si * p[0] + c * p[1], 1.5 * p[2]]
        })
        .collect();
    Shape::new(s.topology.clone(), pos).unwrap()
}

fn metric(name: &str, lambda: f64) -> Box<dyn Metric> {
    let reg = |m: Box<dyn Metric>| -> Box<dyn Metric> { Box::new(Regularized::new(m, lambda)) };
    match name {
        "l2" => Box::new(qcshape::metric::FrozenL2),
        "l2-pose" => Box::new(L2),
        "rigid" => reg(Box::new(Rigid)),
        "isometric" => reg(Box::new(Isometric)),
        "conformal-paper" => reg(Box::new(Conformal {
            form: ConformalForm::Paper,
        })),
        "conformal-quadratic" => reg(Box::new(Conformal {
            form: ConformalForm::Quadratic,
        })),
        "qc-quadratic-endpoints" => reg(Box::new(QuasiConformal {
            form: ConformalForm::Quadratic,
            weights: QcWeights::Endpoints,
        })),
        "qc-paper-endpoints" => reg(Box::new(QuasiConformal {
            form: ConformalForm::Paper,
            weights: QcWeights::Endpoints,
        })),
        "qc-quadratic-segment" => reg(Box::new(QuasiConformal {
            form: ConformalForm::Quadratic,
            weights: QcWeights::Segment,
        })),
        "qc-paper-segment" => reg(Box::new(QuasiConformal {
            form: ConformalForm::Paper,
            weights: QcWeights::Segment,
        })),
        _ => panic!("unknown metric {name}"),
    }
}

const ALL: &[&str] = &[
    "l2",
    "l2-pose",
    "rigid",
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
    let cap: usize = get("--lbfgs-cap").map_or(3000, |s| s.parse().unwrap());
    let lambda: f64 = get("--lambda").map_or(0.1, |s| s.parse().unwrap());
    let skip_gn = args.iter().any(|a| a == "--skip-gn");
    let gn_direct = args.iter().any(|a| a == "--gn-direct");
    println!(
        "threads: {} (set RAYON_NUM_THREADS=1 for one core); N = 8; lambda = {lambda}; coordinates scaled by 1/mean edge length",
        rayon::current_num_threads()
    );
    let gn_name = if gn_direct { "GN direct" } else { "GN" };
    println!("| #V | metric | precond s | its | energy | linear energy | {gn_name} s | its | energy | L-BFGS s | L-BFGS its | L-BFGS reached | L-BFGS/precond | L-BFGS/{gn_name} |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for level in levels {
        let a = icosphere(level);
        let b = twist_stretch(&a);
        for name in &names {
            let m = metric(name, lambda);
            let run = |solver: Solver| {
                let o = GeodesicOptions {
                    steps: 8,
                    solver,
                    ..Default::default()
                };
                let t = Instant::now();
                let g = geodesic(m.as_ref(), &a, &b, &o, Normalization::MeanEdgeOfFirst).unwrap();
                (g, t.elapsed().as_secs_f64())
            };
            let (pc, t_pc) = run(Solver::Preconditioned);
            let (gn, t_gn) = if skip_gn {
                (pc.clone(), f64::NAN)
            } else if gn_direct {
                run(Solver::GaussNewtonDirect)
            } else {
                run(Solver::GaussNewton)
            };
            // Time plain L-BFGS to the best energy found by the other two (+1e-6 relative).
            let target = pc.energy.min(gn.energy) * (1.0 + 1e-6);
            let o = GeodesicOptions {
                steps: 8,
                solver: Solver::Lbfgs,
                target_energy: Some(target),
                max_iterations: cap / 50,
                gradient_tolerance: 0.0,
                energy_tolerance: 0.0,
                ..Default::default()
            };
            let t = Instant::now();
            let lb = geodesic(m.as_ref(), &a, &b, &o, Normalization::MeanEdgeOfFirst).unwrap();
            let t_lb = t.elapsed().as_secs_f64();
            let reached = lb.energy <= target;
            let gt = if reached { "" } else { ">" };
            println!(
                "| {} | {name} | {t_pc:.3} | {} | {:.8e} | {:.6e} | {t_gn:.3} | {} | {:.8e} | {t_lb:.3} | {} | {} | {gt}{:.1}x | {gt}{:.1}x |",
                a.n_vertices(),
                pc.iterations,
                pc.energy,
                pc.initial_energy,
                gn.iterations,
                gn.energy,
                lb.iterations,
                if reached { "yes" } else { "no" },
                t_lb / t_pc,
                t_lb / t_gn
            );
        }
    }
}
