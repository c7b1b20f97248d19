//! `qcshape geodesic`: the discrete geodesic between two poses and their distance.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use qcshape::geodesic::{geodesic, pair_metric, GeodesicOptions, Normalization, OffPath, StopReason};
use qcshape::io::{self, Field};
use qcshape::mesh::Shape;
use qcshape::metric::Folds;
use qcshape_studies::contribution::path_contributions;

use crate::args::{in_pool, MetricArgs, SolverArgs};
use crate::mesh_format::MeshFormat;

/// Compute the discrete geodesic between two meshes of one connectivity and print the
/// distance.
///
/// Both meshes are scaled by one common factor before solving, 1 / ((mean edge length of A +
/// mean edge length of B) / 2), and the metric is calibrated on both (--scale): symmetric in A
/// and B, so that `geodesic A B` and `geodesic B A` give the same distance. Distance and
/// energy are in the metric's units (calibrated: dimensionless; raw: the scaled coordinates';
/// the JSON's `scale` is the factor). The energy is split into the geometric term and the L2
/// regularizer; a warning says when the regularizer carries more than half of it. With --out, the N + 1 poses of
/// the path are written as pose000.ply ... (--format) in the input's units, together with maps of where
/// the two shapes differ (docs/maps.md): segment_000.vtk ... (on pose i: `energy`, the
/// per-vertex energy contribution of segment i, `length`, its length contribution, and
/// `displacement`, P_{i+1} - P_i as vectors in the input's units) and contribution.vtk plus
/// contribution.ply (on A: `energy` and `length` summed over the segments, whose sums are the
/// path energy and the distance, and `displacement` B - A; the PLY's `quality` is `length`,
/// for MeshLab). Face and edge terms are shared equally among their vertices.
#[derive(Debug, clap::Args)]
#[command(about = "Discrete geodesic and distance between two poses", long_about)]
pub struct Args {
    /// First mesh (OBJ, PLY, OFF, STL, VTK, VTP, VTU).
    #[arg(required_unless_present = "demo")]
    a: Option<PathBuf>,
    /// Second mesh, same connectivity as A.
    #[arg(required_unless_present = "demo")]
    b: Option<PathBuf>,
    /// Use built-in data: an icosphere (642 vertices) and a copy twisted by 1.2 rad per unit
    /// height and stretched 1.5x along z (the benchmark pair).
    #[arg(long)]
    demo: bool,
    /// Subdivision level of the demo icosphere: 2 = 162, 3 = 642, 4 = 2,562 vertices.
    /// At most 6.
    #[arg(long, default_value_t = 3, value_parser = crate::bounds::count::<u32>(0, 6), allow_negative_numbers = true)]
    demo_level: u32,
    #[command(flatten)]
    metric: MetricArgs,
    #[command(flatten)]
    solver: SolverArgs,
    /// Iteration limit of the solve (default: 1,000, or 60 sqrt(#V) on meshes above 278
    /// vertices).
    /// At most 1,000,000.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_ITERATIONS as u64), allow_negative_numbers = true)]
    max_iterations: Option<usize>,
    /// Write the path's poses (--format) and the per-vertex contribution maps to this folder.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Mesh format of the written poses.
    #[arg(long, value_enum, default_value_t = MeshFormat::Ply)]
    format: MeshFormat,
    /// Format of the segment maps: vtk (legacy, ParaView), vtp or vtu (VTK XML) or ply (MeshLab).
    #[arg(long, default_value = "vtk", value_parser = ["vtk", "vtp", "vtu", "ply"])]
    maps_format: String,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
}

/// `b - a` per vertex (#V x 3).
fn displacement(a: &[[f64; 3]], b: &[[f64; 3]]) -> Vec<[f64; 3]> {
    a.iter()
        .zip(b)
        .map(|(p, q)| [q[0] - p[0], q[1] - p[1], q[2] - p[2]])
        .collect()
}

