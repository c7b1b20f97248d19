//! Multiresolution benchmark (issue 2): temporal interpolation of one deformation (an
//! icosphere to a twisted, stretched copy; 3 inserted poses, N = 4) with one, two and three
//! spatial levels, for one metric (default: isometric with `lambda = 0.1`): set-up time (hierarchy
//! and solvers), solve time, iterations on the finest level, final energy. A direct N = 4 solve
//! from the linear path is the reference energy. Prints a Markdown table.
//!
//! `cargo bench -p qcshape --bench multires [-- --sizes 4,5 --insert 3 --metric qc]` (icosphere levels:
//! 4 = 2,562 vertices, 5 = 10,242). Run with `RAYON_NUM_THREADS=1` for single-core figures.

use std::time::Instant;

use qcshape::geodesic::{GeodesicOptions, GeodesicSolver, InterpolationOptions, Interpolator};
use qcshape::mesh::Shape;
use qcshape::metric::{MetricKind, MetricSpec};
use qcshape::synth::icosphere;

fn twist_stretch(s: &Shape) -> Vec<[f64; 3]> {
    s.positions
        .iter()
        .map(|p| {
            let a = 1.2 * p[2];
            let (c, si) = (a.cos(), a.sin());
            [c * p[0] - si * p[1], si * p[0] + c * p[1], 1.5 * p[2]]
        })
        .collect()
}

fn arg<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map(String::as_str)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if !args.iter().any(|a| a == "--bench") {
        println!("multires benchmark: run it with `cargo bench -p qcshape --bench multires`");
        return;
    }
    let sizes: Vec<u32> = arg(&args, "--sizes")
        .unwrap_or("4")
        .split(',')
        .map(|s| {
            s.trim()
                .parse()
                .expect("--sizes takes icosphere levels, e.g. 4,5")
        })
        .collect();
    let insert: usize = arg(&args, "--insert").map_or(3, |s| s.parse().expect("--insert takes a count"));
    let kind: MetricKind = arg(&args, "--metric")
        .unwrap_or("isometric")
        .parse()
        .expect("--metric takes l2, rigid, isometric, conformal or quasi-conformal");
    let spec = MetricSpec::new(kind);
    println!("metric {}, {insert} inserted poses", spec.label());
    println!("| vertices | variant | levels (vertices) | setup s | solve s | fine its | energy | energy / direct | time / single |");
    println!("|---:|---|---|---:|---:|---:|---:|---:|---:|");
    for level in sizes {
        let a = icosphere(level);
        let b = twist_stretch(&a);
        let nv = a.n_vertices();
        let geo = GeodesicOptions::default();
        let f = 1.0 / qcshape::mesh::geometry::mean_edge_length(&a.topology, &a.positions);
        let metric = spec
            .build_scaled(&a.topology, &a.positions, f)
            .expect("calibration");
        let metric = metric.as_ref();

        // Reference: direct N = n + 1 solve from the linear path, in the same scale.
        let t = Instant::now();
        let solver = GeodesicSolver::new(
            metric,
            a.topology.clone(),
            GeodesicOptions {
                steps: insert + 1,
                ..geo.clone()
            },
        )
        .expect("solver");
        let setup = t.elapsed().as_secs_f64();
        let sc = |p: &[[f64; 3]]| p.iter().map(|v| v.map(|c| c * f)).collect::<Vec<_>>();
        let t = Instant::now();
        let direct = solver.solve(&sc(&a.positions), &sc(&b)).expect("direct solve");
        let direct_s = t.elapsed().as_secs_f64();
        println!(
            "| {nv} | direct N={} from the linear path (start energy {:.4e}) | 1 ({nv}) | {setup:.2} | {direct_s:.2} | {} | {:.6e} | 1 | - |",
            insert + 1,
            direct.initial_energy,
            direct.iterations,
            direct.energy
        );

        // Each variant to the solver's tolerance. (No common target energy: a target would apply
        // to every level and schedule stage, whose energies are not comparable to the finest
        // level's, and stop them at once.)
        {
            let target: Option<f64> = None;
            let mut single_time = None;
            for levels in [1, 2, 3] {
                let t = Instant::now();
                let ip = Interpolator::new(
                    metric,
                    &a.topology,
                    &a.positions,
                    InterpolationOptions {
                        insert,
                        levels,
                        geodesic: GeodesicOptions {
                            target_energy: target,
                            ..geo.clone()
                        },
                        ..Default::default()
                    },
                )
                .expect("interpolator");
                let setup = t.elapsed().as_secs_f64();
                let t = Instant::now();
                let r = ip.interpolate(&a.positions, &b).expect("interpolation");
                let solve = t.elapsed().as_secs_f64();
                let fine = r.stats.levels.last().expect("a level");
                let single = *single_time.get_or_insert(solve);
                println!(
                    "| {nv} | {levels} level(s), {}{} | {} ({:?}) | {setup:.2} | {solve:.2} | {} | {:.6e} | {:.6} | {:.2} |",
                    if target.is_some() { "to direct energy + 1e-4" } else { "to tolerance" },
                    if r.stats.converged { "" } else { " (not converged)" },
                    ip.hierarchy().n_levels(),
                    ip.hierarchy().vertex_counts(),
                    fine.iterations,
                    r.stats.energy,
                    r.stats.energy / direct.energy,
                    solve / single
                );
                for l in &r.stats.levels {
                    eprintln!(
                        "  {nv} vertices, {levels} level(s): level of {} vertices, N {:?}: start energy {:.6e}, \
                         final {:.6e}, {} its, {:.2} s",
                        l.vertices, l.steps, l.start_energy, l.energy, l.iterations, l.seconds
                    );
                }
            }
        }
    }
}