/// The per-segment and whole-path contribution maps (see the command's help).
fn write_maps(
    dir: &Path,
    ext: &str,
    metric: &dyn qcshape::metric::Metric,
    a: &Shape,
    g: &qcshape::geodesic::Geodesic,
) -> Result<()> {
    let c = path_contributions(metric, &a.topology, &g.poses, g.scale)?;
    let faces = a.topology.faces();
    for (i, w) in g.poses.windows(2).enumerate() {
        let d = displacement(&w[0], &w[1]);
        let fields = [
            Field::scalar("energy", &c.segment_energy[i]),
            Field::scalar("length", &c.segment_length[i]),
            Field::vector("displacement", &d),
        ];
        io::write_mesh_fields(&dir.join(format!("segment_{i:03}.{ext}")), &w[0], faces, &fields)?;
    }
    let last = g.poses.last().expect("a path has poses");
    let d = displacement(&g.poses[0], last);
    let fields = [
        Field::scalar("length", &c.length),
        Field::scalar("energy", &c.energy),
        Field::vector("displacement", &d),
    ];
    for ext in ["vtk", "ply"] {
        io::write_mesh_fields(
            &dir.join(format!("contribution.{ext}")),
            &g.poses[0],
            faces,
            &fields,
        )?;
    }
    Ok(())
}

fn load(p: &Path) -> Result<Shape> {
    Ok(io::load_shape(p)?)
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    if let Some(dir) = &args.out {
        let inputs: Vec<&std::path::Path> = args.a.iter().chain(&args.b).map(PathBuf::as_path).collect();
        crate::input::refuse_out_folder(&inputs, dir, "--out")?;
    }
    let (a, b) = match (&args.a, &args.b) {
        (Some(pa), Some(pb)) => (load(pa)?, load(pb)?),
        _ if args.demo => qcshape::synth::twisted_sphere(args.demo_level),
        _ => bail!("give two meshes A and B, or --demo"),
    };
    if let Err(e) = a.check_same_topology(&b) {
        let names = match (&args.a, &args.b) {
            (Some(pa), Some(pb)) => format!("{} and {}", pa.display(), pb.display()),
            _ => "the demo meshes".into(),
        };
        bail!("{names} cannot be compared: {e}");
    }
    let spec = args.metric.spec()?;
    let (metric, factor) = pair_metric(&spec, &a, &b)?;
    let opts = GeodesicOptions {
        max_iterations: args.max_iterations,
        ..args.solver.options()?
    };
    eprintln!(
        "solving {} on {} vertices, N = {} ...",
        spec.label(),
        a.n_vertices(),
        opts.steps
    );
    // Every warning goes to stderr and into --json's "warnings".
    let mut warnings = Vec::new();
    if let Some((la, lb)) = qcshape::space::size_mismatch(&a.topology, &a.positions, &b.positions) {
        eprintln!("warning: {}", size_warning(la, lb));
        warnings.push(size_warning(la, lb));
    }
    let before_solve = warnings.len();
    // Solver iterations, at least every 10 s in a log (the first line once an interval passed).
    let limit = opts.iteration_limit(a.n_vertices());
    let pb = crate::progress::new_bar(limit);
    if let Some(style) = crate::progress::style(
        "solving: {iterations} of at most {len} iterations, {rate} [{elapsed_precise}]",
    ) {
        pb.set_style(style);
    }
    crate::progress::start(&pb);
    let g = geodesic(metric.as_ref(), &a, &b, &opts, Normalization::Factor(factor));
    crate::progress::finish_with_line(
        &pb,
        &format!(
            "solving: {} iterations, done in {:.1} s",
            crate::progress::iterations(),
            pb.elapsed().as_secs_f64()
        ),
    );
    let g = g?;
    let share = g.regularizer_share();
    if share > 0.5 {
        warnings.push(format!(
            "the L2 regularizer carries {:.0} % of the energy: this {} distance measures \
             L2 displacement more than its own geometry (lower --lambda)",
            100.0 * share,
            spec.kind.label()
        ));
    }
    let folds = spec
        .bends()
        .then(|| Folds::between(&a.topology, &a.positions, &b.positions));
    warnings.extend(folds.and_then(|f| f.warning(g.bending_share(), "--bending 0")));
    warnings.extend(OffPath::find(&a.topology, &g.poses).map(|o| o.warning(spec.bends())));
    if g.stop == StopReason::MaxIterations {
        warnings.push(format!(
            "the solver stopped at its iteration limit after {} iterations ({}: --max-iterations): the distance is not converged",
            g.iterations,
            opts.solver.stall_hint(spec.bends())
        ));
    }
    for w in &warnings[before_solve..] {
        eprintln!("warning: {w}");
    }
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for (i, p) in g.poses.iter().enumerate() {
            let path = dir.join(format!("pose{i:03}.{}", args.format.extension()));
            io::write_mesh(&path, p, a.topology.faces(), &Default::default())?;
        }
        write_maps(dir, &args.maps_format, metric.as_ref(), &a, &g)?;
    }
    if args.json {
        let v = serde_json::json!({
            "metric": spec.label(),
            "vertices": a.n_vertices(),
            "steps": opts.steps,
            "solver": format!("{:?}", opts.solver),
            "distance": g.length,
            "energy": g.energy,
            "geometric_energy": g.geometric_energy,
            "regularizer_energy": g.regularizer_energy,
            "regularizer_share": share,
            "bending_energy": g.bending_energy,
            "bending_share": g.bending_share(),
            "folding_hinges": folds.map(|f| f.folding),
            "largest_turn_degrees": folds.map(|f| f.largest_degrees),
            "metric_scale": spec.scale.label(),
            "lambda": spec.lambda,
            "linear_energy": g.initial_energy,
            "segment_lengths": g.segment_lengths,
            "iterations": g.iterations,
            "converged": g.converged,
            "stop": g.stop,
            "warnings": warnings,
            "gradient_norm": g.gradient_norm,
            "scale": g.scale,
            "normalization": "mean-edge units: coordinates times scale, scale = 1 / mean of the mean edge lengths of A and B",
            "seconds": g.seconds,
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        outln!("metric      {}", spec.label());
        // Six significant digits, fixed-point or engineering notation (--json has every digit).
        let num = |x: f64| qcshape::numfmt::significant(x, 6);
        outln!(
            "distance    {}  ({}: coordinates divided by {}, the mean of A's and B's mean edge \
             lengths)",
            num(g.length),
            qcshape::numfmt::UNITS,
            num(1.0 / g.scale)
        );
        outln!(
            "energy      {}  (linear path {})",
            num(g.energy),
            num(g.initial_energy)
        );
        outln!(
            "terms       geometric {}, L2 regularizer {} ({:.1} % of the energy)",
            num(g.geometric_energy),
            num(g.regularizer_energy),
            100.0 * share
        );
        outln!("iterations  {}", g.iterations);
        outln!(
            "converged   {} ({:?}){}",
            g.converged,
            g.stop,
            if g.converged {
                ""
            } else {
                ": the distance is not converged"
            }
        );
        outln!("seconds     {:.3}", g.seconds);
    }
    Ok(())
}

/// The warning for poses whose mean edge lengths `la` (A's) and `lb` (B's), in the files'
/// units, differ by more than [`qcshape::space::SIZE_RATIO_WARNING`].
fn size_warning(la: f64, lb: f64) -> String {
    let num = |x: f64| qcshape::numfmt::significant(x, 3);
    format!(
        "A's mean edge length ({}) and B's ({}) differ by a factor of {} (more than {}), in the \
         files' own units: are they in the same units (e.g. metres and millimetres)? Both are \
         divided by the mean of the two (mean-edge units), so the smaller shape is nearly a point; \
         such a geodesic converges slowly and `geodesic A B` and `geodesic B A` can differ",
        num(la),
        num(lb),
        num(la.max(lb) / la.min(lb)),
        qcshape::space::SIZE_RATIO_WARNING
    )
}
